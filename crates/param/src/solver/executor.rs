//! The loop around a [`Solver`]: start checks, evaluation, observers and
//! stopping rules.

use super::{
    Iteration, Observer, ROUNDOFF_DECREMENT, SolveReport, Solver, State, Step, StopReason, Stopping,
};
use crate::ParamError;
use crate::flips::check_no_flips;
use crate::linesearch::LineSearch;
use crate::objective::Objective;
use std::time::Instant;

/// Runs a [`Solver`] from a flip-free start: the solver takes the steps;
/// the executor evaluates every iterate, reports it to the observers and
/// decides when to stop (argmin's `Executor`).
///
/// Each iteration `k` (0 = the start):
///
/// 1. `phi` and its gradient at `(x_k, theta_k)`; an error if not finite;
/// 2. every observer sees the [`Iteration`];
/// 3. stop with [`StopReason::GradientTolerance`] when
///    `|grad|_F < grad_tol`, [`StopReason::MaxIterations`] at
///    `k = max_iterations`, [`StopReason::TimeLimit`] past `max_seconds`,
///    [`StopReason::NewtonDecrement`] when the step that led here had a
///    relative decrement below `decrement_tol`;
/// 4. [`Solver::next_iter`]; a stalled step ends the solve:
///    [`StopReason::NewtonDecrement`] when its decrease was below rounding
///    or below `decrement_tol`, else [`StopReason::LineSearchFailed`].
pub struct Executor<'a> {
    solver: &'a dyn Solver,
    line_search: Option<&'a dyn LineSearch>,
    stopping: Option<Stopping>,
    observers: Vec<&'a mut dyn Observer>,
}

impl std::fmt::Debug for Executor<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Executor")
            .field("solver", &self.solver)
            .field("line_search", &self.line_search)
            .field("stopping", &self.stopping)
            .field("observers", &self.observers.len())
            .finish()
    }
}

impl<'a> Executor<'a> {
    /// An executor for `solver` with its default line search and stopping
    /// rules and no observer.
    pub fn new(solver: &'a dyn Solver) -> Self {
        Executor {
            solver,
            line_search: None,
            stopping: None,
            observers: Vec::new(),
        }
    }

    /// Uses `line_search` instead of the solver's default.
    pub fn line_search(mut self, line_search: &'a dyn LineSearch) -> Self {
        self.line_search = Some(line_search);
        self
    }

    /// Uses these stopping rules instead of the solver's defaults.
    pub fn stopping(mut self, stopping: Stopping) -> Self {
        self.stopping = Some(stopping);
        self
    }

    /// Adds an observer (called for every iteration, in the order added).
    pub fn observer(mut self, observer: &'a mut dyn Observer) -> Self {
        self.observers.push(observer);
        self
    }

    /// Minimizes `objective` from `x` (flat positions) and `theta`
    /// (template parameters), both updated in place, also when the solve
    /// stops without converging (that is the report's business, not an
    /// error). On error they keep the last accepted iterate.
    ///
    /// # Errors
    /// [`ParamError::Length`] for a wrong `x`;
    /// [`ParamError::InvertedStart`] when the start inverts an element (unless
    /// the energy [admits inversion](crate::DistortionEnergy::admits_inversion));
    /// [`ParamError::Setting`] for bad solver or line-search settings;
    /// [`ParamError::ObjectiveNotFinite`] when `phi` stops being finite;
    /// the solver's own errors (a factorization that fails).
    pub fn run(
        mut self,
        objective: &mut Objective<'_>,
        x: &mut [f64],
        theta: &mut [f64],
    ) -> Result<SolveReport, ParamError> {
        let t0 = Instant::now();
        let default_line_search;
        let line_search: &dyn LineSearch = match self.line_search {
            Some(l) => l,
            None => {
                default_line_search = self.solver.default_line_search();
                default_line_search.as_ref()
            }
        };
        line_search.validate()?;
        let stopping = self
            .stopping
            .unwrap_or_else(|| self.solver.default_stopping());
        objective.check_len(x)?;
        if !objective.energy().admits_inversion() {
            check_no_flips(objective.mesh(), x)?;
        }
        let mut state = State::new(x.to_vec(), theta.to_vec());
        self.solver.init(objective, &mut state)?;
        objective.update_theta(&state.x, &mut state.theta);
        let result = self.iterate(objective, &mut state, line_search, &stopping, t0);
        x.copy_from_slice(&state.x);
        theta.copy_from_slice(&state.theta);
        result
    }

    fn iterate(
        &mut self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
        stopping: &Stopping,
        t0: Instant,
    ) -> Result<SolveReport, ParamError> {
        loop {
            state.value = objective.value_gradient(&state.x, &state.theta, &mut state.grad);
            if !state.value.is_finite() {
                return Err(ParamError::ObjectiveNotFinite {
                    iteration: state.iteration,
                    value: state.value,
                });
            }
            state.grad_norm = state.grad.iter().map(|g| g * g).sum::<f64>().sqrt();
            let seconds = t0.elapsed().as_secs_f64();
            let it = Iteration {
                iteration: state.iteration,
                value: state.value,
                grad_norm: state.grad_norm,
                step: state.step,
                max_step: state.max_step,
                shift: state.shift,
                seconds,
            };
            for o in &mut self.observers {
                o.observe(&it);
            }
            let (iterations, value, grad_norm) = (state.iteration, state.value, state.grad_norm);
            let report = |reason: StopReason| SolveReport {
                iterations,
                reason,
                converged: reason.converged(),
                value,
                grad_norm,
                seconds,
            };
            let small_decrement = state
                .relative_decrement
                .is_some_and(|d| d < stopping.decrement_tol);
            let stop = if state.grad_norm < stopping.grad_tol {
                Some(StopReason::GradientTolerance)
            } else if state.iteration >= stopping.max_iterations {
                Some(StopReason::MaxIterations)
            } else if seconds >= stopping.max_seconds {
                Some(StopReason::TimeLimit)
            } else if small_decrement {
                Some(StopReason::NewtonDecrement)
            } else {
                None
            };
            if let Some(reason) = stop {
                return Ok(report(reason));
            }
            match self.solver.next_iter(objective, state, line_search)? {
                Step::Moved => state.iteration += 1,
                Step::Stalled { below_roundoff } => {
                    let converged = below_roundoff
                        || state
                            .relative_decrement
                            .is_some_and(|d| d < stopping.decrement_tol);
                    return Ok(report(if converged {
                        StopReason::NewtonDecrement
                    } else {
                        StopReason::LineSearchFailed
                    }));
                }
            }
        }
    }
}

/// `-g·d / (2 |phi|)`: the predicted decrease of a Newton step relative to
/// the objective (`slope = g·d`).
pub(crate) fn relative_decrement(slope: f64, value: f64) -> f64 {
    -slope / 2.0 / value.abs()
}

/// Whether the predicted decrease `-slope / 2` is within the rounding of
/// `phi` ([`ROUNDOFF_DECREMENT`]).
pub(crate) fn below_roundoff(slope: f64, value: f64) -> bool {
    -slope / 2.0 <= ROUNDOFF_DECREMENT * value.abs()
}
