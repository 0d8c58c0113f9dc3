//! The error type of unfold-organs.

use thiserror::Error;
use unfold_mesh::MeshError;
use unfold_param::ParamError;

/// Everything that can go wrong in an organ pipeline. Messages are one line
/// a user can act on (what was wrong, what was expected).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum OrganError {
    /// The input mesh is unusable (validation failed).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The parameterization framework failed (setup or solve).
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The input does not fit the pipeline (a surface where a volume is
    /// needed, too few vertices, ...).
    #[error("{0}")]
    Input(String),
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The boundary could not be split into fetal and maternal sides.
    #[error("parcellation: {0}")]
    Parcellation(String),
    /// An image cannot be used (does not overlap the mesh, empty, ...).
    #[error("image: {0}")]
    Image(String),
}

impl OrganError {
    /// [`OrganError::Config`] for the first `(name, value)` that is not
    /// finite and `> 0`: "`name` must be finite and > 0, got `value`".
    pub(crate) fn check_positive(values: &[(&str, f64)]) -> Result<(), OrganError> {
        match values.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            Some((name, value)) => Err(OrganError::Config(format!(
                "{name} must be finite and > 0, got {value}"
            ))),
            None => Ok(()),
        }
    }
}
