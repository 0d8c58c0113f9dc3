//! Meshes as numpy arrays, the layout of meshio: points float64 `(n, 3)`;
//! cells as one int64 `(m, k)` array per cell type, in a dict keyed by
//! meshio's type names (`"tetra"`, `"triangle"`, `"line"`, ...; the
//! variable-size types by size, e.g. `"polygon5"`, `"polyline3"`); point
//! and cell arrays as dicts of numpy arrays, `(n,)` for one component and
//! `(n, k)` for `k`. Cell arrays run over the cells in the order of the
//! cell dict's blocks.

use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use unfold::io::WriteOptions;
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::{CellMesh, CellType, Field, FieldValues, Fields};

/// meshio's name of a cell type.
fn type_name(t: CellType) -> &'static str {
    match t {
        CellType::Vertex => "vertex",
        CellType::PolyVertex => "polyvertex",
        CellType::Line => "line",
        CellType::PolyLine => "polyline",
        CellType::Triangle => "triangle",
        CellType::Polygon => "polygon",
        CellType::Quad => "quad",
        CellType::Tetra => "tetra",
        CellType::Hexahedron => "hexahedron",
        CellType::Wedge => "wedge",
        CellType::Pyramid => "pyramid",
    }
}

/// The key of a block of `size`-vertex cells of type `t`.
fn block_key(t: CellType, size: usize) -> String {
    match t.fixed_size() {
        Some(_) => type_name(t).to_string(),
        None => format!("{}{size}", type_name(t)),
    }
}

/// The cell type and size of a block key; `None` for an unknown name.
fn parse_key(key: &str) -> Option<(CellType, Option<usize>)> {
    let all = CellType::ALL;
    // The longest name first: "polyline" before "line".
    let mut best: Option<(CellType, Option<usize>)> = None;
    let mut best_len = 0;
    for t in all {
        let name = type_name(t);
        if let Some(rest) = key.strip_prefix(name) {
            let size = match (t.fixed_size(), rest) {
                (Some(_), "") => None,
                (None, "") => None,
                (None, digits) => match digits.parse::<usize>() {
                    Ok(k) => Some(k),
                    Err(_) => continue,
                },
                (Some(_), _) => continue,
            };
            if name.len() > best_len {
                best = Some((t, size));
                best_len = name.len();
            }
        }
    }
    best
}

/// The cells of `mesh` grouped into blocks of one type and size, in order
/// of first appearance: `(key, columns, connectivity)` and the permutation
/// (new cell order -> old cell index).
type Blocks = (Vec<(String, usize, Vec<i64>)>, Vec<usize>);

fn blocks(mesh: &CellMesh) -> Blocks {
    let mut out: Vec<(String, usize, Vec<i64>)> = Vec::new();
    let mut members: Vec<Vec<usize>> = Vec::new();
    for (i, (t, vs)) in mesh.cells().enumerate() {
        let key = block_key(t, vs.len());
        let b = match out.iter().position(|(k, n, _)| *k == key && *n == vs.len()) {
            Some(b) => b,
            None => {
                out.push((key, vs.len(), Vec::new()));
                members.push(Vec::new());
                out.len() - 1
            }
        };
        out[b].2.extend(vs.iter().map(|&v| i64::from(v)));
        members[b].push(i);
    }
    (out, members.concat())
}

/// A field as a numpy array: `(n,)` for one component, `(n, k)` else.
fn field_array<'py>(py: Python<'py>, f: &Field) -> PyResult<Bound<'py, PyAny>> {
    fn shaped<'py, T: numpy::Element>(
        py: Python<'py>,
        v: Vec<T>,
        k: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = v.len() / k;
        let a = v.into_pyarray(py);
        if k == 1 {
            Ok(a.into_any())
        } else {
            Ok(a.reshape([n, k])?.into_any())
        }
    }
    let k = f.components();
    match f.values().clone() {
        FieldValues::F64(v) => shaped(py, v, k),
        FieldValues::F32(v) => shaped(py, v, k),
        FieldValues::I64(v) => shaped(py, v, k),
        FieldValues::I32(v) => shaped(py, v, k),
        FieldValues::U8(v) => shaped(py, v, k),
    }
}

/// `fields` as a dict of numpy arrays.
fn fields_dict<'py>(py: Python<'py>, fields: &Fields) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for f in fields.iter() {
        d.set_item(f.name(), field_array(py, f)?)?;
    }
    Ok(d)
}

/// `(points, cells, point_data, cell_data)` of a mesh as numpy arrays
/// (the module's layout).
pub(crate) fn mesh_tuple<'py>(
    py: Python<'py>,
    mesh: &CellMesh,
) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
    let flat: Vec<f64> = mesh
        .positions
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    let points = Array2::from_shape_vec((mesh.positions.len(), 3), flat)
        .map_err(crate::error)?
        .into_pyarray(py);
    let (blocks, order) = blocks(mesh);
    let cells = PyDict::new(py);
    for (key, k, conn) in blocks {
        let m = conn.len().checked_div(k).unwrap_or(0);
        let a = Array2::from_shape_vec((m, k), conn).map_err(crate::error)?;
        cells.set_item(key, a.into_pyarray(py))?;
    }
    let cell_data = fields_dict(py, &mesh.cell_data.select(&order))?;
    let point_data = fields_dict(py, &mesh.point_data)?;
    pyo3::types::PyTuple::new(
        py,
        [
            points.into_any(),
            cells.into_any(),
            point_data.into_any(),
            cell_data.into_any(),
        ],
    )
}

/// A numpy array (1-D or 2-D, float64/float32/int64/int32/uint8) as a
/// field called `name`.
fn array_field(name: &str, a: &Bound<'_, PyAny>) -> PyResult<Field> {
    fn values<T: numpy::Element + Copy>(a: &Bound<'_, PyAny>) -> Option<(Vec<T>, usize)> {
        if let Ok(x) = a.extract::<PyReadonlyArray1<'_, T>>() {
            return Some((x.as_array().to_vec(), 1));
        }
        if let Ok(x) = a.extract::<PyReadonlyArray2<'_, T>>() {
            let k = x.shape()[1];
            return Some((x.as_array().iter().copied().collect(), k));
        }
        None
    }
    let (v, k) = if let Some((v, k)) = values::<f64>(a) {
        (FieldValues::F64(v), k)
    } else if let Some((v, k)) = values::<f32>(a) {
        (FieldValues::F32(v), k)
    } else if let Some((v, k)) = values::<i64>(a) {
        (FieldValues::I64(v), k)
    } else if let Some((v, k)) = values::<i32>(a) {
        (FieldValues::I32(v), k)
    } else if let Some((v, k)) = values::<u8>(a) {
        (FieldValues::U8(v), k)
    } else {
        return Err(crate::error(format!(
            "array '{name}': expected a 1-D or 2-D numpy array of float64, float32, int64, \
             int32 or uint8"
        )));
    };
    Field::new(name, k, v).map_err(crate::error)
}

/// A mesh from the module's layout; every index and array length checked.
pub(crate) fn cell_mesh(
    points: PyReadonlyArray2<'_, f64>,
    cells: &Bound<'_, PyDict>,
    point_data: Option<&Bound<'_, PyDict>>,
    cell_data: Option<&Bound<'_, PyDict>>,
) -> PyResult<CellMesh> {
    let pts = points.as_array();
    if pts.ncols() != 3 {
        return Err(crate::error(format!(
            "points must have shape (n, 3), got ({}, {})",
            pts.nrows(),
            pts.ncols()
        )));
    }
    let positions: Vec<Point3<f64>> = pts
        .rows()
        .into_iter()
        .map(|r| Point3::new(r[0], r[1], r[2]))
        .collect();
    let n = positions.len();
    let mut mesh = CellMesh::from_points(positions);
    for (key, block) in cells.iter() {
        let key: String = key.extract()?;
        let (t, size) = parse_key(&key).ok_or_else(|| {
            crate::error(format!(
                "cells: unknown cell type '{key}' (use meshio's names: vertex, line, triangle, \
                 quad, tetra, hexahedron, wedge, pyramid, or polygonK / polylineK / \
                 polyvertexK with K vertices)"
            ))
        })?;
        let block: PyReadonlyArray2<'_, i64> = block
            .extract()
            .map_err(|_| crate::error(format!("cells['{key}']: expected a 2-D int64 array")))?;
        let a = block.as_array();
        let k = a.ncols();
        let expected = t.fixed_size().or(size).unwrap_or(k);
        if k != expected || k < t.min_size() {
            return Err(crate::error(format!(
                "cells['{key}'] has {k} columns, a {key} cell has {expected}"
            )));
        }
        let mut row = Vec::with_capacity(k);
        for (c, r) in a.rows().into_iter().enumerate() {
            row.clear();
            for &v in r {
                if v < 0 || v as u64 >= n as u64 {
                    return Err(crate::error(format!(
                        "cells['{key}'] row {c} refers to point {v}, but there are {n} points"
                    )));
                }
                row.push(v as u32);
            }
            mesh.push_cell(t, &row);
        }
    }
    for (data, point) in [(point_data, true), (cell_data, false)] {
        let Some(data) = data else { continue };
        for (name, a) in data.iter() {
            let name: String = name.extract()?;
            let field = array_field(&name, &a)?;
            let r = if point {
                mesh.add_point_field(field)
            } else {
                mesh.add_cell_field(field)
            };
            r.map_err(crate::error)?;
        }
    }
    Ok(mesh)
}

/// Reads a mesh file (every format `unfold convert` reads) into
/// `(points, cells, point_data, cell_data)`.
#[pyfunction]
pub(crate) fn read_mesh<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
    let mesh = py
        .detach(|| unfold::io::read_mesh(&path))
        .map_err(crate::error)?;
    mesh_tuple(py, &mesh)
}

/// Writes a mesh file (the format from the extension), atomically.
#[pyfunction]
#[pyo3(signature = (path, points, cells, point_data=None, cell_data=None, ascii=false))]
pub(crate) fn write_mesh(
    py: Python<'_>,
    path: PathBuf,
    points: PyReadonlyArray2<'_, f64>,
    cells: &Bound<'_, PyDict>,
    point_data: Option<&Bound<'_, PyDict>>,
    cell_data: Option<&Bound<'_, PyDict>>,
    ascii: bool,
) -> PyResult<()> {
    let mesh = cell_mesh(points, cells, point_data, cell_data)?;
    let opts = WriteOptions {
        ascii,
        ..WriteOptions::default()
    };
    py.detach(|| unfold::io::write_mesh(&path, &mesh, &opts))
        .map_err(crate::error)
}
