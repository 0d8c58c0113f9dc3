//! A placenta mesh made from a segmentation (`--seg`): the lattice cube
//! side chosen from the mask (its volume, its thickness, its voxels), the
//! meshing itself, and what the report says of it.

use super::seg_prediction::SegPrediction;
use super::settings::Settings;
use crate::app::error::{AppError, at};
use crate::app::mesh::mask::{describe, warn_dropped};
use crate::app::observer::Observer;
use crate::app::run::memory;
use crate::mesh::mask::inside_distance_quantile;
use crate::mesh::mesher::{MaskMeshOptions, MeshQuality, cube_side_for_cubes};
use crate::mesh::{MeshError, TetMesh, Volume};
use crate::organs::placenta::segmentation::{THICKNESS_QUANTILE, from_segmentation};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Lattice cubes the mask holds at `placenta --seg`'s default cube side.
/// A typical placenta (about 500 cm^3) then gets a cube side near 4.6 mm
/// and, graded, 15,000 to 20,000 tets, within a few times the published
/// meshes' ~6,700 (ALGORITHMS: the placenta paper), whatever the image's
/// resolution: at 3 mm voxels that is 2.4 times fewer tets than the voxel
/// size gives, and flattening costs grow faster than the tet count.
pub const SEG_CUBES: usize = 5_000;

/// Where `placenta --seg`'s lattice cube side came from (`size_from` in
/// the report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SizeFrom {
    /// `--size-mm`.
    Given,
    /// The smallest voxel spacing (`--dense`, or a mask so small or thin
    /// that the other rules would be finer than its voxels).
    Voxel,
    /// [`SEG_CUBES`] cubes in the mask's volume.
    MaskVolume,
    /// Half the mask's half thickness: a thin mask keeps at least four
    /// cubes through its thickness.
    Thickness,
}

/// The cube side `placenta --seg` meshes at: `--size-mm` when given; the
/// smallest voxel spacing `v` with `--dense`; otherwise
/// `max(v, min(s_V, h / 2))` with `s_V` the side at which the mask holds
/// [`SEG_CUBES`] cubes ([`cube_side_for_cubes`]) and `h` the mask's half
/// thickness (the 0.95 quantile of its distance transform, as the
/// pipeline's initial `h`), so that at least four cubes span the
/// thickness. Returns the side and the rule that set it.
///
/// # Errors
/// The distance transform's [`MeshError`].
pub fn seg_cube_side(
    mask: &Volume<bool>,
    given: Option<f64>,
    dense: bool,
) -> Result<(f64, SizeFrom), MeshError> {
    if let Some(s) = given {
        return Ok((s, SizeFrom::Given));
    }
    let voxel = mask.spacing().iter().copied().fold(f64::INFINITY, f64::min);
    if dense {
        return Ok((voxel, SizeFrom::Voxel));
    }
    let Some(by_volume) = cube_side_for_cubes(mask, SEG_CUBES as f64) else {
        return Ok((voxel, SizeFrom::Voxel));
    };
    let half_thickness =
        inside_distance_quantile(mask, THICKNESS_QUANTILE)?.unwrap_or(f64::INFINITY);
    let (side, from) = if half_thickness / 2.0 < by_volume {
        (half_thickness / 2.0, SizeFrom::Thickness)
    } else {
        (by_volume, SizeFrom::MaskVolume)
    };
    Ok(if side > voxel {
        (side, from)
    } else {
        (voxel, SizeFrom::Voxel)
    })
}

/// `segmentation` in `report.json`: how the mesh was made from a mask.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegReport {
    /// The mask.
    pub mask: String,
    /// The mesh written.
    pub mesh: String,
    /// Voxels set, and their volume in mm^3.
    pub mask_voxels: usize,
    /// Volume of the voxels set, mm^3.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub mask_volume_mm3: f64,
    /// Lattice cube side, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub size_mm: f64,
    /// Where the cube side came from.
    pub size_from: SizeFrom,
    /// Gaussian smoothing, voxels.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub smooth_voxels: f64,
    /// Box dilations.
    pub dilate: u8,
    /// Level of the smoothed mask meshed.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub level: f64,
    /// Whether the interior was graded (the default; not with `--dense`).
    pub graded: bool,
    /// Interior vertices removed by the grading.
    pub graded_collapses: usize,
    /// Tet counts of the components left out.
    pub dropped_components: Vec<usize>,
    /// Half thickness: the 95th percentile of the mask's distance
    /// transform, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub half_thickness_mm: f64,
    /// Size and quality of the mesh.
    pub quality: MeshQuality,
    /// What the run was predicted to cost before the mask was meshed
    /// ([`SegPrediction`]).
    pub prediction: SegPrediction,
}

/// A mesh made from a segmentation, with what the report says of it.
#[derive(Debug, Clone)]
pub struct Segmented {
    /// The tet mesh (mm, the mask's world frame, RAS).
    pub mesh: TetMesh,
    /// How it was made.
    pub report: SegReport,
    /// The mask's mean voxel spacing, mm: the default of `--voxel-mm`.
    pub voxel_mm: f64,
}

/// Meshes the mask `seg` as `settings` say (graded at the cube side of
/// [`seg_cube_side`] unless `dense`), predicting the run's tets, memory and
/// time first ([`SegPrediction`]: a warning when large, refused when
/// `--max-memory` is given and the flattening would pass it) and checking
/// the mesher's memory; tells
/// `observer` the mesh's size and quality (and the rule that chose the
/// cube side) and warns of components left out. `mesh_shown` is where the
/// mesh will be written, for the report.
///
/// # Errors
/// Reading the mask, the memory check, the mesher's.
pub fn mesh_segmentation(
    settings: &Settings,
    seg: &Path,
    mesh_shown: &Path,
    observer: &mut dyn Observer,
) -> Result<Segmented, AppError> {
    let m = &settings.mask;
    let label = seg.display().to_string();
    let mask = m.read_mask(seg)?;
    // A mask larger than any organ (a wrong voxel size) before any meshing.
    crate::app::run::units::refuse_mask_larger_than_an_organ(seg, &mask)?;
    let spacing = mask.spacing();
    let (size_mm, size_from) =
        seg_cube_side(&mask, m.size_mm, settings.dense).map_err(|e| at(seg, e))?;
    let options = MaskMeshOptions {
        grade: !settings.dense,
        size_mm: Some(size_mm),
        ..m.options(false)?
    };
    let prediction = SegPrediction::of(&mask, size_mm, options.grade);
    if memory::budget().source == memory::LimitSource::Flag {
        // The flattening's own check comes after the meshing; with a
        // budget given, a run that cannot fit it is refused before.
        memory::check(
            "flattening the placenta (predicted from the mask before meshing)",
            &prediction.estimate(),
            "raise --size-mm (the tets grow as 1/size^3, graded as 1/size^2) or drop --dense",
        )?;
    }
    // The mesher's own memory check first: a run it refuses is one line,
    // without the warning before it.
    m.check_memory(seg, &mask, &options)?;
    if prediction.is_large() {
        observer.warning(&format!(
            "{}: {}",
            seg.display(),
            prediction.note(size_mm, options.grade)
        ));
    }
    let segmented =
        from_segmentation(&mask, &options).map_err(|e| super::errors::organ(&label, e))?;
    drop(mask);
    let (out, h) = (segmented.meshed, segmented.half_thickness_mm);
    warn_dropped(seg, &out, false, observer);
    let quality = MeshQuality::of(&out.mesh)?;
    observer.info(&format!(
        "{}: {}{}",
        seg.display(),
        describe(&out, &quality),
        match size_from {
            SizeFrom::MaskVolume => format!(
                "; cube side from the mask's volume (about {SEG_CUBES} lattice cubes; \
                 --size-mm or --dense for finer)"
            ),
            SizeFrom::Thickness => "; cube side from the mask's thickness (four cubes \
                                    through it; --size-mm or --dense for finer)"
                .to_string(),
            _ => String::new(),
        }
    ));
    let report = SegReport {
        mask: label,
        mesh: mesh_shown.display().to_string(),
        mask_voxels: out.mask_voxels,
        mask_volume_mm3: out.mask_volume_mm3,
        size_mm: out.size_mm,
        size_from,
        smooth_voxels: m.smooth_voxels,
        dilate: m.dilate,
        level: out.level,
        graded: !settings.dense,
        graded_collapses: out.graded_collapses,
        dropped_components: out.dropped_components.clone(),
        half_thickness_mm: h,
        quality,
        prediction,
    };
    Ok(Segmented {
        mesh: out.mesh,
        report,
        voxel_mm: (spacing[0] + spacing[1] + spacing[2]) / 3.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--size-mm` wins, `--dense` takes the voxel size, and otherwise the
    /// cube side from the mask's volume, capped at half its half
    /// thickness, unless that is finer than the voxels.
    #[test]
    fn the_seg_cube_side_follows_the_flags_and_the_mask() {
        let mut affine = nalgebra::Matrix4::identity();
        affine[(0, 0)] = 2.0;
        affine[(1, 1)] = 2.0;
        affine[(2, 2)] = 3.0;
        // A 40 x 40 x 12 block of 12 mm^3 voxels (80 x 80 x 36 mm) inside a
        // margin: (230,400 / 5,000)^(1/3) = 3.58 mm; half thickness about
        // 18 mm, so the volume rule holds.
        let (nx, nz) = (44, 16);
        let block = |x: usize, y: usize, z: usize| {
            (2..42).contains(&x) && (2..42).contains(&y) && (2..14).contains(&z)
        };
        let mut bits = Vec::new();
        for z in 0..nz {
            for y in 0..nx {
                for x in 0..nx {
                    bits.push(block(x, y, z));
                }
            }
        }
        let big = Volume::new([nx, nx, nz, 1], affine, bits).unwrap();
        let (side, from) = seg_cube_side(&big, None, false).unwrap();
        assert_eq!(from, SizeFrom::MaskVolume);
        let expected = (12.0 * (40 * 40 * 12) as f64 / SEG_CUBES as f64).cbrt();
        assert!((side - expected).abs() < 1e-12, "{side} vs {expected}");
        assert_eq!(
            seg_cube_side(&big, None, true).unwrap(),
            (2.0, SizeFrom::Voxel)
        );
        assert_eq!(
            seg_cube_side(&big, Some(7.5), true).unwrap(),
            (7.5, SizeFrom::Given)
        );
        // A sheet 3 voxels (9 mm) thick and 400 mm wide: the volume rule
        // gives 6.6 mm; the distance transform's 0.95 quantile is the middle
        // layer's 6 mm (two 3 mm voxels to the outside), so h / 2 = 3 mm.
        let (n, nz) = (200, 7);
        let mut bits = Vec::new();
        for z in 0..nz {
            for _ in 0..n * n {
                bits.push((2..5).contains(&z));
            }
        }
        let sheet = Volume::new([n, n, nz, 1], affine, bits).unwrap();
        assert_eq!(
            seg_cube_side(&sheet, None, false).unwrap(),
            (3.0, SizeFrom::Thickness)
        );
        // A few voxels: the voxel size.
        let mut bits = vec![false; nx * nx * nz];
        bits[..30].fill(true);
        let small = Volume::new([nx, nx, nz, 1], affine, bits).unwrap();
        assert_eq!(
            seg_cube_side(&small, None, false).unwrap(),
            (2.0, SizeFrom::Voxel)
        );
    }
}
