//! Sparse symmetric positive definite solves by faer's sparse Cholesky.
//!
//! The pattern is analysed once ([`SpdPattern`]: a fill-reducing ordering
//! and the symbolic factorization), then refactorized for every new set of
//! values ([`SpdPattern::factorize`], [`SpdPattern::refactorize`]), as
//! projected Newton needs: the Hessian's sparsity never changes between
//! iterations.
//!
//! The values live in the *ordered* matrix: a pattern stores the lower
//! triangle of `P A P^T` (`P` the fill-reducing permutation) in compressed
//! columns, and [`SpdPattern::slot`] gives, for an entry `(i, j)` of `A`,
//! where its value goes. Assembling into those slots hands the factorization
//! its input as it wants it (no permutation or transposition per
//! factorization), and [`SpdPattern::refactorize`] reuses the factor's
//! storage.
//!
//! A pattern built with [`SpdPattern::with_blocks`] (the `d` coordinates of
//! a vertex are the `d` consecutive unknowns `d v .. d v + d`, all coupled)
//! is ordered by AMD on the vertex graph, each vertex's unknowns kept
//! together, and factorized supernodally: the factor then has dense column
//! blocks of at least `d` columns, which the supernodal kernels handle with
//! dense (BLAS-3 style) updates.
//!
//! A pattern built from a vertex graph ([`SpdPattern::from_vertex_graph_with`])
//! may instead be ordered by nested dissection (`super::nested_dissection`),
//! or not factorized at all: with [`VertexSolver::Multigrid`] the values stay
//! in the vertices' own order, a "factorization" builds a multigrid
//! hierarchy and a solve iterates (`super::multigrid_solve`), for meshes
//! whose factor would not fit (docs/DESIGN-NOTES.md, "Fine tet meshes").
//!
//! A [`Csr`] matrix enters through [`SpdPattern::of_symmetric`] (its
//! pattern) and [`SpdPattern::values_of`] (its values in the slots).

use super::multigrid_solve::{MultigridPlan, MultigridSettings, MultigridSizes};
use super::nested_dissection::{Graph, nested_dissection};
use crate::multigrid::{Multigrid, PcgReport};
use crate::{Csr, LinalgError};
use faer::dyn_stack::{MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use std::mem::MaybeUninit;
use std::sync::Arc;

/// How the systems of a vertex-graph pattern are solved
/// ([`SpdPattern::from_vertex_graph_with`]).
#[derive(Debug, Clone, PartialEq)]
pub enum VertexSolver {
    /// Supernodal Cholesky, the vertices ordered by approximate minimum
    /// degree (faer's AMD).
    CholeskyAmd,
    /// Supernodal Cholesky, the vertices ordered by nested dissection
    /// ([`super::nested_dissection`]).
    CholeskyNestedDissection,
    /// Conjugate gradients preconditioned by multigrid on a background
    /// grid over the vertices (`super::multigrid_solve`): no factor, memory
    /// linear in the mesh; solves to a relative residual.
    Multigrid(MultigridSettings),
}

/// A fixed sparsity pattern of a symmetric `n x n` matrix `A`, with the
/// fill-reducing ordering and the symbolic Cholesky analysis (or the
/// multigrid's plan) done once, and the value slot of every entry (see the
/// module docs).
#[derive(Debug, Clone)]
pub struct SpdPattern {
    n: usize,
    /// The lower triangle of `P A P^T`, compressed columns, rows sorted.
    lower: SymbolicSparseColMat<usize>,
    /// `fwd[k]`: the unknown of `A` at position `k` of the ordering;
    /// `inv[fwd[k]] = k`.
    fwd: Arc<Vec<usize>>,
    inv: Vec<usize>,
    /// The solver: a symbolic Cholesky factorization, or the multigrid
    /// plan.
    backend: Backend,
    /// Slot of `A[i][i]`, per unknown `i`.
    diagonal: Vec<usize>,
    /// Slot of each entry of the compressed pattern given to
    /// [`SpdPattern::from_upper_csc`] (empty for a vertex-graph pattern).
    input_slots: Vec<usize>,
    /// Where the blocks of a [`SpdPattern::from_vertex_graph`] pattern went.
    blocks: Option<VertexBlocks>,
}

/// How a pattern's systems are solved.
#[derive(Debug, Clone)]
enum Backend {
    /// Sparse Cholesky: the symbolic factorization and the workspace of a
    /// numeric one.
    Cholesky {
        symbolic: Arc<SymbolicCholesky<usize>>,
        scratch: StackReq,
    },
    /// Conjugate gradients with a multigrid preconditioner.
    Multigrid(Arc<MultigridPlan>),
}

impl SpdPattern {
    /// The pattern of the given entries (`(i, j)` pairs in any order and
    /// either triangle; duplicates merged); the diagonal is always included.
    /// AMD ordering of the unknowns; faer picks the simplicial or
    /// supernodal factorization from the predicted flop count.
    ///
    /// # Errors
    /// [`LinalgError::EntryOutOfRange`] for an index `>= n`;
    /// [`LinalgError::Faer`] when faer's ordering or analysis fails.
    pub fn new(
        n: usize,
        entries: impl IntoIterator<Item = (u32, u32)>,
    ) -> Result<Self, LinalgError> {
        Self::build(n, 1, entries)
    }

    /// As [`SpdPattern::new`] for a matrix of `n / block` vertices with
    /// `block` unknowns each (`block` divides `n`): ordered by AMD on the
    /// vertex graph (vertex `v` adjacent to `w` when any entry couples
    /// their unknowns) with each vertex's unknowns consecutive, and
    /// factorized supernodally.
    pub fn with_blocks(
        n: usize,
        block: usize,
        entries: impl IntoIterator<Item = (u32, u32)>,
    ) -> Result<Self, LinalgError> {
        Self::build(n, block, entries)
    }

    /// The pattern of the symmetric matrix `a` (both triangles stored):
    /// [`SpdPattern::new`] of the entries of its upper triangle
    /// ([`Csr::upper_triangle`]).
    ///
    /// # Errors
    /// [`LinalgError::NotSquare`]; those of [`SpdPattern::new`].
    pub fn of_symmetric(a: &Csr) -> Result<Self, LinalgError> {
        if a.n_rows() != a.n_cols() {
            return Err(LinalgError::NotSquare {
                rows: a.n_rows(),
                cols: a.n_cols(),
            });
        }
        Self::new(a.n_rows(), a.upper_triangle().map(|(i, j, _)| (i, j)))
    }

    /// The value array of the symmetric matrix `a` in this pattern: every
    /// entry of its upper triangle added into its slot (so each slot holds
    /// `a_ij` once).
    ///
    /// # Errors
    /// [`LinalgError::DimensionMismatch`] when `a` is not `n x n`;
    /// [`LinalgError::EntryNotInPattern`] for an entry without a slot.
    pub fn values_of(&self, a: &Csr) -> Result<Vec<f64>, LinalgError> {
        for (what, found) in [("rows", a.n_rows()), ("columns", a.n_cols())] {
            if found != self.n {
                return Err(LinalgError::DimensionMismatch {
                    what,
                    expected: self.n,
                    found,
                });
            }
        }
        let mut values = vec![0.0; self.nnz()];
        for (i, j, v) in a.upper_triangle() {
            let s = self.slot(i, j).ok_or(LinalgError::EntryNotInPattern {
                row: i as usize,
                col: j as usize,
            })?;
            values[s] += v;
        }
        Ok(values)
    }

    fn build(
        n: usize,
        block: usize,
        entries: impl IntoIterator<Item = (u32, u32)>,
    ) -> Result<Self, LinalgError> {
        let mut cols: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (entry, (i, j)) in entries.into_iter().enumerate() {
            let (r, c) = if i <= j { (i, j) } else { (j, i) };
            if c as usize >= n {
                return Err(LinalgError::EntryOutOfRange {
                    entry,
                    row: i as usize,
                    col: j as usize,
                    n_rows: n,
                    n_cols: n,
                });
            }
            cols[c as usize].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0usize);
        for (c, rows) in cols.iter_mut().enumerate() {
            rows.push(c as u32);
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend(rows.iter().map(|&r| r as usize));
            col_ptr.push(row_idx.len());
        }
        Self::from_upper_csc(n, block, col_ptr, row_idx)
    }

    /// The pattern given directly as the upper triangle of `A` in
    /// compressed sparse columns: column `c` holds the rows
    /// `row_idx[col_ptr[c] .. col_ptr[c + 1]]`, strictly increasing, all
    /// `<= c`, ending with the diagonal `c`. With `block > 1` (dividing
    /// `n`) the matrix is ordered and factorized as in
    /// [`SpdPattern::with_blocks`]. [`SpdPattern::input_slot`] maps the
    /// index of an entry in `row_idx` to its value slot.
    pub fn from_upper_csc(
        n: usize,
        block: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, LinalgError> {
        if block == 0 || !n.is_multiple_of(block) {
            return Err(LinalgError::BlockSize { block, n });
        }
        let upper = validated_upper(n, col_ptr, row_idx)?;
        let (fwd, inv) = if block == 1 {
            scalar_amd(&upper)?
        } else {
            block_amd(&upper, block)?
        };
        // The ordered matrix P A P^T, lower triangle (values) and upper
        // triangle (its transpose, for the symbolic analysis).
        let (ptr, rows) = (upper.col_ptr(), upper.row_idx());
        let (mut lo, mut hi) = (
            Vec::with_capacity(rows.len()),
            Vec::with_capacity(rows.len()),
        );
        for c in 0..n {
            let fc = inv[c];
            for &r in &rows[ptr[c]..ptr[c + 1]] {
                let fr = inv[r];
                hi.push(fr.max(fc));
                lo.push(fr.min(fc));
            }
        }
        let (lower, input_slots) = compress(n, &hi, &lo);
        let (ordered_upper, _) = compress(n, &lo, &hi);
        Self::finish(block, lower, ordered_upper, fwd, inv, input_slots, None)
    }

    /// The pattern of a matrix of `nv` vertices with `block` unknowns each
    /// (vertex `v` owns the unknowns `block v .. block v + block`) whose
    /// nonzero blocks are the vertex pairs of a graph, given as its upper
    /// triangle in compressed columns: column `b` holds the vertices
    /// `row_idx[col_ptr[b] .. col_ptr[b + 1]]`, strictly increasing, all
    /// `<= b`, ending with `b` itself. Every block is full (`block x block`;
    /// a diagonal block stores its upper triangle).
    ///
    /// Ordered by AMD on the graph, each vertex's unknowns consecutive, and
    /// factorized supernodally, as [`SpdPattern::with_blocks`]; the same
    /// matrix as [`SpdPattern::from_upper_csc`] with every block expanded,
    /// but built at the vertex level (`block^2` times fewer entries to sort).
    /// [`SpdPattern::block_slot`] gives the value slots.
    pub fn from_vertex_graph(
        nv: usize,
        block: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, LinalgError> {
        Self::from_vertex_graph_with(nv, block, col_ptr, row_idx, VertexSolver::CholeskyAmd)
    }

    /// As [`SpdPattern::from_vertex_graph`], solved as `solver` says: the
    /// Cholesky factorizations order the vertices (AMD or nested
    /// dissection); the multigrid backend keeps their order and factorizes
    /// nothing (its "factor" is the hierarchy, its solves iterate to
    /// [`MultigridSettings::rel_tol`]).
    ///
    /// # Errors
    /// As [`SpdPattern::from_vertex_graph`]; for the multigrid, those of
    /// its background grid ([`crate::multigrid::point_hierarchy`]) and
    /// [`LinalgError::DimensionMismatch`] for a wrong number of points.
    pub fn from_vertex_graph_with(
        nv: usize,
        block: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        solver: VertexSolver,
    ) -> Result<Self, LinalgError> {
        if block == 0 {
            return Err(LinalgError::BlockSize { block, n: nv });
        }
        let graph = validated_upper(nv, col_ptr, row_idx)?;
        let (vfwd, vinv) = match &solver {
            VertexSolver::CholeskyAmd => scalar_amd(&graph)?,
            VertexSolver::CholeskyNestedDissection => {
                let g = Graph::from_upper(nv, graph.col_ptr(), graph.row_idx())?;
                let fwd = nested_dissection(&g)?;
                let mut inv = vec![0usize; nv];
                for (k, &v) in fwd.iter().enumerate() {
                    inv[v] = k;
                }
                (fwd, inv)
            }
            VertexSolver::Multigrid(_) => ((0..nv).collect(), (0..nv).collect()),
        };
        // The ordered graph: lower triangle with the entry positions, and
        // upper triangle for the symbolic analysis.
        let (ptr, rows) = (graph.col_ptr(), graph.row_idx());
        let (mut lo, mut hi) = (
            Vec::with_capacity(rows.len()),
            Vec::with_capacity(rows.len()),
        );
        let mut flipped = Vec::with_capacity(rows.len());
        for c in 0..nv {
            let fc = vinv[c];
            for &r in &rows[ptr[c]..ptr[c + 1]] {
                let fr = vinv[r];
                hi.push(fr.max(fc));
                lo.push(fr.min(fc));
                flipped.push(fr < fc);
            }
        }
        let (vlower, vslots) = compress(nv, &hi, &lo);
        let n = nv * block;
        let lower = expand_lower(&vlower, block);
        let vptr = vlower.col_ptr();
        let entries = vslots
            .iter()
            .zip(&flipped)
            .map(|(&vs, &flip)| {
                // The ordered column K holding the entry (vs in [vptr[K],
                // vptr[K + 1])) and the entry's position in it.
                let k = vptr.partition_point(|&q| q <= vs) - 1;
                BlockEntry {
                    column: k as u32,
                    position: (vs - vptr[k]) as u32,
                    flipped: flip,
                }
            })
            .collect();
        let mut fwd = vec![0usize; n];
        let mut inv = vec![0usize; n];
        for (k, &v) in vfwd.iter().enumerate() {
            for d in 0..block {
                fwd[block * k + d] = block * v + d;
                inv[block * v + d] = block * k + d;
            }
        }
        let blocks = VertexBlocks { block, entries };
        if let VertexSolver::Multigrid(settings) = solver {
            let plan = MultigridPlan::new(&lower, block, &settings)?;
            let diagonal = (0..n).map(|i| lower.col_ptr()[inv[i]]).collect();
            return Ok(SpdPattern {
                n,
                lower,
                fwd: Arc::new(fwd),
                inv,
                backend: Backend::Multigrid(Arc::new(plan)),
                diagonal,
                input_slots: Vec::new(),
                blocks: Some(blocks),
            });
        }
        let (vupper, _) = compress(nv, &lo, &hi);
        let upper = expand_upper(&vupper, block);
        Self::finish(block, lower, upper, fwd, inv, Vec::new(), Some(blocks))
    }

    /// The value slot of entry `(block a + i, block b + j)` of `A` for the
    /// `e`-th entry `(a, b)` (`a <= b`) of the graph given to
    /// [`SpdPattern::from_vertex_graph`]; `None` for other patterns or out
    /// of range. On a diagonal block `(i, j)` and `(j, i)` share a slot.
    ///
    /// ```text
    /// K, p = ordered column of the entry's block and its position there
    /// diagonal (p = 0):   col = block K + min(i, j), slot = ptr[col] + |i - j|
    /// a after b:          col = block K + j, slot = ptr[col] + (block - j) + block (p - 1) + i
    /// a before b:         the same with i and j swapped
    /// ```
    pub fn block_slot(&self, e: usize, i: usize, j: usize) -> Option<usize> {
        let blocks = self.blocks.as_ref()?;
        let b = blocks.block;
        let entry = blocks.entries.get(e)?;
        if i >= b || j >= b {
            return None;
        }
        let (k, p) = (entry.column as usize, entry.position as usize);
        let ptr = self.lower.col_ptr();
        Some(if p == 0 {
            ptr[b * k + i.min(j)] + i.abs_diff(j)
        } else {
            let (i, j) = if entry.flipped { (j, i) } else { (i, j) };
            ptr[b * k + j] + (b - j) + b * (p - 1) + i
        })
    }

    /// Symbolic analysis of the ordered pattern and the remaining fields.
    fn finish(
        block: usize,
        lower: SymbolicSparseColMat<usize>,
        ordered_upper: SymbolicSparseColMat<usize>,
        fwd: Vec<usize>,
        inv: Vec<usize>,
        input_slots: Vec<usize>,
        blocks: Option<VertexBlocks>,
    ) -> Result<Self, LinalgError> {
        let n = lower.nrows();
        let threshold = if block == 1 {
            SupernodalThreshold::AUTO
        } else {
            SupernodalThreshold::FORCE_SUPERNODAL
        };
        let cholesky = factorize_symbolic_cholesky(
            ordered_upper.as_ref(),
            Side::Upper,
            SymmetricOrdering::Identity,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: threshold,
                ..Default::default()
            },
        )
        .map_err(LinalgError::faer("symbolic Cholesky analysis"))?;
        // Rows are sorted and >= the column, so the diagonal comes first.
        let diagonal = (0..n).map(|i| lower.col_ptr()[inv[i]]).collect();
        let scratch =
            cholesky.factorize_numeric_llt_scratch::<f64>(parallelism(), Default::default());
        Ok(SpdPattern {
            n,
            lower,
            fwd: Arc::new(fwd),
            inv,
            backend: Backend::Cholesky {
                symbolic: Arc::new(cholesky),
                scratch,
            },
            diagonal,
            input_slots,
            blocks,
        })
    }

    /// Matrix size.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries (one triangle, diagonal included): the
    /// length of a value array.
    pub fn nnz(&self) -> usize {
        self.lower.row_idx().len()
    }

    /// Number of stored entries of the Cholesky factor `L` (0 for the
    /// multigrid backend).
    pub fn factor_nnz(&self) -> usize {
        match &self.backend {
            Backend::Cholesky { symbolic, .. } => symbolic.len_val(),
            Backend::Multigrid(_) => 0,
        }
    }

    /// Bytes of the workspace a numeric factorization takes (the dense
    /// update blocks of the supernodal factor; 0 for the multigrid
    /// backend).
    pub fn factor_scratch_bytes(&self) -> usize {
        match &self.backend {
            Backend::Cholesky { scratch, .. } => scratch.unaligned_bytes_required(),
            Backend::Multigrid(_) => 0,
        }
    }

    /// The sizes of the multigrid backend's plan (`None` for a Cholesky
    /// pattern).
    pub fn multigrid_sizes(&self) -> Option<MultigridSizes> {
        match &self.backend {
            Backend::Cholesky { .. } => None,
            Backend::Multigrid(plan) => Some(plan.sizes()),
        }
    }

    /// The value slot of entry `(i, j)` of `A` (either order), if in the
    /// pattern: a binary search in one column of the ordered matrix.
    pub fn slot(&self, i: u32, j: u32) -> Option<usize> {
        let (i, j) = (i as usize, j as usize);
        if i >= self.n || j >= self.n {
            return None;
        }
        let (a, b) = (self.inv[i], self.inv[j]);
        let (r, c) = (a.max(b), a.min(b));
        let (start, end) = (self.lower.col_ptr()[c], self.lower.col_ptr()[c + 1]);
        self.lower.row_idx()[start..end]
            .binary_search(&r)
            .ok()
            .map(|k| start + k)
    }

    /// The value slot of the `e`-th entry of the compressed pattern given
    /// to [`SpdPattern::from_upper_csc`] (`e < nnz`), or of the `e`-th
    /// entry of the upper triangle in column order for the other
    /// constructors.
    pub fn input_slot(&self, e: usize) -> usize {
        self.input_slots[e]
    }

    /// The value slots of the diagonal entries, per unknown.
    pub fn diagonal_slots(&self) -> &[usize] {
        &self.diagonal
    }

    /// `y = A x` for the symmetric matrix with these values.
    pub fn multiply(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        let (col_ptr, row_idx) = (self.lower.col_ptr(), self.lower.row_idx());
        let fwd = &self.fwd;
        for c in 0..self.n {
            let oc = fwd[c];
            for s in col_ptr[c]..col_ptr[c + 1] {
                let (or, v) = (fwd[row_idx[s]], values[s]);
                y[or] += v * x[oc];
                if or != oc {
                    y[oc] += v * x[or];
                }
            }
        }
        y
    }

    /// Numeric Cholesky factorization of the matrix with these values.
    /// When it fails (not positive definite), retries with the diagonal
    /// shifted by `shift * max|diag|`, multiplying the shift by 10 up to
    /// `max_tries` times (ALGORITHMS 1.5). Returns the factor and the
    /// shift used (0 when none).
    pub fn factorize(
        &self,
        values: &[f64],
        shift: f64,
        max_tries: usize,
    ) -> Result<(SpdFactor, f64), LinalgError> {
        let mut factor = self.new_factor();
        let used = self.refactorize(&mut factor, values, shift, max_tries)?;
        Ok((factor, used))
    }

    /// Storage for a factor of this pattern, not yet factorized (solving
    /// with it is an error until [`SpdPattern::refactorize`] succeeds).
    pub fn new_factor(&self) -> SpdFactor {
        let numeric = match &self.backend {
            Backend::Cholesky { symbolic, .. } => Numeric::Cholesky {
                symbolic: Arc::clone(symbolic),
                values: vec![0.0; symbolic.len_val()],
                scratch: Vec::new(),
            },
            Backend::Multigrid(plan) => Numeric::Multigrid {
                plan: Arc::clone(plan),
                hierarchy: None,
            },
        };
        SpdFactor {
            n: self.n,
            fwd: Arc::clone(&self.fwd),
            numeric,
            factored: false,
        }
    }

    /// As [`SpdPattern::factorize`], into an existing factor of this
    /// pattern (its storage is reused). Returns the shift used; after an
    /// error the factor is unusable until a later call succeeds.
    pub fn refactorize(
        &self,
        factor: &mut SpdFactor,
        values: &[f64],
        shift: f64,
        max_tries: usize,
    ) -> Result<f64, LinalgError> {
        self.refactorize_from(factor, values, false, shift, max_tries)
    }

    /// As [`SpdPattern::refactorize`], but the first attempt is already
    /// shifted by `shift * max|diag|` (then `10 shift`, `100 shift`, ...,
    /// `max_tries` more times). For a positive semidefinite matrix that is
    /// singular (a motion the problem does not see), where the unshifted
    /// attempt fails after most of a factorization's work, this saves that
    /// attempt; the shift is far below the scale of the matrix. Returns the
    /// shift used.
    ///
    /// # Errors
    /// As [`SpdPattern::refactorize`].
    pub fn refactorize_shifted(
        &self,
        factor: &mut SpdFactor,
        values: &[f64],
        shift: f64,
        max_tries: usize,
    ) -> Result<f64, LinalgError> {
        self.refactorize_from(factor, values, true, shift, max_tries)
    }

    /// The shift loop of [`SpdPattern::refactorize`] and
    /// [`SpdPattern::refactorize_shifted`].
    fn refactorize_from(
        &self,
        factor: &mut SpdFactor,
        values: &[f64],
        shifted_first: bool,
        shift: f64,
        max_tries: usize,
    ) -> Result<f64, LinalgError> {
        let same = match (&self.backend, &factor.numeric) {
            (Backend::Cholesky { symbolic, .. }, Numeric::Cholesky { symbolic: f, .. }) => {
                Arc::ptr_eq(symbolic, f)
            }
            (Backend::Multigrid(plan), Numeric::Multigrid { plan: f, .. }) => Arc::ptr_eq(plan, f),
            _ => false,
        };
        if !same {
            return Err(LinalgError::ForeignFactor);
        }
        if values.len() != self.nnz() {
            return Err(LinalgError::DimensionMismatch {
                what: "sparse values",
                expected: self.nnz(),
                found: values.len(),
            });
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "sparse matrix value",
                index,
            });
        }
        let scale = self
            .diagonal
            .iter()
            .map(|&s| values[s].abs())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        factor.factored = false;
        let mut used = 0.0;
        let mut delta = shift;
        if shifted_first {
            used = delta * scale;
            delta *= 10.0;
        }
        let mut shifted = Vec::new();
        let mut attempt = 0;
        loop {
            if self.try_factorize(factor, values, used, &mut shifted)? {
                factor.factored = true;
                return Ok(used);
            }
            if attempt == max_tries {
                return Err(LinalgError::NotPositiveDefinite {
                    size: self.n,
                    last_shift: used,
                });
            }
            used = delta * scale;
            delta *= 10.0;
            attempt += 1;
        }
    }

    /// One factorization of the values with `used` added to the diagonal
    /// (`shifted` is the buffer of the shifted copy): whether it succeeded
    /// (false: not positive definite).
    fn try_factorize(
        &self,
        factor: &mut SpdFactor,
        values: &[f64],
        used: f64,
        shifted: &mut Vec<f64>,
    ) -> Result<bool, LinalgError> {
        match (&self.backend, &mut factor.numeric) {
            (
                Backend::Cholesky { symbolic, scratch },
                Numeric::Cholesky {
                    values: l,
                    scratch: work,
                    ..
                },
            ) => {
                let bytes = scratch.unaligned_bytes_required();
                if work.len() < bytes {
                    *work = vec![MaybeUninit::uninit(); bytes];
                }
                let current = if used == 0.0 {
                    values
                } else {
                    shifted.clear();
                    shifted.extend_from_slice(values);
                    for &s in &self.diagonal {
                        shifted[s] += used;
                    }
                    &shifted[..]
                };
                let mat = SparseColMatRef::new(self.lower.as_ref(), current);
                let result = symbolic.factorize_numeric_llt(
                    l,
                    mat,
                    Side::Lower,
                    LltRegularization::default(),
                    parallelism(),
                    MemStack::new(work),
                    Default::default(),
                );
                // (faer's only numeric failure: a pivot that is not positive)
                Ok(result.is_ok())
            }
            (Backend::Multigrid(plan), Numeric::Multigrid { hierarchy, .. }) => {
                *hierarchy = None;
                match plan.setup(values, used) {
                    Ok(mg) => {
                        *hierarchy = Some(mg);
                        Ok(true)
                    }
                    Err(
                        LinalgError::NonPositiveDiagonal { .. }
                        | LinalgError::NegativePivot { .. }
                        | LinalgError::NullDirection { .. },
                    ) => Ok(false),
                    Err(e) => Err(e),
                }
            }
            _ => Err(LinalgError::ForeignFactor),
        }
    }
}

/// faer's global parallelism (rayon unless changed): the supernodal
/// kernels split large dense blocks across threads and run small ones
/// inline.
fn parallelism() -> Par {
    faer::get_global_parallelism()
}

/// Compressed columns of the entries `(rows[e], cols[e])` (each once) with
/// the rows of every column sorted, and the position of each entry: two
/// stable counting sorts, by row and then by column.
fn compress(n: usize, rows: &[usize], cols: &[usize]) -> (SymbolicSparseColMat<usize>, Vec<usize>) {
    let m = rows.len();
    // Entries by row.
    let mut row_ptr = vec![0usize; n + 1];
    for &r in rows {
        row_ptr[r + 1] += 1;
    }
    for k in 0..n {
        row_ptr[k + 1] += row_ptr[k];
    }
    let mut by_row = vec![0usize; m];
    for (e, &r) in rows.iter().enumerate() {
        by_row[row_ptr[r]] = e;
        row_ptr[r] += 1;
    }
    // Stably by column.
    let mut col_ptr = vec![0usize; n + 1];
    for &c in cols {
        col_ptr[c + 1] += 1;
    }
    for k in 0..n {
        col_ptr[k + 1] += col_ptr[k];
    }
    let mut next = col_ptr.clone();
    let mut slot = vec![0usize; m];
    let mut row_idx = vec![0usize; m];
    for &e in &by_row {
        let c = cols[e];
        let s = next[c];
        next[c] += 1;
        slot[e] = s;
        row_idx[s] = rows[e];
    }
    (
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
        slot,
    )
}

/// AMD on the pattern of `A + A^T` (given its upper triangle): the forward
/// and inverse permutations.
fn scalar_amd(
    upper: &SymbolicSparseColMat<usize>,
) -> Result<(Vec<usize>, Vec<usize>), LinalgError> {
    let n = upper.nrows();
    let mut fwd = vec![0usize; n];
    let mut inv = vec![0usize; n];
    let mut scratch = vec![
        MaybeUninit::uninit();
        amd::order_scratch::<usize>(n, upper.row_idx().len())
            .unaligned_bytes_required()
    ];
    amd::order(
        &mut fwd,
        &mut inv,
        upper.as_ref(),
        amd::Control::default(),
        MemStack::new(&mut scratch),
    )
    .map_err(LinalgError::faer("AMD ordering"))?;
    Ok((fwd, inv))
}

/// AMD on the vertex graph of a pattern with `block` unknowns per vertex,
/// expanded to the unknowns (each vertex's unknowns consecutive, in their
/// order): the forward and inverse permutations.
fn block_amd(
    upper: &SymbolicSparseColMat<usize>,
    block: usize,
) -> Result<(Vec<usize>, Vec<usize>), LinalgError> {
    let n = upper.nrows();
    let nb = n / block;
    let mut cols: Vec<Vec<usize>> = vec![Vec::new(); nb];
    let (col_ptr, row_idx) = (upper.col_ptr(), upper.row_idx());
    for c in 0..n {
        for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
            // The upper triangle of the vertex graph (AMD orders by the
            // pattern of `A + A^T`).
            let (a, b) = (r / block, c / block);
            cols[a.max(b)].push(a.min(b));
        }
    }
    let mut bptr = Vec::with_capacity(nb + 1);
    let mut bidx = Vec::new();
    bptr.push(0usize);
    for (b, rows) in cols.iter_mut().enumerate() {
        rows.push(b);
        rows.sort_unstable();
        rows.dedup();
        bidx.extend_from_slice(rows);
        bptr.push(bidx.len());
    }
    let graph = SymbolicSparseColMat::new_checked(nb, nb, bptr, None, bidx);
    let (fwd_b, _) = scalar_amd(&graph)?;
    let mut fwd = vec![0usize; n];
    let mut inv = vec![0usize; n];
    for (k, &v) in fwd_b.iter().enumerate() {
        for d in 0..block {
            fwd[block * k + d] = block * v + d;
            inv[block * v + d] = block * k + d;
        }
    }
    Ok((fwd, inv))
}

/// Where each graph entry of a [`SpdPattern::from_vertex_graph`] pattern
/// went: its block's ordered column and position in the ordered graph, and
/// whether its row vertex comes before its column vertex in the ordering
/// (so that the block lands transposed in the lower triangle).
#[derive(Debug, Clone)]
struct VertexBlocks {
    block: usize,
    entries: Vec<BlockEntry>,
}

#[derive(Debug, Clone, Copy)]
struct BlockEntry {
    column: u32,
    position: u32,
    flipped: bool,
}

/// The checks of [`SpdPattern::from_upper_csc`] on a compressed upper
/// triangle: pointer lengths, strictly increasing rows, each column ending
/// with its diagonal.
fn validated_upper(
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
) -> Result<SymbolicSparseColMat<usize>, LinalgError> {
    if col_ptr.len() != n + 1 {
        return Err(LinalgError::DimensionMismatch {
            what: "sparse pattern: column pointers (columns + 1)",
            expected: n + 1,
            found: col_ptr.len(),
        });
    }
    for at in [0, n] {
        let want = if at == 0 { 0 } else { row_idx.len() };
        if col_ptr[at] != want {
            return Err(LinalgError::BadPointers {
                what: "sparse pattern: column pointers",
                at,
                value: col_ptr[at],
                entries: row_idx.len(),
            });
        }
    }
    for c in 0..n {
        let (start, end) = (col_ptr[c], col_ptr[c + 1]);
        if start >= end || end > row_idx.len() || row_idx[end - 1] != c {
            return Err(LinalgError::MissingDiagonal { column: c });
        }
        if row_idx[start..end].windows(2).any(|w| w[0] >= w[1]) {
            return Err(LinalgError::UnsortedIndices {
                what: "rows of column",
                line: c,
            });
        }
    }
    Ok(SymbolicSparseColMat::new_checked(
        n, n, col_ptr, None, row_idx,
    ))
}

/// The lower triangle of a block matrix from the lower triangle of its
/// vertex graph (rows sorted, diagonal first): unknown column `b K + j`
/// holds the rows `b K + j .. b K + b` of the diagonal block, then all `b`
/// rows of each lower vertex `R` of column `K`.
fn expand_lower(g: &SymbolicSparseColMat<usize>, b: usize) -> SymbolicSparseColMat<usize> {
    let nv = g.nrows();
    let (ptr, rows) = (g.col_ptr(), g.row_idx());
    let mut col_ptr = Vec::with_capacity(nv * b + 1);
    let mut row_idx = Vec::with_capacity(rows.len() * b * b);
    col_ptr.push(0);
    for k in 0..nv {
        for j in 0..b {
            row_idx.extend(b * k + j..b * k + b);
            for &r in &rows[ptr[k] + 1..ptr[k + 1]] {
                row_idx.extend(b * r..b * r + b);
            }
            col_ptr.push(row_idx.len());
        }
    }
    SymbolicSparseColMat::new_checked(nv * b, nv * b, col_ptr, None, row_idx)
}

/// The upper triangle of a block matrix from the upper triangle of its
/// vertex graph (rows sorted, diagonal last): unknown column `b K + j`
/// holds all `b` rows of each upper vertex `R` of column `K`, then the rows
/// `b K .. b K + j` of the diagonal block.
fn expand_upper(g: &SymbolicSparseColMat<usize>, b: usize) -> SymbolicSparseColMat<usize> {
    let nv = g.nrows();
    let (ptr, rows) = (g.col_ptr(), g.row_idx());
    let mut col_ptr = Vec::with_capacity(nv * b + 1);
    let mut row_idx = Vec::with_capacity(rows.len() * b * b);
    col_ptr.push(0);
    for k in 0..nv {
        for j in 0..b {
            for &r in &rows[ptr[k]..ptr[k + 1] - 1] {
                row_idx.extend(b * r..b * r + b);
            }
            row_idx.extend(b * k..=b * k + j);
            col_ptr.push(row_idx.len());
        }
    }
    SymbolicSparseColMat::new_checked(nv * b, nv * b, col_ptr, None, row_idx)
}

/// A numeric Cholesky factor `P A P^T = L L^T`, or for the multigrid
/// backend the hierarchy of `A` (its solves iterate).
#[derive(Debug, Clone)]
pub struct SpdFactor {
    n: usize,
    fwd: Arc<Vec<usize>>,
    numeric: Numeric,
    /// Whether the numeric part holds a successful factorization.
    factored: bool,
}

#[derive(Debug, Clone)]
enum Numeric {
    Cholesky {
        symbolic: Arc<SymbolicCholesky<usize>>,
        values: Vec<f64>,
        /// Workspace of [`SpdPattern::refactorize`].
        scratch: Vec<MaybeUninit<u8>>,
    },
    Multigrid {
        plan: Arc<MultigridPlan>,
        hierarchy: Option<Multigrid>,
    },
}

impl SpdFactor {
    /// Solves `A x = b` in place (`b` has length `n`): two triangular
    /// solves with the Cholesky factor, or conjugate gradients to the
    /// multigrid settings' relative residual.
    ///
    /// # Errors
    /// [`LinalgError::DimensionMismatch`] for a wrong length;
    /// [`LinalgError::NotFactorized`] when the factorization failed or
    /// never ran; for the multigrid backend, [`LinalgError::NoConvergence`]
    /// and [`LinalgError::Breakdown`] (the matrix is not positive
    /// definite).
    pub fn solve_in_place(&self, b: &mut [f64]) -> Result<(), LinalgError> {
        self.solve_reporting(b).map(|_| ())
    }

    /// As [`SpdFactor::solve_in_place`], with the multigrid solve's report
    /// (iterations, relative residual; `None` for a Cholesky factor).
    ///
    /// # Errors
    /// As [`SpdFactor::solve_in_place`].
    pub fn solve_reporting(&self, b: &mut [f64]) -> Result<Option<PcgReport>, LinalgError> {
        if b.len() != self.n {
            return Err(LinalgError::DimensionMismatch {
                what: "right-hand side",
                expected: self.n,
                found: b.len(),
            });
        }
        if !self.factored {
            return Err(LinalgError::NotFactorized);
        }
        match &self.numeric {
            Numeric::Cholesky {
                symbolic, values, ..
            } => {
                let par = parallelism();
                let mut y: Vec<f64> = self.fwd.iter().map(|&i| b[i]).collect();
                let mut scratch = vec![
                    MaybeUninit::uninit();
                    symbolic
                        .solve_in_place_scratch::<f64>(1, par)
                        .unaligned_bytes_required()
                ];
                LltRef::new(symbolic, values).solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(&mut y, self.n, 1),
                    par,
                    MemStack::new(&mut scratch),
                );
                for (&i, yi) in self.fwd.iter().zip(&y) {
                    b[i] = *yi;
                }
                Ok(None)
            }
            Numeric::Multigrid { plan, hierarchy } => {
                let mg = hierarchy.as_ref().ok_or(LinalgError::NotFactorized)?;
                plan.solve(mg, b).map(Some)
            }
        }
    }
}

/// Solves the SPD system given as triplets `(i, j, value)` (entries of both
/// triangles may be given; each upper-triangle position sums the values
/// given for it and its mirror only once, so give each off-diagonal entry
/// once) for the right-hand side `b`. A one-shot convenience over
/// [`SpdPattern`].
pub fn solve_spd(
    n: usize,
    triplets: &[(u32, u32, f64)],
    b: &[f64],
) -> Result<Vec<f64>, LinalgError> {
    let pattern = SpdPattern::new(n, triplets.iter().map(|&(i, j, _)| (i, j)))?;
    let mut values = vec![0.0; pattern.nnz()];
    for &(i, j, v) in triplets {
        if let Some(s) = pattern.slot(i, j) {
            values[s] += v;
        }
    }
    let (factor, _) = pattern.factorize(&values, 0.0, 0)?;
    let mut x = b.to_vec();
    factor.solve_in_place(&mut x)?;
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The 1D Laplacian plus identity: tridiagonal SPD.
    fn tridiagonal(n: usize) -> Vec<(u32, u32, f64)> {
        let mut t = Vec::new();
        for i in 0..n as u32 {
            t.push((i, i, 3.0));
            if i + 1 < n as u32 {
                t.push((i, i + 1, -1.0));
            }
        }
        t
    }

    fn multiply(n: usize, t: &[(u32, u32, f64)], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; n];
        for &(i, j, v) in t {
            y[i as usize] += v * x[j as usize];
            if i != j {
                y[j as usize] += v * x[i as usize];
            }
        }
        y
    }

    proptest! {
        #[test]
        fn solves_spd_systems(n in 1usize..60, b in prop::collection::vec(-10.0..10.0f64, 60)) {
            let t = tridiagonal(n);
            let x = solve_spd(n, &t, &b[..n]).unwrap();
            let r = multiply(n, &t, &x);
            for i in 0..n {
                prop_assert!((r[i] - b[i]).abs() < 1e-10);
            }
        }
    }

    proptest! {
        /// A singular positive semidefinite matrix (a path graph's Laplacian,
        /// constants in its null space): the unshifted attempt fails, the
        /// shifted-first one succeeds on its first try, with exactly
        /// `shift * max|diag|`, and its solution solves the shifted system.
        #[test]
        fn a_singular_laplacian_factorizes_shifted_first(
            n in 2usize..40,
            weights in prop::collection::vec(0.5..2.0f64, 40),
            b in prop::collection::vec(-1.0..1.0f64, 40),
        ) {
            let mut t = Vec::new();
            let mut diag = vec![0.0; n];
            for i in 0..n - 1 {
                let w = weights[i];
                t.push((i as u32, i as u32 + 1, -w));
                diag[i] += w;
                diag[i + 1] += w;
            }
            for (i, &d) in diag.iter().enumerate() {
                t.push((i as u32, i as u32, d));
            }
            let p = SpdPattern::new(n, t.iter().map(|&(i, j, _)| (i, j))).unwrap();
            let mut v = vec![0.0; p.nnz()];
            for &(i, j, x) in &t {
                v[p.slot(i, j).unwrap()] += x;
            }
            let mut f = p.new_factor();
            // Roundoff may let the last pivot through as a tiny positive
            // number; it must never be a usable solve of the singular system.
            if p.refactorize(&mut f, &v, 1e-8, 0).is_ok() {
                let mut x = b[..n].to_vec();
                f.solve_in_place(&mut x).unwrap();
                let big = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                prop_assert!(big > 1e6, "{big}");
            }
            let scale = diag.iter().fold(0.0f64, |m, &d| m.max(d));
            let used = p.refactorize_shifted(&mut f, &v, 1e-8, 4).unwrap();
            prop_assert_eq!(used, 1e-8 * scale);
            let mut x = b[..n].to_vec();
            f.solve_in_place(&mut x).unwrap();
            let mut shifted = multiply(n, &t, &x);
            for (s, xi) in shifted.iter_mut().zip(&x) {
                *s += used * xi;
            }
            for (s, bi) in shifted.iter().zip(&b[..n]) {
                prop_assert!((s - bi).abs() < 1e-6 * (1.0 + bi.abs()), "{s} vs {bi}");
            }
        }
    }

    #[test]
    fn refactorizes_with_new_values_and_shifts_indefinite_ones() {
        let n = 5;
        let t = tridiagonal(n);
        let p = SpdPattern::new(n, t.iter().map(|&(i, j, _)| (j, i))).unwrap();
        let mut v = vec![0.0; p.nnz()];
        for &(i, j, x) in &t {
            v[p.slot(i, j).unwrap()] += x;
        }
        let (f, shift) = p.factorize(&v, 1e-8, 8).unwrap();
        assert_eq!(shift, 0.0);
        let ones = vec![1.0; n];
        assert_eq!(p.multiply(&v, &ones), multiply(n, &t, &ones));
        let mut b = vec![1.0; n];
        f.solve_in_place(&mut b).unwrap();
        assert!((multiply(n, &t, &b)[2] - 1.0).abs() < 1e-12);
        // An indefinite matrix needs a diagonal shift.
        for &s in p.diagonal_slots() {
            v[s] = -1.0;
        }
        let (_, shift) = p.factorize(&v, 1e-8, 12).unwrap();
        assert!(shift > 0.0);
        assert!(matches!(
            p.factorize(&v, 1e-8, 0),
            Err(LinalgError::NotPositiveDefinite { size: 5, .. })
        ));
        // Three tries: the last shift is 1e-6 max|diag|.
        match p.factorize(&v, 1e-8, 2) {
            Err(LinalgError::NotPositiveDefinite {
                size: 5,
                last_shift,
            }) => {
                assert_eq!(last_shift, 1e-8 * 10.0)
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            p.factorize(&v[1..], 1e-8, 0),
            Err(LinalgError::DimensionMismatch {
                expected: 9,
                found: 8,
                ..
            })
        ));
        let mut nan = v.clone();
        nan[4] = f64::NAN;
        assert!(matches!(
            p.factorize(&nan, 1e-8, 0),
            Err(LinalgError::NotFinite { index: 4, .. })
        ));
        assert_eq!(
            SpdPattern::new(2, [(0, 1), (0, 5)]).unwrap_err(),
            LinalgError::EntryOutOfRange {
                entry: 1,
                row: 0,
                col: 5,
                n_rows: 2,
                n_cols: 2
            }
        );
    }

    /// A 2D grid Laplacian with 2 unknowns per vertex (both coupled),
    /// plus the identity: SPD, and as the Hessians of 2D maps are.
    fn grid_blocks(w: usize, h: usize) -> (usize, Vec<(u32, u32, f64)>) {
        let nv = w * h;
        let mut t = Vec::new();
        let id = |x: usize, y: usize| (y * w + x) as u32;
        for y in 0..h {
            for x in 0..w {
                let v = id(x, y);
                let mut deg = 0.0;
                for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                    if nx < w && ny < h {
                        let u = id(nx, ny);
                        for (i, j) in [(0, 0), (1, 1), (0, 1), (1, 0)] {
                            let c = if i == j { -1.0 } else { 0.1 };
                            t.push((2 * v + i, 2 * u + j, c));
                        }
                    }
                    deg += 1.0;
                }
                t.push((2 * v, 2 * v, 5.0 + deg));
                t.push((2 * v + 1, 2 * v + 1, 5.0 + deg));
                t.push((2 * v, 2 * v + 1, 0.5));
            }
        }
        (2 * nv, t)
    }

    /// A random vertex graph's upper triangle in compressed columns (each
    /// column ending with its diagonal).
    fn random_graph(nv: usize, edges: &[(usize, usize)]) -> (Vec<usize>, Vec<usize>) {
        let mut cols: Vec<Vec<usize>> = (0..nv).map(|b| vec![b]).collect();
        for &(a, b) in edges {
            let (a, b) = (a % nv, b % nv);
            cols[a.max(b)].push(a.min(b));
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        (col_ptr, row_idx)
    }

    proptest! {
        /// A vertex-graph pattern is the block-expanded scalar pattern:
        /// `block_slot` is `slot` of the expanded entry, the matrices agree
        /// (products with a random vector) and its factorization solves.
        #[test]
        fn vertex_graph_pattern_is_the_expanded_pattern(
            nv in 1usize..40,
            block in 1usize..4,
            edges in prop::collection::vec((0usize..40, 0usize..40), 0..120),
            vals in prop::collection::vec(-1.0..1.0f64, 64),
            x in prop::collection::vec(-3.0..3.0f64, 120),
        ) {
            let (col_ptr, row_idx) = random_graph(nv, &edges);
            let n = nv * block;
            let p = SpdPattern::from_vertex_graph(nv, block, col_ptr.clone(), row_idx.clone()).unwrap();
            prop_assert_eq!(p.n(), n);
            // The scalar reference: every block expanded, diagonally dominant.
            let mut t = Vec::new();
            let mut k = 0;
            for b in 0..nv {
                for (e, &a) in row_idx.iter().enumerate().take(col_ptr[b + 1]).skip(col_ptr[b]) {
                    for i in 0..block {
                        for j in 0..block {
                            if a == b && i > j {
                                continue;
                            }
                            let (r, c) = ((block * a + i) as u32, (block * b + j) as u32);
                            let v = if r == c { 2.0 * block as f64 * 40.0 } else { vals[k % vals.len()] };
                            k += 1;
                            t.push((e, i, j, r, c, v));
                        }
                    }
                }
            }
            let scalar = SpdPattern::new(n, t.iter().map(|q| (q.3, q.4))).unwrap();
            prop_assert_eq!(p.nnz(), scalar.nnz());
            let (mut vp, mut vs) = (vec![0.0; p.nnz()], vec![0.0; scalar.nnz()]);
            for &(e, i, j, r, c, v) in &t {
                let slot = p.block_slot(e, i, j).unwrap();
                prop_assert_eq!(Some(slot), p.slot(r, c));
                vp[slot] += v;
                vs[scalar.slot(r, c).unwrap()] += v;
            }
            prop_assert_eq!(p.block_slot(e_end(&col_ptr), 0, 0), None);
            prop_assert_eq!(p.block_slot(0, block, 0), None);
            let x = &x[..n];
            let (yp, ys) = (p.multiply(&vp, x), scalar.multiply(&vs, x));
            for i in 0..n {
                prop_assert!((yp[i] - ys[i]).abs() <= 1e-12 * (1.0 + ys[i].abs()));
            }
            let (f, shift) = p.factorize(&vp, 0.0, 0).unwrap();
            prop_assert_eq!(shift, 0.0);
            let mut z = ys.clone();
            f.solve_in_place(&mut z).unwrap();
            for i in 0..n {
                prop_assert!((z[i] - x[i]).abs() < 1e-9, "{} vs {}", z[i], x[i]);
            }
        }
    }

    fn e_end(col_ptr: &[usize]) -> usize {
        col_ptr[col_ptr.len() - 1]
    }

    #[test]
    fn vertex_graph_patterns_refuse_malformed_graphs() {
        let bad = |nv: usize, block: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>| {
            match SpdPattern::from_vertex_graph(nv, block, col_ptr, row_idx) {
                Err(e) => e,
                Ok(p) => panic!("expected an error, got {p:?}"),
            }
        };
        assert_eq!(
            bad(2, 0, vec![0, 1, 3], vec![0, 0, 1]),
            LinalgError::BlockSize { block: 0, n: 2 }
        );
        assert!(matches!(
            bad(2, 2, vec![0, 1], vec![0]),
            LinalgError::DimensionMismatch {
                expected: 3,
                found: 2,
                ..
            }
        ));
        assert_eq!(
            bad(2, 2, vec![0, 1, 2], vec![0, 0]),
            LinalgError::MissingDiagonal { column: 1 }
        );
        assert!(
            bad(2, 2, vec![0, 1, 2], vec![0, 0])
                .to_string()
                .contains("column 1 of the upper-triangle pattern does not end with its diagonal")
        );
        assert_eq!(
            bad(3, 1, vec![0, 1, 2, 5], vec![0, 1, 1, 0, 2]),
            LinalgError::UnsortedIndices {
                what: "rows of column",
                line: 2
            }
        );
        // Scalar patterns have no block slots.
        let p = SpdPattern::new(2, [(0, 1)]).unwrap();
        assert_eq!(p.block_slot(0, 0, 0), None);
    }

    proptest! {
        /// The block-ordered supernodal factorization solves the same
        /// systems as the AMD one: `A x = b` to 1e-10.
        #[test]
        fn block_ordering_solves_like_amd(
            w in 1usize..14,
            h in 1usize..14,
            b in prop::collection::vec(-10.0..10.0f64, 2 * 14 * 14),
        ) {
            let (n, t) = grid_blocks(w, h);
            let b = &b[..n];
            let entries = || t.iter().map(|&(i, j, _)| (i, j));
            let plain = SpdPattern::new(n, entries()).unwrap();
            let blocked = SpdPattern::with_blocks(n, 2, entries()).unwrap();
            prop_assert_eq!(plain.nnz(), blocked.nnz());
            for p in [&plain, &blocked] {
                let mut vals = vec![0.0; p.nnz()];
                for &(i, j, v) in &t {
                    vals[p.slot(i, j).unwrap()] += v;
                }
                let (f, shift) = p.factorize(&vals, 0.0, 0).unwrap();
                prop_assert_eq!(shift, 0.0);
                let mut x = b.to_vec();
                f.solve_in_place(&mut x).unwrap();
                let r = p.multiply(&vals, &x);
                for i in 0..n {
                    prop_assert!((r[i] - b[i]).abs() < 1e-10, "{} vs {}", r[i], b[i]);
                }
            }
        }
    }

    #[test]
    fn a_malformed_compressed_pattern_is_refused() {
        // 2 x 2: column 0 = {0}, column 1 = {0, 1}.
        assert!(SpdPattern::from_upper_csc(2, 1, vec![0, 1, 3], vec![0, 0, 1]).is_ok());
        assert!(SpdPattern::from_upper_csc(2, 2, vec![0, 1, 3], vec![0, 0, 1]).is_ok());
        let pointers = |at, value, entries| LinalgError::BadPointers {
            what: "sparse pattern: column pointers",
            at,
            value,
            entries,
        };
        for (block, ptr, rows, want) in [
            (
                3,
                vec![0, 1, 3],
                vec![0, 0, 1],
                LinalgError::BlockSize { block: 3, n: 2 },
            ),
            (
                0,
                vec![0, 1, 3],
                vec![0, 0, 1],
                LinalgError::BlockSize { block: 0, n: 2 },
            ),
            (
                1,
                vec![0, 1],
                vec![0],
                LinalgError::DimensionMismatch {
                    what: "sparse pattern: column pointers (columns + 1)",
                    expected: 3,
                    found: 2,
                },
            ),
            (1, vec![0, 1, 4], vec![0, 0, 1], pointers(2, 4, 3)),
            (1, vec![1, 1, 3], vec![0, 0, 1], pointers(0, 1, 3)),
            (
                1,
                vec![0, 1, 3],
                vec![0, 1, 0],
                LinalgError::MissingDiagonal { column: 1 },
            ),
            (
                1,
                vec![0, 0, 2],
                vec![0, 1],
                LinalgError::MissingDiagonal { column: 0 },
            ),
            (
                1,
                vec![0, 1, 4],
                vec![0, 1, 0, 1],
                LinalgError::UnsortedIndices {
                    what: "rows of column",
                    line: 1,
                },
            ),
        ] {
            let e = SpdPattern::from_upper_csc(2, block, ptr, rows).unwrap_err();
            assert_eq!(e, want);
        }
        assert_eq!(
            SpdPattern::with_blocks(3, 2, [(0, 1)]).unwrap_err(),
            LinalgError::BlockSize { block: 2, n: 3 }
        );
    }

    #[test]
    fn a_factor_is_refactorized_in_place_and_only_by_its_pattern() {
        let (n, t) = grid_blocks(5, 4);
        let p = SpdPattern::with_blocks(n, 2, t.iter().map(|&(i, j, _)| (i, j))).unwrap();
        let other = SpdPattern::with_blocks(n, 2, t.iter().map(|&(i, j, _)| (i, j))).unwrap();
        let mut vals = vec![0.0; p.nnz()];
        for &(i, j, v) in &t {
            vals[p.slot(i, j).unwrap()] += v;
        }
        let mut f = p.new_factor();
        let mut b = vec![1.0; n];
        // Not factorized yet: a solve is an error, not garbage.
        assert_eq!(f.solve_in_place(&mut b), Err(LinalgError::NotFactorized));
        assert_eq!(p.refactorize(&mut f, &vals, 0.0, 0).unwrap(), 0.0);
        f.solve_in_place(&mut b).unwrap();
        let (g, _) = p.factorize(&vals, 0.0, 0).unwrap();
        let mut c = vec![1.0; n];
        g.solve_in_place(&mut c).unwrap();
        assert_eq!(b, c);
        // Scaled values, same storage: the solution scales back.
        let doubled: Vec<f64> = vals.iter().map(|v| 2.0 * v).collect();
        p.refactorize(&mut f, &doubled, 0.0, 0).unwrap();
        let mut d = vec![2.0; n];
        f.solve_in_place(&mut d).unwrap();
        for (x, y) in d.iter().zip(&c) {
            assert!((x - y).abs() < 1e-12);
        }
        // A failed factorization leaves the factor unusable.
        let mut bad = vals.clone();
        for &s in p.diagonal_slots() {
            bad[s] = -1.0;
        }
        assert_eq!(
            p.refactorize(&mut f, &bad, 0.0, 0),
            Err(LinalgError::NotPositiveDefinite {
                size: n,
                last_shift: 0.0
            })
        );
        assert_eq!(f.solve_in_place(&mut d), Err(LinalgError::NotFactorized));
        // Another pattern's factor is refused.
        let e = other.refactorize(&mut f, &vals, 0.0, 0).unwrap_err();
        assert_eq!(e, LinalgError::ForeignFactor);
        assert!(e.to_string().contains("another pattern"), "{e}");
    }
}
