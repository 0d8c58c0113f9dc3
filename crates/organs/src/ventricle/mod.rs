//! The ventricle pipeline (ALGORITHMS 3), in progress: the enclosing
//! surface S of a heart chamber (a triangle mesh with disk topology, its one
//! boundary loop the basal rim) is flattened to the unit disk with the
//! landmarks in place; the Laplace field, the streamlines into the cylinder,
//! the inverse map and the AHA-17 labels come next.
//!
//! - [`landmarks`]: the two rim landmarks snapped to boundary vertices, the
//!   apex (given and snapped, or the vertex farthest from the rim centroid).
//! - [`disk`]: the LV disk map `phi: S -> D` (harmonic map with arc-length
//!   boundary, the landmarks' bisector along +x, a thin-plate-spline warp
//!   taking the apex to the centre, a Mobius warp where that folds, the
//!   optional display exponent) and the RV half disk.
//! - [`aha`]: the AHA 17-segment label of an LV disk position.

pub mod aha;
pub mod base;
pub mod disk;
pub mod field;
pub mod landmarks;
pub mod map;
pub mod pipeline;
pub mod trace;

pub use map::{Chamber, Chart, ChartConfig, CylinderPoint, ForwardPoint};
pub use pipeline::{Config, LandmarkPoints, Outcome, Report, run};
