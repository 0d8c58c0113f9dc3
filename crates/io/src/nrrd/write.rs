//! Writing a NRRD file (attached header, gzip data).

use super::header::type_name;
use crate::nifti::encode;
use crate::{IoError, NiftiImage};
use flate2::write::GzEncoder;
use std::fmt::Write as _;
use std::io::Write;

/// A vector as NRRD writes it, `(x,y,z)`, each number in Rust's shortest
/// representation that parses back to the same `f64` (`-0` as `0.0`).
fn vector(v: [f64; 3]) -> String {
    let z = |x: f64| if x == 0.0 { 0.0 } else { x };
    format!("({:?},{:?},{:?})", z(v[0]), z(v[1]), z(v[2]))
}

/// Serializes an image as a NRRD file with an attached header:
///
/// ```text
/// NRRD0004
/// type: <NiftiImage::write_datatype>   (int8 ... uint64, float, double)
/// dimension: 3                          (4 for several frames)
/// space: left-posterior-superior
/// sizes: nx ny nz                       (nt nx ny nz)
/// space directions: (d_i) (d_j) (d_k)   (none (d_i) (d_j) (d_k))
/// kinds: domain domain domain           (list domain domain domain)
/// endian: little
/// encoding: gzip
/// space origin: (o)
/// content: <NiftiImage::description>   (when not empty)
/// ```
///
/// The directions and origin are the affine's columns converted from RAS to
/// LPS, `A_lps = diag(-1, -1, 1, 1) · A_ras` (exact: only signs change),
/// printed so that they parse back to the same `f64`. A 4D image is written
/// as Slicer and ITK store a series: the frame axis first (fastest, kind
/// `list`, direction `none`), so values are interleaved, `t + nt (i + nx (j +
/// ny k))`. The time step is not written (NRRD has no field for the step of
/// a `list` axis). Values are stored as in NIfTI (integers rounded and
/// clamped, see [`NiftiImage::with_datatype`]).
pub fn write(img: &NiftiImage) -> Result<Vec<u8>, IoError> {
    let vol = &img.volume;
    let [nx, ny, nz, nt] = vol.dims();
    let a = vol.affine();
    let lps = |r: usize, c: usize| if r < 2 { -a[(r, c)] } else { a[(r, c)] };
    let col = |c: usize| vector([lps(0, c), lps(1, c), lps(2, c)]);
    let four = nt > 1;
    let mut h = String::from(
        "NRRD0004\n# Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n",
    );
    // Writing to a String cannot fail.
    let _ = writeln!(h, "type: {}", type_name(img.write_datatype));
    let _ = writeln!(h, "dimension: {}", if four { 4 } else { 3 });
    h.push_str("space: left-posterior-superior\n");
    let (sizes, none, kinds) = if four {
        (format!("{nt} {nx} {ny} {nz}"), "none ", "list ")
    } else {
        (format!("{nx} {ny} {nz}"), "", "")
    };
    let _ = writeln!(h, "sizes: {sizes}");
    let _ = writeln!(
        h,
        "space directions: {none}{} {} {}",
        col(0),
        col(1),
        col(2)
    );
    let _ = writeln!(h, "kinds: {kinds}domain domain domain");
    h.push_str("endian: little\nencoding: gzip\n");
    let _ = writeln!(h, "space origin: {}", col(3));
    let content: String = img
        .description
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    if !content.trim().is_empty() {
        let _ = writeln!(h, "content: {}", content.trim());
    }
    h.push('\n');

    let data = vol.data();
    let mut raw = Vec::with_capacity(data.len().saturating_mul(img.write_datatype.size()));
    if four {
        let n = vol.frame_len();
        let interleaved: Vec<f32> = (0..n)
            .flat_map(|v| (0..nt).map(move |t| data[v + n * t]))
            .collect();
        encode(&interleaved, img.write_datatype, &mut raw);
    } else {
        encode(data, img.write_datatype, &mut raw);
    }
    let io = |source| IoError::Io {
        path: crate::FilePath::default(),
        source,
    };
    let mut enc = GzEncoder::new(h.into_bytes(), flate2::Compression::default());
    enc.write_all(&raw).map_err(io)?;
    enc.finish().map_err(io)
}
