//! Top view of a planned tube (issue 16): the map (obstacles grey), the corridor's free discs
//! (light blue), the tube's boundaries (blue), the generator curve (black), start (green) and
//! goal (red) and the bottleneck (orange). No text, so it needs no font; `docs/planning.md`
//! carries the caption. The run's top view (`plots::top_view`) draws [`draw_map`] and
//! [`draw_corridor`] under its tube and paths for a planned scenario.

use crate::map::{LoadedMap, Map, Shape};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::Path;
use vt_plan::PlannedTube;
use vt_tube::{Tube, DEFAULT_SAMPLES};

type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;
type DynResult<T> = Result<T, Box<dyn std::error::Error>>;

/// Pixels per metre at most, and the figure's largest side, px.
const MAX_SIDE_PX: f64 = 1400.0;

fn circle_pts(c: [f64; 2], r: f64) -> Vec<(f64, f64)> {
    (0..=72).map(|k| {
        let a = f64::from(k) / 72.0 * std::f64::consts::TAU;
        (c[0] + r * a.cos(), c[1] + r * a.sin())
    }).collect()
}

/// Draws the map's obstacles (grey) on `chart`.
///
/// # Errors
/// A plotters drawing error.
pub fn draw_map(chart: &mut Chart<'_, '_>, map: &LoadedMap) -> DynResult<()> {
    let grey = RGBColor(120, 120, 120).filled();
    match &map.map {
        Map::Geometric { shapes, .. } => {
            for s in shapes {
                let pts = match s {
                    Shape::Circle { center_m, radius_m } => circle_pts(*center_m, *radius_m),
                    Shape::Polygon(v) => v.iter().map(|p| (p[0], p[1])).collect(),
                    Shape::Wall { from_m, to_m, thickness_m } => {
                        let (dx, dy) = (to_m[0] - from_m[0], to_m[1] - from_m[1]);
                        let len = dx.hypot(dy).max(1e-9);
                        let (nx, ny) = (-dy / len * thickness_m / 2.0, dx / len * thickness_m / 2.0);
                        vec![(from_m[0] + nx, from_m[1] + ny), (to_m[0] + nx, to_m[1] + ny), (to_m[0] - nx, to_m[1] - ny), (from_m[0] - nx, from_m[1] - ny)]
                    }
                };
                chart.draw_series(std::iter::once(Polygon::new(pts, grey)))?;
            }
        }
        Map::Grid(g) => {
            let r = g.resolution_m;
            let cells = g.occupied.iter().enumerate().filter(|(_, &o)| o).map(|(k, _)| {
                let (i, j) = ((k % g.width) as f64, (k / g.width) as f64);
                let x0 = g.origin_m[0] + i * r;
                let y0 = g.origin_m[1] + j * r;
                Rectangle::new([(x0, y0), (x0 + r, y0 + r)], grey)
            });
            chart.draw_series(cells)?;
        }
    }
    Ok(())
}

/// Draws the corridor's discs (light blue) and the bottleneck (orange) on `chart`: what the
/// run's top view adds to its own tube and paths.
///
/// # Errors
/// A plotters drawing error.
pub fn draw_corridor(chart: &mut Chart<'_, '_>, t: &PlannedTube) -> DynResult<()> {
    let disc_col = RGBColor(150, 200, 240);
    for d in &t.discs {
        let pts = circle_pts([f64::from(d.center_m.x), f64::from(d.center_m.y)], f64::from(d.radius_m));
        chart.draw_series(std::iter::once(PathElement::new(pts, disc_col.stroke_width(1))))?;
    }
    let bn = &t.bottleneck;
    let pts = circle_pts([f64::from(bn.pos_m.x), f64::from(bn.pos_m.y)], f64::from(bn.half_width_m));
    chart.draw_series(std::iter::once(PathElement::new(pts, RGBColor(240, 140, 0).stroke_width(3))))?;
    Ok(())
}

/// Draws the corridor's discs, the tube and the bottleneck on `chart`.
///
/// # Errors
/// A plotters drawing error or a tube vt-tube rejects.
pub fn draw_plan(chart: &mut Chart<'_, '_>, t: &PlannedTube) -> DynResult<()> {
    draw_corridor(chart, t)?;
    let tube = Tube::<DEFAULT_SAMPLES>::from_waypoints(&t.waypoints).map_err(|e| e.to_string())?;
    let xy = |p: vt_tube::Vec2| (f64::from(p.x), f64::from(p.y));
    let left: Vec<_> = tube.samples().iter().map(|s| xy(s.left_boundary_m())).collect();
    let right: Vec<_> = tube.samples().iter().map(|s| xy(s.right_boundary_m())).collect();
    let centre: Vec<_> = tube.samples().iter().map(|s| xy(s.pos_m)).collect();
    let blue = RGBColor(20, 60, 200);
    chart.draw_series(std::iter::once(PathElement::new(left, blue.stroke_width(3))))?;
    chart.draw_series(std::iter::once(PathElement::new(right, blue.stroke_width(3))))?;
    chart.draw_series(std::iter::once(PathElement::new(centre, BLACK.stroke_width(2))))?;
    for w in &t.waypoints {
        chart.draw_series(std::iter::once(Circle::new(xy(w.pos_m), 3, BLACK.filled())))?;
    }
    if let (Some(a), Some(b)) = (t.waypoints.first(), t.waypoints.last()) {
        chart.draw_series(std::iter::once(Circle::new(xy(a.pos_m), 8, GREEN.filled())))?;
        chart.draw_series(std::iter::once(Circle::new(xy(b.pos_m), 8, RED.filled())))?;
    }
    Ok(())
}

/// Writes a PNG of `map` with the planned tube `t`.
///
/// # Errors
/// The file or drawing error, as text naming the file.
pub fn write(path: &Path, map: &LoadedMap, t: &PlannedTube) -> Result<(), String> {
    let b = map.bounds_m();
    let (w, h) = (b[1] - b[0], b[3] - b[2]);
    let scale = MAX_SIDE_PX / w.max(h);
    let size = ((w * scale).round().max(50.0) as u32, (h * scale).round().max(50.0) as u32);
    let draw = || -> DynResult<()> {
        let root = BitMapBackend::new(path, size).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root).build_cartesian_2d(b[0]..b[1], b[2]..b[3])?;
        draw_map(&mut chart, map)?;
        draw_plan(&mut chart, t)?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("cannot write plot {}: {e}", path.display()))
}
