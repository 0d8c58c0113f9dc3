//! Hole filling: boundary loops whose perimeter `Σ |v_{i+1} - v_i|` (the
//! loop's length, closing edge included) is at most a given distance are
//! closed with triangles over the loop's own vertices (no vertex is added).
//!
//! The loop is projected onto the plane through it with the Newell normal
//! `n = Σ v_i × v_{i+1}` (of the loop reversed, so the new triangles traverse
//! every boundary edge opposite to the triangle that has it: they are
//! oriented with the surface) and triangulated by ear clipping: repeatedly
//! cut off a convex corner whose triangle holds no other loop vertex. A
//! loop too twisted to have such an ear in that plane gets its most convex
//! corner cut instead, so every loop of `k` vertices gets `k - 2` triangles.
//! Each new triangle takes the cell data of the triangle along the loop's
//! first edge.

use super::work::Work;
use crate::{MeshError, TriMesh, topology::boundary_loops};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// What [`fill_holes`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Filled {
    /// Boundary loops closed.
    pub holes: usize,
    /// Triangles added.
    pub triangles: usize,
}

/// The perimeter of a closed loop of points.
pub(crate) fn perimeter(points: &[Point3<f64>]) -> f64 {
    (0..points.len())
        .map(|i| (points[(i + 1) % points.len()] - points[i]).norm())
        .sum()
}

/// Fills the boundary loops of perimeter at most `max_perimeter` (see the
/// module docs). The mesh must be manifold and consistently oriented.
///
/// # Errors
/// As [`boundary_loops`], for a mesh that is not.
pub(crate) fn fill_holes(w: &mut Work<3>, max_perimeter: f64) -> Result<Filled, MeshError> {
    let mesh = TriMesh::new(w.positions.clone(), w.elements.clone());
    let loops = boundary_loops(&mesh)?;
    let mut owner: HashMap<(u32, u32), usize> = HashMap::new();
    for (t, tri) in w.elements.iter().enumerate() {
        for i in 0..3 {
            owner.insert((tri[i], tri[(i + 1) % 3]), t);
        }
    }
    let mut filled = Filled::default();
    for l in loops {
        let pts: Vec<Point3<f64>> = l.iter().map(|&v| w.positions[v as usize]).collect();
        if l.len() < 3 || perimeter(&pts) > max_perimeter {
            continue;
        }
        let row = owner.get(&(l[0], l[1])).map(|&t| w.rows[t]).unwrap_or(0);
        let reversed: Vec<u32> = l.iter().rev().copied().collect();
        let new = ear_clip(&reversed, &w.positions);
        filled.holes += 1;
        filled.triangles += new.len();
        for t in new {
            w.elements.push(t);
            w.rows.push(row);
        }
    }
    Ok(filled)
}

/// Triangulates the polygon `poly` (vertex ids into `positions`) by ear
/// clipping in the plane of its Newell normal; the triangles follow the
/// polygon's direction.
pub(crate) fn ear_clip(poly: &[u32], positions: &[Point3<f64>]) -> Vec<[u32; 3]> {
    let p = |v: u32| positions[v as usize];
    let mut n = Vector3::zeros();
    for i in 0..poly.len() {
        n += p(poly[i])
            .coords
            .cross(&p(poly[(i + 1) % poly.len()]).coords);
    }
    let n = if n.norm() > 0.0 {
        n.normalize()
    } else {
        Vector3::z()
    };
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&helper).normalize();
    let v = n.cross(&u);
    let flat = |id: u32| [p(id).coords.dot(&u), p(id).coords.dot(&v)];
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let mut left: Vec<u32> = poly.to_vec();
    let mut out = Vec::with_capacity(poly.len().saturating_sub(2));
    while left.len() > 3 {
        let k = left.len();
        let corner = |i: usize| (left[(i + k - 1) % k], left[i], left[(i + 1) % k]);
        let is_ear = |i: usize| {
            let (a, b, c) = corner(i);
            let (fa, fb, fc) = (flat(a), flat(b), flat(c));
            cross(fa, fb, fc) > 0.0
                && left.iter().all(|&q| {
                    if q == a || q == b || q == c {
                        return true;
                    }
                    let fq = flat(q);
                    !(cross(fa, fb, fq) >= 0.0
                        && cross(fb, fc, fq) >= 0.0
                        && cross(fc, fa, fq) >= 0.0)
                })
        };
        let i = (0..k).find(|&i| is_ear(i)).unwrap_or_else(|| {
            (0..k)
                .max_by(|&x, &y| {
                    let (a, b, c) = corner(x);
                    let (d, e, f) = corner(y);
                    cross(flat(a), flat(b), flat(c)).total_cmp(&cross(flat(d), flat(e), flat(f)))
                })
                .unwrap_or(0)
        });
        let (a, b, c) = corner(i);
        out.push([a, b, c]);
        left.remove(i);
    }
    if left.len() == 3 {
        out.push([left[0], left[1], left[2]]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle_area_vector;

    #[test]
    fn a_non_convex_polygon_is_clipped_into_k_minus_2_positive_triangles() {
        // An L shape in the plane z = 1, counter-clockwise seen from +z.
        let xy = [
            (0.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (1.0, 1.0),
            (1.0, 2.0),
            (0.0, 2.0),
        ];
        let pos: Vec<Point3<f64>> = xy.iter().map(|&(x, y)| Point3::new(x, y, 1.0)).collect();
        let poly: Vec<u32> = (0..6).collect();
        let tris = ear_clip(&poly, &pos);
        assert_eq!(tris.len(), 4);
        let mut area = 0.0;
        for t in &tris {
            let a = triangle_area_vector(
                &pos[t[0] as usize],
                &pos[t[1] as usize],
                &pos[t[2] as usize],
            );
            assert!(a.z > 0.0, "{t:?}");
            area += a.z;
        }
        assert!((area - 3.0).abs() < 1e-12);
    }

    #[test]
    fn perimeter_of_a_unit_square_is_4() {
        let sq =
            [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(x, y)| Point3::new(x, y, 0.0));
        assert!((perimeter(&sq) - 4.0).abs() < 1e-15);
    }
}
