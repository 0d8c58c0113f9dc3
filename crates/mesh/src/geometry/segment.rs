//! The closest point of a segment to a point, and their distance, in space
//! and in the plane.
//!
//! The closest point of the segment `[a, b]` to `p` is `a + t (b - a)` with
//!
//! ```text
//! t = clamp((p - a) . (b - a) / |b - a|^2, 0, 1)
//! ```
//!
//! the projection's parameter clamped to the segment; a degenerate segment
//! (`|b - a|^2` zero, or NaN) gives `t = 0`, the point `a`. The distance is
//! `|p - (a + t (b - a))|`.

use nalgebra::Point3;

/// The closest point to `p` on the segment `[a, b]` and its parameter `t`
/// in `[0, 1]` (module doc; `t = 0` when `a = b`).
#[inline]
pub fn closest_point_on_segment(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
) -> (Point3<f64>, f64) {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t, t)
}

/// The distance `|p - (a + t (b - a))|` from `p` to the segment `[a, b]`
/// (module doc; `|p - a|` when `a = b`).
#[inline]
pub fn point_segment_distance(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    (p - closest_point_on_segment(p, a, b).0).norm()
}

/// [`closest_point_on_segment`] in the plane: the closest point to `p` on
/// `[a, b]`, `a + t (b - a)` with
/// `t = clamp(((px - ax)(bx - ax) + (py - ay)(by - ay)) / |b - a|^2, 0, 1)`
/// (0 when `a = b`), and `t`.
#[inline]
pub fn closest_point_on_segment_2d(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> ([f64; 2], f64) {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ([a[0] + t * d[0], a[1] + t * d[1]], t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::strategies::point;
    use proptest::prelude::*;

    #[test]
    fn ends_middle_and_degenerate() {
        let (a, b) = (Point3::new(0.0, 0.0, 0.0), Point3::new(2.0, 0.0, 0.0));
        assert_eq!(
            closest_point_on_segment(&Point3::new(1.0, 3.0, 0.0), &a, &b),
            (Point3::new(1.0, 0.0, 0.0), 0.5)
        );
        assert_eq!(
            point_segment_distance(&Point3::new(-3.0, 4.0, 0.0), &a, &b),
            5.0
        );
        assert_eq!(
            point_segment_distance(&Point3::new(5.0, 0.0, 4.0), &a, &b),
            5.0
        );
        // a = b: the distance to a
        assert_eq!(
            point_segment_distance(&Point3::new(0.0, 3.0, 4.0), &a, &a),
            5.0
        );
        assert_eq!(
            closest_point_on_segment_2d([1.0, 1.0], [0.0, 0.0], [0.0, 0.0]),
            ([0.0, 0.0], 0.0)
        );
        assert_eq!(
            closest_point_on_segment_2d([3.0, 1.0], [0.0, 0.0], [2.0, 0.0]),
            ([2.0, 0.0], 1.0)
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Against brute force: no sample of the segment (1001 of them) is
        /// closer than the distance, the closest sample is within the
        /// sampling step of it, and the returned point is on the segment at
        /// that distance. The planar version agrees with the spatial one on
        /// points at `z = 0`.
        #[test]
        fn distance_matches_sampling(p in point(), a in point(), b in point()) {
            let d = point_segment_distance(&p, &a, &b);
            let (q, t) = closest_point_on_segment(&p, &a, &b);
            prop_assert!((0.0..=1.0).contains(&t));
            prop_assert!(((a + (b - a) * t) - q).norm() <= 1e-12 * (1.0 + q.coords.norm()));
            prop_assert!(((p - q).norm() - d).abs() <= 1e-12 * (1.0 + d));
            let steps = 1000;
            let mut best = f64::INFINITY;
            for k in 0..=steps {
                let s = k as f64 / steps as f64;
                let x = a + (b - a) * s;
                let dk = (p - x).norm();
                prop_assert!(dk >= d - 1e-9 * (1.0 + d), "sample {} closer: {} < {}", s, dk, d);
                best = best.min(dk);
            }
            prop_assert!(best - d <= (b - a).norm() / steps as f64 + 1e-9);

            let flat = |x: &Point3<f64>| Point3::new(x.x, x.y, 0.0);
            let (q3, t3) = closest_point_on_segment(&flat(&p), &flat(&a), &flat(&b));
            let (q2, t2) = closest_point_on_segment_2d([p.x, p.y], [a.x, a.y], [b.x, b.y]);
            prop_assert!((t2 - t3).abs() <= 1e-9);
            prop_assert!((q2[0] - q3.x).abs() <= 1e-9 && (q2[1] - q3.y).abs() <= 1e-9);
        }
    }
}
