//! Self-intersections of a triangle surface: the global overlaps that no
//! local test shows.
//!
//! A map of a ball (or a disk) whose elements are all positively oriented
//! and whose boundary image does not meet itself is injective (the degree
//! of the map is the winding number of the boundary image, 1 everywhere
//! inside it, and every preimage counts +1). A tet mesh can be locally
//! injective -- no inverted tet, no folded face -- and still overlap itself
//! when, say, a long slab bends round so that one end passes through the
//! other; its boundary surface then meets itself. This file finds those
//! meetings.
//!
//! Two triangles of a surface **overlap** when (closed triangles, exact
//! predicates [`orient3d_exact`], [`orient2d_exact`]):
//! - they share no vertex and meet at all (crossing, touching, or coplanar
//!   and overlapping). Two non-coplanar triangles meet exactly when an edge
//!   of one meets the other; a segment `s t` meets the triangle `a b c`
//!   when `s` and `t` are not strictly on one side of its plane and the
//!   three signs `orient3d(s, t, a, b)`, `orient3d(s, t, b, c)`,
//!   `orient3d(s, t, c, a)` agree (zeros agree with both); coplanar ones
//!   are compared in the coordinate plane where they keep their area;
//! - they share one vertex `v` and meet anywhere else: exactly when the
//!   edge opposite `v` in one meets the other triangle;
//! - they share an edge and fold flat onto each other (coplanar, their
//!   third vertices on the same side of the edge);
//! - they are the same triangle twice.
//!
//! Triangles with collinear corners (no plane), a non-finite coordinate
//! or an index out of range are left out. Candidate pairs come from
//! the grid of
//! [`overlapping_box_pairs`](super::overlapping_box_pairs)
//! on the triangles' bounding boxes, so a surface of `n` evenly sized
//! triangles costs `O(n log n)`.

use super::broad_phase::filter_box_pairs;
use super::predicates::{collinear_exact, project};
use super::{Aabb, orient2d_exact, orient3d_exact};
use crate::TetMesh;
use crate::error::MeshError;
use nalgebra::Point3;
use rayon::prelude::*;

/// Two triangles of a surface that overlap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleOverlap {
    /// The two triangles' indices, ascending.
    pub triangles: [usize; 2],
    /// Their vertices (as given).
    pub vertices: [[u32; 3]; 2],
    /// A point where they meet (computed in floating point from the exact
    /// decision: where an edge of one crosses the other, or a vertex of
    /// one inside the other), mm.
    pub position: Point3<f64>,
}

/// The overlapping triangle pairs of a surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SelfIntersections {
    /// Every overlapping pair, ascending by `triangles`.
    pub pairs: Vec<TriangleOverlap>,
    /// Triangles in at least one pair.
    pub triangles_involved: usize,
}

impl SelfIntersections {
    fn from_pairs(pairs: Vec<TriangleOverlap>) -> Self {
        let mut t: Vec<usize> = pairs.iter().flat_map(|p| p.triangles).collect();
        t.sort_unstable();
        t.dedup();
        SelfIntersections {
            triangles_involved: t.len(),
            pairs,
        }
    }

    /// Whether no two triangles overlap.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }
}

/// The self-intersections of the surface `triangles` on `positions` (see
/// the module notes for what overlaps).
pub fn triangle_self_intersections(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> SelfIntersections {
    let n = positions.len();
    let usable = |t: &[u32; 3]| {
        t.iter()
            .all(|&v| (v as usize) < n && (0..3).all(|a| positions[v as usize][a].is_finite()))
            && !collinear_exact(
                &positions[t[0] as usize],
                &positions[t[1] as usize],
                &positions[t[2] as usize],
            )
    };
    let boxes: Vec<Aabb> = triangles
        .par_iter()
        .map(|t| {
            if usable(t) {
                Aabb::from_points(&t.map(|v| positions[v as usize]))
            } else {
                Aabb::empty()
            }
        })
        .collect();
    let mut pairs = filter_box_pairs(&boxes, |i, j| {
        let (ti, tj) = (triangles[i as usize], triangles[j as usize]);
        triangles_overlap(ti, tj, positions).map(|position| TriangleOverlap {
            triangles: [i as usize, j as usize],
            vertices: [ti, tj],
            position,
        })
    });
    pairs.sort_unstable_by_key(|p| p.triangles);
    SelfIntersections::from_pairs(pairs)
}

/// The boundary surface of a tet mesh and where it meets itself.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryOverlaps {
    /// The overlapping boundary faces: `triangles` index the boundary faces
    /// (in the order of [`crate::topology::tet_boundary`]), `vertices` are
    /// the volume's vertex ids.
    pub intersections: SelfIntersections,
    /// The tet each boundary face belongs to.
    pub face_tet: Vec<u32>,
}

/// The self-intersections of the boundary surface of `mesh` (the faces of
/// one tet, [`crate::topology::tet_boundary`]). With no inverted tet and
/// none found, the mesh does not overlap itself.
///
/// # Errors
/// Those of [`crate::topology::tet_boundary`] (indices out of range, a
/// face of three or more tets).
pub fn tet_boundary_self_intersections(mesh: &TetMesh) -> Result<BoundaryOverlaps, MeshError> {
    let b = crate::topology::tet_boundary(mesh)?;
    let tris: Vec<[u32; 3]> = b
        .surface
        .triangles
        .iter()
        .map(|t| t.map(|v| b.to_volume[v as usize]))
        .collect();
    Ok(BoundaryOverlaps {
        intersections: triangle_self_intersections(&mesh.positions, &tris),
        face_tet: b.face_tet,
    })
}

/// Where the triangles `ti` and `tj` overlap (module notes), if they do.
fn triangles_overlap(ti: [u32; 3], tj: [u32; 3], pos: &[Point3<f64>]) -> Option<Point3<f64>> {
    let a = ti.map(|v| pos[v as usize]);
    let b = tj.map(|v| pos[v as usize]);
    let mut shared: Vec<(usize, usize)> = Vec::with_capacity(3);
    for (i, &u) in ti.iter().enumerate() {
        for (j, &w) in tj.iter().enumerate() {
            if u == w {
                shared.push((i, j));
            }
        }
    }
    match shared.len() {
        0 => disjoint_triangles_meet(&a, &b),
        1 => {
            let (i, j) = shared[0];
            let (a1, a2) = (a[(i + 1) % 3], a[(i + 2) % 3]);
            let (b1, b2) = (b[(j + 1) % 3], b[(j + 2) % 3]);
            let v = a[i];
            let (s1, s2) = (o3(&v, &a1, &a2, &b1), o3(&v, &a1, &a2, &b2));
            if (s1 > 0.0 && s2 > 0.0) || (s1 < 0.0 && s2 < 0.0) {
                // b meets a's plane at v only
                return None;
            }
            let coplanar = s1 == 0.0 && s2 == 0.0;
            if coplanar && !coplanar_wedges_meet(&v, [&a1, &a2], [&b1, &b2], &a) {
                return None;
            }
            // they meet beyond v exactly when an edge opposite v meets the
            // other triangle (in the plane as well: the wedge test decides,
            // this finds the point)
            let at = segment_meets_triangle(&a1, &a2, &b)
                .or_else(|| segment_meets_triangle(&b1, &b2, &a));
            if coplanar { at.or(Some(v)) } else { at }
        }
        2 => {
            let (i0, j0) = shared[0];
            let (i1, _) = shared[1];
            let (u, v) = (a[i0], a[i1]);
            let p = a[3 - i0 - i1];
            let q = b[3 - j0 - shared[1].1];
            if o3(&u, &v, &p, &q) != 0.0 {
                return None;
            }
            let k = projection_axis(&a);
            let (u2, v2) = (project(&u, k), project(&v, k));
            let (sp, sq) = (o2(u2, v2, project(&p, k)), o2(u2, v2, project(&q, k)));
            ((sp > 0.0 && sq > 0.0) || (sp < 0.0 && sq < 0.0))
                .then(|| Point3::from((u.coords + v.coords + p.coords + q.coords) * 0.25))
        }
        _ => Some(Point3::from(
            (a[0].coords + a[1].coords + a[2].coords) / 3.0,
        )),
    }
}

/// Strict sign: -1, 0 or 1.
fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// Whether two triangles without a common vertex meet (closed).
fn disjoint_triangles_meet(a: &[Point3<f64>; 3], b: &[Point3<f64>; 3]) -> Option<Point3<f64>> {
    let sa = a.map(|p| sign(o3(&b[0], &b[1], &b[2], &p)));
    if sa.iter().all(|&s| s > 0) || sa.iter().all(|&s| s < 0) {
        return None;
    }
    let sb = b.map(|p| sign(o3(&a[0], &a[1], &a[2], &p)));
    if sb.iter().all(|&s| s > 0) || sb.iter().all(|&s| s < 0) {
        return None;
    }
    if sa.iter().all(|&s| s == 0) {
        return coplanar_triangles_meet(a, b);
    }
    (0..3)
        .find_map(|k| segment_meets_triangle(&a[k], &a[(k + 1) % 3], b))
        .or_else(|| (0..3).find_map(|k| segment_meets_triangle(&b[k], &b[(k + 1) % 3], a)))
}

/// Whether the closed segment `s t` meets the closed triangle `tri`
/// (non-degenerate), and where.
fn segment_meets_triangle(
    s: &Point3<f64>,
    t: &Point3<f64>,
    tri: &[Point3<f64>; 3],
) -> Option<Point3<f64>> {
    let os = o3(&tri[0], &tri[1], &tri[2], s);
    let ot = o3(&tri[0], &tri[1], &tri[2], t);
    if (os > 0.0 && ot > 0.0) || (os < 0.0 && ot < 0.0) {
        return None;
    }
    if os == 0.0 && ot == 0.0 {
        let k = projection_axis(tri);
        let t2 = tri.map(|p| project(&p, k));
        return segment_meets_triangle_2d(project(s, k), project(t, k), &t2)
            .map(|f| s + (t - s) * f);
    }
    let w = [
        sign(o3(s, t, &tri[0], &tri[1])),
        sign(o3(s, t, &tri[1], &tri[2])),
        sign(o3(s, t, &tri[2], &tri[0])),
    ];
    let agree = w.iter().all(|&x| x >= 0) || w.iter().all(|&x| x <= 0);
    agree.then(|| {
        let f = if os == 0.0 {
            0.0
        } else if ot == 0.0 {
            1.0
        } else {
            (os / (os - ot)).clamp(0.0, 1.0)
        };
        s + (t - s) * f
    })
}

/// Whether two coplanar, non-degenerate triangles without a common vertex
/// meet: no edge line of either has the other strictly outside (the
/// separating axis test, complete for two convex polygons in the plane);
/// the point is then where an edge of one meets the other, or a vertex of
/// one inside the other.
fn coplanar_triangles_meet(a: &[Point3<f64>; 3], b: &[Point3<f64>; 3]) -> Option<Point3<f64>> {
    let k = projection_axis(a);
    let (a2, b2) = (a.map(|p| project(&p, k)), b.map(|p| project(&p, k)));
    let separates = |t: &[[f64; 2]; 3], other: &[[f64; 2]; 3]| {
        let orientation = sign(o2(t[0], t[1], t[2]));
        (0..3).any(|i| {
            other
                .iter()
                .all(|&q| sign(o2(t[i], t[(i + 1) % 3], q)) == -orientation)
        })
    };
    if separates(&a2, &b2) || separates(&b2, &a2) {
        return None;
    }
    for i in 0..3 {
        if let Some(f) = segment_meets_triangle_2d(a2[i], a2[(i + 1) % 3], &b2) {
            return Some(a[i] + (a[(i + 1) % 3] - a[i]) * f);
        }
    }
    // no edge of a meets b: b is inside a
    Some(b[0])
}

/// Whether two coplanar triangles `a = (v, a1, a2)` and `(v, b1, b2)`
/// sharing only `v` meet anywhere else: near `v` each fills the cone its
/// edges span, and two cones (angles below pi) share a ray exactly when a
/// generator of one lies in the other, closed: with `orient2d(v, p, q) > 0`,
/// `x` is in the cone of `p, q` when `orient2d(v, x, q) >= 0` and
/// `orient2d(v, p, x) >= 0` (`x - v = s (p - v) + t (q - v)`, `s, t >= 0`).
fn coplanar_wedges_meet(
    v: &Point3<f64>,
    a: [&Point3<f64>; 2],
    b: [&Point3<f64>; 2],
    tri_a: &[Point3<f64>; 3],
) -> bool {
    let k = projection_axis(tri_a);
    let v2 = project(v, k);
    let cone = |e: [&Point3<f64>; 2]| {
        let (p, q) = (project(e[0], k), project(e[1], k));
        if o2(v2, p, q) < 0.0 { [q, p] } else { [p, q] }
    };
    let (ca, cb) = (cone(a), cone(b));
    let inside = |x: [f64; 2], c: [[f64; 2]; 2]| o2(v2, x, c[1]) >= 0.0 && o2(v2, c[0], x) >= 0.0;
    cb.iter().any(|&x| inside(x, ca)) || ca.iter().any(|&x| inside(x, cb))
}

/// [`orient3d_exact`], with exact zero at once when the four points share
/// a coordinate (flat, axis-aligned faces, where the exact predicate is at
/// its slowest).
#[inline]
fn o3(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, d: &Point3<f64>) -> f64 {
    if (0..3).any(|k| a[k] == b[k] && a[k] == c[k] && a[k] == d[k]) {
        0.0
    } else {
        orient3d_exact(a, b, c, d)
    }
}

/// [`orient2d_exact`], with exact zero at once when the three points share
/// a coordinate.
#[inline]
pub(super) fn o2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    if (0..2).any(|k| a[k] == b[k] && a[k] == c[k]) {
        0.0
    } else {
        orient2d_exact(a, b, c)
    }
}

/// A coordinate axis whose removal keeps the (non-degenerate) triangle's
/// area: the largest component of its normal.
fn projection_axis(t: &[Point3<f64>; 3]) -> usize {
    (0..3)
        .find(|&k| o2(project(&t[0], k), project(&t[1], k), project(&t[2], k)) != 0.0)
        .unwrap_or(2)
}

/// Whether the closed segment `s t` meets the closed triangle `tri` in the
/// plane; the fraction along `s t` of a point where it does.
pub(super) fn segment_meets_triangle_2d(
    s: [f64; 2],
    t: [f64; 2],
    tri: &[[f64; 2]; 3],
) -> Option<f64> {
    if point_in_triangle_2d(s, tri) {
        return Some(0.0);
    }
    if point_in_triangle_2d(t, tri) {
        return Some(1.0);
    }
    (0..3).find_map(|i| segments_meet_2d(s, t, tri[i], tri[(i + 1) % 3]))
}

/// Whether `p` lies in the closed triangle `tri` (non-degenerate): the
/// three signs `orient2d(tri_i, tri_i+1, p)` agree (zeros agree with both).
pub(super) fn point_in_triangle_2d(p: [f64; 2], tri: &[[f64; 2]; 3]) -> bool {
    let w = [
        sign(o2(tri[0], tri[1], p)),
        sign(o2(tri[1], tri[2], p)),
        sign(o2(tri[2], tri[0], p)),
    ];
    w.iter().all(|&x| x >= 0) || w.iter().all(|&x| x <= 0)
}

/// Whether the closed segments `p0 p1` and `q0 q1` meet, and the fraction
/// along `p0 p1` of a common point: they cross properly (each one's ends
/// strictly on both sides of the other's line), or an end of one lies on
/// the other (`orient2d = 0` and within its coordinate range, both exact).
pub(super) fn segments_meet_2d(
    p0: [f64; 2],
    p1: [f64; 2],
    q0: [f64; 2],
    q1: [f64; 2],
) -> Option<f64> {
    let d0 = o2(q0, q1, p0);
    let d1 = o2(q0, q1, p1);
    let e0 = o2(p0, p1, q0);
    let e1 = o2(p0, p1, q1);
    let opposite = |x: f64, y: f64| (x > 0.0 && y < 0.0) || (x < 0.0 && y > 0.0);
    if opposite(d0, d1) && opposite(e0, e1) {
        return Some((d0 / (d0 - d1)).clamp(0.0, 1.0));
    }
    if d0 == 0.0 && on_segment(p0, q0, q1) {
        return Some(0.0);
    }
    if d1 == 0.0 && on_segment(p1, q0, q1) {
        return Some(1.0);
    }
    let along = |q: [f64; 2]| super::closest_point_on_segment_2d(q, p0, p1).1;
    if e0 == 0.0 && on_segment(q0, p0, p1) {
        return Some(along(q0));
    }
    if e1 == 0.0 && on_segment(q1, p0, p1) {
        return Some(along(q1));
    }
    None
}

/// For `p` on the line of `a b`: whether it lies between them (exact
/// coordinate comparisons).
fn on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> bool {
    (0..2).all(|k| a[k].min(b[k]) <= p[k] && p[k] <= a[k].max(b[k]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::broad_phase::overlapping_box_pairs;
    use crate::shapes::{Pose, kuhn_grid, uv_sphere};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    fn tri(p: [[f64; 3]; 3]) -> [Point3<f64>; 3] {
        p.map(|c| Point3::new(c[0], c[1], c[2]))
    }

    /// The overlaps of the surface of two triangles: `a` on vertices 0..3,
    /// `b` on 3..6; `tb` picks `b`'s vertices among the six, so that a
    /// shared corner is one of `a`'s (the placeholder at its place in
    /// `b` is then unused).
    fn pair_count(a: [[f64; 3]; 3], b: [[f64; 3]; 3], tb: [u32; 3]) -> usize {
        let mut positions: Vec<Point3<f64>> = tri(a).to_vec();
        positions.extend(tri(b));
        triangle_self_intersections(&positions, &[[0, 1, 2], tb])
            .pairs
            .len()
    }

    #[test]
    fn pairs_of_triangles() {
        let a = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
        // crossing through the interior
        assert_eq!(
            pair_count(
                a,
                [[1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [9.0, 9.0, 0.0]],
                [3, 4, 5]
            ),
            1
        );
        // apart above
        assert_eq!(
            pair_count(
                a,
                [[1.0, 1.0, 1.0], [2.0, 1.0, 1.0], [1.0, 2.0, 3.0]],
                [3, 4, 5]
            ),
            0
        );
        // a corner touching the interior
        assert_eq!(
            pair_count(
                a,
                [[1.0, 1.0, 0.0], [1.0, 1.0, 1.0], [2.0, 1.0, 1.0]],
                [3, 4, 5]
            ),
            1
        );
        // coplanar, overlapping; coplanar, inside; coplanar, apart
        assert_eq!(
            pair_count(
                a,
                [[1.0, 1.0, 0.0], [5.0, 1.0, 0.0], [1.0, 5.0, 0.0]],
                [3, 4, 5]
            ),
            1
        );
        assert_eq!(
            pair_count(
                a,
                [[0.5, 0.5, 0.0], [1.0, 0.5, 0.0], [0.5, 1.0, 0.0]],
                [3, 4, 5]
            ),
            1
        );
        assert_eq!(
            pair_count(
                a,
                [[5.0, 5.0, 0.0], [6.0, 5.0, 0.0], [5.0, 6.0, 0.0]],
                [3, 4, 5]
            ),
            0
        );
        // sharing corner 0: apart (a fan), and folded into a
        assert_eq!(
            pair_count(a, [[0.0; 3], [-4.0, 0.0, 0.0], [0.0, -4.0, 1.0]], [0, 4, 5]),
            0
        );
        assert_eq!(
            pair_count(a, [[0.0; 3], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0]], [0, 4, 5]),
            1
        );
        // sharing corner 0, coplanar, the other inside a
        assert_eq!(
            pair_count(a, [[0.0; 3], [1.0, 0.5, 0.0], [0.5, 1.0, 0.0]], [0, 4, 5]),
            1
        );
        // sharing the edge 1-2: a hinge (apart), and folded flat onto a
        assert_eq!(
            pair_count(a, [[0.0; 3], [0.0; 3], [3.0, 3.0, 1.0]], [2, 1, 5]),
            0
        );
        assert_eq!(
            pair_count(a, [[0.0; 3], [0.0; 3], [1.0, 1.0, 0.0]], [2, 1, 5]),
            1
        );
        assert_eq!(
            pair_count(a, [[0.0; 3], [0.0; 3], [3.0, 3.0, 0.0]], [2, 1, 5]),
            0
        );
        // the same triangle twice
        assert_eq!(pair_count(a, a, [0, 1, 2]), 1);
    }

    /// A long slab of `n` x 2 x 2 cells (1 mm) wound round the z axis
    /// through `turn` full turns at radius 10 mm (inner 8 mm), climbing
    /// `pitch` mm and moving in 0.2 mm per turn (so that no two faces are
    /// coplanar): positive tets, no folded face; its ends pass through
    /// each other when `turn > 1` and the pitch is below its 2 mm
    /// thickness.
    fn wound_slab(n: usize, turn: f64, pitch: f64) -> TetMesh {
        let mut m = kuhn_grid([n, 2, 2], [1.0; 3]);
        let len = n as f64;
        for p in &mut m.positions {
            let f = turn * p.x / len;
            let th = 2.0 * std::f64::consts::PI * f;
            let r = 10.0 - p.y - 0.2 * f;
            *p = Point3::new(r * th.cos(), r * th.sin(), p.z + pitch * f);
        }
        m
    }

    #[test]
    fn a_slab_wound_through_itself_overlaps_and_an_open_coil_does_not() {
        // 0.8 turn: an open ring, nothing meets
        let open = wound_slab(60, 0.8, 0.0);
        assert!(crate::geometry::folded_faces(&open).is_empty());
        let b = tet_boundary_self_intersections(&open).unwrap();
        assert!(
            b.intersections.is_empty(),
            "{:?}",
            b.intersections.pairs.first()
        );
        // a coil climbing more than its thickness per turn: nothing meets
        let coil = wound_slab(90, 1.3, 3.0);
        assert!(
            tet_boundary_self_intersections(&coil)
                .unwrap()
                .intersections
                .is_empty()
        );
        // 1.3 turns in a plane: the ends pass through each other
        let wound = wound_slab(90, 1.3, 0.3);
        assert!(crate::geometry::folded_faces(&wound).is_empty());
        let pos = &wound.positions;
        assert!(wound.tets.iter().all(|t| {
            let [a, b, c, d] = t.map(|v| pos[v as usize]);
            crate::geometry::tet_signed_volume(&a, &b, &c, &d) != 0.0
        }));
        let b = tet_boundary_self_intersections(&wound).unwrap();
        let s = &b.intersections;
        assert!(!s.is_empty());
        assert!(s.triangles_involved >= 2 && s.triangles_involved <= 2 * s.pairs.len());
        for p in &s.pairs {
            assert!(p.triangles[0] < p.triangles[1]);
            // both faces from the overlapping stretch: the first and last
            // 0.3 turn, at the same angle
            let r = (p.position.x.powi(2) + p.position.y.powi(2)).sqrt();
            assert!((7.5..=10.1).contains(&r), "{:?}", p.position);
            for (k, f) in p.vertices.iter().enumerate() {
                for &v in f {
                    assert!(
                        (pos[v as usize] - p.position).norm() < 4.0,
                        "face {k} {f:?} is far from {:?}",
                        p.position
                    );
                }
            }
        }
        assert!(s.pairs.windows(2).all(|w| w[0].triangles < w[1].triangles));
    }

    #[test]
    fn clean_surfaces_have_no_overlap() {
        // a box's boundary (flat faces: many coplanar neighbours)
        let bx = kuhn_grid([6, 5, 4], [1.0, 0.7, 1.3]);
        assert!(
            tet_boundary_self_intersections(&bx)
                .unwrap()
                .intersections
                .is_empty()
        );
        // a fine sphere, and an ellipsoid
        let s = uv_sphere(80, 160, 5.0);
        assert!(triangle_self_intersections(&s.positions, &s.triangles).is_empty());
        let e: Vec<Point3<f64>> = s
            .positions
            .iter()
            .map(|p| Point3::new(3.0 * p.x, p.y, 0.2 * p.z))
            .collect();
        assert!(triangle_self_intersections(&e, &s.triangles).is_empty());
        // a flat grid
        let g = crate::shapes::grid_disk(30, 20);
        assert!(triangle_self_intersections(&g.positions, &g.triangles).is_empty());
    }

    /// 200k triangles: a UV sphere (fans of 448 triangles at the poles),
    /// and a flat grid (every neighbour takes the coplanar path): no false
    /// overlap, and the broad phase hands the exact tests a number of box
    /// pairs linear in the triangles (a few dozen each; the poles' fans
    /// add `448^2` per pole), not the `n^2 / 2` of a quadratic one. The
    /// time is `cargo bench`'s business, not this test's.
    #[test]
    fn two_hundred_thousand_triangles_pair_linearly() {
        let boxes = |p: &[Point3<f64>], tris: &[[u32; 3]]| -> Vec<Aabb> {
            tris.iter()
                .map(|t| Aabb::from_points(&t.map(|v| p[v as usize])))
                .collect()
        };
        let s = uv_sphere(224, 448, 50.0);
        assert!(s.triangles.len() > 199_000);
        assert!(triangle_self_intersections(&s.positions, &s.triangles).is_empty());
        let pairs = overlapping_box_pairs(&boxes(&s.positions, &s.triangles)).len();
        assert!(
            pairs < 40 * s.triangles.len() + 2 * 448 * 448,
            "sphere: {pairs} pairs"
        );
        let b = crate::shapes::grid_disk(320, 320);
        assert!(b.triangles.len() > 200_000);
        assert!(triangle_self_intersections(&b.positions, &b.triangles).is_empty());
        let pairs = overlapping_box_pairs(&boxes(&b.positions, &b.triangles)).len();
        assert!(pairs < 40 * b.triangles.len(), "grid: {pairs} pairs");
    }

    #[test]
    fn bad_triangles_are_left_out() {
        let pos = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(0.5, -1.0, 0.0),
            Point3::new(f64::NAN, 0.0, 0.0),
        ];
        // collinear, repeated vertex, out of range, NaN, each over a real one
        let tris = [[0, 1, 2], [0, 0, 3], [0, 1, 9], [0, 3, 4], [0, 3, 2]];
        assert!(triangle_self_intersections(&pos, &tris).is_empty());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// A rigid motion (any rotation, a translation) changes no count,
        /// on a clean and on an overlapping mesh.
        #[test]
        fn counts_do_not_depend_on_a_rigid_motion(
            rot in prop::array::uniform3(-180.0f64..180.0),
            shift in prop::array::uniform3(-100.0f64..100.0),
        ) {
            let motion = Pose::new(rot, shift);
            for (turn, expect_some) in [(0.8, false), (1.3, true)] {
                let mut m = wound_slab(60, turn, 0.3);
                let before = tet_boundary_self_intersections(&m).unwrap().intersections;
                prop_assert_eq!(!before.is_empty(), expect_some);
                motion.apply_all(&mut m.positions);
                let after = tet_boundary_self_intersections(&m).unwrap().intersections;
                prop_assert_eq!(after.pairs.len(), before.pairs.len());
                prop_assert_eq!(after.triangles_involved, before.triangles_involved);
                let moved = Vector3::from(shift);
                if let (Some(p), Some(q)) = (before.pairs.first(), after.pairs.first()) {
                    prop_assert_eq!(p.triangles, q.triangles);
                    let back = motion.rotation() * p.position.coords + moved;
                    prop_assert!((back - q.position.coords).norm() < 1e-6);
                }
            }
        }
    }
}
