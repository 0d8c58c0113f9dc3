//! unfold: maps anatomical shapes onto canonical templates.
//!
//! This facade re-exports the workspace crates; the `unfold` binary is the
//! command-line tool built on them.

pub mod app;
pub mod cli;
pub mod figures;

pub use unfold_io as io;
pub use unfold_linalg as linalg;
pub use unfold_mesh as mesh;
pub use unfold_organs as organs;
pub use unfold_param as param;

/// The `unfold` program on the command line `argv` (program name first),
/// returning its exit code ([`cli::main`]): the binary, and Python's
/// `python -m unfold`.
pub use cli::main as program;
