//! Exact geometric predicates (Shewchuk's adaptive orientation tests, crate
//! `robust`) and the exact collinearity test built on them.

use nalgebra::Point3;

#[inline]
fn c3(p: &Point3<f64>) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// Exact orientation of `d` against the plane of `(a, b, c)`: a value with
/// the exact sign of `(b-a)·((c-a)×(d-a))` (same sign convention as
/// [`tet_signed_volume`](super::tet_signed_volume)); positive when `d` is on the side the
/// counter-clockwise normal of `abc` points to, zero exactly when coplanar.
/// The magnitude is approximate. Shewchuk's adaptive predicate (`robust`).
#[inline]
pub fn orient3d_exact(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, d: &Point3<f64>) -> f64 {
    -robust::orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// Exact orientation of the planar triangle `(a, b, c)`: a value with the
/// exact sign of `(b-a) × (c-a)` (as [`triangle_signed_area_2d`](super::triangle_signed_area_2d)); positive
/// when counter-clockwise, zero exactly when collinear. Magnitude approximate.
#[inline]
pub fn orient2d_exact(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let k = |p: [f64; 2]| robust::Coord { x: p[0], y: p[1] };
    robust::orient2d(k(a), k(b), k(c))
}

/// `p` with coordinate `drop` removed (the projection onto a coordinate plane).
#[inline]
pub(super) fn project(p: &Point3<f64>, drop: usize) -> [f64; 2] {
    match drop {
        0 => [p.y, p.z],
        1 => [p.z, p.x],
        _ => [p.x, p.y],
    }
}

/// Exact collinearity of three points: `(b-a)×(c-a) = 0`, whose components
/// are the 2D orientations of the three coordinate projections.
pub(super) fn collinear_exact(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> bool {
    (0..3).all(|k| orient2d_exact(project(a, k), project(b, k), project(c, k)) == 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::strategies::point;
    use crate::geometry::{tet_signed_volume, triangle_signed_area_2d};
    use proptest::prelude::*;

    proptest! {
        /// The exact predicate has the sign of the float signed volume for
        /// well-conditioned tets.
        #[test]
        fn orient3d_exact_matches_signed_volume(a in point(), b in point(), c in point(), d in point()) {
            let v = tet_signed_volume(&a, &b, &c, &d);
            prop_assume!(v.abs() > 1e-6);
            prop_assert_eq!(orient3d_exact(&a, &b, &c, &d) > 0.0, v > 0.0);
            let s2 = triangle_signed_area_2d([a.x, a.y], [b.x, b.y], [c.x, c.y]);
            prop_assume!(s2.abs() > 1e-6);
            prop_assert_eq!(orient2d_exact([a.x, a.y], [b.x, b.y], [c.x, c.y]) > 0.0, s2 > 0.0);
        }
    }
}
