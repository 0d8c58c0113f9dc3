//! Gradient descent, the placenta paper's Algorithm 1 (ALGORITHMS 1.5).

use super::{Solver, State, Step, Stopping, line_value};
use crate::ParamError;
use crate::linesearch::{Backtracking, LineSearch};
use crate::objective::Objective;

/// Gradient descent exactly as the placenta paper's Algorithm 1: direction
/// `d = -grad / |grad|_F`, first step `a_max` (the line search then takes
/// `min(a_init, beta a_max)`, `0.9 a_max` with the paper's rule), halve
/// until the objective decreases, stop at `|grad|_F < tol`
/// (ALGORITHMS 1.5). When no element ever flips along the direction
/// (`a_max` infinite) the first step is 1. Its defaults are the paper's:
/// [`Backtracking::paper`] and 100,000 iterations.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GradientDescent;

/// Per-solve buffers.
struct Work {
    d: Vec<f64>,
    buf: Vec<f64>,
}

impl Solver for GradientDescent {
    fn name(&self) -> &'static str {
        "gd"
    }

    fn default_line_search(&self) -> Box<dyn LineSearch> {
        Box::new(Backtracking::paper())
    }

    fn default_stopping(&self) -> Stopping {
        Stopping {
            max_iterations: 100_000,
            ..Stopping::default()
        }
    }

    fn next_iter(
        &self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
    ) -> Result<Step, ParamError> {
        let n = state.x.len();
        state.relative_decrement = None;
        let (f, gn) = (state.value, state.grad_norm);
        let mut work = state.take_workspace(|| Work {
            d: vec![0.0; n],
            buf: Vec::with_capacity(n),
        });
        let Work { d, buf } = &mut *work;
        for (di, gi) in d.iter_mut().zip(&state.grad) {
            *di = -gi / gn;
        }
        let a_max = objective.max_step(&state.x, d);
        let a_init = if a_max.is_finite() { a_max } else { 1.0 };
        let r = line_search.search(
            &mut |a| line_value(objective, (&state.x, d), (&state.theta, &[]), a, buf),
            f,
            -gn,
            a_max,
            a_init,
        );
        state.max_step = a_max;
        let step = if r.success {
            state.step = r.step;
            for (xi, di) in state.x.iter_mut().zip(d.iter()) {
                *xi += r.step * di;
            }
            objective.update_theta(&state.x, &mut state.theta);
            Step::Moved
        } else {
            Step::Stalled {
                below_roundoff: false,
            }
        };
        state.put_workspace(work);
        Ok(step)
    }
}
