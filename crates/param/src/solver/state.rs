//! The iterate a solve carries from one iteration to the next.

use std::any::Any;

/// The state of a solve: the iterate, its value and gradient (kept current
/// by the [`Executor`](super::Executor) before every
/// [`Solver::next_iter`](super::Solver::next_iter)), what the last step did,
/// and the solver's own per-solve buffers.
pub struct State {
    /// Positions, flat (`dim` per vertex).
    pub x: Vec<f64>,
    /// Template parameters (empty without a template or parameters).
    pub theta: Vec<f64>,
    /// `phi(x, theta)`.
    pub value: f64,
    /// `d phi / dx` (zero on fixed vertices).
    pub grad: Vec<f64>,
    /// `|grad|_F`.
    pub grad_norm: f64,
    /// Iterations taken so far.
    pub iteration: usize,
    /// The step of the last iteration (0 before the first).
    pub step: f64,
    /// The largest flip-free step of the last search (INFINITY if none).
    pub max_step: f64,
    /// Diagonal shift of the last factorization (Newton; 0 otherwise).
    pub shift: f64,
    /// The relative Newton decrement `-g·d / (2 |phi|)` of the direction
    /// the last iteration searched along, when the solver has one (set
    /// anew by every iteration; `None` otherwise). The stopping rule
    /// [`Stopping::decrement_tol`](super::Stopping::decrement_tol) reads it.
    pub relative_decrement: Option<f64>,
    /// A solver's per-solve buffers (factor storage, flags), created by
    /// [`Solver::init`](super::Solver::init) and downcast by the solver.
    pub workspace: Option<Box<dyn Any + Send>>,
}

impl std::fmt::Debug for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("State")
            .field("iteration", &self.iteration)
            .field("value", &self.value)
            .field("grad_norm", &self.grad_norm)
            .field("step", &self.step)
            .field("max_step", &self.max_step)
            .field("shift", &self.shift)
            .field("relative_decrement", &self.relative_decrement)
            .field("unknowns", &self.x.len())
            .field("theta", &self.theta)
            .finish_non_exhaustive()
    }
}

impl State {
    /// The state at a starting point (value and gradient not yet
    /// evaluated).
    pub fn new(x: Vec<f64>, theta: Vec<f64>) -> Self {
        let n = x.len();
        State {
            x,
            theta,
            value: f64::NAN,
            grad: vec![0.0; n],
            grad_norm: f64::NAN,
            iteration: 0,
            step: 0.0,
            max_step: f64::INFINITY,
            shift: 0.0,
            relative_decrement: None,
            workspace: None,
        }
    }

    /// Takes the solver's workspace of type `W` out of the state (to use it
    /// beside the iterate), or makes a new one with `make` when there is
    /// none (or one of another type). Put it back with
    /// [`State::put_workspace`].
    pub fn take_workspace<W: Any + Send>(&mut self, make: impl FnOnce() -> W) -> Box<W> {
        match self.workspace.take().map(|w| w.downcast::<W>()) {
            Some(Ok(w)) => w,
            _ => Box::new(make()),
        }
    }

    /// Keeps `workspace` for the next iteration.
    pub fn put_workspace<W: Any + Send>(&mut self, workspace: Box<W>) {
        self.workspace = Some(workspace);
    }
}
