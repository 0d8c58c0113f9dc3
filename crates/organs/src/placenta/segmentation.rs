//! From a segmentation to the pipeline's input (ALGORITHMS 2.8 and 2.4):
//! the mask meshed into tets and the initial half thickness `h` measured
//! on the mask itself, as the published pipeline does.

use super::error::PlacentaError;
use crate::OrganError;
use unfold_mesh::Volume;
use unfold_mesh::mask::{dilate_box, inside_distance_quantile};
use unfold_mesh::mesher::{MaskMesh, MaskMeshOptions, mesh_mask};

/// The quantile of the mask's distance transform taken as `h`
/// (ALGORITHMS 2.4).
pub const THICKNESS_QUANTILE: f64 = 0.95;

/// A segmentation ready for [`super::Pipeline`]: its tet mesh and the
/// half thickness to start the template from
/// ([`super::Config::half_thickness_mm`]).
#[derive(Debug, Clone)]
pub struct Segmented {
    /// The mesh of the mask and its statistics (components, lattice,
    /// level, collapses).
    pub meshed: MaskMesh,
    /// `h`: the [`THICKNESS_QUANTILE`] of the distance to the outside over
    /// the mask's voxels (after the same dilation as the mesh), mm.
    pub half_thickness_mm: f64,
}

/// Meshes `mask` with `options` ([`mesh_mask`]) and measures its half
/// thickness: `h = Q_0.95 { d(v) : v inside }`, `d` the distance transform
/// of the mask dilated `options.dilate` times.
///
/// # Errors
/// `Mesh` for a mask that cannot be meshed (empty, options out of range);
/// [`PlacentaError::EmptyMask`] when no voxel is inside,
/// [`PlacentaError::FullMask`] when every voxel is (no background).
pub fn from_segmentation(
    mask: &Volume<bool>,
    options: &MaskMeshOptions,
) -> Result<Segmented, OrganError> {
    if mask.data().iter().all(|&v| v) {
        return Err(PlacentaError::FullMask {
            voxels: mask.data().len(),
        }
        .into());
    }
    let meshed = mesh_mask(mask, options)?;
    let mut thick = None;
    for _ in 0..options.dilate {
        thick = Some(dilate_box(thick.as_ref().unwrap_or(mask))?);
    }
    let h = inside_distance_quantile(thick.as_ref().unwrap_or(mask), THICKNESS_QUANTILE)?
        .filter(|h| *h > 0.0)
        .ok_or(PlacentaError::EmptyMask)?;
    Ok(Segmented {
        meshed,
        half_thickness_mm: h,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::nalgebra::Matrix4;

    /// A slab mask of `2 t + 1` voxels through (1 mm voxels).
    fn slab(t: usize) -> Volume<bool> {
        let dims = [24, 24, 2 * t + 7, 1];
        let z0 = 3;
        let mut data = vec![false; dims[0] * dims[1] * dims[2]];
        for z in z0..=z0 + 2 * t {
            for y in 3..21 {
                for x in 3..21 {
                    data[x + dims[0] * (y + dims[1] * z)] = true;
                }
            }
        }
        Volume::new(dims, Matrix4::identity(), data).unwrap()
    }

    #[test]
    fn a_slab_is_meshed_and_its_half_thickness_measured() {
        for t in [2, 4] {
            let s = from_segmentation(&slab(t), &MaskMeshOptions::default()).unwrap();
            assert!(s.meshed.mesh.num_tets() > 0);
            // The distance to the outside of the middle voxels is t + 1
            // voxel centres; the 95th percentile is at least t.
            assert!(
                s.half_thickness_mm >= t as f64 && s.half_thickness_mm <= (t + 1) as f64,
                "t {t}: h {}",
                s.half_thickness_mm
            );
        }
    }

    #[test]
    fn a_full_mask_is_a_clear_error() {
        let full = Volume::new([6, 6, 6, 1], Matrix4::identity(), vec![true; 216]).unwrap();
        let e = from_segmentation(&full, &MaskMeshOptions::default()).unwrap_err();
        assert!(
            matches!(
                e,
                OrganError::Placenta(PlacentaError::FullMask { voxels: 216 })
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("needs background"), "{e}");
    }

    #[test]
    fn an_empty_mask_is_a_clear_error() {
        let empty = Volume::new([8, 8, 8, 1], Matrix4::identity(), vec![false; 512]).unwrap();
        let e = from_segmentation(&empty, &MaskMeshOptions::default()).unwrap_err();
        assert!(
            matches!(
                e,
                OrganError::Mesh(_) | OrganError::Placenta(PlacentaError::EmptyMask)
            ),
            "{e:?}"
        );
    }
}
