//! Sparse direct solvers: faer's sparse factorizations behind one module
//! (faer changes its API often; nothing else in the workspace names faer's
//! sparse solvers).
//!
//! - [`SpdPattern`] / [`SpdFactor`]: sparse Cholesky of symmetric positive
//!   definite matrices with the symbolic/numeric split (the pattern is
//!   ordered and analysed once, then refactorized for every new set of
//!   values), and the one-shot [`solve_spd`]; for mesh matrices whose
//!   factor would be too large, the same calls backed by multigrid-
//!   preconditioned conjugate gradients ([`VertexSolver::Multigrid`]).
//! - [`nested_dissection`]: the fill-reducing ordering of large vertex
//!   graphs.
//! - [`SparseLu`]: sparse LU of square non-symmetric matrices.
//!
//! Both read their input from the crate's [`crate::Csr`]
//! ([`SpdPattern::of_symmetric`], [`SpdPattern::values_of`],
//! [`SparseLu::factorize`]) or, for assembly-heavy callers such as
//! projected Newton, from compressed patterns and value slots.

mod cholesky;
mod lu;
mod multigrid_solve;
pub mod nested_dissection;

pub use cholesky::{SpdFactor, SpdPattern, VertexSolver, solve_spd};
pub use lu::SparseLu;
pub use multigrid_solve::{
    MULTIGRID_COARSEST, MULTIGRID_MAX_ITERATIONS, MULTIGRID_REL_TOL, MultigridSettings,
    MultigridSizes,
};
