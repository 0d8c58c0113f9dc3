//! `report.json` of a ventricle run: the inputs' names, the library's
//! [`Report`], the transfer, the landmark sensitivity and how S was built
//! (when there are such), and the run's memory and provenance.

use super::sensitivity::SensitivityReport;
use crate::app::run::memory::MemoryReport;
use crate::app::run::provenance::Provenance;
use crate::organs::ventricle::Report;
use crate::organs::ventricle::enclosing::EnclosingReport;
use crate::organs::ventricle::rv_landmarks::FromRv;
use serde::{Deserialize, Serialize};

/// `report.json`: `inputs`, every key of the library's [`Report`]
/// (flattened), then `transfer`, `sensitivity` and `enclosing_surface`
/// when given, then `memory` and `provenance`. The command line and Python
/// write this one type (Python's memory section has the prediction only,
/// its provenance no command line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct VentricleReport {
    /// The inputs' names.
    pub inputs: ReportInputs,
    /// The library's report.
    #[serde(flatten)]
    pub report: Report,
    /// The transfer into a second heart, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transfer: Option<TransferReport>,
    /// The landmark sensitivity (`--sensitivity`), when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensitivity: Option<SensitivityReport>,
    /// How S was built from the anatomy, when it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub enclosing_surface: Option<EnclosingReport>,
    /// Predicted and measured peak memory of the run.
    pub memory: MemoryReport,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: Provenance,
}

impl VentricleReport {
    /// The report as indented JSON, ending in a newline (`report.json`).
    ///
    /// # Errors
    /// `serde_json`'s (a non-finite number where JSON has none is written as
    /// `null`, so in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}

/// The inputs named in `report.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReportInputs {
    /// The anatomy's name.
    pub anatomy: String,
    /// The enclosing surface's name.
    pub surface: String,
    /// The rim landmarks derived from `--rv-landmarks`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rv_landmarks: Option<FromRv>,
}

/// `transfer` in `report.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferReport {
    /// The second heart's enclosing surface.
    pub surface: String,
    /// Points carried over.
    pub points: usize,
    /// Distances from its given landmarks to the vertices they snapped to,
    /// mm (anterior, inferior, apex; 0 for a computed apex).
    #[serde(with = "crate::mesh::nan_as_null")]
    pub landmark_snap_mm: [f64; 3],
    /// Its apex, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub apex_mm: [f64; 3],
    /// Its chart: repair, landmarks and disk map, s.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub disk_seconds: f64,
    /// Its chart: the Laplace field, s.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub laplace_seconds: f64,
    /// The inverse map of every point, s.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub inverse_seconds: f64,
    /// The whole transfer, s.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub seconds: f64,
}
