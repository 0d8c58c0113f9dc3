//! Relaxation of one leaflet's 2D layout (ALGORITHMS 4.3).
//!
//! A leaflet is a 3D triangle mesh (the rest shape, vertices `p_i`) with a
//! 2D layout `q_i = (u_i, v_i)` whose annulus vertices are pinned. Two
//! relaxations move the other vertices (the free lower boundary included):
//!
//! - [`spring`]: the source's mass-spring method, explicit Euler steps on
//!   springs whose rest lengths are the 3D edge lengths. The baseline: it
//!   lowers length and area distortion, not angle distortion, and it can
//!   flip triangles (it counts them).
//! - [`symmetric_dirichlet`] (the default): minimizes the area-weighted 2D
//!   symmetric Dirichlet energy of the map from every 3D triangle to its uv
//!   triangle by projected Newton with the injective line search of
//!   `unfold-param`, so no triangle can ever flip.
//!
//! # Orientation
//!
//! [`ParamMesh::from_triangles`] expresses every 3D triangle `(p0, p1, p2)`
//! in its own orthonormal frame (x along `p1 - p0`, y towards `p2`), so its
//! rest edge matrix `Dm` always has `det Dm > 0`: a uv triangle is
//! positively oriented (`det J = det Ds / det Dm > 0`) when its corners
//! `(q0, q1, q2)` run counter-clockwise in the `(u, v)` plane (u to the
//! right, v up), i.e. `(q1 - q0) x (q2 - q0) > 0`. Nothing in a leaflet's
//! vertex order fixes this: a layout can be the mirror image of that
//! convention (triangles wound the other way round in 3D, or u running the
//! other way). Both relaxations therefore take the orientation of the
//! *majority* of the input triangles (by count; a tie goes to the sign of
//! the total signed area) as "positive"; the triangles of the other sign,
//! or of zero area, are *flipped*. When the majority is clockwise,
//! [`symmetric_dirichlet`] hands `(-u, v)` to the framework and mirrors the
//! result back (the energies are invariant under the reflection, so this is
//! the same minimization). The longitude layout of a leaflet from
//! `unfold_mesh::shapes::mitral_valve` (u increasing along the annulus,
//! v decreasing down the columns) is counter-clockwise, needing no mirror.

use super::RelaxError;
use crate::OrganError;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::time::Instant;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::{flipped_indices, majority_sign, twice_signed_areas_2d};
use unfold_param::energy::SymmetricDirichlet;
use unfold_param::metrics::unique_edges;
use unfold_param::{
    DistortionEnergy, Executor, LineSearch, Objective, ParamMesh, ProjectedNewton, SolveReport,
    Solver, Stopping, Untangler,
};

/// Largest move of a vertex in one [`spring`] step, as a fraction of its
/// shortest incident 2D edge (before the step): the global step `h` is
/// lowered until `h |F_i| <= SPRING_MAX_MOVE * min_j |q_j - q_i|` for every
/// free vertex `i`. This is the source's "forces scaled down to avoid
/// crossings"; it makes crossings rarer but does not exclude them (a thin
/// triangle flips when its apex crosses the opposite edge, which can be
/// much closer than the shortest edge). On the generator's valves the
/// limit binds during the first steps (short edges with large forces near
/// the commissures), so there it, not `step_scale`, sets the pace.
pub const SPRING_MAX_MOVE: f64 = 0.5;

/// [`spring`] stops early (converged) when the largest force on a free
/// vertex is at most `SPRING_FORCE_TOL` times the mean 3D edge length.
pub const SPRING_FORCE_TOL: f64 = 1e-9;

/// Settings of the spring relaxation ([`spring`]).
///
/// The force on a free vertex `i` is
///
/// ```text
/// F_i = sum_{j in N_i} k (|q_j - q_i| - |p_j - p_i|) (q_j - q_i) / |q_j - q_i|
/// ```
///
/// and one explicit Euler step is `q_i <- q_i + h F_i` with
/// `h = min(step_scale, min_i SPRING_MAX_MOVE l_i / |F_i|)`, `l_i` the
/// shortest 2D edge at `i`. `k` and `step_scale` only enter as the product
/// `k step_scale` (up to the move limit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SpringConfig {
    /// Number of Euler steps (the source evaluates 5; default 5). 0 leaves
    /// the layout as it is.
    pub iterations: usize,
    /// The Euler step `h` before the move limit ([`SPRING_MAX_MOVE`]), in
    /// `(0, inf)`; default 0.25. An interior vertex of a regular mesh
    /// feels about 3 k per unit of displacement (six springs, each
    /// contributing `k cos^2` of its angle), and the stiffest (alternating)
    /// mode of the whole mesh about twice that, so explicit Euler is stable
    /// for `h k` below about 1/3; 0.25 is inside that bound and relaxes
    /// length distortion well in 5 steps.
    pub step_scale: f64,
    /// The spring constant `k` (the source's 1; default 1), `> 0`.
    pub stiffness: f64,
}

impl Default for SpringConfig {
    fn default() -> Self {
        SpringConfig {
            iterations: 5,
            step_scale: 0.25,
            stiffness: 1.0,
        }
    }
}

impl SpringConfig {
    /// Checks the values: `step_scale` and `stiffness` finite and `> 0`.
    ///
    /// # Errors
    /// [`OrganError::Config`] naming the offending value.
    pub fn validate(&self) -> Result<(), OrganError> {
        OrganError::check_positive(&[
            ("spring step_scale", self.step_scale),
            ("spring stiffness", self.stiffness),
        ])
    }
}

/// Newton step expansion of the symmetric Dirichlet relaxation
/// ([`ProjectedNewton::expand`]): on the bench series the full projected
/// Newton step falls short in the middle iterations (the clamped twist
/// modes overestimate the curvature); trying 1.5 and 2.25 times it takes
/// the leaflets from 9 and 8 Newton iterations to 7 and 7.
pub const STEP_EXPANSION: f64 = 1.5;

/// Settings of the symmetric Dirichlet relaxation ([`symmetric_dirichlet`]).
///
/// The objective is `phi(q) = sum_t w_t D(J_t)` with `w_t = A_t / sum A`
/// (rest areas, so the weights sum to 1 and `phi >= 4`) and
/// `D(J) = |J|_F^2 + |J^-1|_F^2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SdConfig {
    /// Stop when `|grad phi|_F sqrt(A) < grad_tol`, with `A` the total 3D
    /// area of the leaflet and the gradient over the free coordinates.
    /// `phi` is dimensionless and its gradient scales as `1 / length` and
    /// (for a given distortion) does not grow with the number of vertices,
    /// so this test is independent of units and resolution. Finite and
    /// `> 0`; default 1e-6.
    pub grad_tol: f64,
    /// Newton also stops (converged) once a step's predicted decrease, the
    /// decrement `-g.d / 2`, is below `decrement_tol * phi`: that step is
    /// taken and the solve ends. Finite and `> 0`; default 1e-7. On the
    /// generator's valves (bench, default and open) this saves one Newton
    /// iteration per leaflet against 1e-12 (with `grad_tol` 1e-9) and moves
    /// no vertex by more than 1.7e-5 mm (per-triangle energies within 3e-6
    /// relative).
    pub decrement_tol: f64,
    /// Largest number of Newton iterations (default 100; 0 only evaluates
    /// the start). Expect about 10-30.
    pub max_iterations: usize,
}

impl Default for SdConfig {
    fn default() -> Self {
        SdConfig {
            grad_tol: 1e-6,
            decrement_tol: 1e-7,
            max_iterations: 100,
        }
    }
}

impl SdConfig {
    /// Checks the values: `grad_tol` and `decrement_tol` finite and `> 0`.
    ///
    /// # Errors
    /// [`OrganError::Config`] naming the offending value.
    pub fn validate(&self) -> Result<(), OrganError> {
        OrganError::check_positive(&[
            ("sd grad_tol", self.grad_tol),
            ("sd decrement_tol", self.decrement_tol),
        ])
    }
}

/// What a relaxation did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RelaxReport {
    /// `"spring"` or `"sd"`.
    pub method: Cow<'static, str>,
    /// Steps taken: Euler steps ([`spring`]) or Newton iterations
    /// ([`symmetric_dirichlet`]); 0 when every vertex is fixed.
    pub iterations: usize,
    /// [`spring`]: the largest force on a free vertex at the end is at most
    /// [`SPRING_FORCE_TOL`] times the mean 3D edge length (rarely after a
    /// few steps). [`symmetric_dirichlet`]: the gradient or Newton
    /// decrement test was met. True when nothing is free.
    pub converged: bool,
    /// Triangles of the final layout whose signed area is zero or of the
    /// sign opposite to the input's majority (see the module docs). Always
    /// 0 after [`symmetric_dirichlet`].
    pub flipped_triangles: usize,
    /// Triangles flipped (or of zero area) in the starting layout that the
    /// untangler (ALGORITHMS 1.7) made flip-free before the symmetric
    /// Dirichlet solve; 0 for a flip-free start and for [`spring`].
    #[serde(default)]
    pub untangled_triangles: usize,
    /// Wall-clock seconds, input checks included.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
}

/// Checks the lengths of `uv` and `fixed` against the mesh and that `uv` is
/// finite; returns the rest data (which validates the 3D mesh: indices,
/// finite positions, no degenerate triangle).
fn check_inputs(mesh: &TriMesh, uv: &[[f64; 2]], fixed: &[bool]) -> Result<ParamMesh, OrganError> {
    let n = mesh.positions.len();
    if uv.len() != n {
        return Err(RelaxError::UvCount {
            uv_positions: uv.len(),
            vertices: n,
        }
        .into());
    }
    if fixed.len() != n {
        return Err(RelaxError::FixedCount {
            fixed_flags: fixed.len(),
            vertices: n,
        }
        .into());
    }
    if let Some(v) = uv
        .iter()
        .position(|q| !(q[0].is_finite() && q[1].is_finite()))
    {
        return Err(RelaxError::UvNotFinite {
            vertex: v,
            uv: uv[v],
        }
        .into());
    }
    Ok(ParamMesh::from_triangles(mesh)?)
}

/// Spring forces `F_i` (zero on fixed vertices) and the shortest positive
/// 2D edge length at every vertex (INFINITY when none).
fn spring_forces(
    edges: &[[u32; 2]],
    rest: &[f64],
    uv: &[[f64; 2]],
    fixed: &[bool],
    k: f64,
    force: &mut [[f64; 2]],
    shortest: &mut [f64],
) {
    force.iter_mut().for_each(|f| *f = [0.0; 2]);
    shortest.iter_mut().for_each(|s| *s = f64::INFINITY);
    for (&[i, j], &l0) in edges.iter().zip(rest) {
        let (i, j) = (i as usize, j as usize);
        let d = [uv[j][0] - uv[i][0], uv[j][1] - uv[i][1]];
        let l = d[0].hypot(d[1]);
        if l <= 0.0 {
            // No direction: the spring cannot act (a collapsed edge).
            continue;
        }
        shortest[i] = shortest[i].min(l);
        shortest[j] = shortest[j].min(l);
        // Longer than at rest (l > l0): pulls i towards j and j towards i.
        let s = k * (l - l0) / l;
        let f = [s * d[0], s * d[1]];
        if !fixed[i] {
            force[i][0] += f[0];
            force[i][1] += f[1];
        }
        if !fixed[j] {
            force[j][0] -= f[0];
            force[j][1] -= f[1];
        }
    }
}

/// The source's mass-spring relaxation (ALGORITHMS 4.3), in place.
///
/// Every edge `(i, j)` of `mesh` is a spring of stiffness `k =
/// config.stiffness` whose rest length is its 3D length `|p_j - p_i|`.
/// Each of `config.iterations` explicit Euler steps computes, from the
/// current layout, the force on every free vertex
///
/// ```text
/// F_i = sum_{j in N_i} k (|q_j - q_i| - |p_j - p_i|) (q_j - q_i) / |q_j - q_i|
/// ```
///
/// (an edge longer in 2D than in 3D pulls its ends together; this is the
/// source's formula (44) with the sign that makes it a restoring force, the
/// source omits it) and moves all free vertices at once, `q_i <- q_i + h
/// F_i`, with `h = min(step_scale, min_i SPRING_MAX_MOVE l_i / |F_i|)` and
/// `l_i` the shortest 2D edge at `i` ([`SPRING_MAX_MOVE`]). `F = -grad E`
/// for `E = k/2 sum_edges (|q_j - q_i| - |p_j - p_i|)^2`, so this is
/// gradient descent on that energy with a fixed step. Fixed vertices
/// (`fixed[i]`, the annulus) never move. Stops early when the forces vanish
/// ([`SPRING_FORCE_TOL`]).
///
/// It does **not** guarantee a flip-free result: the report counts the
/// triangles whose orientation differs from the input's majority (or whose
/// area is zero). A start with flipped triangles is accepted.
///
/// # Errors
/// `Config` for a non-finite or non-positive `step_scale` or `stiffness`;
/// `Mitral` ([`RelaxError`]) when `uv` or `fixed` does not have one entry
/// per vertex or `uv` is not finite; `Param` / `Mesh` for an unusable 3D mesh (bad indices,
/// degenerate triangles). On error `uv` is unchanged.
pub fn spring(
    mesh: &TriMesh,
    uv: &mut [[f64; 2]],
    fixed: &[bool],
    config: &SpringConfig,
) -> Result<RelaxReport, OrganError> {
    let t0 = Instant::now();
    config.validate()?;
    let pm = check_inputs(mesh, uv, fixed)?;
    let sign = majority_sign(&twice_signed_areas_2d(uv, &mesh.triangles));
    let n = uv.len();
    let edges = unique_edges(&pm);
    let rest: Vec<f64> = edges
        .iter()
        .map(|&[i, j]| (pm.rest[i as usize] - pm.rest[j as usize]).norm())
        .collect();
    let tol = SPRING_FORCE_TOL * rest.iter().sum::<f64>() / rest.len().max(1) as f64;
    let mut force = vec![[0.0; 2]; n];
    let mut shortest = vec![f64::INFINITY; n];
    let free: Vec<usize> = (0..n).filter(|&i| !fixed[i]).collect();
    // The largest force on a free vertex of the current layout.
    let evaluate = |uv: &[[f64; 2]], force: &mut [[f64; 2]], shortest: &mut [f64]| {
        spring_forces(&edges, &rest, uv, fixed, config.stiffness, force, shortest);
        free.iter()
            .map(|&i| force[i][0].hypot(force[i][1]))
            .fold(0.0, f64::max)
    };
    let mut iterations = 0;
    let mut f_max = evaluate(uv, &mut force, &mut shortest);
    while iterations < config.iterations && f_max > tol {
        let mut h = config.step_scale;
        for &i in &free {
            let f = force[i][0].hypot(force[i][1]);
            if f > 0.0 && shortest[i].is_finite() {
                h = h.min(SPRING_MAX_MOVE * shortest[i] / f);
            }
        }
        for &i in &free {
            uv[i][0] += h * force[i][0];
            uv[i][1] += h * force[i][1];
        }
        iterations += 1;
        f_max = evaluate(uv, &mut force, &mut shortest);
    }
    Ok(RelaxReport {
        method: "spring".into(),
        iterations,
        converged: f_max <= tol,
        flipped_triangles: flipped_indices(&twice_signed_areas_2d(uv, &mesh.triangles), sign).len(),
        untangled_triangles: 0,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Flip-free relaxation (ALGORITHMS 4.3, the default), in place: minimizes
///
/// ```text
/// phi(q) = sum_t w_t D(J_t),   D(J) = |J|_F^2 + |J^-1|_F^2 = s1^2 + s2^2 + s1^-2 + s2^-2,
/// w_t = A_t / sum_t' A_t'
/// ```
///
/// over the free vertices, `J_t` the Jacobian of the affine map from 3D
/// triangle `t` (in its own 2D frame) to its uv triangle and `A_t` its 3D
/// area; `phi >= 4`, with 4 only for an isometric layout. The fixed
/// vertices (`fixed[i]`, the annulus) keep their positions bit for bit and
/// the rest of the boundary is free. Solved by
/// [`ProjectedNewton`] (PSD-projected Hessians, sparse Cholesky) with the
/// injective line search (every step is at most 0.9 times the first step
/// at which a triangle would flip, then Armijo backtracking), starting
/// from `uv`, through `Objective::new(&mesh, &SymmetricDirichlet, 1.0,
/// None, fixed)`. `D` is infinite at `det J -> 0`, so every accepted
/// iterate is flip-free.
///
/// A `uv` with flipped or zero-area triangles (against the majority
/// orientation) is untangled first with the fixed vertices in place
/// ([`Untangler`], ALGORITHMS 1.7; counted in `untangled_triangles`); a
/// clockwise layout is mirrored for the solve and back (module docs). Vertices in no triangle stay where they
/// are. With every vertex fixed nothing is done (0 iterations, converged). Stops as set by `config` ([`SdConfig`]).
///
/// # Errors
/// `Config` for a bad `grad_tol`; `Mitral` ([`RelaxError`]) for wrong
/// lengths, non-finite uv, a start with flipped or zero-area triangles that
/// the untangler cannot make flip-free (or,
/// never expected, a result with flipped triangles:
/// [`RelaxError::InternalFlippedResult`]); `Param` / `Mesh` for an
/// unusable 3D mesh or a failed solve. On error `uv` is unchanged.
pub fn symmetric_dirichlet(
    mesh: &TriMesh,
    uv: &mut [[f64; 2]],
    fixed: &[bool],
    config: &SdConfig,
) -> Result<RelaxReport, OrganError> {
    let solver = default_solver();
    let pieces = Minimizer {
        energy: &SymmetricDirichlet,
        solver: &solver,
        line_search: None,
    };
    minimize(mesh, uv, fixed, config, &pieces, None)
}

/// The relaxation's default solver: projected Newton without the exact
/// Hessian first, with step expansion [`STEP_EXPANSION`]. The unprojected
/// Hessian does not pay here: on the generator's valves it is indefinite
/// for the first iterations (the attempt costs a Hessian and a failed
/// factorization), and where it does factorize later the iteration count
/// is the same (9 and 7 on the bench valve either way).
pub fn default_solver() -> ProjectedNewton {
    ProjectedNewton {
        exact_first: false,
        expand: STEP_EXPANSION,
        ..ProjectedNewton::default()
    }
}

/// The pieces of the flip-free relaxation ([`minimize`]).
#[derive(Debug, Clone, Copy)]
pub struct Minimizer<'a> {
    /// The distortion energy `D` (a barrier energy keeps every iterate
    /// flip-free by itself; any energy stays flip-free through the
    /// injective line search).
    pub energy: &'a dyn DistortionEnergy,
    /// The solver.
    pub solver: &'a dyn Solver,
    /// The line search (`None`: the solver's own).
    pub line_search: Option<&'a dyn LineSearch>,
}

/// Hessian layouts kept across the relaxations of a series: a leaflet
/// whose connectivity and annulus were seen before reuses them
/// ([`unfold_param::LayoutCache`]). Safe to share between threads.
pub use unfold_param::LayoutCache;

/// The flip-free relaxation with any energy, solver and line search
/// ([`Minimizer`]; [`symmetric_dirichlet`] is the published one), with an
/// optional [`LayoutCache`]: the Hessian layout is taken from `cache` when
/// one fits this leaflet (same triangles, same fixed vertices) and added to
/// it otherwise. The result is the same as without the cache, bit for bit.
/// `phi(q) = sum_t w_t D(J_t)` as in [`symmetric_dirichlet`], with the
/// minimizer's `D`.
///
/// # Errors
/// As [`symmetric_dirichlet`].
pub fn minimize(
    mesh: &TriMesh,
    uv: &mut [[f64; 2]],
    fixed: &[bool],
    config: &SdConfig,
    pieces: &Minimizer<'_>,
    cache: Option<&LayoutCache>,
) -> Result<RelaxReport, OrganError> {
    let t0 = Instant::now();
    config.validate()?;
    let pm = check_inputs(mesh, uv, fixed)?;
    let areas = twice_signed_areas_2d(uv, &mesh.triangles);
    let sign = majority_sign(&areas);
    let bad = flipped_indices(&areas, sign);
    // Vertices in no triangle have no energy (and a singular Hessian
    // block): they stay where they are, like the fixed ones.
    let mut pinned = vec![true; fixed.len()];
    for t in &mesh.triangles {
        for &v in t {
            pinned[v as usize] = fixed[v as usize];
        }
    }
    let mut x: Vec<f64> = uv.iter().flat_map(|q| [sign * q[0], q[1]]).collect();
    // A folded start is untangled first (ALGORITHMS 1.7), the fixed
    // vertices in place; refused only when that finds no flip-free layout.
    if let Some(&first) = bad.first() {
        let untangled =
            !pinned.iter().all(|&f| f) && Untangler::default().run(&pm, &mut x, &pinned)?.untangled;
        if !untangled {
            return Err(RelaxError::FlippedStart {
                flipped: bad.len(),
                triangles: areas.len(),
                first,
            }
            .into());
        }
    }
    let done = |iterations: usize, converged: bool| RelaxReport {
        method: "sd".into(),
        iterations,
        converged,
        flipped_triangles: 0,
        untangled_triangles: bad.len(),
        seconds: t0.elapsed().as_secs_f64(),
    };
    if pinned.iter().all(|&f| f) {
        return Ok(done(0, true));
    }
    let total_area: f64 = pm.measure.iter().sum();
    let mut objective = Objective::new(&pm, pieces.energy, 1.0, None, &pinned)?;
    if let Some(cache) = cache {
        objective = cache.attach(objective)?;
    }
    let stopping = Stopping {
        grad_tol: config.grad_tol / total_area.sqrt(),
        max_iterations: config.max_iterations,
        decrement_tol: config.decrement_tol,
        ..Stopping::default()
    };
    let report: SolveReport = match pieces.line_search {
        Some(l) => Executor::new(pieces.solver).line_search(l),
        None => Executor::new(pieces.solver),
    }
    .stopping(stopping)
    .run(&mut objective, &mut x, &mut [])?;
    let mut q = uv.to_vec();
    for (i, qi) in q.iter_mut().enumerate() {
        if !pinned[i] {
            *qi = [sign * x[2 * i], x[2 * i + 1]];
        }
    }
    let bad = flipped_indices(&twice_signed_areas_2d(&q, &mesh.triangles), sign);
    if let Some(&first) = bad.first() {
        // Cannot happen with the injective line search; never hand out a
        // flipped layout as the flip-free one.
        return Err(RelaxError::InternalFlippedResult {
            flipped: bad.len(),
            first,
        }
        .into());
    }
    uv.copy_from_slice(&q);
    Ok(done(report.iterations, report.converged))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitral::MitralError;
    use proptest::prelude::*;
    use unfold_mesh::nalgebra::Point3;
    use unfold_mesh::shapes::{ValveParams, mitral_valve};
    use unfold_param::flips::check_no_flips;
    use unfold_param::metrics::{angle_energy, area_energy, inverted_count, length_energy};

    /// A leaflet with a starting layout and its pinned annulus.
    #[derive(Clone)]
    struct Case {
        mesh: TriMesh,
        uv: Vec<[f64; 2]>,
        fixed: Vec<bool>,
    }

    fn coarse() -> ValveParams {
        ValveParams {
            annulus_segments: 24,
            depth_segments: 4,
            ..ValveParams::default()
        }
    }

    fn fine() -> ValveParams {
        ValveParams {
            annulus_segments: 192,
            depth_segments: 32,
            ..ValveParams::default()
        }
    }

    /// The three valves of the acceptance table.
    fn valves() -> [(&'static str, ValveParams); 3] {
        [
            ("default", ValveParams::default()),
            ("coarse", coarse()),
            ("fine", fine()),
        ]
    }

    /// The longitude layout (ALGORITHMS 4.2): column `i` at `u` = arc length
    /// of its annulus vertex along the leaflet's annulus, `v_0 = 0` and
    /// `v_k = v_{k-1} - |p_k - p_{k-1}|` down the column. With `heights`
    /// the annulus keeps the saddle instead (as the plane modes of 4.1 do,
    /// with the plane `z = 0` of the generator's canonical frame):
    /// `v_0 = z`, `u_i = u_{i-1} + sqrt(|p_i - p_{i-1}|^2 - (z_i -
    /// z_{i-1})^2)`, and the column hangs from there.
    fn longitude_layout(mesh: &TriMesh, columns: &[Vec<u32>], heights: bool) -> Case {
        let p = &mesh.positions;
        let mut uv = vec![[f64::NAN; 2]; p.len()];
        let mut fixed = vec![false; p.len()];
        let mut u = 0.0;
        for (c, col) in columns.iter().enumerate() {
            let top = p[col[0] as usize];
            if c > 0 {
                let prev = p[columns[c - 1][0] as usize];
                let d = (top - prev).norm();
                u += if heights {
                    (d * d - (top.z - prev.z).powi(2)).sqrt()
                } else {
                    d
                };
            }
            let mut v = if heights { top.z } else { 0.0 };
            for (k, &i) in col.iter().enumerate() {
                if k > 0 {
                    v -= (p[i as usize] - p[col[k - 1] as usize]).norm();
                }
                uv[i as usize] = [u, v];
            }
            fixed[col[0] as usize] = true;
        }
        Case {
            mesh: mesh.clone(),
            uv,
            fixed,
        }
    }

    /// A leaflet of the valve `p` with its (straight) longitude layout.
    fn leaflet(p: &ValveParams, anterior: bool) -> Case {
        leaflet_with(p, anterior, false)
    }

    fn leaflet_with(p: &ValveParams, anterior: bool, heights: bool) -> Case {
        let s = mitral_valve(p).unwrap();
        if anterior {
            longitude_layout(&s.anterior, &s.anterior_longitudes, heights)
        } else {
            longitude_layout(&s.posterior, &s.posterior_longitudes, heights)
        }
    }

    fn name(anterior: bool) -> &'static str {
        if anterior { "anterior" } else { "posterior" }
    }

    fn flat(uv: &[[f64; 2]]) -> Vec<f64> {
        uv.iter().flat_map(|q| [q[0], q[1]]).collect()
    }

    fn mean(v: &[f64]) -> f64 {
        v.iter().sum::<f64>() / v.len() as f64
    }

    /// Mean area, angle (MIPS) and length energies of a layout
    /// (ALGORITHMS 4.4; arithmetic means over triangles, triangles and
    /// vertices, as the source).
    fn energies(mesh: &TriMesh, uv: &[[f64; 2]]) -> [f64; 3] {
        let pm = ParamMesh::from_triangles(mesh).unwrap();
        let x = flat(uv);
        [
            mean(&area_energy(&pm, &x)),
            mean(&angle_energy(&pm, &x).unwrap()),
            mean(&length_energy(&pm, &x)),
        ]
    }

    /// `sum_t w_t D(J_t)` of a counter-clockwise layout.
    fn sd_value(mesh: &TriMesh, uv: &[[f64; 2]]) -> f64 {
        let pm = ParamMesh::from_triangles(mesh).unwrap();
        let obj = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &[]).unwrap();
        obj.distortion(&flat(uv))
    }

    /// Flipped triangles of a counter-clockwise layout, counted by the
    /// framework (`det J <= 0`).
    fn inverted(mesh: &TriMesh, uv: &[[f64; 2]]) -> usize {
        let pm = ParamMesh::from_triangles(mesh).unwrap();
        inverted_count(&pm, &flat(uv))
    }

    /// `1/2 sum_edges (|q_j - q_i| - |p_j - p_i|)^2`, the energy the spring
    /// steps descend.
    fn spring_energy(mesh: &TriMesh, uv: &[[f64; 2]]) -> f64 {
        let pm = ParamMesh::from_triangles(mesh).unwrap();
        unique_edges(&pm)
            .iter()
            .map(|&[i, j]| {
                let (i, j) = (i as usize, j as usize);
                let l = (uv[i][0] - uv[j][0]).hypot(uv[i][1] - uv[j][1]);
                0.5 * (l - (pm.rest[i] - pm.rest[j]).norm()).powi(2)
            })
            .sum()
    }

    fn assert_fixed_unchanged(c: &Case, uv: &[[f64; 2]]) {
        for (i, (a, b)) in c.uv.iter().zip(uv).enumerate() {
            if c.fixed[i] {
                assert_eq!(
                    [a[0].to_bits(), a[1].to_bits()],
                    [b[0].to_bits(), b[1].to_bits()],
                    "fixed vertex {i} moved"
                );
            }
        }
    }

    fn sd(c: &Case) -> (Vec<[f64; 2]>, RelaxReport) {
        let mut uv = c.uv.clone();
        let r = symmetric_dirichlet(&c.mesh, &mut uv, &c.fixed, &SdConfig::default()).unwrap();
        (uv, r)
    }

    fn spring5(c: &Case) -> (Vec<[f64; 2]>, RelaxReport) {
        let mut uv = c.uv.clone();
        let r = spring(&c.mesh, &mut uv, &c.fixed, &SpringConfig::default()).unwrap();
        (uv, r)
    }

    /// A high saddle and fully billowing leaflets: the spring flips
    /// triangles of the anterior leaflet after 20 or more steps.
    fn billowing() -> ValveParams {
        ValveParams {
            saddle_height: 14.0,
            billow: 1.0,
            coaptation_depth: 8.0,
            ..ValveParams::default()
        }
    }

    /// Two triangles `0 1 2`, `1 3 2` of a unit square in 3D.
    fn square() -> TriMesh {
        TriMesh::new(
            vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(1.0, 1.0, 0.5),
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        )
    }

    // --- conventions -----------------------------------------------------

    #[test]
    fn longitude_layouts_are_counter_clockwise_as_param_mesh_expects() {
        for anterior in [true, false] {
            let c = leaflet(&coarse(), anterior);
            let pm = ParamMesh::from_triangles(&c.mesh).unwrap();
            check_no_flips(&pm, &flat(&c.uv)).unwrap();
            // Its mirror image is entirely inverted in the framework's
            // convention.
            let mirrored: Vec<[f64; 2]> = c.uv.iter().map(|q| [-q[0], q[1]]).collect();
            assert_eq!(
                inverted_count(&pm, &flat(&mirrored)),
                c.mesh.triangles.len()
            );
        }
    }

    #[test]
    fn sd_relaxes_a_mirrored_layout_to_the_mirrored_result() {
        let c = leaflet(&coarse(), true);
        let (uv, r) = sd(&c);
        let mut m = c.clone();
        m.uv.iter_mut().for_each(|q| q[0] = -q[0]);
        let (uvm, rm) = sd(&m);
        assert_eq!(rm.flipped_triangles, 0);
        assert!(rm.converged);
        assert_eq!(rm.iterations, r.iterations);
        assert_fixed_unchanged(&m, &uvm);
        // Clockwise throughout, like the input.
        assert!(
            twice_signed_areas_2d(&uvm, &m.mesh.triangles)
                .iter()
                .all(|&a| a < 0.0)
        );
        for (a, b) in uv.iter().zip(&uvm) {
            assert!((a[0] + b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
        }
    }

    /// The published relaxation (default solver and settings) through
    /// `cache`.
    fn sd_cached(
        mesh: &TriMesh,
        uv: &mut [[f64; 2]],
        fixed: &[bool],
        cache: &LayoutCache,
    ) -> RelaxReport {
        let solver = default_solver();
        let published = Minimizer {
            energy: &SymmetricDirichlet,
            solver: &solver,
            line_search: None,
        };
        minimize(
            mesh,
            uv,
            fixed,
            &SdConfig::default(),
            &published,
            Some(cache),
        )
        .unwrap()
    }

    /// Steps of a series relaxed in parallel build the shared leaflet's
    /// layout once (the cache is locked while a layout is built).
    #[test]
    fn parallel_steps_build_one_layout() {
        use rayon::prelude::*;
        let cache = LayoutCache::default();
        let c = leaflet(&coarse(), true);
        (0..8).into_par_iter().for_each(|step| {
            let mut moved = c.clone();
            for p in &mut moved.mesh.positions {
                p.z += 0.05 * step as f64 * p.x;
            }
            let mut uv = moved.uv.clone();
            sd_cached(&moved.mesh, &mut uv, &moved.fixed, &cache);
        });
        assert_eq!(cache.len(), 1);
    }

    #[test]
    fn sd_with_a_layout_cache_is_bitwise_the_same_and_shares_layouts() {
        let cache = LayoutCache::default();
        assert!(cache.is_empty());
        let c = leaflet(&coarse(), true);
        let (plain, rp) = sd(&c);
        let mut first = c.uv.clone();
        let r1 = sd_cached(&c.mesh, &mut first, &c.fixed, &cache);
        assert_eq!(cache.len(), 1);
        // Another time step: the same triangles and annulus, moved in 3D.
        let mut moved = c.clone();
        for p in &mut moved.mesh.positions {
            p.z += 0.1 * p.x;
        }
        let (plain_moved, _) = sd(&moved);
        let mut second = moved.uv.clone();
        sd_cached(&moved.mesh, &mut second, &moved.fixed, &cache);
        assert_eq!(cache.len(), 1, "the second step reuses the layout");
        assert_eq!(flat(&first), flat(&plain));
        assert_eq!(flat(&second), flat(&plain_moved));
        assert_eq!(r1.iterations, rp.iterations);
        // Another fixed set: a layout of its own.
        let mut fixed = c.fixed.clone();
        let v = fixed.iter().position(|&f| !f).unwrap();
        fixed[v] = true;
        let mut third = c.uv.clone();
        sd_cached(&c.mesh, &mut third, &fixed, &cache);
        assert_eq!(cache.len(), 2);
    }

    // --- symmetric Dirichlet -----------------------------------------------

    #[test]
    fn sd_is_flip_free_keeps_the_annulus_and_lowers_the_energy() {
        for (valve, p) in valves() {
            for anterior in [true, false] {
                let c = leaflet(&p, anterior);
                let (uv, r) = sd(&c);
                let what = format!("{valve} {}", name(anterior));
                assert_eq!(r.method, "sd");
                assert!(r.converged, "{what}: {r:?}");
                assert!(r.iterations >= 1 && r.iterations < 50, "{what}: {r:?}");
                assert_eq!(r.flipped_triangles, 0, "{what}");
                assert_eq!(inverted(&c.mesh, &uv), 0, "{what}");
                let pm = ParamMesh::from_triangles(&c.mesh).unwrap();
                check_no_flips(&pm, &flat(&uv)).unwrap();
                assert_fixed_unchanged(&c, &uv);
                let (e0, e1) = (sd_value(&c.mesh, &c.uv), sd_value(&c.mesh, &uv));
                assert!(e1 < e0 - 0.1, "{what}: {e0} -> {e1}");
                assert!(e1 >= 4.0, "{what}: {e1}");
                // A relaxed layout is (numerically) stationary: relaxing it
                // again changes nothing.
                let again = Case {
                    uv: uv.clone(),
                    ..c.clone()
                };
                let (uv2, r2) = sd(&again);
                assert!(r2.converged && r2.iterations <= 1, "{what}: {r2:?}");
                assert!((sd_value(&c.mesh, &uv2) - e1).abs() <= 1e-10 * e1);
            }
        }
    }

    #[test]
    fn sd_every_iterate_is_flip_free() {
        // Stopping after k iterations shows the k-th iterate.
        let c = leaflet(&billowing(), true);
        let mut last = sd_value(&c.mesh, &c.uv);
        for k in 1..=6 {
            let mut uv = c.uv.clone();
            let config = SdConfig {
                max_iterations: k,
                ..SdConfig::default()
            };
            let r = symmetric_dirichlet(&c.mesh, &mut uv, &c.fixed, &config).unwrap();
            assert!(r.iterations <= k);
            assert_eq!(inverted(&c.mesh, &uv), 0, "iterate {k}");
            let e = sd_value(&c.mesh, &uv);
            assert!(e <= last, "iterate {k}: {last} -> {e}");
            last = e;
        }
    }

    /// On a valve leaflet the expansion is taken (some step > 1) and saves
    /// Newton iterations against plain full steps, for the same optimum.
    #[test]
    fn sd_step_expansion_is_taken_and_saves_iterations() {
        let c = leaflet(&ValveParams::default(), true);
        let pm = ParamMesh::from_triangles(&c.mesh).unwrap();
        let run = |expand: f64| {
            let mut obj = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &c.fixed).unwrap();
            let mut x: Vec<f64> = c.uv.iter().flat_map(|q| [q[0], q[1]]).collect();
            let solver = ProjectedNewton {
                exact_first: false,
                expand,
                ..ProjectedNewton::default()
            };
            let mut h = unfold_param::History::default();
            let r = Executor::new(&solver)
                .stopping(Stopping {
                    grad_tol: 1e-9,
                    decrement_tol: 1e-12,
                    ..Stopping::default()
                })
                .observer(&mut h)
                .run(&mut obj, &mut x, &mut [])
                .unwrap();
            assert!(r.converged);
            h
        };
        let (plain, expanded) = (run(1.0), run(STEP_EXPANSION));
        assert!(expanded.0.iter().any(|i| i.step > 1.0));
        assert!(plain.0.iter().all(|i| i.step <= 1.0));
        assert!(
            expanded.0.len() < plain.0.len(),
            "{} vs {}",
            expanded.0.len(),
            plain.0.len()
        );
        let (a, b) = (
            plain.0.last().unwrap().value,
            expanded.0.last().unwrap().value,
        );
        assert!((a - b).abs() <= 1e-10 * a, "{a} vs {b}");
    }

    #[test]
    fn sd_zero_iterations_leaves_the_layout() {
        let c = leaflet(&coarse(), false);
        let mut uv = c.uv.clone();
        let config = SdConfig {
            max_iterations: 0,
            ..SdConfig::default()
        };
        let r = symmetric_dirichlet(&c.mesh, &mut uv, &c.fixed, &config).unwrap();
        assert_eq!(
            (r.iterations, r.converged, r.flipped_triangles),
            (0, false, 0)
        );
        assert_eq!(flat(&uv), flat(&c.uv));
    }

    #[test]
    fn sd_with_nothing_fixed_still_relaxes() {
        let mut c = leaflet(&coarse(), true);
        c.fixed.iter_mut().for_each(|f| *f = false);
        let (uv, r) = sd(&c);
        assert_eq!(r.flipped_triangles, 0);
        assert_eq!(inverted(&c.mesh, &uv), 0);
        assert!(sd_value(&c.mesh, &uv) < sd_value(&c.mesh, &c.uv));
    }

    #[test]
    fn sd_leaves_unreferenced_vertices() {
        let mut mesh = square();
        mesh.positions.push(Point3::new(5.0, 5.0, 5.0));
        let mut uv = vec![[0.0, 0.0], [1.3, 0.0], [0.0, 1.0], [1.1, 1.4], [7.0, 7.0]];
        let fixed = [true, false, true, false, false];
        let r = symmetric_dirichlet(&mesh, &mut uv, &fixed, &SdConfig::default()).unwrap();
        assert!(r.converged && r.iterations > 0, "{r:?}");
        assert_eq!(uv[4], [7.0, 7.0]);
        assert!(sd_value(&mesh, &uv) < 4.1);
        let r = spring(&mesh, &mut uv, &fixed, &SpringConfig::default()).unwrap();
        assert_eq!(r.flipped_triangles, 0);
        assert_eq!(uv[4], [7.0, 7.0]);
    }

    // --- spring ------------------------------------------------------------

    #[test]
    fn spring_reduces_length_distortion_on_the_default_valve() {
        for anterior in [true, false] {
            let c = leaflet(&ValveParams::default(), anterior);
            let (uv, r) = spring5(&c);
            assert_eq!(r.method, "spring");
            assert_eq!(r.iterations, 5);
            assert!(!r.converged);
            assert_eq!(r.flipped_triangles, inverted(&c.mesh, &uv));
            assert_fixed_unchanged(&c, &uv);
            let (before, after) = (energies(&c.mesh, &c.uv), energies(&c.mesh, &uv));
            assert!(after[2] < before[2] - 0.01, "{before:?} -> {after:?}");
            assert!(after[0] < before[0], "{before:?} -> {after:?}");
            assert!(spring_energy(&c.mesh, &uv) < spring_energy(&c.mesh, &c.uv));
            // Every step descends the spring energy.
            let mut last = spring_energy(&c.mesh, &c.uv);
            for k in 1..=5 {
                let mut uv = c.uv.clone();
                let config = SpringConfig {
                    iterations: k,
                    ..SpringConfig::default()
                };
                spring(&c.mesh, &mut uv, &c.fixed, &config).unwrap();
                let e = spring_energy(&c.mesh, &uv);
                assert!(e < last, "step {k}: {last} -> {e}");
                last = e;
            }
        }
    }

    #[test]
    fn spring_force_restores_rest_lengths() {
        // Vertex 3 free; its 2D edges too long, then too short.
        let mesh = square();
        let fixed = [true, true, true, false];
        let rest = (mesh.positions[3] - mesh.positions[1]).norm();
        for (start, longer) in [([1.6, 1.6], true), ([0.8, 0.8], false)] {
            let mut uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], start];
            let config = SpringConfig {
                iterations: 1,
                ..SpringConfig::default()
            };
            let r = spring(&mesh, &mut uv, &fixed, &config).unwrap();
            assert_eq!(r.iterations, 1);
            let l = |q: [f64; 2]| (q[0] - 1.0).hypot(q[1]);
            // Pulled in when too long, pushed out when too short, no
            // overshoot past the rest length.
            if longer {
                assert!(uv[3][0] < start[0] && l(uv[3]) >= rest);
            } else {
                assert!(uv[3][0] > start[0] && l(uv[3]) <= rest);
            }
            assert!((l(uv[3]) - rest).abs() < (l(start) - rest).abs());
        }
    }

    #[test]
    fn spring_converges_on_an_isometric_layout() {
        // A planar square laid out isometrically: no force, nothing moves.
        let mut mesh = square();
        mesh.positions[3].z = 0.0;
        let mut uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let r = spring(
            &mesh,
            &mut uv,
            &[true, false, false, false],
            &SpringConfig::default(),
        )
        .unwrap();
        assert_eq!(
            (r.iterations, r.converged, r.flipped_triangles),
            (0, true, 0)
        );
        assert_eq!(uv, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]);
    }

    #[test]
    fn spring_flips_triangles_where_sd_does_not() {
        let c = leaflet(&billowing(), true);
        assert_eq!(inverted(&c.mesh, &c.uv), 0);
        // Five steps keep this layout flip-free...
        let (uv5, r5) = spring5(&c);
        assert_eq!((r5.flipped_triangles, inverted(&c.mesh, &uv5)), (0, 0));
        // ...more steps towards the spring energy's minimum flip triangles
        // near the commissures, and the report says so.
        let mut uv = c.uv.clone();
        let config = SpringConfig {
            iterations: 50,
            ..SpringConfig::default()
        };
        let r = spring(&c.mesh, &mut uv, &c.fixed, &config).unwrap();
        assert_eq!(r.iterations, 50);
        assert!(r.flipped_triangles >= 5, "{r:?}");
        assert_eq!(r.flipped_triangles, inverted(&c.mesh, &uv));
        assert_fixed_unchanged(&c, &uv);
        // The same start through sd: flip-free.
        let (uv_sd, r_sd) = sd(&c);
        assert!(r_sd.converged);
        assert_eq!((r_sd.flipped_triangles, inverted(&c.mesh, &uv_sd)), (0, 0));
        // A flipped spring result is untangled by sd first, then relaxed.
        let mut from_spring = uv.clone();
        let r =
            symmetric_dirichlet(&c.mesh, &mut from_spring, &c.fixed, &SdConfig::default()).unwrap();
        assert_eq!(r.untangled_triangles, inverted(&c.mesh, &uv), "{r:?}");
        assert_eq!(
            (r.flipped_triangles, inverted(&c.mesh, &from_spring)),
            (0, 0)
        );
        assert_fixed_unchanged(&c, &from_spring);
    }

    #[test]
    fn spring_counts_flips_of_a_flipped_start() {
        let mesh = square();
        // Triangle 1 (1 3 2) clockwise: vertex 3 on the wrong side.
        let mut uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.2, 0.2]];
        let config = SpringConfig {
            iterations: 0,
            ..SpringConfig::default()
        };
        let r = spring(&mesh, &mut uv, &[true; 4], &config).unwrap();
        assert_eq!(r.flipped_triangles, 1);
        // The whole layout mirrored: the majority is clockwise now, so the
        // same triangle is the flipped one.
        let mut m = uv.map(|q| [-q[0], q[1]]);
        let r = spring(&mesh, &mut m, &[true; 4], &config).unwrap();
        assert_eq!(r.flipped_triangles, 1);
    }

    // --- acceptance: sd against the spring baseline ------------------------

    /// `[area, angle, length]` means of spring (5 steps) and sd from the
    /// same start.
    fn compare(c: &Case) -> ([f64; 3], [f64; 3]) {
        let (uv_spring, _) = spring5(c);
        let (uv_sd, _) = sd(c);
        (energies(&c.mesh, &uv_spring), energies(&c.mesh, &uv_sd))
    }

    fn table_row(label: &str, c: &Case, spring: [f64; 3], sd: [f64; 3]) -> String {
        let start = energies(&c.mesh, &c.uv);
        format!(
            "{label:<28} area {:.4} / {:.4} / {:.4}  angle {:.4} / {:.4} / {:.4}  length {:.4} / \
             {:.4} / {:.4}",
            start[0], spring[0], sd[0], start[1], spring[1], sd[1], start[2], spring[2], sd[2]
        )
    }

    #[test]
    fn sd_has_lower_angle_distortion_than_spring() {
        for heights in [false, true] {
            for (valve, p) in valves() {
                for anterior in [true, false] {
                    let c = leaflet_with(&p, anterior, heights);
                    let (e_spring, e_sd) = compare(&c);
                    let label = format!("{valve} {} heights={heights}", name(anterior));
                    eprintln!("{}", table_row(&label, &c, e_spring, e_sd));
                    assert!(e_sd[1] < e_spring[1] - 0.02, "{label}: angle");
                }
            }
        }
    }

    /// The issue's acceptance criterion: sd's mean angle energy lower, its
    /// mean length and area energies no higher than the spring's.
    fn assert_acceptance(label: &str, c: &Case) {
        let (e_spring, e_sd) = compare(c);
        let row = table_row(label, c, e_spring, e_sd);
        assert!(e_sd[1] < e_spring[1], "angle: {row}");
        assert!(e_sd[2] <= e_spring[2], "length: {row}");
        assert!(e_sd[0] <= e_spring[0], "area: {row}");
    }

    #[test]
    fn acceptance_holds_on_posterior_leaflets_and_saddle_layouts() {
        for (valve, p) in valves() {
            assert_acceptance(&format!("{valve} posterior"), &leaflet(&p, false));
        }
        for (valve, p) in [("default", ValveParams::default()), ("fine", fine())] {
            for anterior in [true, false] {
                let c = leaflet_with(&p, anterior, true);
                assert_acceptance(&format!("{valve} {} heights", name(anterior)), &c);
            }
        }
    }

    // --- nothing to do, bad input ------------------------------------------

    #[test]
    fn all_fixed_is_a_no_op() {
        let c = leaflet(&coarse(), true);
        let all = vec![true; c.uv.len()];
        let mut uv = c.uv.clone();
        let r = symmetric_dirichlet(&c.mesh, &mut uv, &all, &SdConfig::default()).unwrap();
        assert_eq!(
            (r.method.as_ref(), r.iterations, r.converged),
            ("sd", 0, true)
        );
        let r = spring(&c.mesh, &mut uv, &all, &SpringConfig::default()).unwrap();
        assert_eq!(
            (r.method.as_ref(), r.iterations, r.converged),
            ("spring", 0, true)
        );
        assert_eq!(r.flipped_triangles, 0);
        assert_eq!(flat(&uv), flat(&c.uv));
    }

    #[test]
    fn spring_zero_iterations_is_a_no_op() {
        let c = leaflet(&coarse(), false);
        let mut uv = c.uv.clone();
        let config = SpringConfig {
            iterations: 0,
            ..SpringConfig::default()
        };
        let r = spring(&c.mesh, &mut uv, &c.fixed, &config).unwrap();
        assert_eq!(
            (r.iterations, r.converged, r.flipped_triangles),
            (0, false, 0)
        );
        assert_eq!(flat(&uv), flat(&c.uv));
    }

    #[test]
    fn sd_untangles_a_folded_start_and_refuses_one_it_cannot_move() {
        let c = leaflet(&coarse(), true);
        // Swap a free vertex with its neighbour down the column: the
        // triangles between them flip; a collapsed triangle has zero area.
        let s = mitral_valve(&coarse()).unwrap();
        let (a, b) = (
            s.anterior_longitudes[5][1] as usize,
            s.anterior_longitudes[5][2] as usize,
        );
        let mut swapped = c.uv.clone();
        swapped.swap(a, b);
        let mut collapsed = c.uv.clone();
        let t = c.mesh.triangles[7];
        collapsed[t[2] as usize] = collapsed[t[1] as usize];
        for start in [swapped, collapsed] {
            let mut uv = start.clone();
            let r = symmetric_dirichlet(&c.mesh, &mut uv, &c.fixed, &SdConfig::default()).unwrap();
            assert!(r.untangled_triangles > 0, "{r:?}");
            assert_eq!(r.flipped_triangles, 0);
            let pm = ParamMesh::from_triangles(&c.mesh).unwrap();
            let areas = twice_signed_areas_2d(&uv, &c.mesh.triangles);
            let sign = majority_sign(&areas);
            assert!(flipped_indices(&areas, sign).is_empty());
            assert_eq!(pm.num_elements(), areas.len());
            for (v, &f) in c.fixed.iter().enumerate() {
                if f {
                    assert_eq!(uv[v][0].to_bits(), start[v][0].to_bits());
                    assert_eq!(uv[v][1].to_bits(), start[v][1].to_bits());
                }
            }
        }
        // With every vertex fixed nothing can move: refused, uv unchanged.
        let mut bad = c.uv.clone();
        bad.swap(a, b);
        let before = bad.clone();
        let all = vec![true; c.fixed.len()];
        let err = symmetric_dirichlet(&c.mesh, &mut bad, &all, &SdConfig::default()).unwrap_err();
        let OrganError::Mitral(MitralError::Relax(RelaxError::FlippedStart {
            flipped,
            triangles,
            first,
        })) = err
        else {
            panic!("{err:?}");
        };
        assert!(flipped > 0 && first < triangles, "{err:?}");
        assert_eq!(triangles, c.mesh.triangles.len());
        let msg = err.to_string();
        assert!(msg.contains("flipped") && msg.contains("untangl"), "{msg}");
        assert!(!msg.contains('\n'));
        assert_eq!(flat(&bad), flat(&before));
    }

    #[test]
    fn wrong_lengths_and_non_finite_input_are_errors() {
        let c = leaflet(&coarse(), true);
        let n = c.uv.len();
        let sd_cfg = SdConfig::default();
        let sp_cfg = SpringConfig::default();
        let mut short = c.uv[..n - 1].to_vec();
        let e1 = symmetric_dirichlet(&c.mesh, &mut short, &c.fixed, &sd_cfg).unwrap_err();
        let e2 = spring(&c.mesh, &mut short, &c.fixed, &sp_cfg).unwrap_err();
        for e in [e1, e2] {
            assert_eq!(
                e,
                OrganError::Mitral(MitralError::Relax(RelaxError::UvCount {
                    uv_positions: n - 1,
                    vertices: n
                }))
            );
            assert!(e.to_string().contains("uv positions"), "{e}");
        }
        let mut uv = c.uv.clone();
        for fixed in [&c.fixed[..n - 1], &[][..]] {
            let expected = OrganError::Mitral(MitralError::Relax(RelaxError::FixedCount {
                fixed_flags: fixed.len(),
                vertices: n,
            }));
            let e = symmetric_dirichlet(&c.mesh, &mut uv, fixed, &sd_cfg).unwrap_err();
            assert_eq!(e, expected);
            assert!(e.to_string().contains("fixed flags"), "{e}");
            let e = spring(&c.mesh, &mut uv, fixed, &sp_cfg).unwrap_err();
            assert_eq!(e, expected);
            assert!(e.to_string().contains("fixed flags"), "{e}");
        }
        let mut nan = c.uv.clone();
        nan[40][1] = f64::NAN;
        let e = symmetric_dirichlet(&c.mesh, &mut nan, &c.fixed, &sd_cfg).unwrap_err();
        assert!(
            matches!(
                e,
                OrganError::Mitral(MitralError::Relax(RelaxError::UvNotFinite { vertex: 40, uv }))
                    if uv[1].is_nan()
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("vertex 40"), "{e}");
        let e = spring(&c.mesh, &mut nan, &c.fixed, &sp_cfg).unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        // A degenerate 3D triangle.
        let mut mesh = square();
        mesh.positions[3] = mesh.positions[1];
        let mut uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let fixed = [true, false, false, false];
        assert!(symmetric_dirichlet(&mesh, &mut uv, &fixed, &sd_cfg).is_err());
        assert!(spring(&mesh, &mut uv, &fixed, &sp_cfg).is_err());
        assert_eq!(uv, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]);
    }

    #[test]
    fn bad_configs_are_config_errors() {
        let c = leaflet(&coarse(), true);
        let mut uv = c.uv.clone();
        for (step_scale, stiffness) in [
            (f64::NAN, 1.0),
            (0.0, 1.0),
            (-0.5, 1.0),
            (f64::INFINITY, 1.0),
            (0.25, 0.0),
            (0.25, f64::NAN),
        ] {
            let config = SpringConfig {
                step_scale,
                stiffness,
                ..SpringConfig::default()
            };
            let e = spring(&c.mesh, &mut uv, &c.fixed, &config).unwrap_err();
            assert!(matches!(e, OrganError::Config(_)), "{e:?}");
            assert!(
                e.to_string().starts_with("invalid configuration: spring"),
                "{e}"
            );
        }
        for grad_tol in [f64::NAN, 0.0, -1.0, f64::INFINITY] {
            let config = SdConfig {
                grad_tol,
                ..SdConfig::default()
            };
            let e = symmetric_dirichlet(&c.mesh, &mut uv, &c.fixed, &config).unwrap_err();
            assert!(matches!(e, OrganError::Config(_)), "{e:?}");
            assert!(e.to_string().contains("grad_tol"), "{e}");
            let config = SdConfig {
                decrement_tol: grad_tol,
                ..SdConfig::default()
            };
            let e = symmetric_dirichlet(&c.mesh, &mut uv, &c.fixed, &config).unwrap_err();
            assert!(matches!(e, OrganError::Config(_)), "{e:?}");
            assert!(e.to_string().contains("decrement_tol"), "{e}");
        }
        assert_eq!(flat(&uv), flat(&c.uv));
        assert!(SpringConfig::default().validate().is_ok());
        assert!(SdConfig::default().validate().is_ok());
    }

    #[test]
    fn configs_serialize_and_fill_defaults() {
        let s = SpringConfig::default();
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<SpringConfig>(&json).unwrap(), s);
        let partial: SpringConfig = serde_json::from_str(r#"{"iterations": 12}"#).unwrap();
        assert_eq!(
            partial,
            SpringConfig {
                iterations: 12,
                ..SpringConfig::default()
            }
        );
        let d = SdConfig::default();
        assert_eq!((d.grad_tol, d.max_iterations), (1e-6, 100));
        let json = serde_json::to_string(&d).unwrap();
        assert_eq!(serde_json::from_str::<SdConfig>(&json).unwrap(), d);
        let partial: SdConfig = serde_json::from_str(r#"{"max_iterations": 7}"#).unwrap();
        assert_eq!(partial.max_iterations, 7);
        assert_eq!(partial.grad_tol, 1e-6);
        let r = spring5(&leaflet(&coarse(), true)).1;
        let v: serde_json::Value = serde_json::to_value(r).unwrap();
        assert_eq!(v["method"], "spring");
        assert_eq!(v["iterations"], 5);
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

        #[test]
        fn sd_is_flip_free_on_random_valves(
            saddle in 0.0..12.0f64,
            billow in 0.0..1.0f64,
            segments in 12usize..60,
            depth in 2usize..10,
            anterior in any::<bool>(),
            heights in any::<bool>(),
        ) {
            let p = ValveParams {
                saddle_height: saddle,
                billow,
                annulus_segments: segments,
                depth_segments: depth,
                coaptation_depth: 7.0,
                ..ValveParams::default()
            };
            let c = leaflet_with(&p, anterior, heights);
            let (uv, r) = sd(&c);
            prop_assert!(r.converged, "{:?}", r);
            prop_assert_eq!(r.flipped_triangles, 0);
            prop_assert_eq!(inverted(&c.mesh, &uv), 0);
            assert_fixed_unchanged(&c, &uv);
            prop_assert!(sd_value(&c.mesh, &uv) < sd_value(&c.mesh, &c.uv));
            let (uv_spring, r_spring) = spring5(&c);
            prop_assert_eq!(r_spring.flipped_triangles, inverted(&c.mesh, &uv_spring));
            assert_fixed_unchanged(&c, &uv_spring);
        }
    }
}
