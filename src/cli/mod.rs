//! Subcommands of the `unfold` binary, one module each. They live in the
//! library (`unfold::cli`) so the Python package runs the same code (its
//! batch subjects and cohort tables).

mod aha_segments;
pub mod batch;
pub mod cohort;
mod cohort_figures;
mod cohort_images;
mod cohort_mitral;
mod cohort_mitral_maps;
mod cohort_report;
mod cohort_segments;
mod convert;
pub mod deform;
mod demo;
mod demo_cohort;
mod info;
mod memory;
pub mod mesh;
pub mod mitral;
mod mitral_series;
pub mod placenta;
mod provenance;
mod pushback;
mod repair;
pub mod units;
pub mod ventricle;
mod ventricle_grid_sweep;
pub mod ventricle_inverse;
mod ventricle_landmark_args;
mod ventricle_sensitivity;
pub mod ventricle_surface;

use crate::io::IoError;
use crate::mesh::MeshError;
use crate::organs::OrganError;
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use thiserror::Error;

/// Errors of the command-line tool (one line each when printed).
#[derive(Debug, Error)]
pub enum CliError {
    /// Reading or writing a file failed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A mesh was unusable.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// An output path cannot be written, or the outputs not put in place.
    #[error(transparent)]
    Output(#[from] crate::io::OutputError),
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
    /// A stage would take more memory than the run may use.
    #[error(transparent)]
    Memory(Box<memory::MemoryRefusal>),
    /// An organ command failed on an input smaller than any organ
    /// ([`units::SMALLEST_ORGAN_MM`] across), probably not in millimetres.
    #[error(
        "{source}; {}",
        units::note(path, *side_mm, &format!(
            "a mesh in metres is scaled by `unfold convert {path} OUT --scale 1000`"
        ))
    )]
    SmallerThanAnOrgan {
        /// The failure.
        source: Box<CliError>,
        /// The small input.
        path: String,
        /// Its bounding box's largest side, in the file's units.
        side_mm: f64,
    },
}

/// unfold: map anatomical shapes (placenta, ventricle, mitral valve) onto
/// canonical templates.
#[derive(Debug, Parser)]
#[command(name = "unfold", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The most memory a run may use (e.g. 4G, 512M); a stage whose estimate would pass it is
    /// refused before it allocates [default: the memory available on this machine]
    #[arg(long, global = true, value_name = "SIZE", value_parser = memory::parse_size)]
    max_memory: Option<u64>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// What a mesh or image file contains, and whether it is valid.
    Info(info::InfoArgs),
    /// Convert a mesh between formats (by file extension).
    Convert(convert::ConvertArgs),
    /// Write the built-in synthetic shapes (and their info) to a directory, and run the
    /// placenta, ventricle and mitral pipelines on them.
    Demo(demo::DemoArgs),
    /// Deform a tet mesh towards soft point targets with the least distortion, flip-free.
    Deform(deform::DeformArgs),
    /// Repair a mesh exported by another tool: weld coincident vertices, drop repeated and
    /// degenerate elements, orient consistently, drop unused vertices.
    Repair(repair::RepairArgs),
    /// Mesh a segmentation (a NIfTI or NRRD mask) into tets: smoothing, then isosurface stuffing
    /// with bounded dihedral angles.
    Mesh(mesh::MeshArgs),
    /// Flatten a placenta tet mesh onto a template (two planes, ellipsoid or
    /// single plane), pulling images into the template frame.
    Placenta(Box<placenta::PlacentaArgs>),
    /// Carry a template-space image (atlas, labels) back onto a subject's scanner grid
    /// through the inverse of an `unfold placenta` run's map.
    Pushback(pushback::PushbackArgs),
    /// Carry the anatomy inside a heart chamber into the canonical cylinder: the enclosing
    /// surface flattened to a disk (LV) or half disk (RV), depth along Laplace streamlines,
    /// AHA 17 segments, exact inverse map and transfer to another heart.
    Ventricle(Box<ventricle::VentricleArgs>),
    /// Carry a mesh or label field given in the cylinder's normalized coordinates (xi, zeta,
    /// depth; e.g. an `unfold ventricle` run's normalized.vtu, regions drawn on the disk) back
    /// onto a heart through the exact inverse map.
    VentricleInverse(Box<ventricle_inverse::VentricleInverseArgs>),
    /// Run many subjects from a CSV manifest (one row each, --jobs at a time), then gather their
    /// reports into OUT/cohort.csv.
    Batch(batch::BatchArgs),
    /// Gather the reports of an `unfold batch` output directory into OUT/cohort.csv.
    Cohort(cohort::CohortArgs),
    /// Lay a mitral valve out in 2D: annulus first, leaflets below, relaxed flip-free, with
    /// clinical maps (coaptation, tenting, Carpentier segments) and measurements.
    Mitral(mitral::MitralArgs),
}

/// Runs a parsed command line (the process's arguments are its
/// provenance's command line).
pub fn run(cli: Cli) -> Result<(), CliError> {
    let command_line = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    run_command_line(cli, command_line)
}

/// Runs `cli`, parsed from `command_line` (program name first), which the
/// reports record as their provenance.
pub fn run_command_line(cli: Cli, command_line: Vec<String>) -> Result<(), CliError> {
    memory::init(cli.max_memory);
    // only the commands whose reports carry provenance hash their inputs
    // (a batch hashes each subject's in the subject's own process)
    if matches!(
        cli.command,
        Command::Placenta(_)
            | Command::Ventricle(_)
            | Command::VentricleInverse(_)
            | Command::Mitral(_)
            | Command::Deform(_)
            | Command::Demo(_)
    ) {
        provenance::init(command_line, &cli.command);
    }
    match cli.command {
        Command::Info(a) => info::run(&a),
        Command::Convert(a) => convert::run(&a),
        Command::Demo(a) => demo::run(&a),
        Command::Deform(a) => deform::run(&a),
        Command::Mesh(a) => mesh::run(&a),
        Command::Repair(a) => repair::run(&a),
        Command::Placenta(a) => placenta::run(&a).map_err(|e| hint(e, &a.input_meshes())),
        Command::Pushback(a) => pushback::run(&a),
        Command::Ventricle(a) => ventricle::run(&a).map_err(|e| hint(e, &a.input_meshes())),
        Command::VentricleInverse(a) => ventricle_inverse::run(&a),
        Command::Mitral(a) => mitral::run(&a).map_err(|e| hint(e, &a.input_meshes())),
        Command::Batch(a) => batch::run(&a),
        Command::Cohort(a) => cohort::run(&a),
    }
}

/// `e` with the organ command's small input named ([`units::with_units_hint`]).
fn hint(e: CliError, inputs: &[PathBuf]) -> CliError {
    let paths: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    units::with_units_hint(e, &paths)
}

/// A clap parse error as one line: the message lines before the usage
/// block, joined, without clap's `error: ` prefix.
fn one_line_usage_error(e: &clap::Error) -> String {
    let text = e.to_string();
    let msg: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
        .filter(|l| !l.is_empty())
        .collect();
    let msg = msg.join(" ");
    let msg = msg.strip_prefix("error: ").unwrap_or(&msg);
    format!("{msg} (see --help)")
}

/// The `unfold` program on the command line `argv` (program name first):
/// parses it, runs it, prints a failure as one line `unfold: error: ...` on
/// stderr and returns the exit code: 0 done, 1 failed, 2 a usage error, 3
/// outputs written but the solver did not converge. The `unfold` binary
/// is this function; the Python package runs it as `python -m unfold`.
pub fn main(argv: Vec<std::ffi::OsString>) -> u8 {
    use clap::error::ErrorKind;
    let command_line = argv
        .iter()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let args = match Cli::try_parse_from(argv) {
        Ok(args) => args,
        Err(e) => match e.kind() {
            // Help and version go to stdout as clap prints them.
            ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
                // printing help can only fail on a closed stdout: nothing to report it on
                let _ = e.print();
                return u8::try_from(e.exit_code()).unwrap_or(2);
            }
            _ => {
                let msg = one_line_usage_error(&e);
                eprintln!("unfold: error: {}", printable(&msg));
                write_peak_file();
                return 2;
            }
        },
    };
    let code = match run_command_line(args, command_line) {
        Ok(()) => 0,
        Err(e) => {
            // One line on stderr, so scripts and users see exactly what failed.
            let msg = e.to_string();
            eprintln!("unfold: error: {}", printable(&msg));
            // 3: outputs written, but the solver did not converge
            if matches!(e, CliError::NotConverged { .. }) {
                3
            } else {
                1
            }
        }
    };
    write_peak_file();
    code
}

/// With `UNFOLD_PEAK_FILE=PATH` in the environment, writes the process's
/// peak resident size in bytes (the kernel's `VmHWM`) to `PATH` at exit: a
/// diagnostic for measuring runs, also those that fail (their reports are
/// not written). Nothing is written where the system does not tell it.
pub fn write_peak_file() {
    if let (Some(path), Some(peak)) = (
        std::env::var_os("UNFOLD_PEAK_FILE"),
        memory::peak_resident_bytes(),
    ) {
        // a diagnostic: failing to write it must not change the exit code
        let _ = std::fs::write(path, format!("{}\n", peak as u64));
    }
}

/// The report's name of a solver's stop reason (`max_iterations`, ...).
pub(crate) fn stop_name(r: crate::param::StopReason) -> String {
    serde_json::to_value(r)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| format!("{r:?}"))
}

/// `text` safe to print on a terminal: control characters (C0, DEL, C1:
/// ESC, BEL, OSC, ... as found in hostile files' names and tokens) shown as
/// `\u{1b}` escapes, so a file cannot retitle, recolour or ring the
/// terminal; newlines become spaces (messages are one line).
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => out.push_str(&c.escape_unicode().to_string()),
            c => out.push(c),
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Reads an image after checking that its values fit the run's memory:
/// the header alone first ([`crate::io::read_image_header`]), then
/// `voxels x 4` bytes (the values as `f32`, decoded as they are read) plus
/// `voxels x extra_per_voxel` for what the caller derives from them (a
/// mask: 1 byte per voxel) and a 1 MiB read buffer, checked before the
/// values are read.
///
/// # Errors
/// The readers' errors; [`CliError::Memory`] when the values do not fit.
pub(crate) fn read_image_checked(
    path: &std::path::Path,
    extra_per_voxel: f64,
) -> Result<crate::io::NiftiImage, CliError> {
    let header = crate::io::read_image_header(path)?;
    let voxels = header.value_count() as f64;
    let estimate = crate::mesh::memory::MemoryEstimate::new()
        .with("image values", voxels, 4.0 + extra_per_voxel)
        .with("read buffer", 1.0, 1024.0 * 1024.0);
    memory::check(
        "reading the image",
        &estimate,
        "crop or resample the image (its header declares more voxels than fit), or raise \
         --max-memory",
    )
    .map_err(|e| at(path, e))?;
    Ok(crate::io::read_image(path)?)
}

/// Creates `dir` (and parents) if needed.
pub(crate) fn ensure_dir(dir: &std::path::Path) -> Result<(), CliError> {
    std::fs::create_dir_all(dir).map_err(|source| CliError::Fs {
        path: dir.display().to_string(),
        source,
    })
}

/// Canonical form of a path for comparisons (falls back to the path itself).
pub(crate) fn canonical(p: &std::path::Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
}

/// `e` naming the paths a staged output will have after the commit
/// instead of its staging paths (errors of a run that failed while writing).
pub(crate) fn shown(staged: &crate::io::StagedOutputs, e: CliError) -> CliError {
    match e {
        CliError::Io(e) => CliError::Io(staged.shown_error(e)),
        CliError::Fs { path, source } => CliError::Fs {
            path: staged.shown_text(&path),
            source,
        },
        CliError::Organ { path, source } => CliError::Organ {
            path: staged.shown_text(&path),
            source,
        },
        CliError::Usage(m) => CliError::Usage(staged.shown_text(&m)),
        e => e,
    }
}

impl From<crate::placenta::InputError> for CliError {
    fn from(e: crate::placenta::InputError) -> Self {
        match e {
            crate::placenta::InputError::Usage(m) => CliError::Usage(m),
            crate::placenta::InputError::Organ { path, source } => CliError::Organ { path, source },
        }
    }
}

/// `value` if it is finite and positive, else a usage error naming `flag`.
pub(crate) fn positive(flag: &str, value: f64) -> Result<f64, CliError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(CliError::Usage(format!(
            "{flag} must be a finite number > 0, got {value}"
        )))
    }
}

/// A usage error naming `path`.
pub(crate) fn at(path: &std::path::Path, msg: impl std::fmt::Display) -> CliError {
    about(&path.display().to_string(), msg)
}

/// A usage error about the input called `label` (a path, or what Python
/// calls an array).
pub(crate) fn about(label: &str, msg: impl std::fmt::Display) -> CliError {
    CliError::Usage(format!("{label}: {msg}"))
}

/// A pipeline error (an [`OrganError`] or one of the organs' own errors)
/// about the inputs called `label`; configuration errors are usage errors.
pub(crate) fn organ(label: &str, source: impl Into<OrganError>) -> CliError {
    match source.into() {
        source @ OrganError::Config(_) => CliError::Usage(source.to_string()),
        source => CliError::Organ {
            path: label.to_string(),
            source,
        },
    }
}

/// Writes `figures` as PNG files into `dir/figures/` (created if missing),
/// each atomically; returns the paths written.
pub(crate) fn write_figures(
    dir: &std::path::Path,
    figures: &[crate::figures::Figure],
) -> Result<Vec<PathBuf>, CliError> {
    let out = dir.join("figures");
    ensure_dir(&out)?;
    let mut written = Vec::with_capacity(figures.len());
    for f in figures {
        let path = out.join(&f.name);
        let png = f
            .image
            .to_png()
            .map_err(|e| at(&path, format!("cannot encode the figure: {e}")))?;
        crate::io::atomic_write(&path, &png)?;
        written.push(path);
    }
    Ok(written)
}

/// The frame of the mesh file's coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum MeshFrameArg {
    /// 3D Slicer's SPACE= marker in the file, else RAS.
    Auto,
    /// Right, anterior, superior (NIfTI's world frame).
    Ras,
    /// Left, posterior, superior (ITK, DICOM, 3D Slicer).
    Lps,
}

/// The frame of a mesh file: the flag's, or for `auto` the file's Slicer
/// marker (RAS without one).
pub(crate) fn mesh_frame(
    arg: MeshFrameArg,
    path: &std::path::Path,
) -> Result<crate::io::Frame, CliError> {
    Ok(match arg {
        MeshFrameArg::Ras => crate::io::Frame::Ras,
        MeshFrameArg::Lps => crate::io::Frame::Lps,
        MeshFrameArg::Auto => {
            let bytes = std::fs::read(path).map_err(|e| at(path, e))?;
            crate::io::mesh_frame_hint(&bytes).unwrap_or(crate::io::Frame::Ras)
        }
    })
}

/// Positions in `frame` turned into RAS: LPS `(x, y, z)` is RAS
/// `(-x, -y, z)`, a half turn about z (a rotation: orientation and
/// distances are kept).
pub(crate) fn to_ras(
    frame: crate::io::Frame,
    positions: &mut [crate::mesh::nalgebra::Point3<f64>],
) {
    let [sx, sy, sz] = frame.to_ras_signs();
    for p in positions {
        p.x *= sx;
        p.y *= sy;
        p.z *= sz;
    }
}
