//! An axis-aligned ellipsoid (ALGORITHMS 2.3).

use super::{PlacentaTemplate, TemplateSymmetry};
use crate::placenta::estimate::Estimates;
use crate::placenta::side;
use serde::{Deserialize, Serialize};
use unfold_mesh::nalgebra::{Matrix3, SymmetricEigen, Vector3};
use unfold_param::Template;
use unfold_param::template::update_arguments_fit;

/// An axis-aligned ellipsoid centred at the origin (ALGORITHMS 2.3),
/// `theta = [rx, ry, rz]`, positions with 3 coordinates:
///
/// ```text
/// R = diag(rx^-2, ry^-2, rz^-2),   q = x^T R x
/// T = (q - 1)^2
/// dT/dx  = 4 (q - 1) R x
/// d2T/dx2 = 4 (q - 1) R + 8 (R x)(R x)^T      (projected to PSD)
/// dT/drx = -4 x1^2 rx^-3 (q - 1)              (likewise ry, rz)
/// ```
///
/// The `x1^2` in `dT/drx` is the corrected form (the paper's appendix drops
/// it). The Hessian is projected by clamping the eigenvalues of the 3x3 at 0;
/// it is exact (and PSD) wherever `q >= 1`.
///
/// *Which vertices:* the paper's `dphi/drx` sums over the whole boundary
/// `m in dZ`, and ALGORITHMS 2.3 (unlike the planes) exempts no side, so the
/// whole closed boundary surface is pulled onto the ellipsoid: fetal,
/// maternal *and* margin vertices (every label but [`side::INTERIOR`]).
/// Set `include_margin = false` to exempt the margin as for the planes.
///
/// [`Template::update_theta`]: with `a_i = r_i^-2` the residuals
/// `q_m - 1 = s_m . a - 1`, `s_m = (x1^2, x2^2, x3^2)`, are linear in `a`,
/// so `sum_m w_m T` is a convex quadratic in `a` and a Gauss–Newton step is
/// an exact Newton step. Up to [`Ellipsoid::UPDATE_STEPS`] steps
/// `a <- a + t d`, `d = -(G + mu I)^-1 (G a - b)`
/// (`G = sum w s s^T`, `b = sum w s`, `mu = 1e-12 tr G` for rank-deficient
/// data, which leaves unconstrained radii unchanged) with `t = 1` when the new
/// `a` stays positive, else `t = 0.9` times the step to the boundary `a_i = 0`.
/// Every step decreases the sum (convexity, `t <= 1`) and keeps the radii
/// positive; when the unconstrained minimizer has positive `a` it is reached
/// in one step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Ellipsoid {
    /// Whether margin vertices are pulled onto the ellipsoid (default
    /// `true`: the whole boundary).
    pub include_margin: bool,
}

impl Default for Ellipsoid {
    fn default() -> Self {
        Ellipsoid {
            include_margin: true,
        }
    }
}

impl Ellipsoid {
    /// Maximum number of steps of [`Template::update_theta`].
    pub const UPDATE_STEPS: usize = 8;

    /// The whole boundary on the ellipsoid.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether a vertex with this label has a term.
    #[inline]
    pub fn applies(&self, label: u8) -> bool {
        match label {
            side::INTERIOR => false,
            side::MARGIN => self.include_margin,
            _ => true,
        }
    }

    #[inline]
    fn r_diag(theta: &[f64]) -> Vector3<f64> {
        Vector3::new(theta[0].powi(-2), theta[1].powi(-2), theta[2].powi(-2))
    }

    /// The exact Hessian `4 (q - 1) R + 8 (R x)(R x)^T` (not projected).
    pub fn exact_hessian(x: &[f64], theta: &[f64]) -> Matrix3<f64> {
        let r = Self::r_diag(theta);
        let x = Vector3::new(x[0], x[1], x[2]);
        let rx = r.component_mul(&x);
        let q = x.dot(&rx);
        Matrix3::from_diagonal(&(4.0 * (q - 1.0) * r)) + 8.0 * rx * rx.transpose()
    }
}

/// Projects a symmetric 3x3 matrix to PSD by clamping its eigenvalues at 0.
fn project_psd3(h: Matrix3<f64>) -> Matrix3<f64> {
    let mut eig = SymmetricEigen::new(h);
    if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
        return h;
    }
    eig.eigenvalues.iter_mut().for_each(|l| *l = l.max(0.0));
    let p = eig.recompose();
    (p + p.transpose()) * 0.5
}

impl Template for Ellipsoid {
    fn name(&self) -> &'static str {
        "ellipsoid"
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        vec!["rx", "ry", "rz"]
    }

    fn value(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        if !self.applies(label) {
            return 0.0;
        }
        let r = Self::r_diag(theta);
        let q = r[0] * x[0] * x[0] + r[1] * x[1] * x[1] + r[2] * x[2] * x[2];
        (q - 1.0) * (q - 1.0)
    }

    fn gradient(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if !self.applies(label) {
            return;
        }
        let r = Self::r_diag(theta);
        let q = r[0] * x[0] * x[0] + r[1] * x[1] * x[1] + r[2] * x[2] * x[2];
        for i in 0..3 {
            out[i] = 4.0 * (q - 1.0) * r[i] * x[i];
        }
    }

    fn hessian(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if !self.applies(label) {
            return;
        }
        let h = project_psd3(Self::exact_hessian(x, theta));
        let d = x.len();
        for i in 0..3 {
            for j in 0..3 {
                out[i * d + j] = h[(i, j)];
            }
        }
    }

    fn theta_gradient(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out[..3].fill(0.0);
        if !self.applies(label) {
            return;
        }
        let r = Self::r_diag(theta);
        let q = r[0] * x[0] * x[0] + r[1] * x[1] * x[1] + r[2] * x[2] * x[2];
        for i in 0..3 {
            out[i] = -4.0 * x[i] * x[i] * theta[i].powi(-3) * (q - 1.0);
        }
    }

    fn update_theta(
        &self,
        labels: &[u8],
        xs: &[f64],
        dim: usize,
        weights: &[f64],
        theta: &mut [f64],
    ) -> bool {
        if !update_arguments_fit(labels, xs, dim, weights, 3)
            || theta.len() != 3
            || theta.iter().any(|&r| !(r.is_finite() && r > 0.0))
        {
            return false;
        }
        // F(a) = a^T G a - 2 b.a + const, a = (rx^-2, ry^-2, rz^-2).
        let mut g = Matrix3::zeros();
        let mut b = Vector3::zeros();
        for (m, (&label, &w)) in labels.iter().zip(weights).enumerate() {
            if w == 0.0 || !self.applies(label) {
                continue;
            }
            let x = &xs[m * dim..m * dim + 3];
            let s = Vector3::new(x[0] * x[0], x[1] * x[1], x[2] * x[2]);
            g += w * s * s.transpose();
            b += w * s;
        }
        let tr = g.trace();
        if !(tr.is_finite() && tr > 0.0) {
            return false;
        }
        let Some(lhs_inv) = (g + Matrix3::identity() * (1e-12 * tr)).try_inverse() else {
            return false;
        };
        let mut a = Self::r_diag(theta);
        for _ in 0..Self::UPDATE_STEPS {
            let grad = g * a - b;
            if grad.norm() <= 1e-15 * (b.norm() + (g * a).norm()) {
                break;
            }
            let d = -(lhs_inv * grad);
            let mut t: f64 = 1.0;
            if (a + d).iter().any(|&ai| ai <= 0.0) {
                for i in 0..3 {
                    if d[i] < 0.0 {
                        t = t.min(0.9 * a[i] / -d[i]);
                    }
                }
            }
            let next = a + t * d;
            if !next.iter().all(|&ai| ai.is_finite() && ai > 0.0) {
                break;
            }
            a = next;
        }
        let radii = a.map(|ai| ai.powf(-0.5));
        if !radii.iter().all(|r| r.is_finite() && *r > 0.0) {
            return false;
        }
        theta[..3].copy_from_slice(radii.as_slice());
        true
    }
}

impl PlacentaTemplate for Ellipsoid {
    /// `[rx, ry, rz]` from the estimates (ALGORITHMS 2.4): the half
    /// geodesic widths and the half thickness.
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64> {
        vec![
            estimates.rx_mm,
            estimates.ry_mm,
            estimates.half_thickness_mm,
        ]
    }

    /// An axis-aligned ellipsoid centred at the origin is invariant under
    /// the half turns about its axes; the half turn about z is the one that
    /// keeps the fetal side up. (With `rx = ry` every rotation about z is a
    /// symmetry too; the canonical frame does not use them.)
    fn symmetry(&self) -> TemplateSymmetry {
        TemplateSymmetry::HalfTurnAboutZ
    }
}
