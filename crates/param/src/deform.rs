//! Deformation towards soft positional targets with the least distortion
//! (`unfold deform`): the general injective-deformation problem
//!
//! ```text
//! minimize  sum_k V_k D(J_k)  +  W sum_b |x_b - t_b|^2
//! ```
//!
//! over the positions `x` of a tet mesh, with `V_k` the rest volumes
//! normalized to sum 1, `D` a [`DistortionEnergy`] of the Jacobian `J_k`
//! of tet `k` against its rest shape (the input), and `t_b` the targets of
//! some vertices ([`PointTargets`]). Every iterate keeps every tet
//! positively oriented.
//!
//! [`Deform`] is the pipeline as a value, built from its pieces:
//!
//! ```text
//! Deform::new()                          // symmetric Dirichlet, identity,
//!     .energy(Arap)                      // projected Newton, its line search
//!     .solver(GradientDescent)
//!     .line_search(Backtracking::paper())
//!     .weight(10.0)
//!     .run(&mesh, &targets)?
//! ```

use crate::energy::SymmetricDirichlet;
use crate::initializer::{Constraints, Identity, Initializer};
use crate::linesearch::LineSearch;
use crate::metrics::{folded_count, inverted_count, min_det_j};
use crate::solver::{Executor, Observer, ProjectedNewton, Solver, StopReason, Stopping};
use crate::template::PointTargets;
use crate::{DistortionEnergy, Objective, ParamError, ParamMesh, TemplateTerm};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::time::Instant;
use unfold_mesh::TetMesh;
use unfold_mesh::nalgebra::Point3;

/// The deformation pipeline: its pieces and settings. Defaults: symmetric
/// Dirichlet, the identity start, projected Newton with its default line
/// search and stopping rules, `W = 1`.
#[derive(Debug)]
pub struct Deform {
    energy: Box<dyn DistortionEnergy>,
    initializer: Box<dyn Initializer>,
    line_search: Option<Box<dyn LineSearch>>,
    solver: Box<dyn Solver>,
    stopping: Option<Stopping>,
    weight: f64,
}

impl Default for Deform {
    fn default() -> Self {
        Deform {
            energy: Box::new(SymmetricDirichlet),
            initializer: Box::new(Identity),
            line_search: None,
            solver: Box::new(ProjectedNewton::default()),
            stopping: None,
            weight: 1.0,
        }
    }
}

/// What [`Deform::run`] reports (`OUT.report.json` of `unfold deform`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformReport {
    /// `distortion + target_term` at the result.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub objective: f64,
    /// `sum_k V_k D(J_k)` (volume weights summing to 1).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub distortion: f64,
    /// `W sum_b |x_b - t_b|^2`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub target_term: f64,
    /// Iterations taken.
    pub iterations: usize,
    /// Wall-clock seconds: rest data, objective set-up and the solve.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
    /// Whether the solver met its convergence test.
    pub converged: bool,
    /// Tets with `det J <= 0` at the result (0 for a valid map).
    pub inverted_tets: usize,
    /// Interior faces of the result whose two tets lie on the same side
    /// ([`crate::metrics::folded_count`]; 0 for an injective map).
    pub folded_faces: usize,
    /// The solver's name.
    pub solver: Cow<'static, str>,
    /// The distortion energy's name.
    pub energy: Cow<'static, str>,
    /// The initializer's name.
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
    /// Smallest `det J` at the result.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub min_det_j: f64,
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
    /// The deformed positions, one per input vertex.
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

    /// The starting map (it gets no pins).
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

    /// The stopping rules a run uses: those given, else the solver's.
    pub fn effective_stopping(&self) -> Stopping {
        self.stopping
            .unwrap_or_else(|| self.solver.default_stopping())
    }

    /// Deforms `mesh` (its shape is the rest state) towards `targets`
    /// (`(vertex, position)` pairs).
    ///
    /// # Errors
    /// As [`Deform::run_with`].
    pub fn run(
        &self,
        mesh: &TetMesh,
        targets: &[(usize, [f64; 3])],
    ) -> Result<DeformOutcome, ParamError> {
        self.run_with(mesh, targets, &mut crate::solver::NoObserver)
    }

    /// [`Deform::run`], reporting every iteration to `observer`. Vertices
    /// used by no tet and without a target carry no term: they stay where
    /// the initializer put them.
    ///
    /// # Errors
    /// [`ParamError::Setting`] for a weight that is not finite and `> 0`;
    /// [`ParamError::Mesh`] for an unusable mesh (inverted or degenerate
    /// tets, bad indices); the target errors of [`PointTargets::from_pairs`];
    /// the initializer's and the solver's errors.
    pub fn run_with(
        &self,
        mesh: &TetMesh,
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
        let t0 = Instant::now();
        let n = mesh.num_vertices();
        let rest = ParamMesh::from_tets(mesh)?;
        let point_targets = PointTargets::from_pairs(n, 3, targets)?;
        let labels = vec![0u8; n];
        let mut weights = vec![0.0; n];
        for &(v, _) in targets {
            weights[v] = self.weight;
        }
        let mut used = vec![false; n];
        for t in &mesh.tets {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let fixed: Vec<bool> = (0..n).map(|v| !used[v] && weights[v] == 0.0).collect();
        let fixed: &[bool] = if fixed.iter().any(|&f| f) {
            &fixed
        } else {
            &[]
        };
        let term = TemplateTerm {
            template: &point_targets,
            labels: &labels,
            weights: &weights,
        };
        let mut objective = Objective::new(&rest, self.energy.as_ref(), 1.0, Some(term), fixed)?;
        let mut x = self
            .initializer
            .initialize(&rest, &Constraints::default())?
            .x;
        let stopping = self.effective_stopping();
        let default_line_search = self.solver.default_line_search();
        let line_search = self.line_search.as_deref().unwrap_or(&*default_line_search);
        let solved = Executor::new(self.solver.as_ref())
            .line_search(line_search)
            .stopping(stopping)
            .observer(observer)
            .run(&mut objective, &mut x, &mut [])?;
        let seconds = t0.elapsed().as_secs_f64();
        let distortion = objective.distortion(&x);
        let target_term = objective.template_value(&x, &[]);
        let (mut err_max, mut err_sq) = (0.0f64, 0.0);
        for (v, t) in targets {
            let d2: f64 = (0..3).map(|c| (x[3 * v + c] - t[c]).powi(2)).sum();
            err_max = err_max.max(d2.sqrt());
            err_sq += d2;
        }
        let report = DeformReport {
            objective: distortion + target_term,
            distortion,
            target_term,
            iterations: solved.iterations,
            seconds,
            converged: solved.converged,
            inverted_tets: inverted_count(&rest, &x),
            folded_faces: folded_count(&rest, &x),
            solver: self.solver.name().into(),
            energy: self.energy.name().into(),
            initializer: self.initializer.name().into(),
            line_search: line_search.name().into(),
            weight: self.weight,
            targets: targets.len(),
            tol: stopping.grad_tol,
            max_iterations: stopping.max_iterations,
            stop_reason: solved.reason,
            grad_norm: solved.grad_norm,
            min_det_j: min_det_j(&rest, &x),
            target_error_max: err_max,
            target_error_rms: if targets.is_empty() {
                0.0
            } else {
                (err_sq / targets.len() as f64).sqrt()
            },
        };
        Ok(DeformOutcome {
            positions: x
                .chunks_exact(3)
                .map(|p| Point3::new(p[0], p[1], p[2]))
                .collect(),
            report,
        })
    }
}
