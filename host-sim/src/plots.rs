//! PNG plots of a run (and of two runs side by side), drawn with `plotters`.
//!
//! Fonts: DejaVu Sans is embedded in the binary (crate `dejavu`), so nothing is needed from
//! the machine (no system fonts, fontconfig or freetype). It is registered with plotters'
//! `ab_glyph` backend, but all visible text is rasterised here with `ab_glyph` directly
//! ([`Label`]): plotters 0.3.7's `ab_glyph` text path drops each glyph's left side bearing,
//! which gives visibly uneven letter spacing.
//!
//! Non-finite samples are skipped (lines are broken there); empty records give plots with
//! empty axes and a "no samples recorded" note.

use std::error::Error;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ab_glyph::{point, Font, FontRef, Glyph, PxScale, ScaleFont};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::record::{RunRecord, SceneGeometry};

/// Font family name under which the embedded font is registered with plotters.
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

/// Registers the embedded font with plotters once; later calls return the first outcome.
fn ensure_fonts() -> Result<(), String> {
    static FONTS: OnceLock<Result<(), String>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "embedded DejaVu Sans font is invalid".to_string())?;
            register_font(FONT, FontStyle::Bold, dejavu::sans::bold())
                .map_err(|_| "embedded DejaVu Sans Bold font is invalid".to_string())?;
            face(false)
                .map(|_| ())
                .ok_or_else(|| "embedded DejaVu Sans font is invalid".to_string())
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

// ---------------------------------------------------------------- text

/// Embedded DejaVu Sans (regular or bold), parsed once.
fn face(bold: bool) -> Option<&'static FontRef<'static>> {
    static FACES: OnceLock<(Option<FontRef<'static>>, Option<FontRef<'static>>)> = OnceLock::new();
    let (regular, heavy) = FACES.get_or_init(|| {
        (
            FontRef::try_from_slice(dejavu::sans::regular()).ok(),
            FontRef::try_from_slice(dejavu::sans::bold()).ok(),
        )
    });
    if bold {
        heavy.as_ref().or(regular.as_ref())
    } else {
        regular.as_ref()
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HAlign {
    Left,
    Center,
    Right,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum VAlign {
    Top,
    Center,
    Bottom,
}

/// How a [`Label`] looks and where its anchor sits on the text box.
#[derive(Debug, Clone, Copy)]
struct Txt {
    size: f32,
    bold: bool,
    color: RGBColor,
    h: HAlign,
    v: VAlign,
    /// Rotated 90 degrees counter-clockwise (reads bottom to top).
    vertical: bool,
    /// White outline, for text drawn over data.
    halo: bool,
}

impl Txt {
    fn new(size: f32, h: HAlign, v: VAlign) -> Self {
        Self {
            size,
            bold: false,
            color: BLACK,
            h,
            v,
            vertical: false,
            halo: false,
        }
    }
    fn bold(self) -> Self {
        Self { bold: true, ..self }
    }
    fn color(self, color: RGBColor) -> Self {
        Self { color, ..self }
    }
    fn vertical(self) -> Self {
        Self {
            vertical: true,
            ..self
        }
    }
    fn halo(self) -> Self {
        Self { halo: true, ..self }
    }
}

/// Text laid out on a baseline at y = 0, starting at x = 0.
struct Laid {
    glyphs: Vec<Glyph>,
    width: f32,
    ascent: f32,
    descent: f32,
}

fn lay_out(font: &FontRef<'static>, size: f32, text: &str) -> Laid {
    let scale = PxScale::from(size);
    let sf = font.as_scaled(scale);
    let mut caret = 0.0f32;
    let mut prev = None;
    let mut glyphs = Vec::with_capacity(text.len());
    for c in text.chars() {
        let id = sf.glyph_id(c);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        glyphs.push(id.with_scale_and_position(scale, point(caret, 0.0)));
        caret += sf.h_advance(id);
        prev = Some(id);
    }
    Laid {
        glyphs,
        width: caret,
        ascent: sf.ascent(),
        descent: sf.descent(),
    }
}

/// Advance width of `text` in pixels.
fn text_width(text: &str, st: &Txt) -> i32 {
    face(st.bold).map_or(0, |f| lay_out(f, st.size, text).width.ceil() as i32)
}

/// A line of text, anchored at `pos` (pixel coordinates of the area it is drawn on).
struct Label {
    text: String,
    pos: (i32, i32),
    st: Txt,
}

impl Label {
    fn new(text: impl Into<String>, pos: (i32, i32), st: Txt) -> Self {
        Self {
            text: text.into(),
            pos,
            st,
        }
    }
}

impl Label {
    /// Rasterises the text onto `area` (anti-aliased, blended).
    fn draw_on(&self, area: &Area<'_>) -> DynResult<()> {
        let Some(font) = face(self.st.bold) else {
            return Ok(());
        };
        let (ax, ay) = self.pos;
        let laid = lay_out(font, self.st.size, &self.text);
        let dx = match self.st.h {
            HAlign::Left => 0.0,
            HAlign::Center => -laid.width / 2.0,
            HAlign::Right => -laid.width,
        };
        let dy = match self.st.v {
            VAlign::Top => laid.ascent,
            VAlign::Center => (laid.ascent + laid.descent) / 2.0,
            VAlign::Bottom => laid.descent,
        };
        // Coverage per pixel in text-local coordinates (x along the text, y down).
        let mut pixels: Vec<(i32, i32, f32)> = Vec::new();
        for g in laid.glyphs {
            if let Some(og) = font.outline_glyph(g) {
                let b = og.px_bounds();
                let (x0, y0) = ((b.min.x + dx).round() as i32, (b.min.y + dy).round() as i32);
                og.draw(|gx, gy, c| {
                    if c > 0.02 {
                        let (gx, gy) = (
                            i32::try_from(gx).unwrap_or(0),
                            i32::try_from(gy).unwrap_or(0),
                        );
                        pixels.push((x0 + gx, y0 + gy, c.min(1.0)));
                    }
                });
            }
        }
        let to_screen = |x: i32, y: i32| {
            if self.st.vertical {
                (ax + y, ay - x)
            } else {
                (ax + x, ay + y)
            }
        };
        if self.st.halo {
            for &(x, y, c) in &pixels {
                if c > 0.3 {
                    for (ox, oy) in [
                        (-2, 0),
                        (2, 0),
                        (0, -2),
                        (0, 2),
                        (-1, -1),
                        (1, -1),
                        (-1, 1),
                        (1, 1),
                    ] {
                        area.draw_pixel(to_screen(x + ox, y + oy), &WHITE)?;
                    }
                }
            }
        }
        for (x, y, c) in pixels {
            area.draw_pixel(to_screen(x, y), &self.st.color.mix(f64::from(c)))?;
        }
        Ok(())
    }
}

/// Draws `text` centred at the top of `area`; returns the area below it.
fn titled<'a>(area: &Area<'a>, text: &str, size: f32) -> DynResult<Area<'a>> {
    let (w, _) = area.dim_in_pixel();
    let w = i32::try_from(w).unwrap_or(i32::MAX);
    Label::new(
        text,
        (w / 2, 8),
        Txt::new(size, HAlign::Center, VAlign::Top).bold(),
    )
    .draw_on(area)?;
    let h = (size * 1.25).ceil() as u32 + 14;
    Ok(area.split_vertically(h).1)
}

/// Nice tick values of `range` (the same ones plotters' mesh uses for `n` labels) and their text.
fn ticks(range: &Range<f64>, n: usize) -> Vec<(f64, String)> {
    let values: Vec<f64> = RangedCoordf64::from(range.clone()).key_points(n);
    let step = values
        .windows(2)
        .filter_map(|w| match w {
            [a, b] => Some((b - a).abs()),
            _ => None,
        })
        .fold(f64::INFINITY, f64::min);
    let decimals = if step.is_finite() && step > 0.0 {
        (0..=6usize)
            .find(|&d| {
                let s = step * 10f64.powi(d as i32);
                (s - s.round()).abs() < 1e-6 * s.max(1.0)
            })
            .unwrap_or(6)
    } else {
        1
    };
    values
        .into_iter()
        .map(|v| {
            let v = if v.abs() < step * 1e-9 { 0.0 } else { v };
            (v, format!("{v:.decimals$}"))
        })
        .collect()
}

/// Space to reserve left of the plot for y tick labels and the y axis title.
fn y_label_area(yr: &Range<f64>, n: usize) -> u32 {
    let st = Txt::new(TICK_PX, HAlign::Right, VAlign::Center);
    let widest = ticks(yr, n)
        .iter()
        .map(|(_, s)| text_width(s, &st))
        .max()
        .unwrap_or(0);
    u32::try_from(widest.max(0)).unwrap_or(0) + 14 + DESC_PX as u32 + 16
}

/// Grid, tick marks, tick labels and axis titles of `chart`, which was built on `area`.
fn draw_axes(
    area: &Area<'_>,
    chart: &mut Chart<'_, '_>,
    (nx, ny): (usize, usize),
    x_desc: &str,
    y_desc: &str,
) -> DynResult<()> {
    chart
        .configure_mesh()
        .x_labels(nx)
        .y_labels(ny)
        // Tick text is drawn below with `Label`; plotters only draws grid and tick marks.
        .x_label_formatter(&|_| String::new())
        .y_label_formatter(&|_| String::new())
        .label_style((FONT, TICK_PX))
        .bold_line_style(RGBColor(220, 220, 220))
        .light_line_style(RGBColor(244, 244, 244))
        .axis_style(BLACK.stroke_width(1))
        .draw()?;
    let (xr, yr) = (chart.x_range(), chart.y_range());
    let (base_x, base_y) = area.get_base_pixel();
    let (px, py) = chart.plotting_area().get_pixel_range();
    let local = |p: (i32, i32)| (p.0 - base_x, p.1 - base_y);
    let (left, bottom) = local((px.start, py.end));
    let (right, top) = local((px.end, py.start));

    let tick_st = Txt::new(TICK_PX, HAlign::Center, VAlign::Top);
    for (v, s) in ticks(&xr, nx) {
        let (x, _) = local(chart.backend_coord(&(v, yr.start)));
        Label::new(s, (x, bottom + 9), tick_st).draw_on(area)?;
    }
    let tick_st = Txt::new(TICK_PX, HAlign::Right, VAlign::Center);
    let mut widest = 0;
    for (v, s) in ticks(&yr, ny) {
        let (_, y) = local(chart.backend_coord(&(xr.start, v)));
        widest = widest.max(text_width(&s, &tick_st));
        Label::new(s, (left - 9, y), tick_st).draw_on(area)?;
    }
    let desc = Txt::new(DESC_PX, HAlign::Center, VAlign::Top);
    Label::new(
        x_desc,
        ((left + right) / 2, bottom + 12 + TICK_PX as i32 + 6),
        desc,
    )
    .draw_on(area)?;
    let desc = Txt::new(DESC_PX, HAlign::Center, VAlign::Bottom).vertical();
    Label::new(y_desc, (left - 9 - widest - 10, (top + bottom) / 2), desc).draw_on(area)?;
    Ok(())
}

/// "no samples recorded" in the middle of the plotting area.
fn draw_no_data(area: &Area<'_>, chart: &Chart<'_, '_>) -> DynResult<()> {
    let (base_x, base_y) = area.get_base_pixel();
    let (px, py) = chart.plotting_area().get_pixel_range();
    let c = (
        (px.start + px.end) / 2 - base_x,
        (py.start + py.end) / 2 - base_y,
    );
    let st = Txt::new(24.0, HAlign::Center, VAlign::Center)
        .color(RGBColor(200, 30, 30))
        .bold();
    Label::new("no samples recorded", c, st).draw_on(area)?;
    Ok(())
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
        Self {
            x0: f64::INFINITY,
            x1: f64::NEG_INFINITY,
            y0: f64::INFINITY,
            y1: f64::NEG_INFINITY,
        }
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
    /// Pads by `frac` of the larger side (at least `min_pad`); an empty box becomes [-1, 1]^2.
    fn padded(&self, frac: f64, min_pad: f64) -> Self {
        if !self.is_valid() {
            return Self {
                x0: -1.0,
                x1: 1.0,
                y0: -1.0,
                y1: 1.0,
            };
        }
        let p = ((self.x1 - self.x0).max(self.y1 - self.y0) * frac).max(min_pad);
        Self {
            x0: self.x0 - p,
            x1: self.x1 + p,
            y0: self.y0 - p,
            y1: self.y1 + p,
        }
    }
    /// Grows the short side so that a `pw` x `ph` pixel area has the same metres per pixel in x and y.
    fn fit_aspect(&self, pw: u32, ph: u32) -> Self {
        let (pw, ph) = (f64::from(pw.max(1)), f64::from(ph.max(1)));
        let (dx, dy) = ((self.x1 - self.x0).max(1e-9), (self.y1 - self.y0).max(1e-9));
        let scale = (dx / pw).max(dy / ph);
        let (cx, cy) = ((self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0);
        let (hx, hy) = (scale * pw / 2.0, scale * ph / 2.0);
        Self {
            x0: cx - hx,
            x1: cx + hx,
            y0: cy - hy,
            y1: cy + hy,
        }
    }
}

fn top_view_bounds(scene: &SceneGeometry, recs: &[&RunRecord]) -> Bounds {
    let mut b = Bounds::empty();
    let [bx0, bx1, by0, by1] = scene.bounds_m;
    if bx1 > bx0 && by1 > by0 {
        b.add(bx0, by0);
        b.add(bx1, by1);
    }
    for line in [
        &scene.centerline,
        &scene.left_boundary,
        &scene.right_boundary,
    ] {
        for p in line {
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
        for p in rec.uav_pos_m.iter().flatten() {
            b.add(p[0], p[1]);
        }
    }
    b.padded(0.02, 0.5)
}

/// Figure size for `panels` top views side by side: the height follows the scene's aspect ratio.
fn top_view_size(b: &Bounds, panels: u32) -> (u32, u32) {
    let (w, plot_w, overhead) = if panels <= 1 {
        (1600, 1250.0, 150.0)
    } else {
        (2 * 1150 + LEGEND_W, 1030.0, 210.0)
    };
    let aspect = ((b.y1 - b.y0) / (b.x1 - b.x0).max(1e-9)).clamp(0.05, 20.0);
    // Clamped to a sane range before the (saturating) float-to-int cast.
    let h = (plot_w * aspect + overhead).clamp(450.0, 1500.0) as u32;
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

/// Drops points closer than `min_step` to the previously kept one (keeps the last point);
/// avoids ragged thick lines from many sub-pixel segments.
fn thin_out(run: Vec<(f64, f64)>, min_step: f64) -> Vec<(f64, f64)> {
    let last = run.last().copied();
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(run.len());
    for p in run {
        match out.last() {
            Some(q) if (p.0 - q.0).hypot(p.1 - q.1) < min_step => {}
            _ => out.push(p),
        }
    }
    if let (Some(l), Some(q)) = (last, out.last()) {
        if *q != l {
            out.push(l);
        }
    }
    out
}

fn circle_points(c: [f64; 2], r: f64) -> Vec<(f64, f64)> {
    (0..72)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 72.0;
            (c[0] + r * a.cos(), c[1] + r * a.sin())
        })
        .collect()
}

fn n_uavs(rec: &RunRecord) -> usize {
    let pos = rec.uav_pos_m.iter().map(Vec::len).max().unwrap_or(0);
    let ten = rec.tension_n.iter().map(Vec::len).max().unwrap_or(0);
    pos.max(ten)
}

/// For long time series: keeps, per x bucket (`buckets` over `xr`), the first, lowest, highest
/// and last point in their original order, so peaks stay visible while drawing stays cheap.
fn min_max_decimate(run: Vec<(f64, f64)>, xr: Range<f64>, buckets: usize) -> Vec<(f64, f64)> {
    let width = xr.end - xr.start;
    if run.len() <= 4 * buckets || width.is_nan() || width <= 0.0 {
        return run;
    }
    let bucket_of = |x: f64| ((x - xr.start) / width * buckets as f64).floor() as i64;
    let mut out = Vec::with_capacity(4 * buckets + 4);
    let mut group: Vec<(usize, (f64, f64))> = Vec::with_capacity(4);
    let mut current = None;
    let flush = |group: &mut Vec<(usize, (f64, f64))>, out: &mut Vec<(f64, f64)>| {
        group.sort_by_key(|(k, _)| *k);
        group.dedup_by_key(|(k, _)| *k);
        out.extend(group.drain(..).map(|(_, p)| p));
    };
    let (mut lo, mut hi, mut last) = ((0, (0.0, 0.0)), (0, (0.0, 0.0)), (0, (0.0, 0.0)));
    for (k, p) in run.into_iter().enumerate() {
        let b = bucket_of(p.0);
        if current != Some(b) {
            if current.is_some() {
                group.extend([lo, hi, last]);
                flush(&mut group, &mut out);
            }
            current = Some(b);
            group.push((k, p));
            (lo, hi) = ((k, p), (k, p));
        }
        if p.1 < lo.1 .1 {
            lo = (k, p);
        }
        if p.1 > hi.1 .1 {
            hi = (k, p);
        }
        last = (k, p);
    }
    if current.is_some() {
        group.extend([lo, hi, last]);
        flush(&mut group, &mut out);
    }
    out
}

/// Distinct colour for UAV `i` (tab10, then a golden-ratio hue walk).
pub(crate) fn uav_color(i: usize) -> RGBColor {
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
fn snapshot_indices(rec: &RunRecord) -> Vec<usize> {
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

fn top_view_legend(scene: &SceneGeometry, rec: &RunRecord) -> Vec<LegendEntry> {
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

// ---------------------------------------------------------------- time series

struct Series {
    label: String,
    color: RGBColor,
    width: u32,
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
    x_desc: &'static str,
    y_desc: &'static str,
    series: Vec<Series>,
    hlines: Vec<HLine>,
    /// Shaded horizontal band `(lo, hi, label)`.
    band: Option<(f64, f64, String)>,
    /// Values the y range must include (e.g. 0); a bound equal to one of them gets no padding.
    y_include: Vec<f64>,
}

const BAND_FILL: RGBColor = RGBColor(222, 232, 250);
const BAND_EDGE: RGBColor = RGBColor(100, 150, 230);

impl TimePlot {
    /// Common axis ranges covering `self` and `others`.
    fn ranges(&self, others: &[TimePlot]) -> (Range<f64>, Range<f64>) {
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

    fn legend(&self) -> Vec<LegendEntry> {
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

fn time_series(time: &[f64], values: impl IntoIterator<Item = f64>) -> Vec<(f64, f64)> {
    time.iter().copied().zip(values).collect()
}

fn tension_plot(rec: &RunRecord) -> TimePlot {
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

fn distance_plot(rec: &RunRecord) -> TimePlot {
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

fn altitude_plot(rec: &RunRecord) -> TimePlot {
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

fn draw_time_panel(
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

// ---------------------------------------------------------------- legend column

enum Swatch {
    Line {
        color: RGBColor,
        width: u32,
        dashed: bool,
    },
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
        Self {
            label: label.into(),
            swatch: Swatch::Line {
                color,
                width,
                dashed,
            },
        }
    }
}

/// Draws `entries` as a framed list in `area` (its own pixel coordinates), starting `top` px down.
fn draw_legend(area: &Area<'_>, entries: &[LegendEntry], top: i32) -> DynResult<()> {
    if entries.is_empty() {
        return Ok(());
    }
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (
        i32::try_from(w).unwrap_or(i32::MAX),
        i32::try_from(h).unwrap_or(i32::MAX),
    );
    let n = i32::try_from(entries.len()).unwrap_or(i32::MAX);
    let row = ((h - top - 20) / n.max(1)).clamp(14, 26);
    let font = (row - 8).clamp(11, 17) as f32;
    let shown = n.min((h - top - 12) / row).max(0);
    let (x0, x1, tx) = (16, 50, 60);
    let frame = [(4, top), (w - 8, top + row * shown + 12)];
    area.draw(&Rectangle::new(frame, WHITE.filled()))?;
    area.draw(&Rectangle::new(
        frame,
        RGBColor(160, 160, 160).stroke_width(1),
    ))?;
    for (k, e) in (0..shown).zip(entries) {
        let y = top + 6 + row * k + row / 2;
        match e.swatch {
            Swatch::Line {
                color,
                width,
                dashed,
            } => {
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
                let mid = (x0 + x1) / 2;
                let pts = vec![
                    (x0 + 3, y),
                    (mid, y - d),
                    (x1 - 3, y),
                    (mid, y + d),
                    (x0 + 3, y),
                ];
                area.draw(&Polygon::new(pts.clone(), BLACK.mix(0.08).filled()))?;
                area.draw(&PathElement::new(pts.clone(), BLACK.stroke_width(2)))?;
                for (j, p) in pts.iter().take(4).enumerate() {
                    area.draw(&Circle::new(*p, 3, uav_color(j).filled()))?;
                    area.draw(&Circle::new(*p, 3, BLACK.stroke_width(1)))?;
                }
            }
            Swatch::Ring(color) => {
                let c = ((x0 + x1) / 2, y);
                area.draw(&Circle::new(c, 6, WHITE.filled()))?;
                area.draw(&Circle::new(c, 6, color.stroke_width(3)))?;
            }
        }
        Label::new(
            e.label.as_str(),
            (tx, y),
            Txt::new(font, HAlign::Left, VAlign::Center),
        )
        .draw_on(area)?;
    }
    if shown < n {
        let st = Txt::new(font, HAlign::Left, VAlign::Top).color(RGBColor(120, 120, 120));
        Label::new(
            format!("(+{} more)", n - shown),
            (tx, top + row * shown + 16),
            st,
        )
        .draw_on(area)?;
    }
    Ok(())
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
