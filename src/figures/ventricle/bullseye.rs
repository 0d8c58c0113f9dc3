//! [`BULLSEYE_PNG`]: the LV bull's-eye, each AHA segment filled with the
//! mean of a value over the anatomy points labelled with it, beside a colour
//! bar and a table.

use std::f64::consts::TAU;

use unfold_organs::ventricle::Outcome;
use unfold_render::{Anchor, ColorScale, FillRule, Image, NAN_COLOR, Rect, arc, format_value};

use super::drawing::{clamp32, colorbar_column, ink_on, orientation_words, text, title_band};
use super::segments::segment_outline;
use super::{
    AHA_NAMES, BULLSEYE_COLORMAP, BULLSEYE_PNG, COLORBAR_COLUMN, SOFT_INK, SegmentMean, TITLE_BAND,
    bullseye_layout, figure_size, segment_centre, segment_means,
};
use crate::figures::layout::wrap;
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// [`BULLSEYE_PNG`].
pub(super) fn bullseye(
    outcome: &Outcome,
    name: &str,
    values: &[f64],
    default: bool,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = BULLSEYE_PNG;
    let (w, h) = figure_size(opts, 2, 1)?;
    let layout = bullseye_layout(opts)?;
    let means = segment_means(&outcome.aha, values);
    let finite: Vec<f64> = means.iter().filter_map(|m| m.mean).collect();
    let scale = ColorScale::from_values(BULLSEYE_COLORMAP, &finite);
    let fill = |m: &SegmentMean| m.mean.map_or(NAN_COLOR, |v| scale.color(v));
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    let shown = if default {
        "depth (0 = S, 1 = H)".to_string()
    } else {
        name.to_string()
    };
    title_band(
        &mut img,
        F,
        &format!("LV bull's-eye: mean {shown} per AHA segment"),
        "anterior up, septum left; numbers: AHA segments; grey: no value",
    )?;
    // Fills, then borders, then numbers.
    for seg in 1..=17u8 {
        let poly = segment_outline(&layout, seg);
        img.fill_polygon(
            &poly,
            FillRule::NonZero,
            fill(&means[seg as usize - 1]).opaque(),
        );
    }
    for seg in 1..=17u8 {
        img.polyline(&segment_outline(&layout, seg), true, INK);
    }
    let outer = arc(layout.centre, layout.scale + 1.0, 0.0, TAU);
    img.polyline(&outer, true, INK);
    let ts = if layout.scale >= 120.0 { 2 } else { 1 };
    for seg in 1..=17u8 {
        let m = &means[seg as usize - 1];
        let Some(c) = segment_centre(seg) else {
            continue;
        };
        let p = layout.pixel(c);
        let ink = ink_on(fill(m));
        let th = f64::from(unfold_render::text_height(ts));
        let y = if m.mean.is_some() {
            p[1] - 0.5 * th
        } else {
            p[1] - 0.5 * th - 5.0
        };
        img.draw_text(
            p[0].round() as i32,
            y.round() as i32,
            &seg.to_string(),
            ts,
            ink,
            Anchor::Center,
        )
        .map_err(FigureError::render(F))?;
        if m.mean.is_none() {
            text(
                &mut img,
                F,
                p[0].round() as i64,
                (y + th + 2.0).round() as i64,
                "n/a",
                ink,
                Anchor::Center,
            )?;
        }
    }
    orientation_words(&mut img, F, &layout)?;

    // Right panel: colour bar and table.
    let x0 = i64::from(opts.panel_width);
    let top = TITLE_BAND + 4;
    let bottom = i64::from(h) - 12;
    let mut heading = vec!["segment mean".to_string()];
    if default {
        heading.extend(["depth".to_string(), "(0 = S, 1 = H)".to_string()]);
    } else {
        heading.extend(wrap(name, COLORBAR_COLUMN as u32 - 8, 1));
    }
    colorbar_column(&mut img, F, x0, &scale, &heading)?;
    let tx = x0 + COLORBAR_COLUMN + 4;
    let avail = i64::from(w) - 6 - tx;
    let with_names = avail >= 14 + 24 + 8 * 21 + 8 * 7 + 8 * 8;
    let row_h = ((bottom - top) / 20).clamp(9, 16);
    let mut y = top;
    let right = i64::from(w) - 6;
    text(&mut img, F, tx, y, "seg", INK, Anchor::Left)?;
    if with_names {
        text(&mut img, F, tx + 38, y, "name", INK, Anchor::Left)?;
    }
    text(&mut img, F, right - 8 * 9, y, "points", INK, Anchor::Right)?;
    text(&mut img, F, right, y, "mean", INK, Anchor::Right)?;
    y += row_h + 2;
    for seg in 1..=17u8 {
        let m = &means[seg as usize - 1];
        let sw = (row_h - 5).clamp(6, 10);
        img.fill_rect(
            Rect::new(clamp32(tx), clamp32(y - 1), sw as u32, sw as u32),
            fill(m).opaque(),
        );
        img.stroke_rect(
            Rect::new(clamp32(tx), clamp32(y - 1), sw as u32, sw as u32),
            INK,
        );
        text(
            &mut img,
            F,
            tx + 14 + 16,
            y,
            &seg.to_string(),
            INK,
            Anchor::Right,
        )?;
        if with_names {
            text(
                &mut img,
                F,
                tx + 38,
                y,
                AHA_NAMES[seg as usize - 1],
                INK,
                Anchor::Left,
            )?;
        }
        let mean = m.mean.map_or("n/a".to_string(), format_value);
        text(&mut img, F, right, y, &mean, INK, Anchor::Right)?;
        text(
            &mut img,
            F,
            right - 8 * 9,
            y,
            &m.points.to_string(),
            INK,
            Anchor::Right,
        )?;
        y += row_h;
    }
    y += 4;
    let total: usize = means.iter().map(|m| m.points).sum();
    text(
        &mut img,
        F,
        tx,
        y,
        &format!("{total} anatomy points"),
        SOFT_INK,
        Anchor::Left,
    )?;
    Ok(Figure::new(F, img))
}
