//! Degenerate elements: elements that use a vertex twice, triangles of
//! (almost) zero area and tets of (almost) zero volume.
//!
//! A triangle is a *sliver* when its area is below
//! `DEGENERATE_RELATIVE · ē²` (ē the mean edge length of the mesh), a tet
//! when `|V| < DEGENERATE_RELATIVE · ē³`. `DEGENERATE_RELATIVE` = 1e-7 is
//! above what rounding a point onto an edge in single precision leaves
//! (relative 6e-8) and far below any triangle a mesher makes on purpose.
//!
//! Zero-area triangles are not simply dropped: a sliver usually sits where an
//! exporter split one side of an edge `a-b` by a vertex `m` on it and closed
//! the crack with the needle `[a, m, b]`. Dropping the needle would leave a
//! zero-width hole (the boundary loop `a-m-b`). Instead the sliver is
//! *collapsed*: its corner `m` opposite its longest edge `a-b` is merged
//! into the nearer of `a`, `b` (which keeps its position). The needle and
//! the triangles that held both `m` and that endpoint then repeat a vertex
//! and are dropped, and the split triangle is whole again. A needle whose
//! two close corners are `m` and `a` is collapsed the same way (the nearer
//! endpoint is the close one). The price: when `m` is a vertex of other,
//! unrelated triangles they follow it by up to half the edge; meshers do not
//! produce such a configuration, exporters produce the T-junction above.
//!
//! Zero-volume tets are dropped (inverted-tet policy is not this step's).

use super::work::Work;
use crate::geometry::{tet_signed_volume, triangle_area};

/// The relative area / volume below which a triangle / tet is degenerate
/// (see the module docs).
pub const DEGENERATE_RELATIVE: f64 = 1e-7;

/// Drops the elements that use a vertex more than once; returns how many.
pub(crate) fn drop_repeated<const K: usize>(w: &mut Work<K>) -> usize {
    let repeats: Vec<bool> = w
        .elements
        .iter()
        .map(|el| (0..K).any(|i| (i + 1..K).any(|j| el[i] == el[j])))
        .collect();
    w.retain(|e| !repeats[e])
}

fn find(parent: &mut [usize], mut v: usize) -> usize {
    while parent[v] != v {
        parent[v] = parent[parent[v]];
        v = parent[v];
    }
    v
}

/// What [`collapse_slivers`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Collapsed {
    /// Triangles removed: the slivers and those that collapsed with them.
    pub triangles: usize,
    /// Vertices merged into an endpoint of a sliver's longest edge.
    pub vertices: usize,
}

/// Collapses the zero-area triangles (see the module docs). The elements
/// must not repeat a vertex ([`drop_repeated`] first).
pub(crate) fn collapse_slivers(w: &mut Work<3>) -> Collapsed {
    let e = w.mean_edge();
    let threshold = DEGENERATE_RELATIVE * e * e;
    let n = w.positions.len();
    let mut parent: Vec<usize> = (0..n).collect();
    let mut any = false;
    for t in 0..w.elements.len() {
        let [p, q, r] = w.elements[t].map(|v| w.positions[v as usize]);
        if triangle_area(&p, &q, &r) >= threshold {
            continue;
        }
        let roots = w.elements[t].map(|v| find(&mut parent, v as usize));
        if roots[0] == roots[1] || roots[1] == roots[2] || roots[0] == roots[2] {
            continue; // already collapsed by an earlier sliver
        }
        let pos = roots.map(|v| w.positions[v]);
        // The longest edge (i, i+1); m is the corner opposite it.
        let len = |i: usize| (pos[(i + 1) % 3] - pos[i]).norm();
        let i = (0..3)
            .max_by(|&x, &y| len(x).total_cmp(&len(y)))
            .unwrap_or(0);
        let (a, b, m) = (roots[i], roots[(i + 1) % 3], roots[(i + 2) % 3]);
        let pm = w.positions[m];
        let target = if (w.positions[a] - pm).norm() <= (w.positions[b] - pm).norm() {
            a
        } else {
            b
        };
        parent[m] = target;
        any = true;
    }
    if !any {
        return Collapsed::default();
    }
    let root: Vec<usize> = (0..n).map(|v| find(&mut parent, v)).collect();
    let vertices = w.merge(&root);
    let triangles = drop_repeated(w);
    Collapsed {
        triangles,
        vertices,
    }
}

/// Drops the tets whose volume is below `DEGENERATE_RELATIVE · ē³`; returns
/// how many.
pub(crate) fn drop_flat_tets(w: &mut Work<4>) -> usize {
    let e = w.mean_edge();
    let threshold = DEGENERATE_RELATIVE * e * e * e;
    let flat: Vec<bool> = w
        .elements
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|v| w.positions[v as usize]);
            tet_signed_volume(&a, &b, &c, &d).abs() < threshold
        })
        .collect();
    w.retain(|t| !flat[t])
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    fn square() -> Vec<Point3<f64>> {
        vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.4, 0.0, 0.0), // on edge 0-1
            Point3::new(0.5, -1.0, 0.0),
        ]
    }

    #[test]
    fn a_t_junction_sliver_collapses_into_the_whole_triangle() {
        // Clean: [0,1,2], [0,2,3] and, below edge 0-1, [1,0,5]. The
        // exporter split [0,1,2] at 4 and closed the crack with [0,4,1].
        let tris = vec![[0u32, 4, 2], [4, 1, 2], [0, 2, 3], [1, 0, 5], [0, 4, 1]];
        let mut w = Work::new(&square(), &tris);
        assert_eq!(drop_repeated(&mut w), 0);
        let c = collapse_slivers(&mut w);
        assert_eq!(c.vertices, 1);
        assert_eq!(c.triangles, 2);
        assert_eq!(w.rows, vec![1, 2, 3]);
        let origin_tris: Vec<[usize; 3]> = w
            .elements
            .iter()
            .map(|t| t.map(|v| w.origin[v as usize]))
            .collect();
        assert_eq!(origin_tris, vec![[0, 1, 2], [0, 2, 3], [1, 0, 5]]);
        // Nothing left to collapse.
        assert_eq!(collapse_slivers(&mut w), Collapsed::default());
    }

    #[test]
    fn clean_triangles_and_tets_are_kept() {
        let tris = vec![[0u32, 1, 2], [0, 2, 3]];
        let mut w = Work::new(&square(), &tris);
        assert_eq!(collapse_slivers(&mut w), Collapsed::default());
        assert_eq!(w.elements, tris);
        let mut p = square();
        p.push(Point3::new(0.0, 0.0, 1.0)); // 6
        let mut t = Work::new(&p, &[[0u32, 1, 2, 6], [0, 4, 1, 6], [0, 1, 2, 3]]);
        assert_eq!(drop_flat_tets(&mut t), 2);
        assert_eq!(t.rows, vec![0]);
    }

    #[test]
    fn repeated_vertices_are_dropped() {
        let mut w = Work::new(&square(), &[[0u32, 1, 2], [0, 0, 1], [2, 3, 2]]);
        assert_eq!(drop_repeated(&mut w), 2);
        assert_eq!(w.rows, vec![0]);
    }
}
