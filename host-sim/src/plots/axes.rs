//! Axes: tick values and labels, grid, axis titles.

use super::*;

/// Nice tick values of `range` (the same ones plotters' mesh uses for `n` labels) and their text.
pub(crate) fn ticks(range: &Range<f64>, n: usize) -> Vec<(f64, String)> {
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
pub(crate) fn y_label_area(yr: &Range<f64>, n: usize) -> u32 {
    let st = Txt::new(TICK_PX, HAlign::Right, VAlign::Center);
    let widest = ticks(yr, n)
        .iter()
        .map(|(_, s)| text_width(s, &st))
        .max()
        .unwrap_or(0);
    u32::try_from(widest.max(0)).unwrap_or(0) + 14 + DESC_PX as u32 + 16
}

/// Grid, tick marks, tick labels and axis titles of `chart`, which was built on `area`.
pub(crate) fn draw_axes(
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
pub(crate) fn draw_no_data(area: &Area<'_>, chart: &Chart<'_, '_>) -> DynResult<()> {
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

/// Draws `text` centred at the top of `area`; returns the area below it.
pub(crate) fn titled<'a>(area: &Area<'a>, text: &str, size: f32) -> DynResult<Area<'a>> {
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
