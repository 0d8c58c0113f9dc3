//! unfold-organs: the placenta, ventricle and mitral-valve pipelines, built
//! from the pieces of `unfold-param`. It does no file I/O: inputs and
//! outputs are in-memory meshes, images and reports.
//!
//! - [`placenta`]: volumetric flattening of a placenta tet mesh onto two
//!   parallel planes, an ellipsoid or a single plane (ALGORITHMS 2), with
//!   the boundary parcellation and the image pull-back.
//! - [`mitral`]: the mitral valve's leaflets laid out below their annulus
//!   in 2D, flip-free, with clinical maps and measurements (ALGORITHMS 4).
//! - [`gate`]: quality gates, the checks after each stage that a wrong
//!   result cannot pass, each listed in `report.json`.
//! - [`ventricle`]: the chamber's enclosing surface flattened to the disk
//!   with its landmarks, the anatomy carried along Laplace streamlines into
//!   a cylinder (ALGORITHMS 3).

mod error;
pub mod gate;
pub mod mitral;
mod observer;
pub mod placenta;
pub mod ventricle;

pub use error::{ConfigError, OrganError, Requirement};
pub use observer::{PipelineObserver, Quiet};
pub use unfold_mesh as mesh;
pub use unfold_param as param;
