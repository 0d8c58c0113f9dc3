//! `unfold.mitral`: `unfold mitral` on one valve given as numpy arrays
//! ([`unfold::app::mitral`]: the command line's settings checks, pipeline,
//! messages and `report.json` layout, [`MitralReport`]).

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::{choice, points};
use numpy::{PyReadonlyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::Path;
use unfold::app::mitral::{
    Inputs, MitralReport, Settings, inputs_from_labels, leaflet_of, run_with,
};
use unfold::app::run::provenance::Provenance;
use unfold::mesh::CellMesh;
use unfold::organs::mitral::segmentation::SegmentationReport;

/// A leaflet given as `(points, cells, point_data)` (meshio's layout).
type Leaflet<'py> = (
    PyReadonlyArray2<'py, f64>,
    Bound<'py, PyDict>,
    Option<Bound<'py, PyDict>>,
);

/// Lays one valve out in 2D; returns `(valve2d, valve3d, report_json)`,
/// each mesh as `(points, cells, point_data, cell_data)`.
#[pyfunction]
#[pyo3(signature = (
    anterior, posterior, annulus=None, *, annulus_mode="landmark", init="auto", relax="sd",
    energy="symmetric-dirichlet", iterations=5, step_scale=None, coaptation_mm=2.0, tolerance_mm=None,
    cut_posteromedial=false, name="valve"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mitral<'py>(
    py: Python<'py>,
    anterior: Leaflet<'py>,
    posterior: Leaflet<'py>,
    annulus: Option<PyReadonlyArray2<'py, f64>>,
    annulus_mode: &str,
    init: &str,
    relax: &str,
    energy: &str,
    iterations: i64,
    step_scale: Option<f64>,
    coaptation_mm: f64,
    tolerance_mm: Option<f64>,
    cut_posteromedial: bool,
    name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = unfold::app::run::provenance::now();
    let Ok(iterations) = usize::try_from(iterations) else {
        return Err(crate::error(format!(
            "--iterations must be a whole number >= 0, got {iterations}"
        )));
    };
    let settings = Settings {
        annulus_mode: choice("--annulus-mode", annulus_mode)?,
        init: choice("--init", init)?,
        relax: choice("--relax", relax)?,
        energy: choice("--energy", energy)?,
        iterations,
        step_scale,
        coaptation_mm,
        tolerance_mm,
        cut_posteromedial,
        no_figures: true,
        ..Settings::default()
    };
    let pipeline = settings.pipeline().map_err(crate::error)?;
    let leaflet = |(p, c, d): Leaflet<'py>, which: &str| -> PyResult<_> {
        let cells = cell_mesh(p, &c, d.as_ref(), None)?;
        leaflet_of(&cells, Path::new(&format!("{name}: {which} leaflet"))).map_err(crate::error)
    };
    let anterior = leaflet(anterior, "anterior")?;
    let posterior = leaflet(posterior, "posterior")?;
    // Without a ring, the annulus from the leaflets' shared boundary (as
    // `unfold mitral` without --annulus).
    let ring = match &annulus {
        Some(a) => points(a, "annulus")?,
        None => unfold::organs::mitral::annulus_from_leaflets(
            &anterior,
            &posterior,
            pipeline.settings().tolerance_mm,
        )
        .map(|found| found.ring)
        .map_err(|source| {
            crate::input_error(
                unfold::app::AppError::Organ {
                    path: name.to_string(),
                    source,
                },
                &[
                    ("the anterior leaflet", &anterior.positions),
                    ("the posterior leaflet", &posterior.positions),
                ],
                unfold::app::run::units::OrganSize::MITRAL,
            )
        })?,
    };
    let inputs = Inputs {
        label: name.to_string(),
        anterior,
        posterior,
        ring,
    };
    let parameters = parameters(&settings, annulus.is_some());
    finish(py, &pipeline, &inputs, None, parameters, started)
}

/// The settings as the report has always named them.
fn parameters(settings: &Settings, annulus_given: bool) -> String {
    format!(
        "MitralSettings {{ annulus_mode: {:?}, init: {:?}, relax: {:?}, energy: {:?}, \
         iterations: {:?}, step_scale: {:?}, coaptation_mm: {:?}, tolerance_mm: {:?}, cut_posteromedial: {:?} }}, \
         annulus given: {}",
        settings.annulus_mode,
        settings.init,
        settings.relax,
        settings.energy,
        settings.iterations,
        settings.step_scale,
        settings.coaptation_mm,
        settings.tolerance_mm,
        settings.cut_posteromedial,
        annulus_given
    )
}

/// Runs `pipeline` on `inputs` with the GIL released; returns `(valve2d,
/// valve3d, report_json)`, the report with `segmentation` when given.
fn finish<'py>(
    py: Python<'py>,
    pipeline: &unfold::organs::mitral::Pipeline,
    inputs: &Inputs,
    segmentation: Option<SegmentationReport>,
    parameters: String,
    started: String,
) -> PyResult<Bound<'py, PyTuple>> {
    let run = py
        .detach(|| run_with(pipeline, inputs, &mut unfold::app::observer::Quiet))
        .map_err(|e| {
            crate::input_error(
                e,
                &[
                    ("the anterior leaflet", &inputs.anterior.positions),
                    ("the posterior leaflet", &inputs.posterior.positions),
                    ("the annulus", &inputs.ring),
                ],
                unfold::app::run::units::OrganSize::MITRAL,
            )
        })?;
    let outcome = run.outcome;
    let report = MitralReport {
        provenance: Provenance::python(parameters, started),
        segmentation,
        ..run.report
    };
    // As before: the report without a final newline.
    let json = serde_json::to_string_pretty(&report).map_err(crate::error)?;
    let valve2d = mesh_tuple(py, &CellMesh::from(&outcome.valve2d))?;
    let valve3d = mesh_tuple(py, &CellMesh::from(&outcome.valve3d))?;
    PyTuple::new(
        py,
        [
            valve2d.into_any(),
            valve3d.into_any(),
            json.into_pyobject(py)?.into_any(),
        ],
    )
}

/// Cuts one valve from a label map `(labels, affine)` (`unfold mitral
/// --seg`) and lays it out; returns `(valve2d, valve3d, report_json)`.
#[pyfunction]
#[pyo3(signature = (
    labels, affine, *, anterior_label, posterior_label, annulus_label=None,
    annulus_mode="landmark", init="auto", relax="sd", energy="symmetric-dirichlet",
    coaptation_mm=2.0, tolerance_mm=None, cut_posteromedial=false, name="valve"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mitral_seg<'py>(
    py: Python<'py>,
    labels: PyReadonlyArrayDyn<'py, f32>,
    affine: PyReadonlyArray2<'py, f64>,
    anterior_label: i64,
    posterior_label: i64,
    annulus_label: Option<i64>,
    annulus_mode: &str,
    init: &str,
    relax: &str,
    energy: &str,
    coaptation_mm: f64,
    tolerance_mm: Option<f64>,
    cut_posteromedial: bool,
    name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = unfold::app::run::provenance::now();
    let settings = Settings {
        annulus_mode: choice("--annulus-mode", annulus_mode)?,
        init: choice("--init", init)?,
        relax: choice("--relax", relax)?,
        energy: choice("--energy", energy)?,
        coaptation_mm,
        tolerance_mm,
        cut_posteromedial,
        no_figures: true,
        anterior_label: Some(anterior_label),
        posterior_label: Some(posterior_label),
        annulus_label,
        ..Settings::default()
    };
    let pipeline = settings.pipeline().map_err(crate::error)?;
    let volume = crate::inputs::volume(&labels, &affine, name)?;
    let (inputs, segmentation) = py
        .detach(|| inputs_from_labels(&volume, name.to_string(), &settings))
        .map_err(crate::error)?;
    let parameters = format!(
        "{}, labels: anterior {anterior_label}, posterior {posterior_label}, annulus {annulus_label:?}",
        parameters(&settings, false)
    );
    finish(
        py,
        &pipeline,
        &inputs,
        Some(segmentation),
        parameters,
        started,
    )
}
