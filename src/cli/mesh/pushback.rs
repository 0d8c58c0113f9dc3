//! `unfold pushback IMAGE --run DIR --reference SCAN -o OUT`: the flags
//! turned into the push-back's settings and files
//! ([`crate::app::placenta::pushback`] carries the template-space image
//! back onto the subject's scanner grid), the counts printed on stdout.

use crate::app::AppError;
use crate::app::placenta::pushback::{self, Files, Settings};
use crate::app::run::StagedOutputs;
use crate::cli::choice::named;
use crate::organs::placenta::Interpolation;
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

impl PushbackArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            interp: self.interp,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            image: self.image.clone(),
            run: self.run.clone(),
            reference: self.reference.clone(),
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold pushback`.
pub fn run(a: &PushbackArgs) -> Result<(), AppError> {
    let settings = a.settings();
    let files = a.files();
    files.check()?;
    // The output checked (and staged) before the inputs are read.
    let mut staged = StagedOutputs::new(files.inputs());
    let target = staged.file(&files.output)?;
    let inputs = files.read()?;
    let run = pushback::run(&settings, &files, &inputs)?;
    pushback::write(&run, &target, &staged)?;
    staged.commit()?;
    let r = run.report;
    println!(
        "{} -> {}: {} voxels of {} inside the placenta, {} sampled, {} outside the template image",
        a.image.display(),
        a.output.display(),
        r.inside_mesh,
        r.reference_voxels,
        r.sampled,
        r.outside_image
    );
    Ok(())
}
