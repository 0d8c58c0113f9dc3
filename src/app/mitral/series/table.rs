//! The series table: one row per step (`series.csv`, and `series.json`
//! with the run's provenance) and the step's point of the plot over the
//! cycle.

use crate::app::mitral::inputs::ValveFiles;
use crate::app::run::provenance::Provenance;
use crate::figures::mitral::series::SeriesPoint;
use crate::organs::mitral::Report;
use serde::{Deserialize, Serialize};

/// The columns of `series.csv`: the first fourteen as before issue 22 (the
/// energies final), then the initial energies, the coaptation counts near
/// the zone and the threshold, the posterior and annulus files.
pub const SERIES_COLUMNS: [&str; 21] = [
    "step",
    "anterior_file",
    "annulus_length_mm",
    "u_extent_mm",
    "anterior_area_mm2",
    "posterior_area_mm2",
    "saddle_horn_height_mm",
    "area_above_plane_mm2",
    "coaptation_vertices",
    "angle_energy",
    "area_energy",
    "length_energy",
    "flipped_triangles",
    "seconds",
    "initial_angle_energy",
    "initial_area_energy",
    "initial_length_energy",
    "coaptation_near_vertices",
    "coaptation_threshold_mm",
    "posterior_file",
    "annulus_file",
];

/// One row of the series table (`series.csv`, `series.json`): the
/// measurements of one step, its final and initial mean energies and its
/// coaptation counts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeriesRow {
    /// The step's name (`step_000`, ...).
    pub step: String,
    /// The anterior leaflet's file.
    pub anterior: String,
    /// Length of the annulus ring, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub annulus_length_mm: f64,
    /// Extent of the annulus in `u`, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub u_extent_mm: f64,
    /// Area of the anterior leaflet, mm^2.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub anterior_area_mm2: f64,
    /// Area of the posterior leaflet, mm^2.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub posterior_area_mm2: f64,
    /// Highest annulus point above the annulus plane, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub saddle_horn_height_mm: f64,
    /// Leaflet area on the atrial side of the annulus plane, mm^2.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub area_above_plane_mm2: f64,
    /// Vertices within the coaptation threshold.
    pub coaptation_vertices: usize,
    /// Final mean angle energy.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub angle_energy: f64,
    /// Final mean area energy.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub area_energy: f64,
    /// Final mean length energy.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub length_energy: f64,
    /// Triangles with non-positive area in the final 2D map.
    pub flipped_triangles: usize,
    /// Wall-clock seconds of the step's pipeline.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub seconds: f64,
    /// Initial mean angle energy.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub initial_angle_energy: f64,
    /// Initial mean area energy.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub initial_area_energy: f64,
    /// Initial mean length energy.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub initial_length_energy: f64,
    /// Vertices near the coaptation zone (within twice the threshold).
    pub coaptation_near_vertices: usize,
    /// The coaptation threshold, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub coaptation_threshold_mm: f64,
    /// The posterior leaflet's file.
    pub posterior: String,
    /// The annulus file, or `from the leaflets`.
    pub annulus: String,
}

impl SeriesRow {
    /// The row of step `step` from `files` and its report.
    pub fn new(step: &str, files: &ValveFiles, r: &Report) -> SeriesRow {
        let d = &r.distortion;
        SeriesRow {
            step: step.to_string(),
            anterior: files.anterior.display().to_string(),
            annulus_length_mm: r.annulus_length_mm,
            u_extent_mm: r.u_extent_mm,
            anterior_area_mm2: r.leaflet_area_mm2.anterior,
            posterior_area_mm2: r.leaflet_area_mm2.posterior,
            saddle_horn_height_mm: r.saddle_horn_height_mm,
            area_above_plane_mm2: r.area_above_plane_mm2,
            coaptation_vertices: r.coaptation_vertices.within,
            angle_energy: d.r#final.angle,
            area_energy: d.r#final.area,
            length_energy: d.r#final.length,
            flipped_triangles: r.flipped_triangles,
            seconds: r.seconds,
            initial_angle_energy: d.initial.angle,
            initial_area_energy: d.initial.area,
            initial_length_energy: d.initial.length,
            coaptation_near_vertices: r.coaptation_vertices.near,
            coaptation_threshold_mm: r.coaptation_vertices.threshold_mm,
            posterior: files.posterior.display().to_string(),
            annulus: files
                .annulus
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_else(|| "from the leaflets".into()),
        }
    }

    /// Its values in [`SERIES_COLUMNS`] order (file names with `,` as `_`).
    pub fn csv(&self) -> String {
        let file = |s: &str| s.replace(',', "_");
        [
            self.step.clone(),
            file(&self.anterior),
            self.annulus_length_mm.to_string(),
            self.u_extent_mm.to_string(),
            self.anterior_area_mm2.to_string(),
            self.posterior_area_mm2.to_string(),
            self.saddle_horn_height_mm.to_string(),
            self.area_above_plane_mm2.to_string(),
            self.coaptation_vertices.to_string(),
            self.angle_energy.to_string(),
            self.area_energy.to_string(),
            self.length_energy.to_string(),
            self.flipped_triangles.to_string(),
            self.seconds.to_string(),
            self.initial_angle_energy.to_string(),
            self.initial_area_energy.to_string(),
            self.initial_length_energy.to_string(),
            self.coaptation_near_vertices.to_string(),
            self.coaptation_threshold_mm.to_string(),
            file(&self.posterior),
            file(&self.annulus),
        ]
        .join(",")
    }

    /// The step's point of the plot over the cycle.
    pub fn point(&self) -> SeriesPoint {
        SeriesPoint {
            initial: [
                self.initial_area_energy,
                self.initial_angle_energy,
                self.initial_length_energy,
            ],
            r#final: [self.area_energy, self.angle_energy, self.length_energy],
            coaptation: [self.coaptation_vertices, self.coaptation_near_vertices],
        }
    }
}

/// `series.csv`: the header ([`SERIES_COLUMNS`]) and one line per row,
/// each ending in a newline.
pub fn csv(rows: &[SeriesRow]) -> String {
    let mut csv = SERIES_COLUMNS.join(",");
    csv.push('\n');
    for r in rows {
        csv.push_str(&r.csv());
        csv.push('\n');
    }
    csv
}

/// `series.json`: the series table and the run's provenance (its run hash
/// lets a batch skip a series done before with the same inputs).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeriesReport {
    /// One row per step, as `series.csv`.
    pub steps: Vec<SeriesRow>,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: Provenance,
}

impl SeriesReport {
    /// The table as indented JSON, ending in a newline.
    ///
    /// # Errors
    /// `serde_json`'s (in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}
