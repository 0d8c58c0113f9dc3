//! Taubin's lambda|mu smoothing of a triangle mesh ([`taubin_smooth`]):
//! a low-pass filter on the vertex positions that, unlike repeated
//! Laplacian smoothing, does not shrink the surface.
//!
//! With the umbrella operator `L x_v = (1 / |N(v)|) sum_{w in N(v)} x_w - x_v`
//! (`N(v)` the vertices sharing an edge with `v`), one iteration is two
//! steps,
//!
//! ```text
//! x <- x + lambda L x,    then    x <- x + mu L x,     0 < lambda < -mu,
//! ```
//!
//! a shrinking step and a slightly larger inflating one. Writing `k` for an
//! eigenvalue of `-L` (a frequency, in `[0, 2]`), a component is scaled by
//! `(1 - lambda k)(1 - mu k)` per iteration: 1 at `k = 0` and at the
//! pass-band frequency `k_pb = 1/lambda + 1/mu`, slightly above 1 between
//! them (the lowest frequencies, the overall shape, are kept), below 1
//! above `k_pb` (noise and staircases are damped). The defaults
//! `lambda = 0.5`, `mu = -0.53` give `k_pb = 0.113`. Vertices marked fixed
//! do not move (e.g. a boundary loop that must stay where it is).

use crate::topology::vertex_adjacency;
use crate::{MeshError, TriMesh};
use nalgebra::Point3;

/// Settings of [`taubin_smooth`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Taubin {
    /// Iterations (each one lambda step and one mu step).
    pub iterations: usize,
    /// The shrinking step, in `(0, 1)`. Default 0.5.
    pub lambda: f64,
    /// The inflating step, in `(-1, -lambda)`. Default -0.53.
    pub mu: f64,
}

impl Default for Taubin {
    fn default() -> Self {
        Taubin {
            iterations: 10,
            lambda: 0.5,
            mu: -0.53,
        }
    }
}

/// Smooths `mesh` in place by [`Taubin`]'s iterations (module doc); the
/// vertices with `fixed[v]` (when `fixed` is not empty) keep their
/// positions. Vertices used by no triangle do not move.
///
/// # Errors
/// `InvalidArgument` for `lambda` outside `(0, 1)`, `mu` outside
/// `(-1, -lambda)`, or `fixed` neither empty nor one flag per vertex;
/// `IndexOutOfRange` for a triangle with a vertex out of range.
pub fn taubin_smooth(
    mesh: &mut TriMesh,
    settings: &Taubin,
    fixed: &[bool],
) -> Result<(), MeshError> {
    let Taubin {
        iterations,
        lambda,
        mu,
    } = *settings;
    if !(lambda > 0.0 && lambda < 1.0) {
        return Err(MeshError::InvalidArgument(format!(
            "Taubin's lambda must be in (0, 1), got {lambda}"
        )));
    }
    if !(mu > -1.0 && mu < -lambda) {
        return Err(MeshError::InvalidArgument(format!(
            "Taubin's mu must be in (-1, -lambda) = (-1, {}), got {mu}",
            -lambda
        )));
    }
    let n = mesh.num_vertices();
    if !fixed.is_empty() && fixed.len() != n {
        return Err(MeshError::InvalidArgument(format!(
            "{} fixed flags for {n} vertices",
            fixed.len()
        )));
    }
    crate::geometry::check_indices(n, &mesh.triangles)?;
    let adj = vertex_adjacency(n, &mesh.triangles);
    let moves = |v: usize| adj.degree(v) > 0 && !fixed.get(v).copied().unwrap_or(false);
    let mut next: Vec<Point3<f64>> = mesh.positions.clone();
    for _ in 0..iterations {
        for step in [lambda, mu] {
            for (v, out) in next.iter_mut().enumerate() {
                if !moves(v) {
                    continue;
                }
                let nb = adj.neighbors(v);
                let mean = nb
                    .iter()
                    .map(|&w| mesh.positions[w as usize].coords)
                    .sum::<nalgebra::Vector3<f64>>()
                    / nb.len() as f64;
                let x = mesh.positions[v];
                *out = x + (mean - x.coords) * step;
            }
            std::mem::swap(&mut mesh.positions, &mut next);
            next.copy_from_slice(&mesh.positions);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::enclosed_volume;
    use crate::shapes::uv_sphere;
    use proptest::prelude::*;

    /// A sphere of radius 10 with every vertex moved radially by a
    /// pseudo-random amount in `[-amp, amp]` (a fixed hash of its index).
    fn noisy_sphere(amp: f64, salt: u64) -> TriMesh {
        let mut m = uv_sphere(40, 80, 10.0);
        for (i, p) in m.positions.iter_mut().enumerate() {
            let h = (i as u64 ^ salt).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11;
            let u = h as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
            let r = p.coords.norm();
            *p = Point3::from(p.coords * ((r + amp * u) / r));
        }
        m
    }

    fn radial_spread(m: &TriMesh) -> f64 {
        let r: Vec<f64> = m.positions.iter().map(|p| p.coords.norm()).collect();
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt()
    }

    #[test]
    fn laplacian_smoothing_shrinks_where_taubin_does_not() {
        let m0 = noisy_sphere(0.3, 1);
        let v0 = enclosed_volume(&m0);
        let mut t = m0.clone();
        taubin_smooth(&mut t, &Taubin::default(), &[]).unwrap();
        // plain Laplacian smoothing: lambda steps only, as many of them
        let mut l = m0.clone();
        let adj = vertex_adjacency(l.num_vertices(), &l.triangles);
        for _ in 0..20 {
            let old = l.positions.clone();
            for (v, p) in l.positions.iter_mut().enumerate() {
                let nb = adj.neighbors(v);
                let mean = nb
                    .iter()
                    .map(|&w| old[w as usize].coords)
                    .sum::<nalgebra::Vector3<f64>>()
                    / nb.len() as f64;
                *p = Point3::from(old[v].coords + (mean - old[v].coords) * 0.5);
            }
        }
        let (vt, vl) = (enclosed_volume(&t), enclosed_volume(&l));
        assert!((vt - v0).abs() < 0.01 * v0, "Taubin: {vt} vs {v0}");
        assert!(vl < 0.97 * v0, "Laplacian: {vl} vs {v0}");
        // and the noise is damped
        assert!(radial_spread(&t) < 0.5 * radial_spread(&m0));
    }

    #[test]
    fn fixed_vertices_stay_and_bad_settings_are_refused() {
        let mut m = noisy_sphere(0.3, 2);
        let before = m.positions.clone();
        let fixed: Vec<bool> = (0..m.num_vertices()).map(|v| v % 3 == 0).collect();
        taubin_smooth(&mut m, &Taubin::default(), &fixed).unwrap();
        for (v, p) in m.positions.iter().enumerate() {
            if fixed[v] {
                assert_eq!(*p, before[v]);
            }
        }
        for (lambda, mu) in [
            (0.0, -0.5),
            (1.0, -1.0),
            (0.5, -0.4),
            (0.5, -1.0),
            (f64::NAN, -0.5),
        ] {
            let s = Taubin {
                iterations: 1,
                lambda,
                mu,
            };
            assert!(matches!(
                taubin_smooth(&mut m, &s, &[]),
                Err(MeshError::InvalidArgument(_))
            ));
        }
        assert!(taubin_smooth(&mut m, &Taubin::default(), &[true; 3]).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]
        /// On noisy spheres, Taubin smoothing keeps the enclosed volume
        /// within 1.5 % whatever the noise and the iteration count, and
        /// never widens the radial spread.
        #[test]
        fn taubin_keeps_the_volume_of_noisy_spheres(
            amp in 0.1f64..0.5,
            salt in 0u64..1000,
            iterations in 1usize..30,
        ) {
            let mut m = noisy_sphere(amp, salt);
            let (v0, s0) = (enclosed_volume(&m), radial_spread(&m));
            let s = Taubin { iterations, ..Taubin::default() };
            taubin_smooth(&mut m, &s, &[]).unwrap();
            let v = enclosed_volume(&m);
            prop_assert!((v - v0).abs() < 0.015 * v0, "{} vs {}", v, v0);
            prop_assert!(radial_spread(&m) <= s0 + 1e-9);
        }
    }
}
