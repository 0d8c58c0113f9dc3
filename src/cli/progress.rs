//! How the command line shows a run's progress and messages: a spinner on
//! stderr (when it is a terminal) with the current stage and, while
//! optimizing, the iteration, objective and gradient norm; progress lines
//! only on a terminal; status lines and warnings on stderr; results on
//! stdout. Nothing is drawn when stderr is not a terminal.

use crate::app::observer::Observer;
use crate::organs::PipelineObserver;
use crate::param::Iteration;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Duration;

/// The command line's [`Observer`].
pub(crate) struct Progress {
    bar: Option<ProgressBar>,
    stage: String,
}

impl Progress {
    /// With a spinner when `spinner` and stderr is a terminal.
    pub(crate) fn new(spinner: bool) -> Self {
        let bar = (spinner && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::new_spinner();
            if let Ok(style) = ProgressStyle::with_template("{spinner} [{elapsed}] {wide_msg}") {
                bar.set_style(style);
            }
            bar.enable_steady_tick(Duration::from_millis(120));
            bar
        });
        Progress {
            bar,
            stage: String::new(),
        }
    }

    /// Runs `print` with the spinner out of the way.
    fn print(&self, print: impl FnOnce()) {
        match &self.bar {
            Some(b) => b.suspend(print),
            None => print(),
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl PipelineObserver for Progress {
    fn stage(&mut self, name: &str) {
        self.stage = name.to_string();
        if let Some(b) = &self.bar {
            b.set_message(name.to_string());
        }
    }

    fn iteration(&mut self, it: &Iteration) {
        if let Some(b) = &self.bar {
            b.set_message(format!(
                "{}, it {}: phi {:.5e}, |grad| {:.2e}",
                self.stage, it.iteration, it.value, it.grad_norm
            ));
        }
    }
}

impl Observer for Progress {
    fn progress(&mut self, line: &str) {
        if std::io::stderr().is_terminal() {
            self.print(|| eprintln!("{line}"));
        }
    }

    fn status(&mut self, line: &str) {
        self.print(|| eprintln!("{line}"));
    }

    fn info(&mut self, line: &str) {
        self.print(|| println!("{line}"));
    }

    fn warning(&mut self, text: &str) {
        self.print(|| eprintln!("warning: {text}"));
    }
}
