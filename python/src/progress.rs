//! The `progress(stage, iteration, value)` callback of a pipeline run: a
//! [`PipelineObserver`] that calls it with the GIL re-acquired, at every
//! new stage and at most every 0.1 s during the optimization.

use pyo3::prelude::*;
use std::time::{Duration, Instant};
use unfold::organs::PipelineObserver;
use unfold::param::Iteration;

/// The least time between two iteration calls.
const EVERY: Duration = Duration::from_millis(100);

/// Calls a Python callable with the pipeline's progress; the first
/// exception it raises stops further calls and is re-raised after the run.
pub(crate) struct Callback {
    callback: Option<Py<PyAny>>,
    stage: String,
    last: Option<Instant>,
    /// The callback's first exception.
    pub error: Option<PyErr>,
}

impl Callback {
    /// Progress to `callback` (none: nothing is called).
    pub fn new(callback: Option<Py<PyAny>>) -> Self {
        Callback {
            callback,
            stage: String::new(),
            last: None,
            error: None,
        }
    }

    fn call(&mut self, iteration: usize, value: f64) {
        if self.error.is_some() {
            return;
        }
        if let Some(cb) = &self.callback {
            let stage = self.stage.as_str();
            let result = Python::attach(|py| cb.call1(py, (stage, iteration, value)).map(drop));
            self.error = result.err();
            self.last = Some(Instant::now());
        }
    }
}

impl PipelineObserver for Callback {
    fn stage(&mut self, name: &str) {
        self.stage = name.to_string();
        self.call(0, f64::NAN);
    }

    fn iteration(&mut self, it: &Iteration) {
        if self.last.is_none_or(|t| t.elapsed() >= EVERY) {
            self.call(it.iteration, it.value);
        }
    }
}

/// Warnings on stderr, as the command line prints them; the other messages
/// are the command line's.
impl unfold::app::observer::Observer for Callback {
    fn warning(&mut self, text: &str) {
        eprintln!("warning: {text}");
    }
}
