//! Segment against triangle: does a segment cross a triangle's interior?

use nalgebra::Point3;

/// Whether the segment `p q` crosses the triangle `a b c` inside both
/// (Moller-Trumbore: with `d = q - p`, `e1 = b - a`, `e2 = c - a`,
/// `p + t d = a + u e1 + v e2` solved by Cramer's rule; a crossing needs
/// `u, v > eps`, `u + v < 1 - eps` and `eps < t < 1 - eps`, `eps = 1e-9`).
/// Touching (at a shared corner, along an edge) and coplanar
/// configurations (`|det| <= 1e-9 |d| |e1| |e2|`) do not count.
pub fn segment_crosses_triangle(
    p: &Point3<f64>,
    q: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> bool {
    const EPS: f64 = 1e-9;
    let d = q - p;
    let (e1, e2) = (b - a, c - a);
    let h = d.cross(&e2);
    let det = e1.dot(&h);
    let scale = d.norm() * e1.norm() * e2.norm();
    if det.abs() <= EPS * scale {
        return false;
    }
    let f = 1.0 / det;
    let s = p - a;
    let u = f * s.dot(&h);
    let qv = s.cross(&e1);
    let v = f * d.dot(&qv);
    let t = f * e2.dot(&qv);
    u > EPS && v > EPS && u + v < 1.0 - EPS && t > EPS && t < 1.0 - EPS
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A segment through a point inside the triangle, from one side to
        /// the other, crosses it (either direction); the same segment
        /// stopped short of the plane, or moved outside the triangle,
        /// does not.
        #[test]
        fn crossing_depends_on_the_interior_and_the_plane(
            u in 0.05f64..0.9, frac in 0.05f64..0.9, h in 0.1f64..5.0, tilt in -0.5f64..0.5,
        ) {
            let v = frac * (1.0 - u) * 0.95;
            let (a, b, c) = (
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(2.0, 0.0, 0.0),
                Point3::new(0.0, 3.0, 0.0),
            );
            let x = a + (b - a) * u + (c - a) * v;
            let p = Point3::new(x.x + tilt, x.y, h);
            let q = Point3::new(x.x - tilt, x.y, -h);
            prop_assert!(segment_crosses_triangle(&p, &q, &a, &b, &c));
            prop_assert!(segment_crosses_triangle(&q, &p, &a, &b, &c));
            let mid = Point3::from((p.coords + x.coords) * 0.5);
            prop_assert!(!segment_crosses_triangle(&p, &mid, &a, &b, &c));
            let off = nalgebra::Vector3::new(10.0, 10.0, 0.0);
            prop_assert!(!segment_crosses_triangle(&(p + off), &(q + off), &a, &b, &c));
        }
    }

    #[test]
    fn touching_and_coplanar_segments_do_not_cross() {
        let (a, b, c) = (
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        );
        // through a corner
        assert!(!segment_crosses_triangle(
            &Point3::new(0.0, 0.0, 1.0),
            &Point3::new(0.0, 0.0, -1.0),
            &a,
            &b,
            &c
        ));
        // in the plane
        assert!(!segment_crosses_triangle(
            &Point3::new(-1.0, 0.2, 0.0),
            &Point3::new(2.0, 0.2, 0.0),
            &a,
            &b,
            &c
        ));
    }
}
