//! The quality gates of the placenta's solve: a map that did not
//! move although it ends off the template, or one with a near-degenerate
//! tet, is not a right map.
//!
//! - `solve.template_error_start_voxels`: the template error of the start
//!   map with the starting parameters, `sqrt(sum_m A_m T(x0_m, theta0))`
//!   in voxels (recorded; it says whether the solve had to move).
//! - `solve.moved`: the largest vertex displacement of the solve,
//!   `max_i |x_i - x0_i|`, over the rest mesh's diameter (its bounding
//!   box diagonal). When the map ends off the template (its final error,
//!   with the parameters fitted, above [`ON_TEMPLATE_VOXELS`] voxels) the
//!   solve must have moved at least [`MIN_MOVED`] of the diameter: a solve
//!   that stopped where it began has not done its work. A start already on
//!   the template may stay (a mask that is an ellipsoid, mapped onto the
//!   ellipsoid template, moves rigidly and rightly). The ellipsoid's error
//!   is algebraic (`q - 1`, about twice the relative radial error), so for
//!   it the half-voxel tolerance is loose.
//! - `solve.min_det_j`: the smallest `det J` (mapped over rest volume of a
//!   tet) at least [`MIN_DET_J`]. A scale-invariant (conformal) energy such
//!   as MIPS has no term against a tet shrinking, so its optimum may hold
//!   near-collapsed tets (4.5e-11 on the demo): for it the map is kept and
//!   the failed gate is recorded with that fallback instead of refused.

use super::templates::PlacentaTemplate;
use crate::Requirement;
use crate::gate::{GateError, Gates};
use unfold_mesh::nalgebra::Point3;
use unfold_param::DistortionEnergy;
use unfold_param::metrics::template_matching_error;

/// A map within this many voxels (RMS over the boundary area) of the
/// template is on it: the images the map pulls back are sampled at voxel
/// size, so a half voxel is below what a map can resolve.
pub const ON_TEMPLATE_VOXELS: f64 = 0.5;

/// The least displacement, over the mesh's diameter, of a solve that
/// ended off the template. A solve that ran moves its vertices by a few
/// percent of the diameter (0.05 on the demo, 0.04 on a voxelized disc);
/// 1e-4 of it (0.02 mm on a 200 mm placenta, a fiftieth of a 1 mm voxel)
/// is below any step a solver takes from a map off its optimum, so only a
/// solve that did not move fails (a fetal-atlas case: "converged in 0 iterations",
/// the input rigidly moved).
pub const MIN_MOVED: f64 = 1e-4;

/// The smallest `det J` (volume ratio) of a right placenta map. The
/// template has the placenta's own thickness (its `h` and radii start from
/// the mesh's estimates), so a right map changes volumes by factors of a
/// few (the demo's smallest `det J` is about 0.5 for every energy); a tet
/// squashed to a ten-thousandth of its volume has collapsed, not flattened
/// (`--energy mips` gave 4.5e-11 on the demo), and the images sampled
/// through it would be smeared.
pub const MIN_DET_J: f64 = 1e-4;

/// What helps when the solve did not move.
pub const NOT_MOVED_FIX: &str = "the solve stopped where it started although the map is off the \
    template: lower --tol, raise --max-iterations, or use the default --solver newton";

/// What helps when a tet collapsed.
pub const DEGENERATE_FIX: &str = "a tet collapsed in the map: use --energy symmetric-dirichlet \
    (its barrier keeps det J away from 0) or raise --lambda";

/// The mesh's diameter: its bounding-box diagonal.
fn diameter(rest: &[Point3<f64>]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in rest {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt()
}

/// What the solve gates measure.
#[derive(Debug, Clone, Copy)]
pub struct SolveInput<'a> {
    /// Rest positions.
    pub rest: &'a [Point3<f64>],
    /// The start map, flat (`3 n`).
    pub start: &'a [f64],
    /// The solved map, flat (`3 n`), in the same frame as `start`.
    pub solved: &'a [f64],
    /// The template, its starting parameters, the side labels and the
    /// template weights.
    pub template: &'a dyn PlacentaTemplate,
    /// The template's starting parameters.
    pub theta_initial: &'a [f64],
    /// Per vertex side labels.
    pub labels: &'a [u8],
    /// Per vertex template weights.
    pub weights: &'a [f64],
    /// Smallest `det J` of the solved map.
    pub min_det_j: f64,
    /// The solved map's template error, `sqrt(sum_m A_m T(x_m, theta))`.
    pub final_error_mm: f64,
    /// The voxel size, mm.
    pub voxel_mm: f64,
    /// Whether the energy resists a uniform scaling (see
    /// [`resists_scaling`]); `false` records a collapsed tet instead of
    /// refusing it.
    pub resists_scaling: bool,
}

/// Whether `energy` is higher at `J = 2 I` than at `J = I`: an energy that
/// is not (a conformal one) is blind to volume and cannot keep tets from
/// shrinking.
pub fn resists_scaling(energy: &dyn DistortionEnergy) -> bool {
    let (one, two) = (energy.value(&[1.0; 3]), energy.value(&[2.0; 3]));
    two - one > 1e-9 * one.abs().max(1.0)
}

/// Checks the solve (module docs), appending to `gates`.
///
/// # Errors
/// [`GateError`] for a solve that did not move from a start off the
/// template, or a collapsed tet.
pub fn check_solve(input: &SolveInput<'_>, gates: &mut Gates) -> Result<(), GateError> {
    let start_error = template_matching_error(
        input.template,
        input.labels,
        input.start,
        3,
        input.weights,
        input.theta_initial,
    ) / input.voxel_mm;
    gates.check(
        "solve.template_error_start_voxels",
        start_error,
        Requirement::NonNegative,
        NOT_MOVED_FIX,
    )?;
    let moved = input
        .start
        .chunks_exact(3)
        .zip(input.solved.chunks_exact(3))
        .map(|(a, b)| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
        / diameter(input.rest);
    let must_move = if input.final_error_mm / input.voxel_mm > ON_TEMPLATE_VOXELS {
        Requirement::AtLeast(MIN_MOVED)
    } else {
        Requirement::NonNegative
    };
    gates.check("solve.moved", moved, must_move, NOT_MOVED_FIX)?;
    let requirement = Requirement::AtLeast(MIN_DET_J);
    if input.resists_scaling {
        gates.check(
            "solve.min_det_j",
            input.min_det_j,
            requirement,
            DEGENERATE_FIX,
        )
    } else {
        gates.fallback(
            "solve.min_det_j",
            input.min_det_j,
            requirement,
            "kept the map: the energy is scale-invariant (conformal) and lets tets shrink; \
             --energy symmetric-dirichlet keeps volumes",
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::placenta::ParallelPlanes;

    /// Two boundary vertices per side, 10 mm apart in z; the planes
    /// template at `h` puts them at `z = +-h`.
    fn input<'a>(
        rest: &'a [Point3<f64>],
        start: &'a [f64],
        solved: &'a [f64],
        theta: &'a [f64],
        template: &'a ParallelPlanes,
    ) -> SolveInput<'a> {
        SolveInput {
            rest,
            start,
            solved,
            template,
            theta_initial: theta,
            labels: &[1, 1, 2, 2],
            weights: &[0.25; 4],
            min_det_j: 0.5,
            final_error_mm: 3.0,
            voxel_mm: 1.0,
            resists_scaling: true,
        }
    }

    fn four() -> Vec<Point3<f64>> {
        [
            [0.0, 0.0, 5.0],
            [9.0, 0.0, 5.0],
            [0.0, 0.0, -5.0],
            [9.0, 0.0, -5.0],
        ]
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect()
    }

    #[test]
    fn a_solve_that_did_not_move_from_off_the_template_is_refused() {
        let rest = four();
        let x: Vec<f64> = rest.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let planes = ParallelPlanes::default();
        // h = 2: the start is 3 mm off the planes; staying put is refused.
        let mut gates = Gates::new();
        let e = check_solve(&input(&rest, &x, &x, &[2.0], &planes), &mut gates).unwrap_err();
        assert_eq!(e.name, "solve.moved");
        assert!(e.to_string().contains("--max-iterations"), "{e}");
        let start = gates.get("solve.template_error_start_voxels").unwrap();
        assert!(start.value > 2.0, "{}", start.value);
        // h = 5: the start is on the template and may stay.
        let mut gates = Gates::new();
        let mut on = input(&rest, &x, &x, &[5.0], &planes);
        on.final_error_mm = 0.0;
        check_solve(&on, &mut gates).unwrap();
        assert!(gates.all_passed() && gates.0.len() == 3);
        // Moved: passes.
        let mut moved = x.clone();
        for c in moved.chunks_exact_mut(3) {
            c[2] *= 0.4;
        }
        let mut gates = Gates::new();
        check_solve(&input(&rest, &x, &moved, &[2.0], &planes), &mut gates).unwrap();
        assert!(gates.get("solve.moved").unwrap().value > 0.1);
    }

    #[test]
    fn a_collapsed_tet_is_refused() {
        let rest = four();
        let x: Vec<f64> = rest.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let planes = ParallelPlanes::default();
        let mut i = input(&rest, &x, &x, &[5.0], &planes);
        i.final_error_mm = 0.0;
        i.min_det_j = 4.5e-11;
        let e = check_solve(&i, &mut Gates::new()).unwrap_err();
        assert_eq!(e.name, "solve.min_det_j");
        assert!(
            e.to_string().contains("--energy symmetric-dirichlet"),
            "{e}"
        );
        // A conformal energy's collapse is kept and recorded as failed.
        i.resists_scaling = false;
        let mut gates = Gates::new();
        check_solve(&i, &mut gates).unwrap();
        let g = gates.get("solve.min_det_j").unwrap();
        assert!(!g.passed && g.fallback.is_some());
    }

    #[test]
    fn only_a_conformal_energy_is_blind_to_scaling() {
        use unfold_param::energy::{Arap, AreaRatio, Mips, SymmetricDirichlet};
        assert!(resists_scaling(&SymmetricDirichlet));
        assert!(resists_scaling(&Arap));
        assert!(resists_scaling(&AreaRatio));
        assert!(!resists_scaling(&Mips));
    }
}
