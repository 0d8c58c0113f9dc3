//! `unfold.tet_mesh`: `unfold mesh` on a numpy mask
//! ([`unfold::app::mesh::mask::MaskSettings`], the command line's own
//! checks, messages and mesher).

use crate::arrays::mesh_tuple;
use crate::inputs::volume;
use numpy::{PyReadonlyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use serde::Serialize;
use std::path::Path;
use unfold::app::mesh::mask::MaskSettings;
use unfold::app::observer::Plain;
use unfold::mesh::CellMesh;
use unfold::mesh::mesher::MeshQuality;

/// What the command line prints of a mask's mesh, as a report.
#[derive(Serialize)]
struct Report<'a> {
    mask: &'a str,
    mask_voxels: usize,
    mask_volume_mm3: f64,
    size_mm: f64,
    smooth_voxels: f64,
    dilate: u8,
    level: f64,
    graded_collapses: usize,
    components: usize,
    dropped_components: &'a [usize],
    quality: &'a MeshQuality,
    provenance: crate::report::Provenance,
}

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
    let started = crate::report::started();
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
    how.options(keep_all_components).map_err(crate::error)?;
    let image = volume(&mask, &affine, name)?;
    let parameters = format!("{how:?}, keep_all_components: {keep_all_components}");
    let path = Path::new(name);
    let out = py
        .detach(|| {
            let mask = how.mask_of(path, &image)?;
            let out = how.mesh(path, &mask, keep_all_components, &mut Plain)?;
            let quality = MeshQuality::of(&out.mesh)?;
            Ok::<_, unfold::app::AppError>((out, quality))
        })
        .map_err(crate::error)?;
    let (out, quality) = out;
    let json = crate::report::json(&Report {
        mask: name,
        mask_voxels: out.mask_voxels,
        mask_volume_mm3: out.mask_volume_mm3,
        size_mm: out.size_mm,
        smooth_voxels,
        dilate: dilate as u8,
        level: out.level,
        graded_collapses: out.graded_collapses,
        components: out.components,
        dropped_components: &out.dropped_components,
        quality: &quality,
        provenance: crate::report::Provenance::new(parameters, started),
    })?;
    let mesh = mesh_tuple(py, &CellMesh::from(&out.mesh))?;
    PyTuple::new(py, [mesh.into_any(), json.into_pyobject(py)?.into_any()])
}
