//! `unfold batch MANIFEST.csv -o OUT [--jobs N]`: many subjects, one
//! command each (issue 19).
//!
//! The manifest is CSV with a header and one row per subject:
//!
//! - `id`: the subject, its outputs in `OUT/<id>/` (letters, digits, `.`,
//!   `_`, `-`; unique);
//! - `organ`: `placenta`, `ventricle` or `mitral`;
//! - `input`: the command's positional input (the placenta's mesh, the
//!   ventricle's anatomy);
//! - any long option of that command, without the dashes (`seg`, `image`,
//!   `template`, `surface`, `anterior`, `grid-mm`, ...): an empty cell is
//!   the default; a switch (`no-figures`) is on for `true`, `yes` or `1`;
//!   an option given several times (`image`) takes `;`-separated values;
//!   file paths are relative to the manifest's directory;
//! - every other column is a covariate, carried into the cohort table.
//!
//! Each subject runs as its own `unfold` process (an error, a refusal or a
//! crash stays with its subject), `--jobs` at a time, each with its share
//! of the memory limit. Its command line is the row's, so `OUT/<id>/` is
//! exactly what the single-subject command writes; its output (stdout and
//! stderr) goes to `OUT/logs/<id>.log`. A failing subject does not stop
//! the others: its one-line error goes to `OUT/failures.csv` and the batch
//! exits 1 at the end. A subject whose solver did not converge (exit code
//! 3: its outputs are written) is kept and counted apart; the cohort
//! table's `converged` column marks it. A subject whose `OUT/<id>/report.json` carries the
//! run hash of the same command line and input contents
//! ([`super::provenance`]) is skipped; a mitral series, which has no
//! report of its own, records its run hash in `OUT/<id>/series.json`.
//! Progress: a bar on a terminal, a line per subject otherwise (cluster
//! job logs).
//!
//! The steps are public for the Python package's Dask cohorts, which run
//! them elsewhere: [`plan`] (the manifest read and checked),
//! [`Subject::run_hash`] and [`Subject::is_done`] (the skip decision),
//! [`run_subject`] (one subject's process into a given directory) and
//! [`finish`] (`failures.csv` and the cohort tables); `unfold batch` is a
//! loop over them.

use super::{AppError, at};
use clap::{Args, CommandFactory};
use serde::Serialize;
use std::collections::{BTreeMap, HashSet};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// `unfold batch`.
#[derive(Debug, Args)]
pub struct BatchArgs {
    /// The manifest: CSV with a header, one row per subject (columns `id`, `organ`, `input`,
    /// the command's long options without dashes, covariates).
    manifest: PathBuf,
    /// Output directory: `OUT/<id>/` per subject, `OUT/failures.csv`, `OUT/cohort.csv`,
    /// `OUT/logs/`.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Subjects run at a time [default: the number of CPUs].
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
}

/// The organs a manifest row may name.
const ORGANS: [&str; 3] = ["placenta", "ventricle", "mitral"];

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
    /// they are now ([`super::provenance`]).
    pub fn run_hash(&self) -> String {
        crate::app::run::provenance::run_hash(&self.args).0
    }

    /// Whether `dir` (its output directory) holds a run with this run hash:
    /// the batch skips it.
    pub fn is_done(&self, dir: &Path) -> bool {
        recorded_hash(dir).as_deref() == Some(self.run_hash().as_str())
    }
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

/// How the options of `organ`'s command take their values.
struct OptionKinds {
    /// Long names of options taking a value (true: a file path).
    valued: BTreeMap<String, bool>,
    /// Long names of switches.
    switches: HashSet<String>,
    /// Long names that may repeat.
    repeated: HashSet<String>,
    /// Whether the positional input is a path.
    input: Option<bool>,
}

fn option_kinds(organ: &str) -> Option<OptionKinds> {
    let cli = super::Cli::command();
    let cmd = cli.find_subcommand(organ)?;
    let mut k = OptionKinds {
        valued: BTreeMap::new(),
        switches: HashSet::new(),
        repeated: HashSet::new(),
        input: None,
    };
    for a in cmd.get_arguments() {
        let is_path = a.get_value_parser().type_id() == std::any::TypeId::of::<PathBuf>();
        if a.is_positional() {
            k.input = Some(is_path);
            continue;
        }
        let Some(long) = a.get_long() else { continue };
        if matches!(long, "output" | "help" | "max-memory") {
            continue;
        }
        match a.get_action() {
            clap::ArgAction::SetTrue => {
                k.switches.insert(long.to_string());
            }
            clap::ArgAction::Append => {
                k.repeated.insert(long.to_string());
                k.valued.insert(long.to_string(), is_path);
            }
            clap::ArgAction::Set => {
                k.valued.insert(long.to_string(), is_path);
            }
            _ => {}
        }
    }
    Some(k)
}

/// Every long option of any organ's command (a column named so is not a
/// covariate).
fn all_option_names() -> HashSet<String> {
    let mut names = HashSet::new();
    for organ in ORGANS {
        if let Some(k) = option_kinds(organ) {
            names.extend(k.valued.into_keys());
            names.extend(k.switches);
        }
    }
    names.insert("input".into());
    names
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

/// Whether a subject id is safe as a directory name of `OUT` (not `logs`
/// or `cohort`, which hold the logs and the cohort statistics).
pub(crate) fn valid_id(id: &str) -> bool {
    !id.is_empty()
        && id != "logs"
        && id != "cohort"
        && !id.starts_with('.')
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
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
/// runs (the module documentation says what a row holds).
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
                    super::printable(&id)
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
        let kinds = option_kinds(&organ)
            .filter(|_| ORGANS.contains(&organ.as_str()))
            .ok_or_else(|| {
                row_error(
                    manifest,
                    row,
                    format!(
                        "organ '{}' is not one of {}",
                        super::printable(&organ),
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
/// (no report of its own) in `dir/series.json`, if any.
pub fn recorded_hash(dir: &Path) -> Option<String> {
    ["report.json", "series.json"].iter().find_map(|f| {
        let text = std::fs::read_to_string(dir.join(f)).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        v["provenance"]["run_hash"].as_str().map(str::to_string)
    })
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
        return Err(at(
            out,
            format!("'{}' is not a subject id", super::printable(id)),
        ));
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
                        super::printable(rel)
                    ),
                ));
            }
            let path = staging.join(rel);
            if let Some(parent) = path.parent() {
                super::ensure_dir(parent)?;
            }
            crate::io::atomic_write(&path, bytes).map_err(|e| staged.shown_error(e))?;
        }
        staged.commit()?;
    }
    if let Some(log) = log {
        super::ensure_dir(&out.join("logs"))?;
        crate::io::atomic_write(out.join("logs").join(format!("{id}.log")), log)?;
    }
    Ok(())
}

/// The counts of a batch's ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Subjects in the manifest.
    pub total: usize,
    /// Run and converged.
    pub ran: usize,
    /// Run, outputs written, the solver stopped early.
    pub not_converged: usize,
    /// Skipped: done before with the same run hash.
    pub skipped: usize,
    /// Failed (in `failures.csv`).
    pub failed: usize,
}

/// Ends a batch whose subjects ended as `ended` (any order): writes
/// `OUT/failures.csv` (in the manifest's order) and the cohort tables of
/// [`super::cohort`], and counts the ends.
///
/// # Errors
/// An id of `ended` not in the plan or twice; writing a file.
pub fn finish(out: &Path, plan: &Plan, ended: &[Ended]) -> Result<Counts, AppError> {
    let order: BTreeMap<&str, usize> = plan
        .subjects
        .iter()
        .enumerate()
        .map(|(i, s)| (s.id.as_str(), i))
        .collect();
    let mut seen = HashSet::new();
    for e in ended {
        if !order.contains_key(e.id.as_str()) || !seen.insert(e.id.as_str()) {
            return Err(AppError::Usage(format!(
                "subject '{}' ended twice or is not in the manifest; pass each planned subject \
                 once",
                super::printable(&e.id)
            )));
        }
    }
    let mut ended = ended.to_vec();
    ended.sort_by_key(|e| order.get(e.id.as_str()).copied().unwrap_or(usize::MAX));
    write_failures(out, &ended)?;
    super::cohort::write_cohort(out, &subjects_table(&plan.subjects), &plan.covariates)?;
    let count = |s: &str| ended.iter().filter(|e| e.status == s).count();
    Ok(Counts {
        total: plan.subjects.len(),
        ran: count("done"),
        not_converged: count("not converged"),
        skipped: count("skipped"),
        failed: count("failed"),
    })
}

/// Checks `out` can be a batch's output directory and creates it with its
/// `logs/`.
///
/// # Errors
/// `out` is a file, or cannot be created.
pub fn prepare_output(out: &Path) -> Result<(), AppError> {
    if out.is_file() {
        return Err(at(out, "is a file; -o names a directory"));
    }
    super::ensure_dir(&out.join("logs"))
}

/// Writes `OUT/failures.csv`: one row per failed subject (header only when
/// none failed).
fn write_failures(out: &Path, ended: &[Ended]) -> Result<(), AppError> {
    let path = out.join("failures.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    let err = |e: csv::Error| at(&path, e);
    w.write_record(["id", "organ", "exit_code", "message"])
        .map_err(err)?;
    for e in ended.iter().filter(|e| e.status == "failed") {
        let code = e.exit_code.map(|c| c.to_string()).unwrap_or_default();
        w.write_record([
            e.id.as_str(),
            e.organ.as_str(),
            &code,
            &super::printable(&e.message),
        ])
        .map_err(err)?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    Ok(crate::io::atomic_write(&path, &bytes)?)
}

/// Runs `unfold batch`.
pub fn run(a: &BatchArgs) -> Result<(), AppError> {
    run_manifest(&a.manifest, &a.output, a.jobs)
}

/// Runs the subjects of `manifest` into `out`, `jobs` at a time (see the
/// module documentation).
///
/// # Errors
/// A bad manifest (before anything runs); writing the tables; a failed
/// subject (after all have run).
pub(crate) fn run_manifest(
    manifest: &Path,
    out: &Path,
    jobs: Option<usize>,
) -> Result<(), AppError> {
    let plan = plan(manifest)?;
    let subjects = &plan.subjects;
    let jobs = match jobs {
        Some(0) => return Err(AppError::Usage("--jobs must be at least 1".into())),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    }
    .min(subjects.len());
    prepare_output(out)?;
    let program = Program::this_exe()?;
    let max_memory = crate::app::run::memory::budget()
        .limit_bytes
        .map(|l| (l / jobs as f64) as u64);
    let total = subjects.len();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let results: Mutex<Vec<Ended>> = Mutex::new(Vec::with_capacity(total));
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(total as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("batch [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(s) = subjects.get(i) else { break };
                    let e = if s.is_done(&out.join(&s.id)) {
                        Ended::skipped(s)
                    } else {
                        let log = out.join("logs").join(format!("{}.log", s.id));
                        run_subject(s, &program, &out.join(&s.id), &log, max_memory)
                    };
                    let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                    let line = format!(
                        "[{k}/{total}] {} ({}): {} in {:.1} s{}",
                        s.id,
                        s.organ,
                        e.status,
                        e.seconds,
                        if e.message.is_empty() {
                            String::new()
                        } else {
                            format!(": {}", super::printable(&e.message))
                        }
                    );
                    match &bar {
                        Some(b) => {
                            b.inc(1);
                            b.set_message(format!("{} {}", s.id, e.status));
                        }
                        None => println!("batch {line}"),
                    }
                    if let Ok(mut r) = results.lock() {
                        r.push(e);
                    }
                }
            });
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let ended = results.into_inner().unwrap_or_default();
    let Counts {
        total,
        ran,
        not_converged: unconverged,
        skipped,
        failed,
    } = finish(out, &plan, &ended)?;
    println!(
        "batch: {total} subjects, {ran} run, {unconverged} not converged (outputs written), \
         {skipped} skipped (done before with the same inputs), {failed} failed; wrote {}",
        out.display()
    );
    if failed > 0 {
        let first = subjects
            .iter()
            .find(|s| ended.iter().any(|e| e.id == s.id && e.status == "failed"))
            .map_or("", |s| s.id.as_str());
        return Err(AppError::Usage(format!(
            "{failed} of {total} subjects failed (first: {first}); see {}",
            out.join("failures.csv").display()
        )));
    }
    Ok(())
}

/// The subjects as the cohort table wants them: id, organ, covariates.
fn subjects_table(subjects: &[Subject]) -> Vec<super::cohort::SubjectRow> {
    subjects
        .iter()
        .map(|s| super::cohort::SubjectRow {
            id: s.id.clone(),
            organ: s.organ.clone(),
            covariates: s.covariates.clone(),
        })
        .collect()
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

    #[test]
    fn finish_refuses_unplanned_or_repeated_ids() {
        let d = tempfile::tempdir().unwrap();
        let m = d.path().join("m.csv");
        std::fs::write(&m, "id,organ,input\na,placenta,x.vtu\n").unwrap();
        let plan = plan(&m).unwrap();
        let a = Ended::skipped(&plan.subjects[0]);
        let mut b = a.clone();
        b.id = "b".into();
        for ended in [vec![a.clone(), a.clone()], vec![b]] {
            let e = finish(d.path(), &plan, &ended).unwrap_err();
            assert!(e.to_string().contains("not in the manifest"), "{e}");
        }
        let counts = finish(d.path(), &plan, &[a]).unwrap();
        assert_eq!((counts.total, counts.skipped, counts.failed), (1, 1, 0));
        assert!(d.path().join("failures.csv").is_file());
    }

    #[test]
    fn the_organs_options_are_known_from_their_commands() {
        let p = option_kinds("placenta").unwrap();
        assert_eq!(p.input, Some(true));
        assert_eq!(p.valued.get("seg"), Some(&true));
        assert_eq!(p.valued.get("template"), Some(&false));
        assert!(p.repeated.contains("image"));
        assert!(p.switches.contains("no-figures"));
        assert!(!p.valued.contains_key("output"));
        let m = option_kinds("mitral").unwrap();
        assert_eq!(m.input, None);
        assert_eq!(m.valued.get("annulus"), Some(&true));
        assert!(all_option_names().contains("surface"));
    }
}
