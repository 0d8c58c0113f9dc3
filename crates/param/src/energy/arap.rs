//! The as-rigid-as-possible energy, `sum_i (s_i - 1)^2`.

use super::{DistortionEnergy, twist_denominator};

/// As-rigid-as-possible, `psi(s) = sum_i (s_i - 1)^2 = min_R |F - R|_F^2`
/// over rotations `R` (signed singular values, so inverted elements are
/// measured against the closest *rotation*).
///
/// Minimum 0 at rotations; no barrier (finite for inverted elements, so it
/// relies on the injective line search). Separable with `f(s) = (s - 1)^2`:
///
/// ```text
/// dpsi/ds_i  = 2 (s_i - 1)                 (dpsi/dF = 2 (F - R), R = U V^T)
/// d2psi/ds2  = 2 I
/// twist(i,j) = 2 - 4 / (s_i + s_j)         (< 0 when s_i + s_j < 2)
/// flip(i,j)  = 2
/// ```
///
/// The twist eigenvalue is unbounded as `s_i + s_j -> 0` (flat or inverted
/// elements with `|s_i| = |s_j|`, where the closest rotation is not unique);
/// see [`DistortionEnergy::twist_eigenvalue`] for the floor used there.
#[derive(Debug, Clone, Copy, Default)]
pub struct Arap;

impl DistortionEnergy for Arap {
    fn name(&self) -> &'static str {
        "arap"
    }
    fn value(&self, s: &[f64]) -> f64 {
        s.iter().map(|&x| (x - 1.0) * (x - 1.0)).sum()
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(s) {
            *o = 2.0 * (x - 1.0);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        out[..d * d].fill(0.0);
        for i in 0..d {
            out[i * d + i] = 2.0;
        }
    }
    fn flip_eigenvalue(&self, _s: &[f64], _i: usize, _j: usize) -> f64 {
        2.0
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        2.0 - 4.0 / twist_denominator(s[i], s[j])
    }
    fn minimum(&self, _dim: usize) -> f64 {
        0.0
    }
    fn is_barrier(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::test_support::*;
    use crate::energy::{HessianMode, eval2, eval3};
    use nalgebra::{Matrix2, Matrix3};
    use proptest::prelude::*;

    /// Inverted 3D F (det < 0) whose smallest singular value is clearly
    /// below the middle one, so ARAP is smooth there.
    fn inverted3() -> impl Strategy<Value = (Matrix3<f64>, [f64; 3])> {
        (quat(), 0.3f64..3.0, 0.3f64..3.0, 0.1f64..0.7, quat()).prop_map(|(q1, a, b, t, q2)| {
            let (a, b) = (a.max(b), a.min(b));
            let s = [a, b, -t * b];
            (compose3(q1, s, q2), s)
        })
    }

    fn inverted2() -> impl Strategy<Value = (Matrix2<f64>, [f64; 2])> {
        (angle(), 0.3f64..3.0, 0.1f64..0.7, angle()).prop_map(|(a1, a, t, a2)| {
            let s = [a, -t * a];
            (compose2(a1, s, a2), s)
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn energy_arap_inverted_matches_fd_3d((f, s) in inverted3()) {
            let ev = eval3(&Arap, &f, HessianMode::Exact).unwrap();
            let want: f64 = s.iter().map(|x| (x - 1.0) * (x - 1.0)).sum();
            prop_assert!((ev.value - want).abs() <= 1e-10 * want.max(1.0));
            check_derivatives3(&Arap, &f, 1e-5);
            let p = eval3(&Arap, &f, HessianMode::Projected).unwrap().hess.unwrap();
            check_projection(ev.hess.unwrap().as_slice(), p.as_slice(), 9, "arap inverted");
        }

        #[test]
        fn energy_arap_inverted_matches_fd_2d((f, s) in inverted2()) {
            let ev = eval2(&Arap, &f, HessianMode::Exact).unwrap();
            let want: f64 = s.iter().map(|x| (x - 1.0) * (x - 1.0)).sum();
            prop_assert!((ev.value - want).abs() <= 1e-10 * want.max(1.0));
            check_derivatives2(&Arap, &f, 1e-5);
            let p = eval2(&Arap, &f, HessianMode::Projected).unwrap().hess.unwrap();
            check_projection(ev.hess.unwrap().as_slice(), p.as_slice(), 4, "arap inverted");
        }
    }
}
