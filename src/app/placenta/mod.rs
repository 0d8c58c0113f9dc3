//! The placenta: a tet mesh (or a mask to mesh) flattened onto a canonical
//! template (ALGORITHMS 2), images pulled into the template frame.
//!
//! The pipeline is [`crate::organs::placenta::Pipeline`]: it minimizes
//!
//! ```text
//! phi(X, theta) = sum_{m in boundary} A_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! ```
//!
//! (`T` the template term of the fetal, maternal and margin boundary
//! vertices, `D` the distortion energy), flip-free, and evaluates the map.
//! Every image is then resampled on an axis-aligned grid covering the
//! flattened mesh (ALGORITHMS 2.7), one pull-back table per distinct grid
//! spacing, shared by all frames of a 4D series and by all images with that
//! spacing.
//!
//! A run is [`Settings`] (checked once, [`Settings::validate`]), its
//! [`Files`] checked ([`Files::check`]) and read into [`Inputs`]
//! ([`read`]: the mesh repaired and oriented, or a mask meshed, then every
//! image), [`run`] (or [`run_with`] other pieces) into a [`Run`] with its
//! typed [`PlacentaReport`], and [`write`] into a staged output directory:
//!
//! - `original.vtu`: the input (tets oriented positively) with the point
//!   array `side` (0 interior, 1 fetal, 2 maternal, 3 margin);
//! - `flattened.vtu`: the mapped mesh in the template frame, point array
//!   `side`, cell arrays `log2_det_j` and `sym_dirichlet`;
//! - `<name>_flat.nii.gz` for every image `<name>.nii[.gz]` (or `.nrrd`,
//!   `.seg.nrrd`, `.nhdr`);
//! - `report.json`: the library's report plus `mesh` (the input),
//!   `segmentation`, `displacement`, `memory` and `provenance`;
//! - `mesh.vtu` with a mask, `lambda_sweep.csv` with a sweep, the figures.
//!
//! Tets with a negative orientation are reoriented (a repair that is
//! reported, not an error).

pub mod errors;
pub mod inputs;
pub mod lambda_sweep;
pub mod memory;
pub mod pushback;
pub mod report;
pub mod run;
pub mod seg;
pub mod seg_prediction;
pub mod settings;
pub mod write;

pub use errors::{organ, pipeline_error};
pub use inputs::{Files, ImageInput, Inputs, read};
pub use report::{DisplacementReport, PlacentaReport};
pub use run::{Run, run, run_with};
pub use seg::SegReport;
pub use settings::{Settings, hold_half_thickness};
pub use write::{Outputs, write};
