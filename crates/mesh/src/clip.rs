//! A triangle mesh cut by a plane ([`clip_below`]): the part on the
//! negative side of the plane, its triangles split along it.
//!
//! With `s(x) = n . (x - p)` (`p` a point of the plane, `n` its unit
//! normal), a vertex is *on* the plane when `|s| <= tol` (it is then moved
//! onto the plane, `x - s(x) n`), *below* when `s < -tol`, *above*
//! otherwise. Every triangle is clipped to `s <= 0` (Sutherland-Hodgman): its
//! corners below or on are kept, and an edge from below to above gets the
//! point where it crosses the plane,
//!
//! ```text
//! x = a + t (b - a),   t = s(a) / (s(a) - s(b)),
//! ```
//!
//! one vertex per cut edge, shared by the two triangles of the edge. The
//! clipped polygon (a triangle or a quadrilateral) is fanned from its first
//! corner; polygons with fewer than three distinct corners (a triangle that
//! only touches the plane) are dropped. The orientation of the triangles is
//! kept. Vertices above the plane, and any no triangle uses, are removed.
//! Snapping the vertices within `tol` avoids slivers along the cut.

use crate::reindex::compact_vertices;
use crate::{MeshError, TriMesh};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// The part of `mesh` with `n . (x - p) <= 0`, see the module doc;
/// `tol >= 0` is the snapping distance. Fields are not carried over.
///
/// # Errors
/// `InvalidArgument` for a normal that is not finite and non-zero, or a
/// `tol` that is negative or not finite; `IndexOutOfRange` for a triangle
/// with a vertex out of range.
pub fn clip_below(
    mesh: &TriMesh,
    p: &Point3<f64>,
    n: &Vector3<f64>,
    tol: f64,
) -> Result<TriMesh, MeshError> {
    let len = n.norm();
    if !(len.is_finite() && len > 0.0) {
        return Err(MeshError::InvalidArgument(format!(
            "the cutting plane's normal must be finite and non-zero, got {n:?}"
        )));
    }
    if !(tol.is_finite() && tol >= 0.0) {
        return Err(MeshError::InvalidArgument(format!(
            "the snapping distance must be finite and >= 0, got {tol}"
        )));
    }
    crate::geometry::check_indices(mesh.num_vertices(), &mesh.triangles)?;
    let n = n / len;
    let mut positions = mesh.positions.clone();
    let mut side = Vec::with_capacity(positions.len());
    for x in &mut positions {
        let s = n.dot(&(*x - p));
        if s.abs() <= tol {
            *x -= n * s;
            side.push(0.0);
        } else {
            side.push(s);
        }
    }
    let mut cut: HashMap<(u32, u32), u32> = HashMap::new();
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    for tri in &mesh.triangles {
        if tri.iter().all(|&v| side[v as usize] <= 0.0) {
            triangles.push(*tri);
            continue;
        }
        if tri.iter().all(|&v| side[v as usize] >= 0.0) {
            continue;
        }
        let mut poly: Vec<u32> = Vec::with_capacity(4);
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let (sa, sb) = (side[a as usize], side[b as usize]);
            if sa <= 0.0 {
                poly.push(a);
            }
            if (sa < 0.0 && sb > 0.0) || (sa > 0.0 && sb < 0.0) {
                let key = (a.min(b), a.max(b));
                let v = *cut.entry(key).or_insert_with(|| {
                    let (lo, hi) = (key.0 as usize, key.1 as usize);
                    let (s0, s1) = (side[lo], side[hi]);
                    let t = s0 / (s0 - s1);
                    let x = positions[lo] + (positions[hi] - positions[lo]) * t;
                    // exactly on the plane
                    let x = x - n * n.dot(&(x - p));
                    positions.push(x);
                    side.push(0.0);
                    (positions.len() - 1) as u32
                });
                poly.push(v);
            }
        }
        poly.dedup();
        if poly.len() >= 3 {
            for k in 1..poly.len() - 1 {
                triangles.push([poly[0], poly[k], poly[k + 1]]);
            }
        }
    }
    let c = compact_vertices(&positions, &crate::Fields::default(), &triangles)?;
    Ok(TriMesh::new(c.positions, c.elements))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::total_area;
    use crate::shapes::uv_sphere;
    use crate::topology::{boundary_loops, euler_characteristic};
    use proptest::prelude::*;

    #[test]
    fn a_sphere_cut_at_its_equator_is_a_hemisphere_with_a_planar_rim() {
        let m = uv_sphere(24, 48, 5.0);
        let h = clip_below(&m, &Point3::new(0.0, 0.0, 0.7), &Vector3::z(), 1e-9).unwrap();
        for x in &h.positions {
            assert!(x.z <= 0.7 + 1e-12);
        }
        let loops = boundary_loops(&h).unwrap();
        assert_eq!(loops.len(), 1);
        assert_eq!(euler_characteristic(&h), 1);
        for &v in &loops[0] {
            assert!((h.positions[v as usize].z - 0.7).abs() < 1e-12);
        }
        // the cap below z = 0.7 of a sphere of radius 5: 2 pi r (r + 0.7)
        let exact = 2.0 * std::f64::consts::PI * 5.0 * 5.7;
        assert!((total_area(&h) - exact).abs() < 0.01 * exact);
    }

    #[test]
    fn bad_planes_are_refused() {
        let m = uv_sphere(4, 8, 1.0);
        let o = Point3::origin();
        assert!(clip_below(&m, &o, &Vector3::zeros(), 0.0).is_err());
        assert!(clip_below(&m, &o, &Vector3::new(f64::NAN, 0.0, 1.0), 0.0).is_err());
        assert!(clip_below(&m, &o, &Vector3::z(), -1.0).is_err());
        // a plane below everything leaves nothing
        let below = clip_below(&m, &Point3::new(0.0, 0.0, -2.0), &Vector3::z(), 0.0).unwrap();
        assert!(below.triangles.is_empty() && below.positions.is_empty());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]
        /// Any plane through a sphere leaves one disk whose rim lies on the
        /// plane, and the kept area is the spherical cap's (within 2 %).
        #[test]
        fn any_plane_leaves_a_cap(
            h in -3.5f64..3.5,
            theta in 0.0f64..std::f64::consts::PI,
            phi in 0.0f64..std::f64::consts::TAU,
        ) {
            let m = uv_sphere(30, 60, 5.0);
            let n = Vector3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let p = Point3::from(n * h);
            let c = clip_below(&m, &p, &n, 1e-9).unwrap();
            let loops = boundary_loops(&c).unwrap();
            prop_assert_eq!(loops.len(), 1);
            prop_assert_eq!(euler_characteristic(&c), 1);
            for &v in &loops[0] {
                prop_assert!(n.dot(&(c.positions[v as usize] - p)).abs() < 1e-9);
            }
            let exact = 2.0 * std::f64::consts::PI * 5.0 * (5.0 + h);
            prop_assert!((total_area(&c) - exact).abs() < 0.02 * exact);
        }
    }
}
