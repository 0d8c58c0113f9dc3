//! The largest connected component of a mesh, compacted.

use crate::{
    MeshError, TetMesh, TriMesh, reindex::compact_vertices, topology::connected_components,
};

impl TetMesh {
    /// The connected component (through shared vertices) with the most
    /// tets (the first such on ties), compacted: cell data of its tets and
    /// point data of its vertices are carried over. The returned `Vec` maps
    /// new vertex -> old vertex. An empty mesh gives an empty mesh.
    ///
    /// Fails when an element refers to a vertex that does not exist or a
    /// field's length does not fit the mesh.
    pub fn largest_component(&self) -> Result<(TetMesh, Vec<u32>), MeshError> {
        crate::geometry::check_indices(self.positions.len(), &self.tets)?;
        self.cell_data.check_tuples(self.tets.len())?;
        let rows = largest(&self.tets, self.positions.len());
        let tets: Vec<[u32; 4]> = rows.iter().map(|&t| self.tets[t]).collect();
        let k = compact_vertices(&self.positions, &self.point_data, &tets)?;
        Ok((
            TetMesh {
                positions: k.positions,
                tets: k.elements,
                point_data: k.point_data,
                cell_data: self.cell_data.select(&rows),
            },
            k.to_old,
        ))
    }
}

impl TriMesh {
    /// The connected component (through shared vertices) with the most
    /// triangles (the first such on ties), compacted: cell data of its
    /// triangles and point data of its vertices are carried over. The
    /// returned `Vec` maps new vertex -> old vertex. An empty mesh gives an
    /// empty mesh.
    ///
    /// Fails when an element refers to a vertex that does not exist or a
    /// field's length does not fit the mesh.
    pub fn largest_component(&self) -> Result<(TriMesh, Vec<u32>), MeshError> {
        crate::geometry::check_indices(self.positions.len(), &self.triangles)?;
        self.cell_data.check_tuples(self.triangles.len())?;
        let rows = largest(&self.triangles, self.positions.len());
        let tris: Vec<[u32; 3]> = rows.iter().map(|&t| self.triangles[t]).collect();
        let k = compact_vertices(&self.positions, &self.point_data, &tris)?;
        Ok((
            TriMesh {
                positions: k.positions,
                triangles: k.elements,
                point_data: k.point_data,
                cell_data: self.cell_data.select(&rows),
            },
            k.to_old,
        ))
    }
}

/// Element rows of the largest component (the first on ties).
fn largest<const K: usize>(elements: &[[u32; K]], n: usize) -> Vec<usize> {
    let c = connected_components(n, elements);
    let Some(best) = (0..c.count).max_by(|&a, &b| {
        c.element_counts[a]
            .cmp(&c.element_counts[b])
            .then(b.cmp(&a))
    }) else {
        return Vec::new();
    };
    (0..elements.len())
        .filter(|&e| c.element_label[e] == best as u32)
        .collect()
}
