//! `unfold convert`: between mesh formats, keeping point and cell data
//! (`scale` multiplies the coordinates, e.g. metres to millimetres);
//! between images (NIfTI `.nii` / `.nii.gz` and NRRD `.nrrd`, any
//! direction), keeping the data type, the affine and the header fields both
//! formats hold.
//!
//! [`Settings`] and [`Files`] checked together ([`check`]) into a
//! [`Conversion`], then [`convert_mesh`] or [`convert_image`] into a staged
//! output, each returning what the command line prints.

use crate::app::error::{AppError, positive};
use crate::app::run::StagedOutputs;
use crate::app::run::files::{canonical, read_image_checked};
use crate::io::{
    Datatype, FileKind, LegacyVersion, NiftiImage, WriteOptions, XmlEncoding, read_mesh,
    write_image, write_mesh,
};
use std::path::{Path, PathBuf};

/// How a mesh is written and scaled; the names are the command line's
/// flags (`vtk_version` is `--vtk-version`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Settings {
    /// Text instead of binary where the format has both.
    pub ascii: bool,
    /// How VTK XML files store arrays.
    pub encoding: XmlEncoding,
    /// zlib-compress VTK XML arrays.
    pub compress: bool,
    /// Legacy VTK file version.
    pub vtk_version: LegacyVersion,
    /// Big-endian binary PLY.
    pub big_endian: bool,
    /// Multiply a mesh's point coordinates by this factor (> 0).
    pub scale: Option<f64>,
}

impl Settings {
    /// The writers' options: `ascii` makes VTK XML arrays text too.
    pub fn write_options(&self) -> WriteOptions {
        WriteOptions {
            ascii: self.ascii,
            xml_encoding: if self.ascii {
                XmlEncoding::Ascii
            } else {
                self.encoding
            },
            compress: self.compress,
            legacy_version: self.vtk_version,
            big_endian: self.big_endian,
        }
    }
}

/// The files of a conversion.
#[derive(Debug, Clone)]
pub struct Files {
    /// Input mesh or image.
    pub input: PathBuf,
    /// Output mesh or image (from an image only).
    pub output: PathBuf,
}

/// What a conversion is: between images or between meshes (with the
/// checked scale factor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Conversion {
    /// Image to image.
    Images,
    /// Mesh to mesh, the coordinates multiplied by the factor if any.
    Meshes {
        /// The scale factor (> 0).
        scale: Option<f64>,
    },
}

/// Checks `settings` and `files` before anything is read: the output is
/// not the input, both are known formats, `scale` is positive and given
/// for a mesh only, and both files are images or both meshes.
///
/// # Errors
/// [`AppError::Usage`] (or an unknown extension's error) naming the file
/// or the flag.
pub fn check(settings: &Settings, files: &Files) -> Result<Conversion, AppError> {
    if canonical(&files.input) == canonical(&files.output) {
        return Err(AppError::Usage(format!(
            "{}: refusing to overwrite the input; choose another output path",
            files.output.display()
        )));
    }
    let image_in = FileKind::from_path(&files.input)?.is_image();
    let image_out = FileKind::from_path(&files.output)?.is_image();
    let scale = settings.scale.map(|f| positive("--scale", f)).transpose()?;
    if scale.is_some() && image_in {
        return Err(AppError::Usage(format!(
            "{}: --scale applies to meshes; an image's spacing is in its header",
            files.input.display()
        )));
    }
    match (image_in, image_out) {
        (true, true) => Ok(Conversion::Images),
        (true, false) | (false, true) => Err(AppError::Usage(format!(
            "{} -> {}: convert goes between meshes or between images, not from one to \
             the other",
            files.input.display(),
            files.output.display()
        ))),
        (false, false) => Ok(Conversion::Meshes { scale }),
    }
}

/// What a mesh conversion wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshConversion {
    /// Points of the mesh.
    pub points: usize,
    /// Cells of the mesh.
    pub cells: usize,
    /// Point data arrays.
    pub point_arrays: usize,
    /// Cell data arrays.
    pub cell_arrays: usize,
    /// The output's extension when its format holds no data arrays, and
    /// the arrays not written (besides Medit's own references).
    pub not_written: Option<(&'static str, Vec<String>)>,
}

/// Converts the mesh `files.input` into `target` (a staging path of
/// `staged`, for `files.output`): read, the coordinates multiplied by
/// `scale`, written with `settings`' options.
///
/// # Errors
/// Reading or writing the mesh (a writing error names the path it will
/// have).
pub fn convert_mesh(
    settings: &Settings,
    scale: Option<f64>,
    files: &Files,
    target: &Path,
    staged: &StagedOutputs,
) -> Result<MeshConversion, AppError> {
    let mut mesh = read_mesh(&files.input)?;
    if let Some(f) = scale {
        for p in &mut mesh.positions {
            p.coords *= f;
        }
    }
    write_mesh(target, &mesh, &settings.write_options()).map_err(|e| staged.shown_error(e))?;
    let not_written = match FileKind::from_path(&files.output)? {
        FileKind::Mesh(f) if !f.holds_arrays() => {
            let dropped: Vec<String> = mesh
                .point_data
                .iter()
                .chain(mesh.cell_data.iter())
                .map(|f| f.name())
                .filter(|n| !n.starts_with("medit:"))
                .map(str::to_string)
                .collect();
            (!dropped.is_empty()).then_some((f.extension(), dropped))
        }
        _ => None,
    };
    Ok(MeshConversion {
        points: mesh.num_points(),
        cells: mesh.num_cells(),
        point_arrays: mesh.point_data.len(),
        cell_arrays: mesh.cell_data.len(),
        not_written,
    })
}

/// The data type an image is re-written with: the stored one when the
/// values are unscaled (`scl_slope` 0 or 1, `scl_inter` 0), so that
/// `.nii` <-> `.nii.gz` changes nothing; FLOAT32 for scaled integers (the
/// values are written scaled, slope 1).
pub fn kept_datatype(image: &NiftiImage) -> Datatype {
    let unscaled = (image.scl_slope == 0.0 || image.scl_slope == 1.0) && image.scl_inter == 0.0;
    if unscaled {
        image.datatype
    } else {
        Datatype::Float32
    }
}

/// What an image conversion wrote.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageConversion {
    /// Voxels along i, j, k and frames.
    pub dims: [usize; 4],
    /// The data type written ([`kept_datatype`]).
    pub datatype: Datatype,
}

/// Converts the image `input` (NIfTI, NRRD) into `target`: the values,
/// data type and affine kept, and the header fields the output format
/// holds (NIfTI: codes, units, intent, description; NRRD: description as
/// `content`). `target` is staged, put in place by the caller.
///
/// # Errors
/// Reading (within the memory budget) or writing the image.
pub fn convert_image(input: &Path, target: &Path) -> Result<ImageConversion, AppError> {
    let image = read_image_checked(input, 8.0)?;
    let datatype = kept_datatype(&image);
    let dims = image.volume.dims();
    write_image(target, &image.with_datatype(datatype))?;
    Ok(ImageConversion { dims, datatype })
}
