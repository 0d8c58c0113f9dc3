//! Derivative checks against central finite differences, for the tests of
//! pieces a method developer writes (and ours): a [`Template`]'s gradient in
//! `x` and in `theta`, its Hessian (symmetric, positive semidefinite, and
//! equal to the derivative of the gradient wherever the exact Hessian is
//! PSD), and a [`DistortionEnergy`]'s gradient and Hessian in the singular
//! values.
//!
//! Each difference uses the step `h = 1e-5 max(|v|, 1)` and compares
//! `|analytic - fd| <= rel max(1, max |entries|)` entry by entry.

use crate::{DistortionEnergy, Template};
use thiserror::Error;

/// The first derivative entry that disagrees with its finite difference
/// (or a Hessian that is not symmetric positive semidefinite).
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[error("{what}[{index}]: analytic {analytic}, finite difference {finite_difference}")]
pub struct Mismatch {
    /// Which derivative ("dT/dx", "dT/dtheta", "d2T/dx2", "Hessian symmetry",
    /// "Hessian PSD", "dpsi/ds", "d2psi/ds2").
    pub what: &'static str,
    /// The entry (row-major for matrices; for "Hessian PSD" the eigenvalue
    /// index).
    pub index: usize,
    /// The analytic value (for "Hessian PSD" the negative eigenvalue).
    pub analytic: f64,
    /// What finite differences give (for "Hessian PSD" the largest
    /// eigenvalue).
    pub finite_difference: f64,
}

fn step(v: f64) -> f64 {
    1e-5 * v.abs().max(1.0)
}

/// `|a - b| <= rel max(scale, 1)` entry by entry.
fn compare(what: &'static str, a: &[f64], b: &[f64], rel: f64) -> Result<(), Mismatch> {
    let scale = a.iter().chain(b).fold(1.0f64, |m, v| m.max(v.abs()));
    match a
        .iter()
        .zip(b)
        .position(|(x, y)| (x - y).abs() > rel * scale || x.is_nan() != y.is_nan())
    {
        None => Ok(()),
        Some(index) => Err(Mismatch {
            what,
            index,
            analytic: a[index],
            finite_difference: b[index],
        }),
    }
}

/// Central differences of `f` at `x` in each coordinate.
fn central(x: &[f64], f: impl Fn(&[f64]) -> f64) -> Vec<f64> {
    (0..x.len())
        .map(|i| {
            let h = step(x[i]);
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[i] += h;
            xm[i] -= h;
            (f(&xp) - f(&xm)) / (2.0 * h)
        })
        .collect()
}

/// Row-major central-difference Jacobian of the vector function `g`.
fn central_jacobian(x: &[f64], m: usize, g: impl Fn(&[f64], &mut [f64])) -> Vec<f64> {
    let d = x.len();
    let mut out = vec![0.0; m * d];
    let (mut gp, mut gm) = (vec![0.0; m], vec![0.0; m]);
    for j in 0..d {
        let h = step(x[j]);
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        g(&xp, &mut gp);
        g(&xm, &mut gm);
        for i in 0..m {
            out[i * d + j] = (gp[i] - gm[i]) / (2.0 * h);
        }
    }
    out
}

/// Smallest and largest eigenvalue of a symmetric row-major `d x d`.
fn eigen_range(h: &[f64], d: usize) -> (f64, f64) {
    let e = nalgebra::DMatrix::from_row_slice(d, d, h)
        .symmetric_eigen()
        .eigenvalues;
    (e.min(), e.max())
}

fn symmetric(what: &'static str, h: &[f64], d: usize) -> Result<(), Mismatch> {
    for i in 0..d {
        for j in 0..i {
            let (a, b) = (h[i * d + j], h[j * d + i]);
            if (a - b).abs() > 1e-12 * (1.0 + a.abs().max(b.abs())) {
                return Err(Mismatch {
                    what,
                    index: i * d + j,
                    analytic: a,
                    finite_difference: b,
                });
            }
        }
    }
    Ok(())
}

/// Checks a template at one point: `dT/dx` and `dT/dtheta` against central
/// differences of `T`, the Hessian in `x` symmetric and positive
/// semidefinite, and equal to the central differences of the gradient
/// where those are PSD too (where they are not, the template's Hessian is
/// the projection of an indefinite one and cannot match).
///
/// # Errors
/// The first [`Mismatch`].
pub fn template_derivatives(
    t: &dyn Template,
    vertex: usize,
    label: u8,
    x: &[f64],
    theta: &[f64],
    rel: f64,
) -> Result<(), Mismatch> {
    let d = x.len();
    let (mut g, mut h, mut gt) = (vec![0.0; d], vec![0.0; d * d], vec![0.0; theta.len()]);
    t.gradient(vertex, label, x, theta, &mut g);
    t.hessian(vertex, label, x, theta, &mut h);
    t.theta_gradient(vertex, label, x, theta, &mut gt);
    compare(
        "dT/dx",
        &g,
        &central(x, |y| t.value(vertex, label, y, theta)),
        rel,
    )?;
    compare(
        "dT/dtheta",
        &gt,
        &central(theta, |th| t.value(vertex, label, x, th)),
        rel,
    )?;
    symmetric("Hessian symmetry", &h, d)?;
    let (lo, hi) = eigen_range(&h, d);
    if lo < -1e-9 * hi.abs().max(1e-300) {
        return Err(Mismatch {
            what: "Hessian PSD",
            index: 0,
            analytic: lo,
            finite_difference: hi,
        });
    }
    let fd = central_jacobian(x, d, |y, out| t.gradient(vertex, label, y, theta, out));
    let (lo, hi) = eigen_range(&fd, d);
    if lo >= -1e-6 * hi.abs() {
        compare("d2T/dx2", &h, &fd, rel)?;
    }
    Ok(())
}

/// Checks a distortion energy at singular values `s` (2 or 3, sorted by
/// decreasing magnitude): `dpsi/ds` against central differences of `psi`,
/// and the Hessian in `s` symmetric and equal to central differences of
/// the gradient.
///
/// # Errors
/// The first [`Mismatch`].
pub fn energy_derivatives(e: &dyn DistortionEnergy, s: &[f64], rel: f64) -> Result<(), Mismatch> {
    let d = s.len();
    let (mut g, mut h) = (vec![0.0; d], vec![0.0; d * d]);
    e.gradient(s, &mut g);
    e.hessian(s, &mut h);
    compare("dpsi/ds", &g, &central(s, |y| e.value(y)), rel)?;
    symmetric("Hessian symmetry", &h, d)?;
    compare(
        "d2psi/ds2",
        &h,
        &central_jacobian(s, d, |y, out| e.gradient(y, out)),
        rel,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{Arap, SymmetricDirichlet};
    use crate::template::PointTargets;

    /// A template whose gradient is wrong by a factor 2.
    #[derive(Debug)]
    struct Wrong;

    impl Template for Wrong {
        fn name(&self) -> &'static str {
            "wrong"
        }
        fn parameter_names(&self) -> Vec<&'static str> {
            vec![]
        }
        fn value(&self, _: usize, _: u8, x: &[f64], _: &[f64]) -> f64 {
            x[0] * x[0]
        }
        fn gradient(&self, _: usize, _: u8, x: &[f64], _: &[f64], out: &mut [f64]) {
            out.fill(0.0);
            out[0] = 4.0 * x[0];
        }
        fn hessian(&self, _: usize, _: u8, _: &[f64], _: &[f64], out: &mut [f64]) {
            out.fill(0.0);
        }
        fn theta_gradient(&self, _: usize, _: u8, _: &[f64], _: &[f64], _: &mut [f64]) {}
    }

    #[test]
    fn checks_pass_on_correct_pieces_and_name_the_wrong_entry() {
        let t = PointTargets::from_pairs(2, 3, &[(0, [1.0, 2.0, 3.0])]).unwrap();
        assert!(template_derivatives(&t, 0, 0, &[0.5, -1.0, 2.0], &[], 1e-6).is_ok());
        let m = template_derivatives(&Wrong, 0, 0, &[1.5, 0.0], &[], 1e-6).unwrap_err();
        assert_eq!((m.what, m.index), ("dT/dx", 0));
        assert!((m.analytic - 6.0).abs() < 1e-12 && (m.finite_difference - 3.0).abs() < 1e-6);
        for s in [[1.3, 0.7, 0.2], [2.0, 1.0, -0.5]] {
            assert!(energy_derivatives(&Arap, &s, 1e-6).is_ok(), "{s:?}");
        }
        assert!(energy_derivatives(&SymmetricDirichlet, &[1.3, 0.7, 0.4], 1e-6).is_ok());
    }
}
