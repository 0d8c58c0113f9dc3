//! `unfold convert IN OUT`: between mesh formats, keeping point and cell
//! data (`--scale F` multiplies the coordinates, e.g. metres to
//! millimetres); between images (NIfTI `.nii` / `.nii.gz` and NRRD `.nrrd`, any
//! direction), keeping the data type, the affine and the header fields both
//! formats hold.

use super::AppError;
use crate::app::run::StagedOutputs;
use crate::io::{
    Datatype, FileKind, LegacyVersion, NiftiImage, WriteOptions, XmlEncoding, read_mesh,
    write_image, write_mesh,
};
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

/// Runs `unfold convert`.
pub fn run(a: &ConvertArgs) -> Result<(), AppError> {
    if super::canonical(&a.input) == super::canonical(&a.output) {
        return Err(AppError::Usage(format!(
            "{}: refusing to overwrite the input; choose another output path",
            a.output.display()
        )));
    }
    let image_in = FileKind::from_path(&a.input)?.is_image();
    let image_out = FileKind::from_path(&a.output)?.is_image();
    let scale = a.scale.map(|f| super::positive("--scale", f)).transpose()?;
    if scale.is_some() && image_in {
        return Err(AppError::Usage(format!(
            "{}: --scale applies to meshes; an image's spacing is in its header",
            a.input.display()
        )));
    }
    match (image_in, image_out) {
        (true, true) => {
            let mut staged = StagedOutputs::new([&a.input]);
            let target = staged.file(&a.output)?;
            convert_image(a, &target).map_err(|e| super::shown(&staged, e))?;
            return Ok(staged.commit()?);
        }
        (true, false) | (false, true) => {
            return Err(AppError::Usage(format!(
                "{} -> {}: convert goes between meshes or between images, not from one to \
                 the other",
                a.input.display(),
                a.output.display()
            )));
        }
        (false, false) => {}
    }
    // The output checked (and staged) before the input is read.
    let mut staged = StagedOutputs::new([&a.input]);
    let target = staged.file(&a.output)?;
    let mut mesh = read_mesh(&a.input)?;
    if let Some(f) = scale {
        for p in &mut mesh.positions {
            p.coords *= f;
        }
    }
    let opts = WriteOptions {
        ascii: a.ascii,
        xml_encoding: match (a.ascii, a.encoding) {
            (true, _) | (_, Encoding::Ascii) => XmlEncoding::Ascii,
            (_, Encoding::AppendedRaw) => XmlEncoding::AppendedRaw,
            (_, Encoding::AppendedBase64) => XmlEncoding::AppendedBase64,
            (_, Encoding::InlineBase64) => XmlEncoding::InlineBase64,
        },
        compress: a.compress,
        legacy_version: match a.vtk_version {
            VtkVersion::V42 => LegacyVersion::V4_2,
            VtkVersion::V51 => LegacyVersion::V5_1,
        },
        big_endian: a.big_endian,
    };
    write_mesh(&target, &mesh, &opts).map_err(|e| staged.shown_error(e))?;
    staged.commit()?;
    if let FileKind::Mesh(f) = FileKind::from_path(&a.output)?
        && !f.holds_arrays()
    {
        let dropped: Vec<&str> = mesh
            .point_data
            .iter()
            .chain(mesh.cell_data.iter())
            .map(|f| f.name())
            .filter(|n| !n.starts_with("medit:"))
            .collect();
        if !dropped.is_empty() {
            eprintln!(
                "unfold: note: .{} files hold no data arrays; not written: {}",
                f.extension(),
                dropped.join(", ")
            );
        }
    }
    println!(
        "{} -> {}: {} points, {} cells, {} point arrays, {} cell arrays",
        a.input.display(),
        a.output.display(),
        mesh.num_points(),
        mesh.num_cells(),
        mesh.point_data.len(),
        mesh.cell_data.len()
    );
    Ok(())
}

/// The data type an image is re-written with: the stored one when the
/// values are unscaled (`scl_slope` 0 or 1, `scl_inter` 0), so that
/// `.nii` <-> `.nii.gz` changes nothing; FLOAT32 for scaled integers (the
/// values are written scaled, slope 1).
fn kept_datatype(image: &NiftiImage) -> Datatype {
    let unscaled = (image.scl_slope == 0.0 || image.scl_slope == 1.0) && image.scl_inter == 0.0;
    if unscaled {
        image.datatype
    } else {
        Datatype::Float32
    }
}

/// `unfold convert` between images (NIfTI, NRRD): the values, data type and
/// affine kept, and the header fields the output format holds (NIfTI: codes,
/// units, intent, description; NRRD: description as `content`).
/// The image is written at `target` (staged, put in place by the caller).
fn convert_image(a: &ConvertArgs, target: &std::path::Path) -> Result<(), AppError> {
    let image = super::read_image_checked(&a.input, 8.0)?;
    let datatype = kept_datatype(&image);
    let dims = image.volume.dims();
    write_image(target, &image.with_datatype(datatype))?;
    println!(
        "{} -> {}: {} x {} x {} voxels, {} frame{}, {}",
        a.input.display(),
        a.output.display(),
        dims[0],
        dims[1],
        dims[2],
        dims[3],
        if dims[3] == 1 { "" } else { "s" },
        datatype.name()
    );
    Ok(())
}
