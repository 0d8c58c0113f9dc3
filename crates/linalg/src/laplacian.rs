//! Discrete Laplacians of meshes (ALGORITHMS 1.6, 3.2): the cotangent
//! Laplacian of a triangle surface, the uniform (graph) Laplacian, the P1
//! stiffness matrix of a tet mesh, and mean-value weights (Floater 2003).
//!
//! Sign convention: every Laplacian here is the *positive semidefinite*
//! stiffness matrix `L` (off-diagonal entries `-w_ij`, diagonal
//! `sum_j w_ij`), so for a piecewise-linear function `u` with nodal values
//! `x`
//!
//! ```text
//! x^T L x = sum_{edges ij} w_ij (x_i - x_j)^2 = integral |grad u|^2 = 2 E_D(u)
//! ```
//!
//! with `E_D(u) = 1/2 integral |grad u|^2` the Dirichlet energy. `L x = 0`
//! on a free row is the discrete Laplace equation at that vertex
//! ([`crate::dirichlet`] solves it).
//!
//! The symmetric matrices are [`Csr`] with both triangles stored; their
//! entries are summed per position in `(min(i, j), max(i, j))` order, then
//! mirrored. A value is non-finite only on degenerate geometry that
//! overflows; the solvers refuse such a matrix.

use crate::Csr;
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use unfold_mesh::{TetMesh, TriMesh};

/// The cotangent Laplacian of a triangle surface (its P1 stiffness matrix):
///
/// ```text
/// L_ij = -(cot a_ij + cot b_ij) / 2      (i != j, edge ij)
/// L_ii = -sum_{j != i} L_ij
/// ```
///
/// with `a_ij`, `b_ij` the angles opposite edge `ij` in its one or two
/// triangles (a boundary edge has only one). Positive semidefinite,
/// symmetric, rows summing to 0, and `x^T L x = integral_S |grad u|^2 =
/// 2 E_D(u)` for the piecewise-linear `u` with nodal values `x` (module
/// docs). Identical to `K_ij = sum_t A_t grad(phi_i)·grad(phi_j)` per
/// triangle. Off-diagonal entries are positive (negative weights) on
/// non-Delaunay edges, whose opposite angles sum to more than `pi`.
///
/// Triangles of zero area (or with non-finite coordinates) contribute
/// nothing. Vertices used by no triangle get an empty row.
///
/// # Panics
/// If a triangle refers to a vertex out of range (validate first).
pub fn cotan_laplacian(mesh: &TriMesh) -> Csr {
    let n = mesh.num_vertices();
    let local: Vec<[(u32, u32, f64); 6]> = mesh
        .triangles
        .par_iter()
        .filter_map(|tri| {
            let p = tri.map(|v| mesh.positions[v as usize]);
            let twice_area = (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
            if !(twice_area > 0.0 && twice_area.is_finite()) {
                return None;
            }
            let mut out = [(0, 0, 0.0); 6];
            for c in 0..3 {
                let (a, b) = ((c + 1) % 3, (c + 2) % 3);
                let u = p[a] - p[c];
                let v = p[b] - p[c];
                // cot of the angle at c = cos / sin = u·v / |u × v|.
                let half_cot = 0.5 * u.dot(&v) / twice_area;
                // Edge (a, b) is opposite corner c.
                out[2 * c] = (tri[a], tri[b], -half_cot);
            }
            // Diagonals: L_cc = -(L_ca + L_cb), the off-diagonals of the
            // edges at c, which are opposite corners b and a.
            for c in 0..3 {
                let (a, b) = ((c + 1) % 3, (c + 2) % 3);
                let w = -(out[2 * b].2 + out[2 * a].2);
                out[2 * c + 1] = (tri[c], tri[c], w);
            }
            Some(out)
        })
        .collect();
    Csr::symmetric(n, local.into_iter().flatten())
}

/// The graph (uniform, "Tutte") Laplacian of a triangle mesh: `w_ij = 1` on
/// every edge, `L_ij = -1`, `L_ii = deg(i)`. Positive semidefinite, rows
/// summing to 0.
///
/// # Panics
/// If a triangle refers to a vertex out of range.
pub fn uniform_laplacian(mesh: &TriMesh) -> Csr {
    let n = mesh.num_vertices();
    let edges = unfold_mesh::topology::edges(&mesh.triangles);
    let mut entries = Vec::with_capacity(3 * edges.len());
    for [a, b] in edges {
        entries.push((a, b, -1.0));
        entries.push((a, a, 1.0));
        entries.push((b, b, 1.0));
    }
    Csr::symmetric(n, entries)
}

/// Mean-value weights (Floater 2003) of every vertex `i` towards its
/// neighbours `j`:
///
/// ```text
/// w_ij = (tan(delta_ij / 2) + tan(gamma_ij / 2)) / |p_i - p_j|
/// ```
///
/// with `delta_ij`, `gamma_ij` the angles *at `p_i`* of the (one or two)
/// triangles containing edge `ij`, measured in 3D. Every angle is in
/// `(0, pi)`, so every weight is positive (and finite): a Tutte embedding
/// with these weights and a convex boundary is bijective. The weights are
/// not symmetric (`w_ij != w_ji`) and not normalized; in the plane the
/// normalized weights `w_ij / sum_k w_ik` reproduce linear functions.
///
/// Returns, per vertex, its `(neighbour, weight)` pairs sorted by
/// neighbour. `tan(alpha/2)` is evaluated as
/// `|u × v| / (|u||v| + u·v)`. Triangles of zero area contribute nothing.
///
/// # Panics
/// If a triangle refers to a vertex out of range.
pub fn mean_value_weights(mesh: &TriMesh) -> Vec<Vec<(u32, f64)>> {
    let n = mesh.num_vertices();
    let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for tri in &mesh.triangles {
        let p = tri.map(|v| mesh.positions[v as usize]);
        let mut contributions = [(0u32, 0u32, 0.0f64); 6];
        let mut ok = true;
        for c in 0..3 {
            let (a, b) = ((c + 1) % 3, (c + 2) % 3);
            let u = p[a] - p[c];
            let v = p[b] - p[c];
            let (lu, lv) = (u.norm(), v.norm());
            let sin_part = u.cross(&v).norm();
            let denom = lu * lv + u.dot(&v);
            let t = sin_part / denom;
            if !(sin_part > 0.0 && denom > 0.0 && t.is_finite() && lu > 0.0 && lv > 0.0) {
                ok = false;
                break;
            }
            contributions[2 * c] = (tri[c], tri[a], t / lu);
            contributions[2 * c + 1] = (tri[c], tri[b], t / lv);
        }
        if ok {
            for (i, j, w) in contributions {
                rows[i as usize].push((j, w));
            }
        }
    }
    rows.par_iter_mut().for_each(|row| {
        row.sort_unstable_by_key(|e| e.0);
        let mut merged: Vec<(u32, f64)> = Vec::with_capacity(row.len() / 2 + 1);
        for &(j, w) in row.iter() {
            match merged.last_mut() {
                Some(last) if last.0 == j => last.1 += w,
                _ => merged.push((j, w)),
            }
        }
        *row = merged;
    });
    rows
}

/// The linear (P1) finite-element stiffness matrix of a tet mesh:
///
/// ```text
/// K_ij = sum_t V_t grad(phi_i)·grad(phi_j)
/// ```
///
/// with `phi_i` the hat function of vertex `i` and `V_t` the (unsigned)
/// volume of tet `t`. Per tet, with `Dm = [z1-z0, z2-z0, z3-z0]`, the
/// gradients of `phi_1..phi_3` are the rows of `Dm^-1` and
/// `grad(phi_0) = -(sum of the others)`. Symmetric positive semidefinite,
/// rows summing to 0, `x^T K x = integral |grad u|^2`. Either orientation of
/// a tet gives the same contribution; degenerate tets contribute nothing.
///
/// # Panics
/// If a tet refers to a vertex out of range.
pub fn p1_stiffness(mesh: &TetMesh) -> Csr {
    let n = mesh.num_vertices();
    let local: Vec<[(u32, u32, f64); 10]> = mesh
        .tets
        .par_iter()
        .filter_map(|tet| {
            let p = tet.map(|v| mesh.positions[v as usize]);
            let dm = Matrix3::from_columns(&[p[1] - p[0], p[2] - p[0], p[3] - p[0]]);
            let det = dm.determinant();
            if !(det != 0.0 && det.is_finite()) {
                return None;
            }
            let inv = dm.try_inverse()?;
            let mut g = [Vector3::zeros(); 4];
            for k in 0..3 {
                g[k + 1] = inv.row(k).transpose();
            }
            g[0] = -(g[1] + g[2] + g[3]);
            let vol = det.abs() / 6.0;
            let mut out = [(0, 0, 0.0); 10];
            let mut s = 0;
            for a in 0..4 {
                for b in a..4 {
                    out[s] = (tet[a], tet[b], vol * g[a].dot(&g[b]));
                    s += 1;
                }
            }
            out.iter().all(|e| e.2.is_finite()).then_some(out)
        })
        .collect();
    Csr::symmetric(n, local.into_iter().flatten())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{
        Rng, boundary_mask, lift, perturbed_grid, perturbed_tet_grid, random_disk,
    };
    use nalgebra::Vector2;
    use proptest::prelude::*;

    /// The Dirichlet integral of the piecewise-linear `u` on a triangle
    /// mesh, triangle by triangle: `sum_t A_t |grad u|^2`, with the
    /// barycentric gradients `grad(lambda_i) = n x e_i / (2 A)` (`e_i` the
    /// edge opposite corner `i`, `n` the unit normal).
    fn dirichlet_integral(mesh: &TriMesh, u: &[f64]) -> f64 {
        let mut total = 0.0;
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let p = mesh.triangle_points(t);
            let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let area2 = n.norm();
            let nn = n / area2;
            let mut grad = Vector3::zeros();
            for i in 0..3 {
                let e = p[(i + 2) % 3] - p[(i + 1) % 3];
                grad += nn.cross(&e) * (u[tri[i] as usize] / area2);
            }
            total += 0.5 * area2 * grad.norm_squared();
        }
        total
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn cotan_laplacian_is_symmetric_psd_with_zero_row_sums(
            seed in any::<u64>(),
            xs in prop::collection::vec(-1.0..1.0f64, 200),
        ) {
            let mut rng = Rng(seed);
            let mut m = random_disk(&mut rng, 12, 25, 20);
            lift(&mut m, 0.5);
            let l = cotan_laplacian(&m);
            let n = m.num_vertices();
            // Symmetric storage: both triangles, mirrored exactly.
            prop_assert_eq!(&l.transpose(), &l);
            let x: Vec<f64> = (0..n).map(|i| xs[i % xs.len()] + 0.01 * i as f64).collect();
            let y: Vec<f64> = (0..n).map(|i| xs[(i * 7 + 3) % xs.len()]).collect();
            // Symmetric: y^T L x = x^T L y.
            let ylx: f64 = y.iter().zip(l.multiply(&x)).map(|(a, b)| a * b).sum();
            let xly: f64 = x.iter().zip(l.multiply(&y)).map(|(a, b)| a * b).sum();
            prop_assert!((ylx - xly).abs() < 1e-10 * (1.0 + ylx.abs()));
            // Rows sum to zero.
            let scale = l.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for r in l.multiply(&vec![1.0; n]) {
                prop_assert!(r.abs() < 1e-12 * scale);
            }
            // PSD, and x^T L x is the Dirichlet integral (twice E_D).
            let q = l.quadratic_form(&x);
            let d = dirichlet_integral(&m, &x);
            prop_assert!(q >= -1e-12 * scale);
            prop_assert!((q - d).abs() < 1e-9 * (1.0 + d), "q {} d {}", q, d);
        }

        #[test]
        fn cotan_laplacian_annihilates_linear_functions_on_planar_meshes(
            seed in any::<u64>(), a in -2.0..2.0f64, b in -2.0..2.0f64, c in -2.0..2.0f64,
        ) {
            let mut rng = Rng(seed);
            let m = if seed % 2 == 0 {
                random_disk(&mut rng, 10, 30, 30)
            } else {
                perturbed_grid(6, 5, 0.8, &mut rng)
            };
            let l = cotan_laplacian(&m);
            let u: Vec<f64> = m.positions.iter().map(|p| a * p.x + b * p.y + c).collect();
            let lu = l.multiply(&u);
            let bnd = boundary_mask(&m);
            let scale = l.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, r) in lu.iter().enumerate() {
                if !bnd[i] {
                    prop_assert!(r.abs() < 1e-10 * scale * (1.0 + a.abs() + b.abs() + c.abs()),
                        "row {} residual {}", i, r);
                }
            }
        }

        #[test]
        fn cotan_laplacian_equals_p1_stiffness_of_flat_triangulations(seed in any::<u64>()) {
            let mut rng = Rng(seed);
            let m = random_disk(&mut rng, 9, 20, 25);
            // K_ij = sum_t A_t grad(phi_i)·grad(phi_j) from 2D gradients.
            let mut entries = Vec::new();
            for tri in &m.triangles {
                let p = tri.map(|v| m.positions[v as usize]);
                let dm = nalgebra::Matrix2::new(p[1].x - p[0].x, p[2].x - p[0].x,
                                                p[1].y - p[0].y, p[2].y - p[0].y);
                let area = 0.5 * dm.determinant();
                let inv = dm.try_inverse().unwrap();
                let mut g = [Vector2::zeros(); 3];
                g[1] = inv.row(0).transpose();
                g[2] = inv.row(1).transpose();
                g[0] = -(g[1] + g[2]);
                for a in 0..3 {
                    for b in a..3 {
                        entries.push((tri[a], tri[b], area * g[a].dot(&g[b])));
                    }
                }
            }
            let k = Csr::from_symmetric_entries(m.num_vertices(), entries).unwrap();
            let l = cotan_laplacian(&m);
            prop_assert_eq!(k.nnz(), l.nnz());
            for (e, f) in k.upper_triangle().zip(l.upper_triangle()) {
                prop_assert_eq!((e.0, e.1), (f.0, f.1));
                prop_assert!((e.2 - f.2).abs() < 1e-10 * (1.0 + e.2.abs()), "{:?} vs {:?}", e, f);
            }
        }

        #[test]
        fn p1_stiffness_has_zero_row_sums_and_annihilates_linear_fields(
            seed in any::<u64>(), a in prop::array::uniform3(-2.0..2.0f64), c in -2.0..2.0f64,
        ) {
            let mut rng = Rng(seed);
            let (m, boundary) = perturbed_tet_grid(3, &mut rng, 0.1);
            let k = p1_stiffness(&m);
            let n = m.num_vertices();
            let scale = k.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for r in k.multiply(&vec![1.0; n]) {
                prop_assert!(r.abs() < 1e-12 * scale);
            }
            let av = Vector3::from(a);
            let u: Vec<f64> = m.positions.iter().map(|p| av.dot(&p.coords) + c).collect();
            let ku = k.multiply(&u);
            for (i, r) in ku.iter().enumerate() {
                if !boundary[i] {
                    prop_assert!(r.abs() < 1e-10 * scale * (1.0 + av.norm()), "row {} residual {}", i, r);
                }
            }
            // u^T K u = integral |a|^2 = |a|^2 V (the cube has volume 27).
            let q = k.quadratic_form(&u);
            prop_assert!((q - av.norm_squared() * 27.0).abs() < 1e-9 * (1.0 + q));
        }
    }

    #[test]
    fn mean_value_weights_are_positive_and_not_symmetric() {
        let mut rng = Rng(7);
        let mut m = random_disk(&mut rng, 10, 30, 20);
        lift(&mut m, 0.7);
        let w = mean_value_weights(&m);
        let adj = unfold_mesh::topology::vertex_adjacency(m.num_vertices(), &m.triangles);
        let mut asymmetric = false;
        for (i, row) in w.iter().enumerate() {
            let nbrs: Vec<u32> = row.iter().map(|e| e.0).collect();
            assert_eq!(nbrs, adj.neighbors(i));
            for &(j, wij) in row {
                assert!(wij > 0.0 && wij.is_finite());
                let wji = w[j as usize].iter().find(|e| e.0 == i as u32).unwrap().1;
                asymmetric |= (wij - wji).abs() > 1e-6 * wij;
            }
        }
        assert!(asymmetric);
    }

    #[test]
    fn random_disks_have_obtuse_triangles_and_negative_cotan_weights() {
        let (mut obtuse, mut negative) = (0, 0);
        for seed in 0..10 {
            let m = random_disk(&mut Rng(seed), 10, 30, 30);
            let l = cotan_laplacian(&m);
            negative += l
                .upper_triangle()
                .filter(|t| t.0 != t.1 && t.2 > 0.0)
                .count();
            for t in 0..m.num_triangles() {
                let p = m.triangle_points(t);
                obtuse += (0..3)
                    .filter(|&c| (p[(c + 1) % 3] - p[c]).dot(&(p[(c + 2) % 3] - p[c])) < 0.0)
                    .count();
            }
        }
        assert!(
            obtuse > 0 && negative > 0,
            "obtuse {obtuse}, negative {negative}"
        );
    }
}
