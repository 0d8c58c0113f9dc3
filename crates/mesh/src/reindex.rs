//! Vertex renumbering: dropping the vertices no element uses and renumbering
//! the elements, with point data carried along. Used by repair, topology
//! (boundary extraction), coarsening and stuffing.

use crate::{Fields, MeshError, geometry::check_indices};
use nalgebra::Point3;

/// The result of [`compact_vertices`]: the used vertices only.
#[derive(Debug, Clone, PartialEq)]
pub struct Compacted<const K: usize> {
    /// Positions of the used vertices, in ascending order of their old index.
    pub positions: Vec<Point3<f64>>,
    /// Point data restricted to the used vertices.
    pub point_data: Fields,
    /// The elements renumbered to the new vertex indices.
    pub elements: Vec<[u32; K]>,
    /// New vertex `i` was old vertex `to_old[i]` (ascending).
    pub to_old: Vec<u32>,
}

/// Removes the vertices that no element uses: keeps the used ones in their
/// original order, renumbers the elements and restricts the point data with
/// [`Fields::select`].
///
/// Fails with [`MeshError::IndexOutOfRange`] or [`MeshError::FieldLength`]
/// when the elements or the point data do not fit the positions.
pub fn compact_vertices<const K: usize>(
    positions: &[Point3<f64>],
    point_data: &Fields,
    elements: &[[u32; K]],
) -> Result<Compacted<K>, MeshError> {
    check_indices(positions.len(), elements)?;
    point_data.check_tuples(positions.len())?;
    let mut new_index = vec![u32::MAX; positions.len()];
    for el in elements {
        for &v in el {
            new_index[v as usize] = 0;
        }
    }
    let mut to_old = Vec::new();
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = to_old.len() as u32;
            to_old.push(v as u32);
        }
    }
    let rows: Vec<usize> = to_old.iter().map(|&v| v as usize).collect();
    Ok(Compacted {
        positions: rows.iter().map(|&v| positions[v]).collect(),
        point_data: point_data.select(&rows),
        elements: elements
            .iter()
            .map(|el| el.map(|v| new_index[v as usize]))
            .collect(),
        to_old,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Field;

    #[test]
    fn compact_vertices_keeps_order_and_fields() {
        let positions: Vec<Point3<f64>> = (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let mut pd = Fields::new();
        pd.insert(Field::labels("l", vec![10, 11, 12, 13, 14]));
        let k = compact_vertices(&positions, &pd, &[[4u32, 1], [1, 3]]).unwrap();
        assert_eq!(k.to_old, vec![1, 3, 4]);
        assert_eq!(k.elements, vec![[2, 0], [0, 1]]);
        assert_eq!(k.positions[2].x, 4.0);
        assert_eq!(
            k.point_data.get("l").unwrap().values(),
            &crate::FieldValues::I32(vec![11, 13, 14])
        );
    }
}
