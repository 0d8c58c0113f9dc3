//! Spatial queries, built once and answered in `O(log n)`-ish time: the tet
//! containing a point ([`TetLocator`]), the triangle of a planar mesh
//! containing a 2D point ([`PlanarTriLocator`]), the closest point on a
//! triangle surface ([`ClosestPointQuery`]) and the closest point of a point
//! set ([`PointCloudQuery`]).
//!
//! All of them sit on one bounding volume hierarchy: a binary tree of
//! axis-aligned boxes built top-down by splitting the elements at the median
//! of their box centres along the longest axis (`O(n log n)` build, depth
//! `<= log2(n) + 1`, at most 4 elements per leaf). The structures own
//! precomputed copies of what they need, so they do not borrow the mesh, and
//! they are `Send + Sync` (share them across rayon threads).
//!
//! Constructors never panic: elements with an out-of-range index, a
//! non-finite coordinate or (for locators) no interior are skipped, and an
//! empty input gives a structure whose queries return `None`. Queries with a
//! non-finite point return `None`.

use crate::geometry::{Aabb, closest_point_on_segment};
use crate::{TetMesh, TriMesh};
use nalgebra::Point3;

/// At most this many elements per BVH leaf.
const LEAF_SIZE: usize = 4;
/// Traversal stack size; the median-split tree is at most `log2(n) + 2` deep.
const STACK: usize = 96;

/// A BVH node: a leaf holds slots `start..start + count`; an inner node
/// (`count == 0`) has its left child right after it and its right child at
/// `start`.
#[derive(Debug, Clone)]
struct Node {
    bbox: Aabb,
    start: u32,
    count: u32,
}

/// Bounding volume hierarchy over boxed items. `order[slot]` is the caller's
/// item id of each leaf slot; callers store per-item data in slot order.
#[derive(Debug, Clone, Default)]
struct Bvh {
    nodes: Vec<Node>,
    order: Vec<usize>,
}

impl Bvh {
    /// Builds over `(id, box)` items by recursive median splits.
    fn build(items: Vec<(usize, Aabb)>) -> Bvh {
        let mut items: Vec<(usize, Aabb, Point3<f64>)> =
            items.into_iter().map(|(i, b)| (i, b, b.center())).collect();
        let mut nodes = Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1);
        if !items.is_empty() {
            Self::build_rec(&mut items, 0, &mut nodes);
        }
        Bvh {
            nodes,
            order: items.into_iter().map(|x| x.0).collect(),
        }
    }

    fn build_rec(
        items: &mut [(usize, Aabb, Point3<f64>)],
        offset: usize,
        nodes: &mut Vec<Node>,
    ) -> u32 {
        let bbox = items
            .iter()
            .fold(Aabb::empty(), |acc, item| acc.union(&item.1));
        let idx = nodes.len();
        nodes.push(Node {
            bbox,
            start: offset as u32,
            count: items.len() as u32,
        });
        if items.len() > LEAF_SIZE {
            let mut centres = Aabb::empty();
            for item in items.iter() {
                centres.grow(&item.2);
            }
            let axis = centres.longest_axis();
            let mid = items.len() / 2;
            items.select_nth_unstable_by(mid, |a, b| a.2[axis].total_cmp(&b.2[axis]));
            let (left, right) = items.split_at_mut(mid);
            Self::build_rec(left, offset, nodes);
            let r = Self::build_rec(right, offset + mid, nodes);
            nodes[idx].start = r;
            nodes[idx].count = 0;
        }
        idx as u32
    }

    /// Calls `f(slot)` for the slots of every leaf whose box contains `p`,
    /// until `f` returns `true`.
    #[inline]
    fn visit_containing(&self, p: &Point3<f64>, mut f: impl FnMut(usize) -> bool) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; STACK];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let idx = stack[sp] as usize;
            let node = &self.nodes[idx];
            if !node.bbox.contains(p) {
                continue;
            }
            if node.count > 0 {
                let s = node.start as usize;
                for slot in s..s + node.count as usize {
                    if f(slot) {
                        return;
                    }
                }
            } else {
                stack[sp] = node.start;
                stack[sp + 1] = idx as u32 + 1;
                sp += 2;
            }
        }
    }

    /// Branch and bound: the slot minimising `dist2(slot)` (a squared
    /// distance no smaller than the slot box's distance), visiting nearer
    /// boxes first and skipping boxes farther than the best so far, and
    /// leaves whose `leaf_bound(node)` (a lower bound on the `dist2` of its
    /// slots) is.
    #[inline]
    fn nearest(
        &self,
        p: &Point3<f64>,
        mut dist2: impl FnMut(usize) -> f64,
        leaf_bound: impl Fn(usize) -> f64,
    ) -> Option<(usize, f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<(usize, f64)> = None;
        let mut best2 = f64::INFINITY;
        let mut stack = [(0u32, 0.0f64); STACK];
        stack[0] = (0, self.nodes[0].bbox.distance_squared(p));
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (idx, d2) = stack[sp];
            if d2 > best2 {
                continue;
            }
            let node = &self.nodes[idx as usize];
            if node.count > 0 {
                if leaf_bound(idx as usize) > best2 {
                    continue;
                }
                let s = node.start as usize;
                for slot in s..s + node.count as usize {
                    let d = dist2(slot);
                    if d < best2 {
                        best2 = d;
                        best = Some((slot, d));
                    }
                }
            } else {
                let (l, r) = (idx + 1, node.start);
                let dl = self.nodes[l as usize].bbox.distance_squared(p);
                let dr = self.nodes[r as usize].bbox.distance_squared(p);
                let (near, far) = if dl <= dr {
                    ((l, dl), (r, dr))
                } else {
                    ((r, dr), (l, dl))
                };
                if far.1 <= best2 {
                    stack[sp] = far;
                    sp += 1;
                }
                if near.1 <= best2 {
                    stack[sp] = near;
                    sp += 1;
                }
            }
        }
        best
    }
}

#[inline]
fn finite3(p: &Point3<f64>) -> bool {
    p.coords.iter().all(|x| x.is_finite())
}

/// Corners of element `el` when all indices are in range and finite.
fn corners<const K: usize>(positions: &[Point3<f64>], el: &[u32; K]) -> Option<[Point3<f64>; K]> {
    let mut out = [Point3::origin(); K];
    for (o, &i) in out.iter_mut().zip(el) {
        *o = *positions.get(i as usize)?;
        if !finite3(o) {
            return None;
        }
    }
    Some(out)
}

/// Box of the corners padded for the locator tolerance: a point with all
/// barycentric coordinates `>= -tol` lies within `~K tol diam` of the element.
fn padded_box(pts: &[Point3<f64>], tol: f64) -> Aabb {
    let b = Aabb::from_points(pts);
    let diam = b.extent().norm();
    let mag = b.min.coords.amax().max(b.max.coords.amax());
    b.padded(4.0 * (tol + 1e-12) * diam + 8.0 * f64::EPSILON * mag)
}

// ---------------------------------------------------------------------------
// Point location (tets in space, triangles in the plane)
// ---------------------------------------------------------------------------

/// Default barycentric tolerance of [`TetLocator`] and [`PlanarTriLocator`].
pub const DEFAULT_TOLERANCE: f64 = 1e-9;

/// Tets with `|det| <= DEGENERATE_REL * (longest edge)^3` (resp. `^2` for
/// triangles) have no interior and are skipped by the locators.
const DEGENERATE_REL: f64 = 1e-12;

/// Precomputed affine map of a simplex with `K = D + 1` corners
/// `x_0, ..., x_D`: `(b_1, ..., b_D) = A (p - x_0)` with
/// `A = [x_1 - x_0 | ... | x_D - x_0]^-1`, `b_0 = 1 - b_1 - ... - b_D`
/// (sums left to right).
#[derive(Debug, Clone)]
struct Affine<const D: usize> {
    x0: [f64; D],
    inv: [[f64; D]; D],
}

impl Affine<3> {
    /// The map of the tet `x`; `None` when degenerate (`|det| <=`
    /// [`DEGENERATE_REL`]` l_max^3`, NaN included) or not invertible.
    fn tet(x: &[Point3<f64>; 4]) -> Option<Self> {
        let m = nalgebra::Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        let mut l2: f64 = 0.0;
        for i in 0..4 {
            for j in i + 1..4 {
                l2 = l2.max((x[i] - x[j]).norm_squared());
            }
        }
        let det = m.determinant();
        // Written so that NaN counts as degenerate.
        let solid = det.abs() > DEGENERATE_REL * l2 * l2.sqrt();
        if !solid {
            return None;
        }
        let inv = m.try_inverse()?;
        if !inv.iter().all(|v| v.is_finite()) {
            return None;
        }
        Some(Affine {
            x0: [x[0].x, x[0].y, x[0].z],
            inv: [0, 1, 2].map(|r| [inv[(r, 0)], inv[(r, 1)], inv[(r, 2)]]),
        })
    }
}

impl Affine<2> {
    /// The map of the planar triangle `x`; `None` when degenerate
    /// (`|det| <=` [`DEGENERATE_REL`]` l_max^2`, NaN included) or not
    /// invertible.
    fn triangle(x: &[[f64; 2]; 3]) -> Option<Self> {
        let (ux, uy) = (x[1][0] - x[0][0], x[1][1] - x[0][1]);
        let (vx, vy) = (x[2][0] - x[0][0], x[2][1] - x[0][1]);
        let det = ux * vy - vx * uy;
        let l2 = (ux * ux + uy * uy)
            .max(vx * vx + vy * vy)
            .max((vx - ux).powi(2) + (vy - uy).powi(2));
        let solid = det.abs() > DEGENERATE_REL * l2;
        if !solid {
            return None;
        }
        let inv = [[vy / det, -vx / det], [-uy / det, ux / det]];
        inv.iter()
            .flatten()
            .all(|v| v.is_finite())
            .then_some(Affine { x0: x[0], inv })
    }
}

impl<const D: usize> Affine<D> {
    /// The barycentric coordinates `[b_0, b_1, ..., b_D]` of `p` (`K = D +
    /// 1` of them), each `b_i = sum_j A_ij (p_j - x0_j)` summed over `j`
    /// left to right.
    #[inline]
    fn barycentric<const K: usize>(&self, p: &[f64; D]) -> [f64; K] {
        const { assert!(K == D + 1) };
        let d: [f64; D] = std::array::from_fn(|j| p[j] - self.x0[j]);
        let mut b = [0.0; K];
        let mut b0 = 1.0;
        for i in 0..D {
            let row = &self.inv[i];
            let mut r = row[0] * d[0];
            for j in 1..D {
                r += row[j] * d[j];
            }
            b[i + 1] = r;
        }
        for bi in &b[1..] {
            b0 -= bi;
        }
        b[0] = b0;
        b
    }
}

/// Finds the simplex of a mesh in `D` dimensions (`K = D + 1` corners)
/// containing a point, with its barycentric coordinates: one locator for
/// tets in space ([`TetLocator`], `Locator<3, 4>`) and triangles in the
/// plane ([`PlanarTriLocator`], `Locator<2, 3>`).
///
/// For the simplex `[x_0, ..., x_D]` the barycentric coordinates of `p`
/// solve `p = sum_i b_i x_i`, `sum_i b_i = 1`; they are computed from the
/// precomputed inverse of `[x_1 - x_0 | ... | x_D - x_0]`. `p` is in the
/// simplex when `min_i b_i >= -tolerance` (default [`DEFAULT_TOLERANCE`]
/// `= 1e-9`, relative to the simplex's size), so points on shared faces,
/// edges and the boundary (up to round-off) are found. When several
/// simplices qualify, the one with the largest `min_i b_i` is returned (the
/// search stops early at one with `min_i b_i > tolerance`, which in a
/// non-overlapping mesh is the only one). The coordinates returned are not
/// clamped: they sum to 1 and reconstruct `p` to round-off.
///
/// Inverted (negatively oriented) simplices are handled like positive
/// ones; degenerate (flat) ones, `|det| <= 1e-12 l_max^D`, are skipped.
#[derive(Debug, Clone, Default)]
pub struct Locator<const D: usize, const K: usize> {
    bvh: Bvh,
    /// Affine maps in BVH slot order.
    maps: Vec<Affine<D>>,
    tolerance: f64,
}

/// Finds the tet of a [`TetMesh`] containing a point, with its barycentric
/// coordinates: [`Locator`] in space (`b_0 .. b_3`; `|det| <= 1e-12
/// l_max^3` skipped).
pub type TetLocator = Locator<3, 4>;

/// Finds the triangle of a planar (2D) triangle mesh containing a point,
/// with its barycentric coordinates; e.g. to map a point of a flattened
/// surface back to the 3D surface: [`Locator`] in the plane (clockwise
/// triangles handled like counter-clockwise ones; `|det| <= 1e-12
/// l_max^2` skipped).
pub type PlanarTriLocator = Locator<2, 3>;

impl<const D: usize, const K: usize> Locator<D, K> {
    /// Builds the locator from each element's map and corners (`None` for
    /// an element left out: an index out of range, a non-finite corner, a
    /// degenerate simplex); `tolerance` as in `with_tolerance`.
    fn build(
        tolerance: f64,
        elements: impl ExactSizeIterator<Item = Option<(Affine<D>, [Point3<f64>; K])>>,
    ) -> Self {
        let tolerance = if tolerance > 0.0 { tolerance } else { 0.0 };
        let mut items = Vec::with_capacity(elements.len());
        let mut maps_by_element: Vec<Option<Affine<D>>> = Vec::with_capacity(elements.len());
        for (t, element) in elements.enumerate() {
            let map = element.map(|(map, x)| {
                items.push((t, padded_box(&x, tolerance)));
                map
            });
            maps_by_element.push(map);
        }
        let bvh = Bvh::build(items);
        let maps = bvh
            .order
            .iter()
            .map(|&t| maps_by_element[t].take().expect("boxed elements have maps"))
            .collect();
        Locator {
            bvh,
            maps,
            tolerance,
        }
    }

    /// The barycentric tolerance in use.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// Number of (non-degenerate) elements indexed.
    pub fn len(&self) -> usize {
        self.maps.len()
    }

    /// Whether no element is indexed (every query returns `None`).
    pub fn is_empty(&self) -> bool {
        self.maps.is_empty()
    }

    /// The element containing `p` (`D` coordinates) and `p`'s barycentric
    /// coordinates in it (`p = sum_i b_i x_i`, `sum_i b_i = 1`,
    /// `b_i >= -tolerance`); `None` when `p` is outside the mesh or not
    /// finite.
    #[inline]
    fn locate_coords(&self, p: &[f64; D]) -> Option<(usize, [f64; K])> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let q = Point3::new(p[0], p[1], p.get(2).copied().unwrap_or(0.0));
        let mut best: Option<(usize, [f64; K])> = None;
        let mut best_min = f64::NEG_INFINITY;
        let tol = self.tolerance;
        self.bvh.visit_containing(&q, |slot| {
            let b = self.maps[slot].barycentric::<K>(p);
            let m = b[1..].iter().fold(b[0], |m, &x| m.min(x));
            if m > best_min {
                best_min = m;
                best = Some((slot, b));
            }
            m > tol
        });
        best.filter(|_| best_min >= -tol)
            .map(|(slot, b)| (self.bvh.order[slot], b))
    }
}

impl Locator<3, 4> {
    /// Builds the locator with [`DEFAULT_TOLERANCE`]; `O(n log n)`.
    pub fn new(mesh: &TetMesh) -> Self {
        Self::with_tolerance(mesh, DEFAULT_TOLERANCE)
    }

    /// Builds the locator accepting `min_i b_i >= -tolerance` (negative or
    /// NaN tolerances are treated as 0).
    pub fn with_tolerance(mesh: &TetMesh, tolerance: f64) -> Self {
        Self::build(
            tolerance,
            mesh.tets
                .iter()
                .map(|tet| corners(&mesh.positions, tet).and_then(|x| Some((Affine::tet(&x)?, x)))),
        )
    }

    /// The tet containing `p` and `p`'s barycentric coordinates in it
    /// (`p = sum_i b_i x_i`, `sum_i b_i = 1`, `b_i >= -tolerance`); `None`
    /// when `p` is outside the mesh or not finite.
    pub fn locate(&self, p: &Point3<f64>) -> Option<(usize, [f64; 4])> {
        self.locate_coords(&[p.x, p.y, p.z])
    }
}

impl Locator<2, 3> {
    /// Builds the locator with [`DEFAULT_TOLERANCE`]; `O(n log n)`.
    pub fn new(points: &[[f64; 2]], triangles: &[[u32; 3]]) -> Self {
        Self::with_tolerance(points, triangles, DEFAULT_TOLERANCE)
    }

    /// Builds the locator accepting `min_i b_i >= -tolerance` (negative or
    /// NaN tolerances are treated as 0).
    pub fn with_tolerance(points: &[[f64; 2]], triangles: &[[u32; 3]], tolerance: f64) -> Self {
        let lifted: Vec<Point3<f64>> = points
            .iter()
            .map(|p| Point3::new(p[0], p[1], 0.0))
            .collect();
        Self::build(
            tolerance,
            triangles.iter().map(|tri| {
                corners(&lifted, tri)
                    .and_then(|x| Some((Affine::triangle(&x.map(|q| [q.x, q.y]))?, x)))
            }),
        )
    }

    /// The triangle containing `p` and `p`'s barycentric coordinates in it
    /// (`p = sum_i b_i x_i`, `sum_i b_i = 1`, `b_i >= -tolerance`); `None`
    /// when `p` is outside the mesh or not finite.
    pub fn locate(&self, p: [f64; 2]) -> Option<(usize, [f64; 3])> {
        self.locate_coords(&p)
    }
}

// ---------------------------------------------------------------------------
// Closest points
// ---------------------------------------------------------------------------

/// The closest point of a triangle mesh to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestPoint {
    /// Index of the triangle the closest point lies on.
    pub triangle: usize,
    /// The closest point `q = sum_i b_i x_i`.
    pub point: Point3<f64>,
    /// Its barycentric coordinates `b` in that triangle (`b_i >= 0`,
    /// `sum_i b_i = 1`).
    pub barycentric: [f64; 3],
    /// Euclidean distance `|p - q|`.
    pub distance: f64,
}

/// Exact closest point to `p` on the (closed) triangle `(a, b, c)` and its
/// barycentric coordinates `(b_a, b_b, b_c)`.
///
/// Voronoi-region classification (Ericson, *Real-Time Collision Detection*
/// 5.1.5): with `d1 = ab·ap`, `d2 = ac·ap`, ... the point is a vertex, the
/// projection on an edge, `a + ab t`, or the projection on the plane with
/// `v = V_b / (V_a + V_b + V_c)`, `w = V_c / (V_a + V_b + V_c)` (the `V`s
/// are signed sub-areas times `|n|^2`). Degenerate triangles
/// (`|ab × ac|^2 <= 1e-24 l_max^4`, collinear or repeated corners) are
/// treated as their three edges, so no NaN arises.
pub fn closest_point_on_triangle(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> (Point3<f64>, [f64; 3]) {
    let ab = b - a;
    let ac = c - a;
    let l2 = ab
        .norm_squared()
        .max(ac.norm_squared())
        .max((c - b).norm_squared());
    let proper = ab.cross(&ac).norm_squared() > 1e-24 * l2 * l2;
    if !proper {
        // Degenerate: the closest of the three edges.
        let (qab, t) = closest_point_on_segment(p, a, b);
        let (qbc, u) = closest_point_on_segment(p, b, c);
        let (qca, v) = closest_point_on_segment(p, c, a);
        let cands = [
            (qab, [1.0 - t, t, 0.0]),
            (qbc, [0.0, 1.0 - u, u]),
            (qca, [v, 0.0, 1.0 - v]),
        ];
        return cands
            .into_iter()
            .min_by(|x, y| {
                (x.0 - p)
                    .norm_squared()
                    .total_cmp(&(y.0 - p).norm_squared())
            })
            .unwrap_or((*a, [1.0, 0.0, 0.0]));
    }
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

/// Closest point on a triangle surface, by branch and bound over a BVH of the
/// triangles: boxes are visited nearest first and skipped when their distance
/// exceeds the best found so far; each candidate triangle is solved exactly
/// with [`closest_point_on_triangle`].
#[derive(Debug, Clone, Default)]
pub struct ClosestPointQuery {
    bvh: Bvh,
    /// Triangle corners in BVH slot order.
    tris: Vec<[Point3<f64>; 3]>,
    /// An oriented box per node (used at the leaves), see [`LeafBox`].
    leaf_boxes: Vec<LeafBox>,
}

/// An oriented bounding box of a leaf's triangles: axes `t1, t2, n` (`n`
/// their mean normal) and the extent of the corners along each. Its
/// distance to `p` is a lower bound on the distance to the triangles, and
/// for a sheet-like surface a much tighter one than the axis-aligned box:
/// a leaf beside the foot point of `p` is skipped, where its axis-aligned
/// box (as thick as the sheet's tilt makes it) would have been opened.
#[derive(Debug, Clone, Copy, Default)]
struct LeafBox {
    axes: [[f64; 3]; 3],
    lo: [f64; 3],
    hi: [f64; 3],
}

impl LeafBox {
    /// The box of the corners `pts` around the normal `n` (unit); extents
    /// padded by `1e-12` of their magnitude so rounding cannot make the
    /// bound exceed a true distance.
    fn new(n: [f64; 3], pts: impl Iterator<Item = Point3<f64>> + Clone) -> LeafBox {
        // t1: n x (the axis least aligned with n), t2 = n x t1.
        let (ax, ay, az) = (n[0].abs(), n[1].abs(), n[2].abs());
        let e = if ax <= ay && ax <= az {
            [1.0, 0.0, 0.0]
        } else if ay <= az {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let t1 = cross(n, e);
        let m = (t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]).sqrt();
        let t1 = [t1[0] / m, t1[1] / m, t1[2] / m];
        let t2 = cross(n, t1);
        let axes = [t1, t2, n];
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for q in pts {
            for (k, a) in axes.iter().enumerate() {
                let x = a[0] * q.x + a[1] * q.y + a[2] * q.z;
                lo[k] = lo[k].min(x);
                hi[k] = hi[k].max(x);
            }
        }
        for k in 0..3 {
            let pad = 1e-12 * lo[k].abs().max(hi[k].abs()).max(f64::MIN_POSITIVE);
            lo[k] -= pad;
            hi[k] += pad;
        }
        LeafBox { axes, lo, hi }
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    fn distance_squared(&self, p: &Point3<f64>) -> f64 {
        let mut d2 = 0.0;
        for k in 0..3 {
            let a = &self.axes[k];
            let x = a[0] * p.x + a[1] * p.y + a[2] * p.z;
            let e = (self.lo[k] - x).max(x - self.hi[k]).max(0.0);
            d2 += e * e;
        }
        d2
    }
}

impl ClosestPointQuery {
    /// Builds the query structure; `O(n log n)`. Triangles with an
    /// out-of-range index or a non-finite corner are skipped; degenerate ones
    /// are kept (as segments / points).
    pub fn new(mesh: &TriMesh) -> Self {
        let mut items = Vec::with_capacity(mesh.triangles.len());
        let mut by_tri: Vec<Option<[Point3<f64>; 3]>> = Vec::with_capacity(mesh.triangles.len());
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let x = corners(&mesh.positions, tri);
            if let Some(x) = &x {
                items.push((t, Aabb::from_points(x)));
            }
            by_tri.push(x);
        }
        let bvh = Bvh::build(items);
        let tris = bvh
            .order
            .iter()
            .map(|&t| by_tri[t].expect("boxed triangles have corners"))
            .collect::<Vec<[Point3<f64>; 3]>>();
        let leaf_boxes = bvh
            .nodes
            .iter()
            .map(|node| {
                if node.count == 0 {
                    return LeafBox::default();
                }
                let leaf = &tris[node.start as usize..(node.start + node.count) as usize];
                let mut n = [0.0; 3];
                for [a, b, c] in leaf {
                    let w = (b - a).cross(&(c - a));
                    // Orient every normal like the first (a leaf of a
                    // folded or inconsistent surface still gets a mean).
                    let s = if n[0] * w.x + n[1] * w.y + n[2] * w.z < 0.0 {
                        -1.0
                    } else {
                        1.0
                    };
                    for k in 0..3 {
                        n[k] += s * w[k];
                    }
                }
                let m = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if !(m.is_finite() && m > 0.0) {
                    // Degenerate leaf: no oriented bound (distance 0).
                    return LeafBox::default();
                }
                let n = [n[0] / m, n[1] / m, n[2] / m];
                LeafBox::new(n, leaf.iter().flat_map(|t| t.iter().copied()))
            })
            .collect();
        ClosestPointQuery {
            bvh,
            tris,
            leaf_boxes,
        }
    }

    /// Number of triangles indexed.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether no triangle is indexed (every query returns `None`).
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The point of the surface closest to `p`: `argmin_t min_{q in t} |p-q|`.
    /// On exact ties the first triangle found wins. `None` for an empty mesh
    /// or a non-finite `p`.
    pub fn closest(&self, p: &Point3<f64>) -> Option<ClosestPoint> {
        if !finite3(p) {
            return None;
        }
        let (slot, _) = self.bvh.nearest(
            p,
            |slot| {
                let [a, b, c] = &self.tris[slot];
                (p - closest_point_on_triangle(p, a, b, c).0).norm_squared()
            },
            |node| self.leaf_boxes[node].distance_squared(p),
        )?;
        let [a, b, c] = &self.tris[slot];
        let (point, barycentric) = closest_point_on_triangle(p, a, b, c);
        Some(ClosestPoint {
            triangle: self.bvh.order[slot],
            point,
            barycentric,
            distance: (p - point).norm(),
        })
    }
}

/// Closest point of a point set (e.g. the closest mesh vertex), by branch and
/// bound over a BVH of the points.
#[derive(Debug, Clone, Default)]
pub struct PointCloudQuery {
    bvh: Bvh,
    /// Points in BVH slot order.
    points: Vec<Point3<f64>>,
}

impl PointCloudQuery {
    /// Builds the query structure; `O(n log n)`. Non-finite points are skipped.
    pub fn new(points: &[Point3<f64>]) -> Self {
        let items = points
            .iter()
            .enumerate()
            .filter(|(_, p)| finite3(p))
            .map(|(i, p)| (i, Aabb { min: *p, max: *p }))
            .collect();
        let bvh = Bvh::build(items);
        let points = bvh.order.iter().map(|&i| points[i]).collect();
        PointCloudQuery { bvh, points }
    }

    /// Number of points indexed.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point is indexed (every query returns `None`).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Index of the point closest to `p` and its distance
    /// `min_i |p - p_i|` (the first found on exact ties); `None` for an empty
    /// set or a non-finite `p`.
    pub fn closest_vertex(&self, p: &Point3<f64>) -> Option<(usize, f64)> {
        if !finite3(p) {
            return None;
        }
        self.bvh
            .nearest(p, |slot| (self.points[slot] - p).norm_squared(), |_| 0.0)
            .map(|(slot, d2)| (self.bvh.order[slot], d2.sqrt()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{tet_signed_volume, triangle_signed_area_2d};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    use crate::test_meshes::SplitMix as Rng;

    /// `n[0] x n[1] x n[2]` cubes of side `h`, 6 Kuhn tets each (a conforming
    /// triangulation), every vertex moved by up to `jitter * h` per axis.
    fn perturbed_tet_grid(n: [usize; 3], h: f64, jitter: f64, seed: u64) -> TetMesh {
        let mut rng = Rng(seed);
        let id = |i: usize, j: usize, k: usize| (i + (n[0] + 1) * (j + (n[1] + 1) * k)) as u32;
        let mut positions = Vec::new();
        for k in 0..=n[2] {
            for j in 0..=n[1] {
                for i in 0..=n[0] {
                    let base = Vector3::new(i as f64, j as f64, k as f64) * h;
                    let d = Vector3::new(rng.sym(1.0), rng.sym(1.0), rng.sym(1.0)) * (jitter * h);
                    positions.push(Point3::from(base + d));
                }
            }
        }
        let mut tets = Vec::new();
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    for perm in [
                        [0, 1, 2],
                        [0, 2, 1],
                        [1, 0, 2],
                        [1, 2, 0],
                        [2, 0, 1],
                        [2, 1, 0],
                    ] {
                        let mut c = [i, j, k];
                        let mut tet = [id(c[0], c[1], c[2]); 4];
                        for (s, &axis) in perm.iter().enumerate() {
                            c[axis] += 1;
                            tet[s + 1] = id(c[0], c[1], c[2]);
                        }
                        let [a, b, cc, d] = tet.map(|v| positions[v as usize]);
                        if tet_signed_volume(&a, &b, &cc, &d) < 0.0 {
                            tet.swap(2, 3);
                        }
                        tets.push(tet);
                    }
                }
            }
        }
        TetMesh::new(positions, tets)
    }

    /// Barycentric coordinates by sub-volume ratios, `b_i = V_i / V`.
    fn brute_tet(mesh: &TetMesh, p: &Point3<f64>) -> Option<(usize, f64)> {
        (0..mesh.tets.len())
            .map(|t| {
                let x = mesh.tet_points(t);
                let v = tet_signed_volume(&x[0], &x[1], &x[2], &x[3]);
                let m = (0..4)
                    .map(|i| {
                        let mut y = x;
                        y[i] = *p;
                        tet_signed_volume(&y[0], &y[1], &y[2], &y[3]) / v
                    })
                    .fold(f64::INFINITY, f64::min);
                (t, m)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    fn planar_grid(
        nx: usize,
        ny: usize,
        jitter: f64,
        seed: u64,
        flip: bool,
    ) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut rng = Rng(seed);
        let mut pts = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                pts.push([
                    i as f64 + jitter * rng.sym(1.0),
                    j as f64 + jitter * rng.sym(1.0),
                ]);
            }
        }
        let id = |i: usize, j: usize| (i + (nx + 1) * j) as u32;
        let mut tris = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let mut t1 = [id(i, j), id(i + 1, j), id(i + 1, j + 1)];
                let mut t2 = [id(i, j), id(i + 1, j + 1), id(i, j + 1)];
                if flip && (i + j) % 2 == 1 {
                    t1.swap(0, 1);
                    t2.swap(0, 1);
                }
                tris.push(t1);
                tris.push(t2);
            }
        }
        (pts, tris)
    }

    fn brute_tri(pts: &[[f64; 2]], tris: &[[u32; 3]], p: [f64; 2]) -> Option<(usize, f64)> {
        tris.iter()
            .enumerate()
            .map(|(t, tri)| {
                let x = tri.map(|v| pts[v as usize]);
                let a = triangle_signed_area_2d(x[0], x[1], x[2]);
                let m = (0..3)
                    .map(|i| {
                        let mut y = x;
                        y[i] = p;
                        triangle_signed_area_2d(y[0], y[1], y[2]) / a
                    })
                    .fold(f64::INFINITY, f64::min);
                (t, m)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// Reference closest point: the plane projection when it falls inside,
    /// else the best of the three clamped edge projections.
    fn reference_distance2(p: &Point3<f64>, x: &[Point3<f64>; 3]) -> f64 {
        let seg = |a: &Point3<f64>, b: &Point3<f64>| {
            (crate::geometry::closest_point_on_segment(p, a, b).0 - p).norm_squared()
        };
        let edges = seg(&x[0], &x[1])
            .min(seg(&x[1], &x[2]))
            .min(seg(&x[2], &x[0]));
        let (e0, e1, r) = (x[1] - x[0], x[2] - x[0], p - x[0]);
        let (g00, g01, g11) = (e0.dot(&e0), e0.dot(&e1), e1.dot(&e1));
        let det = g00 * g11 - g01 * g01;
        if det > 1e-10 * g00 * g11 {
            let (r0, r1) = (e0.dot(&r), e1.dot(&r));
            let v = (g11 * r0 - g01 * r1) / det;
            let w = (g00 * r1 - g01 * r0) / det;
            if v >= 0.0 && w >= 0.0 && v + w <= 1.0 {
                return (x[0] + e0 * v + e1 * w - p).norm_squared().min(edges);
            }
        }
        edges
    }

    fn pt(range: f64) -> impl Strategy<Value = Point3<f64>> {
        (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Point3::new(x, y, z))
    }

    // ----- TetLocator --------------------------------------------------------

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// Same tet as brute force (or an equally valid one on shared faces),
        /// barycentrics reconstruct p; outside points give None.
        #[test]
        fn tet_locator_matches_brute_force(
            nx in 1usize..5, ny in 1usize..5, nz in 1usize..4,
            h in 0.1..3.0f64, jitter in 0.0..0.1f64, seed in any::<u64>(),
            queries in prop::collection::vec((-0.2..1.2f64, -0.2..1.2f64, -0.2..1.2f64), 40),
        ) {
            let mesh = perturbed_tet_grid([nx, ny, nz], h, jitter, seed);
            let loc = TetLocator::new(&mesh);
            prop_assert_eq!(loc.len(), mesh.tets.len());
            // Random points, grid vertices and face centroids.
            let ext = Vector3::new(nx as f64, ny as f64, nz as f64) * h;
            let mut pts: Vec<Point3<f64>> = queries
                .iter()
                .map(|&(x, y, z)| Point3::new(x * ext.x, y * ext.y, z * ext.z))
                .collect();
            pts.extend(mesh.positions.iter().step_by(3));
            for t in (0..mesh.tets.len()).step_by(5) {
                let x = mesh.tet_points(t);
                pts.push(Point3::from((x[0].coords + x[1].coords + x[2].coords) / 3.0));
            }
            for p in &pts {
                let brute = brute_tet(&mesh, p).unwrap();
                let got = loc.locate(p);
                if brute.1 >= 1e-7 {
                    prop_assert_eq!(got.map(|g| g.0), Some(brute.0));
                } else if brute.1 < -1e-7 {
                    prop_assert!(got.is_none(), "{:?} outside but located", p);
                } else {
                    prop_assert!(got.is_some(), "{:?} on the boundary not found", p);
                }
                if let Some((t, b)) = got {
                    let x = mesh.tet_points(t);
                    let q = x.iter().zip(&b).fold(Vector3::zeros(), |acc, (xi, bi)| acc + xi.coords * *bi);
                    prop_assert!((q - p.coords).norm() < 1e-9);
                    prop_assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                    prop_assert!(b.iter().all(|&bi| bi >= -loc.tolerance()));
                }
            }
        }
    }

    #[test]
    fn tet_locator_degenerate_inputs() {
        let empty = TetLocator::new(&TetMesh::default());
        assert!(empty.is_empty());
        assert_eq!(empty.locate(&Point3::origin()), None);
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let positions = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(1.0, 1.0, 0.0),
            p(f64::NAN, 0.0, 0.0),
        ];
        let tets = vec![
            [0, 1, 2, 3], // good
            [0, 1, 2, 4], // flat
            [0, 1, 2, 9], // out of range
            [0, 1, 2, 5], // NaN
            [0, 0, 1, 2], // repeated vertex
            [0, 2, 1, 3], // inverted copy of the first
        ];
        let loc = TetLocator::new(&TetMesh::new(positions, tets));
        assert_eq!(loc.len(), 2);
        let (t, b) = loc.locate(&p(0.1, 0.2, 0.3)).unwrap();
        assert!(t == 0 || t == 5);
        assert!(b.iter().all(|&x| x > 0.0));
        assert_eq!(loc.locate(&p(1.0, 1.0, 1.0)), None);
        assert_eq!(loc.locate(&p(f64::NAN, 0.0, 0.0)), None);
        assert_eq!(loc.locate(&p(f64::INFINITY, 0.0, 0.0)), None);
        // Corners and tolerance: a vertex is found, a point just beyond a
        // face is found within tolerance, clearly beyond is not.
        let one = TetLocator::new(&perturbed_tet_grid([1, 1, 1], 1.0, 0.0, 0));
        assert!(one.locate(&p(1.0, 1.0, 1.0)).is_some());
        assert!(one.locate(&p(1.0 + 1e-12, 0.5, 0.5)).is_some());
        assert!(one.locate(&p(1.0 + 1e-6, 0.5, 0.5)).is_none());
        let strict = TetLocator::with_tolerance(&perturbed_tet_grid([1, 1, 1], 1.0, 0.0, 0), -1.0);
        assert_eq!(strict.tolerance(), 0.0);
        assert!(strict.locate(&p(0.5, 0.5, 0.5)).is_some());
    }

    // ----- PlanarTriLocator --------------------------------------------------

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn planar_locator_matches_brute_force(
            nx in 1usize..8, ny in 1usize..8, jitter in 0.0..0.2f64, seed in any::<u64>(), flip in any::<bool>(),
            queries in prop::collection::vec((-0.2..1.2f64, -0.2..1.2f64), 60),
        ) {
            let (pts, tris) = planar_grid(nx, ny, jitter, seed, flip);
            let loc = PlanarTriLocator::new(&pts, &tris);
            let mut qs: Vec<[f64; 2]> = queries.iter().map(|&(x, y)| [x * nx as f64, y * ny as f64]).collect();
            qs.extend(pts.iter().step_by(2));
            for tri in tris.iter().step_by(3) {
                let (a, b) = (pts[tri[0] as usize], pts[tri[1] as usize]);
                qs.push([(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]);
            }
            for q in qs {
                let brute = brute_tri(&pts, &tris, q).unwrap();
                let got = loc.locate(q);
                if brute.1 >= 1e-7 {
                    prop_assert_eq!(got.map(|g| g.0), Some(brute.0));
                } else if brute.1 < -1e-7 {
                    prop_assert!(got.is_none());
                } else {
                    prop_assert!(got.is_some());
                }
                if let Some((t, b)) = got {
                    let x = tris[t].map(|v| pts[v as usize]);
                    for a in 0..2 {
                        let r = b[0] * x[0][a] + b[1] * x[1][a] + b[2] * x[2][a];
                        prop_assert!((r - q[a]).abs() < 1e-9);
                    }
                    prop_assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                    prop_assert!(b.iter().all(|&bi| bi >= -loc.tolerance()));
                }
            }
        }
    }

    #[test]
    fn planar_locator_degenerate_inputs() {
        let empty = PlanarTriLocator::new(&[], &[]);
        assert!(empty.is_empty());
        assert_eq!(empty.locate([0.0, 0.0]), None);
        let pts = [
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [2.0, 0.0],
            [f64::NAN, 1.0],
        ];
        let tris = [[0, 1, 2], [0, 1, 3], [0, 1, 7], [0, 1, 4], [1, 1, 1]];
        let loc = PlanarTriLocator::new(&pts, &tris);
        assert_eq!(loc.len(), 1);
        let (t, b) = loc.locate([0.25, 0.25]).unwrap();
        assert_eq!(t, 0);
        assert!((b[0] - 0.5).abs() < 1e-15 && (b[1] - 0.25).abs() < 1e-15);
        assert_eq!(loc.locate([1.5, 0.0]), None);
        assert_eq!(loc.locate([f64::NAN, 0.0]), None);
    }

    // ----- closest points ----------------------------------------------------

    fn triangle_soup(n: usize, seed: u64, degenerate: bool) -> TriMesh {
        let mut rng = Rng(seed);
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for t in 0..n {
            let c = Vector3::new(rng.sym(1.0), rng.sym(1.0), rng.sym(1.0)) * 5.0;
            let mut corner =
                || Point3::from(c + Vector3::new(rng.sym(1.0), rng.sym(1.0), rng.sym(1.0)));
            let (a, b, mut cc) = (corner(), corner(), corner());
            if degenerate && t % 7 == 0 {
                cc = a + (b - a) * 0.3; // collinear
            }
            let i = positions.len() as u32;
            positions.extend([a, b, cc]);
            if degenerate && t % 11 == 0 {
                tris.push([i, i, i]); // a point
            } else {
                tris.push([i, i + 1, i + 2]);
            }
        }
        TriMesh::new(positions, tris)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The exact per-triangle routine agrees with an independent reference,
        /// also on degenerate triangles, and returns consistent barycentrics.
        #[test]
        fn closest_point_on_triangle_matches_reference(
            p in pt(4.0), a in pt(2.0), b in pt(2.0), c in pt(2.0), kind in 0..4u8, s in 0.0..1.0f64,
        ) {
            let c = match kind {
                0 => c,
                1 => a + (b - a) * s, // collinear
                2 => a,               // repeated corner
                _ => c,
            };
            let b = if kind == 3 && s < 0.2 { a } else { b };
            let (q, bary) = closest_point_on_triangle(&p, &a, &b, &c);
            prop_assert!(q.coords.iter().all(|x| x.is_finite()));
            prop_assert!(bary.iter().all(|&x| (-1e-12..=1.0 + 1e-12).contains(&x)));
            prop_assert!((bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let r = a.coords * bary[0] + b.coords * bary[1] + c.coords * bary[2];
            prop_assert!((r - q.coords).norm() < 1e-9);
            let d_ref = reference_distance2(&p, &[a, b, c]).sqrt();
            prop_assert!(((p - q).norm() - d_ref).abs() < 1e-9, "{} vs {}", (p - q).norm(), d_ref);
        }

        /// BVH branch and bound equals brute force over all triangles.
        #[test]
        fn closest_point_matches_brute_force(
            n in 1usize..150, seed in any::<u64>(), degenerate in any::<bool>(),
            queries in prop::collection::vec(pt(9.0), 30),
        ) {
            let mesh = triangle_soup(n, seed, degenerate);
            let q = ClosestPointQuery::new(&mesh);
            prop_assert_eq!(q.len(), n);
            for p in &queries {
                let brute = (0..n)
                    .map(|t| reference_distance2(p, &mesh.triangle_points(t)))
                    .fold(f64::INFINITY, f64::min)
                    .sqrt();
                let got = q.closest(p).unwrap();
                prop_assert!((got.distance - brute).abs() < 1e-9, "{} vs {}", got.distance, brute);
                let x = mesh.triangle_points(got.triangle);
                let r = x[0].coords * got.barycentric[0] + x[1].coords * got.barycentric[1]
                    + x[2].coords * got.barycentric[2];
                prop_assert!((r - got.point.coords).norm() < 1e-9);
                prop_assert!(((p - got.point).norm() - got.distance).abs() < 1e-12);
            }
        }

        /// On a curved sheet (where the oriented leaf boxes prune most
        /// leaves) the search still equals brute force, for points on
        /// either side, near or far.
        #[test]
        fn closest_point_on_a_curved_sheet_matches_brute_force(
            w in 2usize..14, h in 2usize..14, bend in -0.5..0.5f64, tilt in -1.0..1.0f64,
            queries in prop::collection::vec(pt(6.0), 20),
        ) {
            let id = |x: usize, y: usize| (y * w + x) as u32;
            let mut positions = Vec::new();
            for y in 0..h {
                for x in 0..w {
                    let (fx, fy) = (x as f64 * 0.7 - 3.0, y as f64 * 0.6 - 3.0);
                    positions.push(Point3::new(fx, fy, bend * (fx * fx + 0.5 * fy * fy) + tilt * fx));
                }
            }
            let mut tris = Vec::new();
            for y in 0..h - 1 {
                for x in 0..w - 1 {
                    tris.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                    tris.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
                }
            }
            let mesh = TriMesh::new(positions, tris);
            let q = ClosestPointQuery::new(&mesh);
            for p in &queries {
                let brute = (0..mesh.triangles.len())
                    .map(|t| reference_distance2(p, &mesh.triangle_points(t)))
                    .fold(f64::INFINITY, f64::min)
                    .sqrt();
                let got = q.closest(p).unwrap();
                prop_assert!((got.distance - brute).abs() < 1e-9, "{} vs {}", got.distance, brute);
            }
        }

        /// Closest vertex equals brute force.
        #[test]
        fn closest_vertex_matches_brute_force(
            pts in prop::collection::vec(pt(5.0), 1..300), queries in prop::collection::vec(pt(7.0), 20),
        ) {
            let q = PointCloudQuery::new(&pts);
            for p in &queries {
                let brute = pts.iter().map(|x| (x - p).norm()).fold(f64::INFINITY, f64::min);
                let (i, d) = q.closest_vertex(p).unwrap();
                prop_assert_eq!(d, brute);
                prop_assert_eq!((pts[i] - p).norm(), d);
            }
        }
    }

    #[test]
    fn closest_point_regions_and_empty() {
        let o = Point3::origin();
        let (a, b, c) = (o, Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0));
        // Face, edge and vertex regions.
        let (q, bary) = closest_point_on_triangle(&Point3::new(0.25, 0.25, 2.0), &a, &b, &c);
        assert_eq!(q, Point3::new(0.25, 0.25, 0.0));
        assert!((bary[0] - 0.5).abs() < 1e-15);
        let (q, bary) = closest_point_on_triangle(&Point3::new(0.5, -1.0, 1.0), &a, &b, &c);
        assert_eq!((q, bary), (Point3::new(0.5, 0.0, 0.0), [0.5, 0.5, 0.0]));
        let (q, bary) = closest_point_on_triangle(&Point3::new(2.0, -1.0, 0.0), &a, &b, &c);
        assert_eq!((q, bary), (b, [0.0, 1.0, 0.0]));
        let (q, _) = closest_point_on_triangle(&Point3::new(1.0, 1.0, 0.0), &a, &b, &c);
        assert!((q - Point3::new(0.5, 0.5, 0.0)).norm() < 1e-15);
        // Fully degenerate triangle: a point.
        let (q, bary) = closest_point_on_triangle(&Point3::new(1.0, 1.0, 1.0), &a, &a, &a);
        assert_eq!((q, bary[0] + bary[1] + bary[2]), (a, 1.0));

        let empty = ClosestPointQuery::new(&TriMesh::default());
        assert!(empty.is_empty());
        assert_eq!(empty.closest(&o), None);
        assert_eq!(PointCloudQuery::new(&[]).closest_vertex(&o), None);
        let bad = TriMesh::new(
            vec![o, b, c, Point3::new(f64::NAN, 0.0, 0.0)],
            vec![[0, 1, 5], [0, 1, 3], [0, 1, 2]],
        );
        let q = ClosestPointQuery::new(&bad);
        assert_eq!(q.len(), 1);
        assert_eq!(q.closest(&Point3::new(0.2, 0.2, 1.0)).unwrap().triangle, 2);
        assert_eq!(q.closest(&Point3::new(f64::NAN, 0.2, 1.0)), None);
        let pc = PointCloudQuery::new(&[Point3::new(f64::NAN, 0.0, 0.0), b]);
        assert_eq!(pc.len(), 1);
        assert_eq!(pc.closest_vertex(&o), Some((1, 1.0)));
    }

    /// A large mesh: queries visit few nodes (the answer matches brute force
    /// on a sample) and the build handles 100k tets quickly.
    #[test]
    fn larger_meshes() {
        let mesh = perturbed_tet_grid([20, 20, 10], 1.0, 0.1, 5);
        let loc = TetLocator::new(&mesh);
        let mut rng = Rng(9);
        for _ in 0..20 {
            let p = Point3::new(20.0 * rng.f64(), 20.0 * rng.f64(), 10.0 * rng.f64());
            let brute = brute_tet(&mesh, &p).unwrap();
            let got = loc.locate(&p);
            if brute.1 > 1e-7 {
                assert_eq!(got.unwrap().0, brute.0);
            }
        }
    }
}
