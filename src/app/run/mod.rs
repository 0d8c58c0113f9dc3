//! What every run shares, whatever the organ: its output set staged and
//! put in place whole ([`staged`], the leftovers of killed runs [`stale`]),
//! its memory budget ([`memory`]), where its results come from
//! ([`provenance`]), the note on inputs not in millimetres ([`units`]), the
//! frame of mesh files ([`frame`]), and the files read and written beside
//! the meshes ([`files`]).

pub mod columns;
pub mod files;
pub mod frame;
mod manifest;
pub mod memory;
mod output_error;
pub mod printable;
pub mod provenance;
pub mod staged;
pub mod stale;
pub mod units;

pub use manifest::MANIFEST;
pub use output_error::OutputError;
pub use staged::StagedOutputs;
pub use stale::{STALE_AGE, clean_stale};
