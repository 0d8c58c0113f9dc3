//! The placenta pipeline as a value (ALGORITHMS 2): built from its pieces,
//! run on a tet mesh and the images to pull into the template.

use super::align::{Alignment, PcaAlignment};
use super::canonical::canonical_motion;
use super::config::Config;
use super::error::PullbackError;
use super::estimate::{estimate, estimate_with_thickness};
use super::evaluate::evaluate;
use super::images::{FlatImage, Image, check_images, pull_back};
use super::optimize::{Method, Problem, named, optimize};
use super::parcellation::{Parcellation, parcellate};
use super::prepare::{PreparedMesh, boundary_weights, prepare_mesh};
use super::pullback::{PullbackTable, TemplateGrid};
use super::report::{BoundaryReport, CanonicalReport, InputReport, Pieces, Report, Timings};
use super::solve_gates::{SolveInput, check_solve, resists_scaling};
use super::templates::{ParallelPlanes, PlacentaTemplate};
use crate::{OrganError, PipelineObserver};
use std::time::Instant;
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::{Field, TetMesh};
use unfold_param::energy::SymmetricDirichlet;
use unfold_param::metrics::Summary;
use unfold_param::{
    Constraints, DistortionEnergy, Initializer, LineSearch, ParamMesh, ProjectedNewton, Solver,
};

/// The placenta pipeline: its pieces and settings. [`Pipeline::new`] is the
/// published method (ALGORITHMS 2): the parallel-planes template, the
/// symmetric Dirichlet energy, the PCA alignment (fetal side up) as the
/// start, projected Newton with its Armijo line search. Each piece can be
/// replaced by a shipped one or by a method developer's own:
///
/// ```text
/// Pipeline::new()
///     .template(Ellipsoid::default())       // any PlacentaTemplate
///     .energy(Arap)                         // any DistortionEnergy
///     .initializer(PcaAlignment)            // any Initializer
///     .line_search(Backtracking::paper())   // any LineSearch
///     .solver(GradientDescent)              // any Solver
///     .config(Config { lambda: 2.0, ..Config::default() })
///     .run(&mesh, &images, &mut Quiet)?
/// ```
///
/// The pieces are trait objects, not type parameters: the command line,
/// the Python package and cohort manifests choose them at run time by name,
/// and one `Pipeline` type can hold any combination (see
/// `docs/ARCHITECTURE.md`).
#[derive(Debug)]
pub struct Pipeline {
    template: Box<dyn PlacentaTemplate>,
    energy: Box<dyn DistortionEnergy>,
    initializer: Box<dyn Initializer>,
    line_search: Option<Box<dyn LineSearch>>,
    solver: Box<dyn Solver>,
    config: Config,
}

impl Default for Pipeline {
    fn default() -> Self {
        Pipeline {
            template: Box::new(ParallelPlanes::default()),
            energy: Box::new(SymmetricDirichlet),
            initializer: Box::new(PcaAlignment),
            line_search: None,
            solver: Box::new(ProjectedNewton::default()),
            config: Config::default(),
        }
    }
}

/// Everything a run produces.
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
    /// Input to template frame: the rigid motion that best fits the initial
    /// map (for the default initializer exactly its alignment) followed by
    /// the canonical motion (ALGORITHMS 2.10), so that it maps the input
    /// into the frame of `flattened`.
    pub alignment: Alignment,
    /// Final template parameters.
    pub theta: Vec<f64>,
    /// The images in the template frame, in input order.
    pub images: Vec<FlatImage>,
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

/// The parcellation's Fiedler vector per vertex (ALGORITHMS 2.5: the
/// second eigenvector of the boundary's normalized affinity Laplacian,
/// whose sign splits fetal from maternal), signed so that maternal is
/// positive; 0 off the parcellated boundary.
fn fiedler_field(fiedler: &[f64]) -> Field {
    Field::scalars("fiedler", fiedler.to_vec())
}

impl Pipeline {
    /// The published pipeline (see the type's documentation).
    pub fn new() -> Self {
        Self::default()
    }

    /// The template the boundary is pulled onto.
    pub fn template(mut self, template: impl PlacentaTemplate + 'static) -> Self {
        self.template = Box::new(template);
        self
    }

    /// The distortion energy `D`.
    pub fn energy(mut self, energy: impl DistortionEnergy + 'static) -> Self {
        self.energy = Box::new(energy);
        self
    }

    /// The starting map. It is handed the side labels and the normalized
    /// boundary weights as [`Constraints`] (no pins).
    pub fn initializer(mut self, initializer: impl Initializer + 'static) -> Self {
        self.initializer = Box::new(initializer);
        self
    }

    /// The line search (default: the solver's own).
    pub fn line_search(mut self, line_search: impl LineSearch + 'static) -> Self {
        self.line_search = Some(Box::new(line_search));
        self
    }

    /// The solver.
    pub fn solver(mut self, solver: impl Solver + 'static) -> Self {
        self.solver = Box::new(solver);
        self
    }

    /// The numeric settings.
    pub fn config(mut self, config: Config) -> Self {
        self.config = config;
        self
    }

    /// The numeric settings in use.
    pub fn settings(&self) -> &Config {
        &self.config
    }

    /// Checks the mesh ([`prepare_mesh`]), the settings and the images,
    /// then flattens the mesh and pulls the images into the template,
    /// reporting progress to `observer`. Not converging within the limits is
    /// not an error (`report.converged` says so).
    ///
    /// # Errors
    /// `Config` for bad settings; `Mesh` / [`super::PlacentaError`] for an
    /// unusable mesh or images (no tets, NaN, degenerate tets, several
    /// components, two images of one name, an image beside the mesh, ...);
    /// the parcellation's, the initializer's and the solver's errors.
    pub fn run(
        &self,
        mesh: &TetMesh,
        images: &[Image<'_>],
        observer: &mut dyn PipelineObserver,
    ) -> Result<Outcome, OrganError> {
        let start = Instant::now();
        self.config.validate()?;
        observer.stage("validation");
        let prepared = prepare_mesh(mesh)?;
        let prepare = start.elapsed().as_secs_f64();
        self.run_from(prepared, images, observer, start, prepare)
    }

    /// [`Pipeline::run`] for a mesh already checked by [`prepare_mesh`] (a
    /// caller that validated the input up front does not pay twice).
    ///
    /// # Errors
    /// As [`Pipeline::run`], except the mesh checks.
    pub fn run_prepared(
        &self,
        prepared: PreparedMesh,
        images: &[Image<'_>],
        observer: &mut dyn PipelineObserver,
    ) -> Result<Outcome, OrganError> {
        self.config.validate()?;
        self.run_from(prepared, images, observer, Instant::now(), 0.0)
    }

    fn run_from(
        &self,
        prepared: PreparedMesh,
        images: &[Image<'_>],
        observer: &mut dyn PipelineObserver,
        start: Instant,
        prepare_seconds: f64,
    ) -> Result<Outcome, OrganError> {
        let config = &self.config;
        let mut timings = Timings {
            prepare: prepare_seconds,
            ..Timings::default()
        };
        let rest = prepared.mesh;
        check_images(&rest, images, config.frame_check)?;

        observer.stage("parcellation");
        let t = Instant::now();
        let parcellation = parcellate(&rest, &config.parcellation)?;
        let labels = parcellation.labels.clone();
        let weights = boundary_weights(&parcellation);
        timings.parcellation = t.elapsed().as_secs_f64();

        observer.stage("initialization");
        let t = Instant::now();
        let mut is_boundary = vec![false; rest.num_vertices()];
        for &v in &parcellation.boundary.to_volume {
            is_boundary[v as usize] = true;
        }
        let estimates = match config.half_thickness_mm {
            None => estimate(&rest, &parcellation.boundary.surface, &is_boundary)?,
            Some(h) => estimate_with_thickness(&rest, &parcellation.boundary.surface, h)?,
        };
        let pmesh = ParamMesh::from_tets(&rest)?;
        let start_map = self
            .initializer
            .initialize(
                &pmesh,
                &Constraints {
                    pins: &[],
                    labels: &labels,
                    weights: &weights,
                },
            )
            .map_err(OrganError::from_param)?;
        let initial: Vec<Point3<f64>> = start_map
            .x
            .chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect();
        let alignment = Alignment::fit(&rest.positions, &initial)?;
        timings.initialization = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let problem = Problem {
            mesh: &pmesh,
            labels: &labels,
            weights: &weights,
        };
        let default_line_search = self.solver.default_line_search();
        let line_search = self.line_search.as_deref().unwrap_or(&*default_line_search);
        let method = Method {
            energy: self.energy.as_ref(),
            lambda: config.lambda,
            solver: self.solver.as_ref(),
            line_search,
            stopping: config.stopping(self.solver.as_ref()),
        };
        let mut opt = optimize(
            &problem,
            &method,
            self.template.as_ref(),
            &estimates,
            start_map.x.clone(),
            observer,
        )?;
        // The canonical frame (ALGORITHMS 2.10): a symmetry of the
        // template, so the objective and every figure stay as they are.
        let optimized: Vec<Point3<f64>> = opt
            .x
            .chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect();
        // The solved map in the start's frame, for the solve's gates.
        let solved = opt.x.clone();
        let canonical = canonical_motion(&optimized, &rest.tets, self.template.symmetry());
        for (c, p) in opt.x.chunks_exact_mut(3).zip(&optimized) {
            let q = canonical.apply(p);
            c.copy_from_slice(&[q.x, q.y, q.z]);
        }
        let alignment = alignment.then(&canonical);
        timings.optimization = t.elapsed().as_secs_f64();

        observer.stage("evaluation");
        let t = Instant::now();
        let template = self.template.as_ref();
        let eval = evaluate(
            &pmesh,
            &parcellation,
            template,
            &weights,
            &opt.x,
            &opt.theta,
        );
        let mut gates = parcellation.gates.clone();
        check_solve(
            &SolveInput {
                rest: &rest.positions,
                start: &start_map.x,
                solved: &solved,
                template,
                theta_initial: &opt.theta_initial,
                labels: &labels,
                weights: &weights,
                min_det_j: eval.min_det_j,
                final_error_mm: eval.template_error_mm,
                voxel_mm: config.parcellation.voxel_mm,
                resists_scaling: resists_scaling(self.energy.as_ref()),
            },
            &mut gates,
        )?;
        let names = template.parameter_names();
        let last = opt
            .stages
            .last()
            .map(|s| s.solve)
            .ok_or(super::PlacentaError::NoStage)?;
        let mut original = rest.clone();
        original.add_point_field(side_field(&labels))?;
        original.add_point_field(fiedler_field(&parcellation.fiedler))?;
        let mut flattened = TetMesh::new(
            opt.x
                .chunks_exact(3)
                .map(|c| Point3::new(c[0], c[1], c[2]))
                .collect(),
            rest.tets.clone(),
        );
        flattened.add_point_field(side_field(&labels))?;
        flattened.add_point_field(fiedler_field(&parcellation.fiedler))?;
        flattened.add_cell_field(Field::scalars("log2_det_j", eval.log2_det_j.clone()))?;
        flattened.add_cell_field(Field::scalars("sym_dirichlet", eval.sym_dirichlet.clone()))?;
        timings.evaluation = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let flat_images = pull_back(
            &flattened,
            &original.positions,
            images,
            config.spacing_mm,
            config.grid.as_ref(),
            config.interpolation,
            observer,
        )?;
        timings.images = t.elapsed().as_secs_f64();

        let s = &parcellation.summary;
        let report = Report {
            template: template.name().into(),
            lambda: config.lambda,
            solver: self.solver.name().into(),
            pieces: Pieces {
                template: template.name().into(),
                energy: self.energy.name().into(),
                initializer: self.initializer.name().into(),
                initializer_details: start_map
                    .details
                    .iter()
                    .map(|&(what, which)| (what.into(), which.into()))
                    .collect(),
                line_search: line_search.name().into(),
                solver: self.solver.name().into(),
            },
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
            folded_faces: eval.folded_faces,
            overlapping_boundary_faces: eval.overlapping_boundary_faces,
            theta: named(&names, &opt.theta),
            theta_initial: named(&names, &opt.theta_initial),
            estimates: estimates.clone(),
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
            canonical_frame: CanonicalReport {
                symmetry: template.symmetry(),
                motion: canonical.report(),
            },
            repair: prepared.repair,
            input: InputReport {
                vertices: rest.num_vertices(),
                tets: rest.num_tets(),
                reoriented_tets: prepared.reoriented_tets,
                volume_mm3: estimates.volume_mm3,
            },
            stages: opt.stages,
            images: flat_images.iter().map(|i| i.report.clone()).collect(),
            timings,
            gates,
        };
        Ok(Outcome {
            original,
            flattened,
            labels,
            parcellation,
            alignment,
            theta: opt.theta,
            images: flat_images,
            report,
        })
    }
}
