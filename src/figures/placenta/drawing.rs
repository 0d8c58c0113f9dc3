//! Drawing helpers shared by the placenta figures: panels, scale bars,
//! colour bars, dashed lines and orthographic cameras framing the meshes.

use unfold_render::{Anchor, Camera, ColorScale, Image, Rect, RenderError, Rgba, format_value};

use super::numbers::signed;
use crate::figures::layout::{self, TitleStyle, text_fit};
use crate::figures::{FigureOptions, INK};
use crate::mesh::nalgebra::{Point3, Vector3};

pub(super) const GUIDE: Rgba = Rgba::new(110, 110, 110, 255);

pub(super) const PANEL_EDGE: Rgba = Rgba::new(215, 215, 215, 255);

/// The title band of every placenta panel: the title 6 pixels from the top,
/// one line of subtitle at row 26, 4 pixels free on either side; it fills
/// [`TITLE_BAND`](super::TITLE_BAND).
const TITLE_STYLE: TitleStyle = TitleStyle {
    title_top: 2,
    margin: 8,
    subtitle_top: 27,
    line_step: 13,
    subtitle_lines: 1,
    subtitle_ink: INK,
};

/// A new panel with its title (at most at `title_scale`, so that the panels
/// of a figure can share one, see [`title_scale`]) and subtitle centred in
/// the [`TITLE_BAND`](super::TITLE_BAND), and a light outline.
pub(super) fn panel(
    opts: &FigureOptions,
    title: &str,
    subtitle: &str,
    title_scale: u32,
) -> Result<Image, RenderError> {
    layout::panel(opts, &TITLE_STYLE, title, title_scale, subtitle, PANEL_EDGE)
}

/// The largest title scale (2 or 1) at which all `titles` fit a panel.
pub(super) fn title_scale(opts: &FigureOptions, titles: &[&str]) -> u32 {
    TITLE_STYLE.shared_scale(opts.panel_width, titles, 2)
}

/// A horizontal scale bar of `mm` millimetres at `px_per_mm`, its left end
/// at `(x, y)`, labelled above.
pub(super) fn scale_bar(
    img: &mut Image,
    x: f64,
    y: f64,
    mm: f64,
    px_per_mm: f64,
) -> Result<(), RenderError> {
    let len = mm * px_per_mm;
    for d in [0.0, 1.0] {
        img.line([x, y + d], [x + len, y + d], INK);
    }
    img.line([x, y - 4.0], [x, y + 5.0], INK);
    img.line([x + len, y - 4.0], [x + len, y + 5.0], INK);
    img.draw_text(
        (x + 0.5 * len) as i32,
        (y - 13.0) as i32,
        &format!("{} mm", format_value(mm)),
        1,
        INK,
        Anchor::Center,
    )?;
    Ok(())
}

/// Lines of notes centred under a panel's title band (from row
/// `TITLE_BAND + top`, scale 1, each fitted to the panel's width less 8
/// pixels) and, when `bar` is given, an intensity colour bar below them
/// down to `bottom` pixels above the panel's foot (at least `min_bar`
/// pixels tall). Returns the row below the notes.
pub(super) fn notes(
    p: &mut Image,
    lines: &[String],
    top: i32,
    bar: Option<(&ColorScale, i32, u32)>,
) -> Result<i32, RenderError> {
    let (pw, ph) = (p.width(), p.height());
    let mut y = super::TITLE_BAND as i32 + top;
    for line in lines {
        text_fit(p, (pw / 2) as i32, y, line, 1, pw - 8, Anchor::Center)?;
        y += unfold_render::text_height(1) as i32 + 1;
    }
    if let Some((scale, bottom, min_bar)) = bar {
        let bar_top = y + 2 * top;
        let bar_h = (ph as i32 - bar_top - bottom).max(min_bar as i32) as u32;
        colour_bar(
            p,
            Rect::new((pw / 2) as i32 - 40, bar_top, 120, bar_h),
            scale,
            "intensity",
            false,
        )?;
    }
    Ok(y)
}

/// A vertical colour bar in `rect`: the title on top (scale 1), the
/// gradient (low at the bottom) in an outline, ticks at the ends and the
/// middle, labels 4 pixels right of the ticks (with a `+` on positive values
/// when `signed`, so a tick never reads as a minus sign).
pub(super) fn colour_bar(
    img: &mut Image,
    rect: Rect,
    scale: &ColorScale,
    title: &str,
    signed_labels: bool,
) -> Result<(), RenderError> {
    text_fit(
        img,
        rect.x + rect.width as i32 / 2,
        rect.y,
        title,
        1,
        rect.width,
        Anchor::Center,
    )?;
    let (x0, bw) = (i64::from(rect.x), 18i64);
    let (top, bot) = (i64::from(rect.y) + 16, rect.bottom() - 6);
    if bot - top < 8 {
        return Err(RenderError::InvalidArgument(format!(
            "{}x{} is too small for a colour bar",
            rect.width, rect.height
        )));
    }
    let span = (bot - top) as f64;
    for y in top..=bot {
        let c = scale.map.eval((bot - y) as f64 / span).opaque();
        for x in x0 + 1..x0 + bw - 1 {
            img.put(x, y, c);
        }
    }
    img.stroke_rect(
        Rect::new(rect.x, (top - 1) as i32, bw as u32, (bot - top + 3) as u32),
        INK,
    );
    for (t, v) in [
        (0.0, scale.lo),
        (0.5, 0.5 * (scale.lo + scale.hi)),
        (1.0, scale.hi),
    ] {
        let y = (bot as f64 - t * span).round();
        img.line([(x0 + bw) as f64, y], [(x0 + bw + 3) as f64, y], INK);
        let label = if signed_labels {
            signed(v)
        } else {
            format_value(v)
        };
        img.draw_text(
            (x0 + bw + 8) as i32,
            (y - 4.0) as i32,
            &label,
            1,
            INK,
            Anchor::Left,
        )?;
    }
    Ok(())
}

/// A dashed horizontal line from `x0` to `x1` at row `y`.
pub(super) fn dashed(img: &mut Image, x0: i64, x1: i64, y: i64, c: Rgba) {
    for x in x0..=x1 {
        if (x - x0) % 8 < 5 {
            img.put(x, y, c);
        }
    }
}

/// Centre of the bounding box of `points` and the largest distance from it.
pub(super) fn bounds(points: &[Point3<f64>]) -> (Point3<f64>, f64) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let c = Point3::from((lo + hi) * 0.5);
    let r = points.iter().map(|p| (p - c).norm()).fold(0.0f64, f64::max);
    (c, r.max(1e-6))
}

/// An orthographic camera looking along `dir` at `centre`, `px_per_mm`
/// pixels per millimetre in an image `height` pixels high.
pub(super) fn ortho(
    centre: Point3<f64>,
    radius: f64,
    dir: Vector3<f64>,
    up: Vector3<f64>,
    px_per_mm: f64,
    height: u32,
) -> Result<Camera, RenderError> {
    let f = dir.normalize();
    Camera::orthographic(
        centre - f * (4.0 * radius),
        centre,
        up,
        0.5 * f64::from(height) / px_per_mm,
    )
}
