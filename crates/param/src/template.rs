//! Templates: the penalty `T(x_m, theta)` that pulls boundary vertices onto
//! a canonical shape (ALGORITHMS 2.3), and soft positional targets.

use crate::ParamError;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// A template: the penalty of vertex `vertex` (with label `label`) at mapped
/// position `x` (2 or 3 coordinates) given the template parameters `theta`.
/// The objective adds `sum_m w_m T(m, label_m, x_m, theta)`.
///
/// Implement value, gradient and (PSD) Hessian in `x`, and the gradient in
/// `theta`; optionally a closed-form (or Newton) update of `theta` for
/// fixed positions.
pub trait Template: Send + Sync + Debug {
    /// A short name ("parallel-planes", ...).
    fn name(&self) -> &'static str;
    /// Names of the parameters, in the order of `theta` (may be empty).
    fn parameter_names(&self) -> Vec<&'static str>;
    /// `T(x, theta)`.
    fn value(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64;
    /// `dT/dx` written into `out` (same length as `x`).
    fn gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]);
    /// A positive semidefinite approximation of `d2T/dx2` (the exact Hessian
    /// projected), row-major `d x d`, written into `out`.
    fn hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]);
    /// `dT/dtheta` written into `out` (length `theta.len()`).
    fn theta_gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]);
    /// Whether the solvers optimize `theta` (default true when there are
    /// parameters). A template whose parameters must stay put (e.g. the
    /// single plane, whose `h` comes from the parallel-planes result)
    /// returns false.
    fn optimize_theta(&self) -> bool {
        !self.parameter_names().is_empty()
    }
    /// `d2T/dtheta2` (row-major `p x p`, `p = theta.len()`) written into
    /// `out`. The default differentiates [`Template::theta_gradient`]
    /// numerically (central differences, step `1e-6 (1 + |theta_j|)`);
    /// override with a closed form. Any number of parameters works: the
    /// default's buffers live on the stack up to 8 parameters and on the
    /// heap beyond.
    fn theta_hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        let p = theta.len();
        let mut buffers = Scratch::new(3 * p);
        let (th, rest) = buffers.as_mut().split_at_mut(p);
        let (gp, gm) = rest.split_at_mut(p);
        th.copy_from_slice(theta);
        for j in 0..p {
            let h = 1e-6 * (1.0 + theta[j].abs());
            th[j] = theta[j] + h;
            self.theta_gradient(vertex, label, x, th, gp);
            th[j] = theta[j] - h;
            self.theta_gradient(vertex, label, x, th, gm);
            th[j] = theta[j];
            for i in 0..p {
                out[i * p + j] = (gp[i] - gm[i]) / (2.0 * h);
            }
        }
        for i in 0..p {
            for j in 0..i {
                let m = 0.5 * (out[i * p + j] + out[j * p + i]);
                out[i * p + j] = m;
                out[j * p + i] = m;
            }
        }
    }
    /// The mixed derivative `d2T/(dx_i dtheta_j)` (row-major `d x p`)
    /// written into `out`. The default differentiates
    /// [`Template::theta_gradient`] numerically in `x` (any number of
    /// parameters); override with a closed form.
    fn mixed_hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        let (d, p) = (x.len(), theta.len());
        let mut xx = [0.0; 3];
        let mut buffers = Scratch::new(2 * p);
        let (gp, gm) = buffers.as_mut().split_at_mut(p);
        xx[..d].copy_from_slice(x);
        for i in 0..d {
            let h = 1e-6 * (1.0 + x[i].abs());
            xx[i] = x[i] + h;
            self.theta_gradient(vertex, label, &xx[..d], theta, gp);
            xx[i] = x[i] - h;
            self.theta_gradient(vertex, label, &xx[..d], theta, gm);
            xx[i] = x[i];
            for j in 0..p {
                out[i * p + j] = (gp[j] - gm[j]) / (2.0 * h);
            }
        }
    }
    /// Improves `theta` for fixed positions (`xs` flat, `dim` per vertex,
    /// `weights[m]` the vertex weights, zero for vertices without a term):
    /// the exact minimizer where a closed form exists, else a few Newton
    /// steps. Returns `false` when the template has no such update (theta
    /// then stays fixed, or is optimized by the solver's gradient).
    fn update_theta(
        &self,
        labels: &[u8],
        xs: &[f64],
        dim: usize,
        weights: &[f64],
        theta: &mut [f64],
    ) -> bool {
        let _ = (labels, xs, dim, weights, theta);
        false
    }
}

/// A boxed template is a template (so pipelines can hold and take
/// `Box<dyn Template>`).
impl<T: Template + ?Sized> Template for Box<T> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn parameter_names(&self) -> Vec<&'static str> {
        (**self).parameter_names()
    }
    fn value(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        (**self).value(vertex, label, x, theta)
    }
    fn gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        (**self).gradient(vertex, label, x, theta, out)
    }
    fn hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        (**self).hessian(vertex, label, x, theta, out)
    }
    fn theta_gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        (**self).theta_gradient(vertex, label, x, theta, out)
    }
    fn optimize_theta(&self) -> bool {
        (**self).optimize_theta()
    }
    fn theta_hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        (**self).theta_hessian(vertex, label, x, theta, out)
    }
    fn mixed_hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        (**self).mixed_hessian(vertex, label, x, theta, out)
    }
    fn update_theta(
        &self,
        labels: &[u8],
        xs: &[f64],
        dim: usize,
        weights: &[f64],
        theta: &mut [f64],
    ) -> bool {
        (**self).update_theta(labels, xs, dim, weights, theta)
    }
}

/// A scratch buffer of `len` zeros: on the stack up to 24 values, on the
/// heap beyond (the numeric template derivatives of any parameter count).
enum Scratch {
    Stack([f64; 24], usize),
    Heap(Vec<f64>),
}

impl Scratch {
    fn new(len: usize) -> Self {
        if len <= 24 {
            Scratch::Stack([0.0; 24], len)
        } else {
            Scratch::Heap(vec![0.0; len])
        }
    }

    fn as_mut(&mut self) -> &mut [f64] {
        match self {
            Scratch::Stack(a, len) => &mut a[..*len],
            Scratch::Heap(v) => v,
        }
    }
}

/// Vertex label of an interior vertex (no template term).
pub const LABEL_INTERIOR: u8 = 0;
/// Vertex label of the fetal (chorionic) side of the placenta boundary.
pub const LABEL_FETAL: u8 = 1;
/// Vertex label of the maternal (basal) side of the placenta boundary.
pub const LABEL_MATERNAL: u8 = 2;
/// Vertex label of the placenta margin (the rim between the two sides).
pub const LABEL_MARGIN: u8 = 3;

/// `sum_m w_m T(m, label_m, x_m, theta)` over all vertices (`xs` flat, `dim`
/// per vertex). Vertices with a zero weight are skipped.
///
/// # Panics
/// If `labels`, `weights` and `xs` do not describe the same number of
/// vertices.
pub fn weighted_value<T: Template + ?Sized>(
    template: &T,
    labels: &[u8],
    xs: &[f64],
    dim: usize,
    weights: &[f64],
    theta: &[f64],
) -> f64 {
    check_lengths(labels, xs, dim, weights);
    (0..labels.len())
        .filter(|&m| weights[m] != 0.0)
        .map(|m| weights[m] * template.value(m, labels[m], &xs[m * dim..(m + 1) * dim], theta))
        .sum()
}

/// `sum_m w_m dT/dtheta (m, label_m, x_m, theta)` (length `theta.len()`).
///
/// # Panics
/// As [`weighted_value`].
pub fn weighted_theta_gradient<T: Template + ?Sized>(
    template: &T,
    labels: &[u8],
    xs: &[f64],
    dim: usize,
    weights: &[f64],
    theta: &[f64],
) -> Vec<f64> {
    check_lengths(labels, xs, dim, weights);
    let mut total = vec![0.0; theta.len()];
    let mut g = vec![0.0; theta.len()];
    for m in (0..labels.len()).filter(|&m| weights[m] != 0.0) {
        template.theta_gradient(m, labels[m], &xs[m * dim..(m + 1) * dim], theta, &mut g);
        for (t, gi) in total.iter_mut().zip(&g) {
            *t += weights[m] * gi;
        }
    }
    total
}

fn check_lengths(labels: &[u8], xs: &[f64], dim: usize, weights: &[f64]) {
    assert_eq!(
        labels.len(),
        weights.len(),
        "labels and weights differ in length"
    );
    assert_eq!(
        xs.len(),
        dim * labels.len(),
        "positions do not match labels"
    );
}

/// Whether the arguments of [`Template::update_theta`] are consistent:
/// `dim >= min_dim` coordinates per vertex, one label and one weight per
/// vertex.
fn update_args_ok(labels: &[u8], xs: &[f64], dim: usize, weights: &[f64], min_dim: usize) -> bool {
    dim >= min_dim && labels.len() == weights.len() && xs.len() == dim * labels.len()
}

fn check_weight(name: &'static str, w: f64) -> Result<(), ParamError> {
    if w.is_finite() && w >= 0.0 {
        Ok(())
    } else {
        Err(ParamError::Setting {
            name,
            value: w,
            expected: "finite and non-negative",
        })
    }
}

// ---------------------------------------------------------------------------
// Parallel planes

/// Two parallel planes `z = +h` (fetal side) and `z = -h` (maternal side),
/// the placenta paper's default template (ALGORITHMS 2.3). `theta = [h]`;
/// positions have 3 coordinates, `x3` is the third one.
///
/// ```text
/// T = fw (x3 - h)^2   fetal      dT/dx3 = 2 fw (x3 - h)   dT/dh = -2 fw (x3 - h)
/// T = mw (x3 + h)^2   maternal   dT/dx3 = 2 mw (x3 + h)   dT/dh =  2 mw (x3 + h)
/// T = 0               interior, margin (and any other label)
/// ```
///
/// The Hessian `2 w e3 e3^T` is exact and PSD. [`Template::update_theta`]
/// sets `h` to the exact minimizer for fixed positions (the objective is a
/// quadratic in `h`):
///
/// ```text
/// h = (sum_F fw w_m x3 - sum_M mw w_m x3) / (sum_F fw w_m + sum_M mw w_m)
/// ```
///
/// (ALGORITHMS 2.3 with the side weights `fw`, `mw`; it returns `false` and
/// leaves `h` alone when the denominator vanishes, i.e. no weighted fetal or
/// maternal vertex.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ParallelPlanes {
    /// Weight `fw` of the fetal term (default 1).
    pub fetal_weight: f64,
    /// Weight `mw` of the maternal term (default 1).
    pub maternal_weight: f64,
}

impl Default for ParallelPlanes {
    fn default() -> Self {
        ParallelPlanes {
            fetal_weight: 1.0,
            maternal_weight: 1.0,
        }
    }
}

impl ParallelPlanes {
    /// Both sides weighted 1 (the paper's template).
    pub fn new() -> Self {
        Self::default()
    }

    /// Planes with side weights `fw`, `mw` (finite, non-negative).
    pub fn with_weights(fetal_weight: f64, maternal_weight: f64) -> Result<Self, ParamError> {
        check_weight("fetal_weight", fetal_weight)?;
        check_weight("maternal_weight", maternal_weight)?;
        Ok(ParallelPlanes {
            fetal_weight,
            maternal_weight,
        })
    }

    /// The single-plane relaxation (fetal weight 0, `h` fixed): see
    /// [`SinglePlane`].
    pub fn single_plane() -> SinglePlane {
        SinglePlane::default()
    }

    /// `(side weight, signed offset s)` with `T = w (x3 - s h)^2`, or `None`
    /// for labels without a term.
    #[inline]
    fn side(&self, label: u8) -> Option<(f64, f64)> {
        match label {
            LABEL_FETAL => Some((self.fetal_weight, 1.0)),
            LABEL_MATERNAL => Some((self.maternal_weight, -1.0)),
            _ => None,
        }
    }

    /// The exact minimizer `h` of `sum_m w_m T(x_m, h)` (see the type's
    /// documentation), `None` when no weighted fetal or maternal vertex
    /// exists or the arguments are inconsistent.
    pub fn optimal_h(&self, labels: &[u8], xs: &[f64], dim: usize, weights: &[f64]) -> Option<f64> {
        if !update_args_ok(labels, xs, dim, weights, 3) {
            return None;
        }
        let (mut num, mut den) = (0.0, 0.0);
        for (m, (&label, &w)) in labels.iter().zip(weights).enumerate() {
            if let Some((sw, s)) = self.side(label) {
                let x3 = xs[m * dim + 2];
                num += sw * w * s * x3;
                den += sw * w;
            }
        }
        let h = num / den;
        (den > 0.0 && h.is_finite()).then_some(h)
    }
}

impl Template for ParallelPlanes {
    fn name(&self) -> &'static str {
        "parallel-planes"
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        vec!["h"]
    }

    fn value(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        match self.side(label) {
            Some((w, s)) => {
                let r = x[2] - s * theta[0];
                w * r * r
            }
            None => 0.0,
        }
    }

    fn gradient(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if let Some((w, s)) = self.side(label) {
            out[2] = 2.0 * w * (x[2] - s * theta[0]);
        }
    }

    fn hessian(&self, _vertex: usize, label: u8, x: &[f64], _theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if let Some((w, _)) = self.side(label) {
            let d = x.len();
            out[2 * d + 2] = 2.0 * w;
        }
    }

    fn theta_gradient(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out[0] = match self.side(label) {
            Some((w, s)) => -2.0 * w * s * (x[2] - s * theta[0]),
            None => 0.0,
        };
    }

    fn theta_hessian(
        &self,
        _vertex: usize,
        label: u8,
        _x: &[f64],
        _theta: &[f64],
        out: &mut [f64],
    ) {
        // d2/dh2 of w (x3 - s h)^2 = 2 w s^2 = 2 w.
        out[0] = self.side(label).map_or(0.0, |(w, _)| 2.0 * w);
    }

    fn mixed_hessian(&self, _vertex: usize, label: u8, x: &[f64], _theta: &[f64], out: &mut [f64]) {
        out[..x.len()].fill(0.0);
        if let Some((w, s)) = self.side(label) {
            // d2/(dx3 dh) of w (x3 - s h)^2 = -2 w s.
            out[2] = -2.0 * w * s;
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
        if theta.len() != 1 {
            return false;
        }
        match self.optimal_h(labels, xs, dim, weights) {
            Some(h) => {
                theta[0] = h;
                true
            }
            None => false,
        }
    }
}

// ---------------------------------------------------------------------------
// Single plane

/// The single-plane relaxation of [`ParallelPlanes`] (ALGORITHMS 2.3): the
/// fetal term's weight is 0, so only the maternal side is pulled onto
/// `z = -h` and the fetal side relaxes. `theta = [h]`.
///
/// ```text
/// T = mw (x3 + h)^2  maternal,  0 otherwise
/// ```
///
/// Meant to be started from the converged parallel-planes result. By default
/// `h` is *fixed* at the value it had there ([`Template::update_theta`]
/// returns `false`): with the fetal term gone, `h` only translates the
/// maternal plane, so freeing it changes nothing but the map's offset. With
/// `optimize_h = true` the update sets `h` to its exact minimizer
/// `-sum_M w_m x3 / sum_M w_m` (the planes formula with `fw = 0`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SinglePlane {
    /// Weight `mw` of the maternal term (default 1).
    pub maternal_weight: f64,
    /// Whether `update_theta` moves `h` (default `false`: `h` stays fixed).
    pub optimize_h: bool,
}

impl Default for SinglePlane {
    fn default() -> Self {
        SinglePlane {
            maternal_weight: 1.0,
            optimize_h: false,
        }
    }
}

impl SinglePlane {
    /// Maternal weight 1, `h` fixed.
    pub fn new() -> Self {
        Self::default()
    }

    /// The equivalent [`ParallelPlanes`] (fetal weight 0).
    pub fn planes(&self) -> ParallelPlanes {
        ParallelPlanes {
            fetal_weight: 0.0,
            maternal_weight: self.maternal_weight,
        }
    }
}

impl Template for SinglePlane {
    fn optimize_theta(&self) -> bool {
        self.optimize_h
    }

    fn name(&self) -> &'static str {
        "single-plane"
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        vec!["h"]
    }

    fn value(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        self.planes().value(vertex, label, x, theta)
    }

    fn gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.planes().gradient(vertex, label, x, theta, out);
    }

    fn hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.planes().hessian(vertex, label, x, theta, out);
    }

    fn theta_gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.planes().theta_gradient(vertex, label, x, theta, out);
    }

    fn update_theta(
        &self,
        labels: &[u8],
        xs: &[f64],
        dim: usize,
        weights: &[f64],
        theta: &mut [f64],
    ) -> bool {
        self.optimize_h && self.planes().update_theta(labels, xs, dim, weights, theta)
    }
}

// ---------------------------------------------------------------------------
// Ellipsoid

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
/// maternal *and* margin vertices (every label but [`LABEL_INTERIOR`]).
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
            LABEL_INTERIOR => false,
            LABEL_MARGIN => self.include_margin,
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
        if !update_args_ok(labels, xs, dim, weights, 3)
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

// ---------------------------------------------------------------------------
// Point targets

/// Soft positional targets: `T = |x_b - t_b|^2` (the first `dim` coordinates)
/// for the vertices `b` that have a target, 0 for the others; labels are
/// ignored and there is no `theta`. Gradient `2 (x_b - t_b)`, Hessian
/// `2 I` (exact, PSD). The objective's vertex weight `w_b` must be non-zero
/// for a target to act.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointTargets {
    /// Target per vertex (`None`: no term); only the first `dim` coordinates
    /// are used.
    pub targets: Vec<Option<[f64; 3]>>,
    /// 2 or 3.
    pub dim: usize,
}

impl PointTargets {
    /// Targets per vertex; `dim` must be 2 or 3 and every target finite.
    pub fn new(targets: Vec<Option<[f64; 3]>>, dim: usize) -> Result<Self, ParamError> {
        if dim != 2 && dim != 3 {
            return Err(ParamError::Dimension {
                what: "point targets",
                dim,
            });
        }
        if let Some(v) = targets
            .iter()
            .position(|t| t.is_some_and(|t| t.iter().any(|c| !c.is_finite())))
        {
            return Err(ParamError::TargetNotFinite { vertex: v });
        }
        Ok(PointTargets { targets, dim })
    }

    /// Targets from `(vertex, target)` pairs for a mesh of `num_vertices`
    /// vertices (for `dim = 2` the third coordinate is ignored). Fails on a
    /// vertex index `>= num_vertices`, a vertex listed twice, a non-finite
    /// target or `dim` not 2 or 3.
    pub fn from_pairs(
        num_vertices: usize,
        dim: usize,
        pairs: &[(usize, [f64; 3])],
    ) -> Result<Self, ParamError> {
        let mut targets = vec![None; num_vertices];
        for &(v, t) in pairs {
            if v >= num_vertices {
                return Err(ParamError::Length {
                    what: "point target vertex index (must be below the vertex count)",
                    expected: num_vertices,
                    found: v,
                });
            }
            if targets[v].is_some() {
                return Err(ParamError::TargetRepeated { vertex: v });
            }
            targets[v] = Some(t);
        }
        Self::new(targets, dim)
    }

    /// The target of `vertex`, if any.
    #[inline]
    pub fn target(&self, vertex: usize) -> Option<&[f64; 3]> {
        self.targets.get(vertex).and_then(|t| t.as_ref())
    }

    /// Number of vertices with a target.
    pub fn count(&self) -> usize {
        self.targets.iter().filter(|t| t.is_some()).count()
    }
}

impl Template for PointTargets {
    fn name(&self) -> &'static str {
        "point-targets"
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        Vec::new()
    }

    fn value(&self, vertex: usize, _label: u8, x: &[f64], _theta: &[f64]) -> f64 {
        match self.target(vertex) {
            Some(t) => (0..self.dim.min(x.len()))
                .map(|c| (x[c] - t[c]) * (x[c] - t[c]))
                .sum(),
            None => 0.0,
        }
    }

    fn gradient(&self, vertex: usize, _label: u8, x: &[f64], _theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if let Some(t) = self.target(vertex) {
            for c in 0..self.dim.min(x.len()) {
                out[c] = 2.0 * (x[c] - t[c]);
            }
        }
    }

    fn hessian(&self, vertex: usize, _label: u8, x: &[f64], _theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if self.target(vertex).is_some() {
            let d = x.len();
            for c in 0..self.dim.min(d) {
                out[c * d + c] = 2.0;
            }
        }
    }

    fn theta_gradient(
        &self,
        _vertex: usize,
        _label: u8,
        _x: &[f64],
        _theta: &[f64],
        _out: &mut [f64],
    ) {
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const LABELS: [u8; 4] = [LABEL_INTERIOR, LABEL_FETAL, LABEL_MATERNAL, LABEL_MARGIN];

    /// `|a - b| <= rel * max(scale, 1)` componentwise.
    fn assert_close(a: &[f64], b: &[f64], rel: f64, what: &str) {
        assert_eq!(a.len(), b.len());
        let scale = a.iter().chain(b).fold(1.0f64, |m, v| m.max(v.abs()));
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                (x - y).abs() <= rel * scale,
                "{what}[{i}]: {x} vs {y} (scale {scale})"
            );
        }
    }

    fn step(v: f64) -> f64 {
        1e-5 * v.abs().max(1.0)
    }

    fn fd_x_gradient(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) -> Vec<f64> {
        (0..x.len())
            .map(|i| {
                let h = step(x[i]);
                let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
                xp[i] += h;
                xm[i] -= h;
                (t.value(v, label, &xp, theta) - t.value(v, label, &xm, theta)) / (2.0 * h)
            })
            .collect()
    }

    fn fd_theta_gradient(
        t: &dyn Template,
        v: usize,
        label: u8,
        x: &[f64],
        theta: &[f64],
    ) -> Vec<f64> {
        (0..theta.len())
            .map(|i| {
                let h = step(theta[i]);
                let (mut tp, mut tm) = (theta.to_vec(), theta.to_vec());
                tp[i] += h;
                tm[i] -= h;
                (t.value(v, label, x, &tp) - t.value(v, label, x, &tm)) / (2.0 * h)
            })
            .collect()
    }

    /// Row-major FD Hessian from the analytic gradient.
    fn fd_hessian(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) -> Vec<f64> {
        let d = x.len();
        let mut out = vec![0.0; d * d];
        let (mut gp, mut gm) = (vec![0.0; d], vec![0.0; d]);
        for j in 0..d {
            let h = step(x[j]);
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[j] += h;
            xm[j] -= h;
            t.gradient(v, label, &xp, theta, &mut gp);
            t.gradient(v, label, &xm, theta, &mut gm);
            for i in 0..d {
                out[i * d + j] = (gp[i] - gm[i]) / (2.0 * h);
            }
        }
        out
    }

    fn analytic(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) -> [Vec<f64>; 3] {
        let d = x.len();
        let mut g = vec![0.0; d];
        let mut h = vec![0.0; d * d];
        let mut gt = vec![0.0; theta.len()];
        t.gradient(v, label, x, theta, &mut g);
        t.hessian(v, label, x, theta, &mut h);
        t.theta_gradient(v, label, x, theta, &mut gt);
        [g, h, gt]
    }

    fn min_max_eigen(h: &[f64], d: usize) -> (f64, f64) {
        let m = nalgebra::DMatrix::from_row_slice(d, d, h);
        let e = m.symmetric_eigen().eigenvalues;
        (e.min(), e.max())
    }

    fn assert_psd(h: &[f64], d: usize) {
        for i in 0..d {
            for j in 0..d {
                assert!((h[i * d + j] - h[j * d + i]).abs() <= 1e-12 * (1.0 + h[i * d + j].abs()));
            }
        }
        let (lo, hi) = min_max_eigen(h, d);
        assert!(
            lo >= -1e-9 * hi.abs().max(1e-300),
            "eigenvalues {lo} .. {hi}"
        );
    }

    /// Value/gradient/theta-gradient vs FD, projected Hessian PSD, and the
    /// Hessian vs FD of the gradient where the exact Hessian is PSD.
    fn check_template(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) {
        let d = x.len();
        let [g, h, gt] = analytic(t, v, label, x, theta);
        assert_close(&g, &fd_x_gradient(t, v, label, x, theta), 1e-6, "dT/dx");
        assert_close(
            &gt,
            &fd_theta_gradient(t, v, label, x, theta),
            1e-6,
            "dT/dtheta",
        );
        assert_psd(&h, d);
        let fd_h = fd_hessian(t, v, label, x, theta);
        let (lo, hi) = min_max_eigen(&fd_h, d);
        let exact_psd = lo >= -1e-6 * hi.abs();
        if exact_psd {
            assert_close(&h, &fd_h, 1e-6, "d2T/dx2");
        }
    }

    fn label_strategy() -> impl Strategy<Value = u8> {
        prop::sample::select(LABELS.to_vec())
    }

    fn point3(r: f64) -> impl Strategy<Value = [f64; 3]> {
        [-r..r, -r..r, -r..r]
    }

    #[test]
    fn template_labels_match_the_synthetic_placenta() {
        use unfold_mesh::shapes::{SIDE_FETAL, SIDE_INTERIOR, SIDE_MATERNAL, SIDE_RIM};
        assert_eq!(LABEL_INTERIOR, SIDE_INTERIOR);
        assert_eq!(LABEL_FETAL, SIDE_FETAL);
        assert_eq!(LABEL_MATERNAL, SIDE_MATERNAL);
        assert_eq!(LABEL_MARGIN, SIDE_RIM);
    }

    #[test]
    fn template_trait_objects_describe_themselves() {
        let ts: Vec<Box<dyn Template>> = vec![
            Box::new(ParallelPlanes::new()),
            Box::new(ParallelPlanes::single_plane()),
            Box::new(Ellipsoid::new()),
            Box::new(PointTargets::from_pairs(3, 3, &[(1, [0.0; 3])]).unwrap()),
        ];
        let names: Vec<_> = ts.iter().map(|t| t.name()).collect();
        assert_eq!(
            names,
            [
                "parallel-planes",
                "single-plane",
                "ellipsoid",
                "point-targets"
            ]
        );
        let n: Vec<_> = ts.iter().map(|t| t.parameter_names().len()).collect();
        assert_eq!(n, [1, 1, 3, 0]);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn template_planes_derivatives_match_fd(
            x in point3(50.0), h in -30.0..30.0f64, label in label_strategy(),
            fw in 0.0..3.0f64, mw in 0.0..3.0f64,
        ) {
            let t = ParallelPlanes::with_weights(fw, mw).unwrap();
            check_template(&t, 0, label, &x, &[h]);
            check_template(&SinglePlane { maternal_weight: mw, optimize_h: false }, 0, label, &x, &[h]);
        }

        #[test]
        fn template_ellipsoid_derivatives_match_fd(
            x in point3(30.0), r in [3.0..20.0f64, 3.0..20.0f64, 3.0..20.0f64],
            label in label_strategy(), margin in any::<bool>(),
        ) {
            let t = Ellipsoid { include_margin: margin };
            check_template(&t, 0, label, &x, &r);
            // The unprojected Hessian matches FD everywhere.
            if t.applies(label) {
                let fd_h = fd_hessian(&t, 0, label, &x, &r);
                let exact = Ellipsoid::exact_hessian(&x, &r);
                let exact: Vec<f64> = (0..9).map(|k| exact[(k / 3, k % 3)]).collect();
                assert_close(&exact, &fd_h, 1e-6, "exact d2T/dx2");
            }
        }

        #[test]
        fn template_ellipsoid_projection_is_exact_outside(
            dir in point3(1.0), s in 1.0..3.0f64, r in [3.0..20.0f64, 3.0..20.0f64, 3.0..20.0f64],
        ) {
            // Points with q >= 1: the exact Hessian is PSD and kept as is.
            let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            prop_assume!(n > 1e-3);
            let x: Vec<f64> = (0..3).map(|i| s * r[i] * dir[i] / n).collect();
            let t = Ellipsoid::new();
            let [_, h, _] = analytic(&t, 0, LABEL_FETAL, &x, &r);
            let exact = Ellipsoid::exact_hessian(&x, &r);
            let exact: Vec<f64> = (0..9).map(|k| exact[(k / 3, k % 3)]).collect();
            assert_close(&h, &exact, 1e-12, "projected = exact");
        }

        #[test]
        fn template_ellipsoid_is_zero_on_its_surface(
            phi in 0.0..std::f64::consts::PI, psi in 0.0..std::f64::consts::TAU,
            r in [1.0..50.0f64, 1.0..50.0f64, 1.0..50.0f64], label in 1u8..4,
        ) {
            let x = [r[0] * phi.sin() * psi.cos(), r[1] * phi.sin() * psi.sin(), r[2] * phi.cos()];
            let t = Ellipsoid::new();
            prop_assert!(t.value(0, label, &x, &r) < 1e-24);
            let [g, _, gt] = analytic(&t, 0, label, &x, &r);
            prop_assert!(g.iter().chain(&gt).all(|v| v.abs() < 1e-10));
        }

        #[test]
        fn template_planes_are_zero_on_their_planes(
            xy in [-50.0..50.0f64, -50.0..50.0f64], z in -50.0..50.0f64, h in -30.0..30.0f64,
        ) {
            let t = ParallelPlanes::new();
            let fetal = [xy[0], xy[1], h];
            let maternal = [xy[0], xy[1], -h];
            let other = [xy[0], xy[1], z];
            for (label, x) in [(LABEL_FETAL, fetal), (LABEL_MATERNAL, maternal),
                               (LABEL_MARGIN, other), (LABEL_INTERIOR, other)] {
                prop_assert_eq!(t.value(0, label, &x, &[h]), 0.0);
                let [g, _, gt] = analytic(&t, 0, label, &x, &[h]);
                prop_assert!(g.iter().chain(&gt).all(|v| *v == 0.0));
            }
            // The single plane ignores the fetal side wherever it is.
            prop_assert_eq!(SinglePlane::new().value(0, LABEL_FETAL, &other, &[h]), 0.0);
            prop_assert_eq!(SinglePlane::new().value(0, LABEL_MATERNAL, &maternal, &[h]), 0.0);
        }

        #[test]
        fn template_point_targets_derivatives_match_fd(
            x in point3(20.0), target in point3(20.0), dim in 2usize..4,
        ) {
            let t = PointTargets::from_pairs(3, dim, &[(1, target)]).unwrap();
            let x = &x[..dim];
            check_template(&t, 1, LABEL_INTERIOR, x, &[]);
            check_template(&t, 0, LABEL_FETAL, x, &[]);
            prop_assert_eq!(t.value(0, LABEL_FETAL, x, &[]), 0.0);
            prop_assert_eq!(t.value(1, LABEL_FETAL, &target[..dim], &[]), 0.0);
            let expected: f64 = (0..dim).map(|c| (x[c] - target[c]).powi(2)).sum();
            prop_assert!((t.value(1, 0, x, &[]) - expected).abs() <= 1e-12 * (1.0 + expected));
        }

        #[test]
        fn template_planes_update_is_the_exact_minimizer(
            pts in prop::collection::vec((point3(40.0), label_strategy(), 0.0..1.0f64), 1..40),
            fw in 0.0..2.0f64, mw in 0.0..2.0f64,
        ) {
            let labels: Vec<u8> = pts.iter().map(|p| p.1).collect();
            let xs: Vec<f64> = pts.iter().flat_map(|p| p.0).collect();
            let weights: Vec<f64> = pts.iter().map(|p| p.2).collect();
            let t = ParallelPlanes { fetal_weight: fw, maternal_weight: mw };
            let den: f64 = pts.iter().map(|p| match p.1 {
                LABEL_FETAL => fw * p.2, LABEL_MATERNAL => mw * p.2, _ => 0.0 }).sum();
            let mut theta = [7.0];
            let updated = t.update_theta(&labels, &xs, 3, &weights, &mut theta);
            prop_assert_eq!(updated, den > 1e-9);
            prop_assume!(den > 1e-3);
            let h = theta[0];
            // Stationary ...
            let g = weighted_theta_gradient(&t, &labels, &xs, 3, &weights, &theta)[0];
            let f = |h: f64| weighted_value(&t, &labels, &xs, 3, &weights, &[h]);
            prop_assert!(g.abs() <= 1e-9 * (1.0 + den * 40.0), "dphi/dh = {}", g);
            // ... and the same as a brute-force golden-section search.
            let (mut a, mut b) = (-60.0f64, 60.0f64);
            let ratio = (5f64.sqrt() - 1.0) / 2.0;
            for _ in 0..200 {
                let (c, d) = (b - ratio * (b - a), a + ratio * (b - a));
                if f(c) < f(d) { b = d } else { a = c }
            }
            let brute = 0.5 * (a + b);
            prop_assert!((brute - h).abs() <= 1e-5, "{} vs {}", brute, h);
            prop_assert!(f(h) <= f(brute) + 1e-12 * (1.0 + f(brute)));
        }

        #[test]
        fn template_ellipsoid_update_decreases_and_is_stationary(
            pts in prop::collection::vec(
                ([0.0..std::f64::consts::PI, 0.0..std::f64::consts::TAU], -0.2..0.2f64,
                 1u8..4, 0.1..1.0f64), 12..60),
            r in [5.0..30.0f64, 5.0..30.0f64, 3.0..15.0f64],
            start in [0.5..2.0f64, 0.5..2.0f64, 0.5..2.0f64],
        ) {
            let labels: Vec<u8> = pts.iter().map(|p| p.2).collect();
            let weights: Vec<f64> = pts.iter().map(|p| p.3).collect();
            let xs: Vec<f64> = pts.iter().flat_map(|([phi, psi], noise, _, _)| {
                let s = 1.0 + noise;
                [s * r[0] * phi.sin() * psi.cos(), s * r[1] * phi.sin() * psi.sin(),
                 s * r[2] * phi.cos()]
            }).collect();
            let t = Ellipsoid::new();
            let mut theta: Vec<f64> = (0..3).map(|i| r[i] * start[i]).collect();
            let before = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
            prop_assert!(t.update_theta(&labels, &xs, 3, &weights, &mut theta));
            prop_assert!(theta.iter().all(|r| r.is_finite() && *r > 0.0));
            let after = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
            prop_assert!(after <= before * (1.0 + 1e-12), "{} -> {}", before, after);
            let mut again = theta.clone();
            t.update_theta(&labels, &xs, 3, &weights, &mut again);
            let after2 = weighted_value(&t, &labels, &xs, 3, &weights, &again);
            prop_assert!(after2 <= after * (1.0 + 1e-12));
            // In a = r^-2 the penalty is linear least squares,
            // sum w (q . a - 1)^2 with q = (x1^2, x2^2, x3^2). When its
            // minimizer is interior (every a_i > 0, well-determined) the
            // update reaches it and dphi/dtheta vanishes; otherwise the
            // minimizer lies at a radius -> infinity, which the update
            // rightly stops short of (only the decrease is asserted).
            let mut m = nalgebra::Matrix3::<f64>::zeros();
            let mut b = nalgebra::Vector3::<f64>::zeros();
            for (k, w) in weights.iter().enumerate() {
                let q = nalgebra::Vector3::new(xs[3 * k].powi(2), xs[3 * k + 1].powi(2), xs[3 * k + 2].powi(2));
                m += *w * q * q.transpose();
                b += *w * q;
            }
            let eig = m.symmetric_eigenvalues();
            let well_posed = eig.min() > 1e-8 * eig.max();
            let interior = well_posed && m.lu().solve(&b).is_some_and(|a| a.iter().all(|&ai| ai > 0.0));
            if interior {
                let g = weighted_theta_gradient(&t, &labels, &xs, 3, &weights, &again);
                let scale: f64 = weights.iter().sum::<f64>() / theta.iter().fold(f64::INFINITY, |a, b| a.min(*b));
                prop_assert!(g.iter().all(|g| g.abs() <= 1e-6 * scale), "{:?}", g);
            }
        }
    }

    #[test]
    fn template_ellipsoid_update_recovers_radii() {
        let r = [40.0, 25.0, 12.0];
        let mut labels = Vec::new();
        let mut xs = Vec::new();
        for i in 0..10 {
            for j in 0..20 {
                let (phi, psi) = (0.1 + 0.3 * i as f64, 0.31 * j as f64);
                xs.extend([
                    r[0] * phi.sin() * psi.cos(),
                    r[1] * phi.sin() * psi.sin(),
                    r[2] * phi.cos(),
                ]);
                labels.push(LABELS[1 + (i + j) % 3]);
            }
        }
        // An interior vertex far away must not count.
        labels.push(LABEL_INTERIOR);
        xs.extend([500.0, 0.0, 0.0]);
        let weights = vec![1.0 / labels.len() as f64; labels.len()];
        let mut theta = [10.0, 60.0, 30.0];
        assert!(Ellipsoid::new().update_theta(&labels, &xs, 3, &weights, &mut theta));
        for i in 0..3 {
            assert!((theta[i] - r[i]).abs() < 1e-9 * r[i], "{theta:?}");
        }
    }

    #[test]
    fn template_ellipsoid_update_keeps_unconstrained_radii() {
        // All points in z = 0: rz is not determined and must stay.
        let labels = vec![LABEL_FETAL; 8];
        let xs: Vec<f64> = (0..8)
            .flat_map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 8.0;
                [20.0 * a.cos(), 10.0 * a.sin(), 0.0]
            })
            .collect();
        let weights = vec![1.0; 8];
        let mut theta = [15.0, 15.0, 7.0];
        let t = Ellipsoid::new();
        let before = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
        assert!(t.update_theta(&labels, &xs, 3, &weights, &mut theta));
        assert!(weighted_value(&t, &labels, &xs, 3, &weights, &theta) < 1e-20 * before);
        assert!((theta[0] - 20.0).abs() < 1e-9 && (theta[1] - 10.0).abs() < 1e-9);
        assert!((theta[2] - 7.0).abs() < 1e-9);
    }

    #[test]
    fn template_ellipsoid_update_stays_positive_when_the_fit_is_not_an_ellipsoid() {
        // Points on a hyperboloid x^2/10^2 + y^2/10^2 - z^2/5^2 = 1: the
        // unconstrained least-squares fit has a negative a_z.
        let mut xs = Vec::new();
        for i in 0..6 {
            for j in 0..12 {
                let (u, v) = (-1.0 + 0.4 * i as f64, 0.5 * j as f64);
                xs.extend([
                    10.0 * u.cosh() * v.cos(),
                    10.0 * u.cosh() * v.sin(),
                    5.0 * u.sinh(),
                ]);
            }
        }
        let n = xs.len() / 3;
        let labels = vec![LABEL_MATERNAL; n];
        let weights = vec![1.0; n];
        let t = Ellipsoid::new();
        let mut theta = [10.0, 10.0, 5.0];
        let mut last = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
        for _ in 0..5 {
            assert!(t.update_theta(&labels, &xs, 3, &weights, &mut theta));
            assert!(theta.iter().all(|r| r.is_finite() && *r > 0.0), "{theta:?}");
            let now = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
            assert!(now <= last * (1.0 + 1e-12));
            last = now;
        }
    }

    #[test]
    fn template_update_rejects_inconsistent_arguments() {
        let labels = [LABEL_FETAL, LABEL_MATERNAL];
        let xs = [0.0, 0.0, 1.0, 0.0, 0.0, -1.0];
        let w = [1.0, 1.0];
        let mut h = [0.0];
        assert!(!ParallelPlanes::new().update_theta(&labels, &xs[..5], 3, &w, &mut h));
        assert!(!ParallelPlanes::new().update_theta(&labels, &xs, 3, &w[..1], &mut h));
        assert!(!ParallelPlanes::new().update_theta(&labels, &xs, 2, &w, &mut [0.0; 1]));
        assert!(!ParallelPlanes::new().update_theta(&labels, &xs, 3, &[0.0, 0.0], &mut h));
        assert!(ParallelPlanes::new().update_theta(&labels, &xs, 3, &w, &mut h));
        assert_eq!(h, [1.0]);
        let mut r = [1.0, 1.0, -1.0];
        assert!(!Ellipsoid::new().update_theta(&labels, &xs, 3, &w, &mut r));
        assert!(!Ellipsoid::new().update_theta(&labels, &xs, 3, &w, &mut [1.0, 1.0]));
        assert!(!Ellipsoid::new().update_theta(&[0, 0], &xs, 3, &w, &mut [1.0; 3]));
        assert!(!PointTargets::new(vec![None], 2).unwrap().update_theta(
            &[0],
            &[0.0, 0.0],
            2,
            &[1.0],
            &mut []
        ));
    }

    #[test]
    fn template_single_plane_keeps_h_unless_asked() {
        let labels = [LABEL_FETAL, LABEL_MATERNAL, LABEL_MATERNAL, LABEL_MARGIN];
        let xs = [
            0.0, 0.0, 9.0, 0.0, 0.0, -4.0, 1.0, 0.0, -6.0, 0.0, 0.0, 100.0,
        ];
        let w = [1.0, 1.0, 3.0, 1.0];
        let mut h = [5.5];
        assert!(!SinglePlane::new().update_theta(&labels, &xs, 3, &w, &mut h));
        assert_eq!(h, [5.5]);
        let free = SinglePlane {
            optimize_h: true,
            ..SinglePlane::new()
        };
        assert!(free.update_theta(&labels, &xs, 3, &w, &mut h));
        assert!((h[0] - (4.0 + 18.0) / 4.0).abs() < 1e-12);
        // Parallel planes on the same data: (9 - (-4 - 18)) / 5.
        assert!(ParallelPlanes::new().update_theta(&labels, &xs, 3, &w, &mut h));
        assert!((h[0] - 31.0 / 5.0).abs() < 1e-12);
    }

    #[test]
    fn template_ellipsoid_margin_switch() {
        let x = [1.0, 2.0, 3.0];
        let r = [4.0, 5.0, 6.0];
        assert!(Ellipsoid::new().value(0, LABEL_MARGIN, &x, &r) > 0.0);
        assert_eq!(Ellipsoid::new().value(0, LABEL_INTERIOR, &x, &r), 0.0);
        let no_margin = Ellipsoid {
            include_margin: false,
        };
        assert_eq!(no_margin.value(0, LABEL_MARGIN, &x, &r), 0.0);
        assert!(no_margin.value(0, LABEL_FETAL, &x, &r) > 0.0);
    }

    #[test]
    fn template_point_targets_reject_bad_input() {
        assert!(matches!(
            PointTargets::from_pairs(3, 3, &[(3, [0.0; 3])]),
            Err(ParamError::Length { .. })
        ));
        assert!(PointTargets::from_pairs(3, 3, &[(1, [0.0; 3]), (1, [1.0; 3])]).is_err());
        assert!(PointTargets::from_pairs(3, 3, &[(1, [f64::NAN, 0.0, 0.0])]).is_err());
        assert!(PointTargets::from_pairs(3, 4, &[]).is_err());
        assert!(PointTargets::from_pairs(3, 1, &[]).is_err());
        let t = PointTargets::from_pairs(4, 2, &[(0, [1.0, 2.0, 99.0]), (3, [0.0; 3])]).unwrap();
        assert_eq!(t.count(), 2);
        assert_eq!(t.value(0, 0, &[1.0, 2.0], &[]), 0.0);
        assert_eq!(t.value(0, 0, &[2.0, 2.0], &[]), 1.0);
        // A vertex beyond the table has no target.
        assert_eq!(t.value(10, 0, &[2.0, 2.0], &[]), 0.0);
    }

    #[test]
    fn template_planes_weights_are_validated() {
        assert!(ParallelPlanes::with_weights(-1.0, 1.0).is_err());
        assert!(ParallelPlanes::with_weights(1.0, f64::INFINITY).is_err());
        assert_eq!(
            ParallelPlanes::with_weights(1.0, 1.0).unwrap(),
            ParallelPlanes::new()
        );
        assert_eq!(ParallelPlanes::single_plane().planes().fetal_weight, 0.0);
    }
}
