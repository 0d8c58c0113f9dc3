//! The memory a placenta run is predicted to take, checked against the
//! budget before the flattening allocates.

use crate::app::AppError;
use crate::app::run::memory;

/// Refuses the optimization when the predicted peak passes the budget:
/// the factor and per-tet buffers of the mesh
/// ([`crate::organs::placenta::memory::estimate_memory`]) and one
/// pull-back table per image (and displacement field) on the template grid,
/// `--grid` at the images' finest spacing, else about four times the
/// mesh's volume in voxels (the box of the flattened mesh).
///
/// # Errors
/// [`AppError::Memory`] saying what to change.
pub fn check_memory(
    mesh: &crate::mesh::TetMesh,
    image_spacings: &[[f64; 3]],
    grid: Option<&[f64; 6]>,
    displacement: bool,
) -> Result<(), AppError> {
    let voxel = image_spacings.iter().fold([f64::INFINITY; 3], |m, s| {
        std::array::from_fn(|a| m[a].min(s[a]))
    });
    let voxel = if voxel.iter().all(|x| x.is_finite() && *x > 0.0) {
        voxel
    } else {
        [3.0; 3]
    };
    let template_voxels = match grid {
        Some(g) => (0..3)
            .map(|a| ((g[2 * a + 1] - g[2 * a]) / voxel[a]).ceil() + 1.0)
            .product(),
        None => 4.0 * crate::mesh::geometry::total_volume(mesh) / (voxel[0] * voxel[1] * voxel[2]),
    };
    let tables = image_spacings.len() + usize::from(displacement);
    let estimate = crate::organs::placenta::memory::estimate_memory(mesh, template_voxels, tables)
        .map_err(|e| AppError::Usage(e.to_string()))?;
    let hint = match estimate.largest() {
        Some(p) if p.what == "pull-back tables" => {
            "shrink the --grid box or raise --spacing-mm (the tables grow as the template grid's \
             voxels)"
        }
        _ => "coarsen the mesh (unfold mesh or --seg with a larger --size-mm, or --grade)",
    };
    memory::check("flattening the placenta", &estimate, hint)
}
