//! `unfold.tet_mesh`: `unfold mesh` on a numpy mask
//! ([`unfold::app::mesh::segmentation`], the command line's own checks,
//! messages, mesher and report).

use crate::arrays::mesh_tuple;
use crate::inputs::volume;
use numpy::{PyReadonlyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::path::Path;
use unfold::app::mesh::mask::MaskSettings;
use unfold::app::mesh::segmentation::{self, Settings};
use unfold::app::observer::Plain;
use unfold::app::run::provenance::{Provenance, now};
use unfold::mesh::CellMesh;

/// Meshes a mask; returns `(mesh, report_json)`, the mesh as `(points,
/// cells, point_data, cell_data)`.
#[pyfunction]
#[pyo3(signature = (
    mask, affine, *, size_mm=None, smooth_voxels=1.5, dilate=0, threshold=None, label=None,
    level=None, grade=false, keep_all_components=false, name="mask"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn tet_mesh<'py>(
    py: Python<'py>,
    mask: PyReadonlyArrayDyn<'py, f32>,
    affine: PyReadonlyArray2<'py, f64>,
    size_mm: Option<f64>,
    smooth_voxels: f64,
    dilate: i64,
    threshold: Option<f64>,
    label: Option<f64>,
    level: Option<f64>,
    grade: bool,
    keep_all_components: bool,
    name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = now();
    if !(0..=1).contains(&dilate) {
        return Err(crate::error(format!(
            "--dilate must be 0 or 1, got {dilate}"
        )));
    }
    let how = MaskSettings {
        size_mm,
        smooth_voxels,
        dilate: dilate as u8,
        threshold,
        label,
        level,
        grade,
    };
    let settings = Settings {
        mask: how,
        keep_all_components,
    };
    settings.validate().map_err(crate::error)?;
    let image = volume(&mask, &affine, name)?;
    let parameters = format!("{how:?}, keep_all_components: {keep_all_components}");
    let path = Path::new(name);
    let run = py
        .detach(|| {
            let mask = how.mask_of(path, &image)?;
            segmentation::run(&settings, path, &mask, &mut Plain)
        })
        .map_err(crate::error)?;
    let report = run.report(name, &settings, Provenance::python(parameters, started));
    let json = serde_json::to_string_pretty(&report).map_err(crate::error)?;
    let mesh = mesh_tuple(py, &CellMesh::from(&run.mesh.mesh))?;
    PyTuple::new(py, [mesh.into_any(), json.into_pyobject(py)?.into_any()])
}
