//! `unfold batch` and `unfold cohort` in steps, for `unfold.dask`: the
//! application's cohort functions ([`unfold::app::cohort`]), converted. A subject runs as its own process
//! (`python -m unfold ...`, which is [`main`]), as in the command line's
//! batch, so an error or a crash stays with its subject and each report
//! records its own run.

use pyo3::prelude::*;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use unfold::app::cohort::{self as batch, Ended, PlotSpec, Program, Subject};
use unfold::app::observer::Plain;

/// The `unfold` program on `argv` (program name first): its exit code,
/// its output on this process's stdout and stderr (`python -m unfold`).
#[pyfunction]
pub(crate) fn main(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| unfold::program(argv.into_iter().map(OsString::from).collect()))
}

/// A checked batch manifest ([`batch::plan`]).
#[pyclass(frozen, module = "unfold._native")]
pub(crate) struct Plan {
    plan: batch::Plan,
}

#[pymethods]
impl Plan {
    /// The subjects in the manifest's order, each `(id, organ, args)`
    /// (`args`: the command line after the program name, without `-o`).
    fn subjects(&self) -> Vec<(String, String, Vec<String>)> {
        self.plan
            .subjects
            .iter()
            .map(|s| (s.id.clone(), s.organ.clone(), s.args.clone()))
            .collect()
    }

    /// The covariate columns.
    #[getter]
    fn covariates(&self) -> Vec<String> {
        self.plan.covariates.clone()
    }
}

/// Reads and checks a manifest (every row, before anything runs).
#[pyfunction]
pub(crate) fn plan(py: Python<'_>, manifest: PathBuf) -> PyResult<Plan> {
    let plan = py.detach(|| batch::plan(&manifest)).map_err(crate::error)?;
    Ok(Plan { plan })
}

/// Checks `out_dir` can hold a batch's outputs and creates it with
/// `logs/`.
#[pyfunction]
pub(crate) fn prepare_output(out_dir: PathBuf) -> PyResult<()> {
    batch::prepare_output(&out_dir).map_err(crate::error)
}

/// The run hash recorded in a subject's output directory, if any.
#[pyfunction]
pub(crate) fn recorded_hash(dir: PathBuf) -> Option<String> {
    batch::recorded_hash(&dir)
}

/// The run hash of a subject's arguments and its inputs' contents now.
#[pyfunction]
pub(crate) fn run_hash(py: Python<'_>, args: Vec<String>) -> String {
    py.detach(|| {
        Subject {
            id: String::new(),
            organ: String::new(),
            args,
            covariates: Default::default(),
        }
        .run_hash()
    })
}

/// Runs one subject as a process of `program` (`[executable, *prefix]`)
/// into `dir`, its output to `log`; returns `(status, exit_code, message,
/// seconds)`.
#[pyfunction]
#[pyo3(signature = (id, organ, args, dir, log, program, max_memory=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_subject(
    py: Python<'_>,
    id: String,
    organ: String,
    args: Vec<String>,
    dir: PathBuf,
    log: PathBuf,
    program: Vec<String>,
    max_memory: Option<u64>,
) -> PyResult<(&'static str, Option<i32>, String, f64)> {
    let Some((exe, prefix)) = program.split_first() else {
        return Err(crate::error(
            "program is empty; pass [executable, *arguments]",
        ));
    };
    let program = Program {
        exe: PathBuf::from(exe),
        prefix: prefix.to_vec(),
    };
    let subject = Subject {
        id,
        organ,
        args,
        covariates: Default::default(),
    };
    let e = py.detach(|| batch::run_subject(&subject, &program, &dir, &log, max_memory));
    Ok((e.status, e.exit_code, e.message, e.seconds))
}

/// Puts a subject's outputs, run elsewhere, in place as `out_dir/<id>/`
/// (`files`: relative path -> bytes) and its log as `out_dir/logs/<id>.log`.
#[pyfunction]
#[pyo3(signature = (out_dir, id, files, log=None))]
pub(crate) fn place_subject(
    py: Python<'_>,
    out_dir: PathBuf,
    id: String,
    files: Vec<(String, Vec<u8>)>,
    log: Option<Vec<u8>>,
) -> PyResult<()> {
    py.detach(|| batch::place_subject(&out_dir, &id, &files, log.as_deref()))
        .map_err(crate::error)
}

/// Ends a batch: `failures.csv` and the cohort tables from `ended`, each
/// `(id, status, exit_code, message, seconds)`; returns `(total, ran,
/// not_converged, skipped, failed)`.
#[pyfunction]
pub(crate) fn finish(
    py: Python<'_>,
    plan: &Plan,
    out_dir: PathBuf,
    ended: Vec<(String, String, Option<i32>, String, f64)>,
) -> PyResult<(usize, usize, usize, usize, usize)> {
    let organ = |id: &str| {
        plan.plan
            .subjects
            .iter()
            .find(|s| s.id == id)
            .map_or_else(String::new, |s| s.organ.clone())
    };
    let ended = ended
        .into_iter()
        .map(|(id, status, exit_code, message, seconds)| {
            let status = batch::STATUSES
                .iter()
                .find(|s| **s == status)
                .ok_or_else(|| {
                    crate::error(format!(
                        "status '{status}' of subject '{id}' is not one of {}",
                        batch::STATUSES.join(", ")
                    ))
                })?;
            Ok(Ended {
                organ: organ(&id),
                id,
                status,
                exit_code,
                message,
                seconds,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let c = py
        .detach(|| batch::finish(&out_dir, &plan.plan, &ended, &mut Plain))
        .map_err(crate::error)?;
    Ok((c.total, c.ran, c.not_converged, c.skipped, c.failed))
}

/// `unfold cohort OUT_DIR --plot ...`: the cohort tables, statistics,
/// figures and report of a batch's output directory.
#[pyfunction]
#[pyo3(signature = (out_dir, plots=Vec::new()))]
pub(crate) fn cohort(py: Python<'_>, out_dir: PathBuf, plots: Vec<String>) -> PyResult<()> {
    let plots = plots
        .iter()
        .map(|p| p.parse::<PlotSpec>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(crate::error)?;
    py.detach(|| batch::gather(Path::new(&out_dir), &plots, &mut Plain))
        .map_err(crate::error)
}
