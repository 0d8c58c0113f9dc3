//! The error type of unfold-linalg.

use faer::sparse::FaerError;
use thiserror::Error;

/// Everything that can go wrong building a matrix or solving with it. Each
/// variant holds the indices and numbers that explain the failure.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum LinalgError {
    // ---- shapes and indices ------------------------------------------------
    /// An array or matrix does not have the size the others require.
    #[error("{what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Which array or dimension.
        what: &'static str,
        /// The size required.
        expected: usize,
        /// The size given.
        found: usize,
    },
    /// An index is not below the length it indexes.
    #[error("{what} {index} is out of range (length {len})")]
    IndexOutOfRange {
        /// What the index is (a fixed vertex, a neighbour, a column, ...).
        what: &'static str,
        /// The index.
        index: usize,
        /// The length it must stay below.
        len: usize,
    },
    /// A matrix entry lies outside the matrix.
    #[error("entry {entry} at ({row}, {col}) lies outside a {n_rows} x {n_cols} matrix")]
    EntryOutOfRange {
        /// Position of the entry in the input.
        entry: usize,
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
        /// Rows of the matrix.
        n_rows: usize,
        /// Columns of the matrix.
        n_cols: usize,
    },
    /// An index is listed twice where each may appear once.
    #[error("{what} {index} is listed twice")]
    DuplicateIndex {
        /// What the index is.
        what: &'static str,
        /// The index.
        index: usize,
    },
    /// A matrix dimension exceeds the `u32` indices of the storage.
    #[error("a {rows} x {cols} matrix is too large: dimensions are limited to u32::MAX")]
    TooLarge {
        /// Rows asked for.
        rows: usize,
        /// Columns asked for.
        cols: usize,
    },
    /// Compressed-storage pointers that do not rise from 0 to the number
    /// of entries.
    #[error(
        "{what}: pointer {at} is {value}, but the pointers must rise from 0 to the entry count \
         {entries}"
    )]
    BadPointers {
        /// Which pointer array.
        what: &'static str,
        /// Position of the first bad pointer.
        at: usize,
        /// Its value.
        value: usize,
        /// Number of entries stored.
        entries: usize,
    },
    /// The indices of one row (or column) are not strictly increasing.
    #[error("the {what} {line} are not strictly increasing")]
    UnsortedIndices {
        /// "columns of row" or "rows of column".
        what: &'static str,
        /// The row (or column).
        line: usize,
    },
    /// A column of an upper-triangle pattern does not end with its
    /// diagonal entry.
    #[error("column {column} of the upper-triangle pattern does not end with its diagonal")]
    MissingDiagonal {
        /// The column.
        column: usize,
    },
    /// The block size of a blocked pattern does not divide the matrix size.
    #[error("block size {block} does not divide the matrix size {n}")]
    BlockSize {
        /// The block size.
        block: usize,
        /// The matrix size.
        n: usize,
    },
    /// An entry of the matrix has no slot in the sparsity pattern it is
    /// assembled into.
    #[error("entry ({row}, {col}) is not in the sparsity pattern")]
    EntryNotInPattern {
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
    },

    // ---- matrix properties -------------------------------------------------
    /// A square matrix is required.
    #[error("the matrix must be square, it is {rows} x {cols}")]
    NotSquare {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
    },
    /// A symmetric matrix is required: `|a_ij - a_ji| > 1e-12 max |a|`.
    #[error(
        "the matrix is not symmetric: a[{row}][{col}] = {value:e} but a[{col}][{row}] = {mirror:e}"
    )]
    NotSymmetric {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// `a_ij`.
        value: f64,
        /// `a_ji` (0 when not stored).
        mirror: f64,
    },
    /// A value is NaN or infinite.
    #[error("{what} {index} is not finite")]
    NotFinite {
        /// Which array (matrix values, right-hand side, ...).
        what: &'static str,
        /// Position of the first non-finite value.
        index: usize,
    },
    /// The values given for one position sum to a non-finite value.
    #[error("the duplicates at ({row}, {col}) sum to a value that is not finite")]
    DuplicateSumNotFinite {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
    },
    /// A sparse Cholesky factorization failed, even with the diagonal
    /// shifted.
    #[error(
        "the {size} x {size} matrix is not positive definite: Cholesky failed with a diagonal \
         shift of {last_shift:e}"
    )]
    NotPositiveDefinite {
        /// Matrix size.
        size: usize,
        /// The last diagonal shift tried (0 when none).
        last_shift: f64,
    },
    /// A Cholesky pivot is negative beyond round-off: the matrix is not
    /// positive semidefinite.
    #[error(
        "the matrix is not positive definite: Cholesky pivot {index} is {pivot:e} (diagonal \
         {diagonal:e})"
    )]
    NegativePivot {
        /// The unknown.
        index: usize,
        /// Its pivot.
        pivot: f64,
        /// Its diagonal entry.
        diagonal: f64,
    },
    /// A diagonal entry is not positive where a positive definite matrix
    /// needs it.
    #[error(
        "diagonal entry {index} is {value}; a symmetric positive definite matrix has a positive diagonal"
    )]
    NonPositiveDiagonal {
        /// The unknown.
        index: usize,
        /// Its diagonal entry.
        value: f64,
    },
    /// A dense system is singular.
    #[error("the {what} is singular")]
    Singular {
        /// Which system.
        what: &'static str,
    },
    /// The sparse LU found no pivot: the matrix is structurally singular.
    #[error("the matrix is structurally singular: the sparse LU finds no pivot at step {index}")]
    StructurallySingular {
        /// Elimination step without a pivot.
        index: usize,
    },
    /// The coarsest multigrid level has a null direction that is a nonzero
    /// fine-grid vector: the matrix itself is singular.
    #[error(
        "the matrix is singular: the coarsest level ({size} unknowns) has a null direction (at \
         unknown {unknown}) that is a nonzero fine-grid vector (|Q n|^2 = {norm2:e} of {scale:e})"
    )]
    NullDirection {
        /// The dropped coarsest-level unknown.
        unknown: usize,
        /// Size of the coarsest level.
        size: usize,
        /// `|Q n|^2`.
        norm2: f64,
        /// `sum_i n_i^2 |Q e_i|^2`, its scale.
        scale: f64,
    },
    /// A solution has a large residual: the system is nearly singular.
    #[error("the solution has residual {residual:e} (scale {scale:e}): nearly singular system")]
    IllConditioned {
        /// Largest residual component.
        residual: f64,
        /// Largest component of the right-hand side and the solution.
        scale: f64,
    },

    // ---- factorizations ----------------------------------------------------
    /// A solve with a factor whose factorization failed or never ran.
    #[error("solve with a factor whose factorization failed or never ran")]
    NotFactorized,
    /// A factor handed to the pattern of another matrix.
    #[error("refactorize: the factor belongs to another pattern")]
    ForeignFactor,
    /// faer's sparse machinery failed (index overflow, out of memory).
    #[error("faer failed during the {during}: {source}")]
    Faer {
        /// The step (ordering, symbolic analysis, LU, ...).
        during: &'static str,
        /// faer's error.
        #[source]
        source: FaerError,
    },

    // ---- iterations ----------------------------------------------------------
    /// A tolerance is not positive and finite.
    #[error("{what} must be positive and finite, got {value}")]
    InvalidTolerance {
        /// Which tolerance.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// An iteration stopped at its iteration limit.
    #[error("did not converge in {iterations} iterations (residual {residual:e})")]
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// The residual reached (relative for conjugate gradients, the
        /// largest eigenpair residual for the eigensolver).
        residual: f64,
    },
    /// Conjugate gradients broke down: a quantity that is positive for
    /// positive definite matrices is not.
    #[error(
        "pcg breakdown at iteration {iteration}: {quantity} = {value:e} (the matrix or the \
         preconditioner is not positive definite)"
    )]
    Breakdown {
        /// The iteration.
        iteration: usize,
        /// `p^T A p`, `r^T M^-1 r` or `|r|`.
        quantity: &'static str,
        /// Its value.
        value: f64,
    },
    /// The eigensolver was asked for no pairs, or for more than the
    /// complement of the deflated vectors holds.
    #[error(
        "cannot compute {wanted} eigenpairs with {deflated} deflation vectors of a {size} x \
         {size} matrix (need 1 <= k <= size - deflated)"
    )]
    EigenpairCount {
        /// Pairs asked for.
        wanted: usize,
        /// Deflation vectors.
        deflated: usize,
        /// Matrix size.
        size: usize,
    },
    /// The dense eigendecomposition of the Rayleigh–Ritz matrix did not
    /// converge.
    #[error("the dense eigensolver did not converge on the {size} x {size} Rayleigh–Ritz matrix")]
    RayleighRitz {
        /// Size of the Rayleigh–Ritz matrix.
        size: usize,
    },
    /// No start block orthogonal to the deflated vectors could be built.
    #[error("could not build {wanted} start vectors orthogonal to the deflated ones (got {built})")]
    StartBlock {
        /// Vectors wanted.
        wanted: usize,
        /// Vectors built.
        built: usize,
    },

    // ---- grids -----------------------------------------------------------------
    /// A grid dimension is zero.
    #[error("grid dims {dims:?}: every dimension must be at least 1")]
    EmptyGrid {
        /// The dimensions.
        dims: [usize; 3],
    },
    /// The node count of a grid overflows.
    #[error("grid dims {dims:?}: too many nodes")]
    GridTooLarge {
        /// The dimensions.
        dims: [usize; 3],
    },
    /// A grid spacing that is not positive and finite.
    #[error("grid spacing {spacing}: the spacing must be positive and finite")]
    InvalidSpacing {
        /// The spacing given.
        spacing: f64,
    },
    /// A grid node's unknown number is not below the number of unknowns.
    #[error(
        "grid index: node {node} has unknown number {number}, but there are only {unknowns} \
         unknowns (the numbers must be 0..{unknowns}, each once)"
    )]
    GridNumberOutOfRange {
        /// The node.
        node: usize,
        /// Its unknown number.
        number: u32,
        /// Number of unknowns.
        unknowns: usize,
    },
    /// Two grid nodes have the same unknown number.
    #[error("grid index: unknown number {number} is used by nodes {first} and {second}")]
    GridNumberReused {
        /// The unknown number.
        number: u32,
        /// The first node using it.
        first: usize,
        /// The second node using it.
        second: usize,
    },
    /// The coarsest multigrid level is too large for its dense solve.
    #[error(
        "multigrid: the coarsest level has {size} unknowns, more than the dense solve allows \
         ({max}); give more prolongations"
    )]
    CoarsestTooLarge {
        /// Unknowns of the coarsest level.
        size: usize,
        /// The limit.
        max: usize,
    },

    // ---- Dirichlet problems ------------------------------------------------------
    /// A free vertex is not coupled, through a chain of non-zero entries,
    /// to any fixed vertex: the Dirichlet problem is singular.
    #[error(
        "vertex {vertex} is free but not connected to any fixed vertex: the Dirichlet problem is \
         singular (isolated vertex or component without a fixed vertex)"
    )]
    NotAnchored {
        /// The vertex.
        vertex: usize,
    },
    /// A free vertex has no neighbour to average.
    #[error("vertex {vertex} is free but has no neighbours: the Dirichlet problem is singular")]
    NoNeighbours {
        /// The vertex.
        vertex: usize,
    },
    /// The weights of a free vertex sum to zero (or overflow).
    #[error("the weights of free vertex {vertex} sum to {sum}")]
    ZeroWeightSum {
        /// The vertex.
        vertex: usize,
        /// Their sum.
        sum: f64,
    },

    // ---- scattered data ----------------------------------------------------------
    /// Too few points for an interpolant.
    #[error("{found} points given, at least {needed} needed")]
    TooFewPoints {
        /// Points needed.
        needed: usize,
        /// Points given.
        found: usize,
    },
    /// Two points coincide (closer than the tolerance).
    #[error("points {first} and {second} coincide")]
    CoincidentPoints {
        /// The first point.
        first: usize,
        /// The second point.
        second: usize,
    },
    /// The points are (nearly) collinear.
    #[error("the {count} points are (nearly) collinear")]
    Collinear {
        /// Number of points.
        count: usize,
    },
}

impl LinalgError {
    /// faer's error during `during`.
    pub(crate) fn faer(during: &'static str) -> impl FnOnce(FaerError) -> LinalgError {
        move |source| LinalgError::Faer { during, source }
    }
}
