//! `--lambda-sweep`: the flattening again with each distortion weight, for
//! the trade-off between the template error and the distortion (the
//! placenta paper's Fig. 3): one row per weight.

use super::settings::Settings;
use crate::app::AppError;
use crate::app::error::organ;
use crate::app::observer::Observer;
use crate::organs::Quiet;
use crate::organs::placenta::{Config, PreparedMesh};

/// The table's file name.
pub const LAMBDA_SWEEP_CSV: &str = "lambda_sweep.csv";

/// The table's columns.
pub const COLUMNS: [&str; 7] = [
    "lambda",
    "converged",
    "iterations",
    "template_error_mm",
    "dirichlet_excess_percent",
    "min_det_j",
    "seconds",
];

/// One weight's flattening.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// The weight.
    pub lambda: f64,
    /// Whether it converged.
    pub converged: bool,
    /// Iterations taken.
    pub iterations: usize,
    /// Template error, mm.
    pub template_error_mm: f64,
    /// Dirichlet excess, %.
    pub dirichlet_excess_percent: f64,
    /// Smallest det J.
    pub min_det_j: f64,
    /// Time, s.
    pub seconds: f64,
}

impl SweepRow {
    /// The row's cells, in [`COLUMNS`] order (numbers as Rust writes them).
    pub fn cells(&self) -> [String; 7] {
        [
            self.lambda.to_string(),
            self.converged.to_string(),
            self.iterations.to_string(),
            self.template_error_mm.to_string(),
            self.dirichlet_excess_percent.to_string(),
            self.min_det_j.to_string(),
            self.seconds.to_string(),
        ]
    }
}

/// The sweep's rows, one per weight.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// The rows, in the order of the weights given.
    pub rows: Vec<SweepRow>,
}

/// Flattens `prepared` once per weight of `settings.lambda_sweep` (no
/// images; `config` and the settings' pieces otherwise); `observer` is told
/// which weight runs.
///
/// # Errors
/// A run that fails, named with its weight.
pub fn lambda_sweep(
    settings: &Settings,
    config: Config,
    prepared: &PreparedMesh,
    label: &str,
    observer: &mut dyn Observer,
) -> Result<Sweep, AppError> {
    let mut rows = Vec::with_capacity(settings.lambda_sweep.len());
    for &lambda in &settings.lambda_sweep {
        observer.status(&format!("{label}: lambda sweep, lambda = {lambda}"));
        let outcome = settings
            .pipeline(Config { lambda, ..config })?
            .run_prepared(prepared.clone(), &[], &mut Quiet)
            .map_err(|e| organ(&format!("{label} (--lambda-sweep {lambda})"), e))?;
        let r = &outcome.report;
        rows.push(SweepRow {
            lambda,
            converged: r.converged,
            iterations: r.iterations,
            template_error_mm: r.template_error_mm,
            dirichlet_excess_percent: r.dirichlet_excess_percent,
            min_det_j: r.min_det_j,
            seconds: r.seconds,
        });
    }
    Ok(Sweep { rows })
}
