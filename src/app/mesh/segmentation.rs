//! `unfold mesh` (and Python's `unfold.tet_mesh`): a segmentation meshed
//! into tets ([`crate::mesh::mesher`]: optional dilation, Gaussian
//! smoothing, a level set meshed by isosurface stuffing in world
//! coordinates).
//!
//! The largest connected component is kept (with a warning naming the
//! others' sizes) unless `keep_all_components`. [`Settings`] (checked by
//! [`Settings::validate`]), the [`Files`] checked before anything is read
//! and the mask read ([`Files::read`]), [`run`] into a [`Run`] (the mesh
//! and its quality; [`Run::report`] the typed [`MeshReport`]), [`write`]
//! into the staged output. The mesh file holds the tets only.

use super::mask::{MaskSettings, describe};
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::StagedOutputs;
use crate::app::run::files::canonical;
use crate::app::run::provenance::Provenance;
use crate::io::{WriteOptions, write_mesh};
use crate::mesh::mesher::{MaskMesh, MaskMeshOptions, MeshQuality};
use crate::mesh::pinch::PinchRepair;
use crate::mesh::{CellMesh, Volume};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How a segmentation is meshed; the names are the command line's flags.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// The mesher's settings (`--size-mm`, `--smooth-voxels`, ...).
    #[serde(flatten)]
    pub mask: MaskSettings,
    /// Keep every connected component (default: the largest).
    pub keep_all_components: bool,
}

impl Settings {
    /// The mesher's options, every setting checked
    /// ([`MaskSettings::options`]).
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag out of range.
    pub fn validate(&self) -> Result<MaskMeshOptions, AppError> {
        self.mask.options(self.keep_all_components)
    }
}

/// The files of `unfold mesh`.
#[derive(Debug, Clone)]
pub struct Files {
    /// The segmentation: a 3D image.
    pub mask: PathBuf,
    /// The output tet mesh (format by extension).
    pub output: PathBuf,
}

impl Files {
    /// Checks the files before anything is read: the output is not the
    /// mask.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the output.
    pub fn check(&self) -> Result<(), AppError> {
        if canonical(&self.mask) == canonical(&self.output) {
            return Err(at(
                &self.output,
                "refusing to overwrite the input; choose another output path",
            ));
        }
        Ok(())
    }

    /// Reads the mask of `settings` from the image ([`MaskSettings::read_mask`]).
    ///
    /// # Errors
    /// Reading the image, choosing its voxels.
    pub fn read(&self, settings: &Settings) -> Result<Volume<bool>, AppError> {
        settings.mask.read_mask(&self.mask)
    }
}

/// A segmentation's mesh and its quality.
#[derive(Debug, Clone)]
pub struct Run {
    /// The mesher's result.
    pub mesh: MaskMesh,
    /// The mesh's size and quality figures.
    pub quality: MeshQuality,
}

/// Meshes `mask` (read from `path`, which messages name) with `settings`
/// (the memory budget checked first); a warning to `observer` names the
/// components left out.
///
/// # Errors
/// The settings' errors, [`AppError::Memory`], and the mesher's at `path`.
pub fn run(
    settings: &Settings,
    path: &Path,
    mask: &Volume<bool>,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    let mesh = settings
        .mask
        .mesh(path, mask, settings.keep_all_components, observer)?;
    let quality = MeshQuality::of(&mesh.mesh)?;
    Ok(Run { mesh, quality })
}

impl Run {
    /// One line of figures about the mesh ([`describe`]).
    pub fn describe(&self) -> String {
        describe(&self.mesh, &self.quality)
    }

    /// The report of this run on the mask called `mask` with `settings`.
    pub fn report(&self, mask: &str, settings: &Settings, provenance: Provenance) -> MeshReport {
        let out = &self.mesh;
        MeshReport {
            mask: mask.to_string(),
            mask_voxels: out.mask_voxels,
            mask_volume_mm3: out.mask_volume_mm3,
            size_mm: out.size_mm,
            smooth_voxels: settings.mask.smooth_voxels,
            dilate: settings.mask.dilate,
            level: out.level,
            graded_collapses: out.graded_collapses,
            pinches: out.pinches,
            components: out.components,
            dropped_components: out.dropped_components.clone(),
            quality: self.quality,
            provenance,
        }
    }
}

/// What a segmentation's mesh reports (Python's `unfold.tet_mesh`
/// report): the figures the command line prints, and provenance.
#[derive(Debug, Clone, Serialize)]
pub struct MeshReport {
    /// The mask's name (its path, or what the caller calls it).
    pub mask: String,
    /// Voxels set in the mask.
    pub mask_voxels: usize,
    /// Their volume, mm^3.
    pub mask_volume_mm3: f64,
    /// Lattice cube side used, mm.
    pub size_mm: f64,
    /// Gaussian smoothing of the mask, voxels.
    pub smooth_voxels: f64,
    /// Box dilations before smoothing.
    pub dilate: u8,
    /// The level meshed.
    pub level: f64,
    /// Interior vertices removed by grading.
    pub graded_collapses: usize,
    /// What resolving the boundary's pinches did: vertices split, edges
    /// and vertices opened, tets and volume (mm^3) removed.
    pub pinches: PinchRepair,
    /// Connected components of the meshed domain.
    pub components: usize,
    /// Tet counts of the components left out, largest first.
    pub dropped_components: Vec<usize>,
    /// The mesh's size and quality figures.
    pub quality: MeshQuality,
    /// Version, parameters, start time.
    pub provenance: Provenance,
}

/// Writes the mesh's tets at `target`, a staging path of `staged` (errors
/// name the path it will have).
///
/// # Errors
/// Writing the file.
pub fn write(run: &Run, target: &Path, staged: &StagedOutputs) -> Result<(), AppError> {
    write_mesh(
        target,
        &CellMesh::from(&run.mesh.mesh),
        &WriteOptions::default(),
    )
    .map_err(|e| staged.shown_error(e))?;
    Ok(())
}
