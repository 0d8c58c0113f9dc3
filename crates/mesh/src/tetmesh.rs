//! Tetrahedral volume meshes.

use crate::{Field, Fields, MeshError, cells::check_len};
use nalgebra::Point3;

/// A tet mesh: f64 positions (mm), u32 tet indices and named per-vertex
/// (`point_data`) and per-tet (`cell_data`) fields. A tet `[a, b, c, d]` is
/// positively oriented when `(b-a)·((c-a)×(d-a)) > 0`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TetMesh {
    /// Vertex positions.
    pub positions: Vec<Point3<f64>>,
    /// Tets as vertex index quadruples.
    pub tets: Vec<[u32; 4]>,
    /// One tuple per vertex.
    pub point_data: Fields,
    /// One tuple per tet.
    pub cell_data: Fields,
}

impl TetMesh {
    /// A mesh without fields; no checks (see [`TetMesh::try_new`]).
    pub fn new(positions: Vec<Point3<f64>>, tets: Vec<[u32; 4]>) -> Self {
        TetMesh {
            positions,
            tets,
            point_data: Fields::new(),
            cell_data: Fields::new(),
        }
    }

    /// A mesh, checking that indices are in range and coordinates finite.
    pub fn try_new(positions: Vec<Point3<f64>>, tets: Vec<[u32; 4]>) -> Result<Self, MeshError> {
        crate::geometry::check_finite(&positions)?;
        crate::geometry::check_indices(positions.len(), &tets)?;
        Ok(TetMesh::new(positions, tets))
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of tets.
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }

    /// The corners of tet `t`.
    #[inline]
    pub fn tet_points(&self, t: usize) -> [Point3<f64>; 4] {
        let [a, b, c, d] = self.tets[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
            self.positions[d as usize],
        ]
    }

    /// Adds a per-vertex field after checking its length.
    pub fn add_point_field(&mut self, field: Field) -> Result<(), MeshError> {
        check_len(&field, self.positions.len())?;
        self.point_data.insert(field);
        Ok(())
    }

    /// Adds a per-tet field after checking its length.
    pub fn add_cell_field(&mut self, field: Field) -> Result<(), MeshError> {
        check_len(&field, self.tets.len())?;
        self.cell_data.insert(field);
        Ok(())
    }
}
