//! The ventricle pipeline (ALGORITHMS 3): the anatomy inside a heart
//! chamber carried into a canonical cylinder. The enclosing surface S (a
//! triangle mesh with disk topology, its boundary loop the basal rim) is
//! flattened to the unit disk (LV) or half disk (RV) with the landmarks in
//! place; the Laplace field between S and a hemisphere H on the base gives
//! streamlines, and a point `v` goes to `psi(v) = (phi(v_S), d(v))`, with
//! `v_S` where its streamline meets S and `d` the normalized arc length.
//!
//! - [`landmarks`]: the two rim landmarks snapped to boundary vertices, the
//!   apex (given and snapped, or the vertex farthest from the rim centroid).
//! - [`openings`]: the basal rim among S's boundary loops, the others
//!   capped so that S is a disk.
//! - [`enclosing`]: S built from the anatomy when none is given (voxelize,
//!   dilate, fill, marching tetrahedra, Taubin smoothing, cut at the basal
//!   plane).
//! - [`base`]: S closed down to a planar base (a strip under a tilted rim).
//! - [`disk`]: the LV disk map `phi: S -> D` (harmonic map with arc-length
//!   boundary, the landmarks' bisector along +x, a thin-plate-spline warp
//!   taking the apex to the centre, a Mobius warp where that folds, the
//!   optional display exponent) and the RV half disk.
//! - [`field`]: the Laplace field on a grid (multigrid CG) and the one
//!   continuous interpolant of `grad f`.
//! - [`trace`]: streamlines by Dormand-Prince 5(4) with error control, ended
//!   exactly on S and H.
//! - [`map`]: a [`Chart`] of one heart: `psi`, `psi^-1`, transfer.
//! - [`aha`]: the AHA 17-segment label of an LV disk position.
//! - [`rings_meridians`]: the paper's cup check, rings to circles and
//!   meridians to rays.
//! - [`harmonic_disk`]: [`HarmonicDisk`], the default disk initializer.
//! - [`pipeline`]: [`Pipeline`], the whole pipeline with its outputs and
//!   report, built from its disk map.
//! - [`error`]: [`VentricleError`] and [`PointFailure`], what can go wrong.

pub mod aha;
pub mod base;
pub mod disk;
pub mod enclosing;
pub mod error;
pub mod field;
pub mod harmonic_disk;
pub mod landmarks;
pub mod map;
pub mod openings;
pub mod pipeline;
pub mod rings_meridians;
pub mod rv_landmarks;
pub mod trace;

pub use error::{PointFailure, VentricleError};
pub use harmonic_disk::HarmonicDisk;
pub use map::{Chamber, Chart, ChartConfig, CylinderPoint, ForwardPoint};
pub use pipeline::{Config, LandmarkPoints, Outcome, Pipeline, Report};
