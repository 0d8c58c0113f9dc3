//! The application layer's error: one enum for every organ and command,
//! each variant one line when printed, and the helpers that word the
//! common cases (a usage error naming a flag or a path, an organ's error
//! naming its input).

use super::run::memory::MemoryRefusal;
use super::run::{OutputError, StagedOutputs};
use crate::io::IoError;
use crate::linalg::glm::GlmError;
use crate::mesh::MeshError;
use crate::organs::OrganError;
use thiserror::Error;

/// Errors of running an organ or a command (one line each when printed):
/// the command line prints them after `unfold: error: `, Python raises them
/// as `unfold.UnfoldError`.
#[derive(Debug, Error)]
pub enum AppError {
    /// Reading or writing a file failed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A mesh was unusable.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// An output path cannot be written, or the outputs not put in place.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// `info --strict` found validity problems.
    #[error("{path}: {count} validity problem(s), first: {first}")]
    Invalid {
        /// The file.
        path: String,
        /// Number of problem kinds.
        count: usize,
        /// The first problem.
        first: String,
    },
    /// Output directory or file handling.
    #[error("{path}: {source}")]
    Fs {
        /// The path.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// An organ pipeline rejected its input or failed; `path` names the
    /// input concerned (the mesh, or an image).
    #[error("{path}: {source}")]
    Organ {
        /// The input file (or the name of a built-in shape).
        path: String,
        /// What went wrong.
        source: OrganError,
    },
    /// A usage error not caught by the argument parser.
    #[error("{0}")]
    Usage(String),
    /// The solver stopped before converging; the outputs are written (exit
    /// code 3).
    #[error(
        "{what} did not converge ({reason} after {iterations} iterations); its outputs are \
         written to {output} with converged: false in report.json"
    )]
    NotConverged {
        /// What was solved.
        what: &'static str,
        /// Why the solver stopped.
        reason: String,
        /// Iterations taken.
        iterations: usize,
        /// Where the outputs are.
        output: String,
    },
    /// The deformation found no injective map; the outputs are written and
    /// marked `injective: false` (exit code 3).
    #[error(
        "no injective map found: {inverted} element{} still inverted{} (smallest det J \
         {min_det_j:.3e}); {output} and its report are marked injective: false; fewer fixed \
         vertices or a start closer to a valid map (--init) may help",
        if *inverted == 1 { "" } else { "s" },
        if *folded > 0 { format!(", {folded} interior facets folded") } else { String::new() }
    )]
    NotInjective {
        /// Elements with `det J <= 0` at the end.
        inverted: usize,
        /// Interior faces (edges) whose two elements lie on the same side.
        folded: usize,
        /// The smallest `det J` at the end.
        min_det_j: f64,
        /// The output mesh.
        output: String,
    },
    /// A stage would take more memory than the run may use.
    #[error(transparent)]
    Memory(Box<MemoryRefusal>),
    /// A subject's report exists but does not read as this unfold's report
    /// of its organ (a renamed, missing or retyped field: written by
    /// another version, or edited). The cohort stops rather than leave its
    /// values out; `unfold batch` runs such a subject again.
    #[error(
        "{path}: not a {organ} report of this unfold ({message}); rerun the subject with this \
         unfold: `unfold batch MANIFEST -o OUT` runs again every subject whose report it cannot \
         read (or delete the subject's folder and rerun its command)"
    )]
    Report {
        /// The report file.
        path: String,
        /// The subject's organ.
        organ: String,
        /// What serde says (the field, line and column).
        message: String,
    },
    /// A group comparison's model or test refused its data
    /// (`unfold cohort --compare`): which analysis, and the statistics'
    /// error with its numbers.
    #[error("{analysis}: {source}")]
    Compare {
        /// The comparison and the analysis (`--compare group, placenta
        /// image t2 over 6 subjects`).
        analysis: String,
        /// What the model said.
        source: GlmError,
    },
    /// An organ command failed on an input smaller than the organ
    /// ([`super::run::units::OrganSize`]), probably not in millimetres.
    #[error(
        "{source}; {}",
        super::run::units::note(path, *side_mm, *unit, &super::run::units::convert_fix(path, *unit))
    )]
    SmallerThanAnOrgan {
        /// The failure.
        source: Box<AppError>,
        /// The small input.
        path: String,
        /// Its bounding box's largest side, in the file's units.
        side_mm: f64,
        /// The unit it is likely in.
        unit: super::run::units::LengthUnit,
    },
    /// An input larger than any organ
    /// ([`super::run::units::LARGEST_ORGAN_MM`] across), refused before
    /// anything is meshed or solved: a wrong voxel size or a file in other
    /// units.
    #[error(
        "{path}: the organ is {side_mm:.0} mm across (its bounding box's largest side), larger \
         than any organ unfold maps ({} mm), and unfold reads millimetres: {fix}",
        super::run::units::LARGEST_ORGAN_MM
    )]
    LargerThanAnOrgan {
        /// The input.
        path: String,
        /// Its bounding box's largest side, mm.
        side_mm: f64,
        /// What to check.
        fix: String,
    },
}

/// `e` naming the paths a staged output will have after the commit
/// instead of its staging paths (errors of a run that failed while writing).
pub fn shown(staged: &StagedOutputs, e: AppError) -> AppError {
    match e {
        AppError::Io(e) => AppError::Io(staged.shown_error(e)),
        AppError::Fs { path, source } => AppError::Fs {
            path: staged.shown_text(&path),
            source,
        },
        AppError::Organ { path, source } => AppError::Organ {
            path: staged.shown_text(&path),
            source,
        },
        AppError::Usage(m) => AppError::Usage(staged.shown_text(&m)),
        e => e,
    }
}

/// `value` if it is finite and positive, else a usage error naming `flag`.
pub fn positive(flag: &str, value: f64) -> Result<f64, AppError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(AppError::Usage(format!(
            "{flag} must be a finite number > 0, got {value}"
        )))
    }
}

/// A usage error naming `path`.
pub fn at(path: &std::path::Path, msg: impl std::fmt::Display) -> AppError {
    about(&path.display().to_string(), msg)
}

/// A usage error about the input called `label` (a path, or what Python
/// calls an array).
pub fn about(label: &str, msg: impl std::fmt::Display) -> AppError {
    AppError::Usage(format!("{label}: {msg}"))
}

/// A pipeline error (an [`OrganError`] or one of the organs' own errors)
/// about the inputs called `label`; configuration errors are usage errors.
pub fn organ(label: &str, source: impl Into<OrganError>) -> AppError {
    match source.into() {
        source @ OrganError::Config(_) => AppError::Usage(source.to_string()),
        source => AppError::Organ {
            path: label.to_string(),
            source,
        },
    }
}
