//! One valve's output set: `valve3d.vtu` (both leaflets, anterior first,
//! every map as a point or cell array), `valve2d.vtu` (the same at
//! `(u, v, 0)`), `report.json` and the figures, written into a directory
//! of a [`StagedOutputs`]' staging area (each file atomically).

use super::inputs::{REPORT, VALVE2D, VALVE3D};
use super::run::Run;
use crate::app::AppError;
use crate::app::error::at;
use crate::app::run::StagedOutputs;
use crate::app::run::files::{ensure_dir, write_figures};
use crate::figures::FigureOptions;
use crate::io::{WriteOptions, atomic_write, write_mesh};
use crate::mesh::CellMesh;
use std::path::{Path, PathBuf};

/// Where a valve's outputs go.
#[derive(Debug, Clone, Copy)]
pub struct Outputs<'a> {
    /// The output directory (created if missing): in a staging area of
    /// `staged`.
    pub dir: &'a Path,
    /// The run's staged outputs: where the paths written will be after the
    /// commit.
    pub staged: &'a StagedOutputs,
}

/// Writes `run`'s files into `out.dir` (created if missing): `valve3d.vtu`,
/// `valve2d.vtu`, `report.json` and, with `figures`, the figures in
/// `figures/`. Returns the three files as they will be named after the
/// commit.
///
/// # Errors
/// Writing a file, drawing the figures.
pub fn write(run: &Run, out: &Outputs<'_>, figures: bool) -> Result<Vec<PathBuf>, AppError> {
    let dir = out.dir;
    ensure_dir(dir)?;
    let outcome = &run.outcome;
    let opts = WriteOptions::default();
    write_mesh(dir.join(VALVE3D), &CellMesh::from(&outcome.valve3d), &opts)?;
    write_mesh(dir.join(VALVE2D), &CellMesh::from(&outcome.valve2d), &opts)?;
    let path = dir.join(REPORT);
    let json = run
        .report
        .to_json()
        .map_err(|e| at(&path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&path, json.as_bytes())?;
    if figures {
        let figs = crate::figures::mitral::figures(outcome, &FigureOptions::default())
            .map_err(|e| at(dir, e))?;
        write_figures(dir, &figs)?;
    }
    Ok([VALVE3D, VALVE2D, REPORT]
        .iter()
        .map(|f| out.staged.shown(&dir.join(f)))
        .collect())
}
