//! NRRD images (3D Slicer's and ITK's format): `.nrrd` (attached header),
//! `.nhdr` (detached header naming a data file) and Slicer's `.seg.nrrd`
//! segmentations, read into the same [`NiftiImage`] as NIfTI files.
//!
//! No well-kept NRRD crate exists, so the format is written here:
//! [`header`] parses and checks the header, [`data`] decodes the data,
//! [`write`](mod@write) serializes.
//!
//! # Reading
//!
//! Magic `NRRD0001` to `NRRD0005`; the fields `type` (every spelling:
//! `uchar`, `unsigned char`, `uint8`, `short`, `int16`, `signed short`, ...,
//! `float`, `double`), `dimension` (3, or 4 for a series), `sizes`, `endian`,
//! `encoding` (`raw`, `gzip`/`gz`, `ascii`/`txt`/`text`), `space`
//! (`left-posterior-superior`/`LPS`, `right-anterior-superior`/`RAS`,
//! `left-anterior-superior`/`LAS`; a bare `space dimension: 3` is taken as
//! RAS, i.e. the world coordinates are used as they are), `space directions`
//! (`none` for the non-spatial axis), `space origin`, `spacings`, `kinds`,
//! `byte skip`, `line skip`, `data file` (one file, relative to the header's
//! directory; `LIST` and `%d` patterns are refused) and `content` (kept as
//! [`NiftiImage::description`]). `key:=value` pairs are read and ignored
//! except Slicer's `Segment<N>_Layer` (below); comments and other fields
//! (`thicknesses`, `units`, `measurement frame`, ...) are ignored. `space
//! units` are assumed to be millimetres.
//!
//! The voxel-to-world affine maps voxel `(i, j, k)` of the three spatial axes
//! (in file order) to `origin + i d_i + j d_j + k d_k` with the `space
//! directions` `d`, then to RAS, NIfTI's world frame:
//!
//! ```text
//! A_ras = diag(-1, -1, 1, 1) · A_lps        A_ras = diag(-1, 1, 1, 1) · A_las
//! ```
//!
//! Without `space directions` the affine is `diag(spacings)` (NaN or missing
//! spacings are 1) with origin 0 (or `space origin`), and no flip
//! ([`AffineSource::Spacings`]).
//!
//! A 4D file has one non-spatial axis, the frame axis: the `none` entry of
//! `space directions`, else the axis whose `kinds` entry is not a spatial
//! kind (`domain`, `space`, `???`), else the last axis. It may be anywhere
//! (Slicer puts a `list` axis first); the values are reordered to
//! [`Volume`]'s layout, `i + nx (j + ny (k + nz t))`. Its `spacings` entry,
//! when finite and positive, is [`NiftiImage::time_step`].
//!
//! Slicer's `.seg.nrrd`: a segmentation stored in one layer is a 3D integer
//! label map and reads as any image. A segmentation with several layers
//! (overlapping segments: 4D, a `list` axis of layers, `Segment<N>_Layer`
//! keys) is refused with an error saying how to export a label map: merging
//! layers would have to choose one label where segments overlap, and the
//! same value means different segments in different layers.
//!
//! The image's [`NiftiImage::datatype`] is the stored type, the values are
//! unscaled (`scl_slope` 1), [`NiftiImage::sform_code`] is 1 (scanner) so
//! a NIfTI written from it says the world frame is the scanner's.
//!
//! Limits: the header is at most [`MAX_HEADER`] bytes; each size is at most
//! [`MAX_SIZE`] (the NIfTI-1 limit, so every image read can be written as
//! NIfTI); the data must be exactly as long as the sizes and type declare
//! (see [`data`]).
//!
//! # Writing
//!
//! See [`write()`]: `NRRD0004`, gzip, little-endian, LPS (ITK's and Slicer's
//! default), attached header.

mod data;
mod header;
mod write;

pub use write::write;

use crate::nifti::{AffineSource, UNITS_MM};
use crate::{ImageHeader, IoError, Location, NiftiImage};
use header::{Header, Space};
use nalgebra::Matrix4;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Largest header read, in bytes (1 MiB): a file whose header does not end
/// by then is refused.
pub const MAX_HEADER: usize = 1 << 20;
/// Largest size of an axis (32767, NIfTI-1's limit).
pub const MAX_SIZE: usize = i16::MAX as usize;

/// Kinds of a spatial (resampleable) axis.
const SPATIAL_KINDS: [&str; 4] = ["domain", "space", "???", "none"];

/// A checked header, its axes and the image header fields.
pub(crate) struct Prepared {
    h: Header,
    frame: Option<usize>,
    spatial: [usize; 3],
    meta: ImageHeader,
}

/// Where the data of a header is.
enum DataAt {
    /// Attached, from this byte of the file.
    Attached(usize),
    /// In the file `data file` names (path resolved), on this header line.
    Detached(PathBuf, usize),
}

/// Checks a parsed header and computes the image header fields.
fn prepare(h: Header) -> Result<Prepared, IoError> {
    let (frame, spatial) = axes(&h)?;
    check_segmentation(&h, frame)?;
    let (affine, source) = affine(&h, &spatial);
    let mut dims = [1usize; 4];
    for (d, &a) in dims.iter_mut().zip(&spatial) {
        *d = h.sizes[a];
    }
    if let Some(f) = frame {
        dims[3] = h.sizes[f];
    }
    let time_step = frame
        .and_then(|f| h.spacings.as_ref().map(|s| s[f]))
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(1.0, |s| s as f32);
    let meta = ImageHeader {
        dims,
        affine,
        datatype: h.datatype,
        scl_slope: 1.0,
        scl_inter: 0.0,
        affine_source: source,
        sform_code: 1,
        qform_code: 0,
        xyzt_units: UNITS_MM,
        time_step,
        description: h.content.clone().unwrap_or_default(),
        intent_code: 0,
        intent_params: [0.0; 3],
        intent_name: String::new(),
    };
    // Checking the affine now fails a bad one before the data is decoded.
    meta.check_affine()?;
    Ok(Prepared {
        h,
        frame,
        spatial,
        meta,
    })
}

/// Where the data is: attached after the header (of a file of `len`
/// bytes), or in a detached file in `dir` (`None`: refused).
fn locate(h: &Header, dir: Option<&Path>, len: u64) -> Result<DataAt, IoError> {
    match &h.data_file {
        None => match h.data_offset {
            Some(start) => Ok(DataAt::Attached(start)),
            None => Err(IoError::malformed(
                Location::Byte(len),
                "the header has no 'data file' and no empty line before attached data: \
                 the file is truncated",
            )),
        },
        Some(f) => match dir {
            Some(dir) => Ok(DataAt::Detached(dir.join(&f.name), f.line)),
            None => Err(IoError::unsupported(format!(
                "line {}: detached data ('data file: {}') needs the header's directory",
                f.line, f.name
            ))),
        },
    }
}

/// Streams a detached data file to `sink` (errors name the data file).
fn stream_detached(
    h: &Header,
    path: &Path,
    line: usize,
    sink: &mut dyn FnMut(&[f32]),
) -> Result<(), IoError> {
    let cannot = |e: std::io::Error| {
        IoError::malformed(
            Location::Line(line),
            format!(
                "data file {} cannot be read ({e}); it must be beside the header",
                path.display()
            ),
        )
    };
    let file = File::open(path).map_err(cannot)?;
    let len = file.metadata().map_err(cannot)?.len();
    data::stream(h, &mut BufReader::new(file), len, 0, sink).map_err(|e| e.with_path(path))
}

/// The image of prepared header fields and values in file order.
fn finish(p: Prepared, values: Vec<f32>) -> Result<NiftiImage, IoError> {
    let data = reorder(values, &p.h.sizes, &p.spatial, p.frame);
    p.meta.into_image(data)
}

/// Parses a NRRD file's bytes. `dir` is the directory of the file, where a
/// detached `data file` is looked for (`None`: detached data is refused).
/// See the [module documentation](self).
pub fn read(bytes: &[u8], dir: Option<&Path>) -> Result<NiftiImage, IoError> {
    let p = prepare(header::parse(bytes)?)?;
    let values = match locate(&p.h, dir, bytes.len() as u64)? {
        DataAt::Attached(start) => data::values(&p.h, &bytes[start..], start as u64)?,
        DataAt::Detached(path, line) => {
            let mut out = Vec::new();
            stream_detached(&p.h, &path, line, &mut |v| out.extend_from_slice(v))?;
            out
        }
    };
    finish(p, values)
}

/// The directory of a file's path (`.` for a bare file name).
fn parent(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Reads and checks the header of a NRRD file: at most [`MAX_HEADER`] + 2
/// bytes are read (enough to see whether the header ends within
/// [`MAX_HEADER`] bytes), not the data. A detached data file is not opened.
pub(crate) fn read_header_file(path: &Path) -> Result<(Prepared, ImageHeader), IoError> {
    let (file, len) = crate::format::open(path)?;
    let mut prefix = Vec::new();
    file.take(MAX_HEADER as u64 + 2)
        .read_to_end(&mut prefix)
        .map_err(|source| IoError::Io {
            path: crate::FilePath(path.to_path_buf()),
            source,
        })?;
    let p = prepare(header::parse(&prefix)?)?;
    locate(&p.h, Some(parent(path)), len)?;
    let meta = p.meta.clone();
    Ok((p, meta))
}

/// Streams the values of a NRRD file (attached or detached data) to `sink`,
/// in file order; returns the prepared header.
fn stream_prepared(path: &Path, sink: &mut dyn FnMut(&[f32])) -> Result<Prepared, IoError> {
    let (p, _) = read_header_file(path)?;
    match locate(&p.h, Some(parent(path)), 0)? {
        DataAt::Attached(start) => {
            let (file, len) = crate::format::open(path)?;
            let mut r = BufReader::new(file);
            r.seek(SeekFrom::Start(start as u64))
                .map_err(|source| IoError::Io {
                    path: crate::FilePath(path.to_path_buf()),
                    source,
                })?;
            data::stream(
                &p.h,
                &mut r,
                len.saturating_sub(start as u64),
                start as u64,
                sink,
            )?;
        }
        DataAt::Detached(data, line) => stream_detached(&p.h, &data, line, sink)?,
    }
    Ok(p)
}

/// Streams the values of a NRRD file to `sink` in file order (axis 0
/// fastest; see [`crate::scan_image_values`]); returns its header.
pub(crate) fn stream_file(
    path: &Path,
    sink: &mut dyn FnMut(&[f32]),
) -> Result<ImageHeader, IoError> {
    stream_prepared(path, sink).map(|p| p.meta)
}

/// Reads a NRRD file, header first, decoding the data as it is read (or
/// inflated).
pub(crate) fn read_file(path: &Path) -> Result<NiftiImage, IoError> {
    let mut values = Vec::new();
    let p = stream_prepared(path, &mut |v| values.extend_from_slice(v))?;
    finish(p, values)
}

/// The frame axis (4D) and the three spatial axes, in file order.
fn axes(h: &Header) -> Result<(Option<usize>, [usize; 3]), IoError> {
    let n = h.sizes.len();
    let non_spatial: Vec<usize> = match (&h.directions, &h.kinds) {
        (Some(d), _) => (0..n).filter(|&a| d[a].is_none()).collect(),
        (None, Some(k)) => (0..n)
            .filter(|&a| !SPATIAL_KINDS.contains(&k[a].as_str()))
            .collect(),
        (None, None) => Vec::new(),
    };
    let frame = match (n, non_spatial.as_slice()) {
        (3, []) => None,
        (4, [f]) => Some(*f),
        (4, []) if h.directions.is_none() => Some(3),
        _ => {
            return Err(IoError::unsupported(format!(
                "{n} axes of which {} are not spatial ({}): only 3D images and 4D series \
                 (3 spatial axes) are supported",
                non_spatial.len(),
                match (&h.directions, &h.kinds) {
                    (Some(_), _) => "'none' in space directions",
                    _ => "by their kinds",
                }
            )));
        }
    };
    let mut spatial = [0usize; 3];
    for (s, a) in spatial.iter_mut().zip((0..n).filter(|&a| Some(a) != frame)) {
        *s = a;
    }
    Ok((frame, spatial))
}

/// Refuses a Slicer segmentation with several layers (see the [module
/// documentation](self)).
fn check_segmentation(h: &Header, frame: Option<usize>) -> Result<(), IoError> {
    let layered = h
        .key_values
        .iter()
        .any(|(k, _)| k.starts_with("Segment") && k.ends_with("_Layer"));
    match frame {
        Some(f) if layered && h.sizes[f] > 1 => Err(IoError::unsupported(format!(
            "a Slicer segmentation with {} layers (overlapping segments) is not supported; \
             export it as one label map (Slicer: Segmentations module, Export to files or \
             Export visible segments to binary labelmap) and save that as .nrrd or .nii.gz",
            h.sizes[f]
        ))),
        _ => Ok(()),
    }
}

/// The voxel-to-world (RAS) affine and where it came from.
fn affine(h: &Header, spatial: &[usize; 3]) -> (Matrix4<f64>, AffineSource) {
    let mut m = Matrix4::identity();
    let origin = h.origin.unwrap_or([0.0; 3]);
    for r in 0..3 {
        m[(r, 3)] = origin[r];
    }
    let source = match &h.directions {
        Some(d) => {
            for (c, &a) in spatial.iter().enumerate() {
                // `axes` made every spatial axis one with a direction.
                let v = d[a].unwrap_or([0.0; 3]);
                for r in 0..3 {
                    m[(r, c)] = v[r];
                }
            }
            AffineSource::SpaceDirections
        }
        None => {
            for (c, &a) in spatial.iter().enumerate() {
                let s = h.spacings.as_ref().map_or(1.0, |s| s[a]);
                m[(c, c)] = if s.is_finite() && s != 0.0 { s } else { 1.0 };
            }
            AffineSource::Spacings
        }
    };
    let flip = match h.space {
        Some(Space::Lps) => [-1.0, -1.0, 1.0],
        Some(Space::Las) => [-1.0, 1.0, 1.0],
        Some(Space::Ras) | None => [1.0; 3],
    };
    for (r, f) in flip.iter().enumerate() {
        for c in 0..4 {
            // `+ 0.0` turns the -0 of a flipped 0 into 0.
            m[(r, c)] = m[(r, c)] * f + 0.0;
        }
    }
    (m, source)
}

/// Reorders values in file order (axis 0 fastest) to `Volume`'s layout:
/// the spatial axes, in order, then the frame axis.
fn reorder(
    values: Vec<f32>,
    sizes: &[usize],
    spatial: &[usize; 3],
    frame: Option<usize>,
) -> Vec<f32> {
    let Some(f) = frame else {
        return values;
    };
    if f == sizes.len() - 1 {
        return values;
    }
    let mut stride = vec![1usize; sizes.len()];
    for a in 1..sizes.len() {
        stride[a] = stride[a - 1] * sizes[a - 1];
    }
    let (nx, ny, nz, nt) = (
        sizes[spatial[0]],
        sizes[spatial[1]],
        sizes[spatial[2]],
        sizes[f],
    );
    let mut out = Vec::with_capacity(values.len());
    for t in 0..nt {
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    out.push(
                        values[i * stride[spatial[0]]
                            + j * stride[spatial[1]]
                            + k * stride[spatial[2]]
                            + t * stride[f]],
                    );
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
