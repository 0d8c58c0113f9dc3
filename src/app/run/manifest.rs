//! The manifest a committed output directory carries (`.unfold-run.json`):
//! which program wrote the set and every file in it, so the next run
//! replaces only what an unfold run wrote.

use serde::{Deserialize, Serialize};

/// The manifest's file name in a committed output directory: the files the
/// run wrote, one relative path (`/`-separated) each.
pub const MANIFEST: &str = ".unfold-run.json";

/// The manifest of a committed output directory.
#[derive(Debug, Serialize, Deserialize)]
pub(crate) struct Manifest {
    /// The program and version that wrote it.
    pub written_by: String,
    /// Every file of the set, relative to the directory, `/`-separated,
    /// sorted (the manifest itself not included).
    pub files: Vec<String>,
}

/// The listed files of a manifest, or why it is not one.
pub(crate) fn parse_manifest(bytes: &[u8]) -> Result<Vec<String>, String> {
    let m: Manifest = serde_json::from_slice(bytes).map_err(|e| e.to_string())?;
    if !m.written_by.starts_with("unfold") {
        return Err(format!("written by {:?}", m.written_by));
    }
    Ok(m.files)
}
