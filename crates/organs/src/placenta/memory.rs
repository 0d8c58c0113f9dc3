//! The memory a placenta run will take, predicted before it optimizes
//! (issue 18; [`unfold_mesh::memory`]): the Newton solve's factor (or, for
//! large meshes, its multigrid), Hessian and per-tet buffers
//! ([`unfold_param::memory::mesh_newton_memory`], the factor's exact size
//! from the symbolic analysis) and one pull-back table per image on the
//! template grid.

use crate::OrganError;
use unfold_mesh::TetMesh;
use unfold_mesh::memory::MemoryEstimate;
use unfold_param::ParamMesh;
use unfold_param::memory::mesh_newton_memory;

/// Bytes per template voxel of a pull-back table (the tet and the
/// barycentric weights) and of the flat image written.
pub const BYTES_PER_TEMPLATE_VOXEL: f64 = 48.0;

/// The memory a placenta run on `mesh` will allocate beyond what is
/// resident, with `template_voxels` voxels per pulled grid and `tables`
/// pull-back tables: the solve's estimate plus
/// `48 template_voxels tables` bytes. Runs the symbolic analysis of the
/// Hessian, or builds the multigrid's plan.
///
/// # Errors
/// `Param` when the mesh cannot be set up as an objective.
pub fn estimate_memory(
    mesh: &TetMesh,
    template_voxels: f64,
    tables: usize,
) -> Result<MemoryEstimate, OrganError> {
    let pmesh = ParamMesh::from_tets(mesh).map_err(OrganError::from_param)?;
    let mut e = mesh_newton_memory(&pmesh).map_err(OrganError::from_param)?;
    e.add(
        "pull-back tables",
        template_voxels * tables.max(1) as f64 * BYTES_PER_TEMPLATE_VOXEL,
    );
    Ok(e)
}
