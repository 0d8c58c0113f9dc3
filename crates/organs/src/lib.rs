//! unfold-organs: the placenta, ventricle and mitral-valve pipelines, built
//! from the pieces of `unfold-param`. It does no file I/O.
//!
//! The pipelines arrive with their own issues; for now the crate fixes the
//! dependency direction (`organs -> param, mesh`).

pub use unfold_mesh as mesh;
pub use unfold_param as param;
