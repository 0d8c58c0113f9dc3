//! Folds: local overlaps of a mesh that orientation alone does not show.
//!
//! A tet mesh maps its region injectively near an interior face only if the
//! two tets sharing the face lie on opposite sides of it. With the face
//! `(a, b, c)` and the tets' opposite corners `d1`, `d2`, the face is
//! **folded** when
//!
//! ```text
//! orient3d(a, b, c, d1) * orient3d(a, b, c, d2) > 0
//! ```
//!
//! (both on the same side; signs by the exact predicate
//! [`super::orient3d_exact`]). The test does not depend on the tets'
//! orientation, so a mirrored mesh (every tet negative) has no fold, while
//! a tangled one (a vertex dragged across a face, a jittered slab) does even
//! after every tet is turned positive. Likewise in 2D: an interior edge
//! `(a, b)` of a triangle map is folded when its two triangles' third
//! corners lie on the same side of it (`orient2d`).

use super::{orient2d_exact, orient3d_exact};
use crate::TetMesh;
use nalgebra::Point3;

/// A folded interior face of a tet mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoldedFace {
    /// The face's vertices, ascending.
    pub face: [u32; 3],
    /// The two tets sharing it.
    pub tets: [usize; 2],
    /// The face's centroid, mm.
    pub position: Point3<f64>,
}

/// A folded interior edge of a triangle map in the plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoldedEdge {
    /// The edge's vertices, ascending.
    pub edge: [u32; 2],
    /// The two triangles sharing it.
    pub triangles: [usize; 2],
    /// The edge's midpoint in the plane.
    pub position: [f64; 2],
}

/// The folded interior faces of `mesh` (faces shared by exactly two tets),
/// in ascending face order. Faces of three or more tets (non-manifold) and
/// tets with an out-of-range index are left to validation.
pub fn folded_faces(mesh: &TetMesh) -> Vec<FoldedFace> {
    let n = mesh.positions.len();
    // (sorted face, tet, opposite corner)
    let mut faces: Vec<([u32; 3], usize, u32)> = Vec::with_capacity(4 * mesh.tets.len());
    for (t, tet) in mesh.tets.iter().enumerate() {
        if tet.iter().any(|&v| v as usize >= n) {
            continue;
        }
        for skip in 0..4 {
            let mut f = [0u32; 3];
            let mut k = 0;
            for (c, &v) in tet.iter().enumerate() {
                if c != skip {
                    f[k] = v;
                    k += 1;
                }
            }
            f.sort_unstable();
            faces.push((f, t, tet[skip]));
        }
    }
    faces.sort_unstable_by_key(|&(f, t, _)| (f, t));
    let p = |v: u32| mesh.positions[v as usize];
    let mut out = Vec::new();
    let mut i = 0;
    while i < faces.len() {
        let mut j = i + 1;
        while j < faces.len() && faces[j].0 == faces[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let (f, t1, d1) = faces[i];
            let (_, t2, d2) = faces[i + 1];
            let s1 = orient3d_exact(&p(f[0]), &p(f[1]), &p(f[2]), &p(d1));
            let s2 = orient3d_exact(&p(f[0]), &p(f[1]), &p(f[2]), &p(d2));
            if same_side(s1, s2) {
                let c = (p(f[0]).coords + p(f[1]).coords + p(f[2]).coords) / 3.0;
                out.push(FoldedFace {
                    face: f,
                    tets: [t1, t2],
                    position: Point3::from(c),
                });
            }
        }
        i = j;
    }
    out
}

/// The folded interior edges (shared by exactly two triangles) of the
/// triangle map `uv`, in ascending edge order.
pub fn folded_edges(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> Vec<FoldedEdge> {
    let n = uv.len();
    let mut edges: Vec<([u32; 2], usize, u32)> = Vec::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        if tri.iter().any(|&v| v as usize >= n) {
            continue;
        }
        for skip in 0..3 {
            let (a, b) = (tri[(skip + 1) % 3], tri[(skip + 2) % 3]);
            edges.push(([a.min(b), a.max(b)], t, tri[skip]));
        }
    }
    edges.sort_unstable_by_key(|&(e, t, _)| (e, t));
    let q = |v: u32| uv[v as usize];
    let mut out = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let (e, t1, c1) = edges[i];
            let (_, t2, c2) = edges[i + 1];
            let s1 = orient2d_exact(q(e[0]), q(e[1]), q(c1));
            let s2 = orient2d_exact(q(e[0]), q(e[1]), q(c2));
            if same_side(s1, s2) {
                let (a, b) = (q(e[0]), q(e[1]));
                out.push(FoldedEdge {
                    edge: e,
                    triangles: [t1, t2],
                    position: [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])],
                });
            }
        }
        i = j;
    }
    out
}

/// Both strictly positive or both strictly negative (no product: exact
/// determinants may be tiny or huge).
fn same_side(s1: f64, s2: f64) -> bool {
    (s1 > 0.0 && s2 > 0.0) || (s1 < 0.0 && s2 < 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::kuhn_grid;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// A valid mesh, moved rigidly or mirrored, has no fold (the test
        /// does not depend on orientation); dragging an interior vertex
        /// through a neighbouring vertex's far side folds faces.
        #[test]
        fn folds_appear_only_when_the_mesh_overlaps(
            mirror in any::<bool>(),
            shift in prop::array::uniform3(-50.0f64..50.0),
            jitter in 0.0f64..0.2,
        ) {
            let mut m = kuhn_grid([3, 3, 3], [1.0; 3]);
            for (k, p) in m.positions.iter_mut().enumerate() {
                // a small jitter keeps every tet positive
                let j = jitter * 0.5 * ((k as f64 * 1.7).sin());
                *p = Point3::new(p.x + j + shift[0], p.y + shift[1], p.z - j + shift[2]);
                if mirror {
                    p.x = -p.x;
                }
            }
            prop_assert!(folded_faces(&m).is_empty());
            // Interior vertex (1,1,1) moved past (2,1,1): overlapping tets.
            let id = |i: usize, j: usize, k: usize| i + 4 * (j + 4 * k);
            let target = m.positions[id(2, 1, 1)];
            let from = m.positions[id(1, 1, 1)];
            m.positions[id(1, 1, 1)] = from + (target - from) * 1.6;
            let folds = folded_faces(&m);
            prop_assert!(!folds.is_empty());
            for f in &folds {
                prop_assert!(f.face.windows(2).all(|w| w[0] < w[1]));
                prop_assert!(f.tets[0] < f.tets[1]);
            }
        }

        /// The same in the plane: a triangulated square has no folded edge
        /// under any rigid motion or mirror; a vertex pulled across an edge
        /// folds it.
        #[test]
        fn folded_edges_of_a_planar_map(angle in 0.0f64..6.3, mirror in any::<bool>()) {
            let mut uv = Vec::new();
            for j in 0..4 {
                for i in 0..4 {
                    let (x, y) = (i as f64, j as f64);
                    let (c, s) = (angle.cos(), angle.sin());
                    let x = if mirror { -x } else { x };
                    uv.push([c * x - s * y, s * x + c * y]);
                }
            }
            let mut tris = Vec::new();
            for j in 0..3u32 {
                for i in 0..3u32 {
                    let a = i + 4 * j;
                    tris.push([a, a + 1, a + 5]);
                    tris.push([a, a + 5, a + 4]);
                }
            }
            prop_assert!(folded_edges(&uv, &tris).is_empty());
            let (a, b) = (uv[5], uv[6]);
            uv[5] = [a[0] + 1.5 * (b[0] - a[0]), a[1] + 1.5 * (b[1] - a[1])];
            prop_assert!(!folded_edges(&uv, &tris).is_empty());
        }
    }
}
