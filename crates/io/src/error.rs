//! The error type of unfold-io.

use std::fmt;
use std::path::PathBuf;
use thiserror::Error;
use unfold_mesh::MeshError;

/// Where in a file a problem was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// Somewhere (no better position known).
    Unknown,
    /// A 1-based line number of a text file.
    Line(usize),
    /// A 0-based byte offset (binary files, or a decompressed stream).
    Byte(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Unknown => Ok(()),
            Location::Line(l) => write!(f, "line {l}: "),
            Location::Byte(b) => write!(f, "byte {b}: "),
        }
    }
}

/// Displays a path, or `<input>` for data that did not come from a file.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct FilePath(pub PathBuf);

impl fmt::Display for FilePath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.as_os_str().is_empty() {
            write!(f, "<input>")
        } else {
            write!(f, "{}", self.0.display())
        }
    }
}

/// Everything that can go wrong reading or writing a file. Every variant
/// names the file; parse errors also give the line or byte offset.
///
/// Format modules parse bytes without knowing the path; they report with an
/// empty path, and [`IoError::with_path`] fills it in at the file boundary.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum IoError {
    /// The operating system failed to read or write the file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: FilePath,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file extension names no format unfold knows.
    #[error("{path}: unknown file type (known: {known})")]
    UnknownFormat {
        /// The file.
        path: FilePath,
        /// The extensions unfold knows, for the message.
        known: &'static str,
    },
    /// The file is not valid in its format.
    #[error("{path}: {location}{message}")]
    Malformed {
        /// The file.
        path: FilePath,
        /// Where the problem is.
        location: Location,
        /// What is wrong, and what was expected.
        message: String,
    },
    /// The file is valid but uses something unfold does not support, or the
    /// mesh cannot be stored in the requested format.
    #[error("{path}: {what}")]
    Unsupported {
        /// The file.
        path: FilePath,
        /// What is not supported.
        what: String,
    },
    /// The file was read, but its mesh or image is inconsistent.
    #[error("{path}: {source}")]
    Mesh {
        /// The file.
        path: FilePath,
        /// The mesh problem.
        source: MeshError,
    },
    /// A compressed stream (a `.nii.gz`, a NRRD file's gzip data)
    /// decompresses to a size other than the header declares. Inflation
    /// stops one byte past the declared size, so `found` is at most
    /// `declared + 1`, which means "more than declared".
    #[error("{path}: {}", decompressed_size_message(*.declared, *.found))]
    DecompressedSize {
        /// The file.
        path: FilePath,
        /// Decompressed bytes the header declares (for NIfTI `vox_offset` +
        /// voxels × type size; for NRRD `byte skip` + values × type size).
        declared: u64,
        /// Decompressed bytes found (at most `declared + 1`).
        found: u64,
    },
    /// A zlib block of a VTK XML array inflates to a size other than its
    /// block header declares. Inflation stops one byte past the declared
    /// size, so `found` is at most `declared + 1`, which means "more than
    /// declared" (a stream that would inflate to gigabytes is never
    /// inflated further).
    #[error("{path}: {location}{}", block_size_message(*.block, *.compressed, *.declared, *.found))]
    BlockSize {
        /// The file.
        path: FilePath,
        /// Where the array's data starts.
        location: Location,
        /// The block (0-based) of the array's data.
        block: usize,
        /// The block's compressed bytes (as the block header declares).
        compressed: u64,
        /// The block's uncompressed bytes (as the block header declares).
        declared: u64,
        /// Bytes the block inflates to (at most `declared + 1`).
        found: u64,
    },
    /// The file is not a usable markups (landmarks) file.
    #[error("{path}: {source}")]
    Markups {
        /// The file.
        path: FilePath,
        /// What is wrong with it.
        source: crate::markups::MarkupsError,
    },
    /// The file is not a usable injectivity problem (the benchmark's
    /// rest / init / simplices / handles file).
    #[error("{path}: {source}")]
    Tlc {
        /// The file.
        path: FilePath,
        /// What is wrong with it, and on which line.
        source: crate::tlc::TlcError,
    },
}

impl IoError {
    /// A parse error at `location` (path filled in later).
    pub fn malformed(location: Location, message: impl Into<String>) -> Self {
        IoError::Malformed {
            path: FilePath::default(),
            location,
            message: message.into(),
        }
    }

    /// An unsupported feature or an impossible conversion (path filled in later).
    pub fn unsupported(what: impl Into<String>) -> Self {
        IoError::Unsupported {
            path: FilePath::default(),
            what: what.into(),
        }
    }

    /// The file path of the error.
    fn path_slot(&mut self) -> &mut FilePath {
        match self {
            IoError::Io { path, .. }
            | IoError::UnknownFormat { path, .. }
            | IoError::Malformed { path, .. }
            | IoError::Unsupported { path, .. }
            | IoError::Mesh { path, .. }
            | IoError::DecompressedSize { path, .. }
            | IoError::BlockSize { path, .. }
            | IoError::Markups { path, .. }
            | IoError::Tlc { path, .. } => path,
        }
    }

    /// Sets the file path of the error (only where it is still empty).
    pub fn with_path(mut self, p: impl Into<PathBuf>) -> Self {
        let slot = self.path_slot();
        if slot.0.as_os_str().is_empty() {
            slot.0 = p.into();
        }
        self
    }

    /// The error with its file path replaced by `f(path)` (for a file
    /// written at one place that the user knows by another, as a staged
    /// output).
    pub fn map_path(mut self, f: impl FnOnce(&std::path::Path) -> PathBuf) -> Self {
        let slot = self.path_slot();
        slot.0 = f(&slot.0);
        self
    }
}

/// The message of [`IoError::DecompressedSize`].
fn decompressed_size_message(declared: u64, found: u64) -> String {
    if found > declared {
        format!(
            "the compressed data decompresses to more than {declared} bytes, the size the \
             header declares: the header's dimensions or type are wrong"
        )
    } else {
        format!(
            "the compressed data decompresses to only {found} bytes, but the header declares \
             {declared}: the file is truncated or the header's dimensions or type are wrong"
        )
    }
}

/// The message of [`IoError::BlockSize`].
fn block_size_message(block: usize, compressed: u64, declared: u64, found: u64) -> String {
    if found > declared {
        format!(
            "zlib block {block} ({compressed} compressed bytes) inflates to more than the \
             {declared} bytes its header declares: the file is corrupt or hostile"
        )
    } else {
        format!(
            "zlib block {block} ({compressed} compressed bytes) inflates to only {found} bytes, \
             but its header declares {declared}: the file is truncated or corrupt"
        )
    }
}

impl From<MeshError> for IoError {
    fn from(source: MeshError) -> Self {
        IoError::Mesh {
            path: FilePath::default(),
            source,
        }
    }
}
