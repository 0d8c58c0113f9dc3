//! The memory a Newton solve of an [`Objective`] will take, predicted
//! before it factorizes (issue 18; [`unfold_mesh::memory`]).
//!
//! With a Cholesky factorization the largest part grows faster than the
//! mesh: the factor of the Hessian, whose exact size the symbolic analysis
//! gives (the fill-reducing ordering and the column counts) before any
//! value is allocated, `nnz(L)` entries plus the numeric factorization's
//! workspace. With the multigrid solver every part is linear in the mesh:
//! the matrix with both triangles stored (the plan's index arrays and the
//! finest level's values), the prolongations and the conjugate-gradient
//! vectors (the constants fitted on measured peaks: see each). Then, for both, the
//! Hessian's values and row indices, and the per-element arrays (assembly
//! entries, energies, gradients and the flip-free step's buffers).

use crate::{Objective, ParamError, ParamMesh};
use unfold_mesh::memory::MemoryEstimate;

/// Bytes per factor entry: the value (8 B) and the supernodal structure
/// with the allocator's slack (measured on placenta meshes of 22k and 179k
/// tets, whose factors hold 5.9M and 127M entries: 10 B were enough; 20 %
/// more, as peaks vary by some 10 % run to run). Refit check on the
/// Cholesky runs of `benches/placenta_dense.py` (20k to 79k tets, uniform
/// and graded, with the other constants here): predicted peaks 1.38 to 1.51
/// times the measured ones; left as it was.
pub const BYTES_PER_FACTOR_ENTRY: f64 = 12.0;
/// Bytes per stored Hessian entry (value and row index).
pub const BYTES_PER_HESSIAN_ENTRY: f64 = 16.0;
/// Bytes per entry of the multigrid's symmetric matrix (both triangles):
/// the plan's column and slot (8 B) and the finest level's column and
/// value (12 B). The earlier 44 B also counted the Galerkin product's
/// intermediate `A P` (24 B) as alive at the peak; with it (and 1024 B per
/// element) the predicted peaks of the uniform meshes of
/// `benches/placenta_dense.py` were 1.8 to 2.3 times the measured ones
/// (145k to 2.7M tets: 8.2 GiB predicted, 3.6 GiB measured at 2.7M);
/// the measured peak beyond the resident size was 0.29 of the earlier
/// parts on every uniform multigrid run. Fitted with
/// [`BYTES_PER_PROLONGATION_ENTRY`] and [`BYTES_PER_ELEMENT`] on those
/// runs: see [`BYTES_PER_ELEMENT`] for the ratios.
pub const BYTES_PER_MULTIGRID_ENTRY: f64 = 20.0;
/// Bytes per prolongation entry: the plan's and the hierarchy's copy
/// (12 B each; the earlier 48 B also counted two transposes, fitted away
/// with [`BYTES_PER_MULTIGRID_ENTRY`]).
pub const BYTES_PER_PROLONGATION_ENTRY: f64 = 24.0;
/// Bytes per unknown of the multigrid solve: the conjugate-gradient and
/// V-cycle vectors and the coarse levels (about 16 vectors).
pub const BYTES_PER_MULTIGRID_UNKNOWN: f64 = 128.0;
/// Bytes per element besides the solver: the assembly entries (`10 x 4` B
/// for a tet), the element gradients of the parallel evaluation, the
/// energy and step buffers, with the allocator's slack. Fitted with the
/// multigrid constants on the uniform and graded meshes of
/// `benches/placenta_dense.py` (the 105 x 85 x 20 mm ellipsoid at 5 to
/// 1.5 mm: 20k to 2.72M tets, both solvers), the resident size at the
/// check included: predicted peaks 1.26 (145k tets) to 1.36 (2.72M tets:
/// 4.9 GiB against 3.6 GiB) times the measured ones on the uniform
/// multigrid runs, 1.10 on an 86k-tet graded one, 1.38 to 1.51 on the
/// Cholesky runs (20k to 79k tets). (The earlier 1024 B, fitted on 52k to
/// 1.25M tets of `benches/placenta_scale.py` with the earlier multigrid
/// constants, over-predicted those runs 1.5 to 2.3 times.)
pub const BYTES_PER_ELEMENT: f64 = 384.0;
/// The solver's fixed overhead (threads, small buffers, and the margin
/// that keeps the peaks of small meshes, which vary by some 10 % run to
/// run, below their predictions: 64 MiB keeps an 86k-tet graded multigrid
/// run 1.1 times above its measured peak).
pub const BASE_BYTES: f64 = 64.0 * 1024.0 * 1024.0;

/// The memory a second-order solve of `objective` will allocate: runs its
/// symbolic analysis or builds its multigrid plan (kept in the objective,
/// so solving this objective does not do it again) and sums, for a
/// Cholesky factorization, `12 nnz(L) + workspace` bytes, for the
/// multigrid solver `20 nnz(A) + 24 nnz(P) + 128 n` bytes (`A` with both
/// triangles, `P` all prolongations, `n` unknowns), and for both
/// `16 nnz(H) + 384 elements` bytes and a fixed 64 MiB.
///
/// # Errors
/// Those of [`Objective::pattern`].
pub fn newton_memory(objective: &mut Objective<'_>) -> Result<MemoryEstimate, ParamError> {
    let elements = objective.mesh().num_elements() as f64;
    let pattern = objective.pattern()?;
    let mut estimate = MemoryEstimate::new().with("solver base", 1.0, BASE_BYTES);
    estimate = match pattern.multigrid_sizes() {
        None => estimate
            .with(
                "factor",
                pattern.factor_nnz() as f64,
                BYTES_PER_FACTOR_ENTRY,
            )
            .with(
                "factor workspace",
                pattern.factor_scratch_bytes() as f64,
                1.0,
            ),
        Some(mg) => estimate
            .with(
                "multigrid matrix",
                mg.full_nnz as f64,
                BYTES_PER_MULTIGRID_ENTRY,
            )
            .with(
                "prolongations",
                mg.prolongation_nnz as f64,
                BYTES_PER_PROLONGATION_ENTRY,
            )
            .with(
                "multigrid vectors",
                mg.n as f64,
                BYTES_PER_MULTIGRID_UNKNOWN,
            ),
    };
    Ok(estimate
        .with("Hessian", pattern.nnz() as f64, BYTES_PER_HESSIAN_ENTRY)
        .with("per-element buffers", elements, BYTES_PER_ELEMENT))
}

/// [`newton_memory`] of the distortion objective over `mesh` (no template
/// term, nothing fixed: the template's few parameters add a few dense
/// rows).
///
/// # Errors
/// Those of [`Objective::new`] and [`Objective::pattern`].
pub fn mesh_newton_memory(mesh: &ParamMesh) -> Result<MemoryEstimate, ParamError> {
    let energy = crate::energy::SymmetricDirichlet;
    let mut objective = Objective::new(mesh, &energy, 1.0, None, &[])?;
    newton_memory(&mut objective)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::objective::LinearSolver;

    /// The bytes the arrays each part stands for hold at the least, with
    /// no slack and no copy: 8 B per factor value and its workspace,
    /// `u32` column and `f64` value per multigrid matrix and prolongation
    /// entry, 8 vectors per unknown, the Hessian's `f64` value and `u32`
    /// row per entry, and per element the 4 x 3 gradient, the energy and
    /// the `10 x 4` B assembly entries.
    fn least_bytes(objective: &mut Objective<'_>) -> f64 {
        let elements = objective.mesh().num_elements() as f64;
        let p = objective.pattern().unwrap();
        let solver = match p.multigrid_sizes() {
            None => 8.0 * p.factor_nnz() as f64 + p.factor_scratch_bytes() as f64,
            Some(mg) => {
                12.0 * mg.full_nnz as f64 + 12.0 * mg.prolongation_nnz as f64 + 64.0 * mg.n as f64
            }
        };
        solver + 12.0 * p.nnz() as f64 + (96.0 + 8.0 + 40.0) * elements
    }

    /// On a generated slab, with either solver: the estimate has the
    /// parts of its solver and, its fixed part aside, lies between the
    /// least bytes its arrays hold and three times that (the fitted
    /// constants are 1.3 to 2.7 times the bare sizes: slack, copies and
    /// buffers the peaks showed).
    #[test]
    fn the_estimate_stays_above_and_near_the_bare_sizes_of_its_parts() {
        let shape = unfold_mesh::shapes::placenta_slab(&unfold_mesh::shapes::PlacentaParams {
            cells_radial: 8,
            cells_through: 3,
            ..Default::default()
        })
        .unwrap();
        let pm = ParamMesh::from_tets(&shape.mesh).unwrap();
        let energy = crate::energy::SymmetricDirichlet;
        for solver in [LinearSolver::Cholesky, LinearSolver::Multigrid] {
            let mut objective = Objective::new(&pm, &energy, 1.0, None, &[]).unwrap();
            objective.set_linear_solver(solver);
            let estimate = newton_memory(&mut objective).unwrap();
            let least = least_bytes(&mut objective);
            let names: Vec<&str> = estimate.parts.iter().map(|p| p.what).collect();
            let want = match solver {
                LinearSolver::Multigrid => "multigrid matrix",
                _ => "factor",
            };
            assert!(names.contains(&want), "{solver:?}: {names:?}");
            let variable = estimate.total() - BASE_BYTES;
            assert!(
                variable >= least && variable <= 3.0 * least,
                "{solver:?}: {variable} B predicted, {least} B at the least"
            );
        }
    }
}
