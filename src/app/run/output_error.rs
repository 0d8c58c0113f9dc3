//! Why an output path cannot be written, or an output set not put in place.

use crate::io::FilePath;
use thiserror::Error;

/// Why an output path cannot be written, or an output set not put in
/// place ([`StagedOutputs`](super::StagedOutputs)). Checked before any work.
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
