//! A new distortion energy, used by the mitral relaxation: the conformal
//! AMIPS energy of the leaflet map (Fu, Liu and Guo 2015),
//!
//! ```text
//! psi(s) = exp(f),   f = (s1 / s2 + s2 / s1) / 2 >= 1
//! dpsi/ds = psi f',  d2psi/ds2 = psi (f' f'^T + f'')
//! f' = ((1/s2 - s2/s1^2) / 2, (1/s1 - s1/s2^2) / 2)
//! f'' = [[s2/s1^3, -(1/s1^2 + 1/s2^2)/2], [-(1/s1^2 + 1/s2^2)/2, s1/s2^3]]
//! ```
//!
//! It measures angle distortion only, grows exponentially with it, and is
//! infinite for a flat or flipped triangle (a barrier). Defined for
//! triangles (two singular values). The framework does the SVD, the
//! eigensystem and the PSD projection.
//! Run with `cargo run --release --example amips_mitral`.

use unfold::mesh::shapes::{ValveParams, mitral_valve};
use unfold::organs::mitral::{Pipeline, Report, ValveInput};
use unfold::param::DistortionEnergy;

/// Conformal AMIPS in 2D.
#[derive(Debug)]
pub struct Amips;

/// `psi`, `f'` and `f''` (row-major) at positive `s`.
fn parts(s: &[f64]) -> (f64, [f64; 2], [f64; 4]) {
    let (a, b) = (s[0], s[1]);
    let psi = (0.5 * (a / b + b / a)).exp();
    let g = [0.5 * (1.0 / b - b / (a * a)), 0.5 * (1.0 / a - a / (b * b))];
    let m = -0.5 * (1.0 / (a * a) + 1.0 / (b * b));
    (psi, g, [b / (a * a * a), m, m, a / (b * b * b)])
}

impl DistortionEnergy for Amips {
    fn name(&self) -> &'static str {
        "conformal-amips"
    }
    fn value(&self, s: &[f64]) -> f64 {
        if s.len() == 2 && s[0] > 0.0 && s[1] > 0.0 {
            parts(s).0
        } else {
            f64::INFINITY
        }
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        let (psi, g, _) = parts(s);
        (0..2).for_each(|i| out[i] = psi * g[i]);
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let (psi, g, h) = parts(s);
        (0..4).for_each(|k| out[k] = psi * (g[k / 2] * g[k % 2] + h[k]));
    }
    fn minimum(&self, _dim: usize) -> f64 {
        std::f64::consts::E
    }
    fn is_barrier(&self) -> bool {
        true
    }
}

/// Lays out and relaxes the built-in valve with AMIPS.
pub fn run() -> Result<Report, Box<dyn std::error::Error>> {
    let valve = mitral_valve(&ValveParams::default())?;
    let outcome = Pipeline::new().energy(Amips).run(&ValveInput {
        anterior: &valve.anterior,
        posterior: &valve.posterior,
        annulus: &valve.annulus,
    })?;
    Ok(outcome.report)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("{}", serde_json::to_string_pretty(&run()?)?);
    Ok(())
}
