//! `unfold.ventricle_inverse`: `unfold ventricle-inverse` on numpy arrays
//! ([`unfold::cli::ventricle_inverse::invert`]: the command line's
//! coordinate reading, chart, per-point statuses, messages and
//! `report.json` layout).

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::{opt_point, point, tri_mesh};
use crate::report::{Memory, Provenance};
use clap::ValueEnum;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::time::Instant;
use unfold::cli::ventricle::{MAX_LAYERS, settings, with_vertex_cells};
use unfold::cli::ventricle_inverse::{CoordinatesArg, InverseInput, InverseReport, invert};
use unfold::organs::ventricle::LandmarkPoints;
use unfold::organs::ventricle::field::{DEFAULT_GRID_MM, DEFAULT_HEMISPHERE_MM};
use unfold::organs::ventricle::landmarks::DEFAULT_SNAP_MM;

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
    let started = crate::report::started();
    let clock = Instant::now();
    let config = settings(
        crate::ventricle::chamber(chamber)?,
        grid_mm.unwrap_or(DEFAULT_GRID_MM),
        hemisphere_mm.unwrap_or(DEFAULT_HEMISPHERE_MM),
        display_exponent,
        snap_mm.unwrap_or(DEFAULT_SNAP_MM),
    )
    .map_err(crate::error)?;
    let how = CoordinatesArg::from_str(coordinates, true).map_err(|_| {
        crate::error(format!(
            "--coordinates must be one of auto, arrays, points, got '{coordinates}'"
        ))
    })?;
    let layers = match layers {
        None => None,
        Some(k) if (1..=i64::from(MAX_LAYERS)).contains(&k) => Some(k as u32),
        Some(k) => {
            return Err(crate::error(format!(
                "--layers must be between 1 and {MAX_LAYERS}, got {k}"
            )));
        }
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
    let inverted = py
        .detach(|| {
            invert(&InverseInput {
                normalized: &normalized,
                normalized_label: normalized_name,
                coordinates: how,
                surface: &surface,
                surface_label: surface_name,
                landmarks,
                from_rv: None,
                config,
                layers,
                started: clock,
            })
        })
        .map_err(crate::error)?;
    let json = crate::report::json(&InverseReport {
        body: &inverted.body,
        memory: Memory::predicted(inverted.estimated_bytes),
        provenance: Provenance::new(parameters, started),
    })?;
    let mapped = mesh_tuple(py, &with_vertex_cells(&inverted.mapped))?;
    PyTuple::new(py, [mapped.into_any(), json.into_pyobject(py)?.into_any()])
}
