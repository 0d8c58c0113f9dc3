//! Text in Noto Sans Regular (SIL Open Font License 1.1, the font bytes of
//! the `notosans` crate), rasterised anti-aliased by `ab_glyph`.
//!
//! Metrics, for text scale `s` (all in pixels):
//!
//! - the em square is `EM_PX s = 11 s` pixels;
//! - a line's box is `text_height(s) = LINE_PX s = 12 s` high, with the
//!   baseline `BASELINE_PX s = 9 s` below its top (room for ascenders,
//!   about `0.76 em`, and descenders, about `0.24 em`; the tops of accented
//!   capitals, above `0.82 em`, are cut);
//! - the pen advances by each glyph's advance width plus the kerning of the
//!   pair, `x_{k+1} = x_k + kern(g_{k-1}, g_k) + advance(g_k)`, starting at
//!   `x_0 = 0`; a string is `text_width = ceil(x_n)` wide.
//!
//! Glyphs are placed at fractional pen positions and their coverage is
//! alpha-blended over the image, clipped to the text's box: the same call
//! writes the same bytes every time.

use std::sync::LazyLock;

use ab_glyph::{Font, FontRef, GlyphId, PxScale, ScaleFont, point};

use crate::{Image, Rect, RenderError, Rgba};

/// Largest accepted text scale (a line is `12 scale` pixels high).
pub const MAX_TEXT_SCALE: u32 = 64;

/// Em size of the font at text scale 1, pixels.
const EM_PX: f32 = 11.0;

/// Height of a line's box at text scale 1, pixels.
const LINE_PX: u32 = 12;

/// Rows from the top of a line's box to its baseline at text scale 1.
const BASELINE_PX: u32 = 9;

/// What a character the font has no glyph for is drawn as.
const REPLACEMENT: char = '?';

/// Noto Sans Regular, parsed once; `None` only if the embedded bytes were
/// unreadable (then no text can be drawn and [`Image::draw_text`] errors).
static FONT: LazyLock<Option<FontRef<'static>>> =
    LazyLock::new(|| FontRef::try_from_slice(notosans::REGULAR_TTF).ok());

/// Horizontal anchoring of a string at its reference point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Anchor {
    /// The reference point is the left edge of the text.
    #[default]
    Left,
    /// The reference point is the middle of the text.
    Center,
    /// The reference point is one past the right edge of the text.
    Right,
}

/// The `ab_glyph` pixel scale for text scale `scale`: the em square is
/// `EM_PX scale` pixels, and `ab_glyph` scales by the font's height
/// `ascent - descent`, so `PxScale = EM_PX scale (ascent - descent) / units_per_em`.
fn px_scale(font: &FontRef<'_>, scale: u32) -> PxScale {
    let upem = font.units_per_em().unwrap_or(1000.0);
    PxScale::from(EM_PX * scale as f32 * font.height_unscaled() / upem)
}

/// The glyph of `ch`, or of [`REPLACEMENT`] when the font has none (or `ch`
/// is a control character).
fn glyph_id(font: &FontRef<'_>, ch: char) -> GlyphId {
    let id = font.glyph_id(ch);
    if id.0 == 0 || ch.is_control() {
        font.glyph_id(REPLACEMENT)
    } else {
        id
    }
}

/// The glyphs of `text` with their pen positions (pixels from the left of
/// the box) and the pen position after the last one:
/// `x_{k+1} = x_k + kern(g_{k-1}, g_k) + advance(g_k)`.
fn layout(font: &FontRef<'_>, text: &str, scale: u32) -> (Vec<(GlyphId, f32)>, f32) {
    let sf = font.as_scaled(px_scale(font, scale));
    let mut pen = 0.0f32;
    let mut prev: Option<GlyphId> = None;
    let mut glyphs = Vec::with_capacity(text.len());
    for ch in text.chars() {
        let id = glyph_id(font, ch);
        if let Some(p) = prev {
            pen += sf.kern(p, id);
        }
        glyphs.push((id, pen));
        pen += sf.h_advance(id);
        prev = Some(id);
    }
    (glyphs, pen)
}

/// `ceil(x)` of a non-negative pen position as a pixel count (saturating).
fn ceil_px(x: f32) -> u32 {
    let c = f64::from(x).ceil();
    if c.is_finite() && c > 0.0 {
        c.min(f64::from(u32::MAX)) as u32
    } else {
        0
    }
}

/// Width in pixels of `text` drawn at `scale`: `ceil(x_n)`, the pen
/// position after the last glyph (sum of advances and kerning, see the
/// module doc). Exactly the width of the box [`Image::draw_text`] returns;
/// 0 for empty text (and for a scale of 0, which cannot be drawn).
pub fn text_width(text: &str, scale: u32) -> u32 {
    match FONT.as_ref() {
        Some(font) if scale > 0 && !text.is_empty() => ceil_px(layout(font, text, scale).1),
        _ => 0,
    }
}

/// Height in pixels of a line of text at `scale`: `12 scale`.
pub fn text_height(scale: u32) -> u32 {
    LINE_PX.saturating_mul(scale)
}

/// `c` drawn with opacity `a` in `[0, 1]` over `d`, per channel
/// `round(c a + d (1 - a))`, and alpha `a + d_a (1 - a)` likewise.
fn blend(d: Rgba, c: Rgba, a: f32) -> Rgba {
    let mix = |s: u8, t: u8| -> u8 {
        (f32::from(s) * a + f32::from(t) * (1.0 - a))
            .round()
            .clamp(0.0, 255.0) as u8
    };
    Rgba {
        r: mix(c.r, d.r),
        g: mix(c.g, d.g),
        b: mix(c.b, d.b),
        a: (a * 255.0 + f32::from(d.a) * (1.0 - a))
            .round()
            .clamp(0.0, 255.0) as u8,
    }
}

impl Image {
    /// Draws `text` in Noto Sans at `scale` (a line `12 scale` pixels high,
    /// see the module doc) in colour `c`, anti-aliased: each pixel becomes
    /// `c` over what was there with opacity `coverage * c.a / 255`. `(x, y)`
    /// is the reference point: the top of the text's box, and its left
    /// edge, middle or right end by `anchor` (for [`Anchor::Center`] the box
    /// starts at `x - floor(width / 2)`).
    ///
    /// Returns the box the text occupies, [`text_width`] x [`text_height`];
    /// only pixels inside it (and inside the image) are written. Characters
    /// the font has no glyph for (and control characters) are drawn as `?`.
    /// Empty text is a no-op that returns an empty box at the anchored
    /// position. Errors if `scale` is 0 or larger than [`MAX_TEXT_SCALE`].
    pub fn draw_text(
        &mut self,
        x: i32,
        y: i32,
        text: &str,
        scale: u32,
        c: Rgba,
        anchor: Anchor,
    ) -> Result<Rect, RenderError> {
        self.draw_text_clipped(x, y, text, scale, c, anchor, None)
    }

    /// [`Image::draw_text`] writing only pixels inside `clip` (when given).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn draw_text_clipped(
        &mut self,
        x: i32,
        y: i32,
        text: &str,
        scale: u32,
        c: Rgba,
        anchor: Anchor,
        clip: Option<Rect>,
    ) -> Result<Rect, RenderError> {
        if scale == 0 || scale > MAX_TEXT_SCALE {
            return Err(RenderError::InvalidArgument(format!(
                "text scale {scale} is not in 1..={MAX_TEXT_SCALE}"
            )));
        }
        let font = FONT.as_ref().ok_or(RenderError::Font)?;
        let (glyphs, end) = layout(font, text, scale);
        let width = ceil_px(end);
        let left = match anchor {
            Anchor::Left => i64::from(x),
            Anchor::Center => i64::from(x) - i64::from(width / 2),
            Anchor::Right => i64::from(x) - i64::from(width),
        };
        let clamp32 = |v: i64| v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        let height = if text.is_empty() {
            0
        } else {
            text_height(scale)
        };
        let bx = Rect::new(clamp32(left), y, width, height);
        let pxs = px_scale(font, scale);
        let base = i64::from(y) + i64::from(BASELINE_PX * scale);
        let alpha = f32::from(c.a) / 255.0;
        for (id, pen) in glyphs {
            let gx = left as f64 + f64::from(pen);
            if gx >= f64::from(self.width()) + f64::from(EM_PX) * f64::from(scale) {
                break;
            }
            // Integer part of the pen goes to the pixel offset, the fraction
            // to the glyph, so that positions stay exact far from 0.
            let (ix, fx) = (gx.floor(), (gx - gx.floor()) as f32);
            let glyph = id.with_scale_and_position(pxs, point(fx, 0.0));
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let b = outline.px_bounds();
            let (ox, oy) = (ix as i64 + b.min.x as i64, base + b.min.y as i64);
            outline.draw(|px, py, cov| {
                let (qx, qy) = (ox + i64::from(px), oy + i64::from(py));
                let a = cov.clamp(0.0, 1.0) * alpha;
                if a <= 0.0 || !bx.contains(qx, qy) || clip.is_some_and(|r| !r.contains(qx, qy)) {
                    return;
                }
                if let Some(d) = self.get(qx, qy) {
                    self.put(qx, qy, blend(d, c, a));
                }
            });
        }
        Ok(bx)
    }
}
