//! One valve from its files to its outputs: read, run, written (the
//! command line's single valve and the demo's).

use super::inputs::{ValveFiles, read};
use super::run::{Run, run_with};
use super::write::{Outputs, write};
use crate::app::AppError;
use crate::app::observer::Observer;
use crate::organs::mitral::Pipeline;

/// Reads one valve ([`read`]), runs `pipeline` on it ([`run_with`]) and
/// writes its files into `out.dir` ([`write()`], the figures with
/// `figures`); the report names the inputs as they will be after
/// `out.staged`'s commit.
///
/// # Errors
/// Reading, running or writing.
pub fn run_valve(
    files: &ValveFiles,
    pipeline: &Pipeline,
    out: &Outputs<'_>,
    figures: bool,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    let label = files.shown(out.staged).label();
    let inputs = read(files, label, pipeline)?;
    let run = run_with(pipeline, &inputs, observer)?;
    write(&run, out, figures)?;
    Ok(run)
}
