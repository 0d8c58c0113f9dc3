//! Projected Newton, the default solver (ALGORITHMS 1.5).

use super::executor::{below_roundoff, relative_decrement};
use super::{Solver, State, Step, Stopping, line_value};
use crate::ParamError;
use crate::energy::HessianMode;
use crate::linesearch::LineSearch;
use crate::objective::{Objective, ThetaBlock};
use unfold_linalg::sparse::SpdFactor;

/// Projected Newton: solve `H d = -g` with `H` the sum of the PSD-projected
/// element Hessians and the template Hessian (sparse Cholesky; the symbolic
/// analysis is done once; the diagonal carries `shift * max|H_ii|` from the
/// first attempt, grown tenfold while the factorization fails, so that a
/// singular `H` costs no failed factorization), then search along `d` from
/// `a_init = 1` (ALGORITHMS 1.5). With
/// template parameters optimized jointly, `theta` is eliminated by its Schur
/// complement ([`eliminate_theta`]).
///
/// With `exact_first`, once the previous step was a full Newton step
/// (`a = 1`) with a relative decrement below [`EXACT_NEAR`], an iteration
/// first tries the unprojected Hessian and keeps it
/// when it factorizes without shift (positive definite) and gives a
/// descent direction: near the optimum this restores Newton's quadratic
/// convergence, which clamping the element eigenvalues loses. After the
/// first failed attempt a solve stops trying.
///
/// Each iteration reports its relative decrement `-g·d / (2 |phi|)` for the
/// executor's [`Stopping::decrement_tol`](super::Stopping::decrement_tol).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectedNewton {
    /// Relative diagonal shift: the projected Hessian is factorized with
    /// `shift * max|H_ii|` added to its diagonal (grown tenfold while the
    /// factorization fails); the exact Hessian is factorized unshifted.
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
    /// Shift 1e-10, no expansion, exact Hessian first.
    fn default() -> Self {
        ProjectedNewton {
            shift: 1e-10,
            expand: 1.0,
            exact_first: true,
        }
    }
}

/// Per-solve buffers and flags.
struct Work {
    /// Newton direction.
    d: Vec<f64>,
    /// Line-search positions.
    buf: Vec<f64>,
    /// Hessian values in the pattern's slots.
    values: Vec<f64>,
    /// The factor's storage, reused by every factorization.
    factor: Option<SpdFactor>,
    /// Whether the exact Hessian is still worth trying.
    try_exact: bool,
}

impl Solver for ProjectedNewton {
    fn name(&self) -> &'static str {
        "newton"
    }

    /// [`Stopping::default`] with 200 iterations (projected Newton
    /// converges in tens; the limit keeps a stuck solve bounded).
    fn default_stopping(&self) -> Stopping {
        Stopping {
            max_iterations: 200,
            ..Stopping::default()
        }
    }

    fn init(&self, _objective: &mut Objective<'_>, _state: &mut State) -> Result<(), ParamError> {
        if !(self.expand.is_finite() && self.expand >= 1.0) {
            return Err(ParamError::Setting {
                name: "Newton step expansion",
                value: self.expand,
                expected: "finite and >= 1",
            });
        }
        Ok(())
    }

    fn next_iter(
        &self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
    ) -> Result<Step, ParamError> {
        let n = state.x.len();
        let mut work = state.take_workspace(|| Work {
            d: vec![0.0; n],
            buf: Vec::with_capacity(n),
            values: Vec::new(),
            factor: None,
            try_exact: self.exact_first,
        });
        let result = self.iterate(objective, state, line_search, &mut work);
        state.put_workspace(work);
        result
    }
}

impl ProjectedNewton {
    fn iterate(
        &self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
        work: &mut Work,
    ) -> Result<Step, ParamError> {
        let Work {
            d,
            buf,
            values,
            factor: storage,
            try_exact,
        } = work;
        let f = state.value;
        // The exact Hessian first (quadratic convergence near the optimum,
        // where the total Hessian is positive definite although element
        // Hessians may not be), once the last step was a full one that
        // predicted a decrease below [`EXACT_NEAR`]; the projected one when
        // it is not positive definite or gives no descent direction.
        let near = state.relative_decrement.is_some_and(|r| r < EXACT_NEAR);
        state.relative_decrement = None;
        let modes: &[HessianMode] = if *try_exact && near && state.step == 1.0 {
            &[HessianMode::Exact, HessianMode::Projected]
        } else {
            &[HessianMode::Projected]
        };
        let mut dtheta = Vec::new();
        let mut theta_slope = 0.0;
        let mut slope = f64::NAN;
        for &mode in modes {
            let projected = mode == HessianMode::Projected;
            let block = objective.hessian_with(&state.x, &state.theta, values, mode)?;
            let pattern = objective.pattern()?;
            let factor = storage.get_or_insert_with(|| pattern.new_factor());
            for (di, gi) in d.iter_mut().zip(&state.grad) {
                *di = -gi;
            }
            let used = if projected {
                let used = pattern.refactorize_shifted(factor, values, self.shift, 16)?;
                factor.solve_in_place(d)?;
                used
            } else {
                match pattern.refactorize(factor, values, self.shift, 0) {
                    // (an iterative solve that breaks down: not positive
                    // definite either)
                    Ok(used) if factor.solve_in_place(d).is_ok() => used,
                    _ => {
                        // Not positive definite here: do not pay for the
                        // attempt again in this solve.
                        *try_exact = false;
                        continue;
                    }
                }
            };
            state.shift = used;
            dtheta.clear();
            theta_slope = 0.0;
            if let Some(tb) = &block {
                dtheta = eliminate_theta(factor, tb, d)?;
                theta_slope = tb.g.iter().zip(&dtheta).map(|(a, b)| a * b).sum();
            }
            slope = dot(&state.grad, d) + theta_slope;
            if slope < 0.0 {
                break;
            }
        }
        if !slope.is_finite() {
            return Err(ParamError::DirectionNotFinite {
                iteration: state.iteration,
            });
        }
        if slope >= 0.0 {
            // Not a descent direction (numerically singular system): fall
            // back to steepest descent for this step.
            for (di, gi) in d.iter_mut().zip(&state.grad) {
                *di = -gi;
            }
            dtheta.clear();
            theta_slope = 0.0;
        } else {
            state.relative_decrement = Some(relative_decrement(slope, f));
        }
        let slope = dot(&state.grad, d) + theta_slope;
        let a_max = objective.max_step(&state.x, d);
        state.max_step = a_max;
        let (x, theta) = (&state.x, &state.theta);
        let r = line_search.search(
            &mut |a| line_value(objective, (x, d), (theta, &dtheta), a, buf),
            f,
            slope,
            a_max,
            1.0,
        );
        if !r.success {
            return Ok(Step::Stalled {
                below_roundoff: below_roundoff(slope, f),
            });
        }
        let mut step = r.step;
        if step == 1.0 && self.expand > 1.0 {
            let mut best = r.value;
            let mut a = self.expand;
            while a < 0.9 * a_max {
                let v = line_value(objective, (x, d), (theta, &dtheta), a, buf);
                if v.is_nan() || v >= best {
                    break;
                }
                (best, step) = (v, a);
                a *= self.expand;
            }
        }
        for (xi, di) in state.x.iter_mut().zip(d.iter()) {
            *xi += step * di;
        }
        for (ti, dti) in state.theta.iter_mut().zip(&dtheta) {
            *ti += step * dti;
        }
        state.step = step;
        objective.update_theta(&state.x, &mut state.theta);
        Ok(Step::Moved)
    }
}

/// The relative decrement `-g.d / (2 |phi|)` of the last step below which
/// an iteration tries the exact Hessian first. Far from the optimum the
/// exact Hessian is rarely positive definite, and a failed attempt costs a
/// Hessian and most of a factorization.
pub const EXACT_NEAR: f64 = 1e-3;

/// Solves `(S + sigma I) dt = rhs` for the smallest `sigma` of the sequence
/// `0, 1e-12 m, 1e-11 m, ...` (`m` the largest `|S_ii|` or `|C_ii|`, 1 when
/// they all vanish) at which `S + sigma I` has a Cholesky factor (and a
/// finite solution), trying at last `sigma = ||S||_F`
/// (which bounds `|lambda_min(S)|`, so `S + sigma I` is then positive
/// definite whatever `S`'s signs). The shift is measured against `C` as
/// well as `S`: where the objective is flat along a joint direction of `x`
/// and `theta` (a scale-invariant energy with a template that scales with
/// its parameters, at its minimum) `S` vanishes to roundoff, and a damped
/// step is the answer. With `S + sigma I` positive definite, `rhs^T dt > 0`:
/// the step descends.
///
/// # Errors
/// [`ParamError::ThetaBlockIndefinite`] only when no shift gives a factor
/// and a finite solution, i.e. `S` or `rhs` is not finite.
fn shifted_solve(
    s: &nalgebra::DMatrix<f64>,
    c_diag: &[f64],
    rhs: &nalgebra::DVector<f64>,
) -> Result<nalgebra::DVector<f64>, ParamError> {
    let p = s.nrows();
    let largest = (0..p)
        .map(|i| s[(i, i)].abs().max(c_diag.get(i).map_or(0.0, |c| c.abs())))
        .fold(0.0, f64::max);
    // A block that vanishes (no curvature in theta at all) gets a unit
    // shift: a gradient step in theta, whose length the line search sets.
    let scale = if largest > 0.0 { largest } else { 1.0 };
    // Slightly past the Frobenius norm, so roundoff cannot leave it short.
    let last = (s.norm() * (1.0 + 1e-6)).max(scale);
    let mut shift = 0.0;
    loop {
        let mut sm = s.clone();
        for i in 0..p {
            sm[(i, i)] += shift;
        }
        if let Some(dt) = sm
            .cholesky()
            .map(|ch| ch.solve(rhs))
            .filter(|dt| dt.iter().all(|v| v.is_finite()))
        {
            return Ok(dt);
        }
        if shift >= last || !shift.is_finite() {
            return Err(ParamError::ThetaBlockIndefinite {
                parameters: p,
                shift,
            });
        }
        shift = if shift == 0.0 {
            1e-12 * scale
        } else {
            (shift * 10.0).min(last)
        };
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Eliminates the template parameters from the joint Newton system
/// `[A B; B^T C] [dx; dt] = -[g; g_t]` given the factor of `A` and
/// `d = -A^-1 g`: `S = C - B^T A^-1 B`, `dt = S^-1 (-g_t - B^T d)`,
/// `dx = d - A^-1 B dt`. Returns `dt` and updates `d` in place. `S` is
/// dense `p x p` (any number `p` of parameters), solved by
/// [`shifted_solve`].
fn eliminate_theta(
    factor: &SpdFactor,
    tb: &ThetaBlock,
    d: &mut [f64],
) -> Result<Vec<f64>, ParamError> {
    let (n, p) = (d.len(), tb.p);
    let mut y = tb.b.clone();
    for j in 0..p {
        factor.solve_in_place(&mut y[j * n..(j + 1) * n])?;
    }
    let mut s = nalgebra::DMatrix::<f64>::zeros(p, p);
    let mut rhs = nalgebra::DVector::<f64>::zeros(p);
    for i in 0..p {
        let bi = &tb.b[i * n..(i + 1) * n];
        rhs[i] = -tb.g[i] - dot(bi, d);
        for j in 0..p {
            s[(i, j)] = tb.c[i * p + j] - dot(bi, &y[j * n..(j + 1) * n]);
        }
    }
    let c_diag: Vec<f64> = (0..p).map(|i| tb.c[i * p + i]).collect();
    let dt = shifted_solve(&s, &c_diag, &rhs)?;
    for j in 0..p {
        let yj = &y[j * n..(j + 1) * n];
        for (di, yi) in d.iter_mut().zip(yj) {
            *di -= yi * dt[j];
        }
    }
    Ok(dt.iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use proptest::prelude::*;

    #[test]
    fn a_positive_definite_block_is_solved_unshifted() {
        let s = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 3.0]);
        let rhs = DVector::from_vec(vec![1.0, 2.0]);
        let dt = shifted_solve(&s, &[4.0, 3.0], &rhs).unwrap();
        assert!((&s * &dt - &rhs).norm() < 1e-12);
    }

    #[test]
    fn an_indefinite_block_with_a_zero_diagonal_is_shifted_past_its_norm() {
        // Eigenvalues +-1 and a zero diagonal: no shift up to the largest
        // diagonal entry helps; the Frobenius norm does.
        let s = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 1.0, 0.0]);
        let rhs = DVector::from_vec(vec![1.0, -0.5]);
        let dt = shifted_solve(&s, &[0.0, 0.0], &rhs).unwrap();
        assert!(dt.iter().all(|v| v.is_finite()));
        assert!(rhs.dot(&dt) > 0.0);
    }

    proptest! {
        /// Any finite symmetric block gives a finite descending step.
        #[test]
        fn every_symmetric_block_gives_a_descending_step(
            p in 1usize..5,
            entries in prop::collection::vec(-10.0..10.0f64, 16),
            diag_scale in prop::sample::select(vec![0.0, 1e-6, 1.0]),
            rhs in prop::collection::vec(-1.0..1.0f64, 4),
        ) {
            let mut s = DMatrix::<f64>::zeros(p, p);
            for i in 0..p {
                for j in 0..=i {
                    let v = entries[i * 4 + j];
                    let v = if i == j { v * diag_scale } else { v };
                    s[(i, j)] = v;
                    s[(j, i)] = v;
                }
            }
            let r = DVector::from_iterator(p, rhs.iter().copied().take(p));
            prop_assume!(r.norm() > 1e-6);
            let c: Vec<f64> = (0..p).map(|i| s[(i, i)]).collect();
            let dt = shifted_solve(&s, &c, &r).unwrap();
            prop_assert!(dt.iter().all(|v| v.is_finite()));
            prop_assert!(r.dot(&dt) > 0.0, "{} for {:?}", r.dot(&dt), s);
        }
    }
}
