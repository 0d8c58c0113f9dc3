//! The settings of a deformation: every choice other than its files, with
//! the command line's defaults, checked once (the same checks and messages
//! for the command line and Python).

use crate::app::error::AppError;
use crate::param::energy::EnergyKind;
use crate::param::solver::SolverKind;
use serde::{Deserialize, Serialize};

/// A deformation's settings; the names are the command line's flags
/// (`max_iterations` is `--max-iterations`, a manifest's
/// `max-iterations`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// `W` of the target term `W sum_b |x_b - t_b|^2`.
    pub weight: f64,
    /// The distortion energy `D`.
    pub energy: EnergyKind,
    /// The solver.
    pub solver: SolverKind,
    /// Stop when the gradient norm falls below this.
    pub tol: f64,
    /// The iteration limit (none: [`Settings::iteration_limit`]'s default).
    pub max_iterations: Option<usize>,
}

/// Newton's default iteration limit for a deformation: a map just out of
/// the untangler (some elements barely positive) with a distortion far
/// from its rest shape converges slowly at first (the TLC-PN benchmark
/// example took 359 iterations).
pub const NEWTON_ITERATIONS: usize = 1000;

impl Default for Settings {
    /// The command line's defaults: W = 1, symmetric Dirichlet, Newton,
    /// tol 1e-4, [`Settings::iteration_limit`]'s default.
    fn default() -> Self {
        Settings {
            weight: 1.0,
            energy: EnergyKind::SymmetricDirichlet,
            solver: SolverKind::Newton,
            tol: 1e-4,
            max_iterations: None,
        }
    }
}

impl Settings {
    /// The iteration limit: `max_iterations`, else
    /// [`NEWTON_ITERATIONS`] for Newton and the solver's default otherwise.
    pub fn iteration_limit(&self) -> usize {
        self.max_iterations.unwrap_or_else(|| match self.solver {
            SolverKind::Newton => NEWTON_ITERATIONS,
            other => other.build().default_stopping().max_iterations,
        })
    }

    /// Checks every setting.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag: a weight or tolerance not
    /// finite and positive.
    pub fn validate(&self) -> Result<(), AppError> {
        if !(self.weight.is_finite() && self.weight > 0.0) {
            return Err(AppError::Usage(format!(
                "--weight must be a finite positive number, got {}",
                self.weight
            )));
        }
        if !(self.tol.is_finite() && self.tol > 0.0) {
            return Err(AppError::Usage(format!(
                "--tol must be a finite positive number, got {}",
                self.tol
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_name_their_flags() {
        Settings::default().validate().unwrap();
        let bad = |s: Settings| s.validate().unwrap_err().to_string();
        assert_eq!(
            bad(Settings {
                weight: 0.0,
                ..Settings::default()
            }),
            "--weight must be a finite positive number, got 0"
        );
        assert_eq!(
            bad(Settings {
                tol: f64::INFINITY,
                ..Settings::default()
            }),
            "--tol must be a finite positive number, got inf"
        );
    }

    #[test]
    fn names_are_the_flags() {
        let v = serde_json::to_value(Settings::default()).unwrap();
        for key in ["weight", "energy", "solver", "tol", "max-iterations"] {
            assert!(v.get(key).is_some(), "{key} missing from {v}");
        }
        let s: Settings =
            serde_json::from_value(serde_json::json!({"energy": "arap", "weight": 2.0})).unwrap();
        assert_eq!((s.energy, s.weight), (EnergyKind::Arap, 2.0));
        assert_eq!(s.solver, SolverKind::Newton);
    }
}
