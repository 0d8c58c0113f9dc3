//! Triangle surface meshes.

use crate::{Field, Fields, MeshError, cells::check_len};
use nalgebra::Point3;

/// A triangle mesh: f64 positions (mm), u32 triangle indices and named
/// per-vertex (`point_data`) and per-triangle (`cell_data`) fields.
/// Plain data: derived structures (adjacency, edges, boundary loops) are
/// computed on request by the functions of [`crate::topology`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Point3<f64>>,
    /// Triangles as vertex index triples (counter-clockwise = outward normal).
    pub triangles: Vec<[u32; 3]>,
    /// One tuple per vertex.
    pub point_data: Fields,
    /// One tuple per triangle.
    pub cell_data: Fields,
}

impl TriMesh {
    /// A mesh without fields; no checks (see [`TriMesh::try_new`]).
    pub fn new(positions: Vec<Point3<f64>>, triangles: Vec<[u32; 3]>) -> Self {
        TriMesh {
            positions,
            triangles,
            point_data: Fields::new(),
            cell_data: Fields::new(),
        }
    }

    /// A mesh, checking that indices are in range and coordinates finite.
    pub fn try_new(
        positions: Vec<Point3<f64>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, MeshError> {
        crate::geometry::check_finite(&positions)?;
        crate::geometry::check_indices(positions.len(), &triangles)?;
        Ok(TriMesh::new(positions, triangles))
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// The corners of triangle `t`.
    #[inline]
    pub fn triangle_points(&self, t: usize) -> [Point3<f64>; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Adds a per-vertex field after checking its length.
    pub fn add_point_field(&mut self, field: Field) -> Result<(), MeshError> {
        check_len(&field, self.positions.len())?;
        self.point_data.insert(field);
        Ok(())
    }

    /// Adds a per-triangle field after checking its length.
    pub fn add_cell_field(&mut self, field: Field) -> Result<(), MeshError> {
        check_len(&field, self.triangles.len())?;
        self.cell_data.insert(field);
        Ok(())
    }
}
