//! The error types of unfold-organs.
//!
//! [`OrganError`] is what every pipeline returns. It carries no free text:
//! each failure is a variant of the organ's own error type (or of
//! [`ConfigError`] for a setting out of range) holding the indices and
//! numbers that explain it, so a caller can `match` on "vertex out of range"
//! as against "a longitude starts off the annulus" (parry's style). Each
//! message is one line a user can act on.

use crate::gate::GateError;
use crate::mitral::MitralError;
use crate::placenta::error::PlacentaError;
use crate::ventricle::error::VentricleError;
use thiserror::Error;
use unfold_linalg::LinalgError;
use unfold_mesh::MeshError;
use unfold_param::ParamError;

/// Everything that can go wrong in an organ pipeline.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum OrganError {
    /// The input mesh is unusable (validation failed).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The parameterization framework failed (setup or solve).
    #[error(transparent)]
    Param(#[from] ParamError),
    /// A linear-algebra step called by the pipeline itself failed (the
    /// ventricle's Laplace field, the mitral layout's Dirichlet solve, the
    /// placenta's affinity matrix).
    #[error(transparent)]
    Linalg(#[from] LinalgError),
    /// A setting is out of its range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The mitral valve pipeline rejected its input (see [`MitralError`]).
    #[error(transparent)]
    Mitral(#[from] MitralError),
    /// The placenta pipeline failed (mesh shape, parcellation, pull-back).
    #[error(transparent)]
    Placenta(#[from] PlacentaError),
    /// The ventricle pipeline failed (landmarks, disk map, field, mapping).
    #[error(transparent)]
    Ventricle(#[from] VentricleError),
    /// A quality gate failed: a stage's result is one a right map cannot
    /// have (see [`crate::gate`]).
    #[error(transparent)]
    Gate(#[from] GateError),
}

/// What a setting must satisfy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Requirement {
    /// Finite and `> 0`.
    Positive,
    /// Finite and `>= 0`.
    NonNegative,
    /// Finite and `>= min`.
    AtLeast(f64),
    /// Finite and in `[min, max]`.
    Within(f64, f64),
    /// Finite and in `(min, max)`.
    Between(f64, f64),
    /// An integer count `>= min`.
    CountAtLeast(usize),
    /// An integer in `min..=max`.
    CountWithin(usize, usize),
    /// Finite and in `[min, max)`.
    WithinHalfOpen(f64, f64),
}

impl std::fmt::Display for Requirement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Requirement::Positive => write!(f, "finite and > 0"),
            Requirement::NonNegative => write!(f, "finite and >= 0"),
            Requirement::AtLeast(min) => write!(f, "finite and >= {min}"),
            Requirement::Within(lo, hi) => write!(f, "in [{lo}, {hi}]"),
            Requirement::Between(lo, hi) => write!(f, "in ({lo}, {hi})"),
            Requirement::CountAtLeast(min) => write!(f, ">= {min}"),
            Requirement::CountWithin(lo, hi) => write!(f, "in {lo}..={hi}"),
            Requirement::WithinHalfOpen(lo, hi) => write!(f, "in [{lo}, {hi})"),
        }
    }
}

impl Requirement {
    /// Whether `value` meets the requirement.
    pub fn holds(self, value: f64) -> bool {
        value.is_finite()
            && match self {
                Requirement::Positive => value > 0.0,
                Requirement::NonNegative => value >= 0.0,
                Requirement::AtLeast(min) => value >= min,
                Requirement::Within(lo, hi) => (lo..=hi).contains(&value),
                Requirement::Between(lo, hi) => value > lo && value < hi,
                Requirement::CountAtLeast(min) => value >= min as f64,
                Requirement::CountWithin(lo, hi) => (lo as f64..=hi as f64).contains(&value),
                Requirement::WithinHalfOpen(lo, hi) => value >= lo && value < hi,
            }
    }
}

/// A setting of a pipeline is out of its range: "invalid configuration:
/// `name` must be `requirement`, got `value`".
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[error("invalid configuration: {name} must be {requirement}, got {value}")]
pub struct ConfigError {
    /// The setting (as the library names it, e.g. `lambda`).
    pub name: &'static str,
    /// The value given.
    pub value: f64,
    /// What it must be.
    pub requirement: Requirement,
}

impl ConfigError {
    /// Checks one setting.
    ///
    /// # Errors
    /// [`ConfigError`] when `value` does not meet `requirement`.
    pub fn check(name: &'static str, value: f64, requirement: Requirement) -> Result<(), Self> {
        if requirement.holds(value) {
            Ok(())
        } else {
            Err(ConfigError {
                name,
                value,
                requirement,
            })
        }
    }

    /// Checks that every `(name, value)` is finite and `> 0`; the error
    /// names the first that is not.
    ///
    /// # Errors
    /// [`ConfigError`] with [`Requirement::Positive`].
    pub fn check_positive(values: &[(&'static str, f64)]) -> Result<(), Self> {
        values
            .iter()
            .try_for_each(|&(name, value)| Self::check(name, value, Requirement::Positive))
    }
}

impl OrganError {
    /// A [`ParamError::Piece`] that carries an [`OrganError`] becomes that
    /// error again (an organ initializer's typed failure, passed through
    /// the framework); any other `ParamError` is [`OrganError::Param`].
    pub fn from_param(e: ParamError) -> OrganError {
        if let ParamError::Piece { error, .. } = &e
            && let Some(organ) = error.downcast_ref::<OrganError>()
        {
            return organ.clone();
        }
        OrganError::Param(e)
    }

    /// [`ConfigError::check_positive`] as an [`OrganError`].
    pub(crate) fn check_positive(values: &[(&'static str, f64)]) -> Result<(), OrganError> {
        Ok(ConfigError::check_positive(values)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_errors_name_the_setting_and_the_requirement() {
        let e = ConfigError::check_positive(&[("lambda", 1.0), ("grad_tol", -2.0)]).unwrap_err();
        assert_eq!(e.name, "grad_tol");
        assert_eq!(
            e.to_string(),
            "invalid configuration: grad_tol must be finite and > 0, got -2"
        );
        assert!(ConfigError::check("x", f64::NAN, Requirement::NonNegative).is_err());
        assert!(ConfigError::check("x", 0.0, Requirement::NonNegative).is_ok());
        assert!(ConfigError::check("x", 1.0, Requirement::Between(0.0, 1.0)).is_err());
        assert!(ConfigError::check("x", 1.0, Requirement::Within(0.0, 1.0)).is_ok());
        assert!(ConfigError::check("n", 2.0, Requirement::CountAtLeast(3)).is_err());
        let e = ConfigError::check("rings", 0.0, Requirement::CountWithin(1, 6)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid configuration: rings must be in 1..=6, got 0"
        );
        assert!(ConfigError::check("rings", 6.0, Requirement::CountWithin(1, 6)).is_ok());
        let e = ConfigError::check("f", 1.0, Requirement::WithinHalfOpen(0.0, 1.0)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid configuration: f must be in [0, 1), got 1"
        );
        assert!(ConfigError::check("f", 0.0, Requirement::WithinHalfOpen(0.0, 1.0)).is_ok());
    }
}
