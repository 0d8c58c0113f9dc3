//! The legend beside the 3D view: a colour bar with ticks or one swatch per
//! label, with title and notes wrapped to its width.

use unfold_render::{Anchor, Image, text_height};

use super::specs::Legend;
use crate::figures::layout::{fit, wrap};
use crate::figures::{FigureError, INK};

/// Draws `legend` in the box at `(x, y)` of `width x height` pixels (text
/// wrapped to the width; what does not fit below is left out).
pub(super) fn draw_legend(
    img: &mut Image,
    legend: &Legend,
    x: i32,
    y: i32,
    width: u32,
    height: i32,
    figure: &str,
) -> Result<(), FigureError> {
    let err = || FigureError::render(figure);
    let bottom = y + height;
    // One line of scale-1 text and the step from one line to the next.
    let lh = text_height(1) as i32;
    let step = lh + 1;
    // Writes wrapped lines from row `ty` at column `tx`; returns the next row.
    let lines = |img: &mut Image, tx: i32, ty: i32, s: &str| -> Result<i32, FigureError> {
        let room = (x + width as i32 - tx).max(8) as u32;
        let mut ty = ty;
        for line in wrap(s, room, 1) {
            if ty + lh > bottom {
                break;
            }
            img.draw_text(tx, ty, &line, 1, INK, Anchor::Left)
                .map_err(err())?;
            ty += step;
        }
        Ok(ty)
    };
    let (title, notes) = match legend {
        Legend::Bar { title, notes, .. } | Legend::Swatches { title, notes, .. } => (title, notes),
    };
    let mut ty = y;
    for line in title {
        ty = lines(img, x, ty, line)?;
    }
    ty += 6;
    match legend {
        Legend::Bar { color, ticks, .. } => {
            let note_lines: usize = notes.iter().map(|n| wrap(n, width, 1).len()).sum();
            let note_h = step * note_lines as i32 + 8;
            let bar_h = (bottom - ty - note_h - 8).clamp(20, 200);
            let (y_top, y_bot) = (ty + 4, ty + 4 + bar_h);
            let bar_w = 18;
            img.stroke_rect(
                unfold_render::Rect::new(x, y_top - 1, bar_w as u32, (bar_h + 3) as u32),
                INK,
            );
            for yy in y_top..=y_bot {
                let t = f64::from(y_bot - yy) / f64::from(bar_h);
                let c = color(t).opaque();
                for xx in x + 1..x + bar_w - 1 {
                    img.put(i64::from(xx), i64::from(yy), c);
                }
            }
            for (t, label) in ticks {
                let yy = (f64::from(y_bot) - t * f64::from(bar_h)).round() as i32;
                img.line(
                    [f64::from(x + bar_w), f64::from(yy) + 0.5],
                    [f64::from(x + bar_w + 3), f64::from(yy) + 0.5],
                    INK,
                );
                let room = (width as i32 - bar_w - 8).max(8) as u32;
                let (_, s) = fit(label, 1, room);
                img.draw_text(x + bar_w + 8, yy - lh / 2, &s, 1, INK, Anchor::Left)
                    .map_err(err())?;
            }
            ty = y_bot + 14;
        }
        Legend::Swatches { entries, .. } => {
            for (c, label) in entries {
                if ty + 12 > bottom {
                    break;
                }
                let sw = unfold_render::Rect::new(x, ty, 12, 12);
                img.fill_rect(sw, c.opaque());
                img.stroke_rect(sw, INK);
                ty = lines(img, x + 18, ty + 2, label)?.max(ty + 17);
            }
            ty += 6;
        }
    }
    for line in notes {
        ty = lines(img, x, ty, line)?;
    }
    Ok(())
}
