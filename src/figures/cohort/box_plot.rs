//! Box-and-whisker plots: the statistics of a sample ([`box_stats`]) and
//! a panel of groups side by side ([`box_panel`]), as in the placenta
//! paper's Fig. 7: the median as a black line inside the box, the box from
//! the 25th to the 75th percentile, the whiskers to the most extreme values
//! not considered outliers, the outliers (farther than 1.5 times the
//! interquartile range from the box) as red crosses.

use unfold_render::{Anchor, Image, Rect, RenderError, Rgba, text_width};

use super::axes::{
    Axis, SOFT_INK, TITLE_BAND, clamp32, draw_frame, label_width, line_height, nice_ticks,
    padded_range, text, title_band,
};
use crate::figures::{FigureOptions, INK, PAPER};

/// Fill of the boxes.
pub const BOX_FILL: Rgba = Rgba::new(173, 198, 231, 255);

/// Colour of the outlier crosses.
pub const OUTLIER: Rgba = Rgba::new(214, 39, 40, 255);

/// Whiskers reach to the most extreme values within `WHISKER_IQR` times
/// the interquartile range of the box.
pub const WHISKER_IQR: f64 = 1.5;

/// The box-plot statistics of a sample.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxStats {
    /// Number of (finite) values.
    pub n: usize,
    /// 25th percentile ([`quantile`] at 0.25).
    pub q1: f64,
    /// Median ([`quantile`] at 0.5).
    pub median: f64,
    /// 75th percentile ([`quantile`] at 0.75).
    pub q3: f64,
    /// End of the lower whisker: the smallest value at least `q1 - 1.5
    /// IQR`, or `q1` if that value is above `q1`.
    pub whisker_lo: f64,
    /// End of the upper whisker: the largest value at most `q3 + 1.5 IQR`,
    /// or `q3` if that value is below `q3`.
    pub whisker_hi: f64,
    /// The values below `q1 - 1.5 IQR` or above `q3 + 1.5 IQR`, ascending.
    pub outliers: Vec<f64>,
}

/// The `p`-quantile (`p` in `[0, 1]`, clamped) of ascending `sorted`
/// values by linear interpolation between closest ranks (Hyndman and Fan's
/// type 7, the default of R and NumPy): with `h = (n - 1) p`,
/// `q = x[floor h] + (h - floor h) (x[floor h + 1] - x[floor h])`
/// (0-based). `None` for no value.
pub fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
    let k = (h.floor() as usize).min(n - 1);
    let f = h - k as f64;
    let next = sorted.get(k + 1).copied().unwrap_or(sorted[k]);
    Some(sorted[k] + f * (next - sorted[k]))
}

/// The box-plot statistics of the finite values of `values` (NaN and
/// infinities are left out); `None` when there is none. The quartiles are
/// [`quantile`]s; with `IQR = q3 - q1`, values outside `[q1 - 1.5 IQR, q3 +
/// 1.5 IQR]` are outliers and the whiskers reach to the most extreme values
/// inside it, never into the box (`whisker_lo <= q1 <= median <= q3 <=
/// whisker_hi`). Every value is either in `[whisker_lo, whisker_hi]` or an
/// outlier.
pub fn box_stats(values: &[f64]) -> Option<BoxStats> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let q1 = quantile(&v, 0.25)?;
    let median = quantile(&v, 0.5)?;
    let q3 = quantile(&v, 0.75)?;
    let iqr = q3 - q1;
    let (lo_fence, hi_fence) = (q1 - WHISKER_IQR * iqr, q3 + WHISKER_IQR * iqr);
    let inside = || {
        v.iter()
            .copied()
            .filter(|&x| x >= lo_fence && x <= hi_fence)
    };
    let whisker_lo = inside().fold(q1, f64::min);
    let whisker_hi = inside().fold(q3, f64::max);
    let outliers = v
        .iter()
        .copied()
        .filter(|&x| x < lo_fence || x > hi_fence)
        .collect();
    Some(BoxStats {
        n: v.len(),
        q1,
        median,
        q3,
        whisker_lo,
        whisker_hi,
        outliers,
    })
}

/// One box of a panel: its label under the x axis and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxGroup {
    /// Shown under the box, with `n = ...` below it.
    pub label: String,
    /// The sample (non-finite values are left out).
    pub values: Vec<f64>,
}

/// What a panel of box plots shows.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxPanel {
    /// Title (scale 2 when it fits).
    pub title: String,
    /// Subtitle (wrapped, up to two lines).
    pub subtitle: String,
    /// The measured quantity, above the y axis.
    pub y_label: String,
    /// The boxes, left to right.
    pub groups: Vec<BoxGroup>,
}

/// A cross of half size `r` about `(x, y)`, two pixels thick.
fn cross(img: &mut Image, x: f64, y: f64, r: f64, c: Rgba) {
    for d in [0.0, 1.0] {
        img.line([x - r + d, y - r], [x + r + d, y + r], c);
        img.line([x - r + d, y + r], [x + r + d, y - r], c);
    }
}

/// One panel (`opts.panel_width x opts.panel_height`) of box plots: the
/// title band, the y axis over all values (ticks, grid lines, `y_label`),
/// per group left to right its box (`q1` to `q3`, filled [`BOX_FILL`]), the
/// median (a black line two pixels thick), the whiskers with caps, the
/// outliers as red crosses ([`OUTLIER`]), its label and `n = ...` under the
/// axis. A group without values shows only its label and `n = 0`.
///
/// # Errors
/// The renderer's (a panel too small for its text).
pub fn box_panel(panel: &BoxPanel, opts: &FigureOptions) -> Result<Image, RenderError> {
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut img = Image::new(w, h, PAPER)?;
    title_band(&mut img, &panel.title, &panel.subtitle)?;
    let stats: Vec<Option<BoxStats>> = panel.groups.iter().map(|g| box_stats(&g.values)).collect();
    let all = stats.iter().flatten().flat_map(|s| {
        [s.whisker_lo, s.whisker_hi]
            .into_iter()
            .chain(s.outliers.iter().copied())
    });
    let (lo, hi) = padded_range(all).unwrap_or((0.0, 1.0));
    let lh = line_height();
    let top = TITLE_BAND + lh + 12;
    let bottom = i64::from(h) - 2 * lh - 16;
    let rows = (bottom - top).max(20);
    let ticks = nice_ticks(lo, hi, (rows / 40).clamp(2, 8) as usize);
    let left = 12 + label_width(&ticks);
    let right = i64::from(w) - 12;
    let area = Rect::new(
        clamp32(left),
        clamp32(top),
        (right - left).max(20) as u32,
        rows as u32,
    );
    let y = Axis::over(&ticks, (area.bottom() - 1) as f64, top as f64);
    draw_frame(&mut img, area, &y, &ticks, None, &panel.y_label, "")?;
    let n = panel.groups.len().max(1) as f64;
    let slot = f64::from(area.width) / n;
    let half = (0.25 * slot).clamp(4.0, 40.0);
    for (k, (g, s)) in panel.groups.iter().zip(&stats).enumerate() {
        let cx = (f64::from(area.x) + slot * (k as f64 + 0.5)).round();
        let room = slot.max(8.0) as u32 - 4;
        crate::figures::layout::text_fit(
            &mut img,
            clamp32(cx as i64),
            clamp32(area.bottom() + 5),
            &g.label,
            1,
            room,
            Anchor::Center,
        )?;
        let count = format!("n = {}", s.as_ref().map_or(0, |s| s.n));
        let shown = if text_width(&count, 1) <= room {
            count
        } else {
            s.as_ref().map_or(0, |s| s.n).to_string()
        };
        text(
            &mut img,
            cx as i64,
            area.bottom() + 5 + lh + 3,
            &shown,
            SOFT_INK,
            Anchor::Center,
        )?;
        let Some(s) = s else { continue };
        let (y_q1, y_q3) = (y.pixel(s.q1).round(), y.pixel(s.q3).round());
        let (y_lo, y_hi) = (y.pixel(s.whisker_lo).round(), y.pixel(s.whisker_hi).round());
        // Whiskers and their caps.
        img.line([cx, y_q1], [cx, y_lo], INK);
        img.line([cx, y_q3], [cx, y_hi], INK);
        let cap = (0.5 * half).round();
        img.line([cx - cap, y_lo], [cx + cap, y_lo], INK);
        img.line([cx - cap, y_hi], [cx + cap, y_hi], INK);
        // The box (at least one pixel high) and its median.
        let (bx, bw) = ((cx - half) as i32, (2.0 * half) as u32 + 1);
        let by = y_q3 as i32;
        let bh = ((y_q1 - y_q3) as u32).max(1) + 1;
        img.fill_rect(Rect::new(bx, by, bw, bh), BOX_FILL);
        img.stroke_rect(Rect::new(bx, by, bw, bh), INK);
        let ym = y.pixel(s.median).round();
        for d in [-0.5, 0.5] {
            img.line([cx - half, ym + d], [cx + half, ym + d], INK);
        }
        for &o in &s.outliers {
            cross(&mut img, cx, y.pixel(o), 4.0, OUTLIER);
        }
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn panel() -> BoxPanel {
        BoxPanel {
            title: "t".into(),
            subtitle: "s".into(),
            y_label: "y".into(),
            groups: vec![
                BoxGroup {
                    label: "a".into(),
                    values: vec![1.0, 2.0, 3.0, 4.0, 5.0, 40.0],
                },
                BoxGroup {
                    label: "b".into(),
                    values: vec![],
                },
            ],
        }
    }

    #[test]
    fn a_panel_is_deterministic_and_marks_the_outlier_red() {
        let opts = FigureOptions::default();
        let a = box_panel(&panel(), &opts).unwrap();
        let b = box_panel(&panel(), &opts).unwrap();
        assert_eq!(a.to_png().unwrap(), b.to_png().unwrap());
        // `UNFOLD_FIGURES_DIR` keeps the panel to look at.
        if let Ok(dir) = std::env::var("UNFOLD_FIGURES_DIR") {
            std::fs::create_dir_all(&dir).unwrap();
            let path = std::path::Path::new(&dir).join("box_panel.png");
            std::fs::write(path, a.to_png().unwrap()).unwrap();
        }
        let count = |c: Rgba| {
            (0..a.height())
                .flat_map(|y| (0..a.width()).map(move |x| (x, y)))
                .filter(|&(x, y)| a.get(i64::from(x), i64::from(y)) == Some(c))
                .count()
        };
        assert!(count(OUTLIER) >= 8, "one cross of red pixels");
        assert!(count(BOX_FILL) > 100, "one filled box");
    }

    #[test]
    fn quartiles_of_known_samples() {
        let s = box_stats(&[1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert_eq!((s.q1, s.median, s.q3), (2.0, 3.0, 4.0));
        assert_eq!((s.whisker_lo, s.whisker_hi), (1.0, 5.0));
        assert!(s.outliers.is_empty());
        // Type 7: h = 3 * 0.25 = 0.75 between 10 and 20.
        let s = box_stats(&[40.0, 10.0, 30.0, 20.0]).unwrap();
        assert_eq!((s.q1, s.median, s.q3), (17.5, 25.0, 32.5));
        assert_eq!(quantile(&[7.0], 0.3), Some(7.0));
        assert_eq!(quantile(&[], 0.3), None);
        assert_eq!(box_stats(&[f64::NAN]), None);
    }

    #[test]
    fn far_values_are_outliers_and_the_whiskers_stop_before_them() {
        // q1 = 1.5, q3 = 4.5, IQR = 3: fences -3 and 9.
        let s = box_stats(&[-5.0, 1.0, 2.0, 3.0, 4.0, 5.0, 100.0, f64::NAN]).unwrap();
        assert_eq!(s.n, 7);
        assert_eq!((s.q1, s.q3), (1.5, 4.5));
        assert_eq!((s.whisker_lo, s.whisker_hi), (1.0, 5.0));
        assert_eq!(s.outliers, vec![-5.0, 100.0]);
        // The nearest value inside the fence lies above q1: the whisker
        // stops at the box.
        let s = box_stats(&[0.0, 100.0, 101.0, 102.0]).unwrap();
        assert_eq!(s.q1, 75.0);
        assert_eq!(s.whisker_lo, 75.0);
        assert_eq!(s.outliers, vec![0.0]);
    }

    proptest! {
        #[test]
        fn quartiles_are_ordered_and_every_value_is_whiskered_or_an_outlier(
            v in proptest::collection::vec(-1e6f64..1e6, 1..60)
        ) {
            let s = box_stats(&v).unwrap();
            prop_assert_eq!(s.n, v.len());
            prop_assert!(s.whisker_lo <= s.q1);
            prop_assert!(s.q1 <= s.median && s.median <= s.q3);
            prop_assert!(s.q3 <= s.whisker_hi);
            for &x in &v {
                let whiskered = x >= s.whisker_lo && x <= s.whisker_hi;
                let outlier = s.outliers.contains(&x);
                prop_assert!(whiskered != outlier, "{} in both or neither", x);
            }
        }

        #[test]
        fn the_statistics_do_not_depend_on_the_order(
            v in proptest::collection::vec(-1e3f64..1e3, 1..40),
            seed in any::<u64>(),
        ) {
            let mut w = v.clone();
            // A Fisher-Yates shuffle from a small LCG.
            let mut r = seed | 1;
            for i in (1..w.len()).rev() {
                r = r.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                w.swap(i, (r >> 33) as usize % (i + 1));
            }
            prop_assert_eq!(box_stats(&v), box_stats(&w));
        }
    }
}
