//! The cohort's LV bull's-eyes from the AHA-segment statistics: the mean
//! and the standard deviation of a per-point array's segment means over the
//! hearts, and one subject's z-scores (per segment `z = (x - m) / s`
//! against the mean `m` and standard deviation `s` of the other hearts)
//! on a diverging colour map with a symmetric range of at least +-2.

use unfold_render::{ColorScale, Colormap, format_value};

use crate::figures::ventricle::{BULLSEYE_COLORMAP, Bullseye, bullseye_figure};
use crate::figures::{Figure, FigureError, FigureOptions};

/// Colour map of the z-scores: blue (below the cohort) - white - red.
pub const Z_COLORMAP: Colormap = Colormap::BlueRed;

/// The z colour range is `[-m, m]` with `m` the largest `|z|` shown, and
/// at least this.
pub const Z_MIN_RANGE: f64 = 2.0;

/// Colour map of the standard deviations.
pub const STD_COLORMAP: Colormap = Colormap::Magma;

/// The cohort statistics of one array per AHA segment (index `k - 1`).
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentStatistics {
    /// The per-point array (`depth`, ...).
    pub array: String,
    /// Hearts with a value in the segment.
    pub hearts: [usize; 17],
    /// Mean over those hearts of their segment means.
    pub mean: [Option<f64>; 17],
    /// Their sample standard deviation (`None` below 2 hearts).
    pub std: [Option<f64>; 17],
}

/// File name of the mean bull's-eye of `array`.
pub fn mean_name(array: &str) -> String {
    format!("ventricle_{array}_mean_bullseye.png")
}

/// File name of the standard deviation bull's-eye of `array`.
pub fn std_name(array: &str) -> String {
    format!("ventricle_{array}_std_bullseye.png")
}

/// File name of subject `id`'s z-score bull's-eye of `array`.
pub fn z_name(id: &str, array: &str) -> String {
    format!("ventricle_{array}_z_{id}_bullseye.png")
}

fn finite(v: &[Option<f64>; 17]) -> Vec<f64> {
    v.iter()
        .flatten()
        .copied()
        .filter(|x| x.is_finite())
        .collect()
}

fn heading(first: &str, array: &str) -> Vec<String> {
    let mut h = vec![first.to_string()];
    h.extend(crate::figures::layout::wrap(
        array,
        crate::figures::ventricle::COLORBAR_HEADING_PX,
        1,
    ));
    h
}

/// The most hearts in any segment.
fn most(s: &SegmentStatistics) -> usize {
    s.hearts.iter().copied().max().unwrap_or(0)
}

/// [`mean_name`]: the cohort mean of `s.array` per segment
/// ([`BULLSEYE_COLORMAP`] over the means), hearts per segment in the table.
///
/// # Errors
/// [`bullseye_figure`]'s.
pub fn mean_bullseye(s: &SegmentStatistics, opts: &FigureOptions) -> Result<Figure, FigureError> {
    let scale = ColorScale::from_values(BULLSEYE_COLORMAP, &finite(&s.mean));
    bullseye_figure(
        &mean_name(&s.array),
        &Bullseye {
            title: &format!("cohort mean of {} per AHA segment", s.array),
            subtitle: &format!(
                "mean over {} hearts of each heart's segment mean; anterior up, septum left",
                most(s)
            ),
            heading: &heading("cohort mean", &s.array),
            scale: &scale,
            values: &s.mean,
            value_label: "mean",
            count_label: "hearts",
            counts: &s.hearts.map(|n| n.to_string()),
            footer: &format!("{} hearts", most(s)),
        },
        opts,
    )
}

/// [`std_name`]: the cohort's sample standard deviation of `s.array` per
/// segment ([`STD_COLORMAP`] over them).
///
/// # Errors
/// [`bullseye_figure`]'s.
pub fn std_bullseye(s: &SegmentStatistics, opts: &FigureOptions) -> Result<Figure, FigureError> {
    let scale = ColorScale::from_values(STD_COLORMAP, &finite(&s.std));
    bullseye_figure(
        &std_name(&s.array),
        &Bullseye {
            title: &format!("cohort std of {} per AHA segment", s.array),
            subtitle: &format!(
                "sample standard deviation over {} hearts of the segment means; grey: under 2 \
                 hearts",
                most(s)
            ),
            heading: &heading("cohort std", &s.array),
            scale: &scale,
            values: &s.std,
            value_label: "std",
            count_label: "hearts",
            counts: &s.hearts.map(|n| n.to_string()),
            footer: &format!("{} hearts", most(s)),
        },
        opts,
    )
}

/// [`z_name`]: subject `id`'s z-scores of `array` per segment, `z`, with
/// its segment means `values` in the table, on [`Z_COLORMAP`] over `[-m,
/// m]`, `m = max(`[`Z_MIN_RANGE`]`, max |z|)`.
///
/// # Errors
/// [`bullseye_figure`]'s.
pub fn z_bullseye(
    id: &str,
    array: &str,
    z: &[Option<f64>; 17],
    values: &[Option<f64>; 17],
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    let m = finite(z).iter().fold(Z_MIN_RANGE, |m, v| m.max(v.abs()));
    let scale = ColorScale::new(Z_COLORMAP, -m, m);
    bullseye_figure(
        &z_name(id, array),
        &Bullseye {
            title: &format!("{id}: z-score of {array} per AHA segment"),
            subtitle: "z = (segment mean - mean of the other hearts) / their std; blue below \
                       them, red above; grey: no value",
            heading: &heading("z-score", array),
            scale: &scale,
            values: z,
            value_label: "z",
            count_label: "value",
            counts: &values.map(|v| v.map_or("n/a".to_string(), format_value)),
            footer: &format!("colours span z in [-{0}, {0}]", format_value(m)),
        },
        opts,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::ventricle::{bullseye_layout, segment_centre};

    #[test]
    fn a_z_bullseye_spans_at_least_two_and_is_deterministic() {
        let opts = FigureOptions::default();
        let mut z = [Some(1.0); 17];
        z[16] = None;
        let values = [Some(0.5); 17];
        let a = z_bullseye("h1", "depth", &z, &values, &opts).unwrap();
        let b = z_bullseye("h1", "depth", &z, &values, &opts).unwrap();
        assert_eq!(a.name, "ventricle_depth_z_h1_bullseye.png");
        assert_eq!(a.image.to_png().unwrap(), b.image.to_png().unwrap());
        // z = 1 on [-2, 2]: three quarters up the map, inside segment 1
        // (off its number).
        let layout = bullseye_layout(&opts).unwrap();
        let c = segment_centre(1).unwrap();
        let p = layout.pixel([c[0] + 0.12, c[1]]);
        let got = a.image.get(p[0] as i64, p[1] as i64).unwrap();
        assert_eq!(got, Z_COLORMAP.eval(0.75).opaque());
        // A larger |z| widens the range symmetrically.
        z[0] = Some(-4.0);
        let c = z_bullseye("h1", "depth", &z, &values, &opts).unwrap();
        let got = c.image.get(p[0] as i64, p[1] as i64).unwrap();
        assert_eq!(got, Z_COLORMAP.eval(0.0).opaque());
    }

    #[test]
    fn mean_and_std_bullseyes_are_named_by_array() {
        let opts = FigureOptions::default();
        let s = SegmentStatistics {
            array: "xi".into(),
            hearts: [4; 17],
            mean: [Some(0.25); 17],
            std: [Some(0.1); 17],
        };
        assert_eq!(mean_bullseye(&s, &opts).unwrap().name, mean_name("xi"));
        assert_eq!(std_bullseye(&s, &opts).unwrap().name, std_name("xi"));
    }
}
