//! Geometry: signed volumes and areas, normals, vertex areas, centroid, PCA
//! frame, convex hull membership, bounding boxes.

use crate::{MeshError, TetMesh, TriMesh};
use nalgebra::{Matrix3, Point3, Rotation3, SymmetricEigen, Unit, Vector3};
use std::cmp::Ordering;

/// Signed volume of the tet `(a, b, c, d)`: `(b-a)·((c-a)×(d-a)) / 6`;
/// positive when `d` lies on the side of `abc` its counter-clockwise normal
/// points to.
#[inline]
pub fn tet_signed_volume(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
    d: &Point3<f64>,
) -> f64 {
    (b - a).dot(&(c - a).cross(&(d - a))) / 6.0
}

/// The six interior dihedral angles (radians) of the tet `p`, at the edges
/// `01, 02, 03, 12, 13, 23`: the angle at edge `ij` is `pi` minus the angle
/// between the outward normals of the two faces sharing it,
/// `acos(-n_a · n_b)`. A degenerate tet gives angles of 0 or pi (or NaN for
/// coincident corners).
pub fn tet_dihedral_angles(p: &[Point3<f64>; 4]) -> [f64; 6] {
    // face k is opposite corner k; its outward normal points away from p[k]
    let normal = |k: usize| {
        let f: Vec<usize> = (0..4).filter(|&i| i != k).collect();
        let n = (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]]));
        let n = if n.dot(&(p[k] - p[f[0]])) > 0.0 {
            -n
        } else {
            n
        };
        n / n.norm()
    };
    let n = [normal(0), normal(1), normal(2), normal(3)];
    // edge ij is shared by the faces opposite the two other corners
    let edges = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    edges.map(|(i, j)| {
        let o: Vec<usize> = (0..4).filter(|&x| x != i && x != j).collect();
        (-n[o[0]].dot(&n[o[1]])).clamp(-1.0, 1.0).acos()
    })
}

/// Area vector of the triangle `(a, b, c)`: `(b-a)×(c-a) / 2`, its length the
/// area and its direction the counter-clockwise normal.
#[inline]
pub fn triangle_area_vector(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> Vector3<f64> {
    (b - a).cross(&(c - a)) * 0.5
}

/// Area of the triangle `(a, b, c)`: `|(b-a)×(c-a)| / 2`.
#[inline]
pub fn triangle_area(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    triangle_area_vector(a, b, c).norm()
}

/// Unit normal of the triangle `(a, b, c)`, `None` when it is degenerate.
#[inline]
pub fn triangle_normal(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Option<Unit<Vector3<f64>>> {
    Unit::try_new(triangle_area_vector(a, b, c), f64::MIN_POSITIVE)
}

/// Signed area of the planar triangle `(a, b, c)` (x, y only):
/// `((b-a) × (c-a))_z / 2`, positive when counter-clockwise.
#[inline]
pub fn triangle_signed_area_2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

/// Fails with [`MeshError::NonFiniteCoordinate`] on the first NaN/inf vertex.
pub fn check_finite(positions: &[Point3<f64>]) -> Result<(), MeshError> {
    match positions
        .iter()
        .position(|p| !p.coords.iter().all(|x| x.is_finite()))
    {
        Some(v) => {
            let p = positions[v];
            Err(MeshError::NonFiniteCoordinate {
                vertex: v,
                x: p.x,
                y: p.y,
                z: p.z,
            })
        }
        None => Ok(()),
    }
}

/// Fails with [`MeshError::IndexOutOfRange`] on the first element that refers
/// to a vertex `>= n`.
pub fn check_indices<const K: usize>(n: usize, elements: &[[u32; K]]) -> Result<(), MeshError> {
    for (e, el) in elements.iter().enumerate() {
        if let Some(&i) = el.iter().find(|&&i| i as usize >= n) {
            return Err(MeshError::IndexOutOfRange {
                element: e,
                index: i,
                vertex_count: n,
            });
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Per-element measures
// ---------------------------------------------------------------------------

/// Signed volume of every tet, `V_t = (b-a)·((c-a)×(d-a)) / 6` (see
/// [`tet_signed_volume`]); negative for inverted tets.
///
/// Panics if a tet refers to a vertex out of range (see [`check_indices`]).
pub fn tet_volumes(mesh: &TetMesh) -> Vec<f64> {
    (0..mesh.tets.len())
        .map(|t| {
            let [a, b, c, d] = mesh.tet_points(t);
            tet_signed_volume(&a, &b, &c, &d)
        })
        .collect()
}

/// Sum of the signed tet volumes, `sum_t V_t`; the mesh volume when every tet
/// is positively oriented (inverted tets subtract).
///
/// Panics if a tet refers to a vertex out of range.
pub fn total_volume(mesh: &TetMesh) -> f64 {
    tet_volumes(mesh).iter().sum()
}

/// Area of every triangle, `A_t = |(b-a)×(c-a)| / 2` (see [`triangle_area`]).
///
/// Panics if a triangle refers to a vertex out of range.
pub fn triangle_areas(mesh: &TriMesh) -> Vec<f64> {
    (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.triangle_points(t);
            triangle_area(&a, &b, &c)
        })
        .collect()
}

/// Surface area, `sum_t A_t`.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn total_area(mesh: &TriMesh) -> f64 {
    triangle_areas(mesh).iter().sum()
}

/// Volume enclosed by a closed triangle surface, by the divergence theorem:
/// `V = sum_t a_t·(b_t×c_t) / 6` (each triangle forms a signed tet with the
/// origin). Positive for a closed mesh whose counter-clockwise normals point
/// outward, negative when they point inward. For a closed mesh the result does
/// not depend on the origin; for an open mesh it does (it is then the signed
/// volume of the cone from the origin over the surface).
///
/// Panics if a triangle refers to a vertex out of range.
pub fn enclosed_volume(mesh: &TriMesh) -> f64 {
    (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.triangle_points(t);
            a.coords.dot(&b.coords.cross(&c.coords))
        })
        .sum::<f64>()
        / 6.0
}

/// Area-weighted vertex normals: `n_v = N_v / |N_v|` with
/// `N_v = sum_{t ∋ v} (b_t-a_t)×(c_t-a_t) / 2`, the sum of the (unnormalised)
/// area vectors of the triangles around `v`, so larger triangles weigh more.
/// Vertices used by no triangle, or whose area vectors cancel, get the zero
/// vector.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn vertex_normals(mesh: &TriMesh) -> Vec<Vector3<f64>> {
    let mut acc = vec![Vector3::zeros(); mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = mesh.triangle_points(t);
        let n = triangle_area_vector(&a, &b, &c);
        for &v in tri {
            acc[v as usize] += n;
        }
    }
    for n in &mut acc {
        let len = n.norm();
        *n = if len > 0.0 && len.is_finite() {
            *n / len
        } else {
            Vector3::zeros()
        };
    }
    acc
}

/// Barycentric vertex areas: `A_v = sum_{t ∋ v} A_t / 3` (each triangle gives
/// a third of its area to each corner), so `sum_v A_v = sum_t A_t`. The lumped
/// mass matrix of linear finite elements. Isolated vertices get 0.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn vertex_areas(mesh: &TriMesh) -> Vec<f64> {
    let mut acc = vec![0.0; mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = mesh.triangle_points(t);
        let third = triangle_area(&a, &b, &c) / 3.0;
        for &v in tri {
            acc[v as usize] += third;
        }
    }
    acc
}

/// Barycentric vertex volumes: `V_v = sum_{t ∋ v} |V_t| / 4` (each tet gives a
/// quarter of its unsigned volume to each corner), so `sum_v V_v = sum_t |V_t|`
/// (equal to [`total_volume`] when no tet is inverted). Isolated vertices get 0.
///
/// Panics if a tet refers to a vertex out of range.
pub fn tet_vertex_volumes(mesh: &TetMesh) -> Vec<f64> {
    let mut acc = vec![0.0; mesh.positions.len()];
    for (t, tet) in mesh.tets.iter().enumerate() {
        let [a, b, c, d] = mesh.tet_points(t);
        let quarter = tet_signed_volume(&a, &b, &c, &d).abs() / 4.0;
        for &v in tet {
            acc[v as usize] += quarter;
        }
    }
    acc
}

// ---------------------------------------------------------------------------
// Centroids and PCA
// ---------------------------------------------------------------------------

/// Vertex mean `c = (1/n) sum_i p_i`; `None` for an empty slice.
pub fn centroid(points: &[Point3<f64>]) -> Option<Point3<f64>> {
    if points.is_empty() {
        return None;
    }
    let sum = points
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.coords);
    Some(Point3::from(sum / points.len() as f64))
}

/// Centroid of the surface (a thin shell of uniform density):
/// `c = sum_t A_t (a_t + b_t + c_t)/3 / sum_t A_t`. Unlike [`centroid`] it does
/// not depend on how densely each region is sampled. `None` when the total
/// area is zero (no triangles, or all degenerate) or not finite.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn area_weighted_centroid(mesh: &TriMesh) -> Option<Point3<f64>> {
    let mut total = 0.0;
    let mut acc = Vector3::zeros();
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.triangle_points(t);
        let area = triangle_area(&a, &b, &c);
        total += area;
        acc += (a.coords + b.coords + c.coords) * (area / 3.0);
    }
    (total > 0.0 && total.is_finite()).then(|| Point3::from(acc / total))
}

/// A principal-axes frame of a point set (see [`pca_frame`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcaFrame {
    /// The vertex mean `c`.
    pub centroid: Point3<f64>,
    /// Rows are the principal axes `e_0, e_1, e_2` by decreasing variance, so
    /// `rotation * (p - c)` has the largest variance on x and the smallest on
    /// z. A proper rotation (`det = +1`, `e_2 = e_0 × e_1`).
    pub rotation: Rotation3<f64>,
    /// Variances along the axes, `lambda_0 >= lambda_1 >= lambda_2 >= 0`
    /// (eigenvalues of the covariance, tiny negative round-off clamped to 0).
    pub variances: [f64; 3],
}

impl PcaFrame {
    /// Coordinates of `p` in the frame: `R (p - c)`.
    pub fn to_local(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * (p - self.centroid))
    }

    /// World position of local coordinates `q`: `c + R^T q`.
    pub fn to_world(&self, q: &Point3<f64>) -> Point3<f64> {
        self.centroid + self.rotation.inverse() * q.coords
    }

    /// The `i`-th principal axis (unit vector, `i < 3`), row `i` of `rotation`.
    pub fn axis(&self, i: usize) -> Vector3<f64> {
        self.rotation.matrix().row(i).transpose()
    }
}

/// Flips `v` so that its largest-magnitude component (the first one on ties)
/// is positive.
fn canonical_sign(v: Vector3<f64>) -> Vector3<f64> {
    let i = v.iamax();
    if v[i] < 0.0 { -v } else { v }
}

/// Principal component analysis of a point set.
///
/// With `c` the vertex mean and the (population) covariance
/// `C = (1/n) sum_i (p_i - c)(p_i - c)^T`, the eigen-decomposition
/// `C = sum_k lambda_k e_k e_k^T` (nalgebra's `SymmetricEigen`) gives the
/// axes, ordered so that `lambda_0 >= lambda_1 >= lambda_2`.
///
/// Signs are made deterministic, independent of the eigen solver: `e_0` and
/// `e_1` are flipped so that their largest-magnitude component (the first one
/// on exact ties) is positive, and `e_2 = e_0 × e_1`, which makes `rotation` a
/// proper rotation (`det = +1`). When eigenvalues coincide (e.g. an isotropic
/// cloud) the axes within that eigenspace are whatever the solver returns.
///
/// `None` for an empty slice or when a coordinate is not finite.
pub fn pca_frame(points: &[Point3<f64>]) -> Option<PcaFrame> {
    let c = centroid(points)?;
    if !c.coords.iter().all(|x| x.is_finite()) {
        return None;
    }
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - c;
        cov += d * d.transpose();
    }
    cov /= points.len() as f64;
    if !cov.iter().all(|x| x.is_finite()) {
        return None;
    }
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));

    let e0 = eig.eigenvectors.column(order[0]).into_owned();
    let e0 = canonical_sign(e0.try_normalize(0.0).unwrap_or_else(Vector3::x));
    let e1 = eig.eigenvectors.column(order[1]).into_owned();
    let e1 = e1 - e0 * e0.dot(&e1);
    let e1 = match e1.try_normalize(1e-12) {
        Some(e1) => e1,
        // Not reachable for an orthonormal eigenbasis; any perpendicular will do.
        None => {
            let helper = if e0.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            e0.cross(&helper).normalize()
        }
    };
    let e1 = canonical_sign(e1);
    let e2 = e0.cross(&e1).normalize();
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_rows(&[
        e0.transpose(),
        e1.transpose(),
        e2.transpose(),
    ]));
    let var = |k: usize| eig.eigenvalues[order[k]].max(0.0);
    Some(PcaFrame {
        centroid: c,
        rotation,
        variances: [var(0), var(1), var(2)],
    })
}

// ---------------------------------------------------------------------------
// Exact predicates
// ---------------------------------------------------------------------------

#[inline]
fn c3(p: &Point3<f64>) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// Exact orientation of `d` against the plane of `(a, b, c)`: a value with
/// the exact sign of `(b-a)·((c-a)×(d-a))` (same sign convention as
/// [`tet_signed_volume`]); positive when `d` is on the side the
/// counter-clockwise normal of `abc` points to, zero exactly when coplanar.
/// The magnitude is approximate. Shewchuk's adaptive predicate (`robust`).
#[inline]
pub fn orient3d_exact(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, d: &Point3<f64>) -> f64 {
    -robust::orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// Exact orientation of the planar triangle `(a, b, c)`: a value with the
/// exact sign of `(b-a) × (c-a)` (as [`triangle_signed_area_2d`]); positive
/// when counter-clockwise, zero exactly when collinear. Magnitude approximate.
#[inline]
pub fn orient2d_exact(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let k = |p: [f64; 2]| robust::Coord { x: p[0], y: p[1] };
    robust::orient2d(k(a), k(b), k(c))
}

/// `p` with coordinate `drop` removed (the projection onto a coordinate plane).
#[inline]
fn project(p: &Point3<f64>, drop: usize) -> [f64; 2] {
    match drop {
        0 => [p.y, p.z],
        1 => [p.z, p.x],
        _ => [p.x, p.y],
    }
}

/// Exact collinearity of three points: `(b-a)×(c-a) = 0`, whose components
/// are the 2D orientations of the three coordinate projections.
fn collinear_exact(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> bool {
    (0..3).all(|k| orient2d_exact(project(a, k), project(b, k), project(c, k)) == 0.0)
}

fn lex_cmp(a: &Point3<f64>, b: &Point3<f64>) -> Ordering {
    a.x.total_cmp(&b.x)
        .then(a.y.total_cmp(&b.y))
        .then(a.z.total_cmp(&b.z))
}

// ---------------------------------------------------------------------------
// Convex hull
// ---------------------------------------------------------------------------

/// Which points are vertices (extreme points) of the convex hull of the set.
///
/// A point is marked `true` iff it is a corner of the hull polytope: it is not
/// in the convex hull of the other (distinct) points. Points lying exactly on
/// a hull face or edge without being a corner are **not** marked, nor are
/// interior points. All copies of a duplicated corner are marked. Points with
/// a NaN or infinite coordinate are ignored (marked `false`).
///
/// Degenerate sets are handled by dimension: a single distinct point is its
/// own hull; for collinear sets the two end points are marked; for coplanar
/// sets the corners of the planar convex polygon are marked.
///
/// Coordinates are first scaled by a power of two (exact) so that the largest
/// magnitude is about 1; the result is then exact unless coordinate
/// differences are below ~`1e-100` times that magnitude (where the predicates'
/// products underflow).
///
/// Algorithm: Quickhull (furthest point from a face first, conflict lists,
/// expected `O(n log n)`) on the distinct points, with every visibility
/// decision taken by exact orientation predicates ([`orient3d_exact`]): a
/// point is inserted only when it is strictly outside a face, so the hull
/// stays a consistent convex triangulated sphere whatever the input. As
/// coplanar insertions can leave non-corner points as vertices of that
/// triangulation, a final exact pass keeps only the vertices whose incident
/// triangles span at least three distinct planes (a point in the relative
/// interior of a facet touches one plane, on an edge two).
pub fn convex_hull_vertices(points: &[Point3<f64>]) -> Vec<bool> {
    let n = points.len();
    let mut out = vec![false; n];
    // `+ 0.0` turns -0.0 into +0.0 so that equal points compare equal.
    let canon = |p: &Point3<f64>| Point3::new(p.x + 0.0, p.y + 0.0, p.z + 0.0);
    let mut idx: Vec<usize> = (0..n)
        .filter(|&i| points[i].coords.iter().all(|x| x.is_finite()))
        .collect();
    idx.sort_unstable_by(|&i, &j| lex_cmp(&canon(&points[i]), &canon(&points[j])));
    let mut uniq: Vec<Point3<f64>> = Vec::with_capacity(idx.len());
    let mut group = vec![0usize; n];
    for &i in &idx {
        let p = canon(&points[i]);
        if uniq.last() != Some(&p) {
            uniq.push(p);
        }
        group[i] = uniq.len() - 1;
    }
    // Scale by a power of two (exact) so that the largest magnitude is about
    // 1: the predicates are exact only while their products neither overflow
    // nor underflow.
    let max = uniq
        .iter()
        .flat_map(|p| p.coords.iter().map(|x| x.abs()))
        .fold(0.0f64, f64::max);
    if max > 0.0 {
        let k = max.log2().ceil() as i32;
        let (s1, s2) = (2f64.powi(-(k / 2)), 2f64.powi(-(k - k / 2)));
        for p in &mut uniq {
            *p = Point3::from(p.coords * s1 * s2);
        }
    }
    let extreme = extreme_points_unique(&uniq);
    for &i in &idx {
        out[i] = extreme[group[i]];
    }
    out
}

/// Extreme points of distinct finite points sorted lexicographically.
fn extreme_points_unique(u: &[Point3<f64>]) -> Vec<bool> {
    let m = u.len();
    let mut ext = vec![false; m];
    if m <= 2 {
        ext.iter_mut().for_each(|e| *e = true);
        return ext;
    }
    let a = 0;
    // b: farthest from a (any other point would do: all are distinct).
    let b = (1..m)
        .max_by(|&i, &j| {
            (u[i] - u[a])
                .norm_squared()
                .total_cmp(&(u[j] - u[a]).norm_squared())
        })
        .unwrap_or(1);
    // c: farthest from the line ab (by float score, checked exactly).
    let ab = u[b] - u[a];
    let score_c = |i: usize| ab.cross(&(u[i] - u[a])).norm_squared();
    let mut c = (0..m)
        .max_by(|&i, &j| score_c(i).total_cmp(&score_c(j)))
        .unwrap_or(0);
    if collinear_exact(&u[a], &u[b], &u[c]) {
        match (0..m).find(|&i| !collinear_exact(&u[a], &u[b], &u[i])) {
            Some(i) => c = i,
            None => {
                // Collinear: lexicographic order is monotone along the line.
                ext[0] = true;
                ext[m - 1] = true;
                return ext;
            }
        }
    }
    // d: farthest from the plane abc; the exact predicate is 0 iff coplanar.
    let d = (0..m)
        .map(|i| (i, orient3d_exact(&u[a], &u[b], &u[c], &u[i]).abs()))
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .filter(|x| x.1 > 0.0)
        .map(|x| x.0);
    match d {
        None => planar_hull(u, [a, b, c], &mut ext),
        Some(d) => quickhull(u, [a, b, c, d], &mut ext),
    }
    ext
}

/// Corners of the convex polygon of coplanar points (`tri` non-collinear):
/// projects onto the coordinate plane in which `tri` stays non-degenerate
/// (an affine bijection of the common plane) and runs Andrew's monotone chain
/// with exact 2D orientations, dropping collinear points.
fn planar_hull(u: &[Point3<f64>], tri: [usize; 3], ext: &mut [bool]) {
    let [a, b, c] = tri;
    let drop = (0..3)
        .find(|&k| orient2d_exact(project(&u[a], k), project(&u[b], k), project(&u[c], k)) != 0.0)
        .unwrap_or(2);
    let q: Vec<[f64; 2]> = u.iter().map(|p| project(p, drop)).collect();
    let mut order: Vec<usize> = (0..u.len()).collect();
    order.sort_unstable_by(|&i, &j| {
        q[i][0]
            .total_cmp(&q[j][0])
            .then(q[i][1].total_cmp(&q[j][1]))
    });
    let mut chain: Vec<usize> = Vec::with_capacity(2 * u.len());
    for pass in 0..2 {
        let start = chain.len();
        let iter: Box<dyn Iterator<Item = &usize>> = if pass == 0 {
            Box::new(order.iter())
        } else {
            Box::new(order.iter().rev())
        };
        for &i in iter {
            while chain.len() >= start + 2
                && orient2d_exact(q[chain[chain.len() - 2]], q[chain[chain.len() - 1]], q[i]) <= 0.0
            {
                chain.pop();
            }
            chain.push(i);
        }
    }
    for i in chain {
        ext[i] = true;
    }
}

const NONE: u32 = u32::MAX;

/// A hull triangle; `nbr[i]` lies across the edge `(v[i], v[i+1 mod 3])`.
struct HullFace {
    v: [u32; 3],
    nbr: [u32; 3],
    alive: bool,
    /// Stamp of the last insertion that tested this face, and its result.
    visit: u32,
    visible: bool,
    /// Points strictly outside this face (conflict list) and the farthest.
    pts: Vec<u32>,
    far: u32,
    far_dist: f64,
}

impl HullFace {
    fn new(v: [u32; 3]) -> Self {
        HullFace {
            v,
            nbr: [NONE; 3],
            alive: true,
            visit: 0,
            visible: false,
            pts: Vec::new(),
            far: NONE,
            far_dist: 0.0,
        }
    }

    fn add_point(&mut self, p: u32, dist: f64) {
        self.pts.push(p);
        if self.far == NONE || dist > self.far_dist {
            self.far = p;
            self.far_dist = dist;
        }
    }
}

/// Exact "strictly outside" test of `p` against face `f` (outward = counter-
/// clockwise normal); returns the (approximate) positive height, or `None`.
#[inline]
fn outside(u: &[Point3<f64>], f: &HullFace, p: u32) -> Option<f64> {
    let [a, b, c] = f.v.map(|i| &u[i as usize]);
    let s = orient3d_exact(a, b, c, &u[p as usize]);
    (s > 0.0).then_some(s)
}

fn quickhull(u: &[Point3<f64>], simplex: [usize; 4], ext: &mut [bool]) {
    let [a, mut b, mut c, d] = simplex.map(|i| i as u32);
    if orient3d_exact(
        &u[a as usize],
        &u[b as usize],
        &u[c as usize],
        &u[d as usize],
    ) < 0.0
    {
        std::mem::swap(&mut b, &mut c);
    }
    // Positive tet (a, b, c, d): outward faces.
    let mut faces: Vec<HullFace> = [[a, c, b], [a, b, d], [a, d, c], [b, c, d]]
        .into_iter()
        .map(HullFace::new)
        .collect();
    for f in 0..4 {
        for i in 0..3 {
            let (p, q) = (faces[f].v[i], faces[f].v[(i + 1) % 3]);
            let g = (0..4).find(|&g| {
                g != f && (0..3).any(|j| faces[g].v[j] == q && faces[g].v[(j + 1) % 3] == p)
            });
            faces[f].nbr[i] = g.map_or(NONE, |g| g as u32);
        }
    }
    for p in 0..u.len() as u32 {
        if [a, b, c, d].contains(&p) {
            continue;
        }
        for f in faces.iter_mut() {
            if let Some(s) = outside(u, f, p) {
                f.add_point(p, s);
                break;
            }
        }
    }

    let mut stack: Vec<u32> = (0..4).collect();
    let mut stamp = 0u32;
    let mut visible: Vec<u32> = Vec::new();
    let mut horizon: Vec<(u32, u32, u32)> = Vec::new();
    let mut new_faces: Vec<u32> = Vec::new();
    let mut start_face = vec![NONE; u.len()];
    let mut orphans: Vec<u32> = Vec::new();
    while let Some(f) = stack.pop() {
        let f = f as usize;
        if !faces[f].alive || faces[f].pts.is_empty() {
            continue;
        }
        let p = faces[f].far;
        stamp += 1;
        // Visible region: connected, found by BFS from f with exact tests.
        visible.clear();
        visible.push(f as u32);
        faces[f].visit = stamp;
        faces[f].visible = true;
        let mut k = 0;
        while k < visible.len() {
            let g = visible[k] as usize;
            k += 1;
            for i in 0..3 {
                let h = faces[g].nbr[i] as usize;
                if faces[h].visit != stamp {
                    faces[h].visit = stamp;
                    faces[h].visible = outside(u, &faces[h], p).is_some();
                    if faces[h].visible {
                        visible.push(h as u32);
                    }
                }
            }
        }
        // Horizon edges (u, w) of visible faces with an invisible neighbour h.
        horizon.clear();
        for &g in &visible {
            let g = g as usize;
            for i in 0..3 {
                let h = faces[g].nbr[i] as usize;
                if !faces[h].visible {
                    horizon.push((faces[g].v[i], faces[g].v[(i + 1) % 3], h as u32));
                }
            }
        }
        // Cone from p over the horizon.
        new_faces.clear();
        for &(s, w, h) in &horizon {
            let nf = faces.len() as u32;
            let mut face = HullFace::new([s, w, p]);
            face.nbr[0] = h;
            faces.push(face);
            let hf = &mut faces[h as usize];
            for j in 0..3 {
                if hf.v[j] == w && hf.v[(j + 1) % 3] == s {
                    hf.nbr[j] = nf;
                }
            }
            start_face[s as usize] = nf;
            new_faces.push(nf);
        }
        for &nf in &new_faces {
            let w = faces[nf as usize].v[1];
            let g = start_face[w as usize];
            faces[nf as usize].nbr[1] = g;
            faces[g as usize].nbr[2] = nf;
        }
        // Retire the visible faces and hand their outside points to the cone.
        orphans.clear();
        for &g in &visible {
            let g = g as usize;
            faces[g].alive = false;
            orphans.append(&mut faces[g].pts);
            faces[g].pts.shrink_to_fit();
        }
        for &q in &orphans {
            if q == p {
                continue;
            }
            for &nf in &new_faces {
                if let Some(s) = outside(u, &faces[nf as usize], q) {
                    faces[nf as usize].add_point(q, s);
                    break;
                }
            }
        }
        for &nf in &new_faces {
            if !faces[nf as usize].pts.is_empty() {
                stack.push(nf);
            }
        }
    }

    // Keep the vertices whose incident faces span >= 3 distinct planes.
    let mut count = vec![0u32; u.len() + 1];
    for f in faces.iter().filter(|f| f.alive) {
        for &v in &f.v {
            count[v as usize + 1] += 1;
        }
    }
    for i in 0..u.len() {
        count[i + 1] += count[i];
    }
    let mut fill = count.clone();
    let mut incident = vec![0u32; count[u.len()] as usize];
    for (fi, f) in faces.iter().enumerate().filter(|(_, f)| f.alive) {
        for &v in &f.v {
            incident[fill[v as usize] as usize] = fi as u32;
            fill[v as usize] += 1;
        }
    }
    let coplanar = |f: &HullFace, g: &HullFace| {
        g.v.iter().all(|&w| {
            f.v.contains(&w)
                || orient3d_exact(
                    &u[f.v[0] as usize],
                    &u[f.v[1] as usize],
                    &u[f.v[2] as usize],
                    &u[w as usize],
                ) == 0.0
        })
    };
    for v in 0..u.len() {
        let around = &incident[count[v] as usize..count[v + 1] as usize];
        let mut planes: [usize; 3] = [0; 3];
        let mut np = 0;
        for &g in around {
            let g = g as usize;
            if !planes[..np].iter().any(|&r| coplanar(&faces[r], &faces[g])) {
                planes[np] = g;
                np += 1;
                if np == 3 {
                    ext[v] = true;
                    break;
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Bounding boxes
// ---------------------------------------------------------------------------

/// An axis-aligned bounding box `[min, max]` (closed). The empty box has
/// `min = +inf`, `max = -inf`, so that growing it by a point gives that point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Point3<f64>,
    /// Largest corner.
    pub max: Point3<f64>,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::empty()
    }
}

impl Aabb {
    /// The empty box (`min = +inf`, `max = -inf`): contains nothing, is the
    /// identity of [`Aabb::union`].
    pub fn empty() -> Self {
        Aabb {
            min: Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
            max: Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
        }
    }

    /// Smallest box holding all points: `min_a = min_i p_i,a`,
    /// `max_a = max_i p_i,a`; empty for no points. NaN coordinates are ignored.
    pub fn from_points(points: &[Point3<f64>]) -> Self {
        let mut b = Aabb::empty();
        for p in points {
            b.grow(p);
        }
        b
    }

    /// Whether the box holds no point (`min_a > max_a` on some axis).
    pub fn is_empty(&self) -> bool {
        !(0..3).all(|a| self.min[a] <= self.max[a])
    }

    /// Enlarges the box to hold `p` (NaN coordinates are ignored).
    pub fn grow(&mut self, p: &Point3<f64>) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(p[a]);
            self.max[a] = self.max[a].max(p[a]);
        }
    }

    /// Smallest box holding both boxes.
    pub fn union(&self, other: &Aabb) -> Aabb {
        let mut b = *self;
        for a in 0..3 {
            b.min[a] = b.min[a].min(other.min[a]);
            b.max[a] = b.max[a].max(other.max[a]);
        }
        b
    }

    /// The box grown by `r >= 0` on every side: `[min - r, max + r]`.
    pub fn padded(&self, r: f64) -> Aabb {
        let d = Vector3::repeat(r);
        Aabb {
            min: self.min - d,
            max: self.max + d,
        }
    }

    /// Side lengths `max - min`; zero for the empty box.
    pub fn extent(&self) -> Vector3<f64> {
        if self.is_empty() {
            Vector3::zeros()
        } else {
            self.max - self.min
        }
    }

    /// Centre `(min + max) / 2` (NaN for the empty box).
    pub fn center(&self) -> Point3<f64> {
        Point3::from((self.min.coords + self.max.coords) * 0.5)
    }

    /// Whether `min <= p <= max` on every axis (boundary included).
    #[inline]
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|a| self.min[a] <= p[a] && p[a] <= self.max[a])
    }

    /// Squared Euclidean distance from `p` to the box,
    /// `sum_a max(min_a - p_a, 0, p_a - max_a)^2`; 0 inside, `+inf` for the
    /// empty box.
    #[inline]
    pub fn distance_squared(&self, p: &Point3<f64>) -> f64 {
        let mut d2 = 0.0;
        for a in 0..3 {
            let d = (self.min[a] - p[a]).max(p[a] - self.max[a]).max(0.0);
            d2 += d * d;
        }
        d2
    }

    /// Index (0, 1, 2) of the longest side.
    pub fn longest_axis(&self) -> usize {
        self.extent().imax()
    }
}

/// Bounding box of the points, `None` when there is no (non-NaN) point.
pub fn bounding_box(points: &[Point3<f64>]) -> Option<Aabb> {
    let b = Aabb::from_points(points);
    (!b.is_empty()).then_some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use std::collections::HashMap;

    use crate::topology::test_meshes::SplitMix as Rng;

    /// Flips triangles of a convex, origin-containing surface to face outward.
    fn orient_outward(positions: &[Point3<f64>], tris: &mut [[u32; 3]], center: Point3<f64>) {
        for t in tris.iter_mut() {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let mid = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            if triangle_area_vector(&a, &b, &c).dot(&(mid - center)) < 0.0 {
                t.swap(1, 2);
            }
        }
    }

    fn unit_cube_surface() -> TriMesh {
        let positions: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let quads = [
            [0, 1, 3, 2],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 3, 7, 5],
        ];
        let mut tris: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        orient_outward(&positions, &mut tris, Point3::new(0.5, 0.5, 0.5));
        TriMesh::new(positions, tris)
    }

    /// Subdivided icosahedron on the unit sphere, outward oriented.
    fn icosphere(levels: usize) -> TriMesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut positions: Vec<Point3<f64>> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|p| Point3::from(Vector3::new(p[0], p[1], p[2]).normalize()))
        .collect();
        let mut tris: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
            let mut next = Vec::with_capacity(tris.len() * 4);
            for &[a, b, c] in &tris {
                let mut m = |i: u32, j: u32| {
                    *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                        let p = (positions[i as usize].coords + positions[j as usize].coords)
                            .normalize();
                        positions.push(Point3::from(p));
                        positions.len() as u32 - 1
                    })
                };
                let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            tris = next;
        }
        orient_outward(&positions, &mut tris, Point3::origin());
        TriMesh::new(positions, tris)
    }

    /// The unit cube as 6 positively oriented Kuhn tets.
    fn kuhn_cube() -> TetMesh {
        let positions: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let mut tets = Vec::new();
        for perm in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            let a = 0u32;
            let b = 1u32 << perm[0];
            let c = b | (1 << perm[1]);
            let mut tet = [a, b, c, 7];
            let [p, q, r, s] = tet.map(|i| positions[i as usize]);
            if tet_signed_volume(&p, &q, &r, &s) < 0.0 {
                tet.swap(2, 3);
            }
            tets.push(tet);
        }
        TetMesh::new(positions, tets)
    }

    fn point() -> impl Strategy<Value = Point3<f64>> {
        (-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y, z)| Point3::new(x, y, z))
    }

    fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
            .prop_filter("non-zero quaternion", |q| {
                q.0 * q.0 + q.1 * q.1 + q.2 * q.2 + q.3 * q.3 > 0.05
            })
            .prop_map(|(w, x, y, z)| {
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
                    .to_rotation_matrix()
            })
    }

    // ----- volumes, areas, normals -------------------------------------------

    proptest! {
        /// The exact predicate has the sign of the float signed volume for
        /// well-conditioned tets.
        #[test]
        fn orient3d_exact_matches_signed_volume(a in point(), b in point(), c in point(), d in point()) {
            let v = tet_signed_volume(&a, &b, &c, &d);
            prop_assume!(v.abs() > 1e-6);
            prop_assert_eq!(orient3d_exact(&a, &b, &c, &d) > 0.0, v > 0.0);
            let s2 = triangle_signed_area_2d([a.x, a.y], [b.x, b.y], [c.x, c.y]);
            prop_assume!(s2.abs() > 1e-6);
            prop_assert_eq!(orient2d_exact([a.x, a.y], [b.x, b.y], [c.x, c.y]) > 0.0, s2 > 0.0);
        }

        /// Mirroring the positions (x -> -x) negates every signed tet volume and
        /// the enclosed volume of a surface, and keeps areas.
        #[test]
        fn signed_volumes_flip_under_reflection(pts in prop::collection::vec(point(), 8)) {
            let tets = vec![[0, 1, 2, 3], [4, 5, 6, 7], [0, 2, 4, 6]];
            let mesh = TetMesh::new(pts.clone(), tets);
            let mirrored = TetMesh::new(
                pts.iter().map(|p| Point3::new(-p.x, p.y, p.z)).collect(),
                mesh.tets.clone(),
            );
            for (v, w) in tet_volumes(&mesh).iter().zip(tet_volumes(&mirrored)) {
                prop_assert!((v + w).abs() <= 1e-9 * (1.0 + v.abs()));
            }
            let cube = unit_cube_surface();
            let mut m = cube.clone();
            for p in &mut m.positions { p.x = -p.x; }
            prop_assert!((enclosed_volume(&m) + 1.0).abs() < 1e-12);
            prop_assert!((total_area(&m) - 6.0).abs() < 1e-12);
        }

        /// The divergence-theorem volume of a closed surface does not depend on
        /// where it sits.
        #[test]
        fn enclosed_volume_is_translation_invariant(t in point()) {
            let mut cube = unit_cube_surface();
            for p in &mut cube.positions { *p += t.coords; }
            prop_assert!((enclosed_volume(&cube) - 1.0).abs() < 1e-12);
            let c = area_weighted_centroid(&cube).unwrap();
            prop_assert!((c - (Point3::new(0.5, 0.5, 0.5) + t.coords)).norm() < 1e-12);
        }
    }

    #[test]
    fn cube_measures() {
        let cube = unit_cube_surface();
        assert_relative_eq!(enclosed_volume(&cube), 1.0, epsilon = 1e-14);
        assert_relative_eq!(total_area(&cube), 6.0, epsilon = 1e-14);
        assert_eq!(triangle_areas(&cube), vec![0.5; 12]);
        let tets = kuhn_cube();
        assert_eq!(tets.tets.len(), 6);
        for v in tet_volumes(&tets) {
            assert_relative_eq!(v, 1.0 / 6.0, epsilon = 1e-15);
        }
        assert_relative_eq!(total_volume(&tets), 1.0, epsilon = 1e-14);
        let vv = tet_vertex_volumes(&tets);
        assert_relative_eq!(vv.iter().sum::<f64>(), 1.0, epsilon = 1e-14);
        // Vertices 0 and 7 are in all six tets.
        assert_relative_eq!(vv[0], 0.25, epsilon = 1e-15);
        assert_relative_eq!(vv[7], 0.25, epsilon = 1e-15);
        // Inverted tets still contribute their unsigned volume.
        let mut inv = tets.clone();
        inv.tets[0].swap(0, 1);
        assert_relative_eq!(total_volume(&inv), 4.0 / 6.0, epsilon = 1e-14);
        assert_relative_eq!(
            tet_vertex_volumes(&inv).iter().sum::<f64>(),
            1.0,
            epsilon = 1e-14
        );
        let c = centroid(&cube.positions).unwrap();
        assert_relative_eq!(c, Point3::new(0.5, 0.5, 0.5), epsilon = 1e-15);
        assert_eq!(centroid(&[]), None);
        assert_eq!(area_weighted_centroid(&TriMesh::default()), None);
    }

    #[test]
    fn sphere_normals_areas_and_volume() {
        let s = icosphere(4);
        let normals = vertex_normals(&s);
        for (p, n) in s.positions.iter().zip(&normals) {
            assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-12);
            assert!(n.dot(&p.coords) > 0.999, "normal {n:?} at {p:?}");
        }
        let areas = vertex_areas(&s);
        assert_relative_eq!(
            areas.iter().sum::<f64>(),
            total_area(&s),
            max_relative = 1e-12
        );
        let pi = std::f64::consts::PI;
        assert_relative_eq!(total_area(&s), 4.0 * pi, max_relative = 1e-2);
        assert_relative_eq!(enclosed_volume(&s), 4.0 / 3.0 * pi, max_relative = 2e-2);
        assert!(enclosed_volume(&s) < 4.0 / 3.0 * pi);
        // Inward orientation gives a negative volume.
        let mut inward = s.clone();
        inward.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert_relative_eq!(
            enclosed_volume(&inward),
            -enclosed_volume(&s),
            epsilon = 1e-12
        );
        let c = area_weighted_centroid(&s).unwrap();
        assert!(c.coords.norm() < 1e-12);
    }

    #[test]
    fn isolated_vertices_get_zero() {
        let mut cube = unit_cube_surface();
        cube.positions.push(Point3::new(5.0, 5.0, 5.0));
        let n = vertex_normals(&cube);
        assert_eq!(n[8], Vector3::zeros());
        assert_relative_eq!(n[0], -Vector3::repeat(1.0).normalize(), epsilon = 1e-12);
        assert_eq!(vertex_areas(&cube)[8], 0.0);
        assert!(vertex_normals(&TriMesh::default()).is_empty());
    }

    // ----- PCA ---------------------------------------------------------------

    fn cloud(
        seed: u64,
        n: usize,
        sigma: [f64; 3],
        rot: &Rotation3<f64>,
        shift: Vector3<f64>,
    ) -> Vec<Point3<f64>> {
        let mut rng = Rng(seed);
        (0..n)
            .map(|_| {
                let z = Vector3::new(
                    sigma[0] * rng.gaussian(),
                    sigma[1] * rng.gaussian(),
                    sigma[2] * rng.gaussian(),
                );
                Point3::from(rot * z + shift)
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Always a proper rotation with orthonormal rows, sorted variances and
        /// the documented sign convention.
        #[test]
        fn pca_frame_is_proper_and_sorted(
            seed in any::<u64>(), n in 1usize..200,
            s0 in 0.0..5.0f64, s1 in 0.0..5.0f64, s2 in 0.0..5.0f64,
            rot in rotation(), shift in point(),
        ) {
            let pts = cloud(seed, n, [s0, s1, s2], &rot, shift.coords);
            let f = pca_frame(&pts).unwrap();
            let m = f.rotation.matrix();
            prop_assert!((m.determinant() - 1.0).abs() < 1e-12);
            prop_assert!((m * m.transpose() - Matrix3::identity()).norm() < 1e-12);
            prop_assert!(f.variances[0] >= f.variances[1] && f.variances[1] >= f.variances[2]);
            prop_assert!(f.variances[2] >= 0.0);
            for i in 0..2 {
                let a = f.axis(i);
                prop_assert!(a[a.iamax()] > 0.0);
            }
            // Local coordinates have the variances on x, y, z and zero mean.
            let local: Vec<_> = pts.iter().map(|p| f.to_local(p)).collect();
            let scale = 1.0 + f.variances[0];
            for a in 0..3 {
                let mean = local.iter().map(|q| q[a]).sum::<f64>() / n as f64;
                let var = local.iter().map(|q| q[a] * q[a]).sum::<f64>() / n as f64;
                prop_assert!(mean.abs() < 1e-9 * (1.0 + shift.coords.norm()));
                prop_assert!((var - f.variances[a]).abs() < 1e-9 * scale);
            }
            prop_assert!((f.to_world(&local[0]) - pts[0]).norm() < 1e-9 * (1.0 + shift.coords.norm()));
        }

        /// Well-separated variances: the axes are the generating ones up to
        /// sign, the variances close to sigma^2.
        #[test]
        fn pca_recovers_generating_axes(
            seed in any::<u64>(), s0 in 3.0..5.0f64, r1 in 0.25..0.5f64, r2 in 0.25..0.5f64,
            rot in rotation(), shift in point(),
        ) {
            let sigma = [s0, s0 * r1, s0 * r1 * r2];
            let pts = cloud(seed, 4000, sigma, &rot, shift.coords);
            let f = pca_frame(&pts).unwrap();
            for (i, s) in sigma.iter().enumerate() {
                let truth = rot.matrix().column(i).into_owned();
                prop_assert!(f.axis(i).dot(&truth).abs() > 0.98, "axis {} off", i);
                prop_assert!((f.variances[i] / (s * s) - 1.0).abs() < 0.15);
            }
        }

        /// Rigid motions change neither the variances nor (up to the motion)
        /// the centroid.
        #[test]
        fn pca_variances_invariant_under_rigid_motion(
            seed in any::<u64>(), s0 in 0.1..5.0f64, s1 in 0.1..5.0f64, s2 in 0.1..5.0f64,
            rot in rotation(), motion in rotation(), t in point(),
        ) {
            let pts = cloud(seed, 300, [s0, s1, s2], &rot, Vector3::zeros());
            let moved: Vec<_> = pts.iter().map(|p| motion * p + t.coords).collect();
            let (f, g) = (pca_frame(&pts).unwrap(), pca_frame(&moved).unwrap());
            for k in 0..3 {
                prop_assert!((f.variances[k] - g.variances[k]).abs() < 1e-9 * (1.0 + f.variances[0]));
            }
            prop_assert!((motion * f.centroid + t.coords - g.centroid).norm() < 1e-9);
        }
    }

    #[test]
    fn pca_degenerate_inputs() {
        assert!(pca_frame(&[]).is_none());
        assert!(pca_frame(&[Point3::new(f64::NAN, 0.0, 0.0)]).is_none());
        let one = pca_frame(&[Point3::new(1.0, 2.0, 3.0)]).unwrap();
        assert_eq!(one.variances, [0.0; 3]);
        assert_relative_eq!(one.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
        // Points on a line along y: first axis is +y.
        let line: Vec<_> = (0..10).map(|i| Point3::new(1.0, i as f64, 2.0)).collect();
        let f = pca_frame(&line).unwrap();
        assert_relative_eq!(f.axis(0), Vector3::y(), epsilon = 1e-12);
        assert_relative_eq!(f.variances[0], 8.25, epsilon = 1e-12);
        assert!(f.variances[1].abs() < 1e-12);
        assert_relative_eq!(f.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
    }

    // ----- convex hull -------------------------------------------------------

    fn in_segment(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> bool {
        collinear_exact(a, b, p) && (p - a).dot(&(b - a)) >= 0.0 && (p - b).dot(&(a - b)) >= 0.0
    }

    fn in_triangle(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> bool {
        if collinear_exact(a, b, c) || orient3d_exact(a, b, c, p) != 0.0 {
            return false;
        }
        let k = (0..3)
            .find(|&k| orient2d_exact(project(a, k), project(b, k), project(c, k)) != 0.0)
            .unwrap();
        let [a, b, c, p] = [a, b, c, p].map(|q| project(q, k));
        let o = orient2d_exact(a, b, c);
        [
            orient2d_exact(a, b, p),
            orient2d_exact(b, c, p),
            orient2d_exact(c, a, p),
        ]
        .iter()
        .all(|s| s * o >= 0.0)
    }

    fn in_tet(p: &Point3<f64>, t: [&Point3<f64>; 4]) -> bool {
        let o = orient3d_exact(t[0], t[1], t[2], t[3]);
        o != 0.0
            && (0..4).all(|i| {
                let mut q = t;
                q[i] = p;
                orient3d_exact(q[0], q[1], q[2], q[3]) * o >= 0.0
            })
    }

    /// Extreme points by Carathéodory: `p` is not a corner iff it lies in a
    /// closed non-degenerate segment, triangle or tet of the other points.
    fn brute_extreme(points: &[Point3<f64>]) -> Vec<bool> {
        let mut uniq: Vec<Point3<f64>> = Vec::new();
        for p in points {
            if !uniq.contains(p) {
                uniq.push(*p);
            }
        }
        let ext: Vec<bool> = (0..uniq.len())
            .map(|i| {
                let p = &uniq[i];
                let s: Vec<&Point3<f64>> = uniq
                    .iter()
                    .enumerate()
                    .filter(|e| e.0 != i)
                    .map(|e| e.1)
                    .collect();
                let m = s.len();
                for a in 0..m {
                    for b in a + 1..m {
                        if in_segment(p, s[a], s[b]) {
                            return false;
                        }
                        for c in b + 1..m {
                            if in_triangle(p, s[a], s[b], s[c]) {
                                return false;
                            }
                            for d in c + 1..m {
                                if in_tet(p, [s[a], s[b], s[c], s[d]]) {
                                    return false;
                                }
                            }
                        }
                    }
                }
                true
            })
            .collect();
        points
            .iter()
            .map(|p| ext[uniq.iter().position(|q| q == p).unwrap()])
            .collect()
    }

    fn fibonacci_sphere(n: usize, r: f64, c: Vector3<f64>) -> Vec<Point3<f64>> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let rho = (1.0 - z * z).sqrt();
                let th = golden * i as f64;
                Point3::from(Vector3::new(rho * th.cos(), rho * th.sin(), z) * r + c)
            })
            .collect()
    }

    #[test]
    fn hull_sphere_points_are_all_on_hull() {
        let mut pts = fibonacci_sphere(2000, 3.0, Vector3::new(1.0, -2.0, 0.5));
        let n = pts.len();
        // Interior points are not.
        let mut rng = Rng(7);
        for _ in 0..500 {
            let d = Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()).normalize();
            pts.push(Point3::from(
                d * 2.9 * rng.f64() + Vector3::new(1.0, -2.0, 0.5),
            ));
        }
        let on = convex_hull_vertices(&pts);
        assert!(on[..n].iter().all(|&b| b));
        assert!(on[n..].iter().all(|&b| !b));
    }

    #[test]
    fn hull_cube_interior_faces_and_corners() {
        let mut pts: Vec<Point3<f64>> = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                for k in 0..5 {
                    pts.push(Point3::new(i as f64, j as f64, k as f64) * 0.25);
                }
            }
        }
        let on = convex_hull_vertices(&pts);
        for (p, &b) in pts.iter().zip(&on) {
            let corner = p.coords.iter().all(|&x| x == 0.0 || x == 1.0);
            assert_eq!(b, corner, "{p:?}");
        }
        // Duplicated corners are all marked; shuffled order does not matter.
        let mut dup = pts.clone();
        dup.extend_from_slice(&pts);
        dup.reverse();
        let on2 = convex_hull_vertices(&dup);
        assert_eq!(on2.iter().filter(|&&b| b).count(), 16);
    }

    #[test]
    fn hull_degenerate_inputs() {
        assert!(convex_hull_vertices(&[]).is_empty());
        let p = Point3::new(1.0, 2.0, 3.0);
        assert_eq!(convex_hull_vertices(&[p]), vec![true]);
        assert_eq!(convex_hull_vertices(&[p, p, p]), vec![true; 3]);
        let q = Point3::new(-1.0, 0.0, 3.0);
        assert_eq!(convex_hull_vertices(&[p, q]), vec![true, true]);
        // -0.0 and 0.0 are the same point.
        let z = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(-0.0, 0.0, -0.0),
            Point3::new(1.0, 0.0, 0.0),
        ];
        assert_eq!(convex_hull_vertices(&z), vec![true, true, true]);
        // Collinear: only the end points.
        let line: Vec<_> = (0..7)
            .map(|i| Point3::new(3.0 - i as f64, 2.0 * i as f64, 1.0))
            .collect();
        let on = convex_hull_vertices(&line);
        assert_eq!(on, vec![true, false, false, false, false, false, true]);
        // Coplanar (tilted plane): corners of the polygon only.
        let mut plane = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let (u, v) = (i as f64, j as f64);
                plane.push(Point3::new(u, v, 0.5 * u - 2.0 * v));
            }
        }
        let on = convex_hull_vertices(&plane);
        assert_eq!(on, brute_extreme(&plane));
        assert_eq!(on.iter().filter(|&&b| b).count(), 4);
        // Triangle plus collinear points on its edge.
        let tri = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(4.0, 0.0, 0.0),
            Point3::new(0.0, 4.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(2.0, 2.0, 0.0),
        ];
        assert_eq!(
            convex_hull_vertices(&tri),
            vec![true, true, true, false, false]
        );
        // NaN and infinite points are ignored.
        let mut bad = fibonacci_sphere(50, 1.0, Vector3::zeros());
        bad.push(Point3::new(f64::NAN, 0.0, 0.0));
        bad.push(Point3::new(f64::INFINITY, 0.0, 0.0));
        let on = convex_hull_vertices(&bad);
        assert!(on[..50].iter().all(|&b| b));
        assert!(!on[50] && !on[51]);
        // Tiny and huge coordinates.
        let tiny: Vec<_> = fibonacci_sphere(100, 1e-300, Vector3::zeros());
        assert!(convex_hull_vertices(&tiny).iter().all(|&b| b));
        let huge: Vec<_> = fibonacci_sphere(100, 1e300, Vector3::zeros());
        assert!(convex_hull_vertices(&huge).iter().all(|&b| b));
    }

    #[test]
    fn hull_is_fast_for_10k_points() {
        let mut rng = Rng(3);
        let mut pts = fibonacci_sphere(10_000, 1.0, Vector3::zeros());
        while pts.len() < 20_000 {
            let d = Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()) * 0.4;
            if d.norm() < 0.99 {
                pts.push(Point3::from(d));
            }
        }
        let t = std::time::Instant::now();
        let on = convex_hull_vertices(&pts);
        let el = t.elapsed();
        assert!(on[..10_000].iter().all(|&b| b));
        assert!(on[10_000..].iter().all(|&b| !b));
        assert!(el.as_secs_f64() < 5.0, "{el:?}");
        // Lattice with heavy degeneracy.
        let mut grid = Vec::new();
        for i in 0..22 {
            for j in 0..22 {
                for k in 0..22 {
                    grid.push(Point3::new(i as f64, j as f64, k as f64));
                }
            }
        }
        let on = convex_hull_vertices(&grid);
        assert_eq!(on.iter().filter(|&&b| b).count(), 8);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Small-integer sets (many coplanar / collinear / repeated points)
        /// against the brute-force corner test.
        #[test]
        fn hull_matches_brute_force_on_lattice(
            pts in prop::collection::vec((0..4i32, 0..4i32, 0..3i32), 0..11)
        ) {
            let pts: Vec<_> = pts.iter().map(|&(x, y, z)| Point3::new(x as f64, y as f64, z as f64)).collect();
            prop_assert_eq!(convex_hull_vertices(&pts), brute_extreme(&pts));
        }

        /// Coplanar and collinear lattice subsets in a tilted plane.
        #[test]
        fn hull_matches_brute_force_in_a_plane(
            pts in prop::collection::vec((0..5i32, 0..5i32), 0..12), flat in any::<bool>()
        ) {
            let pts: Vec<_> = pts.iter().map(|&(u, v)| {
                let (u, v) = (u as f64, v as f64);
                if flat { Point3::new(u + v, 2.0 * u + 2.0 * v, 1.0 - u - v + v) } else { Point3::new(u, v, 3.0 * u - v) }
            }).collect();
            prop_assert_eq!(convex_hull_vertices(&pts), brute_extreme(&pts));
        }

        /// Random real coordinates (general position).
        #[test]
        fn hull_matches_brute_force_random(pts in prop::collection::vec(point(), 0..12)) {
            prop_assert_eq!(convex_hull_vertices(&pts), brute_extreme(&pts));
        }
    }

    // ----- bounding boxes ----------------------------------------------------

    #[test]
    fn aabb_basics() {
        let e = Aabb::empty();
        assert!(e.is_empty());
        assert_eq!(e.extent(), Vector3::zeros());
        assert_eq!(e.distance_squared(&Point3::origin()), f64::INFINITY);
        assert!(!e.contains(&Point3::origin()));
        assert_eq!(bounding_box(&[]), None);
        let pts = [Point3::new(1.0, -1.0, 2.0), Point3::new(-1.0, 3.0, 2.5)];
        let b = bounding_box(&pts).unwrap();
        assert_eq!(b.min, Point3::new(-1.0, -1.0, 2.0));
        assert_eq!(b.max, Point3::new(1.0, 3.0, 2.5));
        assert_eq!(b.extent(), Vector3::new(2.0, 4.0, 0.5));
        assert_eq!(b.center(), Point3::new(0.0, 1.0, 2.25));
        assert_eq!(b.longest_axis(), 1);
        assert!(b.contains(&pts[0]) && b.contains(&b.center()));
        assert!(!b.contains(&Point3::new(0.0, 0.0, 3.0)));
        assert_eq!(b.distance_squared(&Point3::new(0.0, 0.0, 2.1)), 0.0);
        assert_relative_eq!(b.distance_squared(&Point3::new(2.0, 5.0, 2.0)), 5.0);
        assert_eq!(e.union(&b), b);
        let mut g = b;
        g.grow(&Point3::new(0.0, 0.0, 10.0));
        assert_eq!(g.max.z, 10.0);
        assert_eq!(
            b.union(&Aabb::from_points(&[Point3::new(0.0, 0.0, 10.0)])),
            g
        );
        assert_eq!(Aabb::from_points(&pts), b);
        assert!(b.padded(1.0).contains(&Point3::new(2.0, 4.0, 3.5)));
    }
}
