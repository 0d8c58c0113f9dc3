//! Per-element evaluation in `F = J`: value, gradient `dpsi/dF` and the exact
//! or PSD-projected Hessian `d2psi/dF2` through the analytic eigensystem
//! (module docs of [`crate::energy`]), and the value-only densities.

use std::f64::consts::FRAC_1_SQRT_2;

use nalgebra::{Matrix2, Matrix3, Matrix4, SMatrix};

use super::eigen3::eigen3_at;
use super::svd::{JACOBI_MAX_SWEEPS, norm2, signed_svd2, signed_svd3};
use super::{DistortionEnergy, PAIRS};

/// Which Hessian [`eval2`] / [`eval3`] compute (default: `Projected`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum HessianMode {
    /// Value and gradient only.
    None,
    /// `d2psi/dF2` assembled from the analytic eigensystem with the raw
    /// eigenvalues (may be indefinite).
    Exact,
    /// The same with every eigenvalue clamped at 0 (PSD), for Newton.
    #[default]
    Projected,
}

/// A 2D element evaluation: `psi(F)`, `dpsi/dF` (2x2) and optionally
/// `d2psi/dF2` (4x4 over column-major `vec(F)`, entry `F[(i, j)]` at
/// index `i + 2 j`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eval2 {
    /// `psi(s(F))`.
    pub value: f64,
    /// `dpsi/dF = U diag(dpsi/ds) V^T`.
    pub grad: Matrix2<f64>,
    /// `d2psi/dF2` (exact or projected), if requested.
    pub hess: Option<Matrix4<f64>>,
}

/// A 3D element evaluation: `psi(F)`, `dpsi/dF` (3x3) and optionally
/// `d2psi/dF2` (9x9 over column-major `vec(F)`, entry `F[(i, j)]` at
/// index `i + 3 j`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eval3 {
    /// `psi(s(F))`.
    pub value: f64,
    /// `dpsi/dF = U diag(dpsi/ds) V^T`.
    pub grad: Matrix3<f64>,
    /// `d2psi/dF2` (exact or projected), if requested.
    pub hess: Option<SMatrix<f64, 9, 9>>,
}

/// PSD projection of a symmetric 3x3 matrix: unchanged when diagonal
/// (clamped) or positive definite (Cholesky succeeds), else eigenvalues
/// clamped at 0 through [`sym_eigen3`].
#[allow(clippy::needless_range_loop)]
pub(super) fn project_sym3(h: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let off = h[0][1].abs() + h[0][2].abs() + h[1][2].abs();
    if off == 0.0 {
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            out[i][i] = h[i][i].max(0.0);
        }
        return out;
    }
    let m = Matrix3::from_fn(|i, j| h[i][j]);
    if !m.iter().all(|x| x.is_finite()) || m.cholesky().is_some() {
        return h;
    }
    let (l, w) = sym_eigen3(h);
    let mut out = [[0.0; 3]; 3];
    for k in 0..3 {
        if l[k] > 0.0 {
            for i in 0..3 {
                for j in 0..3 {
                    out[i][j] += l[k] * w[k][i] * w[k][j];
                }
            }
        }
    }
    out
}

/// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi
/// rotations `A <- J^T A J` (quadratic convergence, stops when every
/// off-diagonal entry is below `1e-18 |A|_F`): eigenvalues `l` and unit
/// eigenvectors `w[k]`, `A = sum_k l_k w_k w_k^T`. Accurate to `eps |A|`
/// also for repeated eigenvalues.
#[allow(clippy::needless_range_loop)]
fn sym_eigen3(h: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut a = h;
    let mut w = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let fro = a.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    let tol = 1e-18 * fro;
    for _sweep in 0..JACOBI_MAX_SWEEPS {
        let mut rotated = false;
        for &(p, q) in &PAIRS {
            let apq = a[p][q];
            if apq.abs() <= tol {
                continue;
            }
            rotated = true;
            let (dd, g2) = (a[q][q] - a[p][p], 2.0 * apq);
            let t = g2 / (dd + (dd * dd + g2 * g2).sqrt().copysign(dd));
            let c = 1.0 / (1.0 + t * t).sqrt();
            let s = c * t;
            // A J (columns p, q), then J^T (A J) (rows p, q).
            for k in 0..3 {
                let (x, y) = (a[k][p], a[k][q]);
                a[k][p] = c * x - s * y;
                a[k][q] = s * x + c * y;
            }
            for k in 0..3 {
                let (x, y) = (a[p][k], a[q][k]);
                a[p][k] = c * x - s * y;
                a[q][k] = s * x + c * y;
            }
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            // W J: eigenvectors as w[k] (columns of W).
            let (wp, wq) = (w[p], w[q]);
            for k in 0..3 {
                w[p][k] = c * wp[k] - s * wq[k];
                w[q][k] = s * wp[k] + c * wq[k];
            }
        }
        if !rotated {
            break;
        }
    }
    ([a[0][0], a[1][1], a[2][2]], w)
}

/// The Hessian `d2psi/dF2` of a 2D element as its eigensystem:
///
/// ```text
/// d2psi/dF2 = sum_k values[k] vec(modes[k]) vec(modes[k])^T
/// ```
///
/// with four Frobenius-orthonormal 2x2 `modes` (signed SVD
/// `F = U diag(s) V^T`): the two scaling modes `U diag(w) V^T` (`w` the unit
/// eigenvectors of `d2psi/ds2`, whose eigenvalues they carry), the twist
/// `U [[0, -1], [1, 0]] V^T / sqrt 2` and the flip
/// `U [[0, 1], [1, 0]] V^T / sqrt 2` ([`crate::energy`] docs). Projected,
/// every eigenvalue is clamped at 0.
///
/// A rank-one sum is what a vertex Hessian wants: with `C` the map from the
/// 6 vertex coordinates to `vec(F)`, `C^T H C = sum_k l_k (C^T m_k)(C^T m_k)^T`,
/// four 6-vectors instead of a 4x4 product on each side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eigen2 {
    /// The eigenvalues `l_k` (clamped at 0 when projected).
    pub values: [f64; 4],
    /// The unit eigenvectors `m_k` as 2x2 matrices.
    pub modes: [Matrix2<f64>; 4],
}

impl Eigen2 {
    /// `sum_k l_k vec(m_k) vec(m_k)^T` (4x4 over column-major `vec(F)`).
    pub fn matrix(&self) -> Matrix4<f64> {
        let mut h = Matrix4::zeros();
        for (l, m) in self.values.iter().zip(&self.modes) {
            let v = [m[(0, 0)], m[(1, 0)], m[(0, 1)], m[(1, 1)]];
            for c in 0..4 {
                for r in 0..4 {
                    h[(r, c)] += l * v[r] * v[c];
                }
            }
        }
        h
    }
}

/// Value, gradient and Hessian eigensystem of `psi` at a 2x2 `F`: the
/// common part of [`eval2`] (value and gradient from the closed form where
/// the energy has one), for callers that want the Hessian as a sum of
/// rank-one terms ([`Eigen2`]). `mode` is `Exact` or `Projected` (`None`
/// is taken as `Projected`). `None` when `psi(F)` is not finite. No heap
/// allocation.
pub fn eval2_eigen(
    e: &dyn DistortionEnergy,
    f: &Matrix2<f64>,
    mode: HessianMode,
) -> Option<(f64, Matrix2<f64>, Eigen2)> {
    let mut grad = Matrix2::zeros();
    let closed = e.closed_form2(f, Some(&mut grad));
    match closed {
        Some(x) if !x.is_finite() => return None,
        None if e.is_barrier() && nonpositive_or_nan(f.determinant()) => return None,
        _ => {}
    }
    let (u, sv, v) = signed_svd2(f);
    let s = [sv[0], sv[1]];
    let value = match closed {
        Some(x) => x,
        None => {
            let x = e.value(&s);
            if !x.is_finite() {
                return None;
            }
            let mut g = [0.0; 2];
            e.gradient(&s, &mut g);
            grad = grad2(&u, &g, &v);
            x
        }
    };
    Some((value, grad, eigen_from_svd(e, &u, &s, &v, mode)))
}

/// The Hessian eigensystem alone ([`Eigen2`]), for assemblies that take
/// value and gradient elsewhere: `None` exactly where [`eval2_eigen`] is
/// (`psi(F)` not finite), the same eigensystem otherwise.
pub fn hessian2_eigen(
    e: &dyn DistortionEnergy,
    f: &Matrix2<f64>,
    mode: HessianMode,
) -> Option<Eigen2> {
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return None;
    }
    let (u, sv, v) = signed_svd2(f);
    let s = [sv[0], sv[1]];
    let admissible = match e.closed_form2(f, None) {
        Some(x) => x.is_finite(),
        None => e.value(&s).is_finite(),
    };
    admissible.then(|| eigen_from_svd(e, &u, &s, &v, mode))
}

/// The eigensystem of [`Eigen2`] from the signed SVD.
#[inline]
fn eigen_from_svd(
    e: &dyn DistortionEnergy,
    u: &Matrix2<f64>,
    s: &[f64; 2],
    v: &Matrix2<f64>,
    mode: HessianMode,
) -> Eigen2 {
    let (u0, u1) = (u.column(0), u.column(1));
    let (v0, v1) = (v.column(0), v.column(1));
    let project = mode != HessianMode::Exact;
    // Scaling block: a Jacobi rotation diagonalizes the symmetric 2x2
    // d2psi/ds2 = [[a, b], [b, c]] (t = tan of the angle, the smaller root
    // of t^2 + 2 z t - 1 = 0, z = (c - a) / 2b).
    let mut h = [0.0; 4];
    e.hessian(s, &mut h);
    let (a, b, c) = (h[0], 0.5 * (h[1] + h[2]), h[3]);
    let (l0, l1, cs, sn) = if b == 0.0 {
        (a, c, 1.0, 0.0)
    } else {
        let z = (c - a) / (2.0 * b);
        let t = (1.0f64).copysign(z) / (z.abs() + norm2(1.0, z));
        let cs = 1.0 / norm2(1.0, t);
        (a - t * b, c + t * b, cs, t * cs)
    };
    let mut twist = [0.0; 1];
    let mut flip = [0.0; 1];
    e.pair_eigenvalues(s, &mut twist, &mut flip);
    let mut values = [l0, l1, twist[0], flip[0]];
    if project {
        for l in &mut values {
            *l = l.max(0.0);
        }
    }
    // Eigenvectors (cs, -sn) and (sn, cs) of the scaling block.
    let p0 = u0 * v0.transpose();
    let p1 = u1 * v1.transpose();
    let x = u0 * v1.transpose();
    let y = u1 * v0.transpose();
    let modes = [
        p0 * cs - p1 * sn,
        p0 * sn + p1 * cs,
        (y - x) * FRAC_1_SQRT_2,
        (x + y) * FRAC_1_SQRT_2,
    ];
    Eigen2 { values, modes }
}

/// `dpsi/dF = U diag(g) V^T` from `g = dpsi/ds`.
#[inline]
pub(super) fn grad2(u: &Matrix2<f64>, g: &[f64; 2], v: &Matrix2<f64>) -> Matrix2<f64> {
    Matrix2::from_fn(|r, c| u[(r, 0)] * g[0] * v[(c, 0)] + u[(r, 1)] * g[1] * v[(c, 1)])
}

/// Value, gradient and (optionally) Hessian of `psi` at a 2x2 `F`.
///
/// `None` when `psi(F)` is not finite (barrier energies at `det F <= 0`,
/// non-finite `F`). Otherwise, with the signed SVD `F = U diag(s) V^T`
/// ([`signed_svd2`]): value `psi(s)`, gradient `U diag(dpsi/ds) V^T` (or
/// both from the energy's [`closed_form2`](DistortionEnergy::closed_form2),
/// without the SVD when no Hessian is asked for), and the
/// Hessian from the analytic eigensystem ([`eval2_eigen`]): 2 scaling modes
/// from the 2x2 `d2psi/ds2`, one twist and one flip mode;
/// [`HessianMode::Projected`] clamps their eigenvalues at 0. No heap
/// allocation.
pub fn eval2(e: &dyn DistortionEnergy, f: &Matrix2<f64>, mode: HessianMode) -> Option<Eval2> {
    if mode == HessianMode::None {
        let mut grad = Matrix2::zeros();
        if let Some(value) = e.closed_form2(f, Some(&mut grad)) {
            return value.is_finite().then_some(Eval2 {
                value,
                grad,
                hess: None,
            });
        }
        if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
            return None;
        }
        let (u, sv, v) = signed_svd2(f);
        let s = [sv[0], sv[1]];
        let value = e.value(&s);
        if !value.is_finite() {
            return None;
        }
        let mut g = [0.0; 2];
        e.gradient(&s, &mut g);
        let grad = grad2(&u, &g, &v);
        return Some(Eval2 {
            value,
            grad,
            hess: None,
        });
    }
    let (value, grad, eigen) = eval2_eigen(e, f, mode)?;
    Some(Eval2 {
        value,
        grad,
        hess: Some(eigen.matrix()),
    })
}

/// Value, gradient and (optionally) Hessian of `psi` at a 3x3 `F`.
///
/// `None` when `psi(F)` is not finite (barrier energies at `det F <= 0`,
/// non-finite `F`). Otherwise, with the signed SVD `F = U diag(s) V^T`
/// ([`signed_svd3`]): value `psi(s)`, gradient `U diag(dpsi/ds) V^T` (both
/// from the energy's [`closed_form3`](DistortionEnergy::closed_form3),
/// without the SVD, when no Hessian is asked for), and the
/// 9x9 Hessian from the analytic eigensystem ([`crate::energy`] docs): 3
/// scaling modes from the 3x3 `d2psi/ds2` (projected through its
/// eigen-decomposition unless it is already positive definite), 3 twist and
/// 3 flip modes;
/// [`HessianMode::Projected`] clamps every eigenvalue at 0. No heap
/// allocation.
pub fn eval3(e: &dyn DistortionEnergy, f: &Matrix3<f64>, mode: HessianMode) -> Option<Eval3> {
    let mut grad = Matrix3::zeros();
    let closed = e.closed_form3(f, Some(&mut grad));
    match closed {
        Some(x) if !x.is_finite() => return None,
        Some(value) if mode == HessianMode::None => {
            return Some(Eval3 {
                value,
                grad,
                hess: None,
            });
        }
        None if e.is_barrier() && nonpositive_or_nan(f.determinant()) => return None,
        _ => {}
    }
    let (u, sv, v) = signed_svd3(f);
    let s = [sv[0], sv[1], sv[2]];
    let value = match closed {
        Some(x) => x,
        None => {
            let x = e.value(&s);
            if !x.is_finite() {
                return None;
            }
            let mut g = [0.0; 3];
            e.gradient(&s, &mut g);
            grad = Matrix3::from_fn(|r, c| {
                u[(r, 0)] * g[0] * v[(c, 0)]
                    + u[(r, 1)] * g[1] * v[(c, 1)]
                    + u[(r, 2)] * g[2] * v[(c, 2)]
            });
            x
        }
    };
    let hess = match mode {
        HessianMode::None => None,
        HessianMode::Exact | HessianMode::Projected => {
            let project = mode == HessianMode::Projected;
            Some(eigen3_at(e, &u, &s, &v, project).matrix())
        }
    };
    Some(Eval3 { value, grad, hess })
}

/// `psi(F)` for a 2x2 `F` (value only, no gradient or Hessian): the
/// energy's closed form ([`DistortionEnergy::closed_form2`]) where it has
/// one, else `psi(s)` of the signed singular values; `f64::INFINITY` when
/// not admissible (barrier energies at `det F <= 0`, which skip the SVD) or
/// not finite. Equal to `eval2(e, f, _).value` where that is `Some`.
pub fn density2(e: &dyn DistortionEnergy, f: &Matrix2<f64>) -> f64 {
    if let Some(x) = e.closed_form2(f, None) {
        return if x.is_finite() { x } else { f64::INFINITY };
    }
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return f64::INFINITY;
    }
    let (_, s, _) = signed_svd2(f);
    let x = e.value(&[s[0], s[1]]);
    if x.is_finite() { x } else { f64::INFINITY }
}

/// `psi(F)` for a 3x3 `F` (value only, no gradient or Hessian): the
/// energy's closed form ([`DistortionEnergy::closed_form3`]) where it has
/// one, else `psi(s)` of the signed singular values, `f64::INFINITY` when not admissible (barrier
/// energies at `det F <= 0`, which skip the SVD) or not finite. Equal to
/// `eval3(e, f, _).value` where that is `Some`.
pub fn density3(e: &dyn DistortionEnergy, f: &Matrix3<f64>) -> f64 {
    if let Some(x) = e.closed_form3(f, None) {
        return if x.is_finite() { x } else { f64::INFINITY };
    }
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return f64::INFINITY;
    }
    let (_, s, _) = signed_svd3(f);
    let x = e.value(&[s[0], s[1], s[2]]);
    if x.is_finite() { x } else { f64::INFINITY }
}

/// `x <= 0` or NaN.
#[inline]
pub(super) fn nonpositive_or_nan(x: f64) -> bool {
    x.is_nan() || x <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::test_support::*;
    use crate::energy::{Arap, SymmetricDirichlet};
    use nalgebra::{Matrix2, Matrix3, Vector3};
    use proptest::prelude::*;

    /// Closed forms in F of the four energies (SD, MIPS, area ratio) and
    /// ARAP from the known signed singular values.
    fn reference_value(
        e: &dyn DistortionEnergy,
        f_norm2: f64,
        det: f64,
        inv_norm2: f64,
        s: &[f64],
    ) -> f64 {
        let d = s.len() as f64;
        match e.name() {
            "symmetric-dirichlet" => f_norm2 + inv_norm2,
            "mips" => f_norm2 / det.powf(2.0 / d),
            "area-ratio" => det + 1.0 / det,
            "arap" => s.iter().map(|x| (x - 1.0) * (x - 1.0)).sum(),
            other => panic!("unknown {other}"),
        }
    }

    #[test]
    fn energy_sym_eigen3_decomposes() {
        let cases = [
            [[2.0, 1.0, 0.5], [1.0, -1.0, 0.3], [0.5, 0.3, 0.0]],
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
            [[0.0, 1e-20, 0.0], [1e-20, 0.0, 1.0], [0.0, 1.0, 0.0]],
            [[1e8, 1.0, 0.0], [1.0, 1e-8, 1e-8], [0.0, 1e-8, -3.0]],
        ];
        for h in cases {
            let (l, w) = sym_eigen3(h);
            let m = Matrix3::from_fn(|i, j| h[i][j]);
            let mut rec = Matrix3::zeros();
            for k in 0..3 {
                let v = Vector3::from(w[k]);
                assert!((v.norm() - 1.0).abs() < 1e-14);
                rec += l[k] * v * v.transpose();
            }
            assert!((rec - m).norm() <= 1e-14 * m.norm(), "{h:?}");
            let p = Matrix3::from_fn(|i, j| project_sym3(h)[i][j]);
            let lp = eigenvalues(p.as_slice(), 3);
            assert!(lp[0] >= -1e-14 * lp[2].abs().max(1e-300), "{h:?} {lp:?}");
        }
    }

    #[test]
    fn energy_derivatives_at_repeated_singular_values() {
        let r = rot3([0.1, 0.8, -0.3, 0.4]);
        let q = rot3([-0.6, 0.2, 0.5, 0.1]);
        for f in [
            Matrix3::identity(),
            r,
            r * Matrix3::from_diagonal(&Vector3::new(2.0, 2.0, 1.0)) * q,
            r * Matrix3::from_diagonal(&Vector3::new(2.0, 1.0, 1.0)) * q,
            r * 1.7,
        ] {
            for e in ENERGIES {
                check_derivatives3(e, &f, 1e-5);
            }
        }
        let a = rot2(0.4);
        for f in [
            Matrix2::identity(),
            a,
            a * 1.7,
            a * Matrix2::new(2.0, 0.0, 0.0, 1.0),
        ] {
            for e in ENERGIES {
                check_derivatives2(e, &f, 1e-5);
            }
        }
    }

    #[test]
    fn energy_barriers_reject_inverted_and_flat_elements() {
        let inverted3 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -0.5));
        let flat3 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0));
        let inverted2 = Matrix2::new(1.0, 0.0, 0.0, -0.5);
        let flat2 = Matrix2::new(1.0, 0.0, 0.0, 0.0);
        for e in ENERGIES {
            for mode in [
                HessianMode::None,
                HessianMode::Exact,
                HessianMode::Projected,
            ] {
                assert_eq!(eval3(e, &inverted3, mode).is_none(), e.is_barrier());
                assert_eq!(eval3(e, &flat3, mode).is_none(), e.is_barrier());
                assert_eq!(eval2(e, &inverted2, mode).is_none(), e.is_barrier());
                assert_eq!(eval2(e, &flat2, mode).is_none(), e.is_barrier());
            }
            assert_eq!(density3(e, &inverted3) == f64::INFINITY, e.is_barrier());
            assert_eq!(density2(e, &flat2) == f64::INFINITY, e.is_barrier());
            let nan3 = Matrix3::from_element(f64::NAN);
            assert!(eval3(e, &nan3, HessianMode::Projected).is_none());
            assert_eq!(density3(e, &nan3), f64::INFINITY);
            assert!(eval2(e, &Matrix2::from_element(f64::NAN), HessianMode::Exact).is_none());
            assert_eq!(e.value(&[1.0, 1.0, -1.0]).is_infinite(), e.is_barrier());
        }
        // ARAP on a flat / exactly reflected element: finite, projected PSD.
        let arap = eval3(&Arap, &flat3, HessianMode::Projected).unwrap();
        assert_eq!(arap.value, 1.0);
        let l = eigenvalues(arap.hess.unwrap().as_slice(), 9);
        assert!(l.iter().all(|x| x.is_finite()) && l[0] >= -1e-9 * l[8]);
        let refl = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        let arap = eval3(&Arap, &refl, HessianMode::Projected).unwrap();
        assert_eq!(arap.value, 4.0);
        assert!(arap.hess.unwrap().iter().all(|x| x.is_finite()));
    }

    #[test]
    fn the_hessian_eigensystem_alone_is_eval2_eigens() {
        let fs = [
            Matrix2::new(1.2, 0.3, -0.2, 0.7),
            Matrix2::new(0.4, -0.9, 0.8, 0.3),
            Matrix2::new(-1.0, 0.0, 0.0, 1.0),
            Matrix2::new(1.0, 2.0, 0.5, 1.0),
            Matrix2::from_element(f64::NAN),
        ];
        for e in ENERGIES {
            for f in &fs {
                for mode in [HessianMode::Exact, HessianMode::Projected] {
                    assert_eq!(
                        hessian2_eigen(e, f, mode),
                        eval2_eigen(e, f, mode).map(|x| x.2),
                        "{} at {f}",
                        e.name()
                    );
                }
            }
        }
    }

    #[test]
    fn energy_modes_agree_on_value_and_gradient() {
        let f = Matrix3::new(1.2, 0.3, -0.1, 0.2, 0.9, 0.4, -0.3, 0.1, 1.5);
        let f2 = Matrix2::new(1.2, 0.3, -0.2, 0.7);
        for e in ENERGIES {
            let a = eval3(e, &f, HessianMode::None).unwrap();
            assert!(a.hess.is_none());
            for mode in [HessianMode::Exact, HessianMode::Projected] {
                let b = eval3(e, &f, mode).unwrap();
                assert_eq!((a.value, a.grad), (b.value, b.grad));
                assert!(b.hess.is_some());
            }
            let a = eval2(e, &f2, HessianMode::None).unwrap();
            assert!(a.hess.is_none());
            let b = eval2(e, &f2, HessianMode::Projected).unwrap();
            assert_eq!((a.value, a.grad), (b.value, b.grad));
        }
    }

    #[test]
    fn energy_hessian_is_symmetric_and_indexed_column_major() {
        // psi = ARAP at F = diag(2, 1.5, 1.2): dpsi/dF = 2 (F - I), and the
        // Hessian is 2 I on the diagonal block of each entry F[(i, i)].
        let f = Matrix3::from_diagonal(&Vector3::new(2.0, 1.5, 1.2));
        let ev = eval3(&Arap, &f, HessianMode::Exact).unwrap();
        let h = ev.hess.unwrap();
        assert_close(h.as_slice(), h.transpose().as_slice(), 0.0, "symmetry");
        for i in 0..3 {
            let k = i + 3 * i;
            assert!((h[(k, k)] - 2.0).abs() < 1e-12);
        }
        // Off-diagonal entry F[(0, 1)] (index 3) couples with F[(1, 0)]
        // (index 1): twist/flip of pair (0, 1) = (2 - 4/3.5 -/+ 2) / 2.
        let lt = 2.0 - 4.0 / 3.5;
        assert!((h[(3, 3)] - 0.5 * (lt + 2.0)).abs() < 1e-12);
        assert!((h[(1, 3)] - 0.5 * (2.0 - lt)).abs() < 1e-12);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn energy_values_match_closed_forms_3d((f, s) in well_shaped3()) {
            let inv = f.try_inverse().unwrap();
            for e in ENERGIES {
                let want = reference_value(e, f.norm_squared(), f.determinant(), inv.norm_squared(), &s);
                let got = eval3(e, &f, HessianMode::None).unwrap().value;
                prop_assert!((got - want).abs() <= 1e-10 * want.abs().max(1.0), "{} {got} {want}", e.name());
                prop_assert_eq!(density3(e, &f), got);
            }
        }

        #[test]
        fn energy_values_match_closed_forms_2d((f, s) in well_shaped2()) {
            let inv = f.try_inverse().unwrap();
            for e in ENERGIES {
                let want = reference_value(e, f.norm_squared(), f.determinant(), inv.norm_squared(), &s);
                let got = eval2(e, &f, HessianMode::None).unwrap().value;
                prop_assert!((got - want).abs() <= 1e-10 * want.abs().max(1.0), "{} {got} {want}", e.name());
                prop_assert_eq!(density2(e, &f), got);
            }
        }

        #[test]
        fn energy_gradient_and_exact_hessian_match_fd_3d((f, _s) in well_shaped3()) {
            for e in ENERGIES {
                check_derivatives3(e, &f, 1e-5);
            }
        }

        #[test]
        fn energy_gradient_and_exact_hessian_match_fd_2d((f, _s) in well_shaped2()) {
            for e in ENERGIES {
                check_derivatives2(e, &f, 1e-5);
            }
        }

        #[test]
        fn energy_rotation_invariance_3d((f, _s) in well_shaped3(), q in quat()) {
            let r = rot3(q);
            for e in ENERGIES {
                let v = density3(e, &f);
                for g in [r * f, f * r] {
                    let w = density3(e, &g);
                    prop_assert!((v - w).abs() <= 1e-11 * v.abs().max(1.0), "{} {v} {w}", e.name());
                }
            }
        }

        #[test]
        fn energy_rotation_invariance_2d((f, _s) in well_shaped2(), a in angle()) {
            let r = rot2(a);
            for e in ENERGIES {
                let v = density2(e, &f);
                for g in [r * f, f * r] {
                    let w = density2(e, &g);
                    prop_assert!((v - w).abs() <= 1e-11 * v.abs().max(1.0), "{} {v} {w}", e.name());
                }
            }
        }

        #[test]
        fn energy_minimum_at_rotations(q in quat(), a in angle()) {
            let (r3, r2) = (rot3(q), rot2(a));
            for e in ENERGIES {
                let ev = eval3(e, &r3, HessianMode::Exact).unwrap();
                prop_assert!((ev.value - e.minimum(3)).abs() < 1e-12, "{} {}", e.name(), ev.value);
                prop_assert!(ev.grad.amax() < 1e-12, "{} {}", e.name(), ev.grad);
                let ev = eval2(e, &r2, HessianMode::Exact).unwrap();
                prop_assert!((ev.value - e.minimum(2)).abs() < 1e-12, "{} {}", e.name(), ev.value);
                prop_assert!(ev.grad.amax() < 1e-12, "{} {}", e.name(), ev.grad);
            }
        }

        #[test]
        fn energy_projected_hessian_is_psd_3d((f, _s) in well_shaped3()) {
            for e in ENERGIES {
                let ex = eval3(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
                let pr = eval3(e, &f, HessianMode::Projected).unwrap().hess.unwrap();
                check_projection(ex.as_slice(), pr.as_slice(), 9, e.name());
            }
        }

        #[test]
        fn energy_projected_hessian_is_psd_2d((f, _s) in well_shaped2()) {
            for e in ENERGIES {
                let ex = eval2(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
                let pr = eval2(e, &f, HessianMode::Projected).unwrap().hess.unwrap();
                check_projection(ex.as_slice(), pr.as_slice(), 4, e.name());
            }
        }

        /// Stretched elements (s in [1, 3]): symmetric Dirichlet and ARAP
        /// are convex there, so Projected must equal Exact.
        #[test]
        fn energy_projected_equals_exact_when_convex(q1 in quat(), s in prop::array::uniform3(1.05f64..3.0), q2 in quat()) {
            let f = compose3(q1, s, q2);
            for e in [&SymmetricDirichlet as &dyn DistortionEnergy, &Arap] {
                let ex = eval3(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
                let pr = eval3(e, &f, HessianMode::Projected).unwrap().hess.unwrap();
                prop_assert!(eigenvalues(ex.as_slice(), 9)[0] > 0.0);
                assert_close(pr.as_slice(), ex.as_slice(), 1e-12, e.name());
            }
        }

        /// Nearly equal singular values (relative gaps down to 0): finite
        /// Hessians matching finite differences (no 0/0 in the flip modes).
        #[test]
        fn energy_near_equal_singular_values_match_fd(
            q1 in quat(), q2 in quat(), sigma in 0.5f64..2.0, t in 0.3f64..0.9,
            a1 in angle(), a2 in angle(),
        ) {
            for gap in [0.0, 1e-15, 1e-12, 1e-9, 1e-7, 1e-5] {
                let f = compose3(q1, [sigma * (1.0 + gap), sigma, t * sigma], q2);
                let g = compose3(q1, [sigma, t * sigma * (1.0 + gap), t * sigma], q2);
                let h = compose2(a1, [sigma * (1.0 + gap), sigma], a2);
                for e in ENERGIES {
                    check_derivatives3(e, &f, 1e-5);
                    check_derivatives3(e, &g, 1e-5);
                    check_derivatives2(e, &h, 1e-5);
                }
            }
        }
    }
}
