//! Figures of the placenta pipeline (issue 8): the original and flattened
//! meshes coloured by boundary side and by `log2 det J`, the flattened
//! mesh's profile, histograms of the distortion measures and, per pulled-back
//! image, slices at five depths from the fetal to the maternal side.
//!
//! [`figures`] makes them all from an [`Outcome`] (and the pulled-back
//! images, [`FlatImage`]):
//!
//! | file | panels (columns x rows) | content |
//! |---|---|---|
//! | [`SIDE_FIGURE`] | 2 x 2 | original (scanner frame) and flattened (template frame), seen obliquely from the fetal side (top row) and from the maternal side (bottom row); boundary coloured by the point array `side` ([`SIDE_COLORS`], legend) |
//! | [`LOG2_DET_J_FIGURE`] | 2 x 2 | the same views, each boundary triangle coloured by its tet's `log2 det J` (diverging, symmetric scale, colour bar) |
//! | [`PROFILE_FIGURE`] | 2 x 1 | the original after the rigid alignment and the flattened mesh, seen exactly along the template's y axis (orthographic, x right, z up, one scale for both, silhouettes in [`PROFILE_COLOR`]), with the template's levels (`z = +-h`, `+-rz`, or the single plane's `-h` and mean fetal `z`) dashed, a scale bar and the x and z extents in mm |
//! | [`DISTORTION_FIGURE`] | 3 x 1 | histograms of `log2 det J` (per tet), `log2` edge-length ratio (per edge) and `log2` area ratio (per boundary triangle), with counts and percentiles |
//! | `<name>_depths.png` ([`depths_figure_name`]) | 6 x 1 | one pulled-back image (frame 0) as five slices of constant template `z` at depths 10, 30, 50, 70 and 90 % from the fetal side ([`DEPTH_FRACTIONS`]), each titled with its `z` in mm, on one viridis scale (1st to 99th percentile), voxels outside the mesh white, with a scale bar; the sixth panel holds the notes and the colour bar |
//! | `<name>_sections.png` ([`sections_figure_name`]; when the original image is given) | 4 x 2 | the original image's three orthogonal voxel-plane sections through the placenta's centre (top) beside the pulled-back image's three sections through the flattened mesh's centre (bottom: mid-depth `z`, then `y` and `x` constant), one intensity scale and one mm scale for all six (the source paper's Fig. 5-6); notes, colour bar and the sections' positions in the fourth column |
//! | `<name>_frames.png` ([`frames_figure_name`]; series of 2 or more frames) | 8 per row | the mid-depth slice of every frame as thumbnails on one intensity scale, then the colour bar (every `k`-th frame when they would not fit, see `frames.rs`) |
//!
//! Views of the original use the same directions as those of the flattened
//! mesh, carried into the scanner frame by the inverse of the alignment's
//! rotation, and all four mesh panels share one scale (mm per pixel), so
//! the panels can be compared side by side. The flattened views carry a
//! small triad of the template axes.
//!
//! One file per figure: the mesh views (`mesh_views.rs`, both 2 x 2
//! figures), the profile (`profile.rs`), the distortion histograms
//! (`distortion.rs`), the depth slices (`depth_slices.rs`), the sections
//! (`sections.rs`) and the frames (`frames.rs`); beside them what they
//! share: the checked meshes (`meshes.rs`), the template's levels
//! (`depths.rs`), rounding and percentiles (`numbers.rs`), image sampling
//! (`sampling.rs`), the image area of a panel (`raster.rs`) and drawing
//! helpers (`drawing.rs`). Text layout is [`crate::figures::layout`]'s.

use std::collections::BTreeSet;

use unfold_render::{ColorScale, Colormap, Rgb};

use super::{Figure, FigureError, FigureOptions};
use crate::mesh::Volume;
use crate::organs::placenta::Outcome;

mod depth_slices;
mod depths;
mod distortion;
mod drawing;
pub mod frames;
pub mod lambda_sweep;
mod mesh_views;
mod meshes;
mod numbers;
mod profile;
mod raster;
mod sampling;
mod sections;

use depth_slices::depth_slices;
use depths::depth_range;
use distortion::distortion;
use frames::frames;
use mesh_views::{Paint, mesh_views};
use meshes::Meshes;
use profile::profile;
use sections::sections;

/// File name of the figure coloured by boundary side.
pub const SIDE_FIGURE: &str = "meshes_side.png";

/// File name of the figure coloured by `log2 det J`.
pub const LOG2_DET_J_FIGURE: &str = "meshes_log2_det_j.png";

/// File name of the side view (profile) of the aligned original and the
/// flattened mesh.
pub const PROFILE_FIGURE: &str = "flattened_profile.png";

/// File name of the distortion histograms.
pub const DISTORTION_FIGURE: &str = "distortion.png";

/// The file name of the depth slices of the pulled-back image `name`:
/// `<name>_depths.png`.
pub fn depths_figure_name(name: &str) -> String {
    format!("{name}_depths.png")
}

/// The file name of the sections figure of the image `name` (original
/// beside flattened): `<name>_sections.png`.
pub fn sections_figure_name(name: &str) -> String {
    format!("{name}_sections.png")
}

/// The file name of the frames figure of the 4D image `name`:
/// `<name>_frames.png`.
pub fn frames_figure_name(name: &str) -> String {
    format!("{name}_frames.png")
}

/// Colours of the `side` labels 0 interior, 1 fetal, 2 maternal, 3 margin
/// (Tableau 10 grey, blue, red, yellow). Other labels are drawn in
/// [`OTHER_LABEL_COLOR`]. Mesh views are lit (flat shading, ambient 0.45,
/// diffuse 0.55), so a face shows `k` times its colour with `k` in
/// [0.45, 1].
pub const SIDE_COLORS: [Rgb; 4] = [
    Rgb::new(186, 176, 172),
    Rgb::new(78, 121, 167),
    Rgb::new(225, 87, 89),
    Rgb::new(237, 201, 72),
];

/// Names of the `side` labels, as in the legend.
pub const SIDE_NAMES: [&str; 4] = ["interior", "fetal", "maternal", "margin"];

/// Colour of a `side` label other than 0..=3.
pub const OTHER_LABEL_COLOR: Rgb = Rgb::new(60, 60, 60);

/// Colour of the meshes in [`PROFILE_FIGURE`] (unlit, so every pixel of a
/// silhouette has exactly this colour).
pub const PROFILE_COLOR: Rgb = Rgb::new(96, 125, 160);

/// Colour of the histogram bars in [`DISTORTION_FIGURE`].
pub const HISTOGRAM_COLOR: Rgb = Rgb::new(70, 110, 170);

/// The depths of the five slices of a depth figure, from the fetal side to
/// the maternal side: slice `k` is at `z = m + f_k d` with `m` the middle
/// and `d` the half distance between the fetal and maternal template levels
/// (`m = 0`, `d = h` for the parallel planes, `d = rz` for the ellipsoid;
/// the single plane's levels are `-h` and the mean `z` of its fetal
/// vertices), i.e. at `50 (1 - f_k)` % of the depth from the fetal side.
pub const DEPTH_FRACTIONS: [f64; 5] = [0.8, 0.4, 0.0, -0.4, -0.8];

/// Height of the title band at the top of every panel, pixels: a title
/// (text scale 2 when it fits) and a subtitle (scale 1).
pub const TITLE_BAND: u32 = 40;

/// Smallest accepted panel size, pixels.
pub const MIN_PANEL: (u32, u32) = (240, 200);

/// A pulled-back image in the template frame: the NIfTI written as
/// `DIR/<name>_flat.nii.gz` by the pipeline (its affine is the template
/// grid's, `z` the template's normal: the fetal side at `z = +h`, the
/// maternal side at `z = -h` for the parallel planes). Voxels holding 0 are
/// outside the mesh. Of a 4D series, the depth and sections figures show
/// frame 0 and the frames figure every frame.
#[derive(Debug, Clone, Copy)]
pub struct FlatImage<'a> {
    /// The image's name (the file name stem, e.g. `bold`): the figures are
    /// `<name>_depths.png`, `<name>_sections.png` and `<name>_frames.png`,
    /// and the name is their title.
    pub name: &'a str,
    /// The pulled-back image (template frame, mm).
    pub volume: &'a Volume<f32>,
    /// The image it was pulled back from (scanner frame, the original
    /// mesh's), for the sections figure; without it that figure is not made.
    pub original: Option<&'a Volume<f32>>,
}

/// Makes every placenta figure of `outcome` at the size `opts` (see the
/// module documentation for the list): [`SIDE_FIGURE`] (only when the
/// meshes have a `side` point array or `outcome.labels` has one label per
/// vertex), [`LOG2_DET_J_FIGURE`] (the flattened mesh's cell array
/// `log2_det_j`, or, when it is missing, `log2` of the ratio of the tet
/// volumes), [`PROFILE_FIGURE`], [`DISTORTION_FIGURE`], then per image, in
/// the order given, its depth figure, its sections figure (when its
/// original is given) and its frames figure (when it has two frames or
/// more).
///
/// # Errors
/// [`FigureError::Input`] for panels smaller than [`MIN_PANEL`] or so large
/// that a figure would exceed [`unfold_render::MAX_SIDE`], an outcome
/// whose meshes disagree (vertex counts, tet indices, non-finite
/// coordinates, no boundary), an image name that is empty, repeated or not
/// a plain file name, an image with no data (no finite non-zero voxel)
/// in the flattened mesh's slab or on the sections, and an original image
/// that does not contain the placenta's centre; [`FigureError::Render`] if the renderer
/// refuses anything else.
pub fn figures(
    outcome: &Outcome,
    images: &[FlatImage<'_>],
    opts: &FigureOptions,
) -> Result<Vec<Figure>, FigureError> {
    check_options(opts, if images.is_empty() { 3 } else { 6 })?;
    let mut names = BTreeSet::new();
    for img in images {
        check_image_name(img.name)?;
        if !names.insert(img.name) {
            return Err(FigureError::input(
                &depths_figure_name(img.name),
                format!("the image name {:?} is given twice", img.name),
            ));
        }
    }
    let meshes = Meshes::new(outcome)?;
    let mut out = Vec::new();
    if let Some(labels) = &meshes.labels {
        let image = mesh_views(&meshes, &Paint::Sides(labels), opts, SIDE_FIGURE)?;
        out.push(Figure::new(SIDE_FIGURE, image));
    }
    let scale = ColorScale::new(Colormap::BlueRed, -meshes.det_j_range, meshes.det_j_range);
    let paint = Paint::Cells {
        values: &meshes.log2_det_j,
        scale,
    };
    out.push(Figure::new(
        LOG2_DET_J_FIGURE,
        mesh_views(&meshes, &paint, opts, LOG2_DET_J_FIGURE)?,
    ));
    let depths = depth_range(outcome, &meshes);
    out.push(Figure::new(
        PROFILE_FIGURE,
        profile(&meshes, &depths, opts)?,
    ));
    out.push(Figure::new(DISTORTION_FIGURE, distortion(&meshes, opts)?));
    for img in images {
        let name = depths_figure_name(img.name);
        let image = depth_slices(img, &meshes, &depths, opts, &name)?;
        out.push(Figure::new(&name, image));
        if let Some(original) = img.original {
            let name = sections_figure_name(img.name);
            let image = sections(img, original, &meshes, &depths, opts, &name)?;
            out.push(Figure::new(&name, image));
        }
        if img.volume.frames() > 1 {
            let name = frames_figure_name(img.name);
            let image = frames(img, &meshes, &depths, opts, &name)?;
            out.push(Figure::new(&name, image));
        }
    }
    Ok(out)
}

/// Checks the panel size: at least [`MIN_PANEL`], and the widest figure
/// (`columns` panels) and the tallest (2 rows) within the renderer's
/// [`unfold_render::MAX_SIDE`].
fn check_options(opts: &FigureOptions, columns: u32) -> Result<(), FigureError> {
    let (w, h) = MIN_PANEL;
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    if pw < w || ph < h {
        return Err(FigureError::input(
            MESH_FIGURES,
            format!(
                "panels of {pw}x{ph} pixels are too small; the placenta figures need at least {w}x{h}"
            ),
        ));
    }
    let max = unfold_render::MAX_SIDE;
    if u64::from(pw) * u64::from(columns) > u64::from(max) || u64::from(ph) * 2 > u64::from(max) {
        return Err(FigureError::input(
            MESH_FIGURES,
            format!(
                "panels of {pw}x{ph} pixels are too large: a figure of {columns} x 2 panels would exceed {max} pixels"
            ),
        ));
    }
    Ok(())
}

fn check_image_name(name: &str) -> Result<(), FigureError> {
    let bad = name.is_empty()
        || name == "."
        || name == ".."
        || name
            .chars()
            .any(|c| c == '/' || c == '\\' || c.is_control());
    if bad {
        return Err(FigureError::input(
            &depths_figure_name(name),
            format!("the image name {name:?} is not a plain file name"),
        ));
    }
    Ok(())
}

pub(super) const MESH_FIGURES: &str = "placenta figures";
