//! The common grid of a placenta cohort's template-space images: one grid
//! for every subject's `<name>_flat.nii.gz`, chosen by the cohort step, and
//! each subject's image on it.
//!
//! The template frame is canonical (ALGORITHMS 2.10: every subject's
//! flattened mesh, and so its pulled-back images, are in one template
//! coordinate system in mm), so images on different grids (runs without a
//! common `--grid`: each pull-back covers its own flattened mesh) can be
//! brought onto one:
//!
//! - when every subject's image has the same dims and affine (to 1e-6 mm),
//!   that grid, unchanged (no resampling);
//! - otherwise the union of the subjects' image boxes (the world
//!   coordinates of their first and last voxel centres along each axis) at
//!   the finest spacing among them (per axis), axis-aligned with positive
//!   spacings: with `lo_a`, `hi_a` the box and `s_a` the spacing along axis
//!   `a`, `dims_a = ceil((hi_a - lo_a) / s_a - 1e-6) + 1` and voxel `(i, j,
//!   k)` centred at `lo + (i s_x, j s_y, k s_z)`. A subject's image whose
//!   affine is not axis-aligned (an off-diagonal entry of its 3 x 3 block
//!   above 1e-6 times its largest) is refused, as is a grid of more than
//!   [`MAX_VOXELS`] values.
//!
//! A subject counts at a common-grid voxel `c` when `c`'s centre lies in
//! its `flattened.vtu` (as on a shared grid: the pull-back sets the voxels
//! outside the mesh to 0, which is no measurement). Its value there is its
//! image interpolated trilinearly from those of its own voxels whose
//! centres lie in the mesh: with `v` the voxel coordinates of `c` in the
//! subject's image and `w_q = prod_a (1 - |v_a - q_a|)` the weight of each
//! of the 8 surrounding voxels `q`,
//!
//! ```text
//! value(c) = sum_{q inside, finite} w_q x_q / sum_{q inside, finite} w_q
//! ```
//!
//! and no value (NaN) when that sum of weights is 0 (no surrounding voxel
//! inside). A constant image stays that constant wherever it is covered.

use crate::app::error::{AppError, at};
use crate::io::{read_image_header, read_tet_mesh};
use crate::mesh::Volume;
use crate::mesh::nalgebra::{Matrix4, Point3};
use crate::mesh::spatial::TetLocator;
use std::path::{Path, PathBuf};

/// The suffix of a pulled-back image.
pub const FLAT: &str = "_flat.nii.gz";

/// The most values (voxels times frames) a chosen common grid may have
/// (64 Mi: the statistics keep three `f64` arrays of the grid).
pub const MAX_VOXELS: usize = 1 << 26;

/// Relative tolerance of an axis-aligned affine's off-diagonal entries.
const AXIS_TOLERANCE: f64 = 1e-6;

/// A common grid: its dims (x, y, z, frames), its voxel-to-world affine,
/// and whether the subjects' images are resampled onto it.
#[derive(Debug, Clone, PartialEq)]
pub struct CommonGrid {
    /// Voxels along x, y, z and frames.
    pub dims: [usize; 4],
    /// Voxel-to-world (template frame, mm).
    pub affine: Matrix4<f64>,
    /// False: every subject's image is on this grid already.
    pub resampled: bool,
}

impl CommonGrid {
    /// The spacing along each axis (mm).
    pub fn spacing(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| {
            (0..3)
                .map(|r| self.affine[(r, a)].powi(2))
                .sum::<f64>()
                .sqrt()
        })
    }

    /// The world position of the centre of voxel 0.
    pub fn origin(&self) -> [f64; 3] {
        [0, 1, 2].map(|r| self.affine[(r, 3)])
    }

    /// Values per frame (`nx ny nz`).
    pub fn frame_len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// One line: "101 x 101 x 31 voxels of 2 x 2 x 2 mm from (-100, -100,
    /// -30) mm".
    pub fn describe(&self) -> String {
        let [nx, ny, nz, _] = self.dims;
        let [sx, sy, sz] = self.spacing();
        let [ox, oy, oz] = self.origin();
        format!("{nx} x {ny} x {nz} voxels of {sx} x {sy} x {sz} mm from ({ox}, {oy}, {oz}) mm")
    }

    /// The grid as `grid.json` records it, with the number of subjects.
    pub fn to_json(&self, subjects: usize) -> serde_json::Value {
        serde_json::json!({
            "dims": &self.dims[..3],
            "frames": self.dims[3],
            "spacing_mm": self.spacing(),
            "origin_mm": self.origin(),
            "subjects": subjects,
            "resampled": self.resampled,
        })
    }
}

/// A subject's pulled-back image `name`: its path in `dir`.
pub fn flat_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}{FLAT}"))
}

/// A chosen grid and the subjects left out of it, `(id, why)`.
pub type Chosen = (CommonGrid, Vec<(String, String)>);

/// Whether two grids are the same (dims and affine to 1e-6 mm).
fn same_grid(a: ([usize; 4], &Matrix4<f64>), b: ([usize; 4], &Matrix4<f64>)) -> bool {
    a.0 == b.0 && (a.1 - b.1).iter().all(|d| d.abs() <= 1e-6)
}

/// Chooses the common grid of image `name` over the subjects `members`
/// (`(id, directory)`, each with `<name>_flat.nii.gz`); returns it and the
/// subjects left out with why (a number of frames other than the first
/// subject's). `None` without members.
///
/// # Errors
/// Reading a header; an image whose affine is not axis-aligned (named);
/// a union grid of more than [`MAX_VOXELS`] values.
pub fn choose(name: &str, members: &[(String, PathBuf)]) -> Result<Option<Chosen>, AppError> {
    let mut headers = Vec::with_capacity(members.len());
    for (id, dir) in members {
        let h = read_image_header(flat_path(dir, name))?;
        headers.push((id.clone(), h.dims, h.affine));
    }
    let Some((_, dims0, affine0)) = headers.first().cloned() else {
        return Ok(None);
    };
    if headers
        .iter()
        .all(|(_, d, a)| same_grid((*d, a), (dims0, &affine0)))
    {
        let grid = CommonGrid {
            dims: dims0,
            affine: affine0,
            resampled: false,
        };
        return Ok(Some((grid, Vec::new())));
    }
    let frames = dims0[3];
    let mut left_out = Vec::new();
    let (mut lo, mut hi, mut spacing) = (
        [f64::INFINITY; 3],
        [f64::NEG_INFINITY; 3],
        [f64::INFINITY; 3],
    );
    for (id, dims, affine) in &headers {
        if dims[3] != frames {
            left_out.push((
                id.clone(),
                format!(
                    "{name}{FLAT} has {} frames, the first subject's {frames}",
                    dims[3]
                ),
            ));
            continue;
        }
        let largest = (0..3)
            .flat_map(|r| (0..3).map(move |c| (r, c)))
            .map(|rc| affine[rc].abs())
            .fold(0.0, f64::max);
        let skew = (0..3)
            .flat_map(|r| (0..3).map(move |c| (r, c)))
            .filter(|(r, c)| r != c)
            .map(|rc| affine[rc].abs())
            .fold(0.0, f64::max);
        if largest.is_nan()
            || largest <= 0.0
            || skew > AXIS_TOLERANCE * largest
            || (0..3).any(|a| affine[(a, a)] == 0.0)
        {
            return Err(AppError::Usage(format!(
                "{id}: {name}{FLAT}'s affine is not axis-aligned (off-diagonal {skew:.3e} of \
                 {largest:.3e}); the cohort resamples template-frame images only, rerun the \
                 subject or give every subject one --grid"
            )));
        }
        for a in 0..3 {
            let first = affine[(a, 3)];
            let last = first + affine[(a, a)] * (dims[a].max(1) - 1) as f64;
            lo[a] = lo[a].min(first.min(last));
            hi[a] = hi[a].max(first.max(last));
            spacing[a] = spacing[a].min(affine[(a, a)].abs());
        }
    }
    let mut dims = [0usize; 4];
    dims[3] = frames;
    for a in 0..3 {
        dims[a] = ((hi[a] - lo[a]) / spacing[a] - 1e-6).ceil().max(0.0) as usize + 1;
    }
    let values = dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
    if values.is_none_or(|v| v > MAX_VOXELS) {
        return Err(AppError::Usage(format!(
            "the common grid of {name}{FLAT} over {} subjects would be {} x {} x {} voxels x {} \
             frames at {} x {} x {} mm (more than {MAX_VOXELS} values); give every subject one \
             coarser --grid or --spacing-mm",
            headers.len() - left_out.len(),
            dims[0],
            dims[1],
            dims[2],
            dims[3],
            spacing[0],
            spacing[1],
            spacing[2]
        )));
    }
    let mut affine = Matrix4::identity();
    for a in 0..3 {
        affine[(a, a)] = spacing[a];
        affine[(a, 3)] = lo[a];
    }
    let grid = CommonGrid {
        dims,
        affine,
        resampled: true,
    };
    Ok(Some((grid, left_out)))
}

/// Which voxels of the grid `(dims, affine)` have their centre in `mesh`.
fn inside(locator: &TetLocator, dims: [usize; 4], affine: &Matrix4<f64>) -> Vec<bool> {
    let [nx, ny, nz, _] = dims;
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                out.push(locator.locate(&p).is_some());
            }
        }
    }
    out
}

/// A subject's image `name` on `grid` and which voxels (of one frame) its
/// flattened mesh covers (module documentation); the values are NaN where
/// the subject has none.
///
/// # Errors
/// Reading the image or `flattened.vtu`; an image not on `grid` when the
/// grid is not resampled.
pub fn on_grid(
    grid: &CommonGrid,
    dir: &Path,
    name: &str,
) -> Result<(Volume<f32>, Vec<bool>), AppError> {
    let path = flat_path(dir, name);
    let img = crate::app::run::files::read_image_checked(&path, 1.0)?;
    let mesh = read_tet_mesh(dir.join("flattened.vtu"))?;
    let locator = TetLocator::new(&mesh);
    let own = img.volume;
    let own_mask = inside(&locator, own.dims(), own.affine());
    if !grid.resampled {
        if !same_grid((own.dims(), own.affine()), (grid.dims, &grid.affine)) {
            return Err(at(
                &path,
                "is not on the cohort's common grid; run the cohort again",
            ));
        }
        return Ok((own, own_mask));
    }
    let mut mask = inside(&locator, grid.dims, &grid.affine);
    let to_voxel = own
        .affine()
        .try_inverse()
        .ok_or_else(|| at(&path, "has a singular affine"))?;
    let [ox, oy, oz, frames] = own.dims();
    let own_len = ox * oy * oz;
    let len = grid.frame_len();
    let mut data = vec![f32::NAN; len * frames];
    let [nx, ny, _, _] = grid.dims;
    for c in 0..len {
        if !mask[c] {
            continue;
        }
        let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
        let p = grid
            .affine
            .transform_point(&Point3::new(i as f64, j as f64, k as f64));
        let v = to_voxel.transform_point(&p);
        let base = [v.x.floor(), v.y.floor(), v.z.floor()];
        // the 8 surrounding voxels inside the subject's mesh, with weights
        let mut corners: Vec<(usize, f64)> = Vec::with_capacity(8);
        for corner in 0..8 {
            let q = [0, 1, 2].map(|a| base[a] + ((corner >> a) & 1) as f64);
            let w: f64 = [v.x, v.y, v.z]
                .iter()
                .zip(&q)
                .map(|(x, qa)| 1.0 - (x - qa).abs())
                .product();
            let in_range = q
                .iter()
                .zip([ox, oy, oz])
                .all(|(&qa, n)| qa >= 0.0 && qa < n as f64);
            if w <= 0.0 || !in_range {
                continue;
            }
            let idx = q[0] as usize + ox * (q[1] as usize + oy * q[2] as usize);
            if own_mask[idx] {
                corners.push((idx, w));
            }
        }
        if corners.is_empty() {
            mask[c] = false;
            continue;
        }
        for t in 0..frames {
            let (mut sw, mut swx) = (0.0f64, 0.0f64);
            for &(idx, w) in &corners {
                let x = f64::from(own.data()[idx + t * own_len]);
                if x.is_finite() {
                    sw += w;
                    swx += w * x;
                }
            }
            if sw > 0.0 {
                data[c + t * len] = (swx / sw) as f32;
            }
        }
    }
    let vol = Volume::new(grid.dims, grid.affine, data).map_err(|e| at(&path, e))?;
    Ok((vol, mask))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_describes_itself() {
        let mut affine = Matrix4::identity();
        affine[(0, 0)] = 2.0;
        affine[(1, 1)] = 2.0;
        affine[(2, 2)] = 1.5;
        affine[(0, 3)] = -10.0;
        let g = CommonGrid {
            dims: [3, 4, 5, 1],
            affine,
            resampled: true,
        };
        assert_eq!(g.spacing(), [2.0, 2.0, 1.5]);
        assert_eq!(g.origin(), [-10.0, 0.0, 0.0]);
        assert_eq!(g.frame_len(), 60);
        assert_eq!(
            g.describe(),
            "3 x 4 x 5 voxels of 2 x 2 x 1.5 mm from (-10, 0, 0) mm"
        );
        assert_eq!(g.to_json(4)["subjects"], 4);
    }
}
