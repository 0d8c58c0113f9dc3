//! The voxelwise general linear model with permutation inference
//! (ALGORITHMS 5): a design of groups and covariates, the t or F of every
//! column of a subjects x columns matrix (voxels of template-space images,
//! or segment values), and two-sided p-values, uncorrected and family-wise
//! corrected by the distribution of the maximum statistic under
//! Freedman-Lane relabelings.
//!
//! - [`design`]: coding the regressors into `M = [Z | X]` and its
//!   orthonormal basis.
//! - [`fit`]: the OLS t and F from projections onto that basis.
//! - [`permutation`]: the relabelings' loop, the counts and the maxima.
//! - `shuffles`: the identity, exhaustive enumeration or a seeded stream.
//! - [`GlmError`]: every failure with its numbers.

pub mod design;
mod error;
pub mod fit;
pub mod permutation;
mod shuffles;
#[cfg(test)]
mod tests;

pub use design::{Design, Regressor, RegressorValues, StatisticKind};
pub use error::GlmError;
pub use permutation::{PermutationSettings, TestResult, permutation_test};
