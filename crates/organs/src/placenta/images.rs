//! Images pulled into the template (ALGORITHMS 2.7): checked against the
//! mesh before the optimization, then resampled through one voxel -> source
//! table per distinct grid spacing, shared by every frame of a 4D series and
//! by every image with that spacing.

use super::config::GridBox;
use super::error::{PlacentaError, PullbackError};
use super::frame_check;
use super::pullback::{Interpolation, PullbackTable, TemplateGrid, image_world_box};
use super::report::ImageReport;
use crate::{OrganError, PipelineObserver};
use unfold_mesh::geometry::bounding_box;
use unfold_mesh::nalgebra::{Matrix4, Point3};
use unfold_mesh::{TetMesh, Volume};
use unfold_param::Named;

/// An image to pull into the template: 3D or 4D, in the mesh's scanner
/// frame.
#[derive(Debug, Clone, Copy)]
pub struct Image<'a> {
    /// Its name (report entries and, on the command line, the output file
    /// `<name>_flat.nii.gz`); unique within a run.
    pub name: &'a str,
    /// The image.
    pub volume: &'a Volume<f32>,
}

/// An image in the template frame.
#[derive(Debug, Clone)]
pub struct FlatImage {
    /// The input image's name.
    pub name: String,
    /// The resampled image: dims `[nx, ny, nz, frames]`, affine of the
    /// template grid.
    pub volume: Volume<f32>,
    /// Its entry of `report.json`.
    pub report: ImageReport,
}

/// Checks the images before any work: distinct names, every image's
/// world box meeting the mesh's bounding box and, with `frame_check`, the
/// mesh lying in every image's foreground ([`frame_check::check`]). A mesh
/// whose box misses an image's but that an axis flip puts in its
/// foreground gets the flip's error rather than `Disjoint`.
///
/// # Errors
/// [`PlacentaError::ImageNameRepeated`]; [`PlacentaError::MeshFlipped`] /
/// [`PlacentaError::MeshOutsideForeground`]; [`PullbackError::Disjoint`]
/// naming the first image that misses the mesh.
pub fn check_images(
    mesh: &TetMesh,
    images: &[Image<'_>],
    frame_check: bool,
) -> Result<(), OrganError> {
    for (index, image) in images.iter().enumerate() {
        if let Some(first) = images[..index].iter().position(|i| i.name == image.name) {
            return Err(PlacentaError::ImageNameRepeated { first, index }.into());
        }
    }
    let Some(bb) = bounding_box(&mesh.positions) else {
        return Ok(());
    };
    let (mesh_lo, mesh_hi) = (
        [bb.min.x, bb.min.y, bb.min.z],
        [bb.max.x, bb.max.y, bb.max.z],
    );
    for (index, image) in images.iter().enumerate() {
        let (image_lo, image_hi) = image_world_box(image.volume);
        if !(0..3).all(|a| image_lo[a] <= mesh_hi[a] && mesh_lo[a] <= image_hi[a]) {
            if frame_check
                && let Err(e @ PlacentaError::MeshFlipped { .. }) =
                    frame_check::check(mesh, image.volume, index)
            {
                return Err(e.into());
            }
            return Err(PullbackError::Disjoint {
                index,
                image_lo,
                image_hi,
                mesh_lo,
                mesh_hi,
            }
            .into());
        }
        if frame_check {
            frame_check::check(mesh, image.volume, index)?;
        }
    }
    Ok(())
}

/// Whether two grid spacings are the same (to 1e-6 relative).
fn same_spacing(a: &[f64; 3], b: &[f64; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= 1e-6 * a[i].abs().max(b[i].abs()))
}

fn row_major(m: &Matrix4<f64>) -> [[f64; 4]; 4] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// The template grid of a pull-back at `spacing`: the fixed box `grid`
/// when given ([`TemplateGrid::fixed`], the same for every subject), else
/// the grid covering the flattened mesh ([`TemplateGrid::covering`]).
///
/// # Errors
/// As [`TemplateGrid::fixed`] and [`TemplateGrid::covering`].
pub fn template_grid(
    flattened: &TetMesh,
    spacing: [f64; 3],
    grid: Option<&GridBox>,
) -> Result<TemplateGrid, PullbackError> {
    match grid {
        Some(b) => TemplateGrid::fixed(b.min, b.max, spacing),
        None => TemplateGrid::covering(&flattened.positions, spacing),
    }
}

/// Pulls every image back: the grid covers the flattened mesh, or is the
/// fixed box `grid` ([`TemplateGrid::fixed`]), at `spacing_mm` (isotropic)
/// or at each image's own voxel spacing; one table per distinct spacing;
/// every image sampled with `interpolation`. Flattened vertices outside a
/// fixed box are counted in the image's report (`vertices_outside_grid`),
/// not an error.
///
/// # Errors
/// [`PlacentaError::ImagePullback`] naming the image, with the error of
/// [`TemplateGrid::covering`] / [`TemplateGrid::fixed`],
/// [`PullbackTable::new`] or [`PullbackTable::apply`].
pub fn pull_back(
    flattened: &TetMesh,
    original: &[Point3<f64>],
    images: &[Image<'_>],
    spacing_mm: Option<f64>,
    grid: Option<&GridBox>,
    interpolation: Interpolation,
    observer: &mut dyn PipelineObserver,
) -> Result<Vec<FlatImage>, OrganError> {
    let mut tables: Vec<([f64; 3], PullbackTable)> = Vec::new();
    let mut out = Vec::with_capacity(images.len());
    for (index, image) in images.iter().enumerate() {
        let failed = |e: PullbackError| PlacentaError::ImagePullback {
            index,
            source: Box::new(e),
        };
        let spacing = spacing_mm.map_or_else(|| image.volume.spacing(), |s| [s; 3]);
        let k = match tables.iter().position(|(s, _)| same_spacing(s, &spacing)) {
            Some(k) => k,
            None => {
                observer.stage(&format!(
                    "pull-back table at [{}] mm",
                    spacing.map(|s| format!("{s:.3}")).join(", ")
                ));
                let grid = template_grid(flattened, spacing, grid).map_err(failed)?;
                let table =
                    PullbackTable::new(grid, &flattened.positions, &flattened.tets, original)
                        .map_err(failed)?;
                tables.push((spacing, table));
                tables.len() - 1
            }
        };
        let table = &tables[k].1;
        observer.stage(&format!("pulling back {}", image.name));
        let (volume, stats) = table
            .apply_with(image.volume, interpolation)
            .map_err(failed)?;
        let grid = *table.grid();
        let (lo, hi) = grid.bounds();
        let vertices_outside_grid = flattened
            .positions
            .iter()
            .filter(|p| (0..3).any(|a| p[a] < lo[a] || p[a] > hi[a]))
            .count();
        out.push(FlatImage {
            name: image.name.to_string(),
            report: ImageReport {
                name: image.name.to_string(),
                input: None,
                output: None,
                interpolation: interpolation.name().into(),
                spacing_mm: grid.spacing,
                dims: grid.dims,
                frames: volume.frames(),
                affine: row_major(&grid.affine()),
                inside_mesh: stats.inside_mesh,
                sampled: stats.sampled,
                outside_image: stats.outside_image,
                vertices_outside_grid,
            },
            volume,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spacings_compare_relatively() {
        assert!(same_spacing(&[2.0; 3], &[2.0 + 1e-9, 2.0, 2.0]));
        assert!(!same_spacing(&[2.0; 3], &[2.0, 2.1, 2.0]));
    }
}
