//! A deformation's outputs: the deformed mesh and `OUT.report.json`
//! beside it, each written at its staged path of a [`StagedOutputs`]
//! (atomically).

use super::run::Run;
use crate::app::error::{AppError, at};
use crate::app::run::StagedOutputs;
use crate::io::{WriteOptions, atomic_write, write_mesh};
use std::path::{Path, PathBuf};

/// Where a deformation's outputs go.
#[derive(Debug, Clone, Copy)]
pub struct Outputs<'a> {
    /// The staged path of the output mesh.
    pub mesh: &'a Path,
    /// The staged path of its report.
    pub report: &'a Path,
    /// The run's staged outputs: where the paths written will be after the
    /// commit (the report's `output`, messages).
    pub staged: &'a StagedOutputs,
}

/// Writes `run`'s mesh and its report (with the output mesh named as after
/// the commit). Returns both files as they will be named after the
/// commit.
///
/// # Errors
/// Writing either file.
pub fn write(run: &Run, out: &Outputs<'_>) -> Result<Vec<PathBuf>, AppError> {
    let staged = out.staged;
    write_mesh(out.mesh, &run.mesh, &WriteOptions::default()).map_err(|e| staged.shown_error(e))?;
    let (mesh, report) = (staged.shown(out.mesh), staged.shown(out.report));
    let mut full = run.report.clone();
    full.output = mesh.display().to_string();
    let json = full
        .to_json()
        .map_err(|e| at(&report, format!("cannot serialize the report: {e}")))?;
    atomic_write(out.report, json.as_bytes()).map_err(|e| staged.shown_error(e))?;
    Ok(vec![mesh, report])
}
