//! `OUT.report.json` of a deformation: the files, what the repair of the
//! input changed (a tet REST without INIT only), the library's
//! [`DeformReport`] and the run's provenance.

use crate::app::run::provenance::Provenance;
use crate::mesh::repair::RepairReport;
use crate::param::DeformReport;
use serde::{Deserialize, Serialize};

/// `OUT.report.json`: `mesh`, `targets_file`, `init`, `fixed_file`
/// (`null` when not given), `output`, `repair`, then
/// every key of the library's [`DeformReport`] (flattened), then
/// `provenance`. The command line and Python write this one type (Python's
/// `output` is empty, its provenance has no command line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DeformRunReport {
    /// REST, the input mesh.
    pub mesh: String,
    /// The targets file (`null`: none).
    pub targets_file: Option<String>,
    /// INIT, the start (`null`: REST's shape).
    pub init: Option<String>,
    /// HANDLES, the fixed vertices (`null`: none listed).
    pub fixed_file: Option<String>,
    /// The output mesh.
    pub output: String,
    /// What the repair of the input mesh changed (`null`: not repaired,
    /// because INIT's vertex numbers must match REST's or REST is a
    /// triangle mesh).
    pub repair: Option<RepairReport>,
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
