//! Deformation with the least distortion (`unfold deform`): the general
//! injective-mapping problem
//!
//! ```text
//! minimize  sum_k V_k D(J_k)  +  W sum_b |x_b - t_b|^2
//! subject to  x_h = x0_h for the fixed vertices h,  det J_k > 0
//! ```
//!
//! over the positions `x` of a tet mesh mapped into space or a triangle mesh
//! (planar or a surface) mapped to the plane, with `V_k` the rest measures
//! normalized to sum 1, `D` a [`DistortionEnergy`] of the Jacobian `J_k`
//! of element `k` against its rest shape (the input), `t_b` soft targets of
//! some vertices ([`PointTargets`]) and hard constraints: fixed vertices,
//! eliminated from the unknowns, so they keep their starting positions bit
//! for bit.
//!
//! The start is the rest shape (tets) or positions given with
//! [`Deform::start`], which may be tangled: then the [`Untangler`] first
//! finds a flip-free map with the fixed vertices in place, and the solver
//! lowers the distortion from there, every iterate flip-free. This is the
//! problem of the Locally Injective Mappings benchmark (Du et al. 2020,
//! "Lifting Simplices to Find Injectivity"): a rest mesh, a tangled
//! initial embedding and handles that must stay where they are.
//!
//! [`Deform`] is the pipeline as a value, built from its pieces:
//!
//! ```text
//! Deform::new()                          // symmetric Dirichlet, identity,
//!     .energy(Arap)                      // projected Newton, its line search
//!     .solver(GradientDescent)
//!     .line_search(Backtracking::paper())
//!     .weight(10.0)
//!     .start(positions).fixed(handles)   // a tangled start, hard handles
//!     .run(&mesh, &targets)?
//! ```

use crate::energy::SymmetricDirichlet;
use crate::initializer::{Constraints, Identity, Initializer};
use crate::linesearch::LineSearch;
use crate::metrics::{folded_count, inverted_count, min_det_j};
use crate::solver::{Executor, Observer, ProjectedNewton, Solver, StopReason, Stopping};
use crate::template::PointTargets;
use crate::untangle::{UntangleReport, Untangler};
use crate::{DistortionEnergy, Objective, ParamError, ParamMesh, TemplateTerm};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::time::Instant;
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::{TetMesh, TriMesh};

/// Projected Newton as a deformation runs it: the default with step
/// expansion 2 ([`ProjectedNewton::expand`]). After an untangling the map
/// starts with elements barely positive, whose clamped twist modes make the
/// projected Hessian overestimate the curvature, so full steps fall short:
/// on the untangling bench's tets with sparse handles (12k tets, scramble
/// 0.1) the distortion solve took 40 instead of 113 iterations.
pub fn deform_newton() -> ProjectedNewton {
    ProjectedNewton {
        expand: 2.0,
        ..ProjectedNewton::default()
    }
}

/// The deformation pipeline: its pieces and settings. Defaults: symmetric
/// Dirichlet, the identity start, projected Newton ([`deform_newton`]) with
/// its default line search and stopping rules, `W = 1`, no fixed vertex, the default
/// [`Untangler`].
#[derive(Debug)]
pub struct Deform {
    energy: Box<dyn DistortionEnergy>,
    initializer: Box<dyn Initializer>,
    line_search: Option<Box<dyn LineSearch>>,
    solver: Box<dyn Solver>,
    stopping: Option<Stopping>,
    weight: f64,
    start: Option<Vec<f64>>,
    fixed: Vec<usize>,
    untangler: Untangler,
}

impl Default for Deform {
    fn default() -> Self {
        Deform {
            energy: Box::new(SymmetricDirichlet),
            initializer: Box::new(Identity),
            line_search: None,
            solver: Box::new(deform_newton()),
            stopping: None,
            weight: 1.0,
            start: None,
            fixed: Vec::new(),
            untangler: Untangler::default(),
        }
    }
}

/// The rest shape of a deformation.
#[derive(Debug, Clone, Copy)]
pub enum RestShape<'a> {
    /// A tet mesh, mapped into space (every tet positively oriented).
    Tets(&'a TetMesh),
    /// A triangle mesh, planar or a surface, mapped to the plane.
    Triangles(&'a TriMesh),
}

/// Inverted and folded elements of a map, and its smallest `det J`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlipCounts {
    /// Elements with `det J <= 0`.
    pub inverted: usize,
    /// Interior faces (tets) or edges (triangles) whose two elements lie on
    /// the same side ([`crate::metrics::folded_count`]).
    pub folded: usize,
    /// Smallest `det J`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub min_det_j: f64,
}

impl FlipCounts {
    /// The counts of the map `x` of `mesh`.
    pub fn of(mesh: &ParamMesh, x: &[f64]) -> Self {
        FlipCounts {
            inverted: inverted_count(mesh, x),
            folded: folded_count(mesh, x),
            min_det_j: min_det_j(mesh, x),
        }
    }

    /// Whether nothing is inverted or folded.
    pub fn injective(&self) -> bool {
        self.inverted == 0 && self.folded == 0
    }
}

/// What [`Deform::run`] reports (`OUT.report.json` of `unfold deform`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformReport {
    /// Whether the result inverts and folds nothing and every fixed vertex
    /// is exactly at its start: a locally injective map.
    pub injective: bool,
    /// `distortion + target_term` at the result.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub objective: f64,
    /// `sum_k V_k D(J_k)` (rest measures summing to 1); infinite when a
    /// barrier energy meets an inverted element.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub distortion: f64,
    /// `W sum_b |x_b - t_b|^2`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub target_term: f64,
    /// Iterations of the distortion solve.
    pub iterations: usize,
    /// Wall-clock seconds: rest data, untangling, objective set-up and the
    /// solve.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
    /// Whether the solver met its convergence test.
    pub converged: bool,
    /// `"tets"` (mapped into space) or `"triangles"` (mapped to the plane).
    pub elements: Cow<'static, str>,
    /// Number of elements.
    pub element_count: usize,
    /// The map at the start: the rest shape or the given positions.
    pub start: FlipCounts,
    /// The map at the result.
    pub end: FlipCounts,
    /// The untangling of a start that inverted elements (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub untangle: Option<UntangleReport>,
    /// Whether the start was mirrored (`y -> -y`) for the solve and back:
    /// triangles given clockwise in the plane.
    pub mirrored: bool,
    /// Number of fixed vertices (hard constraints).
    pub fixed: usize,
    /// Largest distance of a fixed vertex from its start (0: they are
    /// eliminated from the unknowns).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub fixed_error_max: f64,
    /// The solver's name.
    pub solver: Cow<'static, str>,
    /// The distortion energy's name.
    pub energy: Cow<'static, str>,
    /// The initializer's name (`untangle` for a given start).
    pub initializer: Cow<'static, str>,
    /// The line search's name.
    pub line_search: Cow<'static, str>,
    /// W.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub weight: f64,
    /// Number of target vertices.
    pub targets: usize,
    /// The gradient tolerance.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub tol: f64,
    /// The iteration limit.
    pub max_iterations: usize,
    /// Why the solver stopped.
    pub stop_reason: StopReason,
    /// `|grad|_F` at the result.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub grad_norm: f64,
    /// Largest distance of a target vertex from its target.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub target_error_max: f64,
    /// Root mean square distance of the target vertices from their targets.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub target_error_rms: f64,
}

/// The deformed positions and the report.
#[derive(Debug, Clone, PartialEq)]
pub struct DeformOutcome {
    /// The deformed positions, one per input vertex (`z = 0` for a triangle
    /// mesh mapped to the plane).
    pub positions: Vec<Point3<f64>>,
    /// The report.
    pub report: DeformReport,
}

impl Deform {
    /// The default pipeline.
    pub fn new() -> Self {
        Self::default()
    }

    /// The distortion energy `D`.
    pub fn energy(mut self, energy: impl DistortionEnergy + 'static) -> Self {
        self.energy = Box::new(energy);
        self
    }

    /// The starting map when no [`start`](Self::start) is given (it gets no
    /// pins).
    pub fn initializer(mut self, initializer: impl Initializer + 'static) -> Self {
        self.initializer = Box::new(initializer);
        self
    }

    /// The line search (default: the solver's).
    pub fn line_search(mut self, line_search: impl LineSearch + 'static) -> Self {
        self.line_search = Some(Box::new(line_search));
        self
    }

    /// The solver.
    pub fn solver(mut self, solver: impl Solver + 'static) -> Self {
        self.solver = Box::new(solver);
        self
    }

    /// The stopping rules (default: the solver's).
    pub fn stopping(mut self, stopping: Stopping) -> Self {
        self.stopping = Some(stopping);
        self
    }

    /// The weight `W` of the target term (finite and `> 0`).
    pub fn weight(mut self, weight: f64) -> Self {
        self.weight = weight;
        self
    }

    /// The starting positions, flat, 3 per vertex for tets and 2 (in the
    /// plane) for triangles; tangled or not.
    pub fn start(mut self, positions: Vec<f64>) -> Self {
        self.start = Some(positions);
        self
    }

    /// Vertices held exactly at their starting positions (hard constraints).
    pub fn fixed(mut self, vertices: Vec<usize>) -> Self {
        self.fixed = vertices;
        self
    }

    /// The untangler's settings.
    pub fn untangler(mut self, untangler: Untangler) -> Self {
        self.untangler = untangler;
        self
    }

    /// The stopping rules a run uses: those given, else the solver's.
    pub fn effective_stopping(&self) -> Stopping {
        self.stopping
            .unwrap_or_else(|| self.solver.default_stopping())
    }

    /// Deforms the tet mesh `mesh` (its shape is the rest state) towards
    /// `targets` (`(vertex, position)` pairs).
    ///
    /// # Errors
    /// As [`Deform::run_shape`].
    pub fn run(
        &self,
        mesh: &TetMesh,
        targets: &[(usize, [f64; 3])],
    ) -> Result<DeformOutcome, ParamError> {
        self.run_shape(
            RestShape::Tets(mesh),
            targets,
            &mut crate::solver::NoObserver,
        )
    }

    /// [`Deform::run_shape`] of a tet mesh.
    ///
    /// # Errors
    /// As [`Deform::run_shape`].
    pub fn run_with(
        &self,
        mesh: &TetMesh,
        targets: &[(usize, [f64; 3])],
        observer: &mut dyn Observer,
    ) -> Result<DeformOutcome, ParamError> {
        self.run_shape(RestShape::Tets(mesh), targets, observer)
    }

    /// Deforms `rest` towards `targets` (`(vertex, position)` pairs; for
    /// triangles the first two coordinates), reporting every iteration of
    /// the distortion solve to `observer`. Vertices used by no element and
    /// without a target carry no term: they stay at their start.
    ///
    /// A start that inverts elements is untangled first; when the untangler
    /// finds no flip-free map, the distortion is not minimized and the
    /// report says so (`injective: false`, `stop_reason: not_untangled`,
    /// the positions the untangler's last), which is not an error.
    ///
    /// # Errors
    /// [`ParamError::Setting`] for a weight that is not finite and `> 0` or
    /// bad untangler settings; [`ParamError::Mesh`] for an unusable mesh
    /// (inverted or degenerate rest elements, bad indices);
    /// [`ParamError::Length`] for a start of the wrong size;
    /// [`ParamError::PinOutOfRange`] / [`ParamError::PinRepeated`] for bad
    /// fixed vertices, [`ParamError::PinNotFinite`] for a start that is not
    /// finite; the target errors of [`PointTargets::from_pairs`]; the
    /// initializer's and the solver's errors.
    pub fn run_shape(
        &self,
        rest: RestShape<'_>,
        targets: &[(usize, [f64; 3])],
        observer: &mut dyn Observer,
    ) -> Result<DeformOutcome, ParamError> {
        if !(self.weight.is_finite() && self.weight > 0.0) {
            return Err(ParamError::Setting {
                name: "target weight",
                value: self.weight,
                expected: "finite and > 0",
            });
        }
        self.untangler.validate()?;
        let t0 = Instant::now();
        let (mesh, elements) = match rest {
            RestShape::Tets(m) => (ParamMesh::from_tets(m)?, "tets"),
            RestShape::Triangles(m) => (ParamMesh::from_triangles(m)?, "triangles"),
        };
        let (n, d) = (mesh.num_vertices(), mesh.dim());
        let (mut x, initializer) = match &self.start {
            Some(start) => {
                if start.len() != d * n {
                    return Err(ParamError::Length {
                        what: "starting positions",
                        expected: d * n,
                        found: start.len(),
                    });
                }
                if let Some(v) =
                    (0..n).find(|&v| !start[d * v..d * v + d].iter().all(|c| c.is_finite()))
                {
                    return Err(ParamError::PinNotFinite { vertex: v as u32 });
                }
                (start.clone(), "untangle")
            }
            None => (
                self.initializer
                    .initialize(&mesh, &Constraints::default())?
                    .x,
                self.initializer.name(),
            ),
        };
        let mut fixed = vec![false; n];
        for &v in &self.fixed {
            if v >= n {
                return Err(ParamError::PinOutOfRange {
                    vertex: v as u32,
                    vertices: n,
                });
            }
            if std::mem::replace(&mut fixed[v], true) {
                return Err(ParamError::PinRepeated { vertex: v as u32 });
            }
        }
        // Triangles given clockwise in the plane (more than 3/4 of them
        // inverted: a scrambled start inverts about half): solve the mirror
        // image (y -> -y is exact, so fixed positions stay bit for bit).
        let mirrored = d == 2 && 4 * inverted_count(&mesh, &x) > 3 * mesh.num_elements();
        let mirror = |x: &mut [f64]| {
            if mirrored {
                x.iter_mut().skip(1).step_by(2).for_each(|y| *y = -*y);
            }
        };
        mirror(&mut x);
        let mirrored_targets: Vec<(usize, [f64; 3])>;
        let targets = if mirrored {
            mirrored_targets = targets
                .iter()
                .map(|&(v, t)| (v, [t[0], -t[1], t[2]]))
                .collect();
            &mirrored_targets[..]
        } else {
            targets
        };
        let point_targets = PointTargets::from_pairs(n, d, targets)?;
        let x0 = x.clone();
        let labels = vec![0u8; n];
        let mut weights = vec![0.0; n];
        for &(v, _) in targets {
            weights[v] = self.weight;
        }
        let mut used = vec![false; n];
        for e in 0..mesh.num_elements() {
            for &v in mesh.element(e) {
                used[v as usize] = true;
            }
        }
        for v in 0..n {
            if !used[v] && weights[v] == 0.0 {
                fixed[v] = true;
            }
        }
        let start_counts = FlipCounts::of(&mesh, &x);
        let fixed_flags: &[bool] = if fixed.iter().any(|&f| f) {
            &fixed
        } else {
            &[]
        };
        let untangle =
            if start_counts.inverted > 0 || start_counts.min_det_j < crate::objective::MIN_DET_J {
                Some(self.untangler.run(&mesh, &mut x, fixed_flags)?)
            } else {
                None
            };
        let stopping = self.effective_stopping();
        let default_line_search = self.solver.default_line_search();
        let line_search = self.line_search.as_deref().unwrap_or(&*default_line_search);
        let term = TemplateTerm {
            template: &point_targets,
            labels: &labels,
            weights: &weights,
        };
        let mut objective =
            Objective::new(&mesh, self.energy.as_ref(), 1.0, Some(term), fixed_flags)?;
        let solved = if untangle.as_ref().is_none_or(|u| u.untangled) {
            let solved = Executor::new(self.solver.as_ref())
                .line_search(line_search)
                .stopping(stopping)
                .observer(observer)
                .run(&mut objective, &mut x, &mut [])?;
            (
                solved.iterations,
                solved.converged,
                solved.reason,
                solved.grad_norm,
            )
        } else {
            (0, false, StopReason::NotUntangled, f64::NAN)
        };
        let seconds = t0.elapsed().as_secs_f64();
        let distortion = objective.distortion(&x);
        let target_term = objective.template_value(&x, &[]);
        let (mut err_max, mut err_sq) = (0.0f64, 0.0);
        for (v, t) in targets {
            let d2: f64 = (0..d).map(|c| (x[d * v + c] - t[c]).powi(2)).sum();
            err_max = err_max.max(d2.sqrt());
            err_sq += d2;
        }
        let fixed_error_max = self
            .fixed
            .iter()
            .map(|&v| {
                (0..d)
                    .map(|c| (x[d * v + c] - x0[d * v + c]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max);
        let end = FlipCounts::of(&mesh, &x);
        mirror(&mut x);
        let report = DeformReport {
            injective: end.injective() && end.min_det_j > 0.0 && fixed_error_max == 0.0,
            objective: distortion + target_term,
            distortion,
            target_term,
            iterations: solved.0,
            seconds,
            converged: solved.1,
            elements: elements.into(),
            element_count: mesh.num_elements(),
            start: start_counts,
            end,
            untangle,
            mirrored,
            fixed: self.fixed.len(),
            fixed_error_max,
            solver: self.solver.name().into(),
            energy: self.energy.name().into(),
            initializer: initializer.into(),
            line_search: line_search.name().into(),
            weight: self.weight,
            targets: targets.len(),
            tol: stopping.grad_tol,
            max_iterations: stopping.max_iterations,
            stop_reason: solved.2,
            grad_norm: solved.3,
            target_error_max: err_max,
            target_error_rms: if targets.is_empty() {
                0.0
            } else {
                (err_sq / targets.len() as f64).sqrt()
            },
        };
        let positions = x
            .chunks_exact(d)
            .map(|p| Point3::new(p[0], p[1], if d == 3 { p[2] } else { 0.0 }))
            .collect();
        Ok(DeformOutcome { positions, report })
    }
}
