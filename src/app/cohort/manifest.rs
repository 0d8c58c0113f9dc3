//! A batch's manifest: CSV with a header and one row per subject.
//!
//! - `id`: the subject, its outputs in `OUT/<id>/` (letters, digits, `.`,
//!   `_`, `-`; unique);
//! - `organ`: `placenta`, `ventricle` or `mitral`;
//! - `input`: the command's positional input (the placenta's mesh, the
//!   ventricle's anatomy);
//! - any setting or file of that organ by its name, the flag's without the
//!   dashes (`seg`, `image`, `template`, `surface`, `anterior`, `grid-mm`,
//!   ...): an empty cell is the default; a switch (`no-figures`) is on for
//!   `true`, `yes` or `1`; a setting that takes several values (`image`)
//!   takes `;`-separated values; file paths are relative to the manifest's
//!   directory;
//! - every other column is a covariate, carried into the cohort table.
//!
//! Each row becomes the command line of the subject's own process.

use super::columns::organ_columns;
use super::subject::{Subject, valid_id};
use crate::app::error::{AppError, at};
use crate::app::run::printable::printable;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// The organs a manifest row may name.
pub const ORGANS: [&str; 3] = ["placenta", "ventricle", "mitral"];

/// Every column any organ takes (a column named so is not a covariate).
fn all_option_names() -> HashSet<String> {
    let mut names = HashSet::new();
    for organ in ORGANS {
        if let Some(k) = organ_columns(organ) {
            names.extend(k.valued.into_keys());
            names.extend(k.switches);
        }
    }
    names.insert("input".into());
    names
}

/// A checked manifest: the subjects in row order and the covariate
/// columns.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The subjects, in the manifest's order.
    pub subjects: Vec<Subject>,
    /// The covariate columns, in the manifest's order.
    pub covariates: Vec<String>,
}

/// A manifest cell's problem, for one row.
fn row_error(manifest: &Path, row: usize, msg: impl std::fmt::Display) -> AppError {
    at(manifest, format!("row {row}: {msg}"))
}

/// `value` as a path relative to `base` (absolute paths kept).
fn resolve(base: &Path, value: &str) -> String {
    let p = Path::new(value);
    if p.is_absolute() {
        value.to_string()
    } else {
        base.join(p).display().to_string()
    }
}

/// Why a header lacks the column `needed`, when a spreadsheet's export
/// explains it: columns separated by semicolons or tabs (the manifest's are
/// commas; `;` separates an option's repeated values inside a cell), or
/// the name in other letter cases. Empty otherwise.
fn header_hint(header: &[String], needed: &str) -> String {
    if let [only] = header {
        for (sep, name) in [(';', "semicolons"), ('\t', "tabs")] {
            if only.contains(sep) {
                return format!(
                    ": its columns are separated by {name}, and a manifest's by commas"
                );
            }
        }
    }
    match header.iter().find(|h| h.eq_ignore_ascii_case(needed)) {
        Some(h) => format!(": column names are lower case ('{needed}', not '{h}')"),
        None => String::new(),
    }
}

/// Reads the manifest into subjects, every row checked before anything
/// runs (the module documentation says what a row holds; each organ takes
/// its columns as [`organ_columns`] says).
///
/// # Errors
/// The manifest cannot be read, or a row is unusable (the message names
/// the row and the cell).
pub fn plan(manifest: &Path) -> Result<Plan, AppError> {
    let base = match manifest.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(manifest)
        .map_err(|e| at(manifest, e))?;
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| at(manifest, e))?
        .iter()
        .map(str::to_string)
        .collect();
    for needed in ["id", "organ"] {
        if !header.iter().any(|h| h == needed) {
            return Err(at(
                manifest,
                format!(
                    "the header has no '{needed}' column (it has: {}){}",
                    header.join(", "),
                    header_hint(&header, needed)
                ),
            ));
        }
    }
    let mut seen = HashSet::new();
    for h in &header {
        if !seen.insert(h.as_str()) {
            return Err(at(manifest, format!("the column '{h}' appears twice")));
        }
    }
    let options = all_option_names();
    let covariate_names: Vec<String> = header
        .iter()
        .filter(|h| !matches!(h.as_str(), "id" | "organ") && !options.contains(*h))
        .cloned()
        .collect();
    let mut subjects = Vec::new();
    let mut ids = HashSet::new();
    for (k, record) in reader.records().enumerate() {
        let row = k + 2; // the header is line 1
        let record = record.map_err(|e| row_error(manifest, row, e))?;
        let cell = |name: &str| -> &str {
            header
                .iter()
                .position(|h| h == name)
                .and_then(|i| record.get(i))
                .unwrap_or("")
        };
        let id = cell("id").to_string();
        if !valid_id(&id) {
            return Err(row_error(
                manifest,
                row,
                format!(
                    "the id '{}' is not a usable directory name (letters, digits, '.', '_', \
                     '-'; not starting with '.'; not 'logs' or 'cohort')",
                    printable(&id)
                ),
            ));
        }
        if !ids.insert(id.clone()) {
            return Err(row_error(
                manifest,
                row,
                format!("the id '{id}' appears twice"),
            ));
        }
        let organ = cell("organ").to_string();
        let kinds = organ_columns(&organ)
            .filter(|_| ORGANS.contains(&organ.as_str()))
            .ok_or_else(|| {
                row_error(
                    manifest,
                    row,
                    format!(
                        "organ '{}' is not one of {}",
                        printable(&organ),
                        ORGANS.join(", ")
                    ),
                )
            })?;
        let mut args = vec![organ.clone()];
        let input = cell("input");
        match (kinds.input, input.is_empty()) {
            (Some(is_path), false) => args.push(if is_path {
                resolve(&base, input)
            } else {
                input.to_string()
            }),
            (None, false) => {
                return Err(row_error(
                    manifest,
                    row,
                    format!("{organ} takes no positional input; leave 'input' empty"),
                ));
            }
            _ => {}
        }
        let mut covariates = BTreeMap::new();
        for (i, name) in header.iter().enumerate() {
            let value = record.get(i).unwrap_or("");
            if matches!(name.as_str(), "id" | "organ" | "input") {
                continue;
            }
            if covariate_names.contains(name) {
                covariates.insert(name.clone(), value.to_string());
                continue;
            }
            if value.is_empty() {
                continue;
            }
            if kinds.switches.contains(name) {
                match value.to_ascii_lowercase().as_str() {
                    "true" | "yes" | "1" => args.push(format!("--{name}")),
                    "false" | "no" | "0" => {}
                    v => {
                        return Err(row_error(
                            manifest,
                            row,
                            format!("'{name}' is a switch: true or false, got '{v}'"),
                        ));
                    }
                }
            } else if let Some(&is_path) = kinds.valued.get(name) {
                let values: Vec<&str> = if kinds.repeated.contains(name) {
                    value
                        .split(';')
                        .map(str::trim)
                        .filter(|v| !v.is_empty())
                        .collect()
                } else {
                    vec![value]
                };
                // `--name=value`: a value may start with '-' (a coordinate)
                for v in values {
                    let v = if is_path {
                        resolve(&base, v)
                    } else {
                        v.to_string()
                    };
                    args.push(format!("--{name}={v}"));
                }
            } else {
                return Err(row_error(
                    manifest,
                    row,
                    format!("'{name}' is not an option of unfold {organ}; leave it empty"),
                ));
            }
        }
        subjects.push(Subject {
            id,
            organ,
            args,
            covariates,
        });
    }
    if subjects.is_empty() {
        return Err(at(manifest, "the manifest has no subject rows"));
    }
    Ok(Plan {
        subjects,
        covariates: covariate_names,
    })
}
