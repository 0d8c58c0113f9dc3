//! A series of valves (`unfold mitral --series DIR`): the time steps of a
//! directory ([`steps`]), every step read first (the first unreadable file
//! is the error; an annulus not given is found from the leaflets), the
//! steps run in parallel sharing their Newton layouts
//! ([`Pipeline::run_series`]), then written in order, one output set per
//! step in `OUT/<step>/`, stopping at the first failed step; then the
//! summary table `OUT/series.csv` (and `series.json`: `steps`, the same
//! rows, and `provenance`, the run's, as a single valve's report has) and
//! the plot over the cycle `OUT/figures/series.png`.

pub mod steps;
pub mod table;

use super::inputs::{Inputs, Step, check_not_inputs, read as read_valve};
use super::report::summary;
use super::run::Run;
use super::write::{Outputs as ValveOutputs, write as write_valve};
use crate::app::AppError;
use crate::app::error::{at, organ, shown};
use crate::app::observer::Observer;
use crate::app::run::files::write_figures;
use crate::app::run::{StagedOutputs, provenance};
use crate::figures::FigureOptions;
use crate::figures::mitral::series::{SeriesPoint, series_plot};
use crate::io::atomic_write;
use crate::organs::mitral::{Pipeline, ValveInput};
use std::path::Path;
use table::{SeriesReport, SeriesRow, csv};

/// The series table in the output directory.
pub const SERIES_CSV: &str = "series.csv";
/// The series table with the run's provenance.
pub const SERIES_JSON: &str = "series.json";

/// Where a series' outputs go.
#[derive(Debug, Clone, Copy)]
pub struct Outputs<'a> {
    /// The output directory as given (for messages).
    pub dir: &'a Path,
    /// Its staging directory, where everything is written.
    pub staging: &'a Path,
    /// The run's staged outputs.
    pub staged: &'a StagedOutputs,
}

/// Reads every step of a series, in order: first checks that no output of
/// the step's directory in `dir` (the output directory) is one of its
/// inputs, then reads it ([`read_valve`], named by its files' label).
///
/// # Errors
/// The first step's error.
pub fn read(pipeline: &Pipeline, steps: &[Step], dir: &Path) -> Result<Vec<Inputs>, AppError> {
    let mut loaded = Vec::with_capacity(steps.len());
    for step in steps {
        check_not_inputs(&dir.join(&step.name), &step.files.paths())?;
        loaded.push(read_valve(&step.files, step.files.label(), pipeline)?);
    }
    Ok(loaded)
}

/// Runs `pipeline` on every step, in parallel, sharing the Newton layouts
/// ([`Pipeline::run_series`]); one run (or the error about its inputs) per
/// step, in order.
pub fn run(pipeline: &Pipeline, inputs: &[Inputs]) -> Vec<Result<Run, AppError>> {
    let valves: Vec<ValveInput<'_>> = inputs
        .iter()
        .map(|i| ValveInput {
            anterior: &i.anterior,
            posterior: &i.posterior,
            annulus: &i.ring,
        })
        .collect();
    pipeline
        .run_series(&valves)
        .into_iter()
        .zip(inputs)
        .map(|(outcome, i)| {
            outcome
                .map(|o| Run::new(o, &i.label))
                .map_err(|e| organ(&i.label, e))
        })
        .collect()
}

/// Writes every step's output set into its directory of `out.staging`, in
/// order, telling `observer` each step's summary line
/// (`step_000: annulus ...`) once it is written, stopping at the first
/// failed step; then `series.csv`, `series.json` and, with `figures`, the
/// plot over the cycle. Returns the table.
///
/// # Errors
/// The first failed step's error, writing a file, drawing the plot (named
/// as after the commit).
pub fn write(
    steps: &[Step],
    runs: Vec<Result<Run, AppError>>,
    out: &Outputs<'_>,
    figures: bool,
    observer: &mut dyn Observer,
) -> Result<SeriesReport, AppError> {
    let staged = out.staged;
    let mut rows = Vec::with_capacity(steps.len());
    for (step, run) in steps.iter().zip(runs) {
        let run = run?;
        let dir = out.staging.join(&step.name);
        write_valve(&run, &ValveOutputs { dir: &dir, staged }, figures)
            .map_err(|e| shown(staged, e))?;
        observer.info(&format!("{}: {}", step.name, summary(&run.outcome.report)));
        rows.push(SeriesRow::new(&step.name, &step.files, &run.outcome.report));
    }
    atomic_write(out.staging.join(SERIES_CSV), csv(&rows).as_bytes())
        .map_err(|e| staged.shown_error(e))?;
    let report = SeriesReport {
        steps: rows,
        provenance: provenance::this_run(),
    };
    let json = report
        .to_json()
        .map_err(|e| at(out.dir, format!("cannot serialize the series table: {e}")))?;
    atomic_write(out.staging.join(SERIES_JSON), json.as_bytes())
        .map_err(|e| staged.shown_error(e))?;
    if figures {
        let points: Vec<SeriesPoint> = report.steps.iter().map(SeriesRow::point).collect();
        let fig = series_plot(&points, &FigureOptions::default()).map_err(|e| at(out.dir, e))?;
        write_figures(out.staging, &[fig]).map_err(|e| shown(staged, e))?;
    }
    Ok(report)
}
