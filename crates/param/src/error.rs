//! The error type of unfold-param.

use std::sync::Arc;
use thiserror::Error;
use unfold_linalg::LinalgError;
use unfold_mesh::MeshError;

/// The kind of elements of a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Elements {
    /// Triangles mapped to the plane.
    Triangles,
    /// Tetrahedra mapped to space.
    Tets,
}

impl std::fmt::Display for Elements {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Elements::Triangles => "triangle",
            Elements::Tets => "tet",
        })
    }
}

/// The error of a piece written outside this crate (an organ's
/// initializer, a method developer's template), carried through
/// [`ParamError::Piece`] with its own type: the caller can
/// [`downcast_ref`](PieceError::downcast_ref) it back.
#[derive(Clone)]
pub struct PieceError(pub Arc<dyn std::error::Error + Send + Sync>);

impl PieceError {
    /// Wraps an error.
    pub fn new(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        PieceError(Arc::new(e))
    }

    /// The error as its own type, if it is one.
    pub fn downcast_ref<E: std::error::Error + 'static>(&self) -> Option<&E> {
        self.0.downcast_ref::<E>()
    }
}

impl std::fmt::Debug for PieceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(&*self.0, f)
    }
}

impl std::fmt::Display for PieceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&*self.0, f)
    }
}

/// Two piece errors are equal when they are the same error.
impl PartialEq for PieceError {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Everything that can go wrong setting up or running a parameterization.
/// Each variant holds the numbers that explain it; messages are one line.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ParamError {
    /// The input mesh is unusable (inverted or degenerate elements, bad
    /// indices, not a disk, ...).
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
    /// A setting is out of its range.
    #[error("{name} must be {expected}, got {value}")]
    Setting {
        /// The setting.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must be ("finite and >= 0", "in (0, 1]", ...).
        expected: &'static str,
    },
    /// A template weight is negative or not finite.
    #[error("the template weight of vertex {vertex} must be finite and >= 0, got {weight}")]
    TemplateWeight {
        /// The vertex.
        vertex: usize,
        /// Its weight.
        weight: f64,
    },
    /// A point target is not finite.
    #[error("point targets: the target of vertex {vertex} is not finite")]
    TargetNotFinite {
        /// The vertex.
        vertex: usize,
    },
    /// A vertex is given two point targets.
    #[error("point targets: vertex {vertex} has two targets")]
    TargetRepeated {
        /// The vertex.
        vertex: usize,
    },
    /// A mapped dimension other than 2 or 3.
    #[error("{what}: the mapped dimension must be 2 or 3, got {dim}")]
    Dimension {
        /// What was given the dimension.
        what: &'static str,
        /// The dimension given.
        dim: usize,
    },
    /// The objective became NaN or infinite during a solve.
    #[error("the objective is not finite at iteration {iteration} ({value})")]
    ObjectiveNotFinite {
        /// The iteration.
        iteration: usize,
        /// Its value.
        value: f64,
    },
    /// The Newton direction has a NaN or infinite entry.
    #[error("the Newton direction is not finite at iteration {iteration}")]
    DirectionNotFinite {
        /// The iteration.
        iteration: usize,
    },
    /// The template parameters' block of the joint Newton system (their
    /// Schur complement) is not positive definite even after shifts.
    #[error(
        "the template parameters' Newton block ({parameters} x {parameters}) is not positive \
         definite even with a diagonal shift of {shift:e}"
    )]
    ThetaBlockIndefinite {
        /// Number of template parameters.
        parameters: usize,
        /// The largest shift tried.
        shift: f64,
    },
    /// A Hessian layout built for another connectivity or fixed set.
    #[error("the Hessian layout was built for another connectivity or fixed set")]
    LayoutMismatch,
    /// A piece needs the other kind of mesh.
    #[error("{piece}: needs a {needs} mesh, got a {found} mesh{hint}")]
    WrongElements {
        /// The piece ("identity initializer", ...).
        piece: &'static str,
        /// What it needs.
        needs: Elements,
        /// What it got.
        found: Elements,
        /// What to use instead ("" or "; use ...").
        hint: &'static str,
    },
    /// An initializer cannot place prescribed vertices.
    #[error("{initializer}: cannot honour {pins} pinned vertices (it has no prescribed positions)")]
    PinsUnsupported {
        /// The initializer.
        initializer: &'static str,
        /// Number of pins given.
        pins: usize,
    },
    /// A pinned (or given boundary) vertex is out of range.
    #[error("pinned vertex {vertex} out of range ({vertices} vertices)")]
    PinOutOfRange {
        /// The vertex.
        vertex: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A vertex is pinned twice.
    #[error("vertex {vertex} is pinned twice")]
    PinRepeated {
        /// The vertex.
        vertex: u32,
    },
    /// A pinned vertex is used by no element.
    #[error("pinned vertex {vertex} is used by no triangle")]
    PinUnused {
        /// The vertex.
        vertex: u32,
    },
    /// A pinned position is not finite.
    #[error("the pinned position of vertex {vertex} is not finite")]
    PinNotFinite {
        /// The vertex.
        vertex: u32,
    },
    /// An embedding needs at least one pinned vertex.
    #[error("{piece}: no vertex is pinned")]
    NoPins {
        /// The piece.
        piece: &'static str,
    },
    /// A boundary loop to place on a circle has fewer than 3 vertices.
    #[error("circle boundary: a loop needs at least 3 vertices, got {found}")]
    LoopTooShort {
        /// Its vertex count.
        found: usize,
    },
    /// A boundary loop to place on a circle has zero or non-finite length.
    #[error("circle boundary: the loop has length {length}")]
    LoopLength {
        /// Its length.
        length: f64,
    },
    /// PCA is undefined: no points, or a coordinate is not finite.
    #[error("PCA alignment: no points, or a coordinate is not finite ({points} points)")]
    PcaUndefined {
        /// Number of points.
        points: usize,
    },
    /// A piece from outside this crate failed with its own error.
    #[error("{piece}: {error}")]
    Piece {
        /// The piece's name.
        piece: &'static str,
        /// Its error.
        error: PieceError,
    },
    /// The untangler stopped with elements still inverted: no flip-free map
    /// was found from this start with these fixed vertices.
    #[error(
        "no flip-free map found: {inverted} elements still inverted after {stages} untangling stages (smallest det J {min_det:e})"
    )]
    NotUntangled {
        /// Elements with `det J <= 0` left.
        inverted: usize,
        /// Stages run.
        stages: usize,
        /// The smallest `det J` left.
        min_det: f64,
    },
    /// An internal invariant failed (a bug: please report).
    #[error("internal error: {what} (please report)")]
    Internal {
        /// What failed.
        what: &'static str,
    },
}

impl ParamError {
    /// A piece's own error (`piece` its name) as [`ParamError::Piece`]; the
    /// caller gets it back with [`PieceError::downcast_ref`].
    pub fn piece(
        piece: &'static str,
        error: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        ParamError::Piece {
            piece,
            error: PieceError::new(error),
        }
    }
}
