//! [`BULLSEYE_PNG`]: the LV bull's-eye, each AHA segment filled with the
//! mean of a value over the anatomy points labelled with it, beside a colour
//! bar and a table. The drawing itself ([`bullseye_figure`]) takes any 17
//! per-segment values, so that the cohort figures (mean, standard
//! deviation, a subject's z-scores) draw the same bull's-eye.

use std::f64::consts::TAU;

use unfold_organs::ventricle::Outcome;
use unfold_render::{
    Anchor, ColorScale, FillRule, Image, NAN_COLOR, Rect, Rgb, arc, format_value, text_width,
};

use super::drawing::{clamp32, colorbar_column, ink_on, orientation_words, text, title_band};
use super::segments::segment_outline;
use super::{
    AHA_NAMES, BULLSEYE_COLORMAP, BULLSEYE_PNG, COLORBAR_COLUMN, SOFT_INK, TITLE_BAND,
    bullseye_layout, figure_size, segment_centre, segment_means,
};
use crate::figures::layout::wrap;
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// What a bull's-eye shows: one value per AHA segment (index `k - 1` for
/// segment `k`; `None` is drawn grey, "n/a"), how values map to colours,
/// and the text around it.
#[derive(Debug, Clone, Copy)]
pub struct Bullseye<'a> {
    /// Title of the figure (scale 2 when it fits).
    pub title: &'a str,
    /// Subtitle (up to two lines).
    pub subtitle: &'a str,
    /// Lines above the colour bar.
    pub heading: &'a [String],
    /// Colours of the values.
    pub scale: &'a ColorScale,
    /// The value of each segment.
    pub values: &'a [Option<f64>; 17],
    /// Heading of the table's value column (`mean`, `std`, `z`).
    pub value_label: &'a str,
    /// Heading of the table's second column (`points`, `hearts`, ...).
    pub count_label: &'a str,
    /// That column's entry per segment.
    pub counts: &'a [String; 17],
    /// A note under the table.
    pub footer: &'a str,
}

/// [`BULLSEYE_PNG`] of a subject: the mean of `values` per segment.
pub(super) fn bullseye(
    outcome: &Outcome,
    name: &str,
    values: &[f64],
    default: bool,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    let means = segment_means(&outcome.aha, values);
    let finite: Vec<f64> = means.iter().filter_map(|m| m.mean).collect();
    let scale = ColorScale::from_values(BULLSEYE_COLORMAP, &finite);
    let shown = if default {
        "depth (0 = S, 1 = H)".to_string()
    } else {
        name.to_string()
    };
    let mut heading = vec!["segment mean".to_string()];
    if default {
        heading.extend(["depth".to_string(), "(0 = S, 1 = H)".to_string()]);
    } else {
        heading.extend(wrap(name, super::COLORBAR_HEADING_PX, 1));
    }
    let total: usize = means.iter().map(|m| m.points).sum();
    bullseye_figure(
        BULLSEYE_PNG,
        &Bullseye {
            title: &format!("LV bull's-eye: mean {shown} per AHA segment"),
            subtitle: "anterior up, septum left; numbers: AHA segments; grey: no value",
            heading: &heading,
            scale: &scale,
            values: &means.each_ref().map(|m| m.mean),
            value_label: "mean",
            count_label: "points",
            counts: &means.each_ref().map(|m| m.points.to_string()),
            footer: &format!("{total} anatomy points"),
        },
        opts,
    )
}

/// The bull's-eye figure `name` of `b` (2 x 1 panels): the 17 segments
/// (anterior up, septum left) filled with `b.scale`'s colour of their value
/// (grey, "n/a", without one) and numbered, beside the colour bar under
/// `b.heading` and a table of segment, name (when it fits), count and
/// value, and `b.footer` under it.
///
/// # Errors
/// [`FigureError::Input`] for a panel smaller than the ventricle figures'
/// minimum; the renderer's.
pub fn bullseye_figure(
    name: &str,
    b: &Bullseye<'_>,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    let f = name;
    let (w, h) = figure_size(opts, 2, 1)?;
    let layout = bullseye_layout(opts)?;
    let fill = |v: &Option<f64>| v.map_or(NAN_COLOR, |v| b.scale.color(v));
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(f))?;
    title_band(&mut img, f, b.title, b.subtitle)?;
    // Fills, then borders, then numbers.
    for seg in 1..=17u8 {
        let poly = segment_outline(&layout, seg);
        img.fill_polygon(
            &poly,
            FillRule::NonZero,
            fill(&b.values[seg as usize - 1]).opaque(),
        );
    }
    for seg in 1..=17u8 {
        img.polyline(&segment_outline(&layout, seg), true, INK);
    }
    let outer = arc(layout.centre, layout.scale + 1.0, 0.0, TAU);
    img.polyline(&outer, true, INK);
    let ts = if layout.scale >= 120.0 { 2 } else { 1 };
    for seg in 1..=17u8 {
        let v = &b.values[seg as usize - 1];
        let Some(c) = segment_centre(seg) else {
            continue;
        };
        let p = layout.pixel(c);
        let ink = ink_on(fill(v));
        let th = f64::from(unfold_render::text_height(ts));
        let y = if v.is_some() {
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
        .map_err(FigureError::render(f))?;
        if v.is_none() {
            text(
                &mut img,
                f,
                p[0].round() as i64,
                (y + th + 2.0).round() as i64,
                "n/a",
                ink,
                Anchor::Center,
            )?;
        }
    }
    orientation_words(&mut img, f, &layout)?;

    // Right panel: colour bar and table.
    let x0 = i64::from(opts.panel_width);
    let top = TITLE_BAND + 4;
    let bottom = i64::from(h) - 12;
    colorbar_column(&mut img, f, x0, b.scale, b.heading)?;
    let tx = x0 + COLORBAR_COLUMN + 4;
    let avail = i64::from(w) - 6 - tx;
    let width = |s: &str| i64::from(text_width(s, 1));
    // The value column is 9 characters wide (`-1.23e-5`), the count column
    // 8; the name column fits the longest AHA name and a gap.
    let value_col = width("-0.000000");
    let names_w = width("basal inferoseptal   ") + width("0000000") + width("00000000");
    let with_names = avail >= 14 + 24 + names_w;
    // The segment number right-aligned after the swatch, the name after it.
    let seg_right = tx + 14 + width("00");
    let name_x = seg_right + 8;
    let row_h = ((bottom - top) / 20).clamp(9, 16);
    let mut y = top;
    let right = i64::from(w) - 6;
    text(&mut img, f, tx, y, "seg", INK, Anchor::Left)?;
    if with_names {
        text(&mut img, f, name_x, y, "name", INK, Anchor::Left)?;
    }
    text(
        &mut img,
        f,
        right - value_col,
        y,
        b.count_label,
        INK,
        Anchor::Right,
    )?;
    text(&mut img, f, right, y, b.value_label, INK, Anchor::Right)?;
    y += row_h + 2;
    for seg in 1..=17u8 {
        let v = &b.values[seg as usize - 1];
        let sw = (row_h - 5).clamp(6, 10);
        let swatch: Rgb = fill(v);
        img.fill_rect(
            Rect::new(clamp32(tx), clamp32(y - 1), sw as u32, sw as u32),
            swatch.opaque(),
        );
        img.stroke_rect(
            Rect::new(clamp32(tx), clamp32(y - 1), sw as u32, sw as u32),
            INK,
        );
        text(
            &mut img,
            f,
            seg_right,
            y,
            &seg.to_string(),
            INK,
            Anchor::Right,
        )?;
        if with_names {
            text(
                &mut img,
                f,
                name_x,
                y,
                AHA_NAMES[seg as usize - 1],
                INK,
                Anchor::Left,
            )?;
        }
        let shown = v.map_or("n/a".to_string(), format_value);
        text(&mut img, f, right, y, &shown, INK, Anchor::Right)?;
        text(
            &mut img,
            f,
            right - value_col,
            y,
            &b.counts[seg as usize - 1],
            INK,
            Anchor::Right,
        )?;
        y += row_h;
    }
    y += 4;
    text(&mut img, f, tx, y, b.footer, SOFT_INK, Anchor::Left)?;
    Ok(Figure::new(name, img))
}
