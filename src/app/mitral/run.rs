//! A mitral run on one valve's inputs: the library's [`Pipeline`] (the
//! annulus laid out, the leaflets below it, relaxed flip-free, the maps)
//! and the typed report. Nothing is written here ([`super::write()`] does).

use super::inputs::Inputs;
use super::report::MitralReport;
use super::settings::Settings;
use crate::app::AppError;
use crate::app::error::organ;
use crate::app::observer::Observer;
use crate::app::run::provenance;
use crate::mesh::TriMesh;
use crate::mesh::nalgebra::Point3;
use crate::organs::mitral::{Outcome, Pipeline, ValveInput};

/// What a run produced.
#[derive(Debug, Clone)]
pub struct Run {
    /// The library's outcome: both leaflets in 3D and 2D with their maps,
    /// and its report.
    pub outcome: Outcome,
    /// `report.json`: the outcome's report with the inputs named and the
    /// run's provenance.
    pub report: MitralReport,
}

impl Run {
    /// The run of `outcome` on the inputs called `label`, with this
    /// process's provenance.
    pub fn new(outcome: Outcome, label: &str) -> Run {
        let report = MitralReport {
            inputs: label.to_string(),
            report: outcome.report.clone(),
            segmentation: None,
            provenance: provenance::this_run(),
        };
        Run { outcome, report }
    }
}

/// Runs the pipeline of `settings` on `inputs` ([`run_with`]).
///
/// # Errors
/// The settings' ([`Settings::pipeline`]) and the pipeline's, about the
/// inputs.
pub fn run(
    settings: &Settings,
    inputs: &Inputs,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    run_with(&settings.pipeline()?, inputs, observer)
}

/// Runs `pipeline` (its pieces may be a method developer's) on `inputs`;
/// the stage goes to `observer` (the library's mitral pipeline reports no
/// iterations: its solves take well under a second each), and a warning for
/// each quality gate that failed with a fallback (the spring map's flips).
///
/// # Errors
/// The pipeline's, about `inputs.label` (settings as usage errors).
pub fn run_with(
    pipeline: &Pipeline,
    inputs: &Inputs,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    observer.stage("mitral: layout, relaxation and maps");
    let outcome = map_valve(
        pipeline,
        &inputs.anterior,
        &inputs.posterior,
        &inputs.ring,
        &inputs.label,
    )?;
    // a gate that failed with a sound fallback: the run goes on, said once
    for g in outcome.report.gates.0.iter().filter(|g| !g.passed) {
        if let Some(fallback) = &g.fallback {
            observer.warning(&format!(
                "quality gate {}: {} is not {}; {fallback}",
                g.name, g.value, g.requirement
            ));
        }
    }
    Ok(Run::new(outcome, &inputs.label))
}

/// Runs `pipeline` on one valve (named `label` in messages).
///
/// # Errors
/// The pipeline's, about `label` (settings as usage errors).
pub fn map_valve(
    pipeline: &Pipeline,
    anterior: &TriMesh,
    posterior: &TriMesh,
    annulus: &[Point3<f64>],
    label: &str,
) -> Result<Outcome, AppError> {
    pipeline
        .run(&ValveInput {
            anterior,
            posterior,
            annulus,
        })
        .map_err(|e| organ(label, e))
}
