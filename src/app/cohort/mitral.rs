//! The measurements of a mitral cohort in one table (issue 19): every
//! valve, and every step of a valve series, one row each, in
//! `OUT/cohort/mitral_measurements.csv`.
//!
//! The columns are those of a series' `series.csv` (`step`, annulus length,
//! extent, leaflet areas, saddle height, area above the plane, coaptation
//! vertices, energies, flipped triangles, seconds) after `id`. A series
//! subject contributes its `series.csv` rows; a single valve one row from
//! its `report.json` (`step` empty, `anterior_file` empty; the energies
//! are its `distortion.final`, the quantities a series writes).

use super::reports::{SubjectReport, subject_report};
use super::subject::SubjectRow;
use crate::app::error::{AppError, at};
use crate::app::mitral::{MitralReport, SERIES_COLUMNS};
use crate::app::run::files::ensure_dir;
use std::path::{Path, PathBuf};

/// The measurement columns: those of `series.csv` after `step` up to
/// `seconds` (the columns a series had before issue 22; the cohort's
/// per-step table keeps them).
pub(super) const COLUMNS: &[&str] = SERIES_COLUMNS.split_at(14).0.split_at(1).1;

/// A number as the report writes it (`serde_json`'s text; empty for a
/// non-finite value, which the report writes as `null`).
fn num(x: f64) -> String {
    serde_json::Number::from_f64(x)
        .map(|n| n.to_string())
        .unwrap_or_default()
}

/// A single valve's row from its report, in [`COLUMNS`] order.
pub(super) fn report_row(report: &MitralReport) -> Vec<String> {
    let r = &report.report;
    COLUMNS
        .iter()
        .map(|c| match *c {
            "annulus_length_mm" => num(r.annulus_length_mm),
            "u_extent_mm" => num(r.u_extent_mm),
            "anterior_area_mm2" => num(r.leaflet_area_mm2.anterior),
            "posterior_area_mm2" => num(r.leaflet_area_mm2.posterior),
            "saddle_horn_height_mm" => num(r.saddle_horn_height_mm),
            "area_above_plane_mm2" => num(r.area_above_plane_mm2),
            "coaptation_vertices" => r.coaptation_vertices.within.to_string(),
            // The same quantities as a series' columns (`unfold mitral`
            // writes `distortion.final` there).
            "angle_energy" => num(r.distortion.r#final.angle),
            "area_energy" => num(r.distortion.r#final.area),
            "length_energy" => num(r.distortion.r#final.length),
            "flipped_triangles" => r.flipped_triangles.to_string(),
            "seconds" => num(r.seconds),
            // `anterior_file`: a single valve has no step files
            _ => String::new(),
        })
        .collect()
}

/// Writes the table for the mitral subjects; the file written (none
/// without a mitral subject with outputs).
///
/// # Errors
/// Reading a subject's `series.csv` or its report (one that exists but
/// does not read as a valve's: [`AppError::Report`]), writing the table.
pub fn mitral_measurements(
    out: &Path,
    subjects: &[SubjectRow],
) -> Result<Option<PathBuf>, AppError> {
    let mut rows: Vec<Vec<String>> = Vec::new();
    for s in subjects.iter().filter(|s| s.organ == "mitral") {
        let dir = out.join(&s.id);
        let series = dir.join("series.csv");
        if series.is_file() {
            let mut r = csv::Reader::from_path(&series).map_err(|e| at(&series, e))?;
            let header: Vec<String> = r
                .headers()
                .map_err(|e| at(&series, e))?
                .iter()
                .map(str::to_string)
                .collect();
            for rec in r.records() {
                let rec = rec.map_err(|e| at(&series, e))?;
                let get = |name: &str| {
                    header
                        .iter()
                        .position(|h| h == name)
                        .and_then(|i| rec.get(i))
                        .unwrap_or("")
                        .to_string()
                };
                let mut row = vec![s.id.clone(), get("step")];
                row.extend(COLUMNS.iter().map(|c| get(c)));
                rows.push(row);
            }
        } else if let Some(SubjectReport::Mitral(report)) = subject_report(&dir, &s.organ)? {
            let mut row = vec![s.id.clone(), String::new()];
            row.extend(report_row(&report));
            rows.push(row);
        }
    }
    if rows.is_empty() {
        return Ok(None);
    }
    let stats_dir = out.join("cohort");
    ensure_dir(&stats_dir)?;
    let path = stats_dir.join("mitral_measurements.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["id", "step"];
    header.extend(COLUMNS);
    w.write_record(&header).map_err(|e| at(&path, e))?;
    for r in &rows {
        w.write_record(r).map_err(|e| at(&path, e))?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    crate::io::atomic_write(&path, &bytes)?;
    Ok(Some(path))
}
