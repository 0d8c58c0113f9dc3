//! Property tests across compositions of the framework's pieces: proptest
//! draws a template (the placenta's three, soft point targets, or a
//! ten-parameter template written here), a distortion energy, a line search
//! and a solver, and a random small mesh (a jittered tet block, or a
//! jittered triangle disk mapped to the plane). A solver wrapper checks
//! every accepted step: no element inverted, the objective not increased.

use proptest::prelude::*;
use std::sync::Mutex;
use unfold_mesh::nalgebra::Rotation3;
use unfold_mesh::shapes::{grid_disk, kuhn_grid, side};
use unfold_mesh::topology::tet_boundary;
use unfold_organs::placenta::{Ellipsoid, ParallelPlanes, SinglePlane};
use unfold_param::energy::{Arap, AreaRatio, Mips, SymmetricDirichlet};
use unfold_param::flips::check_no_flips;
use unfold_param::initializer::TutteDisk;
use unfold_param::linesearch::Backtracking;
use unfold_param::metrics::inverted_count;
use unfold_param::template::PointTargets;
use unfold_param::{
    Constraints, DistortionEnergy, Executor, GradientDescent, Initializer, LineSearch, Objective,
    ParamError, ParamMesh, ProjectedNewton, Solver, State, Step, Stopping, Template, TemplateTerm,
};

/// Delegates to a solver and checks every step it takes.
#[derive(Debug)]
struct Checked {
    inner: Box<dyn Solver>,
    violations: Mutex<Vec<String>>,
}

impl Checked {
    fn new(inner: Box<dyn Solver>) -> Self {
        Checked {
            inner,
            violations: Mutex::new(Vec::new()),
        }
    }
}

impl Solver for Checked {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn default_line_search(&self) -> Box<dyn LineSearch> {
        self.inner.default_line_search()
    }
    fn default_stopping(&self) -> Stopping {
        self.inner.default_stopping()
    }
    fn init(&self, objective: &mut Objective<'_>, state: &mut State) -> Result<(), ParamError> {
        self.inner.init(objective, state)
    }
    fn next_iter(
        &self,
        objective: &mut Objective<'_>,
        state: &mut State,
        line_search: &dyn LineSearch,
    ) -> Result<Step, ParamError> {
        let before = state.value;
        let step = self.inner.next_iter(objective, state, line_search)?;
        if step == Step::Moved {
            let mut v = self.violations.lock().unwrap();
            if let Err(e) = check_no_flips(objective.mesh(), &state.x) {
                v.push(format!("iteration {}: {e}", state.iteration));
            }
            let after = objective.value(&state.x, &state.theta);
            if after.is_nan() || after > before + 1e-12 * before.abs() {
                v.push(format!(
                    "iteration {}: {before} -> {after}",
                    state.iteration
                ));
            }
        }
        Ok(step)
    }
}

/// A template with ten parameters: the fetal side pulled onto the cubic
/// height field `z = sum_k theta_k b_k(x, y)`, `b = (1, x, y, x^2, xy, y^2,
/// x^3, x^2 y, x y^2, y^3)` (coordinates over 10), plus a small ridge
/// `1e-3 |theta|^2` that keeps the parameters determined. The Hessian in x
/// is the Gauss-Newton one (PSD); the parameter Hessians are the trait's
/// numeric defaults, which work for any parameter count.
#[derive(Debug)]
struct CubicHeight;

impl CubicHeight {
    fn basis(x: &[f64]) -> ([f64; 10], [f64; 10], [f64; 10]) {
        let (a, b) = (x[0] / 10.0, x[1] / 10.0);
        let f = [
            1.0,
            a,
            b,
            a * a,
            a * b,
            b * b,
            a * a * a,
            a * a * b,
            a * b * b,
            b * b * b,
        ];
        let fa = [
            0.0,
            1.0,
            0.0,
            2.0 * a,
            b,
            0.0,
            3.0 * a * a,
            2.0 * a * b,
            b * b,
            0.0,
        ];
        let fb = [
            0.0,
            0.0,
            1.0,
            0.0,
            a,
            2.0 * b,
            0.0,
            a * a,
            2.0 * a * b,
            3.0 * b * b,
        ];
        (f, fa.map(|v| v / 10.0), fb.map(|v| v / 10.0))
    }
    /// The residual and its gradient in x.
    fn residual(x: &[f64], theta: &[f64]) -> (f64, [f64; 3]) {
        let (f, fa, fb) = Self::basis(x);
        let dot = |u: &[f64; 10]| u.iter().zip(theta).map(|(p, q)| p * q).sum::<f64>();
        (x[2] - dot(&f), [-dot(&fa), -dot(&fb), 1.0])
    }
}

impl Template for CubicHeight {
    fn name(&self) -> &'static str {
        "cubic-height"
    }
    fn parameter_names(&self) -> Vec<&'static str> {
        vec!["c0", "c1", "c2", "c3", "c4", "c5", "c6", "c7", "c8", "c9"]
    }
    fn value(&self, _: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        if label != side::FETAL {
            return 0.0;
        }
        let (r, _) = Self::residual(x, theta);
        r * r + 1e-3 * theta.iter().map(|t| t * t).sum::<f64>()
    }
    fn gradient(&self, _: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if label == side::FETAL {
            let (r, dr) = Self::residual(x, theta);
            (0..3).for_each(|i| out[i] = 2.0 * r * dr[i]);
        }
    }
    fn hessian(&self, _: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if label == side::FETAL {
            let (_, dr) = Self::residual(x, theta);
            (0..9).for_each(|k| out[k] = 2.0 * dr[k / 3] * dr[k % 3]);
        }
    }
    fn theta_gradient(&self, _: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if label == side::FETAL {
            let (r, _) = Self::residual(x, theta);
            let (f, _, _) = Self::basis(x);
            (0..10).for_each(|k| out[k] = -2.0 * r * f[k] + 2e-3 * theta[k]);
        }
    }
}

fn energy(k: usize) -> Box<dyn DistortionEnergy> {
    match k {
        0 => Box::new(SymmetricDirichlet),
        1 => Box::new(Arap),
        2 => Box::new(Mips),
        _ => Box::new(AreaRatio),
    }
}

fn line_search(k: usize) -> Box<dyn LineSearch> {
    match k {
        0 => Box::new(Backtracking::default()),
        1 => Box::new(Backtracking::paper()),
        _ => Box::new(Backtracking {
            beta: 0.5,
            rho: 0.3,
            armijo: Some(0.3),
            max_halvings: 40,
        }),
    }
}

fn solver(k: usize) -> Box<dyn Solver> {
    match k {
        0 => Box::new(ProjectedNewton::default()),
        1 => Box::new(ProjectedNewton {
            exact_first: false,
            expand: 1.5,
            ..ProjectedNewton::default()
        }),
        _ => Box::new(GradientDescent),
    }
}

/// A jittered, rotated tet block; side labels by face (top fetal, bottom
/// maternal, the rest of the boundary margin); equal boundary weights.
fn block(n: [usize; 3], jitter: &[f64], angles: [f64; 3]) -> (ParamMesh, Vec<u8>, Vec<f64>) {
    let mut m = kuhn_grid(n, [10.0, 10.0, 5.0]);
    let top = 5.0 * n[2] as f64;
    let b = tet_boundary(&m).unwrap();
    let mut labels = vec![side::INTERIOR; m.num_vertices()];
    for &v in &b.to_volume {
        let z = m.positions[v as usize].z;
        labels[v as usize] = if z == top {
            side::FETAL
        } else if z == 0.0 {
            side::MATERNAL
        } else {
            side::MARGIN
        };
    }
    let r = Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
    for (i, p) in m.positions.iter_mut().enumerate() {
        let j = |k: usize| jitter[(3 * i + k) % jitter.len()];
        if labels[i] == side::INTERIOR {
            *p += unfold_mesh::nalgebra::Vector3::new(j(0), j(1), j(2));
        }
        *p = r * *p;
    }
    let boundary = labels.iter().filter(|&&l| l != side::INTERIOR).count() as f64;
    let weights = labels
        .iter()
        .map(|&l| {
            if l == side::INTERIOR {
                0.0
            } else {
                1.0 / boundary
            }
        })
        .collect();
    (ParamMesh::from_tets(&m).unwrap(), labels, weights)
}

/// Runs one composition; returns the violations, the inverted elements of
/// the result and whether the objective went up overall.
fn run(
    mesh: &ParamMesh,
    term: Option<TemplateTerm<'_>>,
    theta: &mut [f64],
    x: &mut [f64],
    (e, l, s): (usize, usize, usize),
) -> (Vec<String>, usize, bool) {
    let energy = energy(e);
    let line_search = line_search(l);
    let solver = Checked::new(solver(s));
    let mut objective = Objective::new(mesh, energy.as_ref(), 0.5, term, &[]).unwrap();
    let start = objective.value(x, theta);
    let report = Executor::new(&solver)
        .line_search(line_search.as_ref())
        .stopping(Stopping {
            grad_tol: 1e-9,
            max_iterations: 25,
            ..Stopping::default()
        })
        .run(&mut objective, x, theta)
        .unwrap();
    let violations = solver.violations.into_inner().unwrap();
    (violations, inverted_count(mesh, x), report.value > start)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Tet blocks: any template, energy, line search and solver.
    #[test]
    fn every_step_of_every_composition_is_flip_free_and_descending(
        n in [2usize..4, 2usize..4, 1usize..3],
        jitter in prop::collection::vec(-1.0..1.0f64, 30),
        angles in [-3.0..3.0f64, -3.0..3.0, -3.0..3.0],
        template in 0usize..5,
        pieces in (0usize..4, 0usize..3, 0usize..3),
    ) {
        let (mesh, labels, weights) = block(n, &jitter, angles);
        let planes = ParallelPlanes::default();
        let ellipsoid = Ellipsoid::default();
        let single = SinglePlane::default();
        let cubic = CubicHeight;
        let targets = PointTargets::new(
            mesh.rest.iter().map(|p| Some([p.x + 1.0, p.y - 0.5, p.z + 0.7])).collect(),
            3,
        ).unwrap();
        let (t, mut theta): (&dyn Template, Vec<f64>) = match template {
            0 => (&planes, vec![3.0]),
            1 => (&ellipsoid, vec![20.0, 15.0, 5.0]),
            2 => (&single, vec![3.0]),
            3 => (&cubic, vec![0.0; 10]),
            _ => (&targets, vec![]),
        };
        let term = TemplateTerm { template: t, labels: &labels, weights: &weights };
        let mut x = mesh.rest_flat();
        let (violations, inverted, went_up) = run(&mesh, Some(term), &mut theta, &mut x, pieces);
        prop_assert!(violations.is_empty(), "{}: {:?}", t.name(), violations);
        prop_assert_eq!(inverted, 0);
        prop_assert!(!went_up);
    }

    /// Triangle disks mapped to the plane, started from the Tutte embedding
    /// (the initializer), pulled towards soft targets.
    #[test]
    fn planar_compositions_from_the_tutte_start_stay_flip_free(
        nx in 2usize..6, ny in 2usize..6,
        jitter in prop::collection::vec(-0.3..0.3f64, 20),
        pieces in (0usize..4, 0usize..3, 0usize..3),
    ) {
        let mut m = grid_disk(nx, ny);
        for (i, p) in m.positions.iter_mut().enumerate() {
            let j = |k: usize| jitter[(2 * i + k) % jitter.len()];
            *p += unfold_mesh::nalgebra::Vector3::new(j(0), j(1), 0.5 * (p.x * p.y).sin());
        }
        let mesh = ParamMesh::from_triangles(&m).unwrap();
        let mut x = TutteDisk::mean_value().initialize(&mesh, &Constraints::default()).unwrap().x;
        let targets = PointTargets::new(
            (0..m.num_vertices()).map(|v| Some([0.5 * x[2 * v] + 0.1, 1.5 * x[2 * v + 1], 0.0])).collect(),
            2,
        ).unwrap();
        let labels = vec![0u8; m.num_vertices()];
        let weights = vec![1.0 / m.num_vertices() as f64; m.num_vertices()];
        let term = TemplateTerm { template: &targets, labels: &labels, weights: &weights };
        let (violations, inverted, went_up) = run(&mesh, Some(term), &mut [], &mut x, pieces);
        prop_assert!(violations.is_empty(), "{:?}", violations);
        prop_assert_eq!(inverted, 0);
        prop_assert!(!went_up);
    }
}

/// The ten-parameter template's derivatives, and its parameters of any
/// count through the numeric defaults (heap buffers past eight).
#[test]
fn a_ten_parameter_template_has_consistent_derivatives() {
    let theta: Vec<f64> = (0..10).map(|k| 0.1 * k as f64 - 0.3).collect();
    let x = [3.0, -4.0, 2.0];
    let mut h = vec![0.0; 100];
    CubicHeight.theta_hessian(0, side::FETAL, &x, &theta, &mut h);
    let (f, _, _) = CubicHeight::basis(&x);
    for i in 0..10 {
        for j in 0..10 {
            let exact = 2.0 * f[i] * f[j] + if i == j { 2e-3 } else { 0.0 };
            assert!((h[i * 10 + j] - exact).abs() < 1e-6, "({i}, {j})");
        }
    }
    let mut mixed = vec![0.0; 30];
    CubicHeight.mixed_hessian(0, side::FETAL, &x, &theta, &mut mixed);
    let (_, dr) = CubicHeight::residual(&x, &theta);
    // d2T/(dz dtheta_k) = -2 f_k dr/dz.
    for k in 0..10 {
        assert!((mixed[2 * 10 + k] + 2.0 * f[k] * dr[2]).abs() < 1e-6, "{k}");
    }
}
