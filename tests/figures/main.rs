//! The figures of the three pipelines (issue 8), one test binary: content,
//! sizes and determinism of `unfold::figures::{placenta, ventricle,
//! mitral}` on real outcomes of the pipelines on synthetic shapes.
//!
//! Set `UNFOLD_FIGURES_DIR` to also write the figures there as PNG files.

mod mitral;
mod placenta;
mod ventricle;
