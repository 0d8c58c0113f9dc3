//! The generalized winding number of a closed triangle surface about a
//! point.
//!
//! Each triangle `(x0, x1, x2)` subtends at `p` the signed solid angle
//! `Omega`, by Van Oosterom and Strackee's formula with `a = x0 - p`,
//! `b = x1 - p`, `c = x2 - p`:
//!
//! ```text
//! tan(Omega / 2) = a . (b x c) / (|a||b||c| + (a . b)|c| + (a . c)|b| + (b . c)|a|)
//! ```
//!
//! (`Omega = 2 atan2(numerator, denominator)`, in `(-2 pi, 2 pi]`), and the
//! winding number is `w(p) = sum_t Omega_t / (4 pi)`: 1 inside a closed
//! surface oriented outward (counter-clockwise seen from outside), 0
//! outside, -1 inside one oriented inward, and fractional on open
//! surfaces or near the surface (where it jumps).

use nalgebra::Point3;

/// The winding number `sum_t Omega_t / (4 pi)` of the triangles `tris` of
/// `positions` about `p` (module doc: Van Oosterom and Strackee's solid
/// angles, summed in triangle order).
///
/// # Panics
/// When a triangle refers to a vertex out of range of `positions`.
pub fn winding_number(p: &Point3<f64>, positions: &[Point3<f64>], tris: &[[u32; 3]]) -> f64 {
    let mut total = 0.0;
    for t in tris {
        let [a, b, c] = t.map(|v| positions[v as usize] - p);
        let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
        let num = a.dot(&b.cross(&c));
        let den = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::uv_sphere;
    use proptest::prelude::*;

    /// The unit cube `[0, 1]^3`, 12 triangles oriented outward.
    fn cube() -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let mut pos = Vec::new();
        for k in 0..8u32 {
            pos.push(Point3::new(
                (k & 1) as f64,
                ((k >> 1) & 1) as f64,
                ((k >> 2) & 1) as f64,
            ));
        }
        let quads = [
            [0, 2, 3, 1], // z = 0, normal -z
            [4, 5, 7, 6], // z = 1, +z
            [0, 1, 5, 4], // y = 0, -y
            [2, 6, 7, 3], // y = 1, +y
            [0, 4, 6, 2], // x = 0, -x
            [1, 3, 7, 5], // x = 1, +x
        ];
        let tris = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (pos, tris)
    }

    #[test]
    fn cube_inside_outside_and_reversed() {
        let (pos, tris) = cube();
        let inside = Point3::new(0.3, 0.6, 0.5);
        assert!((winding_number(&inside, &pos, &tris) - 1.0).abs() < 1e-12);
        let outside = Point3::new(1.5, 0.5, 0.5);
        assert!(winding_number(&outside, &pos, &tris).abs() < 1e-12);
        let reversed: Vec<[u32; 3]> = tris.iter().map(|t| [t[0], t[2], t[1]]).collect();
        assert!((winding_number(&inside, &pos, &reversed) + 1.0).abs() < 1e-12);
        assert_eq!(winding_number(&inside, &pos, &[]), 0.0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// A sphere of radius 1 (triangulated, so slightly inside the
        /// round one): 1 within radius 0.9, 0 beyond 1.1.
        #[test]
        fn sphere_inside_is_one_outside_is_zero(
            dir in prop::array::uniform3(-1.0f64..1.0),
            r in 0.0f64..3.0,
            centre in prop::array::uniform3(-5.0f64..5.0),
        ) {
            let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            prop_assume!(n > 1e-3);
            prop_assume!(!(0.9..=1.1).contains(&r));
            let m = uv_sphere(24, 32, 1.0);
            let c = Point3::from(centre);
            let pos: Vec<Point3<f64>> = m.positions.iter().map(|q| q + c.coords).collect();
            let p = c + nalgebra::Vector3::from(dir) * (r / n);
            let w = winding_number(&p, &pos, &m.triangles);
            let expected = if r < 0.9 { 1.0 } else { 0.0 };
            prop_assert!((w - expected).abs() < 1e-9, "w = {} at r = {}", w, r);
        }
    }
}
