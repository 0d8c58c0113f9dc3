//! Untangling: from any starting map, tangled or not, to one that inverts
//! no element, with fixed vertices exactly in place (Garanzha et al.,
//! "Foldover-free maps in 50 lines of code", ACM TOG 40(4), 2021;
//! ALGORITHMS 1.7).
//!
//! The [`Untangler`] minimizes the regularized energy
//! [`Untangling`](crate::energy::Untangling) for a decreasing sequence of
//! `eps`. Each stage runs projected Newton (steps not bounded by flips, an
//! Armijo line search, the exact Hessian never tried) for one iteration at
//! a fixed `eps` ([`Untangler::stage_iterations`]), the Hessian factorized
//! in every [`Untangler::refactor_every`]-th stage only, the stages
//! between solving with that factor (chord steps; `step.rs`); then, with
//! `E_prev` and `E` the energy before and after the stage and `D_min` the
//! smallest `det J`,
//!
//! ```text
//! sigma = max(1 - E / E_prev, 1/10)
//! mu    = (1 - sigma) chi(D_min, eps)
//! eps   = 2 sqrt(mu (mu - D_min))        (so that chi(D_min, eps_new) = mu)
//! ```
//!
//! so the regularized determinant of the worst element shrinks by the
//! stage's relative progress. When `eps` falls below [`RESTART_EPS`], or
//! below [`RESTART_RATIO`] `|D_min|`, with elements still inverted (the
//! schedule ran ahead of the map: the barrier `chi(D_min, eps) ~ eps^2 /
//! (4 |D_min|)` now holds the inverted elements where they are), it starts
//! again from `eps = max(|D_min| / 5, 1e-3)`, at most [`MAX_RESTARTS`]
//! times; once they are spent, `eps` falling below [`RESTART_EPS`] ends
//! the run, reported not untangled (a smaller `eps` only steepens the
//! barrier that holds the remaining inversions, until the energy
//! overflows). It stops as soon as every `det J >=`
//! [`MIN_DET_J`](crate::objective::MIN_DET_J) (an orientation certain
//! above rounding): the caller's flip-free solve takes over from there.
//!
//! The energy assumes `det J ~ 1` for a good map, so the untangler solves
//! against the rest mesh scaled to the map's size: by the spread of the
//! fixed vertices (`c^2 = sum |x_h - xbar|^2 / sum |z_h - zbar|^2`, with
//! at least 3 of them), else by the measure (`c^d sum_k |T_k| = sum_k
//! |T_k| det J_k`, the signed mapped measure; the absolute one when the
//! signed one is not positive). Scaling the rest changes neither the
//! elements' orientation nor the fixed positions.
//!
//! [`Untangle`] wraps it as an [`Initializer`]: a starting map (positions
//! given, or another initializer's) made flip-free with the pipeline's
//! pins as fixed vertices.

mod step;

use crate::energy::{Untangling, chi};
use crate::initializer::{Constraints, InitialMap, Initializer};
use crate::metrics::det_j;
use crate::objective::MIN_DET_J;
use crate::{Objective, ParamError, ParamMesh};
use serde::{Deserialize, Serialize};
use std::time::Instant;
use step::{Direction, ScheduledUntangling, Stepper};

/// Below this `eps` with elements still inverted, the schedule restarts
/// from `eps = max(D_min / 5, 1e-3)` (the start's rule).
pub const RESTART_EPS: f64 = 1e-6;
/// Below this fraction of `|D_min|` (with elements still inverted) the
/// schedule restarts as below [`RESTART_EPS`], while restarts are left. On
/// the untangling bench's planar 30k case with sparse handles, the
/// inverted count stayed at 110-150 and `D_min` near -3 while `eps` fell
/// from 1e-2 to 1e-6, 150 stages before each restart (DESIGN-NOTES,
/// "Untangling: restarting when the barrier holds").
pub const RESTART_RATIO: f64 = 1e-3;
/// Restarts of the `eps` schedule at most.
pub const MAX_RESTARTS: usize = 3;

/// The untangler's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Untangler {
    /// Weight `theta` of the volume term ([`Untangling::DEFAULT_THETA`]).
    pub theta: f64,
    /// Largest number of `eps` stages (1000).
    pub max_stages: usize,
    /// Newton iterations per stage (1: on generated tangled grids, one
    /// iteration per stage took 2 to 4 times fewer iterations in all than
    /// 3 or 10, the `eps` schedule doing the work).
    pub stage_iterations: usize,
    /// Time limit in seconds (infinite).
    pub max_seconds: f64,
    /// Stages per factorization at most (5): the projected Hessian is
    /// assembled and factorized in a stage when `refactor_every` stages
    /// have passed since the last factorization or the last step was not
    /// a full one (`a < 1`); the other stages solve with the last factor
    /// (the Hessian of an earlier iterate and `eps`: a chord step), and
    /// factorize afresh when its line search finds no step
    /// (ALGORITHMS 1.7). 1 factorizes in every stage. Tet meshes only:
    /// triangle maps factorize in every stage (their factorizations are
    /// cheap, and reusing them left a 30k-triangle case of the bench
    /// tangled). On the bench's tet grids with sparse handles 5 took 3
    /// times less CPU time than 1 for about the same number of stages
    /// (DESIGN-NOTES, "Untangling").
    #[serde(default = "default_refactor_every")]
    pub refactor_every: usize,
}

fn default_refactor_every() -> usize {
    Untangler::default().refactor_every
}

impl Default for Untangler {
    fn default() -> Self {
        Untangler {
            theta: Untangling::DEFAULT_THETA,
            max_stages: 1000,
            stage_iterations: 1,
            max_seconds: f64::INFINITY,
            refactor_every: 5,
        }
    }
}

/// What an untangling did (`untangle` in a deformation's report).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UntangleReport {
    /// Elements with `det J <= 0` at the start.
    pub inverted_start: usize,
    /// Smallest `det J` at the start (against the unscaled rest).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub min_det_start: f64,
    /// Elements with `det J <= 0` at the end.
    pub inverted_end: usize,
    /// Smallest `det J` at the end (against the unscaled rest).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub min_det_end: f64,
    /// `eps` stages run.
    pub stages: usize,
    /// Newton iterations over all stages.
    pub iterations: usize,
    /// Factorizations of the Hessian over all stages.
    #[serde(default)]
    pub factorizations: usize,
    /// The first `eps`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub eps_start: f64,
    /// The last `eps`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub eps_end: f64,
    /// Restarts of the `eps` schedule (at most [`MAX_RESTARTS`]).
    #[serde(default)]
    pub restarts: usize,
    /// The rest mesh's scale `c` for the solve.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub scale: f64,
    /// Wall-clock seconds.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
    /// Whether every element ended with `det J >= MIN_DET_J`.
    pub untangled: bool,
}

impl Untangler {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`ParamError::Setting`] for `theta` outside `[0, 1)`, no stage or no
    /// iteration per stage.
    pub fn validate(&self) -> Result<(), ParamError> {
        let setting = |name, value, expected| ParamError::Setting {
            name,
            value,
            expected,
        };
        if !(self.theta >= 0.0 && self.theta < 1.0) {
            return Err(setting("untangler theta", self.theta, "in [0, 1)"));
        }
        if self.max_stages == 0 {
            return Err(setting("untangler stages", 0.0, ">= 1"));
        }
        if self.stage_iterations == 0 {
            return Err(setting("untangler iterations per stage", 0.0, ">= 1"));
        }
        if self.refactor_every == 0 {
            return Err(setting("untangler stages per factorization", 0.0, ">= 1"));
        }
        Ok(())
    }

    /// Untangles `x` (flat, `mesh.dim()` per vertex) in place, `fixed[v]`
    /// vertices kept bit for bit (empty: none). Not finding a flip-free map
    /// is reported (`untangled: false`, `x` the last iterate), not an error.
    ///
    /// # Errors
    /// [`ParamError::Length`] for a wrong `x` or `fixed`;
    /// [`ParamError::Setting`] for bad settings; [`ParamError::Linalg`] when
    /// a factorization fails.
    pub fn run(
        &self,
        mesh: &ParamMesh,
        x: &mut [f64],
        fixed: &[bool],
    ) -> Result<UntangleReport, ParamError> {
        self.validate()?;
        let t0 = Instant::now();
        let n = mesh.num_vertices();
        if x.len() != mesh.dim() * n {
            return Err(ParamError::Length {
                what: "starting positions",
                expected: mesh.dim() * n,
                found: x.len(),
            });
        }
        if !fixed.is_empty() && fixed.len() != n {
            return Err(ParamError::Length {
                what: "fixed vertices",
                expected: n,
                found: fixed.len(),
            });
        }
        let dets = det_j(mesh, x);
        let (inverted_start, min_det_start) = inverted_and_min(&dets);
        let scale = handle_scale(mesh, x, fixed).unwrap_or_else(|| map_scale(mesh, &dets));
        let mut report = UntangleReport {
            inverted_start,
            min_det_start,
            inverted_end: inverted_start,
            min_det_end: min_det_start,
            stages: 0,
            iterations: 0,
            factorizations: 0,
            eps_start: f64::NAN,
            eps_end: f64::NAN,
            restarts: 0,
            scale,
            seconds: 0.0,
            untangled: min_det_start >= MIN_DET_J,
        };
        if report.untangled {
            report.seconds = t0.elapsed().as_secs_f64();
            return Ok(report);
        }
        let scaled = mesh.scaled(scale);
        // det J against the scaled rest: det J / c^d.
        let cd = scale.powi(mesh.dim() as i32);
        let mut d_min = min_det_start / cd;
        let mut eps = (1e-12 + 0.04 * d_min.min(0.0).powi(2)).sqrt().max(1e-3);
        report.eps_start = eps;
        // The exact Hessian of the regularized energy is indefinite around
        // inverted elements: trying it first would cost failed factorizations.
        // One objective through all stages (the energy's eps set per
        // stage): its layout, element buffers and flip floors are built once.
        let energy = ScheduledUntangling::new(eps, self.theta);
        let mut objective = Objective::new(&scaled, &energy, 1.0, None, fixed)?;
        let mut stepper = Stepper::default();
        let mut xs = x.to_vec();
        // Reuse a factor on tet meshes only (see `refactor_every`).
        let refactor_every = if mesh.dim() == 3 {
            self.refactor_every
        } else {
            1
        };
        let mut since_factor = usize::MAX;
        let mut full_step = false;
        while report.stages < self.max_stages && t0.elapsed().as_secs_f64() < self.max_seconds {
            energy.set_eps(eps);
            let e_prev = stepper.evaluate(&objective, &xs);
            let mut e = e_prev;
            for k in 0..self.stage_iterations {
                if k > 0 {
                    e = stepper.evaluate(&objective, &xs);
                }
                let mut how = if since_factor >= refactor_every || !full_step {
                    Direction::Fresh
                } else {
                    Direction::Stale
                };
                let before = stepper.factorizations;
                let mut moved = stepper.step(&mut objective, &mut xs, e, how, report.iterations)?;
                if moved.is_none() && how == Direction::Stale {
                    // The old factor gave no acceptable step: a fresh one.
                    how = Direction::Fresh;
                    moved = stepper.step(&mut objective, &mut xs, e, how, report.iterations)?;
                }
                if stepper.factorizations > before {
                    since_factor = 0;
                }
                let Some((value, step)) = moved else { break };
                e = value;
                // A factor is reused only while its steps are full ones.
                full_step = step == 1.0;
                report.iterations += 1;
            }
            since_factor = since_factor.saturating_add(1);
            report.stages += 1;
            d_min = det_j(&scaled, &xs)
                .into_iter()
                .fold(f64::INFINITY, f64::min);
            report.eps_end = eps;
            if d_min * cd >= MIN_DET_J {
                break;
            }
            match next_eps(eps, d_min, e / e_prev, report.restarts) {
                NextEps::Continue(next) => eps = next,
                NextEps::Restart(next) => {
                    report.restarts += 1;
                    eps = next;
                }
                NextEps::End => break,
            }
        }
        report.factorizations = stepper.factorizations;
        x.copy_from_slice(&xs);
        let dets = det_j(mesh, x);
        let (inverted_end, min_det_end) = inverted_and_min(&dets);
        report.inverted_end = inverted_end;
        report.min_det_end = min_det_end;
        report.untangled = min_det_end >= MIN_DET_J;
        report.seconds = t0.elapsed().as_secs_f64();
        Ok(report)
    }
}

/// What the `eps` schedule does after a stage that left elements inverted.
#[derive(Debug, Clone, Copy, PartialEq)]
enum NextEps {
    /// The next stage's `eps`.
    Continue(f64),
    /// Start the schedule again from this `eps`.
    Restart(f64),
    /// Every restart spent and `eps` below [`RESTART_EPS`]: stop.
    End,
}

/// The schedule's step (module docs) from the stage's `eps`, the smallest
/// `det J` after it (`d_min`, below the orientation floor) and its energy
/// ratio `E / E_prev`, with `restarts` restarts made so far:
/// `sigma = max(1 - E / E_prev, 1/10)`, `mu = (1 - sigma) chi(D_min, eps)`,
/// `eps' = 2 sqrt(mu (mu - D_min))` (unchanged when `D_min >= mu`); then a
/// restart from `max(|D_min| / 5, 1e-3)` when `eps'` is below
/// [`RESTART_EPS`], or below [`RESTART_RATIO`] `|D_min|` while restarts are
/// left, and the end when it is below [`RESTART_EPS`] with every restart
/// spent.
fn next_eps(eps: f64, d_min: f64, energy_ratio: f64, restarts: usize) -> NextEps {
    let sigma = (1.0 - energy_ratio).max(0.1);
    let mu = (1.0 - sigma) * chi(d_min, eps);
    let next = if d_min < mu {
        2.0 * (mu * (mu - d_min)).sqrt()
    } else {
        eps
    };
    let held = next < RESTART_RATIO * d_min.abs();
    if next < RESTART_EPS || (held && restarts < MAX_RESTARTS) {
        if restarts == MAX_RESTARTS {
            // Every restart spent: smaller eps only steepens the barrier
            // that holds the remaining inversions.
            return NextEps::End;
        }
        // Stuck: eps has vanished (or is vanishing against D_min) with
        // elements still inverted, the energy's barrier now holds them.
        // Start the schedule again from the remaining inversion.
        return NextEps::Restart((0.2 * d_min.abs()).max(1e-3));
    }
    NextEps::Continue(next)
}

/// `(#{det J <= 0}, min det J)`.
fn inverted_and_min(dets: &[f64]) -> (usize, f64) {
    (
        dets.iter().filter(|&&d| d <= 0.0 || d.is_nan()).count(),
        dets.iter().copied().fold(f64::INFINITY, f64::min),
    )
}

/// The scale `c` of the fixed vertices' spread: `c^2 = sum |x_h - xbar|^2 /
/// sum |z_h - zbar|^2` over the fixed vertices `h` (mapped `x`, rest `z`,
/// their centroids `xbar`, `zbar`; for a map to the plane, `z` in the rest's
/// best-fit plane is what the spread measures); `None` with fewer than 3
/// fixed vertices or no spread.
fn handle_scale(mesh: &ParamMesh, x: &[f64], fixed: &[bool]) -> Option<f64> {
    let d = mesh.dim();
    let h: Vec<usize> = (0..fixed.len()).filter(|&v| fixed[v]).collect();
    if h.len() < 3 {
        return None;
    }
    let k = h.len() as f64;
    let (mut xbar, mut zbar) = ([0.0; 3], [0.0; 3]);
    for &v in &h {
        for c in 0..3 {
            zbar[c] += mesh.rest[v][c] / k;
            if c < d {
                xbar[c] += x[d * v + c] / k;
            }
        }
    }
    let (mut sx, mut sz) = (0.0, 0.0);
    for &v in &h {
        for c in 0..3 {
            sz += (mesh.rest[v][c] - zbar[c]).powi(2);
            if c < d {
                sx += (x[d * v + c] - xbar[c]).powi(2);
            }
        }
    }
    let c = (sx / sz).sqrt();
    (c.is_finite() && c > 0.0).then_some(c)
}

/// The scale `c` with `c^d sum |T_k| = sum |T_k| det J_k` (the signed mapped
/// measure), or the absolute mapped measure when the signed one is not
/// positive; 1 when neither is.
fn map_scale(mesh: &ParamMesh, dets: &[f64]) -> f64 {
    let rest: f64 = mesh.measure.iter().map(|m| m.abs()).sum();
    let signed: f64 = mesh
        .measure
        .iter()
        .zip(dets)
        .map(|(m, d)| m.abs() * d)
        .sum();
    let absolute: f64 = mesh
        .measure
        .iter()
        .zip(dets)
        .map(|(m, d)| m.abs() * d.abs())
        .sum();
    let mapped = if signed > 0.0 { signed } else { absolute };
    let c = (mapped / rest).powf(1.0 / mesh.dim() as f64);
    if c.is_finite() && c > 0.0 { c } else { 1.0 }
}

/// The untangler as an [`Initializer`]: the positions `start` (flat,
/// `mesh.dim()` per vertex), the pipeline's pins put in place and held
/// fixed, untangled.
#[derive(Debug, Clone, PartialEq)]
pub struct Untangle {
    /// The starting positions, tangled or not.
    pub start: Vec<f64>,
    /// The untangler's settings.
    pub untangler: Untangler,
}

impl Initializer for Untangle {
    fn name(&self) -> &'static str {
        "untangle"
    }

    /// # Errors
    /// [`ParamError::Length`] for a `start` of the wrong size; the pin
    /// errors ([`ParamError::PinOutOfRange`], [`ParamError::PinRepeated`],
    /// [`ParamError::PinNotFinite`]); [`ParamError::NotUntangled`] when
    /// elements stay inverted.
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        let (d, n) = (mesh.dim(), mesh.num_vertices());
        let mut x = self.start.clone();
        if x.len() != d * n {
            return Err(ParamError::Length {
                what: "starting positions",
                expected: d * n,
                found: x.len(),
            });
        }
        let mut fixed = vec![false; n];
        for pin in constraints.pins {
            let v = pin.vertex as usize;
            if v >= n {
                return Err(ParamError::PinOutOfRange {
                    vertex: pin.vertex,
                    vertices: n,
                });
            }
            if fixed[v] {
                return Err(ParamError::PinRepeated { vertex: pin.vertex });
            }
            if !pin.position[..d].iter().all(|c| c.is_finite()) {
                return Err(ParamError::PinNotFinite { vertex: pin.vertex });
            }
            fixed[v] = true;
            x[d * v..d * v + d].copy_from_slice(&pin.position[..d]);
        }
        let report = self.untangler.run(mesh, &mut x, &fixed)?;
        if !report.untangled {
            return Err(ParamError::NotUntangled {
                inverted: report.inverted_end,
                stages: report.stages,
                min_det: report.min_det_end,
            });
        }
        let mut map = InitialMap::new(x);
        if report.inverted_start > 0 {
            map.details.push(("untangled", "yes"));
        }
        Ok(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::inverted_count;
    use crate::{Deform, RestShape};
    use proptest::prelude::*;
    use unfold_mesh::shapes::{Handles, TangledCase, TangledKind, TangledParams, tangled_case};

    /// A stall like the planar 30k bench case's (`D_min` near -3 for 150
    /// stages, no progress), here with `D_min = -5`.
    #[test]
    fn a_barrier_that_holds_the_inversions_restarts_the_schedule_early() {
        // eps still above 1e-3 |D_min|: the schedule goes on.
        let NextEps::Continue(next) = next_eps(2e-2, -5.0, 0.999, 0) else {
            panic!("continue expected");
        };
        assert!(next < 2e-2 && next > 5e-3, "{next}");
        // Below it, far above RESTART_EPS: a restart from |D_min| / 5.
        assert_eq!(next_eps(5e-3, -5.0, 0.999, 0), NextEps::Restart(1.0));
        // With every restart spent the ratio alone never ends a run...
        assert!(matches!(
            next_eps(5e-3, -5.0, 0.999, MAX_RESTARTS),
            NextEps::Continue(_)
        ));
        // ...only eps below RESTART_EPS does.
        assert_eq!(next_eps(1e-6, -5.0, 0.999, MAX_RESTARTS), NextEps::End);
    }

    proptest! {
        /// The schedule's step: `eps` shrinks so that `chi(D_min, eps)`
        /// shrinks by the stage's progress (at least 1/10); restarts come
        /// exactly when `eps` vanishes, absolutely or against `|D_min|`,
        /// and the run ends only with every restart spent.
        #[test]
        fn the_eps_schedule_follows_its_formula(
            log_eps in -7.0f64..3.0,
            log_d in -4.0f64..3.0,
            ratio in 0.0f64..1.5,
            restarts in 0usize..=MAX_RESTARTS,
        ) {
            let (eps, d_min) = (10f64.powf(log_eps), -(10f64.powf(log_d)));
            let sigma = (1.0 - ratio).max(0.1);
            let mu = (1.0 - sigma) * chi(d_min, eps);
            let next = 2.0 * (mu * (mu - d_min)).sqrt();
            let vanished = next < RESTART_EPS;
            let held = next < RESTART_RATIO * d_min.abs();
            match next_eps(eps, d_min, ratio, restarts) {
                NextEps::Continue(e) => {
                    prop_assert!(!vanished);
                    prop_assert!(!held || restarts == MAX_RESTARTS);
                    prop_assert!(e < eps, "{} !< {}", e, eps);
                    let target = (1.0 - sigma) * chi(d_min, eps);
                    prop_assert!((chi(d_min, e) - target).abs() <= 1e-9 * target);
                }
                NextEps::Restart(e) => {
                    prop_assert!(restarts < MAX_RESTARTS);
                    prop_assert!(vanished || held);
                    prop_assert_eq!(e, (0.2 * d_min.abs()).max(1e-3));
                }
                NextEps::End => {
                    prop_assert!(vanished && restarts == MAX_RESTARTS);
                }
            }
        }
    }

    /// `case` through [`Deform`] from its tangled start with its handles
    /// fixed; checked independently: every element positive by the exact
    /// orientation predicate, every handle bit for bit at its start.
    fn solve_and_check(case: &TangledCase) -> crate::DeformReport {
        let d = if case.is_tets() { 3 } else { 2 };
        let start: Vec<f64> = case.init.iter().flat_map(|p| p[..d].to_vec()).collect();
        let fixed: Vec<usize> = case.fixed.iter().map(|&v| v as usize).collect();
        let pipeline = Deform::new().start(start).fixed(fixed);
        let (tets, tris) = (case.to_tet_mesh(), case.to_tri_mesh());
        let rest = match (&tets, &tris) {
            (Some(t), _) => RestShape::Tets(t),
            (None, Some(t)) => RestShape::Triangles(t),
            _ => unreachable!("a case has tets or triangles"),
        };
        let out = pipeline
            .run_shape(rest, &[], &mut crate::NoObserver)
            .unwrap();
        let positions: Vec<[f64; 3]> = out.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
        assert!(out.report.injective, "{:?}", out.report);
        assert_eq!(case.inverted_in(&positions), 0, "{:?}", out.report);
        for &h in &case.fixed {
            let h = h as usize;
            for (p, q) in positions[h][..d].iter().zip(&case.init[h][..d]) {
                assert_eq!(p.to_bits(), q.to_bits(), "handle {h}");
            }
        }
        out.report
    }

    #[test]
    fn untangles_every_kind_with_boundary_or_sparse_handles() {
        for kind in [
            TangledKind::Planar,
            TangledKind::SurfaceToPlane,
            TangledKind::Tets,
        ] {
            for handles in [Handles::Boundary, Handles::Sparse { fraction: 0.05 }] {
                let case = tangled_case(&TangledParams {
                    kind,
                    elements: 600,
                    handles,
                    scramble: 0.3,
                    seed: 5,
                })
                .unwrap();
                let before = case.inverted_in_init();
                assert!(before > 0);
                let r = solve_and_check(&case);
                let u = r.untangle.expect("a tangled start is untangled");
                assert_eq!((u.inverted_start, u.inverted_end), (before, 0), "{kind:?}");
                assert!(u.untangled && u.stages >= 1);
            }
        }
    }

    /// Factorizing every 5th stage untangles what factorizing every
    /// stage does, handles bit for bit, with fewer factorizations than
    /// stages; factorizing every stage pays one per stage.
    #[test]
    fn a_reused_factor_untangles_with_fewer_factorizations() {
        let case = tangled_case(&TangledParams {
            kind: TangledKind::Tets,
            elements: 600,
            handles: Handles::Sparse { fraction: 0.05 },
            scramble: 0.3,
            seed: 7,
        })
        .unwrap();
        let mesh = ParamMesh::from_tets(&case.to_tet_mesh().unwrap()).unwrap();
        let start: Vec<f64> = case.init.iter().flat_map(|p| *p).collect();
        let mut fixed = vec![false; mesh.num_vertices()];
        for &v in &case.fixed {
            fixed[v as usize] = true;
        }
        for refactor_every in [1, 5] {
            let mut x = start.clone();
            let untangler = Untangler {
                refactor_every,
                ..Untangler::default()
            };
            let r = untangler.run(&mesh, &mut x, &fixed).unwrap();
            assert!(r.untangled && r.inverted_end == 0, "{r:?}");
            assert_eq!(inverted_count(&mesh, &x), 0);
            if refactor_every == 1 {
                assert_eq!(r.factorizations, r.stages, "{r:?}");
            } else {
                assert!(r.factorizations < r.stages, "{r:?}");
            }
            for (v, &f) in fixed.iter().enumerate() {
                if f {
                    for c in 0..3 {
                        assert_eq!(x[3 * v + c].to_bits(), start[3 * v + c].to_bits());
                    }
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// Every generated tangled problem (feasible by construction) gets
        /// an injective map with its handles exact.
        #[test]
        fn every_feasible_tangled_problem_gets_an_injective_map(
            kind in prop_oneof![
                Just(TangledKind::Planar),
                Just(TangledKind::SurfaceToPlane),
                Just(TangledKind::Tets),
            ],
            sparse in any::<bool>(),
            scramble in 0.05f64..0.5,
            seed in 0u64..1000,
        ) {
            let handles = if sparse {
                Handles::Sparse { fraction: 0.05 }
            } else {
                Handles::Boundary
            };
            let case = tangled_case(&TangledParams { kind, elements: 300, handles, scramble, seed })
                .unwrap();
            solve_and_check(&case);
        }
    }

    #[test]
    fn a_flip_free_start_is_left_alone_and_settings_are_checked() {
        let case = tangled_case(&TangledParams {
            scramble: 0.0,
            ..TangledParams::default()
        })
        .unwrap();
        let mesh = ParamMesh::from_triangles(&case.to_tri_mesh().unwrap()).unwrap();
        let mut x: Vec<f64> = case.init.iter().flat_map(|p| [p[0], p[1]]).collect();
        let before = x.clone();
        let r = Untangler::default().run(&mesh, &mut x, &[]).unwrap();
        assert!(r.untangled && r.stages == 0 && r.inverted_start == 0);
        assert_eq!(x, before);
        assert_eq!(inverted_count(&mesh, &x), 0);
        for bad in [
            Untangler {
                theta: 1.0,
                ..Untangler::default()
            },
            Untangler {
                max_stages: 0,
                ..Untangler::default()
            },
            Untangler {
                stage_iterations: 0,
                ..Untangler::default()
            },
            Untangler {
                refactor_every: 0,
                ..Untangler::default()
            },
        ] {
            assert!(matches!(
                bad.run(&mesh, &mut x, &[]),
                Err(ParamError::Setting { .. })
            ));
        }
        let err = Untangler::default()
            .run(&mesh, &mut x[1..], &[])
            .unwrap_err();
        assert!(matches!(err, ParamError::Length { .. }), "{err}");
    }

    #[test]
    fn the_initializer_honours_pins_and_refuses_what_it_cannot_untangle() {
        use crate::initializer::{Constraints, Pin};
        let case = tangled_case(&TangledParams {
            elements: 200,
            scramble: 0.3,
            ..TangledParams::default()
        })
        .unwrap();
        let mesh = ParamMesh::from_triangles(&case.to_tri_mesh().unwrap()).unwrap();
        let start: Vec<f64> = case.init.iter().flat_map(|p| [p[0], p[1]]).collect();
        let pins: Vec<Pin> = case
            .fixed
            .iter()
            .map(|&v| Pin::planar(v, [case.init[v as usize][0], case.init[v as usize][1]]))
            .collect();
        let init = Untangle {
            start: start.clone(),
            untangler: Untangler::default(),
        };
        let map = init
            .initialize(
                &mesh,
                &Constraints {
                    pins: &pins,
                    ..Constraints::default()
                },
            )
            .unwrap();
        assert_eq!(inverted_count(&mesh, &map.x), 0);
        assert_eq!(map.detail("untangled"), Some("yes"));
        // Every vertex pinned where the start is tangled: nothing can move.
        let all: Vec<Pin> = (0..mesh.num_vertices() as u32)
            .map(|v| Pin::planar(v, [start[2 * v as usize], start[2 * v as usize + 1]]))
            .collect();
        let err = init
            .initialize(
                &mesh,
                &Constraints {
                    pins: &all,
                    ..Constraints::default()
                },
            )
            .unwrap_err();
        assert!(
            matches!(err, ParamError::NotUntangled { inverted, .. } if inverted > 0),
            "{err}"
        );
        assert!(err.to_string().contains("no flip-free map found"), "{err}");
    }

    #[test]
    fn an_infeasible_problem_ends_after_its_restarts_without_an_error() {
        // The boundary fixed in its mirror image: every map with it has a
        // negative signed area in all, so some triangle stays inverted
        // whatever the interior does.
        let case = tangled_case(&TangledParams {
            elements: 200,
            scramble: 0.1,
            ..TangledParams::default()
        })
        .unwrap();
        let mesh = ParamMesh::from_triangles(&case.to_tri_mesh().unwrap()).unwrap();
        let mut x: Vec<f64> = case.solution.iter().flat_map(|p| [-p[0], p[1]]).collect();
        let mut fixed = vec![false; mesh.num_vertices()];
        for &v in &case.fixed {
            fixed[v as usize] = true;
        }
        let before = x.clone();
        let report = Untangler::default().run(&mesh, &mut x, &fixed).unwrap();
        assert!(!report.untangled);
        assert!(report.inverted_end > 0);
        assert_eq!(report.restarts, MAX_RESTARTS);
        assert!(
            report.stages < Untangler::default().max_stages,
            "{report:?}"
        );
        assert!(x.iter().all(|v| v.is_finite()));
        for (v, &f) in fixed.iter().enumerate() {
            if f {
                assert_eq!(x[2 * v].to_bits(), before[2 * v].to_bits());
                assert_eq!(x[2 * v + 1].to_bits(), before[2 * v + 1].to_bits());
            }
        }
    }
}
