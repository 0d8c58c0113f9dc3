//! `unfold ventricle ANATOMY --surface S --anterior X,Y,Z --inferior X,Y,Z
//! -o DIR`: the anatomy inside a heart chamber carried into the canonical
//! cylinder (ALGORITHMS 3).
//!
//! The pipeline is [`crate::organs::ventricle::Pipeline`]: S (a triangle mesh
//! with disk topology, its one boundary loop the basal rim) is flattened to
//! the unit disk (LV) or half disk (RV) with the landmarks in place, the
//! Laplace field between S and the hemisphere H is solved on a grid, and
//! every anatomy point `v` goes to
//!
//! ```text
//! psi(v) = (phi(v_S), d(v)),   d(v) = len(v_S -> v) / len(v_S -> v_H)
//! ```
//!
//! (`v_S`, `v_H` the ends of the streamline through `v` on S and H), and
//! back (`psi^-1`, the round-trip error). The anatomy is any mesh file:
//! triangles, tets or bare points (VTK `VERTICES`, a PLY without faces);
//! only its points are mapped, its cells are kept.
//!
//! Outputs in DIR (created if missing), each written atomically:
//!
//! - `normalized.vtu`: the anatomy in the cylinder, points `(X, Y, depth)`
//!   with `(X, Y)` the displayed disk position; point arrays `xi`, `zeta`,
//!   `depth` and (LV) `aha`;
//! - `anatomy.vtu`: the input anatomy with the same arrays;
//! - `disk.vtu`: S flattened (`z = 0`), arrays `xi`, `zeta`;
//! - `transferred.vtu` with `--to-surface`: the anatomy carried into the
//!   second heart, `psi_2^-1(psi(v))`, with the arrays of `anatomy.vtu`;
//! - `surface.vtu` without `--surface`: S built from the anatomy
//!   ([`super::ventricle_surface`]);
//! - `report.json`: the library's report, the inputs, (with a transfer)
//!   `transfer` and (with a built S) `enclosing_surface`;
//! - with `--sensitivity MM`, the point arrays `sensitivity_mm`,
//!   `sensitivity_disk`, `sensitivity_depth` in `normalized.vtu` and
//!   `anatomy.vtu`, `sensitivity` in `report.json` and
//!   `figures/sensitivity.png` ([`super::ventricle_sensitivity`]);
//! - with `--grid-sweep`, `grid_sweep.csv` and `figures/grid_sweep.png`
//!   ([`super::ventricle_grid_sweep`]).
//!
//! The landmarks come from the flags or from a 3D Slicer markups file
//! (`--landmarks FILE.mrk.json`, points labelled `anterior`, `inferior`,
//! `apex`; a flag next to the file is a usage error). S may have several
//! openings: the basal rim is the one nearest the rim landmarks (or
//! `--rim-near X,Y,Z`), the others are capped; `report.json` lists them
//! under `openings`.
//!
//! An anatomy without cells is written with one VTK vertex cell per point,
//! so that viewers show it. Progress lines (`ventricle: ...`) go to stderr
//! when it is a terminal.

use super::ventricle_landmark_args::HeartLandmarkArgs;
use super::{AppError, at, organ, positive};
use crate::app::run::StagedOutputs;
use crate::io::{
    FilePath, IoError, MarkupsError, WriteOptions, atomic_write, read_markups, read_mesh,
    read_tri_mesh, write_mesh,
};
use crate::mesh::nalgebra::Point3;
use crate::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
use crate::mesh::{CellMesh, CellType, Field, TriMesh};
use crate::organs::ventricle::enclosing::EnclosingReport;
use crate::organs::ventricle::field::{DEFAULT_GRID_MM, DEFAULT_HEMISPHERE_MM, FieldConfig};
use crate::organs::ventricle::landmarks::DEFAULT_SNAP_MM;
use crate::organs::ventricle::openings::RimChoice;
use crate::organs::ventricle::rv_landmarks::{FromRv, rim_landmarks_from_rv};
use crate::organs::ventricle::{
    Chamber, ChartConfig, Config, CylinderPoint, LandmarkPoints, Outcome, Pipeline, Report,
};
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::borrow::Cow;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `--chamber`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ChamberArg {
    /// Left ventricle: the unit disk, AHA 17 segments.
    Lv,
    /// Right ventricle: the half disk (landmarks: the two septal corners).
    Rv,
}

impl From<ChamberArg> for Chamber {
    fn from(c: ChamberArg) -> Self {
        match c {
            ChamberArg::Lv => Chamber::Lv,
            ChamberArg::Rv => Chamber::Rv,
        }
    }
}

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
    enclosing: super::ventricle_surface::EnclosingArgs,
    #[command(flatten)]
    heart: HeartLandmarkArgs,
    /// The frame of the mesh files' coordinates: auto (3D Slicer's SPACE=
    /// marker in each file, else RAS), ras, or lps (ITK, Slicer's default
    /// for models). Meshes are turned into RAS, the frame of the
    /// coordinates given on the command line and of every output;
    /// landmarks files carry their own frame.
    #[arg(long, value_parser = super::choice::named::<super::MeshFrame>(), default_value = "auto")]
    mesh_frame: super::MeshFrame,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The chamber S encloses.
    #[arg(long, value_enum, default_value = "lv")]
    chamber: ChamberArg,
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

/// Label of the anterior landmark (LV) or first septal corner (RV) in a
/// markups file (compared case-insensitively; no synonyms).
const ANTERIOR_LABELS: &[&str] = &["anterior"];
/// Label of the inferior landmark (LV) or second septal corner (RV).
const INFERIOR_LABELS: &[&str] = &["inferior"];
/// Label of the apex (optional in the file).
const APEX_LABELS: &[&str] = &["apex"];

/// The landmarks of one heart: from a markups file, or the flags'
/// `anterior`, `inferior` and `apex` (clap makes sure one of the two is
/// given, never both).
fn landmark_points(
    file: Option<&Path>,
    anterior: Option<Point3<f64>>,
    inferior: Option<Point3<f64>>,
    apex: Option<Point3<f64>>,
    rim_near: Option<Point3<f64>>,
    flags: &str,
) -> Result<LandmarkPoints, AppError> {
    let Some(path) = file else {
        let (Some(anterior), Some(inferior)) = (anterior, inferior) else {
            return Err(AppError::Usage(format!(
                "give {flags} (the rim landmarks) or a markups file with them"
            )));
        };
        return Ok(LandmarkPoints {
            anterior,
            inferior,
            apex,
            rim_near,
        });
    };
    let m = read_markups(path)?;
    let labelled = |e: MarkupsError| -> AppError {
        IoError::Markups {
            path: FilePath(path.into()),
            source: e,
        }
        .into()
    };
    Ok(LandmarkPoints {
        anterior: m.require(ANTERIOR_LABELS).map_err(labelled)?,
        inferior: m.require(INFERIOR_LABELS).map_err(labelled)?,
        apex: m.find(APEX_LABELS).map_err(labelled)?,
        rim_near,
    })
}

/// Parses a point `X,Y,Z` (spaces around the commas allowed).
pub(crate) fn parse_point(s: &str) -> Result<Point3<f64>, String> {
    let fields: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || format!("expected X,Y,Z (three numbers separated by commas), got {s:?}");
    if fields.len() != 3 {
        return Err(bad());
    }
    let mut x = [0.0; 3];
    for (k, f) in fields.iter().enumerate() {
        let v: f64 = f.parse().map_err(|_| bad())?;
        if !v.is_finite() {
            return Err(format!("coordinate {f:?} of {s:?} is not finite"));
        }
        x[k] = v;
    }
    Ok(Point3::new(x[0], x[1], x[2]))
}

/// Reads an enclosing surface S and turns it into RAS (`--mesh-frame`).
pub(crate) fn read_surface(path: &Path, frame: super::MeshFrame) -> Result<TriMesh, AppError> {
    let mut m = read_tri_mesh(path)?;
    super::to_ras(super::mesh_frame(frame, path)?, &mut m.positions);
    Ok(m)
}

/// The landmarks of S (named `surface_label` in messages) from the flags:
/// `--rv-landmarks` (LV only: the rim landmarks derived from the RV
/// insertion points, returned too for the report), else a markups file or
/// `--anterior`/`--inferior`/`--apex` ([`landmark_points`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn heart_landmarks(
    surface: &TriMesh,
    surface_label: &str,
    chamber: ChamberArg,
    flags: &HeartLandmarkArgs,
) -> Result<(LandmarkPoints, Option<FromRv>), AppError> {
    let HeartLandmarkArgs {
        anterior,
        inferior,
        ref rv_landmarks,
        apex,
        landmarks: ref file,
        rim_near,
    } = *flags;
    let file = file.as_deref();
    let rv_landmarks = rv_landmarks.as_slice();
    let from_rv = match rv_landmarks {
        [] => None,
        [p, q] => {
            if chamber == ChamberArg::Rv {
                return Err(AppError::Usage(
                    "--rv-landmarks derives the LV's rim landmarks; give the RV's septal \
                     corners as --anterior and --inferior"
                        .into(),
                ));
            }
            Some(rim_landmarks_from_rv(surface, [*p, *q]).map_err(|e| organ(surface_label, e))?)
        }
        more => {
            return Err(AppError::Usage(format!(
                "--rv-landmarks takes two points, got {}",
                more.len()
            )));
        }
    };
    let landmarks = match &from_rv {
        Some(f) => LandmarkPoints {
            anterior: Point3::from(f.landmarks[0]),
            inferior: Point3::from(f.landmarks[1]),
            apex,
            rim_near,
        },
        None => landmark_points(
            file,
            anterior,
            inferior,
            apex,
            rim_near,
            "--anterior and --inferior",
        )?,
    };
    Ok((landmarks, from_rv))
}

impl VentricleArgs {
    /// The pipeline settings, every flag checked ([`settings`]).
    fn config(&self) -> Result<Config, AppError> {
        settings(
            self.chamber.into(),
            self.grid_mm,
            self.hemisphere_mm,
            self.display_exponent,
            self.snap_mm,
        )
    }
}

/// A progress line `ventricle: ...` on stderr, only when stderr is a
/// terminal (scripts see the summary on stdout and, on failure, the one-line
/// error on stderr; like the placenta spinner).
fn progress(line: impl FnOnce() -> String) {
    if std::io::stderr().is_terminal() {
        eprintln!("ventricle: {}", line());
    }
}

/// Most transmural layers `--layers` takes (the command line's and
/// Python's bound).
pub const MAX_LAYERS: u32 = 100;

/// `--layers n`: the transmural layer of each point, `1` at S to `n` at H:
/// `min(floor(d n) + 1, n)` for the depth `d` in `[0, 1]`.
pub(crate) fn transmural_layers(coords: &[CylinderPoint], n: u32) -> Vec<i32> {
    let n = f64::from(n);
    coords
        .iter()
        .map(|c| ((c.depth * n).floor() + 1.0).clamp(1.0, n) as i32)
        .collect()
}

/// The output files.
const NORMALIZED: &str = "normalized.vtu";
const ANATOMY: &str = "anatomy.vtu";
const DISK: &str = "disk.vtu";
const TRANSFERRED: &str = "transferred.vtu";
/// The LV's AHA-segment table (not written for the RV).
const AHA_SEGMENTS: &str = "aha_segments.csv";
const REPORT: &str = "report.json";

/// The second heart of a transfer.
#[derive(Debug, Clone)]
pub struct TransferInput<'a> {
    /// Its name in messages and the report (its path, usually).
    pub label: &'a str,
    /// Its enclosing surface.
    pub surface: &'a TriMesh,
    /// Its landmarks.
    pub landmarks: LandmarkPoints,
}

/// What [`run_pipeline`] works on.
#[derive(Debug, Clone)]
pub(crate) struct PipelineInput<'a> {
    /// The anatomy's name in messages and the report.
    pub anatomy_label: &'a str,
    /// The anatomy (points mapped, cells kept).
    pub anatomy: &'a CellMesh,
    /// S's name in messages and the report.
    pub surface_label: &'a str,
    /// The enclosing surface S.
    pub surface: &'a TriMesh,
    /// The landmarks of S.
    pub landmarks: LandmarkPoints,
    /// Pipeline settings (already checked).
    pub config: Config,
    /// An optional transfer into a second heart.
    pub transfer: Option<TransferInput<'a>>,
    /// Output directory (created if missing).
    pub dir: &'a Path,
    /// Write the figures into `dir/figures/`.
    pub figures: bool,
    /// The point array of the anatomy shown on the bull's-eye (LV);
    /// `None`: the depth.
    pub bullseye_array: Option<&'a str>,
    /// How `--rv-landmarks` gave the rim landmarks, for the report.
    pub from_rv: Option<&'a FromRv>,
    /// `--layers`: transmural layers to label.
    pub layers: Option<u32>,
    /// `--sensitivity MM`: the landmark displacement to test.
    pub sensitivity: Option<f64>,
    /// How S was built from the anatomy (then written as `surface.vtu`).
    pub enclosing: Option<&'a EnclosingReport>,
}

/// `report.json`: `inputs`, the library's report, the optional transfer,
/// `memory` and `provenance` (the sections the command line and the Python
/// package fill differently are type parameters, so both write one layout).
#[derive(Serialize)]
pub struct FullReport<'a, M, P> {
    /// The inputs' names.
    pub inputs: Inputs<'a>,
    /// The library's report.
    #[serde(flatten)]
    pub report: &'a Report,
    /// The transfer into a second heart, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transfer: Option<&'a TransferReport>,
    /// The landmark sensitivity (`--sensitivity`), when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensitivity: Option<&'a super::ventricle_sensitivity::SensitivityReport>,
    /// How S was built from the anatomy, when it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub enclosing_surface: Option<&'a EnclosingReport>,
    /// Predicted and measured peak memory of the run.
    pub memory: M,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: P,
}

/// The inputs named in `report.json`.
#[derive(Serialize)]
pub struct Inputs<'a> {
    /// The anatomy's name.
    pub anatomy: &'a str,
    /// The enclosing surface's name.
    pub surface: &'a str,
    /// The rim landmarks derived from `--rv-landmarks`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rv_landmarks: Option<&'a FromRv>,
}

/// `transfer` in `report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct TransferReport {
    /// The second heart's enclosing surface.
    pub surface: String,
    /// Points carried over.
    pub points: usize,
    /// Distances from its given landmarks to the vertices they snapped to,
    /// mm (anterior, inferior, apex; 0 for a computed apex).
    pub landmark_snap_mm: [f64; 3],
    /// Its apex, mm.
    pub apex_mm: [f64; 3],
    /// Its chart: repair, landmarks and disk map, s.
    pub disk_seconds: f64,
    /// Its chart: the Laplace field, s.
    pub laplace_seconds: f64,
    /// The inverse map of every point, s.
    pub inverse_seconds: f64,
    /// The whole transfer, s.
    pub seconds: f64,
}

/// What a run produced.
#[derive(Debug)]
pub(crate) struct RunResult {
    /// The library's outcome.
    pub outcome: Outcome,
    /// The transfer, when asked for.
    pub transfer: Option<TransferReport>,
    /// Every file written, in order.
    pub written: Vec<PathBuf>,
}

/// `mesh`, or a copy with one vertex cell per point when it has no cells
/// (viewers show nothing of a mesh without cells).
pub fn with_vertex_cells(mesh: &CellMesh) -> Cow<'_, CellMesh> {
    if mesh.num_cells() > 0 {
        return Cow::Borrowed(mesh);
    }
    let mut m = mesh.clone();
    for i in 0..m.positions.len() as u32 {
        m.push_cell(CellType::Vertex, &[i]);
    }
    Cow::Owned(m)
}

/// The anatomy mapped, and carried into the second heart when asked for.
#[derive(Debug)]
pub struct Mapped {
    /// The library's outcome.
    pub outcome: Outcome,
    /// The anatomy in the second heart (its cells and arrays kept) and the
    /// transfer's report.
    pub transferred: Option<(CellMesh, TransferReport)>,
}

/// The settings of `unfold ventricle`, every flag checked: `chamber`,
/// `--grid-mm`, `--hemisphere-mm`, `--display-exponent` (none: 1/3),
/// `--snap-mm`.
///
/// # Errors
/// [`AppError::Usage`] naming the flag that is not a finite number > 0.
pub fn settings(
    chamber: Chamber,
    grid_mm: f64,
    hemisphere_mm: f64,
    display_exponent: Option<f64>,
    snap_mm: f64,
) -> Result<Config, AppError> {
    let defaults = Config::default();
    let display_exponent = match display_exponent {
        Some(n) => positive("--display-exponent", n)?,
        None => defaults.display_exponent,
    };
    Ok(Config {
        chart: ChartConfig {
            chamber,
            field: FieldConfig {
                grid_mm: positive("--grid-mm", grid_mm)?,
                hemisphere_mm: positive("--hemisphere-mm", hemisphere_mm)?,
                ..defaults.chart.field
            },
            snap_mm: positive("--snap-mm", snap_mm)?,
            ..defaults.chart
        },
        display_exponent,
    })
}

/// Runs the pipeline on `anatomy` inside `surface` (named by the labels in
/// messages): every anatomy point `v` goes to `psi(v) = (phi(v_S), d(v))`
/// (module doc), and with a transfer on to `psi_2^-1(psi(v))` in the second
/// heart; nothing is written. The Laplace field's estimate is checked
/// against the memory budget.
///
/// # Errors
/// The pipeline's, about `anatomy + surface`, and the transfer's, about
/// the second heart.
pub fn map_anatomy(
    anatomy_label: &str,
    anatomy: &CellMesh,
    surface_label: &str,
    surface: &TriMesh,
    landmarks: &LandmarkPoints,
    config: Config,
    transfer: Option<&TransferInput<'_>>,
) -> Result<Mapped, AppError> {
    let input = MapInput {
        anatomy_label,
        anatomy,
        surface_label,
        surface,
        landmarks,
        config,
    };
    let label = format!("{} + {}", input.anatomy_label, input.surface_label);
    progress(|| {
        format!(
            "disk map and Laplace field of {} ({} vertices, {} triangles; {} grid {} mm), \
             then mapping {} anatomy points to the cylinder and back ...",
            input.surface_label,
            input.surface.positions.len(),
            input.surface.triangles.len(),
            chamber_name(input.config.chart.chamber),
            input.config.chart.field.grid_mm,
            input.anatomy.positions.len()
        )
    });
    // The field checks its estimate against the room left (issue 18).
    let mut config = input.config;
    config.chart.field.max_memory_bytes = crate::app::run::memory::room();
    let pipeline = Pipeline::new().config(config);
    let resident = crate::app::run::memory::resident_bytes().unwrap_or(0.0);
    let outcome = pipeline
        .run(input.anatomy, input.surface, input.landmarks)
        .map_err(|e| organ(&label, e))?;
    crate::app::run::memory::record(resident + outcome.report.field.estimated_bytes);
    let r = &outcome.report;
    progress(|| {
        format!(
            "disk map {:.2} s, Laplace field {:.2} s ({} unknowns, {} CG iterations), \
             mapping {} anatomy points {:.2} s, inverse {:.2} s",
            r.seconds.disk,
            r.seconds.laplace,
            r.field.unknowns,
            r.field.cg_iterations,
            r.anatomy_points,
            r.seconds.streamlines,
            r.seconds.inverse
        )
    });

    let transferred = match transfer {
        None => None,
        Some(t) => {
            progress(|| {
                format!(
                    "transfer: disk map and Laplace field of {} ({} vertices) ...",
                    t.label,
                    t.surface.positions.len()
                )
            });
            let t0 = Instant::now();
            let chart = pipeline
                .chart(t.surface, &t.landmarks)
                .map_err(|e| organ(t.label, e))?;
            progress(|| {
                format!(
                    "transfer: mapping {} anatomy points into {} ...",
                    outcome.coords.len(),
                    t.label
                )
            });
            let t1 = Instant::now();
            let points = chart
                .inverse_all(&outcome.coords)
                .map_err(|e| organ(t.label, e))?;
            let t2 = Instant::now();
            let timings = chart.timings();
            let s = chart.surface();
            let apex = s.positions[chart.landmarks().apex as usize];
            let mut mesh = outcome.anatomy.clone();
            mesh.positions = points;
            Some((
                mesh,
                TransferReport {
                    surface: t.label.to_string(),
                    points: outcome.coords.len(),
                    landmark_snap_mm: chart.landmarks().snap_distances_mm,
                    apex_mm: [apex.x, apex.y, apex.z],
                    disk_seconds: timings.disk,
                    laplace_seconds: timings.laplace,
                    inverse_seconds: (t2 - t1).as_secs_f64(),
                    seconds: (t2 - t0).as_secs_f64(),
                },
            ))
        }
    };

    Ok(Mapped {
        outcome,
        transferred,
    })
}

/// The inputs of [`map_anatomy`] (for its progress lines).
struct MapInput<'a> {
    anatomy_label: &'a str,
    anatomy: &'a CellMesh,
    surface_label: &'a str,
    surface: &'a TriMesh,
    landmarks: &'a LandmarkPoints,
    config: Config,
}

/// Runs the pipeline (and the transfer) and writes the outputs into
/// `input.dir`: the meshes first, `report.json` last. Nothing is written
/// when the pipeline or the transfer fails.
pub(crate) fn run_pipeline(input: &PipelineInput<'_>) -> Result<RunResult, AppError> {
    let Mapped {
        outcome,
        transferred,
    } = map_anatomy(
        input.anatomy_label,
        input.anatomy,
        input.surface_label,
        input.surface,
        &input.landmarks,
        input.config,
        input.transfer.as_ref(),
    )?;
    let dir = input.dir;
    super::ensure_dir(dir)?;
    let opts = WriteOptions::default();
    let mut written = Vec::new();
    let mut meshes: Vec<(&str, Cow<'_, CellMesh>)> = vec![
        (NORMALIZED, with_vertex_cells(&outcome.normalized)),
        (ANATOMY, with_vertex_cells(&outcome.anatomy)),
        (DISK, Cow::Owned(CellMesh::from(&outcome.disk))),
    ];
    if let Some(n) = input.layers {
        let layer = Field::labels("layer", transmural_layers(&outcome.coords, n));
        for (_, mesh) in meshes.iter_mut().take(2) {
            mesh.to_mut().point_data.insert(layer.clone());
        }
    }
    let sensitivity = match input.sensitivity {
        None => None,
        Some(mm) => {
            let s = super::ventricle_sensitivity::sensitivity(
                &outcome,
                input.anatomy,
                input.surface,
                &input.landmarks,
                input.config,
                mm,
                &format!("{} + {}", input.anatomy_label, input.surface_label),
            )?;
            for (_, mesh) in meshes.iter_mut().take(2) {
                s.add_arrays(mesh.to_mut());
            }
            Some(s)
        }
    };
    if let Some((mesh, _)) = &transferred {
        meshes.push((TRANSFERRED, with_vertex_cells(mesh)));
    }
    if input.enclosing.is_some() {
        meshes.push((
            super::ventricle_surface::SURFACE,
            Cow::Owned(CellMesh::from(input.surface)),
        ));
    }
    for (name, mesh) in &meshes {
        let p = dir.join(name);
        write_mesh(&p, mesh, &opts)?;
        written.push(p);
    }
    // The LV's segment table, from the anatomy as written.
    if let Some(segments) = meshes
        .iter()
        .find(|(name, _)| *name == ANATOMY)
        .and_then(|(_, mesh)| super::aha_segments::heart_segments(mesh))
    {
        let p = dir.join(AHA_SEGMENTS);
        atomic_write(&p, &super::aha_segments::segment_table(&segments, &p)?)?;
        written.push(p);
    }
    drop(meshes);
    let (transferred_mesh, transfer) = match transferred {
        Some((mesh, report)) => (Some(mesh), Some(report)),
        None => (None, None),
    };
    let report_path = dir.join(REPORT);
    let json = serde_json::to_string_pretty(&FullReport {
        inputs: Inputs {
            anatomy: input.anatomy_label,
            surface: input.surface_label,
            rv_landmarks: input.from_rv,
        },
        report: &outcome.report,
        transfer: transfer.as_ref(),
        sensitivity: sensitivity.as_ref().map(|s| &s.report),
        enclosing_surface: input.enclosing,
        memory: crate::app::run::memory::report(),
        provenance: crate::app::run::provenance::this_run(),
    })
    .map_err(|e| at(&report_path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_path, format!("{json}\n").as_bytes())?;
    written.push(report_path);
    if input.figures {
        let values = match input.bullseye_array {
            None => None,
            Some(name) => {
                let field = input.anatomy.point_data.get(name).ok_or_else(|| {
                    at(
                        Path::new(input.anatomy_label),
                        format!("has no point array {name:?} for the bull's-eye"),
                    )
                })?;
                if field.components() != 1 {
                    return Err(at(
                        Path::new(input.anatomy_label),
                        format!(
                            "point array {name:?} has {} components; the bull's-eye needs 1",
                            field.components()
                        ),
                    ));
                }
                Some((name, field.values().to_f64()))
            }
        };
        let figs = crate::figures::ventricle::figures(
            &outcome,
            input.config.chart.chamber,
            values.as_ref().map(|(n, v)| (*n, v.as_slice())),
            &crate::figures::FigureOptions::default(),
        )
        .map_err(|e| at(dir, e))?;
        written.extend(super::write_figures(dir, &figs)?);
        if let (Some(mesh), Some(t)) = (&transferred_mesh, &transfer) {
            let fig = crate::figures::ventricle::transfer_figure(
                &outcome,
                mesh,
                &t.surface,
                &crate::figures::FigureOptions::default(),
            )
            .map_err(|e| at(dir, e))?;
            written.extend(super::write_figures(dir, &[fig])?);
        }
        if let Some(s) = &sensitivity {
            written.extend(super::write_figures(dir, &[s.figure(&outcome, dir)?])?);
        }
    }
    Ok(RunResult {
        outcome,
        transfer,
        written,
    })
}

fn chamber_name(c: Chamber) -> &'static str {
    match c {
        Chamber::Lv => "LV",
        Chamber::Rv => "RV",
    }
}

/// A length in micrometres: three decimals, or three significant digits
/// below 0.01 um.
fn micrometres(x: f64) -> String {
    if x == 0.0 || x.abs() >= 0.01 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// A one-line summary of a report: round trip, AHA segments, timings.
pub(crate) fn summary(r: &Report) -> String {
    let aha = match &r.aha_points {
        Some(counts) => format!(
            "{}/17 AHA segments non-empty",
            counts.iter().filter(|&&c| c > 0).count()
        ),
        None => "no AHA segments (RV)".into(),
    };
    let s = &r.seconds;
    format!(
        "{} points, round trip mean {} um, max {} um; {aha}; {} flipped disk triangles; \
         {:.2} s (disk {:.2}, Laplace {:.2}, streamlines {:.2}, inverse {:.2})",
        r.anatomy_points,
        micrometres(r.roundtrip_error_um.mean),
        micrometres(r.roundtrip_error_um.max),
        r.flipped_disk_triangles,
        s.disk + s.laplace + s.streamlines + s.inverse,
        s.disk,
        s.laplace,
        s.streamlines,
        s.inverse
    )
}

/// Refuses an output directory whose files would overwrite an input.
fn check_not_inputs(dir: &Path, inputs: &[&PathBuf]) -> Result<(), AppError> {
    let d = super::canonical(dir);
    for input in inputs {
        let c = super::canonical(input);
        for f in [NORMALIZED, ANATOMY, DISK, TRANSFERRED, AHA_SEGMENTS, REPORT] {
            if d.join(f) == c {
                return Err(at(
                    input,
                    format!(
                        "is an input and would be overwritten by the output {f}; choose another -o"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The hemisphere of radius `r` (mm) as an enclosing surface: the built-in
/// cup with equal radius and length, cut at the equator (its base centre at
/// the origin, apex on +z).
///
/// # Errors
/// The shape's, as a usage error of `--to-hemisphere`.
pub fn hemisphere(r: f64) -> Result<VentricleShape, AppError> {
    ventricle_cup(&VentricleParams {
        radius: r,
        length: r,
        base_above_equator: 0.0,
        anatomy_point_depth: 0.05 * r,
        anatomy_surface_depth: 0.1 * r,
        rings: 40,
        ..VentricleParams::default()
    })
    .map_err(|e| AppError::Usage(format!("--to-hemisphere {r}: {e}")))
}

impl VentricleArgs {
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

/// Runs `unfold ventricle`.
pub fn run(a: &VentricleArgs) -> Result<(), AppError> {
    let start = Instant::now();
    let config = a.config()?;
    if let Some(mm) = a.sensitivity {
        positive("--sensitivity", mm)?;
    }
    super::ventricle_grid_sweep::check_grids(&a.grid_sweep)?;
    let out = a.output.as_path();
    if out.exists() && !out.is_dir() {
        return Err(at(
            out,
            "exists and is not a directory; -o needs a directory (created if missing)",
        ));
    }
    if a.to_surface.is_some()
        && a.to_landmarks.is_none()
        && (a.to_anterior.is_none() || a.to_inferior.is_none())
    {
        return Err(AppError::Usage(
            "--to-surface needs --to-anterior and --to-inferior (the second heart's rim \
             landmarks) or --to-landmarks FILE"
                .into(),
        ));
    }
    let mut inputs = vec![&a.anatomy];
    inputs.extend(&a.surface);
    inputs.extend(&a.to_surface);
    inputs.extend(&a.heart.landmarks);
    inputs.extend(&a.to_landmarks);
    check_not_inputs(out, &inputs)?;
    // Every output checked (and staged) before any input is read.
    let mut staged = StagedOutputs::new(&inputs);
    let staging = staged.dir(out)?;

    let mut anatomy = read_mesh(&a.anatomy)?;
    super::to_ras(
        super::mesh_frame(a.mesh_frame, &a.anatomy)?,
        &mut anatomy.positions,
    );
    if anatomy.positions.is_empty() {
        return Err(at(
            &a.anatomy,
            "has no points; the anatomy to map is a mesh or points inside S",
        ));
    }
    // The bull's-eye's array is checked before any work, not after it.
    if let Some(name) = &a.bullseye_array {
        match anatomy.point_data.get(name) {
            None => {
                return Err(at(
                    &a.anatomy,
                    format!("has no point array {name:?} for the bull's-eye"),
                ));
            }
            Some(f) if f.components() != 1 => {
                return Err(at(
                    &a.anatomy,
                    format!(
                        "point array {name:?} has {} components; the bull's-eye needs 1",
                        f.components()
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    let (surface, built) = match &a.surface {
        Some(p) => (read_surface(p, a.mesh_frame)?, None),
        None => {
            let h = &a.heart;
            let given = match h.rv_landmarks.as_slice() {
                [p, q] => LandmarkPoints {
                    anterior: *p,
                    inferior: *q,
                    apex: h.apex,
                    rim_near: None,
                },
                _ => landmark_points(
                    h.landmarks.as_deref(),
                    h.anterior,
                    h.inferior,
                    h.apex,
                    h.rim_near,
                    "--anterior and --inferior",
                )?,
            };
            let b = super::ventricle_surface::build(&a.enclosing, &anatomy, &a.anatomy, &given)?;
            (b.surface.clone(), Some(b))
        }
    };
    let to_surface = match &a.to_surface {
        Some(p) => Some(read_surface(p, a.mesh_frame)?),
        None => None,
    };
    let hemisphere = match a.to_hemisphere {
        Some(r) => Some(hemisphere(positive("--to-hemisphere", r)?)?),
        None => None,
    };
    let anatomy_label = a.anatomy.display().to_string();
    let surface_label = match &a.surface {
        Some(p) => p.display().to_string(),
        None => format!("S built from {}", a.anatomy.display()),
    };
    let to_label = match (&a.to_surface, a.to_hemisphere) {
        (Some(p), _) => p.display().to_string(),
        (None, Some(r)) => format!("the hemisphere of radius {r} mm"),
        _ => String::new(),
    };
    let (mut landmarks, from_rv) = heart_landmarks(&surface, &surface_label, a.chamber, &a.heart)?;
    if let (Some(b), None) = (&built, &from_rv) {
        // the given rim landmarks lie on the anatomy's rim: carried to S's
        [landmarks.anterior, landmarks.inferior] = b.rim_landmarks;
    }
    let transfer = match (&to_surface, &hemisphere) {
        (Some(surface), _) => Some(TransferInput {
            label: &to_label,
            surface,
            landmarks: landmark_points(
                a.to_landmarks.as_deref(),
                a.to_anterior,
                a.to_inferior,
                a.to_apex,
                a.to_rim_near,
                "--to-anterior and --to-inferior",
            )?,
        }),
        (None, Some(h)) => Some(TransferInput {
            label: &to_label,
            surface: &h.surface,
            landmarks: LandmarkPoints {
                anterior: h.anterior,
                inferior: h.inferior,
                apex: Some(h.apex),
                rim_near: None,
            },
        }),
        _ => None,
    };
    progress(|| {
        format!(
            "read {} ({} points, {} cells) and {}",
            anatomy_label,
            anatomy.positions.len(),
            anatomy.num_cells(),
            surface_label
        )
    });
    let result = run_pipeline(&PipelineInput {
        anatomy_label: &anatomy_label,
        anatomy: &anatomy,
        surface_label: &surface_label,
        surface: &surface,
        landmarks,
        config,
        transfer,
        dir: &staging,
        figures: !a.no_figures,
        bullseye_array: a.bullseye_array.as_deref(),
        from_rv: from_rv.as_ref(),
        layers: a.layers,
        sensitivity: a.sensitivity,
        enclosing: built.as_ref().map(|b| &b.report),
    })
    .map_err(|e| super::shown(&staged, e))?;
    let mut written = result.written.clone();
    if !a.grid_sweep.is_empty() {
        written.extend(
            super::ventricle_grid_sweep::grid_sweep(
                &a.grid_sweep,
                &anatomy,
                &surface,
                &landmarks,
                config,
                &format!("{anatomy_label} + {surface_label}"),
                &staging,
                !a.no_figures,
            )
            .map_err(|e| super::shown(&staged, e))?,
        );
    }
    staged.commit()?;
    println!("{}: {}", anatomy_label, summary(&result.outcome.report));
    let o = &result.outcome.report.openings;
    if o.loops.len() > 1 {
        println!(
            "{}: {} openings; the rim is opening {} (nearest the {}), {} capped with {} triangles",
            surface_label,
            o.loops.len(),
            o.rim,
            match o.chosen_by {
                RimChoice::RimNear => "--rim-near point",
                _ => "rim landmarks",
            },
            o.cap_vertices,
            o.cap_triangles
        );
    }
    if let Some(t) = &result.transfer {
        println!(
            "transferred {} points into {} in {:.2} s",
            t.points, t.surface, t.seconds
        );
    }
    for p in &written {
        println!("wrote {}", staged.shown(p).display());
    }
    progress(|| format!("done in {:.2} s", start.elapsed().as_secs_f64()));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_parse_with_or_without_spaces() {
        assert_eq!(
            parse_point("1,2.5,-3").unwrap(),
            Point3::new(1.0, 2.5, -3.0)
        );
        assert_eq!(
            parse_point(" 1, 2 ,3e1 ").unwrap(),
            Point3::new(1.0, 2.0, 30.0)
        );
        for bad in ["1,2", "1,2,3,4", "1,,3", "a,b,c", "", "1 2 3"] {
            let e = parse_point(bad).unwrap_err();
            assert!(e.contains("expected X,Y,Z"), "{bad}: {e}");
        }
        assert!(parse_point("1,nan,3").unwrap_err().contains("not finite"));
        assert!(parse_point("inf,0,3").unwrap_err().contains("not finite"));
    }

    #[test]
    fn micrometres_keep_three_significant_digits_when_small() {
        assert_eq!(micrometres(1.23456), "1.235");
        assert_eq!(micrometres(0.0), "0.000");
        assert_eq!(micrometres(0.000148), "1.48e-4");
    }

    #[test]
    fn a_mesh_without_cells_gets_vertex_cells() {
        let m = CellMesh::from_points(vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0)]);
        let v = with_vertex_cells(&m);
        assert_eq!(v.num_cells(), 2);
        assert!(
            v.cells()
                .all(|(t, vs)| t == CellType::Vertex && vs.len() == 1)
        );
        let mut tri = CellMesh::from_points(vec![Point3::origin(); 3]);
        tri.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(matches!(with_vertex_cells(&tri), Cow::Borrowed(_)));
    }
}
