//! `unfold.deform`: `unfold deform` on numpy arrays
//! ([`unfold::app::deform`]: the command line's own checks, repair, solve,
//! messages and `OUT.report.json` layout, [`DeformRunReport`]); the
//! targets and fixed vertices are arrays checked row by row as the command
//! line checks its files line by line.

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::choice;
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::{Path, PathBuf};
use unfold::app::deform::{DeformRunReport, Inputs, Rest, Settings, rest_of, run, start_of};
use unfold::app::run::provenance::Provenance;
use unfold::mesh::nalgebra::Point3;

/// Deforms a tet or triangle mesh: soft targets, a start (tangled or not)
/// and fixed vertices, as `unfold deform`; returns `(deformed,
/// report_json)`, the mesh as `(points, cells, point_data, cell_data)`.
#[pyfunction]
#[pyo3(signature = (
    points, cells, vertices=None, targets=None, *, init=None, fixed=None, fixed_boundary=false,
    point_data=None, cell_data=None, weight=1.0, energy="symmetric-dirichlet", solver="newton",
    tol=1e-4, max_iterations=None, name="mesh", targets_name="targets", init_name="init",
    fixed_name="fixed"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn deform<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: &Bound<'py, PyDict>,
    vertices: Option<PyReadonlyArray1<'py, i64>>,
    targets: Option<PyReadonlyArray2<'py, f64>>,
    init: Option<PyReadonlyArray2<'py, f64>>,
    fixed: Option<PyReadonlyArray1<'py, i64>>,
    fixed_boundary: bool,
    point_data: Option<&Bound<'py, PyDict>>,
    cell_data: Option<&Bound<'py, PyDict>>,
    weight: f64,
    energy: &str,
    solver: &str,
    tol: f64,
    max_iterations: Option<i64>,
    name: &str,
    targets_name: &str,
    init_name: &str,
    fixed_name: &str,
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
    if vertices.is_none() && init.is_none() && fixed.is_none() && !fixed_boundary {
        return Err(crate::error(
            "nothing to do: give targets (vertices and their target points), init, fixed or \
             fixed_boundary=True",
        ));
    }
    let cells = cell_mesh(points, cells, point_data, cell_data)?;
    let rest = rest_of(&cells, name).map_err(crate::error)?;
    let n = rest.num_vertices();
    if matches!(rest, Rest::Triangles(_)) && init.is_none() {
        return Err(crate::error(format!(
            "{name}: a triangle mesh is mapped to the plane: give its start with init= (an \
             (n, 2) array, or (n, 3) in z = 0)"
        )));
    }
    let start = match &init {
        Some(a) => {
            let a = a.as_array();
            if a.ncols() != 3 {
                return Err(crate::error(format!(
                    "{init_name}: expected shape ({n}, 3), got {:?}",
                    a.shape()
                )));
            }
            let p: Vec<Point3<f64>> = a
                .rows()
                .into_iter()
                .map(|r| Point3::new(r[0], r[1], r[2]))
                .collect();
            if let Some(v) = p.iter().position(|q| !q.iter().all(|c| c.is_finite())) {
                return Err(crate::error(format!(
                    "{init_name}: row {v} is not finite ({}, {}, {})",
                    p[v].x, p[v].y, p[v].z
                )));
            }
            Some(start_of(&rest, &p, init_name).map_err(crate::error)?)
        }
        None => None,
    };
    let pairs = match (&vertices, &targets) {
        (Some(v), Some(t)) => target_pairs(v, t, n, targets_name)?,
        (None, None) => Vec::new(),
        _ => {
            return Err(crate::error(format!(
                "{targets_name}: give the targeted vertices and their target points together"
            )));
        }
    };
    let handles = match &fixed {
        Some(f) => fixed_indices(f, n, fixed_name)?,
        None => Vec::new(),
    };
    // The settings as the report has always named them.
    let parameters = format!(
        "DeformSettings {{ weight: {:?}, energy: {:?}, solver: {:?}, tol: {:?}, \
         max_iterations: {:?} }}",
        settings.weight, settings.energy, settings.solver, settings.tol, settings.max_iterations
    );
    let given = |yes: bool, what: &str| yes.then(|| PathBuf::from(what));
    let inputs = Inputs {
        mesh: Path::new(name).to_path_buf(),
        targets: given(vertices.is_some(), targets_name),
        init: given(init.is_some(), init_name),
        fixed_file: given(fixed.is_some(), fixed_name),
        cells,
        rest,
        pairs,
        start,
        handles,
        fixed_boundary,
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

/// The fixed vertices, checked as the command line checks its HANDLES file
/// (a row for a line): in range, each once.
fn fixed_indices(fixed: &PyReadonlyArray1<'_, i64>, n: usize, what: &str) -> PyResult<Vec<usize>> {
    let mut row_of = vec![usize::MAX; n];
    let mut out = Vec::with_capacity(fixed.len());
    for (row, &v) in fixed.as_array().iter().enumerate() {
        if v < 0 || v as u64 >= n as u64 {
            return Err(crate::error(format!(
                "{what}: row {row}: vertex {v} is out of range (the mesh has {n} vertices, \
                 numbered from 0)"
            )));
        }
        let v = v as usize;
        if row_of[v] != usize::MAX {
            return Err(crate::error(format!(
                "{what}: row {row}: vertex {v} is listed twice (first on row {})",
                row_of[v]
            )));
        }
        row_of[v] = row;
        out.push(v);
    }
    Ok(out)
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
