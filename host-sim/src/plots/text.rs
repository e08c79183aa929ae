//! Text for the plots, shared with `xtask`'s scaling plot: the embedded DejaVu Sans faces
//! (crate `dejavu`), layout with `ab_glyph` (advances, kerning, ascent/descent, alignment,
//! 90-degree rotation) and anti-aliased drawing of a [`Label`] onto any plotters drawing area.
//!
//! What stays hand-written, and why: plotters 0.3.7 does lay out text with `ab_glyph` (feature
//! `ab_glyph`), but its glyph placement drops each glyph's left side bearing, which gives
//! visibly uneven letter spacing, and it has no halo. So the glyph outlines and coverage come
//! from `ab_glyph` (`outline_glyph`, `draw`), and only the placement (caret, kerning, anchor)
//! and the blending into the drawing area (`draw_pixel` with coverage as alpha) are here,
//! about 100 lines. Plotters still gets the font registered ([`register_fonts`]) because its
//! mesh code asks for one even when every label is empty.

use std::error::Error;
use std::sync::OnceLock;

use ab_glyph::{point, Font, FontRef, Glyph, PxScale, ScaleFont};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

/// Font family name under which the embedded font is registered with plotters.
pub const FONT: &str = "sans-serif";

/// Registers the embedded regular and bold faces with plotters as [`FONT`], once per process;
/// later calls return the first outcome.
///
/// # Errors
/// The embedded font data is invalid (text).
pub fn register_fonts() -> Result<(), String> {
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

/// Embedded DejaVu Sans (regular or bold), parsed once.
pub fn face(bold: bool) -> Option<&'static FontRef<'static>> {
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

/// Where the anchor sits horizontally on the text box (before rotation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HAlign {
    /// At the start of the text.
    Left,
    /// In the middle.
    Center,
    /// At the end.
    Right,
}

/// Where the anchor sits vertically on the text box (before rotation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VAlign {
    /// At the ascent line.
    Top,
    /// Half-way between ascent and descent.
    Center,
    /// At the descent line.
    Bottom,
}

/// How a [`Label`] looks and where its anchor sits on the text box.
#[derive(Debug, Clone, Copy)]
pub struct Txt {
    /// Font size (em height), px.
    pub size: f32,
    /// Bold face.
    pub bold: bool,
    /// Text colour.
    pub color: RGBColor,
    /// Horizontal anchor.
    pub h: HAlign,
    /// Vertical anchor.
    pub v: VAlign,
    /// Rotated 90 degrees counter-clockwise (reads bottom to top).
    pub vertical: bool,
    /// White outline, for text drawn over data.
    pub halo: bool,
}

impl Txt {
    /// Regular black horizontal text of `size` px anchored at (`h`, `v`).
    pub fn new(size: f32, h: HAlign, v: VAlign) -> Self {
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
    /// The same, bold.
    pub fn bold(self) -> Self {
        Self { bold: true, ..self }
    }
    /// The same, in `color`.
    pub fn color(self, color: RGBColor) -> Self {
        Self { color, ..self }
    }
    /// The same, rotated 90 degrees counter-clockwise.
    pub fn vertical(self) -> Self {
        Self {
            vertical: true,
            ..self
        }
    }
    /// The same, with a white outline.
    pub fn halo(self) -> Self {
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
pub fn text_width(text: &str, st: &Txt) -> i32 {
    face(st.bold).map_or(0, |f| lay_out(f, st.size, text).width.ceil() as i32)
}

/// A line of text, anchored at `pos` (pixel coordinates of the area it is drawn on).
pub struct Label {
    /// The text.
    pub text: String,
    /// Anchor, px.
    pub pos: (i32, i32),
    /// Look and anchor placement.
    pub st: Txt,
}

impl Label {
    /// `text` anchored at `pos` (px) with style `st`.
    pub fn new(text: impl Into<String>, pos: (i32, i32), st: Txt) -> Self {
        Self {
            text: text.into(),
            pos,
            st,
        }
    }
}

impl Label {
    /// Rasterises the text onto `area` (anti-aliased, blended).
    ///
    /// # Errors
    /// The drawing area's backend fails.
    pub fn draw_on<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), Box<dyn Error>>
    where
        DB::ErrorType: 'static,
    {
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
