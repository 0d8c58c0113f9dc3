//! The commands about files and meshes: `unfold mesh MASK -o MESH` (here:
//! a tet mesh of a segmentation, [`crate::app::mesh::segmentation`]),
//! [`repair`], [`convert`], [`info`] and the placenta's [`pushback`]; each
//! turns its flags into the application's settings and files, runs it and
//! prints.
//!
//! `unfold mesh`'s mesh file's format follows its extension (`.vtu`,
//! `.vtk`, `.mesh`, `.msh`); it holds the tets only. The largest connected
//! component is kept (with a warning naming the others' sizes) unless
//! `--keep-all-components`.

pub(crate) mod convert;
pub(crate) mod info;
pub(crate) mod pushback;
pub(crate) mod repair;

use super::progress::Progress;
use crate::app::AppError;
use crate::app::mesh::mask::MaskSettings;
use crate::app::mesh::segmentation::{self, Files, Settings};
use crate::app::run::StagedOutputs;
use clap::Args;
use std::path::PathBuf;

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
    /// The settings of the flags.
    pub(crate) fn settings(&self) -> MaskSettings {
        MaskSettings {
            size_mm: self.size_mm,
            smooth_voxels: self.smooth_voxels,
            dilate: self.dilate,
            threshold: self.threshold,
            label: self.label,
            level: self.level,
            grade: self.grade,
        }
    }
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

impl MeshArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            mask: self.how.settings(),
            keep_all_components: self.keep_all_components,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            mask: self.mask.clone(),
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold mesh`.
pub fn run(a: &MeshArgs) -> Result<(), AppError> {
    let settings = a.settings();
    let files = a.files();
    files.check()?;
    settings.validate()?;
    // The output checked (and staged) before the mask is read.
    let mut staged = StagedOutputs::new([&files.mask]);
    let target = staged.file(&files.output)?;
    let mask = files.read(&settings)?;
    let run = segmentation::run(&settings, &files.mask, &mask, &mut Progress::new(false))?;
    segmentation::write(&run, &target, &staged)?;
    staged.commit()?;
    println!("{}: {}", a.output.display(), run.describe());
    Ok(())
}
