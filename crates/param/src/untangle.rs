//! Untangling: from any starting map, tangled or not, to one that inverts
//! no element, with fixed vertices exactly in place (Garanzha et al.,
//! "Foldover-free maps in 50 lines of code", ACM TOG 40(4), 2021;
//! ALGORITHMS 1.7).
//!
//! The [`Untangler`] minimizes the regularized energy
//! [`Untangling`](crate::energy::Untangling) for a decreasing sequence of
//! `eps`. Each stage runs projected Newton (steps not bounded by flips, an
//! Armijo line search) for a few iterations at a fixed `eps`; then, with
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
//! stage's relative progress. It stops as soon as every `det J >=`
//! [`MIN_DET_J`](crate::objective::MIN_DET_J) (an orientation certain
//! above rounding): the caller's flip-free solve takes over from there.
//!
//! The energy assumes `det J ~ 1` for a good map, so the untangler solves
//! against the rest mesh scaled to the map's size: `c^d sum_k |T_k| =
//! sum_k |T_k| det J_k` (the signed mapped measure, which for a fixed
//! boundary is the target's measure; the absolute one when the signed one
//! is not positive). Scaling the rest changes neither the elements'
//! orientation nor the fixed positions.
//!
//! [`Untangle`] wraps it as an [`Initializer`]: a starting map (positions
//! given, or another initializer's) made flip-free with the pipeline's
//! pins as fixed vertices.

use crate::energy::{Untangling, chi};
use crate::initializer::{Constraints, InitialMap, Initializer};
use crate::linesearch::Backtracking;
use crate::metrics::det_j;
use crate::objective::MIN_DET_J;
use crate::solver::{Executor, ProjectedNewton, Stopping};
use crate::{Objective, ParamError, ParamMesh};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The untangler's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Untangler {
    /// Weight `theta` of the volume term ([`Untangling::DEFAULT_THETA`]).
    pub theta: f64,
    /// Largest number of `eps` stages (200).
    pub max_stages: usize,
    /// Newton iterations per stage (10).
    pub stage_iterations: usize,
    /// Time limit in seconds (infinite).
    pub max_seconds: f64,
}

impl Default for Untangler {
    fn default() -> Self {
        Untangler {
            theta: Untangling::DEFAULT_THETA,
            max_stages: 200,
            stage_iterations: 10,
            max_seconds: f64::INFINITY,
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
    /// The first `eps`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub eps_start: f64,
    /// The last `eps`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub eps_end: f64,
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
        let scale = map_scale(mesh, &dets);
        let mut report = UntangleReport {
            inverted_start,
            min_det_start,
            inverted_end: inverted_start,
            min_det_end: min_det_start,
            stages: 0,
            iterations: 0,
            eps_start: f64::NAN,
            eps_end: f64::NAN,
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
        let solver = ProjectedNewton::default();
        let line_search = Backtracking::default();
        let mut layout = None;
        while report.stages < self.max_stages {
            let elapsed = t0.elapsed().as_secs_f64();
            if elapsed >= self.max_seconds {
                break;
            }
            let energy = Untangling {
                eps,
                theta: self.theta,
            };
            let mut objective = Objective::new(&scaled, &energy, 1.0, None, fixed)?;
            if let Some(l) = layout.clone() {
                objective = objective.with_layout(l)?;
            }
            let e_prev = objective.value(x, &[]);
            let solved = Executor::new(&solver)
                .line_search(&line_search)
                .stopping(Stopping {
                    grad_tol: 0.0,
                    decrement_tol: 1e-9,
                    max_iterations: self.stage_iterations,
                    max_seconds: self.max_seconds - elapsed,
                })
                .run(&mut objective, x, &mut [])?;
            if layout.is_none() {
                layout = Some(objective.layout()?);
            }
            report.stages += 1;
            report.iterations += solved.iterations;
            let e = objective.value(x, &[]);
            let dets = det_j(&scaled, x);
            d_min = dets.iter().copied().fold(f64::INFINITY, f64::min);
            report.eps_end = eps;
            if d_min * cd >= MIN_DET_J {
                break;
            }
            let sigma = (1.0 - e / e_prev).max(0.1);
            let mu = (1.0 - sigma) * chi(d_min, eps);
            if d_min < mu {
                eps = 2.0 * (mu * (mu - d_min)).sqrt();
            }
        }
        let dets = det_j(mesh, x);
        let (inverted_end, min_det_end) = inverted_and_min(&dets);
        report.inverted_end = inverted_end;
        report.min_det_end = min_det_end;
        report.untangled = min_det_end >= MIN_DET_J;
        report.seconds = t0.elapsed().as_secs_f64();
        Ok(report)
    }
}

/// `(#{det J <= 0}, min det J)`.
fn inverted_and_min(dets: &[f64]) -> (usize, f64) {
    (
        dets.iter().filter(|&&d| d <= 0.0 || d.is_nan()).count(),
        dets.iter().copied().fold(f64::INFINITY, f64::min),
    )
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
    use unfold_mesh::shapes::{grid_disk, kuhn_grid};

    /// A deterministic generator in [0, 1) (splitmix64).
    struct Mix(u64);
    impl Mix {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A grid's map with the boundary at a smooth bijective warp and the
    /// interior scrambled: feasible by construction (the warp is a solution).
    type Problem = (ParamMesh, Vec<f64>, Vec<bool>, Vec<f64>);
    type OnBoundary = Box<dyn Fn(&[f64]) -> bool>;

    pub(super) fn tangled_grid_pub(dim: usize, n: usize, seed: u64) -> Problem {
        tangled_grid(dim, n, seed)
    }

    fn tangled_grid(dim: usize, n: usize, seed: u64) -> Problem {
        let mut mix = Mix(seed);
        let (mesh, on_boundary): (ParamMesh, OnBoundary) = if dim == 2 {
            let m = grid_disk(n, n);
            let nn = n as f64;
            (
                ParamMesh::from_triangles(&m).unwrap(),
                Box::new(move |p: &[f64]| p[..2].iter().any(|&c| c == 0.0 || c == nn)),
            )
        } else {
            let m = kuhn_grid([n; 3], [1.0; 3]);
            let nn = n as f64;
            (
                ParamMesh::from_tets(&m).unwrap(),
                Box::new(move |p: &[f64]| p.iter().any(|&c| c == 0.0 || c == nn)),
            )
        };
        let w = n as f64;
        let warp = |p: &[f64]| -> Vec<f64> {
            let k = std::f64::consts::PI / w;
            (0..dim)
                .map(|i| {
                    let j = (i + 1) % dim;
                    p[i] + 0.08 * w * (k * p[j]).sin() * (k * p[i]).sin()
                })
                .collect()
        };
        let mut solution = Vec::new();
        let mut x = Vec::new();
        let mut fixed = Vec::new();
        for p in &mesh.rest {
            let p = &p.coords.as_slice()[..dim];
            let s = warp(p);
            solution.extend_from_slice(&s);
            let b = on_boundary(p);
            fixed.push(b);
            if b {
                x.extend_from_slice(&s);
            } else {
                x.extend((0..dim).map(|i| s[i] + 0.6 * (mix.next() - 0.5) * w));
            }
        }
        (mesh, x, fixed, solution)
    }

    #[test]
    fn untangles_scrambled_grids_with_the_boundary_exact() {
        for (dim, n) in [(2, 12), (3, 5)] {
            let (mesh, mut x, fixed, solution) = tangled_grid(dim, n, 7);
            assert_eq!(inverted_count(&mesh, &solution), 0);
            let start = x.clone();
            let before = inverted_count(&mesh, &x);
            assert!(before > 0, "the start must be tangled");
            let r = Untangler::default().run(&mesh, &mut x, &fixed).unwrap();
            assert!(r.untangled, "{dim}D: {r:?}");
            assert_eq!(inverted_count(&mesh, &x), 0);
            assert_eq!(r.inverted_start, before);
            for (v, &f) in fixed.iter().enumerate() {
                if f {
                    for i in 0..dim {
                        assert_eq!(x[dim * v + i].to_bits(), start[dim * v + i].to_bits());
                    }
                }
            }
            eprintln!("{dim}D n={n}: {r:?}");
        }
    }
}
#[cfg(test)]
mod scratch {
    #[test]
    fn scratch_sizes() {
        for (dim, n) in [(2usize, 100usize), (3, 15), (3, 19)] {
            let (mesh, mut x, fixed, _) = super::tests::tangled_grid_pub(dim, n, 3);
            let t = std::time::Instant::now();
            let r = super::Untangler::default()
                .run(&mesh, &mut x, &fixed)
                .unwrap();
            let t1 = t.elapsed().as_secs_f64();
            // then SD
            let sd = crate::energy::SymmetricDirichlet;
            let mut obj = crate::Objective::new(&mesh, &sd, 1.0, None, &fixed).unwrap();
            let solved = crate::Executor::new(&crate::ProjectedNewton::default())
                .run(&mut obj, &mut x, &mut [])
                .unwrap();
            eprintln!(
                "{dim}D n={n} elems={} untangle {t1:.2}s stages {} its {} | SD {} its {:?} total {:.2}s",
                mesh.num_elements(),
                r.stages,
                r.iterations,
                solved.iterations,
                solved.reason,
                t.elapsed().as_secs_f64()
            );
        }
    }
}
