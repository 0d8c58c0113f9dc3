//! Planar point sets: the coordinates of points that lie in one plane, in
//! that plane.
//!
//! With the principal-axes frame ([`super::pca_frame`]) of the points, `e_0`,
//! `e_1` span the best-fitting plane and `e_2` is its normal. The points lie
//! in one plane when every distance to it is within `rel_tol` of the
//! bounding box's diagonal `D`:
//!
//! ```text
//! max_i |e_2 . (p_i - c)| <= rel_tol * D
//! ```
//!
//! and their plane coordinates are then `(e_0 . (p_i - c), e_1 . (p_i - c))`.
//! A triangle map written to a file as 3D points (a flattening with z = 0,
//! or a plane tilted in space) is judged in those coordinates: its inverted
//! triangles ([`super::Orientations`]) and folded edges
//! ([`super::folded_edges`]).

use super::{bounding_box, pca_frame};
use nalgebra::Point3;

/// The relative flatness [`plane_coordinates`] accepts by default: a plane
/// written in single precision (about `1e-7` relative) is still one.
pub const PLANAR_REL_TOL: f64 = 1e-6;

/// The points' coordinates in their common plane (module doc), or `None`
/// when they do not lie in one plane within `rel_tol * D`, when there are
/// fewer than three, when a coordinate is not finite, or when they all
/// coincide (`D == 0`).
pub fn plane_coordinates(points: &[Point3<f64>], rel_tol: f64) -> Option<Vec<[f64; 2]>> {
    if points.len() < 3 {
        return None;
    }
    let b = bounding_box(points)?;
    let diagonal = (b.max - b.min).norm();
    if !(diagonal.is_finite() && diagonal > 0.0) {
        return None;
    }
    let frame = pca_frame(points)?;
    let mut uv = Vec::with_capacity(points.len());
    for p in points {
        let q = frame.to_local(p);
        if q.z.abs() > rel_tol * diagonal {
            return None;
        }
        uv.push([q.x, q.y]);
    }
    Some(uv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// A plane moved anywhere is planar, and its plane coordinates keep
        /// every distance; a point lifted off it by more than the tolerance
        /// makes the set non-planar.
        #[test]
        fn a_moved_plane_is_planar_and_keeps_distances(
            axis in prop::array::uniform3(-1.0f64..1.0),
            angle in 0.0f64..3.0,
            shift in prop::array::uniform3(-100.0f64..100.0),
            lift in 1e-3f64..1.0,
        ) {
            let r = Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(Vector3::from(axis) + Vector3::new(1e-3, 0.0, 0.0)),
                angle,
            );
            let flat: Vec<Point3<f64>> = (0..20)
                .map(|k| {
                    let (x, y) = ((k % 5) as f64 * 3.0, (k / 5) as f64 * 2.0 + 0.1 * k as f64);
                    Point3::from(r * Vector3::new(x, y, 0.0) + Vector3::from(shift))
                })
                .collect();
            let uv = plane_coordinates(&flat, PLANAR_REL_TOL).expect("planar");
            for i in 0..flat.len() {
                for j in 0..flat.len() {
                    let d3 = (flat[i] - flat[j]).norm();
                    let d2 = ((uv[i][0] - uv[j][0]).powi(2) + (uv[i][1] - uv[j][1]).powi(2)).sqrt();
                    prop_assert!((d3 - d2).abs() <= 1e-9 * (1.0 + d3));
                }
            }
            let mut bent = flat.clone();
            bent[7] += r * Vector3::new(0.0, 0.0, lift);
            prop_assert!(plane_coordinates(&bent, PLANAR_REL_TOL).is_none());
        }
    }

    #[test]
    fn too_few_or_coincident_points_are_not_a_plane() {
        let p = Point3::new(1.0, 2.0, 3.0);
        assert!(plane_coordinates(&[p, p], PLANAR_REL_TOL).is_none());
        assert!(plane_coordinates(&[p, p, p], PLANAR_REL_TOL).is_none());
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        assert!(plane_coordinates(&[p, nan, Point3::origin()], PLANAR_REL_TOL).is_none());
    }
}
