//! Solvers: gradient descent (the placenta paper's Algorithm 1, kept as the
//! baseline) and projected Newton (the default), both with the injective
//! line search, reporting every iteration to an [`Observer`]
//! (ALGORITHMS 1.4, 1.5).

use crate::energy::HessianMode;
use crate::linesearch::Backtracking;
use crate::objective::Objective;
use crate::{LineSearch, ParamError};
use serde::Serialize;
use std::time::Instant;

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
    /// Seconds since the solver started.
    pub seconds: f64,
}

/// Receives every iteration.
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

/// When to stop.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stopping {
    /// Stop when `|grad phi|_F < grad_tol` (1e-4, as the source).
    pub grad_tol: f64,
    /// Newton: when the decrement `-g·d / 2 < decrement_tol * |phi|`, take
    /// that last step (its line search costs a few objective values, the
    /// Newton direction is already paid for) and stop; and, whatever this
    /// is, stop when a line search fails with a decrement below
    /// [`ROUNDOFF_DECREMENT`]` * |phi|`.
    pub decrement_tol: f64,
    /// Iteration limit.
    pub max_iterations: usize,
    /// Time limit in seconds.
    pub max_seconds: f64,
}

impl Default for Stopping {
    fn default() -> Self {
        Stopping {
            grad_tol: 1e-4,
            decrement_tol: 1e-12,
            max_iterations: 1000,
            max_seconds: f64::INFINITY,
        }
    }
}

/// Why a solver stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// `|grad|_F < grad_tol`.
    GradientTolerance,
    /// The Newton decrement fell below its tolerance.
    NewtonDecrement,
    /// The iteration limit was reached.
    MaxIterations,
    /// The time limit was reached.
    TimeLimit,
    /// The line search found no decreasing step (numerically stationary).
    LineSearchFailed,
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
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SolveReport {
    /// Iterations taken.
    pub iterations: usize,
    /// Why it stopped.
    pub reason: StopReason,
    /// Whether it converged.
    pub converged: bool,
    /// Final objective value.
    pub value: f64,
    /// Final `|grad|_F`.
    pub grad_norm: f64,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Minimizes an [`Objective`] from a flip-free starting point, keeping
/// every iterate flip-free.
pub trait Solver {
    /// A short name ("newton", "gd").
    fn name(&self) -> &'static str;
    /// Minimizes in place: `x` (flat positions) and `theta` (template
    /// parameters, updated by the template's own rule after every step).
    fn solve(
        &self,
        objective: &mut Objective<'_>,
        x: &mut [f64],
        theta: &mut [f64],
        observer: &mut dyn Observer,
    ) -> Result<SolveReport, ParamError>;
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The state after evaluating an iterate: its value, gradient norm and
/// time, reported to the observer, and the stopping rule it meets, if any.
struct Checkpoint {
    value: f64,
    grad_norm: f64,
    seconds: f64,
    stop: Option<StopReason>,
}

impl Checkpoint {
    /// Evaluates `phi` and its gradient at `x` (into `g`), reports the
    /// iteration and applies the gradient, iteration and time limits.
    #[allow(clippy::too_many_arguments)]
    fn new(
        objective: &Objective<'_>,
        x: &[f64],
        theta: &[f64],
        g: &mut [f64],
        stopping: &Stopping,
        t0: Instant,
        (it, step, max_step, shift): (usize, f64, f64, f64),
        observer: &mut dyn Observer,
    ) -> Result<Self, ParamError> {
        let value = objective.value_gradient(x, theta, g);
        if !value.is_finite() {
            return Err(ParamError::NotFinite(format!(
                "objective at iteration {it}"
            )));
        }
        let grad_norm = norm(g);
        let seconds = t0.elapsed().as_secs_f64();
        observer.observe(&Iteration {
            iteration: it,
            value,
            grad_norm,
            step,
            max_step,
            shift,
            seconds,
        });
        let stop = if grad_norm < stopping.grad_tol {
            Some(StopReason::GradientTolerance)
        } else if it >= stopping.max_iterations {
            Some(StopReason::MaxIterations)
        } else if seconds >= stopping.max_seconds {
            Some(StopReason::TimeLimit)
        } else {
            None
        };
        Ok(Checkpoint {
            value,
            grad_norm,
            seconds,
            stop,
        })
    }

    /// The report of a solve that ends here after `iterations`.
    fn report(&self, iterations: usize, reason: StopReason) -> SolveReport {
        SolveReport {
            iterations,
            reason,
            converged: reason.converged(),
            value: self.value,
            grad_norm: self.grad_norm,
            seconds: self.seconds,
        }
    }
}

fn start(objective: &Objective<'_>, x: &[f64], theta: &mut [f64]) -> Result<(), ParamError> {
    objective.check_len(x)?;
    crate::initializer::check_no_flips(objective.mesh(), x)?;
    objective.update_theta(x, theta);
    Ok(())
}

/// The moving point `(x + a d, theta + a dtheta)` evaluated by the line
/// search (`dtheta` empty: theta stays).
fn line_value(
    objective: &Objective<'_>,
    x: &[f64],
    d: &[f64],
    theta: &[f64],
    dtheta: &[f64],
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

/// Eliminates the template parameters from the joint Newton system
/// `[A B; B^T C] [dx; dt] = -[g; g_t]` given the factor of `A` and
/// `d = -A^-1 g`: `S = C - B^T A^-1 B`, `dt = S^-1 (-g_t - B^T d)`,
/// `dx = d - A^-1 B dt`. Returns `dt` and updates `d` in place.
fn eliminate_theta(
    factor: &unfold_linalg::sparse::SpdFactor,
    tb: &crate::objective::ThetaBlock,
    d: &mut [f64],
) -> Result<Vec<f64>, ParamError> {
    let (n, p) = (d.len(), tb.p);
    let mut y = tb.b.clone();
    for j in 0..p {
        factor.solve_in_place(&mut y[j * n..(j + 1) * n])?;
    }
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut s = nalgebra::DMatrix::<f64>::zeros(p, p);
    let mut rhs = nalgebra::DVector::<f64>::zeros(p);
    for i in 0..p {
        let bi = &tb.b[i * n..(i + 1) * n];
        rhs[i] = -tb.g[i] - dot(bi, d);
        for j in 0..p {
            s[(i, j)] = tb.c[i * p + j] - dot(bi, &y[j * n..(j + 1) * n]);
        }
    }
    let scale = (0..p)
        .map(|i| s[(i, i)].abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut shift = 0.0;
    let dt = loop {
        let mut sm = s.clone();
        for i in 0..p {
            sm[(i, i)] += shift;
        }
        if let Some(ch) = sm.cholesky() {
            break ch.solve(&rhs);
        }
        shift = if shift == 0.0 {
            1e-12 * scale
        } else {
            shift * 10.0
        };
        if shift > scale {
            return Err(unfold_linalg::LinalgError::NotPositiveDefinite {
                size: p,
                last_shift: shift / 10.0, // the last one tried
            }
            .into());
        }
    };
    for j in 0..p {
        let yj = &y[j * n..(j + 1) * n];
        for (di, yi) in d.iter_mut().zip(yj) {
            *di -= yi * dt[j];
        }
    }
    Ok(dt.iter().copied().collect())
}

/// Gradient descent exactly as the placenta paper's Algorithm 1: direction
/// `-grad / |grad|_F`, first step `0.9 a_max`, halve until the objective
/// decreases, stop at `|grad|_F < tol` (ALGORITHMS 1.5). When no element
/// ever flips along the direction (`a_max` infinite) the first step is 1.
#[derive(Debug, Clone, Copy)]
pub struct GradientDescent {
    /// Stopping rules (`max_iterations` large: the paper needs thousands).
    pub stopping: Stopping,
    /// The line search (the paper's rule by default).
    pub line_search: Backtracking,
}

impl Default for GradientDescent {
    fn default() -> Self {
        GradientDescent {
            stopping: Stopping {
                max_iterations: 100_000,
                ..Stopping::default()
            },
            line_search: Backtracking::paper(),
        }
    }
}

impl Solver for GradientDescent {
    fn name(&self) -> &'static str {
        "gd"
    }

    fn solve(
        &self,
        objective: &mut Objective<'_>,
        x: &mut [f64],
        theta: &mut [f64],
        observer: &mut dyn Observer,
    ) -> Result<SolveReport, ParamError> {
        let t0 = Instant::now();
        start(objective, x, theta)?;
        let mut g = vec![0.0; x.len()];
        let mut buf = Vec::with_capacity(x.len());
        let mut d = vec![0.0; x.len()];
        let (mut step, mut a_max) = (0.0, f64::INFINITY);
        let mut it = 0;
        loop {
            let c = Checkpoint::new(
                objective,
                x,
                theta,
                &mut g,
                &self.stopping,
                t0,
                (it, step, a_max, 0.0),
                observer,
            )?;
            if let Some(reason) = c.stop {
                return Ok(c.report(it, reason));
            }
            let (f, gn) = (c.value, c.grad_norm);
            for (di, gi) in d.iter_mut().zip(&g) {
                *di = -gi / gn;
            }
            a_max = objective.max_step(x, &d);
            let a_init = if a_max.is_finite() { a_max } else { 1.0 };
            let th = theta.to_vec();
            let r = self.line_search.search(
                &mut |a| line_value(objective, x, &d, &th, &[], a, &mut buf),
                f,
                -gn,
                a_max,
                a_init,
            );
            if !r.success {
                return Ok(c.report(it, StopReason::LineSearchFailed));
            }
            step = r.step;
            for (xi, di) in x.iter_mut().zip(&d) {
                *xi += step * di;
            }
            objective.update_theta(x, theta);
            it += 1;
        }
    }
}

/// Relative Newton decrement below which a failed line search means
/// convergence to machine precision ([`StopReason::NewtonDecrement`]): the
/// predicted decrease `-g·d / 2 <= ROUNDOFF_DECREMENT |phi|` is within the
/// rounding error of evaluating `phi` (a sum over all elements), so no step
/// can show an Armijo decrease.
pub const ROUNDOFF_DECREMENT: f64 = 64.0 * f64::EPSILON;

/// Projected Newton (the default): solve `H d = -g` with `H` the sum of the
/// PSD-projected element Hessians and the template Hessian (sparse
/// Cholesky; the symbolic analysis is done once, a diagonal shift is added
/// when a factorization fails), then the injective line search with
/// `a_init = 1` (ALGORITHMS 1.5). With `exact_first`, once the previous
/// step was a full Newton step (`a = 1`), an iteration first tries the
/// unprojected Hessian and keeps it when it factorizes without shift
/// (positive definite) and gives a descent direction: near the optimum this
/// restores Newton's quadratic convergence, which clamping the element
/// eigenvalues loses. After the first failed attempt a solve stops trying.
#[derive(Debug, Clone, Copy)]
pub struct ProjectedNewton {
    /// Stopping rules.
    pub stopping: Stopping,
    /// The line search (Armijo backtracking, bounded by `0.9 a_max`).
    pub line_search: Backtracking,
    /// Relative diagonal shift tried first when a factorization fails.
    pub shift: f64,
    /// Step expansion: when the line search accepts the full Newton step
    /// (`a = 1`), also try `a = expand, expand^2, ...` while each lowers
    /// `phi` further and stays below `0.9 a_max` (so flip-free), and keep
    /// the last that did. The projected Hessian overestimates the curvature
    /// where element Hessians were clamped, so the full step often falls
    /// short; one extra objective value is cheap against a Newton
    /// iteration. `1` (the default) turns it off; finite and `>= 1`.
    pub expand: f64,
    /// Try the exact (unprojected) Hessian before the projected one.
    pub exact_first: bool,
}

impl Default for ProjectedNewton {
    fn default() -> Self {
        ProjectedNewton {
            stopping: Stopping::default(),
            line_search: Backtracking::default(),
            shift: 1e-10,
            expand: 1.0,
            exact_first: true,
        }
    }
}

impl Solver for ProjectedNewton {
    fn name(&self) -> &'static str {
        "newton"
    }

    fn solve(
        &self,
        objective: &mut Objective<'_>,
        x: &mut [f64],
        theta: &mut [f64],
        observer: &mut dyn Observer,
    ) -> Result<SolveReport, ParamError> {
        let t0 = Instant::now();
        if !(self.expand.is_finite() && self.expand >= 1.0) {
            return Err(ParamError::InvalidArgument(format!(
                "Newton step expansion must be finite and >= 1, got {}",
                self.expand
            )));
        }
        start(objective, x, theta)?;
        let n = x.len();
        let mut g = vec![0.0; n];
        let mut d = vec![0.0; n];
        let mut buf = Vec::with_capacity(n);
        let mut values = Vec::new();
        // The factor's storage, reused by every factorization.
        let mut storage: Option<unfold_linalg::sparse::SpdFactor> = None;
        let (mut step, mut a_max, mut shift) = (0.0, f64::INFINITY, 0.0);
        let mut try_exact = self.exact_first;
        let mut it = 0;
        // Set when the decrement test passed: the step is taken, then stop.
        let mut last_step = false;
        loop {
            let c = Checkpoint::new(
                objective,
                x,
                theta,
                &mut g,
                &self.stopping,
                t0,
                (it, step, a_max, shift),
                observer,
            )?;
            let done = |reason: StopReason| Ok(c.report(it, reason));
            if let Some(reason) = c.stop {
                return done(reason);
            }
            if last_step {
                return done(StopReason::NewtonDecrement);
            }
            let f = c.value;
            // The exact Hessian first (quadratic convergence near the
            // optimum, where the total Hessian is positive definite although
            // element Hessians may not be); the projected one when it is not
            // positive definite or gives no descent direction.
            let modes: &[HessianMode] = if try_exact && it > 0 && step == 1.0 {
                &[HessianMode::Exact, HessianMode::Projected]
            } else {
                &[HessianMode::Projected]
            };
            let mut dtheta = Vec::new();
            let mut theta_slope = 0.0;
            let mut slope = f64::NAN;
            for &mode in modes {
                let projected = mode == HessianMode::Projected;
                let block = objective.hessian_with(x, theta, &mut values, mode)?;
                let pattern = objective.pattern()?;
                let factor = storage.get_or_insert_with(|| pattern.new_factor());
                let factored = pattern.refactorize(
                    factor,
                    &values,
                    self.shift,
                    if projected { 16 } else { 0 },
                );
                let used = match factored {
                    Ok(used) => used,
                    Err(e) if projected => return Err(e.into()),
                    Err(_) => {
                        // Not positive definite here: do not pay for the
                        // attempt again in this solve.
                        try_exact = false;
                        continue;
                    }
                };
                shift = used;
                for (di, gi) in d.iter_mut().zip(&g) {
                    *di = -gi;
                }
                factor.solve_in_place(&mut d)?;
                dtheta.clear();
                theta_slope = 0.0;
                if let Some(tb) = &block {
                    dtheta = eliminate_theta(factor, tb, &mut d)?;
                    theta_slope = tb.g.iter().zip(&dtheta).map(|(a, b)| a * b).sum();
                }
                slope = g.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>() + theta_slope;
                if slope < 0.0 {
                    break;
                }
            }
            if !slope.is_finite() {
                return Err(ParamError::NotFinite("Newton direction".into()));
            }
            if slope >= 0.0 {
                // Not a descent direction (numerically singular system):
                // fall back to steepest descent for this step.
                for (di, gi) in d.iter_mut().zip(&g) {
                    *di = -gi;
                }
                dtheta.clear();
                theta_slope = 0.0;
            } else if -slope / 2.0 < self.stopping.decrement_tol * f.abs() {
                last_step = true;
            }
            let slope: f64 = g.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>() + theta_slope;
            a_max = objective.max_step(x, &d);
            let th = theta.to_vec();
            let r = self.line_search.search(
                &mut |a| line_value(objective, x, &d, &th, &dtheta, a, &mut buf),
                f,
                slope,
                a_max,
                1.0,
            );
            if !r.success {
                // A decrease below the rounding of phi cannot be seen by
                // any line search: at machine precision, not a failure.
                if last_step || -slope / 2.0 <= ROUNDOFF_DECREMENT * f.abs() {
                    return done(StopReason::NewtonDecrement);
                }
                return done(StopReason::LineSearchFailed);
            }
            step = r.step;
            if step == 1.0 && self.expand > 1.0 {
                let mut best = r.value;
                let mut a = self.expand;
                while a < 0.9 * a_max {
                    let v = line_value(objective, x, &d, &th, &dtheta, a, &mut buf);
                    if v.is_nan() || v >= best {
                        break;
                    }
                    (best, step) = (v, a);
                    a *= self.expand;
                }
            }
            for (xi, di) in x.iter_mut().zip(&d) {
                *xi += step * di;
            }
            for (ti, dti) in theta.iter_mut().zip(&dtheta) {
                *ti += step * dti;
            }
            objective.update_theta(x, theta);
            it += 1;
        }
    }
}
