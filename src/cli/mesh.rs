//! `unfold mesh MASK -o MESH`: a tet mesh of a segmentation
//! ([`crate::mesh::mesher`]: optional dilation, Gaussian smoothing, a
//! level set meshed by isosurface stuffing in world coordinates).
//!
//! The mesh file's format follows its extension (`.vtu`, `.vtk`, `.mesh`,
//! `.msh`); it holds the tets only. The largest connected component is kept
//! (with a warning naming the others' sizes) unless `--keep-all-components`.

use super::{AppError, at, positive};
use crate::app::run::StagedOutputs;
use crate::io::{WriteOptions, write_mesh};
use crate::mesh::mesher::{
    IsoLevel, MaskMesh, MaskMeshOptions, MaskSelection, MeshQuality, estimate_memory,
    mask_from_image, mesh_mask,
};
use crate::mesh::{CellMesh, MeshError, Volume};
use clap::Args;
use std::path::{Path, PathBuf};

/// How a segmentation is meshed (shared by `unfold mesh`, `unfold placenta
/// --seg` and the Python package's `unfold.tet_mesh`).
#[derive(Debug, Clone, Args)]
pub struct MaskArgs {
    /// Lattice cube side, mm (tet edges are this and 0.87 of it)
    /// [default: the smallest voxel spacing; placenta --seg: from the
    /// mask's volume, see --dense].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub size_mm: Option<f64>,
    /// Gaussian smoothing of the mask, voxels (0: none).
    #[arg(
        long,
        value_name = "VOXELS",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub smooth_voxels: f64,
    /// 3x3x3 box dilations before smoothing (the reference pipeline used 1,
    /// which thickens the object by a voxel).
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=1))]
    pub dilate: u8,
    /// Voxels with a value above this are inside [default: the mask's one
    /// value besides 0 (1, 255, a label...) is inside].
    #[arg(
        long,
        value_name = "T",
        allow_negative_numbers = true,
        conflicts_with = "label"
    )]
    pub threshold: Option<f64>,
    /// Voxels equal to this value are inside: one structure of a label map
    /// (the placenta's label among others).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub label: Option<f64>,
    /// Level of the smoothed mask to mesh, in (0, 1) (the reference: 0.5)
    /// [default: the level that keeps the mask's volume].
    #[arg(long, value_name = "C", allow_negative_numbers = true)]
    pub level: Option<f64>,
    /// Coarser tets inside: edges grow from the cube side at the boundary
    /// by half the depth below it (the boundary is kept; dihedral angles
    /// stay within 10..165 degrees).
    #[arg(long)]
    pub grade: bool,
}

impl MaskArgs {
    /// The mesher's options, every flag checked.
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
    pub(crate) fn read_mask(&self, path: &Path) -> Result<Volume<bool>, AppError> {
        let image = super::read_image_checked(path, 1.0)?;
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

    /// Refuses meshing `mask` when the predicted peak passes the budget
    /// ([`estimate_memory`]).
    pub(crate) fn check_memory(
        &self,
        path: &Path,
        mask: &Volume<bool>,
        keep_all_components: bool,
    ) -> Result<(), AppError> {
        self.check_memory_of(path, mask, &self.options(keep_all_components)?)
    }

    /// As [`MaskArgs::check_memory`], for meshing with `opts`.
    pub(crate) fn check_memory_of(
        &self,
        path: &Path,
        mask: &Volume<bool>,
        opts: &MaskMeshOptions,
    ) -> Result<(), AppError> {
        let estimate = estimate_memory(mask, opts).map_err(|e| at(path, e))?;
        crate::app::run::memory::check(
            "meshing the mask",
            &estimate,
            "raise --size-mm (the lattice and the tets grow as 1/size^3), lower --smooth-voxels, \
             drop --grade, or crop the mask",
        )
    }

    /// Meshes the mask read from `path` (the memory budget checked first);
    /// warns on stderr about dropped components.
    ///
    /// # Errors
    /// The options' errors, [`AppError::Memory`], and the mesher's at
    /// `path`.
    pub fn mesh(
        &self,
        path: &Path,
        mask: &Volume<bool>,
        keep_all_components: bool,
    ) -> Result<MaskMesh, AppError> {
        self.check_memory(path, mask, keep_all_components)?;
        let opts = self.options(keep_all_components)?;
        let out = mesh_mask(mask, &opts).map_err(|e| at(path, e))?;
        warn_dropped(path, &out, keep_all_components);
        Ok(out)
    }
}

/// Warns on stderr when the mesher left components out.
pub(crate) fn warn_dropped(path: &Path, out: &MaskMesh, keep_all_components: bool) {
    if out.dropped_components.is_empty() {
        return;
    }
    let sizes: Vec<String> = out
        .dropped_components
        .iter()
        .map(|n| n.to_string())
        .collect();
    eprintln!(
        "warning: {}: the segmentation has {} connected components; kept the largest \
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
    );
}

/// Arguments of `unfold mesh`.
#[derive(Debug, Args)]
#[command(
    after_help = "Prints the mesh's size and quality: tets, boundary triangles, volume against \
the mask's, dihedral angle range."
)]
pub struct MeshArgs {
    /// The segmentation: a 3D image (.nii .nii.gz .nrrd .seg.nrrd .nhdr), 0
    /// outside and one other value inside (a label map with --label, any
    /// values with --threshold).
    mask: PathBuf,
    /// Output tet mesh (.vtu .vtk .mesh; formats unfold can write).
    #[arg(short, long, value_name = "MESH")]
    output: PathBuf,
    #[command(flatten)]
    how: MaskArgs,
    /// Keep every connected component (default: the largest).
    #[arg(long)]
    keep_all_components: bool,
}

/// One line of figures about a mask's mesh.
pub(crate) fn describe(out: &MaskMesh, q: &MeshQuality) -> String {
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
        },
        q.volume_mm3,
        100.0 * (q.volume_mm3 / out.mask_volume_mm3 - 1.0),
        out.mask_volume_mm3,
        q.min_dihedral_deg,
        q.max_dihedral_deg
    )
}

/// Runs `unfold mesh`.
pub fn run(a: &MeshArgs) -> Result<(), AppError> {
    if super::canonical(&a.mask) == super::canonical(&a.output) {
        return Err(at(
            &a.output,
            "refusing to overwrite the input; choose another output path",
        ));
    }
    a.how.options(a.keep_all_components)?;
    // The output checked (and staged) before the mask is read.
    let mut staged = StagedOutputs::new([&a.mask]);
    let target = staged.file(&a.output)?;
    let mask = a.how.read_mask(&a.mask)?;
    let out = a.how.mesh(&a.mask, &mask, a.keep_all_components)?;
    let q = MeshQuality::of(&out.mesh)?;
    write_mesh(
        &target,
        &CellMesh::from(&out.mesh),
        &WriteOptions::default(),
    )
    .map_err(|e| staged.shown_error(e))?;
    staged.commit()?;
    println!("{}: {}", a.output.display(), describe(&out, &q));
    Ok(())
}
