//! The legend column at the right of every figure.

use super::*;

pub(crate) enum Swatch {
    Line {
        color: RGBColor,
        width: u32,
        dashed: bool,
    },
    Fill(RGBColor, RGBColor),
    Formation,
    Ring(RGBColor),
}

pub(crate) struct LegendEntry {
    pub(crate) label: String,
    pub(crate) swatch: Swatch,
}

impl LegendEntry {
    pub(crate) fn line(label: &str, color: RGBColor, width: u32, dashed: bool) -> Self {
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
pub(crate) fn draw_legend(area: &Area<'_>, entries: &[LegendEntry], top: i32) -> DynResult<()> {
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
