//! (in progress)

use crate::{IoError, WriteOptions};
use unfold_mesh::CellMesh;

/// Parses a `.vtu` or `.vtp` file's bytes.
pub fn read(_bytes: &[u8]) -> Result<CellMesh, IoError> {
    Err(IoError::unsupported("reader in progress"))
}

/// Serializes a mesh as `.vtu`.
pub fn write_vtu(_mesh: &CellMesh, _opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    Err(IoError::unsupported("writer in progress"))
}

/// Serializes a mesh as `.vtp`.
pub fn write_vtp(_mesh: &CellMesh, _opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    Err(IoError::unsupported("writer in progress"))
}
