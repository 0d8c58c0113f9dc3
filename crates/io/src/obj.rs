//! (in progress)

use crate::{IoError, WriteOptions};
use unfold_mesh::CellMesh;

/// Parses a file's bytes.
pub fn read(_bytes: &[u8]) -> Result<CellMesh, IoError> {
    Err(IoError::unsupported("reader in progress"))
}

/// Serializes a mesh.
pub fn write(_mesh: &CellMesh, _opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    Err(IoError::unsupported("writer in progress"))
}
