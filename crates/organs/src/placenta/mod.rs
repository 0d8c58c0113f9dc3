//! The placenta pipeline (ALGORITHMS 2): flatten a tet mesh of the placenta
//! onto a template by minimizing
//!
//! ```text
//! phi(X, theta) = sum_{m in boundary} A_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! ```
//!
//! (`A_m` normalized boundary vertex areas, `V_k` normalized rest volumes,
//! `D` the symmetric Dirichlet energy), flip-free, then evaluate the map and
//! pull images into the template.
//!
//! [`flatten`] runs everything; the steps are public so that a pipeline can
//! be composed from code:
//!
//! 1. [`prepare_mesh`]: validate, fix tet orientation (reported);
//! 2. [`parcellation::parcellate`]: fetal side, maternal side and margin;
//! 3. [`align::align`]: PCA frame, fetal side up (+z);
//! 4. [`estimate::estimate`]: initial `h` / radii from the mesh alone;
//! 5. [`optimize`]: projected Newton (default) or gradient descent, one
//!    stage per template (the single plane starts from the planes result);
//! 6. [`evaluate`]: the figures of ALGORITHMS 2.6;
//! 7. [`pullback`]: images into the template grid.

pub mod align;
pub mod error;
pub mod estimate;
pub mod parcellation;
pub mod pullback;

use crate::{ConfigError, OrganError, Requirement};
use align::{Alignment, TransformReport, align};
pub use error::{PlacentaError, PullbackError};
use estimate::{Estimates, estimate, estimate_with_thickness};
use parcellation::{Parcellation, ParcellationConfig, ParcellationSummary, parcellate};
use pullback::{PullbackTable, TemplateGrid};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Instant;
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::{Field, TetMesh};
use unfold_param::energy::SymmetricDirichlet;
use unfold_param::metrics::{
    Summary, dirichlet_excess_percent, inverted_count, log2_area_ratio, log2_det_j,
    log2_edge_ratio, min_det_j, symmetric_dirichlet, template_matching_error,
};
use unfold_param::template::{Ellipsoid, LABEL_INTERIOR, ParallelPlanes, SinglePlane};
use unfold_param::{
    Executor, GradientDescent, Iteration, Objective, ParamMesh, ProjectedNewton, SolveReport,
    Solver, StopReason, Stopping, Template, TemplateTerm,
};

/// The canonical templates (ALGORITHMS 2.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TemplateKind {
    /// Two parallel planes `z = +-h` (fetal up); the paper's recommendation.
    #[default]
    Planes,
    /// An axis-aligned ellipsoid with radii `(rx, ry, rz)`.
    Ellipsoid,
    /// The maternal side on `z = -h`, the fetal side free (started from the
    /// converged planes).
    SinglePlane,
}

impl TemplateKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            TemplateKind::Planes => "planes",
            TemplateKind::Ellipsoid => "ellipsoid",
            TemplateKind::SinglePlane => "single-plane",
        }
    }
}

/// The optimizers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Projected Newton with a sparse Cholesky factorization (default).
    #[default]
    Newton,
    /// Gradient descent with the injective line search (the paper's
    /// Algorithm 1; a baseline, thousands of iterations).
    Gd,
}

impl SolverKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Newton => "newton",
            SolverKind::Gd => "gd",
        }
    }

    /// The default iteration limit: 200 for Newton, 100,000 for gradient
    /// descent.
    pub fn default_max_iterations(self) -> usize {
        match self {
            SolverKind::Newton => 200,
            SolverKind::Gd => 100_000,
        }
    }
}

/// Settings of the placenta pipeline; every default from ALGORITHMS 2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// The template (default parallel planes).
    pub template: TemplateKind,
    /// Weight `lambda` of the distortion term (default 1; the paper finds
    /// 0.1..5 alike).
    pub lambda: f64,
    /// The optimizer (default projected Newton).
    pub solver: SolverKind,
    /// Stop when `|grad phi|_F < grad_tol` (default 1e-4).
    pub grad_tol: f64,
    /// Iteration limit per stage (default: the solver's).
    pub max_iterations: Option<usize>,
    /// Time limit per stage, seconds (default none).
    pub max_seconds: Option<f64>,
    /// Boundary parcellation settings (margin, voxel size, ...). Its
    /// `voxel_mm` is also the voxel of `template_error_voxels`.
    pub parcellation: ParcellationConfig,
    /// Half the placenta thickness (`h`, `rz`) when known from the
    /// segmentation (the 95th percentile of its distance transform,
    /// ALGORITHMS 2.4, see `unfold_mesh::mask::inside_distance_quantile`);
    /// `None` (the default): estimated from the mesh.
    pub half_thickness_mm: Option<f64>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            template: TemplateKind::Planes,
            lambda: 1.0,
            solver: SolverKind::Newton,
            grad_tol: 1e-4,
            max_iterations: None,
            max_seconds: None,
            parcellation: ParcellationConfig::default(),
            half_thickness_mm: None,
        }
    }
}

impl Config {
    /// Checks every value; the error names the offending one.
    pub fn validate(&self) -> Result<(), OrganError> {
        OrganError::check_positive(&[("lambda", self.lambda), ("grad_tol", self.grad_tol)])?;
        if let Some(n) = self.max_iterations {
            ConfigError::check("max_iterations", n as f64, Requirement::CountAtLeast(1))?;
        }
        if let Some(s) = self.max_seconds
            && (s.is_nan() || s <= 0.0)
        {
            return Err(ConfigError {
                name: "max_seconds",
                value: s,
                requirement: Requirement::Positive,
            }
            .into());
        }
        if let Some(h) = self.half_thickness_mm {
            ConfigError::check("half_thickness_mm", h, Requirement::Positive)?;
        }
        Ok(self.parcellation.validate()?)
    }

    fn stopping(&self) -> Stopping {
        Stopping {
            grad_tol: self.grad_tol,
            max_iterations: self
                .max_iterations
                .unwrap_or(self.solver.default_max_iterations()),
            max_seconds: self.max_seconds.unwrap_or(f64::INFINITY),
            ..Stopping::default()
        }
    }

    fn solver(&self) -> Box<dyn Solver> {
        match self.solver {
            SolverKind::Newton => Box::new(ProjectedNewton::default()),
            SolverKind::Gd => Box::new(GradientDescent),
        }
    }
}

/// Receives the pipeline's progress (for progress bars and logs). Every
/// method has an empty default.
pub trait PipelineObserver {
    /// A step starts ("parcellation", "optimization (planes)", ...).
    fn stage(&mut self, _name: &str) {}
    /// An optimizer iteration of the current stage.
    fn iteration(&mut self, _it: &Iteration) {}
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct Quiet;

impl PipelineObserver for Quiet {}

/// The input mesh after [`prepare_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedMesh {
    /// The mesh, every tet positively oriented.
    pub mesh: TetMesh,
    /// Tets whose vertex order was swapped to orient them positively.
    pub reoriented_tets: usize,
}

/// Checks that `mesh` is a usable placenta mesh and orients its tets
/// positively (a repair that is reported, not an error): it must have tets,
/// finite coordinates, no degenerate tets, one connected component, a
/// manifold boundary and no unused vertices.
///
/// # Errors
/// [`PlacentaError::NoTetrahedra`] for a mesh without tets (a surface
/// mesh); `Mesh` with the first validation problem otherwise.
pub fn prepare_mesh(mesh: &TetMesh) -> Result<PreparedMesh, OrganError> {
    if mesh.tets.is_empty() {
        return Err(PlacentaError::NoTetrahedra.into());
    }
    unfold_mesh::geometry::check_finite(&mesh.positions)?;
    let mut m = mesh.clone();
    let reoriented_tets = m.orient()?;
    m.validate()?;
    Ok(PreparedMesh {
        mesh: m,
        reoriented_tets,
    })
}

/// Normalized barycentric boundary vertex areas `A_m` (sum 1) over the
/// parcellated boundary (every vertex with a label other than interior),
/// per volume vertex (0 elsewhere).
pub fn boundary_weights(parcellation: &Parcellation) -> Vec<f64> {
    let areas = unfold_mesh::geometry::vertex_areas(&parcellation.boundary.surface);
    let mut w = vec![0.0; parcellation.labels.len()];
    for (&v, a) in parcellation.boundary.to_volume.iter().zip(areas) {
        if parcellation.labels[v as usize] != LABEL_INTERIOR {
            w[v as usize] = a;
        }
    }
    let total: f64 = w.iter().sum();
    if total > 0.0 {
        w.iter_mut().for_each(|x| *x /= total);
    }
    w
}

/// One optimization stage.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageReport {
    /// The template of the stage.
    pub template: &'static str,
    /// Template parameters at the start (named).
    pub theta_initial: BTreeMap<&'static str, f64>,
    /// Template parameters at the end (named).
    pub theta: BTreeMap<&'static str, f64>,
    /// The solver's report.
    pub solve: SolveReport,
}

/// The result of [`optimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Optimized {
    /// Mapped positions, flat (`3 n`), template frame.
    pub x: Vec<f64>,
    /// Final template parameters.
    pub theta: Vec<f64>,
    /// Initial template parameters of the first stage.
    pub theta_initial: Vec<f64>,
    /// One entry per stage.
    pub stages: Vec<StageReport>,
}

fn named(names: &[&'static str], theta: &[f64]) -> BTreeMap<&'static str, f64> {
    names.iter().copied().zip(theta.iter().copied()).collect()
}

/// The template object of a kind, for the final stage.
pub fn template_of(kind: TemplateKind) -> Box<dyn Template> {
    match kind {
        TemplateKind::Planes => Box::new(ParallelPlanes::default()),
        TemplateKind::Ellipsoid => Box::new(Ellipsoid::default()),
        TemplateKind::SinglePlane => Box::new(SinglePlane::default()),
    }
}

/// The initial parameters of a template from the estimates (ALGORITHMS
/// 2.4): `[h]` for planes and single plane, `[rx, ry, rz]` for the
/// ellipsoid.
pub fn initial_theta(kind: TemplateKind, e: &Estimates) -> Vec<f64> {
    match kind {
        TemplateKind::Planes | TemplateKind::SinglePlane => vec![e.half_thickness_mm],
        TemplateKind::Ellipsoid => vec![e.rx_mm, e.ry_mm, e.half_thickness_mm],
    }
}

/// The fixed data of an optimization: the rest mesh, the boundary labels
/// and the template weights `A_m` (per vertex).
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// Rest data of the tet mesh.
    pub mesh: &'a ParamMesh,
    /// Per vertex labels ([`LABEL_INTERIOR`], fetal, maternal, margin).
    pub labels: &'a [u8],
    /// Per vertex template weights (normalized boundary areas).
    pub weights: &'a [f64],
}

/// Runs one stage: minimizes `phi` for `template` from `x`, `theta`.
fn stage(
    problem: &Problem<'_>,
    config: &Config,
    template: &dyn Template,
    x: &mut [f64],
    theta: &mut [f64],
    observer: &mut dyn PipelineObserver,
) -> Result<StageReport, OrganError> {
    observer.stage(&format!("optimization ({})", template.name()));
    let term = TemplateTerm {
        template,
        labels: problem.labels,
        weights: problem.weights,
    };
    let mut objective = Objective::new(
        problem.mesh,
        &SymmetricDirichlet,
        config.lambda,
        Some(term),
        &[],
    )?;
    let theta_initial = named(&template.parameter_names(), theta);
    let mut forward = |it: &Iteration| observer.iteration(it);
    let solver = config.solver();
    let solve = Executor::new(solver.as_ref())
        .stopping(config.stopping())
        .observer(&mut forward)
        .run(&mut objective, x, theta)?;
    Ok(StageReport {
        template: template.name(),
        theta_initial,
        theta: named(&template.parameter_names(), theta),
        solve,
    })
}

/// Minimizes `phi` from `x0` (aligned rest positions, flat) for the
/// configured template: one stage, or two for the single plane (parallel
/// planes first, then the single plane with `h` fixed at the planes'
/// value). `theta0` as [`initial_theta`].
///
/// # Errors
/// `Config` for bad settings; `Param` when the objective cannot be set up
/// or the solver fails.
pub fn optimize(
    problem: &Problem<'_>,
    config: &Config,
    x0: Vec<f64>,
    theta0: Vec<f64>,
    observer: &mut dyn PipelineObserver,
) -> Result<Optimized, OrganError> {
    config.validate()?;
    let mut x = x0;
    let mut theta = theta0.clone();
    let mut stages = Vec::new();
    if config.template == TemplateKind::SinglePlane {
        let planes = ParallelPlanes::default();
        stages.push(stage(
            problem, config, &planes, &mut x, &mut theta, observer,
        )?);
    }
    let template = template_of(config.template);
    stages.push(stage(
        problem,
        config,
        template.as_ref(),
        &mut x,
        &mut theta,
        observer,
    )?);
    Ok(Optimized {
        x,
        theta,
        theta_initial: theta0,
        stages,
    })
}

/// Boundary vertex counts by side.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoundaryReport {
    /// Fetal vertices.
    pub fetal: usize,
    /// Maternal vertices.
    pub maternal: usize,
    /// Margin vertices.
    pub margin: usize,
    /// The parcellation's details.
    pub parcellation: ParcellationSummary,
}

/// The input, as the pipeline saw it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InputReport {
    /// Vertices.
    pub vertices: usize,
    /// Tets.
    pub tets: usize,
    /// Tets whose orientation was repaired.
    pub reoriented_tets: usize,
    /// Volume, mm^3.
    pub volume_mm3: f64,
}

/// Seconds per step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Timings {
    /// Validation and orientation.
    pub prepare: f64,
    /// Parcellation.
    pub parcellation: f64,
    /// Alignment and initial estimates.
    pub initialization: f64,
    /// Optimization (all stages).
    pub optimization: f64,
    /// Evaluation.
    pub evaluation: f64,
}

/// `report.json` (ALGORITHMS 2.6).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The template ("planes", "ellipsoid", "single-plane").
    pub template: &'static str,
    /// `lambda`.
    pub lambda: f64,
    /// The solver ("newton", "gd").
    pub solver: &'static str,
    /// Iterations, all stages.
    pub iterations: usize,
    /// Wall-clock seconds of the whole pipeline.
    pub seconds: f64,
    /// Whether the last stage converged.
    pub converged: bool,
    /// Why the last stage stopped.
    pub stop_reason: StopReason,
    /// Final `phi`.
    pub objective: f64,
    /// Final `|grad phi|_F`.
    pub grad_norm: f64,
    /// `sqrt(sum_m A_m T(x_m, theta))`, mm.
    pub template_error_mm: f64,
    /// The same in voxels of `voxel_mm`.
    pub template_error_voxels: f64,
    /// The voxel size, mm.
    pub voxel_mm: f64,
    /// `(sum V_k D(J_k) - 6) / 6 * 100`.
    pub dirichlet_excess_percent: f64,
    /// Smallest `det J`.
    pub min_det_j: f64,
    /// Tets with `det J <= 0` (0 by construction).
    pub inverted_tets: usize,
    /// Final template parameters, mm (`h`, or `rx`, `ry`, `rz`).
    pub theta: BTreeMap<&'static str, f64>,
    /// Initial template parameters (ALGORITHMS 2.4), mm.
    pub theta_initial: BTreeMap<&'static str, f64>,
    /// The mesh-only estimates behind `theta_initial`.
    pub estimates: Estimates,
    /// Per tet `log2 det J`.
    pub log2_det_j: Option<Summary>,
    /// Per edge `log2(|x_ij| / |z_ij|)`.
    pub log2_edge_ratio: Option<Summary>,
    /// Per boundary triangle `log2(area ratio)`.
    pub log2_area_ratio: Option<Summary>,
    /// Boundary vertex counts.
    pub boundary: BoundaryReport,
    /// Input to template frame.
    pub transform: TransformReport,
    /// The input.
    pub input: InputReport,
    /// One entry per optimization stage.
    pub stages: Vec<StageReport>,
    /// Seconds per step.
    pub timings: Timings,
}

/// Everything [`flatten`] produces.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The input (tets oriented) with the point array `side` (0 interior, 1
    /// fetal, 2 maternal, 3 margin).
    pub original: TetMesh,
    /// The mapped mesh in the template frame (fetal side up), point array
    /// `side`, cell arrays `log2_det_j` and `sym_dirichlet`.
    pub flattened: TetMesh,
    /// Per vertex labels (as `side`).
    pub labels: Vec<u8>,
    /// The parcellation.
    pub parcellation: Parcellation,
    /// Input to template frame.
    pub alignment: Alignment,
    /// Final template parameters.
    pub theta: Vec<f64>,
    /// The report.
    pub report: Report,
}

impl Outcome {
    /// The pull-back table of a grid covering the flattened mesh at
    /// `spacing` mm (ALGORITHMS 2.7): voxel -> source point in the input
    /// frame, to apply to every image and frame.
    ///
    /// # Errors
    /// As [`TemplateGrid::covering`] and [`PullbackTable::new`].
    pub fn pullback_table(&self, spacing: [f64; 3]) -> Result<PullbackTable, PullbackError> {
        let grid = TemplateGrid::covering(&self.flattened.positions, spacing)?;
        PullbackTable::new(
            grid,
            &self.flattened.positions,
            &self.flattened.tets,
            &self.original.positions,
        )
    }
}

fn side_field(labels: &[u8]) -> Field {
    Field::labels("side", labels.iter().map(|&l| i32::from(l)).collect())
}

/// The figures of ALGORITHMS 2.6 for a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// `sqrt(sum_m A_m T(x_m, theta))`, mm.
    pub template_error_mm: f64,
    /// Dirichlet excess, percent.
    pub dirichlet_excess_percent: f64,
    /// Smallest `det J`.
    pub min_det_j: f64,
    /// Tets with `det J <= 0`.
    pub inverted_tets: usize,
    /// Per tet `log2 det J`.
    pub log2_det_j: Vec<f64>,
    /// Per tet `D(J)` (symmetric Dirichlet).
    pub sym_dirichlet: Vec<f64>,
    /// Per edge `log2(|x_ij| / |z_ij|)`.
    pub log2_edge_ratio: Vec<f64>,
    /// Per boundary triangle `log2(area ratio)`.
    pub log2_area_ratio: Vec<f64>,
}

/// Evaluates a map (ALGORITHMS 2.6).
pub fn evaluate(
    mesh: &ParamMesh,
    parcellation: &Parcellation,
    template: &dyn Template,
    weights: &[f64],
    x: &[f64],
    theta: &[f64],
) -> Evaluation {
    let mapped: Vec<Point3<f64>> = x
        .chunks_exact(3)
        .map(|c| Point3::new(c[0], c[1], c[2]))
        .collect();
    let boundary = &parcellation.boundary;
    let tris: Vec<[u32; 3]> = boundary
        .surface
        .triangles
        .iter()
        .map(|t| t.map(|v| boundary.to_volume[v as usize]))
        .collect();
    Evaluation {
        template_error_mm: template_matching_error(
            template,
            &parcellation.labels,
            x,
            3,
            weights,
            theta,
        ),
        dirichlet_excess_percent: dirichlet_excess_percent(mesh, x),
        min_det_j: min_det_j(mesh, x),
        inverted_tets: inverted_count(mesh, x),
        log2_det_j: log2_det_j(mesh, x),
        sym_dirichlet: symmetric_dirichlet(mesh, x),
        log2_edge_ratio: log2_edge_ratio(mesh, x),
        log2_area_ratio: log2_area_ratio(&mesh.rest, &mapped, &tris),
    }
}

/// Runs the whole pipeline quietly; see [`flatten_with`].
///
/// # Errors
/// As [`flatten_with`].
pub fn flatten(mesh: &TetMesh, config: &Config) -> Result<Outcome, OrganError> {
    flatten_with(mesh, config, &mut Quiet)
}

/// Runs the whole pipeline on a placenta tet mesh (millimetres, scanner
/// frame), reporting progress to `observer`. Not converging within the
/// limits is not an error (`report.converged` says so).
///
/// # Errors
/// `Config` for bad settings; `Placenta` / `Mesh` for an unusable mesh (no
/// tets, NaN, degenerate tets, several components, ...); `Placenta` (a
/// parcellation variant of [`PlacentaError`]) when the boundary has no two
/// sides; `Param` when the optimization fails.
pub fn flatten_with(
    mesh: &TetMesh,
    config: &Config,
    observer: &mut dyn PipelineObserver,
) -> Result<Outcome, OrganError> {
    let start = Instant::now();
    config.validate()?;
    observer.stage("validation");
    let prepared = prepare_mesh(mesh)?;
    let prepare_seconds = start.elapsed().as_secs_f64();
    flatten_prepared_impl(prepared, config, observer, start, prepare_seconds)
}

/// [`flatten_with`] for a mesh already checked by [`prepare_mesh`] (so a
/// caller that validated the input up front does not pay for it twice).
///
/// # Errors
/// As [`flatten_with`], except the mesh checks.
pub fn flatten_prepared_with(
    prepared: PreparedMesh,
    config: &Config,
    observer: &mut dyn PipelineObserver,
) -> Result<Outcome, OrganError> {
    config.validate()?;
    flatten_prepared_impl(prepared, config, observer, Instant::now(), 0.0)
}

fn flatten_prepared_impl(
    prepared: PreparedMesh,
    config: &Config,
    observer: &mut dyn PipelineObserver,
    start: Instant,
    prepare_seconds: f64,
) -> Result<Outcome, OrganError> {
    let mut timings = Timings {
        prepare: prepare_seconds,
        ..Timings::default()
    };
    let rest = prepared.mesh;

    observer.stage("parcellation");
    let t = Instant::now();
    let parcellation = parcellate(&rest, &config.parcellation)?;
    let labels = parcellation.labels.clone();
    let weights = boundary_weights(&parcellation);
    timings.parcellation = t.elapsed().as_secs_f64();

    observer.stage("initialization");
    let t = Instant::now();
    let alignment = align(&rest.positions, &labels, &weights)?;
    let mut is_boundary = vec![false; rest.num_vertices()];
    for &v in &parcellation.boundary.to_volume {
        is_boundary[v as usize] = true;
    }
    let estimates = match config.half_thickness_mm {
        None => estimate(&rest, &parcellation.boundary.surface, &is_boundary)?,
        Some(h) => estimate_with_thickness(&rest, &parcellation.boundary.surface, h)?,
    };
    let pmesh = ParamMesh::from_tets(&rest)?;
    let x0: Vec<f64> = rest
        .positions
        .iter()
        .flat_map(|p| {
            let q = alignment.apply(p);
            [q.x, q.y, q.z]
        })
        .collect();
    let theta0 = initial_theta(config.template, &estimates);
    timings.initialization = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let problem = Problem {
        mesh: &pmesh,
        labels: &labels,
        weights: &weights,
    };
    let opt = optimize(&problem, config, x0, theta0, observer)?;
    timings.optimization = t.elapsed().as_secs_f64();

    observer.stage("evaluation");
    let t = Instant::now();
    let template = template_of(config.template);
    let eval = evaluate(
        &pmesh,
        &parcellation,
        template.as_ref(),
        &weights,
        &opt.x,
        &opt.theta,
    );
    let names = template.parameter_names();
    let last = opt
        .stages
        .last()
        .map(|s| s.solve)
        .ok_or(PlacentaError::NoStage)?;
    let mut original = rest.clone();
    original.add_point_field(side_field(&labels))?;
    let mut flattened = TetMesh::new(
        opt.x
            .chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect(),
        rest.tets.clone(),
    );
    flattened.add_point_field(side_field(&labels))?;
    flattened.add_cell_field(Field::scalars("log2_det_j", eval.log2_det_j.clone()))?;
    flattened.add_cell_field(Field::scalars("sym_dirichlet", eval.sym_dirichlet.clone()))?;
    timings.evaluation = t.elapsed().as_secs_f64();

    let s = &parcellation.summary;
    let report = Report {
        template: config.template.name(),
        lambda: config.lambda,
        solver: config.solver.name(),
        iterations: opt.stages.iter().map(|s| s.solve.iterations).sum(),
        seconds: start.elapsed().as_secs_f64(),
        converged: last.converged,
        stop_reason: last.reason,
        objective: last.value,
        grad_norm: last.grad_norm,
        template_error_mm: eval.template_error_mm,
        template_error_voxels: eval.template_error_mm / config.parcellation.voxel_mm,
        voxel_mm: config.parcellation.voxel_mm,
        dirichlet_excess_percent: eval.dirichlet_excess_percent,
        min_det_j: eval.min_det_j,
        inverted_tets: eval.inverted_tets,
        theta: named(&names, &opt.theta),
        theta_initial: named(&names, &opt.theta_initial),
        estimates,
        log2_det_j: Summary::of(&eval.log2_det_j),
        log2_edge_ratio: Summary::of(&eval.log2_edge_ratio),
        log2_area_ratio: Summary::of(&eval.log2_area_ratio),
        boundary: BoundaryReport {
            fetal: s.fetal,
            maternal: s.maternal,
            margin: s.margin,
            parcellation: *s,
        },
        transform: alignment.report(),
        input: InputReport {
            vertices: rest.num_vertices(),
            tets: rest.num_tets(),
            reoriented_tets: prepared.reoriented_tets,
            volume_mm3: estimates.volume_mm3,
        },
        stages: opt.stages,
        timings,
    };
    Ok(Outcome {
        original,
        flattened,
        labels,
        parcellation,
        alignment,
        theta: opt.theta,
        report,
    })
}
