//! The placenta's inverse map (`unfold pushback`): a template-space image
//! (an atlas, labels drawn on the flat template, a cohort mean) carried
//! back onto a subject's scanner grid through the inverse of the flattening
//! map of an `unfold placenta` run
//! ([`crate::organs::placenta::pushback`]).
//!
//! The run's `DIR/original.vtu` (scanner frame) and `DIR/flattened.vtu`
//! (template frame) give the piecewise linear map; every voxel centre of the
//! reference image's grid inside the original mesh is mapped into the
//! template and the image is sampled there (trilinearly, or by the nearest
//! voxel, keeping an integer label image's type). Voxels outside the mesh,
//! or mapped outside the image, are 0. The output has the reference image's
//! grid and affine, and the image's frames.
//!
//! [`Settings`], the [`Files`] checked ([`Files::check`]) and read
//! ([`Files::read`]) into [`Inputs`], [`run`] into a [`Run`] with its typed
//! [`PushbackReport`], and [`write`] into the staged output.

use super::inputs::{FLATTENED, ORIGINAL};
use super::write::nearest_datatype;
use crate::app::error::{AppError, at};
use crate::app::run::StagedOutputs;
use crate::app::run::files::{canonical, read_image_checked};
use crate::io::{FileKind, NiftiImage, read_tet_mesh, write_image};
use crate::mesh::TetMesh;
use crate::organs::placenta::pushback::push_back;
use crate::organs::placenta::{Interpolation, PullbackError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How the image is carried back; the names are the command line's flags.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// How the image is sampled: linear (intensities) or nearest (label
    /// maps).
    pub interp: Interpolation,
}

/// The files of a push-back.
#[derive(Debug, Clone)]
pub struct Files {
    /// The template-space image (3D or 4D, NIfTI or NRRD).
    pub image: PathBuf,
    /// The output directory of an `unfold placenta` run.
    pub run: PathBuf,
    /// A scanner image of the subject: its grid and affine are the
    /// output's.
    pub reference: PathBuf,
    /// The output image (.nii, .nii.gz or .nrrd).
    pub output: PathBuf,
}

/// What a push-back works on, read and checked.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// The run's mesh in the scanner frame.
    pub original: TetMesh,
    /// The same mesh in the template frame.
    pub flattened: TetMesh,
    /// The template-space image.
    pub image: NiftiImage,
    /// The reference scanner image.
    pub reference: NiftiImage,
}

impl Files {
    /// The run's mesh in the scanner frame, `DIR/original.vtu`.
    pub fn original(&self) -> PathBuf {
        self.run.join(ORIGINAL)
    }

    /// The run's mesh in the template frame, `DIR/flattened.vtu`.
    pub fn flattened(&self) -> PathBuf {
        self.run.join(FLATTENED)
    }

    /// Every input file: the image, the reference and the run's meshes.
    pub fn inputs(&self) -> [PathBuf; 4] {
        [
            self.image.clone(),
            self.reference.clone(),
            self.original(),
            self.flattened(),
        ]
    }

    /// Checks the files before anything is read: the output is an image
    /// path and no input, and the run directory holds both meshes.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the file.
    pub fn check(&self) -> Result<(), AppError> {
        let out = &self.output;
        if !matches!(
            FileKind::from_path(out),
            Ok(FileKind::Nifti { .. } | FileKind::Nrrd { detached: false })
        ) {
            return Err(at(
                out,
                "the output must be an image (.nii, .nii.gz or .nrrd)",
            ));
        }
        let target = canonical(out);
        for input in &self.inputs() {
            if canonical(input) == target {
                return Err(at(
                    input,
                    "is an input and would be overwritten by -o; choose another output",
                ));
            }
        }
        for p in [self.original(), self.flattened()] {
            if !p.is_file() {
                return Err(at(
                    &self.run,
                    format!(
                        "is not the output directory of an `unfold placenta` run: {} is missing",
                        p.display()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Reads the run's meshes (checked to be one mesh: same vertices and
    /// tets), then the image and the reference (within the memory budget).
    ///
    /// # Errors
    /// Reading a file, meshes of different runs.
    pub fn read(&self) -> Result<Inputs, AppError> {
        let original_path = self.original();
        let flattened_path = self.flattened();
        let original = read_tet_mesh(&original_path)?;
        let flattened = read_tet_mesh(&flattened_path)?;
        if original.num_vertices() != flattened.num_vertices() || original.tets != flattened.tets {
            return Err(at(
                &flattened_path,
                format!(
                    "does not match {} ({} vertices and {} tets against {} and {}, or other \
                     connectivity): both must come from the same `unfold placenta` run",
                    original_path.display(),
                    flattened.num_vertices(),
                    flattened.num_tets(),
                    original.num_vertices(),
                    original.num_tets()
                ),
            ));
        }
        let image = read_image_checked(&self.image, 0.0)?;
        let reference = read_image_checked(&self.reference, 48.0)?;
        Ok(Inputs {
            original,
            flattened,
            image,
            reference,
        })
    }
}

/// What a push-back reports: the counts of the reference grid's voxels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct PushbackReport {
    /// Voxels of the reference grid (one frame).
    pub reference_voxels: usize,
    /// Voxels whose centre lies inside the placenta (the original mesh).
    pub inside_mesh: usize,
    /// Of those, voxels mapped inside the template image (sampled).
    pub sampled: usize,
    /// Of those, voxels mapped outside the template image (set to 0).
    pub outside_image: usize,
}

/// What a push-back produced.
#[derive(Debug, Clone)]
pub struct Run {
    /// The image on the reference grid, with the template image's frames.
    pub image: NiftiImage,
    /// The counts.
    pub report: PushbackReport,
}

/// Carries `inputs.image` back onto the reference grid through the
/// inverse of the run's map; the output keeps the image's time step and
/// units, and with nearest-neighbour sampling its integer data type
/// ([`nearest_datatype`]).
///
/// # Errors
/// The push-back's, attributed to the file they are about (`files`).
pub fn run(settings: &Settings, files: &Files, inputs: &Inputs) -> Result<Run, AppError> {
    let interpolation = settings.interp;
    let (volume, stats) = push_back(
        &inputs.original.positions,
        &inputs.original.tets,
        &inputs.flattened.positions,
        &inputs.reference.volume,
        &inputs.image.volume,
        interpolation,
    )
    .map_err(|e| match e {
        PullbackError::EmptyTable { .. } => at(
            &files.reference,
            format!(
                "no voxel centre of this grid lies inside the placenta of {} (is it an \
                 image of the same subject, in the same frame?)",
                files.original().display()
            ),
        ),
        PullbackError::ReferenceGridSize { .. } | PullbackError::ReferenceAffine => {
            at(&files.reference, e)
        }
        PullbackError::NoOverlap { .. } | PullbackError::EmptyImage { .. } => at(&files.image, e),
        e => at(&files.run, e),
    })?;
    let mut img = NiftiImage::new(volume);
    img.time_step = inputs.image.time_step;
    img.xyzt_units = inputs.image.xyzt_units;
    img.description = "unfold pushback: template image on the scanner grid".into();
    if interpolation == Interpolation::Nearest {
        img = img.with_datatype(nearest_datatype(&inputs.image));
    }
    Ok(Run {
        image: img,
        report: PushbackReport {
            reference_voxels: inputs.reference.volume.frame_len(),
            inside_mesh: stats.inside_mesh,
            sampled: stats.sampled,
            outside_image: stats.outside_image,
        },
    })
}

/// Writes the pushed-back image at `target`, a staging path of `staged`
/// (errors name the path it will have).
///
/// # Errors
/// Writing the image.
pub fn write(run: &Run, target: &Path, staged: &StagedOutputs) -> Result<(), AppError> {
    write_image(target, &run.image).map_err(|e| staged.shown_error(e))?;
    Ok(())
}
