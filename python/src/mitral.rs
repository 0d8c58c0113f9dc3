//! `unfold.mitral`: `unfold mitral` on one valve given as numpy arrays
//! ([`unfold::cli::mitral`]: the command line's settings checks, pipeline,
//! messages and `report.json` layout).

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::{choice, points};
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::Path;
use unfold::cli::mitral::{FullReport, MitralSettings, leaflet_of, map_valve};
use unfold::mesh::CellMesh;

/// A leaflet given as `(points, cells, point_data)` (meshio's layout).
type Leaflet<'py> = (
    PyReadonlyArray2<'py, f64>,
    Bound<'py, PyDict>,
    Option<Bound<'py, PyDict>>,
);

/// Lays one valve out in 2D; returns `(valve2d, valve3d, report_json)`,
/// each mesh as `(points, cells, point_data, cell_data)`.
#[pyfunction]
#[pyo3(signature = (
    anterior, posterior, annulus=None, *, annulus_mode="landmark", init="auto", relax="sd",
    iterations=5, step_scale=None, coaptation_mm=2.0, tolerance_mm=None,
    cut_posteromedial=false, name="valve"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mitral<'py>(
    py: Python<'py>,
    anterior: Leaflet<'py>,
    posterior: Leaflet<'py>,
    annulus: Option<PyReadonlyArray2<'py, f64>>,
    annulus_mode: &str,
    init: &str,
    relax: &str,
    iterations: i64,
    step_scale: Option<f64>,
    coaptation_mm: f64,
    tolerance_mm: Option<f64>,
    cut_posteromedial: bool,
    name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = crate::report::started();
    let Ok(iterations) = usize::try_from(iterations) else {
        return Err(crate::error(format!(
            "--iterations must be a whole number >= 0, got {iterations}"
        )));
    };
    let settings = MitralSettings {
        annulus_mode: choice("--annulus-mode", annulus_mode)?,
        init: choice("--init", init)?,
        relax: choice("--relax", relax)?,
        iterations,
        step_scale,
        coaptation_mm,
        tolerance_mm,
        cut_posteromedial,
    };
    let pipeline = settings.pipeline().map_err(crate::error)?;
    let leaflet = |(p, c, d): Leaflet<'py>, which: &str| -> PyResult<_> {
        let cells = cell_mesh(p, &c, d.as_ref(), None)?;
        leaflet_of(&cells, Path::new(&format!("{name}: {which} leaflet"))).map_err(crate::error)
    };
    let anterior = leaflet(anterior, "anterior")?;
    let posterior = leaflet(posterior, "posterior")?;
    // Without a ring, the annulus from the leaflets' shared boundary (as
    // `unfold mitral` without --annulus).
    let ring = match &annulus {
        Some(a) => points(a, "annulus")?,
        None => unfold::organs::mitral::annulus_from_leaflets(
            &anterior,
            &posterior,
            pipeline.settings().tolerance_mm,
        )
        .map(|found| found.ring)
        .map_err(|source| {
            crate::input_error(
                unfold::cli::AppError::Organ {
                    path: name.to_string(),
                    source,
                },
                &[
                    ("the anterior leaflet", &anterior.positions),
                    ("the posterior leaflet", &posterior.positions),
                ],
            )
        })?,
    };
    let parameters = format!("{settings:?}, annulus given: {}", annulus.is_some());
    let outcome = py
        .detach(|| map_valve(&pipeline, &anterior, &posterior, &ring, name))
        .map_err(|e| {
            crate::input_error(
                e,
                &[
                    ("the anterior leaflet", &anterior.positions),
                    ("the posterior leaflet", &posterior.positions),
                    ("the annulus", &ring),
                ],
            )
        })?;
    let json = crate::report::json(&FullReport {
        inputs: name,
        report: &outcome.report,
        provenance: crate::report::Provenance::new(parameters, started),
    })?;
    let valve2d = mesh_tuple(py, &CellMesh::from(&outcome.valve2d))?;
    let valve3d = mesh_tuple(py, &CellMesh::from(&outcome.valve3d))?;
    PyTuple::new(
        py,
        [
            valve2d.into_any(),
            valve3d.into_any(),
            json.into_pyobject(py)?.into_any(),
        ],
    )
}
