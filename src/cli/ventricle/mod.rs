//! `unfold ventricle ANATOMY --surface S --anterior X,Y,Z --inferior X,Y,Z
//! -o DIR`: the flags of a ventricle run turned into its settings and files
//! ([`crate::app::ventricle`] runs it; the outputs are listed there), and
//! the summary printed on stdout. `unfold ventricle-inverse` is
//! [`inverse`].

pub mod inverse;
mod landmark_args;
mod summary;
mod surface_args;

use super::choice::named;
use super::progress::Progress;
use crate::app::AppError;
use crate::app::error::shown;
use crate::app::observer::Observer;
use crate::app::run::StagedOutputs;
use crate::app::run::frame::MeshFrame;
use crate::app::ventricle::{
    self, Files, HeartLandmarks, MAX_LAYERS, Outputs, Settings, grid_sweep,
};
use crate::mesh::nalgebra::Point3;
use crate::organs::ventricle::Chamber;
use crate::organs::ventricle::field::{DEFAULT_GRID_MM, DEFAULT_HEMISPHERE_MM};
use crate::organs::ventricle::landmarks::DEFAULT_SNAP_MM;
use crate::organs::ventricle::openings::RimChoice;
use clap::Args;
use landmark_args::{HeartLandmarkArgs, parse_point};
use std::path::PathBuf;
use std::time::Instant;
pub(crate) use summary::summary;
use surface_args::EnclosingArgs;

/// Arguments of `unfold ventricle`.
#[derive(Debug, Args)]
#[command(
    after_help = "Writes DIR/normalized.vtu (the anatomy at (X, Y, depth) in the cylinder), \
                  DIR/anatomy.vtu (the input anatomy), both with the point arrays xi, zeta, depth \
                  and (LV) aha, DIR/disk.vtu (S flattened), DIR/report.json and, with \
                  --to-surface, DIR/transferred.vtu (the anatomy carried into the second heart); \
                  without --surface, DIR/surface.vtu (S built from the anatomy); \
                  --sensitivity adds the sensitivity_* arrays and DIR/figures/sensitivity.png, \
                  --grid-sweep DIR/grid_sweep.csv and DIR/figures/grid_sweep.png. \
                  Points are X,Y,Z in mm, e.g. --anterior 14.3,20.5,0 (or \"14.3, 20.5, 0\")."
)]
pub struct VentricleArgs {
    /// Do not write the PNG figures into DIR/figures/.
    #[arg(long)]
    no_figures: bool,
    /// A point array of the anatomy to show on the bull's-eye (LV), as its
    /// mean per AHA segment [default: the depth].
    #[arg(long, value_name = "NAME", conflicts_with = "no_figures")]
    bullseye_array: Option<String>,
    /// Label N transmural layers of equal depth: the point array `layer`
    /// of normalized.vtu and anatomy.vtu, 1 at S (depth 0) to N at the
    /// hemisphere H (depth 1), `min(floor(depth N) + 1, N)` (3: the
    /// enclosing surface's, middle and inner thirds).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_LAYERS)))]
    layers: Option<u32>,
    /// Landmark sensitivity (the source paper's Fig. 14-17): rebuild the
    /// chart with the landmarks moved MM mm, ten ways (each rim landmark
    /// either way along the rim, both towards and away from each other,
    /// the apex four ways along S), and give each anatomy point the spread
    /// of its map: point arrays sensitivity_mm (largest |v -
    /// psi_k^-1(psi(v))|), sensitivity_disk, sensitivity_depth, report.json's
    /// `sensitivity`, figures/sensitivity.png.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    sensitivity: Option<f64>,
    /// Also run the pipeline on each of these grid spacings of the Laplace
    /// field (mm, comma-separated, each > 0) and write DIR/grid_sweep.csv
    /// (per grid: unknowns, round-trip error mean and max, shift of the map
    /// from the finest grid, seconds, estimated and peak memory) and
    /// DIR/figures/grid_sweep.png (error and time against the grid, the
    /// source paper's Fig. 11); the other outputs are those of --grid-mm.
    #[arg(
        long,
        value_name = "MM,MM,...",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    grid_sweep: Vec<f64>,
    /// The anatomy inside S (any mesh file: triangles, tets, or bare points
    /// such as VTK VERTICES or a PLY without faces), mm. Only its points are
    /// mapped; its cells are kept.
    anatomy: PathBuf,
    /// The enclosing surface S of the chamber: a triangle mesh with disk
    /// topology, its one boundary loop the basal rim [default: S built from
    /// the anatomy (tets or a surface), written as DIR/surface.vtu].
    #[arg(long, value_name = "S")]
    surface: Option<PathBuf>,
    /// Building S from the anatomy (without --surface).
    #[command(flatten)]
    enclosing: EnclosingArgs,
    #[command(flatten)]
    heart: HeartLandmarkArgs,
    /// The frame of the mesh files' coordinates: auto (3D Slicer's SPACE=
    /// marker in each file, else RAS), ras, or lps (ITK, Slicer's default
    /// for models). Meshes are turned into RAS, the frame of the
    /// coordinates given on the command line and of every output;
    /// landmarks files carry their own frame.
    #[arg(long, value_parser = named::<MeshFrame>(), default_value = "auto")]
    mesh_frame: MeshFrame,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The chamber S encloses.
    #[arg(long, value_parser = named::<Chamber>(), default_value = "lv")]
    chamber: Chamber,
    /// Grid spacing of the Laplace field, mm (finer is slower and more
    /// accurate).
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_GRID_MM, allow_negative_numbers = true)]
    grid_mm: f64,
    /// Radius of the hemisphere H at the centre of the base, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_HEMISPHERE_MM, allow_negative_numbers = true)]
    hemisphere_mm: f64,
    /// Display exponent n of the LV disk, r' = r^n (the AHA labels follow
    /// the displayed disk; 1 labels the harmonic disk) [default: 1/3].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    display_exponent: Option<f64>,
    /// Largest distance from a given rim landmark to the rim of S, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_SNAP_MM, allow_negative_numbers = true)]
    snap_mm: f64,
    /// Transfer the anatomy into a second heart with this enclosing surface
    /// (same chamber, grid and settings): writes DIR/transferred.vtu.
    #[arg(long, value_name = "S2")]
    to_surface: Option<PathBuf>,
    /// Transfer the anatomy onto a hemisphere of this radius (mm; centre of
    /// its base at the origin, apex on +z, landmarks 110 degrees apart about
    /// +x, like the demo's cup): writes DIR/transferred.vtu.
    #[arg(
        long,
        value_name = "MM",
        conflicts_with = "to_surface",
        allow_negative_numbers = true
    )]
    to_hemisphere: Option<f64>,
    /// Anterior landmark of the second heart (with --to-surface).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          requires = "to_surface")]
    to_anterior: Option<Point3<f64>>,
    /// Inferior landmark of the second heart (with --to-surface).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          requires = "to_surface")]
    to_inferior: Option<Point3<f64>>,
    /// Apex of the second heart (with --to-surface) [default: the vertex of
    /// S2 farthest from its rim's centroid].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          requires = "to_surface")]
    to_apex: Option<Point3<f64>>,
    /// The second heart's landmarks from a Slicer markups file (with
    /// --to-surface; like --landmarks).
    #[arg(long, value_name = "FILE", requires = "to_surface",
          conflicts_with_all = ["to_anterior", "to_inferior", "to_apex"])]
    to_landmarks: Option<PathBuf>,
    /// A point near the second heart's basal rim (with --to-surface; like
    /// --rim-near).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          requires = "to_surface")]
    to_rim_near: Option<Point3<f64>>,
}

impl VentricleArgs {
    /// The settings of the flags.
    pub(crate) fn settings(&self) -> Settings {
        Settings {
            chart: ventricle::ChartSettings {
                chamber: self.chamber,
                grid_mm: self.grid_mm,
                hemisphere_mm: self.hemisphere_mm,
                display_exponent: self.display_exponent,
                snap_mm: self.snap_mm,
            },
            no_figures: self.no_figures,
            bullseye_array: self.bullseye_array.clone(),
            layers: self.layers,
            sensitivity: self.sensitivity,
            grid_sweep: self.grid_sweep.clone(),
            mesh_frame: self.mesh_frame,
            to_hemisphere: self.to_hemisphere,
            enclosing: self.enclosing.settings(),
        }
    }

    /// The files of the flags.
    pub(crate) fn files(&self) -> Files {
        Files {
            anatomy: self.anatomy.clone(),
            surface: self.surface.clone(),
            heart: self.heart.landmarks(),
            to_surface: self.to_surface.clone(),
            to: HeartLandmarks {
                anterior: self.to_anterior,
                inferior: self.to_inferior,
                rv_landmarks: Vec::new(),
                apex: self.to_apex,
                landmarks: self.to_landmarks.clone(),
                rim_near: self.to_rim_near,
            },
            output: self.output.clone(),
        }
    }

    /// The mesh files read (anatomy, S, S2), for the units hint.
    pub(crate) fn input_meshes(&self) -> Vec<PathBuf> {
        let mut inputs = vec![self.anatomy.clone()];
        inputs.extend(crate::app::run::units::mesh_inputs(&[
            &self.surface,
            &self.to_surface,
        ]));
        inputs
    }
}

/// Runs `unfold ventricle`: every flag checked before any file is read,
/// every output checked (and staged) before any input is read, the run,
/// its outputs written, the grid sweep, the outputs put in place, the
/// summary on stdout.
pub fn run(a: &VentricleArgs) -> Result<(), AppError> {
    let start = Instant::now();
    let settings = a.settings();
    let files = a.files();
    let config = settings.validate()?;
    files.check()?;
    // Every output checked (and staged) before any input is read.
    let mut staged = StagedOutputs::new(files.inputs());
    let staging = staged.dir(&a.output)?;
    let mut progress = Progress::new(false);
    let inputs = ventricle::read(&settings, &files, &mut progress)?;
    let out = Outputs {
        dir: &staging,
        staged: &staged,
    };
    let (run, mut written) = ventricle::run(&settings, &inputs, &mut progress)
        .and_then(|run| {
            let written = ventricle::write(&run, &settings, &inputs, &out)?;
            Ok((run, written))
        })
        .map_err(|e| shown(&staged, e))?;
    if !settings.grid_sweep.is_empty() {
        written.extend(
            grid_sweep::sweep(
                &settings.grid_sweep,
                &inputs.anatomy,
                &inputs.surface,
                &inputs.landmarks,
                config,
                &format!("{} + {}", inputs.anatomy_label, inputs.surface_label),
                &mut progress,
            )
            .and_then(|sweep| grid_sweep::write(&sweep, &staging, !settings.no_figures, &staged))
            .map_err(|e| shown(&staged, e))?,
        );
    }
    staged.commit()?;
    let report = &run.report;
    println!("{}: {}", inputs.anatomy_label, summary(&report.report));
    let o = &report.report.openings;
    if o.loops.len() > 1 {
        println!(
            "{}: {} openings; the rim is opening {} ({}), {} capped with {} triangles",
            inputs.surface_label,
            o.loops.len(),
            o.rim,
            match o.chosen_by {
                RimChoice::RimNear => "nearest the --rim-near point",
                RimChoice::Anatomy => "the largest facing away from the apex",
                _ => "nearest the rim landmarks",
            },
            o.cap_vertices,
            o.cap_triangles
        );
    }
    if let Some(t) = &report.transfer {
        println!(
            "transferred {} points into {} in {:.2} s",
            t.points, t.surface, t.seconds
        );
    }
    for p in &written {
        println!("wrote {}", p.display());
    }
    progress.progress(&format!(
        "ventricle: done in {:.2} s",
        start.elapsed().as_secs_f64()
    ));
    Ok(())
}
