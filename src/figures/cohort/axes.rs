//! What the cohort figures share: the title band, round tick values
//! ([`nice_ticks`]), a linear data-to-pixel map ([`Axis`]) and the drawing
//! of a plot's frame with its ticks, grid lines and labels ([`draw_frame`]).
//! Text is measured with the renderer's `text_width` / `text_height`.

use unfold_render::{
    Anchor, Image, Rect, RenderError, Rgba, format_value, text_height, text_width,
};

use crate::figures::layout::{self, TitleStyle};
use crate::figures::{FigureError, FigureOptions, INK};

/// Grey of subtitles, axis labels and notes.
pub const SOFT_INK: Rgba = Rgba::new(90, 90, 90, 255);

/// Grey of the grid lines.
pub const GRID: Rgba = Rgba::new(225, 225, 225, 255);

/// Height of the title band: a title (scale 2 when it fits) and up to two
/// lines of subtitle.
pub const TITLE_BAND: i64 = 52;

/// The title band of the cohort figures: the title 6 pixels from the top,
/// up to two subtitle lines from row 27 in [`SOFT_INK`].
pub const TITLE_STYLE: TitleStyle = TitleStyle {
    title_top: 6,
    margin: 12,
    subtitle_top: 27,
    line_step: 11,
    subtitle_lines: 2,
    subtitle_ink: SOFT_INK,
};

/// Smallest panel accepted, pixels (width, height).
pub const MIN_PANEL: (u32, u32) = (240, 200);

/// Checks the panel size of `opts` against [`MIN_PANEL`] for `figure`.
///
/// # Errors
/// [`FigureError::Input`] naming both sizes.
pub fn check_panel(figure: &str, opts: &FigureOptions) -> Result<(), FigureError> {
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    if pw < MIN_PANEL.0 || ph < MIN_PANEL.1 {
        return Err(FigureError::input(
            figure,
            format!(
                "panel {pw}x{ph} is smaller than {}x{} pixels",
                MIN_PANEL.0, MIN_PANEL.1
            ),
        ));
    }
    Ok(())
}

/// Draws the title band of a cohort panel or figure ([`TITLE_STYLE`]).
pub fn title_band(img: &mut Image, title: &str, subtitle: &str) -> Result<(), RenderError> {
    layout::title_band(img, &TITLE_STYLE, title, 2, subtitle)
}

/// Text at scale 1 in `ink`, its top at `y`.
pub fn text(
    img: &mut Image,
    x: i64,
    y: i64,
    s: &str,
    ink: Rgba,
    anchor: Anchor,
) -> Result<Rect, RenderError> {
    img.draw_text(clamp32(x), clamp32(y), s, 1, ink, anchor)
}

/// `v` clamped into `i32`.
pub fn clamp32(v: i64) -> i32 {
    v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// Height of a line of text at scale 1, pixels.
pub fn line_height() -> i64 {
    i64::from(text_height(1))
}

/// Round ticks covering `[lo, hi]`: the multiples of `step` from
/// `floor(lo / step) step` to `ceil(hi / step) step`, where `step` is the
/// smallest of `{1, 2, 5} x 10^k` giving at most `max_ticks` (at least 2)
/// intervals. An empty or non-finite range gives the ticks of `[lo - 1, lo
/// + 1]` (of `[-1, 1]` when `lo` is not finite either).
pub fn nice_ticks(lo: f64, hi: f64, max_ticks: usize) -> Vec<f64> {
    let (lo, hi) = match (lo.is_finite(), hi.is_finite()) {
        (true, true) if hi > lo => (lo, hi),
        (true, _) => (lo - 1.0, lo + 1.0),
        _ => (-1.0, 1.0),
    };
    let max = max_ticks.max(2) as f64;
    let raw = (hi - lo) / max;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
        .into_iter()
        .map(|k| k * p)
        .find(|s| ((hi / s).ceil() - (lo / s).floor()) <= max)
        .unwrap_or(100.0 * p);
    let (k0, k1) = ((lo / step).floor() as i64, (hi / step).ceil() as i64);
    (k0..=k1)
        .map(|k| {
            let v = k as f64 * step;
            // Representation noise (0.30000000000000004) away.
            format!("{v:.12e}").parse().unwrap_or(v)
        })
        .collect()
}

/// A linear map of the data interval `[lo, hi]` onto the pixel interval
/// from `p0` to `p1` (`p1 < p0` for a vertical axis, up the picture).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// Data value at `p0`.
    pub lo: f64,
    /// Data value at `p1`.
    pub hi: f64,
    /// Pixel of `lo`.
    pub p0: f64,
    /// Pixel of `hi`.
    pub p1: f64,
}

impl Axis {
    /// The axis over the ticks `ticks` (their first and last) from pixel
    /// `p0` to `p1`.
    pub fn over(ticks: &[f64], p0: f64, p1: f64) -> Axis {
        let lo = ticks.first().copied().unwrap_or(0.0);
        let hi = ticks.last().copied().unwrap_or(1.0);
        Axis { lo, hi, p0, p1 }
    }

    /// The pixel of `v`: `p0 + (v - lo) / (hi - lo) (p1 - p0)` (the middle
    /// when `hi == lo`).
    pub fn pixel(&self, v: f64) -> f64 {
        let d = self.hi - self.lo;
        if d == 0.0 {
            0.5 * (self.p0 + self.p1)
        } else {
            self.p0 + (v - self.lo) / d * (self.p1 - self.p0)
        }
    }
}

/// The finite range of `values` widened by 5% of its span on both sides
/// (by 1 about a single value); `None` without a finite value.
pub fn padded_range(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) =
        values
            .into_iter()
            .filter(|v| v.is_finite())
            .fold(None, |acc: Option<(f64, f64)>, v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })?;
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        lo.abs().max(1.0) * 0.1
    };
    Some((lo - pad, hi + pad))
}

/// The labels of evenly spaced `ticks`, all with the digits their step
/// needs so that no two read the same: with `step = t_1 - t_0` and `d =
/// max(0, -floor(log10 step))` decimals, fixed notation (`0.035`, `2.045`,
/// `120`); scientific notation with the mantissa digits the step needs
/// when the largest `|t|` is at least `10^5` or the step below `10^-4`.
pub fn tick_labels(ticks: &[f64]) -> Vec<String> {
    let step = match ticks {
        [a, b, ..] if b > a => b - a,
        _ => return ticks.iter().map(|&t| format_value(t)).collect(),
    };
    let big = ticks.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    let e_step = (step.log10() + 1e-9).floor();
    if big >= 1e5 || step < 1e-4 {
        let e_big = big.log10().floor();
        let d = (e_big - e_step).clamp(0.0, 6.0) as usize;
        return ticks
            .iter()
            .map(|&t| {
                if t == 0.0 {
                    "0".to_string()
                } else {
                    format!("{t:.d$e}")
                }
            })
            .collect();
    }
    let d = (-e_step).max(0.0) as usize;
    ticks
        .iter()
        .map(|&t| {
            let s = format!("{t:.d$}");
            // No "-0.00".
            if s.trim_start_matches('-')
                .chars()
                .all(|c| c == '0' || c == '.')
            {
                s.trim_start_matches('-').to_string()
            } else {
                s
            }
        })
        .collect()
}

/// The widest of `ticks`' labels ([`tick_labels`]), pixels.
pub fn label_width(ticks: &[f64]) -> i64 {
    tick_labels(ticks)
        .iter()
        .map(|t| i64::from(text_width(t, 1)))
        .max()
        .unwrap_or(0)
}

/// Width of the colour bar column at the right of a map panel, pixels.
pub const MAP_BAR_COLUMN: i64 = 92;

/// A map panel's layout ([`map_frame`]): the plot area, its pixels per mm
/// and the colour bar's place.
#[derive(Debug, Clone, Copy)]
pub struct MapFrame {
    /// The plot area (its frame drawn).
    pub area: Rect,
    /// Its left and top pixel.
    pub x0: i64,
    /// Its top pixel.
    pub y0: i64,
    /// Its width, pixels.
    pub width: i64,
    /// Its height, pixels.
    pub height: i64,
    /// Pixels per mm, the same along x and y.
    pub pixels_per_mm: f64,
    /// Where the colour bar goes (the column at the right).
    pub bar: Rect,
}

impl MapFrame {
    /// The template point `(x, y)` in mm at the centre of area pixel
    /// `(px, py)`: `x = xlo + (px + 1/2) / s`, `y = yhi - (py + 1/2) / s`.
    pub fn point(&self, xlo: f64, yhi: f64, px: i64, py: i64) -> (f64, f64) {
        (
            xlo + (px as f64 + 0.5) / self.pixels_per_mm,
            yhi - (py as f64 + 0.5) / self.pixels_per_mm,
        )
    }
}

/// Lays out a map of the template box `[xlo, xhi] x [ylo, yhi]` (mm) in a
/// panel below its title band: equal mm scales along x and y (`s = min(cols
/// / (xhi - xlo), rows / (yhi - ylo))`), the box centred in the free area
/// left of the colour bar column, and its frame drawn with round ticks and
/// the axes labelled "template x, mm" and "template y, mm".
///
/// # Errors
/// Drawing the frame.
pub fn map_frame(
    img: &mut Image,
    opts: &FigureOptions,
    (xlo, xhi): (f64, f64),
    (ylo, yhi): (f64, f64),
) -> Result<MapFrame, RenderError> {
    let lh = line_height();
    let top = TITLE_BAND + lh + 12;
    let bottom = i64::from(opts.panel_height) - 2 * lh - 22;
    let rows = (bottom - top).max(20);
    let y_ticks = nice_ticks(ylo, yhi, (rows / 40).clamp(2, 8) as usize);
    let left = 12 + label_width(&y_ticks);
    let right = i64::from(opts.panel_width) - MAP_BAR_COLUMN - 8;
    let cols = (right - left).max(20);
    let s = (cols as f64 / (xhi - xlo)).min(rows as f64 / (yhi - ylo));
    let (aw, ah) = (
        ((xhi - xlo) * s).round().max(1.0) as i64,
        ((yhi - ylo) * s).round().max(1.0) as i64,
    );
    let (ax, ay) = (left + (cols - aw) / 2, top + (rows - ah) / 2);
    let area = Rect::new(clamp32(ax), clamp32(ay), aw as u32, ah as u32);
    let x_ticks: Vec<f64> = nice_ticks(xlo, xhi, (aw / 70).clamp(2, 8) as usize)
        .into_iter()
        .filter(|t| (xlo..=xhi).contains(t))
        .collect();
    let y_ticks: Vec<f64> = y_ticks
        .into_iter()
        .filter(|t| (ylo..=yhi).contains(t))
        .collect();
    let xa = Axis {
        lo: xlo,
        hi: xhi,
        p0: ax as f64,
        p1: (ax + aw) as f64,
    };
    let ya = Axis {
        lo: ylo,
        hi: yhi,
        p0: (ay + ah) as f64,
        p1: ay as f64,
    };
    draw_frame(
        img,
        area,
        &ya,
        &y_ticks,
        Some((&xa, &x_ticks)),
        "template y, mm",
        "template x, mm",
    )?;
    let bar = Rect::new(
        clamp32(i64::from(opts.panel_width) - MAP_BAR_COLUMN),
        clamp32(top),
        (MAP_BAR_COLUMN - 10) as u32,
        rows as u32,
    );
    Ok(MapFrame {
        area,
        x0: ax,
        y0: ay,
        width: aw,
        height: ah,
        pixels_per_mm: s,
        bar,
    })
}

/// Draws the frame of the plot area `area` with the y ticks `y_ticks`
/// (labels left of the frame, grid lines across it) and, when given, the x
/// ticks (labels below it); `y_label` above the frame's top left corner
/// and `x_label` centred below the x tick labels.
pub fn draw_frame(
    img: &mut Image,
    area: Rect,
    y: &Axis,
    y_ticks: &[f64],
    x: Option<(&Axis, &[f64])>,
    y_label: &str,
    x_label: &str,
) -> Result<(), RenderError> {
    let lh = line_height();
    let (left, right) = (i64::from(area.x), area.right() - 1);
    let (top, bottom) = (i64::from(area.y), area.bottom() - 1);
    for (&t, label) in y_ticks.iter().zip(tick_labels(y_ticks)) {
        let py = y.pixel(t).round();
        img.line([left as f64, py], [right as f64, py], GRID);
        img.line([left as f64 - 4.0, py], [left as f64, py], INK);
        text(
            img,
            left - 6,
            py as i64 - lh / 2,
            &label,
            INK,
            Anchor::Right,
        )?;
    }
    if let Some((xa, ticks)) = x {
        for (&t, label) in ticks.iter().zip(tick_labels(ticks)) {
            let px = xa.pixel(t).round();
            img.line([px, top as f64], [px, bottom as f64], GRID);
            img.line([px, bottom as f64], [px, bottom as f64 + 4.0], INK);
            text(img, px as i64, bottom + 7, &label, INK, Anchor::Center)?;
        }
    }
    img.stroke_rect(area, INK);
    if !y_label.is_empty() {
        layout::text_fit(
            img,
            clamp32(left - 6),
            clamp32(top - lh - 6),
            y_label,
            1,
            img.width().saturating_sub(8),
            Anchor::Left,
        )?;
    }
    if !x_label.is_empty() {
        let cx = (left + right) / 2;
        let room = (2 * cx.min(i64::from(img.width()) - cx)).max(1) as u32;
        layout::text_fit(
            img,
            clamp32(cx),
            clamp32(bottom + 7 + lh + 5),
            x_label,
            1,
            room.saturating_sub(8),
            Anchor::Center,
        )?;
    }
    Ok(())
}

/// The frame of an x-y plot filling a panel of `img` under its title band
/// (one line of space above, two lines and 22 pixels for the x labels
/// below), for data in `x_range` and `y_range` (their padded ranges, see
/// [`padded_range`]): nice ticks, about one per 40 rows and 70 columns,
/// drawn by [`draw_frame`]. Returns the x and y axes (data to pixels).
pub fn xy_frame(
    img: &mut Image,
    (xlo, xhi): (f64, f64),
    (ylo, yhi): (f64, f64),
    x_label: &str,
    y_label: &str,
) -> Result<(Axis, Axis), RenderError> {
    let (w, h) = (img.width(), img.height());
    let lh = line_height();
    let top = TITLE_BAND + lh;
    let bottom = i64::from(h) - 2 * lh - 22;
    let rows = (bottom - top).max(20);
    let y_ticks = nice_ticks(ylo, yhi, (rows / 40).clamp(2, 8) as usize);
    let left = 12 + label_width(&y_ticks);
    let right = i64::from(w) - 16;
    let cols = (right - left).max(20);
    let x_ticks = nice_ticks(xlo, xhi, (cols / 70).clamp(2, 8) as usize);
    let area = Rect::new(
        i32::try_from(left).unwrap_or(0),
        i32::try_from(top).unwrap_or(0),
        u32::try_from(cols).unwrap_or(20),
        u32::try_from(rows).unwrap_or(20),
    );
    let ya = Axis::over(&y_ticks, (area.bottom() - 1) as f64, top as f64);
    let xa = Axis::over(&x_ticks, left as f64, (area.right() - 1) as f64);
    draw_frame(
        img,
        area,
        &ya,
        &y_ticks,
        Some((&xa, &x_ticks)),
        y_label,
        x_label,
    )?;
    Ok((xa, ya))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(nice_ticks(0.0, 1.0, 5), vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
        assert_eq!(
            nice_ticks(3.0, 97.0, 5),
            vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]
        );
        let t = nice_ticks(-0.013, 0.041, 6);
        assert!(t[0] <= -0.013 && *t.last().unwrap() >= 0.041);
        assert!(t.len() <= 7);
        assert_eq!(nice_ticks(2.0, 2.0, 4), vec![1.0, 1.5, 2.0, 2.5, 3.0]);
    }

    #[test]
    fn tick_labels_differ_and_carry_the_step_s_digits() {
        assert_eq!(
            tick_labels(&[2.03, 2.035, 2.04]),
            vec!["2.030", "2.035", "2.040"]
        );
        assert_eq!(tick_labels(&[-0.5, 0.0, 0.5]), vec!["-0.5", "0.0", "0.5"]);
        assert_eq!(tick_labels(&[0.0, 20.0, 40.0]), vec!["0", "20", "40"]);
        assert_eq!(
            tick_labels(&[2.0e5, 3.0e5, 4.0e5]),
            vec!["2e5", "3e5", "4e5"]
        );
        assert_eq!(
            tick_labels(&[0.0, 5e-5, 1e-4]),
            vec!["0", "5.0e-5", "1.0e-4"]
        );
    }

    #[test]
    fn an_axis_maps_linearly() {
        let a = Axis::over(&[0.0, 5.0, 10.0], 100.0, 0.0);
        assert_eq!(a.pixel(0.0), 100.0);
        assert_eq!(a.pixel(10.0), 0.0);
        assert_eq!(a.pixel(2.5), 75.0);
        assert_eq!(padded_range([1.0, 3.0]), Some((0.9, 3.1)));
        assert_eq!(padded_range([f64::NAN]), None);
    }
}
