//! Proptest strategies shared by the geometry tests.

use nalgebra::Point3;
use proptest::prelude::*;

/// A point with coordinates uniform in `[-10, 10)`.
pub(crate) fn point() -> impl Strategy<Value = Point3<f64>> {
    (-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y, z)| Point3::new(x, y, z))
}
