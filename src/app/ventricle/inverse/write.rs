//! The output set of `ventricle-inverse`: `mapped.vtu` and `report.json`,
//! written into a staging area of a [`StagedOutputs`] (each file
//! atomically).

use super::inputs::{MAPPED, REPORT};
use super::run::Run;
use crate::app::AppError;
use crate::app::error::at;
use crate::app::run::files::ensure_dir;
use crate::app::run::{StagedOutputs, memory};
use crate::app::ventricle::write::with_vertex_cells;
use crate::io::{WriteOptions, atomic_write, write_mesh};
use std::path::{Path, PathBuf};

/// Where a run's outputs go.
#[derive(Debug, Clone, Copy)]
pub struct Outputs<'a> {
    /// The output directory (created if missing): in a staging area of
    /// `staged`.
    pub dir: &'a Path,
    /// The run's staged outputs: where the paths written will be after the
    /// commit, for the list of files written.
    pub staged: &'a StagedOutputs,
}

/// Writes `mapped.vtu` (a vertex cell per point when the mesh has no
/// cells) and `report.json` (its memory section now) into `out.dir`;
/// returns them as they will be named after the commit.
///
/// # Errors
/// Writing a file.
pub fn write(run: &Run, out: &Outputs<'_>) -> Result<Vec<PathBuf>, AppError> {
    ensure_dir(out.dir)?;
    let mapped_path = out.dir.join(MAPPED);
    write_mesh(
        &mapped_path,
        &with_vertex_cells(&run.mapped),
        &WriteOptions::default(),
    )?;
    let report_path = out.dir.join(REPORT);
    let mut report = run.report.clone();
    report.memory = memory::report();
    let json = report
        .to_json()
        .map_err(|e| at(&report_path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_path, json.as_bytes())?;
    Ok([mapped_path, report_path]
        .iter()
        .map(|p| out.staged.shown(p))
        .collect())
}
