//! How a segmentation is meshed: the settings shared by `unfold mesh`,
//! `unfold placenta --seg` and Python's `unfold.tet_mesh`, checked into the
//! mesher's options, the mask chosen from an image's values, the memory
//! predicted before meshing, and the one-line description of the result.

use crate::app::error::{AppError, at, positive};
use crate::app::observer::Observer;
use crate::app::run::{files, memory};
use crate::mesh::mesher::{
    IsoLevel, MaskMesh, MaskMeshOptions, MaskSelection, MeshQuality, estimate_memory,
    mask_from_image, mesh_mask,
};
use crate::mesh::pinch::PinchRepair;
use crate::mesh::{MeshError, Volume};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How a mask is meshed (the flags `--size-mm`, `--smooth-voxels`,
/// `--dilate`, `--threshold`, `--label`, `--level`, `--grade`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct MaskSettings {
    /// Lattice cube side, mm (none: the smallest voxel spacing; `placenta
    /// --seg` chooses its own).
    pub size_mm: Option<f64>,
    /// Gaussian smoothing of the mask, voxels (0: none).
    pub smooth_voxels: f64,
    /// 3x3x3 box dilations before smoothing (0 or 1).
    pub dilate: u8,
    /// Voxels above this value are inside.
    pub threshold: Option<f64>,
    /// Voxels equal to this value are inside.
    pub label: Option<f64>,
    /// Level of the smoothed mask to mesh, in (0, 1) (none: the level that
    /// keeps the mask's volume).
    pub level: Option<f64>,
    /// Coarser tets inside.
    pub grade: bool,
}

impl Default for MaskSettings {
    /// The flags' defaults: smoothing 1.5 voxels, nothing else.
    fn default() -> Self {
        MaskSettings {
            size_mm: None,
            smooth_voxels: 1.5,
            dilate: 0,
            threshold: None,
            label: None,
            level: None,
            grade: false,
        }
    }
}

impl MaskSettings {
    /// Whether every setting is its default (`placenta` refuses them
    /// without `--seg`).
    pub fn is_default(&self) -> bool {
        *self == MaskSettings::default()
    }

    /// The mesher's options, every setting checked.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag out of range.
    pub fn options(&self, keep_all_components: bool) -> Result<MaskMeshOptions, AppError> {
        if let Some(s) = self.size_mm {
            positive("--size-mm", s)?;
        }
        if !(self.smooth_voxels.is_finite() && self.smooth_voxels >= 0.0) {
            return Err(AppError::Usage(format!(
                "--smooth-voxels must be a finite number >= 0, got {}",
                self.smooth_voxels
            )));
        }
        if self.dilate > 1 {
            return Err(AppError::Usage(format!(
                "--dilate must be 0 or 1, got {}",
                self.dilate
            )));
        }
        if self.threshold.is_some() && self.label.is_some() {
            // (the parser refuses it on the command line; Python gets here)
            return Err(AppError::Usage(
                "--threshold cannot be used with --label: the one takes the voxels above a \
                 value, the other those equal to it"
                    .into(),
            ));
        }
        for (flag, value) in [("--threshold", self.threshold), ("--label", self.label)] {
            if let Some(v) = value
                && !v.is_finite()
            {
                return Err(AppError::Usage(format!("{flag} must be finite, got {v}")));
            }
        }
        let level = match self.level {
            None => IsoLevel::PreserveVolume,
            Some(c) if c > 0.0 && c < 1.0 => IsoLevel::Fixed(c),
            Some(c) => {
                return Err(AppError::Usage(format!(
                    "--level must be in (0, 1), got {c}"
                )));
            }
        };
        Ok(MaskMeshOptions {
            size_mm: self.size_mm,
            smooth_voxels: self.smooth_voxels,
            dilate: usize::from(self.dilate),
            level,
            keep_all_components,
            grade: self.grade,
        })
    }

    /// Reads the mask image at `path` (3D, binary or thresholded).
    ///
    /// # Errors
    /// Reading the image (within the memory budget), [`Self::mask_of`]'s.
    pub fn read_mask(&self, path: &Path) -> Result<Volume<bool>, AppError> {
        let image = files::read_image_checked(path, 1.0)?;
        self.mask_of(path, &image.volume)
    }

    /// The mask of the image `volume` (named `path` in messages): its
    /// voxels above `--threshold`, equal to `--label`, or its one value
    /// besides 0.
    ///
    /// # Errors
    /// [`mask_from_image`]'s (a label map without `--label` or
    /// `--threshold`, a label it does not hold, several frames), at `path`.
    pub fn mask_of(&self, path: &Path, volume: &Volume<f32>) -> Result<Volume<bool>, AppError> {
        let selection = match (self.label, self.threshold) {
            (Some(l), _) => MaskSelection::Label(l),
            (None, Some(t)) => MaskSelection::Above(t),
            (None, None) => MaskSelection::Nonzero,
        };
        mask_from_image(volume, selection).map_err(|e| match e {
            MeshError::MaskValues { .. } => at(
                path,
                format!("{e} (--label N: the voxels equal to N; --threshold T: those above T)"),
            ),
            e => at(path, e),
        })
    }

    /// Refuses meshing `mask` with `opts` when the predicted peak passes
    /// the budget ([`estimate_memory`]).
    ///
    /// # Errors
    /// [`AppError::Memory`] saying what to change.
    pub fn check_memory(
        &self,
        path: &Path,
        mask: &Volume<bool>,
        opts: &MaskMeshOptions,
    ) -> Result<(), AppError> {
        let estimate = estimate_memory(mask, opts).map_err(|e| at(path, e))?;
        memory::check(
            "meshing the mask",
            &estimate,
            "raise --size-mm (the lattice and the tets grow as 1/size^3), lower --smooth-voxels, \
             drop --grade, or crop the mask",
        )
    }

    /// Meshes the mask read from `path` (the memory budget checked first);
    /// a warning to `observer` names the components left out.
    ///
    /// # Errors
    /// The options' errors, [`AppError::Memory`], and the mesher's at
    /// `path`.
    pub fn mesh(
        &self,
        path: &Path,
        mask: &Volume<bool>,
        keep_all_components: bool,
        observer: &mut dyn Observer,
    ) -> Result<MaskMesh, AppError> {
        let opts = self.options(keep_all_components)?;
        self.check_memory(path, mask, &opts)?;
        let out = mesh_mask(mask, &opts).map_err(|e| at(path, e))?;
        warn_dropped(path, &out, keep_all_components, observer);
        Ok(out)
    }
}

/// Warns `observer` when the mesher left components out.
pub fn warn_dropped(
    path: &Path,
    out: &MaskMesh,
    keep_all_components: bool,
    observer: &mut dyn Observer,
) {
    if out.dropped_components.is_empty() {
        return;
    }
    let sizes: Vec<String> = out
        .dropped_components
        .iter()
        .map(|n| n.to_string())
        .collect();
    observer.warning(&format!(
        "{}: the segmentation has {} connected components; kept the largest \
         ({} tets), dropped {} of {} tets{}",
        path.display(),
        out.components,
        out.mesh.num_tets(),
        if sizes.len() == 1 {
            "one"
        } else {
            "the others"
        },
        sizes.join(", "),
        if keep_all_components {
            ""
        } else {
            " (--keep-all-components keeps them)"
        }
    ));
}

/// What resolving the boundary's pinches did, for [`describe`] (empty when
/// nothing was pinched).
fn describe_pinches(p: &PinchRepair) -> String {
    if !p.changed() {
        return String::new();
    }
    let mut s = format!(", pinches resolved: {} vertices split", p.vertices_split);
    if p.tets_removed > 0 {
        s += &format!(
            ", {} edges and {} vertices opened ({} tets, {:.3} mm^3 removed)",
            p.edges_opened, p.vertices_opened, p.tets_removed, p.volume_removed
        );
    }
    s
}

/// One line of figures about a mask's mesh: its size, cube side, level,
/// grading, pinches resolved, volume against the mask's, dihedral angle range.
pub fn describe(out: &MaskMesh, q: &MeshQuality) -> String {
    format!(
        "{} tets, {} vertices, {} boundary triangles (cube side {:.3} mm, level {:.3}{}); \
         volume {:.1} mm^3 ({:+.2} % of the mask's {:.1}); dihedral angles {:.1} .. {:.1} degrees",
        q.tets,
        q.vertices,
        q.boundary_triangles,
        out.size_mm,
        out.level,
        if out.graded_collapses > 0 {
            format!(
                ", graded: {} interior vertices removed",
                out.graded_collapses
            )
        } else {
            String::new()
        } + &describe_pinches(&out.pinches),
        q.volume_mm3,
        100.0 * (q.volume_mm3 / out.mask_volume_mm3 - 1.0),
        out.mask_volume_mm3,
        q.min_dihedral_deg,
        q.max_dihedral_deg
    )
}
