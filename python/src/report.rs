//! The section of a Python run's report that differs from the command
//! line's: `provenance` (no command line, no input files), with the command
//! line's keys (the memory section is
//! `unfold::app::run::memory::MemoryReport::predicted`).

use serde::Serialize;

/// `provenance` in a Python report: the command line's keys where they
/// apply (no command line, no input files).
#[derive(Serialize)]
pub(crate) struct Provenance {
    pub unfold_version: &'static str,
    pub interface: &'static str,
    pub command_line: Vec<String>,
    pub parameters: String,
    pub inputs: Vec<String>,
    pub run_hash: String,
    pub started: String,
}

impl Provenance {
    /// A Python run's provenance: `parameters` (the call's settings) and
    /// when it `started` ([`started`]).
    pub fn new(parameters: String, started: String) -> Self {
        Provenance {
            unfold_version: env!("CARGO_PKG_VERSION"),
            interface: "python",
            command_line: Vec::new(),
            parameters,
            inputs: Vec::new(),
            run_hash: String::new(),
            started,
        }
    }
}

/// Now, as `provenance.started` says it (RFC 3339 to the second, UTC, as
/// the command line's): taken as a call begins.
pub(crate) fn started() -> String {
    humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string()
}

/// `report` as indented JSON (the layout of `report.json`).
pub(crate) fn json(report: &impl Serialize) -> pyo3::PyResult<String> {
    serde_json::to_string_pretty(report).map_err(crate::error)
}
