//! A batch: many subjects, one process each (`unfold batch MANIFEST.csv -o
//! OUT [--jobs N]`).
//!
//! The manifest's columns: [`super::manifest`].
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
//! ([`crate::app::run::provenance`]) is skipped; a mitral series, which has no
//! report of its own, records its run hash in `OUT/<id>/series.json`.
//! Progress: every subject's end is told to a [`BatchObserver`] (the
//! command line draws a bar on a terminal, a line per subject otherwise).
//!
//! The steps are public for the Python package's Dask cohorts, which run
//! them elsewhere: [`super::manifest::plan`] (the manifest read and checked),
//! [`Subject::run_hash`] and [`Subject::is_done`] (the skip decision),
//! [`run_subject`] (one subject's process into a given directory) and
//! [`finish`] (`failures.csv` and the cohort tables); `unfold batch` is a
//! loop over them.

use super::finish::{Counts, finish, prepare_output};
use super::manifest::{Plan, plan};
use super::subject::{Ended, Program, Subject, run_subject};
use crate::app::AppError;
use crate::app::observer::Observer;
use crate::app::run::memory;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Told how a batch goes: its start, every subject's end (from the worker
/// threads, one call at a time) and its end; the cohort's lines as any
/// run's ([`Observer`]).
pub trait BatchObserver: Observer + Send {
    /// The batch starts with `total` subjects.
    fn start(&mut self, _total: usize) {}
    /// The `k`-th subject to end (of `total`) ended as `ended`.
    fn ended(&mut self, _k: usize, _total: usize, _subject: &Subject, _ended: &Ended) {}
    /// Every subject has ended.
    fn finished(&mut self) {}
}

/// Runs the subjects of `manifest` into `out`, `jobs` at a time (see the
/// module documentation).
///
/// # Errors
/// A bad manifest (before anything runs); writing the tables; a failed
/// subject (after all have run).
pub fn run_manifest(
    manifest: &Path,
    out: &Path,
    jobs: Option<usize>,
    observer: &mut dyn BatchObserver,
) -> Result<(), AppError> {
    run_plan(&plan(manifest)?, out, jobs, observer)
}

/// Runs the subjects of `plan` (a manifest read and checked) into `out`,
/// as [`run_manifest`].
///
/// # Errors
/// As [`run_manifest`], after the manifest is read.
pub fn run_plan(
    plan: &Plan,
    out: &Path,
    jobs: Option<usize>,
    observer: &mut dyn BatchObserver,
) -> Result<(), AppError> {
    let subjects = &plan.subjects;
    let jobs = match jobs {
        Some(0) => return Err(AppError::Usage("--jobs must be at least 1".into())),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    }
    .min(subjects.len());
    prepare_output(out)?;
    let program = Program::this_exe()?;
    let max_memory = memory::budget()
        .limit_bytes
        .map(|l| (l / jobs as f64) as u64);
    let total = subjects.len();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let results: Mutex<Vec<Ended>> = Mutex::new(Vec::with_capacity(total));
    observer.start(total);
    let observer = Mutex::new(observer);
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
                    if let Ok(mut o) = observer.lock() {
                        o.ended(k, total, s, &e);
                    }
                    if let Ok(mut r) = results.lock() {
                        r.push(e);
                    }
                }
            });
        }
    });
    let observer = match observer.into_inner() {
        Ok(o) => o,
        Err(poisoned) => poisoned.into_inner(),
    };
    observer.finished();
    let ended = results.into_inner().unwrap_or_default();
    let Counts {
        total,
        ran,
        not_converged: unconverged,
        skipped,
        failed,
    } = finish(out, plan, &ended, &mut *observer)?;
    observer.info(&format!(
        "batch: {total} subjects, {ran} run, {unconverged} not converged (outputs written), \
         {skipped} skipped (done before with the same inputs), {failed} failed; wrote {}",
        out.display()
    ));
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
