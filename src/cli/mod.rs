//! Subcommands of the `unfold` binary, one module each. They live in the
//! library (`unfold::cli`) so the Python package runs the same code (its
//! batch subjects and cohort tables).

pub mod cohort;
pub mod deform;
mod demo;
mod demo_cohort;
pub mod mesh;
pub mod mitral;
pub mod placenta;
pub mod ventricle;

mod choice;
mod progress;

use mesh::{convert, info, pushback, repair};

pub use crate::app::AppError;
pub(crate) use crate::app::error::shown;
pub(crate) use crate::app::names::stop_name;
pub use crate::app::run::files::{canonical, ensure_dir, read_image_checked, write_figures};
pub use crate::app::run::printable::printable;
use crate::app::run::units::OrganSize;
pub(crate) use crate::app::run::{memory, provenance, units};
use clap::{Parser, Subcommand};
use std::path::PathBuf;

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
    /// Map a tet mesh (into space) or a triangle mesh (to the plane) with the least distortion,
    /// flip-free, from any start: untangles a folded start, keeps fixed vertices exactly,
    /// pulls towards soft targets.
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
    VentricleInverse(Box<ventricle::inverse::VentricleInverseArgs>),
    /// Run many subjects from a CSV manifest (one row each, --jobs at a time), then gather their
    /// reports into OUT/cohort.csv.
    Batch(cohort::BatchArgs),
    /// Gather the reports of an `unfold batch` output directory into OUT/cohort.csv.
    Cohort(cohort::CohortArgs),
    /// Lay a mitral valve out in 2D: annulus first, leaflets below, relaxed flip-free, with
    /// clinical maps (coaptation, tenting, Carpentier segments) and measurements.
    Mitral(mitral::MitralArgs),
}

/// Runs a parsed command line (the process's arguments are its
/// provenance's command line).
pub fn run(cli: Cli) -> Result<(), AppError> {
    let command_line = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    run_command_line(cli, command_line)
}

/// Runs `cli`, parsed from `command_line` (program name first), which the
/// reports record as their provenance.
pub fn run_command_line(cli: Cli, command_line: Vec<String>) -> Result<(), AppError> {
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
        Command::Placenta(a) => {
            placenta::run(&a).map_err(|e| hint(e, &a.input_meshes(), OrganSize::PLACENTA))
        }
        Command::Pushback(a) => pushback::run(&a),
        Command::Ventricle(a) => {
            ventricle::run(&a).map_err(|e| hint(e, &a.input_meshes(), OrganSize::VENTRICLE))
        }
        Command::VentricleInverse(a) => ventricle::inverse::run(&a),
        Command::Mitral(a) => {
            mitral::run(&a).map_err(|e| hint(e, &a.input_meshes(), OrganSize::MITRAL))
        }
        Command::Batch(a) => cohort::run(&a),
        Command::Cohort(a) => cohort::run_cohort(&a),
    }
}

/// `e` with the organ command's small input named ([`units::with_units_hint`]).
fn hint(e: AppError, inputs: &[PathBuf], organ: OrganSize) -> AppError {
    let paths: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    units::with_units_hint(e, &paths, organ)
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
/// outputs written but the solver did not converge (or `unfold deform`
/// found no injective map). The `unfold` binary
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
            // 3: outputs written, but the solver did not converge or found
            // no injective map
            if matches!(
                e,
                AppError::NotConverged { .. } | AppError::NotInjective { .. }
            ) {
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
