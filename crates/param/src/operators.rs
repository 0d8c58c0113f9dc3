//! Discrete operators shared by the organ pipelines (ALGORITHMS 1.6, 3.2):
//! the cotangent Laplacian of a triangle surface, the P1 stiffness matrix of
//! a tet mesh, mean-value weights (Floater 2003), Dirichlet (harmonic) solves
//! with symmetric and non-symmetric weights, and a 2D thin-plate spline.
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
//! on a free row is the discrete Laplace equation at that vertex.
//!
//! Every sparse solve lives in this module: symmetric positive definite
//! systems go through [`crate::sparse`] (faer's Cholesky), non-symmetric
//! ones through faer's sparse LU.

use crate::ParamError;
use crate::sparse::SpdPattern;
use faer::MatMut;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use nalgebra::{DMatrix, Matrix3, Vector3};
use rayon::prelude::*;
use unfold_mesh::{TetMesh, TriMesh};

// ---------------------------------------------------------------------------
// Sparse symmetric matrices
// ---------------------------------------------------------------------------

/// A sparse symmetric `n x n` matrix stored as its upper triangle (diagonal
/// included): `triplets` holds `(i, j, a_ij)` with `i <= j`, sorted by
/// `(i, j)`, every position at most once (duplicates merged by summing).
/// The entry `a_ji` of the lower triangle is implied (`a_ji = a_ij`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SparseSym {
    /// Matrix size.
    pub n: usize,
    /// Upper-triangle entries `(i, j, a_ij)`, `i <= j`, sorted, unique.
    pub triplets: Vec<(u32, u32, f64)>,
}

impl SparseSym {
    /// The symmetric matrix `A = sum_k a_k (e_i e_j^T + e_j e_i^T) / (1 + [i == j])`
    /// of the given entries: each `(i, j, a)` is put in the upper triangle
    /// (`(min, max)`), and values at the same position are summed. So give
    /// every off-diagonal entry once, in either triangle.
    ///
    /// # Panics
    /// If an index is `>= n`.
    pub fn from_entries(n: usize, entries: impl IntoIterator<Item = (u32, u32, f64)>) -> Self {
        let mut t: Vec<(u32, u32, f64)> = entries
            .into_iter()
            .map(|(i, j, v)| {
                assert!(
                    (i as usize) < n && (j as usize) < n,
                    "sparse entry ({i}, {j}) outside a {n} x {n} matrix"
                );
                if i <= j { (i, j, v) } else { (j, i, v) }
            })
            .collect();
        t.sort_unstable_by_key(|e| (e.0, e.1));
        let mut triplets: Vec<(u32, u32, f64)> = Vec::with_capacity(t.len());
        for (i, j, v) in t {
            match triplets.last_mut() {
                Some(last) if last.0 == i && last.1 == j => last.2 += v,
                _ => triplets.push((i, j, v)),
            }
        }
        SparseSym { n, triplets }
    }

    /// Number of stored (upper-triangle) entries.
    pub fn nnz(&self) -> usize {
        self.triplets.len()
    }

    /// The entry `a_ij` (either triangle; 0 when not stored).
    pub fn get(&self, i: u32, j: u32) -> f64 {
        let key = if i <= j { (i, j) } else { (j, i) };
        self.triplets
            .binary_search_by(|&(a, b, _)| (a, b).cmp(&key))
            .map(|k| self.triplets[k].2)
            .unwrap_or(0.0)
    }

    /// The diagonal `a_ii`.
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.n];
        for &(i, j, v) in &self.triplets {
            if i == j {
                d[i as usize] += v;
            }
        }
        d
    }

    /// `y = A x` (both triangles applied).
    ///
    /// # Panics
    /// If `x.len() != n`.
    pub fn multiply(&self, x: &[f64]) -> Vec<f64> {
        assert_eq!(x.len(), self.n, "SparseSym::multiply: vector length");
        let mut y = vec![0.0; self.n];
        for &(i, j, v) in &self.triplets {
            let (i, j) = (i as usize, j as usize);
            y[i] += v * x[j];
            if i != j {
                y[j] += v * x[i];
            }
        }
        y
    }

    /// The quadratic form `x^T A x` (for a Laplacian: twice the Dirichlet
    /// energy of the piecewise-linear function with nodal values `x`).
    ///
    /// # Panics
    /// If `x.len() != n`.
    pub fn quadratic_form(&self, x: &[f64]) -> f64 {
        assert_eq!(x.len(), self.n, "SparseSym::quadratic_form: vector length");
        self.triplets
            .iter()
            .map(|&(i, j, v)| {
                let (i, j) = (i as usize, j as usize);
                if i == j {
                    v * x[i] * x[i]
                } else {
                    2.0 * v * x[i] * x[j]
                }
            })
            .sum()
    }
}

// ---------------------------------------------------------------------------
// Laplacians and weights
// ---------------------------------------------------------------------------

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
pub fn cotan_laplacian(mesh: &TriMesh) -> SparseSym {
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
    SparseSym::from_entries(n, local.into_iter().flatten())
}

/// The graph (uniform, "Tutte") Laplacian of a triangle mesh: `w_ij = 1` on
/// every edge, `L_ij = -1`, `L_ii = deg(i)`. Positive semidefinite, rows
/// summing to 0.
///
/// # Panics
/// If a triangle refers to a vertex out of range.
pub fn uniform_laplacian(mesh: &TriMesh) -> SparseSym {
    let n = mesh.num_vertices();
    let edges = unfold_mesh::topology::edges(&mesh.triangles);
    let mut entries = Vec::with_capacity(3 * edges.len());
    for [a, b] in edges {
        entries.push((a, b, -1.0));
        entries.push((a, a, 1.0));
        entries.push((b, b, 1.0));
    }
    SparseSym::from_entries(n, entries)
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
pub fn p1_stiffness(mesh: &TetMesh) -> SparseSym {
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
    SparseSym::from_entries(n, local.into_iter().flatten())
}

// ---------------------------------------------------------------------------
// Dirichlet solves
// ---------------------------------------------------------------------------

/// Checks the fixed set and the value columns; returns, per vertex, its
/// index among the free vertices (`u32::MAX` for fixed ones) and the free
/// vertices in order.
fn split_free(
    n: usize,
    fixed: &[u32],
    values: &[Vec<f64>],
) -> Result<(Vec<u32>, Vec<u32>), ParamError> {
    let mut local = vec![0u32; n];
    for &f in fixed {
        let f = f as usize;
        if f >= n {
            return Err(ParamError::InvalidArgument(format!(
                "fixed vertex {f} out of range (matrix of size {n})"
            )));
        }
        if local[f] == u32::MAX {
            return Err(ParamError::InvalidArgument(format!(
                "fixed vertex {f} listed twice"
            )));
        }
        local[f] = u32::MAX;
    }
    for col in values {
        if col.len() != fixed.len() {
            return Err(ParamError::Length {
                what: "Dirichlet values (one per fixed vertex)",
                expected: fixed.len(),
                found: col.len(),
            });
        }
        if !col.iter().all(|v| v.is_finite()) {
            return Err(ParamError::NotFinite("Dirichlet values".into()));
        }
    }
    let mut free = Vec::with_capacity(n - fixed.len());
    for (v, l) in local.iter_mut().enumerate() {
        if *l != u32::MAX {
            *l = free.len() as u32;
            free.push(v as u32);
        }
    }
    Ok((local, free))
}

/// Fails when a free vertex is not connected, through non-zero couplings
/// (`neighbors(v)`), to any fixed vertex: its block of the system would be
/// singular.
fn check_reaches_fixed<I: Iterator<Item = u32>>(
    n: usize,
    local: &[u32],
    neighbors: impl Fn(usize) -> I,
) -> Result<(), ParamError> {
    let mut seen: Vec<bool> = local.iter().map(|&l| l == u32::MAX).collect();
    let mut stack: Vec<usize> = (0..n).filter(|&v| seen[v]).collect();
    while let Some(v) = stack.pop() {
        for w in neighbors(v) {
            let w = w as usize;
            if !seen[w] {
                seen[w] = true;
                stack.push(w);
            }
        }
    }
    match seen.iter().position(|s| !s) {
        None => Ok(()),
        Some(v) => Err(ParamError::InvalidArgument(format!(
            "vertex {v} is free but not connected to any fixed vertex: the Dirichlet \
             problem is singular (isolated vertex or component without a fixed vertex)"
        ))),
    }
}

/// Solves the Dirichlet problem of a symmetric positive semidefinite
/// operator `A` (a Laplacian / stiffness matrix): with `F` the free and `C`
/// the fixed vertices,
///
/// ```text
/// A_FF x_F = -A_FC x_C,      x_C = the given values
/// ```
///
/// i.e. `(A x)_i = 0` on every free row: the discrete harmonic extension of
/// the boundary values. `A_FF` is factorized once (sparse Cholesky,
/// [`crate::sparse`]) and reused for every column of `values` (one column
/// per coordinate, each with one value per entry of `fixed`, in that
/// order). Returns one full column of length `n` per input column (fixed
/// entries set to their values).
///
/// # Errors
/// `InvalidArgument` for a fixed index out of range or listed twice, or a
/// free vertex not coupled (through non-zero entries) to any fixed vertex;
/// `Length` when a column does not have `fixed.len()` values;
/// `Factorization` when `A_FF` is not positive definite.
pub fn solve_dirichlet(
    matrix: &SparseSym,
    fixed: &[u32],
    values: &[Vec<f64>],
) -> Result<Vec<Vec<f64>>, ParamError> {
    let n = matrix.n;
    let (local, free) = split_free(n, fixed, values)?;
    if let Some(&(i, j, _)) = matrix
        .triplets
        .iter()
        .find(|&&(i, j, _)| i as usize >= n || j as usize >= n)
    {
        return Err(ParamError::InvalidArgument(format!(
            "sparse entry ({i}, {j}) outside a {n} x {n} matrix"
        )));
    }
    if !matrix.triplets.iter().all(|t| t.2.is_finite()) {
        return Err(ParamError::NotFinite("matrix entries".into()));
    }
    let mut full: Vec<Vec<f64>> = values
        .iter()
        .map(|col| {
            let mut x = vec![0.0; n];
            for (&f, &v) in fixed.iter().zip(col) {
                x[f as usize] = v;
            }
            x
        })
        .collect();
    if free.is_empty() {
        return Ok(full);
    }
    // Coupling graph for the connectivity check.
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(i, j, v) in &matrix.triplets {
        if i != j && v != 0.0 {
            adj[i as usize].push(j);
            adj[j as usize].push(i);
        }
    }
    check_reaches_fixed(n, &local, |v| adj[v].iter().copied())?;

    let nf = free.len();
    let ff = |&&(i, j, _): &&(u32, u32, f64)| {
        local[i as usize] != u32::MAX && local[j as usize] != u32::MAX
    };
    let pattern = SpdPattern::new(
        nf,
        matrix
            .triplets
            .iter()
            .filter(ff)
            .map(|&(i, j, _)| (local[i as usize], local[j as usize])),
    )?;
    let mut vals = vec![0.0; pattern.nnz()];
    for &(i, j, v) in matrix.triplets.iter().filter(ff) {
        let (a, b) = (local[i as usize], local[j as usize]);
        if let Some(s) = pattern.slot(a, b) {
            vals[s] += v;
        }
    }
    let (factor, _) = pattern.factorize(&vals, 0.0, 0).map_err(|e| {
        ParamError::Factorization(format!(
            "the free block of the Dirichlet problem is not positive definite: {e}"
        ))
    })?;
    for x in full.iter_mut() {
        // rhs_F = -A_FC x_C
        let mut rhs = vec![0.0; nf];
        for &(i, j, v) in &matrix.triplets {
            let (li, lj) = (local[i as usize], local[j as usize]);
            if li != u32::MAX && lj == u32::MAX {
                rhs[li as usize] -= v * x[j as usize];
            } else if lj != u32::MAX && li == u32::MAX {
                rhs[lj as usize] -= v * x[i as usize];
            }
        }
        factor.solve_in_place(&mut rhs)?;
        if !rhs.iter().all(|v| v.is_finite()) {
            return Err(ParamError::NotFinite("Dirichlet solution".into()));
        }
        for (k, &v) in free.iter().enumerate() {
            x[v as usize] = rhs[k];
        }
    }
    Ok(full)
}

/// Solves the Dirichlet problem of a (possibly non-symmetric) weighted
/// averaging operator, e.g. [`mean_value_weights`]: every free vertex is
/// the weighted mean of its neighbours,
///
/// ```text
/// sum_j w_ij (x_i - x_j) = 0   <=>   x_i = sum_j lambda_ij x_j,
/// lambda_ij = w_ij / sum_k w_ik
/// ```
///
/// with the fixed vertices at the given values. The rows are normalized
/// (unit diagonal) and the sparse system `(I - Lambda_FF) x_F =
/// Lambda_FC x_C` is solved by faer's sparse LU (factorized once for all
/// columns of `values`), followed by one step of iterative refinement. For
/// positive weights the matrix is an irreducibly diagonally dominant
/// M-matrix when every free vertex is connected to a fixed one, hence
/// non-singular. `weights[i]` lists `(j, w_ij)`; self-references are
/// ignored and repeated neighbours summed; rows of fixed vertices are not
/// used. Returns one full column of length `weights.len()` per value column.
///
/// # Errors
/// As [`solve_dirichlet`]; also `InvalidArgument` for a neighbour index out
/// of range, a non-finite weight or a free row whose weights sum to 0, and
/// `Factorization` when the LU fails or its solution has a large residual.
pub fn solve_dirichlet_weights(
    weights: &[Vec<(u32, f64)>],
    fixed: &[u32],
    values: &[Vec<f64>],
) -> Result<Vec<Vec<f64>>, ParamError> {
    let n = weights.len();
    let (local, free) = split_free(n, fixed, values)?;
    let mut full: Vec<Vec<f64>> = values
        .iter()
        .map(|col| {
            let mut x = vec![0.0; n];
            for (&f, &v) in fixed.iter().zip(col) {
                x[f as usize] = v;
            }
            x
        })
        .collect();
    if free.is_empty() {
        return Ok(full);
    }
    // Normalized rows of the free vertices.
    let mut rows: Vec<Vec<(u32, f64)>> = Vec::with_capacity(free.len());
    for &i in &free {
        let mut sum = 0.0;
        let mut row = Vec::with_capacity(weights[i as usize].len());
        for &(j, w) in &weights[i as usize] {
            if j as usize >= n {
                return Err(ParamError::InvalidArgument(format!(
                    "weight of vertex {i} refers to vertex {j} out of range ({n} vertices)"
                )));
            }
            if !w.is_finite() {
                return Err(ParamError::InvalidArgument(format!(
                    "weight of vertex {i} towards {j} is not finite ({w})"
                )));
            }
            if j != i && w != 0.0 {
                sum += w;
                row.push((j, w));
            }
        }
        if row.is_empty() {
            return Err(ParamError::InvalidArgument(format!(
                "vertex {i} is free but has no neighbours: the Dirichlet problem is singular"
            )));
        }
        if sum == 0.0 || !sum.is_finite() {
            return Err(ParamError::InvalidArgument(format!(
                "the weights of free vertex {i} sum to {sum}"
            )));
        }
        for e in row.iter_mut() {
            e.1 /= sum;
        }
        rows.push(row);
    }
    // x_i depends on x_j when lambda_ij > 0: every free vertex needs a
    // chain of dependencies ending at a fixed vertex (then I - Lambda_FF is
    // weakly chained diagonally dominant, hence non-singular, for positive
    // weights). Search from the fixed vertices along reversed dependencies.
    let mut dependents: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (k, row) in rows.iter().enumerate() {
        for &(j, _) in row {
            dependents[j as usize].push(free[k]);
        }
    }
    check_reaches_fixed(n, &local, |v| dependents[v].iter().copied())?;

    let nf = free.len();
    // Assemble I - Lambda_FF column by column (CSC, sorted unique rows).
    let mut entries: Vec<(u32, u32, f64)> =
        Vec::with_capacity(nf + rows.iter().map(Vec::len).sum::<usize>());
    for (k, row) in rows.iter().enumerate() {
        entries.push((k as u32, k as u32, 1.0));
        for &(j, l) in row {
            let lj = local[j as usize];
            if lj != u32::MAX {
                entries.push((k as u32, lj, -l));
            }
        }
    }
    // Sort by (column, row) and merge.
    entries.sort_unstable_by_key(|e| (e.1, e.0));
    let mut merged: Vec<(u32, u32, f64)> = Vec::with_capacity(entries.len());
    for e in entries {
        match merged.last_mut() {
            Some(last) if last.0 == e.0 && last.1 == e.1 => last.2 += e.2,
            _ => merged.push(e),
        }
    }
    let mut col_ptr = vec![0usize; nf + 1];
    for &(_, c, _) in &merged {
        col_ptr[c as usize + 1] += 1;
    }
    for c in 0..nf {
        col_ptr[c + 1] += col_ptr[c];
    }
    let row_idx: Vec<usize> = merged.iter().map(|e| e.0 as usize).collect();
    let vals: Vec<f64> = merged.iter().map(|e| e.2).collect();
    let symbolic = SymbolicSparseColMat::new_checked(nf, nf, col_ptr, None, row_idx);
    let mat = SparseColMatRef::new(symbolic.as_ref(), &vals);
    let symbolic_lu = SymbolicLu::try_new(symbolic.as_ref())
        .map_err(|e| ParamError::Factorization(format!("symbolic LU: {e:?}")))?;
    let lu = Lu::try_new_with_symbolic(symbolic_lu, mat)
        .map_err(|e| ParamError::Factorization(format!("sparse LU: {e:?}")))?;

    // A x for the assembled matrix (row-major view through the CSC).
    let apply = |x: &[f64], out: &mut [f64]| {
        out.iter_mut().for_each(|o| *o = 0.0);
        for &(r, c, v) in &merged {
            out[r as usize] += v * x[c as usize];
        }
    };
    let ncols = values.len();
    let mut rhs = vec![0.0; nf * ncols];
    for (c, x) in full.iter().enumerate() {
        for (k, row) in rows.iter().enumerate() {
            rhs[c * nf + k] = row
                .iter()
                .filter(|e| local[e.0 as usize] == u32::MAX)
                .map(|&(j, l)| l * x[j as usize])
                .sum();
        }
    }
    let mut sol = rhs.clone();
    lu.solve_in_place(MatMut::from_column_major_slice_mut(&mut sol, nf, ncols));
    // One step of iterative refinement: x += A^-1 (b - A x).
    let mut resid = vec![0.0; nf * ncols];
    let mut ax = vec![0.0; nf];
    for c in 0..ncols {
        apply(&sol[c * nf..(c + 1) * nf], &mut ax);
        for k in 0..nf {
            resid[c * nf + k] = rhs[c * nf + k] - ax[k];
        }
    }
    lu.solve_in_place(MatMut::from_column_major_slice_mut(&mut resid, nf, ncols));
    for (s, d) in sol.iter_mut().zip(&resid) {
        *s += d;
    }
    if !sol.iter().all(|v| v.is_finite()) {
        return Err(ParamError::Factorization(
            "sparse LU solution is not finite (singular system?)".into(),
        ));
    }
    for c in 0..ncols {
        let x = &sol[c * nf..(c + 1) * nf];
        apply(x, &mut ax);
        let b = &rhs[c * nf..(c + 1) * nf];
        let scale = b
            .iter()
            .chain(x)
            .fold(0.0f64, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let worst = ax
            .iter()
            .zip(b)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        if worst > 1e-8 * scale {
            return Err(ParamError::Factorization(format!(
                "sparse LU residual {worst:e} too large (scale {scale:e}): nearly singular system"
            )));
        }
        for (k, &v) in free.iter().enumerate() {
            full[c][v as usize] = x[k];
        }
    }
    Ok(full)
}

// ---------------------------------------------------------------------------
// Thin-plate spline
// ---------------------------------------------------------------------------

/// The thin-plate radial basis `phi(r) = r^2 log r` (`phi(0) = 0`), from
/// the squared distance: `phi = r2 log(r2) / 2`.
#[inline]
fn tps_phi(r2: f64) -> f64 {
    if r2 > 0.0 { 0.5 * r2 * r2.ln() } else { 0.0 }
}

/// A 2D thin-plate spline `f: R^2 -> R^2` interpolating values at centres:
///
/// ```text
/// f(p) = a + A p + sum_i w_i phi(|p - c_i|),   phi(r) = r^2 log r,
/// sum_i w_i = 0,   sum_i w_i c_i^T = 0          (side conditions)
/// ```
///
/// the minimizer of the bending energy
/// `integral |d2f/dx2|^2 + 2 |d2f/dxdy|^2 + |d2f/dy2|^2` among the
/// interpolants of the data. It reproduces affine maps exactly (`w = 0`).
///
/// Internally the centres are centred and scaled (`q = (p - m) / s`); the
/// spline is invariant under similarities, so this only improves the
/// conditioning (`a`, `A`, `w` are stored in the normalized coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct ThinPlateSpline2 {
    /// Normalized centres `(c_i - m) / s`.
    centers: Vec<[f64; 2]>,
    /// Radial weights `w_i` (one 2-vector per centre).
    weights: Vec<[f64; 2]>,
    /// Affine part per output coordinate `k`: `f_k = aff[k][0] +
    /// aff[k][1] q_x + aff[k][2] q_y + ...`.
    affine: [[f64; 3]; 2],
    /// Normalization: `q = (p - shift) / scale`.
    shift: [f64; 2],
    scale: f64,
}

impl ThinPlateSpline2 {
    /// Fits the spline with `f(c_i) = v_i` by solving the dense saddle-point
    /// system (nalgebra LU)
    ///
    /// ```text
    /// [ K   P ] [w]   [v]      K_ij = phi(|c_i - c_j|),
    /// [ P^T 0 ] [a] = [0],     P = [1, c_x, c_y]   (n x 3)
    /// ```
    ///
    /// Cost `O(n^3)`: meant for up to a few thousand centres.
    ///
    /// # Errors
    /// `Length` when `values.len() != centers.len()`; `NotFinite` for a
    /// non-finite coordinate; `InvalidArgument` with fewer than 3 centres,
    /// two centres closer than `1e-10` times the spread of the centres
    /// (duplicates), or all centres (nearly) collinear (the affine part is
    /// then not determined); `Factorization` when the LU fails.
    pub fn fit(centers: &[[f64; 2]], values: &[[f64; 2]]) -> Result<Self, ParamError> {
        let n = centers.len();
        if values.len() != n {
            return Err(ParamError::Length {
                what: "thin-plate spline values (one per centre)",
                expected: n,
                found: values.len(),
            });
        }
        if !centers
            .iter()
            .chain(values)
            .flatten()
            .all(|v| v.is_finite())
        {
            return Err(ParamError::NotFinite(
                "thin-plate spline centres or values".into(),
            ));
        }
        if n < 3 {
            return Err(ParamError::InvalidArgument(format!(
                "a thin-plate spline needs at least 3 non-collinear centres, got {n}"
            )));
        }
        let shift = {
            let (sx, sy) = centers
                .iter()
                .fold((0.0, 0.0), |(x, y), c| (x + c[0], y + c[1]));
            [sx / n as f64, sy / n as f64]
        };
        let scale = centers
            .iter()
            .map(|c| ((c[0] - shift[0]).powi(2) + (c[1] - shift[1]).powi(2)).sqrt())
            .fold(0.0, f64::max);
        // (scale is finite and >= 0: the centres are finite.)
        if scale <= 0.0 {
            return Err(ParamError::InvalidArgument(
                "thin-plate spline: all centres coincide".into(),
            ));
        }
        let q: Vec<[f64; 2]> = centers
            .iter()
            .map(|c| [(c[0] - shift[0]) / scale, (c[1] - shift[1]) / scale])
            .collect();
        // Duplicates: sweep along x.
        let tol = 1e-10;
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| q[a][0].total_cmp(&q[b][0]));
        for (s, &a) in order.iter().enumerate() {
            for &b in &order[s + 1..] {
                if q[b][0] - q[a][0] > tol {
                    break;
                }
                if (q[b][1] - q[a][1]).abs() <= tol {
                    let (i, j) = (a.min(b), a.max(b));
                    return Err(ParamError::InvalidArgument(format!(
                        "thin-plate spline: centres {i} and {j} coincide ({:?})",
                        centers[i]
                    )));
                }
            }
        }
        // Collinearity: the smallest eigenvalue of the 2x2 covariance.
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for c in &q {
            sxx += c[0] * c[0];
            sxy += c[0] * c[1];
            syy += c[1] * c[1];
        }
        let (sxx, sxy, syy) = (sxx / n as f64, sxy / n as f64, syy / n as f64);
        let tr = sxx + syy;
        let disc = ((sxx - syy).powi(2) + 4.0 * sxy * sxy).sqrt();
        let lmin = 0.5 * (tr - disc);
        let lmax = 0.5 * (tr + disc);
        if lmin.is_nan() || lmin <= 1e-12 * lmax {
            return Err(ParamError::InvalidArgument(
                "thin-plate spline: the centres are (nearly) collinear".into(),
            ));
        }
        let size = n + 3;
        let mut m = DMatrix::<f64>::zeros(size, size);
        for i in 0..n {
            for j in i + 1..n {
                let r2 = (q[i][0] - q[j][0]).powi(2) + (q[i][1] - q[j][1]).powi(2);
                let k = tps_phi(r2);
                m[(i, j)] = k;
                m[(j, i)] = k;
            }
            let p = [1.0, q[i][0], q[i][1]];
            for (c, &pc) in p.iter().enumerate() {
                m[(i, n + c)] = pc;
                m[(n + c, i)] = pc;
            }
        }
        let mut rhs = DMatrix::<f64>::zeros(size, 2);
        for (i, v) in values.iter().enumerate() {
            rhs[(i, 0)] = v[0];
            rhs[(i, 1)] = v[1];
        }
        let sol = m.clone().lu().solve(&rhs).ok_or_else(|| {
            ParamError::Factorization("thin-plate spline system is singular".into())
        })?;
        if !sol.iter().all(|v| v.is_finite()) {
            return Err(ParamError::Factorization(
                "thin-plate spline solution is not finite".into(),
            ));
        }
        let weights = (0..n).map(|i| [sol[(i, 0)], sol[(i, 1)]]).collect();
        let affine = [
            [sol[(n, 0)], sol[(n + 1, 0)], sol[(n + 2, 0)]],
            [sol[(n, 1)], sol[(n + 1, 1)], sol[(n + 2, 1)]],
        ];
        Ok(ThinPlateSpline2 {
            centers: q,
            weights,
            affine,
            shift,
            scale,
        })
    }

    /// Normalized coordinates of `p`.
    #[inline]
    fn normalize(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.shift[0]) / self.scale,
            (p[1] - self.shift[1]) / self.scale,
        ]
    }

    /// `f(p) = a + A p + sum_i w_i phi(|p - c_i|)`; interpolates the centres
    /// (`f(c_i) = v_i` up to round-off).
    pub fn eval(&self, p: [f64; 2]) -> [f64; 2] {
        let q = self.normalize(p);
        let mut f = self.affine.map(|a| a[0] + a[1] * q[0] + a[2] * q[1]);
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let phi = tps_phi((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2));
            f[0] += w[0] * phi;
            f[1] += w[1] * phi;
        }
        f
    }

    /// [`Self::eval`] at many points (in parallel).
    pub fn eval_many(&self, points: &[[f64; 2]]) -> Vec<[f64; 2]> {
        points.par_iter().map(|&p| self.eval(p)).collect()
    }

    /// The Jacobian `df/dp` at `p` (row `k` = gradient of `f_k`):
    ///
    /// ```text
    /// df/dp = A + sum_i w_i (2 log r_i + 1) (p - c_i)^T,   r_i = |p - c_i|
    /// ```
    ///
    /// since `grad phi(|p - c|) = phi'(r)/r (p - c)` with
    /// `phi'(r)/r = 2 log r + 1` (the term vanishes at `r = 0`). Evaluated in
    /// the normalized coordinates and scaled by `dq/dp = 1/s`. Its
    /// determinant tells whether the warp folds at `p`.
    pub fn jacobian(&self, p: [f64; 2]) -> [[f64; 2]; 2] {
        let q = self.normalize(p);
        let mut j = [[0.0; 2]; 2];
        for (k, row) in j.iter_mut().enumerate() {
            row[0] = self.affine[k][1];
            row[1] = self.affine[k][2];
        }
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let d = [q[0] - c[0], q[1] - c[1]];
            let r2 = d[0] * d[0] + d[1] * d[1];
            if r2 > 0.0 {
                let g = r2.ln() + 1.0; // 2 log r + 1
                for k in 0..2 {
                    j[k][0] += w[k] * g * d[0];
                    j[k][1] += w[k] * g * d[1];
                }
            }
        }
        // dq/dp = 1/s.
        for row in j.iter_mut() {
            row[0] /= self.scale;
            row[1] /= self.scale;
        }
        j
    }

    /// The radial weights `w_i` (in the normalized coordinates; all zero
    /// when the data are affine).
    pub fn weights(&self) -> &[[f64; 2]] {
        &self.weights
    }

    /// Number of centres.
    pub fn num_centers(&self) -> usize {
        self.centers.len()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{Point3, Vector2};
    use proptest::prelude::*;
    use unfold_mesh::shapes::primitives::kuhn_grid;
    use unfold_mesh::topology::boundary_loops;

    /// A tiny deterministic generator (SplitMix64).
    pub(crate) struct Rng(pub u64);

    impl Rng {
        pub(crate) fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [0, 1).
        pub(crate) fn f64(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Uniform in [-h, h).
        pub(crate) fn sym(&mut self, h: f64) -> f64 {
            (2.0 * self.f64() - 1.0) * h
        }
        /// Uniform in 0..n.
        pub(crate) fn below(&mut self, n: usize) -> usize {
            (self.next_u64() % n as u64) as usize
        }
    }

    pub(crate) fn orient2(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
        0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x))
    }

    /// A height field lifting a planar mesh to a curved surface (a graph,
    /// so the triangles keep their orientation seen from +z).
    pub(crate) fn lift(mesh: &mut TriMesh, amplitude: f64) {
        for p in &mut mesh.positions {
            p.z = amplitude * ((1.3 * p.x).sin() * (0.7 * p.y).cos() + 0.2 * p.x * p.x);
        }
    }

    /// An `nx x ny` unit grid with random diagonals, interior vertices
    /// jittered by at most 0.15 (keeps every triangle positive), then
    /// sheared by `x += shear * y` (obtuse triangles); planar, ccw.
    pub(crate) fn perturbed_grid(nx: usize, ny: usize, shear: f64, rng: &mut Rng) -> TriMesh {
        let id = |x: usize, y: usize| (x + (nx + 1) * y) as u32;
        let mut positions = Vec::new();
        for y in 0..=ny {
            for x in 0..=nx {
                let interior = x > 0 && x < nx && y > 0 && y < ny;
                let (dx, dy) = if interior {
                    (rng.sym(0.15), rng.sym(0.15))
                } else {
                    (0.0, 0.0)
                };
                let (px, py) = (x as f64 + dx, y as f64 + dy);
                positions.push(Point3::new(px + shear * py, py, 0.0));
            }
        }
        let mut tris = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
                if rng.below(2) == 0 {
                    tris.push([a, b, c]);
                    tris.push([a, c, d]);
                } else {
                    tris.push([a, b, d]);
                    tris.push([b, c, d]);
                }
            }
        }
        let m = TriMesh::new(positions, tris);
        for t in 0..m.num_triangles() {
            let [a, b, c] = m.triangle_points(t);
            assert!(orient2(&a, &b, &c) > 0.0);
        }
        m
    }

    /// A random planar triangulated disk: a star-shaped (non-convex)
    /// polygon fanned from the origin, then random triangle splits at
    /// random interior points (thin, obtuse triangles) and random flips of
    /// interior edges of strictly convex quads (non-Delaunay). Counter-
    /// clockwise.
    pub(crate) fn random_disk(
        rng: &mut Rng,
        boundary: usize,
        splits: usize,
        flips: usize,
    ) -> TriMesh {
        // With at least 4 boundary vertices and a jitter of 0.2, consecutive
        // angles differ by less than pi: the fan is valid.
        let boundary = boundary.max(4);
        let mut pos = vec![Point3::origin()];
        for k in 0..boundary {
            let t = std::f64::consts::TAU * (k as f64 + rng.sym(0.2)) / boundary as f64;
            let r = 0.6 + 0.8 * rng.f64();
            pos.push(Point3::new(r * t.cos(), r * t.sin(), 0.0));
        }
        let mut tris: Vec<[u32; 3]> = (0..boundary)
            .map(|k| [0, 1 + k as u32, 1 + ((k + 1) % boundary) as u32])
            .collect();
        let area = |pos: &[Point3<f64>], t: [u32; 3]| {
            orient2(
                &pos[t[0] as usize],
                &pos[t[1] as usize],
                &pos[t[2] as usize],
            )
        };
        for _ in 0..splits {
            let k = rng.below(tris.len());
            let t = tris[k];
            let mut w = [0.03 + rng.f64(), 0.03 + rng.f64(), 0.03 + rng.f64()];
            let s = w[0] + w[1] + w[2];
            w.iter_mut().for_each(|x| *x /= s);
            let p = Point3::from(
                pos[t[0] as usize].coords * w[0]
                    + pos[t[1] as usize].coords * w[1]
                    + pos[t[2] as usize].coords * w[2],
            );
            let v = pos.len() as u32;
            pos.push(p);
            tris[k] = [t[0], t[1], v];
            tris.push([t[1], t[2], v]);
            tris.push([t[2], t[0], v]);
        }
        for _ in 0..flips {
            // Directed edge -> triangle.
            let mut owner = std::collections::HashMap::new();
            for (k, t) in tris.iter().enumerate() {
                for i in 0..3 {
                    owner.insert((t[i], t[(i + 1) % 3]), (k, t[(i + 2) % 3]));
                }
            }
            let k1 = rng.below(tris.len());
            let i = rng.below(3);
            let t1 = tris[k1];
            let (a, b, c) = (t1[i], t1[(i + 1) % 3], t1[(i + 2) % 3]);
            let Some(&(k2, d)) = owner.get(&(b, a)) else {
                continue;
            };
            let (n1, n2) = ([c, a, d], [c, d, b]);
            let min = 1e-4 * (area(&pos, t1) + area(&pos, tris[k2]));
            if area(&pos, n1) > min && area(&pos, n2) > min && !owner.contains_key(&(c, d)) {
                tris[k1] = n1;
                tris[k2] = n2;
            }
        }
        let m = TriMesh::new(pos, tris);
        for t in 0..m.num_triangles() {
            let [a, b, c] = m.triangle_points(t);
            assert!(orient2(&a, &b, &c) > 0.0);
        }
        m
    }

    /// Vertices on the boundary loops.
    pub(crate) fn boundary_mask(mesh: &TriMesh) -> Vec<bool> {
        let mut b = vec![false; mesh.num_vertices()];
        for lp in boundary_loops(mesh).unwrap() {
            for v in lp {
                b[v as usize] = true;
            }
        }
        b
    }

    /// A Kuhn grid with its interior vertices jittered (all tets stay
    /// positive for `jitter <= 0.1`).
    fn perturbed_tet_grid(n: usize, rng: &mut Rng, jitter: f64) -> (TetMesh, Vec<bool>) {
        let mut m = kuhn_grid([n, n, n], [1.0, 1.0, 1.0]);
        let mut boundary = Vec::new();
        for p in &mut m.positions {
            let on = [p.x, p.y, p.z]
                .iter()
                .any(|&c| c.abs() < 1e-9 || (c - n as f64).abs() < 1e-9);
            boundary.push(on);
            if !on {
                p.x += rng.sym(jitter);
                p.y += rng.sym(jitter);
                p.z += rng.sym(jitter);
            }
        }
        for t in 0..m.num_tets() {
            let [a, b, c, d] = m.tet_points(t);
            assert!(unfold_mesh::geometry::tet_signed_volume(&a, &b, &c, &d) > 0.0);
        }
        (m, boundary)
    }

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

    #[test]
    fn sparse_sym_merges_entries_into_the_upper_triangle() {
        let a = SparseSym::from_entries(3, [(1, 0, 2.0), (0, 1, 1.0), (2, 2, 4.0), (0, 0, 1.0)]);
        assert_eq!(a.triplets, vec![(0, 0, 1.0), (0, 1, 3.0), (2, 2, 4.0)]);
        assert_eq!(a.get(1, 0), 3.0);
        assert_eq!(a.get(1, 2), 0.0);
        assert_eq!(a.multiply(&[1.0, 2.0, 3.0]), vec![7.0, 3.0, 12.0]);
        assert_eq!(a.quadratic_form(&[1.0, 2.0, 3.0]), 1.0 + 12.0 + 36.0);
        assert_eq!(a.diagonal(), vec![1.0, 0.0, 4.0]);
        assert_eq!(a.nnz(), 3);
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
            prop_assert!(l.triplets.iter().all(|t| t.0 <= t.1));
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
            let k = SparseSym::from_entries(m.num_vertices(), entries);
            let l = cotan_laplacian(&m);
            prop_assert_eq!(k.nnz(), l.nnz());
            for (e, f) in k.triplets.iter().zip(&l.triplets) {
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

        #[test]
        fn harmonic_solve_reproduces_linear_functions(
            seed in any::<u64>(), a in -2.0..2.0f64, b in -2.0..2.0f64,
        ) {
            let mut rng = Rng(seed);
            // Triangles: cotangent Laplacian of a planar mesh.
            let m = random_disk(&mut rng, 11, 30, 30);
            let bnd = boundary_mask(&m);
            let fixed: Vec<u32> = (0..m.num_vertices() as u32).filter(|&v| bnd[v as usize]).collect();
            let f = |p: &Point3<f64>| [p.x, p.y, a * p.x + b * p.y + 1.0];
            let values: Vec<Vec<f64>> = (0..3)
                .map(|k| fixed.iter().map(|&v| f(&m.positions[v as usize])[k]).collect())
                .collect();
            let sol = solve_dirichlet(&cotan_laplacian(&m), &fixed, &values).unwrap();
            // The mean-value solve (non-symmetric LU) has linear precision too.
            let mv = solve_dirichlet_weights(&mean_value_weights(&m), &fixed, &values).unwrap();
            for (i, p) in m.positions.iter().enumerate() {
                let e = f(p);
                for k in 0..3 {
                    prop_assert!((sol[k][i] - e[k]).abs() < 1e-9, "cotan {} {}", i, k);
                    prop_assert!((mv[k][i] - e[k]).abs() < 1e-9, "mean value {} {}", i, k);
                }
            }
            // Tets: P1 stiffness of a perturbed grid.
            let (t, boundary) = perturbed_tet_grid(3, &mut rng, 0.1);
            let fixed: Vec<u32> = (0..t.num_vertices() as u32).filter(|&v| boundary[v as usize]).collect();
            let g = |p: &Point3<f64>| a * p.x - b * p.y + 0.5 * p.z - 2.0;
            let values = vec![fixed.iter().map(|&v| g(&t.positions[v as usize])).collect::<Vec<_>>()];
            let sol = solve_dirichlet(&p1_stiffness(&t), &fixed, &values).unwrap();
            for (i, p) in t.positions.iter().enumerate() {
                prop_assert!((sol[0][i] - g(p)).abs() < 1e-9);
            }
        }

        #[test]
        fn tps_interpolates_its_centres(
            pts in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64, -5.0..5.0f64, -5.0..5.0f64), 3..40),
        ) {
            let centers: Vec<[f64; 2]> = pts.iter().map(|p| [p.0, p.1]).collect();
            let values: Vec<[f64; 2]> = pts.iter().map(|p| [p.2, p.3]).collect();
            match ThinPlateSpline2::fit(&centers, &values) {
                Ok(tps) => {
                    for (c, v) in centers.iter().zip(&values) {
                        let f = tps.eval(*c);
                        prop_assert!((f[0] - v[0]).abs() < 1e-7 && (f[1] - v[1]).abs() < 1e-7,
                            "f({:?}) = {:?}, expected {:?}", c, f, v);
                    }
                    let many = tps.eval_many(&centers);
                    prop_assert_eq!(many[0], tps.eval(centers[0]));
                }
                // Random centres may (rarely) nearly coincide or line up.
                Err(ParamError::InvalidArgument(_)) => {}
                Err(e) => prop_assert!(false, "{e}"),
            }
        }

        #[test]
        fn tps_reproduces_affine_maps(
            pts in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64), 4..30),
            aff in prop::array::uniform6(-3.0..3.0f64),
            probe in prop::array::uniform2(-15.0..15.0f64),
        ) {
            let centers: Vec<[f64; 2]> = pts.iter().map(|p| [p.0, p.1]).collect();
            let map = |p: [f64; 2]| [aff[0] + aff[1] * p[0] + aff[2] * p[1],
                                     aff[3] + aff[4] * p[0] + aff[5] * p[1]];
            let values: Vec<[f64; 2]> = centers.iter().map(|&c| map(c)).collect();
            if let Ok(tps) = ThinPlateSpline2::fit(&centers, &values) {
                let scale = 1.0 + aff.iter().fold(0.0f64, |m, v| m.max(v.abs())) * 30.0;
                for w in tps.weights() {
                    prop_assert!(w[0].abs() < 1e-8 * scale && w[1].abs() < 1e-8 * scale, "{:?}", w);
                }
                let (f, e) = (tps.eval(probe), map(probe));
                prop_assert!((f[0] - e[0]).abs() < 1e-7 * scale && (f[1] - e[1]).abs() < 1e-7 * scale);
                let j = tps.jacobian(probe);
                prop_assert!((j[0][0] - aff[1]).abs() < 1e-7 * scale && (j[1][1] - aff[5]).abs() < 1e-7 * scale);
            }
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
                .triplets
                .iter()
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

    #[test]
    fn dirichlet_solves_reject_bad_input() {
        let m = random_disk(&mut Rng(3), 8, 5, 0);
        let l = cotan_laplacian(&m);
        let w = mean_value_weights(&m);
        let n = m.num_vertices() as u32;
        let bnd: Vec<u32> = (1..9).collect();
        let vals = vec![vec![1.0; 8]];
        assert!(solve_dirichlet(&l, &bnd, &vals).is_ok());
        // Out of range, duplicate, wrong length, not finite.
        let mut bad = bnd.clone();
        bad[0] = n;
        assert!(matches!(
            solve_dirichlet(&l, &bad, &vals),
            Err(ParamError::InvalidArgument(_))
        ));
        assert!(matches!(
            solve_dirichlet_weights(&w, &bad, &vals),
            Err(ParamError::InvalidArgument(_))
        ));
        let mut dup = bnd.clone();
        dup[1] = dup[0];
        assert!(matches!(
            solve_dirichlet(&l, &dup, &vals),
            Err(ParamError::InvalidArgument(_))
        ));
        assert!(matches!(
            solve_dirichlet(&l, &bnd, &[vec![1.0; 7]]),
            Err(ParamError::Length { .. })
        ));
        assert!(matches!(
            solve_dirichlet_weights(&w, &bnd, &[vec![f64::NAN; 8]]),
            Err(ParamError::NotFinite(_))
        ));
        // No fixed vertex: singular.
        assert!(matches!(
            solve_dirichlet(&l, &[], &[vec![]]),
            Err(ParamError::InvalidArgument(_))
        ));
        assert!(matches!(
            solve_dirichlet_weights(&w, &[], &[vec![]]),
            Err(ParamError::InvalidArgument(_))
        ));
        // An isolated vertex that is free.
        let mut m2 = m.clone();
        m2.positions.push(Point3::new(5.0, 5.0, 0.0));
        let err = solve_dirichlet(&cotan_laplacian(&m2), &bnd, &vals).unwrap_err();
        assert!(err.to_string().contains("not connected"), "{err}");
        assert!(solve_dirichlet_weights(&mean_value_weights(&m2), &bnd, &vals).is_err());
        // Everything fixed: the values come back.
        let all: Vec<u32> = (0..n).collect();
        let v: Vec<f64> = (0..n).map(f64::from).collect();
        assert_eq!(
            solve_dirichlet(&l, &all, std::slice::from_ref(&v)).unwrap()[0],
            v
        );
        assert_eq!(
            solve_dirichlet_weights(&w, &all, std::slice::from_ref(&v)).unwrap()[0],
            v
        );
    }

    #[test]
    fn tps_rejects_duplicate_collinear_and_too_few_centres() {
        let v3 = [[0.0, 0.0]; 3];
        let dup = ThinPlateSpline2::fit(
            &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
            &[[0.0; 2]; 4],
        );
        assert!(
            matches!(dup, Err(ParamError::InvalidArgument(ref s)) if s.contains("coincide")),
            "{dup:?}"
        );
        let line = ThinPlateSpline2::fit(
            &[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]],
            &[[0.0; 2]; 4],
        );
        assert!(
            matches!(line, Err(ParamError::InvalidArgument(ref s)) if s.contains("collinear")),
            "{line:?}"
        );
        assert!(ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0]], &[[0.0; 2]; 2]).is_err());
        assert!(matches!(
            ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &v3[..2]),
            Err(ParamError::Length { .. })
        ));
        assert!(ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0], [0.0, f64::NAN]], &v3).is_err());
        assert!(ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &v3).is_ok());
    }

    #[test]
    fn tps_moves_an_interior_point_keeping_the_boundary_and_its_jacobian_is_exact() {
        // The ventricle use: boundary circle fixed, apex image moved to 0.
        let mut centers: Vec<[f64; 2]> = (0..24)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 24.0;
                [t.cos(), t.sin()]
            })
            .collect();
        let mut values = centers.clone();
        centers.push([0.2, -0.1]);
        values.push([0.0, 0.0]);
        let tps = ThinPlateSpline2::fit(&centers, &values).unwrap();
        let f = tps.eval([0.2, -0.1]);
        assert!(f[0].abs() < 1e-12 && f[1].abs() < 1e-12);
        assert!((tps.eval([1.0, 0.0])[0] - 1.0).abs() < 1e-12);
        assert_eq!(tps.num_centers(), 25);
        let h = 1e-6;
        for p in [[0.3, 0.4], [-0.5, 0.1], [0.2, -0.1], [0.0, 0.9]] {
            let j = tps.jacobian(p);
            for d in 0..2 {
                let mut pp = p;
                let mut pm = p;
                pp[d] += h;
                pm[d] -= h;
                let (fp, fm) = (tps.eval(pp), tps.eval(pm));
                for k in 0..2 {
                    let fd = (fp[k] - fm[k]) / (2.0 * h);
                    assert!(
                        (j[k][d] - fd).abs() < 1e-6,
                        "J[{k}][{d}] = {} vs {fd}",
                        j[k][d]
                    );
                }
            }
            // This mild warp does not fold.
            assert!(j[0][0] * j[1][1] - j[0][1] * j[1][0] > 0.0);
        }
    }
}
