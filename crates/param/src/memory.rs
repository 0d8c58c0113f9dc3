//! The memory a Newton solve of an [`Objective`] will take, predicted
//! before it factorizes (issue 18; [`unfold_mesh::memory`]).
//!
//! The largest part grows faster than the mesh: the Cholesky factor of the
//! Hessian, whose exact size the symbolic analysis gives (the
//! fill-reducing ordering and the column counts) before any value is
//! allocated, `nnz(L)` entries plus the numeric factorization's workspace.
//! Then the Hessian's values and row indices, and the per-element arrays
//! (assembly slots, `(d+1)d x (d+1)d` local entries per element; energies,
//! gradients and the flip-free step's buffers).

use crate::{Objective, ParamError, ParamMesh};
use unfold_mesh::memory::MemoryEstimate;

/// Bytes per factor entry: the value (8 B) and the supernodal structure
/// with the allocator's slack (measured on placenta meshes of 22k and 179k
/// tets, whose factors hold 5.9M and 127M entries: 10 B were enough; 20 %
/// more, as peaks vary by some 10 % run to run).
pub const BYTES_PER_FACTOR_ENTRY: f64 = 12.0;
/// Bytes per stored Hessian entry (value and row index).
pub const BYTES_PER_HESSIAN_ENTRY: f64 = 16.0;
/// Bytes per element besides the factor: the assembly slots (`144 x 4` B
/// for a tet), the element Hessians and gradients of the parallel assembly,
/// the energy and step buffers, with the allocator's slack (measured: 2 KiB
/// were enough; 25 % more).
pub const BYTES_PER_ELEMENT: f64 = 2560.0;
/// The solver's fixed overhead (threads, small buffers).
pub const BASE_BYTES: f64 = 32.0 * 1024.0 * 1024.0;

/// The memory a second-order solve of `objective` will allocate: runs its
/// symbolic analysis (kept in the objective, so solving this objective
/// does not analyse again) and sums
/// `12 nnz(L) + workspace + 16 nnz(H) + 2560 elements` bytes and a fixed
/// 32 MiB.
///
/// # Errors
/// Those of [`Objective::pattern`].
pub fn newton_memory(objective: &mut Objective<'_>) -> Result<MemoryEstimate, ParamError> {
    let elements = objective.mesh().num_elements() as f64;
    let pattern = objective.pattern()?;
    Ok(MemoryEstimate::new()
        .with("solver base", 1.0, BASE_BYTES)
        .with(
            "factor",
            pattern.factor_nnz() as f64,
            BYTES_PER_FACTOR_ENTRY,
        )
        .with(
            "factor workspace",
            pattern.factor_scratch_bytes() as f64,
            1.0,
        )
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
