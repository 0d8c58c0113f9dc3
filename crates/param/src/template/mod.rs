//! Templates: the penalty `T(x_m, theta)` that pulls boundary vertices onto
//! a canonical shape (ALGORITHMS 2.3), and soft positional targets
//! ([`PointTargets`]). The organ templates (the placenta's planes and
//! ellipsoid) live with their organ in `unfold-organs`; [`check`] tests any
//! template's derivatives against finite differences.

pub mod check;
mod point_targets;

pub use point_targets::PointTargets;

use std::fmt::Debug;

/// A template: the penalty of vertex `vertex` (with label `label`) at mapped
/// position `x` (2 or 3 coordinates) given the template parameters `theta`.
/// The objective adds `sum_m w_m T(m, label_m, x_m, theta)`.
///
/// Implement value, gradient and (PSD) Hessian in `x`, and the gradient in
/// `theta`; optionally a closed-form (or Newton) update of `theta` for
/// fixed positions.
pub trait Template: Send + Sync + Debug {
    /// A short name ("planes", ...).
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
/// vertex (a template's update returns `false` otherwise).
pub fn update_arguments_fit(
    labels: &[u8],
    xs: &[f64],
    dim: usize,
    weights: &[f64],
    min_dim: usize,
) -> bool {
    dim >= min_dim && labels.len() == weights.len() && xs.len() == dim * labels.len()
}
