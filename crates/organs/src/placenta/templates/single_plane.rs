//! The single-plane relaxation of the parallel planes (ALGORITHMS 2.3).

use super::{ParallelPlanes, PlacentaTemplate, TemplateSymmetry};
use crate::placenta::estimate::Estimates;
use serde::{Deserialize, Serialize};
use unfold_param::Template;

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

impl PlacentaTemplate for SinglePlane {
    /// `[h]`, the estimated half thickness (ALGORITHMS 2.4); the planes'
    /// stage runs first and hands over its `h`.
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64> {
        vec![estimates.half_thickness_mm]
    }

    /// The parallel planes with the same maternal weight: their optimum is
    /// where the single plane starts.
    fn warm_start(&self) -> Option<Box<dyn PlacentaTemplate>> {
        Some(Box::new(ParallelPlanes::default()))
    }

    /// The plane `z = -h` (and the free fetal side) is invariant under
    /// translations in x and y and rotations about z.
    fn symmetry(&self) -> TemplateSymmetry {
        TemplateSymmetry::InPlane
    }
}
