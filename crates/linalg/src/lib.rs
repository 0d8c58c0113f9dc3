//! unfold-linalg: the linear algebra under the parameterizations and the
//! organ pipelines.
//!
//! - [`Csr`] ([`csr`]): the one sparse matrix type, compressed sparse rows
//!   (symmetric matrices store both triangles), with the constructors and
//!   products the solvers need.
//! - [`sparse`]: faer's sparse direct solvers behind one module: the
//!   Cholesky pattern/factor pair [`SpdPattern`] / [`SpdFactor`] (symbolic
//!   analysis once, numeric refactorization per set of values; AMD or
//!   nested dissection, or a multigrid-PCG backend for large meshes) and
//!   the LU [`SparseLu`].
//! - [`eigen`]: the few smallest eigenpairs of a sparse symmetric positive
//!   semidefinite matrix (shift-invert block Krylov with Rayleigh–Ritz).
//! - [`multigrid`]: multigrid-preconditioned conjugate gradients on masked
//!   3D grids, and background grids for unstructured points.
//! - [`laplacian`]: cotangent and uniform Laplacians, P1 stiffness,
//!   mean-value weights.
//! - [`dirichlet`]: harmonic extensions of boundary values (symmetric and
//!   non-symmetric operators).
//! - [`tps`]: the 2D thin-plate spline.
//! - [`glm`]: the voxelwise general linear model with max-statistic
//!   permutation inference (Freedman-Lane), for group comparisons in
//!   template space.
//!
//! Every failure is a [`LinalgError`] variant holding the numbers that
//! explain it.

pub mod csr;
pub mod dirichlet;
pub mod eigen;
mod error;
pub mod glm;
pub mod laplacian;
pub mod multigrid;
pub mod sparse;
#[cfg(any(test, feature = "test-support"))]
pub mod test_support;
pub mod tps;

pub use csr::Csr;
pub use dirichlet::{solve_dirichlet, solve_dirichlet_weights};
pub use eigen::{EigenOptions, Eigenpairs, smallest_eigenpairs};
pub use error::LinalgError;
pub use laplacian::{cotan_laplacian, mean_value_weights, p1_stiffness, uniform_laplacian};
pub use multigrid::{Multigrid, PcgReport, grid_prolongation, pcg};
pub use sparse::{SparseLu, SpdFactor, SpdPattern, solve_spd};
pub use tps::ThinPlateSpline2;
