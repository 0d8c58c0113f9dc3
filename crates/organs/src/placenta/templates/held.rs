//! A template whose parameters are held at given values: the map is
//! optimized against `T(x, theta_0)` with `theta_0` fixed (the command
//! line's `--fix-h`: the parallel planes at a chosen half thickness).

use super::{Estimates, PlacentaTemplate, TemplateSymmetry};
use unfold_param::Template;

/// `inner` with its parameters held at `theta`: the pipeline starts from
/// them ([`PlacentaTemplate::initial_theta`]) and neither the solver
/// ([`Template::optimize_theta`]) nor the template's own update
/// ([`Template::update_theta`]) moves them. A warm-start template of
/// `inner` (the single plane's planes) is held at the same values.
#[derive(Debug)]
pub struct Held {
    inner: Box<dyn PlacentaTemplate>,
    theta: Vec<f64>,
}

impl Held {
    /// Holds `inner`'s parameters at `theta`; `None` when `theta` does not
    /// have one value per [`Template::parameter_names`].
    pub fn new(inner: Box<dyn PlacentaTemplate>, theta: Vec<f64>) -> Option<Held> {
        (theta.len() == inner.parameter_names().len()).then_some(Held { inner, theta })
    }
}

impl Template for Held {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn parameter_names(&self) -> Vec<&'static str> {
        self.inner.parameter_names()
    }
    fn value(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        self.inner.value(vertex, label, x, theta)
    }
    fn gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.inner.gradient(vertex, label, x, theta, out)
    }
    fn hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.inner.hessian(vertex, label, x, theta, out)
    }
    fn theta_gradient(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.inner.theta_gradient(vertex, label, x, theta, out)
    }
    /// Held: never unknowns of the solve.
    fn optimize_theta(&self) -> bool {
        false
    }
    fn theta_hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.inner.theta_hessian(vertex, label, x, theta, out)
    }
    fn mixed_hessian(&self, vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.inner.mixed_hessian(vertex, label, x, theta, out)
    }
    /// Held: no update.
    fn update_theta(
        &self,
        _labels: &[u8],
        _xs: &[f64],
        _dim: usize,
        _weights: &[f64],
        _theta: &mut [f64],
    ) -> bool {
        false
    }
}

impl PlacentaTemplate for Held {
    /// The held values, whatever the estimates.
    fn initial_theta(&self, _estimates: &Estimates) -> Vec<f64> {
        self.theta.clone()
    }
    fn warm_start(&self) -> Option<Box<dyn PlacentaTemplate>> {
        // A start with other parameters than the held ones is dropped: the
        // stage then starts from the map alone.
        let start = self.inner.warm_start()?;
        Held::new(start, self.theta.clone()).map(|h| Box::new(h) as Box<dyn PlacentaTemplate>)
    }
    fn symmetry(&self) -> TemplateSymmetry {
        self.inner.symmetry()
    }
}
