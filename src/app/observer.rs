//! What a run tells its caller while it works: the pipeline's stages and
//! iterations ([`PipelineObserver`]), and lines for the user. The command
//! line prints them (a spinner and progress lines on a terminal, warnings
//! on stderr, results on stdout); Python hands the stages to its progress
//! callback; a test may collect them.

use crate::organs::PipelineObserver;

/// Receives a run's progress and messages; every method has an empty
/// default, so [`Quiet`] ignores everything.
pub trait Observer: PipelineObserver {
    /// A line about work in progress ("ventricle: Laplace field ..."): the
    /// command line shows it only on a terminal.
    fn progress(&mut self, _line: &str) {}

    /// A line about the run's course that belongs in its log ("lambda
    /// sweep, lambda = 0.3"): the command line prints it on stderr.
    fn status(&mut self, _line: &str) {}

    /// A result worth a line of its own before the run ends (a mask's
    /// mesh and its quality): the command line prints it on stdout.
    fn info(&mut self, _line: &str) {}

    /// Something the user should read although the run goes on (a
    /// component dropped, vertices outside the grid): the command line
    /// prints `warning: <text>` on stderr.
    fn warning(&mut self, _text: &str) {}
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct Quiet;

impl PipelineObserver for Quiet {}
impl Observer for Quiet {}

/// An observer that prints as the command line does without a terminal:
/// info lines on stdout, status lines and warnings on stderr, no progress
/// (Python's runs, whose messages went there before there was an
/// observer).
#[derive(Debug, Default, Clone, Copy)]
pub struct Plain;

impl PipelineObserver for Plain {}
impl Observer for Plain {
    fn status(&mut self, line: &str) {
        eprintln!("{line}");
    }

    fn info(&mut self, line: &str) {
        println!("{line}");
    }

    fn warning(&mut self, text: &str) {
        eprintln!("warning: {text}");
    }
}
