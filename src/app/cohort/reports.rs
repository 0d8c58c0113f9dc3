//! A subject's `report.json` read back as its organ's report type: the one
//! way the cohort reads a report. A renamed, missing or retyped
//! field is an error naming the file and the field, not a silently empty
//! cell: serde reads the typed report (the report structs deny unknown
//! fields), and a key of the file that the type does not have (a renamed
//! optional field in a flattened section, which serde alone would skip)
//! is refused too.

use crate::app::error::AppError;
use crate::app::mitral::MitralReport;
use crate::app::placenta::PlacentaReport;
use crate::app::run::provenance::Provenance;
use crate::app::ventricle::VentricleReport;
use serde::Serialize;
use std::path::Path;

/// The file a subject's run writes its report to (`OUT/<id>/report.json`).
pub const REPORT: &str = "report.json";

/// A subject's report, typed by its organ.
#[derive(Debug, Clone)]
pub enum SubjectReport {
    /// `unfold placenta`'s.
    Placenta(Box<PlacentaReport>),
    /// `unfold ventricle`'s.
    Ventricle(Box<VentricleReport>),
    /// `unfold mitral`'s (one valve, or one step of a series).
    Mitral(Box<MitralReport>),
}

/// How a placenta's solver ended (the report page's convergence line).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Convergence {
    /// Whether the last stage converged.
    pub converged: bool,
    /// Iterations, all stages.
    pub iterations: usize,
    /// Why the last stage stopped (its name in the report, e.g.
    /// `gradient_tolerance`).
    pub stop_reason: String,
}

impl SubjectReport {
    /// Where the run comes from.
    pub fn provenance(&self) -> &Provenance {
        match self {
            SubjectReport::Placenta(r) => &r.provenance,
            SubjectReport::Ventricle(r) => &r.provenance,
            SubjectReport::Mitral(r) => &r.provenance,
        }
    }

    /// The report as the JSON value it was read from (the same keys and
    /// numbers: the cohort table's scalars are taken from it).
    ///
    /// # Errors
    /// `serde_json`'s (in practice none).
    pub fn to_value(&self) -> Result<serde_json::Value, serde_json::Error> {
        match self {
            SubjectReport::Placenta(r) => serde_json::to_value(r),
            SubjectReport::Ventricle(r) => serde_json::to_value(r),
            SubjectReport::Mitral(r) => serde_json::to_value(r),
        }
    }

    /// The solver's end, for the organs whose report has one (the
    /// placenta's).
    pub fn convergence(&self) -> Option<Convergence> {
        match self {
            SubjectReport::Placenta(r) => Some(Convergence {
                converged: r.report.converged,
                iterations: r.report.iterations,
                stop_reason: serde_json::to_value(r.report.stop_reason)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_else(|| format!("{:?}", r.report.stop_reason)),
            }),
            SubjectReport::Ventricle(_) | SubjectReport::Mitral(_) => None,
        }
    }
}

/// Reads the report at `path` as `organ`'s report type (`placenta`,
/// `ventricle` or `mitral`; a mitral series step's `report.json` is a
/// valve's).
///
/// # Errors
/// [`AppError::Report`] naming the file when it cannot be read, is not
/// `organ`'s report of this unfold (serde's message names the field, line
/// and column), has a key that report does not have, or `organ` is none of
/// the three.
pub fn read_report(path: &Path, organ: &str) -> Result<SubjectReport, AppError> {
    let fail = |message: String| AppError::Report {
        path: path.display().to_string(),
        organ: organ.to_string(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
    let report = match organ {
        "placenta" => SubjectReport::Placenta(typed(&text).map_err(fail)?),
        "ventricle" => SubjectReport::Ventricle(typed(&text).map_err(fail)?),
        "mitral" => SubjectReport::Mitral(typed(&text).map_err(fail)?),
        other => {
            return Err(fail(format!(
                "'{}' is not an organ with a report (placenta, ventricle, mitral)",
                crate::app::run::printable::printable(other)
            )));
        }
    };
    Ok(report)
}

/// The report at `path` as whichever organ's report it reads as (none
/// when it cannot be read or reads as none: the batch's skip check, which
/// knows no organ).
pub fn read_any_report(path: &Path) -> Option<SubjectReport> {
    ["placenta", "ventricle", "mitral"]
        .iter()
        .find_map(|organ| read_report(path, organ).ok())
}

/// The report of the subject whose outputs are in `dir` (its
/// [`REPORT`]), none when there is no such file (a failed subject, a
/// mitral series).
///
/// # Errors
/// As [`read_report`], for a file that exists.
pub fn subject_report(dir: &Path, organ: &str) -> Result<Option<SubjectReport>, AppError> {
    let path = dir.join(REPORT);
    if path.is_file() {
        read_report(&path, organ).map(Some)
    } else {
        Ok(None)
    }
}

/// `text` as `T`, refusing a key `T` does not have (module doc).
fn typed<T: serde::de::DeserializeOwned + Serialize>(text: &str) -> Result<Box<T>, String> {
    let report: T = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let read: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let typed = serde_json::to_value(&report).map_err(|e| e.to_string())?;
    if let Some(key) = unknown_key(&read, &typed, "") {
        let name = key.rsplit('.').next().unwrap_or(&key);
        return Err(format!(
            "unknown field `{name}` (at `{key}`){}",
            position(text, name)
        ));
    }
    Ok(Box::new(report))
}

/// The first key (dotted path) of `read` that `typed` does not have, in
/// objects at the same place.
fn unknown_key(read: &serde_json::Value, typed: &serde_json::Value, at: &str) -> Option<String> {
    use serde_json::Value;
    let join = |k: &str| {
        if at.is_empty() {
            k.to_string()
        } else {
            format!("{at}.{k}")
        }
    };
    match (read, typed) {
        (Value::Object(r), Value::Object(t)) => r.iter().find_map(|(k, v)| match t.get(k) {
            None => Some(join(k)),
            Some(tv) => unknown_key(v, tv, &join(k)),
        }),
        (Value::Array(r), Value::Array(t)) => r
            .iter()
            .zip(t)
            .enumerate()
            .find_map(|(i, (v, tv))| unknown_key(v, tv, &join(&i.to_string()))),
        _ => None,
    }
}

/// ` at line L column C` of the first `"name":` in `text` (empty when not
/// found), as serde says where a field is.
fn position(text: &str, name: &str) -> String {
    let Some(offset) = text.find(&format!("\"{name}\":")) else {
        return String::new();
    };
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    format!(" at line {line} column {column}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_key_the_type_lacks_is_found_with_its_path() {
        let typed = json!({"a": 1, "b": {"c": [ {"d": 1} ]}});
        assert_eq!(unknown_key(&typed, &typed, ""), None);
        let read = json!({"a": 1, "b": {"c": [ {"d": 1, "e": 2} ]}});
        assert_eq!(unknown_key(&read, &typed, "").as_deref(), Some("b.c.0.e"));
        let read = json!({"a2": 1, "b": {"c": []}});
        assert_eq!(unknown_key(&read, &typed, "").as_deref(), Some("a2"));
    }

    #[test]
    fn a_position_is_a_line_and_column() {
        let text = "{\n  \"a\": 1,\n  \"bb\": 2\n}";
        assert_eq!(position(text, "bb"), " at line 3 column 3");
        assert_eq!(position(text, "zz"), "");
    }

    #[test]
    fn an_unknown_organ_or_a_missing_file_is_a_report_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REPORT);
        let e = read_report(&path, "placenta").unwrap_err().to_string();
        assert!(e.starts_with(&path.display().to_string()), "{e}");
        assert!(subject_report(dir.path(), "placenta").unwrap().is_none());
        std::fs::write(&path, "{}").unwrap();
        let e = read_report(&path, "liver").unwrap_err().to_string();
        assert!(e.contains("'liver' is not an organ"), "{e}");
        let e = read_report(&path, "mitral").unwrap_err().to_string();
        assert!(e.contains("missing field `inputs`"), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
