//! The mitral valve laid out in 2D (ALGORITHMS 4): the annulus first (arc
//! length and height above its plane), the leaflets below it, relaxed
//! flip-free; clinical maps and measurements.
//!
//! The pipeline is [`crate::organs::mitral::Pipeline`]. A run is
//! [`Settings`] (checked once into the pipeline, [`Settings::pipeline`]),
//! its [`Files`] checked ([`Files::check`]: one valve's [`ValveFiles`], or
//! a series directory's steps) and read into [`Inputs`] ([`read`]: the
//! leaflets, then the annulus ring from its file or from the places where
//! the leaflets' boundaries meet), [`run()`] (or [`run_with`] other pieces)
//! into a [`Run`] with its typed [`MitralReport`], and [`write()`] into a
//! staged output directory ([`run_valve`] does all three):
//!
//! - `valve3d.vtu`: both leaflets, anterior first, with every map as a
//!   point or cell array;
//! - `valve2d.vtu`: the same at `(u, v, 0)`;
//! - `report.json`: `inputs`, the library's report and `provenance`;
//! - the figures in `figures/`.
//!
//! A label map ([`seg`], `--seg`) gives the leaflets' atrial surfaces and
//! the annulus ring; `report.json` then has `segmentation`.
//!
//! A series ([`series`]) writes one such set per step in `OUT/<step>/`, the
//! table `OUT/series.csv` (and `series.json`) and the plot over the cycle.

pub mod inputs;
pub mod report;
pub mod run;
pub mod seg;
pub mod series;
pub mod settings;
pub mod valve;
pub mod write;

pub use inputs::{
    Files, Inputs, Job, Step, ValveFiles, check_settings, leaflet_of, read, read_leaflet, read_ring,
};
pub use report::{MitralReport, summary};
pub use run::{Run, map_valve, run, run_with};
pub use seg::{SegFiles, inputs_from_labels, read_seg};
pub use series::table::SERIES_COLUMNS;
pub use settings::Settings;
pub use valve::run_valve;
pub use write::{Outputs, write};
