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
    /// The file is not a usable markups (landmarks) file.
    #[error("{path}: {source}")]
    Markups {
        /// The file.
        path: FilePath,
        /// What is wrong with it.
        source: crate::markups::MarkupsError,
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
            | IoError::Markups { path, .. } => path,
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

impl From<MeshError> for IoError {
    fn from(source: MeshError) -> Self {
        IoError::Mesh {
            path: FilePath::default(),
            source,
        }
    }
}

/// Why an output path cannot be written, or an output set not put in
/// place ([`StagedOutputs`](crate::StagedOutputs)). Checked before any work.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OutputError {
    /// An output directory's path is an existing file.
    #[error("{path}: exists and is not a directory; -o needs a directory (created if missing)")]
    NotADirectory {
        /// The path.
        path: FilePath,
    },
    /// An output file's path is an existing directory.
    #[error("{path}: is a directory; give a file path for this output")]
    IsADirectory {
        /// The path.
        path: FilePath,
    },
    /// An output file's directory does not exist.
    #[error("{path}: the directory {dir} does not exist; create it first or choose another path")]
    MissingDirectory {
        /// The output file.
        path: FilePath,
        /// Its directory.
        dir: FilePath,
    },
    /// An output directory is a mount point: it cannot be replaced by a
    /// rename.
    #[error("{path}: is a mount point, which a run cannot replace; give a directory inside it")]
    MountPoint {
        /// The path.
        path: FilePath,
    },
    /// An output directory is (or holds) the current directory: replacing
    /// it would leave the shell in a deleted directory.
    #[error(
        "{path}: is the current directory (or holds it), which a run replaces as a whole; \
         give a new subdirectory such as -o out"
    )]
    CurrentDirectory {
        /// The path.
        path: FilePath,
    },
    /// The path has no last component to name a staging area after (`/`,
    /// `..`).
    #[error("{path}: cannot be written as a whole; give a path ending in a file or directory name")]
    NoName {
        /// The path.
        path: FilePath,
    },
    /// An existing output directory holds entries that no unfold run wrote
    /// (not listed in its `.unfold-run.json`); a run replaces its directory
    /// as a whole, so it is refused rather than deleting them.
    #[error(
        "{path}: holds {count} file(s) not written by an earlier unfold run into it \
         ({examples}); a run replaces its \
         output directory as a whole: choose a new or empty directory"
    )]
    ForeignFiles {
        /// The output directory.
        path: FilePath,
        /// How many such entries (a directory counts once).
        count: usize,
        /// The first few, relative to it, comma-separated.
        examples: String,
    },
    /// An output directory's `.unfold-run.json` is not a manifest unfold
    /// wrote.
    #[error(
        "{path}: its .unfold-run.json is not an unfold manifest ({reason}); choose a new or \
         empty directory"
    )]
    BadManifest {
        /// The output directory.
        path: FilePath,
        /// What is wrong with it.
        reason: String,
    },
    /// An input lies inside an output directory (which a run replaces as a
    /// whole) or is an output file.
    #[error(
        "{input}: is an input and would be replaced by the output {output}; choose another output path"
    )]
    InputIsOutput {
        /// The input.
        input: FilePath,
        /// The output directory or file.
        output: FilePath,
    },
    /// The operating system failed to create, rename or remove a path.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: FilePath,
        /// The OS error.
        source: std::io::Error,
    },
}
