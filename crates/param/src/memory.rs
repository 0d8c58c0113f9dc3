//! The memory a Newton solve of an [`Objective`] will take, predicted
//! before it factorizes (issue 18; [`unfold_mesh::memory`]).
//!
//! With a Cholesky factorization the largest part grows faster than the
//! mesh: the factor of the Hessian, whose exact size the symbolic analysis
//! gives (the fill-reducing ordering and the column counts) before any
//! value is allocated, `nnz(L)` entries plus the numeric factorization's
//! workspace. With the multigrid solver every part is linear in the mesh:
//! the matrix with both triangles stored (the plan's index arrays, the
//! finest level's values, the Galerkin product's intermediate `A P`), the
//! prolongations and the conjugate-gradient vectors. Then, for both, the
//! Hessian's values and row indices, and the per-element arrays (assembly
//! entries, energies, gradients and the flip-free step's buffers).

use crate::{Objective, ParamError, ParamMesh};
use unfold_mesh::memory::MemoryEstimate;

/// Bytes per factor entry: the value (8 B) and the supernodal structure
/// with the allocator's slack (measured on placenta meshes of 22k and 179k
/// tets, whose factors hold 5.9M and 127M entries: 10 B were enough; 20 %
/// more, as peaks vary by some 10 % run to run).
pub const BYTES_PER_FACTOR_ENTRY: f64 = 12.0;
/// Bytes per stored Hessian entry (value and row index).
pub const BYTES_PER_HESSIAN_ENTRY: f64 = 16.0;
/// Bytes per entry of the multigrid's symmetric matrix (both triangles):
/// the plan's column and slot (8 B), the finest level's column and value
/// (12 B) and the Galerkin product's intermediate `A P`, whose rows hold
/// about twice as many entries (24 B).
pub const BYTES_PER_MULTIGRID_ENTRY: f64 = 44.0;
/// Bytes per prolongation entry: the plan's, the hierarchy's copy and its
/// transpose, and the transpose the Galerkin product makes (12 B each).
pub const BYTES_PER_PROLONGATION_ENTRY: f64 = 48.0;
/// Bytes per unknown of the multigrid solve: the conjugate-gradient and
/// V-cycle vectors and the coarse levels (about 16 vectors).
pub const BYTES_PER_MULTIGRID_UNKNOWN: f64 = 128.0;
/// Bytes per element besides the solver: the assembly entries (`10 x 4` B
/// for a tet), the element gradients of the parallel evaluation, the
/// energy and step buffers and the pipeline's own per-element arrays, with
/// the allocator's slack (fitted on the placenta meshes of
/// `benches/placenta_scale.py`, 52k to 1.25M tets, with the other parts:
/// the predicted peaks are 1.2 to 1.5 times the measured ones).
pub const BYTES_PER_ELEMENT: f64 = 1024.0;
/// The solver's fixed overhead (threads, small buffers, and the margin
/// that keeps the peaks of small meshes, which vary by some 10 % run to
/// run, below their predictions).
pub const BASE_BYTES: f64 = 48.0 * 1024.0 * 1024.0;

/// The memory a second-order solve of `objective` will allocate: runs its
/// symbolic analysis or builds its multigrid plan (kept in the objective,
/// so solving this objective does not do it again) and sums, for a
/// Cholesky factorization, `12 nnz(L) + workspace` bytes, for the
/// multigrid solver `44 nnz(A) + 48 nnz(P) + 128 n` bytes (`A` with both
/// triangles, `P` all prolongations, `n` unknowns), and for both
/// `16 nnz(H) + 1024 elements` bytes and a fixed 48 MiB.
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
