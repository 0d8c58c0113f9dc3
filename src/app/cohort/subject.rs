//! One subject of a batch: its own `unfold` process into a directory, how
//! it ended, the run hash its outputs record, and outputs run elsewhere put
//! in place.

use super::reports::{REPORT, read_any_report};
use crate::app::error::{AppError, at};
use crate::app::mitral::series::SERIES_JSON;
use crate::app::mitral::series::table::SeriesReport;
use crate::app::run::files::ensure_dir;
use crate::app::run::printable::printable;
use crate::app::run::provenance;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One subject to run: a manifest row.
#[derive(Debug, Clone)]
pub struct Subject {
    /// Its id (its outputs in `OUT/<id>/`).
    pub id: String,
    /// Its organ (`placenta`, `ventricle`, `mitral`).
    pub organ: String,
    /// The arguments after the program name, without `-o`; file paths
    /// resolved against the manifest's directory.
    pub args: Vec<String>,
    /// Covariate columns and their values.
    pub covariates: BTreeMap<String, String>,
}

impl Subject {
    /// The run hash of its command line and the contents of its inputs as
    /// they are now ([`provenance`]).
    pub fn run_hash(&self) -> String {
        provenance::run_hash(&self.args).0
    }

    /// Whether `dir` (its output directory) holds a run with this run hash:
    /// the batch skips it.
    pub fn is_done(&self, dir: &Path) -> bool {
        recorded_hash(dir).as_deref() == Some(self.run_hash().as_str())
    }
}

/// A subject as the batch ran it.
#[derive(Debug, Clone, PartialEq)]
pub struct SubjectRow {
    /// Its id (`OUT/<id>/`).
    pub id: String,
    /// Its organ.
    pub organ: String,
    /// Covariate values by column.
    pub covariates: BTreeMap<String, String>,
}

/// Whether a subject id is safe as a directory name of `OUT` (not `logs`
/// or `cohort`, which hold the logs and the cohort statistics).
pub fn valid_id(id: &str) -> bool {
    !id.is_empty()
        && id != "logs"
        && id != "cohort"
        && !id.starts_with('.')
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
}

/// How one subject ended.
#[derive(Debug, Clone, Serialize)]
pub struct Ended {
    /// The subject's id.
    pub id: String,
    /// Its organ.
    pub organ: String,
    /// `done`, `not converged` (outputs written), `skipped` or `failed`
    /// (one of [`STATUSES`]).
    pub status: &'static str,
    /// The exit code (none for a skip or a signal).
    pub exit_code: Option<i32>,
    /// The one-line error of a failure.
    pub message: String,
    /// Its wall-clock time, seconds.
    pub seconds: f64,
}

/// The statuses an [`Ended`] may have.
pub const STATUSES: [&str; 4] = ["done", "not converged", "skipped", "failed"];

impl Ended {
    /// A subject skipped because its outputs are done with the same run hash.
    pub fn skipped(s: &Subject) -> Self {
        Ended {
            id: s.id.clone(),
            organ: s.organ.clone(),
            status: "skipped",
            exit_code: None,
            message: String::new(),
            seconds: 0.0,
        }
    }
}

/// How a subject's command starts: the program and the arguments before
/// the subject's own (the `unfold` binary itself, or a Python interpreter
/// with `-m unfold`).
#[derive(Debug, Clone)]
pub struct Program {
    /// The executable.
    pub exe: PathBuf,
    /// Arguments before the subject's.
    pub prefix: Vec<String>,
}

impl Program {
    /// This process's executable, no prefix (`unfold batch` runs itself).
    ///
    /// # Errors
    /// The system does not tell the executable.
    pub fn this_exe() -> Result<Self, AppError> {
        let exe = std::env::current_exe()
            .map_err(|e| AppError::Usage(format!("cannot find the unfold binary: {e}")))?;
        Ok(Program {
            exe,
            prefix: Vec::new(),
        })
    }
}

/// The run hash recorded in `dir/report.json`, or for a mitral series
/// (no report of its own) in `dir/series.json`, if any. A file that does
/// not read as this unfold's report of an organ (or series table) records
/// none: the subject is not done, and runs again.
pub fn recorded_hash(dir: &Path) -> Option<String> {
    let report = || read_any_report(&dir.join(REPORT)).map(|r| r.provenance().run_hash.clone());
    let series = || {
        let text = std::fs::read_to_string(dir.join(SERIES_JSON)).ok()?;
        let series: SeriesReport = serde_json::from_str(&text).ok()?;
        Some(series.provenance.run_hash)
    };
    report().or_else(series)
}

/// Runs one subject as its own process of `program` into `dir`, its
/// stdout and stderr to the file `log` (whatever `dir` holds is replaced
/// only when the run writes its outputs; no skip check: see
/// [`Subject::is_done`]).
pub fn run_subject(
    s: &Subject,
    program: &Program,
    dir: &Path,
    log: &Path,
    max_memory: Option<u64>,
) -> Ended {
    let t = Instant::now();
    let ended = |status, exit_code, message: String| Ended {
        id: s.id.clone(),
        organ: s.organ.clone(),
        status,
        exit_code,
        message,
        seconds: t.elapsed().as_secs_f64(),
    };
    let mut cmd = std::process::Command::new(&program.exe);
    cmd.args(&program.prefix).args(&s.args).arg("-o").arg(dir);
    if let Some(m) = max_memory {
        cmd.arg("--max-memory").arg(m.to_string());
    }
    let output = match cmd.stdin(std::process::Stdio::null()).output() {
        Ok(o) => o,
        Err(e) => return ended("failed", None, format!("cannot start unfold: {e}")),
    };
    let mut text = output.stdout.clone();
    text.extend_from_slice(&output.stderr);
    // the log is a convenience: a failure to write it does not fail the subject
    let _ = crate::io::atomic_write(log, &text);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let last = stderr
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .trim_start_matches("unfold: error: ")
        .to_string();
    match output.status.code() {
        Some(0) => ended("done", Some(0), String::new()),
        // outputs written, solver stopped early: kept, and the cohort
        // table's `converged` column says so
        Some(3) => ended("not converged", Some(3), last),
        Some(c) => ended("failed", Some(c), last),
        None => ended(
            "failed",
            None,
            format!("killed by a signal ({:?}); {last}", output.status),
        ),
    }
}

/// Puts a subject's outputs, run elsewhere, in place as `OUT/<id>/`:
/// `files` (paths relative to the subject's output directory,
/// `/`-separated, the hidden manifest of the set left out) replace the
/// directory whole, as a run's outputs do ([`crate::app::run::StagedOutputs`]);
/// `log` (the run's stdout and stderr) goes to `OUT/logs/<id>.log`.
///
/// # Errors
/// An id that is not a directory name, a path that leaves the directory,
/// `OUT/<id>` holding files that are not a previous unfold output, writing.
pub fn place_subject(
    out: &Path,
    id: &str,
    files: &[(String, Vec<u8>)],
    log: Option<&[u8]>,
) -> Result<(), AppError> {
    if !valid_id(id) {
        return Err(at(out, format!("'{}' is not a subject id", printable(id))));
    }
    let dir = out.join(id);
    if !files.is_empty() {
        let mut staged = crate::app::run::StagedOutputs::new(std::iter::empty::<&Path>());
        let staging = staged.dir(&dir)?;
        for (rel, bytes) in files {
            let inside = !rel.is_empty()
                && rel != crate::app::run::MANIFEST
                && Path::new(rel)
                    .components()
                    .all(|c| matches!(c, std::path::Component::Normal(_)));
            if !inside {
                return Err(at(
                    &dir,
                    format!(
                        "the output '{}' is not a relative path inside the subject's \
                         directory; pass the files as the run wrote them",
                        printable(rel)
                    ),
                ));
            }
            let path = staging.join(rel);
            if let Some(parent) = path.parent() {
                ensure_dir(parent)?;
            }
            crate::io::atomic_write(&path, bytes).map_err(|e| staged.shown_error(e))?;
        }
        staged.commit()?;
    }
    if let Some(log) = log {
        ensure_dir(&out.join("logs"))?;
        crate::io::atomic_write(out.join("logs").join(format!("{id}.log")), log)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_directory_names() {
        for ok in ["s01", "a.b_c-d", "P7"] {
            assert!(valid_id(ok), "{ok}");
        }
        for bad in [
            "", ".", "..", ".hidden", "a/b", "a b", "x\u{1b}", "logs", "cohort",
        ] {
            assert!(!valid_id(bad), "{bad:?}");
        }
    }

    #[test]
    fn placed_outputs_replace_the_subject_directory_whole() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path();
        let f = |p: &str, b: &str| (p.to_string(), b.as_bytes().to_vec());
        place_subject(
            out,
            "s1",
            &[f("report.json", "{}"), f("a/b.txt", "x")],
            Some(b"log"),
        )
        .unwrap();
        assert_eq!(std::fs::read(out.join("s1/a/b.txt")).unwrap(), b"x");
        assert_eq!(std::fs::read(out.join("logs/s1.log")).unwrap(), b"log");
        assert!(out.join("s1").join(crate::app::run::MANIFEST).is_file());
        // a second set replaces the first: no file of the first is left
        place_subject(out, "s1", &[f("report.json", "{\"x\":1}")], None).unwrap();
        assert!(!out.join("s1/a/b.txt").exists());
        assert_eq!(
            std::fs::read_to_string(out.join("s1/report.json")).unwrap(),
            "{\"x\":1}"
        );
        // no files: the directory is left as it is (a failed subject)
        place_subject(out, "s1", &[], Some(b"failed")).unwrap();
        assert!(out.join("s1/report.json").is_file());
        for bad in [
            "../escape",
            "/abs",
            "",
            "a/../../b",
            crate::app::run::MANIFEST,
        ] {
            let e = place_subject(out, "s2", &[f(bad, "x")], None).unwrap_err();
            assert!(e.to_string().contains("not a relative path"), "{bad}: {e}");
        }
        assert!(!d.path().parent().unwrap().join("escape").exists());
        assert!(!out.join("s2").exists());
        let e = place_subject(out, "../s", &[f("a", "x")], None).unwrap_err();
        assert!(e.to_string().contains("not a subject id"), "{e}");
        // somebody's file in the directory: refused, kept
        std::fs::write(out.join("s1/notes.txt"), "mine").unwrap();
        assert!(place_subject(out, "s1", &[f("report.json", "{}")], None).is_err());
        assert!(out.join("s1/notes.txt").is_file());
    }
}
