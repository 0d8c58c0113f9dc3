//! The boundary of a planar triangle map crossing itself.
//!
//! A map of a disk into the plane with every triangle positively oriented
//! is injective when its boundary polygon is simple; a locally injective
//! map (no flipped triangle, no folded edge) can still overlap itself if
//! its boundary winds over itself. The boundary edges (edges of one
//! triangle) of the map **cross** when (closed segments, exact
//! [`orient2d_exact`](super::orient2d_exact)):
//! - two edges without a common vertex meet: each one's ends strictly on
//!   both sides of the other's line, or an end of one on the other
//!   (`orient2d = 0` and within its coordinate range);
//! - two edges `v a` and `v b` from a common vertex run along each other:
//!   `orient2d(v, a, b) = 0` with `a - v` and `b - v` pointing the same
//!   way (exact coordinate comparisons).
//!
//! Edges of zero length, with a non-finite end, or of triangles with an
//! index out of range are left out. Candidate pairs come from
//! the grid of
//! [`overlapping_box_pairs`](super::overlapping_box_pairs).

use super::Aabb;
use super::broad_phase::filter_box_pairs;
use super::self_intersections::{o2, segments_meet_2d};
use nalgebra::Point3;

/// Two boundary edges of a planar map that cross.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeCrossing {
    /// The two edges (vertices ascending), in ascending order.
    pub edges: [[u32; 2]; 2],
    /// A point where they meet, in the plane.
    pub position: [f64; 2],
}

/// The crossing boundary edges of a planar map.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BoundaryCrossings {
    /// Every crossing pair, ascending by `edges`.
    pub pairs: Vec<EdgeCrossing>,
    /// Boundary edges in at least one pair.
    pub edges_involved: usize,
}

impl BoundaryCrossings {
    /// Whether no two boundary edges cross.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }
}

/// The crossings of the boundary edges of the triangle map `uv` (see the
/// module notes).
pub fn boundary_edge_crossings(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> BoundaryCrossings {
    let n = uv.len();
    let mut all: Vec<[u32; 2]> = Vec::with_capacity(3 * triangles.len());
    for t in triangles {
        if t.iter().any(|&v| v as usize >= n) {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            all.push([a.min(b), a.max(b)]);
        }
    }
    all.sort_unstable();
    let mut edges: Vec<[u32; 2]> = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let mut j = i + 1;
        while j < all.len() && all[j] == all[i] {
            j += 1;
        }
        let e = all[i];
        let (p, q) = (uv[e[0] as usize], uv[e[1] as usize]);
        let finite = p.iter().chain(&q).all(|c| c.is_finite());
        if j - i == 1 && finite && p != q {
            edges.push(e);
        }
        i = j;
    }
    let boxes: Vec<Aabb> = edges
        .iter()
        .map(|e| {
            Aabb::from_points(&e.map(|v| {
                let p = uv[v as usize];
                Point3::new(p[0], p[1], 0.0)
            }))
        })
        .collect();
    let mut pairs = filter_box_pairs(&boxes, |i, j| {
        let (ei, ej) = (edges[i as usize], edges[j as usize]);
        edges_cross(ei, ej, uv).map(|position| EdgeCrossing {
            edges: [ei, ej],
            position,
        })
    });
    pairs.sort_unstable_by_key(|p| p.edges);
    let mut involved: Vec<[u32; 2]> = pairs.iter().flat_map(|p| p.edges).collect();
    involved.sort_unstable();
    involved.dedup();
    BoundaryCrossings {
        edges_involved: involved.len(),
        pairs,
    }
}

/// Where the boundary edges `e` and `f` cross (module notes), if they do.
fn edges_cross(e: [u32; 2], f: [u32; 2], uv: &[[f64; 2]]) -> Option<[f64; 2]> {
    let at =
        |p: [f64; 2], q: [f64; 2], s: f64| [p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])];
    let common = e.iter().find(|v| f.contains(v));
    match common {
        None => {
            let (p0, p1) = (uv[e[0] as usize], uv[e[1] as usize]);
            let (q0, q1) = (uv[f[0] as usize], uv[f[1] as usize]);
            segments_meet_2d(p0, p1, q0, q1).map(|s| at(p0, p1, s))
        }
        Some(&v) => {
            let other = |g: [u32; 2]| if g[0] == v { g[1] } else { g[0] };
            let (o, a, b) = (uv[v as usize], uv[other(e) as usize], uv[other(f) as usize]);
            if o2(o, a, b) != 0.0 {
                return None;
            }
            // collinear: the same way from `o` on an axis where `a` differs
            let k = if a[0] != o[0] { 0 } else { 1 };
            let same = (a[k] > o[k]) == (b[k] > o[k]) && b[k] != o[k];
            same.then(|| {
                // the nearer of a and b lies on both edges
                let da = (a[0] - o[0]).abs() + (a[1] - o[1]).abs();
                let db = (b[0] - o[0]).abs() + (b[1] - o[1]).abs();
                if da <= db { a } else { b }
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::orient2d_exact;
    use proptest::prelude::*;

    /// A star-shaped polygon around the origin: `n` vertices at radius
    /// `1 + 0.3 sin(3 angle)`, angle `2 pi winding k / n`, triangulated
    /// as a fan from the centre (vertex `n`). With `winding = 1` it is a
    /// disk map with a simple boundary; with `winding = 2` every
    /// triangle is still positive, but the boundary goes round twice.
    fn star(n: usize, winding: f64) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut uv: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                let a = 2.0 * std::f64::consts::PI * winding * k as f64 / n as f64;
                let r = 1.0 + 0.3 * (3.0 * a).sin() + 0.05 * (k as f64 / n as f64);
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        uv.push([0.0, 0.0]);
        let c = n as u32;
        let tris = (0..n as u32).map(|k| [c, k, (k + 1) % c]).collect();
        (uv, tris)
    }

    #[test]
    fn a_simple_boundary_has_no_crossing_and_a_double_winding_has() {
        let (uv, tris) = star(60, 1.0);
        assert!(boundary_edge_crossings(&uv, &tris).is_empty());
        assert!(super::super::folded_edges(&uv, &tris).is_empty());
        let (uv, tris) = star(61, 2.0);
        // every triangle positive, no folded edge: locally injective
        for t in &tris {
            let [a, b, c] = t.map(|v| uv[v as usize]);
            assert!(orient2d_exact(a, b, c) > 0.0);
        }
        assert!(super::super::folded_edges(&uv, &tris).is_empty());
        let x = boundary_edge_crossings(&uv, &tris);
        assert!(!x.is_empty());
        assert!(x.edges_involved >= 2 && x.edges_involved <= 2 * x.pairs.len());
        assert!(x.pairs.windows(2).all(|w| w[0].edges < w[1].edges));
        for p in &x.pairs {
            // the two edges share no vertex and the point is on both
            assert!(p.edges[0].iter().all(|v| !p.edges[1].contains(v)));
            let r = (p.position[0].powi(2) + p.position[1].powi(2)).sqrt();
            assert!((0.6..1.4).contains(&r), "{:?}", p.position);
        }
    }

    #[test]
    fn a_pinched_polygon_crosses_itself() {
        // A bow tie: the square 0-1-3-2 with two corners swapped, its
        // boundary crossing itself in the middle.
        let bow = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let x = boundary_edge_crossings(&bow, &[[0, 1, 2], [0, 2, 3]]);
        assert_eq!(x.pairs.len(), 1);
        assert_eq!(x.pairs[0].edges, [[0, 3], [1, 2]]);
        assert_eq!(x.pairs[0].position, [0.5, 0.5]);
        assert_eq!(x.edges_involved, 2);
        // A U shape (every triangle positive, a simple boundary), then its
        // right arm's tip pulled onto the left arm: the boundary touches
        // itself there, every triangle still positive.
        let mut u = vec![
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 3.0],
            [2.0, 3.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 3.0],
            [0.0, 3.0],
        ];
        let tris = [
            [0, 1, 4],
            [0, 4, 5],
            [1, 2, 3],
            [1, 3, 4],
            [0, 5, 6],
            [0, 6, 7],
        ];
        assert!(boundary_edge_crossings(&u, &tris).is_empty());
        u[3] = [1.0, 2.5];
        for t in &tris {
            let [a, b, c] = t.map(|v| u[v as usize]);
            assert!(orient2d_exact(a, b, c) > 0.0);
        }
        let x = boundary_edge_crossings(&u, &tris);
        let edges: Vec<[[u32; 2]; 2]> = x.pairs.iter().map(|p| p.edges).collect();
        assert_eq!(edges, vec![[[2, 3], [5, 6]], [[3, 4], [5, 6]]]);
        assert!(x.pairs.iter().all(|p| p.position == [1.0, 2.5]));
        assert_eq!(x.edges_involved, 3);
        // two boundary edges from one vertex running along each other (the
        // second triangle flipped onto the first), and the flipped one's
        // corner on the first's edge
        let fold = [[0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [1.0, 0.0]];
        let x = boundary_edge_crossings(&fold, &[[0, 1, 2], [0, 2, 3]]);
        let edges: Vec<[[u32; 2]; 2]> = x.pairs.iter().map(|p| p.edges).collect();
        assert_eq!(edges, vec![[[0, 1], [0, 3]], [[0, 1], [2, 3]]]);
        assert!(x.pairs.iter().all(|p| p.position == [1.0, 0.0]));
        // bad input is left out, no panic
        let nan = [[0.0, 0.0], [f64::NAN, 0.0], [0.0, 1.0], [0.0, 0.0]];
        assert!(boundary_edge_crossings(&nan, &[[0, 1, 2], [0, 2, 9], [0, 3, 2]]).is_empty());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// A rigid motion of the plane (rotation, translation, mirror)
        /// changes no count, for a simple and for a doubly wound boundary.
        #[test]
        fn counts_do_not_depend_on_a_rigid_motion(
            angle in 0.0f64..6.3, shift in prop::array::uniform2(-50.0f64..50.0), mirror in any::<bool>(),
        ) {
            for (winding, n) in [(1.0, 60), (2.0, 61)] {
                let (uv, tris) = star(n, winding);
                let before = boundary_edge_crossings(&uv, &tris);
                prop_assert_eq!(before.is_empty(), winding == 1.0);
                let (c, s) = (angle.cos(), angle.sin());
                let moved: Vec<[f64; 2]> = uv
                    .iter()
                    .map(|p| {
                        let x = if mirror { -p[0] } else { p[0] };
                        [c * x - s * p[1] + shift[0], s * x + c * p[1] + shift[1]]
                    })
                    .collect();
                let after = boundary_edge_crossings(&moved, &tris);
                prop_assert_eq!(after.pairs.len(), before.pairs.len());
                prop_assert_eq!(after.edges_involved, before.edges_involved);
                let edges = |x: &BoundaryCrossings| x.pairs.iter().map(|p| p.edges).collect::<Vec<_>>();
                prop_assert_eq!(edges(&after), edges(&before));
            }
        }
    }
}
