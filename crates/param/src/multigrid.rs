//! Multigrid-preconditioned conjugate gradients for large sparse symmetric
//! positive definite systems, made for grid Laplacians on irregular masked 3D
//! grids (the Laplace field of a heart chamber: 0.3-3 million unknowns).
//!
//! The pieces:
//!
//! - [`Csr`]: a compressed-sparse-row matrix with the products multigrid
//!   needs (`y = A x` in parallel, `A^T`, the Galerkin product `P^T A P`).
//! - [`grid_prolongation`]: trilinear interpolation `P` from the grid
//!   coarsened by 2 in each direction to the masked fine grid.
//! - [`Multigrid`]: the hierarchy `A_0 = A`, `A_{l+1} = P_l^T A_l P_l`
//!   (Galerkin coarse operators) and one symmetric V(1,1) cycle as the
//!   preconditioner `z = M^{-1} r`: a forward Gauss-Seidel sweep before the
//!   coarse correction, a backward sweep after it, an exact dense solve on the
//!   coarsest level.
//! - [`pcg`]: preconditioned conjugate gradients with that preconditioner.
//!   With a good hierarchy the iteration count does not grow with the grid
//!   size (about ten iterations for `1e-10` on 7-point Laplacians).
//!
//! Masked grids make the coarse levels rank deficient: a coarse node whose
//! own fine node is outside the mask has a basis function built from its
//! fine neighbours only, and such functions can be linearly dependent (an
//! isolated fine node at an odd position has 8 coarse parents with the same
//! column in `P`). Then `A_{l+1}` is only semidefinite, with null space
//! `null(P_0 ... P_l)`. This is harmless for the V-cycle (the coarse right
//! hand sides are orthogonal to that null space, and null-space components
//! of a coarse correction vanish on the fine grid), provided the smoother
//! skips zero diagonals and the coarsest solve handles a semidefinite matrix:
//! it is a Cholesky factorization that drops (fixes to zero) every unknown
//! whose pivot vanishes, and each dropped direction `n` is checked to satisfy
//! `Q n = 0` for the composite prolongation `Q` (else `A` itself is singular,
//! an error).

use crate::ParamError;
use rayon::prelude::*;

/// Rows (or vector entries) per rayon task.
const ROW_CHUNK: usize = 4096;

/// Vectors and matrices with fewer rows than this are handled sequentially.
const PAR_MIN: usize = 10_000;

/// Default size of the coarsest level: [`Multigrid::new`] stops coarsening
/// once a level has at most this many unknowns.
pub const COARSEST: usize = 1000;

/// Largest coarsest level solved by the dense Cholesky factorization
/// (`8 n^2` bytes, `n^3 / 3` multiply-adds); a larger one is an error.
pub const MAX_DENSE: usize = 4000;

/// A coarsest-level pivot `s_j <= PIVOT_TOL a_jj` counts as zero (the unknown
/// is linearly dependent on the earlier ones).
const PIVOT_TOL: f64 = 1e-10;

/// A dropped coarsest-level direction `n` is a null vector of the
/// prolongations when `|Q n|^2 <= NULL_TOL sum_i n_i^2 |Q e_i|^2`.
const NULL_TOL: f64 = 1e-8;

/// Largest matrix dimension: indices are stored as `u32`.
const MAX_DIM: usize = u32::MAX as usize;

// ---------------------------------------------------------------------------
// Compressed sparse rows
// ---------------------------------------------------------------------------

/// Compressed sparse row matrix (f64), row-major, column indices sorted and
/// unique within a row.
///
/// Row `i` holds the entries `a_{i, col[k]} = val[k]` for
/// `k in row_ptr[i] .. row_ptr[i + 1]`. Every value is finite; both
/// dimensions are at most `u32::MAX`.
#[derive(Debug, Clone, PartialEq)]
pub struct Csr {
    n_rows: usize,
    n_cols: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<f64>,
}

impl Csr {
    /// A matrix from its CSR arrays, checked: `row_ptr` has `n_rows + 1`
    /// non-decreasing entries from 0 to `col.len() == val.len()`, columns are
    /// strictly increasing within each row and `< n_cols`, values finite.
    ///
    /// # Errors
    /// [`ParamError::InvalidArgument`] naming the first violation.
    pub fn from_raw(
        n_rows: usize,
        n_cols: usize,
        row_ptr: Vec<usize>,
        col: Vec<u32>,
        val: Vec<f64>,
    ) -> Result<Csr, ParamError> {
        let bad = |why: String| Err(ParamError::InvalidArgument(format!("CSR arrays: {why}")));
        if n_rows > MAX_DIM || n_cols > MAX_DIM {
            return bad(format!("{n_rows} x {n_cols} exceeds u32::MAX"));
        }
        if row_ptr.len() != n_rows + 1 || row_ptr[0] != 0 {
            return bad(format!(
                "row_ptr must have {} entries starting at 0",
                n_rows + 1
            ));
        }
        if col.len() != val.len() || row_ptr[n_rows] != col.len() {
            return bad(format!(
                "row_ptr ends at {}, with {} columns and {} values",
                row_ptr[n_rows],
                col.len(),
                val.len()
            ));
        }
        for i in 0..n_rows {
            if row_ptr[i] > row_ptr[i + 1] {
                return bad(format!("row_ptr decreases at row {i}"));
            }
            let cols = &col[row_ptr[i]..row_ptr[i + 1]];
            if cols.windows(2).any(|w| w[0] >= w[1]) {
                return bad(format!("columns of row {i} are not strictly increasing"));
            }
            if cols.last().is_some_and(|&c| c as usize >= n_cols) {
                return bad(format!("a column of row {i} is out of range"));
            }
        }
        if let Some(k) = val.iter().position(|v| !v.is_finite()) {
            return bad(format!("value {k} is not finite"));
        }
        Ok(Csr {
            n_rows,
            n_cols,
            row_ptr,
            col,
            val,
        })
    }

    /// The `n_rows x n_cols` matrix `A = sum_t v_t e_{i_t} e_{j_t}^T` of the
    /// triplets `(i_t, j_t, v_t)`: values at the same position are summed
    /// (an entry summing to zero is kept as an explicit zero).
    ///
    /// # Errors
    /// [`ParamError::InvalidArgument`] if a dimension exceeds `u32::MAX`, an
    /// index is out of range, or a value (or a sum of duplicates) is not
    /// finite.
    pub fn from_triplets(
        n_rows: usize,
        n_cols: usize,
        triplets: &[(u32, u32, f64)],
    ) -> Result<Csr, ParamError> {
        if n_rows > MAX_DIM || n_cols > MAX_DIM {
            return Err(ParamError::InvalidArgument(format!(
                "a {n_rows} x {n_cols} matrix is too large: dimensions are limited to u32::MAX"
            )));
        }
        for (t, &(i, j, v)) in triplets.iter().enumerate() {
            if i as usize >= n_rows || j as usize >= n_cols {
                return Err(ParamError::InvalidArgument(format!(
                    "triplet {t}: index ({i}, {j}) is out of range for a {n_rows} x {n_cols} matrix"
                )));
            }
            if !v.is_finite() {
                return Err(ParamError::InvalidArgument(format!(
                    "triplet {t}: value {v} at ({i}, {j}) is not finite"
                )));
            }
        }
        // Bucket by row (counting sort), then sort and merge each row.
        let mut start = vec![0usize; n_rows + 1];
        for &(i, _, _) in triplets {
            start[i as usize + 1] += 1;
        }
        for i in 0..n_rows {
            start[i + 1] += start[i];
        }
        let mut next = start[..n_rows].to_vec();
        let mut col = vec![0u32; triplets.len()];
        let mut val = vec![0.0; triplets.len()];
        for &(i, j, v) in triplets {
            let p = next[i as usize];
            col[p] = j;
            val[p] = v;
            next[i as usize] += 1;
        }
        let mut row_ptr = Vec::with_capacity(n_rows + 1);
        row_ptr.push(0);
        let mut out = 0;
        let mut scratch: Vec<(u32, f64)> = Vec::new();
        for i in 0..n_rows {
            scratch.clear();
            scratch.extend(
                col[start[i]..start[i + 1]]
                    .iter()
                    .copied()
                    .zip(val[start[i]..start[i + 1]].iter().copied()),
            );
            scratch.sort_unstable_by_key(|&(j, _)| j);
            let row_start = out;
            for &(j, v) in &scratch {
                if out > row_start && col[out - 1] == j {
                    val[out - 1] += v;
                } else {
                    // `out <= start[i] + (entries read so far)`: never ahead of
                    // what is still unread, and the row is in `scratch`.
                    col[out] = j;
                    val[out] = v;
                    out += 1;
                }
            }
            row_ptr.push(out);
        }
        col.truncate(out);
        val.truncate(out);
        if let Some(k) = val.iter().position(|v| !v.is_finite()) {
            let i = row_ptr.partition_point(|&p| p <= k) - 1;
            return Err(ParamError::InvalidArgument(format!(
                "the duplicates at ({i}, {}) sum to {}, which is not finite",
                col[k], val[k]
            )));
        }
        Ok(Csr {
            n_rows,
            n_cols,
            row_ptr,
            col,
            val,
        })
    }

    /// The `n x n` identity matrix `I` (`n <= u32::MAX`).
    fn identity(n: usize) -> Csr {
        Csr {
            n_rows: n,
            n_cols: n,
            row_ptr: (0..=n).collect(),
            col: (0..n as u32).collect(),
            val: vec![1.0; n],
        }
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Number of columns.
    pub fn n_cols(&self) -> usize {
        self.n_cols
    }

    /// Number of stored entries (explicit zeros included).
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Row `i` as `(column indices, values)`: the entries `a_{i, cols[k]} = vals[k]`,
    /// columns ascending.
    ///
    /// # Panics
    /// If `i >= n_rows`.
    #[inline]
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
        (&self.col[s..e], &self.val[s..e])
    }

    /// `sum_j a_ij x_j`.
    #[inline]
    fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let (c, v) = self.row(i);
        c.iter().zip(v).map(|(&j, &a)| a * x[j as usize]).sum()
    }

    /// Calls `f(i, &mut y[i])` for every row `i`, in parallel over chunks
    /// of [`ROW_CHUNK`] rows when the matrix is large.
    fn for_each_row(&self, y: &mut [f64], f: impl Fn(usize, &mut f64) + Sync) {
        if y.len() < PAR_MIN {
            y.iter_mut().enumerate().for_each(|(i, yi)| f(i, yi));
        } else {
            y.par_chunks_mut(ROW_CHUNK)
                .enumerate()
                .for_each(|(c, chunk)| {
                    let base = c * ROW_CHUNK;
                    for (k, yi) in chunk.iter_mut().enumerate() {
                        f(base + k, yi);
                    }
                });
        }
    }

    /// `y = A x`, i.e. `y_i = sum_k val[k] x[col[k]]` over the entries `k`
    /// of row `i`; rayon-parallel over chunks of 4096 rows (sequential
    /// below 10 000 rows).
    ///
    /// # Panics
    /// If `x.len() != n_cols` or `y.len() != n_rows` (a programming error;
    /// checked in every build, it costs two comparisons).
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.n_cols, "Csr::mul_vec: x has the wrong length");
        assert_eq!(y.len(), self.n_rows, "Csr::mul_vec: y has the wrong length");
        self.for_each_row(y, |i, yi| *yi = self.row_dot(i, x));
    }

    /// `y += A x`.
    fn mul_vec_add(&self, x: &[f64], y: &mut [f64]) {
        debug_assert_eq!(x.len(), self.n_cols);
        debug_assert_eq!(y.len(), self.n_rows);
        self.for_each_row(y, |i, yi| *yi += self.row_dot(i, x));
    }

    /// `res = b - A x`.
    fn residual(&self, b: &[f64], x: &[f64], res: &mut [f64]) {
        debug_assert_eq!(x.len(), self.n_cols);
        debug_assert_eq!(b.len(), self.n_rows);
        debug_assert_eq!(res.len(), self.n_rows);
        self.for_each_row(res, |i, ri| *ri = b[i] - self.row_dot(i, x));
    }

    /// The transpose `A^T` (`(A^T)_{ji} = a_ij`), by a counting sort over
    /// the columns; rows of the result come out sorted.
    pub fn transpose(&self) -> Csr {
        let mut row_ptr = vec![0usize; self.n_cols + 1];
        for &j in &self.col {
            row_ptr[j as usize + 1] += 1;
        }
        for j in 0..self.n_cols {
            row_ptr[j + 1] += row_ptr[j];
        }
        let mut next = row_ptr[..self.n_cols].to_vec();
        let mut col = vec![0u32; self.nnz()];
        let mut val = vec![0.0; self.nnz()];
        for i in 0..self.n_rows {
            let (c, v) = self.row(i);
            for (&j, &a) in c.iter().zip(v) {
                let p = next[j as usize];
                col[p] = i as u32;
                val[p] = a;
                next[j as usize] += 1;
            }
        }
        Csr {
            n_rows: self.n_cols,
            n_cols: self.n_rows,
            row_ptr,
            col,
            val,
        }
    }

    /// The diagonal `d_i = a_ii`, `i < min(n_rows, n_cols)` (zero where no
    /// entry is stored).
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.n_rows.min(self.n_cols))
            .map(|i| {
                let (c, v) = self.row(i);
                c.binary_search(&(i as u32)).map_or(0.0, |k| v[k])
            })
            .collect()
    }

    /// Galerkin coarse operator `P^T A P` (`A` square `n x n`, `P` `n x m`)
    /// -> `m x m`:
    ///
    /// ```text
    /// (P^T A P)_{IJ} = sum_{i,j} p_{iI} a_{ij} p_{jJ}
    /// ```
    ///
    /// computed as `AP = A P`, then `P^T (AP)` with the explicit transpose,
    /// both row by row (Gustavson) with a dense accumulator and marker array
    /// of size `m` per rayon task.
    ///
    /// # Errors
    /// [`ParamError::InvalidArgument`] if `A` is not square,
    /// [`ParamError::Length`] if `P` does not have `n` rows,
    /// [`ParamError::NotFinite`] if the product overflows.
    pub fn galerkin(&self, p: &Csr) -> Result<Csr, ParamError> {
        if self.n_rows != self.n_cols {
            return Err(ParamError::InvalidArgument(format!(
                "galerkin: A must be square, it is {} x {}",
                self.n_rows, self.n_cols
            )));
        }
        if p.n_rows != self.n_rows {
            return Err(ParamError::Length {
                what: "galerkin: rows of the prolongation P",
                expected: self.n_rows,
                found: p.n_rows,
            });
        }
        let ap = spgemm(self, p);
        let c = spgemm(&p.transpose(), &ap);
        if c.val.iter().any(|v| !v.is_finite()) {
            return Err(ParamError::NotFinite(
                "the Galerkin product P^T A P overflowed".into(),
            ));
        }
        Ok(c)
    }
}

/// The sparse product `C = A B` (`a.n_cols == b.n_rows`), row by row:
/// `c_{i.} = sum_k a_ik b_{k.}` gathered in a dense accumulator of size
/// `b.n_cols` with a marker array (no per-row allocation), rows in parallel
/// blocks.
fn spgemm(a: &Csr, b: &Csr) -> Csr {
    debug_assert_eq!(a.n_cols, b.n_rows);
    let (n, m) = (a.n_rows, b.n_cols);
    let tasks = 4 * rayon::current_num_threads().max(1);
    let block = n.div_ceil(tasks).max(ROW_CHUNK);
    let starts: Vec<usize> = (0..n).step_by(block).collect();
    let parts: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = starts
        .par_iter()
        .map(|&s| {
            let e = (s + block).min(n);
            // `marker[j] == i` iff column j already has an entry in row i
            // (`i < n <= u32::MAX`, so `u32::MAX` is never a row).
            let mut marker = vec![u32::MAX; m];
            let mut acc = vec![0.0; m];
            let mut pattern: Vec<u32> = Vec::new();
            let mut lens = Vec::with_capacity(e - s);
            let mut col = Vec::new();
            let mut val = Vec::new();
            for i in s..e {
                let row = i as u32;
                pattern.clear();
                let (ac, av) = a.row(i);
                for (&k, &aik) in ac.iter().zip(av) {
                    let (bc, bv) = b.row(k as usize);
                    for (&j, &bkj) in bc.iter().zip(bv) {
                        let ju = j as usize;
                        if marker[ju] != row {
                            marker[ju] = row;
                            acc[ju] = aik * bkj;
                            pattern.push(j);
                        } else {
                            acc[ju] += aik * bkj;
                        }
                    }
                }
                pattern.sort_unstable();
                col.extend_from_slice(&pattern);
                val.extend(pattern.iter().map(|&j| acc[j as usize]));
                lens.push(pattern.len());
            }
            (lens, col, val)
        })
        .collect();
    let mut row_ptr = Vec::with_capacity(n + 1);
    row_ptr.push(0);
    for len in parts.iter().flat_map(|p| &p.0) {
        row_ptr.push(row_ptr.last().copied().unwrap_or(0) + len);
    }
    // Gather the blocks in parallel (first-touching fresh memory is slow:
    // spread it over the threads).
    let nnz = row_ptr.last().copied().unwrap_or(0);
    let mut col = vec![0u32; nnz];
    let mut val = vec![0.0; nnz];
    let mut targets = Vec::with_capacity(parts.len());
    let (mut col_rest, mut val_rest) = (&mut col[..], &mut val[..]);
    for p in &parts {
        let (c, cr) = col_rest.split_at_mut(p.1.len());
        let (v, vr) = val_rest.split_at_mut(p.2.len());
        targets.push((c, v));
        (col_rest, val_rest) = (cr, vr);
    }
    parts.par_iter().zip(targets).for_each(|(p, (c, v))| {
        c.copy_from_slice(&p.1);
        v.copy_from_slice(&p.2);
    });
    Csr {
        n_rows: n,
        n_cols: m,
        row_ptr,
        col,
        val,
    }
}

// ---------------------------------------------------------------------------
// Grid prolongation
// ---------------------------------------------------------------------------

/// The 1D trilinear parents of fine coordinate `i`: `i = 2I` has the single
/// parent `I` (weight 1), `i = 2I + 1` has `I` and `I + 1` (weight 1/2 each).
#[inline]
fn parents_1d(i: usize) -> ([(usize, f64); 2], usize) {
    if i.is_multiple_of(2) {
        ([(i / 2, 1.0), (0, 0.0)], 1)
    } else {
        ([(i / 2, 0.5), (i / 2 + 1, 0.5)], 2)
    }
}

/// Trilinear prolongation for a masked vertex-centred 3D grid coarsened by 2
/// in each direction.
///
/// `dims = [nx, ny, nz]` fine nodes, node `(i, j, k)` has linear id
/// `i + nx (j + ny k)`; `index[id]` is the unknown number of that node or
/// `u32::MAX` if the node is not an unknown (the unknown numbers must be
/// `0 .. n_fine`, each used once, in any order).
///
/// Coarse node `(I, J, K)` sits at fine node `(2I, 2J, 2K)`; the coarse dims
/// are `[nx / 2 + 1, ny / 2 + 1, nz / 2 + 1]` (integer division: `(n - 1) / 2 + 1`
/// for odd `n`; for even `n` one more, the last coarse layer at fine
/// position `n`, just outside the grid, because the last fine layer
/// `n - 1` is odd and interpolates from it).
///
/// The row of fine unknown `(i, j, k)` is the tensor product of the 1D
/// weights: an even coordinate `2I` has the parent `I` with weight 1, an odd
/// one `2I + 1` the parents `I`, `I + 1` with weight 1/2 each, so
///
/// ```text
/// p_{(i,j,k),(I,J,K)} = w(i, I) w(j, J) w(k, K)     (1, 1/2, 1/4 or 1/8; rows sum to 1)
/// ```
///
/// A coarse node is active iff some active fine node has it among its
/// parents; active coarse nodes are numbered in order of their linear id
/// `I + cx (J + cy K)`.
///
/// Returns `(P: n_fine x n_coarse, coarse dims, coarse index array with the
/// same convention)`.
///
/// # Errors
/// [`ParamError::InvalidArgument`] for a zero dimension, a node count that
/// overflows, or unknown numbers that are not `0 .. n_fine` each once;
/// [`ParamError::Length`] if `index.len() != nx ny nz`.
pub fn grid_prolongation(
    dims: [usize; 3],
    index: &[u32],
) -> Result<(Csr, [usize; 3], Vec<u32>), ParamError> {
    let n_nodes = grid_nodes(dims)?;
    if index.len() != n_nodes {
        return Err(ParamError::Length {
            what: "grid index (one entry per node)",
            expected: n_nodes,
            found: index.len(),
        });
    }
    let node_of = unknown_nodes(index)?;
    let [nx, ny, _] = dims;
    let cdims = dims.map(|d| d / 2 + 1);
    let [cx, cy, cz] = cdims;
    let coarse_id = |ci: usize, cj: usize, ck: usize| ci + cx * (cj + cy * ck);

    // Mark the active coarse nodes, then number them in linear-id order.
    let mut cindex = vec![u32::MAX; cx * cy * cz];
    // The trilinear parents of fine node `id`: (coarse linear id, weight),
    // k outer, i inner, i.e. by ascending coarse linear id.
    let for_each_parent = |id: usize, f: &mut dyn FnMut(usize, f64)| {
        let (i, j, k) = (id % nx, (id / nx) % ny, id / (nx * ny));
        let (pi, ni) = parents_1d(i);
        let (pj, nj) = parents_1d(j);
        let (pk, nk) = parents_1d(k);
        for &(ck, wk) in &pk[..nk] {
            for &(cj, wj) in &pj[..nj] {
                for &(ci, wi) in &pi[..ni] {
                    f(coarse_id(ci, cj, ck), wi * wj * wk);
                }
            }
        }
    };
    for &id in &node_of {
        for_each_parent(id, &mut |c, _| cindex[c] = 0);
    }
    let mut n_coarse = 0usize;
    for c in cindex.iter_mut().filter(|c| **c != u32::MAX) {
        if n_coarse >= MAX_DIM {
            return Err(ParamError::InvalidArgument(
                "grid_prolongation: more than u32::MAX - 1 coarse unknowns".into(),
            ));
        }
        *c = n_coarse as u32;
        n_coarse += 1;
    }

    // Rows: parents enumerated k outer, i inner, i.e. by ascending coarse
    // linear id, hence ascending coarse unknown number.
    let mut row_ptr = Vec::with_capacity(node_of.len() + 1);
    row_ptr.push(0);
    let mut col = Vec::with_capacity(node_of.len() * 4);
    let mut val = Vec::with_capacity(node_of.len() * 4);
    for &id in &node_of {
        for_each_parent(id, &mut |c, w| {
            col.push(cindex[c]);
            val.push(w);
        });
        row_ptr.push(col.len());
    }
    let p = Csr {
        n_rows: node_of.len(),
        n_cols: n_coarse,
        row_ptr,
        col,
        val,
    };
    Ok((p, cdims, cindex))
}

/// `nx ny nz`, every dimension positive, without overflow.
fn grid_nodes(dims: [usize; 3]) -> Result<usize, ParamError> {
    if dims.contains(&0) {
        return Err(ParamError::InvalidArgument(format!(
            "grid dims {dims:?}: every dimension must be at least 1"
        )));
    }
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| ParamError::InvalidArgument(format!("grid dims {dims:?}: too many nodes")))
}

/// `node_of[u]`: the node id of unknown `u`, checking that the unknown
/// numbers in `index` are `0 .. n` each once.
fn unknown_nodes(index: &[u32]) -> Result<Vec<usize>, ParamError> {
    let n = index.iter().filter(|&&u| u != u32::MAX).count();
    let mut node_of = vec![usize::MAX; n];
    for (id, &u) in index.iter().enumerate() {
        if u == u32::MAX {
            continue;
        }
        let slot = node_of.get_mut(u as usize).ok_or_else(|| {
            ParamError::InvalidArgument(format!(
                "grid index: node {id} has unknown number {u}, but there are only {n} unknowns \
                 (the numbers must be 0..{n}, each once)"
            ))
        })?;
        if *slot != usize::MAX {
            return Err(ParamError::InvalidArgument(format!(
                "grid index: unknown number {u} is used by nodes {} and {id}",
                *slot
            )));
        }
        *slot = id;
    }
    Ok(node_of)
}

// ---------------------------------------------------------------------------
// Multigrid
// ---------------------------------------------------------------------------

/// One level above the coarsest: its operator, the smoother's inverse
/// diagonal, the prolongation from the next level and its transpose (the
/// restriction).
#[derive(Debug, Clone)]
struct Level {
    a: Csr,
    inv_diag: Vec<f64>,
    p: Csr,
    r: Csr,
}

/// A dense Cholesky factor `A_KK = L_KK L_KK^T` of the coarsest operator on
/// its kept unknowns `K` (the others are dropped: fixed to zero).
#[derive(Debug, Clone)]
struct DenseCholesky {
    n: usize,
    /// Column-major `n x n`; the lower triangle holds `L`. Columns of
    /// dropped unknowns are zero; their rows hold `L_jk`, `k < j`, which
    /// define their null vectors.
    l: Vec<f64>,
    kept: Vec<bool>,
}

impl DenseCholesky {
    /// Right-looking Cholesky of a symmetric positive semidefinite `a`
    /// (lower triangle read): at step `j` the pivot is
    /// `s_j = a_jj - sum_{k<j} l_jk^2`; if `s_j > PIVOT_TOL a_jj` then
    /// `l_jj = sqrt(s_j)`, else if `s_j >= -PIVOT_TOL a_jj` unknown `j` is
    /// linearly dependent on the earlier kept ones and dropped, else `a` is
    /// not positive semidefinite (an error).
    /// Returns the factor and the dropped unknowns.
    fn factor(a: &Csr) -> Result<(DenseCholesky, Vec<usize>), ParamError> {
        let n = a.n_rows;
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            let (c, v) = a.row(i);
            for (&j, &x) in c.iter().zip(v) {
                if (j as usize) <= i {
                    l[i + n * j as usize] = x;
                }
            }
        }
        let diag0: Vec<f64> = (0..n).map(|j| l[j + n * j]).collect();
        let mut kept = vec![true; n];
        let mut dropped = Vec::new();
        for j in 0..n {
            let s = l[j + n * j];
            let scale = diag0[j].abs();
            if !s.is_finite() {
                return Err(ParamError::NotFinite(format!(
                    "coarsest-level Cholesky: pivot {j} is {s}"
                )));
            }
            if s > PIVOT_TOL * scale && s > 0.0 {
                let d = s.sqrt();
                let (left, right) = l.split_at_mut(n * (j + 1));
                let colj = &mut left[n * j..];
                colj[j] = d;
                for x in &mut colj[j + 1..] {
                    *x /= d;
                }
                for k in j + 1..n {
                    let lkj = colj[k];
                    if lkj == 0.0 {
                        continue;
                    }
                    let colk = &mut right[n * (k - j - 1)..n * (k - j)];
                    for (x, &y) in colk[k..].iter_mut().zip(&colj[k..]) {
                        *x -= lkj * y;
                    }
                }
            } else if s >= -PIVOT_TOL * scale {
                kept[j] = false;
                dropped.push(j);
                l[n * j + j..n * (j + 1)].fill(0.0);
            } else {
                return Err(ParamError::InvalidArgument(format!(
                    "the matrix is not positive definite: coarsest-level Cholesky pivot {j} \
                     is {s:e} (diagonal {:e})",
                    diag0[j]
                )));
            }
        }
        Ok((DenseCholesky { n, l, kept }, dropped))
    }

    /// `x = E_K A_KK^{-1} E_K^T b` (dropped unknowns zero): forward
    /// substitution `L w = b`, back substitution `L^T x = w`, on `K`.
    fn solve(&self, b: &[f64], x: &mut [f64]) {
        let n = self.n;
        x.copy_from_slice(b);
        for j in 0..n {
            if !self.kept[j] {
                x[j] = 0.0;
                continue;
            }
            let col = &self.l[n * j..n * (j + 1)];
            let xj = x[j] / col[j];
            x[j] = xj;
            for (xi, &lij) in x[j + 1..].iter_mut().zip(&col[j + 1..]) {
                *xi -= lij * xj;
            }
        }
        for j in (0..n).rev() {
            if !self.kept[j] {
                x[j] = 0.0;
                continue;
            }
            let col = &self.l[n * j..n * (j + 1)];
            let s: f64 = col[j + 1..]
                .iter()
                .zip(&x[j + 1..])
                .map(|(&lij, &xi)| lij * xi)
                .sum();
            x[j] = (x[j] - s) / col[j];
        }
    }

    /// The null vector of dropped unknown `j`: `n_j = 1`, `n_K<j = -c` with
    /// `L_KK^T c = (l_jk)_{k in K, k < j}`, zero elsewhere, so that
    /// `A n = 0` up to the dropped pivot.
    fn null_vector(&self, j: usize) -> Vec<f64> {
        let n = self.n;
        let mut c = vec![0.0; n];
        for k in (0..j).rev() {
            if !self.kept[k] {
                continue;
            }
            let col = &self.l[n * k..n * (k + 1)];
            let s: f64 = col[k + 1..j]
                .iter()
                .zip(&c[k + 1..j])
                .map(|(&lik, &ci)| lik * ci)
                .sum();
            c[k] = (col[j] - s) / col[k];
        }
        c.iter_mut().for_each(|x| *x = -*x);
        c[j] = 1.0;
        c
    }
}

/// A multigrid V-cycle preconditioner: levels `A_0 = A`,
/// `A_{l+1} = P_l^T A_l P_l`, symmetric Gauss-Seidel smoothing on every
/// level but the coarsest, which is solved by a dense Cholesky
/// factorization (see the module docs for semidefinite coarse levels).
#[derive(Debug, Clone)]
pub struct Multigrid {
    levels: Vec<Level>,
    coarsest: DenseCholesky,
}

impl Multigrid {
    /// The hierarchy `A_0 = a`, `A_{l+1} = P_l^T A_l P_l` with
    /// `prolongations[l]` mapping level `l + 1` to level `l`; stops adding
    /// levels early once a level has at most [`COARSEST`] unknowns. The
    /// coarsest level is factorized by a dense Cholesky.
    ///
    /// # Errors
    /// [`ParamError::InvalidArgument`] if `a` is not square, not symmetric
    /// (`|a_ij - a_ji| > 1e-12 max |a|`), has a diagonal entry that is not
    /// positive, or is singular or indefinite (found on the coarsest level),
    /// or if the coarsest level has more than [`MAX_DENSE`] unknowns;
    /// [`ParamError::Length`] if a prolongation has the wrong number of rows.
    pub fn new(a: Csr, prolongations: Vec<Csr>) -> Result<Multigrid, ParamError> {
        Self::with_coarsest(a, prolongations, COARSEST)
    }

    /// [`Multigrid::new`] with another coarsest-level size: levels are
    /// added while the current one has more than `coarsest` unknowns (and
    /// prolongations remain). Errors as [`Multigrid::new`].
    pub fn with_coarsest(
        a: Csr,
        prolongations: Vec<Csr>,
        coarsest: usize,
    ) -> Result<Multigrid, ParamError> {
        if a.n_rows != a.n_cols {
            return Err(ParamError::InvalidArgument(format!(
                "multigrid: the matrix must be square, it is {} x {}",
                a.n_rows, a.n_cols
            )));
        }
        check_symmetric(&a)?;
        if let Some((i, d)) = a
            .diagonal()
            .into_iter()
            .enumerate()
            .find(|&(_, d)| !(d > 0.0 && d.is_finite()))
        {
            return Err(ParamError::InvalidArgument(format!(
                "multigrid: diagonal entry {i} is {d}; a symmetric positive definite matrix \
                 has a positive diagonal"
            )));
        }
        let mut levels = Vec::new();
        let mut cur = a;
        for p in prolongations {
            if cur.n_rows <= coarsest {
                break;
            }
            if p.n_rows != cur.n_rows {
                return Err(ParamError::Length {
                    what: "multigrid: rows of a prolongation (unknowns of its fine level)",
                    expected: cur.n_rows,
                    found: p.n_rows,
                });
            }
            let next = cur.galerkin(&p)?;
            let inv_diag = smoother_diagonal(&cur);
            let r = p.transpose();
            levels.push(Level {
                a: cur,
                inv_diag,
                p,
                r,
            });
            cur = next;
        }
        if cur.n_rows > MAX_DENSE {
            return Err(ParamError::InvalidArgument(format!(
                "multigrid: the coarsest level has {} unknowns, more than the dense solve \
                 allows ({MAX_DENSE}); give more prolongations",
                cur.n_rows
            )));
        }
        let (coarsest_factor, dropped) = DenseCholesky::factor(&cur)?;
        let mg = Multigrid {
            levels,
            coarsest: coarsest_factor,
        };
        if !dropped.is_empty() {
            mg.check_null_directions(&dropped)?;
        }
        Ok(mg)
    }

    /// The finest operator `A_0` when it is a smoothed level (`None` when
    /// the whole problem is the coarsest level, solved densely): lets a
    /// caller hand its matrix over instead of keeping a copy.
    pub fn matrix(&self) -> Option<&Csr> {
        self.levels.first().map(|l| &l.a)
    }

    /// Each dropped coarsest-level direction `n` must vanish on the fine
    /// grid: `|Q n|^2 = n^T G n <= NULL_TOL sum_i n_i^2 G_ii` with
    /// `Q = P_0 ... P_{L-1}` and `G = Q^T Q` (built like the Galerkin
    /// operators: `G_1 = P_0^T P_0`, `G_{l+1} = P_l^T G_l P_l`). Otherwise
    /// `A Q n = 0` with `Q n != 0`: `A` is singular.
    fn check_null_directions(&self, dropped: &[usize]) -> Result<(), ParamError> {
        let m = self.coarsest.n;
        let g = match self.levels.split_first() {
            None => Csr::identity(m),
            Some((first, rest)) => {
                let mut g = spgemm(&first.r, &first.p);
                for lev in rest {
                    g = g.galerkin(&lev.p)?;
                }
                g
            }
        };
        let gd = g.diagonal();
        let mut gn = vec![0.0; m];
        for &j in dropped {
            let nv = self.coarsest.null_vector(j);
            g.mul_vec(&nv, &mut gn);
            let ngn: f64 = nv.iter().zip(&gn).map(|(a, b)| a * b).sum();
            let scale: f64 = nv.iter().zip(&gd).map(|(a, d)| a * a * d).sum();
            if ngn.is_nan() || ngn > NULL_TOL * scale {
                return Err(ParamError::InvalidArgument(format!(
                    "the matrix is singular: the coarsest level ({m} unknowns) has a null \
                     direction (at unknown {j}) that is a nonzero fine-grid vector \
                     (|Q n|^2 = {:e} of {scale:e})",
                    ngn
                )));
            }
        }
        Ok(())
    }

    /// Convenience: the hierarchy of a masked grid (conventions of
    /// [`grid_prolongation`]; `a` is the operator on the unknowns numbered
    /// by `index`), calling [`grid_prolongation`] repeatedly until a level
    /// has at most [`COARSEST`] unknowns or coarsening no longer reduces the
    /// unknown count.
    ///
    /// # Errors
    /// Those of [`grid_prolongation`] and [`Multigrid::new`];
    /// [`ParamError::Length`] if `index` does not number `a.n_rows()` unknowns.
    pub fn for_grid(a: Csr, dims: [usize; 3], index: &[u32]) -> Result<Multigrid, ParamError> {
        Self::for_grid_with_coarsest(a, dims, index, COARSEST)
    }

    /// [`Multigrid::for_grid`] with another coarsest-level size (see
    /// [`Multigrid::with_coarsest`]).
    pub fn for_grid_with_coarsest(
        a: Csr,
        dims: [usize; 3],
        index: &[u32],
        coarsest: usize,
    ) -> Result<Multigrid, ParamError> {
        let n_nodes = grid_nodes(dims)?;
        if index.len() != n_nodes {
            return Err(ParamError::Length {
                what: "grid index (one entry per node)",
                expected: n_nodes,
                found: index.len(),
            });
        }
        let n_active = index.iter().filter(|&&u| u != u32::MAX).count();
        if n_active != a.n_rows {
            return Err(ParamError::Length {
                what: "multigrid: unknowns in the grid index (rows of the matrix)",
                expected: a.n_rows,
                found: n_active,
            });
        }
        let mut prolongations = Vec::new();
        let mut d = dims;
        let mut coarse_index: Option<Vec<u32>> = None;
        let mut n = n_active;
        while n > coarsest {
            let (p, cd, ci) = grid_prolongation(d, coarse_index.as_deref().unwrap_or(index))?;
            if p.n_cols >= n {
                break;
            }
            n = p.n_cols;
            prolongations.push(p);
            d = cd;
            coarse_index = Some(ci);
        }
        Self::with_coarsest(a, prolongations, coarsest)
    }

    /// Number of levels, the coarsest included (1: a dense solve of `A`).
    pub fn levels(&self) -> usize {
        self.levels.len() + 1
    }

    /// Unknowns per level, finest first.
    pub fn level_sizes(&self) -> Vec<usize> {
        self.levels
            .iter()
            .map(|l| l.a.n_rows)
            .chain(std::iter::once(self.coarsest.n))
            .collect()
    }

    /// Number of unknowns of the finest level (the size of `A`).
    pub fn size(&self) -> usize {
        self.levels.first().map_or(self.coarsest.n, |l| l.a.n_rows)
    }

    /// `z = M^{-1} r`, one symmetric V(1,1) cycle. On level `l` with right
    /// hand side `b` (`b = r` on level 0):
    ///
    /// ```text
    /// x = 0
    /// x_i += (b_i - (A_l x)_i) / a_ii,  i = 0, 1, ..., n-1      (forward Gauss-Seidel)
    /// x  += P_l V_{l+1}(P_l^T (b - A_l x))                       (coarse correction)
    /// x_i += (b_i - (A_l x)_i) / a_ii,  i = n-1, ..., 1, 0      (backward Gauss-Seidel)
    /// ```
    ///
    /// and `V_L(b) = A_L^{-1} b` (dense Cholesky) on the coarsest level. The
    /// backward sweep is the adjoint of the forward one, so `M^{-1}` is
    /// symmetric positive definite. `z` need not be zeroed by the caller.
    ///
    /// # Panics
    /// If `r` or `z` does not have [`Multigrid::size`] entries.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = self.size();
        assert_eq!(r.len(), n, "Multigrid::apply: r has the wrong length");
        assert_eq!(z.len(), n, "Multigrid::apply: z has the wrong length");
        self.cycle(0, r, z);
    }

    fn cycle(&self, l: usize, b: &[f64], x: &mut [f64]) {
        let Some(lev) = self.levels.get(l) else {
            self.coarsest.solve(b, x);
            return;
        };
        x.fill(0.0);
        gauss_seidel(&lev.a, &lev.inv_diag, b, x, false);
        let mut res = vec![0.0; b.len()];
        lev.a.residual(b, x, &mut res);
        let mut bc = vec![0.0; lev.p.n_cols];
        lev.r.mul_vec(&res, &mut bc);
        drop(res);
        let mut xc = vec![0.0; lev.p.n_cols];
        self.cycle(l + 1, &bc, &mut xc);
        lev.p.mul_vec_add(&xc, x);
        gauss_seidel(&lev.a, &lev.inv_diag, b, x, true);
    }
}

/// `1 / a_ii` for the Gauss-Seidel smoother, `0` (the unknown is left
/// alone) where `a_ii <= 1e-14 max_i a_ii`: on a semidefinite coarse level
/// such an unknown lies in the null space.
fn smoother_diagonal(a: &Csr) -> Vec<f64> {
    let d = a.diagonal();
    let max = d.iter().copied().fold(0.0f64, f64::max);
    d.iter()
        .map(|&x| if x > 1e-14 * max { 1.0 / x } else { 0.0 })
        .collect()
}

/// One Gauss-Seidel sweep `x_i += (b_i - sum_j a_ij x_j) inv_diag_i`,
/// rows ascending, or descending if `backward`.
fn gauss_seidel(a: &Csr, inv_diag: &[f64], b: &[f64], x: &mut [f64], backward: bool) {
    let step = |i: usize, x: &mut [f64]| {
        let (c, v) = a.row(i);
        let mut s = b[i];
        for (&j, &aij) in c.iter().zip(v) {
            s -= aij * x[j as usize];
        }
        x[i] += s * inv_diag[i];
    };
    if backward {
        for i in (0..x.len()).rev() {
            step(i, x);
        }
    } else {
        for i in 0..x.len() {
            step(i, x);
        }
    }
}

/// `|a_ij - a_ji| <= 1e-12 max |a|` for every stored entry (a missing
/// mirror entry counts as zero).
fn check_symmetric(a: &Csr) -> Result<(), ParamError> {
    let amax = a.val.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = 1e-12 * amax;
    let check_row = |i: usize| {
        let (c, v) = a.row(i);
        c.iter().zip(v).find_map(|(&j, &aij)| {
            let (cj, vj) = a.row(j as usize);
            let aji = cj.binary_search(&(i as u32)).map_or(0.0, |k| vj[k]);
            ((aij - aji).abs() > tol).then_some((i, j, aij, aji))
        })
    };
    let bad = if a.n_rows < PAR_MIN {
        (0..a.n_rows).find_map(check_row)
    } else {
        (0..a.n_rows).into_par_iter().find_map_first(check_row)
    };
    match bad {
        None => Ok(()),
        Some((i, j, aij, aji)) => Err(ParamError::InvalidArgument(format!(
            "the matrix is not symmetric: a[{i}][{j}] = {aij:e} but a[{j}][{i}] = {aji:e}"
        ))),
    }
}

// ---------------------------------------------------------------------------
// Conjugate gradients
// ---------------------------------------------------------------------------

/// Outcome of [`pcg`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgReport {
    /// Conjugate-gradient iterations done (each one product with `A` and one
    /// preconditioner application).
    pub iterations: usize,
    /// The achieved `|b - A x| / |b|`, recomputed from `x` (0 for `b = 0`).
    pub relative_residual: f64,
}

/// `sum_i a_i b_i`, in parallel chunks for long vectors (chunk sums added
/// in order, so the result does not depend on the thread count).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() < PAR_MIN {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    } else {
        let parts: Vec<f64> = a
            .par_chunks(ROW_CHUNK)
            .zip(b.par_chunks(ROW_CHUNK))
            .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum())
            .collect();
        parts.iter().sum()
    }
}

/// `y += alpha x`.
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    if y.len() < PAR_MIN {
        y.iter_mut().zip(x).for_each(|(yi, &xi)| *yi += alpha * xi);
    } else {
        y.par_iter_mut()
            .zip(x.par_iter())
            .for_each(|(yi, &xi)| *yi += alpha * xi);
    }
}

/// `y = x + beta y`.
fn xpby(x: &[f64], beta: f64, y: &mut [f64]) {
    if y.len() < PAR_MIN {
        y.iter_mut()
            .zip(x)
            .for_each(|(yi, &xi)| *yi = xi + beta * *yi);
    } else {
        y.par_iter_mut()
            .zip(x.par_iter())
            .for_each(|(yi, &xi)| *yi = xi + beta * *yi);
    }
}

/// Preconditioned conjugate gradients on `A x = b` from the initial `x`,
/// preconditioner `M^{-1}` = one [`Multigrid::apply`]:
///
/// ```text
/// r = b - A x,  z = M^{-1} r,  p = z
/// repeat:  alpha = r.z / p.A p,  x += alpha p,  r -= alpha A p,
///          stop if |r| <= rel_tol |b|,
///          z' = M^{-1} r,  beta = r.z' / r.z,  p = z' + beta p
/// ```
///
/// until `|b - A x| <= rel_tol |b|`. When the recurrence residual reaches
/// the tolerance the true residual `b - A x` is recomputed; if rounding made
/// them drift apart the iteration restarts from the true residual. The
/// report gives the true relative residual reached. `b = 0` gives `x = 0`.
///
/// # Errors
/// [`ParamError::Length`] for lengths that do not match `A` (or the
/// preconditioner); [`ParamError::InvalidArgument`] if `A` is not square,
/// `rel_tol` is not positive and finite, `b` or `x` has a non-finite entry,
/// or the iteration did not converge within `max_iter` iterations (the
/// message says "did not converge" and gives the residual reached);
/// [`ParamError::NotFinite`] on a breakdown (`p^T A p <= 0` or NaN,
/// `r^T M^{-1} r <= 0` or NaN: `A` or `M` is not positive definite).
pub fn pcg(
    a: &Csr,
    b: &[f64],
    x: &mut [f64],
    m: &Multigrid,
    rel_tol: f64,
    max_iter: usize,
) -> Result<PcgReport, ParamError> {
    let n = a.n_rows;
    if a.n_cols != n {
        return Err(ParamError::InvalidArgument(format!(
            "pcg: the matrix must be square, it is {} x {}",
            a.n_rows, a.n_cols
        )));
    }
    for (what, len) in [
        ("pcg: right-hand side b", b.len()),
        ("pcg: initial guess x", x.len()),
        ("pcg: preconditioner size", m.size()),
    ] {
        if len != n {
            return Err(ParamError::Length {
                what,
                expected: n,
                found: len,
            });
        }
    }
    if !(rel_tol > 0.0 && rel_tol.is_finite()) {
        return Err(ParamError::InvalidArgument(format!(
            "pcg: the relative tolerance must be positive and finite, it is {rel_tol}"
        )));
    }
    for (name, v) in [("b", b), ("x", &*x)] {
        if let Some(i) = v.iter().position(|t| !t.is_finite()) {
            return Err(ParamError::InvalidArgument(format!(
                "pcg: {name}[{i}] = {} is not finite",
                v[i]
            )));
        }
    }
    let b_norm = dot(b, b).sqrt();
    if b_norm == 0.0 {
        x.fill(0.0);
        return Ok(PcgReport {
            iterations: 0,
            relative_residual: 0.0,
        });
    }
    let target = rel_tol * b_norm;
    let mut r = vec![0.0; n];
    a.residual(b, x, &mut r);
    let mut r_norm = dot(&r, &r).sqrt();
    if !r_norm.is_finite() {
        return Err(ParamError::NotFinite(
            "pcg: the initial residual b - A x is not finite".into(),
        ));
    }
    if r_norm <= target {
        return Ok(PcgReport {
            iterations: 0,
            relative_residual: r_norm / b_norm,
        });
    }
    let mut z = vec![0.0; n];
    let mut p = vec![0.0; n];
    let mut q = vec![0.0; n];
    let restart = |r: &[f64], z: &mut [f64], p: &mut [f64], it: usize| {
        m.apply(r, z);
        p.copy_from_slice(z);
        let rz = dot(r, z);
        if rz > 0.0 && rz.is_finite() {
            Ok(rz)
        } else {
            Err(breakdown_rz(it, rz))
        }
    };
    let mut rz = restart(&r, &mut z, &mut p, 0)?;
    for it in 1..=max_iter {
        a.mul_vec(&p, &mut q);
        let pq = dot(&p, &q);
        if !(pq > 0.0 && pq.is_finite()) {
            return Err(ParamError::NotFinite(format!(
                "pcg breakdown at iteration {it}: p^T A p = {pq:e} (A is not positive definite)"
            )));
        }
        let alpha = rz / pq;
        axpy(alpha, &p, x);
        axpy(-alpha, &q, &mut r);
        r_norm = dot(&r, &r).sqrt();
        if !r_norm.is_finite() {
            return Err(ParamError::NotFinite(format!(
                "pcg breakdown at iteration {it}: the residual is not finite"
            )));
        }
        if r_norm <= target {
            a.residual(b, x, &mut r);
            r_norm = dot(&r, &r).sqrt();
            if r_norm <= target {
                return Ok(PcgReport {
                    iterations: it,
                    relative_residual: r_norm / b_norm,
                });
            }
            rz = restart(&r, &mut z, &mut p, it)?;
            continue;
        }
        m.apply(&r, &mut z);
        let rz_new = dot(&r, &z);
        if !(rz_new > 0.0 && rz_new.is_finite()) {
            return Err(breakdown_rz(it, rz_new));
        }
        xpby(&z, rz_new / rz, &mut p);
        rz = rz_new;
    }
    Err(ParamError::InvalidArgument(format!(
        "pcg did not converge in {max_iter} iterations: relative residual {:.3e} > {rel_tol:e}",
        r_norm / b_norm
    )))
}

fn breakdown_rz(it: usize, rz: f64) -> ParamError {
    ParamError::NotFinite(format!(
        "pcg breakdown at iteration {it}: r^T M^-1 r = {rz:e} (the preconditioner is not \
         positive definite)"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use proptest::prelude::*;
    use std::time::Instant;

    struct SplitMix(u64);

    impl SplitMix {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [0, 1).
        fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next_u64() % n as u64) as usize
        }
    }

    fn dense(a: &Csr) -> DMatrix<f64> {
        let mut d = DMatrix::zeros(a.n_rows(), a.n_cols());
        for i in 0..a.n_rows() {
            let (c, v) = a.row(i);
            for (&j, &x) in c.iter().zip(v) {
                d[(i, j as usize)] += x;
            }
        }
        d
    }

    fn random_csr(rows: usize, cols: usize, nnz: usize, rng: &mut SplitMix) -> Csr {
        let t: Vec<(u32, u32, f64)> = (0..nnz)
            .map(|_| {
                (
                    rng.below(rows) as u32,
                    rng.below(cols) as u32,
                    rng.unit() * 4.0 - 2.0,
                )
            })
            .collect();
        Csr::from_triplets(rows, cols, &t).unwrap()
    }

    fn assert_structure(a: &Csr) {
        assert_eq!(a.row_ptr.len(), a.n_rows + 1);
        assert_eq!(*a.row_ptr.last().unwrap(), a.nnz());
        for i in 0..a.n_rows {
            let (c, _) = a.row(i);
            assert!(
                c.windows(2).all(|w| w[0] < w[1]),
                "row {i} not sorted/unique"
            );
            assert!(c.iter().all(|&j| (j as usize) < a.n_cols));
        }
    }

    /// Numbering of the `true` nodes in linear-id order.
    fn numbering(mask: &[bool]) -> Vec<u32> {
        let mut k = 0;
        mask.iter()
            .map(|&m| {
                if m {
                    k += 1;
                    k - 1
                } else {
                    u32::MAX
                }
            })
            .collect()
    }

    /// 7-point Laplacian on the unknowns of `index`: diagonal 6, -1 between
    /// neighbouring unknowns (masked-out neighbours and the outside are
    /// Dirichlet 0). With `neumann`, the diagonal is the neighbour count
    /// instead (singular: constants are in the kernel).
    fn laplacian(dims: [usize; 3], index: &[u32], neumann: bool) -> Csr {
        let [nx, ny, nz] = dims;
        let mut t = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let u = index[i + nx * (j + ny * k)];
                    if u == u32::MAX {
                        continue;
                    }
                    let mut deg = 0.0;
                    let nb = [
                        (i > 0).then(|| (i - 1, j, k)),
                        (i + 1 < nx).then_some((i + 1, j, k)),
                        (j > 0).then(|| (i, j - 1, k)),
                        (j + 1 < ny).then_some((i, j + 1, k)),
                        (k > 0).then(|| (i, j, k - 1)),
                        (k + 1 < nz).then_some((i, j, k + 1)),
                    ];
                    for (a, b, c) in nb.into_iter().flatten() {
                        let v = index[a + nx * (b + ny * c)];
                        if v != u32::MAX {
                            t.push((u, v, -1.0));
                            deg += 1.0;
                        }
                    }
                    t.push((u, u, if neumann { deg } else { 6.0 }));
                }
            }
        }
        let n = index.iter().filter(|&&u| u != u32::MAX).count();
        Csr::from_triplets(n, n, &t).unwrap()
    }

    fn rel_residual(a: &Csr, b: &[f64], x: &[f64]) -> f64 {
        let mut r = vec![0.0; b.len()];
        a.residual(b, x, &mut r);
        dot(&r, &r).sqrt() / dot(b, b).sqrt()
    }

    // ---- Csr ---------------------------------------------------------------

    #[test]
    fn from_triplets_sums_duplicates_and_sorts() {
        let a = Csr::from_triplets(
            3,
            4,
            &[
                (1, 3, 1.0),
                (0, 2, 2.0),
                (1, 0, -1.0),
                (1, 3, 0.5),
                (0, 2, -2.0),
                (2, 1, 7.0),
                (1, 3, 0.25),
            ],
        )
        .unwrap();
        assert_eq!(a.n_rows(), 3);
        assert_eq!(a.n_cols(), 4);
        assert_eq!(a.nnz(), 4);
        assert_eq!(a.row(0), (&[2u32][..], &[0.0][..]));
        assert_eq!(a.row(1), (&[0u32, 3][..], &[-1.0, 1.75][..]));
        assert_eq!(a.row(2), (&[1u32][..], &[7.0][..]));
        assert_eq!(a.diagonal(), vec![0.0, 0.0, 0.0]);
        let t = a.transpose();
        assert_eq!(t.n_rows(), 4);
        assert_eq!(t.row(3), (&[1u32][..], &[1.75][..]));
        assert_eq!(t.transpose(), a);
        let empty = Csr::from_triplets(2, 0, &[]).unwrap();
        assert_eq!(empty.nnz(), 0);
        assert_eq!(empty.row(1).0.len(), 0);
    }

    #[test]
    fn from_triplets_rejects_bad_input() {
        let msg = |r: Result<Csr, ParamError>| match r {
            Err(ParamError::InvalidArgument(m)) => m,
            other => panic!("expected InvalidArgument, got {other:?}"),
        };
        let m = msg(Csr::from_triplets(2, 3, &[(0, 0, 1.0), (2, 1, 1.0)]));
        assert!(m.contains("triplet 1") && m.contains("out of range"), "{m}");
        let m = msg(Csr::from_triplets(2, 3, &[(1, 3, 1.0)]));
        assert!(m.contains("(1, 3)") && m.contains("out of range"), "{m}");
        let m = msg(Csr::from_triplets(2, 3, &[(0, 0, 1.0), (1, 1, f64::NAN)]));
        assert!(m.contains("triplet 1") && m.contains("not finite"), "{m}");
        let m = msg(Csr::from_triplets(2, 3, &[(1, 1, f64::INFINITY)]));
        assert!(m.contains("not finite"), "{m}");
        let m = msg(Csr::from_triplets(
            1,
            1,
            &[(0, 0, f64::MAX), (0, 0, f64::MAX)],
        ));
        assert!(m.contains("sum to") && m.contains("not finite"), "{m}");
        let m = msg(Csr::from_triplets(usize::MAX, 1, &[]));
        assert!(m.contains("too large"), "{m}");
    }

    #[test]
    fn galerkin_rejects_mismatched_sizes() {
        let mut rng = SplitMix(3);
        let a = random_csr(4, 4, 10, &mut rng);
        let p = random_csr(5, 2, 6, &mut rng);
        assert!(matches!(
            a.galerkin(&p),
            Err(ParamError::Length {
                expected: 4,
                found: 5,
                ..
            })
        ));
        let rect = random_csr(4, 5, 6, &mut rng);
        let err = rect.galerkin(&p).unwrap_err();
        assert!(err.to_string().contains("square"), "{err}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn mul_vec_transpose_diagonal_match_dense(
            rows in 1usize..14, cols in 1usize..14, nnz in 0usize..80, seed in any::<u64>(),
        ) {
            let mut rng = SplitMix(seed);
            let a = random_csr(rows, cols, nnz, &mut rng);
            assert_structure(&a);
            let d = dense(&a);
            let x: Vec<f64> = (0..cols).map(|_| rng.unit() - 0.5).collect();
            let mut y = vec![f64::NAN; rows];
            a.mul_vec(&x, &mut y);
            let yd = &d * DVector::from_column_slice(&x);
            for i in 0..rows {
                prop_assert!((y[i] - yd[i]).abs() <= 1e-12, "row {}: {} vs {}", i, y[i], yd[i]);
            }
            let t = a.transpose();
            assert_structure(&t);
            prop_assert_eq!(dense(&t), d.transpose());
            let diag = a.diagonal();
            prop_assert_eq!(diag.len(), rows.min(cols));
            for (i, &v) in diag.iter().enumerate() {
                prop_assert_eq!(v, d[(i, i)]);
            }
        }

        #[test]
        fn galerkin_matches_dense(
            n in 1usize..16, m in 1usize..10, nnz_a in 0usize..100, nnz_p in 0usize..40,
            seed in any::<u64>(),
        ) {
            let mut rng = SplitMix(seed);
            let a = random_csr(n, n, nnz_a, &mut rng);
            let p = random_csr(n, m, nnz_p, &mut rng);
            let c = a.galerkin(&p).unwrap();
            assert_structure(&c);
            prop_assert_eq!((c.n_rows(), c.n_cols()), (m, m));
            let (da, dp) = (dense(&a), dense(&p));
            let expect = dp.transpose() * da * &dp;
            let got = dense(&c);
            for i in 0..m {
                for j in 0..m {
                    prop_assert!(
                        (got[(i, j)] - expect[(i, j)]).abs() <= 1e-12 * (1.0 + expect[(i, j)].abs()),
                        "({}, {}): {} vs {}", i, j, got[(i, j)], expect[(i, j)]
                    );
                }
            }
        }
    }

    #[test]
    fn spgemm_parallel_blocks_match_sequential_product() {
        // Enough rows for several rayon blocks.
        let mut rng = SplitMix(11);
        let a = random_csr(20_000, 300, 100_000, &mut rng);
        let b = random_csr(300, 50, 2_000, &mut rng);
        let c = spgemm(&a, &b);
        assert_structure(&c);
        let x: Vec<f64> = (0..50).map(|_| rng.unit()).collect();
        let (mut bx, mut abx, mut cx) = (vec![0.0; 300], vec![0.0; 20_000], vec![0.0; 20_000]);
        b.mul_vec(&x, &mut bx);
        a.mul_vec(&bx, &mut abx);
        c.mul_vec(&x, &mut cx);
        for (u, v) in abx.iter().zip(&cx) {
            assert!((u - v).abs() <= 1e-11 * (1.0 + u.abs()));
        }
    }

    // ---- grid prolongation ---------------------------------------------------

    #[test]
    fn prolongation_of_a_line_is_linear_interpolation() {
        // Odd size: coarse nodes at fine 0, 2, 4.
        let (p, cd, ci) = grid_prolongation([5, 1, 1], &[0, 1, 2, 3, 4]).unwrap();
        assert_eq!(cd, [3, 1, 1]);
        assert_eq!(ci, vec![0, 1, 2]);
        let expect = DMatrix::from_row_slice(
            5,
            3,
            &[
                1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0,
            ],
        );
        assert_eq!(dense(&p), expect);
        // Even size: the last fine node interpolates from a coarse node at
        // fine position 4, outside the grid.
        let (p, cd, _) = grid_prolongation([4, 1, 1], &[0, 1, 2, 3]).unwrap();
        assert_eq!(cd, [3, 1, 1]);
        assert_eq!(p.row(3), (&[1u32, 2][..], &[0.5, 0.5][..]));
        // A masked line: node 2 out; unknowns numbered in reverse order.
        let (p, _, ci) = grid_prolongation([5, 1, 1], &[3, 2, u32::MAX, 1, 0]).unwrap();
        assert_eq!(ci, vec![0, 1, 2]);
        assert_eq!(p.row(0), (&[2u32][..], &[1.0][..])); // unknown 0 = node 4
        assert_eq!(p.row(1), (&[1u32, 2][..], &[0.5, 0.5][..])); // node 3
        assert_eq!(p.row(3), (&[0u32][..], &[1.0][..])); // node 0
    }

    #[test]
    fn prolongation_of_an_isolated_odd_node_has_eight_parents() {
        let mut index = vec![u32::MAX; 27];
        index[1 + 3 * (1 + 3)] = 0;
        let (p, cd, ci) = grid_prolongation([3, 3, 3], &index).unwrap();
        assert_eq!(cd, [2, 2, 2]);
        assert_eq!(ci, (0..8).collect::<Vec<u32>>());
        assert_eq!(
            p.row(0),
            (&[0u32, 1, 2, 3, 4, 5, 6, 7][..], &[0.125; 8][..])
        );
    }

    #[test]
    fn prolongation_rejects_bad_index() {
        let err = grid_prolongation([2, 2, 2], &[0; 7]).unwrap_err();
        assert!(matches!(
            err,
            ParamError::Length {
                expected: 8,
                found: 7,
                ..
            }
        ));
        let err = grid_prolongation([2, 0, 2], &[]).unwrap_err();
        assert!(err.to_string().contains("at least 1"), "{err}");
        let err = grid_prolongation([3, 1, 1], &[0, 0, 1]).unwrap_err();
        assert!(err.to_string().contains("used by nodes 0 and 1"), "{err}");
        let err = grid_prolongation([3, 1, 1], &[0, 5, u32::MAX]).unwrap_err();
        assert!(err.to_string().contains("only 2 unknowns"), "{err}");
        let err = grid_prolongation([usize::MAX, 2, 1], &[]).unwrap_err();
        assert!(err.to_string().contains("too many nodes"), "{err}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn prolongation_reproduces_constants_and_index_is_consistent(
            nx in 1usize..10, ny in 1usize..10, nz in 1usize..10,
            density in 0.05f64..1.0, seed in any::<u64>(),
        ) {
            let dims = [nx, ny, nz];
            let mut rng = SplitMix(seed);
            let n_nodes = nx * ny * nz;
            // Random mask, unknowns numbered in a random order.
            let active: Vec<usize> = (0..n_nodes).filter(|_| rng.unit() < density).collect();
            let mut order: Vec<u32> = (0..active.len() as u32).collect();
            for i in (1..order.len()).rev() {
                order.swap(i, rng.below(i + 1));
            }
            let mut index = vec![u32::MAX; n_nodes];
            for (&id, &u) in active.iter().zip(&order) {
                index[id] = u;
            }
            let (p, cd, ci) = grid_prolongation(dims, &index).unwrap();
            assert_structure(&p);
            prop_assert_eq!(cd, [nx / 2 + 1, ny / 2 + 1, nz / 2 + 1]);
            prop_assert_eq!(ci.len(), cd[0] * cd[1] * cd[2]);
            prop_assert_eq!(p.n_rows(), active.len());
            // Coarse numbers: 0..n_cols once each, ascending with the id.
            let numbers: Vec<u32> = ci.iter().copied().filter(|&c| c != u32::MAX).collect();
            prop_assert_eq!(numbers, (0..p.n_cols() as u32).collect::<Vec<_>>());
            let mut coarse_node = vec![usize::MAX; p.n_cols()];
            for (id, &c) in ci.iter().enumerate() {
                if c != u32::MAX {
                    coarse_node[c as usize] = id;
                }
            }
            let mut used = vec![false; p.n_cols()];
            for (&id, &u) in active.iter().zip(&order) {
                let (c, v) = p.row(u as usize);
                let sum: f64 = v.iter().sum();
                prop_assert_eq!(sum, 1.0, "row {} sums to {}", u, sum);
                let f = [id % nx, (id / nx) % ny, id / (nx * ny)];
                for (&cj, &w) in c.iter().zip(v) {
                    used[cj as usize] = true;
                    let cid = coarse_node[cj as usize];
                    let g = [cid % cd[0], (cid / cd[0]) % cd[1], cid / (cd[0] * cd[1])];
                    // Trilinear weight of coarse node g at fine node f.
                    let expect: f64 = (0..3)
                        .map(|a| (1.0 - (f[a] as f64 - 2.0 * g[a] as f64).abs() / 2.0).max(0.0))
                        .product();
                    prop_assert!(expect > 0.0);
                    prop_assert_eq!(w, expect);
                }
                // Every parent with a positive weight is present.
                prop_assert_eq!(
                    c.len(),
                    f.iter().map(|&x| if x % 2 == 0 { 1 } else { 2 }).product::<usize>()
                );
            }
            prop_assert!(used.iter().all(|&u| u), "an active coarse node has no fine child");
        }
    }

    // ---- multigrid and pcg ---------------------------------------------------

    /// Full box of `s^3` unknowns, `b = 1`; (iterations, seconds, levels).
    fn solve_box(s: usize) -> (PcgReport, f64, Vec<usize>) {
        let dims = [s, s, s];
        let index: Vec<u32> = (0..(s * s * s) as u32).collect();
        let a = laplacian(dims, &index, false);
        let start = Instant::now();
        let mg = Multigrid::for_grid(a.clone(), dims, &index).unwrap();
        let setup = start.elapsed().as_secs_f64();
        let b = vec![1.0; a.n_rows()];
        let mut x = vec![0.0; a.n_rows()];
        let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 100).unwrap();
        let total = start.elapsed().as_secs_f64();
        assert!(rel_residual(&a, &b, &x) <= 1e-10);
        assert_eq!(rep.relative_residual, rel_residual(&a, &b, &x));
        println!(
            "{s}^3 = {} unknowns: {} iterations, relative residual {:.2e}, levels {:?}, \
             setup {setup:.3} s, total {total:.3} s",
            a.n_rows(),
            rep.iterations,
            rep.relative_residual,
            mg.level_sizes()
        );
        (rep, total, mg.level_sizes())
    }

    #[test]
    fn iteration_count_is_mesh_independent() {
        let (r33, _, l33) = solve_box(33);
        let (r65, _, l65) = solve_box(65);
        assert_eq!(l33, vec![35_937, 4_913, 729]);
        assert_eq!(l65, vec![274_625, 35_937, 4_913, 729]);
        assert!(r33.iterations < 25, "33^3: {} iterations", r33.iterations);
        assert!(r65.iterations < 25, "65^3: {} iterations", r65.iterations);
        assert!(
            r65.iterations <= r33.iterations + 3,
            "33^3: {}, 65^3: {} iterations",
            r33.iterations,
            r65.iterations
        );
    }

    fn random_mask(dims: [usize; 3], density: f64, rng: &mut SplitMix) -> Vec<bool> {
        (0..dims.iter().product::<usize>())
            .map(|_| rng.unit() < density)
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        #[test]
        fn pcg_on_random_masks_matches_dense_solve(density in 0.3f64..1.0, seed in any::<u64>()) {
            let dims = [9, 10, 11];
            let mut rng = SplitMix(seed);
            let index = numbering(&random_mask(dims, density, &mut rng));
            let a = laplacian(dims, &index, false);
            let n = a.n_rows();
            prop_assume!(n > 0);
            // A small coarsest level: several (rank-deficient) levels.
            let mg = Multigrid::for_grid_with_coarsest(a.clone(), dims, &index, 20).unwrap();
            prop_assert!(mg.levels() >= 3, "levels {:?}", mg.level_sizes());
            let b: Vec<f64> = (0..n).map(|_| rng.unit() - 0.3).collect();
            let mut x: Vec<f64> = (0..n).map(|_| rng.unit()).collect();
            let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 60).unwrap();
            prop_assert!(rep.relative_residual <= 1e-10);
            prop_assert!((rep.relative_residual - rel_residual(&a, &b, &x)).abs() < 1e-14);
            prop_assert!(rep.iterations <= 20, "{} iterations", rep.iterations);
            let exact = dense(&a).cholesky().unwrap().solve(&DVector::from_column_slice(&b));
            let scale = exact.amax();
            for i in 0..n {
                prop_assert!(
                    (x[i] - exact[i]).abs() <= 1e-8 * scale,
                    "x[{}] = {} vs {}", i, x[i], exact[i]
                );
            }
        }

        #[test]
        fn preconditioner_is_symmetric_positive_definite(density in 0.3f64..1.0, seed in any::<u64>()) {
            let dims = [9, 10, 11];
            let mut rng = SplitMix(seed);
            let index = numbering(&random_mask(dims, density, &mut rng));
            let a = laplacian(dims, &index, false);
            let n = a.n_rows();
            prop_assume!(n > 0);
            let mg = Multigrid::for_grid_with_coarsest(a, dims, &index, 20).unwrap();
            let r1: Vec<f64> = (0..n).map(|_| rng.unit() - 0.5).collect();
            let r2: Vec<f64> = (0..n).map(|_| rng.unit() - 0.5).collect();
            let (mut z1, mut z2) = (vec![f64::NAN; n], vec![7.0; n]);
            mg.apply(&r1, &mut z1);
            mg.apply(&r2, &mut z2);
            let (a12, a21) = (dot(&z1, &r2), dot(&z2, &r1));
            prop_assert!((a12 - a21).abs() <= 1e-12 * (dot(&z1, &r1) + dot(&z2, &r2)), "{} vs {}", a12, a21);
            prop_assert!(dot(&z1, &r1) > 0.0 && dot(&z2, &r2) > 0.0);
        }
    }

    #[test]
    fn small_system_is_solved_exactly_by_the_coarsest_level() {
        let dims = [6, 7, 8];
        let mut rng = SplitMix(5);
        let index = numbering(&random_mask(dims, 0.7, &mut rng));
        let a = laplacian(dims, &index, false);
        let mg = Multigrid::for_grid(a.clone(), dims, &index).unwrap();
        assert_eq!(mg.levels(), 1);
        assert_eq!(mg.size(), a.n_rows());
        let b: Vec<f64> = (0..a.n_rows()).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut x = vec![0.0; a.n_rows()];
        let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 5).unwrap();
        assert_eq!(rep.iterations, 1);
        assert!(rep.relative_residual < 1e-13);
    }

    #[test]
    fn rank_deficient_prolongation_is_handled() {
        // One unknown at the odd node (1,1,1): P is 1 x 8 (all columns
        // equal), A_1 = P^T A P has rank 1; 7 coarse directions are dropped
        // and verified to vanish under P.
        let a = Csr::from_triplets(1, 1, &[(0, 0, 6.0)]).unwrap();
        let mut index = vec![u32::MAX; 27];
        index[13] = 0;
        let (p, _, _) = grid_prolongation([3, 3, 3], &index).unwrap();
        let mg = Multigrid::with_coarsest(a, vec![p], 0).unwrap();
        assert_eq!(mg.level_sizes(), vec![1, 8]);
        let mut z = [0.0];
        mg.apply(&[3.0], &mut z);
        // Gauss-Seidel alone is exact here: z = 3/6, the coarse correction 0.
        assert!((z[0] - 0.5).abs() < 1e-15, "{}", z[0]);
    }

    #[test]
    fn singular_matrix_is_an_error() {
        // Neumann Laplacian: constants are in the kernel, and P reproduces them.
        let dims = [12, 12, 12];
        let index: Vec<u32> = (0..1728).collect();
        let a = laplacian(dims, &index, true);
        let err = Multigrid::for_grid_with_coarsest(a, dims, &index, 30).unwrap_err();
        assert!(err.to_string().contains("singular"), "{err}");
        // Also without coarse levels.
        let a = Csr::from_triplets(
            2,
            2,
            &[(0, 0, 1.0), (0, 1, -1.0), (1, 0, -1.0), (1, 1, 1.0)],
        )
        .unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(err.to_string().contains("singular"), "{err}");
        // Indefinite.
        let a = Csr::from_triplets(2, 2, &[(0, 0, 1.0), (0, 1, 2.0), (1, 0, 2.0), (1, 1, 1.0)])
            .unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(err.to_string().contains("not positive definite"), "{err}");
    }

    #[test]
    fn multigrid_rejects_bad_matrices() {
        let a = Csr::from_triplets(2, 2, &[(0, 0, 2.0), (0, 1, -1.0), (1, 1, 2.0)]).unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(err.to_string().contains("not symmetric"), "{err}");
        let a = Csr::from_triplets(2, 2, &[(0, 0, 2.0), (1, 1, 0.0)]).unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(err.to_string().contains("diagonal entry 1"), "{err}");
        let a = Csr::from_triplets(2, 3, &[]).unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(err.to_string().contains("square"), "{err}");
        // Prolongation with the wrong number of rows.
        let dims = [11, 11, 11];
        let index: Vec<u32> = (0..1331).collect();
        let a = laplacian(dims, &index, false);
        let p = Csr::from_triplets(1000, 10, &[]).unwrap();
        let err = Multigrid::new(a.clone(), vec![p]).unwrap_err();
        assert!(matches!(
            err,
            ParamError::Length {
                expected: 1331,
                found: 1000,
                ..
            }
        ));
        // Grid index that does not number the matrix's unknowns.
        let err = Multigrid::for_grid(a.clone(), [11, 11, 10], &index[..1210]).unwrap_err();
        assert!(matches!(
            err,
            ParamError::Length {
                expected: 1331,
                found: 1210,
                ..
            }
        ));
        // Coarsest level too large for the dense solve.
        let dims = [17, 17, 17];
        let index: Vec<u32> = (0..4913).collect();
        let a = laplacian(dims, &index, false);
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(err.to_string().contains("dense solve"), "{err}");
    }

    #[test]
    fn pcg_rejects_bad_input() {
        let dims = [12, 12, 12];
        let index: Vec<u32> = (0..1728).collect();
        let a = laplacian(dims, &index, false);
        let mg = Multigrid::for_grid(a.clone(), dims, &index).unwrap();
        assert_eq!(mg.levels(), 2);
        let n = a.n_rows();
        let b = vec![1.0; n];
        let mut x = vec![0.0; n];
        let err = pcg(&a, &b[..n - 1], &mut x, &mg, 1e-10, 50).unwrap_err();
        assert!(matches!(
            err,
            ParamError::Length {
                expected: 1728,
                found: 1727,
                ..
            }
        ));
        let mut short = vec![0.0; n + 1];
        let err = pcg(&a, &b, &mut short, &mg, 1e-10, 50).unwrap_err();
        assert!(matches!(
            err,
            ParamError::Length {
                expected: 1728,
                found: 1729,
                ..
            }
        ));
        let small = laplacian([3, 3, 3], &(0..27).collect::<Vec<_>>(), false);
        let err = pcg(&small, &b[..27], &mut x[..27], &mg, 1e-10, 50).unwrap_err();
        assert!(err.to_string().contains("preconditioner"), "{err}");
        let mut bad = b.clone();
        bad[5] = f64::NAN;
        let err = pcg(&a, &bad, &mut x, &mg, 1e-10, 50).unwrap_err();
        assert!(err.to_string().contains("b[5]") && err.to_string().contains("not finite"));
        let mut xbad = vec![0.0; n];
        xbad[7] = f64::INFINITY;
        let err = pcg(&a, &b, &mut xbad, &mg, 1e-10, 50).unwrap_err();
        assert!(err.to_string().contains("x[7]"), "{err}");
        let err = pcg(&a, &b, &mut x, &mg, 0.0, 50).unwrap_err();
        assert!(err.to_string().contains("tolerance"), "{err}");
        let err = pcg(&a, &b, &mut x, &mg, 1e-10, 2).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("did not converge in 2 iterations"), "{msg}");
        // The residual reached is reported, and it is above the tolerance.
        let reached: f64 = msg
            .split("relative residual ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(reached > 1e-10 && reached < 1.0, "{msg}");
        // Then converges, starting from where it stopped; b = 0 gives x = 0.
        let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 50).unwrap();
        assert!(rep.relative_residual <= 1e-10);
        let rep = pcg(&a, &vec![0.0; n], &mut x, &mg, 1e-10, 50).unwrap();
        assert_eq!(
            rep,
            PcgReport {
                iterations: 0,
                relative_residual: 0.0
            }
        );
        assert!(x.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn pcg_reports_breakdown_on_an_indefinite_matrix() {
        // The preconditioner is built from an SPD matrix, pcg is run on the
        // negative definite -I of the same size: p^T A p < 0 at once.
        let dims = [12, 12, 12];
        let index: Vec<u32> = (0..1728).collect();
        let spd = laplacian(dims, &index, false);
        let mg = Multigrid::for_grid(spd, dims, &index).unwrap();
        let t: Vec<(u32, u32, f64)> = (0..1728u32).map(|i| (i, i, -1.0)).collect();
        let a = Csr::from_triplets(1728, 1728, &t).unwrap();
        let b = vec![1.0; 1728];
        let mut x = vec![0.0; 1728];
        let err = pcg(&a, &b, &mut x, &mg, 1e-10, 50).unwrap_err();
        assert!(matches!(err, ParamError::NotFinite(_)), "{err:?}");
        assert!(err.to_string().contains("breakdown"), "{err}");
    }
}
