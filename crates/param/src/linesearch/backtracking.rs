//! Backtracking line search bounded by the first flip (ALGORITHMS 1.4).
//!
//! [`Backtracking`] starts at `a = min(a_init, beta a_max)` and multiplies by
//! `rho` until the objective decreases enough (Armijo) or at all (the
//! placenta paper's rule), giving up after a bounded number of halvings.

use super::{LineSearch, LineSearchResult};
use crate::ParamError;

/// Backtracking line search bounded by the first flip (ALGORITHMS 1.4,
/// Smith & Schaefer 2015).
///
/// Tries `a_0 = min(a_init, beta a_max)`, then `a_j = rho^j a_0`, and accepts
/// the first finite `phi(a_j)` with
///
/// - `armijo = Some(c)`: `phi(a) - phi(0) <= c a (g · d)` and
///   `phi(a) < phi(0)` (sufficient decrease, the default, `c = 1e-4`);
/// - `armijo = None`: `phi(a) < phi(0)` (plain decrease, the placenta
///   paper's rule).
///
/// The strict decrease is also required under Armijo so a step whose gain is
/// below floating-point resolution is not reported as progress. Candidates
/// `>= a_max` (possible only with `beta >= 1`) are skipped, never evaluated
/// nor returned. After `max_halvings` reductions without success it returns
/// `success: false`, step 0 and `value = phi(0)`; at most
/// `max_halvings + 1` evaluations are made.
///
/// Without an admissible start it fails at once (0 evaluations): `a_max <= 0`
/// (an element is already flat), `a_0` not finite (both `a_init` and `a_max`
/// infinite: give a finite `a_init`), `phi(0)` not finite, or, under Armijo,
/// `g · d >= 0` (not a descent direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backtracking {
    /// Fraction of `a_max` for the first step (0.9), in `(0, 1]`.
    pub beta: f64,
    /// Shrink factor per rejection (0.5), in `(0, 1)`.
    pub rho: f64,
    /// Armijo constant `c` in `(0, 1)` (`Some(1e-4)`), or `None` for plain
    /// decrease.
    pub armijo: Option<f64>,
    /// Maximum number of reductions by `rho` before giving up (60).
    pub max_halvings: usize,
}

impl Default for Backtracking {
    /// Armijo backtracking: `beta = 0.9`, `rho = 0.5`, `c = 1e-4`,
    /// 60 halvings.
    fn default() -> Self {
        Backtracking {
            beta: 0.9,
            rho: 0.5,
            armijo: Some(1e-4),
            max_halvings: 60,
        }
    }
}

impl Backtracking {
    /// The placenta paper's rule (Algorithm 1): `a = 0.9 a_max`, halve until
    /// the objective decreases at all (`armijo = None`), 60 halvings.
    pub fn paper() -> Self {
        Backtracking {
            armijo: None,
            ..Self::default()
        }
    }
}

impl LineSearch for Backtracking {
    /// `"armijo-backtracking"`, or `"backtracking"` for the paper's plain
    /// decrease rule.
    fn name(&self) -> &'static str {
        if self.armijo.is_some() {
            "armijo-backtracking"
        } else {
            "backtracking"
        }
    }

    /// Checks the parameters: `beta` in `(0, 1]`, `rho` in `(0, 1)`, the
    /// Armijo constant in `(0, 1)`. ([`LineSearch::search`] stays bounded
    /// and below `a_max` with any parameters, but may then never succeed.)
    fn validate(&self) -> Result<(), ParamError> {
        let setting = |name, value, expected| ParamError::Setting {
            name,
            value,
            expected,
        };
        if !(self.beta > 0.0 && self.beta <= 1.0) {
            return Err(setting("backtracking beta", self.beta, "in (0, 1]"));
        }
        if !(self.rho > 0.0 && self.rho < 1.0) {
            return Err(setting("backtracking rho", self.rho, "in (0, 1)"));
        }
        if let Some(c) = self.armijo
            && !(c > 0.0 && c < 1.0)
        {
            return Err(setting("Armijo constant", c, "in (0, 1)"));
        }
        Ok(())
    }

    fn search(
        &self,
        phi: &mut dyn FnMut(f64) -> f64,
        f0: f64,
        slope: f64,
        a_max: f64,
        a_init: f64,
    ) -> LineSearchResult {
        let fail = |evaluations| LineSearchResult::rejected(f0, evaluations);
        if !f0.is_finite() || a_max.is_nan() || a_max <= 0.0 || a_init.is_nan() || a_init <= 0.0 {
            return fail(0);
        }
        if self.armijo.is_some() && (slope.is_nan() || slope >= 0.0) {
            return fail(0);
        }
        let mut a = a_init.min(self.beta * a_max);
        if !a.is_finite() {
            return fail(0);
        }
        let mut evaluations = 0;
        for _ in 0..=self.max_halvings {
            if a > 0.0 && a < a_max {
                let value = phi(a);
                evaluations += 1;
                let accepted = value.is_finite()
                    && value < f0
                    && self.armijo.is_none_or(|c| value - f0 <= c * a * slope);
                if accepted {
                    return LineSearchResult::accepted(a, value, evaluations);
                }
            } else if a.is_nan() || a <= 0.0 {
                break;
            }
            a *= self.rho;
        }
        fail(evaluations)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linesearch::roots::tests::log_uniform;
    use proptest::prelude::*;

    // ----- backtracking -----

    #[test]
    fn backtracking_defaults() {
        let b = Backtracking::default();
        assert_eq!(
            (b.beta, b.rho, b.armijo, b.max_halvings),
            (0.9, 0.5, Some(1e-4), 60)
        );
        let p = Backtracking::paper();
        assert_eq!((p.beta, p.rho, p.armijo), (0.9, 0.5, None));
        assert!(b.validate().is_ok() && p.validate().is_ok());
        assert!(Backtracking { rho: 1.0, ..b }.validate().is_err());
        assert!(Backtracking { beta: 0.0, ..b }.validate().is_err());
        assert!(
            Backtracking {
                armijo: Some(1.5),
                ..b
            }
            .validate()
            .is_err()
        );
    }

    #[test]
    fn backtracking_accepts_newton_step() {
        // phi(a) = (a - 1)^2: the full step is optimal.
        let mut phi = |a: f64| (a - 1.0) * (a - 1.0);
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, f64::INFINITY, 1.0);
        assert_eq!(
            r,
            LineSearchResult {
                step: 1.0,
                value: 0.0,
                evaluations: 1,
                success: true
            }
        );
        // Bounded by a_max: starts at 0.9 a_max.
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, 0.3, 1.0);
        assert!(r.success && r.step == 0.9 * 0.3 && r.evaluations == 1);
        // Too long a first step: halved until Armijo holds.
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, f64::INFINITY, 8.0);
        assert!(r.success && r.step == 1.0 && r.evaluations == 4);
    }

    #[test]
    fn backtracking_gives_up_on_a_function_that_never_decreases() {
        for ls in [Backtracking::default(), Backtracking::paper()] {
            let mut calls = 0;
            let mut phi = |a: f64| {
                calls += 1;
                1.0 + a
            };
            let r = ls.search(&mut phi, 1.0, -1.0, 10.0, 1.0);
            assert_eq!(
                r,
                LineSearchResult {
                    step: 0.0,
                    value: 1.0,
                    evaluations: 61,
                    success: false
                }
            );
            assert_eq!(calls, 61);
            // A constant: no decrease at all, even below resolution.
            let r = ls.search(&mut |_| 1.0, 1.0, -1.0, 10.0, 1.0);
            assert!(!r.success && r.step == 0.0);
        }
    }

    #[test]
    fn backtracking_handles_infinity_and_nan() {
        // Admissible only below 0.1 (a barrier energy past a flip).
        let mut phi = |a: f64| {
            if a > 0.1 {
                f64::INFINITY
            } else {
                (a - 1.0).powi(2)
            }
        };
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, f64::INFINITY, 1.0);
        assert!(r.success && r.step <= 0.1 && r.value.is_finite());
        assert_eq!(r.step, 0.0625);
        let mut phi = |a: f64| if a > 0.3 { f64::NAN } else { 1.0 - a };
        let r = Backtracking::paper().search(&mut phi, 1.0, -1.0, f64::INFINITY, 1.0);
        assert!(r.success && r.step == 0.25);
    }

    #[test]
    fn backtracking_paper_rule_vs_armijo() {
        // A decrease far weaker than the slope promises.
        let mut phi = |a: f64| 1.0 - 1e-9 * a;
        let r = Backtracking::paper().search(&mut phi, 1.0, -1.0, f64::INFINITY, 1.0);
        assert!(r.success && r.step == 1.0);
        let r = Backtracking::default().search(&mut phi, 1.0, -1.0, f64::INFINITY, 1.0);
        assert!(!r.success && r.evaluations == 61);
    }

    #[test]
    fn backtracking_inadmissible_starts() {
        let mut phi = |a: f64| (a - 1.0).powi(2);
        let ls = Backtracking::default();
        let failed = |r: LineSearchResult| !r.success && r.step == 0.0 && r.evaluations == 0;
        assert!(failed(ls.search(&mut phi, 1.0, -2.0, 0.0, 1.0)));
        assert!(failed(ls.search(
            &mut phi,
            1.0,
            -2.0,
            f64::INFINITY,
            f64::INFINITY
        )));
        assert!(failed(ls.search(&mut phi, f64::INFINITY, -2.0, 1.0, 1.0)));
        assert!(failed(ls.search(&mut phi, 1.0, 2.0, 1.0, 1.0)));
        assert!(failed(ls.search(&mut phi, 1.0, f64::NAN, 1.0, 1.0)));
        // beta = 1 never reaches a_max; rho >= 1 stays bounded.
        let r = Backtracking { beta: 1.0, ..ls }.search(&mut phi, 1.0, -2.0, 0.5, 5.0);
        assert!(r.success && r.step == 0.25);
        let r = Backtracking {
            beta: 1.0,
            rho: 1.0,
            max_halvings: 5,
            ..ls
        }
        .search(&mut phi, 1.0, -2.0, 0.5, 5.0);
        assert!(!r.success && r.evaluations == 0);
        let r = Backtracking { rho: 2.0, ..ls }.search(&mut |_| 2.0, 1.0, -2.0, 0.5, 0.1);
        assert!(!r.success && r.evaluations <= 61);
    }

    proptest! {
        #[test]
        fn backtracking_satisfies_its_rule(
            curvature in log_uniform(-3.0, 3.0),
            slope in -10.0f64..-1e-3,
            a_max in prop_oneof![Just(f64::INFINITY), log_uniform(-3.0, 2.0)],
            a_init in log_uniform(-2.0, 2.0),
            barrier in prop_oneof![Just(f64::INFINITY), log_uniform(-3.0, 1.0)],
            armijo in any::<bool>(),
        ) {
            // phi(a) = f0 + slope a + curvature a^2 / 2, infinite past the barrier.
            let f0 = 3.0;
            let mut evals = 0;
            let mut phi = |a: f64| {
                evals += 1;
                if a >= barrier { f64::INFINITY } else { f0 + slope * a + 0.5 * curvature * a * a }
            };
            let ls = if armijo { Backtracking::default() } else { Backtracking::paper() };
            let r = ls.search(&mut phi, f0, slope, a_max, a_init);
            prop_assert_eq!(r.evaluations, evals);
            prop_assert!(r.evaluations <= ls.max_halvings + 1);
            // A descent direction on a smooth function always succeeds.
            prop_assert!(r.success);
            prop_assert!(r.step > 0.0 && r.step < a_max && r.step <= ls.beta * a_max);
            prop_assert!(r.step <= a_init && r.step < barrier);
            prop_assert!(r.value < f0);
            if armijo {
                prop_assert!(r.value - f0 <= 1e-4 * r.step * slope);
            }
            // The previous (doubled) candidate was rejected.
            if r.evaluations > 1 {
                let prev = r.step / ls.rho;
                let v = if prev >= barrier { f64::INFINITY } else { f0 + slope * prev + 0.5 * curvature * prev * prev };
                let ok = v.is_finite() && v < f0 && (!armijo || v - f0 <= 1e-4 * prev * slope);
                prop_assert!(!ok);
            }
        }
    }
}
