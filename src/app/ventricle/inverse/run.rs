//! A `ventricle-inverse` run: the target heart's chart, then `psi^-1` of
//! every point on its own, a status per point, and the typed report.
//! Nothing is written here ([`super::write`] does).

use super::coordinates::{Source, cylinder_coordinates};
use super::inputs::Inputs;
use super::report::{FailureCounts, FailureEntry, InverseInputs, InverseReport, InverseSeconds};
use super::settings::Settings;
use crate::app::AppError;
use crate::app::error::{about, organ};
use crate::app::run::{memory, provenance};
use crate::app::ventricle::layers::transmural_layers;
use crate::mesh::nalgebra::Point3;
use crate::mesh::{CellMesh, Field};
use crate::organs::ventricle::{Pipeline, PointFailure};
use rayon::prelude::*;
use std::time::Instant;

/// `inverse_status` of a point mapped.
pub const STATUS_MAPPED: i32 = 0;
/// `inverse_status`: not a cylinder point (not finite, depth outside
/// `[0, 1]`).
pub const STATUS_NOT_ON_CYLINDER: i32 = 1;
/// `inverse_status`: the disk position lies outside the flattened S.
pub const STATUS_OFF_DISK: i32 = 2;
/// `inverse_status`: the streamline failed.
pub const STATUS_STREAMLINE: i32 = 3;

/// The `inverse_status` of a failure.
fn status_of(f: &PointFailure) -> i32 {
    match f {
        PointFailure::NotOnCylinder { .. } | PointFailure::NotFinite { .. } => {
            STATUS_NOT_ON_CYLINDER
        }
        PointFailure::OffDisk { .. } => STATUS_OFF_DISK,
        _ => STATUS_STREAMLINE,
    }
}

/// How many first failures `report.json` lists with their messages.
pub const LISTED_FAILURES: usize = 20;

/// What a run produced.
#[derive(Debug)]
pub struct Run {
    /// The input with its points at `psi^-1` and the point arrays of the
    /// module doc (`mapped.vtu`).
    pub mapped: CellMesh,
    /// The report (its memory section is taken again when it is written).
    pub report: InverseReport,
    /// The field's predicted memory, bytes.
    pub estimated_bytes: f64,
}

/// `psi^-1` of every point of a mesh in cylinder coordinates onto one
/// heart (the module doc of [`super`]): the command line's and Python's
/// one path.
///
/// # Errors
/// The settings' ([`Settings::validate`]); a usage error for an input
/// without points, coordinates that cannot be read, or no point mapped;
/// the pipeline's error about S.
pub fn run(settings: &Settings, input: &Inputs) -> Result<Run, AppError> {
    let config = settings.validate()?;
    let normalized = &input.normalized;
    if normalized.positions.is_empty() {
        return Err(about(
            &input.normalized_label,
            "has no points; give a mesh in normalized coordinates (xi, zeta, depth)",
        ));
    }
    let chamber = config.chart.chamber;
    let (coords, source) = cylinder_coordinates(
        normalized,
        &input.normalized_label,
        settings.coordinates,
        chamber,
        config.display_exponent,
    )?;
    // The field checks its estimate against the room left (issue 18).
    let mut chart_config = config;
    chart_config.chart.field.max_memory_bytes = memory::room();
    let resident = memory::resident_bytes().unwrap_or(0.0);
    let chart = Pipeline::new()
        .config(chart_config)
        .chart(&input.surface, &input.landmarks)
        .map_err(|e| organ(&input.surface_label, e))?;
    let estimated_bytes = chart.field().stats().estimated_bytes;
    memory::record(resident + estimated_bytes);

    let t0 = Instant::now();
    let results: Vec<Result<Point3<f64>, PointFailure>> =
        coords.par_iter().map(|c| chart.inverse(c)).collect();
    let inverse_seconds = t0.elapsed().as_secs_f64();

    let n = coords.len();
    let nowhere = chart.field().frame().world([0.0; 3]);
    let mut status = Vec::with_capacity(n);
    let mut positions = Vec::with_capacity(n);
    let mut counts = FailureCounts::default();
    let mut first_failures = Vec::new();
    for (i, r) in results.iter().enumerate() {
        match r {
            Ok(p) => {
                status.push(STATUS_MAPPED);
                positions.push(*p);
            }
            Err(f) => {
                let s = status_of(f);
                match s {
                    STATUS_NOT_ON_CYLINDER => counts.not_on_cylinder += 1,
                    STATUS_OFF_DISK => counts.off_disk += 1,
                    _ => counts.streamline += 1,
                }
                if first_failures.len() < LISTED_FAILURES {
                    first_failures.push(FailureEntry {
                        point: i,
                        status: s,
                        reason: f.to_string(),
                    });
                }
                status.push(s);
                positions.push(nowhere);
            }
        }
    }
    let failed = n - status.iter().filter(|&&s| s == STATUS_MAPPED).count();
    if failed == n {
        let first = &first_failures[0];
        return Err(about(
            &input.normalized_label,
            format!(
                "none of its {n} points maps onto the heart (not a cylinder point: {}, off the \
                 disk: {}, streamline: {}); point {}: {} (read from the {})",
                counts.not_on_cylinder,
                counts.off_disk,
                counts.streamline,
                first.point,
                first.reason,
                match source {
                    Source::Arrays => "point arrays xi, zeta, depth",
                    Source::Points => "points as (X, Y, depth)",
                }
            ),
        ));
    }

    let mut mapped = normalized.clone();
    mapped.positions = positions;
    mapped
        .point_data
        .insert(Field::labels("inverse_status", status.clone()));
    if source == Source::Points {
        mapped
            .point_data
            .insert(Field::scalars("xi", coords.iter().map(|c| c.xi).collect()));
        mapped.point_data.insert(Field::scalars(
            "zeta",
            coords.iter().map(|c| c.zeta).collect(),
        ));
        mapped.point_data.insert(Field::scalars(
            "depth",
            coords.iter().map(|c| c.depth).collect(),
        ));
    }
    if let Some(k) = settings.layers {
        let layer: Vec<i32> = transmural_layers(&coords, k)
            .into_iter()
            .zip(&status)
            .map(|(l, &s)| if s == STATUS_MAPPED { l } else { 0 })
            .collect();
        mapped.point_data.insert(Field::labels("layer", layer));
    }
    let timings = chart.timings();
    let apex = chart.surface().positions[chart.landmarks().apex as usize];
    let report = InverseReport {
        inputs: InverseInputs {
            normalized: input.normalized_label.clone(),
            surface: input.surface_label.clone(),
            coordinates: source,
            rv_landmarks: input.from_rv.clone(),
        },
        chamber,
        points: n,
        mapped: n - failed,
        failed,
        failed_points_at_mm: [nowhere.x, nowhere.y, nowhere.z],
        failures: counts,
        first_failures,
        grid_mm: chart.field().grid_mm(),
        hemisphere_mm: chart.field().hemisphere_radius(),
        display_exponent: config.display_exponent,
        landmark_snap_mm: chart.landmarks().snap_distances_mm,
        apex_mm: [apex.x, apex.y, apex.z],
        seconds: InverseSeconds {
            disk: timings.disk,
            laplace: timings.laplace,
            inverse: inverse_seconds,
            total: input.started.elapsed().as_secs_f64(),
        },
        memory: memory::report(),
        provenance: provenance::this_run(),
    };
    Ok(Run {
        mapped,
        report,
        estimated_bytes,
    })
}
