//! `unfold.deform`: `unfold deform` on numpy arrays
//! ([`unfold::app::deform`]: the command line's own repair, solve,
//! messages and `OUT.report.json` layout, [`DeformRunReport`]).

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::choice;
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::Path;
use unfold::app::deform::{DeformRunReport, Inputs, Settings, run, tet_mesh_of};
use unfold::app::run::provenance::Provenance;

/// Deforms a tet mesh towards targets; returns `(deformed, report_json)`,
/// the mesh as `(points, cells, point_data, cell_data)`.
#[pyfunction]
#[pyo3(signature = (
    points, cells, vertices, targets, *, point_data=None, cell_data=None, weight=1.0,
    energy="symmetric-dirichlet", solver="newton", tol=1e-4, max_iterations=None,
    name="mesh", targets_name="targets"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn deform<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: &Bound<'py, PyDict>,
    vertices: PyReadonlyArray1<'py, i64>,
    targets: PyReadonlyArray2<'py, f64>,
    point_data: Option<&Bound<'py, PyDict>>,
    cell_data: Option<&Bound<'py, PyDict>>,
    weight: f64,
    energy: &str,
    solver: &str,
    tol: f64,
    max_iterations: Option<i64>,
    name: &str,
    targets_name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = unfold::app::run::provenance::now();
    let settings = Settings {
        weight,
        energy: choice("--energy", energy)?,
        solver: choice("--solver", solver)?,
        tol,
        max_iterations: crate::inputs::max_iterations(max_iterations, "--max-iterations")?,
    };
    settings.validate().map_err(crate::error)?;
    let mesh_path = Path::new(name);
    let targets_path = Path::new(targets_name);
    let cells = cell_mesh(points, cells, point_data, cell_data)?;
    let tets = tet_mesh_of(&cells, mesh_path).map_err(crate::error)?;
    let pairs = target_pairs(&vertices, &targets, cells.positions.len(), targets_name)?;
    // The settings as the report has always named them.
    let parameters = format!(
        "DeformSettings {{ weight: {:?}, energy: {:?}, solver: {:?}, tol: {:?}, \
         max_iterations: {:?} }}",
        settings.weight, settings.energy, settings.solver, settings.tol, settings.max_iterations
    );
    let inputs = Inputs {
        mesh: mesh_path.to_path_buf(),
        targets: targets_path.to_path_buf(),
        cells,
        tets,
        pairs,
    };
    let run = py
        .detach(|| run(&settings, inputs, &mut unfold::app::observer::Quiet))
        .map_err(crate::error)?;
    let report = DeformRunReport {
        provenance: Provenance::python(parameters, started),
        ..run.report
    };
    // As before: the report without a final newline.
    let json = serde_json::to_string_pretty(&report).map_err(crate::error)?;
    let mesh = mesh_tuple(py, &run.mesh)?;
    PyTuple::new(py, [mesh.into_any(), json.into_pyobject(py)?.into_any()])
}

/// `(vertex, target)` pairs, checked as the command line checks its
/// targets file (a row for a line): in range, finite, each vertex once.
fn target_pairs(
    vertices: &PyReadonlyArray1<'_, i64>,
    targets: &PyReadonlyArray2<'_, f64>,
    n: usize,
    what: &str,
) -> PyResult<Vec<(usize, [f64; 3])>> {
    let k = vertices.len();
    if targets.shape() != [k, 3] {
        return Err(crate::error(format!(
            "{what}: expected {k} target points of shape ({k}, 3) for the {k} vertices, got {:?}",
            targets.shape()
        )));
    }
    if k == 0 {
        return Err(crate::error(format!(
            "{what}: no targets (expected vertices and their target points)"
        )));
    }
    let mut row_of = vec![usize::MAX; n];
    let t = targets.as_array();
    let mut pairs = Vec::with_capacity(k);
    for (row, &v) in vertices.as_array().iter().enumerate() {
        if v < 0 || v as u64 >= n as u64 {
            return Err(crate::error(format!(
                "{what}: row {row}: vertex {v} is out of range (the mesh has {n} vertices, \
                 numbered from 0)"
            )));
        }
        let v = v as usize;
        let p = [t[[row, 0]], t[[row, 1]], t[[row, 2]]];
        if let Some(c) = p.iter().position(|x| !x.is_finite()) {
            return Err(crate::error(format!(
                "{what}: row {row}: bad {} coordinate `{}` (expected a finite number)",
                ["x", "y", "z"][c],
                p[c]
            )));
        }
        if row_of[v] != usize::MAX {
            return Err(crate::error(format!(
                "{what}: row {row}: vertex {v} is listed twice (first on row {})",
                row_of[v]
            )));
        }
        row_of[v] = row;
        pairs.push((v, p));
    }
    Ok(pairs)
}
