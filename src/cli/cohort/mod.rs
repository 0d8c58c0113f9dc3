//! `unfold batch MANIFEST.csv -o OUT [--jobs N]` and `unfold cohort OUT
//! [--compare COLUMN ...]`:
//! the flags of a cohort turned into the application's batch
//! ([`crate::app::cohort`]), its progress drawn (a bar on a terminal, a
//! line per subject otherwise: cluster job logs).

use super::choice::named;
use super::progress::Progress;
use crate::app::AppError;
#[cfg(test)]
use crate::app::cohort::OrganColumns;
use crate::app::cohort::{BatchObserver, CompareSettings, Ended, Layout, PlotSpec, Subject};
use crate::app::observer::Observer;
use crate::app::run::printable::printable;
use crate::organs::PipelineObserver;
use clap::Args;
use std::io::IsTerminal;
use std::path::PathBuf;

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
    /// How OUT is laid out: `default`, or `bids` (a BIDS derivative dataset:
    /// `OUT/dataset_description.json`, `OUT/sub-<label>/`, `OUT/group/`; the
    /// default layout's files in `OUT/work/`).
    #[arg(long, value_parser = named::<Layout>(), default_value = "default")]
    layout: Layout,
}

/// `unfold cohort`.
#[derive(Debug, Args)]
pub struct CohortArgs {
    /// The output directory of an `unfold batch` run.
    output: PathBuf,
    /// A scatter plot of a `cohort.csv` column against a numeric covariate
    /// (repeatable; default: every numeric covariate against the headline
    /// measurements of each organ).
    #[arg(long = "plot", value_name = "MEASURE:COVARIATE")]
    plot: Vec<PlotSpec>,
    /// Compare the groups of a subjects.csv column (categorical when a value is not a number;
    /// else its continuous effect) in template space: OUT/cohort/stats/ (t or F, FWE-corrected
    /// and uncorrected p per voxel, segment and measurement; compare.json).
    #[arg(long, value_name = "COLUMN")]
    compare: Option<String>,
    /// Numeric subjects.csv columns as nuisance covariates of --compare.
    #[arg(
        long,
        value_name = "C1,C2",
        value_delimiter = ',',
        requires = "compare"
    )]
    covariates: Vec<String>,
    /// Relabelings of --compare's permutation test, the identity included (all the distinct
    /// ones when they are fewer) [default: 1000].
    #[arg(long, value_name = "N", requires = "compare")]
    permutations: Option<usize>,
    /// Seed of --compare's random relabelings (the same seed, the same files) [default: 0].
    #[arg(long, value_name = "S", requires = "compare")]
    seed: Option<u64>,
}

/// The batch's progress on the command line.
struct BatchProgress {
    bar: Option<indicatif::ProgressBar>,
    lines: Progress,
}

impl PipelineObserver for BatchProgress {}

impl Observer for BatchProgress {
    fn info(&mut self, line: &str) {
        self.lines.info(line);
    }
}

impl BatchObserver for BatchProgress {
    fn start(&mut self, total: usize) {
        self.bar = std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new(total as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template("batch [{bar:30}] {pos}/{len} {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        });
    }

    fn ended(&mut self, k: usize, total: usize, s: &Subject, e: &Ended) {
        match &self.bar {
            Some(b) => {
                b.inc(1);
                b.set_message(format!("{} {}", s.id, e.status));
            }
            None => println!(
                "batch [{k}/{total}] {} ({}): {} in {:.1} s{}",
                s.id,
                s.organ,
                e.status,
                e.seconds,
                if e.message.is_empty() {
                    String::new()
                } else {
                    format!(": {}", printable(&e.message))
                }
            ),
        }
    }

    fn finished(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }
}

/// Runs `unfold batch`.
pub fn run(a: &BatchArgs) -> Result<(), AppError> {
    match a.layout {
        Layout::Default => run_manifest(&a.manifest, &a.output, a.jobs),
        Layout::Bids => {
            let command_line: Vec<String> = std::env::args().collect();
            let mut progress = BatchProgress {
                bar: None,
                lines: Progress::new(false),
            };
            crate::app::cohort::run_manifest_bids(
                &a.manifest,
                &a.output,
                a.jobs,
                &command_line,
                &mut progress,
            )
        }
    }
}

/// Runs the subjects of `manifest` into `out` ([`crate::app::cohort::run_manifest`]).
pub(crate) fn run_manifest(
    manifest: &std::path::Path,
    out: &std::path::Path,
    jobs: Option<usize>,
) -> Result<(), AppError> {
    let mut progress = BatchProgress {
        bar: None,
        lines: Progress::new(false),
    };
    crate::app::cohort::run_manifest(manifest, out, jobs, &mut progress)
}

/// Runs `unfold cohort`: reads `OUT/subjects.csv`, writes `OUT/cohort.csv`
/// (and with `--compare` the group comparison).
pub fn run_cohort(a: &CohortArgs) -> Result<(), AppError> {
    let compare = a.compare.as_ref().map(|c| {
        let mut s = CompareSettings::new(c);
        s.covariates.clone_from(&a.covariates);
        s.permutations = a.permutations.unwrap_or(s.permutations);
        s.seed = a.seed.unwrap_or(s.seed);
        s
    });
    crate::app::cohort::gather_compare(
        &a.output,
        &a.plot,
        compare.as_ref(),
        &mut Progress::new(false),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// How `organ`'s command takes the manifest's columns, read from its
    /// clap arguments: what the application's [`crate::app::cohort::organ_columns`]
    /// must say (its settings and files by name).
    fn clap_columns(organ: &str) -> Option<OrganColumns> {
        let cli = crate::cli::Cli::command();
        let cmd = cli.find_subcommand(organ)?;
        let mut k = OrganColumns::default();
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

    /// The manifest takes exactly the flags of each organ's command, each
    /// of the same kind (a path, a value, a switch, repeated), so adding a
    /// flag without its setting (or the other way round) fails here.
    #[test]
    fn manifest_columns_are_the_commands_flags() {
        for organ in crate::app::cohort::manifest::ORGANS {
            assert_eq!(
                crate::app::cohort::organ_columns(organ),
                clap_columns(organ),
                "{organ}"
            );
        }
    }
}
