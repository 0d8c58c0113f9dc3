//! The application layer: running an organ (or a command) from its
//! settings and inputs to its outputs, the same for the command line, the
//! Python package and cohorts.
//!
//! One folder per organ and per command family, each with its settings
//! (plain serde structs with the defaults, checked once), its run (inputs
//! in, a typed report out, progress to an observer) and the writing of its
//! output set. Below them, [`run`] holds what every run shares: the staged
//! output set, the memory budget, provenance, the units note and the mesh
//! frame. The layer never parses a command line and never prints; the
//! command line (the `cli` module) turns flags into settings and prints, Python
//! turns numpy arrays into settings and inputs.

pub mod cohort;
pub mod deform;
pub mod error;
pub mod mesh;
pub mod mitral;
pub mod names;
pub mod observer;
pub mod placenta;
pub mod run;
pub mod ventricle;

pub use error::AppError;
