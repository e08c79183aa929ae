//! Time-series panels: tensions, clearances, load altitude (and the xy plot of campaigns).

use super::*;

pub(crate) struct Series {
    pub(crate) label: String,
    pub(crate) color: RGBColor,
    pub(crate) width: u32,
    pub(crate) points: Vec<(f64, f64)>,
}

pub(crate) struct HLine {
    pub(crate) label: String,
    pub(crate) y: f64,
    pub(crate) color: RGBColor,
    pub(crate) width: u32,
    pub(crate) dashed: bool,
}

pub(crate) struct TimePlot {
    pub(crate) x_desc: &'static str,
    pub(crate) y_desc: &'static str,
    pub(crate) series: Vec<Series>,
    pub(crate) hlines: Vec<HLine>,
    /// Shaded horizontal band `(lo, hi, label)`.
    pub(crate) band: Option<(f64, f64, String)>,
    /// Values the y range must include (e.g. 0); a bound equal to one of them gets no padding.
    pub(crate) y_include: Vec<f64>,
}

pub(crate) const BAND_FILL: RGBColor = RGBColor(222, 232, 250);
pub(crate) const BAND_EDGE: RGBColor = RGBColor(100, 150, 230);

impl TimePlot {
    /// Common axis ranges covering `self` and `others`.
    pub(crate) fn ranges(&self, others: &[TimePlot]) -> (Range<f64>, Range<f64>) {
        let mut b = Bounds::empty();
        let mut y_lo = f64::INFINITY;
        let mut y_hi = f64::NEG_INFINITY;
        let mut extra = |y: f64| {
            if y.is_finite() {
                y_lo = y_lo.min(y);
                y_hi = y_hi.max(y);
            }
        };
        for p in std::iter::once(self).chain(others) {
            for &(x, y) in p.series.iter().flat_map(|s| &s.points) {
                b.add(x, y);
            }
            p.hlines.iter().for_each(|h| extra(h.y));
            if let Some((lo, hi, _)) = &p.band {
                extra(*lo);
                extra(*hi);
            }
            p.y_include.iter().for_each(|&y| extra(y));
        }
        let (mut x0, mut x1) = if b.is_valid() {
            (b.x0, b.x1)
        } else {
            (0.0, 1.0)
        };
        if x1 - x0 <= 1e-9 {
            x0 -= 0.5;
            x1 += 0.5;
        }
        let (mut y0, mut y1) = if b.is_valid() {
            (b.y0.min(y_lo), b.y1.max(y_hi))
        } else {
            (y_lo, y_hi)
        };
        if !(y0.is_finite() && y1.is_finite()) {
            (y0, y1) = (0.0, 1.0);
        }
        if y1 - y0 < 1e-6 {
            y0 -= 0.5;
            y1 += 0.5;
        }
        let pad = (y1 - y0) * 0.06;
        let lo_pad = if self.y_include.contains(&y0) {
            0.0
        } else {
            pad
        };
        (x0..x1, (y0 - lo_pad)..(y1 + pad))
    }

    pub(crate) fn legend(&self) -> Vec<LegendEntry> {
        let mut e: Vec<LegendEntry> = self
            .series
            .iter()
            .map(|s| LegendEntry::line(&s.label, s.color, s.width.max(2), false))
            .collect();
        e.extend(
            self.hlines
                .iter()
                .map(|h| LegendEntry::line(&h.label, h.color, h.width, h.dashed)),
        );
        if let Some((_, _, label)) = &self.band {
            e.push(LegendEntry {
                label: label.clone(),
                swatch: Swatch::Fill(BAND_FILL, BAND_EDGE),
            });
        }
        e
    }
}

pub(crate) fn time_series(time: &[f64], values: impl IntoIterator<Item = f64>) -> Vec<(f64, f64)> {
    time.iter().copied().zip(values).collect()
}

pub(crate) fn tension_plot(rec: &RunRecord) -> TimePlot {
    let series = (0..n_uavs(rec))
        .map(|i| Series {
            label: format!("UAV {}", i + 1),
            color: uav_color(i),
            width: 2,
            points: time_series(
                &rec.time_s,
                rec.tension_n
                    .iter()
                    .map(|row| row.get(i).copied().unwrap_or(f64::NAN)),
            ),
        })
        .collect();
    let hlines = if rec.f_max_n.is_finite() && rec.f_max_n > 0.0 {
        vec![HLine {
            label: format!("f_max = {:.1} N", rec.f_max_n),
            y: rec.f_max_n,
            color: RED,
            width: 2,
            dashed: true,
        }]
    } else {
        Vec::new()
    };
    TimePlot {
        x_desc: "time [s]",
        y_desc: "cable tension [N]",
        series,
        hlines,
        band: None,
        y_include: vec![0.0],
    }
}

pub(crate) fn distance_plot(rec: &RunRecord) -> TimePlot {
    let s = |label: &str, color: RGBColor, v: &[f64]| Series {
        label: label.into(),
        color,
        width: 2,
        points: time_series(&rec.time_s, v.iter().copied()),
    };
    TimePlot {
        x_desc: "time [s]",
        y_desc: "distance [m]",
        series: vec![
            s(
                "min UAV-boundary",
                RGBColor(31, 119, 180),
                &rec.min_uav_boundary_m,
            ),
            s(
                "load-boundary",
                RGBColor(44, 160, 44),
                &rec.min_load_boundary_m,
            ),
            s("min UAV-UAV", RGBColor(148, 103, 189), &rec.min_uav_uav_m),
        ],
        hlines: vec![HLine {
            label: format!("safety floor {SAFETY_FLOOR_M} m"),
            y: SAFETY_FLOOR_M,
            color: RED,
            width: 2,
            dashed: true,
        }],
        band: None,
        y_include: vec![0.0],
    }
}

pub(crate) fn altitude_plot(rec: &RunRecord) -> TimePlot {
    let z = rec.load_altitude_ref_m;
    let (hlines, band) = if z.is_finite() {
        (
            vec![HLine {
                label: format!("reference {z:.1} m"),
                y: z,
                color: BLACK,
                width: 2,
                dashed: false,
            }],
            Some((
                z - ALTITUDE_BAND_M,
                z + ALTITUDE_BAND_M,
                format!("reference +/- {ALTITUDE_BAND_M:.0} m"),
            )),
        )
    } else {
        (Vec::new(), None)
    };
    TimePlot {
        x_desc: "time [s]",
        y_desc: "load altitude [m]",
        series: vec![Series {
            label: "load altitude".into(),
            color: RGBColor(31, 119, 180),
            width: 2,
            points: time_series(&rec.time_s, rec.load_pos_m.iter().map(|p| p[2])),
        }],
        hlines,
        band,
        y_include: Vec::new(),
    }
}

pub(crate) fn draw_time_panel(
    area: &Area<'_>,
    title: &str,
    plot: &TimePlot,
    xr: Range<f64>,
    yr: Range<f64>,
) -> DynResult<()> {
    let (x0, x1) = (xr.start, xr.end);
    let inner = titled(area, title, TITLE_PX)?;
    let (ny, nx) = (8, 12);
    let mut chart = ChartBuilder::on(&inner)
        .margin_left(10)
        .margin_right(30)
        .margin_top(10)
        .margin_bottom(10)
        .x_label_area_size(60)
        .y_label_area_size(y_label_area(&yr, ny) + 10)
        .build_cartesian_2d(xr, yr)?;
    draw_axes(&inner, &mut chart, (nx, ny), plot.x_desc, plot.y_desc)?;

    if let Some((lo, hi, _)) = &plot.band {
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x0, *lo), (x1, *hi)],
            BAND_FILL.filled(),
        )))?;
        for y in [*lo, *hi] {
            chart.draw_series(DashedLineSeries::new(
                vec![(x0, y), (x1, y)],
                10,
                6,
                BAND_EDGE.stroke_width(1),
            ))?;
        }
    }
    for s in &plot.series {
        for run in finite_runs(s.points.iter().copied()) {
            let run = min_max_decimate(run, x0..x1, 2 * TS_PANEL.0 as usize);
            chart.draw_series(LineSeries::new(run, s.color.stroke_width(s.width)))?;
        }
    }
    for h in &plot.hlines {
        let pts = vec![(x0, h.y), (x1, h.y)];
        if h.dashed {
            chart.draw_series(DashedLineSeries::new(
                pts,
                12,
                8,
                h.color.stroke_width(h.width),
            ))?;
        } else {
            chart.draw_series(LineSeries::new(pts, h.color.stroke_width(h.width)))?;
        }
    }
    if plot.series.iter().all(|s| {
        s.points
            .iter()
            .all(|(x, y)| !(x.is_finite() && y.is_finite()))
    }) {
        draw_no_data(&inner, &chart)?;
    }
    Ok(())
}
