//! Helpers shared by the energy tests: the four energies, rotations and
//! well-shaped Jacobians, finite differences and the checks built on them.

use super::{
    Arap, AreaRatio, DistortionEnergy, HessianMode, Mips, SymmetricDirichlet, density2, density3,
    eval2, eval3,
};
use nalgebra::{
    DMatrix, Matrix2, Matrix3, Quaternion, Rotation2, UnitQuaternion, Vector2, Vector3,
};
use proptest::prelude::*;

pub(super) const ENERGIES: [&dyn DistortionEnergy; 4] =
    [&SymmetricDirichlet, &Mips, &Arap, &AreaRatio];

pub(super) fn rot3(q: [f64; 4]) -> Matrix3<f64> {
    let q = Quaternion::new(q[0], q[1], q[2], q[3]);
    let q = if q.norm() < 1e-3 {
        Quaternion::identity()
    } else {
        q
    };
    UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .into_inner()
}

pub(super) fn rot2(a: f64) -> Matrix2<f64> {
    Rotation2::new(a).into_inner()
}

pub(super) fn compose3(q1: [f64; 4], s: [f64; 3], q2: [f64; 4]) -> Matrix3<f64> {
    rot3(q1) * Matrix3::from_diagonal(&Vector3::from(s)) * rot3(q2)
}

pub(super) fn compose2(a1: f64, s: [f64; 2], a2: f64) -> Matrix2<f64> {
    rot2(a1) * Matrix2::from_diagonal(&Vector2::from(s)) * rot2(a2)
}

pub(super) fn quat() -> impl Strategy<Value = [f64; 4]> {
    prop::array::uniform4(-1.0f64..1.0).prop_filter("quaternion away from 0", |q| {
        q.iter().map(|x| x * x).sum::<f64>() > 0.01
    })
}

pub(super) fn angle() -> impl Strategy<Value = f64> {
    -std::f64::consts::PI..std::f64::consts::PI
}

/// Well-shaped 3D F = R1 diag(s) R2 with s in [0.3, 3], and its s.
pub(super) fn well_shaped3() -> impl Strategy<Value = (Matrix3<f64>, [f64; 3])> {
    (quat(), prop::array::uniform3(0.3f64..3.0), quat())
        .prop_map(|(q1, s, q2)| (compose3(q1, s, q2), s))
}

pub(super) fn well_shaped2() -> impl Strategy<Value = (Matrix2<f64>, [f64; 2])> {
    (angle(), prop::array::uniform2(0.3f64..3.0), angle())
        .prop_map(|(a1, s, a2)| (compose2(a1, s, a2), s))
}

pub(super) fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// `max |a - b| <= tol * max(1, max |b|)`.
pub(super) fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len());
    let scale = max_abs(b).max(1.0);
    let err = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        err <= tol * scale,
        "{what}: error {err:e} > {tol:e} * {scale:e}\n got {a:?}\nwant {b:?}"
    );
}

pub(super) const H: f64 = 1e-6;

/// Central differences of `phi` at `x`.
pub(super) fn fd_gradient(x: &[f64], phi: impl Fn(&[f64]) -> f64) -> Vec<f64> {
    (0..x.len())
        .map(|k| {
            let mut p = x.to_vec();
            let mut m = x.to_vec();
            p[k] += H;
            m[k] -= H;
            (phi(&p) - phi(&m)) / (2.0 * H)
        })
        .collect()
}

/// Central differences of the vector function `grad` at `x`, column `k`
/// is `d grad / d x_k` (column-major like the Hessians).
pub(super) fn fd_jacobian(x: &[f64], grad: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let n = x.len();
    let mut out = vec![0.0; n * n];
    for k in 0..n {
        let mut p = x.to_vec();
        let mut m = x.to_vec();
        p[k] += H;
        m[k] -= H;
        let (gp, gm) = (grad(&p), grad(&m));
        for r in 0..n {
            out[r + n * k] = (gp[r] - gm[r]) / (2.0 * H);
        }
    }
    out
}

pub(super) fn check_derivatives3(e: &dyn DistortionEnergy, f: &Matrix3<f64>, tol: f64) {
    let ev = eval3(e, f, HessianMode::Exact).expect("admissible");
    let x = f.as_slice();
    let g_fd = fd_gradient(x, |y| density3(e, &Matrix3::from_column_slice(y)));
    assert_close(ev.grad.as_slice(), &g_fd, tol, e.name());
    let h_fd = fd_jacobian(x, |y| {
        eval3(e, &Matrix3::from_column_slice(y), HessianMode::None)
            .expect("admissible")
            .grad
            .as_slice()
            .to_vec()
    });
    let hess = ev.hess.expect("requested");
    assert!(hess.iter().all(|v| v.is_finite()), "{}", e.name());
    assert_close(hess.as_slice(), &h_fd, tol, e.name());
}

pub(super) fn check_derivatives2(e: &dyn DistortionEnergy, f: &Matrix2<f64>, tol: f64) {
    let ev = eval2(e, f, HessianMode::Exact).expect("admissible");
    let x = f.as_slice();
    let g_fd = fd_gradient(x, |y| density2(e, &Matrix2::from_column_slice(y)));
    assert_close(ev.grad.as_slice(), &g_fd, tol, e.name());
    let h_fd = fd_jacobian(x, |y| {
        eval2(e, &Matrix2::from_column_slice(y), HessianMode::None)
            .expect("admissible")
            .grad
            .as_slice()
            .to_vec()
    });
    let hess = ev.hess.expect("requested");
    assert!(hess.iter().all(|v| v.is_finite()), "{}", e.name());
    assert_close(hess.as_slice(), &h_fd, tol, e.name());
}

pub(super) fn eigenvalues(h: &[f64], n: usize) -> Vec<f64> {
    let m = DMatrix::from_column_slice(n, n, h);
    let mut l: Vec<f64> = m.symmetric_eigenvalues().iter().copied().collect();
    l.sort_by(f64::total_cmp);
    l
}

/// Projected is PSD; equals Exact when Exact is PSD.
pub(super) fn check_projection(exact: &[f64], proj: &[f64], n: usize, what: &str) {
    let lp = eigenvalues(proj, n);
    let top = lp[n - 1].abs().max(1e-300);
    assert!(lp[0] >= -1e-9 * top, "{what}: projected eigenvalues {lp:?}");
    let le = eigenvalues(exact, n);
    if le[0] >= 0.0 {
        assert_close(proj, exact, 1e-10, what);
    }
}
