//! (in progress)

use crate::IoError;
use unfold_mesh::Volume;

/// A NIfTI-1 image: values (after scl_slope / scl_inter) on a grid with its
/// voxel-to-world affine.
#[derive(Debug, Clone, PartialEq)]
pub struct NiftiImage {
    /// The voxel values and the voxel-to-world affine.
    pub volume: Volume<f32>,
}

/// Parses a `.nii` or `.nii.gz` file's bytes.
pub fn read(_bytes: &[u8]) -> Result<NiftiImage, IoError> {
    Err(IoError::unsupported("reader in progress"))
}

/// Serializes an image, gzip-compressed when `gzip`.
pub fn write(_img: &NiftiImage, _gzip: bool) -> Result<Vec<u8>, IoError> {
    Err(IoError::unsupported("writer in progress"))
}
