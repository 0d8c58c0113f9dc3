//! The error type of unfold-param.

use thiserror::Error;
use unfold_linalg::LinalgError;
use unfold_mesh::MeshError;

/// Everything that can go wrong setting up or running a parameterization.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ParamError {
    /// The input mesh is unusable (inverted or degenerate elements, bad
    /// indices, ...).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A starting map inverts (or flattens) an element.
    #[error("element {element} is inverted or flat in the starting map (det J = {det:e})")]
    InvertedStart {
        /// Element index.
        element: usize,
        /// Its Jacobian determinant.
        det: f64,
    },
    /// Array lengths do not fit the mesh (positions, labels, weights, ...).
    #[error("{what}: expected {expected} values, got {found}")]
    Length {
        /// Which array.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Found length.
        found: usize,
    },
    /// A linear-algebra step failed (a factorization that is not positive
    /// definite even after diagonal shifts, a malformed sparsity pattern,
    /// ...).
    #[error(transparent)]
    Linalg(#[from] LinalgError),
    /// The objective or its gradient became NaN or infinite.
    #[error("the objective is not finite ({0})")]
    NotFinite(String),
    /// A parameter is out of its valid range.
    #[error("{0}")]
    InvalidArgument(String),
}
