//! Templates: the penalty `T(x_m, theta)` that pulls boundary vertices onto
//! a canonical shape (ALGORITHMS 2.3), and soft positional targets.

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
