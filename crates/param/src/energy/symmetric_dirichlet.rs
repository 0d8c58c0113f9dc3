//! The symmetric Dirichlet energy, `|F|_F^2 + |F^-1|_F^2`.

use nalgebra::{Matrix2, Matrix3};

use super::{DistortionEnergy, all_positive};

/// Symmetric Dirichlet, `psi(s) = sum_i s_i^2 + s_i^-2 = |F|_F^2 + |F^-1|_F^2`.
///
/// Minimum `2 d` at rotations (4 in 2D, 6 in 3D); a barrier (infinite for
/// any `s_i <= 0`). Separable with `f(s) = s^2 + s^-2`:
///
/// ```text
/// dpsi/ds_i  = 2 s_i - 2 s_i^-3            (dpsi/dF = 2 F - 2 F^-T F^-1 F^-T)
/// d2psi/ds_i^2 = 2 + 6 s_i^-4              (off-diagonal 0)
/// twist(i,j) = 2 - 2 (s_i^2 - s_i s_j + s_j^2) / (s_i^3 s_j^3)   (can be < 0)
/// flip(i,j)  = 2 + 2 (s_i^2 + s_i s_j + s_j^2) / (s_i^3 s_j^3)
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct SymmetricDirichlet;

impl DistortionEnergy for SymmetricDirichlet {
    fn name(&self) -> &'static str {
        "symmetric-dirichlet"
    }
    fn value(&self, s: &[f64]) -> f64 {
        if !all_positive(s) {
            return f64::INFINITY;
        }
        s.iter()
            .map(|&x| {
                let x2 = x * x;
                x2 + 1.0 / x2
            })
            .sum()
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(s) {
            *o = 2.0 * x - 2.0 / (x * x * x);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        out[..d * d].fill(0.0);
        for (i, &x) in s.iter().enumerate() {
            let x2 = x * x;
            out[i * d + i] = 2.0 + 6.0 / (x2 * x2);
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (a, b) = (s[i], s[j]);
        let ab = a * b;
        2.0 + 2.0 * (a * a + ab + b * b) / (ab * ab * ab)
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (a, b) = (s[i], s[j]);
        let ab = a * b;
        2.0 - 2.0 * (a * a - ab + b * b) / (ab * ab * ab)
    }
    /// With `I2 = |F|_F^2`, `I3 = det F`: `psi = I2 (1 + I3^-2)` and
    /// `dpsi/dF = 2 (1 + I3^-2) F - 2 I2 I3^-3 cof F`,
    /// `cof F = [[f22, -f21], [-f12, f11]]`; infinite for `I3 <= 0`.
    fn closed_form2(&self, f: &Matrix2<f64>, grad: Option<&mut Matrix2<f64>>) -> Option<f64> {
        let det = f.m11 * f.m22 - f.m12 * f.m21;
        if det.is_nan() || det <= 0.0 {
            return Some(f64::INFINITY);
        }
        let i2 = f.m11 * f.m11 + f.m12 * f.m12 + f.m21 * f.m21 + f.m22 * f.m22;
        let r = 1.0 / (det * det);
        let value = i2 * (1.0 + r);
        if !value.is_finite() {
            return Some(f64::INFINITY);
        }
        if let Some(g) = grad {
            let k = 2.0 * (1.0 + r);
            let c = 2.0 * i2 * r / det;
            *g = Matrix2::new(
                k * f.m11 - c * f.m22,
                k * f.m12 + c * f.m21,
                k * f.m21 + c * f.m12,
                k * f.m22 - c * f.m11,
            );
        }
        Some(value)
    }
    /// With `C = cof F` (so `F^-1 = C^T / det F`):
    /// `psi = |F|_F^2 + |C|_F^2 / det^2` and
    /// `dpsi/dF = 2 F - 2 F^-T F^-1 F^-T = 2 F - 2 C C^T C / det^3`;
    /// infinite for `det F <= 0`.
    fn closed_form3(&self, f: &Matrix3<f64>, grad: Option<&mut Matrix3<f64>>) -> Option<f64> {
        let det = f.determinant();
        if det.is_nan() || det <= 0.0 {
            return Some(f64::INFINITY);
        }
        let c = cofactor3(f);
        let r = 1.0 / (det * det);
        let value = f.norm_squared() + c.norm_squared() * r;
        if !value.is_finite() {
            return Some(f64::INFINITY);
        }
        if let Some(g) = grad {
            *g = 2.0 * f - (2.0 * r / det) * (c * c.transpose() * c);
        }
        Some(value)
    }
    fn minimum(&self, dim: usize) -> f64 {
        2.0 * dim as f64
    }
    fn is_barrier(&self) -> bool {
        true
    }
}

/// The cofactor matrix, `cof(F)_ij = (-1)^(i+j) M_ij` (`M_ij` the minor
/// without row `i` and column `j`), so that `F^-1 = cof(F)^T / det F`.
pub(super) fn cofactor3(f: &Matrix3<f64>) -> Matrix3<f64> {
    Matrix3::new(
        f.m22 * f.m33 - f.m23 * f.m32,
        f.m23 * f.m31 - f.m21 * f.m33,
        f.m21 * f.m32 - f.m22 * f.m31,
        f.m13 * f.m32 - f.m12 * f.m33,
        f.m11 * f.m33 - f.m13 * f.m31,
        f.m12 * f.m31 - f.m11 * f.m32,
        f.m12 * f.m23 - f.m13 * f.m22,
        f.m13 * f.m21 - f.m11 * f.m23,
        f.m11 * f.m22 - f.m12 * f.m21,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::eval::grad2;
    use crate::energy::test_support::*;
    use crate::energy::{HessianMode, eval3, signed_svd2};
    use nalgebra::Matrix3;
    use proptest::prelude::*;

    #[test]
    fn energy_symmetric_dirichlet_gradient_matches_matrix_formula() {
        // dD/dJ = 2 J - 2 J^-T J^-1 J^-T (ALGORITHMS 1.2).
        let f = Matrix3::new(1.2, 0.3, -0.1, 0.2, 0.9, 0.4, -0.3, 0.1, 1.5);
        let inv = f.try_inverse().unwrap();
        let want = 2.0 * f - 2.0 * inv.transpose() * inv * inv.transpose();
        let got = eval3(&SymmetricDirichlet, &f, HessianMode::None)
            .unwrap()
            .grad;
        assert_close(got.as_slice(), want.as_slice(), 1e-13, "sd gradient");
    }

    proptest! {
        /// The symmetric Dirichlet closed form in `F` (no SVD) agrees with
        /// the singular-value path, and is infinite for `det F <= 0`.
        #[test]
        fn symmetric_dirichlet_closed_form_matches_the_svd_path(
            a in -3.0..3.0f64, b in -3.0..3.0f64, c in -3.0..3.0f64, d in -3.0..3.0f64,
        ) {
            let f = Matrix2::new(a, b, c, d);
            let mut g = Matrix2::zeros();
            let x = SymmetricDirichlet.closed_form2(&f, Some(&mut g)).unwrap();
            prop_assert_eq!(SymmetricDirichlet.closed_form2(&f, None), Some(x));
            if f.determinant() <= 1e-3 {
                if f.determinant() <= 0.0 {
                    prop_assert_eq!(x, f64::INFINITY);
                }
                return Ok(());
            }
            let (u, sv, v) = signed_svd2(&f);
            let s = [sv[0], sv[1]];
            let y = SymmetricDirichlet.value(&s);
            let mut gs = [0.0; 2];
            SymmetricDirichlet.gradient(&s, &mut gs);
            let gy = grad2(&u, &gs, &v);
            prop_assert!((x - y).abs() <= 1e-12 * y, "{} vs {}", x, y);
            let scale = gy.norm().max(1.0);
            prop_assert!((g - gy).norm() <= 1e-11 * scale, "{} vs {}", g, gy);
        }
    }
    proptest! {
        /// The 3D closed form (cofactors, no SVD) agrees with the
        /// singular-value path to rounding, and is infinite for
        /// `det F <= 0`.
        #[test]
        fn symmetric_dirichlet_closed_form3_matches_the_svd_path(
            e in prop::collection::vec(-3.0..3.0f64, 9),
        ) {
            let f = Matrix3::from_row_slice(&e);
            let mut g = Matrix3::zeros();
            let x = SymmetricDirichlet.closed_form3(&f, Some(&mut g)).unwrap();
            prop_assert_eq!(SymmetricDirichlet.closed_form3(&f, None), Some(x));
            let det = f.determinant();
            if det <= 0.0 {
                prop_assert_eq!(x, f64::INFINITY);
                return Ok(());
            }
            // Well enough conditioned that both paths keep 1e-10.
            let (u, sv, v) = crate::energy::signed_svd3(&f);
            prop_assume!(sv[2] > 1e-2 * sv[0]);
            let s = [sv[0], sv[1], sv[2]];
            let y = SymmetricDirichlet.value(&s);
            let mut gs = [0.0; 3];
            SymmetricDirichlet.gradient(&s, &mut gs);
            let gy = u * Matrix3::from_diagonal(&nalgebra::Vector3::from(gs)) * v.transpose();
            prop_assert!((x - y).abs() <= 1e-10 * y, "{} vs {}", x, y);
            let scale = gy.norm().max(1.0);
            prop_assert!((g - gy).norm() <= 1e-10 * scale, "{} vs {}", g, gy);
        }
    }
}
