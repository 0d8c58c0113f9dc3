//! `unfold.ventricle_inverse`: `ventricle-inverse` of the application
//! layer ([`unfold::app::ventricle::inverse`]) on numpy arrays: the
//! command line's coordinate reading, chart, per-point statuses, messages
//! and `report.json` layout ([`InverseReport`]).

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::{choice, opt_point, point, tri_mesh};
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::time::Instant;
use unfold::app::run::memory::MemoryReport;
use unfold::app::run::provenance::Provenance;
use unfold::app::ventricle::inverse::{Coordinates, Inputs, InverseReport, Settings, run};
use unfold::app::ventricle::layers::check_layers;
use unfold::app::ventricle::{ChartSettings, with_vertex_cells};
use unfold::organs::ventricle::LandmarkPoints;
use unfold::param::Named;

/// The mesh in cylinder coordinates, as `(points, cells, point_data,
/// cell_data)`.
type Normalized<'py> = (
    PyReadonlyArray2<'py, f64>,
    Bound<'py, PyDict>,
    Option<Bound<'py, PyDict>>,
    Option<Bound<'py, PyDict>>,
);

/// Carries a mesh in cylinder coordinates onto the heart of S; returns
/// `(mapped, report_json)`, the mesh as `(points, cells, point_data,
/// cell_data)`.
#[pyfunction]
#[pyo3(signature = (
    normalized, points, triangles, *, anterior, inferior, apex=None, rim_near=None,
    coordinates="auto", layers=None, chamber="lv", grid_mm=None, hemisphere_mm=None,
    display_exponent=None, snap_mm=None, normalized_name="normalized", surface_name="surface"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn ventricle_inverse<'py>(
    py: Python<'py>,
    normalized: Normalized<'py>,
    points: PyReadonlyArray2<'py, f64>,
    triangles: PyReadonlyArray2<'py, i64>,
    anterior: [f64; 3],
    inferior: [f64; 3],
    apex: Option<[f64; 3]>,
    rim_near: Option<[f64; 3]>,
    coordinates: &str,
    layers: Option<i64>,
    chamber: &str,
    grid_mm: Option<f64>,
    hemisphere_mm: Option<f64>,
    display_exponent: Option<f64>,
    snap_mm: Option<f64>,
    normalized_name: &str,
    surface_name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = unfold::app::run::provenance::now();
    let clock = Instant::now();
    let defaults = ChartSettings::default();
    let chart = ChartSettings {
        chamber: crate::ventricle::chamber(chamber)?,
        grid_mm: grid_mm.unwrap_or(defaults.grid_mm),
        hemisphere_mm: hemisphere_mm.unwrap_or(defaults.hemisphere_mm),
        display_exponent,
        snap_mm: snap_mm.unwrap_or(defaults.snap_mm),
    };
    let config = chart.config().map_err(crate::error)?;
    let how = match Coordinates::by_name(&coordinates.to_ascii_lowercase()) {
        Some(how) => how,
        None => choice("--coordinates", coordinates)?,
    };
    let layers = check_layers(layers).map_err(crate::error)?;
    let settings = Settings {
        coordinates: how,
        chart,
        layers,
        ..Settings::default()
    };
    let parameters = format!("{config:?}");
    let surface = tri_mesh(&points, &triangles, surface_name)?;
    let (np_, nc, npd, ncd) = normalized;
    let normalized = cell_mesh(np_, &nc, npd.as_ref(), ncd.as_ref())?;
    let landmarks = LandmarkPoints {
        anterior: point(anterior, "anterior")?,
        inferior: point(inferior, "inferior")?,
        apex: opt_point(apex, "apex")?,
        rim_near: opt_point(rim_near, "rim_near")?,
    };
    let inputs = Inputs {
        normalized,
        normalized_label: normalized_name.to_string(),
        surface,
        surface_label: surface_name.to_string(),
        landmarks,
        from_rv: None,
        started: clock,
    };
    let inverted = py
        .detach(|| run(&settings, &inputs))
        .map_err(crate::error)?;
    let mut report: InverseReport = inverted.report.clone();
    report.memory = MemoryReport::predicted(inverted.estimated_bytes);
    report.provenance = Provenance::python(parameters, started);
    let json = serde_json::to_string_pretty(&report).map_err(crate::error)?;
    let mapped = mesh_tuple(py, &with_vertex_cells(&inverted.mapped))?;
    PyTuple::new(py, [mapped.into_any(), json.into_pyobject(py)?.into_any()])
}
