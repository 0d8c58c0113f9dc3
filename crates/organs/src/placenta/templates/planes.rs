//! Two parallel planes, the placenta paper's default template
//! (ALGORITHMS 2.3).

use super::TemplateSymmetry;
use super::{PlacentaTemplate, SinglePlane};
use crate::placenta::estimate::Estimates;
use crate::placenta::side;
use crate::{ConfigError, Requirement};
use serde::{Deserialize, Serialize};
use unfold_param::Template;
use unfold_param::template::update_arguments_fit;

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
    pub fn with_weights(fetal_weight: f64, maternal_weight: f64) -> Result<Self, ConfigError> {
        ConfigError::check("fetal_weight", fetal_weight, Requirement::NonNegative)?;
        ConfigError::check("maternal_weight", maternal_weight, Requirement::NonNegative)?;
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
            side::FETAL => Some((self.fetal_weight, 1.0)),
            side::MATERNAL => Some((self.maternal_weight, -1.0)),
            _ => None,
        }
    }

    /// The exact minimizer `h` of `sum_m w_m T(x_m, h)` (see the type's
    /// documentation), `None` when no weighted fetal or maternal vertex
    /// exists or the arguments are inconsistent.
    pub fn optimal_h(&self, labels: &[u8], xs: &[f64], dim: usize, weights: &[f64]) -> Option<f64> {
        if !update_arguments_fit(labels, xs, dim, weights, 3) {
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
        "planes"
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

impl PlacentaTemplate for ParallelPlanes {
    /// `[h]`, the estimated half thickness (ALGORITHMS 2.4).
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64> {
        vec![estimates.half_thickness_mm]
    }

    /// The planes `z = +-h` are invariant under translations in x and y and
    /// rotations about z.
    fn symmetry(&self) -> TemplateSymmetry {
        TemplateSymmetry::InPlane
    }
}
