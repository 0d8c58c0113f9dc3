//! Validation of raw mesh arrays: finite coordinates, indices in range.

use crate::MeshError;
use nalgebra::Point3;

/// Fails with [`MeshError::NonFiniteCoordinate`] on the first NaN/inf vertex.
pub fn check_finite(positions: &[Point3<f64>]) -> Result<(), MeshError> {
    match positions
        .iter()
        .position(|p| !p.coords.iter().all(|x| x.is_finite()))
    {
        Some(v) => {
            let p = positions[v];
            Err(MeshError::NonFiniteCoordinate {
                vertex: v,
                x: p.x,
                y: p.y,
                z: p.z,
            })
        }
        None => Ok(()),
    }
}

/// Fails with [`MeshError::IndexOutOfRange`] on the first element that refers
/// to a vertex `>= n`.
pub fn check_indices<const K: usize>(n: usize, elements: &[[u32; K]]) -> Result<(), MeshError> {
    for (e, el) in elements.iter().enumerate() {
        if let Some(&i) = el.iter().find(|&&i| i as usize >= n) {
            return Err(MeshError::IndexOutOfRange {
                element: e,
                index: i,
                vertex_count: n,
            });
        }
    }
    Ok(())
}
