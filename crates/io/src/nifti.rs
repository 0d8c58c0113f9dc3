//! NIfTI-1 images: `.nii` (single file, magic `n+1`) and `.nii.gz`.
//!
//! The reader and writer are written here rather than taken from the `nifti`
//! crate: the header is a fixed 348-byte struct, the crate pulls in `ndarray`
//! and a second linear-algebra stack, its writer does not control
//! sform / qform, and a hand-written parser lets every field be checked
//! against the file's size before anything is allocated.
//!
//! # Reading
//!
//! Both byte orders are read (the order is the one in which `sizeof_hdr`
//! reads 348). gzip input (magic `1f 8b`) is decompressed with
//! [`flate2::read::MultiGzDecoder`] as it is read: the header's 348 bytes
//! first; the size the header declares (`vox_offset + voxels × type size`)
//! is checked against the most a gzip stream of that length can expand to
//! before anything more is inflated, and the stream is never inflated more
//! than one byte past that size: a stream holding more or less is refused
//! with [`IoError::DecompressedSize`]. Values are decoded [`CHUNK`] bytes at
//! a time, so reading costs the `f32` values and 1 MiB; the header alone is
//! read by [`crate::read_image_header`] and the values streamed by
//! [`crate::scan_image_values`].
//!
//! Values are scaled, `value = scl_slope * stored + scl_inter`, when
//! `scl_slope` is finite and non-zero (slope 0 means "no scaling"), computed in
//! `f64` and stored as `f32`.
//!
//! The voxel-to-world affine is chosen as the NIfTI-1 standard says:
//!
//! 1. `sform_code > 0`: the rows `srow_x`, `srow_y`, `srow_z`, i.e.
//!    `x = srow_x · (i, j, k, 1)` and likewise `y`, `z`.
//! 2. else `qform_code > 0`: `R · diag(dx, dy, qfac · dz) · (i, j, k) + qoffset`
//!    from the quaternion, see [`qform_affine`] and [`quaternion_rotation`].
//! 3. else the ANALYZE fallback `diag(pixdim[1], pixdim[2], pixdim[3], 1)`
//!    (NIfTI "method 1"; nibabel instead centres and x-flips this case).
//!
//! [`NiftiImage::affine_source`] says which was used.
//!
//! The data type comes from `datatype` (`bitpix` is not checked). `dim[0]`
//! must be 1 to 7 and `dim[1..=dim[0]]` at least 1; missing spatial
//! dimensions are 1, and `dim[5..]` must be 1, except for vector images
//! (intent [`INTENT_VECTOR`] or [`INTENT_DISPVECT`], `dim[4] = 1`): their
//! components along `dim[5]` become the volume's frames. Extensions between byte 352
//! and `vox_offset` are skipped; bytes after the data are ignored (`.nii`) or
//! refused as above (`.nii.gz`). A `vox_offset` of 0 is taken as 352.
//!
//! # Writing
//!
//! Always NIfTI-1 single file, little-endian, `vox_offset = 352`, no
//! extensions, `scl_slope = 1`, `scl_inter = 0`, data type
//! [`NiftiImage::write_datatype`] (FLOAT32 unless changed with
//! [`NiftiImage::with_datatype`]). Both the sform (the affine, code
//! [`NiftiImage::sform_code`] or 2 = aligned) and, when the affine is a
//! rotation times a positive scaling, the qform (see [`qform_params`]) are
//! written (qform code [`NiftiImage::qform_code`], else the sform code; 0
//! and no quaternion for sheared affines); `pixdim[0] = qfac = ±1` (the sign
//! of the affine's determinant), `pixdim[1..=3]` are the affine's column
//! norms, `dim[0]` is 3, or 4 with `pixdim[4]` = [`NiftiImage::time_step`]
//! when there are several frames (5 with `dim[4] = 1` and the frames as
//! `dim[5]` components for vector intents, as ITK writes displacement
//! fields), and `xyzt_units` is millimetres (plus
//! seconds, or the temporal unit read, for 4D).

use crate::{ImageHeader, IoError, Location};
use flate2::read::MultiGzDecoder;
use flate2::write::GzEncoder;
use nalgebra::{Matrix3, Matrix4, Vector3};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use unfold_mesh::Volume;

/// Size of a NIfTI-1 header (`sizeof_hdr`).
const HEADER_LEN: usize = 348;
/// Offset of the voxel data in files written here (header + 4 extension bytes).
const WRITE_VOX_OFFSET: usize = 352;
/// Largest expansion of a deflate stream (the format's limit is about 1032:1).
pub(crate) const GZ_MAX_RATIO: u64 = 1100;

/// `intent_code` of a vector-valued image (NIFTI_INTENT_VECTOR): the
/// components are stored along `dim[5]`. ITK reads and writes displacement
/// fields with this intent.
pub const INTENT_VECTOR: i16 = 1007;
/// `intent_code` of a displacement vector field (NIFTI_INTENT_DISPVECT);
/// stored like [`INTENT_VECTOR`].
pub const INTENT_DISPVECT: i16 = 1006;

/// Whether `intent_code` stores vector components along `dim[5]`.
pub fn is_vector_intent(intent_code: i16) -> bool {
    intent_code == INTENT_VECTOR || intent_code == INTENT_DISPVECT
}

/// Spatial unit code for millimetres (`xyzt_units & 0x07`).
pub const UNITS_MM: u8 = 2;
/// Temporal unit code for seconds (`xyzt_units & 0x38`).
pub const UNITS_SEC: u8 = 8;

/// A voxel data type that can be read and written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Datatype {
    /// `DT_UINT8` (code 2).
    Uint8,
    /// `DT_INT8` (code 256).
    Int8,
    /// `DT_INT16` (code 4).
    Int16,
    /// `DT_UINT16` (code 512).
    Uint16,
    /// `DT_INT32` (code 8).
    Int32,
    /// `DT_UINT32` (code 768).
    Uint32,
    /// `DT_INT64` (code 1024).
    Int64,
    /// `DT_UINT64` (code 1280).
    Uint64,
    /// `DT_FLOAT32` (code 16).
    Float32,
    /// `DT_FLOAT64` (code 64).
    Float64,
}

impl Datatype {
    /// Every supported data type.
    pub const ALL: [Datatype; 10] = [
        Datatype::Uint8,
        Datatype::Int8,
        Datatype::Int16,
        Datatype::Uint16,
        Datatype::Int32,
        Datatype::Uint32,
        Datatype::Int64,
        Datatype::Uint64,
        Datatype::Float32,
        Datatype::Float64,
    ];

    /// The NIfTI-1 `datatype` code.
    pub fn code(self) -> i16 {
        match self {
            Datatype::Uint8 => 2,
            Datatype::Int16 => 4,
            Datatype::Int32 => 8,
            Datatype::Float32 => 16,
            Datatype::Float64 => 64,
            Datatype::Int8 => 256,
            Datatype::Uint16 => 512,
            Datatype::Uint32 => 768,
            Datatype::Int64 => 1024,
            Datatype::Uint64 => 1280,
        }
    }

    /// The data type of a `datatype` code, `None` for unsupported codes.
    pub fn from_code(code: i16) -> Option<Datatype> {
        Datatype::ALL.into_iter().find(|d| d.code() == code)
    }

    /// Bytes per voxel value.
    pub fn size(self) -> usize {
        match self {
            Datatype::Uint8 | Datatype::Int8 => 1,
            Datatype::Int16 | Datatype::Uint16 => 2,
            Datatype::Int32 | Datatype::Uint32 | Datatype::Float32 => 4,
            Datatype::Int64 | Datatype::Uint64 | Datatype::Float64 => 8,
        }
    }

    /// The NIfTI name, e.g. `"INT16"`.
    pub fn name(self) -> &'static str {
        match self {
            Datatype::Uint8 => "UINT8",
            Datatype::Int8 => "INT8",
            Datatype::Int16 => "INT16",
            Datatype::Uint16 => "UINT16",
            Datatype::Int32 => "INT32",
            Datatype::Uint32 => "UINT32",
            Datatype::Int64 => "INT64",
            Datatype::Uint64 => "UINT64",
            Datatype::Float32 => "FLOAT32",
            Datatype::Float64 => "FLOAT64",
        }
    }
}

/// Which header fields the affine of an image read from a file came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AffineSource {
    /// `srow_x/y/z` (`sform_code > 0`).
    Sform,
    /// The quaternion, `pixdim` and `qoffset` (`sform_code == 0 < qform_code`).
    Qform,
    /// Neither code set: `diag(pixdim[1], pixdim[2], pixdim[3])`.
    Analyze,
    /// A NRRD file's `space directions` and `space origin` (see
    /// [`crate::nrrd`]).
    SpaceDirections,
    /// A NRRD file without orientation: `diag(spacings)`, origin 0.
    Spacings,
}

/// A NIfTI-1 image: values (after `scl_slope` / `scl_inter`) on a grid with
/// its voxel-to-world affine, and the header fields worth keeping.
#[derive(Debug, Clone, PartialEq)]
pub struct NiftiImage {
    /// The voxel values and the voxel-to-world affine.
    pub volume: Volume<f32>,
    /// The data type the file stored (FLOAT32 for an image made in memory).
    pub datatype: Datatype,
    /// The data type [`write()`] stores: FLOAT32 unless set, also after
    /// [`read()`] (so re-writing a scaled integer file loses nothing).
    pub write_datatype: Datatype,
    /// `scl_slope` as read (the values in `volume` are already scaled; the
    /// writer always writes 1).
    pub scl_slope: f32,
    /// `scl_inter` as read (the writer always writes 0).
    pub scl_inter: f32,
    /// Where the affine came from.
    pub affine_source: AffineSource,
    /// `sform_code` as read; the writer uses it when positive, otherwise 2
    /// (aligned).
    pub sform_code: i16,
    /// `qform_code` as read; the writer uses it when positive, otherwise the
    /// sform code (0 when the affine has no qform).
    pub qform_code: i16,
    /// `xyzt_units` as read. The writer writes millimetres and, for 4D images,
    /// this field's temporal unit (seconds when it has none).
    pub xyzt_units: u8,
    /// `pixdim[4]`, the time between frames, for 4D images (1 otherwise).
    pub time_step: f32,
    /// `descrip` (at most 79 bytes are written).
    pub description: String,
    /// `intent_code`.
    pub intent_code: i16,
    /// `intent_p1`, `intent_p2`, `intent_p3`.
    pub intent_params: [f32; 3],
    /// `intent_name` (at most 15 bytes are written).
    pub intent_name: String,
}

impl NiftiImage {
    /// An image of `volume` with default header fields: FLOAT32, sform code 2
    /// (aligned), no intent, no description.
    pub fn new(volume: Volume<f32>) -> NiftiImage {
        NiftiImage {
            volume,
            datatype: Datatype::Float32,
            write_datatype: Datatype::Float32,
            scl_slope: 1.0,
            scl_inter: 0.0,
            affine_source: AffineSource::Sform,
            sform_code: 2,
            qform_code: 0,
            xyzt_units: UNITS_MM,
            time_step: 1.0,
            description: String::new(),
            intent_code: 0,
            intent_params: [0.0; 3],
            intent_name: String::new(),
        }
    }

    /// The same image, to be written as `datatype` (e.g. UINT8 or INT16 for
    /// label images). Integer types round half away from zero and clamp to
    /// the type's range; NaN becomes 0.
    pub fn with_datatype(mut self, datatype: Datatype) -> NiftiImage {
        self.write_datatype = datatype;
        self
    }
}

impl From<Volume<f32>> for NiftiImage {
    fn from(volume: Volume<f32>) -> NiftiImage {
        NiftiImage::new(volume)
    }
}

/// The rotation of a NIfTI quaternion `(b, c, d)` with `a = sqrt(1 - b² - c² -
/// d²)` (when `b² + c² + d² > 1 - 1e-7`, `(b, c, d)` is normalized and
/// `a = 0`):
///
/// ```text
///     [ a²+b²-c²-d²   2(bc-ad)      2(bd+ac)    ]
/// R = [ 2(bc+ad)      a²+c²-b²-d²   2(cd-ab)    ]
///     [ 2(bd-ac)      2(cd+ab)      a²+d²-c²-b² ]
/// ```
pub fn quaternion_rotation(b: f64, c: f64, d: f64) -> Matrix3<f64> {
    let n2 = b * b + c * c + d * d;
    let (a, b, c, d) = if 1.0 - n2 < 1e-7 {
        let s = 1.0 / n2.sqrt();
        (0.0, b * s, c * s, d * s)
    } else {
        ((1.0 - n2).sqrt(), b, c, d)
    };
    Matrix3::new(
        a * a + b * b - c * c - d * d,
        2.0 * (b * c - a * d),
        2.0 * (b * d + a * c),
        2.0 * (b * c + a * d),
        a * a + c * c - b * b - d * d,
        2.0 * (c * d - a * b),
        2.0 * (b * d - a * c),
        2.0 * (c * d + a * b),
        a * a + d * d - c * c - b * b,
    )
}

/// The qform ("method 2") affine:
///
/// ```text
/// [x y z]ᵀ = R · diag(dx, dy, qfac · dz) · [i j k]ᵀ + [qoffset_x qoffset_y qoffset_z]ᵀ
/// ```
///
/// with `R` from [`quaternion_rotation`], `qfac = -1` when `pixdim[0] < 0`
/// and `+1` otherwise (including 0), and `dx, dy, dz = pixdim[1..=3]`, each
/// replaced by 1 when not positive (as `nifti1_io` does).
pub fn qform_affine(quatern: [f64; 3], qoffset: [f64; 3], pixdim: [f64; 4]) -> Matrix4<f64> {
    let r = quaternion_rotation(quatern[0], quatern[1], quatern[2]);
    let pos = |x: f64| if x > 0.0 { x } else { 1.0 };
    let qfac = if pixdim[0] < 0.0 { -1.0 } else { 1.0 };
    let s = [pos(pixdim[1]), pos(pixdim[2]), qfac * pos(pixdim[3])];
    let mut m = Matrix4::identity();
    for i in 0..3 {
        for j in 0..3 {
            m[(i, j)] = r[(i, j)] * s[j];
        }
        m[(i, 3)] = qoffset[i];
    }
    m
}

/// The qform of an affine `[M t; 0 1]`, when `M = R · diag(s)` with `R`
/// orthogonal and `s > 0` (relative tolerance 1e-5 on `RᵀR = I`):
/// returns `(quatern [b, c, d], qfac)`. `s_j` are the column norms of `M`;
/// `qfac = -1` when `det M < 0`, and then the third column of `R` is negated
/// to make it a proper rotation. `R` is orthonormalized (nearest orthogonal
/// matrix by SVD, the polar factor) and converted to a unit quaternion with
/// `a ≥ 0`. `None` for shears and other affines the qform cannot represent.
pub fn qform_params(affine: &Matrix4<f64>) -> Option<([f64; 3], f64)> {
    let m = affine.fixed_view::<3, 3>(0, 0).into_owned();
    let mut q = m;
    for j in 0..3 {
        let n = m.column(j).norm();
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        q.column_mut(j).scale_mut(1.0 / n);
    }
    let err = (q.transpose() * q - Matrix3::identity()).abs().max();
    if err.is_nan() || err > 1e-5 {
        return None;
    }
    let qfac = if q.determinant() < 0.0 {
        q.column_mut(2).neg_mut();
        -1.0
    } else {
        1.0
    };
    let svd = q.svd(true, true);
    let r = svd.u? * svd.v_t?;
    let (r00, r01, r02) = (r[(0, 0)], r[(0, 1)], r[(0, 2)]);
    let (r10, r11, r12) = (r[(1, 0)], r[(1, 1)], r[(1, 2)]);
    let (r20, r21, r22) = (r[(2, 0)], r[(2, 1)], r[(2, 2)]);
    let trace = r00 + r11 + r22;
    let (a, b, c, d) = if trace > 0.0 {
        let s = 0.5 / (trace + 1.0).sqrt();
        (0.25 / s, (r21 - r12) * s, (r02 - r20) * s, (r10 - r01) * s)
    } else if r00 > r11 && r00 > r22 {
        let s = 2.0 * (1.0 + r00 - r11 - r22).sqrt();
        ((r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s)
    } else if r11 > r22 {
        let s = 2.0 * (1.0 + r11 - r00 - r22).sqrt();
        ((r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s)
    } else {
        let s = 2.0 * (1.0 + r22 - r00 - r11).sqrt();
        ((r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s)
    };
    let sign = if a < 0.0 { -1.0 } else { 1.0 };
    let quat = [sign * b, sign * c, sign * d];
    quat.iter().all(|x| x.is_finite()).then_some((quat, qfac))
}

/// Reads fields of a 348-byte header in its byte order.
struct Fields<'a> {
    b: &'a [u8],
    big_endian: bool,
}

impl Fields<'_> {
    fn bytes<const N: usize>(&self, off: usize) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[off..off + N]);
        if self.big_endian {
            a.reverse();
        }
        a
    }
    fn i16(&self, off: usize) -> i16 {
        i16::from_le_bytes(self.bytes(off))
    }
    #[cfg(test)]
    fn i32(&self, off: usize) -> i32 {
        i32::from_le_bytes(self.bytes(off))
    }
    fn f32(&self, off: usize) -> f32 {
        f32::from_le_bytes(self.bytes(off))
    }
    fn text(&self, off: usize, len: usize) -> String {
        let raw = &self.b[off..off + len];
        let end = raw.iter().position(|&c| c == 0).unwrap_or(len);
        String::from_utf8_lossy(&raw[..end]).into_owned()
    }
}

/// What the header says, checked.
pub(crate) struct Header {
    big_endian: bool,
    /// Offset of the data.
    offset: u64,
    /// Bytes of data.
    data_len: u64,
    /// `(slope, inter)` when values are scaled.
    scale: Option<(f64, f64)>,
    /// The header fields.
    pub(crate) meta: ImageHeader,
}

impl Header {
    /// Bytes the file holds up to the end of the data, `vox_offset + data`.
    fn total(&self) -> Result<u64, IoError> {
        self.offset
            .checked_add(self.data_len)
            .ok_or_else(|| malformed(108, "vox_offset plus data size overflows"))
    }
}

fn malformed(off: u64, msg: impl Into<String>) -> IoError {
    IoError::malformed(Location::Byte(off), msg)
}

/// Parses and checks the header (the first 348 bytes of `h`; fewer is an
/// error).
fn parse_header(h: &[u8]) -> Result<Header, IoError> {
    if h.len() < HEADER_LEN {
        return Err(malformed(
            h.len() as u64,
            format!(
                "the file ends after {} bytes; a NIfTI-1 header has {HEADER_LEN}",
                h.len()
            ),
        ));
    }
    let le = i32::from_le_bytes([h[0], h[1], h[2], h[3]]);
    let be = i32::from_be_bytes([h[0], h[1], h[2], h[3]]);
    let big_endian = match (le, be) {
        (348, _) => false,
        (_, 348) => true,
        (540, _) | (_, 540) => {
            return Err(IoError::unsupported(
                "NIfTI-2 files (sizeof_hdr 540) are not supported; convert to NIfTI-1",
            ));
        }
        _ => {
            return Err(malformed(
                0,
                format!("sizeof_hdr is {le}, expected 348: not a NIfTI-1 file"),
            ));
        }
    };
    let f = Fields { b: h, big_endian };
    match &h[344..348] {
        b"n+1\0" => {}
        b"ni1\0" => {
            return Err(IoError::unsupported(
                "NIfTI-1 header/image pairs (.hdr/.img, magic ni1) are not supported; \
                 use a single .nii file",
            ));
        }
        m => {
            return Err(IoError::unsupported(format!(
                "magic is {:?}, expected \"n+1\": ANALYZE 7.5 and other formats are not supported",
                String::from_utf8_lossy(m)
            )));
        }
    }

    // Dimensions.
    let dim: Vec<i16> = (0..8).map(|i| f.i16(40 + 2 * i)).collect();
    let ndim = dim[0];
    if !(1..=7).contains(&ndim) {
        return Err(malformed(40, format!("dim[0] is {ndim}, expected 1 to 7")));
    }
    let ndim = ndim as usize;
    for (i, &d) in dim.iter().enumerate().take(ndim + 1).skip(1) {
        if d < 1 {
            return Err(malformed(
                40 + 2 * i as u64,
                format!("dim[{i}] is {d}, expected at least 1"),
            ));
        }
    }
    let dn = |i: usize| if i <= ndim { dim[i] as usize } else { 1 };
    // Vector images keep their components along dim[5] (dim[4] = 1).
    let vector = is_vector_intent(f.i16(68)) && ndim >= 5 && dn(4) == 1;
    for (i, &d) in dim.iter().enumerate().take(ndim + 1).skip(5) {
        if d != 1 && !(vector && i == 5) {
            return Err(IoError::unsupported(format!(
                "images of more than 4 dimensions are not supported (dim[{i}] = {d}); \
                 5D images are read only as vector images (intent_code 1006 or 1007, dim[4] = 1)"
            )));
        }
    }
    let dims = [dn(1), dn(2), dn(3), if vector { dn(5) } else { dn(4) }];

    // Data type.
    let code = f.i16(70);
    let datatype = Datatype::from_code(code).ok_or_else(|| {
        let name = match code {
            0 => Some("UNKNOWN"),
            1 => Some("BINARY"),
            32 => Some("COMPLEX64"),
            128 => Some("RGB24"),
            1536 => Some("FLOAT128"),
            1792 => Some("COMPLEX128"),
            2048 => Some("COMPLEX256"),
            2304 => Some("RGBA32"),
            _ => None,
        };
        match name {
            Some(n) => IoError::unsupported(format!(
                "NIfTI datatype {code} ({n}) is not supported; supported: integers of \
                 8 to 64 bits, FLOAT32, FLOAT64"
            )),
            None => malformed(70, format!("unknown NIfTI datatype code {code}")),
        }
    })?;

    // Data location and size.
    let vox_offset = f.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= 0.0 && vox_offset.fract() == 0.0)
        || (vox_offset > 0.0 && vox_offset < WRITE_VOX_OFFSET as f32)
    {
        return Err(malformed(
            108,
            format!("vox_offset is {vox_offset}, expected a whole number of at least 352"),
        ));
    }
    // vox_offset 0 in a single file (some old writers) means right after the
    // header and extension flag.
    let offset = if vox_offset == 0.0 {
        WRITE_VOX_OFFSET as u64
    } else {
        vox_offset as u64
    };
    let data_len = dims
        .iter()
        .try_fold(datatype.size() as u64, |a, &d| a.checked_mul(d as u64))
        .ok_or_else(|| malformed(40, format!("dimensions {dims:?} overflow")))?;

    // Scaling.
    let slope = f.f32(112);
    let inter = f.f32(116);
    let scale = if slope != 0.0 && slope.is_finite() {
        if !inter.is_finite() {
            return Err(malformed(
                116,
                format!("scl_inter is {inter} with scl_slope {slope}"),
            ));
        }
        (slope != 1.0 || inter != 0.0).then_some((f64::from(slope), f64::from(inter)))
    } else {
        None
    };

    // Affine.
    let pixdim: Vec<f64> = (0..8).map(|i| f64::from(f.f32(76 + 4 * i))).collect();
    let qform_code = f.i16(252);
    let sform_code = f.i16(254);
    let (affine, affine_source) = if sform_code > 0 {
        let mut m = Matrix4::identity();
        for r in 0..3 {
            for c in 0..4 {
                m[(r, c)] = f64::from(f.f32(280 + 16 * r + 4 * c));
            }
        }
        (m, AffineSource::Sform)
    } else if qform_code > 0 {
        let q = [256, 260, 264].map(|o| f64::from(f.f32(o)));
        if !q.iter().all(|x| x.is_finite()) {
            return Err(malformed(
                256,
                format!("the qform quaternion {q:?} is not finite"),
            ));
        }
        let t = [268, 272, 276].map(|o| f64::from(f.f32(o)));
        let m = qform_affine(q, t, [pixdim[0], pixdim[1], pixdim[2], pixdim[3]]);
        (m, AffineSource::Qform)
    } else {
        let mut m = Matrix4::identity();
        for i in 0..3 {
            m[(i, i)] = pixdim[i + 1];
        }
        (m, AffineSource::Analyze)
    };

    let time_step = if ndim >= 4 && pixdim[4].is_finite() {
        pixdim[4] as f32
    } else {
        1.0
    };
    let meta = ImageHeader {
        dims,
        affine,
        datatype,
        scl_slope: slope,
        scl_inter: inter,
        affine_source,
        sform_code,
        qform_code,
        xyzt_units: h[123],
        time_step,
        description: f.text(148, 80),
        intent_code: f.i16(68),
        intent_params: [f.f32(56), f.f32(60), f.f32(64)],
        intent_name: f.text(328, 16),
    };
    // Checking the affine now (cheap) fails a bad one before any data is read.
    meta.check_affine()?;
    Ok(Header {
        big_endian,
        offset,
        data_len,
        scale,
        meta,
    })
}
/// Bytes of stored values decoded at a time when streaming (1 MiB, a
/// multiple of every type size).
pub(crate) const CHUNK: usize = 1 << 20;

/// Appends packed values of type `datatype` (in the given byte order) to
/// `out` as `f32`, as `value = slope * stored + inter` (computed in `f64`)
/// when `scale` is `Some((slope, inter))`. A trailing partial value is
/// ignored.
pub(crate) fn decode_into(
    raw: &[u8],
    datatype: Datatype,
    be: bool,
    scale: Option<(f64, f64)>,
    out: &mut Vec<f32>,
) {
    out.reserve(raw.len() / datatype.size());
    match (datatype, scale) {
        // Bytes need no reassembly (the common label-map case, kept cheap).
        (Datatype::Uint8, None) => out.extend(raw.iter().map(|&v| f32::from(v))),
        (Datatype::Int8, None) => out.extend(raw.iter().map(|&v| f32::from(v as i8))),
        _ => decode_multibyte(raw, datatype, be, scale, out),
    }
}

/// [`decode_into`] for every type and scaling.
fn decode_multibyte(
    raw: &[u8],
    datatype: Datatype,
    be: bool,
    scale: Option<(f64, f64)>,
    out: &mut Vec<f32>,
) {
    macro_rules! values {
        ($t:ty) => {{
            const N: usize = std::mem::size_of::<$t>();
            raw.chunks_exact(N).map(move |c| {
                let mut a = [0u8; N];
                a.copy_from_slice(c);
                if be {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            })
        }};
    }
    macro_rules! convert {
        ($t:ty) => {{
            match scale {
                Some((s, i)) => out.extend(values!($t).map(|v| (v as f64 * s + i) as f32)),
                None => out.extend(values!($t).map(|v| v as f32)),
            }
        }};
    }
    match datatype {
        Datatype::Uint8 => convert!(u8),
        Datatype::Int8 => convert!(i8),
        Datatype::Int16 => convert!(i16),
        Datatype::Uint16 => convert!(u16),
        Datatype::Int32 => convert!(i32),
        Datatype::Uint32 => convert!(u32),
        Datatype::Int64 => convert!(i64),
        Datatype::Uint64 => convert!(u64),
        Datatype::Float32 => convert!(f32),
        Datatype::Float64 => convert!(f64),
    }
}

/// Reads until `buf` is full or the stream ends; returns the bytes read.
pub(crate) fn fill(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// Reads up to `len` bytes of packed values from `r`, [`CHUNK`] bytes at a
/// time, and hands each chunk, decoded (see [`decode_into`]), to `sink`.
/// Returns the bytes read: fewer than `len` when the stream ended early.
/// Read errors are mapped by `err` (with the offset, from the first byte,
/// of the failed read).
pub(crate) fn stream_packed(
    r: &mut impl Read,
    len: u64,
    (datatype, be, scale): (Datatype, bool, Option<(f64, f64)>),
    sink: &mut dyn FnMut(&[f32]),
    err: &dyn Fn(std::io::Error, u64) -> IoError,
) -> Result<u64, IoError> {
    let mut buf = vec![0u8; len.min(CHUNK as u64) as usize];
    let mut values = Vec::new();
    let mut done = 0u64;
    while done < len {
        let want = (len - done).min(CHUNK as u64) as usize;
        let n = fill(r, &mut buf[..want]).map_err(|e| err(e, done))?;
        values.clear();
        decode_into(&buf[..n], datatype, be, scale, &mut values);
        if !values.is_empty() {
            sink(&values);
        }
        done += n as u64;
        if n < want {
            break;
        }
    }
    Ok(done)
}

fn gz_error(e: std::io::Error, at: u64) -> IoError {
    IoError::malformed(
        Location::Byte(at),
        format!("gzip decompression failed: {e}"),
    )
}

/// The error of a read failing at `at` (decompressed offset for gzip).
fn read_error(gzip: bool) -> impl Fn(std::io::Error, u64) -> IoError {
    move |e, at| {
        if gzip {
            gz_error(e, at)
        } else {
            IoError::Io {
                path: crate::FilePath::default(),
                source: e,
            }
        }
    }
}

/// Reads and checks the header: the first 348 bytes of `r`, no more.
fn read_header(r: &mut impl Read, gzip: bool) -> Result<Header, IoError> {
    let mut buf = [0u8; HEADER_LEN];
    let n = fill(r, &mut buf).map_err(|e| read_error(gzip)(e, 0))?;
    parse_header(&buf[..n])
}

/// Fails unless an uncompressed file of `len` bytes holds the data.
fn check_file_len(h: &Header, len: u64) -> Result<(), IoError> {
    if h.total()? <= len {
        return Ok(());
    }
    Err(h.short(len, false))
}

/// Fails when `compressed` gzip bytes cannot hold what the header declares
/// (checked before anything more is inflated).
fn check_gz_capacity(h: &Header, compressed: u64) -> Result<(), IoError> {
    let total = h.total()?;
    let most = compressed.saturating_mul(GZ_MAX_RATIO).saturating_add(4096);
    if total > most {
        return Err(malformed(
            0,
            format!(
                "the header declares {total} bytes, more than {compressed} compressed bytes can \
                 hold: the file is truncated or the header is wrong"
            ),
        ));
    }
    Ok(())
}

impl Header {
    fn datatype(&self) -> Datatype {
        self.meta.datatype
    }

    /// The error of a file or stream ending after `found` bytes.
    fn short(&self, found: u64, gzip: bool) -> IoError {
        let total = self.offset.saturating_add(self.data_len);
        if gzip {
            IoError::DecompressedSize {
                path: crate::FilePath::default(),
                declared: total,
                found,
            }
        } else {
            malformed(
                found,
                format!(
                    "the file ends after {found} bytes, but the header declares {} bytes of {} \
                     data for dimensions {:?} at offset {}",
                    self.data_len,
                    self.datatype().name(),
                    self.meta.dims,
                    self.offset
                ),
            )
        }
    }
}

/// Streams the values after the header (`r` is positioned at byte 348 of
/// the decompressed file), [`CHUNK`] bytes at a time, scaled, to `sink`.
/// Extensions are skipped. For gzip (`gzip`), the stream must end right after
/// the data: it is never inflated further than one byte past it
/// ([`IoError::DecompressedSize`] otherwise), and reaching its end checks its
/// CRC.
pub(crate) fn stream_values(
    h: &Header,
    r: &mut impl Read,
    gzip: bool,
    sink: &mut dyn FnMut(&[f32]),
) -> Result<(), IoError> {
    let err = read_error(gzip);
    let pos = HEADER_LEN as u64;
    let skip = h.offset - pos;
    let skipped =
        std::io::copy(&mut r.take(skip), &mut std::io::sink()).map_err(|e| err(e, pos))?;
    if skipped < skip {
        return Err(h.short(pos + skipped, gzip));
    }
    let layout = (h.datatype(), h.big_endian, h.scale);
    let at = h.offset;
    let got = stream_packed(r, h.data_len, layout, sink, &|e, n| err(e, at + n))?;
    if got < h.data_len {
        return Err(h.short(h.offset + got, gzip));
    }
    if gzip {
        let total = h.offset + h.data_len;
        let extra = fill(r, &mut [0u8; 1]).map_err(|e| err(e, total))?;
        if extra > 0 {
            return Err(IoError::DecompressedSize {
                path: crate::FilePath::default(),
                declared: total,
                found: total + 1,
            });
        }
    }
    Ok(())
}

/// Reads all values after the header into the image.
fn collect(h: Header, r: &mut impl Read, gzip: bool) -> Result<NiftiImage, IoError> {
    // The size is checked against the file (or what its gzip stream can
    // hold) before this allocation.
    let mut data = Vec::with_capacity((h.data_len / h.datatype().size() as u64) as usize);
    stream_values(&h, r, gzip, &mut |v| data.extend_from_slice(v))?;
    h.meta.into_image(data)
}

/// Parses a `.nii` or `.nii.gz` file's bytes (gzip is recognized by its magic
/// bytes `1f 8b`). See the [module documentation](self) for what is read.
pub fn read(bytes: &[u8]) -> Result<NiftiImage, IoError> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut dec = MultiGzDecoder::new(bytes);
        let h = read_header(&mut dec, true)?;
        check_gz_capacity(&h, bytes.len() as u64)?;
        collect(h, &mut dec, true)
    } else {
        let h = parse_header(bytes)?;
        check_file_len(&h, bytes.len() as u64)?;
        collect(h, &mut &bytes[HEADER_LEN..], false)
    }
}

/// An open image file, positioned after its header (decompressing when it
/// is gzip).
pub(crate) struct Opened {
    reader: Box<dyn Read>,
    gzip: bool,
}

/// Opens a `.nii` / `.nii.gz` file (gzip recognized by its magic bytes) and
/// reads and checks its header: only the first 348 (decompressed) bytes are
/// read, and the file's size is checked against the data the header declares.
pub(crate) fn open_file(path: &Path) -> Result<(Header, Opened), IoError> {
    let (file, len) = crate::format::open(path)?;
    let mut file = BufReader::new(file);
    let io = |source| IoError::Io {
        path: crate::FilePath(path.to_path_buf()),
        source,
    };
    let gzip = file.fill_buf().map_err(io)?.starts_with(&[0x1f, 0x8b]);
    let mut reader: Box<dyn Read> = if gzip {
        Box::new(flate2::bufread::MultiGzDecoder::new(file))
    } else {
        Box::new(file)
    };
    let h = read_header(&mut reader, gzip)?;
    if gzip {
        check_gz_capacity(&h, len)?;
    } else {
        check_file_len(&h, len)?;
    }
    Ok((h, Opened { reader, gzip }))
}

/// Streams the values of a `.nii` / `.nii.gz` file to `sink` (see
/// [`stream_values`]); returns its header.
pub(crate) fn stream_file(
    path: &Path,
    sink: &mut dyn FnMut(&[f32]),
) -> Result<ImageHeader, IoError> {
    let (h, mut o) = open_file(path)?;
    stream_values(&h, &mut o.reader, o.gzip, sink)?;
    Ok(h.meta)
}

/// Reads a `.nii` / `.nii.gz` file, header first, decoding the values as they
/// are read (see [`stream_values`]).
pub(crate) fn read_file(path: &Path) -> Result<NiftiImage, IoError> {
    let (h, mut o) = open_file(path)?;
    collect(h, &mut o.reader, o.gzip)
}

/// Writes header fields little-endian.
struct Out(Vec<u8>);

impl Out {
    fn i16(&mut self, off: usize, v: i16) {
        self.0[off..off + 2].copy_from_slice(&v.to_le_bytes());
    }
    fn i32(&mut self, off: usize, v: i32) {
        self.0[off..off + 4].copy_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, off: usize, v: f32) {
        self.0[off..off + 4].copy_from_slice(&v.to_le_bytes());
    }
    /// A NUL-terminated string of at most `len - 1` bytes (cut at a character
    /// boundary).
    fn text(&mut self, off: usize, len: usize, s: &str) {
        let mut end = s.len().min(len - 1);
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        self.0[off..off + end].copy_from_slice(&s.as_bytes()[..end]);
    }
}

/// An `f64` header value as `f32`, failing when it does not fit.
fn header_f32(v: f64, what: &str) -> Result<f32, IoError> {
    let x = v as f32;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(IoError::unsupported(format!(
            "{what} ({v}) does not fit in a NIfTI-1 header (f32)"
        )))
    }
}

/// The NIfTI-1 header of `img` (348 bytes + 4 zero extension bytes).
fn header_bytes(img: &NiftiImage) -> Result<Vec<u8>, IoError> {
    let vol = &img.volume;
    let dims = vol.dims();
    let a = vol.affine();
    let dt = img.write_datatype;
    let mut o = Out(vec![0u8; WRITE_VOX_OFFSET]);
    o.i32(0, HEADER_LEN as i32);
    o.0[38] = b'r'; // regular
    // Vector images: components along dim[5], dim[4] = 1.
    let vector = is_vector_intent(img.intent_code) && dims[3] > 1;
    let ndim: i16 = match (vector, dims[3] > 1) {
        (true, _) => 5,
        (false, true) => 4,
        (false, false) => 3,
    };
    o.i16(40, ndim);
    for i in 4..8 {
        o.i16(40 + 2 * i, 1);
    }
    for (i, &d) in dims.iter().enumerate() {
        let d = i16::try_from(d).map_err(|_| {
            IoError::unsupported(format!(
                "dimension {d} does not fit NIfTI-1 (at most 32767 voxels per axis)"
            ))
        })?;
        let slot = if vector && i == 3 { 4 } else { i };
        o.i16(42 + 2 * slot, d);
    }
    for (i, &p) in img.intent_params.iter().enumerate() {
        o.f32(56 + 4 * i, p);
    }
    o.i16(68, img.intent_code);
    o.i16(70, dt.code());
    o.i16(72, (8 * dt.size()) as i16);

    // pixdim: qfac, column norms, time step, then 1.
    let qform = qform_params(a);
    let m3 = a.fixed_view::<3, 3>(0, 0).into_owned();
    let qfac = match qform {
        Some((_, qfac)) => qfac,
        None if m3.determinant() < 0.0 => -1.0,
        None => 1.0,
    };
    o.f32(76, qfac as f32);
    for j in 0..3 {
        let n = Vector3::new(a[(0, j)], a[(1, j)], a[(2, j)]).norm();
        o.f32(80 + 4 * j, header_f32(n, "a voxel size")?);
    }
    o.f32(92, if ndim == 4 { img.time_step } else { 1.0 });
    for i in 5..8 {
        o.f32(76 + 4 * i, 1.0);
    }
    o.f32(108, WRITE_VOX_OFFSET as f32);
    o.f32(112, 1.0);
    o.f32(116, 0.0);
    let time_units = if ndim == 4 {
        match img.xyzt_units & 0x38 {
            0 => UNITS_SEC,
            t => t,
        }
    } else {
        0
    };
    o.0[123] = UNITS_MM | time_units;
    o.text(148, 80, &img.description);

    let sform_code = if img.sform_code > 0 {
        img.sform_code
    } else {
        2
    };
    let qform_code = match qform {
        None => 0,
        Some(_) if img.qform_code > 0 => img.qform_code,
        Some(_) => sform_code,
    };
    o.i16(252, qform_code);
    o.i16(254, sform_code);
    if let Some((quat, _)) = qform {
        for (i, &q) in quat.iter().enumerate() {
            o.f32(256 + 4 * i, q as f32);
        }
    }
    for r in 0..3 {
        o.f32(268 + 4 * r, header_f32(a[(r, 3)], "an affine entry")?);
        for c in 0..4 {
            o.f32(
                280 + 16 * r + 4 * c,
                header_f32(a[(r, c)], "an affine entry")?,
            );
        }
    }
    o.text(328, 16, &img.intent_name);
    o.0[344..348].copy_from_slice(b"n+1\0");
    Ok(o.0)
}

/// Appends the values as `dt`, little-endian. Integers: rounded half away
/// from zero, clamped to the type's range, NaN as 0 (Rust's saturating `as`).
pub(crate) fn encode(values: &[f32], dt: Datatype, out: &mut Vec<u8>) {
    macro_rules! put {
        ($t:ty, $conv:expr) => {{
            let conv = $conv;
            for &v in values {
                let x: $t = conv(v);
                out.extend_from_slice(&x.to_le_bytes());
            }
        }};
    }
    let round = |v: f32| f64::from(v).round();
    match dt {
        Datatype::Uint8 => put!(u8, |v| round(v) as u8),
        Datatype::Int8 => put!(i8, |v| round(v) as i8),
        Datatype::Int16 => put!(i16, |v| round(v) as i16),
        Datatype::Uint16 => put!(u16, |v| round(v) as u16),
        Datatype::Int32 => put!(i32, |v| round(v) as i32),
        Datatype::Uint32 => put!(u32, |v| round(v) as u32),
        Datatype::Int64 => put!(i64, |v| round(v) as i64),
        Datatype::Uint64 => put!(u64, |v| round(v) as u64),
        Datatype::Float32 => put!(f32, |v| v),
        Datatype::Float64 => put!(f64, f64::from),
    }
}

/// Serializes an image as NIfTI-1 single file, gzip-compressed when `gzip`.
/// See the [module documentation](self) for the header written.
pub fn write(img: &NiftiImage, gzip: bool) -> Result<Vec<u8>, IoError> {
    let mut bytes = header_bytes(img)?;
    let data = img.volume.data();
    bytes.reserve(data.len().saturating_mul(img.write_datatype.size()));
    encode(data, img.write_datatype, &mut bytes);
    if !gzip {
        return Ok(bytes);
    }
    let io = |source| IoError::Io {
        path: crate::FilePath::default(),
        source,
    };
    let mut enc = GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(&bytes).map_err(io)?;
    enc.finish().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use proptest::prelude::*;

    /// A hand-built NIfTI-1 header in either byte order (independent of the
    /// writer above).
    struct Raw {
        b: Vec<u8>,
        be: bool,
    }

    impl Raw {
        fn new(be: bool, dims: &[i16], datatype: i16, bitpix: i16) -> Raw {
            let mut r = Raw {
                b: vec![0u8; 352],
                be,
            };
            r.i32(0, 348);
            r.i16(40, dims.len() as i16);
            for (i, &d) in dims.iter().enumerate() {
                r.i16(42 + 2 * i, d);
            }
            r.i16(70, datatype);
            r.i16(72, bitpix);
            for i in 0..8 {
                r.f32(76 + 4 * i, 1.0);
            }
            r.f32(108, 352.0);
            r.b[344..348].copy_from_slice(b"n+1\0");
            r
        }
        fn put(&mut self, off: usize, mut le: Vec<u8>) {
            if self.be {
                le.reverse();
            }
            self.b[off..off + le.len()].copy_from_slice(&le);
        }
        fn i16(&mut self, off: usize, v: i16) {
            self.put(off, v.to_le_bytes().to_vec());
        }
        fn i32(&mut self, off: usize, v: i32) {
            self.put(off, v.to_le_bytes().to_vec());
        }
        fn f32(&mut self, off: usize, v: f32) {
            self.put(off, v.to_le_bytes().to_vec());
        }
        fn sform(&mut self, code: i16, rows: [[f32; 4]; 3]) {
            self.i16(254, code);
            for (r, row) in rows.iter().enumerate() {
                for (c, &v) in row.iter().enumerate() {
                    self.f32(280 + 16 * r + 4 * c, v);
                }
            }
        }
        fn qform(&mut self, code: i16, quat: [f32; 3], offset: [f32; 3], pixdim: [f32; 4]) {
            self.i16(252, code);
            for i in 0..3 {
                self.f32(256 + 4 * i, quat[i]);
                self.f32(268 + 4 * i, offset[i]);
            }
            for (i, &p) in pixdim.iter().enumerate() {
                self.f32(76 + 4 * i, p);
            }
        }
        fn with_data(mut self, data: &[u8]) -> Vec<u8> {
            self.b.extend_from_slice(data);
            self.b
        }
    }

    /// `values` stored as `dt` in byte order `be`.
    fn raw_values(dt: Datatype, values: &[f64], be: bool) -> Vec<u8> {
        let mut out = Vec::new();
        for &v in values {
            let mut b = match dt {
                Datatype::Uint8 => (v as u8).to_le_bytes().to_vec(),
                Datatype::Int8 => (v as i8).to_le_bytes().to_vec(),
                Datatype::Int16 => (v as i16).to_le_bytes().to_vec(),
                Datatype::Uint16 => (v as u16).to_le_bytes().to_vec(),
                Datatype::Int32 => (v as i32).to_le_bytes().to_vec(),
                Datatype::Uint32 => (v as u32).to_le_bytes().to_vec(),
                Datatype::Int64 => (v as i64).to_le_bytes().to_vec(),
                Datatype::Uint64 => (v as u64).to_le_bytes().to_vec(),
                Datatype::Float32 => (v as f32).to_le_bytes().to_vec(),
                Datatype::Float64 => v.to_le_bytes().to_vec(),
            };
            if be {
                b.reverse();
            }
            out.extend_from_slice(&b);
        }
        out
    }

    /// Eight values that `dt` holds exactly, including its extremes.
    fn sample_values(dt: Datatype) -> Vec<f64> {
        match dt {
            Datatype::Uint8 => vec![0.0, 1.0, 2.0, 17.0, 100.0, 128.0, 200.0, 255.0],
            Datatype::Int8 => vec![-128.0, -5.0, -1.0, 0.0, 1.0, 7.0, 100.0, 127.0],
            Datatype::Int16 => vec![-32768.0, -300.0, -1.0, 0.0, 1.0, 256.0, 1000.0, 32767.0],
            Datatype::Uint16 => vec![0.0, 1.0, 255.0, 256.0, 1000.0, 30000.0, 40000.0, 65535.0],
            Datatype::Int32 => vec![
                -2147483648.0,
                -70000.0,
                -1.0,
                0.0,
                1.0,
                65536.0,
                1e6,
                2147483647.0,
            ],
            Datatype::Uint32 => vec![0.0, 1.0, 65535.0, 65536.0, 1e6, 3e9, 4e9, 4294967295.0],
            Datatype::Int64 => vec![-9.0e18, -1e12, -1.0, 0.0, 1.0, 1e10, 1e15, 9.0e18],
            Datatype::Uint64 => vec![0.0, 1.0, 2.0, 1e10, 1e15, 1e18, 1e19, 1.8e19],
            Datatype::Float32 => vec![-1.5e30, -2.25, -0.0, 0.0, 0.5, 3.25, 1e-20, 3.0e38],
            Datatype::Float64 => vec![-1.5e30, -2.25, -0.0, 0.0, 0.5, 3.25, 1e-20, 1.0e38],
        }
    }

    fn assert_affine_eq(a: &Matrix4<f64>, b: &Matrix4<f64>, tol: f64) {
        let scale = a.abs().max().max(1.0);
        let err = (a - b).abs().max();
        assert!(err <= tol * scale, "affines differ by {err}:\n{a}\n{b}");
    }

    #[test]
    fn every_datatype_both_byte_orders_with_and_without_scaling() {
        for dt in Datatype::ALL {
            for be in [false, true] {
                for (slope, inter) in [(0.0f32, 5.0f32), (1.0, 0.0), (2.5, -1.0), (-0.5, 3.0)] {
                    let vals = sample_values(dt);
                    let mut r = Raw::new(be, &[2, 2, 2], dt.code(), 8 * dt.size() as i16);
                    r.f32(112, slope);
                    r.f32(116, inter);
                    let img = read(&r.with_data(&raw_values(dt, &vals, be))).unwrap();
                    assert_eq!(img.datatype, dt);
                    assert_eq!(img.write_datatype, Datatype::Float32);
                    assert_eq!(img.scl_slope, slope);
                    assert_eq!(img.scl_inter, inter);
                    assert_eq!(img.volume.dims(), [2, 2, 2, 1]);
                    // Values as the file stores them (f64 holds every sample).
                    let stored: Vec<f64> = match dt {
                        Datatype::Float32 => vals.iter().map(|&v| f64::from(v as f32)).collect(),
                        Datatype::Int64 => vals.iter().map(|&v| v as i64 as f64).collect(),
                        Datatype::Uint64 => vals.iter().map(|&v| v as u64 as f64).collect(),
                        _ => vals.clone(),
                    };
                    let want: Vec<f32> = stored
                        .iter()
                        .map(|&v| {
                            if slope == 0.0 {
                                v as f32
                            } else {
                                (v * f64::from(slope) + f64::from(inter)) as f32
                            }
                        })
                        .collect();
                    assert_eq!(img.volume.data(), &want[..], "{dt:?} be={be} slope={slope}");
                }
            }
        }
    }

    #[test]
    fn big_endian_int16_file() {
        let mut r = Raw::new(true, &[3, 2, 1], 4, 16);
        r.sform(
            1,
            [
                [2.0, 0.0, 0.0, -10.0],
                [0.0, 3.0, 0.0, 5.0],
                [0.0, 0.0, 4.0, 7.5],
            ],
        );
        r.f32(112, 0.5);
        r.f32(116, 10.0);
        r.b[123] = 2;
        r.b[148..152].copy_from_slice(b"abc\0");
        let mut data = Vec::new();
        for v in [-4i16, -2, 0, 2, 4, 1000] {
            data.extend_from_slice(&v.to_be_bytes());
        }
        let img = read(&r.with_data(&data)).unwrap();
        assert_eq!(img.volume.data(), &[8.0, 9.0, 10.0, 11.0, 12.0, 510.0]);
        assert_eq!(img.volume.dims(), [3, 2, 1, 1]);
        assert_eq!(img.affine_source, AffineSource::Sform);
        assert_eq!(img.sform_code, 1);
        assert_eq!(img.description, "abc");
        assert_eq!(img.xyzt_units, 2);
        let mut want = Matrix4::identity();
        want[(0, 0)] = 2.0;
        want[(1, 1)] = 3.0;
        want[(2, 2)] = 4.0;
        want[(0, 3)] = -10.0;
        want[(1, 3)] = 5.0;
        want[(2, 3)] = 7.5;
        assert_eq!(img.volume.affine(), &want);
    }

    #[test]
    fn qform_only_matches_hand_formula() {
        // 90° about z: (b, c, d) = (0, 0, sin 45°), a = cos 45°, so
        // R = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]; qfac = -1 flips the k column.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let mut r = Raw::new(false, &[2, 2, 2], 16, 32);
        r.qform(1, [0.0, 0.0, h], [10.0, 20.0, 30.0], [-1.0, 2.0, 3.0, 4.0]);
        let img = read(&r.with_data(&[0u8; 32])).unwrap();
        assert_eq!(img.affine_source, AffineSource::Qform);
        #[rustfmt::skip]
        let want = Matrix4::new(
            0.0, -3.0, 0.0, 10.0,
            2.0, 0.0, 0.0, 20.0,
            0.0, 0.0, -4.0, 30.0,
            0.0, 0.0, 0.0, 1.0,
        );
        assert_affine_eq(img.volume.affine(), &want, 1e-6);

        // A general quaternion, written out with the standard's formula; qfac
        // 0 counts as +1.
        let (b, c, d) = (0.1f64, 0.2f64, 0.3f64);
        let a = (1.0 - b * b - c * c - d * d).sqrt();
        let (dx, dy, dz) = (1.5, 0.75, 2.0);
        let mut r = Raw::new(false, &[2, 2, 2], 16, 32);
        r.qform(2, [0.1, 0.2, 0.3], [-1.0, 0.5, 4.0], [0.0, 1.5, 0.75, 2.0]);
        let img = read(&r.with_data(&[0u8; 32])).unwrap();
        #[rustfmt::skip]
        let want = Matrix4::new(
            (a * a + b * b - c * c - d * d) * dx, 2.0 * (b * c - a * d) * dy, 2.0 * (b * d + a * c) * dz, -1.0,
            2.0 * (b * c + a * d) * dx, (a * a + c * c - b * b - d * d) * dy, 2.0 * (c * d - a * b) * dz, 0.5,
            2.0 * (b * d - a * c) * dx, 2.0 * (c * d + a * b) * dy, (a * a + d * d - c * c - b * b) * dz, 4.0,
            0.0, 0.0, 0.0, 1.0,
        );
        assert_affine_eq(img.volume.affine(), &want, 1e-6);
        assert_eq!(img.qform_code, 2);
        assert_eq!(img.sform_code, 0);
    }

    #[test]
    fn sform_has_priority_over_qform() {
        let mut r = Raw::new(false, &[2, 2, 2], 16, 32);
        r.qform(1, [0.0, 0.0, 1.0], [1.0, 2.0, 3.0], [1.0, 9.0, 9.0, 9.0]);
        r.sform(
            4,
            [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
        );
        let img = read(&r.with_data(&[0u8; 32])).unwrap();
        assert_eq!(img.affine_source, AffineSource::Sform);
        assert_eq!(img.volume.affine(), &Matrix4::identity());
        assert_eq!((img.sform_code, img.qform_code), (4, 1));
    }

    #[test]
    fn analyze_fallback_uses_pixdim() {
        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.f32(80, 0.5);
        r.f32(84, 2.0);
        r.f32(88, 3.0);
        // The sform rows are ignored when sform_code is 0.
        r.sform(
            0,
            [
                [7.0, 0.0, 0.0, 1.0],
                [0.0, 7.0, 0.0, 1.0],
                [0.0, 0.0, 7.0, 1.0],
            ],
        );
        let img = read(&r.with_data(&[1u8; 8])).unwrap();
        assert_eq!(img.affine_source, AffineSource::Analyze);
        let want = Matrix4::from_diagonal(&nalgebra::Vector4::new(0.5, 2.0, 3.0, 1.0));
        assert_eq!(img.volume.affine(), &want);
        assert_eq!(img.volume.data(), &[1.0; 8]);
    }

    #[test]
    fn unsupported_variants_are_named() {
        let msg = |b: Vec<u8>| read(&b).unwrap_err().to_string();

        let mut r = Raw::new(false, &[2, 2, 2], 16, 32);
        r.b[344..348].copy_from_slice(b"ni1\0");
        assert!(msg(r.with_data(&[0; 32])).contains("pairs"));

        for be in [false, true] {
            let mut r = Raw::new(be, &[2, 2, 2], 16, 32);
            r.i32(0, 540);
            assert!(msg(r.with_data(&[0; 32])).contains("NIfTI-2"));
        }

        for (code, name) in [(32, "COMPLEX64"), (128, "RGB24"), (2304, "RGBA32")] {
            let r = Raw::new(false, &[2, 2, 2], code, 64);
            let m = msg(r.with_data(&[0; 512]));
            assert!(m.contains(&code.to_string()) && m.contains(name), "{m}");
        }
        let r = Raw::new(false, &[2, 2, 2], 99, 8);
        assert!(msg(r.with_data(&[0; 64])).contains("99"));

        let r = Raw::new(false, &[2, 2, 2, 1, 2], 2, 8);
        assert!(msg(r.with_data(&[0; 16])).contains("dim[5]"));

        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.b[344..348].copy_from_slice(b"\0\0\0\0");
        assert!(msg(r.with_data(&[0; 8])).contains("ANALYZE"));
    }

    #[test]
    fn unit_trailing_dims_and_short_dims_are_read() {
        let r = Raw::new(false, &[2, 1, 2, 3, 1, 1], 2, 8);
        let img = read(&r.with_data(&[5u8; 12])).unwrap();
        assert_eq!(img.volume.dims(), [2, 1, 2, 3]);
        let r = Raw::new(false, &[4, 3], 2, 8);
        let img = read(&r.with_data(&[5u8; 12])).unwrap();
        assert_eq!(img.volume.dims(), [4, 3, 1, 1]);
    }

    #[test]
    fn malformed_headers_are_reported_at_their_field() {
        let at = |b: Vec<u8>| match read(&b).unwrap_err() {
            IoError::Malformed { location, .. } => location,
            e => panic!("{e}"),
        };
        assert_eq!(at(vec![0u8; 10]), Location::Byte(10));
        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.i16(40, 0);
        assert_eq!(at(r.with_data(&[0; 8])), Location::Byte(40));
        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.i16(40, 8);
        assert_eq!(at(r.with_data(&[0; 8])), Location::Byte(40));
        let r = Raw::new(false, &[2, -2, 2], 2, 8);
        assert_eq!(at(r.with_data(&[0; 8])), Location::Byte(44));
        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.f32(108, 100.0);
        assert_eq!(at(r.with_data(&[0; 8])), Location::Byte(108));
        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.f32(108, f32::NAN);
        assert_eq!(at(r.with_data(&[0; 8])), Location::Byte(108));
        let r = Raw::new(false, &[2, 2, 2], 2, 8);
        assert_eq!(at(r.with_data(&[0; 7])), Location::Byte(359));
        // Huge dimensions fail on size, before anything is allocated.
        let r = Raw::new(false, &[32767, 32767, 32767, 32767, 1, 1, 1], 64, 64);
        assert!(read(&r.with_data(&[0; 8])).is_err());
        // A sform that is singular.
        let mut r = Raw::new(false, &[2, 2, 2], 2, 8);
        r.sform(2, [[0.0; 4]; 3]);
        assert!(matches!(
            read(&r.with_data(&[0; 8])),
            Err(IoError::Mesh { .. })
        ));
    }

    #[test]
    fn vox_offset_zero_and_extensions_and_trailing_bytes() {
        let mut r = Raw::new(false, &[2, 1, 1], 2, 8);
        r.f32(108, 0.0);
        assert_eq!(
            read(&r.with_data(&[3, 4])).unwrap().volume.data(),
            &[3.0, 4.0]
        );
        // Data after 16 bytes of (ignored) extension, then trailing bytes.
        let mut r = Raw::new(false, &[2, 1, 1], 2, 8);
        r.f32(108, 368.0);
        r.b[348] = 1;
        let mut payload = vec![9u8; 16];
        payload.extend_from_slice(&[3, 4, 99, 99]);
        assert_eq!(
            read(&r.with_data(&payload)).unwrap().volume.data(),
            &[3.0, 4.0]
        );
    }

    fn gz(bytes: &[u8]) -> Vec<u8> {
        let mut e = GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn gzip_guards() {
        let r = Raw::new(false, &[2, 1, 1], 2, 8);
        let file = r.with_data(&[3, 4]);
        assert_eq!(read(&gz(&file)).unwrap().volume.data(), &[3.0, 4.0]);

        // Two concatenated members.
        let mut two = gz(&file[..200]);
        two.extend_from_slice(&gz(&file[200..]));
        assert_eq!(read(&two).unwrap().volume.data(), &[3.0, 4.0]);

        // A stream holding more or less than the header declares (354
        // bytes) is refused with both sizes; more is inflated one byte past.
        let mut padded = file.clone();
        padded.extend_from_slice(&[0u8; 1000]);
        assert!(matches!(
            read(&gz(&padded)),
            Err(IoError::DecompressedSize {
                declared: 354,
                found: 355,
                ..
            })
        ));
        let e = read(&gz(&file[..353])).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::DecompressedSize {
                    declared: 354,
                    found: 353,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("only 353 bytes"), "{e}");
        // Extensions cut short count as well.
        let mut r = Raw::new(false, &[2, 1, 1], 2, 8);
        r.f32(108, 400.0);
        let e = read(&gz(&r.with_data(&[0; 10]))).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::DecompressedSize {
                    declared: 402,
                    found: 362,
                    ..
                }
            ),
            "{e}"
        );

        // A header declaring far more than the stream can hold fails before
        // decompressing.
        let r = Raw::new(false, &[2000, 2000, 2000], 64, 64);
        let e = read(&gz(&r.with_data(&[0; 64]))).unwrap_err();
        assert!(e.to_string().contains("compressed bytes can hold"), "{e}");

        // A corrupted CRC.
        let mut bad = gz(&file);
        let n = bad.len();
        bad[n - 6] ^= 0xff;
        assert!(read(&bad).is_err());
    }

    fn test_image(dims: [usize; 4], affine: Matrix4<f64>) -> NiftiImage {
        let n: usize = dims.iter().product();
        let data = (0..n).map(|i| i as f32 * 0.25 - 3.0).collect();
        NiftiImage::new(Volume::new(dims, affine, data).unwrap())
    }

    #[test]
    fn written_header_fields() {
        let mut a = Matrix4::identity();
        a[(0, 0)] = -2.0; // a reflection: qfac -1
        a[(1, 1)] = 3.0;
        a[(2, 2)] = 0.5;
        a[(0, 3)] = 7.0;
        let mut img = test_image([2, 3, 4, 5], a);
        img.description = "é".repeat(60);
        img.intent_name = "labels".into();
        img.intent_code = 1002;
        img.intent_params = [1.0, 2.0, 3.0];
        img.time_step = 2.5;
        let b = write(&img, false).unwrap();
        assert_eq!(b.len(), 352 + 4 * 120);
        let f = Fields {
            b: &b,
            big_endian: false,
        };
        assert_eq!(f.i32(0), 348);
        assert_eq!(&b[344..348], b"n+1\0");
        assert_eq!(f.f32(108), 352.0);
        assert_eq!(
            (0..5).map(|i| f.i16(40 + 2 * i)).collect::<Vec<_>>(),
            [4, 2, 3, 4, 5]
        );
        assert_eq!((f.i16(70), f.i16(72)), (16, 32));
        assert_eq!(
            (0..5).map(|i| f.f32(76 + 4 * i)).collect::<Vec<_>>(),
            [-1.0, 2.0, 3.0, 0.5, 2.5]
        );
        assert_eq!((f.f32(112), f.f32(116)), (1.0, 0.0));
        assert_eq!(b[123], UNITS_MM | UNITS_SEC);
        assert_eq!((f.i16(252), f.i16(254)), (2, 2));
        assert_eq!(f.text(148, 80).len(), 78); // 39 two-byte characters
        let back = read(&b).unwrap();
        assert_eq!(back.description, "é".repeat(39));
        assert_eq!(back.intent_name, "labels");
        assert_eq!(back.intent_code, 1002);
        assert_eq!(back.intent_params, [1.0, 2.0, 3.0]);
        assert_eq!(back.time_step, 2.5);
        assert_eq!(back.volume, img.volume);

        let b3 = write(&test_image([2, 2, 2, 1], a), false).unwrap();
        assert_eq!(b3[123], UNITS_MM);
        assert_eq!(i16::from_le_bytes([b3[40], b3[41]]), 3);
    }

    #[test]
    fn vector_images_keep_their_components_on_dim5() {
        let a = Matrix4::new_scaling(2.0);
        let mut img = test_image([2, 3, 4, 3], a);
        img.intent_code = INTENT_VECTOR;
        let b = write(&img, false).unwrap();
        let dim = |i: usize| i16::from_le_bytes([b[40 + 2 * i], b[41 + 2 * i]]);
        assert_eq!(
            (0..8).map(dim).collect::<Vec<_>>(),
            [5, 2, 3, 4, 1, 3, 1, 1]
        );
        assert_eq!(b[123], UNITS_MM);
        let back = read(&b).unwrap();
        assert_eq!(back.intent_code, INTENT_VECTOR);
        assert_eq!(back.volume, img.volume);
        // A 5D image of another intent is refused, saying which are read.
        let mut other = b.clone();
        other[68..70].copy_from_slice(&0i16.to_le_bytes());
        let e = read(&other).unwrap_err().to_string();
        assert!(e.contains("dim[5] = 3") && e.contains("1007"), "{e}");
    }

    #[test]
    fn integer_datatypes_round_and_clamp() {
        let vals = vec![-1.5f32, 0.4, 0.5, 2.5, 300.0, f32::NAN, -300.0, 1e30];
        let vol = Volume::new([8, 1, 1, 1], Matrix4::identity(), vals).unwrap();
        let cases: [(Datatype, [f32; 8]); 4] = [
            (
                Datatype::Uint8,
                [0.0, 0.0, 1.0, 3.0, 255.0, 0.0, 0.0, 255.0],
            ),
            (
                Datatype::Int8,
                [-2.0, 0.0, 1.0, 3.0, 127.0, 0.0, -128.0, 127.0],
            ),
            (
                Datatype::Int16,
                [-2.0, 0.0, 1.0, 3.0, 300.0, 0.0, -300.0, 32767.0],
            ),
            (
                Datatype::Uint16,
                [0.0, 0.0, 1.0, 3.0, 300.0, 0.0, 0.0, 65535.0],
            ),
        ];
        for (dt, want) in cases {
            let img = NiftiImage::new(vol.clone()).with_datatype(dt);
            for gzip in [false, true] {
                let back = read(&write(&img, gzip).unwrap()).unwrap();
                assert_eq!(back.datatype, dt);
                assert_eq!(back.volume.data(), &want, "{dt:?}");
            }
        }
        for dt in Datatype::ALL {
            let ints =
                Volume::new([3, 1, 1, 1], Matrix4::identity(), vec![0.0f32, 1.0, 100.0]).unwrap();
            let img = NiftiImage::from(ints.clone()).with_datatype(dt);
            let back = read(&write(&img, false).unwrap()).unwrap();
            assert_eq!(back.volume, ints, "{dt:?}");
        }
    }

    #[test]
    fn too_large_dimension_is_unsupported_on_write() {
        let img = test_image([32768, 1, 1, 1], Matrix4::identity());
        assert!(matches!(
            write(&img, false),
            Err(IoError::Unsupported { .. })
        ));
    }

    #[test]
    fn sheared_affine_has_no_qform() {
        let mut a = Matrix4::identity();
        a[(0, 1)] = 0.25;
        let b = write(&test_image([2, 2, 2, 1], a), false).unwrap();
        assert_eq!(i16::from_le_bytes([b[252], b[253]]), 0);
        assert_eq!(read(&b).unwrap().volume.affine(), &a);
    }

    #[test]
    fn qform_near_half_turn() {
        // Near 180° a = sqrt(1 - b² - c² - d²) is poorly determined by f32
        // (b, c, d): the qform is still close, the sform is exact to f32.
        for angle in [std::f64::consts::PI, 3.1, 3.0] {
            let axis = Vector3::new(0.3, -0.5, 0.8).normalize() * angle;
            let r = Rotation3::from_scaled_axis(axis);
            let mut a = Matrix4::identity();
            a.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(r.matrix() * 2.0));
            a[(0, 3)] = 5.0;
            let mut b = write(&test_image([2, 2, 2, 1], a), false).unwrap();
            assert_affine_eq(read(&b).unwrap().volume.affine(), &a, 1e-6);
            b[254] = 0;
            let q = read(&b).unwrap();
            assert_eq!(q.affine_source, AffineSource::Qform);
            assert_affine_eq(q.volume.affine(), &a, 1e-3);
        }
    }

    /// Rotation (by a scaled axis) × positive scaling, optionally a
    /// reflection, plus a translation.
    fn rigid_affine() -> impl Strategy<Value = Matrix4<f64>> {
        (
            prop::array::uniform3(-4.0..4.0f64),
            prop::array::uniform3(0.1..5.0f64),
            any::<bool>(),
            prop::array::uniform3(-200.0..200.0f64),
        )
            .prop_map(|(axis, s, reflect, t)| {
                let r = Rotation3::from_scaled_axis(Vector3::from(axis));
                let mut m = Matrix4::identity();
                let sign = if reflect { -1.0 } else { 1.0 };
                let s = [s[0], s[1], sign * s[2]];
                for i in 0..3 {
                    for j in 0..3 {
                        m[(i, j)] = r[(i, j)] * s[j];
                    }
                    m[(i, 3)] = t[i];
                }
                m
            })
    }

    /// A general (sheared, non-orthogonal) invertible affine.
    fn general_affine() -> impl Strategy<Value = Matrix4<f64>> {
        (
            prop::array::uniform9(-5.0..5.0f64),
            prop::array::uniform3(-200.0..200.0f64),
        )
            .prop_filter_map("near-singular", |(m, t)| {
                let mut a = Matrix4::identity();
                for i in 0..3 {
                    for j in 0..3 {
                        a[(i, j)] = m[3 * i + j];
                    }
                    a[(i, 3)] = t[i];
                }
                (a.fixed_view::<3, 3>(0, 0).determinant().abs() > 0.5).then_some(a)
            })
    }

    fn dims() -> impl Strategy<Value = [usize; 4]> {
        (1..5usize, 1..5usize, 1..5usize, 1..4usize).prop_map(|(a, b, c, d)| [a, b, c, d])
    }

    fn image(affine: impl Strategy<Value = Matrix4<f64>>) -> impl Strategy<Value = NiftiImage> {
        (dims(), affine).prop_flat_map(|(d, a)| {
            let n = d.iter().product::<usize>();
            prop::collection::vec(any::<f32>(), n)
                .prop_map(move |data| NiftiImage::new(Volume::new(d, a, data).unwrap()))
        })
    }

    fn check_round_trip(img: &NiftiImage, gzip: bool) -> Result<(), TestCaseError> {
        let bytes = write(img, gzip).unwrap();
        prop_assert_eq!(bytes.starts_with(&[0x1f, 0x8b]), gzip);
        let back = read(&bytes).unwrap();
        prop_assert_eq!(back.volume.dims(), img.volume.dims());
        prop_assert_eq!(back.affine_source, AffineSource::Sform);
        assert_affine_eq(back.volume.affine(), img.volume.affine(), 1e-6);
        let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(bits(back.volume.data()), bits(img.volume.data()));
        Ok(())
    }

    proptest! {
        #[test]
        fn round_trip_rigid(img in image(rigid_affine()), gzip in any::<bool>()) {
            check_round_trip(&img, gzip)?;
            // The qform alone gives the same affine (f32 quaternion precision).
            let mut bytes = write(&img, false).unwrap();
            prop_assert!(i16::from_le_bytes([bytes[252], bytes[253]]) > 0);
            bytes[254] = 0;
            bytes[255] = 0;
            let back = read(&bytes).unwrap();
            prop_assert_eq!(back.affine_source, AffineSource::Qform);
            // a = sqrt(1 - b² - c² - d²) from f32 (b, c, d) is only good to
            // about sqrt(f32 eps) for rotations near 180°: an inherent limit of
            // the qform, hence the looser tolerance on the 3x3 columns.
            let (a, b) = (img.volume.affine(), back.volume.affine());
            for j in 0..3 {
                let (ca, cb) = (a.fixed_view::<3, 1>(0, j), b.fixed_view::<3, 1>(0, j));
                prop_assert!((ca - cb).norm() <= 1e-3 * ca.norm(), "column {}:{}{}", j, a, b);
            }
            let (ta, tb) = (a.fixed_view::<3, 1>(0, 3), b.fixed_view::<3, 1>(0, 3));
            prop_assert!((ta - tb).norm() <= 1e-6 * ta.norm().max(1.0), "{}{}", a, b);
        }

        #[test]
        fn round_trip_general(img in image(general_affine()), gzip in any::<bool>()) {
            check_round_trip(&img, gzip)?;
        }

        #[test]
        fn random_bytes_never_panic(
            mut bytes in prop::collection::vec(any::<u8>(), 0..1200),
            prefix in 0..3usize,
        ) {
            // Also random bytes that start like gzip, and a valid gzip of them.
            match prefix {
                0 => {}
                1 => bytes.splice(0..0, [0x1f, 0x8b]).for_each(drop),
                _ => bytes = gz(&bytes),
            }
            prop_assert!(read(&bytes).is_err());
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn every_truncation_is_an_error(img in image(rigid_affine()), gzip in any::<bool>()) {
            let bytes = write(&img, gzip).unwrap();
            for n in 0..bytes.len() {
                prop_assert!(read(&bytes[..n]).is_err(), "prefix of {} bytes read", n);
            }
        }
    }

    proptest! {
        #[test]
        fn header_corruptions_never_panic(
            img in image(general_affine()),
            dims in prop::array::uniform8(any::<i16>()),
            small_dims in prop::array::uniform8(-2..40i16),
            datatype in prop_oneof![any::<i16>(), prop::sample::select(
                vec![0i16, 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 768, 1024, 1280, 1536, 2304])],
            vox_offset in prop_oneof![any::<f32>(), 0.0..2000.0f32, Just(352.0f32), Just(0.0f32)],
            which in 0..8u8,
            pokes in prop::collection::vec((0..352usize, any::<u8>()), 0..4),
            gzip in any::<bool>(),
        ) {
            let mut b = write(&img, false).unwrap();
            let mut put = |off: usize, v: &[u8]| b[off..off + v.len()].copy_from_slice(v);
            if which & 1 != 0 {
                let d = if which & 4 != 0 { dims } else { small_dims };
                for (i, x) in d.iter().enumerate() {
                    put(40 + 2 * i, &x.to_le_bytes());
                }
            }
            if which & 2 != 0 {
                put(70, &datatype.to_le_bytes());
            }
            if which & 4 != 0 {
                put(108, &vox_offset.to_le_bytes());
            }
            for (off, v) in pokes {
                b[off] = v;
            }
            let b = if gzip { gz(&b) } else { b };
            let _ = read(&b);
        }
    }
}
