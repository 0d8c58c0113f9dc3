//! Distortion energies as functions of the singular values of the element
//! Jacobian, with values, gradients and PSD-projected Hessians through the
//! analytic eigensystem (ALGORITHMS 1.2).
//!
//! Conventions: `vec(F)` is column-major (nalgebra's storage order), so the
//! 3D Hessian is 9x9 with index `i + 3 j` for `F[(i, j)]`. Signed singular
//! values: `F = U diag(s) V^T` with `U`, `V` proper rotations; the smallest
//! singular value carries the sign of `det F`.

use std::fmt::Debug;

/// An isotropic distortion density `psi(s)` of the signed singular values
/// `s` (2 or 3 of them, sorted by decreasing magnitude, the last one signed).
///
/// Implement `value`, `gradient` and `hessian` in `s`; the framework does the
/// SVD, the analytic eigensystem and the projection.
pub trait DistortionEnergy: Send + Sync + Debug {
    /// A short name ("symmetric-dirichlet", ...).
    fn name(&self) -> &'static str;
    /// `psi(s)`; `f64::INFINITY` where the energy is a barrier and `s` is
    /// not admissible (some `s_i <= 0`).
    fn value(&self, s: &[f64]) -> f64;
    /// `dpsi/ds_i` into `out` (same length as `s`).
    fn gradient(&self, s: &[f64], out: &mut [f64]);
    /// `d2psi/(ds_i ds_j)` into `out` (row-major `d x d`).
    fn hessian(&self, s: &[f64], out: &mut [f64]);
    /// The "flip" eigenvalue `(psi_i - psi_j) / (s_i - s_j)` of the pair
    /// `(i, j)`, evaluated stably when `s_i ~ s_j` (its limit is
    /// `psi_ii - psi_ij`). Override with a closed form where one exists.
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let d = s.len();
        let mut g = vec![0.0; d];
        self.gradient(s, &mut g);
        let ds = s[i] - s[j];
        if ds.abs() > 1e-6 * (s[i].abs() + s[j].abs()).max(1e-300) {
            (g[i] - g[j]) / ds
        } else {
            let mut h = vec![0.0; d * d];
            self.hessian(s, &mut h);
            h[i * d + i] - h[i * d + j]
        }
    }
    /// The minimum value (at rotations) in dimension `dim`.
    fn minimum(&self, dim: usize) -> f64;
    /// Whether the energy is infinite at `det J -> 0` (a barrier against
    /// inversion). Energies without a barrier rely on the injective line
    /// search alone.
    fn is_barrier(&self) -> bool;
}
