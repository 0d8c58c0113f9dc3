//! Geometry: signed volumes and areas, normals, vertex areas, centroid, PCA
//! frame, convex hull membership, bounding boxes.

use crate::MeshError;
use nalgebra::{Point3, Unit, Vector3};

/// Signed volume of the tet `(a, b, c, d)`: `(b-a)·((c-a)×(d-a)) / 6`;
/// positive when `d` lies on the side of `abc` its counter-clockwise normal
/// points to.
#[inline]
pub fn tet_signed_volume(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
    d: &Point3<f64>,
) -> f64 {
    (b - a).dot(&(c - a).cross(&(d - a))) / 6.0
}

/// Area vector of the triangle `(a, b, c)`: `(b-a)×(c-a) / 2`, its length the
/// area and its direction the counter-clockwise normal.
#[inline]
pub fn triangle_area_vector(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> Vector3<f64> {
    (b - a).cross(&(c - a)) * 0.5
}

/// Area of the triangle `(a, b, c)`: `|(b-a)×(c-a)| / 2`.
#[inline]
pub fn triangle_area(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    triangle_area_vector(a, b, c).norm()
}

/// Unit normal of the triangle `(a, b, c)`, `None` when it is degenerate.
#[inline]
pub fn triangle_normal(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Option<Unit<Vector3<f64>>> {
    Unit::try_new(triangle_area_vector(a, b, c), f64::MIN_POSITIVE)
}

/// Signed area of the planar triangle `(a, b, c)` (x, y only):
/// `((b-a) × (c-a))_z / 2`, positive when counter-clockwise.
#[inline]
pub fn triangle_signed_area_2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

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
