//! unfold-organs: the placenta, ventricle and mitral-valve pipelines, built
//! from the pieces of `unfold-param`. It does no file I/O: inputs and
//! outputs are in-memory meshes, images and reports.
//!
//! - [`placenta`]: volumetric flattening of a placenta tet mesh onto two
//!   parallel planes, an ellipsoid or a single plane (ALGORITHMS 2), with
//!   the boundary parcellation and the image pull-back.
//! - [`mitral`]: the mitral valve's leaflets laid out below their annulus
//!   in 2D, flip-free, with clinical maps and measurements (ALGORITHMS 4).
//! - [`ventricle`] (in progress): the chamber's enclosing surface flattened
//!   to the disk with its landmarks (ALGORITHMS 3.1, 3.2).

mod error;
pub mod mitral;
pub mod placenta;
pub mod ventricle;

pub use error::{ConfigError, OrganError, Requirement};
pub use unfold_mesh as mesh;
pub use unfold_param as param;
