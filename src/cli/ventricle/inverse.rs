//! `unfold ventricle-inverse NORMALIZED --surface S --anterior X,Y,Z
//! --inferior X,Y,Z -o OUT`: the flags turned into the settings and files
//! of [`crate::app::ventricle::inverse`] (which carries the mesh back onto
//! the heart; the coordinates and outputs are described there), and the
//! summary printed on stdout.

use super::landmark_args::HeartLandmarkArgs;
use crate::app::AppError;
use crate::app::error::shown;
use crate::app::run::StagedOutputs;
use crate::app::run::frame::MeshFrame;
use crate::app::ventricle::ChartSettings;
use crate::app::ventricle::MAX_LAYERS;
use crate::app::ventricle::inverse::{self, Coordinates, Files, Outputs, Settings};
use crate::cli::choice::named;
use crate::organs::ventricle::Chamber;
use crate::organs::ventricle::field::{DEFAULT_GRID_MM, DEFAULT_HEMISPHERE_MM};
use crate::organs::ventricle::landmarks::DEFAULT_SNAP_MM;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `unfold ventricle-inverse`.
#[derive(Debug, Args)]
#[command(
    after_help = "NORMALIZED's cylinder coordinates: with --coordinates auto (default) the point \
                  arrays xi, zeta, depth when it has all three (what unfold ventricle writes into \
                  normalized.vtu), else its points as (X, Y, depth) with (X, Y) on the displayed \
                  disk (the LV disk warped by r' = r^n, n the --display-exponent, inverted here). \
                  Writes OUT/mapped.vtu (NORMALIZED's cells and arrays, the points carried onto \
                  the heart; point arrays inverse_status: 0 mapped, 1 not a cylinder point, 2 \
                  off the disk, 3 streamline failed, placed at the centre of the base; xi, zeta, \
                  depth; \
                  layer with --layers) and OUT/report.json. The heart's flags are those of \
                  unfold ventricle."
)]
pub struct VentricleInverseArgs {
    /// The mesh in normalized coordinates (any mesh file: points, lines,
    /// triangles, tets), e.g. an `unfold ventricle` run's normalized.vtu, a
    /// label field drawn on the disk, an atlas in the cylinder.
    normalized: PathBuf,
    /// Where the cylinder coordinates come from (see below).
    #[arg(long, value_parser = named::<Coordinates>(), default_value = "auto")]
    coordinates: Coordinates,
    /// The enclosing surface S of the target heart (as for `unfold
    /// ventricle`).
    #[arg(long, value_name = "S")]
    surface: PathBuf,
    #[command(flatten)]
    heart: HeartLandmarkArgs,
    /// The frame of S's coordinates (auto, ras, lps); NORMALIZED is in
    /// cylinder coordinates and is not converted.
    #[arg(long, value_parser = named::<MeshFrame>(), default_value = "auto")]
    mesh_frame: MeshFrame,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The chamber S encloses.
    #[arg(long, value_parser = named::<Chamber>(), default_value = "lv")]
    chamber: Chamber,
    /// Grid spacing of the Laplace field, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_GRID_MM, allow_negative_numbers = true)]
    grid_mm: f64,
    /// Radius of the hemisphere H at the centre of the base, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_HEMISPHERE_MM, allow_negative_numbers = true)]
    hemisphere_mm: f64,
    /// Display exponent n of the LV disk, r' = r^n, inverted for
    /// coordinates read from the points [default: 1/3].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    display_exponent: Option<f64>,
    /// Largest distance from a given rim landmark to the rim of S, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_SNAP_MM, allow_negative_numbers = true)]
    snap_mm: f64,
    /// Label N transmural layers of equal depth: the point array `layer`,
    /// 1 at S (depth 0) to N at H (depth 1), `min(floor(depth N) + 1, N)`;
    /// 0 for a point not mapped.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_LAYERS)))]
    layers: Option<u32>,
}

impl VentricleInverseArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            coordinates: self.coordinates,
            mesh_frame: self.mesh_frame,
            chart: ChartSettings {
                chamber: self.chamber,
                grid_mm: self.grid_mm,
                hemisphere_mm: self.hemisphere_mm,
                display_exponent: self.display_exponent,
                snap_mm: self.snap_mm,
            },
            layers: self.layers,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            normalized: self.normalized.clone(),
            surface: self.surface.clone(),
            heart: self.heart.landmarks(),
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold ventricle-inverse`: every flag checked, every output
/// checked (and staged) before any input is read, the run, its outputs
/// put in place, the summary on stdout.
pub fn run(a: &VentricleInverseArgs) -> Result<(), AppError> {
    let start = Instant::now();
    let settings = a.settings();
    let files = a.files();
    settings.validate()?;
    files.check()?;
    let mut staged = StagedOutputs::new(files.inputs());
    let staging = staged.dir(&a.output)?;
    let inputs = inverse::read(&settings, &files, start)?;
    let run = inverse::run(&settings, &inputs)?;
    let written = inverse::write(
        &run,
        &Outputs {
            dir: &staging,
            staged: &staged,
        },
    )
    .map_err(|e| shown(&staged, e))?;
    staged.commit()?;
    let r = &run.report;
    let (n, failed, counts) = (r.points, r.failed, r.failures);
    println!(
        "{}: {} of {} points mapped onto {}{} in {:.2} s (chart {:.2} s, inverse {:.2} s)",
        inputs.normalized_label,
        n - failed,
        n,
        inputs.surface_label,
        if failed > 0 {
            format!(
                "; {failed} not (not a cylinder point: {}, off the disk: {}, streamline: {}; \
                 see inverse_status)",
                counts.not_on_cylinder, counts.off_disk, counts.streamline
            )
        } else {
            String::new()
        },
        start.elapsed().as_secs_f64(),
        r.seconds.disk + r.seconds.laplace,
        r.seconds.inverse
    );
    for p in &written {
        println!("wrote {}", p.display());
    }
    Ok(())
}
