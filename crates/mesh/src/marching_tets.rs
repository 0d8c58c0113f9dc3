//! The zero level set of a sampled scalar field as a closed triangle mesh,
//! by marching tetrahedra on the Kuhn (Freudenthal) subdivision of the
//! voxel grid ([`isosurface`]).
//!
//! Every grid cube `[i, i+1] x [j, j+1] x [k, k+1]` is split into the six
//! tets `{c, c + e_a, c + e_a + e_b, c + 1}` (one per permutation
//! `(a, b, c)` of the axes, `1 = (1, 1, 1)`); the subdivision is the same
//! in every cube, so neighbouring cubes' tets share their faces. On each tet
//! the field is interpolated linearly, and its zero set is a triangle (one
//! corner on the other side from the three others) or a quadrilateral (two
//! and two, split into two triangles); an edge `(p, q)` with values
//! `f_p < 0 <= f_q` is cut at
//!
//! ```text
//! x = p + t (q - p),   t = f_p / (f_p - f_q)
//! ```
//!
//! and each cut edge gives one vertex shared by every tet around it. A value
//! `0` counts as outside (non-negative), so no vertex of the grid lies on the
//! surface. The surface is the zero set of the piecewise-linear interpolant:
//! a 2-manifold without boundary when every value on the grid's border is
//! non-negative, oriented with normals pointing from negative to
//! non-negative values (outward of the region `f < 0`). Each triangle's
//! orientation is decided on the triangle of its edges' midpoints (which
//! the interpolated triangle reaches by sliding its corners along their
//! edges, so the orientation is the same), so slivers of nearly coincident
//! corners are oriented as reliably as the others.

use crate::{MeshError, TriMesh};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// The six tets of the unit cube, as corner bit masks (`bit a` set: `+1`
/// along axis `a`): `0 -> e_a -> e_a + e_b -> 1` for every permutation.
const KUHN: [[u8; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// The zero level set of `values`, sampled at the grid points `(i, j, k)`,
/// `0 <= i < dims[0]` etc., value of `(i, j, k)` at
/// `values[i + dims[0] (j + dims[1] k)]`. Positions are in grid units
/// (`(i, j, k)` is the point `(i, j, k)`); the caller scales and moves
/// them. See the module doc for the construction and the orientation.
///
/// # Errors
/// `InvalidArgument` when `values.len()` is not the product of `dims`, a
/// value is NaN, or the grid has more than `u32::MAX` points.
pub fn isosurface(values: &[f32], dims: [usize; 3]) -> Result<TriMesh, MeshError> {
    let [nx, ny, nz] = dims;
    let total = nx
        .checked_mul(ny)
        .and_then(|n| n.checked_mul(nz))
        .ok_or_else(|| MeshError::InvalidArgument(format!("grid {dims:?} is too large")))?;
    if values.len() != total {
        return Err(MeshError::InvalidArgument(format!(
            "{} values for a grid of {nx} x {ny} x {nz} = {total} points",
            values.len()
        )));
    }
    if total > u32::MAX as usize {
        return Err(MeshError::InvalidArgument(format!(
            "a grid of {total} points is more than {} (u32 indices)",
            u32::MAX
        )));
    }
    if let Some(i) = values.iter().position(|v| v.is_nan()) {
        return Err(MeshError::InvalidArgument(format!(
            "value {i} of the grid is NaN"
        )));
    }
    let index = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
    let point = |v: u32| -> Point3<f64> {
        let v = v as usize;
        Point3::new(
            (v % nx) as f64,
            ((v / nx) % ny) as f64,
            (v / (nx * ny)) as f64,
        )
    };
    let inside = |v: u32| values[v as usize] < 0.0;
    let mut positions: Vec<Point3<f64>> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut cut: HashMap<(u32, u32), u32> = HashMap::new();
    // the vertex of the cut edge {a, b} (a inside, b outside)
    let mut vertex = |a: u32, b: u32, positions: &mut Vec<Point3<f64>>| -> u32 {
        let key = (a.min(b), a.max(b));
        *cut.entry(key).or_insert_with(|| {
            let (fa, fb) = (f64::from(values[a as usize]), f64::from(values[b as usize]));
            let t = (fa / (fa - fb)).clamp(0.0, 1.0);
            let (pa, pb) = (point(a), point(b));
            positions.push(pa + (pb - pa) * t);
            (positions.len() - 1) as u32
        })
    };
    for k in 0..nz.saturating_sub(1) {
        for j in 0..ny.saturating_sub(1) {
            for i in 0..nx.saturating_sub(1) {
                let corner = |m: u8| -> u32 {
                    index(
                        i + usize::from(m & 1),
                        j + usize::from((m >> 1) & 1),
                        k + usize::from((m >> 2) & 1),
                    ) as u32
                };
                let c: [u32; 8] = std::array::from_fn(|m| corner(m as u8));
                let n_in = c.iter().filter(|&&v| inside(v)).count();
                if n_in == 0 || n_in == 8 {
                    continue;
                }
                for tet in KUHN {
                    let t = tet.map(|m| c[m as usize]);
                    let (ins, outs): (Vec<u32>, Vec<u32>) =
                        t.iter().copied().partition(|&v| inside(v));
                    // the direction from the inside corners to the outside ones
                    let centroid = |vs: &[u32]| {
                        vs.iter().map(|&v| point(v).coords).sum::<Vector3<f64>>() / vs.len() as f64
                    };
                    let mut emit = |edges: [(u32, u32); 3], positions: &mut Vec<Point3<f64>>| {
                        let mid = edges.map(|(a, b)| (point(a).coords + point(b).coords) * 0.5);
                        let normal = (mid[1] - mid[0]).cross(&(mid[2] - mid[0]));
                        let out = centroid(&outs) - centroid(&ins);
                        let tri = edges.map(|(a, b)| vertex(a, b, positions));
                        if normal.dot(&out) >= 0.0 {
                            triangles.push(tri);
                        } else {
                            triangles.push([tri[0], tri[2], tri[1]]);
                        }
                    };
                    match (ins.as_slice(), outs.as_slice()) {
                        ([a], [p, q, r]) => emit([(*a, *p), (*a, *q), (*a, *r)], &mut positions),
                        ([a, b, c], [p]) => emit([(*a, *p), (*b, *p), (*c, *p)], &mut positions),
                        ([a, b], [p, q]) => {
                            // the quad (a p, a q, b q, b p), a parallelogram of midpoints
                            emit([(*a, *p), (*a, *q), (*b, *q)], &mut positions);
                            emit([(*a, *p), (*b, *q), (*b, *p)], &mut positions);
                        }
                        _ => {}
                    }
                }
            }
        }
    }
    Ok(TriMesh::new(positions, triangles))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{enclosed_volume, total_area};
    use crate::topology::{boundary_loops, connected_components, euler_characteristic};
    use proptest::prelude::*;

    /// `f(x) = |x - c| - r` on an `n^3` grid.
    fn ball(n: usize, c: [f64; 3], r: f64) -> Vec<f32> {
        let mut v = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let d = ((i as f64 - c[0]).powi(2)
                        + (j as f64 - c[1]).powi(2)
                        + (k as f64 - c[2]).powi(2))
                    .sqrt();
                    v.push((d - r) as f32);
                }
            }
        }
        v
    }

    fn closed_manifold(m: &TriMesh) {
        // every edge used exactly twice, once in each direction
        let mut e: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &m.triangles {
            for a in 0..3 {
                let (p, q) = (t[a], t[(a + 1) % 3]);
                *e.entry((p.min(q), p.max(q))).or_default() += if p < q { 1 } else { -1 };
            }
        }
        let mut count: HashMap<(u32, u32), usize> = HashMap::new();
        for t in &m.triangles {
            for a in 0..3 {
                let (p, q) = (t[a], t[(a + 1) % 3]);
                *count.entry((p.min(q), p.max(q))).or_default() += 1;
            }
        }
        assert!(count.values().all(|&c| c == 2), "an edge not used twice");
        assert!(e.values().all(|&s| s == 0), "inconsistent orientation");
        assert!(boundary_loops(m).unwrap().is_empty());
    }

    #[test]
    fn a_ball_is_a_closed_outward_sphere_of_the_right_volume() {
        let r = 6.3;
        let m = isosurface(&ball(16, [7.5, 7.2, 7.9], r), [16, 16, 16]).unwrap();
        closed_manifold(&m);
        assert_eq!(euler_characteristic(&m), 2);
        assert_eq!(
            connected_components(m.num_vertices(), &m.triangles).count,
            1
        );
        let exact = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        let v = enclosed_volume(&m);
        // outward normals: positive volume, within 3 % (the interpolant
        // cuts the sphere's chords)
        assert!(
            v > 0.0 && (v - exact).abs() < 0.03 * exact,
            "{v} vs {exact}"
        );
        let area = 4.0 * std::f64::consts::PI * r * r;
        assert!((total_area(&m) - area).abs() < 0.05 * area);
        // every vertex within a grid diagonal of the sphere
        for p in &m.positions {
            let d = (p - Point3::new(7.5, 7.2, 7.9)).norm();
            assert!((d - r).abs() < 0.1, "{d}");
        }
    }

    #[test]
    fn a_hollow_ball_gives_two_spheres_the_inner_one_inward() {
        let n = 20;
        let c = [9.5, 9.5, 9.5];
        let outer = ball(n, c, 8.0);
        let inner = ball(n, c, 4.0);
        // inside the shell 4 < r < 8: max(d - 8, 4 - d) < 0
        let v: Vec<f32> = outer.iter().zip(&inner).map(|(o, i)| o.max(-i)).collect();
        let m = isosurface(&v, [n, n, n]).unwrap();
        closed_manifold(&m);
        assert_eq!(
            connected_components(m.num_vertices(), &m.triangles).count,
            2
        );
        let exact = 4.0 / 3.0 * std::f64::consts::PI * (8.0f64.powi(3) - 4.0f64.powi(3));
        let vol = enclosed_volume(&m);
        assert!((vol - exact).abs() < 0.04 * exact, "{vol} vs {exact}");
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(matches!(
            isosurface(&[0.0; 7], [2, 2, 2]),
            Err(MeshError::InvalidArgument(_))
        ));
        let mut v = vec![1.0f32; 8];
        v[3] = f32::NAN;
        assert!(isosurface(&v, [2, 2, 2]).is_err());
        // nothing negative: no surface
        assert!(
            isosurface(&[1.0; 8], [2, 2, 2])
                .unwrap()
                .triangles
                .is_empty()
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Random fields (negative inside, the border positive) always give
        /// a closed, consistently oriented manifold whose enclosed volume is
        /// non-negative.
        #[test]
        fn random_fields_give_closed_oriented_manifolds(
            seed in proptest::collection::vec(-1.0f32..1.0, 6 * 6 * 6)
        ) {
            let n = 8;
            let mut v = vec![1.0f32; n * n * n];
            for k in 0..6 {
                for j in 0..6 {
                    for i in 0..6 {
                        v[(i + 1) + n * ((j + 1) + n * (k + 1))] = seed[i + 6 * (j + 6 * k)];
                    }
                }
            }
            let m = isosurface(&v, [n, n, n]).unwrap();
            closed_manifold(&m);
            prop_assert!(enclosed_volume(&m) >= -1e-9);
        }
    }
}
