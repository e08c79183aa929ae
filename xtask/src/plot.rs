//! The scaling plot of `docs/benchmarks.md`: cost against team size, log-log, for the
//! dissipative control step and the QP allocation.
//!
//! Text: host-sim's text layout (`host_sim::plots::text`, the embedded DejaVu Sans), the same
//! as the simulator's plots; nothing is needed from the machine.

use std::path::Path;

use host_sim::plots::text::{register_fonts, HAlign, Label, Txt, VAlign};
use plotters::prelude::*;

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

fn draw(path: &Path, title: &str, series: &[Series]) -> DynResult<()> {
    register_fonts()?;
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
        text(&root, TICK_PX, &format!("{x:.0}"), (px, py + 8), (HAlign::Center, VAlign::Top))?;
    }
    let mut d = y0;
    while d <= y1 * 1.0001 {
        chart.draw_series(LineSeries::new([(X_RANGE.0, d), (X_RANGE.1, d)], grid.stroke_width(1)))?;
        let (px, py) = chart.backend_coord(&(X_RANGE.0, d));
        text(&root, TICK_PX, &time_label(d), (px - 8, py), (HAlign::Right, VAlign::Center))?;
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
    Label::new(title, (w / 2, 14), Txt::new(TITLE_PX, HAlign::Center, VAlign::Top).bold()).draw_on(&root)?;
    let (left, _) = chart.backend_coord(&(X_RANGE.0, y0));
    let (right, _) = chart.backend_coord(&(X_RANGE.1, y0));
    text(&root, TEXT_PX, "team size n (UAVs)", ((left + right) / 2, h - 30), (HAlign::Center, VAlign::Top))?;
    // Legend, top left inside the plot.
    let (lx, ly) = chart.backend_coord(&(X_RANGE.0, y1));
    for (k, s) in series.iter().enumerate() {
        let y = ly + 22 + 28 * i32::try_from(k).unwrap_or(0);
        let x = lx + 20;
        root.draw(&PathElement::new(vec![(x, y), (x + 40, y)], s.color.stroke_width(3)))?;
        text(&root, TEXT_PX, &s.label, (x + 50, y), (HAlign::Left, VAlign::Center))?;
    }
    // y axis title, written vertically.
    let (_, top) = chart.backend_coord(&(X_RANGE.0, y1));
    let (_, bottom) = chart.backend_coord(&(X_RANGE.0, y0));
    let st = Txt::new(TEXT_PX, HAlign::Center, VAlign::Center).vertical();
    Label::new("time per step (median, host)", (22, (top + bottom) / 2), st).draw_on(&root)?;
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

/// Draws `s` in black, regular, `size` px, anchored at `anchor` by `align`.
fn text<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    size: f32,
    s: &str,
    anchor: (i32, i32),
    (h, v): (HAlign, VAlign),
) -> DynResult<()>
where
    DB::ErrorType: 'static,
{
    Label::new(s, anchor, Txt::new(size, h, v)).draw_on(area)
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

#[cfg(test)]
mod render_tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]
    use super::*;

    /// A fixed plot is written, has the figure size and is not blank (text and lines drawn).
    #[test]
    fn scaling_plot_is_written() {
        let series = vec![
            Series { label: "control step".into(), points: vec![(3.0, 900.0), (10.0, 2500.0), (100.0, 30000.0)], color: RGBColor(31, 119, 180), dashed: false },
            Series { label: "O(n) reference".into(), points: vec![(3.0, 800.0), (100.0, 26000.0)], color: RGBColor(127, 127, 127), dashed: true },
        ];
        let path = std::env::temp_dir().join(format!("xtask_scaling_plot_{}.png", std::process::id()));
        write(&path, "Cost per control step (test data)", &series).expect("plot written");
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).expect("png")));
        let mut reader = decoder.read_info().expect("header");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("data");
        assert_eq!((info.width, info.height), SIZE);
        let dark = buf.chunks(info.color_type.samples()).filter(|p| p[0] < 80 && p[1] < 80 && p[2] < 80).count();
        assert!(dark > 2000, "only {dark} dark pixels: no text?");
        let _ = std::fs::copy(&path, std::env::temp_dir().join("xtask_scaling_plot.png"));
        let _ = std::fs::remove_file(&path);
    }
}
