//! unfold-param: the parameterization framework (energies, templates,
//! initializers, injective line searches, solvers, metrics).
//!
//! The framework itself arrives with its own issue; for now the crate only
//! re-exports the mesh types it builds on, so the dependency direction of the
//! workspace (`param -> mesh`) is in place.

pub use unfold_mesh as mesh;
