//! [`Csr`]: the one sparse matrix type of the crate, compressed sparse rows.
//!
//! Row `i` of an `n_rows x n_cols` matrix holds the entries
//! `a_{i, col[k]} = val[k]` for `k in row_ptr[i] .. row_ptr[i + 1]`, the
//! columns strictly increasing. A symmetric matrix stores both triangles
//! (the mesh operators, the eigensolver's input, the multigrid levels), so
//! that `y = A x` is one pass over the rows with each row's sum in column
//! order (reproducible, and parallel over rows without atomics).
//!
//! The products the solvers need live here: `y = A x` (rayon-parallel over
//! chunks of rows for large matrices), `A^T`, the sparse product `A B`
//! (Gustavson, row by row) and the Galerkin product `P^T A P`.
//!
//! Values: the checked constructors ([`Csr::from_raw`],
//! [`Csr::from_triplets`], [`Csr::from_symmetric_entries`]) refuse
//! non-finite values. The mesh operators of [`crate::laplacian`] build
//! their matrices directly and can hold a non-finite value on degenerate
//! geometry (an overflowing cotangent); every solver checks its matrix
//! ([`Csr::check_finite`]).

use crate::LinalgError;
use rayon::prelude::*;

/// Rows (or vector entries) per rayon task.
pub(crate) const ROW_CHUNK: usize = 4096;

/// Vectors and matrices with fewer rows than this are handled sequentially.
pub(crate) const PAR_MIN: usize = 10_000;

/// Largest matrix dimension: indices are stored as `u32`.
pub(crate) const MAX_DIM: usize = u32::MAX as usize;

/// Compressed sparse row matrix (f64), row-major, column indices sorted and
/// unique within a row.
///
/// Row `i` holds the entries `a_{i, col[k]} = val[k]` for
/// `k in row_ptr[i] .. row_ptr[i + 1]`. Both dimensions are at most
/// `u32::MAX`.
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
    /// The first violation: [`LinalgError::TooLarge`],
    /// [`LinalgError::DimensionMismatch`] (array lengths),
    /// [`LinalgError::BadPointers`], [`LinalgError::UnsortedIndices`],
    /// [`LinalgError::IndexOutOfRange`] (a column),
    /// [`LinalgError::NotFinite`] (a value).
    pub fn from_raw(
        n_rows: usize,
        n_cols: usize,
        row_ptr: Vec<usize>,
        col: Vec<u32>,
        val: Vec<f64>,
    ) -> Result<Csr, LinalgError> {
        if n_rows > MAX_DIM || n_cols > MAX_DIM {
            return Err(LinalgError::TooLarge {
                rows: n_rows,
                cols: n_cols,
            });
        }
        if row_ptr.len() != n_rows + 1 {
            return Err(LinalgError::DimensionMismatch {
                what: "CSR row pointers (rows + 1)",
                expected: n_rows + 1,
                found: row_ptr.len(),
            });
        }
        if col.len() != val.len() {
            return Err(LinalgError::DimensionMismatch {
                what: "CSR values (one per column index)",
                expected: col.len(),
                found: val.len(),
            });
        }
        let bad_pointer = |at: usize| LinalgError::BadPointers {
            what: "CSR row pointers",
            at,
            value: row_ptr[at],
            entries: col.len(),
        };
        if row_ptr[0] != 0 {
            return Err(bad_pointer(0));
        }
        if row_ptr[n_rows] != col.len() {
            return Err(bad_pointer(n_rows));
        }
        for i in 0..n_rows {
            if row_ptr[i] > row_ptr[i + 1] {
                return Err(bad_pointer(i + 1));
            }
            let cols = &col[row_ptr[i]..row_ptr[i + 1]];
            if cols.windows(2).any(|w| w[0] >= w[1]) {
                return Err(LinalgError::UnsortedIndices {
                    what: "columns of row",
                    line: i,
                });
            }
            if let Some(&c) = cols.last().filter(|&&c| c as usize >= n_cols) {
                return Err(LinalgError::IndexOutOfRange {
                    what: "column index",
                    index: c as usize,
                    len: n_cols,
                });
            }
        }
        if let Some(k) = val.iter().position(|v| !v.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "CSR value",
                index: k,
            });
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
    /// [`LinalgError::TooLarge`] if a dimension exceeds `u32::MAX`,
    /// [`LinalgError::EntryOutOfRange`] for an index out of range,
    /// [`LinalgError::NotFinite`] for a value that is not finite,
    /// [`LinalgError::DuplicateSumNotFinite`] when duplicates overflow.
    pub fn from_triplets(
        n_rows: usize,
        n_cols: usize,
        triplets: &[(u32, u32, f64)],
    ) -> Result<Csr, LinalgError> {
        if n_rows > MAX_DIM || n_cols > MAX_DIM {
            return Err(LinalgError::TooLarge {
                rows: n_rows,
                cols: n_cols,
            });
        }
        for (t, &(i, j, v)) in triplets.iter().enumerate() {
            if i as usize >= n_rows || j as usize >= n_cols {
                return Err(LinalgError::EntryOutOfRange {
                    entry: t,
                    row: i as usize,
                    col: j as usize,
                    n_rows,
                    n_cols,
                });
            }
            if !v.is_finite() {
                return Err(LinalgError::NotFinite {
                    what: "triplet value",
                    index: t,
                });
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
            return Err(LinalgError::DuplicateSumNotFinite {
                row: i,
                col: col[k] as usize,
            });
        }
        Ok(Csr {
            n_rows,
            n_cols,
            row_ptr,
            col,
            val,
        })
    }

    /// The symmetric `n x n` matrix
    /// `A = sum_k a_k (e_i e_j^T + e_j e_i^T) / (1 + [i == j])` of the given
    /// entries `(i, j, a)`: each is put in the upper triangle (`(min, max)`),
    /// values at the same position are summed, and both triangles are
    /// stored. So give every off-diagonal entry once, in either triangle.
    ///
    /// # Errors
    /// [`LinalgError::TooLarge`] if `n` exceeds `u32::MAX`,
    /// [`LinalgError::EntryOutOfRange`] for an index `>= n`,
    /// [`LinalgError::NotFinite`] for a value that is not finite,
    /// [`LinalgError::DuplicateSumNotFinite`] when duplicates overflow.
    pub fn from_symmetric_entries(
        n: usize,
        entries: impl IntoIterator<Item = (u32, u32, f64)>,
    ) -> Result<Csr, LinalgError> {
        if n > MAX_DIM {
            return Err(LinalgError::TooLarge { rows: n, cols: n });
        }
        let mut checked = Vec::new();
        for (entry, (i, j, v)) in entries.into_iter().enumerate() {
            if i as usize >= n || j as usize >= n {
                return Err(LinalgError::EntryOutOfRange {
                    entry,
                    row: i as usize,
                    col: j as usize,
                    n_rows: n,
                    n_cols: n,
                });
            }
            if !v.is_finite() {
                return Err(LinalgError::NotFinite {
                    what: "symmetric entry value",
                    index: entry,
                });
            }
            checked.push((i, j, v));
        }
        let a = Self::symmetric(n, checked);
        if let Some(k) = a.val.iter().position(|v| !v.is_finite()) {
            let i = a.row_ptr.partition_point(|&p| p <= k) - 1;
            return Err(LinalgError::DuplicateSumNotFinite {
                row: i,
                col: a.col[k] as usize,
            });
        }
        Ok(a)
    }

    /// [`Csr::from_symmetric_entries`] without the checks, for the mesh
    /// operators (indices in range by construction; values as computed).
    ///
    /// The entries are moved to the upper triangle, sorted by `(i, j)` and
    /// merged by summing in that order; the upper triangle is then mirrored
    /// row by row, so row `r` holds the mirrored entries `(i, r)`, `i < r`,
    /// followed by `(r, j)`, `j >= r`: columns ascending.
    ///
    /// # Panics
    /// If an index is `>= n`.
    pub(crate) fn symmetric(n: usize, entries: impl IntoIterator<Item = (u32, u32, f64)>) -> Csr {
        let mut t: Vec<(u32, u32, f64)> = entries
            .into_iter()
            .map(|(i, j, v)| if i <= j { (i, j, v) } else { (j, i, v) })
            .collect();
        t.sort_unstable_by_key(|e| (e.0, e.1));
        let mut upper: Vec<(u32, u32, f64)> = Vec::with_capacity(t.len());
        for (i, j, v) in t {
            match upper.last_mut() {
                Some(last) if last.0 == i && last.1 == j => last.2 += v,
                _ => upper.push((i, j, v)),
            }
        }
        let mut count = vec![0usize; n + 1];
        for &(i, j, _) in &upper {
            count[i as usize + 1] += 1;
            if i != j {
                count[j as usize + 1] += 1;
            }
        }
        for r in 0..n {
            count[r + 1] += count[r];
        }
        let row_ptr = count.clone();
        let mut next = count;
        let mut col = vec![0u32; row_ptr[n]];
        let mut val = vec![0.0; row_ptr[n]];
        for &(i, j, v) in &upper {
            let s = next[i as usize];
            col[s] = j;
            val[s] = v;
            next[i as usize] += 1;
            if i != j {
                let s = next[j as usize];
                col[s] = i;
                val[s] = v;
                next[j as usize] += 1;
            }
        }
        Csr {
            n_rows: n,
            n_cols: n,
            row_ptr,
            col,
            val,
        }
    }

    /// A matrix from CSR arrays its builder guarantees valid (pointers
    /// rising from 0 to `col.len() == val.len()`, columns strictly
    /// increasing and `< n_cols` in every row, dimensions `<= u32::MAX`);
    /// checked in debug builds only.
    pub(crate) fn from_sorted_parts(
        n_rows: usize,
        n_cols: usize,
        row_ptr: Vec<usize>,
        col: Vec<u32>,
        val: Vec<f64>,
    ) -> Csr {
        debug_assert!(n_rows <= MAX_DIM && n_cols <= MAX_DIM);
        debug_assert_eq!(row_ptr.len(), n_rows + 1);
        debug_assert_eq!(row_ptr.last().copied(), Some(col.len()));
        debug_assert_eq!(col.len(), val.len());
        debug_assert!((0..n_rows).all(|i| {
            let c = &col[row_ptr[i]..row_ptr[i + 1]];
            c.windows(2).all(|w| w[0] < w[1]) && c.iter().all(|&j| (j as usize) < n_cols)
        }));
        Csr {
            n_rows,
            n_cols,
            row_ptr,
            col,
            val,
        }
    }

    /// The `n x n` identity matrix `I` (`n <= u32::MAX`).
    pub(crate) fn identity(n: usize) -> Csr {
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

    /// Number of stored entries (explicit zeros included; both triangles of
    /// a symmetric matrix).
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// The row pointers (`n_rows + 1` entries, from 0 to [`Csr::nnz`]).
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// The column index of every stored entry, row after row.
    pub fn col_indices(&self) -> &[u32] {
        &self.col
    }

    /// The value of every stored entry, row after row.
    pub fn values(&self) -> &[f64] {
        &self.val
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

    /// The entry `a_ij` (0 when not stored, or out of range): a binary
    /// search in row `i`.
    pub fn get(&self, i: u32, j: u32) -> f64 {
        if i as usize >= self.n_rows {
            return 0.0;
        }
        let (c, v) = self.row(i as usize);
        c.binary_search(&j).map_or(0.0, |k| v[k])
    }

    /// The entries `(i, j, a_ij)` with `j >= i` (the upper triangle,
    /// diagonal included), row by row, columns ascending: for a symmetric
    /// matrix, each position of its upper triangle once.
    pub fn upper_triangle(&self) -> impl Iterator<Item = (u32, u32, f64)> + '_ {
        (0..self.n_rows).flat_map(move |i| {
            let (c, v) = self.row(i);
            let start = c.partition_point(|&j| (j as usize) < i);
            c[start..]
                .iter()
                .zip(&v[start..])
                .map(move |(&j, &a)| (i as u32, j, a))
        })
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
    /// of row `i` (in column order); rayon-parallel over chunks of 4096
    /// rows (sequential below 10 000 rows).
    ///
    /// # Panics
    /// If `x.len() != n_cols` or `y.len() != n_rows` (a programming error;
    /// checked in every build, it costs two comparisons).
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.n_cols, "Csr::mul_vec: x has the wrong length");
        assert_eq!(y.len(), self.n_rows, "Csr::mul_vec: y has the wrong length");
        self.for_each_row(y, |i, yi| *yi = self.row_dot(i, x));
    }

    /// `A x` as a new vector ([`Csr::mul_vec`]).
    ///
    /// # Panics
    /// If `x.len() != n_cols`.
    pub fn multiply(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n_rows];
        self.mul_vec(x, &mut y);
        y
    }

    /// `y += A x`.
    pub(crate) fn mul_vec_add(&self, x: &[f64], y: &mut [f64]) {
        debug_assert_eq!(x.len(), self.n_cols);
        debug_assert_eq!(y.len(), self.n_rows);
        self.for_each_row(y, |i, yi| *yi += self.row_dot(i, x));
    }

    /// `res = b - A x`.
    pub(crate) fn residual(&self, b: &[f64], x: &[f64], res: &mut [f64]) {
        debug_assert_eq!(x.len(), self.n_cols);
        debug_assert_eq!(b.len(), self.n_rows);
        debug_assert_eq!(res.len(), self.n_rows);
        self.for_each_row(res, |i, ri| *ri = b[i] - self.row_dot(i, x));
    }

    /// The quadratic form `x^T A x = sum_i x_i (A x)_i` (for a Laplacian:
    /// twice the Dirichlet energy of the piecewise-linear function with
    /// nodal values `x`).
    ///
    /// # Panics
    /// If the matrix is not square or `x.len() != n_cols`.
    pub fn quadratic_form(&self, x: &[f64]) -> f64 {
        assert_eq!(self.n_rows, self.n_cols, "Csr::quadratic_form: not square");
        assert_eq!(x.len(), self.n_cols, "Csr::quadratic_form: vector length");
        (0..self.n_rows).map(|i| x[i] * self.row_dot(i, x)).sum()
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

    /// `|A|_inf = max_i sum_j |a_ij|`, the largest absolute row sum (for a
    /// symmetric matrix an upper bound on `|A|_2`; 0 for an empty matrix).
    pub fn max_row_sum(&self) -> f64 {
        self.row_ptr
            .windows(2)
            .map(|w| self.val[w[0]..w[1]].iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max)
    }

    /// The principal submatrix `A_KK` of the kept rows and columns:
    /// `index[i]` is the new number of row and column `i`, or `u32::MAX`
    /// to drop it (the new numbers `0 .. m`, each once; entries keep their
    /// order when the numbering is increasing).
    ///
    /// # Errors
    /// [`LinalgError::NotSquare`]; [`LinalgError::DimensionMismatch`] if
    /// `index.len() != n_rows`; [`LinalgError::IndexOutOfRange`] for a new
    /// number `>=` the number kept; [`LinalgError::DuplicateIndex`] for a
    /// new number used twice.
    pub fn principal_submatrix(&self, index: &[u32]) -> Result<Csr, LinalgError> {
        if self.n_rows != self.n_cols {
            return Err(LinalgError::NotSquare {
                rows: self.n_rows,
                cols: self.n_cols,
            });
        }
        if index.len() != self.n_rows {
            return Err(LinalgError::DimensionMismatch {
                what: "principal submatrix: new numbers (one per row)",
                expected: self.n_rows,
                found: index.len(),
            });
        }
        let m = index.iter().filter(|&&k| k != u32::MAX).count();
        let mut old = vec![usize::MAX; m];
        for (i, &k) in index.iter().enumerate() {
            if k == u32::MAX {
                continue;
            }
            let slot = old
                .get_mut(k as usize)
                .ok_or(LinalgError::IndexOutOfRange {
                    what: "principal submatrix: new number",
                    index: k as usize,
                    len: m,
                })?;
            if *slot != usize::MAX {
                return Err(LinalgError::DuplicateIndex {
                    what: "principal submatrix: new number",
                    index: k as usize,
                });
            }
            *slot = i;
        }
        let mut row_ptr = Vec::with_capacity(m + 1);
        row_ptr.push(0);
        let mut col = Vec::new();
        let mut val = Vec::new();
        let mut scratch: Vec<(u32, f64)> = Vec::new();
        for &i in &old {
            let (c, v) = self.row(i);
            scratch.clear();
            scratch.extend(
                c.iter()
                    .zip(v)
                    .filter(|e| index[*e.0 as usize] != u32::MAX)
                    .map(|(&j, &a)| (index[j as usize], a)),
            );
            if scratch.windows(2).any(|w| w[0].0 > w[1].0) {
                scratch.sort_unstable_by_key(|e| e.0);
            }
            col.extend(scratch.iter().map(|e| e.0));
            val.extend(scratch.iter().map(|e| e.1));
            row_ptr.push(col.len());
        }
        Ok(Csr {
            n_rows: m,
            n_cols: m,
            row_ptr,
            col,
            val,
        })
    }

    /// The first non-finite value.
    ///
    /// # Errors
    /// [`LinalgError::NotFinite`] with `what` and the position of that
    /// value among the stored entries.
    pub fn check_finite(&self, what: &'static str) -> Result<(), LinalgError> {
        match self.val.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(index) => Err(LinalgError::NotFinite { what, index }),
        }
    }

    /// Checks `|a_ij - a_ji| <= 1e-12 max |a|` for every stored entry (a
    /// missing mirror entry counts as zero), rows in parallel for large
    /// matrices.
    ///
    /// # Errors
    /// [`LinalgError::NotSquare`]; [`LinalgError::NotSymmetric`] with the
    /// first offending entry.
    pub fn check_symmetric(&self) -> Result<(), LinalgError> {
        if self.n_rows != self.n_cols {
            return Err(LinalgError::NotSquare {
                rows: self.n_rows,
                cols: self.n_cols,
            });
        }
        let amax = self.val.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tol = 1e-12 * amax;
        let check_row = |i: usize| {
            let (c, v) = self.row(i);
            c.iter().zip(v).find_map(|(&j, &aij)| {
                let (cj, vj) = self.row(j as usize);
                let aji = cj.binary_search(&(i as u32)).map_or(0.0, |k| vj[k]);
                ((aij - aji).abs() > tol).then_some((i, j, aij, aji))
            })
        };
        let bad = if self.n_rows < PAR_MIN {
            (0..self.n_rows).find_map(check_row)
        } else {
            (0..self.n_rows).into_par_iter().find_map_first(check_row)
        };
        match bad {
            None => Ok(()),
            Some((i, j, aij, aji)) => Err(LinalgError::NotSymmetric {
                row: i,
                col: j as usize,
                value: aij,
                mirror: aji,
            }),
        }
    }

    /// The sparse product `C = A B`.
    ///
    /// # Errors
    /// [`LinalgError::DimensionMismatch`] if `b` does not have `n_cols`
    /// rows.
    pub fn matmul(&self, b: &Csr) -> Result<Csr, LinalgError> {
        if b.n_rows != self.n_cols {
            return Err(LinalgError::DimensionMismatch {
                what: "matmul: rows of B (columns of A)",
                expected: self.n_cols,
                found: b.n_rows,
            });
        }
        Ok(spgemm(self, b))
    }

    /// Galerkin coarse operator `P^T A P` (`A` square `n x n`, `P` `n x m`)
    /// -> `m x m`:
    ///
    /// ```text
    /// (P^T A P)_{IJ} = sum_{i,j} p_{iI} a_{ij} p_{jJ}
    /// ```
    ///
    /// computed row by row from the explicit transpose `P^T` without storing
    /// `A P` (Gustavson, a dense accumulator and marker array of size `m`
    /// per rayon task; see [`Csr::galerkin_with_transpose`]).
    ///
    /// # Errors
    /// [`LinalgError::NotSquare`] if `A` is not square,
    /// [`LinalgError::DimensionMismatch`] if `P` does not have `n` rows,
    /// [`LinalgError::NotFinite`] if the product overflows.
    pub fn galerkin(&self, p: &Csr) -> Result<Csr, LinalgError> {
        self.galerkin_with_transpose(p, &p.transpose())
    }

    /// [`Csr::galerkin`] with `P^T` given (a multigrid keeps it as its
    /// restriction): row `I` of `P^T A P` is
    /// `sum_i (P^T)_{Ii} sum_k a_{ik} p_{k.}`, gathered without storing `A P`.
    ///
    /// # Errors
    /// Those of [`Csr::galerkin`]; [`LinalgError::DimensionMismatch`] if
    /// `pt` is not `m x n`.
    pub fn galerkin_with_transpose(&self, p: &Csr, pt: &Csr) -> Result<Csr, LinalgError> {
        if self.n_rows != self.n_cols {
            return Err(LinalgError::NotSquare {
                rows: self.n_rows,
                cols: self.n_cols,
            });
        }
        if p.n_rows != self.n_rows {
            return Err(LinalgError::DimensionMismatch {
                what: "galerkin: rows of the prolongation P",
                expected: self.n_rows,
                found: p.n_rows,
            });
        }
        if pt.n_rows != p.n_cols {
            return Err(LinalgError::DimensionMismatch {
                what: "galerkin: rows of the transpose P^T (columns of P)",
                expected: p.n_cols,
                found: pt.n_rows,
            });
        }
        if pt.n_cols != p.n_rows {
            return Err(LinalgError::DimensionMismatch {
                what: "galerkin: columns of the transpose P^T (rows of P)",
                expected: p.n_rows,
                found: pt.n_cols,
            });
        }
        let c = triple_product(pt, self, p);
        c.check_finite("value of the Galerkin product P^T A P")?;
        Ok(c)
    }
}

/// The dense accumulator of one Gustavson row: `add(j, v)` adds `v` to
/// column `j` of the current row.
struct RowAcc {
    /// `marker[j] == row` iff column `j` already has an entry in the row
    /// (`row < n <= u32::MAX`, so `u32::MAX` is never a row).
    marker: Vec<u32>,
    acc: Vec<f64>,
    pattern: Vec<u32>,
    row: u32,
}

impl RowAcc {
    #[inline]
    fn add(&mut self, j: u32, v: f64) {
        let ju = j as usize;
        if self.marker[ju] != self.row {
            self.marker[ju] = self.row;
            self.acc[ju] = v;
            self.pattern.push(j);
        } else {
            self.acc[ju] += v;
        }
    }
}

/// An `n x m` sparse matrix built row by row (Gustavson): `row(i, acc)`
/// adds row `i`'s contributions to `acc` ([`RowAcc::add`]), which gathers
/// them in a dense accumulator of size `m` with a marker array (no per-row
/// allocation); rows in parallel blocks, each block's rows stored once and
/// then copied into the result.
fn gustavson<F>(n: usize, m: usize, row: F) -> Csr
where
    F: Fn(usize, &mut RowAcc) + Sync,
{
    let tasks = 4 * rayon::current_num_threads().max(1);
    let block = n.div_ceil(tasks).max(ROW_CHUNK);
    let starts: Vec<usize> = (0..n).step_by(block).collect();
    let parts: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = starts
        .par_iter()
        .map(|&s| {
            let e = (s + block).min(n);
            let mut acc = RowAcc {
                marker: vec![u32::MAX; m],
                acc: vec![0.0; m],
                pattern: Vec::new(),
                row: 0,
            };
            let mut lens = Vec::with_capacity(e - s);
            let mut col = Vec::new();
            let mut val = Vec::new();
            for i in s..e {
                acc.row = i as u32;
                acc.pattern.clear();
                row(i, &mut acc);
                acc.pattern.sort_unstable();
                col.extend_from_slice(&acc.pattern);
                val.extend(acc.pattern.iter().map(|&j| acc.acc[j as usize]));
                lens.push(acc.pattern.len());
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

/// The sparse product `C = A B` (`a.n_cols == b.n_rows`), row by row:
/// `c_{i.} = sum_k a_ik b_{k.}` ([`gustavson`]).
pub(crate) fn spgemm(a: &Csr, b: &Csr) -> Csr {
    debug_assert_eq!(a.n_cols, b.n_rows);
    gustavson(a.n_rows, b.n_cols, |i, acc| {
        let (ac, av) = a.row(i);
        for (&k, &aik) in ac.iter().zip(av) {
            let (bc, bv) = b.row(k as usize);
            for (&j, &bkj) in bc.iter().zip(bv) {
                acc.add(j, aik * bkj);
            }
        }
    })
}

/// The triple product `C = R A P` (`r.n_cols == a.n_rows`,
/// `a.n_cols == p.n_rows`) without storing `A P`: row `I` of `C` is
/// `c_{I.} = sum_i r_{Ii} sum_k a_{ik} p_{k.}` ([`gustavson`]). With
/// `R = P^T` it is the Galerkin product; `A P` is recomputed for each of a
/// fine row's coarse parents (a few more multiply-adds) instead of being
/// held, which is the largest allocation of a multigrid setup.
pub(crate) fn triple_product(r: &Csr, a: &Csr, p: &Csr) -> Csr {
    debug_assert_eq!(r.n_cols, a.n_rows);
    debug_assert_eq!(a.n_cols, p.n_rows);
    gustavson(r.n_rows, p.n_cols, |ci, acc| {
        let (rc, rv) = r.row(ci);
        for (&i, &rii) in rc.iter().zip(rv) {
            let (ac, av) = a.row(i as usize);
            for (&k, &aik) in ac.iter().zip(av) {
                let w = rii * aik;
                let (pc, pv) = p.row(k as usize);
                for (&j, &pkj) in pc.iter().zip(pv) {
                    acc.add(j, w * pkj);
                }
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Rng, assert_structure, dense, random_csr};
    use nalgebra::DVector;
    use proptest::prelude::*;

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
        let out = |entry, row, col| {
            Err(LinalgError::EntryOutOfRange {
                entry,
                row,
                col,
                n_rows: 2,
                n_cols: 3,
            })
        };
        assert_eq!(
            Csr::from_triplets(2, 3, &[(0, 0, 1.0), (2, 1, 1.0)]),
            out(1, 2, 1)
        );
        assert_eq!(Csr::from_triplets(2, 3, &[(1, 3, 1.0)]), out(0, 1, 3));
        let e = Csr::from_triplets(2, 3, &[(1, 3, 1.0)]).unwrap_err();
        assert!(e.to_string().contains("(1, 3)"), "{e}");
        let not_finite = |index| {
            Err(LinalgError::NotFinite {
                what: "triplet value",
                index,
            })
        };
        assert_eq!(
            Csr::from_triplets(2, 3, &[(0, 0, 1.0), (1, 1, f64::NAN)]),
            not_finite(1)
        );
        assert_eq!(
            Csr::from_triplets(2, 3, &[(1, 1, f64::INFINITY)]),
            not_finite(0)
        );
        assert_eq!(
            Csr::from_triplets(1, 1, &[(0, 0, f64::MAX), (0, 0, f64::MAX)]),
            Err(LinalgError::DuplicateSumNotFinite { row: 0, col: 0 })
        );
        let e = Csr::from_triplets(usize::MAX, 1, &[]).unwrap_err();
        assert_eq!(
            e,
            LinalgError::TooLarge {
                rows: usize::MAX,
                cols: 1
            }
        );
        assert!(e.to_string().contains("too large"), "{e}");
    }

    #[test]
    fn from_raw_checks_every_array() {
        let ok = Csr::from_raw(2, 3, vec![0, 1, 3], vec![2, 0, 1], vec![1.0, 2.0, 3.0]).unwrap();
        assert_eq!(ok.row(1), (&[0u32, 1][..], &[2.0, 3.0][..]));
        assert_eq!(
            (ok.row_ptr(), ok.col_indices(), ok.values()),
            (&[0, 1, 3][..], &[2u32, 0, 1][..], &[1.0, 2.0, 3.0][..])
        );
        let raw = |ptr: Vec<usize>, col: Vec<u32>, val: Vec<f64>| {
            Csr::from_raw(2, 3, ptr, col, val).unwrap_err()
        };
        assert!(matches!(
            raw(vec![0, 3], vec![0, 1, 2], vec![1.0; 3]),
            LinalgError::DimensionMismatch {
                expected: 3,
                found: 2,
                ..
            }
        ));
        assert!(matches!(
            raw(vec![0, 1, 3], vec![0, 1, 2], vec![1.0; 2]),
            LinalgError::DimensionMismatch {
                expected: 3,
                found: 2,
                ..
            }
        ));
        let pointers = |at, value| LinalgError::BadPointers {
            what: "CSR row pointers",
            at,
            value,
            entries: 3,
        };
        assert_eq!(
            raw(vec![1, 1, 3], vec![0, 1, 2], vec![1.0; 3]),
            pointers(0, 1)
        );
        assert_eq!(
            raw(vec![0, 1, 2], vec![0, 1, 2], vec![1.0; 3]),
            pointers(2, 2)
        );
        let decreasing = Csr::from_raw(3, 3, vec![0, 2, 1, 3], vec![0, 1, 2], vec![1.0; 3]);
        assert_eq!(
            decreasing,
            Err(LinalgError::BadPointers {
                what: "CSR row pointers",
                at: 2,
                value: 1,
                entries: 3
            })
        );
        assert_eq!(
            raw(vec![0, 2, 3], vec![1, 1, 2], vec![1.0; 3]),
            LinalgError::UnsortedIndices {
                what: "columns of row",
                line: 0
            }
        );
        assert_eq!(
            raw(vec![0, 1, 3], vec![0, 1, 3], vec![1.0; 3]),
            LinalgError::IndexOutOfRange {
                what: "column index",
                index: 3,
                len: 3
            }
        );
        assert_eq!(
            raw(vec![0, 1, 3], vec![0, 1, 2], vec![1.0, f64::NAN, 1.0]),
            LinalgError::NotFinite {
                what: "CSR value",
                index: 1
            }
        );
        assert!(matches!(
            Csr::from_raw(usize::MAX, 1, vec![], vec![], vec![]),
            Err(LinalgError::TooLarge { .. })
        ));
    }

    #[test]
    fn galerkin_rejects_mismatched_sizes() {
        let mut rng = Rng(3);
        let a = random_csr(4, 4, 10, &mut rng);
        let p = random_csr(5, 2, 6, &mut rng);
        assert!(matches!(
            a.galerkin(&p),
            Err(LinalgError::DimensionMismatch {
                expected: 4,
                found: 5,
                ..
            })
        ));
        let rect = random_csr(4, 5, 6, &mut rng);
        let err = rect.galerkin(&p).unwrap_err();
        assert_eq!(err, LinalgError::NotSquare { rows: 4, cols: 5 });
        assert!(err.to_string().contains("square"), "{err}");
        assert!(matches!(
            a.matmul(&p),
            Err(LinalgError::DimensionMismatch {
                expected: 4,
                found: 5,
                ..
            })
        ));
        // Overflow in the product.
        let big = Csr::from_triplets(1, 1, &[(0, 0, f64::MAX)]).unwrap();
        assert!(matches!(
            big.galerkin(&big),
            Err(LinalgError::NotFinite { index: 0, .. })
        ));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn mul_vec_transpose_diagonal_match_dense(
            rows in 1usize..14, cols in 1usize..14, nnz in 0usize..80, seed in any::<u64>(),
        ) {
            let mut rng = Rng(seed);
            let a = random_csr(rows, cols, nnz, &mut rng);
            assert_structure(&a);
            let d = dense(&a);
            let x: Vec<f64> = (0..cols).map(|_| rng.f64() - 0.5).collect();
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
            let mut rng = Rng(seed);
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

    proptest! {
        /// The fused `R A P` equals `R (A P)` from two products, for any
        /// `R` (not only `P^T`).
        #[test]
        fn triple_product_matches_two_products(
            m in 1usize..10, n in 1usize..16, k in 1usize..12,
            nnz_r in 0usize..60, nnz_a in 0usize..100, nnz_p in 0usize..40,
            seed in any::<u64>(),
        ) {
            let mut rng = Rng(seed);
            let r = random_csr(m, n, nnz_r, &mut rng);
            let a = random_csr(n, n, nnz_a, &mut rng);
            let p = random_csr(n, k, nnz_p, &mut rng);
            let c = triple_product(&r, &a, &p);
            assert_structure(&c);
            prop_assert_eq!((c.n_rows(), c.n_cols()), (m, k));
            let (got, expect) = (dense(&c), dense(&spgemm(&r, &spgemm(&a, &p))));
            for i in 0..m {
                for j in 0..k {
                    prop_assert!(
                        (got[(i, j)] - expect[(i, j)]).abs() <= 1e-12 * (1.0 + expect[(i, j)].abs()),
                        "({}, {}): {} vs {}", i, j, got[(i, j)], expect[(i, j)]
                    );
                }
            }
        }
    }

    #[test]
    fn galerkin_with_a_wrong_transpose_is_refused() {
        let mut rng = Rng(5);
        let a = random_csr(6, 6, 20, &mut rng);
        let p = random_csr(6, 3, 8, &mut rng);
        for (pt, what) in [
            (random_csr(4, 6, 8, &mut rng), "rows of the transpose"),
            (random_csr(3, 5, 8, &mut rng), "columns of the transpose"),
        ] {
            match a.galerkin_with_transpose(&p, &pt).unwrap_err() {
                e @ LinalgError::DimensionMismatch { .. } => {
                    assert!(e.to_string().contains(what), "{e}")
                }
                e => panic!("{e:?}"),
            }
        }
        let ok = a.galerkin_with_transpose(&p, &p.transpose()).unwrap();
        assert_eq!(ok, a.galerkin(&p).unwrap());
    }

    #[test]
    fn spgemm_parallel_blocks_match_sequential_product() {
        // Enough rows for several rayon blocks.
        let mut rng = Rng(11);
        let a = random_csr(20_000, 300, 100_000, &mut rng);
        let b = random_csr(300, 50, 2_000, &mut rng);
        let c = spgemm(&a, &b);
        assert_structure(&c);
        let x: Vec<f64> = (0..50).map(|_| rng.f64()).collect();
        let (mut bx, mut abx, mut cx) = (vec![0.0; 300], vec![0.0; 20_000], vec![0.0; 20_000]);
        b.mul_vec(&x, &mut bx);
        a.mul_vec(&bx, &mut abx);
        c.mul_vec(&x, &mut cx);
        for (u, v) in abx.iter().zip(&cx) {
            assert!((u - v).abs() <= 1e-11 * (1.0 + u.abs()));
        }
    }

    #[test]
    fn symmetric_entries_are_merged_in_the_upper_triangle_and_mirrored() {
        let a =
            Csr::from_symmetric_entries(3, [(1, 0, 2.0), (0, 1, 1.0), (2, 2, 4.0), (0, 0, 1.0)])
                .unwrap();
        assert_eq!(
            a.upper_triangle().collect::<Vec<_>>(),
            vec![(0, 0, 1.0), (0, 1, 3.0), (2, 2, 4.0)]
        );
        assert_eq!(a.row(1), (&[0u32][..], &[3.0][..]));
        assert_eq!(a.get(1, 0), 3.0);
        assert_eq!(a.get(0, 1), 3.0);
        assert_eq!(a.get(1, 2), 0.0);
        assert_eq!(a.get(7, 2), 0.0);
        assert_eq!(a.multiply(&[1.0, 2.0, 3.0]), vec![7.0, 3.0, 12.0]);
        assert_eq!(a.quadratic_form(&[1.0, 2.0, 3.0]), 1.0 + 12.0 + 36.0);
        assert_eq!(a.diagonal(), vec![1.0, 0.0, 4.0]);
        assert_eq!(a.nnz(), 4);
        assert_eq!(a.max_row_sum(), 4.0);
        assert!(a.check_symmetric().is_ok());
        assert_eq!(a.transpose(), a);
        assert_eq!(
            Csr::from_symmetric_entries(3, [(0, 0, 1.0), (1, 3, 1.0)]),
            Err(LinalgError::EntryOutOfRange {
                entry: 1,
                row: 1,
                col: 3,
                n_rows: 3,
                n_cols: 3
            })
        );
        assert_eq!(
            Csr::from_symmetric_entries(3, [(0, 2, f64::NAN)]),
            Err(LinalgError::NotFinite {
                what: "symmetric entry value",
                index: 0
            })
        );
        assert_eq!(
            Csr::from_symmetric_entries(2, [(0, 1, f64::MAX), (1, 0, f64::MAX)]),
            Err(LinalgError::DuplicateSumNotFinite { row: 0, col: 1 })
        );
    }

    #[test]
    fn symmetry_and_finiteness_checks_name_the_entry() {
        let a = Csr::from_triplets(3, 3, &[(0, 0, 2.0), (0, 2, -1.0), (2, 0, -1.5)]).unwrap();
        assert_eq!(
            a.check_symmetric(),
            Err(LinalgError::NotSymmetric {
                row: 0,
                col: 2,
                value: -1.0,
                mirror: -1.5
            })
        );
        let b = Csr::from_triplets(3, 3, &[(1, 2, 1e-20), (1, 1, 1.0)]).unwrap();
        assert!(b.check_symmetric().is_ok(), "below 1e-12 max |a|");
        let c = Csr::from_triplets(2, 3, &[]).unwrap();
        assert_eq!(
            c.check_symmetric(),
            Err(LinalgError::NotSquare { rows: 2, cols: 3 })
        );
        let d = Csr::symmetric(2, [(0, 1, f64::NAN), (0, 0, 1.0)]);
        assert_eq!(
            d.check_finite("value"),
            Err(LinalgError::NotFinite {
                what: "value",
                index: 1
            })
        );
        assert!(a.check_finite("value").is_ok());
    }

    #[test]
    fn principal_submatrix_keeps_and_renumbers() {
        let mut rng = Rng(5);
        let a = random_csr(7, 7, 30, &mut rng);
        // Keep rows/columns 1, 3, 4, 6 as 0..4, increasing.
        let keep = [1usize, 3, 4, 6];
        let mut index = vec![u32::MAX; 7];
        for (k, &i) in keep.iter().enumerate() {
            index[i] = k as u32;
        }
        let s = a.principal_submatrix(&index).unwrap();
        assert_structure(&s);
        let (da, ds) = (dense(&a), dense(&s));
        for (p, &i) in keep.iter().enumerate() {
            for (q, &j) in keep.iter().enumerate() {
                assert_eq!(ds[(p, q)], da[(i, j)]);
            }
        }
        // A decreasing numbering: the rows are re-sorted.
        let mut rev = vec![u32::MAX; 7];
        for (k, &i) in keep.iter().enumerate() {
            rev[i] = (3 - k) as u32;
        }
        let r = a.principal_submatrix(&rev).unwrap();
        assert_structure(&r);
        let dr = dense(&r);
        for (p, &i) in keep.iter().enumerate() {
            for (q, &j) in keep.iter().enumerate() {
                assert_eq!(dr[(3 - p, 3 - q)], da[(i, j)]);
            }
        }
        assert!(matches!(
            a.principal_submatrix(&index[..6]),
            Err(LinalgError::DimensionMismatch { .. })
        ));
        let mut twice = index.clone();
        twice[0] = 0;
        twice[1] = 0;
        twice[3] = 1;
        twice[4] = 2;
        twice[6] = u32::MAX;
        assert!(matches!(
            a.principal_submatrix(&twice),
            Err(LinalgError::DuplicateIndex { index: 0, .. })
        ));
        let mut far = index.clone();
        far[6] = 9;
        assert!(matches!(
            a.principal_submatrix(&far),
            Err(LinalgError::IndexOutOfRange {
                index: 9,
                len: 4,
                ..
            })
        ));
        let rect = Csr::from_triplets(2, 3, &[]).unwrap();
        assert!(matches!(
            rect.principal_submatrix(&[0, 1]),
            Err(LinalgError::NotSquare { .. })
        ));
    }
}
