//! Degenerate elements: elements that use a vertex twice, triangles of
//! (almost) zero area and tets of (almost) zero volume.
//!
//! An element is degenerate when its height over its largest side — `h =
//! 2A / L` for a triangle of area `A` and longest edge `L`, `h = 3|V| / F`
//! for a tet of volume `V` and largest face area `F` — is below
//!
//! ```text
//! h_min = max(DEGENERATE_RELATIVE · ē, SINGLE_PRECISION · max |x|)
//! ```
//!
//! with `ē` the mean edge length and `max |x|` the largest absolute
//! coordinate. `DEGENERATE_RELATIVE` = 1e-5 is far below any element a
//! mesher makes on purpose; the second term (5e-7, four single-precision
//! ulps) covers a point put on an edge and then written in single precision
//! (STL), whose distance to the edge is rounding of the coordinates, not of
//! the edge.
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
use nalgebra::Point3;

/// The height, relative to the mean edge, below which an element is
/// degenerate (see the module docs).
pub const DEGENERATE_RELATIVE: f64 = 1e-5;

/// The height, relative to the largest absolute coordinate, below which an
/// element is degenerate (single-precision rounding; see the module docs).
pub const SINGLE_PRECISION: f64 = 5e-7;

/// `h_min` of the module docs.
fn min_height<const K: usize>(w: &Work<K>) -> f64 {
    let scale = w
        .positions
        .iter()
        .map(|p| p.coords.amax())
        .fold(0.0, f64::max);
    (DEGENERATE_RELATIVE * w.mean_edge()).max(SINGLE_PRECISION * scale)
}

/// The height of a triangle over its longest edge, `2A / L` (0 when all
/// three corners coincide).
fn triangle_height(p: &Point3<f64>, q: &Point3<f64>, r: &Point3<f64>) -> f64 {
    let l = (q - p).norm().max((r - q).norm()).max((p - r).norm());
    if l == 0.0 {
        0.0
    } else {
        2.0 * triangle_area(p, q, r) / l
    }
}

/// The height of a tet over its largest face, `3|V| / F` (0 when flat in
/// every direction).
fn tet_height(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, d: &Point3<f64>) -> f64 {
    let f = triangle_area(a, b, c)
        .max(triangle_area(a, b, d))
        .max(triangle_area(a, c, d))
        .max(triangle_area(b, c, d));
    if f == 0.0 {
        0.0
    } else {
        3.0 * tet_signed_volume(a, b, c, d).abs() / f
    }
}

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
    let threshold = min_height(w);
    let n = w.positions.len();
    let mut parent: Vec<usize> = (0..n).collect();
    let mut any = false;
    for t in 0..w.elements.len() {
        let [p, q, r] = w.elements[t].map(|v| w.positions[v as usize]);
        if triangle_height(&p, &q, &r) >= threshold {
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

/// Drops the tets whose height is below `h_min` (see the module docs);
/// returns how many.
pub(crate) fn drop_flat_tets(w: &mut Work<4>) -> usize {
    let threshold = min_height(w);
    let flat: Vec<bool> = w
        .elements
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|v| w.positions[v as usize]);
            tet_height(&a, &b, &c, &d) < threshold
        })
        .collect();
    w.retain(|t| !flat[t])
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn a_t_junction_rounded_to_single_precision_still_collapses() {
        // Far from the origin (scanner coordinates), the point on the edge
        // written as f32.
        let off = nalgebra::Vector3::new(-180.3, 95.7, 240.1);
        let p: Vec<Point3<f64>> = square()
            .iter()
            .map(|q| (q + off).map(|c| c as f32 as f64))
            .collect();
        let on_edge =
            Point3::from((p[0].coords * 0.6 + p[1].coords * 0.4).map(|c| c as f32 as f64));
        let mut p = p;
        p[4] = on_edge;
        let tris = vec![[0u32, 4, 2], [4, 1, 2], [0, 2, 3], [1, 0, 5], [0, 4, 1]];
        let mut w = Work::new(&p, &tris);
        let c = collapse_slivers(&mut w);
        assert_eq!((c.vertices, c.triangles), (1, 2));
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
