//! Figures: PNG views of every pipeline's result (issue 8), composed with
//! [`unfold_render`] from the pipelines' in-memory outcomes. The command
//! line writes them into `DIR/figures/` (`--no-figures` skips them).
//!
//! Every function returns named [`Figure`]s (the file name and the image);
//! nothing here touches the file system. Figures are deterministic: the
//! same outcome and options give the same PNG bytes.
//!
//! One module per organ ([`placenta`], [`ventricle`], [`mitral`]), each a
//! folder with one file per figure family, and [`cohort`] for the figures
//! of a whole cohort (`unfold cohort`); the text layout they share
//! (wrapping, fitting, title bands, panels) is [`layout`].

pub mod cohort;
pub mod layout;
pub mod mitral;
pub mod placenta;
pub mod ventricle;

pub use unfold_render as render;

use thiserror::Error;
use unfold_render::{Image, RenderError, Rgba};

/// Colour of text and lines in every figure.
pub const INK: Rgba = Rgba::BLACK;

/// Background of every figure.
pub const PAPER: Rgba = Rgba::WHITE;

/// Errors of figure making.
#[derive(Debug, Error)]
pub enum FigureError {
    /// The renderer refused something (size, coordinates, ...).
    #[error("rendering {figure}: {source}")]
    Render {
        /// The figure being made.
        figure: String,
        /// What the renderer said.
        source: RenderError,
    },
    /// The outcome lacks something a figure needs (an array, a label, ...).
    #[error("{figure}: {what}")]
    Input {
        /// The figure being made.
        figure: String,
        /// What is missing or wrong.
        what: String,
    },
}

impl FigureError {
    /// A renderer error while making `figure`.
    pub fn render(figure: &str) -> impl FnOnce(RenderError) -> FigureError + '_ {
        move |source| FigureError::Render {
            figure: figure.to_string(),
            source,
        }
    }

    /// A missing or wrong input of `figure`.
    pub fn input(figure: &str, what: impl Into<String>) -> FigureError {
        FigureError::Input {
            figure: figure.to_string(),
            what: what.into(),
        }
    }
}

/// One figure: its file name in `figures/` (ending in `.png`) and the image.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name, e.g. `sides.png`.
    pub name: String,
    /// The picture.
    pub image: Image,
}

impl Figure {
    /// The figure `image` saved as `name`.
    pub fn new(name: impl Into<String>, image: Image) -> Figure {
        Figure {
            name: name.into(),
            image,
        }
    }
}

/// Size of the figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FigureOptions {
    /// Width of one panel, pixels (a figure of several panels is a multiple
    /// of it). Default 480.
    pub panel_width: u32,
    /// Height of one panel, pixels. Default 400.
    pub panel_height: u32,
}

impl Default for FigureOptions {
    fn default() -> Self {
        FigureOptions {
            panel_width: 480,
            panel_height: 400,
        }
    }
}
