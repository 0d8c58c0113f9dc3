//! One streaming pass over an image's values, in bounded memory.
//!
//! [`scan_image_values`] reads the header (see [`crate::read_image_header`])
//! and then hands the values to a callback about 1 MiB of stored data at a
//! time (decoded to `f32`, NIfTI's `scl_slope` / `scl_inter` applied),
//! reading or inflating the file as it goes: memory stays bounded by the
//! chunk, whatever the image's size. The values come in file order (x
//! fastest); for a NRRD series whose frame axis is not the last, that is not
//! [`unfold_mesh::Volume`]'s order. Errors are those of
//! [`crate::read_image`]: a gzip stream holding more or less than the header
//! declares is refused ([`IoError::DecompressedSize`]) without inflating more
//! than one byte past the declared size. NRRD `ascii` data is the exception
//! to the bound: its text is read whole (it is never larger than the file).
//!
//! [`image_value_summary`] is the pass `unfold info` makes: the count and the
//! range of the values.

use crate::{ImageHeader, IoError};
use std::path::Path;

/// What a pass over an image's values found.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ValueSummary {
    /// Values seen.
    pub count: u64,
    /// Values that are NaN.
    pub nan: u64,
    /// `(min, max)` of the values that are not NaN (infinities included),
    /// as [`unfold_mesh::Volume::value_range`]; `None` when every value is NaN.
    pub range: Option<(f64, f64)>,
}

impl ValueSummary {
    /// Adds values to the summary.
    pub fn add(&mut self, values: &[f32]) {
        self.count += values.len() as u64;
        // One plain loop (this runs over every voxel): comparisons with NaN
        // are false, so NaN never moves (lo, hi), left at (inf, -inf) when
        // every value is NaN (or there are none), and lo <= hi otherwise.
        let (mut lo, mut hi, mut nan) = (f32::INFINITY, f32::NEG_INFINITY, 0u64);
        for &x in values {
            if x < lo {
                lo = x;
            }
            if x > hi {
                hi = x;
            }
            nan += u64::from(x.is_nan());
        }
        self.nan += nan;
        if lo <= hi {
            let (lo, hi) = (f64::from(lo), f64::from(hi));
            self.range = Some(match self.range {
                None => (lo, hi),
                Some((a, b)) => (a.min(lo), b.max(hi)),
            });
        }
    }
}

/// Streams the values of an image file to `sink` in chunks (see the [module
/// documentation](self)); returns the header.
pub fn scan_image_values(
    path: impl AsRef<Path>,
    mut sink: impl FnMut(&[f32]),
) -> Result<ImageHeader, IoError> {
    let path = path.as_ref();
    match crate::format::image_kind(path)? {
        crate::FileKind::Nrrd { .. } => crate::nrrd::stream_file(path, &mut sink),
        _ => crate::nifti::stream_file(path, &mut sink),
    }
    .map_err(|e| e.with_path(path))
}

/// The header and a [`ValueSummary`] of an image file, in one streaming pass.
pub fn image_value_summary(path: impl AsRef<Path>) -> Result<(ImageHeader, ValueSummary), IoError> {
    let mut s = ValueSummary::default();
    let h = scan_image_values(path, |v| s.add(v))?;
    Ok((h, s))
}
