//! `unfold mitral --anterior AL --posterior PL --annulus RING -o DIR`: the
//! mitral valve laid out in 2D (ALGORITHMS 4): the annulus first (arc
//! length and height above its plane), the leaflets below it, relaxed
//! flip-free; clinical maps and measurements.
//!
//! Inputs: two leaflet surfaces (triangle meshes with disk topology, any
//! surface format) and, optionally, the annulus ring (without it, the ring
//! is found from the places where the leaflets' boundaries meet,
//! [`annulus_from_leaflets`]): a closed polyline in a mesh file
//! (one polyline cell, or 2-point line segments that chain into one ring;
//! `.vtu`, `.vtp`, `.vtk`, `.obj`, ...), a file of points only
//! (in ring order), or a text file (`.csv`, `.txt`, `.xyz`) with one
//! `x,y,z` (or `x y z`) per line.
//!
//! Outputs in DIR: `valve3d.vtu` (both leaflets, anterior first, with every
//! map as a point or cell array), `valve2d.vtu` (the same at `(u, v, 0)`)
//! and `report.json`.
//!
//! `--series DIR`: the leaflets named `AL*` / `PL*` or `*anterior*` /
//! `*posterior*`, annulus files `*annulus*` (for every step or none),
//! paired by the rest of their names (`mitral_series.rs`); one output
//! set per step in `OUT/<step>/`, a summary table `OUT/series.csv` (and
//! `series.json`: `steps`, the same rows, and `provenance`, the run's, as a
//! single valve's report has) and the plot over the cycle
//! `OUT/figures/series.png`.

use super::choice::named;
use super::{AppError, at, organ};
use crate::app::run::StagedOutputs;
use crate::figures::FigureOptions;
use crate::figures::mitral::series::{SeriesPoint, series_plot};
use crate::io::{WriteOptions, atomic_write, read_mesh, write_mesh};
use crate::mesh::nalgebra::Point3;
use crate::mesh::{CellMesh, CellType, TriMesh};
use crate::organs::mitral::{
    AnnulusMode, Config, InitMode, LeafletLayout, Outcome, Pipeline, RelaxMode, Report, ValveInput,
    annulus_from_leaflets,
};
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `unfold mitral`.
#[derive(Debug, Args)]
#[command(
    after_help = "Writes DIR/valve3d.vtu, DIR/valve2d.vtu (arrays: leaflet, u_gradient, \
                  u_interval, checker, carpentier, area_energy, angle_energy, length_energy, \
                  coaptation, coaptation_distance_mm, tenting_mm, uv) and DIR/report.json; with \
                  --series, one such set per time step, DIR/series.csv and \
                  DIR/figures/series.png. Without --annulus the ring is found from the places \
                  where the leaflets' boundaries meet (the commissures)."
)]
pub struct MitralArgs {
    /// Do not write the PNG figures into DIR/figures/.
    #[arg(long)]
    no_figures: bool,
    /// Anterior leaflet (triangle mesh, disk topology).
    #[arg(long, value_name = "AL", required_unless_present = "series")]
    anterior: Option<PathBuf>,
    /// Posterior leaflet (triangle mesh, disk topology).
    #[arg(long, value_name = "PL", required_unless_present = "series")]
    posterior: Option<PathBuf>,
    /// Annulus ring: a closed polyline (mesh file) or x,y,z lines (.csv .txt
    /// .xyz); without it, found from the leaflets' shared boundary.
    #[arg(long, value_name = "RING")]
    annulus: Option<PathBuf>,
    /// A directory of time steps: leaflets named AL* / PL* or *anterior* /
    /// *posterior*, optional *annulus* files, paired by the rest of the name.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["anterior", "posterior", "annulus"])]
    series: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// How the annulus is laid out.
    #[arg(long, value_parser = named::<AnnulusMode>(), default_value = "landmark")]
    annulus_mode: AnnulusMode,
    /// Initial leaflet layout.
    #[arg(long, value_parser = named::<InitMode>(), default_value = "auto")]
    init: InitMode,
    /// Relaxation.
    #[arg(long, value_parser = named::<RelaxMode>(), default_value = "sd")]
    relax: RelaxMode,
    /// Spring relaxation: number of explicit steps.
    #[arg(long, value_name = "N", default_value_t = 5)]
    iterations: usize,
    /// Spring relaxation: step scale (smaller is safer).
    #[arg(long, value_name = "S")]
    step_scale: Option<f64>,
    /// Coaptation threshold, mm (the zone: closer than this to the other leaflet).
    #[arg(long, value_name = "MM", default_value_t = 2.0)]
    coaptation_mm: f64,
    /// Distance within which a leaflet boundary vertex lies on the ring, mm.
    #[arg(long, value_name = "MM")]
    tolerance_mm: Option<f64>,
    /// Second cut at the posteromedial commissure (the leaflets drawn apart there).
    #[arg(long)]
    cut_posteromedial: bool,
}

impl MitralArgs {
    /// The settings of the flags.
    fn settings(&self) -> MitralSettings {
        MitralSettings {
            annulus_mode: self.annulus_mode,
            init: self.init,
            relax: self.relax,
            iterations: self.iterations,
            step_scale: self.step_scale,
            coaptation_mm: self.coaptation_mm,
            tolerance_mm: self.tolerance_mm,
            cut_posteromedial: self.cut_posteromedial,
        }
    }

    /// The pipeline of the flags ([`MitralSettings::pipeline`]).
    fn pipeline(&self) -> Result<Pipeline, AppError> {
        self.settings().pipeline()
    }
}

/// The settings of `unfold mitral` other than its files (the flags'
/// defaults: [`MitralSettings::default`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MitralSettings {
    /// `--annulus-mode`.
    pub annulus_mode: AnnulusMode,
    /// `--init`.
    pub init: InitMode,
    /// `--relax`.
    pub relax: RelaxMode,
    /// `--iterations` (spring relaxation steps).
    pub iterations: usize,
    /// `--step-scale` (none: the library's).
    pub step_scale: Option<f64>,
    /// `--coaptation-mm`.
    pub coaptation_mm: f64,
    /// `--tolerance-mm` (none: the library's).
    pub tolerance_mm: Option<f64>,
    /// `--cut-posteromedial`.
    pub cut_posteromedial: bool,
}

impl Default for MitralSettings {
    /// The command line's defaults: landmark annulus, auto init, sd
    /// relaxation, 5 spring steps, coaptation 2 mm.
    fn default() -> Self {
        MitralSettings {
            annulus_mode: AnnulusMode::Landmark,
            init: InitMode::Auto,
            relax: RelaxMode::Sd,
            iterations: 5,
            step_scale: None,
            coaptation_mm: 2.0,
            tolerance_mm: None,
            cut_posteromedial: false,
        }
    }
}

impl MitralSettings {
    /// The pipeline of the settings: the layout mode as the initializer,
    /// the published pieces otherwise, every setting checked.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag out of range.
    pub fn pipeline(&self) -> Result<Pipeline, AppError> {
        let init = LeafletLayout { mode: self.init };
        Ok(Pipeline::new().initializer(init).config(self.config()?))
    }

    fn config(&self) -> Result<Config, AppError> {
        let mut c = Config {
            annulus_mode: self.annulus_mode,
            relax: self.relax,
            cut_posteromedial: self.cut_posteromedial,
            ..Config::default()
        };
        c.spring.iterations = self.iterations;
        if let Some(s) = self.step_scale {
            if !(s.is_finite() && s > 0.0) {
                return Err(AppError::Usage(format!(
                    "--step-scale must be a finite number > 0, got {s}"
                )));
            }
            c.spring.step_scale = s;
        }
        if !(self.coaptation_mm.is_finite() && self.coaptation_mm > 0.0) {
            return Err(AppError::Usage(format!(
                "--coaptation-mm must be a finite number > 0, got {}",
                self.coaptation_mm
            )));
        }
        c.maps.coaptation_mm = self.coaptation_mm;
        if let Some(t) = self.tolerance_mm {
            if !(t.is_finite() && t > 0.0) {
                return Err(AppError::Usage(format!(
                    "--tolerance-mm must be a finite number > 0, got {t}"
                )));
            }
            c.tolerance_mm = t;
        }
        c.validate().map_err(|e| AppError::Usage(e.to_string()))?;
        Ok(c)
    }
}

/// A leaflet file as a triangle mesh (surface cells only; lines and points
/// are dropped, volume cells are an error).
pub(crate) fn read_leaflet(path: &Path) -> Result<TriMesh, AppError> {
    leaflet_of(&read_mesh(path)?, path)
}

/// The leaflet in `cells` (named `path` in messages) as a triangle mesh:
/// its surface cells and point arrays (lines and points are dropped).
///
/// # Errors
/// Volume cells, no triangles, or cells that do not make a triangle mesh,
/// at `path`.
pub fn leaflet_of(cells: &CellMesh, path: &Path) -> Result<TriMesh, AppError> {
    let mut surface = CellMesh::from_points(cells.positions.clone());
    let mut volume = 0;
    for (t, vs) in cells.cells() {
        match t.dimension() {
            2 => surface.push_cell(t, vs),
            3 => volume += 1,
            _ => {}
        }
    }
    if volume > 0 {
        return Err(at(
            path,
            format!("has {volume} volume cell(s); a leaflet is a triangle surface"),
        ));
    }
    if surface.num_cells() == 0 {
        return Err(at(
            path,
            "has no triangles; a leaflet is a triangle surface",
        ));
    }
    surface.point_data = cells.point_data.clone();
    surface.to_tri_mesh().map_err(|e| at(path, e))
}

/// Parses `x,y,z` (or whitespace-separated) lines; blank lines, `#`
/// comments and one non-numeric header line are skipped.
fn parse_points(text: &str, path: &Path) -> Result<Vec<Point3<f64>>, AppError> {
    let mut points = Vec::new();
    let mut header_allowed = true;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        let nums: Result<Vec<f64>, _> = fields.iter().map(|f| f.parse::<f64>()).collect();
        match nums {
            Ok(v) if v.len() == 3 => {
                if !v.iter().all(|x| x.is_finite()) {
                    return Err(at(
                        path,
                        format!("line {}: a coordinate is not finite", i + 1),
                    ));
                }
                points.push(Point3::new(v[0], v[1], v[2]));
            }
            Ok(v) => {
                return Err(at(
                    path,
                    format!("line {}: expected 3 coordinates, found {}", i + 1, v.len()),
                ));
            }
            Err(_) if header_allowed => {}
            Err(_) => {
                return Err(at(
                    path,
                    format!("line {}: not three numbers: {line:?}", i + 1),
                ));
            }
        }
        header_allowed = false;
    }
    Ok(points)
}

/// The annulus ring's points in ring order.
pub(crate) fn read_ring(path: &Path) -> Result<Vec<Point3<f64>>, AppError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if matches!(ext.as_str(), "csv" | "txt" | "xyz") {
        let text = std::fs::read_to_string(path).map_err(|source| AppError::Fs {
            path: path.display().to_string(),
            source,
        })?;
        return parse_points(&text, path);
    }
    let cells = read_mesh(path)?;
    let lines = cells.polylines();
    match lines.len() {
        1 => Ok(lines[0]
            .iter()
            .map(|&v| cells.positions[v as usize])
            .collect()),
        0 => {
            let only_points = cells
                .cells()
                .all(|(t, _)| t == CellType::Vertex || t == CellType::PolyVertex);
            if only_points {
                Ok(cells.positions.clone())
            } else {
                Err(at(
                    path,
                    "has no polyline; the annulus ring is one closed polyline (or its points in order)",
                ))
            }
        }
        // Separate 2-point segments (as meshio and many tools write a
        // curve) are chained into the ring.
        n if lines.iter().all(|l| l.len() == 2) => {
            let segments: Vec<[u32; 2]> = lines.iter().map(|l| [l[0], l[1]]).collect();
            let order = crate::mesh::chain::chain_segments(&segments)
                .map_err(|e| at(path, format!("its {n} line segments are not one ring: {e}")))?;
            Ok(order.iter().map(|&v| cells.positions[v as usize]).collect())
        }
        n => Err(at(
            path,
            format!("has {n} polylines; the annulus ring is one closed polyline"),
        )),
    }
}

/// One valve's input files.
#[derive(Debug, Clone)]
pub(crate) struct ValveFiles {
    pub anterior: PathBuf,
    pub posterior: PathBuf,
    /// None: found from the leaflets.
    pub annulus: Option<PathBuf>,
}

impl ValveFiles {
    /// `anterior + posterior + annulus` (or `anterior + posterior (annulus
    /// from the leaflets)`), naming the inputs in errors and reports.
    fn label(&self) -> String {
        let ring = match &self.annulus {
            Some(r) => format!(" + {}", r.display()),
            None => " (annulus from the leaflets)".into(),
        };
        format!(
            "{} + {}{ring}",
            self.anterior.display(),
            self.posterior.display(),
        )
    }

    /// The input files (the annulus when given).
    fn paths(&self) -> Vec<&PathBuf> {
        let mut v = vec![&self.anterior, &self.posterior];
        v.extend(&self.annulus);
        v
    }

    /// The files as `out` will show them after its commit.
    fn shown(&self, out: &StagedOutputs) -> ValveFiles {
        ValveFiles {
            anterior: out.shown(&self.anterior),
            posterior: out.shown(&self.posterior),
            annulus: self.annulus.as_ref().map(|r| out.shown(r)),
        }
    }
}

/// The annulus ring of `files`: read from its file, or found from the
/// leaflets' shared boundary with `pipeline`'s tolerance (errors about
/// `label`).
fn ring_of(
    files: &ValveFiles,
    anterior: &TriMesh,
    posterior: &TriMesh,
    pipeline: &Pipeline,
    label: &str,
) -> Result<Vec<Point3<f64>>, AppError> {
    match &files.annulus {
        Some(path) => read_ring(path),
        None => annulus_from_leaflets(anterior, posterior, pipeline.settings().tolerance_mm)
            .map(|f| f.ring)
            .map_err(|e| organ(label, e)),
    }
}

/// Reads one valve and runs the pipeline; writes `valve3d.vtu`,
/// `valve2d.vtu`, `report.json` and (with `figures`) `figures/*.png` into
/// `dir`; the report names the inputs as they will be after `out`'s
/// commit.
pub(crate) fn run_valve(
    files: &ValveFiles,
    pipeline: &Pipeline,
    dir: &Path,
    figures: bool,
    out: &StagedOutputs,
) -> Result<Outcome, AppError> {
    let anterior = read_leaflet(&files.anterior)?;
    let posterior = read_leaflet(&files.posterior)?;
    let label = files.shown(out).label();
    let ring = ring_of(files, &anterior, &posterior, pipeline, &label)?;
    let outcome = map_valve(pipeline, &anterior, &posterior, &ring, &label)?;
    write_outcome(&outcome, dir, &label, figures)?;
    Ok(outcome)
}

/// Runs `pipeline` on one valve (named `label` in messages).
///
/// # Errors
/// The pipeline's, about `label` (settings as usage errors).
pub fn map_valve(
    pipeline: &Pipeline,
    anterior: &TriMesh,
    posterior: &TriMesh,
    annulus: &[Point3<f64>],
    label: &str,
) -> Result<Outcome, AppError> {
    pipeline
        .run(&ValveInput {
            anterior,
            posterior,
            annulus,
        })
        .map_err(|e| organ(label, e))
}

/// `report.json` with the inputs named: `inputs`, every key of the
/// library's [`Report`], `provenance` (the command line's or the Python
/// package's: a type parameter, so both write one layout).
#[derive(Serialize)]
pub struct FullReport<'a, P> {
    /// The inputs' names.
    pub inputs: &'a str,
    /// The library's report.
    #[serde(flatten)]
    pub report: &'a Report,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: P,
}

/// Writes one outcome's files into `dir` (created if missing), with its
/// figures in `dir/figures/` when `figures`.
pub(crate) fn write_outcome(
    outcome: &Outcome,
    dir: &Path,
    label: &str,
    figures: bool,
) -> Result<(), AppError> {
    super::ensure_dir(dir)?;
    let opts = WriteOptions::default();
    write_mesh(
        dir.join("valve3d.vtu"),
        &CellMesh::from(&outcome.valve3d),
        &opts,
    )?;
    write_mesh(
        dir.join("valve2d.vtu"),
        &CellMesh::from(&outcome.valve2d),
        &opts,
    )?;
    let path = dir.join("report.json");
    let json = serde_json::to_string_pretty(&FullReport {
        inputs: label,
        report: &outcome.report,
        provenance: crate::app::run::provenance::this_run(),
    })
    .map_err(|e| at(&path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&path, format!("{json}\n").as_bytes())?;
    if figures {
        let figs = crate::figures::mitral::figures(outcome, &FigureOptions::default())
            .map_err(|e| at(dir, e))?;
        super::write_figures(dir, &figs)?;
    }
    Ok(())
}

/// A one-paragraph summary of a report.
pub(crate) fn summary(r: &Report) -> String {
    format!(
        "annulus {:.1} mm (u extent {:.1} mm), saddle horn {:.2} mm, leaflets {:.0} + {:.0} mm^2 \
         ({:.0} mm^2 above the annulus plane); relax {} from {}/{}: mean energies area {:.3} -> \
         {:.3}, angle {:.3} -> {:.3}, length {:.3} -> {:.3}; {} flipped triangles; coaptation \
         {} vertices; {:.3} s",
        r.annulus_length_mm,
        r.u_extent_mm,
        r.saddle_horn_height_mm,
        r.leaflet_area_mm2.anterior,
        r.leaflet_area_mm2.posterior,
        r.area_above_plane_mm2,
        r.relax,
        r.init[0],
        r.init[1],
        r.distortion.initial.area,
        r.distortion.r#final.area,
        r.distortion.initial.angle,
        r.distortion.r#final.angle,
        r.distortion.initial.length,
        r.distortion.r#final.length,
        r.flipped_triangles,
        r.coaptation_vertices.within,
        r.seconds
    )
}

/// One row of the series table (`series.csv`, `series.json`): the
/// measurements of one step, its final and initial mean energies and its
/// coaptation counts.
#[derive(Serialize)]
struct SeriesRow {
    step: String,
    anterior: String,
    annulus_length_mm: f64,
    u_extent_mm: f64,
    anterior_area_mm2: f64,
    posterior_area_mm2: f64,
    saddle_horn_height_mm: f64,
    area_above_plane_mm2: f64,
    coaptation_vertices: usize,
    angle_energy: f64,
    area_energy: f64,
    length_energy: f64,
    flipped_triangles: usize,
    seconds: f64,
    initial_angle_energy: f64,
    initial_area_energy: f64,
    initial_length_energy: f64,
    coaptation_near_vertices: usize,
    coaptation_threshold_mm: f64,
    posterior: String,
    annulus: String,
}

impl SeriesRow {
    /// The row of step `step` from `files` and its report.
    fn new(step: &str, files: &ValveFiles, r: &Report) -> SeriesRow {
        let d = &r.distortion;
        SeriesRow {
            step: step.to_string(),
            anterior: files.anterior.display().to_string(),
            annulus_length_mm: r.annulus_length_mm,
            u_extent_mm: r.u_extent_mm,
            anterior_area_mm2: r.leaflet_area_mm2.anterior,
            posterior_area_mm2: r.leaflet_area_mm2.posterior,
            saddle_horn_height_mm: r.saddle_horn_height_mm,
            area_above_plane_mm2: r.area_above_plane_mm2,
            coaptation_vertices: r.coaptation_vertices.within,
            angle_energy: d.r#final.angle,
            area_energy: d.r#final.area,
            length_energy: d.r#final.length,
            flipped_triangles: r.flipped_triangles,
            seconds: r.seconds,
            initial_angle_energy: d.initial.angle,
            initial_area_energy: d.initial.area,
            initial_length_energy: d.initial.length,
            coaptation_near_vertices: r.coaptation_vertices.near,
            coaptation_threshold_mm: r.coaptation_vertices.threshold_mm,
            posterior: files.posterior.display().to_string(),
            annulus: files
                .annulus
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_else(|| "from the leaflets".into()),
        }
    }

    /// Its values in [`SERIES_COLUMNS`] order (file names with `,` as `_`).
    fn csv(&self) -> String {
        let file = |s: &str| s.replace(',', "_");
        [
            self.step.clone(),
            file(&self.anterior),
            self.annulus_length_mm.to_string(),
            self.u_extent_mm.to_string(),
            self.anterior_area_mm2.to_string(),
            self.posterior_area_mm2.to_string(),
            self.saddle_horn_height_mm.to_string(),
            self.area_above_plane_mm2.to_string(),
            self.coaptation_vertices.to_string(),
            self.angle_energy.to_string(),
            self.area_energy.to_string(),
            self.length_energy.to_string(),
            self.flipped_triangles.to_string(),
            self.seconds.to_string(),
            self.initial_angle_energy.to_string(),
            self.initial_area_energy.to_string(),
            self.initial_length_energy.to_string(),
            self.coaptation_near_vertices.to_string(),
            self.coaptation_threshold_mm.to_string(),
            file(&self.posterior),
            file(&self.annulus),
        ]
        .join(",")
    }

    /// The step's point of the plot over the cycle.
    fn point(&self) -> SeriesPoint {
        SeriesPoint {
            initial: [
                self.initial_area_energy,
                self.initial_angle_energy,
                self.initial_length_energy,
            ],
            r#final: [self.area_energy, self.angle_energy, self.length_energy],
            coaptation: [self.coaptation_vertices, self.coaptation_near_vertices],
        }
    }
}

/// The columns of `series.csv`: the first fourteen as before issue 22 (the
/// energies final), then the initial energies, the coaptation counts near
/// the zone and the threshold, the posterior and annulus files.
pub(crate) const SERIES_COLUMNS: [&str; 21] = [
    "step",
    "anterior_file",
    "annulus_length_mm",
    "u_extent_mm",
    "anterior_area_mm2",
    "posterior_area_mm2",
    "saddle_horn_height_mm",
    "area_above_plane_mm2",
    "coaptation_vertices",
    "angle_energy",
    "area_energy",
    "length_energy",
    "flipped_triangles",
    "seconds",
    "initial_angle_energy",
    "initial_area_energy",
    "initial_length_energy",
    "coaptation_near_vertices",
    "coaptation_threshold_mm",
    "posterior_file",
    "annulus_file",
];

/// `series.json`: the series table and the run's provenance (its run hash
/// lets a batch skip a series done before with the same inputs).
#[derive(Serialize)]
struct SeriesJson<'a> {
    /// One row per step, as `series.csv`.
    steps: &'a [SeriesRow],
    /// Version, command line, parameters, input hashes, start time.
    provenance: crate::app::run::provenance::Provenance,
}

impl MitralArgs {
    /// The mesh files read (leaflets and ring; none for a series), for the
    /// units hint.
    pub(crate) fn input_meshes(&self) -> Vec<PathBuf> {
        crate::app::run::units::mesh_inputs(&[&self.anterior, &self.posterior, &self.annulus])
    }
}

/// Runs `unfold mitral`.
pub fn run(a: &MitralArgs) -> Result<(), AppError> {
    let pipeline = a.pipeline()?;
    let out = a.output.as_path();
    if out.exists() && !out.is_dir() {
        return Err(at(
            out,
            "exists and is not a directory; -o needs a directory",
        ));
    }
    let Some(series) = &a.series else {
        let (Some(anterior), Some(posterior)) = (&a.anterior, &a.posterior) else {
            return Err(AppError::Usage(
                "give --anterior and --posterior (and --annulus, or it is found from the \
                 leaflets), or --series DIR"
                    .into(),
            ));
        };
        let files = ValveFiles {
            anterior: anterior.clone(),
            posterior: posterior.clone(),
            annulus: a.annulus.clone(),
        };
        check_not_inputs(out, &files.paths())?;
        let mut staged = StagedOutputs::new(files.paths());
        let dir = staged.dir(out)?;
        let outcome = run_valve(&files, &pipeline, &dir, !a.no_figures, &staged)
            .map_err(|e| super::shown(&staged, e))?;
        staged.commit()?;
        println!("{}", summary(&outcome.report));
        for f in ["valve3d.vtu", "valve2d.vtu", "report.json"] {
            println!("wrote {}", out.join(f).display());
        }
        return Ok(());
    };
    let steps: Vec<(String, ValveFiles)> = super::mitral_series::series_steps(series)?
        .into_iter()
        .enumerate()
        .map(|(i, s)| {
            (
                format!("step_{i:03}"),
                ValveFiles {
                    anterior: s.anterior,
                    posterior: s.posterior,
                    annulus: s.annulus,
                },
            )
        })
        .collect();
    // The whole series is staged: `out` holds all its steps or none.
    let mut staged = StagedOutputs::new(steps.iter().flat_map(|(_, f)| f.paths()));
    let staging = staged.dir(out)?;
    // Every step read first (the first unreadable file is the error; an
    // annulus not given is found from the leaflets), then the steps run in
    // parallel sharing their Newton layouts (`run_series`), then written in
    // order, stopping at the first failed step.
    let mut loaded = Vec::with_capacity(steps.len());
    for (name, files) in &steps {
        check_not_inputs(&out.join(name), &files.paths())?;
        let anterior = read_leaflet(&files.anterior)?;
        let posterior = read_leaflet(&files.posterior)?;
        let ring = ring_of(files, &anterior, &posterior, &pipeline, &files.label())?;
        loaded.push((anterior, posterior, ring));
    }
    let inputs: Vec<ValveInput<'_>> = loaded
        .iter()
        .map(|(anterior, posterior, annulus)| ValveInput {
            anterior,
            posterior,
            annulus,
        })
        .collect();
    let outcomes = pipeline.run_series(&inputs);
    let mut rows = Vec::with_capacity(steps.len());
    for ((name, files), outcome) in steps.iter().zip(outcomes) {
        let dir = staging.join(name);
        let label = files.label();
        let outcome = outcome.map_err(|e| organ(&label, e))?;
        write_outcome(&outcome, &dir, &label, !a.no_figures)
            .map_err(|e| super::shown(&staged, e))?;
        println!("{name}: {}", summary(&outcome.report));
        rows.push(SeriesRow::new(name, files, &outcome.report));
    }
    let mut csv = SERIES_COLUMNS.join(",");
    csv.push('\n');
    for r in &rows {
        csv.push_str(&r.csv());
        csv.push('\n');
    }
    atomic_write(staging.join("series.csv"), csv.as_bytes()).map_err(|e| staged.shown_error(e))?;
    let json = serde_json::to_string_pretty(&SeriesJson {
        steps: &rows,
        provenance: crate::app::run::provenance::this_run(),
    })
    .map_err(|e| at(out, format!("cannot serialize the series table: {e}")))?;
    atomic_write(staging.join("series.json"), format!("{json}\n").as_bytes())
        .map_err(|e| staged.shown_error(e))?;
    if !a.no_figures {
        let points: Vec<SeriesPoint> = rows.iter().map(SeriesRow::point).collect();
        let fig = series_plot(&points, &FigureOptions::default()).map_err(|e| at(out, e))?;
        super::write_figures(&staging, &[fig]).map_err(|e| super::shown(&staged, e))?;
    }
    staged.commit()?;
    println!(
        "wrote {} steps into {} and the table {}",
        rows.len(),
        out.display(),
        out.join("series.csv").display()
    );
    Ok(())
}

/// Refuses an output directory whose files would overwrite an input.
fn check_not_inputs(dir: &Path, inputs: &[&PathBuf]) -> Result<(), AppError> {
    let d = super::canonical(dir);
    for input in inputs {
        let c = super::canonical(input);
        for f in ["valve3d.vtu", "valve2d.vtu", "report.json"] {
            if d.join(f) == c {
                return Err(at(
                    input,
                    format!("is an input and would be overwritten by the output {f}"),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `unfold mitral` alone, to parse its flags.
    #[derive(clap::Parser)]
    struct Mitral {
        #[command(flatten)]
        args: MitralArgs,
    }

    #[test]
    fn settings_default_to_the_flags_defaults() {
        use clap::Parser;
        let m = Mitral::try_parse_from(["mitral", "--series", "d", "-o", "o"]).unwrap();
        assert_eq!(m.args.settings(), MitralSettings::default());
        let m = Mitral::try_parse_from([
            "mitral",
            "--series",
            "d",
            "-o",
            "o",
            "--relax",
            "spring",
            "--coaptation-mm",
            "3",
        ])
        .unwrap();
        assert_eq!(m.args.settings().relax, RelaxMode::Spring);
        assert_eq!(m.args.settings().coaptation_mm, 3.0);
    }

    #[test]
    fn ring_text_accepts_commas_spaces_comments_and_a_header() {
        let p = Path::new("ring.csv");
        let pts = parse_points("# ring\nx,y,z\n1,2,3\n4 5 6\n\n7;8;9\n", p).unwrap();
        assert_eq!(pts.len(), 3);
        assert_eq!(pts[1], Point3::new(4.0, 5.0, 6.0));
        let e = parse_points("1,2,3\n4,5\n", p).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("3 coordinates"), "{e}");
        let e = parse_points("1,2,3\nx,y,z\n", p).unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        let e = parse_points("1,2,nan\n", p).unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
    }
}
