//! When a solve stops: the rules the [`Executor`](super::Executor) applies
//! after every iteration, outside the solver.

use serde::{Deserialize, Serialize};

/// Relative Newton decrement below which a failed line search means
/// convergence to machine precision ([`StopReason::NewtonDecrement`]): the
/// predicted decrease `-g·d / 2 <= ROUNDOFF_DECREMENT |phi|` is within the
/// rounding error of evaluating `phi` (a sum over all elements), so no step
/// can show an Armijo decrease.
pub const ROUNDOFF_DECREMENT: f64 = 64.0 * f64::EPSILON;

/// The stopping rules.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stopping {
    /// Stop when `|grad phi|_F < grad_tol` (1e-4, as the source).
    pub grad_tol: f64,
    /// Stop once a step's predicted decrease, the relative Newton decrement
    /// `-g·d / (2 |phi|)` reported by the solver
    /// ([`State::relative_decrement`](super::State::relative_decrement)), is
    /// below this: that step is taken, then the solve ends. A stalled line
    /// search after such a direction also counts as converged.
    pub decrement_tol: f64,
    /// Iteration limit.
    pub max_iterations: usize,
    /// Time limit in seconds.
    pub max_seconds: f64,
}

impl Default for Stopping {
    /// `grad_tol` 1e-4, `decrement_tol` 1e-12, 1000 iterations, no time
    /// limit.
    fn default() -> Self {
        Stopping {
            grad_tol: 1e-4,
            decrement_tol: 1e-12,
            max_iterations: 1000,
            max_seconds: f64::INFINITY,
        }
    }
}

/// Why a solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// `|grad|_F < grad_tol`.
    GradientTolerance,
    /// The Newton decrement fell below its tolerance (or below the
    /// rounding of `phi`).
    NewtonDecrement,
    /// The iteration limit was reached.
    MaxIterations,
    /// The time limit was reached.
    TimeLimit,
    /// The line search found no decreasing step (numerically stationary).
    LineSearchFailed,
    /// The start inverts elements and the untangler found no flip-free map
    /// from it ([`crate::untangle`]); the distortion was not minimized.
    NotUntangled,
}

impl StopReason {
    /// Whether this counts as converged.
    pub fn converged(self) -> bool {
        matches!(
            self,
            StopReason::GradientTolerance | StopReason::NewtonDecrement
        )
    }
}

/// The result of a solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolveReport {
    /// Iterations taken.
    pub iterations: usize,
    /// Why it stopped.
    pub reason: StopReason,
    /// Whether it converged.
    pub converged: bool,
    /// Final objective value.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub value: f64,
    /// Final `|grad|_F`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub grad_norm: f64,
    /// Wall-clock seconds.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
}
