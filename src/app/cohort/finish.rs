//! The end of a batch: `OUT/failures.csv`, the cohort tables, the counts.

use super::manifest::Plan;
use super::subject::Ended;
use super::subject::Subject;
use super::subject::SubjectRow;
use super::table::write_cohort;
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::files::ensure_dir;
use crate::app::run::printable::printable;
use std::collections::{BTreeMap, HashSet};
use std::path::Path;

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
/// [`super::table`], and counts the ends.
///
/// # Errors
/// An id of `ended` not in the plan or twice; writing a file.
pub fn finish(
    out: &Path,
    plan: &Plan,
    ended: &[Ended],
    observer: &mut dyn Observer,
) -> Result<Counts, AppError> {
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
                printable(&e.id)
            )));
        }
    }
    let mut ended = ended.to_vec();
    ended.sort_by_key(|e| order.get(e.id.as_str()).copied().unwrap_or(usize::MAX));
    write_failures(out, &ended)?;
    write_cohort(
        out,
        &subjects_table(&plan.subjects),
        &plan.covariates,
        observer,
    )?;
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
    ensure_dir(&out.join("logs"))
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
            &printable(&e.message),
        ])
        .map_err(err)?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    Ok(crate::io::atomic_write(&path, &bytes)?)
}

/// The subjects as the cohort table wants them: id, organ, covariates.
fn subjects_table(subjects: &[Subject]) -> Vec<SubjectRow> {
    subjects
        .iter()
        .map(|s| SubjectRow {
            id: s.id.clone(),
            organ: s.organ.clone(),
            covariates: s.covariates.clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::cohort::manifest::plan;
    use crate::app::observer::Quiet;

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
            let e = finish(d.path(), &plan, &ended, &mut Quiet).unwrap_err();
            assert!(e.to_string().contains("not in the manifest"), "{e}");
        }
        let counts = finish(d.path(), &plan, &[a], &mut Quiet).unwrap();
        assert_eq!((counts.total, counts.skipped, counts.failed), (1, 1, 0));
        assert!(d.path().join("failures.csv").is_file());
    }
}
