//! Line searches along a descent direction, bounded by the first flip.
//!
//! A [`LineSearch`] picks the step `a` along a direction `d`: it is handed
//! `phi(a)`, the objective along the line, with `phi(0)`, the slope
//! `g · d` and `a_max`, the largest step before some element flips
//! ([`max_step_tets`], [`max_step_tris`], ALGORITHMS 1.3), and must return
//! a step below `a_max`, so every accepted iterate stays flip-free. Any
//! line search works with any [`Solver`](crate::Solver): the
//! [`Executor`](crate::Executor) hands it to the solver.
//!
//! - [`roots`]: robust smallest positive roots of quadratics and cubics;
//! - [`max_step`]: the largest flip-free step of a mesh;
//! - [`backtracking`]: Armijo / plain-decrease backtracking
//!   ([`Backtracking`], the default).

pub mod backtracking;
pub mod max_step;
mod registry;
pub mod roots;

pub use backtracking::Backtracking;
pub use max_step::{max_step_tets, max_step_tets_above, max_step_tris, max_step_tris_above};
pub use registry::LineSearchKind;
pub use roots::{smallest_positive_root_cubic, smallest_positive_root_quadratic};

use crate::ParamError;

/// The outcome of a line search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSearchResult {
    /// The accepted step (0 when none was found).
    pub step: f64,
    /// The objective at the accepted step (the start value when none).
    pub value: f64,
    /// How many objective evaluations were made.
    pub evaluations: usize,
    /// Whether a step satisfying the acceptance rule was found.
    pub success: bool,
}

impl LineSearchResult {
    /// An accepted step `a` with `value = phi(a)`.
    pub fn accepted(step: f64, value: f64, evaluations: usize) -> Self {
        LineSearchResult {
            step,
            value,
            evaluations,
            success: true,
        }
    }

    /// No acceptable step: `step = 0`, `value = f0`, `success = false`.
    pub fn rejected(f0: f64, evaluations: usize) -> Self {
        LineSearchResult {
            step: 0.0,
            value: f0,
            evaluations,
            success: false,
        }
    }
}

/// Picks a step along a search direction.
///
/// `phi(a)` evaluates the objective at `x + a d` (`f64::INFINITY` where it is
/// not admissible); `f0 = phi(0)`, `slope = g · d < 0`; `a_max` is the
/// largest step before some element flips (`f64::INFINITY` if none);
/// `a_init` the solver's preferred first step (1 for Newton).
///
/// The contract: the returned step is `0` (with `success: false` and
/// `value = f0`) or lies in `(0, a_max)` with `value = phi(step)` finite and
/// below `f0`, so the objective never increases and no element flips.
pub trait LineSearch: Send + Sync + std::fmt::Debug {
    /// A short name for reports (default: the type's name).
    fn name(&self) -> &'static str {
        std::any::type_name::<Self>()
    }
    /// Checks the settings before a solve (the default accepts all).
    ///
    /// # Errors
    /// [`ParamError::Setting`] naming the setting out of range.
    fn validate(&self) -> Result<(), ParamError> {
        Ok(())
    }
    /// Searches for a step.
    fn search(
        &self,
        phi: &mut dyn FnMut(f64) -> f64,
        f0: f64,
        slope: f64,
        a_max: f64,
        a_init: f64,
    ) -> LineSearchResult;
}

/// A boxed line search is a line search (so pipelines can hold and take
/// `Box<dyn LineSearch>`).
impl<L: LineSearch + ?Sized> LineSearch for Box<L> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn validate(&self) -> Result<(), ParamError> {
        (**self).validate()
    }
    fn search(
        &self,
        phi: &mut dyn FnMut(f64) -> f64,
        f0: f64,
        slope: f64,
        a_max: f64,
        a_init: f64,
    ) -> LineSearchResult {
        (**self).search(phi, f0, slope, a_max, a_init)
    }
}
