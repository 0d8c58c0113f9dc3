//! The ventricle: the anatomy inside a heart chamber carried into the
//! canonical cylinder (ALGORITHMS 3), and back from it ([`inverse`]).
//!
//! The pipeline is [`crate::organs::ventricle::Pipeline`]: S (a triangle mesh
//! with disk topology, its one boundary loop the basal rim) is flattened to
//! the unit disk (LV) or half disk (RV) with the landmarks in place, the
//! Laplace field between S and the hemisphere H is solved on a grid, and
//! every anatomy point `v` goes to
//!
//! ```text
//! psi(v) = (phi(v_S), d(v)),   d(v) = len(v_S -> v) / len(v_S -> v_H)
//! ```
//!
//! (`v_S`, `v_H` the ends of the streamline through `v` on S and H), and
//! back (`psi^-1`, the round-trip error). The anatomy is any mesh file:
//! triangles, tets or bare points (VTK `VERTICES`, a PLY without faces);
//! only its points are mapped, its cells are kept.
//!
//! A run is [`Settings`] (checked once, [`Settings::validate`]), its
//! [`Files`] checked ([`Files::check`]) and read into [`Inputs`] ([`read`]:
//! the anatomy, S read or built from the anatomy ([`surface`]), the
//! landmarks ([`landmarks`]), the second heart of a transfer), [`run`] into
//! a [`Run`] with its typed [`VentricleReport`], and [`write`] into a
//! staged output directory (each file atomically):
//!
//! - `normalized.vtu`: the anatomy in the cylinder, points `(X, Y, depth)`
//!   with `(X, Y)` the displayed disk position; point arrays `xi`, `zeta`,
//!   `depth` and (LV) `aha`;
//! - `anatomy.vtu`: the input anatomy with the same arrays;
//! - `disk.vtu`: S flattened (`z = 0`), arrays `xi`, `zeta`;
//! - `transferred.vtu` with a second heart: the anatomy carried into it,
//!   `psi_2^-1(psi(v))`, with the arrays of `anatomy.vtu`;
//! - `surface.vtu` without a surface file: S built from the anatomy;
//! - `aha_segments.csv` (LV): the anatomy's arrays per AHA segment
//!   ([`aha_segments`]);
//! - `report.json`: the library's report, the inputs, (with a transfer)
//!   `transfer` and (with a built S) `enclosing_surface`;
//! - with `sensitivity`, the point arrays `sensitivity_mm`,
//!   `sensitivity_disk`, `sensitivity_depth` in `normalized.vtu` and
//!   `anatomy.vtu`, `sensitivity` in `report.json` and
//!   `figures/sensitivity.png` ([`sensitivity`]);
//! - with `grid_sweep` ([`grid_sweep`], run after the main set is
//!   written), `grid_sweep.csv` and `figures/grid_sweep.png`.
//!
//! The landmarks come from points or from a 3D Slicer markups file (points
//! labelled `anterior`, `inferior`, `apex`). S may have several openings:
//! the basal rim is the one nearest the rim landmarks (or `rim_near`), the
//! others are capped; `report.json` lists them under `openings`.
//!
//! An anatomy without cells is written with one VTK vertex cell per point,
//! so that viewers show it. Progress lines (`ventricle: ...`) go to the
//! observer's [`crate::app::observer::Observer::progress`].

pub mod aha_segments;
pub mod grid_sweep;
pub mod inputs;
pub mod inverse;
pub mod landmarks;
pub mod layers;
pub mod report;
pub mod run;
pub mod sensitivity;
pub mod settings;
pub mod surface;
pub mod write;

pub use inputs::{Files, Inputs, Transfer, hemisphere, read, read_surface};
pub use landmarks::HeartLandmarks;
pub use layers::{MAX_LAYERS, transmural_layers};
pub use report::{ReportInputs, TransferReport, VentricleReport};
pub use run::{Run, run};
pub use settings::{ChartSettings, Settings};
pub use surface::EnclosingSettings;
pub use write::{Outputs, with_vertex_cells, write};
