//! What the [`Executor`](super::Executor) reports after every iteration,
//! and who receives it.

use serde::Serialize;

/// What one iteration did, for progress bars, logs and plots.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Iteration {
    /// Iteration number (0 = the starting point).
    pub iteration: usize,
    /// Objective value.
    pub value: f64,
    /// `|grad phi|_F` over the free unknowns.
    pub grad_norm: f64,
    /// The step taken to reach this point (0 at the start).
    pub step: f64,
    /// The largest flip-free step of that search (INFINITY if none).
    pub max_step: f64,
    /// Diagonal shift the factorization needed (Newton; 0 otherwise).
    pub shift: f64,
    /// Seconds since the solve started.
    pub seconds: f64,
}

/// Receives every iteration (argmin's observers): logs, progress bars,
/// histories. Observers watch; they do not steer (the stopping rules do).
pub trait Observer {
    /// Called once per iteration, starting with iteration 0.
    fn observe(&mut self, it: &Iteration);
}

/// An observer that does nothing.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoObserver;

impl Observer for NoObserver {
    fn observe(&mut self, _: &Iteration) {}
}

/// Keeps every iteration.
#[derive(Debug, Default, Clone)]
pub struct History(pub Vec<Iteration>);

impl Observer for History {
    fn observe(&mut self, it: &Iteration) {
        self.0.push(*it);
    }
}

impl<F: FnMut(&Iteration)> Observer for F {
    fn observe(&mut self, it: &Iteration) {
        self(it)
    }
}
