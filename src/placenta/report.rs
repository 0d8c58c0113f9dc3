//! `report.json` of a placenta run: the library's [`Report`] with the
//! input's name, how a mask was meshed and the displacement field (when
//! there are such), and the run's memory and provenance.

use crate::organs::placenta::Report;
use serde::Serialize;

/// `report.json`: `mesh`, then `segmentation` and `displacement` when
/// given, then every key of the library's [`Report`] (flattened), then
/// `memory` and `provenance`. The sections the callers fill differently
/// (the command line: its `--seg` meshing, the ITK field, the process's
/// memory budget, the command line and input hashes; Python: its own
/// memory and provenance) are type parameters, so both write one layout.
#[derive(Debug, Serialize)]
pub struct FullReport<'a, S, D, M, P> {
    /// The input mesh's name (its path, or what the caller calls it).
    pub mesh: &'a str,
    /// How the mesh was made from a segmentation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<S>,
    /// The map as a displacement field.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub displacement: Option<D>,
    /// The library's report.
    #[serde(flatten)]
    pub report: &'a Report,
    /// Predicted and measured peak memory of the run.
    pub memory: M,
    /// Version, parameters, inputs, start time.
    pub provenance: P,
}

impl<S: Serialize, D: Serialize, M: Serialize, P: Serialize> FullReport<'_, S, D, M, P> {
    /// The report as indented JSON, ending in a newline.
    ///
    /// # Errors
    /// `serde_json`'s (a non-finite number where JSON has none is written as
    /// `null`, so in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}
