//! ASCII text in the 8x8 bitmap font of `font8x8`.

use crate::{Image, Rect, RenderError, Rgba};

/// Largest accepted text scale (a glyph is `8 scale` pixels square).
pub const MAX_TEXT_SCALE: u32 = 64;

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

/// Width in pixels of `text` drawn at `scale`: `8 scale n` for `n`
/// characters (every character, ASCII or not, takes one 8x8 cell).
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u64;
    (8 * u64::from(scale) * n).min(u64::from(u32::MAX)) as u32
}

/// Height in pixels of a line of text at `scale`: `8 scale`.
pub fn text_height(scale: u32) -> u32 {
    8u32.saturating_mul(scale)
}

/// The 8 rows of the glyph of `ch` (bit `k` of a row is column `k`, left to
/// right). Characters outside printable ASCII are drawn as `?`.
fn glyph(ch: char) -> [u8; 8] {
    let code = if (' '..='~').contains(&ch) {
        ch as usize
    } else {
        '?' as usize
    };
    font8x8::legacy::BASIC_LEGACY[code]
}

impl Image {
    /// Draws `text` at integer `scale` (each font pixel becomes a `scale x
    /// scale` block) in colour `c`. `(x, y)` is the reference point: the top
    /// of the text, and its left edge, middle or right end by `anchor`
    /// (for [`Anchor::Center`] the box starts at `x - floor(width / 2)`).
    ///
    /// Returns the box the text occupies, `text_width x text_height`; only
    /// pixels inside it (and inside the image) are written. Characters
    /// outside printable ASCII are drawn as `?`. Empty text is a no-op that
    /// returns an empty box at the anchored position. Errors if `scale` is 0
    /// or larger than [`MAX_TEXT_SCALE`].
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
        let width = text_width(text, scale);
        let left = match anchor {
            Anchor::Left => i64::from(x),
            Anchor::Center => i64::from(x) - i64::from(width / 2),
            Anchor::Right => i64::from(x) - i64::from(width),
        };
        let top = i64::from(y);
        let s = i64::from(scale);
        for (k, ch) in text.chars().enumerate() {
            let gx = left + 8 * s * k as i64;
            if gx >= i64::from(self.width()) {
                break;
            }
            if gx + 8 * s <= 0 {
                continue;
            }
            for (row, bits) in glyph(ch).iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for dy in 0..s {
                        for dx in 0..s {
                            let px = gx + col as i64 * s + dx;
                            let py = top + row as i64 * s + dy;
                            if clip.is_none_or(|r| r.contains(px, py)) {
                                self.put(px, py, c);
                            }
                        }
                    }
                }
            }
        }
        let clamp32 = |v: i64| v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        Ok(Rect::new(
            clamp32(left),
            y,
            width,
            if text.is_empty() {
                0
            } else {
                text_height(scale)
            },
        ))
    }
}
