//! Initializers: valid (non-inverted) starting maps.

use crate::{ParamError, ParamMesh};

/// Produces a starting map for a [`ParamMesh`]: a flat vector of
/// `mesh.dim()` coordinates per vertex in which no element is inverted.
pub trait Initializer: Send + Sync + std::fmt::Debug {
    /// A short name.
    fn name(&self) -> &'static str;
    /// The starting positions.
    fn initialize(&self, mesh: &ParamMesh) -> Result<Vec<f64>, ParamError>;
}
