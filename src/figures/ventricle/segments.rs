//! The AHA 17 segments on the displayed LV disk: where each lies, its
//! middle, its outline on a drawing, and the per-segment means of a value.

use std::f64::consts::TAU;

use unfold_render::{annular_sector, arc};

use super::DiskLayout;

/// Where a segment lies on the displayed LV disk: radii `r0 <= r < r1` and
/// disk angles `a0 <= a < a1` in degrees (from `+xi`, the septum, towards
/// `+zeta`, anterior; `a1` may exceed 360), as [`aha_segment`](unfold_organs::ventricle::aha::aha_segment) labels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentShape {
    /// Inner radius (0 for the apex).
    pub r0: f64,
    /// Outer radius.
    pub r1: f64,
    /// First angle, degrees.
    pub a0: f64,
    /// Last angle, degrees.
    pub a1: f64,
}

/// The shape of AHA segment `segment` (1..=17) on the displayed LV disk;
/// `None` for other numbers.
pub fn segment_shape(segment: u8) -> Option<SegmentShape> {
    // Basal sectors by segment 1..6: [60,120) 1, [0,60) 2, [300,360) 3,
    // [240,300) 4, [180,240) 5, [120,180) 6.
    const BASAL_START: [f64; 6] = [60.0, 0.0, 300.0, 240.0, 180.0, 120.0];
    // Apical 13 anterior [45,135), 14 septal [315,405), 15 inferior
    // [225,315), 16 lateral [135,225).
    const APICAL_START: [f64; 4] = [45.0, 315.0, 225.0, 135.0];
    let s = |r0, r1, a0: f64, span: f64| SegmentShape {
        r0,
        r1,
        a0,
        a1: a0 + span,
    };
    match segment {
        1..=6 => Some(s(0.75, 1.0, BASAL_START[segment as usize - 1], 60.0)),
        7..=12 => Some(s(0.5, 0.75, BASAL_START[segment as usize - 7], 60.0)),
        13..=16 => Some(s(0.25, 0.5, APICAL_START[segment as usize - 13], 90.0)),
        17 => Some(s(0.0, 0.25, 0.0, 360.0)),
        _ => None,
    }
}

/// The middle of AHA segment `segment` on the displayed LV disk (mid
/// radius, mid angle; the origin for the apex), where its number is
/// written; `None` for numbers outside 1..=17.
pub fn segment_centre(segment: u8) -> Option<[f64; 2]> {
    let s = segment_shape(segment)?;
    if segment == 17 {
        return Some([0.0, 0.0]);
    }
    let r = 0.5 * (s.r0 + s.r1);
    let a = (0.5 * (s.a0 + s.a1)).to_radians();
    Some([r * a.cos(), r * a.sin()])
}

/// The value of one AHA segment in the bull's-eye.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SegmentMean {
    /// Anatomy points labelled with the segment.
    pub points: usize,
    /// Mean of their finite values; `None` when there is none.
    pub mean: Option<f64>,
}

/// Per-segment means of `values` over the points labelled `aha` (1..=17;
/// other labels and non-finite values are skipped). `aha` and `values`
/// are zipped (the shorter decides).
pub fn segment_means(aha: &[u8], values: &[f64]) -> [SegmentMean; 17] {
    let mut sum = [0.0f64; 17];
    let mut finite = [0usize; 17];
    let mut out = [SegmentMean::default(); 17];
    for (&a, &v) in aha.iter().zip(values) {
        if !(1..=17).contains(&a) {
            continue;
        }
        let k = a as usize - 1;
        out[k].points += 1;
        if v.is_finite() {
            sum[k] += v;
            finite[k] += 1;
        }
    }
    for k in 0..17 {
        if finite[k] > 0 {
            out[k].mean = Some(sum[k] / finite[k] as f64);
        }
    }
    out
}

/// The outline of segment `segment` on a disk drawn with `layout`.
pub(super) fn segment_outline(layout: &DiskLayout, segment: u8) -> Vec<[f64; 2]> {
    let Some(s) = segment_shape(segment) else {
        return Vec::new();
    };
    let c = layout.centre;
    let r = layout.scale;
    if segment == 17 {
        return arc(c, s.r1 * r, 0.0, TAU);
    }
    let (b0, b1) = (
        layout.screen_angle(s.a0.to_radians()),
        layout.screen_angle(s.a1.to_radians()),
    );
    let (b0, b1) = if b0 <= b1 { (b0, b1) } else { (b1, b0) };
    annular_sector(c, s.r0 * r, s.r1 * r, b0, b1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_organs::ventricle::aha::aha_segment;

    #[test]
    fn segment_centres_carry_their_own_labels() {
        for seg in 1..=17u8 {
            let c = segment_centre(seg).unwrap();
            assert_eq!(aha_segment(c), seg, "segment {seg} at {c:?}");
        }
        assert!(segment_centre(0).is_none() && segment_centre(18).is_none());
    }

    #[test]
    fn segment_means_skip_unlabelled_points_and_non_finite_values() {
        let m = segment_means(&[1, 1, 2, 0, 17, 3], &[1.0, 3.0, f64::NAN, 5.0, 7.0, 2.0]);
        assert_eq!(
            m[0],
            SegmentMean {
                points: 2,
                mean: Some(2.0)
            }
        );
        assert_eq!(
            m[1],
            SegmentMean {
                points: 1,
                mean: None
            }
        );
        assert_eq!(m[16].mean, Some(7.0));
        assert_eq!(m[3], SegmentMean::default());
    }
}
