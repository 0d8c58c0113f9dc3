//! The error type of unfold-render.

use thiserror::Error;

/// Everything that can be wrong with the input handed to unfold-render.
///
/// The renderer never panics on user input: image sizes, camera parameters,
/// non-finite coordinates, indices out of range and mismatched attribute
/// lengths all come back as one of these variants.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum RenderError {
    /// An image (or z-buffer) size is zero or larger than [`crate::MAX_SIDE`].
    #[error("invalid image size {width} x {height} (each side must be in 1..={max})", max = crate::MAX_SIDE)]
    InvalidSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
    },
    /// A coordinate or parameter is NaN or infinite.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// What was not finite ("vertex", "point", "value", ...).
        what: &'static str,
        /// Its index in the slice it came from (0 for a single value).
        index: usize,
    },
    /// A triangle refers to a vertex index `>=` the number of vertices.
    #[error("triangle {triangle} refers to vertex {index}, but there are {vertex_count} vertices")]
    IndexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The offending vertex index.
        index: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A per-vertex or per-triangle attribute has the wrong length.
    #[error("{what}: expected {expected} entries, got {got}")]
    LengthMismatch {
        /// Which attribute ("per-vertex colours", ...).
        what: &'static str,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// Camera parameters that do not define a view (eye on the target, `up`
    /// parallel to the view direction, non-positive extent, field of view
    /// outside (0, 180) degrees, ...).
    #[error("invalid camera: {0}")]
    InvalidCamera(String),
    /// Some input that must not be empty is (no points to frame, ...).
    #[error("empty input: {0}")]
    Empty(&'static str),
    /// Any other invalid argument (zero bins, zero text scale, a rectangle
    /// too small for a widget, ...).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// The embedded font (Noto Sans Regular) could not be read, so no text
    /// can be drawn; the build is broken, not the input.
    #[error(
        "the embedded font could not be read: rebuild unfold-render from an intact notosans crate"
    )]
    Font,
    /// PNG encoding or decoding failed.
    #[error("PNG: {0}")]
    Png(String),
}
