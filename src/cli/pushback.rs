//! `unfold pushback IMAGE --run DIR --reference SCAN -o OUT`: carries a
//! template-space image (an atlas, labels drawn on the flat template, a
//! cohort mean) back onto a subject's scanner grid through the inverse of
//! the flattening map of an `unfold placenta` run
//! ([`crate::organs::placenta::pushback`]).
//!
//! The run's `DIR/original.vtu` (scanner frame) and `DIR/flattened.vtu`
//! (template frame) give the piecewise linear map; every voxel centre of the
//! reference image's grid inside the original mesh is mapped into the
//! template and IMAGE is sampled there (trilinearly, or with `--interp
//! nearest` by the nearest voxel, keeping an integer label image's type).
//! Voxels outside the mesh, or mapped outside IMAGE, are 0. OUT has the
//! reference image's grid and affine, and IMAGE's frames.

use super::choice::named;
use super::{AppError, at};
use crate::app::placenta::write::nearest_datatype;
use crate::app::run::StagedOutputs;
use crate::io::{FileKind, NiftiImage, read_tet_mesh, write_image};
use crate::organs::placenta::pushback::push_back;
use crate::organs::placenta::{Interpolation, PullbackError};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `unfold pushback`.
#[derive(Debug, Args)]
#[command(
    after_help = "The map is the one of an `unfold placenta` run: DIR/original.vtu and \
DIR/flattened.vtu. OUT has the grid of --reference; voxels outside the placenta are 0."
)]
pub struct PushbackArgs {
    /// A template-space image (the frame of DIR/flattened.vtu and of the
    /// `<name>_flat.nii.gz` images), 3D or 4D, NIfTI or NRRD.
    image: PathBuf,
    /// Output directory of an `unfold placenta` run (holding original.vtu and
    /// flattened.vtu).
    #[arg(long, value_name = "DIR")]
    run: PathBuf,
    /// A scanner image of the subject: its voxel grid and affine are the
    /// output's (its values are not used).
    #[arg(long, value_name = "SCAN")]
    reference: PathBuf,
    /// Output image (.nii, .nii.gz or .nrrd).
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// How IMAGE is sampled: linear (intensities) or nearest (label maps).
    #[arg(long, value_parser = named::<Interpolation>(), default_value = "linear")]
    interp: Interpolation,
}

/// Runs `unfold pushback`.
pub fn run(a: &PushbackArgs) -> Result<(), AppError> {
    let out = &a.output;
    if !matches!(
        FileKind::from_path(out),
        Ok(FileKind::Nifti { .. } | FileKind::Nrrd { detached: false })
    ) {
        return Err(at(
            out,
            "the output must be an image (.nii, .nii.gz or .nrrd)",
        ));
    }
    let original_path = a.run.join("original.vtu");
    let flattened_path = a.run.join("flattened.vtu");
    let target = super::canonical(out);
    for input in [&a.image, &a.reference, &original_path, &flattened_path] {
        if super::canonical(input) == target {
            return Err(at(
                input,
                "is an input and would be overwritten by -o; choose another output",
            ));
        }
    }
    for p in [&original_path, &flattened_path] {
        if !p.is_file() {
            return Err(at(
                &a.run,
                format!(
                    "is not the output directory of an `unfold placenta` run: {} is missing",
                    p.display()
                ),
            ));
        }
    }
    // The output checked (and staged) before the inputs are read.
    let mut staged = StagedOutputs::new([&a.image, &a.reference, &original_path, &flattened_path]);
    let target = staged.file(out)?;
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
    let image = super::read_image_checked(&a.image, 0.0)?;
    let reference = super::read_image_checked(&a.reference, 48.0)?;
    let interpolation = a.interp;
    let (volume, stats) = push_back(
        &original.positions,
        &original.tets,
        &flattened.positions,
        &reference.volume,
        &image.volume,
        interpolation,
    )
    .map_err(|e| match e {
        PullbackError::EmptyTable { .. } => at(
            &a.reference,
            format!(
                "no voxel centre of this grid lies inside the placenta of {} (is it an \
                 image of the same subject, in the same frame?)",
                original_path.display()
            ),
        ),
        PullbackError::ReferenceGridSize { .. } | PullbackError::ReferenceAffine => {
            at(&a.reference, e)
        }
        PullbackError::NoOverlap { .. } | PullbackError::EmptyImage { .. } => at(&a.image, e),
        e => at(&a.run, e),
    })?;
    let mut img = NiftiImage::new(volume);
    img.time_step = image.time_step;
    img.xyzt_units = image.xyzt_units;
    img.description = "unfold pushback: template image on the scanner grid".into();
    if interpolation == Interpolation::Nearest {
        img = img.with_datatype(nearest_datatype(&image));
    }
    write_image(&target, &img).map_err(|e| staged.shown_error(e))?;
    staged.commit()?;
    println!(
        "{} -> {}: {} voxels of {} inside the placenta, {} sampled, {} outside the template image",
        a.image.display(),
        out.display(),
        stats.inside_mesh,
        reference.volume.frame_len(),
        stats.sampled,
        stats.outside_image
    );
    Ok(())
}
