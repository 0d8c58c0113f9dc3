//! A general cell mesh, as files hold it: points, cells of mixed types (VTK's
//! cell model), point data and cell data. Readers produce it, writers take it;
//! pipelines convert it to a [`TriMesh`] or [`TetMesh`].

use crate::{Field, Fields, MeshError, TetMesh, TriMesh};
use nalgebra::Point3;

/// Cell types, numbered as in VTK.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum CellType {
    /// A single point.
    Vertex = 1,
    /// A set of points.
    PolyVertex = 2,
    /// A segment (2 points).
    Line = 3,
    /// An open polyline (2 or more points).
    PolyLine = 4,
    /// A triangle.
    Triangle = 5,
    /// A simple polygon (3 or more points).
    Polygon = 7,
    /// A quadrilateral.
    Quad = 9,
    /// A tetrahedron.
    Tetra = 10,
    /// A hexahedron (VTK point order).
    Hexahedron = 12,
    /// A wedge (triangular prism).
    Wedge = 13,
    /// A pyramid.
    Pyramid = 14,
}

impl CellType {
    /// Every cell type unfold supports, in VTK id order.
    pub const ALL: [CellType; 11] = [
        CellType::Vertex,
        CellType::PolyVertex,
        CellType::Line,
        CellType::PolyLine,
        CellType::Triangle,
        CellType::Polygon,
        CellType::Quad,
        CellType::Tetra,
        CellType::Hexahedron,
        CellType::Wedge,
        CellType::Pyramid,
    ];

    /// The VTK cell type id.
    pub fn vtk_id(self) -> u8 {
        self as u8
    }

    /// The cell type for a VTK id, if unfold supports it.
    pub fn from_vtk_id(id: u8) -> Option<CellType> {
        CellType::ALL.into_iter().find(|t| t.vtk_id() == id)
    }

    /// Topological dimension: 0 points, 1 lines, 2 surfaces, 3 volumes.
    pub fn dimension(self) -> u8 {
        use CellType::*;
        match self {
            Vertex | PolyVertex => 0,
            Line | PolyLine => 1,
            Triangle | Polygon | Quad => 2,
            Tetra | Hexahedron | Wedge | Pyramid => 3,
        }
    }

    /// The fixed number of vertices, or `None` for variable-size cells.
    pub fn fixed_size(self) -> Option<usize> {
        use CellType::*;
        match self {
            Vertex => Some(1),
            Line => Some(2),
            Triangle => Some(3),
            Quad => Some(4),
            Tetra => Some(4),
            Hexahedron => Some(8),
            Wedge => Some(6),
            Pyramid => Some(5),
            PolyVertex | PolyLine | Polygon => None,
        }
    }

    /// The smallest valid number of vertices.
    pub fn min_size(self) -> usize {
        use CellType::*;
        match self {
            PolyVertex => 1,
            PolyLine => 2,
            Polygon => 3,
            t => t.fixed_size().unwrap_or(1),
        }
    }
}

/// Points, mixed cells (CSR: `offsets[i]..offsets[i+1]` into `connectivity`)
/// and their data arrays.
#[derive(Debug, Clone, PartialEq)]
pub struct CellMesh {
    /// Point positions (mm).
    pub positions: Vec<Point3<f64>>,
    /// One type per cell.
    pub cell_types: Vec<CellType>,
    /// Cell `i` is `connectivity[offsets[i]..offsets[i + 1]]`; `offsets[0] == 0`.
    pub offsets: Vec<usize>,
    /// Concatenated point indices of all cells.
    pub connectivity: Vec<u32>,
    /// One tuple per point.
    pub point_data: Fields,
    /// One tuple per cell.
    pub cell_data: Fields,
}

impl Default for CellMesh {
    fn default() -> Self {
        CellMesh {
            positions: Vec::new(),
            cell_types: Vec::new(),
            offsets: vec![0],
            connectivity: Vec::new(),
            point_data: Fields::new(),
            cell_data: Fields::new(),
        }
    }
}

impl CellMesh {
    /// Points and no cells.
    pub fn from_points(positions: Vec<Point3<f64>>) -> Self {
        CellMesh {
            positions,
            ..CellMesh::default()
        }
    }

    /// Appends a cell (no checks; see [`CellMesh::check`]).
    pub fn push_cell(&mut self, cell_type: CellType, vertices: &[u32]) {
        self.cell_types.push(cell_type);
        self.connectivity.extend_from_slice(vertices);
        self.offsets.push(self.connectivity.len());
    }

    /// Number of points.
    pub fn num_points(&self) -> usize {
        self.positions.len()
    }

    /// Number of cells.
    pub fn num_cells(&self) -> usize {
        self.cell_types.len()
    }

    /// Cell `i`: its type and point indices.
    pub fn cell(&self, i: usize) -> (CellType, &[u32]) {
        (
            self.cell_types[i],
            &self.connectivity[self.offsets[i]..self.offsets[i + 1]],
        )
    }

    /// All cells in order.
    pub fn cells(&self) -> impl Iterator<Item = (CellType, &[u32])> + '_ {
        (0..self.num_cells()).map(|i| self.cell(i))
    }

    /// How many cells of each type, sorted by type.
    pub fn cell_type_counts(&self) -> Vec<(CellType, usize)> {
        let mut counts = std::collections::BTreeMap::new();
        for &t in &self.cell_types {
            *counts.entry(t).or_insert(0usize) += 1;
        }
        counts.into_iter().collect()
    }

    /// Checks the CSR layout, cell sizes, point indices, finite coordinates
    /// and the tuple counts of point and cell data.
    pub fn check(&self) -> Result<(), MeshError> {
        let n = self.cell_types.len();
        if self.offsets.len() != n + 1
            || self.offsets[0] != 0
            || self.offsets[n] != self.connectivity.len()
            || self.offsets.windows(2).any(|w| w[0] > w[1])
        {
            return Err(MeshError::InvalidArgument(
                "cell offsets are inconsistent with the connectivity".into(),
            ));
        }
        for (i, (t, vs)) in self.cells().enumerate() {
            let ok = match t.fixed_size() {
                Some(k) => vs.len() == k,
                None => vs.len() >= t.min_size(),
            };
            if !ok {
                return Err(MeshError::CellSize {
                    cell: i,
                    cell_type: t,
                    found: vs.len(),
                });
            }
            for &v in vs {
                if v as usize >= self.positions.len() {
                    return Err(MeshError::IndexOutOfRange {
                        element: i,
                        index: v,
                        vertex_count: self.positions.len(),
                    });
                }
            }
        }
        crate::geometry::check_finite(&self.positions)?;
        self.point_data.check_tuples(self.positions.len())?;
        self.cell_data.check_tuples(n)
    }

    /// The surface cells as a triangle mesh: triangles as they are, quads and
    /// polygons fan-triangulated from their first vertex (their cell data is
    /// repeated for each triangle). Any cell that is not a surface cell is an
    /// error. Point data is kept.
    pub fn to_tri_mesh(&self) -> Result<TriMesh, MeshError> {
        self.check()?;
        let mut triangles = Vec::with_capacity(self.num_cells());
        let mut rows = Vec::with_capacity(self.num_cells());
        for (i, (t, vs)) in self.cells().enumerate() {
            if t.dimension() != 2 {
                return Err(MeshError::WrongCellType {
                    cell: i,
                    found: t,
                    expected: "triangle",
                });
            }
            for k in 1..vs.len() - 1 {
                triangles.push([vs[0], vs[k], vs[k + 1]]);
                rows.push(i);
            }
        }
        Ok(TriMesh {
            positions: self.positions.clone(),
            triangles,
            point_data: self.point_data.clone(),
            cell_data: self.cell_data.select(&rows),
        })
    }

    /// The mesh as a tet mesh; every cell must be a tetrahedron.
    pub fn to_tet_mesh(&self) -> Result<TetMesh, MeshError> {
        self.check()?;
        let mut tets = Vec::with_capacity(self.num_cells());
        for (i, (t, vs)) in self.cells().enumerate() {
            if t != CellType::Tetra {
                return Err(MeshError::WrongCellType {
                    cell: i,
                    found: t,
                    expected: "tetrahedral",
                });
            }
            tets.push([vs[0], vs[1], vs[2], vs[3]]);
        }
        Ok(TetMesh {
            positions: self.positions.clone(),
            tets,
            point_data: self.point_data.clone(),
            cell_data: self.cell_data.clone(),
        })
    }

    /// The tets of the mesh, as a file holds them: lower-dimensional cells
    /// (boundary triangles, edges, points) are dropped with their cell data;
    /// any other volume cell is an error. A mesh without tets gives a
    /// [`TetMesh`] without tets (the caller decides whether that is an
    /// error). The lenient twin of [`CellMesh::to_tet_mesh`].
    ///
    /// # Errors
    /// [`MeshError::WrongCellType`] for a volume cell that is not a tet;
    /// the errors of the cell checks.
    pub fn volume_tets(&self) -> Result<TetMesh, MeshError> {
        self.check()?;
        let mut tets = Vec::with_capacity(self.num_cells());
        let mut rows = Vec::with_capacity(self.num_cells());
        for (i, (t, vs)) in self.cells().enumerate() {
            match t {
                CellType::Tetra => {
                    tets.push([vs[0], vs[1], vs[2], vs[3]]);
                    rows.push(i);
                }
                t if t.dimension() == 3 => {
                    return Err(MeshError::WrongCellType {
                        cell: i,
                        found: t,
                        expected: "tetrahedral (split other volume cells into tets first)",
                    });
                }
                _ => {}
            }
        }
        let cell_data = if rows.len() == self.num_cells() {
            self.cell_data.clone()
        } else {
            self.cell_data.select(&rows)
        };
        Ok(TetMesh {
            positions: self.positions.clone(),
            tets,
            point_data: self.point_data.clone(),
            cell_data,
        })
    }

    /// The line cells (lines and polylines) as vertex sequences.
    pub fn polylines(&self) -> Vec<Vec<u32>> {
        self.cells()
            .filter(|(t, _)| t.dimension() == 1)
            .map(|(_, vs)| vs.to_vec())
            .collect()
    }

    /// Adds a point-data field after checking its length.
    pub fn add_point_field(&mut self, field: Field) -> Result<(), MeshError> {
        check_len(&field, self.positions.len())?;
        self.point_data.insert(field);
        Ok(())
    }

    /// Adds a cell-data field after checking its length.
    pub fn add_cell_field(&mut self, field: Field) -> Result<(), MeshError> {
        check_len(&field, self.num_cells())?;
        self.cell_data.insert(field);
        Ok(())
    }
}

pub(crate) fn check_len(field: &Field, n: usize) -> Result<(), MeshError> {
    if field.tuples() != n {
        return Err(MeshError::FieldLength {
            name: field.name().to_string(),
            expected: n,
            found: field.tuples(),
        });
    }
    Ok(())
}

fn from_fixed<const K: usize>(
    positions: &[Point3<f64>],
    elems: &[[u32; K]],
    t: CellType,
    point_data: &Fields,
    cell_data: &Fields,
) -> CellMesh {
    CellMesh {
        positions: positions.to_vec(),
        cell_types: vec![t; elems.len()],
        offsets: (0..=elems.len()).map(|i| i * K).collect(),
        connectivity: elems.iter().flatten().copied().collect(),
        point_data: point_data.clone(),
        cell_data: cell_data.clone(),
    }
}

impl From<&TriMesh> for CellMesh {
    fn from(m: &TriMesh) -> Self {
        from_fixed(
            &m.positions,
            &m.triangles,
            CellType::Triangle,
            &m.point_data,
            &m.cell_data,
        )
    }
}

impl From<&TetMesh> for CellMesh {
    fn from(m: &TetMesh) -> Self {
        from_fixed(
            &m.positions,
            &m.tets,
            CellType::Tetra,
            &m.point_data,
            &m.cell_data,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_vtk_id_maps_to_its_type_and_no_other_id_to_any() {
        for t in CellType::ALL {
            assert_eq!(CellType::from_vtk_id(t.vtk_id()), Some(t));
        }
        let known: Vec<u8> = CellType::ALL.iter().map(|t| t.vtk_id()).collect();
        for id in 0..=u8::MAX {
            assert_eq!(
                CellType::from_vtk_id(id).is_some(),
                known.contains(&id),
                "{id}"
            );
        }
    }

    #[test]
    fn volume_tets_drop_lower_cells_and_refuse_other_volume_cells() {
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let mut m = CellMesh::from_points(vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(1.0, 1.0, 0.0),
        ]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        let t = m.volume_tets().unwrap();
        assert_eq!(t.tets, vec![[0, 1, 2, 3]]);
        let mut tri = CellMesh::from_points(m.positions.clone());
        tri.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(tri.volume_tets().unwrap().tets.is_empty());
        let mut pyramid = CellMesh::from_points(m.positions.clone());
        pyramid.push_cell(CellType::Pyramid, &[0, 1, 4, 2, 3]);
        let e = pyramid.volume_tets().unwrap_err();
        assert!(
            matches!(
                e,
                MeshError::WrongCellType {
                    cell: 0,
                    found: CellType::Pyramid,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("split other volume cells"), "{e}");
    }

    fn quad_mesh() -> CellMesh {
        let mut m = CellMesh::from_points(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ]);
        m.push_cell(CellType::Quad, &[0, 1, 2, 3]);
        m.add_cell_field(Field::labels("id", vec![7])).unwrap();
        m
    }

    #[test]
    fn quad_becomes_two_triangles_with_repeated_cell_data() {
        let t = quad_mesh().to_tri_mesh().unwrap();
        assert_eq!(t.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(t.cell_data.get("id").unwrap().tuples(), 2);
    }

    #[test]
    fn check_catches_bad_index_and_size() {
        let mut m = quad_mesh();
        m.push_cell(CellType::Triangle, &[0, 1, 9]);
        assert!(matches!(
            m.check(),
            Err(MeshError::IndexOutOfRange { index: 9, .. })
        ));
        let mut m = quad_mesh();
        m.cell_data = Fields::new();
        m.push_cell(CellType::Tetra, &[0, 1, 2]);
        assert!(matches!(m.check(), Err(MeshError::CellSize { .. })));
        assert!(matches!(
            quad_mesh().to_tet_mesh(),
            Err(MeshError::WrongCellType { .. })
        ));
    }
}
