//! Summary statistics of a set of values: [`Summary`] (mean, standard
//! deviation, extremes and percentiles) and [`percentile_sorted`].
//!
//! One home for the statistics that reports print about per-element
//! values (distortion metrics, errors). It is not geometry (no positions,
//! only numbers), hence its own module beside `geometry`; it lives in this
//! crate because every crate that reports statistics depends on it.
//!
//! The standard deviation convention is the **sample** one,
//! `sqrt(sum (v - mean)^2 / (n - 1))`, as MATLAB's `std` which the placenta
//! paper's code uses and which `report.json` has always printed for the
//! placenta's distortion summaries; the population one (`n` in the
//! denominator) is `std * sqrt((n - 1) / n)` up to rounding.

use serde::{Deserialize, Serialize};

/// Mean, standard deviation, extremes and percentiles of a set of values
/// (ALGORITHMS 2.6 "mean, std and percentiles").
///
/// - `mean = sum v / n` and `std` the sample standard deviation
///   `sqrt(sum (v - mean)^2 / (n - 1))` (0 for a single value), as MATLAB's
///   `std` which the placenta paper's code uses; both sums run over the
///   values sorted ascending (so the result does not depend on their
///   order, to the bit).
/// - Percentiles interpolate linearly between order statistics: with the
///   values sorted ascending `v_0 <= ... <= v_{n-1}`, the `p`-th percentile
///   is at rank `r = p/100 (n - 1)`, i.e.
///   `v_floor(r) + (r - floor r)(v_ceil(r) - v_floor(r))` (NumPy's default
///   `linear` method, R's type 7; `p50` is the usual median).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Summary {
    /// Arithmetic mean.
    #[serde(with = "crate::nan_as_null")]
    pub mean: f64,
    /// Sample standard deviation (`n - 1` in the denominator).
    #[serde(with = "crate::nan_as_null")]
    pub std: f64,
    /// Smallest value.
    #[serde(with = "crate::nan_as_null")]
    pub min: f64,
    /// Largest value.
    #[serde(with = "crate::nan_as_null")]
    pub max: f64,
    /// 5th percentile.
    #[serde(with = "crate::nan_as_null")]
    pub p5: f64,
    /// 25th percentile (first quartile).
    #[serde(with = "crate::nan_as_null")]
    pub p25: f64,
    /// 50th percentile (median).
    #[serde(with = "crate::nan_as_null")]
    pub p50: f64,
    /// 75th percentile (third quartile).
    #[serde(with = "crate::nan_as_null")]
    pub p75: f64,
    /// 95th percentile.
    #[serde(with = "crate::nan_as_null")]
    pub p95: f64,
}

impl Summary {
    /// The summary of `values`; `None` when `values` is empty or contains a
    /// NaN. Infinite values are accepted and propagate (e.g. an infinite
    /// `max`, and then a NaN `std`).
    pub fn of(values: &[f64]) -> Option<Summary> {
        if values.is_empty() || values.iter().any(|v| v.is_nan()) {
            return None;
        }
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let mean = sorted.iter().sum::<f64>() / n as f64;
        let std = if n > 1 {
            (sorted.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Some(Summary {
            mean,
            std,
            min: sorted[0],
            max: sorted[n - 1],
            p5: percentile_sorted(&sorted, 5.0),
            p25: percentile_sorted(&sorted, 25.0),
            p50: percentile_sorted(&sorted, 50.0),
            p75: percentile_sorted(&sorted, 75.0),
            p95: percentile_sorted(&sorted, 95.0),
        })
    }
}

/// The `p`-th percentile (`0 <= p <= 100`, clamped) of ascending `sorted`
/// values by linear interpolation at rank `p/100 (n - 1)` (see
/// [`Summary`]); NaN for an empty slice.
pub fn percentile_sorted(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let rank = (p.clamp(0.0, 100.0) / 100.0) * (n - 1) as f64;
    let lo = rank.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    let frac = rank - lo as f64;
    if frac == 0.0 || sorted[lo] == sorted[hi] {
        sorted[lo]
    } else {
        sorted[lo] + frac * (sorted[hi] - sorted[lo])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn metrics_summary_of_known_data() {
        let s = Summary::of(&[5.0, 1.0, 4.0, 2.0, 3.0]).unwrap();
        assert_eq!((s.min, s.max, s.mean), (1.0, 5.0, 3.0));
        assert!((s.std - 2.5f64.sqrt()).abs() < 1e-15);
        assert_eq!((s.p25, s.p50, s.p75), (2.0, 3.0, 4.0));
        assert!((s.p5 - 1.2).abs() < 1e-12 && (s.p95 - 4.8).abs() < 1e-12);
        let s = Summary::of(&[20.0, 10.0]).unwrap();
        assert_eq!((s.p25, s.p50, s.p75), (12.5, 15.0, 17.5));
        let s = Summary::of(&[7.0]).unwrap();
        assert_eq!((s.std, s.p5, s.p95, s.mean), (0.0, 7.0, 7.0, 7.0));
        assert!(Summary::of(&[]).is_none());
        assert!(Summary::of(&[1.0, f64::NAN]).is_none());
        let s = Summary::of(&[1.0, f64::INFINITY]).unwrap();
        assert_eq!(s.max, f64::INFINITY);
        assert_eq!(percentile_sorted(&[0.0, 10.0], 150.0), 10.0);
        assert!(percentile_sorted(&[], 50.0).is_nan());
    }

    #[test]
    fn metrics_summary_percentiles_are_monotone() {
        let v: Vec<f64> = (0..101).map(|i| ((i * 37) % 101) as f64).collect();
        let s = Summary::of(&v).unwrap();
        assert_eq!(
            (s.p5, s.p25, s.p50, s.p75, s.p95),
            (5.0, 25.0, 50.0, 75.0, 95.0)
        );
        assert_eq!(s.mean, 50.0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Against the direct formulas: mean, sample std (`n - 1`), extremes
        /// and the median of the sorted values; order does not matter.
        #[test]
        fn summary_matches_the_direct_formulas(
            v in prop::collection::vec(-1e3f64..1e3, 1..60),
        ) {
            let s = Summary::of(&v).unwrap();
            let n = v.len() as f64;
            let mean = v.iter().sum::<f64>() / n;
            let var = if v.len() > 1 {
                v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0)
            } else {
                0.0
            };
            prop_assert!((s.mean - mean).abs() <= 1e-9);
            prop_assert!((s.std - var.sqrt()).abs() <= 1e-9);
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            prop_assert_eq!(s.min, sorted[0]);
            prop_assert_eq!(s.max, sorted[v.len() - 1]);
            let m = v.len() / 2;
            let median = if v.len() % 2 == 1 {
                sorted[m]
            } else {
                0.5 * (sorted[m - 1] + sorted[m])
            };
            prop_assert!((s.p50 - median).abs() <= 1e-9);
            prop_assert!(s.min <= s.p5 && s.p5 <= s.p25 && s.p25 <= s.p50);
            prop_assert!(s.p50 <= s.p75 && s.p75 <= s.p95 && s.p95 <= s.max);
            let mut reversed = v.clone();
            reversed.reverse();
            prop_assert_eq!(Summary::of(&reversed), Some(s));
        }
    }
}
