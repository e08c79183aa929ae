//! Text: the embedded DejaVu Sans faces, layout (kerning, alignment, rotation) and anti-aliased
//! rasterisation of labels onto a plotters drawing area.

use super::*;

/// Embedded DejaVu Sans (regular or bold), parsed once.
pub(crate) fn face(bold: bool) -> Option<&'static FontRef<'static>> {
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
pub(crate) enum HAlign {
    Left,
    Center,
    Right,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum VAlign {
    Top,
    Center,
    Bottom,
}

/// How a [`Label`] looks and where its anchor sits on the text box.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Txt {
    pub(crate) size: f32,
    pub(crate) bold: bool,
    pub(crate) color: RGBColor,
    pub(crate) h: HAlign,
    pub(crate) v: VAlign,
    /// Rotated 90 degrees counter-clockwise (reads bottom to top).
    pub(crate) vertical: bool,
    /// White outline, for text drawn over data.
    pub(crate) halo: bool,
}

impl Txt {
    pub(crate) fn new(size: f32, h: HAlign, v: VAlign) -> Self {
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
    pub(crate) fn bold(self) -> Self {
        Self { bold: true, ..self }
    }
    pub(crate) fn color(self, color: RGBColor) -> Self {
        Self { color, ..self }
    }
    pub(crate) fn vertical(self) -> Self {
        Self {
            vertical: true,
            ..self
        }
    }
    pub(crate) fn halo(self) -> Self {
        Self { halo: true, ..self }
    }
}

/// Text laid out on a baseline at y = 0, starting at x = 0.
pub(crate) struct Laid {
    pub(crate) glyphs: Vec<Glyph>,
    pub(crate) width: f32,
    pub(crate) ascent: f32,
    pub(crate) descent: f32,
}

pub(crate) fn lay_out(font: &FontRef<'static>, size: f32, text: &str) -> Laid {
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
pub(crate) fn text_width(text: &str, st: &Txt) -> i32 {
    face(st.bold).map_or(0, |f| lay_out(f, st.size, text).width.ceil() as i32)
}

/// A line of text, anchored at `pos` (pixel coordinates of the area it is drawn on).
pub(crate) struct Label {
    pub(crate) text: String,
    pub(crate) pos: (i32, i32),
    pub(crate) st: Txt,
}

impl Label {
    pub(crate) fn new(text: impl Into<String>, pos: (i32, i32), st: Txt) -> Self {
        Self {
            text: text.into(),
            pos,
            st,
        }
    }
}

impl Label {
    /// Rasterises the text onto `area` (anti-aliased, blended).
    pub(crate) fn draw_on(&self, area: &Area<'_>) -> DynResult<()> {
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
