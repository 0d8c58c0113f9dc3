//! The placenta pipeline (ALGORITHMS 2): flatten a tet mesh of the placenta
//! onto a template by minimizing
//!
//! ```text
//! phi(X, theta) = sum_{m in boundary} A_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! ```
//!
//! (`A_m` normalized boundary vertex areas, `V_k` normalized rest volumes,
//! `D` the symmetric Dirichlet energy by default), flip-free, then evaluate
//! the map and pull images into the template.
//!
//! [`Pipeline`] is the whole method as a value built from its pieces (a
//! [`PlacentaTemplate`], a distortion energy, an initializer, a line search,
//! a solver); its steps are public so that a pipeline can be composed from
//! code:
//!
//! 1. [`prepare_mesh`]: validate, fix tet orientation (reported);
//! 2. [`parcellation::parcellate`]: fetal side, maternal side and margin
//!    (the labels of [`side`]);
//! 3. the initializer ([`PcaAlignment`]: PCA frame, fetal side up) and
//!    [`estimate::estimate`]: the initial map and `h` / radii;
//! 4. [`optimize::optimize`]: one stage per template (the single plane
//!    starts from the planes result);
//! 5. [`evaluate::evaluate`]: the figures of ALGORITHMS 2.6, and the
//!    solve's quality gates ([`solve_gates`]; the side split's are in
//!    [`parcellation`]), all listed in the report's `gates`;
//! 6. [`images`]: images into the template grid ([`pullback`]); and back:
//!    [`pushback`] carries template-space images onto a scanner grid.

pub mod align;
pub mod canonical;
pub mod config;
pub mod displacement;
pub mod error;
pub mod estimate;
pub mod evaluate;
pub mod frame_check;
pub mod images;
pub mod memory;
pub mod optimize;
pub mod parcellation;
mod pipeline;
pub mod prepare;
pub mod pullback;
pub mod pushback;
pub mod report;
pub mod segmentation;
pub mod solve_gates;
pub mod templates;

pub use align::{Alignment, PcaAlignment, TransformReport};
pub use canonical::{TemplateSymmetry, canonical_motion};
pub use config::{Config, GridBox};
pub use error::{PlacentaError, PullbackError};
pub use images::{FlatImage, Image};
pub use pipeline::{Outcome, Pipeline};
pub use prepare::{PreparedMesh, boundary_weights, prepare_mesh};
pub use pullback::Interpolation;
pub use report::{CanonicalReport, ImageReport, Pieces, Report};
pub use templates::{Ellipsoid, Held, ParallelPlanes, PlacentaTemplate, SinglePlane, TemplateKind};
pub use unfold_mesh::shapes::side;
