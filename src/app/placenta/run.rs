//! A placenta run on its inputs: the library's [`Pipeline`] (flatten, pull
//! every image back), the typed report, and the lambda sweep when asked
//! for. Nothing is written here ([`super::write`] does).

use super::errors::pipeline_error;
use super::inputs::{ImageInput, Inputs, check_names};
use super::lambda_sweep::{Sweep, lambda_sweep};
use super::report::PlacentaReport;
use super::settings::Settings;
use crate::app::AppError;
use crate::app::observer::Observer;
use crate::app::run::{memory, provenance};
use crate::io::Frame;
use crate::organs::OrganError;
use crate::organs::placenta::images::check_images;
use crate::organs::placenta::{Config, Image, Outcome, Pipeline};

/// What a run produced.
#[derive(Debug)]
pub struct Run {
    /// The library's outcome: the meshes, labels and flat images.
    pub outcome: Outcome,
    /// The report (the files' paths and the displacement field are filled
    /// in when they are written).
    pub report: PlacentaReport,
    /// The lambda sweep, when asked for.
    pub sweep: Option<Sweep>,
    /// The pipeline's configuration (the displacement field's grid).
    pub config: Config,
}

/// Runs the placenta pipeline of `settings` on `inputs`, telling
/// `observer` its progress ([`run_with`] with the settings' pipeline).
///
/// # Errors
/// The settings' ([`Settings::config`], [`Settings::pipeline`]) and the
/// pipeline's, attributed to the input they are about.
pub fn run(
    settings: &Settings,
    inputs: &Inputs,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    let pipeline = settings.pipeline(config(settings, inputs)?)?;
    run_with(&pipeline, settings, inputs, observer)
}

/// The pipeline's configuration for `inputs`: `settings` with the defaults
/// the inputs imply (the mask's voxel size and half thickness).
///
/// # Errors
/// [`Settings::config`]'s.
pub fn config(settings: &Settings, inputs: &Inputs) -> Result<Config, AppError> {
    settings.config(
        inputs.voxel_mm,
        inputs.segmentation.as_ref().map(|s| s.half_thickness_mm),
    )
}

/// Runs `pipeline` (its pieces may be a method developer's) on `inputs`:
/// checks the image names (their outputs must differ) and the images
/// against the mesh before any work, flattens, pulls every image back,
/// warns of mesh vertices outside a `--grid` box, and with
/// `settings.lambda_sweep` flattens again with each weight.
///
/// # Errors
/// The pipeline's, attributed to the input they are about.
pub fn run_with(
    pipeline: &Pipeline,
    settings: &Settings,
    inputs: &Inputs,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    let label = inputs.label.as_str();
    check_names(
        inputs
            .images
            .iter()
            .map(|i| (i.path.as_path(), i.name.as_str())),
    )?;
    let images: Vec<Image<'_>> = inputs
        .images
        .iter()
        .map(|i| Image {
            name: &i.name,
            volume: &i.image.volume,
        })
        .collect();
    // The library checks the images again; checking them here first means
    // nothing is done for a run that cannot start.
    let frame_check = pipeline.settings().frame_check;
    check_images(&inputs.mesh.mesh, &images, frame_check)
        .map_err(|e| error(label, inputs.frame, &inputs.images, e))?;
    let outcome = pipeline
        .run_prepared(inputs.mesh.clone(), &images, &mut *observer)
        .map_err(|e| error(label, inputs.frame, &inputs.images, e))?;
    for i in &outcome.report.images {
        if i.vertices_outside_grid > 0 {
            observer.warning(&format!(
                "{}: {} of the flattened mesh's {} vertices lie outside the --grid box \
                 (counted in report.json)",
                i.name,
                i.vertices_outside_grid,
                outcome.flattened.num_vertices()
            ));
        }
    }
    let report = PlacentaReport {
        mesh: label.to_string(),
        segmentation: inputs.segmentation.clone(),
        displacement: None,
        report: outcome.report.clone(),
        memory: memory::report(),
        provenance: provenance::this_run(),
    };
    let sweep = if settings.lambda_sweep.is_empty() {
        None
    } else {
        Some(lambda_sweep(
            settings,
            *pipeline.settings(),
            &inputs.mesh,
            label,
            observer,
        )?)
    };
    Ok(Run {
        outcome,
        report,
        sweep,
        config: *pipeline.settings(),
    })
}

/// A pipeline error, attributed to the file it is about
/// ([`pipeline_error`]).
fn error(label: &str, frame: Frame, images: &[ImageInput], e: OrganError) -> AppError {
    let paths: Vec<String> = images
        .iter()
        .map(|i| i.path.display().to_string())
        .collect();
    pipeline_error(label, frame, &paths, e)
}
