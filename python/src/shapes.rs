//! The synthetic placenta slab, ventricle and mitral valve of `unfold demo`
//! (`unfold_mesh::shapes`) as numpy arrays, so tutorials and tests need no
//! files.

use crate::arrays::mesh_tuple;
use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{
    PlacentaParams, ValveParams, VentricleParams, mitral_valve, placenta_slab as slab,
    ventricle_cup,
};
use unfold::mesh::{CellMesh, TriMesh};

/// Points as an `(n, 3)` float64 array.
fn points_array<'py>(py: Python<'py>, p: &[Point3<f64>]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = p.iter().flat_map(|q| [q.x, q.y, q.z]).collect();
    Ok(Array2::from_shape_vec((p.len(), 3), flat)
        .map_err(crate::error)?
        .into_pyarray(py)
        .into_any())
}

/// A triangle mesh in the module's layout.
fn tri<'py>(py: Python<'py>, m: &TriMesh) -> PyResult<Bound<'py, PyAny>> {
    Ok(mesh_tuple(py, &CellMesh::from(m))?.into_any())
}

/// The demo's ventricle cup: `(surface, anatomy, anatomy_points, anterior,
/// inferior, apex)`; `rings` sets S's resolution (None: the default).
#[pyfunction]
#[pyo3(signature = (rings=None))]
pub(crate) fn ventricle_cup_shape<'py>(
    py: Python<'py>,
    rings: Option<usize>,
) -> PyResult<Bound<'py, PyTuple>> {
    let mut p = VentricleParams::default();
    if let Some(r) = rings {
        p.rings = r;
    }
    let v = ventricle_cup(&p).map_err(crate::error)?;
    PyTuple::new(
        py,
        [
            tri(py, &v.surface)?,
            tri(py, &v.anatomy)?,
            points_array(py, &v.anatomy_points)?,
            points_array(py, &[v.anterior])?,
            points_array(py, &[v.inferior])?,
            points_array(py, &[v.apex])?,
        ],
    )
}

/// The demo's mitral valve: `(anterior, posterior, annulus)`.
#[pyfunction]
pub(crate) fn mitral_valve_shape<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
    let v = mitral_valve(&ValveParams::default()).map_err(crate::error)?;
    PyTuple::new(
        py,
        [
            tri(py, &v.anterior)?,
            tri(py, &v.posterior)?,
            points_array(py, &v.annulus)?,
        ],
    )
}

/// The synthetic placenta slab of `unfold demo` (`unfold_mesh::shapes`),
/// in its own frame, as `(points, cells, point_data, cell_data)`;
/// `cells_radial` sets its resolution.
#[pyfunction]
#[pyo3(signature = (cells_radial=None))]
pub(crate) fn placenta_slab<'py>(
    py: Python<'py>,
    cells_radial: Option<usize>,
) -> PyResult<Bound<'py, PyTuple>> {
    let mut params = PlacentaParams::default();
    if let Some(c) = cells_radial {
        params.cells_radial = c;
    }
    let shape = slab(&params).map_err(crate::error)?;
    mesh_tuple(py, &CellMesh::from(&shape.mesh))
}
