//! The MIPS (conformal) energy, `|F|_F^2 / (det F)^(2/d)`.

use super::{DistortionEnergy, PAIRS, all_positive, product};

/// MIPS (most isometric parameterization), the conformal (angle) distortion
/// `psi(s) = |F|_F^2 / (det F)^(2/d) = (sum_i s_i^2) / (prod_i s_i)^(2/d)`.
///
/// In 2D this is `s1/s2 + s2/s1` (ALGORITHMS 1.2), minimum 2. In 3D it is the
/// same scale-invariant formula, `(s1^2 + s2^2 + s3^2) / (s1 s2 s3)^(2/3)`,
/// minimum 3 (so `minimum(d) = d`; divide by `d` for the variant with
/// minimum 1). A barrier (infinite for any `s_i <= 0`). Not convex: the
/// twist eigenvalues are `<= 0`. With `S = sum s_k^2`, `c = (prod s_k)^(-2/d)`:
///
/// ```text
/// dpsi/ds_i  = c (2 s_i - (2/d) S / s_i)
/// d2psi/ds_i ds_j = c [ 2 d_ij + (2/d) d_ij S / s_i^2
///                       - (4/d) (s_i / s_j + s_j / s_i) + (4/d^2) S / (s_i s_j) ]
/// twist(i,j) = c (2 - (2/d) S / (s_i s_j))
/// flip(i,j)  = c (2 + (2/d) S / (s_i s_j))
/// ```
///
/// (2D: twist `-(s1 - s2)^2 / (s1 s2)^2`, flip `(s1 + s2)^2 / (s1 s2)^2`.)
#[derive(Debug, Clone, Copy, Default)]
pub struct Mips;

impl Mips {
    /// `(S, c) = (sum s_k^2, (prod s_k)^(-2/d))`.
    #[inline]
    fn parts(s: &[f64]) -> (f64, f64) {
        let sum2: f64 = s.iter().map(|&x| x * x).sum();
        let p = product(s);
        let c = match s.len() {
            2 => 1.0 / p,
            3 => {
                let r = p.cbrt();
                1.0 / (r * r)
            }
            d => p.powf(-2.0 / d as f64),
        };
        (sum2, c)
    }
}

impl DistortionEnergy for Mips {
    fn name(&self) -> &'static str {
        "mips"
    }
    fn value(&self, s: &[f64]) -> f64 {
        if !all_positive(s) {
            return f64::INFINITY;
        }
        let (sum2, c) = Mips::parts(s);
        sum2 * c
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        for (o, &x) in out.iter_mut().zip(s) {
            *o = c * (2.0 * x - k * sum2 / x);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / d as f64;
        for i in 0..d {
            for j in 0..d {
                let (a, b) = (s[i], s[j]);
                let mut h = -2.0 * k * (a / b + b / a) + k * k * sum2 / (a * b);
                if i == j {
                    h += 2.0 + k * sum2 / (a * a);
                }
                out[i * d + j] = c * h;
            }
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        c * (2.0 + k * sum2 / (s[i] * s[j]))
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        c * (2.0 - k * sum2 / (s[i] * s[j]))
    }
    fn pair_eigenvalues(&self, s: &[f64], twist: &mut [f64], flip: &mut [f64]) {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        let npairs = s.len() * (s.len() - 1) / 2;
        for (m, &(i, j)) in PAIRS[..npairs].iter().enumerate() {
            let x = k * sum2 / (s[i] * s[j]);
            twist[m] = c * (2.0 - x);
            flip[m] = c * (2.0 + x);
        }
    }
    fn minimum(&self, dim: usize) -> f64 {
        dim as f64
    }
    fn is_barrier(&self) -> bool {
        true
    }
}
