//! `report.json` of a placenta run: the library's [`Report`] with the
//! input's name, how a mask was meshed and the displacement field (when
//! there are such), and the run's memory and provenance.

use super::seg::SegReport;
use crate::app::run::memory::MemoryReport;
use crate::app::run::provenance::Provenance;
use crate::organs::placenta::Report;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// `report.json`: `mesh`, then `segmentation` and `displacement` when
/// given, then every key of the library's [`Report`] (flattened), then
/// `memory` and `provenance`. The command line and Python write this one
/// type (Python's memory section has the prediction only, its provenance
/// no command line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlacentaReport {
    /// The input mesh's name (its path, or what the caller calls it).
    pub mesh: String,
    /// How the mesh was made from a segmentation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<SegReport>,
    /// The map as a displacement field.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub displacement: Option<DisplacementReport>,
    /// The library's report.
    #[serde(flatten)]
    pub report: Report,
    /// Predicted and measured peak memory of the run.
    pub memory: MemoryReport,
    /// Version, parameters, inputs, start time.
    pub provenance: Provenance,
}

impl PlacentaReport {
    /// The report as indented JSON, ending in a newline.
    ///
    /// # Errors
    /// `serde_json`'s (a non-finite number where JSON has none is written as
    /// `null`, so in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}

/// `displacement` in `report.json`: the map as an ITK displacement field.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisplacementReport {
    /// The file written.
    pub path: String,
    /// How to read it.
    pub convention: Cow<'static, str>,
    /// Voxel size of the template grid, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub spacing_mm: [f64; 3],
    /// Voxels of the template grid.
    pub dims: [usize; 3],
    /// Voxels inside the flattened mesh (the others are 0).
    pub inside_mesh: usize,
}
