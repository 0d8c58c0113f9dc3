//! numpy inputs turned into the library's types, every shape and index
//! checked: points, triangle meshes, landmark points, image volumes and
//! their affines (and volumes back into numpy).

use numpy::ndarray::{Array, IxDyn};
use numpy::{IntoPyArray, PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use unfold::mesh::nalgebra::{Matrix4, Point3};
use unfold::mesh::{TriMesh, Volume};

/// The rows of an `(n, 3)` array as points; `what` names it in messages.
pub(crate) fn points(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<Point3<f64>>> {
    if a.shape()[1] != 3 {
        return Err(crate::error(format!(
            "{what} must have shape (n, 3), got {:?}",
            a.shape()
        )));
    }
    Ok(a.as_array()
        .rows()
        .into_iter()
        .map(|r| Point3::new(r[0], r[1], r[2]))
        .collect())
}

/// A point from three coordinates, each finite; `what` names it.
pub(crate) fn point(p: [f64; 3], what: &str) -> PyResult<Point3<f64>> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(Point3::new(p[0], p[1], p[2]))
    } else {
        Err(crate::error(format!(
            "{what} must be three finite coordinates, got {p:?}"
        )))
    }
}

/// An optional point ([`point`]).
pub(crate) fn opt_point(p: Option<[f64; 3]>, what: &str) -> PyResult<Option<Point3<f64>>> {
    p.map(|p| point(p, what)).transpose()
}

/// The rows of an `(m, N)` index array as cells over `n` points, every
/// index checked; `what` names them in messages ("tets", "S triangles").
pub(crate) fn cells<const N: usize>(
    a: &PyReadonlyArray2<'_, i64>,
    n: usize,
    what: &str,
) -> PyResult<Vec<[u32; N]>> {
    if a.shape()[1] != N {
        return Err(crate::error(format!(
            "{what} must have shape (m, {N}), got {:?}",
            a.shape()
        )));
    }
    let mut out = Vec::with_capacity(a.shape()[0]);
    for (t, r) in a.as_array().rows().into_iter().enumerate() {
        let mut cell = [0u32; N];
        for (slot, &v) in cell.iter_mut().zip(r) {
            if v < 0 || v as u64 >= n as u64 {
                return Err(crate::error(format!(
                    "{what} row {t} refers to point {v}, but there are {n} points"
                )));
            }
            *slot = v as u32;
        }
        out.push(cell);
    }
    Ok(out)
}

/// A triangle mesh from `(n, 3)` points and `(m, 3)` triangles; `what`
/// names it in messages.
pub(crate) fn tri_mesh(
    points: &PyReadonlyArray2<'_, f64>,
    triangles: &PyReadonlyArray2<'_, i64>,
    what: &str,
) -> PyResult<TriMesh> {
    let positions = self::points(points, &format!("{what} points"))?;
    let tris = cells::<3>(triangles, positions.len(), &format!("{what} triangles"))?;
    Ok(TriMesh::new(positions, tris))
}

/// A 4x4 affine (voxel indices to RAS mm); `what` names it.
pub(crate) fn affine(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Matrix4<f64>> {
    if a.shape() != [4, 4] {
        return Err(crate::error(format!(
            "{what}: the affine must be a 4x4 array, got shape {:?}",
            a.shape()
        )));
    }
    let v = a.as_array();
    Ok(Matrix4::from_fn(|r, c| v[[r, c]]))
}

/// A volume from a 3D `(nx, ny, nz)` or 4D `(nx, ny, nz, nt)` array
/// (indexed as nibabel's `get_fdata()`: `[i, j, k, t]`) and its affine.
pub(crate) fn volume(
    data: &PyReadonlyArrayDyn<'_, f32>,
    affine: &PyReadonlyArray2<'_, f64>,
    what: &str,
) -> PyResult<Volume<f32>> {
    let shape = data.shape();
    let dims = match *shape {
        [x, y, z] => [x, y, z, 1],
        [x, y, z, t] => [x, y, z, t],
        _ => {
            return Err(crate::error(format!(
                "{what}: expected a 3D or 4D array, got shape {shape:?}"
            )));
        }
    };
    let a = data.as_array();
    // i fastest, as the volume stores its voxels.
    let values: Vec<f32> = a.reversed_axes().iter().copied().collect();
    Volume::new(dims, self::affine(affine, what)?, values)
        .map_err(|e| crate::error(format!("{what}: {e}")))
}

/// A volume as `(data, affine)`: data `(nx, ny, nz)` (one frame) or `(nx,
/// ny, nz, nt)`, float32; the affine 4x4 float64.
pub(crate) fn volume_arrays<'py>(
    py: Python<'py>,
    v: &Volume<f32>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let [x, y, z, t] = v.dims();
    let reversed: Vec<usize> = if t == 1 {
        vec![z, y, x]
    } else {
        vec![t, z, y, x]
    };
    let data = Array::from_shape_vec(IxDyn(&reversed), v.data().to_vec())
        .map_err(crate::error)?
        .reversed_axes()
        .as_standard_layout()
        .into_owned();
    let m = v.affine();
    let affine = Array::from_shape_fn((4, 4), |(r, c)| m[(r, c)]);
    Ok((
        data.into_pyarray(py).into_any(),
        affine.into_pyarray(py).into_any(),
    ))
}

/// An optional iteration cap (`--max-iterations`) as a count: None, or a
/// whole number not below 0 (the settings check the least count they
/// take); `what` names it in the message.
pub(crate) fn max_iterations(value: Option<i64>, what: &str) -> PyResult<Option<usize>> {
    value
        .map(|v| {
            usize::try_from(v)
                .map_err(|_| crate::error(format!("{what} must not be negative, got {v}")))
        })
        .transpose()
}

/// The value of `T` called `value` ([`unfold::app::names::parse`]: the
/// command line's message listing the choices otherwise).
pub(crate) fn choice<T: unfold::param::Named>(flag: &str, value: &str) -> PyResult<T> {
    unfold::app::names::parse(flag, value).map_err(crate::error)
}
