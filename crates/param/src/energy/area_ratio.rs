//! The area (2D) / volume (3D) ratio energy, `det F + 1 / det F`.

use super::{DistortionEnergy, all_positive, product};

/// Area ratio (2D) / volume ratio (3D), `psi(s) = P + 1/P` with
/// `P = prod_i s_i = det F` (`A/Â + Â/A`, resp. `V/V̂ + V̂/V`).
///
/// Minimum 2 wherever `det F = 1` (in particular at rotations); a barrier
/// (infinite for `P <= 0`, i.e. any `s_i <= 0`). Measures only the change of
/// measure, not the shape, so its Hessian has a `d^2 - 1` dimensional
/// kernel-or-negative part: pair it with a shape energy. With `P = prod s_k`:
///
/// ```text
/// dpsi/ds_i  = (P - 1/P) / s_i
/// d2psi/ds_i^2 = 2 / (P s_i^2),  d2psi/ds_i ds_j = (P + 1/P) / (s_i s_j)  (i != j)
/// twist(i,j) =  (P - 1/P) / (s_i s_j)
/// flip(i,j)  = -(P - 1/P) / (s_i s_j)
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct AreaRatio;

impl DistortionEnergy for AreaRatio {
    fn name(&self) -> &'static str {
        "area-ratio"
    }
    fn value(&self, s: &[f64]) -> f64 {
        let p = product(s);
        if !all_positive(s) || p <= 0.0 {
            return f64::INFINITY;
        }
        p + 1.0 / p
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        let p = product(s);
        let a = p - 1.0 / p;
        for (o, &x) in out.iter_mut().zip(s) {
            *o = a / x;
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        let p = product(s);
        let b = p + 1.0 / p;
        for i in 0..d {
            for j in 0..d {
                out[i * d + j] = if i == j {
                    2.0 / (p * s[i] * s[i])
                } else {
                    b / (s[i] * s[j])
                };
            }
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let p = product(s);
        -(p - 1.0 / p) / (s[i] * s[j])
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let p = product(s);
        (p - 1.0 / p) / (s[i] * s[j])
    }
    fn minimum(&self, _dim: usize) -> f64 {
        2.0
    }
    fn is_barrier(&self) -> bool {
        true
    }
}
