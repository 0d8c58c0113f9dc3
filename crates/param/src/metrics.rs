//! Distortion metrics of a map (ALGORITHMS 2.6 and 4.4): per element, per
//! edge, per vertex and per boundary triangle, and [`Summary`] statistics.
//!
//! Every per-element function takes the rest mesh (a [`ParamMesh`]) and the
//! mapped positions `x`, flat with `mesh.dim()` coordinates per vertex (3
//! for tets, 2 for triangles mapped to the plane), and returns one value per
//! element in element order. The Jacobian is `J = Ds Dm^-1`
//! (ALGORITHMS 1.1); an element is *inverted* when `det J <= 0`.
//!
//! # Panics
//! Every function taking `(mesh, x)` panics when
//! `x.len() != mesh.dim() * mesh.num_vertices()`.

use crate::template::{Template, weighted_value};
use crate::{ParamMesh, RestElements};
use nalgebra::{Matrix2, Matrix3, Point3, Vector2, Vector3};
use rayon::prelude::*;

// ---------------------------------------------------------------------------
// Summary statistics

/// [`Summary`] and [`percentile_sorted`] live in [`unfold_mesh::stats`] (one
/// home for summary statistics); re-exported here, where the distortion
/// metrics they summarize are.
pub use unfold_mesh::stats::{Summary, percentile_sorted};

// ---------------------------------------------------------------------------
// Jacobians

/// The element Jacobians `J_k = Ds_k Dm_k^-1` of a map (ALGORITHMS 1.1).
#[derive(Debug, Clone, PartialEq)]
pub enum Jacobians {
    /// 3x3 per tet.
    Tets(Vec<Matrix3<f64>>),
    /// 2x2 per triangle (rest triangle in its local orthonormal frame).
    Tris(Vec<Matrix2<f64>>),
}

impl Jacobians {
    /// Number of elements.
    pub fn len(&self) -> usize {
        match self {
            Jacobians::Tets(j) => j.len(),
            Jacobians::Tris(j) => j.len(),
        }
    }

    /// Whether there are no elements.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `det J` per element.
    pub fn determinants(&self) -> Vec<f64> {
        match self {
            Jacobians::Tets(j) => j.iter().map(|j| j.determinant()).collect(),
            Jacobians::Tris(j) => j.iter().map(|j| j.determinant()).collect(),
        }
    }
}

/// One element's Jacobian.
#[derive(Clone, Copy)]
enum Jac {
    D3(Matrix3<f64>),
    D2(Matrix2<f64>),
}

impl Jac {
    fn det(&self) -> f64 {
        match self {
            Jac::D3(j) => j.determinant(),
            Jac::D2(j) => j.determinant(),
        }
    }

    /// `|J|_F^2`.
    fn fro2(&self) -> f64 {
        match self {
            Jac::D3(j) => j.norm_squared(),
            Jac::D2(j) => j.norm_squared(),
        }
    }

    /// `|J^-1|_F^2`, `None` when `det J <= 0` (or not invertible).
    fn inv_fro2(&self) -> Option<f64> {
        if self.det() <= 0.0 {
            return None;
        }
        match self {
            Jac::D3(j) => j.try_inverse().map(|i| i.norm_squared()),
            Jac::D2(j) => j.try_inverse().map(|i| i.norm_squared()),
        }
    }
}

fn check_x(mesh: &ParamMesh, x: &[f64]) {
    assert_eq!(
        x.len(),
        mesh.dim() * mesh.num_vertices(),
        "mapped positions: expected {} values ({} per vertex), got {}",
        mesh.dim() * mesh.num_vertices(),
        mesh.dim(),
        x.len()
    );
}

#[inline]
fn jac3(x: &[f64], t: &[u32; 4], dm_inv: &Matrix3<f64>) -> Matrix3<f64> {
    let p = |i: u32| {
        let i = 3 * i as usize;
        Vector3::new(x[i], x[i + 1], x[i + 2])
    };
    let x0 = p(t[0]);
    Matrix3::from_columns(&[p(t[1]) - x0, p(t[2]) - x0, p(t[3]) - x0]) * dm_inv
}

#[inline]
fn jac2(x: &[f64], t: &[u32; 3], dm_inv: &Matrix2<f64>) -> Matrix2<f64> {
    let p = |i: u32| {
        let i = 2 * i as usize;
        Vector2::new(x[i], x[i + 1])
    };
    let x0 = p(t[0]);
    Matrix2::from_columns(&[p(t[1]) - x0, p(t[2]) - x0]) * dm_inv
}

/// `f(J_k)` for every element, in parallel.
fn map_elements<F>(mesh: &ParamMesh, x: &[f64], f: F) -> Vec<f64>
where
    F: Fn(Jac) -> f64 + Sync + Send,
{
    check_x(mesh, x);
    match &mesh.elements {
        RestElements::Tets { tets, dm_inv } => tets
            .par_iter()
            .zip(dm_inv.par_iter())
            .map(|(t, d)| f(Jac::D3(jac3(x, t, d))))
            .collect(),
        RestElements::Tris { tris, dm_inv } => tris
            .par_iter()
            .zip(dm_inv.par_iter())
            .map(|(t, d)| f(Jac::D2(jac2(x, t, d))))
            .collect(),
    }
}

/// The Jacobian `J_k = Ds_k Dm_k^-1` of every element (ALGORITHMS 1.1):
/// 3x3 for tets, 2x2 for triangles mapped to the plane.
pub fn jacobians(mesh: &ParamMesh, x: &[f64]) -> Jacobians {
    check_x(mesh, x);
    match &mesh.elements {
        RestElements::Tets { tets, dm_inv } => Jacobians::Tets(
            tets.par_iter()
                .zip(dm_inv.par_iter())
                .map(|(t, d)| jac3(x, t, d))
                .collect(),
        ),
        RestElements::Tris { tris, dm_inv } => Jacobians::Tris(
            tris.par_iter()
                .zip(dm_inv.par_iter())
                .map(|(t, d)| jac2(x, t, d))
                .collect(),
        ),
    }
}

/// `det J_k` per element: the ratio of mapped to rest volume (tets) or area
/// (triangles), negative for inverted elements.
pub fn det_j(mesh: &ParamMesh, x: &[f64]) -> Vec<f64> {
    map_elements(mesh, x, |j| j.det())
}

// ---------------------------------------------------------------------------
// Per element

/// Volumetric distortion `log2 det J_k` per element (ALGORITHMS 2.6): 0 for
/// a volume-preserving map, 1 where the volume doubles, -1 where it halves
/// (for triangles: the area ratio). `-inf` for inverted or flat elements
/// (`det J <= 0`, see [`inverted_count`]).
pub fn log2_det_j(mesh: &ParamMesh, x: &[f64]) -> Vec<f64> {
    map_elements(mesh, x, |j| {
        let d = j.det();
        if d > 0.0 { d.log2() } else { f64::NEG_INFINITY }
    })
}

/// Symmetric Dirichlet energy per element (ALGORITHMS 1.2):
/// `D = |J|_F^2 + |J^-1|_F^2 = sum_i s_i^2 + s_i^-2`, minimum `2 dim`
/// (6 for tets, 4 for triangles) at rotations; `+inf` when `det J <= 0`.
pub fn symmetric_dirichlet(mesh: &ParamMesh, x: &[f64]) -> Vec<f64> {
    map_elements(mesh, x, |j| match j.inv_fro2() {
        Some(inv) => j.fro2() + inv,
        None => f64::INFINITY,
    })
}

/// Dirichlet excess in percent (ALGORITHMS 2.6):
///
/// ```text
/// (sum_k V_k D(J_k) - 2 dim) / (2 dim) * 100
/// ```
///
/// with `V_k` the normalized rest measures (`mesh.weight`, sum 1), `D` the
/// symmetric Dirichlet energy and `2 dim` its minimum (6 for tets: the
/// paper's `(E - 6)/6`; 4 for triangles). 0 for a rigid map; `+inf` when an
/// element is inverted.
pub fn dirichlet_excess_percent(mesh: &ParamMesh, x: &[f64]) -> f64 {
    let d = symmetric_dirichlet(mesh, x);
    let e: f64 = d.iter().zip(&mesh.weight).map(|(d, w)| w * d).sum();
    let min = 2.0 * mesh.dim() as f64;
    (e - min) / min * 100.0
}

/// MIPS (conformal / angle distortion) of a triangle mapped to the plane
/// (ALGORITHMS 1.2): `s1/s2 + s2/s1 = |J|_F^2 / det J`, minimum 2 at
/// similarities, `+inf` when `det J <= 0`. `None` for a tet mesh. Equal to
/// [`angle_energy`] (the same quantity from the cotangent formula).
pub fn mips_2d(mesh: &ParamMesh, x: &[f64]) -> Option<Vec<f64>> {
    match mesh.elements {
        RestElements::Tris { .. } => Some(map_elements(mesh, x, |j| {
            let d = j.det();
            if d > 0.0 { j.fro2() / d } else { f64::INFINITY }
        })),
        RestElements::Tets { .. } => None,
    }
}

/// Area energy per element (ALGORITHMS 4.4): `E_A = A/Â + Â/A` with `A` the
/// mapped and `Â` the rest area, i.e. `det J + 1/det J`; minimum 2 where the
/// area is kept, `+inf` when `det J <= 0`. For tets the same with volumes.
/// (ALGORITHMS 4.4 colours it white at <= 2, blue/red at >= 3, shrunk where
/// `det J < 1`.)
pub fn area_energy(mesh: &ParamMesh, x: &[f64]) -> Vec<f64> {
    map_elements(mesh, x, |j| {
        let d = j.det();
        if d > 0.0 { d + 1.0 / d } else { f64::INFINITY }
    })
}

/// Angle energy of a triangle mapped to the plane (ALGORITHMS 4.4, the MIPS
/// energy in its cotangent form):
///
/// ```text
/// E_M = (cot a |a'|^2 + cot b |b'|^2 + cot c |c'|^2) / (2 A')
/// ```
///
/// with `a, b, c` the angles of the rest (3D) triangle, `a', b', c'` the
/// mapped edges opposite them and `A'` the signed mapped area. Minimum 2 at
/// similarities; `+inf` when `A' <= 0`. `None` for a tet mesh.
pub fn angle_energy(mesh: &ParamMesh, x: &[f64]) -> Option<Vec<f64>> {
    let RestElements::Tris { tris, .. } = &mesh.elements else {
        return None;
    };
    check_x(mesh, x);
    let rest = &mesh.rest;
    Some(
        tris.par_iter()
            .map(|t| {
                let p = t.map(|i| rest[i as usize]);
                let q = t.map(|i| Vector2::new(x[2 * i as usize], x[2 * i as usize + 1]));
                let area2 = (q[1] - q[0]).perp(&(q[2] - q[0]));
                if area2 <= 0.0 {
                    return f64::INFINITY;
                }
                let mut sum = 0.0;
                for c in 0..3 {
                    let (i, j) = ((c + 1) % 3, (c + 2) % 3);
                    let (e1, e2) = (p[i] - p[c], p[j] - p[c]);
                    let cot = e1.dot(&e2) / e1.cross(&e2).norm();
                    sum += cot * (q[j] - q[i]).norm_squared();
                }
                // 2 A' = area2.
                sum / area2
            })
            .collect(),
    )
}

/// Length energy per vertex (ALGORITHMS 4.4):
///
/// ```text
/// E_l(i) = 1/|N_i| sum_{j in N_i} (|q_i - q_j| / |p_i - p_j| + |p_i - p_j| / |q_i - q_j|)
/// ```
///
/// over the edge neighbours `N_i` of vertex `i` in the elements, `p` rest
/// (3D) and `q` mapped positions. Minimum 2 where every incident edge keeps
/// its length; `+inf` where a mapped edge has zero length; NaN for a vertex
/// in no element (filter before [`Summary::of`]). Works for triangles and
/// tets.
pub fn length_energy(mesh: &ParamMesh, x: &[f64]) -> Vec<f64> {
    check_x(mesh, x);
    let dim = mesh.dim();
    let mut sum = vec![0.0; mesh.num_vertices()];
    let mut count = vec![0usize; mesh.num_vertices()];
    for [i, j] in unique_edges(mesh) {
        let (i, j) = (i as usize, j as usize);
        let rest = (mesh.rest[i] - mesh.rest[j]).norm();
        let mapped = mapped_distance(x, dim, i, j);
        let ratio = mapped / rest;
        let e = ratio + 1.0 / ratio;
        for v in [i, j] {
            sum[v] += e;
            count[v] += 1;
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| if c == 0 { f64::NAN } else { s / c as f64 })
        .collect()
}

/// Number of inverted (or flat) elements, `det J <= 0`. Must be 0 for a
/// valid map (ALGORITHMS 2.6).
pub fn inverted_count(mesh: &ParamMesh, x: &[f64]) -> usize {
    det_j(mesh, x).iter().filter(|&&d| d <= 0.0).count()
}

/// Folded interior faces (tets) or edges (triangles in the plane) of the
/// map `x`: the two elements sharing the face or edge lie on the same side
/// of it ([`unfold_mesh::geometry::folded_faces`],
/// [`unfold_mesh::geometry::folded_edges`]). In a consistently oriented
/// mesh a face can only fold where one of its elements is inverted, so with
/// [`inverted_count`] 0 this is 0 too; it counts what orientation alone
/// misses where the elements' orientation is not trusted (a reoriented
/// input). Locally injective maps can still overlap globally: see
/// [`unfold_mesh::geometry::tet_boundary_self_intersections`] and
/// [`unfold_mesh::geometry::boundary_edge_crossings`].
pub fn folded_count(mesh: &ParamMesh, x: &[f64]) -> usize {
    check_x(mesh, x);
    match &mesh.elements {
        RestElements::Tets { tets, .. } => {
            let mapped = x
                .chunks_exact(3)
                .map(|c| Point3::new(c[0], c[1], c[2]))
                .collect();
            unfold_mesh::geometry::folded_faces(&unfold_mesh::TetMesh::new(mapped, tets.clone()))
                .len()
        }
        RestElements::Tris { tris, .. } => {
            let uv: Vec<[f64; 2]> = x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
            unfold_mesh::geometry::folded_edges(&uv, tris).len()
        }
    }
}

/// `min_k det J_k` (ALGORITHMS 2.6); positive for a valid map.
pub fn min_det_j(mesh: &ParamMesh, x: &[f64]) -> f64 {
    det_j(mesh, x).into_iter().fold(f64::INFINITY, f64::min)
}

// ---------------------------------------------------------------------------
// Per edge

/// The unique edges `[i, j]` (`i < j`) of the elements of `mesh` (6 per tet,
/// 3 per triangle, shared ones once), sorted; the order of
/// [`log2_edge_ratio`].
pub fn unique_edges(mesh: &ParamMesh) -> Vec<[u32; 2]> {
    let mut edges: Vec<[u32; 2]> = Vec::new();
    let mut push = |a: u32, b: u32| edges.push([a.min(b), a.max(b)]);
    match &mesh.elements {
        RestElements::Tets { tets, .. } => {
            for t in tets {
                for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                    push(t[a], t[b]);
                }
            }
        }
        RestElements::Tris { tris, .. } => {
            for t in tris {
                for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                    push(t[a], t[b]);
                }
            }
        }
    }
    unfold_mesh::topology::sort_dedup_pairs(&mut edges);
    edges
}

fn mapped_distance(x: &[f64], dim: usize, i: usize, j: usize) -> f64 {
    (0..dim)
        .map(|c| (x[dim * i + c] - x[dim * j + c]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Metric distortion per edge (ALGORITHMS 2.6):
/// `log2(|x_i - x_j| / |z_i - z_j|)` over [`unique_edges`] (in that order),
/// `x` mapped and `z` rest positions; for triangles mapped to the plane the
/// rest length is the 3D length. 0 where the length is kept, 1 where it
/// doubles; `-inf` for a collapsed mapped edge.
pub fn log2_edge_ratio(mesh: &ParamMesh, x: &[f64]) -> Vec<f64> {
    check_x(mesh, x);
    let dim = mesh.dim();
    unique_edges(mesh)
        .par_iter()
        .map(|&[i, j]| {
            let (i, j) = (i as usize, j as usize);
            (mapped_distance(x, dim, i, j) / (mesh.rest[i] - mesh.rest[j]).norm()).log2()
        })
        .collect()
}

// ---------------------------------------------------------------------------
// Per boundary triangle

/// Area distortion per (boundary) triangle (ALGORITHMS 2.6):
/// `log2(area(mapped) / area(rest))` with unsigned 3D areas. `-inf` where
/// the mapped triangle is degenerate.
///
/// # Panics
/// If a triangle index is out of range of `rest` or `mapped`.
pub fn log2_area_ratio(
    rest: &[Point3<f64>],
    mapped: &[Point3<f64>],
    tris: &[[u32; 3]],
) -> Vec<f64> {
    let area = |p: &[Point3<f64>], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(&(c - a)).norm()
    };
    tris.par_iter()
        .map(|t| (area(mapped, t) / area(rest, t)).log2())
        .collect()
}

// ---------------------------------------------------------------------------
// Template fit

/// Template matching error (ALGORITHMS 2.6): `sqrt(sum_m w_m T(x_m, theta))`
/// with `w_m` the normalized boundary vertex areas (sum 1), in the units of
/// the positions (mm); divide by the voxel size for voxels.
///
/// # Panics
/// If `labels`, `weights` and `xs` (`dim` per vertex) differ in vertex
/// count.
pub fn template_matching_error<T: Template + ?Sized>(
    template: &T,
    labels: &[u8],
    xs: &[f64],
    dim: usize,
    weights: &[f64],
    theta: &[f64],
) -> f64 {
    weighted_value(template, labels, xs, dim, weights, theta)
        .max(0.0)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::template::PointTargets;
    use nalgebra::Rotation3;
    use proptest::prelude::*;
    use unfold_mesh::shapes::{grid_disk, kuhn_grid};
    use unfold_mesh::{TetMesh, TriMesh};

    fn tet_mesh() -> ParamMesh {
        ParamMesh::from_tets(&kuhn_grid([2, 3, 2], [1.0, 1.5, 2.0])).unwrap()
    }

    fn tri_mesh() -> ParamMesh {
        // A bumpy (non-planar) grid so the rest triangles are genuinely 3D.
        let mut m = grid_disk(4, 3);
        for p in &mut m.positions {
            p.z = 0.1 * (p.x * 1.3).sin() * (p.y * 0.7).cos();
        }
        ParamMesh::from_triangles(&m).unwrap()
    }

    fn flat_tri_mesh() -> ParamMesh {
        ParamMesh::from_triangles(&grid_disk(4, 3)).unwrap()
    }

    fn uv_of_flat(mesh: &ParamMesh) -> Vec<f64> {
        mesh.rest.iter().flat_map(|p| [p.x, p.y]).collect()
    }

    fn all_close(v: &[f64], target: f64, tol: f64) -> bool {
        v.iter().all(|x| (x - target).abs() <= tol)
    }

    /// Symmetric Dirichlet from singular values.
    fn sd_of(s: &[f64]) -> f64 {
        s.iter().map(|s| s * s + 1.0 / (s * s)).sum()
    }

    #[test]
    fn metrics_identity_map_of_tets_has_no_distortion() {
        let mesh = tet_mesh();
        let x = mesh.rest_flat();
        assert!(all_close(&log2_det_j(&mesh, &x), 0.0, 1e-12));
        assert!(all_close(&symmetric_dirichlet(&mesh, &x), 6.0, 1e-12));
        assert!(dirichlet_excess_percent(&mesh, &x).abs() < 1e-10);
        assert!(all_close(&log2_edge_ratio(&mesh, &x), 0.0, 1e-12));
        assert!(all_close(&area_energy(&mesh, &x), 2.0, 1e-12));
        assert!(all_close(&length_energy(&mesh, &x), 2.0, 1e-12));
        assert_eq!(inverted_count(&mesh, &x), 0);
        assert!((min_det_j(&mesh, &x) - 1.0).abs() < 1e-12);
        assert!(mips_2d(&mesh, &x).is_none() && angle_energy(&mesh, &x).is_none());
        let Jacobians::Tets(j) = jacobians(&mesh, &x) else {
            panic!("tets expected")
        };
        assert_eq!(j.len(), mesh.num_elements());
        assert!(j.iter().all(|j| (j - Matrix3::identity()).norm() < 1e-12));
    }

    #[test]
    fn metrics_identity_map_of_triangles_has_no_distortion() {
        let mesh = flat_tri_mesh();
        let x = uv_of_flat(&mesh);
        assert!(all_close(&log2_det_j(&mesh, &x), 0.0, 1e-12));
        assert!(all_close(&symmetric_dirichlet(&mesh, &x), 4.0, 1e-12));
        assert!(dirichlet_excess_percent(&mesh, &x).abs() < 1e-10);
        assert!(all_close(&log2_edge_ratio(&mesh, &x), 0.0, 1e-12));
        assert!(all_close(&mips_2d(&mesh, &x).unwrap(), 2.0, 1e-12));
        assert!(all_close(&angle_energy(&mesh, &x).unwrap(), 2.0, 1e-12));
        assert!(all_close(&area_energy(&mesh, &x), 2.0, 1e-12));
        assert!(all_close(&length_energy(&mesh, &x), 2.0, 1e-12));
        assert_eq!(inverted_count(&mesh, &x), 0);
        assert_eq!(jacobians(&mesh, &x).len(), mesh.num_elements());
    }

    #[test]
    fn metrics_uniform_scaling_by_two() {
        let mesh = tet_mesh();
        let x: Vec<f64> = mesh.rest_flat().iter().map(|v| 2.0 * v).collect();
        assert!(all_close(&log2_det_j(&mesh, &x), 3.0, 1e-12));
        assert!(all_close(&log2_edge_ratio(&mesh, &x), 1.0, 1e-12));
        // D = 3 (4 + 1/4), excess = (12.75 - 6) / 6.
        assert!(all_close(&symmetric_dirichlet(&mesh, &x), 12.75, 1e-12));
        assert!((dirichlet_excess_percent(&mesh, &x) - 112.5).abs() < 1e-9);
        assert!(all_close(&length_energy(&mesh, &x), 2.5, 1e-12));
        assert!(all_close(&area_energy(&mesh, &x), 8.125, 1e-12));

        let tris = flat_tri_mesh();
        let uv: Vec<f64> = uv_of_flat(&tris).iter().map(|v| 2.0 * v).collect();
        assert!(all_close(&log2_det_j(&tris, &uv), 2.0, 1e-12));
        assert!(all_close(&log2_edge_ratio(&tris, &uv), 1.0, 1e-12));
        assert!(all_close(&mips_2d(&tris, &uv).unwrap(), 2.0, 1e-12));

        // Boundary-triangle area ratios: log2 4 = 2.
        let rest: Vec<Point3<f64>> = tris.rest.clone();
        let mapped: Vec<Point3<f64>> = rest.iter().map(|p| Point3::from(2.0 * p.coords)).collect();
        let RestElements::Tris { tris: t, .. } = &tris.elements else {
            unreachable!()
        };
        assert!(all_close(&log2_area_ratio(&rest, &mapped, t), 2.0, 1e-12));
    }

    #[test]
    fn metrics_anisotropic_triangle_map() {
        // u' = 2 u, v' = v: s = (2, 1).
        let mesh = flat_tri_mesh();
        let uv: Vec<f64> = mesh.rest.iter().flat_map(|p| [2.0 * p.x, p.y]).collect();
        assert!(all_close(&mips_2d(&mesh, &uv).unwrap(), 2.5, 1e-12));
        assert!(all_close(&angle_energy(&mesh, &uv).unwrap(), 2.5, 1e-12));
        assert!(all_close(&area_energy(&mesh, &uv), 2.5, 1e-12));
        assert!(all_close(
            &symmetric_dirichlet(&mesh, &uv),
            4.0 + 1.0 + 0.25 + 1.0,
            1e-12
        ));
        assert!(all_close(&log2_det_j(&mesh, &uv), 1.0, 1e-12));
    }

    #[test]
    fn metrics_inverted_elements_are_counted() {
        let positions = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(0.0, 0.0, -1.0),
        ];
        // Two tets sharing the face (0, 1, 2).
        let mesh = ParamMesh::from_tets(&TetMesh::new(positions, vec![[0, 1, 2, 3], [0, 2, 1, 4]]))
            .unwrap();
        let mut x = mesh.rest_flat();
        assert_eq!(inverted_count(&mesh, &x), 0);
        // Push vertex 3 through the shared face: the first tet inverts.
        x[3 * 3 + 2] = -0.5;
        assert_eq!(inverted_count(&mesh, &x), 1);
        assert!((min_det_j(&mesh, &x) + 0.5).abs() < 1e-12);
        let l = log2_det_j(&mesh, &x);
        assert_eq!(l[0], f64::NEG_INFINITY);
        assert!(l[1].abs() < 1e-12);
        let sd = symmetric_dirichlet(&mesh, &x);
        assert_eq!(sd[0], f64::INFINITY);
        assert!((sd[1] - 6.0).abs() < 1e-12);
        assert_eq!(dirichlet_excess_percent(&mesh, &x), f64::INFINITY);
        assert_eq!(area_energy(&mesh, &x)[0], f64::INFINITY);
        // Flattened counts as inverted too.
        x[3 * 3 + 2] = 0.0;
        assert_eq!(inverted_count(&mesh, &x), 1);

        // A flipped triangle.
        let tri = ParamMesh::from_triangles(&TriMesh::new(
            vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2]],
        ))
        .unwrap();
        let flipped = [0.0, 0.0, 1.0, 0.0, 0.0, -1.0];
        assert_eq!(inverted_count(&tri, &flipped), 1);
        assert_eq!(mips_2d(&tri, &flipped).unwrap()[0], f64::INFINITY);
        assert_eq!(angle_energy(&tri, &flipped).unwrap()[0], f64::INFINITY);
    }

    #[test]
    fn metrics_unique_edges() {
        let cube = ParamMesh::from_tets(&kuhn_grid([1, 1, 1], [1.0; 3])).unwrap();
        // 12 cube edges, 6 face diagonals, 1 main diagonal.
        assert_eq!(unique_edges(&cube).len(), 19);
        let square = ParamMesh::from_triangles(&grid_disk(1, 1)).unwrap();
        assert_eq!(
            unique_edges(&square),
            vec![[0, 1], [0, 2], [0, 3], [1, 3], [2, 3]]
        );
        let x = cube.rest_flat();
        assert_eq!(log2_edge_ratio(&cube, &x).len(), 19);
    }

    #[test]
    fn metrics_length_energy_of_an_unreferenced_vertex_is_nan() {
        let mut m = grid_disk(1, 1);
        m.positions.push(Point3::new(5.0, 5.0, 0.0));
        let mesh = ParamMesh::from_triangles(&m).unwrap();
        let e = length_energy(&mesh, &uv_of_flat(&mesh));
        assert!(all_close(&e[..4], 2.0, 1e-12));
        assert!(e[4].is_nan());
    }

    #[test]
    #[should_panic(expected = "mapped positions")]
    fn metrics_wrong_position_length_panics() {
        let mesh = tet_mesh();
        let x = mesh.rest_flat();
        log2_det_j(&mesh, &x[1..]);
    }

    #[test]
    fn metrics_template_matching_error() {
        let labels = [0, 0, 0];
        let xs = [0.0, 0.0, 11.0, 0.0, 0.0, -10.0, 0.0, 0.0, 50.0];
        let w = [0.5, 0.25, 0.25];
        // 0.5 * 1^2 at vertex 0, 0 at vertex 1, vertex 2 without a target.
        let targets =
            PointTargets::from_pairs(3, 3, &[(0, [0.0, 0.0, 10.0]), (1, [0.0, 0.0, -10.0])])
                .unwrap();
        let e = template_matching_error(&targets, &labels, &xs, 3, &w, &[]);
        assert!((e - 0.5f64.sqrt()).abs() < 1e-15);
    }

    fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
        [-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64]
            .prop_map(|a| Rotation3::from_euler_angles(a[0], a[1], a[2]))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn metrics_rigid_maps_have_no_distortion(
            rot in rotation(), t in [-50.0..50.0f64, -50.0..50.0f64, -50.0..50.0f64],
        ) {
            let mesh = tet_mesh();
            let x: Vec<f64> = mesh.rest.iter()
                .flat_map(|p| { let q = rot * p + nalgebra::Vector3::from(t); [q.x, q.y, q.z] })
                .collect();
            prop_assert!(all_close(&log2_det_j(&mesh, &x), 0.0, 1e-10));
            prop_assert!(all_close(&symmetric_dirichlet(&mesh, &x), 6.0, 1e-10));
            prop_assert!(dirichlet_excess_percent(&mesh, &x).abs() < 1e-8);
            prop_assert!(all_close(&log2_edge_ratio(&mesh, &x), 0.0, 1e-10));
            // Boundary-style area ratios under a rigid motion of 3D triangles.
            let tris = tri_mesh();
            let RestElements::Tris { tris: ts, .. } = &tris.elements else { unreachable!() };
            let moved: Vec<Point3<f64>> = tris.rest.iter().map(|p| rot * p).collect();
            prop_assert!(all_close(&log2_area_ratio(&tris.rest, &moved, ts), 0.0, 1e-10));
        }

        #[test]
        fn metrics_match_singular_values_of_random_maps(
            a in prop::collection::vec(-0.15..0.15f64, 9), noise in prop::collection::vec(-0.05..0.05f64, 300),
        ) {
            // Tets: a near-identity affine map plus per-vertex noise.
            let mesh = tet_mesh();
            let m = Matrix3::identity() + Matrix3::from_row_slice(&a);
            let x: Vec<f64> = mesh.rest.iter().enumerate()
                .flat_map(|(i, p)| {
                    let q = m * p.coords;
                    [q.x + noise[3 * i], q.y + noise[3 * i + 1], q.z + noise[3 * i + 2]]
                })
                .collect();
            let Jacobians::Tets(js) = jacobians(&mesh, &x) else { unreachable!() };
            let sd = symmetric_dirichlet(&mesh, &x);
            let l2 = log2_det_j(&mesh, &x);
            for (k, j) in js.iter().enumerate() {
                prop_assert!(j.determinant() > 0.0);
                prop_assert!((sd[k] - sd_of(j.singular_values().as_slice())).abs() <= 1e-10 * sd[k]);
                prop_assert!((l2[k] - j.determinant().log2()).abs() <= 1e-12);
                // det J = mapped volume / rest volume.
                let t = mesh.element(k);
                let pt = |i: u32| Point3::new(x[3 * i as usize], x[3 * i as usize + 1], x[3 * i as usize + 2]);
                let vol = unfold_mesh::geometry::tet_signed_volume(&pt(t[0]), &pt(t[1]), &pt(t[2]), &pt(t[3]));
                prop_assert!((vol / mesh.measure[k] - j.determinant()).abs() <= 1e-10);
            }
            // Triangles: a 2D map of a bumpy surface; the cotangent angle
            // energy equals MIPS from J, and area / length energies match
            // their definitions.
            let tris = tri_mesh();
            let m2 = nalgebra::Matrix2::new(1.0 + a[0], a[1], a[2], 1.0 + a[3]);
            let uv: Vec<f64> = tris.rest.iter().enumerate()
                .flat_map(|(i, p)| {
                    let q = m2 * nalgebra::Vector2::new(p.x, p.y);
                    [q.x + noise[2 * i], q.y + noise[2 * i + 1]]
                })
                .collect();
            let mips = mips_2d(&tris, &uv).unwrap();
            let angle = angle_energy(&tris, &uv).unwrap();
            let area = area_energy(&tris, &uv);
            let Jacobians::Tris(js) = jacobians(&tris, &uv) else { unreachable!() };
            for k in 0..tris.num_elements() {
                let s = js[k].singular_values();
                prop_assert!((mips[k] - (s[0] / s[1] + s[1] / s[0])).abs() <= 1e-10 * mips[k]);
                prop_assert!((angle[k] - mips[k]).abs() <= 1e-10 * mips[k]);
                let t = tris.element(k);
                let q = |i: u32| nalgebra::Vector2::new(uv[2 * i as usize], uv[2 * i as usize + 1]);
                let a_map = 0.5 * (q(t[1]) - q(t[0])).perp(&(q(t[2]) - q(t[0])));
                let r = a_map / tris.measure[k];
                prop_assert!((area[k] - (r + 1.0 / r)).abs() <= 1e-10 * area[k]);
                prop_assert!((symmetric_dirichlet(&tris, &uv)[k] - sd_of(js[k].singular_values().as_slice())).abs() <= 1e-10 * area[k]);
            }
            let le = length_energy(&tris, &uv);
            let v = 5usize; // an interior-ish vertex: check by brute force
            let mut sum = 0.0;
            let mut n = 0;
            for [i, j] in unique_edges(&tris) {
                let (i, j) = (i as usize, j as usize);
                if i == v || j == v {
                    let rest = (tris.rest[i] - tris.rest[j]).norm();
                    let map = ((uv[2 * i] - uv[2 * j]).powi(2) + (uv[2 * i + 1] - uv[2 * j + 1]).powi(2)).sqrt();
                    sum += map / rest + rest / map;
                    n += 1;
                }
            }
            prop_assert!((le[v] - sum / n as f64).abs() <= 1e-12 * le[v]);
        }
    }
}
