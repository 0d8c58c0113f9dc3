//! The injective maximal step (ALGORITHMS 1.3) and backtracking line
//! searches (1.4).

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

/// Picks a step along a search direction.
///
/// `phi(a)` evaluates the objective at `x + a d` (`f64::INFINITY` where it is
/// not admissible); `f0 = phi(0)`, `slope = g · d < 0`; `a_max` is the
/// largest step before some element flips (`f64::INFINITY` if none);
/// `a_init` the solver's preferred first step (1 for Newton).
pub trait LineSearch: Send + Sync + std::fmt::Debug {
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
