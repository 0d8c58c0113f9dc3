//! `OUT.report.json` of a deformation: the files, what the repair of the
//! input changed, the library's [`DeformReport`] and the run's provenance.

use crate::app::run::provenance::Provenance;
use crate::mesh::repair::RepairReport;
use crate::param::DeformReport;
use serde::{Deserialize, Serialize};

/// `OUT.report.json`: `mesh`, `targets_file`, `output`, `repair`, then
/// every key of the library's [`DeformReport`] (flattened), then
/// `provenance`. The command line and Python write this one type (Python's
/// `output` is empty, its provenance has no command line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DeformRunReport {
    /// The input mesh.
    pub mesh: String,
    /// The targets file.
    pub targets_file: String,
    /// The output mesh.
    pub output: String,
    /// What the repair of the input mesh changed.
    pub repair: RepairReport,
    /// The library's report.
    #[serde(flatten)]
    pub report: DeformReport,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: Provenance,
}

impl DeformRunReport {
    /// The report as indented JSON, ending in a newline.
    ///
    /// # Errors
    /// `serde_json`'s (in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}
