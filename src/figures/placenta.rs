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
//!
//! Views of the original use the same directions as those of the flattened
//! mesh, carried into the scanner frame by the inverse of the alignment's
//! rotation, and all four mesh panels share one scale (mm per pixel), so
//! the panels can be compared side by side. The flattened views carry a
//! small triad of the template axes.

use std::collections::BTreeSet;

use super::{Figure, FigureError, FigureOptions};
use crate::mesh::geometry::tet_signed_volume;
use crate::mesh::nalgebra::{Point3, Rotation3, Vector3};
use crate::mesh::topology::{edges, tet_boundary};
use crate::mesh::{Field, TetMesh, Volume};
use crate::organs::placenta::Outcome;
use unfold_render::{
    Anchor, Camera, ColorScale, Coloring, Colormap, HistogramStyle, Image, Lighting, NAN_COLOR,
    Rect, RenderError, Renderer, Rgb, Rgba, Shading, draw_histogram, format_value, text_height,
    text_width,
};

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
/// outside the mesh. Of a 4D series, frame 0 is shown.
#[derive(Debug, Clone, Copy)]
pub struct FlatImage<'a> {
    /// The image's name (the file name stem, e.g. `bold`): the figure is
    /// `<name>_depths.png` and the name is its title.
    pub name: &'a str,
    /// The pulled-back image (template frame, mm).
    pub volume: &'a Volume<f32>,
}

/// Makes every placenta figure of `outcome` at the size `opts` (see the
/// module documentation for the list): [`SIDE_FIGURE`] (only when the
/// meshes have a `side` point array or `outcome.labels` has one label per
/// vertex), [`LOG2_DET_J_FIGURE`] (the flattened mesh's cell array
/// `log2_det_j`, or, when it is missing, `log2` of the ratio of the tet
/// volumes), [`PROFILE_FIGURE`], [`DISTORTION_FIGURE`], then one depth
/// figure per image, in the order given.
///
/// # Errors
/// [`FigureError::Input`] for panels smaller than [`MIN_PANEL`] or so large
/// that a figure would exceed [`unfold_render::MAX_SIDE`], an outcome
/// whose meshes disagree (vertex counts, tet indices, non-finite
/// coordinates, no boundary), an image name that is empty, repeated or not
/// a plain file name, and an image with no data (no finite non-zero voxel)
/// in the flattened mesh's slab; [`FigureError::Render`] if the renderer
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
        out.push(figure(SIDE_FIGURE, image));
    }
    let scale = ColorScale::new(Colormap::BlueRed, -meshes.det_j_range, meshes.det_j_range);
    let paint = Paint::Cells {
        values: &meshes.log2_det_j,
        scale,
    };
    out.push(figure(
        LOG2_DET_J_FIGURE,
        mesh_views(&meshes, &paint, opts, LOG2_DET_J_FIGURE)?,
    ));
    let depths = depth_range(outcome, &meshes);
    out.push(figure(PROFILE_FIGURE, profile(&meshes, &depths, opts)?));
    out.push(figure(DISTORTION_FIGURE, distortion(&meshes, opts)?));
    for img in images {
        let name = depths_figure_name(img.name);
        let image = depth_slices(img, &meshes, &depths, opts, &name)?;
        out.push(figure(&name, image));
    }
    Ok(out)
}

fn figure(name: &str, image: Image) -> Figure {
    Figure {
        name: name.to_string(),
        image,
    }
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

// ---------------------------------------------------------------------------
// The meshes and their derived data

/// What every figure needs from the outcome, checked once.
struct Meshes<'a> {
    /// Original positions (scanner frame).
    original: &'a [Point3<f64>],
    /// Flattened positions (template frame).
    flattened: &'a [Point3<f64>],
    /// The original after the rigid alignment (template axes).
    aligned: Vec<Point3<f64>>,
    /// The tets (shared by both meshes).
    tets: &'a [[u32; 4]],
    /// Boundary triangles in volume vertex indices.
    tris: Vec<[u32; 3]>,
    /// The tet of each boundary triangle.
    face_tet: Vec<u32>,
    /// Scanner -> template rotation.
    rotation: Rotation3<f64>,
    /// Per vertex `side` labels, when known.
    labels: Option<Vec<u8>>,
    /// Per tet `log2 det J`.
    log2_det_j: Vec<f64>,
    /// Half range of the `log2 det J` colour scale.
    det_j_range: f64,
}

const MESH_FIGURES: &str = "placenta figures";

impl<'a> Meshes<'a> {
    fn new(outcome: &'a Outcome) -> Result<Self, FigureError> {
        let bad = |what: String| FigureError::input(MESH_FIGURES, what);
        let (orig, flat) = (&outcome.original, &outcome.flattened);
        let n = flat.positions.len();
        if orig.positions.len() != n {
            return Err(bad(format!(
                "the original mesh has {} vertices, the flattened one {n}",
                orig.positions.len()
            )));
        }
        if flat.tets.is_empty() {
            return Err(bad("the flattened mesh has no tetrahedra".into()));
        }
        for (what, p) in [
            ("original", &orig.positions),
            ("flattened", &flat.positions),
        ] {
            if let Some(v) = p
                .iter()
                .position(|q| !q.coords.iter().all(|x| x.is_finite()))
            {
                return Err(bad(format!("vertex {v} of the {what} mesh is not finite")));
            }
        }
        let bare = TetMesh::new(flat.positions.clone(), flat.tets.clone());
        let boundary =
            tet_boundary(&bare).map_err(|e| bad(format!("the flattened mesh's boundary: {e}")))?;
        let tris: Vec<[u32; 3]> = boundary
            .surface
            .triangles
            .iter()
            .map(|t| t.map(|v| boundary.to_volume[v as usize]))
            .collect();
        if tris.is_empty() {
            return Err(bad("the flattened mesh has no boundary".into()));
        }
        let rotation = outcome.alignment.rotation();
        let rotation = if rotation.matrix().iter().all(|x| x.is_finite()) {
            rotation
        } else {
            Rotation3::identity()
        };
        let aligned: Vec<Point3<f64>> = orig
            .positions
            .iter()
            .map(|p| outcome.alignment.apply(p))
            .collect();
        let aligned = if aligned
            .iter()
            .all(|p| p.coords.iter().all(|x| x.is_finite()))
        {
            aligned
        } else {
            orig.positions.clone()
        };
        let labels = side_labels(outcome, n);
        let log2_det_j = match scalar_field(flat.cell_data.get("log2_det_j"), flat.tets.len()) {
            Some(v) => v,
            None => volume_ratios(&orig.positions, &flat.positions, &flat.tets),
        };
        let det_j_range = symmetric_range(&log2_det_j);
        Ok(Meshes {
            original: &orig.positions,
            flattened: &flat.positions,
            aligned,
            tets: &flat.tets,
            tris,
            face_tet: boundary.face_tet,
            rotation,
            labels,
            log2_det_j,
            det_j_range,
        })
    }
}

/// The `side` labels: the original's point array, else the flattened one's,
/// else `outcome.labels`, whichever has one value per vertex.
fn side_labels(outcome: &Outcome, n: usize) -> Option<Vec<u8>> {
    for mesh in [&outcome.original, &outcome.flattened] {
        if let Some(v) = scalar_field(mesh.point_data.get("side"), n) {
            return Some(
                v.iter()
                    .map(|&x| {
                        if x.is_finite() && (0.0..=254.0).contains(&x) && x.fract() == 0.0 {
                            x as u8
                        } else {
                            u8::MAX
                        }
                    })
                    .collect(),
            );
        }
    }
    (outcome.labels.len() == n && n > 0).then(|| outcome.labels.clone())
}

/// The values of a one-component field with `n` tuples.
fn scalar_field(field: Option<&Field>, n: usize) -> Option<Vec<f64>> {
    let f = field?;
    (f.components() == 1 && f.tuples() == n).then(|| f.values().to_f64())
}

/// `log2` of the flattened over the original signed tet volume (`det J` of
/// the linear map), `-inf` for a flattened tet with volume `<= 0`.
fn volume_ratios(orig: &[Point3<f64>], flat: &[Point3<f64>], tets: &[[u32; 4]]) -> Vec<f64> {
    tets.iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|i| i as usize);
            let vo = tet_signed_volume(&orig[a], &orig[b], &orig[c], &orig[d]);
            let vf = tet_signed_volume(&flat[a], &flat[b], &flat[c], &flat[d]);
            if vf <= 0.0 {
                f64::NEG_INFINITY
            } else {
                (vf / vo).log2()
            }
        })
        .collect()
}

/// The half range `m` of a symmetric scale `[-m, m]` for `values`: the 99th
/// percentile of the finite `|v|` (a few extreme tets do not wash the map
/// out; they take the end colours), at least `1e-3`, rounded up to two
/// significant digits.
fn symmetric_range(values: &[f64]) -> f64 {
    let mut abs: Vec<f64> = values
        .iter()
        .filter(|v| v.is_finite())
        .map(|v| v.abs())
        .collect();
    abs.sort_by(f64::total_cmp);
    ceil_2(percentile(&abs, 0.99).unwrap_or(0.0).max(1e-3))
}

/// `x > 0` rounded up to two significant digits (0.497 -> 0.5, 0.0441 ->
/// 0.045), for readable scale ends.
fn ceil_2(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return x;
    }
    let p = 10f64.powf(x.log10().floor() - 1.0);
    let r = (x / p).ceil() * p;
    // Undo representation noise (0.5 shown as 0.5, not 0.5000000001).
    format!("{r:.12e}").parse().unwrap_or(r)
}

/// Nearest-rank percentile `q` in [0, 1] of sorted values.
fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let k = (q * (sorted.len() - 1) as f64).round() as usize;
    sorted.get(k.min(sorted.len() - 1)).copied()
}

/// The template's fetal and maternal `z` (top, bottom), mm.
struct Depths {
    top: f64,
    bottom: f64,
    /// How they were found, for captions (`h = 12.5 mm`).
    label: String,
    /// Short names of the two levels (`+h`, `-h`).
    names: [&'static str; 2],
}

impl Depths {
    fn z(&self, fraction: f64) -> f64 {
        0.5 * (self.top + self.bottom) + fraction * 0.5 * (self.top - self.bottom)
    }

    /// `fetal side: z = +9.67 mm (+h)`-style descriptions of the two
    /// levels.
    fn describe(&self) -> [String; 2] {
        [
            format!(
                "fetal side: z = {} mm ({})",
                signed(self.top),
                self.names[0]
            ),
            format!(
                "maternal side: z = {} mm ({})",
                signed(self.bottom),
                self.names[1]
            ),
        ]
    }
}

/// A value with its sign (`+9.67`, `-9.67`, `0`).
fn signed(v: f64) -> String {
    if v > 0.0 {
        format!("+{}", format_value(v))
    } else {
        format_value(v)
    }
}

/// `z = +-h` for the planes, `+-rz` for the ellipsoid, `-h` and the mean
/// fetal `z` for the single plane; the flattened mesh's `z` range when the
/// report's parameters are missing or unusable.
fn depth_range(outcome: &Outcome, m: &Meshes<'_>) -> Depths {
    let theta = &outcome.report.theta;
    let good = |v: Option<&f64>| v.copied().filter(|x| x.is_finite() && *x > 0.0);
    let fetal_mean = || {
        let labels = m.labels.as_ref()?;
        let z: Vec<f64> = labels
            .iter()
            .zip(m.flattened)
            .filter(|(l, _)| **l == 1)
            .map(|(_, p)| p.z)
            .collect();
        (!z.is_empty()).then(|| z.iter().sum::<f64>() / z.len() as f64)
    };
    match outcome.report.template {
        "ellipsoid" => {
            if let Some(rz) = good(theta.get("rz")) {
                return Depths {
                    top: rz,
                    bottom: -rz,
                    label: format!("rz = {} mm", format_value(rz)),
                    names: ["+rz", "-rz"],
                };
            }
        }
        "single-plane" => {
            if let Some(h) = good(theta.get("h")) {
                let top = fetal_mean().filter(|t| *t > -h).unwrap_or(h);
                return Depths {
                    top,
                    bottom: -h,
                    label: format!("h = {} mm", format_value(h)),
                    names: ["fetal", "-h"],
                };
            }
        }
        _ => {
            if let Some(h) = good(theta.get("h")) {
                return Depths {
                    top: h,
                    bottom: -h,
                    label: format!("h = {} mm", format_value(h)),
                    names: ["+h", "-h"],
                };
            }
        }
    }
    let (lo, hi) = m
        .flattened
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.z), hi.max(p.z))
        });
    Depths {
        top: hi,
        bottom: lo,
        label: "the mesh's z range".into(),
        names: ["top", "bottom"],
    }
}

// ---------------------------------------------------------------------------
// Drawing helpers

const INK: Rgba = Rgba::BLACK;
const PAPER: Rgba = Rgba::WHITE;
const GUIDE: Rgba = Rgba::new(110, 110, 110, 255);
const PANEL_EDGE: Rgba = Rgba::new(215, 215, 215, 255);

/// Draws `text` at the largest scale `<= max_scale` that fits `max_width`
/// (cut with `...` at scale 1 if it does not fit at all); returns its
/// height.
fn text_fit(
    img: &mut Image,
    x: i32,
    y: i32,
    text: &str,
    max_scale: u32,
    max_width: u32,
    anchor: Anchor,
) -> Result<u32, RenderError> {
    let mut scale = max_scale.max(1);
    while scale > 1 && text_width(text, scale) > max_width {
        scale -= 1;
    }
    if text_width(text, scale) <= max_width {
        img.draw_text(x, y, text, scale, INK, anchor)?;
    } else {
        let n = (max_width / 8) as usize;
        let cut: String = if n > 3 {
            text.chars().take(n - 3).chain("...".chars()).collect()
        } else {
            text.chars().take(n).collect()
        };
        img.draw_text(x, y, &cut, scale, INK, anchor)?;
    }
    Ok(text_height(scale))
}

/// A new panel with its title (line 1 at scale 2 when it fits) and subtitle
/// (scale 1) centred in the [`TITLE_BAND`], and a light outline.
fn panel(opts: &FigureOptions, title: &str, subtitle: &str) -> Result<Image, RenderError> {
    panel_scaled(opts, title, subtitle, 2)
}

/// [`panel`] with the title at most at `title_scale` (so that the panels
/// of a figure can share one, see [`title_scale`]).
fn panel_scaled(
    opts: &FigureOptions,
    title: &str,
    subtitle: &str,
    title_scale: u32,
) -> Result<Image, RenderError> {
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut img = Image::new(w, h, PAPER)?;
    let cx = (w / 2) as i32;
    text_fit(&mut img, cx, 6, title, title_scale, w - 8, Anchor::Center)?;
    if !subtitle.is_empty() {
        text_fit(&mut img, cx, 26, subtitle, 1, w - 8, Anchor::Center)?;
    }
    img.stroke_rect(img.rect(), PANEL_EDGE);
    Ok(img)
}

/// The largest title scale (2 or 1) at which all `titles` fit a panel.
fn title_scale(opts: &FigureOptions, titles: &[&str]) -> u32 {
    if titles
        .iter()
        .all(|t| text_width(t, 2) <= opts.panel_width - 8)
    {
        2
    } else {
        1
    }
}

/// Composes `panels` (row-major, `columns` per row) into one figure.
fn compose(panels: &[Image], columns: u32, opts: &FigureOptions) -> Result<Image, RenderError> {
    let rows = (panels.len() as u32).div_ceil(columns.max(1));
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut fig = Image::new(w.saturating_mul(columns), h.saturating_mul(rows), PAPER)?;
    for (k, p) in panels.iter().enumerate() {
        let (c, r) = (k as u32 % columns, k as u32 / columns);
        fig.blit(p, i64::from(c * w), i64::from(r * h));
    }
    Ok(fig)
}

/// A round length (1, 2 or 5 times a power of ten) of at most `max`.
fn nice_length(max: f64) -> f64 {
    if !(max.is_finite() && max > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(max.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|k| k * p)
        .find(|&l| l <= max)
        .unwrap_or(p)
}

/// A horizontal scale bar of `mm` millimetres at `px_per_mm`, its left end
/// at `(x, y)`, labelled above.
fn scale_bar(img: &mut Image, x: f64, y: f64, mm: f64, px_per_mm: f64) -> Result<(), RenderError> {
    let len = mm * px_per_mm;
    for d in [0.0, 1.0] {
        img.line([x, y + d], [x + len, y + d], INK);
    }
    img.line([x, y - 4.0], [x, y + 5.0], INK);
    img.line([x + len, y - 4.0], [x + len, y + 5.0], INK);
    img.draw_text(
        (x + 0.5 * len) as i32,
        (y - 13.0) as i32,
        &format!("{} mm", format_value(mm)),
        1,
        INK,
        Anchor::Center,
    )?;
    Ok(())
}

/// A vertical colour bar in `rect`: the title on top (scale 1), the
/// gradient (low at the bottom) in an outline, ticks at the ends and the
/// middle, labels 4 pixels right of the ticks (with a `+` on positive values
/// when `signed`, so a tick never reads as a minus sign).
fn colour_bar(
    img: &mut Image,
    rect: Rect,
    scale: &ColorScale,
    title: &str,
    signed_labels: bool,
) -> Result<(), RenderError> {
    text_fit(
        img,
        rect.x + rect.width as i32 / 2,
        rect.y,
        title,
        1,
        rect.width,
        Anchor::Center,
    )?;
    let (x0, bw) = (i64::from(rect.x), 18i64);
    let (top, bot) = (i64::from(rect.y) + 16, rect.bottom() - 6);
    if bot - top < 8 {
        return Err(RenderError::InvalidArgument(format!(
            "{}x{} is too small for a colour bar",
            rect.width, rect.height
        )));
    }
    let span = (bot - top) as f64;
    for y in top..=bot {
        let c = scale.map.eval((bot - y) as f64 / span).opaque();
        for x in x0 + 1..x0 + bw - 1 {
            img.put(x, y, c);
        }
    }
    img.stroke_rect(
        Rect::new(rect.x, (top - 1) as i32, bw as u32, (bot - top + 3) as u32),
        INK,
    );
    for (t, v) in [
        (0.0, scale.lo),
        (0.5, 0.5 * (scale.lo + scale.hi)),
        (1.0, scale.hi),
    ] {
        let y = (bot as f64 - t * span).round();
        img.line([(x0 + bw) as f64, y], [(x0 + bw + 3) as f64, y], INK);
        let label = if signed_labels {
            signed(v)
        } else {
            format_value(v)
        };
        img.draw_text(
            (x0 + bw + 8) as i32,
            (y - 4.0) as i32,
            &label,
            1,
            INK,
            Anchor::Left,
        )?;
    }
    Ok(())
}

/// A dashed horizontal line from `x0` to `x1` at row `y`.
fn dashed(img: &mut Image, x0: i64, x1: i64, y: i64, c: Rgba) {
    for x in x0..=x1 {
        if (x - x0) % 8 < 5 {
            img.put(x, y, c);
        }
    }
}

/// Centre of the bounding box of `points` and the largest distance from it.
fn bounds(points: &[Point3<f64>]) -> (Point3<f64>, f64) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let c = Point3::from((lo + hi) * 0.5);
    let r = points.iter().map(|p| (p - c).norm()).fold(0.0f64, f64::max);
    (c, r.max(1e-6))
}

/// An orthographic camera looking along `dir` at `centre`, `px_per_mm`
/// pixels per millimetre in an image `height` pixels high.
fn ortho(
    centre: Point3<f64>,
    radius: f64,
    dir: Vector3<f64>,
    up: Vector3<f64>,
    px_per_mm: f64,
    height: u32,
) -> Result<Camera, RenderError> {
    let f = dir.normalize();
    Camera::orthographic(
        centre - f * (4.0 * radius),
        centre,
        up,
        0.5 * f64::from(height) / px_per_mm,
    )
}

// ---------------------------------------------------------------------------
// Mesh views (sides, log2 det J)

/// How the boundary is coloured.
enum Paint<'a> {
    /// By per-vertex `side` label, each triangle split into the three
    /// regions nearest its corners (no blending of categories).
    Sides(&'a [u8]),
    /// By a per-tet value on a colour scale.
    Cells {
        values: &'a [f64],
        scale: ColorScale,
    },
}

/// The colour of a `side` label.
fn side_color(label: u8) -> Rgb {
    SIDE_COLORS
        .get(usize::from(label))
        .copied()
        .unwrap_or(OTHER_LABEL_COLOR)
}

/// The boundary split for categorical colours: every triangle whose corners
/// differ in label becomes six triangles (corner, edge midpoint, centroid),
/// each coloured by its corner's label.
fn categorical_mesh(
    positions: &[Point3<f64>],
    tris: &[[u32; 3]],
    labels: &[u8],
) -> (Vec<Point3<f64>>, Vec<[u32; 3]>, Vec<Rgb>) {
    let mut p = Vec::with_capacity(3 * tris.len());
    let mut t = Vec::with_capacity(tris.len());
    let mut c = Vec::with_capacity(tris.len());
    for tri in tris {
        let idx = tri.map(|v| v as usize);
        let l = idx.map(|v| labels[v]);
        let q = idx.map(|v| positions[v]);
        let base = p.len() as u32;
        if l[0] == l[1] && l[1] == l[2] {
            p.extend_from_slice(&q);
            t.push([base, base + 1, base + 2]);
            c.push(side_color(l[0]));
            continue;
        }
        let mid = |a: usize, b: usize| Point3::from((q[a].coords + q[b].coords) * 0.5);
        let g = Point3::from((q[0].coords + q[1].coords + q[2].coords) / 3.0);
        // 0, 1, 2: corners; 3: m01, 4: m12, 5: m20; 6: centroid.
        p.extend_from_slice(&q);
        p.extend_from_slice(&[mid(0, 1), mid(1, 2), mid(2, 0), g]);
        let sub = [
            (0, [0, 3, 6]),
            (0, [0, 6, 5]),
            (1, [1, 4, 6]),
            (1, [1, 6, 3]),
            (2, [2, 5, 6]),
            (2, [2, 6, 4]),
        ];
        for (corner, s) in sub {
            t.push(s.map(|k| base + k));
            c.push(side_color(l[corner]));
        }
    }
    (p, t, c)
}

/// View directions in the template frame: (direction, up, subtitle). The
/// second is the first turned half a turn about x (the placenta flipped
/// over like a page), so the near rim is at the bottom in both.
const VIEWS: [([f64; 3], [f64; 3], &str); 2] = [
    (
        [0.25, 0.6, -1.0],
        [0.0, 0.0, 1.0],
        "seen from the fetal side",
    ),
    (
        [0.25, -0.6, 1.0],
        [0.0, 0.0, -1.0],
        "seen from the maternal side",
    ),
];

/// Titles of the mesh views' columns.
const TITLES: [&str; 2] = ["original (scanner frame)", "flattened (template frame)"];

/// Light for the mesh views: shape visible, colours still readable.
const MESH_LIGHT: Lighting = Lighting {
    ambient: 0.45,
    diffuse: 0.55,
};

/// Width of the legend / colour bar strip on the right of the right-hand
/// mesh panels.
fn strip_width(opts: &FigureOptions) -> u32 {
    (opts.panel_width / 4).clamp(100, 140)
}

/// The 2 x 2 mesh views: columns original, flattened; rows from the fetal
/// side, from the maternal side.
fn mesh_views(
    m: &Meshes<'_>,
    paint: &Paint<'_>,
    opts: &FigureOptions,
    name: &str,
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    let strip = strip_width(opts);
    let area_h = ph - TITLE_BAND - 4;
    let (co, ro) = bounds(m.original);
    let (cf, rf) = bounds(m.flattened);
    let radius = ro.max(rf);
    let px_per_mm = f64::from((pw - strip).min(area_h)) / (2.0 * radius * 1.04);
    let inverse = m.rotation.inverse();

    // The coloured meshes (same for both views).
    let coloured = |positions: &[Point3<f64>]| match paint {
        Paint::Sides(labels) => categorical_mesh(positions, &m.tris, labels),
        Paint::Cells { values, scale } => {
            let colors = m
                .face_tet
                .iter()
                .map(|&t| {
                    values
                        .get(t as usize)
                        .map_or(NAN_COLOR, |&v| scale.color(v))
                })
                .collect();
            (positions.to_vec(), m.tris.clone(), colors)
        }
    };
    let meshes = [
        (coloured(m.original), co, true),
        (coloured(m.flattened), cf, false),
    ];

    let ts = title_scale(opts, &TITLES);
    let mut panels = Vec::with_capacity(4);
    for (row, (dir, up, subtitle)) in VIEWS.iter().enumerate() {
        let (dir, up) = (Vector3::from(*dir), Vector3::from(*up));
        for (col, ((pos, tris, colors), centre, is_original)) in meshes.iter().enumerate() {
            let title = TITLES[usize::from(!*is_original)];
            let mut img = panel_scaled(opts, title, subtitle, ts).map_err(err(name))?;
            let aw = if col == 1 { pw - strip } else { pw };
            let (d, u) = if *is_original {
                (inverse * dir, inverse * up)
            } else {
                (dir, up)
            };
            let cam = ortho(*centre, radius, d, u, px_per_mm, area_h).map_err(err(name))?;
            let mut r = Renderer::new(aw - 2, area_h, PAPER, cam).map_err(err(name))?;
            r.set_lighting(MESH_LIGHT);
            r.draw_mesh(pos, tris, Coloring::PerTriangle(colors), Shading::Flat)
                .map_err(err(name))?;
            if !*is_original {
                axis_triad(&mut r, 34.0, f64::from(area_h) - 34.0).map_err(err(name))?;
            }
            img.blit(r.image(), 1, i64::from(TITLE_BAND));
            if col == 1 {
                let x0 = (pw - strip) as i32;
                let y0 = TITLE_BAND as i32 + 6;
                match (paint, row) {
                    (Paint::Sides(labels), 0) => side_legend(&mut img, m, labels, x0, y0),
                    (Paint::Sides(labels), _) => side_counts(&mut img, m, labels, x0, y0),
                    (Paint::Cells { scale, .. }, 0) => {
                        let h = (area_h - 12).min(260);
                        colour_bar(
                            &mut img,
                            Rect::new(x0 + 6, y0, strip - 10, h),
                            scale,
                            "log2 det J",
                            true,
                        )
                    }
                    (Paint::Cells { values, scale }, _) => {
                        det_j_notes(&mut img, values, scale, x0, y0, strip)
                    }
                }
                .map_err(err(name))?;
            }
            panels.push(img);
        }
    }
    compose(&panels, 2, opts).map_err(err(name))
}

/// The template axes as a small triad at pixel `(x, y)` of the renderer's
/// image (projected by its camera).
fn axis_triad(r: &mut Renderer, x: f64, y: f64) -> Result<(), RenderError> {
    let cam = *r.camera();
    let img = r.image_mut();
    let len = 24.0;
    for (axis, name) in [
        (Vector3::x(), "x"),
        (Vector3::y(), "y"),
        (Vector3::z(), "z"),
    ] {
        let (dx, dy) = (axis.dot(&cam.right()), -axis.dot(&cam.up()));
        let (ex, ey) = (x + len * dx, y + len * dy);
        img.line([x, y], [ex, ey], INK);
        let n = dx.hypot(dy);
        if n > 0.2 {
            let (lx, ly) = (ex + 8.0 * dx / n, ey + 8.0 * dy / n);
            img.draw_text(lx as i32, (ly - 4.0) as i32, name, 1, INK, Anchor::Center)?;
        } else {
            // Along the view direction: a dot with the name beside it.
            img.draw_text(
                (x + 6.0) as i32,
                (y + 4.0) as i32,
                name,
                1,
                INK,
                Anchor::Left,
            )?;
        }
    }
    Ok(())
}

/// The labels present on the boundary, in order.
fn boundary_labels(m: &Meshes<'_>, labels: &[u8]) -> BTreeSet<u8> {
    m.tris
        .iter()
        .flat_map(|t| t.iter().map(|&v| labels[v as usize]))
        .collect()
}

/// The legend of the side colours (labels on the boundary only).
fn side_legend(
    img: &mut Image,
    m: &Meshes<'_>,
    labels: &[u8],
    x0: i32,
    y0: i32,
) -> Result<(), RenderError> {
    img.draw_text(x0 + 6, y0, "side", 2, INK, Anchor::Left)?;
    let mut y = y0 + 26;
    for l in boundary_labels(m, labels) {
        let name = SIDE_NAMES
            .get(usize::from(l))
            .map_or_else(|| format!("label {l}"), |s| s.to_string());
        img.fill_rect(Rect::new(x0 + 6, y, 14, 14), side_color(l).opaque());
        img.stroke_rect(Rect::new(x0 + 6, y, 14, 14), INK);
        img.draw_text(x0 + 26, y + 3, &name, 1, INK, Anchor::Left)?;
        y += 22;
    }
    Ok(())
}

/// Boundary vertex counts per side.
fn side_counts(
    img: &mut Image,
    m: &Meshes<'_>,
    labels: &[u8],
    x0: i32,
    y0: i32,
) -> Result<(), RenderError> {
    let mut on_boundary = vec![false; labels.len()];
    for t in &m.tris {
        for &v in t {
            on_boundary[v as usize] = true;
        }
    }
    img.draw_text(x0 + 6, y0, "boundary", 1, INK, Anchor::Left)?;
    img.draw_text(x0 + 6, y0 + 11, "vertices:", 1, INK, Anchor::Left)?;
    let mut y = y0 + 30;
    for l in boundary_labels(m, labels) {
        let n = labels
            .iter()
            .zip(&on_boundary)
            .filter(|(x, b)| **x == l && **b)
            .count();
        let name = SIDE_NAMES
            .get(usize::from(l))
            .map_or_else(|| format!("label {l}"), |s| s.to_string());
        img.fill_rect(Rect::new(x0 + 6, y, 8, 8), side_color(l).opaque());
        img.draw_text(x0 + 18, y, &format!("{name} {n}"), 1, INK, Anchor::Left)?;
        y += 14;
    }
    Ok(())
}

/// How to read `log2 det J`, and its summary.
fn det_j_notes(
    img: &mut Image,
    values: &[f64],
    scale: &ColorScale,
    x0: i32,
    y0: i32,
    strip: u32,
) -> Result<(), RenderError> {
    let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let beyond = values
        .iter()
        .filter(|v| !v.is_finite() || v.abs() > scale.hi)
        .count();
    let mut lines = vec![
        "tet volume:".to_string(),
        " 0 kept".into(),
        "+1 doubled".into(),
        "-1 halved".into(),
        String::new(),
    ];
    if let (Some(p5), Some(p50), Some(p95)) = (
        percentile(&sorted, 0.05),
        percentile(&sorted, 0.5),
        percentile(&sorted, 0.95),
    ) {
        lines.push(format!("5%: {}", format_value(p5)));
        lines.push(format!("50%: {}", format_value(p50)));
        lines.push(format!("95%: {}", format_value(p95)));
    }
    if beyond > 0 {
        lines.push(String::new());
        lines.push(format!("{beyond} tets:"));
        lines.push(format!("|v| > {},", format_value(scale.hi)));
        lines.push("end colours".into());
    }
    for (k, line) in lines.iter().enumerate() {
        text_fit(
            img,
            x0 + 6,
            y0 + 12 * k as i32,
            line,
            1,
            strip - 8,
            Anchor::Left,
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Profile

/// The aligned original and the flattened mesh seen along the template's y
/// axis (x right, z up), same scale, the template's levels (`z = +-h`)
/// dashed behind the meshes.
fn profile(m: &Meshes<'_>, depths: &Depths, opts: &FigureOptions) -> Result<Image, FigureError> {
    let name = PROFILE_FIGURE;
    let err = FigureError::render;
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    let bottom = 46;
    let area_h = ph - TITLE_BAND - bottom;
    let area_w = pw - 2;
    // Room on each side for the level names.
    let side_room = 40.0;
    let mid = depths.z(0.0);
    let extent = |pos: &[Point3<f64>]| {
        pos.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
        )
    };
    let meshes = [
        (&m.aligned[..], "original, rigidly aligned"),
        (m.flattened, "flattened"),
    ];
    let boxes = meshes.map(|(pos, _)| extent(pos));
    // One scale for both: the wider mesh fills the width, the farthest
    // point from the middle level (or the levels) fits the height.
    let span_x = boxes
        .iter()
        .map(|(lo, hi)| hi.x - lo.x)
        .fold(1e-6, f64::max);
    let reach_z = boxes
        .iter()
        .flat_map(|(lo, hi)| [(hi.z - mid).abs(), (lo.z - mid).abs()])
        .fold(0.5 * (depths.top - depths.bottom).abs(), f64::max)
        .max(1e-6);
    let px_per_mm = ((f64::from(area_w) - 2.0 * side_room) / (1.02 * span_x))
        .min((0.5 * f64::from(area_h) - 12.0).max(1.0) / (1.05 * reach_z));
    let ts = title_scale(opts, &meshes.map(|m| m.1));
    let mut panels = Vec::with_capacity(2);
    for ((pos, title), (lo, hi)) in meshes.into_iter().zip(boxes) {
        let mut img =
            panel_scaled(opts, title, "view along y (x right, z up)", ts).map_err(err(name))?;
        let centre = Point3::from((lo + hi) * 0.5);
        let target = Point3::new(centre.x, centre.y, mid);
        let radius = (hi - lo).norm().max(1e-6);
        let cam = ortho(
            target,
            radius,
            Vector3::y(),
            Vector3::z(),
            px_per_mm,
            area_h,
        )
        .map_err(err(name))?;
        let mut r = Renderer::new(area_w, area_h, PAPER, cam).map_err(err(name))?;
        // The levels first: the mesh covers them where it reaches them.
        let wr = i64::from(area_w);
        for (z, label, above) in [
            (depths.top, depths.names[0], true),
            (depths.bottom, depths.names[1], false),
        ] {
            let Some(p) = r.project(&Point3::new(centre.x, centre.y, z)) else {
                continue;
            };
            let y = p.y.floor() as i64;
            if (0..i64::from(area_h)).contains(&y) {
                let img = r.image_mut();
                dashed(img, 0, wr - 1, y, GUIDE);
                let ty = if above { y - 10 } else { y + 3 };
                img.draw_text(3, ty as i32, label, 1, GUIDE, Anchor::Left)
                    .map_err(err(name))?;
                img.draw_text(wr as i32 - 3, ty as i32, label, 1, GUIDE, Anchor::Right)
                    .map_err(err(name))?;
            }
        }
        r.draw_mesh(
            pos,
            &m.tris,
            Coloring::Uniform(PROFILE_COLOR),
            Shading::Unlit,
        )
        .map_err(err(name))?;
        img.blit(r.image(), 1, i64::from(TITLE_BAND));
        // Scale bar and extents.
        let bar = nice_length(0.25 * f64::from(pw) / px_per_mm);
        scale_bar(
            &mut img,
            12.0,
            f64::from(ph - bottom) + 20.0,
            bar,
            px_per_mm,
        )
        .map_err(err(name))?;
        for (k, line) in [
            format!("x extent {} mm", format_value(hi.x - lo.x)),
            format!("z extent {} mm", format_value(hi.z - lo.z)),
        ]
        .iter()
        .enumerate()
        {
            text_fit(
                &mut img,
                (pw - 8) as i32,
                (ph - bottom + 8 + 12 * k as u32) as i32,
                line,
                1,
                pw.saturating_sub(90),
                Anchor::Right,
            )
            .map_err(err(name))?;
        }
        text_fit(
            &mut img,
            (pw / 2) as i32,
            (ph - 11) as i32,
            &format!(
                "dashed: {}, {}; {}",
                depths.names[0], depths.names[1], depths.label
            ),
            1,
            pw - 8,
            Anchor::Center,
        )
        .map_err(err(name))?;
        panels.push(img);
    }
    compose(&panels, 2, opts).map_err(err(name))
}

// ---------------------------------------------------------------------------
// Distortion histograms

/// Histograms of the three distortion measures.
fn distortion(m: &Meshes<'_>, opts: &FigureOptions) -> Result<Image, FigureError> {
    let name = DISTORTION_FIGURE;
    let err = FigureError::render;
    let (o, f) = (m.original, m.flattened);
    let edge_ratio: Vec<f64> = edges(m.tets)
        .iter()
        .map(|&[a, b]| {
            let (a, b) = (a as usize, b as usize);
            ((f[a] - f[b]).norm() / (o[a] - o[b]).norm()).log2()
        })
        .collect();
    let area = |p: &[Point3<f64>], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(&(c - a)).norm()
    };
    let area_ratio: Vec<f64> = m
        .tris
        .iter()
        .map(|t| (area(f, t) / area(o, t)).log2())
        .collect();
    let measures: [(&str, &str, &[f64], &str); 3] = [
        ("log2 det J", "per tet; bars: tets", &m.log2_det_j, "tets"),
        (
            "log2 edge ratio",
            "flat / original length; bars: edges",
            &edge_ratio,
            "edges",
        ),
        (
            "log2 area ratio",
            "per boundary triangle; bars: triangles",
            &area_ratio,
            "triangles",
        ),
    ];
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    let mut panels = Vec::with_capacity(3);
    let ts = title_scale(opts, &measures.map(|m| m.0));
    for (title, subtitle, values, unit) in measures {
        let mut img = panel_scaled(opts, title, subtitle, ts).map_err(err(name))?;
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let half = ceil_2(sorted.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-3));
        let n = sorted.len();
        let mean = if n > 0 {
            sorted.iter().sum::<f64>() / n as f64
        } else {
            f64::NAN
        };
        let sd = if n > 1 {
            (sorted.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let p = |q| percentile(&sorted, q).map_or("-".into(), format_value);
        let mut lines = vec![
            format!("n = {} {unit}", values.len()),
            format!("mean {}   sd {}", format_value(mean), format_value(sd)),
            format!("median {}", p(0.5)),
            format!("5% to 95%: {} to {}", p(0.05), p(0.95)),
        ];
        if values.len() > n {
            lines.push(format!("{} non-finite (inverted)", values.len() - n));
        }
        let stats_h = 12 * lines.len() as u32 + 4;
        let rect = Rect::new(
            10,
            TITLE_BAND as i32 + 4,
            pw - 20,
            ph - TITLE_BAND - 8 - stats_h,
        );
        let style = HistogramStyle {
            bar: HISTOGRAM_COLOR,
            ..HistogramStyle::default()
        };
        draw_histogram(&mut img, rect, values, 41, Some((-half, half)), "", &style)
            .map_err(err(name))?;
        // The zero line and its label (the layout of draw_histogram: plot
        // columns axis_x + 1 ..= right - 1, the axis 12 rows above the bottom).
        let lh = i64::from(text_height(1));
        let axis_x = i64::from(rect.x) + 1;
        let plot_w = rect.right() - 1 - axis_x;
        let x_zero = axis_x + 1 + plot_w / 2;
        let plot_top = i64::from(rect.y) + lh + 2;
        let axis_y = rect.bottom() - 1 - lh - 3;
        for y in plot_top..axis_y {
            if (y - plot_top) % 6 < 3 {
                img.put(x_zero, y, GUIDE);
            }
        }
        img.draw_text(
            x_zero as i32,
            (axis_y + 3) as i32,
            "0",
            1,
            INK,
            Anchor::Center,
        )
        .map_err(err(name))?;
        let y0 = (ph - stats_h) as i32;
        for (k, line) in lines.iter().enumerate() {
            text_fit(
                &mut img,
                (pw / 2) as i32,
                y0 + 12 * k as i32,
                line,
                1,
                pw - 8,
                Anchor::Center,
            )
            .map_err(err(name))?;
        }
        panels.push(img);
    }
    compose(&panels, 3, opts).map_err(err(name))
}

// ---------------------------------------------------------------------------
// Depth slices

/// Frame 0 of `vol` at world point `p`: the trilinear interpolation over the
/// corner voxels that hold data (finite and non-zero), renormalized; `None`
/// when those carry less than half the weight (outside the mesh) or `p` is
/// more than half a voxel outside the grid.
fn sample_masked(vol: &Volume<f32>, p: &Point3<f64>) -> Option<f64> {
    let v = vol.world_to_voxel(p);
    let d = vol.dims();
    let mut base = [0usize; 3];
    let mut frac = [0.0f64; 3];
    for a in 0..3 {
        let n = d[a];
        let x = v[a];
        if !x.is_finite() || x < -0.5 || x > n as f64 - 0.5 {
            return None;
        }
        if n == 1 {
            continue;
        }
        let x = x.clamp(0.0, (n - 1) as f64);
        base[a] = (x.floor() as usize).min(n - 2);
        frac[a] = x - base[a] as f64;
    }
    let (mut acc, mut wsum) = (0.0, 0.0);
    for corner in 0..8usize {
        let mut w = 1.0;
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let up = (corner >> a) & 1 == 1;
            if d[a] == 1 {
                if up {
                    w = 0.0;
                }
                continue;
            }
            idx[a] = base[a] + usize::from(up);
            w *= if up { frac[a] } else { 1.0 - frac[a] };
        }
        if w <= 0.0 {
            continue;
        }
        if let Some(x) = vol.get(idx[0], idx[1], idx[2], 0) {
            let x = f64::from(x);
            if x.is_finite() && x != 0.0 {
                acc += w * x;
                wsum += w;
            }
        }
    }
    (wsum >= 0.5).then(|| acc / wsum)
}

/// Five slices of constant template `z` of one image and a colour bar panel.
fn depth_slices(
    img: &FlatImage<'_>,
    m: &Meshes<'_>,
    depths: &Depths,
    opts: &FigureOptions,
    name: &str,
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    let bottom = 34;
    let (ax, ay) = (8u32, TITLE_BAND);
    let (aw, ah) = (pw - 2 * ax, ph - TITLE_BAND - bottom);
    // The flattened mesh's x-y extent, with a small margin, fills the area.
    let (lo, hi) = m.flattened.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let (cx, cy) = (0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
    let (ex, ey) = (
        (hi.x - lo.x).max(1e-6) * 1.04,
        (hi.y - lo.y).max(1e-6) * 1.04,
    );
    let s = (f64::from(aw) / ex).min(f64::from(ah) / ey);
    let (w2, h2) = (0.5 * f64::from(aw), 0.5 * f64::from(ah));
    let mut slices: Vec<Vec<Option<f64>>> = Vec::with_capacity(DEPTH_FRACTIONS.len());
    let mut all = Vec::new();
    for &f in &DEPTH_FRACTIONS {
        let z = depths.z(f);
        let mut vals = Vec::with_capacity((aw * ah) as usize);
        for j in 0..ah {
            let y = cy - (f64::from(j) + 0.5 - h2) / s;
            for i in 0..aw {
                let x = cx + (f64::from(i) + 0.5 - w2) / s;
                let v = sample_masked(img.volume, &Point3::new(x, y, z));
                if let Some(v) = v {
                    all.push(v);
                }
                vals.push(v);
            }
        }
        slices.push(vals);
    }
    if all.is_empty() {
        let d = img.volume.dims();
        return Err(FigureError::input(
            name,
            format!(
                "the image {:?} ({}x{}x{} voxels) has no non-zero voxel in the flattened \
                 mesh's slab (template x in [{}, {}], y in [{}, {}], z in [{}, {}] mm); \
                 is it a pulled-back image (<name>_flat.nii.gz, template frame)?",
                img.name,
                d[0],
                d[1],
                d[2],
                format_value(lo.x),
                format_value(hi.x),
                format_value(lo.y),
                format_value(hi.y),
                format_value(depths.bottom),
                format_value(depths.top),
            ),
        ));
    }
    all.sort_by(f64::total_cmp);
    let (vlo, vhi) = (
        percentile(&all, 0.01).unwrap_or(0.0),
        percentile(&all, 0.99).unwrap_or(1.0),
    );
    let scale = ColorScale::new(Colormap::Viridis, vlo, vhi);
    let bar = nice_length(0.3 * f64::from(aw) / s);

    let mut panels = Vec::with_capacity(6);
    for (k, (&f, vals)) in DEPTH_FRACTIONS.iter().zip(&slices).enumerate() {
        let z = depths.z(f);
        let title = format!("z = {} mm", signed(z));
        let subtitle = format!(
            "depth {}% from the fetal side",
            format_value(50.0 * (1.0 - f))
        );
        let mut p = panel(opts, &title, &subtitle).map_err(err(name))?;
        for j in 0..ah {
            for i in 0..aw {
                if let Some(v) = vals[(j * aw + i) as usize] {
                    p.put(
                        i64::from(ax + i),
                        i64::from(ay + j),
                        scale.color(v).opaque(),
                    );
                }
            }
        }
        p.stroke_rect(
            Rect::new(ax as i32 - 1, ay as i32 - 1, aw + 2, ah + 2),
            PANEL_EDGE,
        );
        scale_bar(&mut p, f64::from(ax) + 4.0, f64::from(ph) - 10.0, bar, s).map_err(err(name))?;
        if k == 0 {
            // Orientation: template x to the right, y up.
            let (ox, oy) = (f64::from(pw) - 40.0, f64::from(ph) - 6.0);
            let l = 20.0;
            p.line([ox, oy], [ox + l, oy], INK);
            p.line([ox + l, oy], [ox + l - 4.0, oy - 3.0], INK);
            p.line([ox + l, oy], [ox + l - 4.0, oy + 3.0], INK);
            p.line([ox, oy], [ox, oy - l], INK);
            p.line([ox, oy - l], [ox - 3.0, oy - l + 4.0], INK);
            p.line([ox, oy - l], [ox + 3.0, oy - l + 4.0], INK);
            p.draw_text(
                (ox + l + 4.0) as i32,
                (oy - 4.0) as i32,
                "x",
                1,
                INK,
                Anchor::Left,
            )
            .map_err(err(name))?;
            p.draw_text(
                (ox + 6.0) as i32,
                (oy - l) as i32,
                "y",
                1,
                INK,
                Anchor::Left,
            )
            .map_err(err(name))?;
        }
        panels.push(p);
    }

    // The colour bar panel.
    let mut p = panel(opts, img.name, "pulled back into the template").map_err(err(name))?;
    let frames = img.volume.frames();
    let [fetal, maternal] = depths.describe();
    let mut notes = vec![
        "slices of constant template z".to_string(),
        fetal,
        maternal,
        depths.label.clone(),
        "white: outside the mesh".into(),
        "colours: 1-99th percentile".into(),
    ];
    if frames > 1 {
        notes.push(format!("frame 1 of {frames}"));
    }
    let mut y = TITLE_BAND as i32 + 4;
    for line in &notes {
        text_fit(&mut p, (pw / 2) as i32, y, line, 1, pw - 8, Anchor::Center).map_err(err(name))?;
        y += 12;
    }
    let bar_top = y + 8;
    let bar_h = (ph as i32 - bar_top - 10).max(40) as u32;
    colour_bar(
        &mut p,
        Rect::new((pw / 2) as i32 - 40, bar_top, 120, bar_h),
        &scale,
        "intensity",
        false,
    )
    .map_err(err(name))?;
    panels.push(p);
    compose(&panels, 6, opts).map_err(err(name))
}
