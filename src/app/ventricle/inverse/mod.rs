//! `ventricle-inverse`: a mesh given in the normalized coordinates of the
//! cylinder carried back onto a heart, `v = psi^-1(xi, zeta, depth)`
//! (ALGORITHMS 3.4; the source paper's Algorithm 2, §3.5).
//!
//! The mesh is any mesh file (points, lines, triangles, tets). Its points'
//! cylinder coordinates are read by [`Coordinates`]:
//!
//! - `arrays`: the point arrays `xi`, `zeta` (the harmonic disk position
//!   `phi(v_S)`) and `depth`, as `unfold ventricle` writes them into
//!   `normalized.vtu`;
//! - `points`: the points themselves as `(X, Y, depth)`, `(X, Y)` the
//!   *displayed* disk position (the LV disk warped by `r' = r^n`, the
//!   display exponent `n`, which is inverted: `r = r'^(1/n)`; the RV half
//!   disk as it is), as `normalized.vtu`'s points are. Regions drawn on
//!   the displayed disk or the bull's-eye are given this way;
//! - `auto` (default): the arrays when the mesh has all three, else the
//!   points (one or two of the arrays alone is an error).
//!
//! The chart of the target heart is built from S and its landmarks with
//! the chart settings of `unfold ventricle` ([`super::ChartSettings`],
//! [`super::HeartLandmarks`]). Every point is mapped by
//! [`crate::organs::ventricle::Chart::inverse`] on its own: one that cannot
//! be mapped (depth outside `[0, 1]`, a disk position outside the
//! flattened S, a failed streamline) gets a status instead of failing the
//! run, and is placed at the centre of the base (the centre of H, where no
//! mapped point lies; mesh files cannot hold NaN); all points failing is an
//! error.
//!
//! Outputs in the output directory (created if missing), each written
//! atomically:
//!
//! - `mapped.vtu`: the input's cells and every point and cell array
//!   (label fields come along), the points at `psi^-1`, in RAS mm; point
//!   arrays `inverse_status` (0 mapped, 1 not a cylinder point, 2 off the
//!   disk, 3 streamline failed), `xi`, `zeta`, `depth` (the coordinates
//!   used) and with `layers` N `layer` (1 at S to N at H, 0 for a point
//!   not mapped); the points not mapped at the centre of the base;
//! - `report.json`: the points, how many were mapped, the failures per
//!   reason and the first ones with their messages, the chart's settings
//!   and landmarks, seconds, memory and provenance ([`InverseReport`]).

pub mod coordinates;
pub mod inputs;
pub mod report;
pub mod run;
pub mod settings;
pub mod write;

pub use coordinates::{Coordinates, Source};
pub use inputs::{Files, Inputs, read};
pub use report::InverseReport;
pub use run::{Run, run};
pub use settings::Settings;
pub use write::{Outputs, write};
