//! A ventricle run's output set: the meshes (with the layers and the
//! sensitivity's arrays when asked for), the LV's AHA-segment table,
//! `report.json` (after the meshes) and the figures, written into a
//! staging area of a [`StagedOutputs`] (each file atomically).

use super::aha_segments::{heart_segments, segment_table};
use super::inputs::{
    AHA_SEGMENTS, ANATOMY, DISK, Inputs, NORMALIZED, REPORT, TRANSFERRED, bullseye_field,
};
use super::layers::transmural_layers;
use super::run::Run;
use super::settings::Settings;
use super::surface::SURFACE;
use crate::app::error::{AppError, at};
use crate::app::run::files::{ensure_dir, write_figures};
use crate::app::run::{StagedOutputs, memory};
use crate::figures::FigureOptions;
use crate::io::{WriteOptions, atomic_write, write_mesh};
use crate::mesh::{CellMesh, CellType, Field};
use std::borrow::Cow;
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

/// `mesh`, or a copy with one vertex cell per point when it has no cells
/// (viewers show nothing of a mesh without cells).
pub fn with_vertex_cells(mesh: &CellMesh) -> Cow<'_, CellMesh> {
    if mesh.num_cells() > 0 {
        return Cow::Borrowed(mesh);
    }
    let mut m = mesh.clone();
    for i in 0..m.positions.len() as u32 {
        m.push_cell(CellType::Vertex, &[i]);
    }
    Cow::Owned(m)
}

/// Writes `run`'s outputs into `out.dir`: `normalized.vtu`,
/// `anatomy.vtu` (both with `layer` for `settings.layers` and the
/// sensitivity's arrays), `disk.vtu`, `transferred.vtu` with a transfer,
/// `surface.vtu` when S was built, `aha_segments.csv` (LV), `report.json`
/// (its memory section now), and unless `settings.no_figures` the figures.
/// Returns the files as they will be named after the commit, in order.
///
/// # Errors
/// Writing a file, the bull's-eye's array, drawing a figure.
pub fn write(
    run: &Run,
    settings: &Settings,
    inputs: &Inputs,
    out: &Outputs<'_>,
) -> Result<Vec<PathBuf>, AppError> {
    let dir = out.dir;
    let outcome = &run.outcome;
    ensure_dir(dir)?;
    let opts = WriteOptions::default();
    let mut written = Vec::new();
    let mut meshes: Vec<(&str, Cow<'_, CellMesh>)> = vec![
        (NORMALIZED, with_vertex_cells(&outcome.normalized)),
        (ANATOMY, with_vertex_cells(&outcome.anatomy)),
        (DISK, Cow::Owned(CellMesh::from(&outcome.disk))),
    ];
    if let Some(n) = settings.layers {
        let layer = Field::labels("layer", transmural_layers(&outcome.coords, n));
        for (_, mesh) in meshes.iter_mut().take(2) {
            mesh.to_mut().point_data.insert(layer.clone());
        }
    }
    if let Some(s) = &run.sensitivity {
        for (_, mesh) in meshes.iter_mut().take(2) {
            s.add_arrays(mesh.to_mut());
        }
    }
    if let Some(mesh) = &run.transferred {
        meshes.push((TRANSFERRED, with_vertex_cells(mesh)));
    }
    if inputs.enclosing.is_some() {
        meshes.push((SURFACE, Cow::Owned(CellMesh::from(&inputs.surface))));
    }
    for (name, mesh) in &meshes {
        let p = dir.join(name);
        write_mesh(&p, mesh, &opts)?;
        written.push(p);
    }
    // The LV's segment table, from the anatomy as written.
    if let Some(segments) = meshes
        .iter()
        .find(|(name, _)| *name == ANATOMY)
        .and_then(|(_, mesh)| heart_segments(mesh))
    {
        let p = dir.join(AHA_SEGMENTS);
        atomic_write(&p, &segment_table(&segments, &p)?)?;
        written.push(p);
    }
    drop(meshes);
    let report_path = dir.join(REPORT);
    let mut report = run.report.clone();
    report.memory = memory::report();
    let json = report
        .to_json()
        .map_err(|e| at(&report_path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_path, json.as_bytes())?;
    written.push(report_path);
    if !settings.no_figures {
        written.extend(write_run_figures(run, settings, inputs, dir)?);
    }
    Ok(written.iter().map(|p| out.staged.shown(p)).collect())
}

/// Draws the ventricle figures of `run` (the bull's-eye of
/// `settings.bullseye_array` or the depth, the transfer, the sensitivity)
/// and writes them into `dir/figures/`.
fn write_run_figures(
    run: &Run,
    settings: &Settings,
    inputs: &Inputs,
    dir: &Path,
) -> Result<Vec<PathBuf>, AppError> {
    let outcome = &run.outcome;
    let mut written = Vec::new();
    let values = match &settings.bullseye_array {
        None => None,
        Some(name) => {
            let field = bullseye_field(&inputs.anatomy, name, &inputs.anatomy_label)?;
            Some((name.as_str(), field.values().to_f64()))
        }
    };
    let figs = crate::figures::ventricle::figures(
        outcome,
        run.config.chart.chamber,
        values.as_ref().map(|(n, v)| (*n, v.as_slice())),
        &FigureOptions::default(),
    )
    .map_err(|e| at(dir, e))?;
    written.extend(write_figures(dir, &figs)?);
    if let (Some(mesh), Some(t)) = (&run.transferred, &run.report.transfer) {
        let fig = crate::figures::ventricle::transfer_figure(
            outcome,
            mesh,
            &t.surface,
            &FigureOptions::default(),
        )
        .map_err(|e| at(dir, e))?;
        written.extend(write_figures(dir, &[fig])?);
    }
    if let Some(s) = &run.sensitivity {
        written.extend(write_figures(dir, &[s.figure(outcome, dir)?])?);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::nalgebra::Point3;

    #[test]
    fn a_mesh_without_cells_gets_vertex_cells() {
        let m = CellMesh::from_points(vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0)]);
        let v = with_vertex_cells(&m);
        assert_eq!(v.num_cells(), 2);
        assert!(
            v.cells()
                .all(|(t, vs)| t == CellType::Vertex && vs.len() == 1)
        );
        let mut tri = CellMesh::from_points(vec![Point3::origin(); 3]);
        tri.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(matches!(with_vertex_cells(&tri), Cow::Borrowed(_)));
    }
}
