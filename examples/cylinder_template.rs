//! A new placenta template, plugged into the whole placenta pipeline: the
//! two sides of the placenta pulled onto two coaxial cylinders around the
//! y axis (through `z = -R`) at radii `R + h` (fetal) and `R - h`
//! (maternal), a curved shell instead of the paper's planes. `theta = [h]`,
//! optimized jointly with the map (the parameter Hessians are the trait's
//! numeric defaults).
//!
//! ```text
//! rho = |(x1, x3 + R)|,  n = (x1, 0, x3 + R) / rho,  T = (rho - r)^2
//! dT/dx = 2 (rho - r) n,  dT/dh = -+ 2 (rho - r)
//! d2T/dx2 = 2 n n^T + 2 (rho - r) / rho (P - n n^T),  P = diag(1, 0, 1)
//! ```
//!
//! (the second term clamped at `rho < r`, so the Hessian stays PSD).
//! Run with `cargo run --release --example cylinder_template`.

use unfold::organs::placenta::{Pipeline, PlacentaTemplate, Report, estimate::Estimates};
use unfold::{mesh::shapes::*, organs::Quiet, param::Template};

/// Radius of the cylinders' mid-surface, mm.
const R: f64 = 150.0;

/// Two coaxial cylinders `R +- h`.
#[derive(Debug)]
pub struct Cylinders;

/// `rho - r`, `n` and `rho` of a position, and `s = dr/dh`: `+1` on the
/// fetal side, `-1` on the maternal side, `0` (and all else zero) off them.
fn parts(label: u8, x: &[f64], h: f64) -> (f64, [f64; 3], f64, f64) {
    let s = f64::from(label == side::FETAL) - f64::from(label == side::MATERNAL);
    let rho = x[0].hypot(x[2] + R).max(1e-12);
    let n = [x[0] / rho, 0.0, (x[2] + R) / rho].map(|c| c * s * s);
    (s * s * (rho - R - s * h), n, rho, s)
}

impl Template for Cylinders {
    fn name(&self) -> &'static str {
        "cylinders"
    }
    fn parameter_names(&self) -> Vec<&'static str> {
        vec!["h"]
    }
    fn value(&self, _: usize, label: u8, x: &[f64], t: &[f64]) -> f64 {
        parts(label, x, t[0]).0.powi(2)
    }
    fn gradient(&self, _: usize, label: u8, x: &[f64], t: &[f64], out: &mut [f64]) {
        let (d, n, _, _) = parts(label, x, t[0]);
        (0..3).for_each(|i| out[i] = 2.0 * d * n[i]);
    }
    fn hessian(&self, _: usize, label: u8, x: &[f64], t: &[f64], out: &mut [f64]) {
        let (d, n, rho, _) = parts(label, x, t[0]);
        let bend = 2.0 * d.max(0.0) / rho;
        for (k, o) in out.iter_mut().enumerate() {
            let (i, j) = (k / 3, k % 3);
            *o = 2.0 * n[i] * n[j] + bend * (f64::from(i == j && i != 1) - n[i] * n[j]);
        }
    }
    fn theta_gradient(&self, _: usize, label: u8, x: &[f64], t: &[f64], out: &mut [f64]) {
        let (d, _, _, s) = parts(label, x, t[0]);
        out[0] = -2.0 * s * d;
    }
}

impl PlacentaTemplate for Cylinders {
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64> {
        vec![estimates.half_thickness_mm]
    }
}

/// Flattens the synthetic placenta onto the cylinders.
pub fn run() -> Result<Report, Box<dyn std::error::Error>> {
    let shape = PlacentaParams {
        cells_radial: 8,
        cells_through: 3,
        ..PlacentaParams::default()
    };
    let slab = placenta_slab(&shape)?;
    Ok(Pipeline::new()
        .template(Cylinders)
        .run(&slab.mesh, &[], &mut Quiet)?
        .report)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("{}", serde_json::to_string_pretty(&run()?)?);
    Ok(())
}
