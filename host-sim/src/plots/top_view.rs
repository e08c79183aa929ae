//! The top view: obstacles, tube, UAV and load paths, formation snapshots.

use super::*;

pub(crate) fn draw_top_panel(
    area: &Area<'_>,
    scene: &SceneGeometry,
    rec: &RunRecord,
    bounds: &Bounds,
    title: &str,
) -> DynResult<()> {
    let inner = titled(area, title, TITLE_PX)?;
    // Tick labels depend on the range only through its magnitude; measure with the padded bounds.
    let y_area = y_label_area(&(bounds.y0..bounds.y1), 8);
    let builder = |b: &Bounds| -> DynResult<Chart<'_, '_>> {
        Ok(ChartBuilder::on(&inner)
            .margin_left(10)
            .margin_right(25)
            .margin_top(10)
            .margin_bottom(10)
            .x_label_area_size(60)
            .y_label_area_size(y_area + 10)
            .build_cartesian_2d(b.x0..b.x1, b.y0..b.y1)?)
    };
    // Measure the plotting area first, then rebuild with equal metres per pixel on both axes.
    let (pw, ph) = builder(bounds)?.plotting_area().dim_in_pixel();
    let fitted = bounds.fit_aspect(pw, ph);
    let mut chart = builder(&fitted)?;
    let n_ticks = (((pw / 90).max(3)) as usize, ((ph / 70).max(3)) as usize);
    draw_axes(&inner, &mut chart, n_ticks, "x (east) [m]", "y (north) [m]")?;
    let m_per_px = (fitted.x1 - fitted.x0) / f64::from(pw.max(1));

    // Obstacles.
    for o in &scene.obstacles {
        let ok =
            o.center_m.iter().all(|v| v.is_finite()) && o.radius_m.is_finite() && o.radius_m > 0.0;
        if ok {
            let pts = circle_points(o.center_m, o.radius_m);
            chart.draw_series(std::iter::once(Polygon::new(
                pts.clone(),
                OBSTACLE_FILL.filled(),
            )))?;
            let mut ring = pts;
            if let Some(first) = ring.first().copied() {
                ring.push(first);
            }
            chart.draw_series(std::iter::once(PathElement::new(
                ring,
                OBSTACLE_EDGE.stroke_width(1),
            )))?;
        }
    }

    // A planned tube's map (any obstacle shape, occupancy grids) and corridor (issue 16).
    if let Some(p) = &scene.plan {
        crate::plan_plot::draw_map(&mut chart, &p.map)?;
        crate::plan_plot::draw_corridor(&mut chart, &p.tube)?;
    }

    // Tube: centreline dashed and light, boundaries dark.
    for run in finite_runs(scene.centerline.iter().map(|p| (p[0], p[1]))) {
        chart.draw_series(DashedLineSeries::new(
            run,
            12,
            8,
            CENTERLINE_COLOR.stroke_width(2),
        ))?;
    }
    for line in [&scene.left_boundary, &scene.right_boundary] {
        for run in finite_runs(line.iter().map(|p| (p[0], p[1]))) {
            chart.draw_series(LineSeries::new(
                thin_out(run, 6.0 * m_per_px),
                BOUNDARY_COLOR.stroke_width(3),
            ))?;
        }
    }

    // Paths: UAVs thin, load thick on top.
    for i in 0..n_uavs(rec) {
        let pts = rec
            .uav_pos_m
            .iter()
            .map(|row| row.get(i).map_or((f64::NAN, f64::NAN), |p| (p[0], p[1])));
        for run in finite_runs(pts) {
            chart.draw_series(LineSeries::new(
                thin_out(run, 3.0 * m_per_px),
                uav_color(i).stroke_width(1),
            ))?;
        }
    }
    for run in finite_runs(rec.load_pos_m.iter().map(|p| (p[0], p[1]))) {
        chart.draw_series(LineSeries::new(
            thin_out(run, 6.0 * m_per_px),
            LOAD_COLOR.stroke_width(4),
        ))?;
    }

    // Formation snapshots.
    let (base_x, base_y) = inner.get_base_pixel();
    for k in snapshot_indices(rec) {
        let uavs: Vec<(usize, (f64, f64))> = rec
            .uav_pos_m
            .get(k)
            .map(|row| {
                row.iter()
                    .enumerate()
                    .map(|(i, p)| (i, (p[0], p[1])))
                    .filter(|(_, (x, y))| x.is_finite() && y.is_finite())
                    .collect()
            })
            .unwrap_or_default();
        let load = rec
            .load_pos_m
            .get(k)
            .map(|p| (p[0], p[1]))
            .filter(|(x, y)| x.is_finite() && y.is_finite());
        if uavs.is_empty() && load.is_none() {
            continue;
        }
        // Vertices ordered by angle around their centroid, so the polygon is simple.
        let n = uavs.len().max(1) as f64;
        let cx = uavs.iter().map(|(_, p)| p.0).sum::<f64>() / n;
        let cy = uavs.iter().map(|(_, p)| p.1).sum::<f64>() / n;
        let mut ring: Vec<(f64, f64)> = uavs.iter().map(|(_, p)| *p).collect();
        ring.sort_by(|a, b| {
            (a.1 - cy)
                .atan2(a.0 - cx)
                .total_cmp(&(b.1 - cy).atan2(b.0 - cx))
        });
        if ring.len() >= 3 {
            chart.draw_series(std::iter::once(Polygon::new(
                ring.clone(),
                BLACK.mix(0.08).filled(),
            )))?;
        }
        if let Some(first) = ring.first().copied() {
            ring.push(first);
        }
        if ring.len() >= 3 {
            chart.draw_series(std::iter::once(PathElement::new(
                ring,
                BLACK.stroke_width(2),
            )))?;
        }
        for (i, p) in &uavs {
            chart.draw_series(std::iter::once(Circle::new(*p, 5, uav_color(*i).filled())))?;
            chart.draw_series(std::iter::once(Circle::new(*p, 5, BLACK.stroke_width(1))))?;
        }
        if let Some(l) = load {
            chart.draw_series(std::iter::once(Circle::new(l, 7, WHITE.filled())))?;
            chart.draw_series(std::iter::once(Circle::new(
                l,
                7,
                LOAD_COLOR.stroke_width(3),
            )))?;
        }
        // Time tag just above the formation.
        let top_y = uavs
            .iter()
            .map(|(_, p)| p.1)
            .chain(load.map(|l| l.1))
            .fold(f64::NEG_INFINITY, f64::max);
        if let Some(t) = rec.time_s.get(k).filter(|t| t.is_finite()) {
            let (x, y) = chart.backend_coord(&(load.map_or(cx, |l| l.0), top_y));
            let st = Txt::new(17.0, HAlign::Center, VAlign::Bottom).bold().halo();
            Label::new(format!("t = {t:.1} s"), (x - base_x, y - base_y - 9), st)
                .draw_on(&inner)?;
        }
    }

    if rec.load_pos_m.is_empty() && rec.uav_pos_m.is_empty() {
        draw_no_data(&inner, &chart)?;
    }
    Ok(())
}

/// Formation snapshot sample indices: first, last and the narrowest moment (smallest
/// load-boundary distance, else UAV-boundary distance, so the flattened formation is always
/// shown), with the others spread as evenly as possible in between; `N_SNAPSHOTS` in all
/// (one more when the narrowest moment is known).
pub(crate) fn snapshot_indices(rec: &RunRecord) -> Vec<usize> {
    let n = rec.uav_pos_m.len().max(rec.load_pos_m.len());
    if n == 0 {
        return Vec::new();
    }
    let argmin = |v: &[f64]| {
        v.iter()
            .take(n)
            .enumerate()
            .filter(|(_, d)| d.is_finite())
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, _)| k)
    };
    let mut fixed = vec![0, n - 1];
    fixed.extend(argmin(&rec.min_load_boundary_m).or_else(|| argmin(&rec.min_uav_boundary_m)));
    fixed.sort_unstable();
    fixed.dedup();
    // Share the remaining snapshots among the gaps so that sub-gaps come out as equal as possible.
    let mut gaps: Vec<(usize, usize, usize)> = fixed
        .windows(2)
        .filter_map(|w| {
            if let [a, b] = w {
                Some((*a, *b, 0))
            } else {
                None
            }
        })
        .collect();
    for _ in 0..N_SNAPSHOTS.saturating_sub(2) {
        let widest = gaps
            .iter_mut()
            .filter(|(a, b, m)| b - a > *m + 1)
            .max_by(|x, y| ((x.1 - x.0) * (y.2 + 1)).cmp(&((y.1 - y.0) * (x.2 + 1))));
        match widest {
            Some(g) => g.2 += 1,
            None => break,
        }
    }
    let mut idx = fixed;
    for (a, b, m) in gaps {
        idx.extend((1..=m).map(|q| a + (b - a) * q / (m + 1)));
    }
    idx.sort_unstable();
    idx.dedup();
    idx
}

pub(crate) fn top_view_legend(scene: &SceneGeometry, rec: &RunRecord) -> Vec<LegendEntry> {
    let mut e = Vec::new();
    if !scene.left_boundary.is_empty() || !scene.right_boundary.is_empty() {
        e.push(LegendEntry::line("tube boundary", BOUNDARY_COLOR, 3, false));
    }
    if !scene.centerline.is_empty() {
        e.push(LegendEntry::line(
            "tube centreline",
            CENTERLINE_COLOR,
            2,
            true,
        ));
    }
    if !scene.obstacles.is_empty() {
        e.push(LegendEntry {
            label: "obstacle".into(),
            swatch: Swatch::Fill(OBSTACLE_FILL, OBSTACLE_EDGE),
        });
    }
    e.push(LegendEntry::line("load path", LOAD_COLOR, 4, false));
    for i in 0..n_uavs(rec) {
        e.push(LegendEntry::line(
            &format!("UAV {} path", i + 1),
            uav_color(i),
            2,
            false,
        ));
    }
    e.push(LegendEntry {
        label: "formation snapshot".into(),
        swatch: Swatch::Formation,
    });
    e.push(LegendEntry {
        label: "load at snapshot".into(),
        swatch: Swatch::Ring(LOAD_COLOR),
    });
    e
}
