//! Drawing helpers shared by the ventricle figures: the title band, text at
//! scale 1, the colour bar column, markers, the orientation words and the
//! glyph of the disk axes.

use std::f64::consts::TAU;

use unfold_render::{
    Anchor, ColorScale, FillRule, Image, Rect, Rgb, Rgba, arc, draw_colorbar, text_height,
};

use super::{COLORBAR_COLUMN, DiskLayout, SOFT_INK, TITLE_BAND};
use crate::figures::layout::{self, TitleStyle};
use crate::figures::{FigureError, INK, PAPER};

/// The title band of a ventricle figure ([`TITLE_STYLE`]): a title (scale 2
/// when it fits) and up to two lines of subtitle, centred.
pub(super) fn title_band(
    img: &mut Image,
    figure: &str,
    heading: &str,
    subtitle: &str,
) -> Result<(), FigureError> {
    layout::title_band(img, &TITLE_STYLE, heading, 2, subtitle).map_err(FigureError::render(figure))
}

/// The title band of the ventricle figures: the title 6 pixels from the
/// top, up to two lines of subtitle from row 27 in [`SOFT_INK`], 6 pixels
/// free on either side; it fills [`TITLE_BAND`].
const TITLE_STYLE: TitleStyle = TitleStyle {
    title_top: 2,
    margin: 12,
    subtitle_top: 27,
    line_step: 13,
    subtitle_lines: 2,
    subtitle_ink: SOFT_INK,
};

/// Text at scale 1.
pub(super) fn text(
    img: &mut Image,
    figure: &str,
    x: i64,
    y: i64,
    s: &str,
    ink: Rgba,
    anchor: Anchor,
) -> Result<Rect, FigureError> {
    img.draw_text(clamp32(x), clamp32(y), s, 1, ink, anchor)
        .map_err(FigureError::render(figure))
}

pub(super) fn clamp32(v: i64) -> i32 {
    v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// A colour bar in the column `x .. x + COLORBAR_COLUMN`, below the title
/// band (from row `TITLE_BAND + 4`) down to 12 rows above the bottom of
/// `img`, under the title lines `heading` (scale 1, centred on the column).
pub(super) fn colorbar_column(
    img: &mut Image,
    figure: &str,
    x: i64,
    scale: &ColorScale,
    heading: &[impl AsRef<str>],
) -> Result<(), FigureError> {
    let mut y = TITLE_BAND + 4;
    for line in heading {
        text(
            img,
            figure,
            x + COLORBAR_COLUMN / 2,
            y,
            line.as_ref(),
            INK,
            Anchor::Center,
        )?;
        y += i64::from(text_height(1)) + 1;
    }
    y += 4;
    let h = (i64::from(img.height()) - 12 - y).max(40);
    draw_colorbar(
        img,
        Rect::new(
            clamp32(x + 16),
            clamp32(y),
            (COLORBAR_COLUMN - 20) as u32,
            h as u32,
        ),
        scale,
        "",
        INK,
        1,
    )
    .map_err(FigureError::render(figure))
}

/// Ink that reads on `fill`.
pub(super) fn ink_on(fill: Rgb) -> Rgba {
    if fill.luminance() > 0.45 { INK } else { PAPER }
}

/// A filled disk of radius `r` about `c` (a marker).
pub(super) fn dot(img: &mut Image, c: [f64; 2], r: f64, fill: Rgba) {
    img.fill_polygon(&arc(c, r, 0.0, TAU), FillRule::NonZero, fill);
}

/// The four orientation words around an LV disk drawn with `layout`
/// (radius `layout.scale`): anterior (`+zeta`) up, inferior down, septal
/// (`+xi`) and lateral beside it, on the sides the layout puts them.
pub(super) fn orientation_words(
    img: &mut Image,
    figure: &str,
    layout: &DiskLayout,
) -> Result<(), FigureError> {
    let at = |u: f64, v: f64| layout.pixel([u, v]);
    let top = at(0.0, 1.0);
    text(
        img,
        figure,
        top[0] as i64,
        (top[1] - 14.0) as i64,
        "anterior",
        INK,
        Anchor::Center,
    )?;
    let bottom = at(0.0, -1.0);
    text(
        img,
        figure,
        bottom[0] as i64,
        (bottom[1] + 6.0) as i64,
        "inferior",
        INK,
        Anchor::Center,
    )?;
    let septal = at(1.0, 0.0);
    let lateral = at(-1.0, 0.0);
    for (p, word) in [(septal, "septal"), (lateral, "lateral")] {
        let left = p[0] < layout.centre[0];
        let (x, anchor) = if left {
            (p[0] - 6.0, Anchor::Right)
        } else {
            (p[0] + 7.0, Anchor::Left)
        };
        text(
            img,
            figure,
            x as i64,
            (p[1] - 4.0) as i64,
            word,
            INK,
            anchor,
        )?;
    }
    Ok(())
}

/// A landmark marker: a black dot with a white rim.
pub(super) fn landmark_marker(img: &mut Image, p: [f64; 2]) {
    dot(img, p, 5.0, PAPER);
    dot(img, p, 4.0, INK);
}

/// The apex marker: a cross in a white square.
pub(super) fn apex_marker(img: &mut Image, p: [f64; 2]) {
    img.fill_rect(Rect::new(p[0] as i32 - 5, p[1] as i32 - 5, 11, 11), PAPER);
    for d in [-0.5, 0.5] {
        img.line([p[0] - 5.0, p[1] + d], [p[0] + 5.0, p[1] + d], INK);
        img.line([p[0] + d, p[1] - 5.0], [p[0] + d, p[1] + 5.0], INK);
    }
}

/// A small glyph of the disk's axes `+xi` and `+zeta` with its origin at
/// `o` (pixels): `+zeta` up, `+xi` left when mirrored.
pub(super) fn axes_glyph(
    img: &mut Image,
    figure: &str,
    o: [f64; 2],
    mirrored: bool,
) -> Result<(), FigureError> {
    let len = 26.0;
    let (ox, sx) = if mirrored {
        (o[0] + len + 4.0, -1.0)
    } else {
        (o[0], 1.0)
    };
    let tip_x = ox + sx * len;
    img.line([ox, o[1]], [tip_x, o[1]], SOFT_INK);
    img.line([tip_x, o[1]], [tip_x - sx * 4.0, o[1] - 3.0], SOFT_INK);
    img.line([tip_x, o[1]], [tip_x - sx * 4.0, o[1] + 3.0], SOFT_INK);
    img.line([ox, o[1]], [ox, o[1] - len], SOFT_INK);
    img.line([ox, o[1] - len], [ox - 3.0, o[1] - len + 4.0], SOFT_INK);
    img.line([ox, o[1] - len], [ox + 3.0, o[1] - len + 4.0], SOFT_INK);
    let xi_anchor = if mirrored {
        Anchor::Right
    } else {
        Anchor::Left
    };
    text(
        img,
        figure,
        (tip_x + sx * 3.0) as i64,
        (o[1] - 4.0) as i64,
        "xi",
        SOFT_INK,
        xi_anchor,
    )?;
    text(
        img,
        figure,
        ox as i64,
        (o[1] - len - 11.0) as i64,
        "zeta",
        SOFT_INK,
        Anchor::Center,
    )?;
    Ok(())
}

/// The 17 rows of an AHA legend from row `y` at `x0`, `row_h` apart: the
/// segment's colour swatch, its number and `name (count)` with
/// `counts[k]` the count of segment `k`. Returns the row after the last.
pub(super) fn aha_rows(
    img: &mut Image,
    figure: &str,
    x0: i64,
    mut y: i64,
    row_h: i64,
    counts: &[usize; 18],
) -> Result<i64, FigureError> {
    for seg in 1..=17u8 {
        let sw = (row_h - 5).clamp(6, 10);
        let rect = Rect::new(clamp32(x0), clamp32(y - 1), sw as u32, sw as u32);
        img.fill_rect(rect, super::AHA_COLORS[seg as usize - 1].opaque());
        img.stroke_rect(rect, INK);
        text(
            img,
            figure,
            x0 + 30,
            y,
            &seg.to_string(),
            INK,
            Anchor::Right,
        )?;
        text(
            img,
            figure,
            x0 + 38,
            y,
            &format!(
                "{} ({})",
                super::AHA_NAMES[seg as usize - 1],
                counts[seg as usize]
            ),
            INK,
            Anchor::Left,
        )?;
        y += row_h;
    }
    Ok(y)
}
