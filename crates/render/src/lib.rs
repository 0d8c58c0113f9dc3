//! unfold-render: a small deterministic software renderer for the figures of
//! unfold (issue 8: PNG views of every pipeline's result).
//!
//! - [`Image`]: RGBA8 pixels, [`Image::blit`] to compose panels,
//!   [`Image::to_png`] / [`Image::from_png`]; 2D drawing in pixel space
//!   ([`Image::line`], [`Image::polyline`], [`Image::fill_polygon`] with
//!   [`FillRule`], [`arc`], [`annular_sector`]) and text
//!   ([`Image::draw_text`], [`text_width`]) in Noto Sans Regular, anti-aliased
//!   by `ab_glyph` (the font bytes come from the `notosans` crate; Noto Sans
//!   is under the SIL Open Font License 1.1, see `THIRD-PARTY.md` at the
//!   repository root).
//! - [`Camera`]: orthographic or perspective, [`Camera::frame`] to fit a
//!   point set in a panel.
//! - [`Renderer`]: z-buffered triangles with a top-left-style fill rule
//!   ([`Renderer::draw_mesh`], per-vertex or per-triangle [`Coloring`],
//!   [`Shading`] unlit / flat / smooth under a two-sided headlight),
//!   depth-tested wireframes and 3D polylines.
//! - [`Colormap`] and [`ColorScale`] (from `colorous`), [`draw_colorbar`],
//!   [`draw_histogram`].
//!
//! Everything is sequential and deterministic: the same calls give the same
//! PNG bytes. Bad input (sizes, non-finite coordinates, indices out of range)
//! gives a [`RenderError`], never a panic; the 2D pixel-space primitives
//! instead draw nothing for non-finite coordinates, as documented on each.
//!
//! ```
//! use unfold_render::{Camera, Coloring, Lens, Renderer, Rgb, Rgba, Shading};
//! use unfold_render::nalgebra::{Point3, Vector3};
//!
//! let positions = [
//!     Point3::new(0.0, 0.0, 0.0),
//!     Point3::new(1.0, 0.0, 0.0),
//!     Point3::new(0.0, 1.0, 0.0),
//! ];
//! let triangles = [[0u32, 1, 2]];
//! let camera = Camera::frame(&positions, -Vector3::z(), Vector3::y(), Lens::Orthographic, 64, 64, 0.1)?;
//! let mut r = Renderer::new(64, 64, Rgba::WHITE, camera)?;
//! r.draw_mesh(&positions, &triangles, Coloring::Uniform(Rgb::new(200, 30, 30)), Shading::Unlit)?;
//! let png = r.image().to_png()?;
//! assert_eq!(&png[1..4], b"PNG");
//! # Ok::<(), unfold_render::RenderError>(())
//! ```

#![warn(missing_docs)]

mod camera;
mod color;
mod colormap;
mod draw;
mod error;
mod image;
mod raster;
mod text;
mod widgets;

pub use camera::{Camera, Lens, Projected, Projection};
pub use color::{Rgb, Rgba};
pub use colormap::{ColorScale, Colormap, NAN_COLOR, format_value};
pub use draw::{FillRule, annular_sector, arc};
pub use error::RenderError;
pub use image::{Image, Rect};
pub use nalgebra;
pub use raster::{Coloring, DrawStats, GUARD_BAND, Lighting, Renderer, SUBPIXEL, Shading};
pub use text::{Anchor, MAX_TEXT_SCALE, text_height, text_width};
pub use widgets::{Histogram, HistogramStyle, draw_colorbar, draw_histogram};

/// Largest accepted image side in pixels.
pub const MAX_SIDE: u32 = 16384;

#[cfg(test)]
mod tests;
