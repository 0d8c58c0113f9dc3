//! `unfold convert IN OUT`: the flags turned into the conversion's settings
//! and files ([`crate::app::mesh::convert`] converts), what was written
//! printed on stdout.

use crate::app::AppError;
use crate::app::error::shown;
use crate::app::mesh::convert::{
    self, Conversion, Files, ImageConversion, MeshConversion, Settings,
};
use crate::app::run::StagedOutputs;
use crate::io::{LegacyVersion, XmlEncoding};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Encoding {
    AppendedRaw,
    AppendedBase64,
    InlineBase64,
    Ascii,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum VtkVersion {
    #[value(name = "4.2")]
    V42,
    #[value(name = "5.1")]
    V51,
}

/// Arguments of `unfold convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Input mesh (.vtk .vtu .vtp .ply .obj .stl .off .mesh .msh) or image
    /// (.nii .nii.gz .nrrd .seg.nrrd .nhdr).
    input: PathBuf,
    /// Output mesh (.vtk .vtu .vtp .ply .obj .stl .off .mesh) or image (.nii
    /// .nii.gz .nrrd; from an image only).
    output: PathBuf,
    /// Write text instead of binary where the format has both.
    #[arg(long)]
    ascii: bool,
    /// How VTK XML files store arrays.
    #[arg(long, value_enum, default_value = "appended-raw")]
    encoding: Encoding,
    /// zlib-compress VTK XML arrays.
    #[arg(long)]
    compress: bool,
    /// Legacy VTK file version.
    #[arg(long, value_enum, default_value = "4.2")]
    vtk_version: VtkVersion,
    /// Big-endian binary PLY.
    #[arg(long)]
    big_endian: bool,
    /// Multiply a mesh's point coordinates by this factor (> 0), e.g. 1000
    /// for a mesh in metres, since unfold reads millimetres; point and cell
    /// arrays are copied as they are. Meshes only.
    #[arg(long, value_name = "FACTOR", allow_negative_numbers = true)]
    scale: Option<f64>,
}

impl ConvertArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            ascii: self.ascii,
            encoding: match self.encoding {
                Encoding::Ascii => XmlEncoding::Ascii,
                Encoding::AppendedRaw => XmlEncoding::AppendedRaw,
                Encoding::AppendedBase64 => XmlEncoding::AppendedBase64,
                Encoding::InlineBase64 => XmlEncoding::InlineBase64,
            },
            compress: self.compress,
            vtk_version: match self.vtk_version {
                VtkVersion::V42 => LegacyVersion::V4_2,
                VtkVersion::V51 => LegacyVersion::V5_1,
            },
            big_endian: self.big_endian,
            scale: self.scale,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            input: self.input.clone(),
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold convert`.
pub fn run(a: &ConvertArgs) -> Result<(), AppError> {
    let settings = a.settings();
    let files = a.files();
    let scale = match convert::check(&settings, &files)? {
        Conversion::Images => {
            let mut staged = StagedOutputs::new([&files.input]);
            let target = staged.file(&files.output)?;
            let c = convert::convert_image(&files.input, &target).map_err(|e| shown(&staged, e))?;
            print_image(a, &c);
            return Ok(staged.commit()?);
        }
        Conversion::Meshes { scale } => scale,
    };
    // The output checked (and staged) before the input is read.
    let mut staged = StagedOutputs::new([&files.input]);
    let target = staged.file(&files.output)?;
    let c = convert::convert_mesh(&settings, scale, &files, &target, &staged)?;
    staged.commit()?;
    print_mesh(a, &c);
    Ok(())
}

/// Prints what a mesh conversion wrote (and, on stderr, the arrays the
/// output format cannot hold).
fn print_mesh(a: &ConvertArgs, c: &MeshConversion) {
    if let Some((extension, dropped)) = &c.not_written {
        eprintln!(
            "unfold: note: .{extension} files hold no data arrays; not written: {}",
            dropped.join(", ")
        );
    }
    println!(
        "{} -> {}: {} points, {} cells, {} point arrays, {} cell arrays",
        a.input.display(),
        a.output.display(),
        c.points,
        c.cells,
        c.point_arrays,
        c.cell_arrays
    );
}

/// Prints what an image conversion wrote.
fn print_image(a: &ConvertArgs, c: &ImageConversion) {
    let dims = c.dims;
    println!(
        "{} -> {}: {} x {} x {} voxels, {} frame{}, {}",
        a.input.display(),
        a.output.display(),
        dims[0],
        dims[1],
        dims[2],
        dims[3],
        if dims[3] == 1 { "" } else { "s" },
        c.datatype.name()
    );
}
