//! A ventricle run on its inputs: the library's [`Pipeline`] (every
//! anatomy point to the cylinder and back), the transfer into a second
//! heart, the landmark sensitivity when asked for, and the typed report.
//! Nothing is written here ([`super::write`] does).

use super::inputs::{Inputs, Transfer};
use super::report::{ReportInputs, TransferReport, VentricleReport};
use super::sensitivity::{Sensitivity, sensitivity};
use super::settings::Settings;
use crate::app::error::{AppError, organ};
use crate::app::observer::Observer;
use crate::app::run::{memory, provenance};
use crate::mesh::CellMesh;
use crate::organs::ventricle::{Chamber, Config, Outcome, Pipeline};
use std::time::Instant;

/// What a run produced.
#[derive(Debug)]
pub struct Run {
    /// The library's outcome: the anatomy in the cylinder, S flattened,
    /// the chart.
    pub outcome: Outcome,
    /// The anatomy in the second heart (its cells and arrays kept), when
    /// asked for.
    pub transferred: Option<CellMesh>,
    /// The landmark sensitivity's per-point arrays, when asked for.
    pub sensitivity: Option<Sensitivity>,
    /// The report (its memory section is taken again when it is written).
    pub report: VentricleReport,
    /// The pipeline's configuration.
    pub config: Config,
}

/// The report's name of a chamber.
fn chamber_name(c: Chamber) -> &'static str {
    match c {
        Chamber::Lv => "LV",
        Chamber::Rv => "RV",
    }
}

/// Runs the ventricle pipeline of `settings` on `inputs`: every anatomy
/// point `v` goes to `psi(v) = (phi(v_S), d(v))` (module doc of
/// [`super`]) and back, with a transfer on to `psi_2^-1(psi(v))` in the
/// second heart, and with `settings.sensitivity` the landmarks' ten
/// perturbations ([`sensitivity`]). The Laplace field's estimate is
/// checked against the memory budget. Progress lines go to `observer`.
///
/// # Errors
/// The settings' ([`Settings::validate`]); the pipeline's, about `anatomy
/// + surface`; the transfer's, about the second heart; the sensitivity's.
pub fn run(
    settings: &Settings,
    inputs: &Inputs,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    let config = settings.validate()?;
    let label = format!("{} + {}", inputs.anatomy_label, inputs.surface_label);
    observer.progress(&format!(
        "ventricle: disk map and Laplace field of {} ({} vertices, {} triangles; {} grid {} mm), \
         then mapping {} anatomy points to the cylinder and back ...",
        inputs.surface_label,
        inputs.surface.positions.len(),
        inputs.surface.triangles.len(),
        chamber_name(config.chart.chamber),
        config.chart.field.grid_mm,
        inputs.anatomy.positions.len()
    ));
    // The field checks its estimate against the room left (issue 18).
    let mut field_config = config;
    field_config.chart.field.max_memory_bytes = memory::room();
    let pipeline = Pipeline::new().config(field_config);
    let resident = memory::resident_bytes().unwrap_or(0.0);
    let outcome = pipeline
        .run(&inputs.anatomy, &inputs.surface, &inputs.landmarks)
        .map_err(|e| organ(&label, e))?;
    memory::record(resident + outcome.report.field.estimated_bytes);
    let r = &outcome.report;
    observer.progress(&format!(
        "ventricle: disk map {:.2} s, Laplace field {:.2} s ({} unknowns, {} CG iterations), \
         mapping {} anatomy points {:.2} s, inverse {:.2} s",
        r.seconds.disk,
        r.seconds.laplace,
        r.field.unknowns,
        r.field.cg_iterations,
        r.anatomy_points,
        r.seconds.streamlines,
        r.seconds.inverse
    ));
    let transferred = match &inputs.transfer {
        None => None,
        Some(t) => Some(transfer(&pipeline, &outcome, t, observer)?),
    };
    let sensitivity = match settings.sensitivity {
        None => None,
        Some(mm) => Some(sensitivity(
            &outcome,
            &inputs.anatomy,
            &inputs.surface,
            &inputs.landmarks,
            config,
            mm,
            &label,
            observer,
        )?),
    };
    let (transferred, transfer) = match transferred {
        Some((mesh, report)) => (Some(mesh), Some(report)),
        None => (None, None),
    };
    let report = VentricleReport {
        inputs: ReportInputs {
            anatomy: inputs.anatomy_label.clone(),
            surface: inputs.surface_label.clone(),
            rv_landmarks: inputs.from_rv.clone(),
        },
        report: outcome.report.clone(),
        transfer,
        sensitivity: sensitivity.as_ref().map(|s| s.report.clone()),
        enclosing_surface: inputs.enclosing.clone(),
        memory: memory::report(),
        provenance: provenance::this_run(),
    };
    Ok(Run {
        outcome,
        transferred,
        sensitivity,
        report,
        config,
    })
}

/// The anatomy of `outcome` carried into the second heart `t`: its chart
/// by `pipeline`, then `psi_2^-1` of every cylinder point.
///
/// # Errors
/// The chart's or the inverse map's, about the second heart.
fn transfer(
    pipeline: &Pipeline,
    outcome: &Outcome,
    t: &Transfer,
    observer: &mut dyn Observer,
) -> Result<(CellMesh, TransferReport), AppError> {
    observer.progress(&format!(
        "ventricle: transfer: disk map and Laplace field of {} ({} vertices) ...",
        t.label,
        t.surface.positions.len()
    ));
    let t0 = Instant::now();
    let chart = pipeline
        .chart(&t.surface, &t.landmarks)
        .map_err(|e| organ(&t.label, e))?;
    observer.progress(&format!(
        "ventricle: transfer: mapping {} anatomy points into {} ...",
        outcome.coords.len(),
        t.label
    ));
    let t1 = Instant::now();
    let points = chart
        .inverse_all(&outcome.coords)
        .map_err(|e| organ(&t.label, e))?;
    let t2 = Instant::now();
    let timings = chart.timings();
    let s = chart.surface();
    let apex = s.positions[chart.landmarks().apex as usize];
    let mut mesh = outcome.anatomy.clone();
    mesh.positions = points;
    Ok((
        mesh,
        TransferReport {
            surface: t.label.clone(),
            points: outcome.coords.len(),
            landmark_snap_mm: chart.landmarks().snap_distances_mm,
            apex_mm: [apex.x, apex.y, apex.z],
            disk_seconds: timings.disk,
            laplace_seconds: timings.laplace,
            inverse_seconds: (t2 - t1).as_secs_f64(),
            seconds: (t2 - t0).as_secs_f64(),
        },
    ))
}
