//! `report.json` of `ventricle-inverse`: the inputs, how many points were
//! mapped and why the others were not, the chart's settings and landmarks,
//! the seconds, and the run's memory and provenance.

use super::coordinates::Source;
use crate::app::run::memory::MemoryReport;
use crate::app::run::provenance::Provenance;
use crate::organs::ventricle::Chamber;
use crate::organs::ventricle::rv_landmarks::FromRv;
use serde::Serialize;

/// `report.json` of `ventricle-inverse`. The command line and Python
/// write this one type (Python's memory section has the prediction only,
/// its provenance no command line).
#[derive(Debug, Clone, Serialize)]
pub struct InverseReport {
    /// The inputs' names and where the coordinates came from.
    pub inputs: InverseInputs,
    /// The chamber S encloses.
    pub chamber: Chamber,
    /// Points of the mesh in cylinder coordinates.
    pub points: usize,
    /// Points carried onto the heart.
    pub mapped: usize,
    /// Points that could not be.
    pub failed: usize,
    /// Where `mapped.vtu` puts them: the centre of the base (of H), mm.
    pub failed_points_at_mm: [f64; 3],
    /// Failures per reason.
    pub failures: FailureCounts,
    /// The first failures, with their messages.
    pub first_failures: Vec<FailureEntry>,
    /// Grid spacing of the Laplace field, mm.
    pub grid_mm: f64,
    /// Radius of the hemisphere H, mm.
    pub hemisphere_mm: f64,
    /// Display exponent of the LV disk.
    pub display_exponent: f64,
    /// Distances from the given landmarks to the vertices they snapped to,
    /// mm (anterior, inferior, apex).
    pub landmark_snap_mm: [f64; 3],
    /// The apex, mm.
    pub apex_mm: [f64; 3],
    /// Seconds per step.
    pub seconds: InverseSeconds,
    /// Predicted (and measured) peak memory.
    pub memory: MemoryReport,
    /// Version, parameters, time.
    pub provenance: Provenance,
}

impl InverseReport {
    /// The report as indented JSON, ending in a newline (`report.json`).
    ///
    /// # Errors
    /// `serde_json`'s (in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}

/// The inputs named in `report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct InverseInputs {
    /// The mesh in cylinder coordinates.
    pub normalized: String,
    /// The target heart's S.
    pub surface: String,
    /// `arrays` or `points`.
    pub coordinates: Source,
    /// The rim landmarks derived from `--rv-landmarks`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rv_landmarks: Option<FromRv>,
}

/// Failures per reason in `report.json`.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FailureCounts {
    /// Not a cylinder point (not finite, depth outside `[0, 1]`).
    pub not_on_cylinder: usize,
    /// Disk position outside the flattened S.
    pub off_disk: usize,
    /// The streamline failed.
    pub streamline: usize,
}

/// One failure listed in `report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct FailureEntry {
    /// Index of the point in the mesh.
    pub point: usize,
    /// Its `inverse_status`.
    pub status: i32,
    /// Why.
    pub reason: String,
}

/// Seconds per step.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct InverseSeconds {
    /// Repair, landmarks and disk map of S.
    pub disk: f64,
    /// The Laplace field.
    pub laplace: f64,
    /// The inverse map of every point.
    pub inverse: f64,
    /// The whole run.
    pub total: f64,
}
