//! The untangler's Newton steps (ALGORITHMS 1.7): one objective for all
//! stages (the energy's `eps` set per stage), the projected Newton step of
//! [`ProjectedNewton`](crate::ProjectedNewton) with the exact Hessian never
//! tried and no flip bound, and its cheaper variants that reuse a factor.
//!
//! A stage's direction `d` solves `H d = -g` with `H` the PSD-projected
//! Hessian factorized with the diagonal shift `1e-10 max|H_ii|` (grown
//! tenfold while the factorization fails); `d = -g` when that is no
//! descent direction. Along `d`, Armijo backtracking from `a = 1`
//! ([`Backtracking::default`]), unbounded (`a_max = inf`: the energy
//! admits inversion).
//!
//! - [`Direction::Fresh`]: assemble and factorize `H` at the stage's `x`
//!   and `eps` (Newton).
//! - [`Direction::Stale`]: solve with the factor of an earlier iterate or
//!   `eps` (a chord step: no Hessian, no factorization). The factor is
//!   positive definite, so `d` descends wherever `g != 0`.

use crate::ParamError;
use crate::energy::{DistortionEnergy, Untangling};
use crate::linesearch::{Backtracking, LineSearch};
use crate::objective::Objective;
use crate::solver::line_value;
use nalgebra::{Matrix2, Matrix3};
use std::sync::atomic::{AtomicU64, Ordering};
use unfold_linalg::sparse::SpdFactor;

/// The relative diagonal shift of the factorizations (as
/// [`ProjectedNewton::default`](crate::ProjectedNewton)).
const SHIFT: f64 = 1e-10;
/// Tenfold shift increases at most.
const SHIFT_TRIES: usize = 16;

/// [`Untangling`] whose `eps` is set per stage, so that one [`Objective`]
/// (its element buffers, flip floors and layout) serves every stage.
#[derive(Debug)]
pub(super) struct ScheduledUntangling {
    eps: AtomicU64,
    theta: f64,
}

impl ScheduledUntangling {
    pub(super) fn new(eps: f64, theta: f64) -> Self {
        ScheduledUntangling {
            eps: AtomicU64::new(eps.to_bits()),
            theta,
        }
    }

    /// Sets `eps` for the next evaluations.
    pub(super) fn set_eps(&self, eps: f64) {
        self.eps.store(eps.to_bits(), Ordering::Relaxed);
    }

    /// The energy at the current `eps`.
    fn now(&self) -> Untangling {
        Untangling {
            eps: f64::from_bits(self.eps.load(Ordering::Relaxed)),
            theta: self.theta,
        }
    }
}

impl DistortionEnergy for ScheduledUntangling {
    fn name(&self) -> &'static str {
        self.now().name()
    }
    fn value(&self, s: &[f64]) -> f64 {
        self.now().value(s)
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        self.now().gradient(s, out)
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        self.now().hessian(s, out)
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        self.now().flip_eigenvalue(s, i, j)
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        self.now().twist_eigenvalue(s, i, j)
    }
    fn pair_eigenvalues(&self, s: &[f64], twist: &mut [f64], flip: &mut [f64]) {
        self.now().pair_eigenvalues(s, twist, flip)
    }
    fn closed_form2(&self, f: &Matrix2<f64>, grad: Option<&mut Matrix2<f64>>) -> Option<f64> {
        self.now().closed_form2(f, grad)
    }
    fn closed_form3(&self, f: &Matrix3<f64>, grad: Option<&mut Matrix3<f64>>) -> Option<f64> {
        self.now().closed_form3(f, grad)
    }
    fn minimum(&self, dim: usize) -> f64 {
        self.now().minimum(dim)
    }
    fn is_barrier(&self) -> bool {
        false
    }
    fn admits_inversion(&self) -> bool {
        true
    }
}

/// How a step's direction is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Direction {
    /// Assemble and factorize the projected Hessian here.
    Fresh,
    /// Solve with the last factor (none yet: as `Fresh`).
    Stale,
}

/// The buffers of the untangler's steps, kept through all stages.
#[derive(Default)]
pub(super) struct Stepper {
    /// `d phi / dx` at the current iterate.
    pub(super) grad: Vec<f64>,
    d: Vec<f64>,
    buf: Vec<f64>,
    values: Vec<f64>,
    factor: Option<SpdFactor>,
    /// Factorizations made.
    pub(super) factorizations: usize,
}

impl Stepper {
    /// `phi(x)`, its gradient into [`Stepper::grad`].
    pub(super) fn evaluate(&mut self, objective: &Objective<'_>, x: &[f64]) -> f64 {
        self.grad.resize(x.len(), 0.0);
        objective.value_gradient(x, &[], &mut self.grad)
    }

    /// One step from `x` (value `f`, gradient in [`Stepper::grad`]): the
    /// direction as `how` says, Armijo backtracking along it, `x` moved.
    /// Returns the new value and the step length, `None` when the line
    /// search found no step (`x` unchanged).
    ///
    /// # Errors
    /// A factorization that fails; [`ParamError::DirectionNotFinite`].
    pub(super) fn step(
        &mut self,
        objective: &mut Objective<'_>,
        x: &mut [f64],
        f: f64,
        how: Direction,
        iteration: usize,
    ) -> Result<Option<(f64, f64)>, ParamError> {
        let n = x.len();
        self.d.resize(n, 0.0);
        for (di, gi) in self.d.iter_mut().zip(&self.grad) {
            *di = -gi;
        }
        if how == Direction::Fresh || self.factor.is_none() {
            objective.hessian(x, &[], &mut self.values)?;
            let pattern = objective.pattern()?;
            let factor = self.factor.get_or_insert_with(|| pattern.new_factor());
            pattern.refactorize_shifted(factor, &self.values, SHIFT, SHIFT_TRIES)?;
            self.factorizations += 1;
        }
        if let Some(factor) = &self.factor {
            factor.solve_in_place(&mut self.d)?;
        }
        let mut slope = dot(&self.grad, &self.d);
        if !slope.is_finite() {
            return Err(ParamError::DirectionNotFinite { iteration });
        }
        if slope >= 0.0 {
            // Not a descent direction (numerically singular system):
            // steepest descent for this step.
            for (di, gi) in self.d.iter_mut().zip(&self.grad) {
                *di = -gi;
            }
            slope = dot(&self.grad, &self.d);
        }
        let a_max = objective.max_step(x, &self.d);
        let (d, buf) = (&self.d[..], &mut self.buf);
        let no_theta: &[f64] = &[];
        let r = Backtracking::default().search(
            &mut |a| line_value(objective, (&*x, d), (no_theta, no_theta), a, buf),
            f,
            slope,
            a_max,
            1.0,
        );
        if !r.success {
            return Ok(None);
        }
        for (xi, di) in x.iter_mut().zip(d) {
            *xi += r.step * di;
        }
        Ok(Some((r.value, r.step)))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scheduled energy answers as [`Untangling`] at the `eps` last
    /// set, in every method the objective calls.
    #[test]
    fn the_scheduled_energy_is_untangling_at_the_eps_set() {
        let s3 = [1.3, 0.7, -0.4];
        let f3 = Matrix3::new(1.1, 0.2, -0.3, 0.1, 0.9, 0.4, -0.2, 0.3, -0.8);
        let scheduled = ScheduledUntangling::new(1.0, Untangling::DEFAULT_THETA);
        for eps in [1.0, 0.3, 1e-4] {
            scheduled.set_eps(eps);
            let e = Untangling::new(eps);
            assert_eq!(scheduled.value(&s3), e.value(&s3));
            let (mut g1, mut g2) = ([0.0; 3], [0.0; 3]);
            scheduled.gradient(&s3, &mut g1);
            e.gradient(&s3, &mut g2);
            assert_eq!(g1, g2);
            let (mut t1, mut f1, mut t2, mut f2) = ([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]);
            scheduled.pair_eigenvalues(&s3, &mut t1, &mut f1);
            e.pair_eigenvalues(&s3, &mut t2, &mut f2);
            assert_eq!((t1, f1), (t2, f2));
            assert_eq!(scheduled.closed_form3(&f3, None), e.closed_form3(&f3, None));
            assert_eq!(scheduled.minimum(3), e.minimum(3));
        }
        assert!(scheduled.admits_inversion() && !scheduled.is_barrier());
    }
}
