//! Figure widgets: a vertical colour bar and a histogram.

use crate::colormap::{finite_range, format_value};
use crate::text::{text_height, text_width};
use crate::{Anchor, ColorScale, Image, Rect, RenderError, Rgb, Rgba};

/// Draws a vertical colour bar for `scale` inside `rect`.
///
/// Layout, top to bottom: the `title` centred (omitted if empty), then the
/// gradient bar on the left of the rectangle inside a 1-pixel outline, ticks at the
/// bottom (`lo`), middle and top (`hi`) and their labels ([`format_value`])
/// to the right. Row `y` of the bar, from `y_top` to `y_bot`, shows
/// `scale.map.eval(t)` with `t = (y_bot - y) / (y_bot - y_top)`, so the
/// colour runs from `lo` at the bottom to `hi` at the top.
///
/// Text and lines are drawn in `ink` at text scale `text_scale`, and nothing
/// is written outside `rect` (long labels are cut). Errors if `text_scale`
/// is invalid or `rect` is too small for the title, two label heights and a
/// bar of 8 pixels (height) or for the bar and its ticks (width).
pub fn draw_colorbar(
    img: &mut Image,
    rect: Rect,
    scale: &ColorScale,
    title: &str,
    ink: Rgba,
    text_scale: u32,
) -> Result<(), RenderError> {
    check_scale(text_scale)?;
    let lh = i64::from(text_height(text_scale));
    let title_h = if title.is_empty() { 0 } else { lh + 4 };
    let bar_w = (i64::from(rect.width) / 3).clamp(6, 24);
    let (x0, y0) = (i64::from(rect.x), i64::from(rect.y));
    let y_top = y0 + title_h + lh / 2;
    let y_bot = rect.bottom() - 1 - lh / 2;
    if y_bot - y_top < 8 || i64::from(rect.width) < bar_w + 6 {
        return Err(RenderError::InvalidArgument(format!(
            "rectangle {}x{} is too small for a colour bar at text scale {text_scale}",
            rect.width, rect.height
        )));
    }
    let clip = Some(rect);
    if !title.is_empty() {
        let cx = x0 + i64::from(rect.width) / 2;
        img.draw_text_clipped(
            clamp32(cx),
            rect.y,
            title,
            text_scale,
            ink,
            Anchor::Center,
            clip,
        )?;
    }
    let span = (y_bot - y_top) as f64;
    // The outline sits one pixel outside the gradient, so both end colours
    // are visible.
    img.stroke_rect(
        Rect::new(
            rect.x,
            clamp32(y_top - 1),
            bar_w as u32,
            (y_bot - y_top + 3) as u32,
        ),
        ink,
    );
    for y in y_top..=y_bot {
        let t = (y_bot - y) as f64 / span;
        let c = scale.map.eval(t).opaque();
        for x in x0 + 1..x0 + bar_w - 1 {
            img.put(x, y, c);
        }
    }
    for (t, v) in [
        (0.0, scale.lo),
        (0.5, 0.5 * (scale.lo + scale.hi)),
        (1.0, scale.hi),
    ] {
        let y = (y_bot as f64 - t * span).round() as i64;
        // a short tick and a wide gap, so that the tick does not read as
        // a minus sign of the label
        for x in x0 + bar_w..x0 + bar_w + 3 {
            if rect.contains(x, y) {
                img.put(x, y, ink);
            }
        }
        let label = format_value(v);
        img.draw_text_clipped(
            clamp32(x0 + bar_w + 9),
            clamp32(y - lh / 2),
            &label,
            text_scale,
            ink,
            Anchor::Left,
            clip,
        )?;
    }
    Ok(())
}

/// The colours of a histogram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistogramStyle {
    /// Bar colour, unless `scale` is given.
    pub bar: Rgb,
    /// When given, each bar takes the colour of its bin centre on this scale
    /// (so the histogram matches the colour map of a figure).
    pub scale: Option<ColorScale>,
    /// Axes and text.
    pub ink: Rgba,
    /// Text scale.
    pub text_scale: u32,
}

impl Default for HistogramStyle {
    fn default() -> Self {
        Self {
            bar: Rgb::new(70, 110, 170),
            scale: None,
            ink: Rgba::BLACK,
            text_scale: 1,
        }
    }
}

/// What [`draw_histogram`] counted.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    /// The value range of the bins.
    pub lo: f64,
    /// Upper end of the range.
    pub hi: f64,
    /// Count per bin; bin `k` holds `lo + k d <= v < lo + (k + 1) d` with
    /// `d = (hi - lo) / bins` (the last bin includes `hi`).
    pub counts: Vec<usize>,
    /// Finite values outside `[lo, hi]`, counted in the end bins.
    pub clamped: usize,
    /// Non-finite values, not counted.
    pub ignored: usize,
}

/// Bins `values` into `bins` bins over `range` (or the range of the finite
/// values; a zero-width range becomes `[v - 0.5, v + 0.5]`) and draws the
/// histogram into `rect`.
///
/// Bin of `v`: `k = clamp(floor((v - lo) / (hi - lo) bins), 0, bins - 1)`;
/// values outside the range go to the end bins (and are counted in
/// [`Histogram::clamped`]), non-finite values are ignored. Bar heights are
/// `round(count / max_count h_plot)`. Drawn: the `title` centred on top (if
/// not empty), the largest count at the top left, the bars on an x and a y
/// axis, `lo` and `hi` under the ends of the x axis. Nothing is drawn
/// outside `rect`.
///
/// Errors: `bins == 0`, a non-finite or reversed `range`, an invalid text
/// scale, or a rectangle too small for the text and a plot of at least 8 x 8
/// pixels.
pub fn draw_histogram(
    img: &mut Image,
    rect: Rect,
    values: &[f64],
    bins: usize,
    range: Option<(f64, f64)>,
    title: &str,
    style: &HistogramStyle,
) -> Result<Histogram, RenderError> {
    if bins == 0 {
        return Err(RenderError::InvalidArgument(
            "a histogram needs at least one bin".into(),
        ));
    }
    check_scale(style.text_scale)?;
    let (lo, hi) = match range {
        Some((lo, hi)) => {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(RenderError::InvalidArgument(format!(
                    "histogram range ({lo}, {hi})"
                )));
            }
            (lo, hi)
        }
        None => finite_range(values).unwrap_or((0.0, 1.0)),
    };
    let (lo, hi) = if lo == hi {
        (lo - 0.5, hi + 0.5)
    } else {
        (lo, hi)
    };
    let mut counts = vec![0usize; bins];
    let (mut clamped, mut ignored) = (0, 0);
    for &v in values {
        if !v.is_finite() {
            ignored += 1;
            continue;
        }
        if v < lo || v > hi {
            clamped += 1;
        }
        let k = ((v - lo) / (hi - lo) * bins as f64).floor();
        let k = if k.is_nan() {
            0
        } else {
            k.clamp(0.0, (bins - 1) as f64) as usize
        };
        counts[k] += 1;
    }

    let lh = i64::from(text_height(style.text_scale));
    let title_h = if title.is_empty() { 0 } else { lh + 4 };
    let (x0, y0) = (i64::from(rect.x), i64::from(rect.y));
    // Plot area: below the title and the max-count label, above the labels.
    let axis_x = x0 + 1;
    let plot_top = y0 + title_h + lh + 2;
    let axis_y = rect.bottom() - 1 - lh - 3;
    let plot_right = rect.right() - 1;
    if axis_y - plot_top < 8 || plot_right - axis_x < 8 {
        return Err(RenderError::InvalidArgument(format!(
            "rectangle {}x{} is too small for a histogram at text scale {}",
            rect.width, rect.height, style.text_scale
        )));
    }
    let clip = Some(rect);
    let ink = style.ink;
    let (ts, cx) = (style.text_scale, x0 + i64::from(rect.width) / 2);
    if !title.is_empty() {
        img.draw_text_clipped(clamp32(cx), rect.y, title, ts, ink, Anchor::Center, clip)?;
    }
    let max_count = counts.iter().copied().max().unwrap_or(0);
    img.draw_text_clipped(
        clamp32(axis_x + 3),
        clamp32(y0 + title_h),
        &max_count.to_string(),
        ts,
        ink,
        Anchor::Left,
        clip,
    )?;
    let plot_w = plot_right - axis_x; // columns axis_x + 1 ..= plot_right
    let plot_h = axis_y - plot_top; // rows plot_top .. axis_y
    for (k, &n) in counts.iter().enumerate() {
        let c0 = axis_x + 1 + (k as i64 * plot_w) / bins as i64;
        let mut c1 = axis_x + 1 + ((k as i64 + 1) * plot_w) / bins as i64;
        if c1 - c0 >= 3 {
            c1 -= 1; // a 1-pixel gap between wide bars
        }
        let bar_h = if max_count == 0 {
            0
        } else {
            ((n as f64 / max_count as f64) * plot_h as f64).round() as i64
        };
        let color = match style.scale {
            Some(s) => s.color(lo + (k as f64 + 0.5) / bins as f64 * (hi - lo)),
            None => style.bar,
        }
        .opaque();
        for y in axis_y - bar_h..axis_y {
            for x in c0..c1 {
                img.put(x, y, color);
            }
        }
    }
    for x in axis_x..=plot_right {
        img.put(x, axis_y, ink);
    }
    for y in plot_top..=axis_y {
        img.put(axis_x, y, ink);
    }
    let label_y = clamp32(axis_y + 3);
    img.draw_text_clipped(
        clamp32(axis_x),
        label_y,
        &format_value(lo),
        ts,
        ink,
        Anchor::Left,
        clip,
    )?;
    let hi_label = format_value(hi);
    // Keep the hi label right-aligned unless it would overlap the lo label.
    let lo_w = i64::from(text_width(&format_value(lo), ts));
    if plot_right + 1 - i64::from(text_width(&hi_label, ts)) > axis_x + lo_w + 4 {
        img.draw_text_clipped(
            clamp32(plot_right + 1),
            label_y,
            &hi_label,
            ts,
            ink,
            Anchor::Right,
            clip,
        )?;
    }
    Ok(Histogram {
        lo,
        hi,
        counts,
        clamped,
        ignored,
    })
}

fn check_scale(s: u32) -> Result<(), RenderError> {
    if s == 0 || s > crate::text::MAX_TEXT_SCALE {
        Err(RenderError::InvalidArgument(format!(
            "text scale {s} is not in 1..={}",
            crate::text::MAX_TEXT_SCALE
        )))
    } else {
        Ok(())
    }
}

fn clamp32(v: i64) -> i32 {
    v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}
