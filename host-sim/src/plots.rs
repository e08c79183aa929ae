//! PNG plots of a run (and of two runs side by side), drawn with `plotters`.
//!
//! Text is rendered with DejaVu Sans embedded in the binary (crate `dejavu`) through
//! plotters' `ab_glyph` backend, so no system fonts, fontconfig or freetype are needed.
//! Non-finite samples are skipped (lines are broken there); empty records give plots
//! with empty axes and a "no samples" note.

use std::error::Error;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use crate::record::{RunRecord, SceneGeometry};

/// Font family name under which the embedded font is registered.
const FONT: &str = "sans-serif";
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
        Self { path: path.to_path_buf(), message: message.into() }
    }
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write plot {}: {}", self.path.display(), self.message)
    }
}

impl Error for PlotError {}

type DynResult<T> = Result<T, Box<dyn Error>>;
type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Registers the embedded font once; later calls return the first outcome.
fn ensure_fonts() -> Result<(), String> {
    static FONTS: OnceLock<Result<(), String>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "embedded DejaVu Sans font is invalid".to_string())?;
            register_font(FONT, FontStyle::Bold, dejavu::sans::bold())
                .map_err(|_| "embedded DejaVu Sans Bold font is invalid".to_string())?;
            Ok(())
        })
        .clone()
}

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
    render(&path, top_view_size(&top_view_bounds(scene, &[rec]), 1), |root| {
        let (panel, legend) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(LEGEND_W));
        let title = format!("Top view - scenario: {}, controller: {}", rec.scenario, rec.controller);
        draw_top_panel(&panel, scene, rec, &top_view_bounds(scene, &[rec]), &title)?;
        draw_legend(&legend, &top_view_legend(scene, rec), 60)
    })?;
    out.push(path);

    let path = dir.join("tensions.png");
    render(&path, (TS_PANEL.0 + LEGEND_W, TS_PANEL.1), |root| {
        let (panel, legend) = root.split_horizontally(TS_PANEL.0);
        let plot = tension_plot(rec);
        let (xr, yr) = plot.ranges(&[]);
        let title = format!("Cable tensions - {} / {}", rec.scenario, rec.controller);
        draw_time_panel(&panel, &title, &plot, xr, yr)?;
        draw_legend(&legend, &plot.legend(), 60)
    })?;
    out.push(path);

    let path = dir.join("distances.png");
    render(&path, (TS_PANEL.0 + LEGEND_W, TS_PANEL.1), |root| {
        let (panel, legend) = root.split_horizontally(TS_PANEL.0);
        let plot = distance_plot(rec);
        let (xr, yr) = plot.ranges(&[]);
        let title = format!("Clearances - {} / {}", rec.scenario, rec.controller);
        draw_time_panel(&panel, &title, &plot, xr, yr)?;
        draw_legend(&legend, &plot.legend(), 60)
    })?;
    out.push(path);

    let path = dir.join("load_altitude.png");
    render(&path, (TS_PANEL.0 + LEGEND_W, TS_PANEL.1), |root| {
        let (panel, legend) = root.split_horizontally(TS_PANEL.0);
        let plot = altitude_plot(rec);
        let (xr, yr) = plot.ranges(&[]);
        let title = format!("Load altitude - {} / {}", rec.scenario, rec.controller);
        draw_time_panel(&panel, &title, &plot, xr, yr)?;
        draw_legend(&legend, &plot.legend(), 60)
    })?;
    out.push(path);

    Ok(out)
}

/// Writes `compare_top_view.png` and `compare_tensions.png` into `dir` (created if missing):
/// runs `a` (left) and `b` (right) on identical axes. Returns the paths.
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
        let body = root.titled(
            &format!("Top view - scenario: {scenario}: {} vs {}", a.controller, b.controller),
            (FONT, 30).into_font().style(FontStyle::Bold),
        )?;
        let (panels, legend) = body.split_horizontally(w.saturating_sub(LEGEND_W));
        let halves = panels.split_evenly((1, 2));
        for (half, rec) in halves.iter().zip([a, b]) {
            draw_top_panel(half, scene, rec, &bounds, &format!("controller: {}", rec.controller))?;
        }
        draw_legend(&legend, &top_view_legend(scene, a), 40)
    })?;
    out.push(path);

    let path = dir.join("compare_tensions.png");
    let plots = [tension_plot(a), tension_plot(b)];
    let (xr, yr) = plots[0].ranges(&plots[1..]);
    let panel_w = 1000u32;
    render(&path, (2 * panel_w + LEGEND_W, TS_PANEL.1 + 50), |root| {
        let body = root.titled(
            &format!("Cable tensions - scenario: {scenario}: {} vs {}", a.controller, b.controller),
            (FONT, 30).into_font().style(FontStyle::Bold),
        )?;
        let (panels, legend) = body.split_horizontally(2 * panel_w);
        let halves = panels.split_evenly((1, 2));
        for ((half, plot), rec) in halves.iter().zip(&plots).zip([a, b]) {
            draw_time_panel(half, &format!("controller: {}", rec.controller), plot, xr.clone(), yr.clone())?;
        }
        let longer = if plots[1].series.len() > plots[0].series.len() { &plots[1] } else { &plots[0] };
        draw_legend(&legend, &longer.legend(), 40)
    })?;
    out.push(path);

    Ok(out)
}

fn prepare(dir: &Path) -> Result<(), PlotError> {
    ensure_fonts().map_err(|m| PlotError::new(dir, m))?;
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

// ---------------------------------------------------------------- geometry helpers

/// Axis-aligned box accumulated from finite points.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bounds {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Bounds {
    fn empty() -> Self {
        Self { x0: f64::INFINITY, x1: f64::NEG_INFINITY, y0: f64::INFINITY, y1: f64::NEG_INFINITY }
    }
    fn add(&mut self, x: f64, y: f64) {
        if x.is_finite() && y.is_finite() {
            self.x0 = self.x0.min(x);
            self.x1 = self.x1.max(x);
            self.y0 = self.y0.min(y);
            self.y1 = self.y1.max(y);
        }
    }
    fn is_valid(&self) -> bool {
        self.x0.is_finite() && self.x1.is_finite() && self.y0.is_finite() && self.y1.is_finite()
    }
    /// Pads by `frac` of the larger side (at least `min_pad`); a degenerate/empty box becomes usable.
    fn padded(&self, frac: f64, min_pad: f64) -> Self {
        if !self.is_valid() {
            return Self { x0: -1.0, x1: 1.0, y0: -1.0, y1: 1.0 };
        }
        let p = ((self.x1 - self.x0).max(self.y1 - self.y0) * frac).max(min_pad);
        Self { x0: self.x0 - p, x1: self.x1 + p, y0: self.y0 - p, y1: self.y1 + p }
    }
    /// Grows the short side so that a `pw` x `ph` pixel area has the same metres per pixel in x and y.
    fn fit_aspect(&self, pw: u32, ph: u32) -> Self {
        let (pw, ph) = (f64::from(pw.max(1)), f64::from(ph.max(1)));
        let (dx, dy) = ((self.x1 - self.x0).max(1e-9), (self.y1 - self.y0).max(1e-9));
        let scale = (dx / pw).max(dy / ph);
        let (cx, cy) = ((self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0);
        let (hx, hy) = (scale * pw / 2.0, scale * ph / 2.0);
        Self { x0: cx - hx, x1: cx + hx, y0: cy - hy, y1: cy + hy }
    }
}

fn top_view_bounds(scene: &SceneGeometry, recs: &[&RunRecord]) -> Bounds {
    let mut b = Bounds::empty();
    let [bx0, bx1, by0, by1] = scene.bounds_m;
    if bx1 > bx0 && by1 > by0 {
        b.add(bx0, by0);
        b.add(bx1, by1);
    }
    for line in [&scene.centerline, &scene.left_boundary, &scene.right_boundary] {
        for p in line.iter() {
            b.add(p[0], p[1]);
        }
    }
    for o in &scene.obstacles {
        if o.radius_m.is_finite() && o.radius_m >= 0.0 {
            b.add(o.center_m[0] - o.radius_m, o.center_m[1] - o.radius_m);
            b.add(o.center_m[0] + o.radius_m, o.center_m[1] + o.radius_m);
        }
    }
    for rec in recs {
        for p in &rec.load_pos_m {
            b.add(p[0], p[1]);
        }
        for row in &rec.uav_pos_m {
            for p in row {
                b.add(p[0], p[1]);
            }
        }
    }
    b.padded(0.02, 0.5)
}

/// Figure size for `panels` top views side by side: height follows the scene's aspect ratio.
fn top_view_size(b: &Bounds, panels: u32) -> (u32, u32) {
    let plot_w: f64 = if panels <= 1 { 1270.0 } else { 1040.0 };
    let aspect = ((b.y1 - b.y0) / (b.x1 - b.x0).max(1e-9)).clamp(0.05, 20.0);
    let overhead = if panels <= 1 { 150.0 } else { 200.0 };
    // Saturating float-to-int cast; clamped to a sane range first.
    let h = (plot_w * aspect + overhead).clamp(450.0, 1500.0) as u32;
    let w = if panels <= 1 { 1600 } else { 2 * 1150 + LEGEND_W };
    (w, h)
}

/// Splits a point stream into runs of finite points (a line is broken at every NaN/inf).
fn finite_runs(points: impl IntoIterator<Item = (f64, f64)>) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for (x, y) in points {
        if x.is_finite() && y.is_finite() {
            cur.push((x, y));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

fn circle_points(c: [f64; 2], r: f64) -> Vec<(f64, f64)> {
    (0..64)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 64.0;
            (c[0] + r * a.cos(), c[1] + r * a.sin())
        })
        .collect()
}

fn n_uavs(rec: &RunRecord) -> usize {
    let pos = rec.uav_pos_m.iter().map(Vec::len).max().unwrap_or(0);
    let ten = rec.tension_n.iter().map(Vec::len).max().unwrap_or(0);
    pos.max(ten)
}

/// Distinct colour for UAV `i` (tab10, then evenly spread hues).
fn uav_color(i: usize) -> RGBColor {
    const TAB10: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    match TAB10.get(i) {
        Some(c) => *c,
        None => {
            // Golden-ratio hue walk for larger teams.
            let h = (i as f64 * 0.618_033_988_75).fract();
            let c = HSLColor(h, 0.7, 0.45).to_backend_color();
            RGBColor(c.rgb.0, c.rgb.1, c.rgb.2)
        }
    }
}

const BOUNDARY_COLOR: RGBColor = RGBColor(40, 55, 90);
const CENTERLINE_COLOR: RGBColor = RGBColor(150, 150, 150);
const OBSTACLE_FILL: RGBColor = RGBColor(175, 175, 175);
const OBSTACLE_EDGE: RGBColor = RGBColor(110, 110, 110);
const LOAD_COLOR: RGBColor = RGBColor(0, 0, 0);

// ---------------------------------------------------------------- top view

fn draw_top_panel(
    area: &Area<'_>,
    scene: &SceneGeometry,
    rec: &RunRecord,
    bounds: &Bounds,
    title: &str,
) -> DynResult<()> {
    let inner = area.titled(title, (FONT, 26).into_font().style(FontStyle::Bold))?;
    let builder = |b: &Bounds| -> DynResult<_> {
        Ok(ChartBuilder::on(&inner)
            .margin_left(10)
            .margin_right(25)
            .margin_top(10)
            .margin_bottom(10)
            .x_label_area_size(55)
            .y_label_area_size(70)
            .build_cartesian_2d(b.x0..b.x1, b.y0..b.y1)?)
    };
    // Measure the plotting area first, then rebuild with equal metres-per-pixel on both axes.
    let (pw, ph) = builder(bounds)?.plotting_area().dim_in_pixel();
    let fitted = bounds.fit_aspect(pw, ph);
    let mut chart = builder(&fitted)?;
    chart
        .configure_mesh()
        .x_desc("x (east) [m]")
        .y_desc("y (north) [m]")
        .x_labels((pw / 90).max(3) as usize)
        .y_labels((ph / 90).max(3) as usize)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 20))
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(RGBColor(245, 245, 245))
        .draw()?;

    // Obstacles.
    for o in &scene.obstacles {
        let ok = o.center_m.iter().all(|v| v.is_finite()) && o.radius_m.is_finite() && o.radius_m > 0.0;
        if ok {
            let pts = circle_points(o.center_m, o.radius_m);
            chart.draw_series(std::iter::once(Polygon::new(pts.clone(), OBSTACLE_FILL.filled())))?;
            let mut ring = pts;
            if let Some(first) = ring.first().copied() {
                ring.push(first);
            }
            chart.draw_series(std::iter::once(PathElement::new(ring, OBSTACLE_EDGE.stroke_width(1))))?;
        }
    }

    // Tube: centreline dashed, boundaries dark.
    for run in finite_runs(scene.centerline.iter().map(|p| (p[0], p[1]))) {
        chart.draw_series(DashedLineSeries::new(run, 12, 8, CENTERLINE_COLOR.stroke_width(2)))?;
    }
    for line in [&scene.left_boundary, &scene.right_boundary] {
        for run in finite_runs(line.iter().map(|p| (p[0], p[1]))) {
            chart.draw_series(LineSeries::new(run, BOUNDARY_COLOR.stroke_width(3)))?;
        }
    }

    // Paths: UAVs thin, load thick on top.
    for i in 0..n_uavs(rec) {
        let pts = rec.uav_pos_m.iter().map(|row| row.get(i).map_or((f64::NAN, f64::NAN), |p| (p[0], p[1])));
        for run in finite_runs(pts) {
            chart.draw_series(LineSeries::new(run, uav_color(i).mix(0.75).stroke_width(1)))?;
        }
    }
    for run in finite_runs(rec.load_pos_m.iter().map(|p| (p[0], p[1]))) {
        chart.draw_series(LineSeries::new(run, LOAD_COLOR.stroke_width(4)))?;
    }

    // Formation snapshots.
    for k in snapshot_indices(rec) {
        let Some(row) = rec.uav_pos_m.get(k) else { continue };
        let uavs: Vec<(usize, (f64, f64))> = row
            .iter()
            .enumerate()
            .map(|(i, p)| (i, (p[0], p[1])))
            .filter(|(_, (x, y))| x.is_finite() && y.is_finite())
            .collect();
        let load = rec.load_pos_m.get(k).map(|p| (p[0], p[1])).filter(|(x, y)| x.is_finite() && y.is_finite());
        if uavs.is_empty() && load.is_none() {
            continue;
        }
        // Order the vertices by angle around their centroid so the polygon is simple.
        let n = uavs.len().max(1) as f64;
        let cx = uavs.iter().map(|(_, p)| p.0).sum::<f64>() / n;
        let cy = uavs.iter().map(|(_, p)| p.1).sum::<f64>() / n;
        let mut ring: Vec<(f64, f64)> = uavs.iter().map(|(_, p)| *p).collect();
        ring.sort_by(|a, b| (a.1 - cy).atan2(a.0 - cx).total_cmp(&(b.1 - cy).atan2(b.0 - cx)));
        if ring.len() >= 3 {
            chart.draw_series(std::iter::once(Polygon::new(ring.clone(), BLACK.mix(0.08).filled())))?;
        }
        if let Some(first) = ring.first().copied() {
            ring.push(first);
        }
        if ring.len() >= 2 {
            chart.draw_series(std::iter::once(PathElement::new(ring, BLACK.stroke_width(2))))?;
        }
        for (i, p) in &uavs {
            chart.draw_series(std::iter::once(Circle::new(*p, 5, uav_color(*i).filled())))?;
            chart.draw_series(std::iter::once(Circle::new(*p, 5, BLACK.stroke_width(1))))?;
        }
        if let Some(l) = load {
            chart.draw_series(std::iter::once(Circle::new(l, 7, WHITE.filled())))?;
            chart.draw_series(std::iter::once(Circle::new(l, 7, LOAD_COLOR.stroke_width(3))))?;
        }
        // Time tag above the formation.
        let top = uavs
            .iter()
            .map(|(_, p)| *p)
            .chain(load)
            .fold(None::<(f64, f64)>, |acc, p| match acc {
                Some(a) if a.1 >= p.1 => Some(a),
                _ => Some(p),
            });
        if let (Some(t), Some(top)) = (rec.time_s.get(k).filter(|t| t.is_finite()), top) {
            let anchor = (load.map_or(cx, |l| l.0), top.1);
            let style = TextStyle::from((FONT, 17).into_font().style(FontStyle::Bold))
                .pos(Pos::new(HPos::Center, VPos::Bottom));
            chart.draw_series(std::iter::once(
                EmptyElement::at(anchor) + Text::new(format!("t = {t:.1} s"), (0, -10), style),
            ))?;
        }
    }

    if rec.load_pos_m.is_empty() && rec.uav_pos_m.is_empty() {
        let (x, y) = ((fitted.x0 + fitted.x1) / 2.0, (fitted.y0 + fitted.y1) / 2.0);
        let style = TextStyle::from((FONT, 24)).pos(Pos::new(HPos::Center, VPos::Center)).color(&RED);
        chart.draw_series(std::iter::once(Text::new("no samples recorded", (x, y), style)))?;
    }
    Ok(())
}

/// Up to `N_SNAPSHOTS` sample indices evenly spread over the run.
fn snapshot_indices(rec: &RunRecord) -> Vec<usize> {
    let n = rec.uav_pos_m.len().max(rec.load_pos_m.len());
    if n == 0 {
        return Vec::new();
    }
    let count = N_SNAPSHOTS.min(n);
    if count == 1 {
        return vec![0];
    }
    let mut idx: Vec<usize> = (0..count).map(|k| k * (n - 1) / (count - 1)).collect();
    idx.dedup();
    idx
}

fn top_view_legend(scene: &SceneGeometry, rec: &RunRecord) -> Vec<LegendEntry> {
    let mut e = Vec::new();
    if !scene.left_boundary.is_empty() || !scene.right_boundary.is_empty() {
        e.push(LegendEntry::line("tube boundary", BOUNDARY_COLOR, 3, false));
    }
    if !scene.centerline.is_empty() {
        e.push(LegendEntry::line("tube centreline", CENTERLINE_COLOR, 2, true));
    }
    if !scene.obstacles.is_empty() {
        e.push(LegendEntry { label: "obstacle".into(), swatch: Swatch::Fill(OBSTACLE_FILL, OBSTACLE_EDGE) });
    }
    e.push(LegendEntry::line("load path", LOAD_COLOR, 4, false));
    for i in 0..n_uavs(rec) {
        e.push(LegendEntry::line(&format!("UAV {}", i + 1), uav_color(i), 2, false));
    }
    e.push(LegendEntry { label: "formation snapshot".into(), swatch: Swatch::Formation });
    e.push(LegendEntry { label: "load at snapshot".into(), swatch: Swatch::Ring(LOAD_COLOR) });
    e
}

// ---------------------------------------------------------------- time series

struct Series {
    label: String,
    color: RGBColor,
    width: u32,
    dashed: bool,
    points: Vec<(f64, f64)>,
}

struct HLine {
    label: String,
    y: f64,
    color: RGBColor,
    width: u32,
    dashed: bool,
}

struct TimePlot {
    y_desc: &'static str,
    series: Vec<Series>,
    hlines: Vec<HLine>,
    /// Shaded horizontal band `(lo, hi, label)`.
    band: Option<(f64, f64, String)>,
    /// Values the y range must include (e.g. 0).
    y_include: Vec<f64>,
}

const BAND_COLOR: RGBColor = RGBColor(100, 150, 230);

impl TimePlot {
    /// Common axis ranges covering `self` and `others`.
    fn ranges(&self, others: &[TimePlot]) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
        let mut b = Bounds::empty();
        let mut y_extra = Bounds::empty();
        for p in std::iter::once(self).chain(others) {
            for s in &p.series {
                for &(x, y) in &s.points {
                    b.add(x, y);
                }
            }
            for h in &p.hlines {
                y_extra.add(0.0, h.y);
            }
            if let Some((lo, hi, _)) = &p.band {
                y_extra.add(0.0, *lo);
                y_extra.add(0.0, *hi);
            }
            for &y in &p.y_include {
                y_extra.add(0.0, y);
            }
        }
        let (mut x0, mut x1) = if b.is_valid() { (b.x0, b.x1) } else { (0.0, 1.0) };
        if x1 - x0 <= 1e-9 {
            x0 -= 0.5;
            x1 += 0.5;
        }
        let (mut y0, mut y1) = if b.is_valid() { (b.y0, b.y1) } else { (f64::INFINITY, f64::NEG_INFINITY) };
        if y_extra.is_valid() {
            y0 = y0.min(y_extra.y0);
            y1 = y1.max(y_extra.y1);
        }
        if !(y0.is_finite() && y1.is_finite()) {
            (y0, y1) = (0.0, 1.0);
        }
        let pad = ((y1 - y0) * 0.06).max(0.05);
        let lo_pad = if self.y_include.iter().any(|&v| v == y0) { 0.0 } else { pad };
        (x0..x1, (y0 - lo_pad)..(y1 + pad))
    }

    fn legend(&self) -> Vec<LegendEntry> {
        let mut e: Vec<LegendEntry> = self
            .series
            .iter()
            .map(|s| LegendEntry::line(&s.label, s.color, s.width.max(2), s.dashed))
            .collect();
        e.extend(self.hlines.iter().map(|h| LegendEntry::line(&h.label, h.color, h.width, h.dashed)));
        if let Some((_, _, label)) = &self.band {
            e.push(LegendEntry { label: label.clone(), swatch: Swatch::Fill(BAND_COLOR.mix(0.2).opaque(), BAND_COLOR) });
        }
        e
    }
}

/// Helper trait: opaque RGB of a colour (for legend swatches).
trait Opaque {
    fn opaque(&self) -> RGBColor;
}
impl Opaque for RGBAColor {
    fn opaque(&self) -> RGBColor {
        // Blend on white, as drawn.
        let a = self.3.clamp(0.0, 1.0);
        let f = |c: u8| (f64::from(c) * a + 255.0 * (1.0 - a)).round().clamp(0.0, 255.0) as u8;
        RGBColor(f(self.0), f(self.1), f(self.2))
    }
}

fn time_series(time: &[f64], values: impl IntoIterator<Item = f64>) -> Vec<(f64, f64)> {
    time.iter().copied().zip(values).collect()
}

fn tension_plot(rec: &RunRecord) -> TimePlot {
    let series = (0..n_uavs(rec))
        .map(|i| Series {
            label: format!("UAV {}", i + 1),
            color: uav_color(i),
            width: 2,
            dashed: false,
            points: time_series(&rec.time_s, rec.tension_n.iter().map(|row| row.get(i).copied().unwrap_or(f64::NAN))),
        })
        .collect();
    let hlines = if rec.f_max_n.is_finite() {
        vec![HLine { label: format!("f_max = {:.1} N", rec.f_max_n), y: rec.f_max_n, color: RED, width: 2, dashed: true }]
    } else {
        Vec::new()
    };
    TimePlot { y_desc: "cable tension [N]", series, hlines, band: None, y_include: vec![0.0] }
}

fn distance_plot(rec: &RunRecord) -> TimePlot {
    let s = |label: &str, color: RGBColor, v: &[f64]| Series {
        label: label.into(),
        color,
        width: 2,
        dashed: false,
        points: time_series(&rec.time_s, v.iter().copied()),
    };
    TimePlot {
        y_desc: "distance [m]",
        series: vec![
            s("min UAV-boundary", RGBColor(31, 119, 180), &rec.min_uav_boundary_m),
            s("load-boundary", RGBColor(44, 160, 44), &rec.min_load_boundary_m),
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

fn altitude_plot(rec: &RunRecord) -> TimePlot {
    let z = rec.load_altitude_ref_m;
    let (hlines, band) = if z.is_finite() {
        (
            vec![HLine { label: format!("reference {z:.1} m"), y: z, color: BLACK, width: 2, dashed: false }],
            Some((z - ALTITUDE_BAND_M, z + ALTITUDE_BAND_M, format!("reference +/- {ALTITUDE_BAND_M:.0} m"))),
        )
    } else {
        (Vec::new(), None)
    };
    TimePlot {
        y_desc: "load altitude [m]",
        series: vec![Series {
            label: "load altitude".into(),
            color: RGBColor(31, 119, 180),
            width: 3,
            dashed: false,
            points: time_series(&rec.time_s, rec.load_pos_m.iter().map(|p| p[2])),
        }],
        hlines,
        band,
        y_include: Vec::new(),
    }
}

fn draw_time_panel(
    area: &Area<'_>,
    title: &str,
    plot: &TimePlot,
    xr: std::ops::Range<f64>,
    yr: std::ops::Range<f64>,
) -> DynResult<()> {
    let (x0, x1) = (xr.start, xr.end);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 26).into_font().style(FontStyle::Bold))
        .margin_left(10)
        .margin_right(30)
        .margin_top(10)
        .margin_bottom(10)
        .x_label_area_size(55)
        .y_label_area_size(75)
        .build_cartesian_2d(xr, yr)?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc(plot.y_desc)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 20))
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(RGBColor(245, 245, 245))
        .draw()?;

    if let Some((lo, hi, _)) = &plot.band {
        chart.draw_series(std::iter::once(Rectangle::new([(x0, *lo), (x1, *hi)], BAND_COLOR.mix(0.2).filled())))?;
        for y in [*lo, *hi] {
            chart.draw_series(DashedLineSeries::new(vec![(x0, y), (x1, y)], 10, 6, BAND_COLOR.stroke_width(1)))?;
        }
    }
    for s in &plot.series {
        for run in finite_runs(s.points.iter().copied()) {
            if s.dashed {
                chart.draw_series(DashedLineSeries::new(run, 10, 6, s.color.stroke_width(s.width)))?;
            } else {
                chart.draw_series(LineSeries::new(run, s.color.stroke_width(s.width)))?;
            }
        }
    }
    for h in &plot.hlines {
        let pts = vec![(x0, h.y), (x1, h.y)];
        if h.dashed {
            chart.draw_series(DashedLineSeries::new(pts, 12, 8, h.color.stroke_width(h.width)))?;
        } else {
            chart.draw_series(LineSeries::new(pts, h.color.stroke_width(h.width)))?;
        }
    }
    if plot.series.iter().all(|s| s.points.iter().all(|(x, y)| !(x.is_finite() && y.is_finite()))) {
        let (ya, yb) = (chart.y_range().start, chart.y_range().end);
        let style = TextStyle::from((FONT, 24)).pos(Pos::new(HPos::Center, VPos::Center)).color(&RED);
        chart.draw_series(std::iter::once(Text::new("no samples recorded", ((x0 + x1) / 2.0, (ya + yb) / 2.0), style)))?;
    }
    Ok(())
}

// ---------------------------------------------------------------- legend column

enum Swatch {
    Line { color: RGBColor, width: u32, dashed: bool },
    Fill(RGBColor, RGBColor),
    Formation,
    Ring(RGBColor),
}

struct LegendEntry {
    label: String,
    swatch: Swatch,
}

impl LegendEntry {
    fn line(label: &str, color: RGBColor, width: u32, dashed: bool) -> Self {
        Self { label: label.into(), swatch: Swatch::Line { color, width, dashed } }
    }
}

/// Draws `entries` as a framed list in `area` (pixel coordinates), starting `top` px down.
fn draw_legend(area: &Area<'_>, entries: &[LegendEntry], top: i32) -> DynResult<()> {
    if entries.is_empty() {
        return Ok(());
    }
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (i32::try_from(w).unwrap_or(i32::MAX), i32::try_from(h).unwrap_or(i32::MAX));
    let n = i32::try_from(entries.len()).unwrap_or(i32::MAX);
    let row = ((h - top - 20) / n.max(1)).clamp(14, 26);
    let font = (row - 8).clamp(11, 17);
    let (x0, x1, tx) = (16, 50, 60);
    let height = row * n + 12;
    area.draw(&Rectangle::new([(4, top), (w - 8, top + height)], WHITE.filled()))?;
    area.draw(&Rectangle::new([(4, top), (w - 8, top + height)], RGBColor(160, 160, 160).stroke_width(1)))?;
    for (k, e) in (0..).zip(entries) {
        let y = top + 6 + row * k + row / 2;
        if y > h - 4 {
            break;
        }
        match e.swatch {
            Swatch::Line { color, width, dashed } => {
                let style = color.stroke_width(width);
                if dashed {
                    for s in [x0, x0 + 13, x0 + 26] {
                        area.draw(&PathElement::new(vec![(s, y), (s + 8, y)], style))?;
                    }
                } else {
                    area.draw(&PathElement::new(vec![(x0, y), (x1, y)], style))?;
                }
            }
            Swatch::Fill(fill, edge) => {
                let r = [(x0, y - row / 3), (x1, y + row / 3)];
                area.draw(&Rectangle::new(r, fill.filled()))?;
                area.draw(&Rectangle::new(r, edge.stroke_width(1)))?;
            }
            Swatch::Formation => {
                let d = row / 3;
                let pts = vec![(x0 + 2, y), ((x0 + x1) / 2, y - d), (x1 - 2, y), ((x0 + x1) / 2, y + d), (x0 + 2, y)];
                area.draw(&PathElement::new(pts.clone(), BLACK.stroke_width(2)))?;
                for p in pts.iter().take(4) {
                    area.draw(&Circle::new(*p, 3, uav_color(0).filled()))?;
                    area.draw(&Circle::new(*p, 3, BLACK.stroke_width(1)))?;
                }
            }
            Swatch::Ring(color) => {
                let c = ((x0 + x1) / 2, y);
                area.draw(&Circle::new(c, 6, WHITE.filled()))?;
                area.draw(&Circle::new(c, 6, color.stroke_width(3)))?;
            }
        }
        let style = TextStyle::from((FONT, font)).pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(e.label.clone(), (tx, y), style))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

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
            scene.right_boundary.push([g[0] - w * n[0], g[1] - w * n[1]]);
        }
        for j in 0..11 {
            let u = 0.05 + 0.9 * f64::from(j) / 10.0;
            let (g, n) = curve(u);
            let side = if j % 2 == 0 { 1.0 } else { -1.0 };
            let r = 0.8 + 0.3 * f64::from(j % 3);
            let d = side * (half_width(u) + r + 0.3);
            scene.obstacles.push(Obstacle { center_m: [g[0] + d * n[0], g[1] + d * n[1]], radius_m: r });
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
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
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
                pos.push([g[0] + ct * tang[0] + cn * n[0], g[1] + ct * tang[1] + cn * n[1], z + 3.0]);
                ten.push(17.0 + 1.5 * noise() + 2.0 * (1.0 - squeeze) * phi.cos());
            }
            rec.uav_pos_m.push(pos);
            rec.tension_n.push(ten);
            rec.min_uav_boundary_m.push(half_width(u) - b - 0.1 * noise().abs());
            rec.min_load_boundary_m.push(half_width(u));
            rec.min_uav_uav_m.push(2.0 * a * (std::f64::consts::PI / 10.0).sin() * squeeze.max(0.4));
        }
        (scene, rec)
    }

    fn temp_dir(tag: &str) -> PathBuf {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        std::env::temp_dir().join(format!("host-sim-plots-{tag}-{}-{nanos}", std::process::id()))
    }

    fn assert_png(p: &Path) {
        let bytes = std::fs::read(p).unwrap();
        assert!(bytes.len() > 10_000, "{} is only {} bytes", p.display(), bytes.len());
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{} is not a PNG", p.display());
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
        let names: Vec<_> = files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(names, ["top_view.png", "tensions.png", "distances.png", "load_altitude.png"]);
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
        let empty = RunRecord { f_max_n: f64::INFINITY, load_altitude_ref_m: f64::NAN, ..RunRecord::default() };
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
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn equal_aspect_fit() {
        let b = Bounds { x0: 0.0, x1: 60.0, y0: -10.0, y1: 10.0 }.fit_aspect(1200, 300);
        let sx = (b.x1 - b.x0) / 1200.0;
        let sy = (b.y1 - b.y0) / 300.0;
        assert!((sx - sy).abs() < 1e-12);
        assert!(b.x0 <= 0.0 && b.x1 >= 60.0 && b.y0 <= -10.0 && b.y1 >= 10.0);
    }
}
