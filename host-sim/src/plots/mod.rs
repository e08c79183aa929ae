//! PNG plots of a run (and of two runs side by side), drawn with `plotters`.
//!
//! By concept: [`top_view`] (obstacles, tube, paths, formation snapshots), [`time_series`]
//! (tensions, clearances, load altitude, campaign xy plots), [`legend`] (the legend column),
//! [`axes`] (ticks, grid, axis titles), [`geometry`] (bounds, thinning, decimation, colours)
//! and [`text`] (the embedded DejaVu Sans and text layout, shared with `xtask`; it says what
//! stays hand-written and why). Nothing is needed from the machine (no system fonts,
//! fontconfig or freetype).
//!
//! Non-finite samples are skipped (lines are broken there); empty records give plots with
//! empty axes and a "no samples recorded" note.

use std::error::Error;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::record::{RunRecord, SceneGeometry};

mod axes;
mod geometry;
mod legend;
pub mod text;
mod time_series;
mod top_view;

use axes::*;
use geometry::*;
pub(crate) use geometry::uav_color;
use legend::*;
use text::*;
use time_series::*;
use top_view::*;

/// Safety floor drawn on the distance plot, m.
const SAFETY_FLOOR_M: f64 = 0.4;
/// Half width of the load-altitude band, m.
const ALTITUDE_BAND_M: f64 = 1.0;
/// Number of formation snapshots on the top view.
const N_SNAPSHOTS: usize = 6;
/// Width of the legend column at the right of every figure, px.
const LEGEND_W: u32 = 230;
/// Pixel size of a time-series panel (without the legend column).
const TS_PANEL: (u32, u32) = (1180, 620);
/// Text sizes, px.
const TITLE_PX: f32 = 26.0;
const SUPTITLE_PX: f32 = 30.0;
const TICK_PX: f32 = 16.0;
const DESC_PX: f32 = 20.0;

/// A plot could not be written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlotError {
    /// File (or directory) concerned.
    pub path: PathBuf,
    /// What went wrong (text of the underlying plotters / io error).
    pub message: String,
}

impl PlotError {
    fn new(path: &Path, message: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "cannot write plot {}: {}",
            self.path.display(),
            self.message
        )
    }
}

impl Error for PlotError {}

type DynResult<T> = Result<T, Box<dyn Error>>;
type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Writes `top_view.png`, `tensions.png`, `distances.png` and `load_altitude.png` into `dir`
/// (created if missing) and returns their paths.
pub fn write_run_plots(
    dir: &Path,
    scene: &SceneGeometry,
    rec: &RunRecord,
) -> Result<Vec<PathBuf>, PlotError> {
    prepare(dir)?;
    let mut out = Vec::with_capacity(4);

    let path = dir.join("top_view.png");
    let bounds = top_view_bounds(scene, &[rec]);
    render(&path, top_view_size(&bounds, 1), |root| {
        let (panel, legend) =
            root.split_horizontally(root.dim_in_pixel().0.saturating_sub(LEGEND_W));
        let title = format!(
            "Top view - scenario: {}, controller: {}",
            rec.scenario, rec.controller
        );
        draw_top_panel(&panel, scene, rec, &bounds, &title)?;
        draw_legend(&legend, &top_view_legend(scene, rec), 60)
    })?;
    out.push(path);

    let (scenario, controller) = (&rec.scenario, &rec.controller);
    let time_plots = [
        (
            "tensions.png",
            format!("Cable tensions - {scenario} / {controller}"),
            tension_plot(rec),
        ),
        (
            "distances.png",
            format!("Clearances - {scenario} / {controller}"),
            distance_plot(rec),
        ),
        (
            "load_altitude.png",
            format!("Load altitude - {scenario} / {controller}"),
            altitude_plot(rec),
        ),
    ];
    for (name, title, plot) in &time_plots {
        let path = dir.join(name);
        render(&path, (TS_PANEL.0 + LEGEND_W, TS_PANEL.1), |root| {
            let (panel, legend) = root.split_horizontally(TS_PANEL.0);
            let (xr, yr) = plot.ranges(&[]);
            draw_time_panel(&panel, title, plot, xr, yr)?;
            draw_legend(&legend, &plot.legend(), 60)
        })?;
        out.push(path);
    }
    Ok(out)
}

/// Writes `compare_top_view.png` and `compare_tensions.png` into `dir` (created if missing):
/// runs `a` (left panel) and `b` (right panel) on identical axes. Returns the paths.
pub fn write_comparison_plots(
    dir: &Path,
    scene: &SceneGeometry,
    a: &RunRecord,
    b: &RunRecord,
) -> Result<Vec<PathBuf>, PlotError> {
    prepare(dir)?;
    let mut out = Vec::with_capacity(2);
    let scenario = if a.scenario == b.scenario {
        a.scenario.clone()
    } else {
        format!("{} | {}", a.scenario, b.scenario)
    };

    let path = dir.join("compare_top_view.png");
    let bounds = top_view_bounds(scene, &[a, b]);
    render(&path, top_view_size(&bounds, 2), |root| {
        let (w, _) = root.dim_in_pixel();
        let title = format!(
            "Top view - scenario: {scenario} - {} vs {}",
            a.controller, b.controller
        );
        let body = titled(root, &title, SUPTITLE_PX)?;
        let (panels, legend) = body.split_horizontally(w.saturating_sub(LEGEND_W));
        for (half, rec) in panels.split_evenly((1, 2)).iter().zip([a, b]) {
            draw_top_panel(
                half,
                scene,
                rec,
                &bounds,
                &format!("controller: {}", rec.controller),
            )?;
        }
        let widest = if n_uavs(b) > n_uavs(a) { b } else { a };
        draw_legend(&legend, &top_view_legend(scene, widest), 40)
    })?;
    out.push(path);

    let path = dir.join("compare_tensions.png");
    let (pa, pb) = (tension_plot(a), tension_plot(b));
    let (xr, yr) = pa.ranges(std::slice::from_ref(&pb));
    let panel_w = 1000u32;
    render(&path, (2 * panel_w + LEGEND_W, TS_PANEL.1 + 50), |root| {
        let title = format!(
            "Cable tensions - scenario: {scenario} - {} vs {}",
            a.controller, b.controller
        );
        let body = titled(root, &title, SUPTITLE_PX)?;
        let (panels, legend) = body.split_horizontally(2 * panel_w);
        for ((half, plot), rec) in panels
            .split_evenly((1, 2))
            .iter()
            .zip([&pa, &pb])
            .zip([a, b])
        {
            draw_time_panel(
                half,
                &format!("controller: {}", rec.controller),
                plot,
                xr.clone(),
                yr.clone(),
            )?;
        }
        let widest = if pb.series.len() > pa.series.len() {
            &pb
        } else {
            &pa
        };
        draw_legend(&legend, &widest.legend(), 40)
    })?;
    out.push(path);

    Ok(out)
}

/// Writes a line plot of `series` (label, points) to `path`: e.g. success rate against
/// disturbance level for a campaign. `y_include` values are kept inside the y range.
pub fn write_xy_plot(
    path: &Path,
    title: &str,
    x_desc: &'static str,
    y_desc: &'static str,
    series: &[(String, Vec<(f64, f64)>)],
    y_include: &[f64],
) -> Result<PathBuf, PlotError> {
    if let Some(dir) = path.parent() {
        prepare(dir)?;
    }
    let plot = TimePlot {
        x_desc,
        y_desc,
        series: series
            .iter()
            .enumerate()
            .map(|(i, (label, pts))| Series { label: label.clone(), color: uav_color(i), width: 3, points: pts.clone() })
            .collect(),
        hlines: Vec::new(),
        band: None,
        y_include: y_include.to_vec(),
    };
    render(path, (TS_PANEL.0 + LEGEND_W, TS_PANEL.1), |root| {
        let (panel, legend) = root.split_horizontally(TS_PANEL.0);
        let (xr, yr) = plot.ranges(&[]);
        draw_time_panel(&panel, title, &plot, xr, yr)?;
        draw_legend(&legend, &plot.legend(), 60)
    })?;
    Ok(path.to_path_buf())
}

fn prepare(dir: &Path) -> Result<(), PlotError> {
    register_fonts().map_err(|m| PlotError::new(dir, m))?;
    std::fs::create_dir_all(dir).map_err(|e| PlotError::new(dir, e.to_string()))
}

/// Creates a white `size` PNG at `path`, lets `draw` paint it and saves it.
fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> DynResult<()>,
) -> Result<(), PlotError> {
    let res = (|| -> DynResult<()> {
        let root = BitMapBackend::new(path, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
        Ok(())
    })();
    res.map_err(|e| PlotError::new(path, e.to_string()))
}


#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )]

    use super::*;
    use crate::record::Obstacle;

    /// Tube half width as a function of arc position `u` in [0, 1]: 4 m, narrowing to 2.2 m mid-way.
    fn half_width(u: f64) -> f64 {
        4.0 - 1.8 * (-((u - 0.5) / 0.1).powi(2)).exp()
    }

    /// S-shaped centreline over 60 m and its unit normal.
    fn curve(u: f64) -> ([f64; 2], [f64; 2]) {
        let x = 60.0 * u;
        let y = 8.0 * (std::f64::consts::TAU * u).sin();
        let dy = 8.0 * std::f64::consts::TAU / 60.0 * (std::f64::consts::TAU * u).cos();
        let norm = (1.0 + dy * dy).sqrt();
        ([x, y], [-dy / norm, 1.0 / norm])
    }

    fn synthetic() -> (SceneGeometry, RunRecord) {
        let mut scene = SceneGeometry::default();
        for k in 0..=300 {
            let u = f64::from(k) / 300.0;
            let (g, n) = curve(u);
            let w = half_width(u);
            scene.centerline.push(g);
            scene.left_boundary.push([g[0] + w * n[0], g[1] + w * n[1]]);
            scene
                .right_boundary
                .push([g[0] - w * n[0], g[1] - w * n[1]]);
        }
        for j in 0..11 {
            let u = 0.05 + 0.9 * f64::from(j) / 10.0;
            let (g, n) = curve(u);
            let side = if j % 2 == 0 { 1.0 } else { -1.0 };
            let r = 0.8 + 0.3 * f64::from(j % 3);
            let d = side * (half_width(u) + r + 0.3);
            scene.obstacles.push(Obstacle {
                center_m: [g[0] + d * n[0], g[1] + d * n[1]],
                radius_m: r,
            });
        }
        scene.bounds_m = [-5.0, 65.0, -16.0, 16.0];

        let mut rec = RunRecord {
            scenario: "s_tube_narrow".into(),
            controller: "dissipative".into(),
            f_max_n: 30.0,
            load_altitude_ref_m: 10.0,
            ..RunRecord::default()
        };
        let n_uav = 10;
        let mut seed = 12345u64;
        let mut noise = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for k in 0..=600 {
            let t = f64::from(k) * 0.1;
            let u = t / 60.0;
            let (g, n) = curve(u);
            let tang = [n[1], -n[0]];
            // Circle of 2.5 m flattening across the tube in the narrow part.
            let squeeze = (half_width(u) - 1.0) / 3.0;
            let b = 2.5 * squeeze.clamp(0.3, 1.0);
            let a = 2.5 * (2.0 - squeeze.clamp(0.3, 1.0));
            rec.time_s.push(t);
            let z = 10.0 + 0.4 * (t * 0.7).sin();
            rec.load_pos_m.push([g[0], g[1], z]);
            rec.load_vel_mps.push([1.0, 0.0, 0.0]);
            let mut pos = Vec::new();
            let mut ten = Vec::new();
            for i in 0..n_uav {
                let phi = std::f64::consts::TAU * f64::from(i) / f64::from(n_uav);
                let (ct, cn) = (a * phi.cos(), b * phi.sin());
                pos.push([
                    g[0] + ct * tang[0] + cn * n[0],
                    g[1] + ct * tang[1] + cn * n[1],
                    z + 3.0,
                ]);
                ten.push(17.0 + 1.5 * noise() + 2.0 * (1.0 - squeeze) * phi.cos());
            }
            rec.uav_pos_m.push(pos);
            rec.tension_n.push(ten);
            rec.min_uav_boundary_m
                .push(half_width(u) - b - 0.1 * noise().abs());
            rec.min_load_boundary_m.push(half_width(u));
            rec.min_uav_uav_m
                .push(2.0 * a * (std::f64::consts::PI / 10.0).sin() * squeeze.max(0.4));
        }
        (scene, rec)
    }

    fn temp_dir(tag: &str) -> PathBuf {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        std::env::temp_dir().join(format!(
            "host-sim-plots-{tag}-{}-{nanos}",
            std::process::id()
        ))
    }

    fn assert_png(p: &Path) {
        let bytes = std::fs::read(p).unwrap();
        assert!(
            bytes.len() > 10_000,
            "{} is only {} bytes",
            p.display(),
            bytes.len()
        );
        assert_eq!(
            &bytes[..8],
            b"\x89PNG\r\n\x1a\n",
            "{} is not a PNG",
            p.display()
        );
    }

    #[test]
    fn synthetic_run_plots_are_written() {
        let (scene, rec) = synthetic();
        let mut other = rec.clone();
        other.controller = "baseline".into();
        for row in &mut other.tension_n {
            for t in row.iter_mut() {
                *t *= 1.3;
            }
        }
        // A few NaNs must be skipped, not drawn or panicked on.
        other.load_pos_m[100] = [f64::NAN; 3];
        other.tension_n[50][3] = f64::NAN;
        other.min_uav_uav_m[20] = f64::INFINITY;

        let dir = temp_dir("synthetic");
        let files = write_run_plots(&dir, &scene, &rec).unwrap();
        let names: Vec<_> = files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "top_view.png",
                "tensions.png",
                "distances.png",
                "load_altitude.png"
            ]
        );
        let cmp = write_comparison_plots(&dir, &scene, &rec, &other).unwrap();
        assert_eq!(cmp.len(), 2);
        for p in files.iter().chain(&cmp) {
            assert!(p.exists());
            assert_png(p);
        }
        if std::env::var_os("KEEP_PLOTS").is_none() {
            std::fs::remove_dir_all(&dir).unwrap();
        } else {
            eprintln!("plots kept in {}", dir.display());
        }
    }

    #[test]
    fn empty_and_nan_records_do_not_panic() {
        let dir = temp_dir("empty");
        let empty = RunRecord {
            f_max_n: f64::INFINITY,
            load_altitude_ref_m: f64::NAN,
            ..RunRecord::default()
        };
        let files = write_run_plots(&dir, &SceneGeometry::default(), &empty).unwrap();
        assert_eq!(files.len(), 4);
        let nan = RunRecord {
            time_s: vec![f64::NAN, 1.0],
            uav_pos_m: vec![vec![[f64::NAN; 3]], vec![]],
            tension_n: vec![vec![f64::NAN], vec![]],
            load_pos_m: vec![[f64::NAN; 3]],
            min_uav_boundary_m: vec![f64::NAN; 5],
            ..RunRecord::default()
        };
        let files = write_comparison_plots(&dir, &SceneGeometry::default(), &empty, &nan).unwrap();
        assert_eq!(files.len(), 2);
        for p in &files {
            assert!(std::fs::metadata(p).unwrap().len() > 0);
        }
        if std::env::var_os("KEEP_PLOTS").is_none() {
            std::fs::remove_dir_all(&dir).unwrap();
        } else {
            eprintln!("plots kept in {}", dir.display());
        }
    }

    #[test]
    fn decimation_keeps_extremes_and_order() {
        let run: Vec<(f64, f64)> = (0..100_000)
            .map(|k| {
                let t = f64::from(k) * 1e-3;
                (t, if k == 54_321 { 99.0 } else { (t * 3.0).sin() })
            })
            .collect();
        let out = min_max_decimate(run, 0.0..100.0, 1000);
        assert!(out.len() <= 4 * 1000 + 4, "{}", out.len());
        assert!(out.iter().any(|p| p.1 == 99.0));
        assert!(out.windows(2).all(|w| w[0].0 <= w[1].0));
        assert_eq!(out.first().unwrap().0, 0.0);
        assert!((out.last().unwrap().0 - 99.999).abs() < 1e-9);
    }

    #[test]
    fn equal_aspect_fit() {
        let b = Bounds {
            x0: 0.0,
            x1: 60.0,
            y0: -10.0,
            y1: 10.0,
        }
        .fit_aspect(1200, 300);
        let sx = (b.x1 - b.x0) / 1200.0;
        let sy = (b.y1 - b.y0) / 300.0;
        assert!((sx - sy).abs() < 1e-12);
        assert!(b.x0 <= 0.0 && b.x1 >= 60.0 && b.y0 <= -10.0 && b.y1 >= 10.0);
    }
}
