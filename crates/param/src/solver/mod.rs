//! Solvers and the loop that runs them (ALGORITHMS 1.5), split the way
//! argmin splits them:
//!
//! - a [`Solver`] knows one thing: how to take the next step from a
//!   [`State`] (direction, the [`LineSearch`] it is handed, the move);
//! - the [`Executor`] owns the loop: it checks the start (flip-free, the
//!   right length), evaluates `phi` and its gradient at every iterate,
//!   reports each [`Iteration`] to the [`Observer`]s and applies the
//!   [`Stopping`] rules;
//! - the line search is a separate piece ([`LineSearch`]), handed to the
//!   solver by the executor, so any line search works with any solver.
//!
//! ```text
//! Executor::new(&ProjectedNewton::default())
//!     .line_search(&Backtracking::default())   // optional: the solver's default
//!     .stopping(Stopping { grad_tol: 1e-6, ..Stopping::default() })
//!     .observer(&mut history)
//!     .run(&mut objective, &mut x, &mut theta)?
//! ```
//!
//! Two solvers ship: [`GradientDescent`] (the placenta paper's baseline) and
//! [`ProjectedNewton`] (the default).

mod executor;
mod gradient_descent;
mod newton;
mod observer;
mod registry;
mod state;
mod stopping;

pub use executor::Executor;
pub use gradient_descent::GradientDescent;
pub use newton::ProjectedNewton;
pub use observer::{History, Iteration, NoObserver, Observer};
pub use registry::SolverKind;
pub use state::State;
pub use stopping::{ROUNDOFF_DECREMENT, SolveReport, StopReason, Stopping};

use crate::ParamError;
use crate::linesearch::{Backtracking, LineSearch};
use crate::objective::Objective;

/// What one [`Solver::next_iter`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// The iterate moved (`State::x`, `theta`, `step` updated).
    Moved,
    /// No step was accepted: the iterate is unchanged. `below_roundoff`:
    /// the predicted decrease was within the rounding of `phi`
    /// ([`ROUNDOFF_DECREMENT`]), so the point is stationary to machine
    /// precision rather than stuck.
    Stalled {
        /// Whether the predicted decrease was below the rounding of `phi`.
        below_roundoff: bool,
    },
}

/// A descent method for an [`Objective`] that keeps every iterate
/// flip-free: each call of [`next_iter`](Solver::next_iter) picks a
/// direction, asks the line search for a step below the first flip
/// ([`Objective::max_step`]) and moves. The loop, the stopping rules and
/// the observers are the [`Executor`]'s.
///
/// Implement `name` and `next_iter`; `init` to check settings or allocate
/// buffers (kept in [`State::workspace`]); the defaults say which line
/// search and stopping rules suit the method.
pub trait Solver: Send + Sync + std::fmt::Debug {
    /// A short name ("newton", "gd").
    fn name(&self) -> &'static str;

    /// The line search used when the caller gives none: Armijo
    /// backtracking ([`Backtracking::default`]).
    fn default_line_search(&self) -> Box<dyn LineSearch> {
        Box::new(Backtracking::default())
    }

    /// The stopping rules used when the caller gives none
    /// ([`Stopping::default`]).
    fn default_stopping(&self) -> Stopping {
        Stopping::default()
    }

    /// Checks the solver's settings and prepares per-solve buffers, once
    /// before the first iteration (the start is already checked and
    /// evaluated). The default does nothing.
    ///
    /// # Errors
    /// [`ParamError::Setting`] for a setting out of range.
    fn init(&self, objective: &mut Objective<'_>, state: &mut State) -> Result<(), ParamError> {
        let _ = (objective, state);
        Ok(())
    }

    /// One iteration from `state`, whose `value`, `grad` and `grad_norm`
    /// are those of `(x, theta)`: choose a direction `d` (and `dtheta`),
    /// search along it with `line_search` (bounded by
    /// `objective.max_step(x, d)`), move `x` and `theta`, and let the
    /// template update `theta` ([`Objective::update_theta`]). Set
    /// `state.step`, `max_step`, `shift` and `relative_decrement`; the
    /// executor re-evaluates `phi` at the new point.
    ///
    /// # Errors
    /// A factorization or evaluation that fails.
    fn next_iter(
        &self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
    ) -> Result<Step, ParamError>;
}

/// The moving point `(x + a d, theta + a dtheta)` evaluated by a line
/// search (`dtheta` empty: theta stays); `buf` is scratch for the
/// positions.
pub fn line_value(
    objective: &Objective<'_>,
    (x, d): (&[f64], &[f64]),
    (theta, dtheta): (&[f64], &[f64]),
    a: f64,
    buf: &mut Vec<f64>,
) -> f64 {
    buf.clear();
    buf.extend(x.iter().zip(d).map(|(xi, di)| xi + a * di));
    if dtheta.is_empty() {
        objective.value(buf, theta)
    } else {
        let th: Vec<f64> = theta.iter().zip(dtheta).map(|(t, dt)| t + a * dt).collect();
        objective.value(buf, &th)
    }
}

/// A boxed solver is a solver (so pipelines can hold and take
/// `Box<dyn Solver>`).
impl<S: Solver + ?Sized> Solver for Box<S> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn default_line_search(&self) -> Box<dyn LineSearch> {
        (**self).default_line_search()
    }
    fn default_stopping(&self) -> Stopping {
        (**self).default_stopping()
    }
    fn init(&self, objective: &mut Objective<'_>, state: &mut State) -> Result<(), ParamError> {
        (**self).init(objective, state)
    }
    fn next_iter(
        &self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
    ) -> Result<Step, ParamError> {
        (**self).next_iter(objective, state, line_search)
    }
}
