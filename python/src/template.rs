//! A Python object as a placenta template: [`PyTemplate`] implements the
//! library's [`Template`] and [`PlacentaTemplate`] by calling the object's
//! methods with the GIL re-acquired, so a method developer prototypes a
//! template `T(x_m, theta)` in Python and runs it in the Rust pipeline.
//!
//! The object (see `unfold.Template` in `python/unfold/_template.py`) has
//! `name`, `parameter_names`, optionally `symmetry`, and the methods
//! `initial_theta(estimates)`, `value(label, x, theta)`, `gradient(label, x,
//! theta)`, `hessian(label, x, theta)` and `theta_gradient(label, x,
//! theta)`, with `x` and `theta` float64 numpy vectors, and optionally
//! `update_theta(labels, xs, weights, theta)` (the best `theta` for fixed
//! positions, or None). The `theta` Hessians are the trait's finite
//! differences of `theta_gradient`.
//!
//! The trait's methods cannot fail, so the first exception a method raises
//! (or a result of the wrong shape or a non-finite one) is kept, every
//! later call returns NaN (which no line search accepts), and the caller
//! raises the kept error after the run ([`PyTemplate::error_slot`]).

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::fmt;
use std::sync::{Arc, Mutex};
use unfold::organs::placenta::estimate::Estimates;
use unfold::organs::placenta::{PlacentaTemplate, TemplateSymmetry};
use unfold::param::Template;

/// A Python template object, checked once at construction.
pub(crate) struct PyTemplate {
    object: Py<PyAny>,
    /// `object.name`, leaked once (the trait hands out `&'static str`).
    name: &'static str,
    /// `object.parameter_names`, leaked once.
    parameter_names: Vec<&'static str>,
    symmetry: TemplateSymmetry,
    /// Whether the object has an `update_theta` method.
    has_update: bool,
    /// The first exception or bad result of any call, shared by the clones
    /// the pipeline may make of a warm start.
    error: Arc<Mutex<Option<PyErr>>>,
}

impl fmt::Debug for PyTemplate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PyTemplate")
            .field("name", &self.name)
            .field("parameter_names", &self.parameter_names)
            .field("symmetry", &self.symmetry)
            .finish()
    }
}

/// Leaks `s` (a template's name or parameter name, once per template).
fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

impl PyTemplate {
    /// Wraps `object`, reading its `name`, `parameter_names` and `symmetry`
    /// and checking that it has the five methods.
    pub fn new(object: &Bound<'_, PyAny>) -> PyResult<Self> {
        for method in [
            "initial_theta",
            "value",
            "gradient",
            "hessian",
            "theta_gradient",
        ] {
            let callable = object
                .getattr(method)
                .map(|m| m.is_callable())
                .unwrap_or(false);
            if !callable {
                return Err(crate::error(format!(
                    "template must be planes, ellipsoid, single-plane or an object with the \
                     methods initial_theta, value, gradient, hessian and theta_gradient \
                     (see unfold.Template); {} has no method {method}",
                    object.get_type().name()?
                )));
            }
        }
        let name: String = match object.getattr("name") {
            Ok(n) => n.extract()?,
            Err(_) => object.get_type().name()?.to_string(),
        };
        let parameter_names: Vec<String> = match object.getattr("parameter_names") {
            Ok(p) => p.extract()?,
            Err(_) => Vec::new(),
        };
        let symmetry = match object.getattr("symmetry") {
            Ok(s) if !s.is_none() => match s.extract::<String>()?.as_str() {
                "none" => TemplateSymmetry::None,
                "half-turn-about-z" => TemplateSymmetry::HalfTurnAboutZ,
                "in-plane" => TemplateSymmetry::InPlane,
                other => {
                    return Err(crate::error(format!(
                        "template symmetry must be none, half-turn-about-z or in-plane, got \
                         '{other}'"
                    )));
                }
            },
            _ => TemplateSymmetry::None,
        };
        let has_update = object
            .getattr("update_theta")
            .map(|m| m.is_callable())
            .unwrap_or(false);
        Ok(PyTemplate {
            has_update,
            object: object.clone().unbind(),
            name: leak(name),
            parameter_names: parameter_names.into_iter().map(leak).collect(),
            symmetry,
            error: Arc::new(Mutex::new(None)),
        })
    }

    /// The slot of the first error a call met, to read after the pipeline
    /// has consumed the template.
    pub fn error_slot(&self) -> Arc<Mutex<Option<PyErr>>> {
        Arc::clone(&self.error)
    }

    fn failed(&self) -> bool {
        self.error.lock().map(|e| e.is_some()).unwrap_or(true)
    }

    fn keep(&self, e: PyErr) {
        if let Ok(mut slot) = self.error.lock()
            && slot.is_none()
        {
            *slot = Some(e);
        }
    }

    /// Calls `object.method(label, x, theta)` and writes its result (a
    /// sequence of `out.len()` finite numbers, any shape) into `out`; NaN
    /// on any failure, which is kept.
    fn call_into(&self, method: &str, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        if self.failed() {
            out.fill(f64::NAN);
            return;
        }
        let result = Python::attach(|py| -> PyResult<()> {
            let args = (
                label,
                PyArray1::from_slice(py, x),
                PyArray1::from_slice(py, theta),
            );
            let value = self.object.bind(py).call_method1(method, args)?;
            let (array, shape) = numpy_f64(py, &value)?;
            if array.len() != out.len() {
                return Err(crate::error(format!(
                    "template {}.{method} returned {} numbers (shape {:?}) for a point of {} \
                     coordinates and {} parameters; it must return {}",
                    self.name,
                    array.len(),
                    shape,
                    x.len(),
                    theta.len(),
                    out.len()
                )));
            }
            for (o, v) in out.iter_mut().zip(array.iter()) {
                *o = *v;
            }
            Ok(())
        });
        match result.and_then(|()| self.finite(method, out)) {
            Ok(()) => {}
            Err(e) => {
                out.fill(f64::NAN);
                self.keep(e);
            }
        }
    }

    fn finite(&self, method: &str, values: &[f64]) -> PyResult<()> {
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => Err(crate::error(format!(
                "template {}.{method} returned a non-finite number ({}) at entry {i}",
                self.name, values[i]
            ))),
        }
    }
}

/// `value` (a number, a list, an array of any shape) as a flat float64
/// vector and its shape.
fn numpy_f64(py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let array = py
        .import("numpy")?
        .call_method1("asarray", (value, "float64"))?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    let flat = array.call_method0("ravel")?.cast_into::<PyArray1<f64>>()?;
    let values = flat.readonly().as_slice()?.to_vec();
    Ok((values, shape))
}

impl Template for PyTemplate {
    fn name(&self) -> &'static str {
        self.name
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        self.parameter_names.clone()
    }

    fn value(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        let mut out = [0.0];
        self.call_into("value", label, x, theta, &mut out);
        out[0]
    }

    fn gradient(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.call_into("gradient", label, x, theta, out);
    }

    fn hessian(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.call_into("hessian", label, x, theta, out);
    }

    fn theta_gradient(&self, _vertex: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        self.call_into("theta_gradient", label, x, theta, out);
    }

    /// `object.update_theta(labels, xs, weights, theta)` with `labels`
    /// uint8 (n,), `xs` float64 (n, dim), `weights` float64 (n,) and
    /// `theta` float64 (p,); its result (p numbers) replaces `theta`, None
    /// leaves it. False without the method, after None, or on a failure
    /// (kept).
    fn update_theta(
        &self,
        labels: &[u8],
        xs: &[f64],
        dim: usize,
        weights: &[f64],
        theta: &mut [f64],
    ) -> bool {
        if !self.has_update
            || self.failed()
            || !unfold::param::template::update_arguments_fit(labels, xs, dim, weights, 1)
        {
            return false;
        }
        let result = Python::attach(|py| -> PyResult<Option<Vec<f64>>> {
            let xs = PyArray1::from_slice(py, xs).reshape([labels.len(), dim])?;
            let args = (
                PyArray1::from_slice(py, labels),
                xs,
                PyArray1::from_slice(py, weights),
                PyArray1::from_slice(py, theta),
            );
            let value = self.object.bind(py).call_method1("update_theta", args)?;
            if value.is_none() {
                return Ok(None);
            }
            let (new, shape) = numpy_f64(py, &value)?;
            if new.len() != theta.len() {
                return Err(crate::error(format!(
                    "template {}.update_theta returned {} numbers (shape {shape:?}) for {} \
                     parameters",
                    self.name,
                    new.len(),
                    theta.len()
                )));
            }
            self.finite("update_theta", &new)?;
            Ok(Some(new))
        });
        match result {
            Ok(Some(new)) => {
                theta.copy_from_slice(&new);
                true
            }
            Ok(None) => false,
            Err(e) => {
                self.keep(e);
                false
            }
        }
    }
}

impl PlacentaTemplate for PyTemplate {
    /// `object.initial_theta(estimates)` with the estimates as a dict
    /// (`half_thickness_mm`, `rx_mm`, `ry_mm`, `volume_mm3`); NaN (and the
    /// error kept) if it fails or returns the wrong count.
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64> {
        let p = self.parameter_names.len();
        let result = Python::attach(|py| -> PyResult<Vec<f64>> {
            let dict = PyDict::new(py);
            dict.set_item("half_thickness_mm", estimates.half_thickness_mm)?;
            dict.set_item("rx_mm", estimates.rx_mm)?;
            dict.set_item("ry_mm", estimates.ry_mm)?;
            dict.set_item("volume_mm3", estimates.volume_mm3)?;
            let value = self
                .object
                .bind(py)
                .call_method1("initial_theta", (dict,))?;
            let (theta, _) = numpy_f64(py, &value)?;
            if theta.len() != p {
                return Err(crate::error(format!(
                    "template {}.initial_theta returned {} numbers for {p} parameter names {:?}",
                    self.name,
                    theta.len(),
                    self.parameter_names
                )));
            }
            Ok(theta)
        });
        match result.and_then(|t| self.finite("initial_theta", &t).map(|()| t)) {
            Ok(theta) => theta,
            Err(e) => {
                self.keep(e);
                vec![f64::NAN; p]
            }
        }
    }

    fn symmetry(&self) -> TemplateSymmetry {
        self.symmetry
    }
}

/// Checks a template's derivatives at one point against central finite
/// differences (`unfold_param::template::check::template_derivatives`:
/// step `h = 1e-5 max(|v|, 1)`, entries compared to `rel max(1, max
/// |entries|)`): `dT/dx`, `dT/dtheta`, the Hessian symmetric, PSD and equal
/// to the differences of the gradient where those are PSD. Raises
/// `UnfoldError` naming the first entry that disagrees.
#[pyfunction]
#[pyo3(signature = (template, label, x, theta, rel=1e-6))]
pub(crate) fn check_template(
    template: &Bound<'_, PyAny>,
    label: u8,
    x: PyReadonlyArray1<'_, f64>,
    theta: PyReadonlyArray1<'_, f64>,
    rel: f64,
) -> PyResult<()> {
    let t = PyTemplate::new(template)?;
    let (x, theta) = (x.as_slice()?.to_vec(), theta.as_slice()?.to_vec());
    if !(1..=3).contains(&x.len()) {
        return Err(crate::error(format!(
            "x must have 1 to 3 coordinates, got {}",
            x.len()
        )));
    }
    if theta.len() != t.parameter_names.len() {
        return Err(crate::error(format!(
            "theta has {} numbers but the template names {} parameters {:?}",
            theta.len(),
            t.parameter_names.len(),
            t.parameter_names
        )));
    }
    let slot = t.error_slot();
    let checked = template.py().detach(|| {
        unfold::param::template::check::template_derivatives(&t, 0, label, &x, &theta, rel)
    });
    if let Some(e) = slot.lock().ok().and_then(|mut e| e.take()) {
        return Err(e);
    }
    checked.map_err(|m| {
        crate::error(format!(
            "template {} at label {label}, x {x:?}, theta {theta:?}: {m}",
            t.name
        ))
    })
}
