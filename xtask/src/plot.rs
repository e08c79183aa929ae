//! The scaling plot of `docs/benchmarks.md`: cost against team size, log-log, for the
//! dissipative control step and the QP allocation.
//!
//! Text is rasterised here with `ab_glyph` from the embedded DejaVu Sans (crate `dejavu`),
//! as host-sim's plots do: nothing is needed from the machine, and plotters' own text path
//! (which drops glyph bearings) is not used.

use std::path::Path;
use std::sync::OnceLock;

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

/// Figure size, px.
const SIZE: (u32, u32) = (1100, 720);
/// Text sizes, px.
const TITLE_PX: f32 = 26.0;
const TEXT_PX: f32 = 18.0;
const TICK_PX: f32 = 16.0;
/// Axis ranges: team size and cost, ns.
const X_RANGE: (f64, f64) = (2.0, 150.0);
/// Team sizes with a tick label.
const X_TICKS: [f64; 4] = [3.0, 10.0, 30.0, 100.0];

/// One line of the plot.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// (n, cost in ns).
    pub points: Vec<(f64, f64)>,
    /// Line colour.
    pub color: RGBColor,
    /// Dashed (reference lines).
    pub dashed: bool,
}

type DynResult<T> = Result<T, Box<dyn std::error::Error>>;

/// Writes the PNG to `path`.
///
/// # Errors
/// The font is unreadable or the file cannot be written.
pub fn write(path: &Path, title: &str, series: &[Series]) -> Result<(), String> {
    draw(path, title, series).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Registers the embedded font with plotters (its mesh code asks for a font even when every
/// label is empty); once per process.
fn ensure_font() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular()).map_err(|_| "embedded DejaVu Sans is invalid".to_string())
    })
    .clone()
}

fn draw(path: &Path, title: &str, series: &[Series]) -> DynResult<()> {
    ensure_font()?;
    let font = FontRef::try_from_slice(dejavu::sans::regular())?;
    let bold = FontRef::try_from_slice(dejavu::sans::bold())?;
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let finite: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).filter(|v| v.is_finite() && *v > 0.0).collect();
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(0.0, f64::max);
    let (y0, y1) = if lo.is_finite() && hi > 0.0 {
        (10f64.powf(lo.log10().floor()), 10f64.powf(hi.log10().ceil()))
    } else {
        (1.0, 1e6)
    };
    let mut chart = ChartBuilder::on(&root)
        .margin_top(60)
        .margin_right(30)
        .x_label_area_size(70)
        .y_label_area_size(110)
        .build_cartesian_2d((X_RANGE.0..X_RANGE.1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_labels(0)
        .y_labels(0)
        .x_label_formatter(&|_| String::new())
        .y_label_formatter(&|_| String::new())
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(RGBColor(245, 245, 245))
        .axis_style(BLACK.stroke_width(1))
        .draw()?;
    // Grid and tick labels: team sizes on x, decades on y.
    let grid = RGBColor(225, 225, 225);
    for x in X_TICKS {
        chart.draw_series(LineSeries::new([(x, y0), (x, y1)], grid.stroke_width(1)))?;
        let (px, py) = chart.backend_coord(&(x, y0));
        text(&root, &font, TICK_PX, &format!("{x:.0}"), (px, py + 8), (0.5, 0.0), BLACK)?;
    }
    let mut d = y0;
    while d <= y1 * 1.0001 {
        chart.draw_series(LineSeries::new([(X_RANGE.0, d), (X_RANGE.1, d)], grid.stroke_width(1)))?;
        let (px, py) = chart.backend_coord(&(X_RANGE.0, d));
        text(&root, &font, TICK_PX, &time_label(d), (px - 8, py), (1.0, 0.5), BLACK)?;
        d *= 10.0;
    }
    for s in series {
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| p.1.is_finite() && p.1 > 0.0).collect();
        let style = s.color.stroke_width(if s.dashed { 2 } else { 3 });
        if s.dashed {
            chart.draw_series(DashedLineSeries::new(pts.clone(), 10, 8, style))?;
        } else {
            chart.draw_series(LineSeries::new(pts.clone(), style))?;
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 6, s.color.filled())))?;
        }
    }
    // Titles.
    let (w, h) = SIZE;
    let (w, h) = (i32::try_from(w).unwrap_or(0), i32::try_from(h).unwrap_or(0));
    text(&root, &bold, TITLE_PX, title, (w / 2, 14), (0.5, 0.0), BLACK)?;
    let (left, _) = chart.backend_coord(&(X_RANGE.0, y0));
    let (right, _) = chart.backend_coord(&(X_RANGE.1, y0));
    text(&root, &font, TEXT_PX, "team size n (UAVs)", ((left + right) / 2, h - 30), (0.5, 0.0), BLACK)?;
    // Legend, top left inside the plot.
    let (lx, ly) = chart.backend_coord(&(X_RANGE.0, y1));
    for (k, s) in series.iter().enumerate() {
        let y = ly + 22 + 28 * i32::try_from(k).unwrap_or(0);
        let x = lx + 20;
        root.draw(&PathElement::new(vec![(x, y), (x + 40, y)], s.color.stroke_width(3)))?;
        text(&root, &font, TEXT_PX, &s.label, (x + 50, y), (0.0, 0.5), BLACK)?;
    }
    // y axis title, written vertically.
    let (_, top) = chart.backend_coord(&(X_RANGE.0, y1));
    let (_, bottom) = chart.backend_coord(&(X_RANGE.0, y0));
    text_vertical(&root, &font, TEXT_PX, "time per step (median, host)", (22, (top + bottom) / 2), BLACK)?;
    root.present()?;
    Ok(())
}

/// `1e-9 s` multiples as text: 10 ns, 1 us, 1 ms.
fn time_label(ns: f64) -> String {
    if ns >= 1e6 {
        format!("{:.0} ms", ns / 1e6)
    } else if ns >= 1e3 {
        format!("{:.0} \u{b5}s", ns / 1e3)
    } else {
        format!("{ns:.0} ns")
    }
}

/// Draws `s` with its anchor at `anchor`; `align` = (fraction of the width left of the anchor,
/// fraction of the height above it).
fn text<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    font: &FontRef<'_>,
    size: f32,
    s: &str,
    anchor: (i32, i32),
    align: (f32, f32),
    color: RGBColor,
) -> DynResult<()>
where
    DB::ErrorType: 'static,
{
    let pixels = raster(font, size, s);
    let (w, h) = extent(font, size, s);
    let x0 = anchor.0 - (align.0 * w).round() as i32;
    let y0 = anchor.1 - (align.1 * h).round() as i32;
    for (x, y, c) in pixels {
        area.draw_pixel((x0 + x, y0 + y), &color.mix(f64::from(c)))?;
    }
    Ok(())
}

/// Draws `s` rotated 90 degrees counter-clockwise, centred on `center`.
fn text_vertical<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    font: &FontRef<'_>,
    size: f32,
    s: &str,
    center: (i32, i32),
    color: RGBColor,
) -> DynResult<()>
where
    DB::ErrorType: 'static,
{
    let (w, h) = extent(font, size, s);
    for (x, y, c) in raster(font, size, s) {
        let (sx, sy) = (center.0 + y - (h / 2.0) as i32, center.1 - x + (w / 2.0) as i32);
        area.draw_pixel((sx, sy), &color.mix(f64::from(c)))?;
    }
    Ok(())
}

/// Width and height (ascent - descent) of `s`, px.
fn extent(font: &FontRef<'_>, size: f32, s: &str) -> (f32, f32) {
    let sf = font.as_scaled(PxScale::from(size));
    let w: f32 = s.chars().map(|c| sf.h_advance(sf.glyph_id(c))).sum();
    (w, sf.ascent() - sf.descent())
}

/// Coverage of every pixel of `s` laid out from (0, 0) at the top left, y down.
fn raster(font: &FontRef<'_>, size: f32, s: &str) -> Vec<(i32, i32, f32)> {
    let scale = PxScale::from(size);
    let sf = font.as_scaled(scale);
    let mut caret = 0.0f32;
    let mut prev = None;
    let mut out = Vec::new();
    for c in s.chars() {
        let id = sf.glyph_id(c);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        let g = id.with_scale_and_position(scale, point(caret, sf.ascent()));
        caret += sf.h_advance(id);
        prev = Some(id);
        if let Some(og) = font.outline_glyph(g) {
            let b = og.px_bounds();
            let (bx, by) = (b.min.x.round() as i32, b.min.y.round() as i32);
            og.draw(|x, y, cov| {
                if cov > 0.02 {
                    out.push((bx + i32::try_from(x).unwrap_or(0), by + i32::try_from(y).unwrap_or(0), cov.min(1.0)));
                }
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_labels_use_the_right_unit() {
        assert_eq!(time_label(10.0), "10 ns");
        assert_eq!(time_label(1e3), "1 \u{b5}s");
        assert_eq!(time_label(1e7), "10 ms");
    }
}
