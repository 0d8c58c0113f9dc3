//! Errors of the leaflet relaxation ([`relax`](crate::mitral::relax)).

use thiserror::Error;

/// A relaxation's input does not fit, or its result broke its promise.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum RelaxError {
    /// Not one `(u, v)` per leaflet vertex.
    #[error(
        "relax: the layout has {uv_positions} uv positions for a leaflet of {vertices} vertices"
    )]
    UvCount {
        /// Positions given.
        uv_positions: usize,
        /// The leaflet's vertices.
        vertices: usize,
    },
    /// Not one fixed flag per leaflet vertex.
    #[error("relax: {fixed_flags} fixed flags for a leaflet of {vertices} vertices")]
    FixedCount {
        /// Flags given.
        fixed_flags: usize,
        /// The leaflet's vertices.
        vertices: usize,
    },
    /// A `(u, v)` is not finite.
    #[error("relax: uv of vertex {vertex} is not finite ({uv:?})")]
    UvNotFinite {
        /// The vertex.
        vertex: usize,
        /// Its `(u, v)`.
        uv: [f64; 2],
    },
    /// The symmetric Dirichlet relaxation got a start with flipped or
    /// zero-area triangles that the untangler could not make flip-free.
    #[error(
        "relax: the starting layout has {flipped} flipped or zero-area triangles of {triangles} \
         (first: triangle {first}) and untangling it with the annulus fixed found no flip-free \
         layout; the symmetric Dirichlet relaxation needs a flip-free start"
    )]
    FlippedStart {
        /// Triangles not of the majority orientation (or zero or NaN area).
        flipped: usize,
        /// The leaflet's triangles.
        triangles: usize,
        /// The first such triangle.
        first: usize,
    },
    /// Internal invariant broken: the symmetric Dirichlet solve (whose
    /// injective line search never flips) produced a flipped triangle; the
    /// layout is left as it was (please report).
    #[error("relax: the symmetric Dirichlet solve produced a flipped triangle (please report)")]
    InternalFlippedResult {
        /// Flipped triangles in the solve's result.
        flipped: usize,
        /// The first of them.
        first: usize,
    },
}
