//! Ventricle figures (issue 8; ALGORITHMS 3.2, 3.6): the AHA 17-segment
//! bull's-eye, the flattened surface coloured by AHA label, and the anatomy
//! in the cylinder.
//!
//! [`figures`] returns, for the LV:
//!
//! - [`BULLSEYE_PNG`] (2 panels wide, 1 high): the bull's-eye in the
//!   clinical orientation (anterior up, septum left, segments numbered
//!   counter-clockwise on screen from the anterior one), each segment filled
//!   with the mean of a per-anatomy-point value over the anatomy points
//!   labelled with it (default: the depth `d`, 0 on S, 1 on H) on
//!   [`BULLSEYE_COLORMAP`] from the smallest to the largest segment mean;
//!   segments without a point (or without a finite value) are grey
//!   ([`NAN_COLOR`]) and marked `n/a`.
//!   The right panel holds the colour bar and a table (segment, name,
//!   points, mean).
//! - [`DISK_AHA_PNG`] (2 x 1 panels): S flattened (the displayed disk
//!   `outcome.disk`), each triangle in the [`AHA_COLORS`] colour of the
//!   segment of its centroid (the rule the pipeline uses for anatomy
//!   points, [`aha_segment`] on the displayed disk), a light wireframe (when
//!   the triangles cover 16 pixels or more on average), the
//!   unit circle, the two RV insertion points and the apex, in the same
//!   clinical orientation as the bull's-eye (mirrored from the disk's own
//!   axes: `+xi`, the septum, points left); the right panel is the legend.
//! - [`CYLINDER_PNG`] (1 x 1 panel): the anatomy in the cylinder
//!   (`outcome.normalized`, points `(X, Y, d)`), an oblique orthographic
//!   view from the S side (30 degrees off the disk plane; depth runs down
//!   the picture, so that the disk appears as in the bull's-eye, anterior
//!   up and septal left), coloured by depth on [`DEPTH_COLORMAP`] from the
//!   smallest to the largest depth present (the colour bar gives the
//!   range); drawn as its surface cells and the boundary faces of its
//!   volume cells (smooth shading), its line cells as coloured segments,
//!   and its other points as 5-pixel squares; the cylinder's outline (the
//!   unit circle at depth 0 and 1, the silhouette edges), depth-tested, and
//!   the orientation words.
//!
//! For the RV there is no AHA labelling, hence no bull's-eye (and a `value`
//! array is an error); [`figures`] returns
//!
//! - [`DISK_ANGLE_PNG`] (1 x 1 panel): the half disk in its own axes (the
//!   septal edge `x = 1.25` on the left, the first septal corner `(1.25, 1)`
//!   up), each triangle coloured by the angle of its centroid about the
//!   circle's centre `(1.25, 0)`, `atan2(y, x - 1.25)` in degrees from -90
//!   (second corner) to +90 (first corner), on [`ANGLE_COLORMAP`] (0: the
//!   middle of the free wall; per triangle because the angle is singular at
//!   the middle of the septal edge), a light wireframe, the corners and the
//!   apex;
//! - [`CYLINDER_PNG`]: as for the LV in the half cylinder, but seen from
//!   the H side with depth up the picture, so that the half disk appears in
//!   its own axes (septal edge left, first corner up).
//!
//! The layouts of the disk drawings are exposed ([`bullseye_layout`],
//! [`disk_layout`], [`segment_centre`]) so that tests and callers can find
//! a segment's pixels.

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use unfold_mesh::{CellMesh, CellType};
use unfold_organs::ventricle::aha::aha_segment;
use unfold_organs::ventricle::disk::RV_CENTRE;
use unfold_organs::ventricle::{Chamber, Outcome};
use unfold_render::nalgebra::{Point3, Vector3};
use unfold_render::{
    Anchor, Camera, ColorScale, Coloring, Colormap, FillRule, Image, NAN_COLOR, Projection, Rect,
    Renderer, Rgb, Rgba, Shading, annular_sector, arc, draw_colorbar, format_value, text_width,
};

use super::{Figure, FigureError, FigureOptions};

/// File name of the LV bull's-eye.
pub const BULLSEYE_PNG: &str = "bullseye.png";
/// File name of the LV disk coloured by AHA segment.
pub const DISK_AHA_PNG: &str = "disk_aha.png";
/// File name of the RV half disk coloured by angle.
pub const DISK_ANGLE_PNG: &str = "disk_angle.png";
/// File name of the anatomy in the cylinder.
pub const CYLINDER_PNG: &str = "cylinder.png";

/// Colour map of the bull's-eye: segment means from the smallest (`t = 0`)
/// to the largest (`t = 1`).
pub const BULLSEYE_COLORMAP: Colormap = Colormap::Viridis;

/// Colour map of the depth in [`CYLINDER_PNG`]: the smallest depth present
/// at `t = 0`, the largest at `t = 1`.
pub const DEPTH_COLORMAP: Colormap = Colormap::Viridis;

/// Colour map of the RV half disk's angle, `[-90, 90]` degrees.
pub const ANGLE_COLORMAP: Colormap = Colormap::PurpleOrange;

/// The categorical colour of AHA segment `k` (index `k - 1`): one hue per
/// wall (anterior blue, anteroseptal orange, inferoseptal green, inferior
/// red, inferolateral purple, anterolateral brown), dark for the basal
/// segments 1-6 and light for the mid segments 7-12 (Tableau 20); the
/// apical segments 13-16 and the apex 17 in four more hues. All 17 differ,
/// and none is grey.
pub const AHA_COLORS: [Rgb; 17] = [
    Rgb::new(0x1f, 0x77, 0xb4),
    Rgb::new(0xff, 0x7f, 0x0e),
    Rgb::new(0x2c, 0xa0, 0x2c),
    Rgb::new(0xd6, 0x27, 0x28),
    Rgb::new(0x94, 0x67, 0xbd),
    Rgb::new(0x8c, 0x56, 0x4b),
    Rgb::new(0xae, 0xc7, 0xe8),
    Rgb::new(0xff, 0xbb, 0x78),
    Rgb::new(0x98, 0xdf, 0x8a),
    Rgb::new(0xff, 0x98, 0x96),
    Rgb::new(0xc5, 0xb0, 0xd5),
    Rgb::new(0xc4, 0x9c, 0x94),
    Rgb::new(0xe3, 0x77, 0xc2),
    Rgb::new(0x17, 0xbe, 0xcf),
    Rgb::new(0xbc, 0xbd, 0x22),
    Rgb::new(0xf7, 0xb6, 0xd2),
    Rgb::new(0x9e, 0xda, 0xe5),
];

/// The AHA names of segments 1..=17 (index `k - 1`).
pub const AHA_NAMES: [&str; 17] = [
    "basal anterior",
    "basal anteroseptal",
    "basal inferoseptal",
    "basal inferior",
    "basal inferolateral",
    "basal anterolateral",
    "mid anterior",
    "mid anteroseptal",
    "mid inferoseptal",
    "mid inferior",
    "mid inferolateral",
    "mid anterolateral",
    "apical anterior",
    "apical septal",
    "apical inferior",
    "apical lateral",
    "apex",
];

/// Smallest panel accepted, pixels (width, height): below it the text no
/// longer fits.
pub const MIN_PANEL: (u32, u32) = (200, 160);

const INK: Rgba = Rgba::BLACK;
const PAPER: Rgba = Rgba::WHITE;
const SOFT_INK: Rgba = Rgba::new(90, 90, 90, 255);
/// Height of the title band (a title at text scale 2 and up to two lines
/// of subtitle).
const TITLE_BAND: i64 = 52;

/// Where a drawing of the (displayed) disk sits in a figure: the disk point
/// `origin` is drawn at pixel `centre`, `scale` pixels per disk unit,
/// mirrored (`+xi` to the left: the clinical orientation of the LV) or not.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskLayout {
    /// Pixel coordinates (x right, y down) of `origin`.
    pub centre: [f64; 2],
    /// Pixels per unit of the disk.
    pub scale: f64,
    /// The disk point drawn at `centre`: `(0, 0)` for the LV, `(1.75, 0)`
    /// (the middle of the half disk) for the RV.
    pub origin: [f64; 2],
    /// Whether `+xi` points left (LV: septum left, anterior `+zeta` up).
    pub mirrored: bool,
}

impl DiskLayout {
    /// The pixel of disk point `uv`: `x = c_x + m scale (u - o_u)` with
    /// `m = -1` when mirrored and `+1` otherwise, `y = c_y - scale (v -
    /// o_v)`.
    pub fn pixel(&self, uv: [f64; 2]) -> [f64; 2] {
        let sx = if self.mirrored { -1.0 } else { 1.0 };
        [
            self.centre[0] + sx * self.scale * (uv[0] - self.origin[0]),
            self.centre[1] - self.scale * (uv[1] - self.origin[1]),
        ]
    }

    /// The screen angle (as in [`arc`]: counter-clockwise on screen, 0
    /// pointing right) of disk angle `a` (radians from `+xi` towards
    /// `+zeta`).
    fn screen_angle(&self, a: f64) -> f64 {
        if self.mirrored { PI - a } else { a }
    }
}

/// Where a segment lies on the displayed LV disk: radii `r0 <= r < r1` and
/// disk angles `a0 <= a < a1` in degrees (from `+xi`, the septum, towards
/// `+zeta`, anterior; `a1` may exceed 360), as [`aha_segment`] labels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentShape {
    /// Inner radius (0 for the apex).
    pub r0: f64,
    /// Outer radius.
    pub r1: f64,
    /// First angle, degrees.
    pub a0: f64,
    /// Last angle, degrees.
    pub a1: f64,
}

/// The shape of AHA segment `segment` (1..=17) on the displayed LV disk;
/// `None` for other numbers.
pub fn segment_shape(segment: u8) -> Option<SegmentShape> {
    // Basal sectors by segment 1..6: [60,120) 1, [0,60) 2, [300,360) 3,
    // [240,300) 4, [180,240) 5, [120,180) 6.
    const BASAL_START: [f64; 6] = [60.0, 0.0, 300.0, 240.0, 180.0, 120.0];
    // Apical 13 anterior [45,135), 14 septal [315,405), 15 inferior
    // [225,315), 16 lateral [135,225).
    const APICAL_START: [f64; 4] = [45.0, 315.0, 225.0, 135.0];
    let s = |r0, r1, a0: f64, span: f64| SegmentShape {
        r0,
        r1,
        a0,
        a1: a0 + span,
    };
    match segment {
        1..=6 => Some(s(0.75, 1.0, BASAL_START[segment as usize - 1], 60.0)),
        7..=12 => Some(s(0.5, 0.75, BASAL_START[segment as usize - 7], 60.0)),
        13..=16 => Some(s(0.25, 0.5, APICAL_START[segment as usize - 13], 90.0)),
        17 => Some(s(0.0, 0.25, 0.0, 360.0)),
        _ => None,
    }
}

/// The middle of AHA segment `segment` on the displayed LV disk (mid
/// radius, mid angle; the origin for the apex), where its number is
/// written; `None` for numbers outside 1..=17.
pub fn segment_centre(segment: u8) -> Option<[f64; 2]> {
    let s = segment_shape(segment)?;
    if segment == 17 {
        return Some([0.0, 0.0]);
    }
    let r = 0.5 * (s.r0 + s.r1);
    let a = (0.5 * (s.a0 + s.a1)).to_radians();
    Some([r * a.cos(), r * a.sin()])
}

/// The value of one AHA segment in the bull's-eye.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SegmentMean {
    /// Anatomy points labelled with the segment.
    pub points: usize,
    /// Mean of their finite values; `None` when there is none.
    pub mean: Option<f64>,
}

/// Per-segment means of `values` over the points labelled `aha` (1..=17;
/// other labels and non-finite values are skipped). `aha` and `values`
/// are zipped (the shorter decides).
pub fn segment_means(aha: &[u8], values: &[f64]) -> [SegmentMean; 17] {
    let mut sum = [0.0f64; 17];
    let mut finite = [0usize; 17];
    let mut out = [SegmentMean::default(); 17];
    for (&a, &v) in aha.iter().zip(values) {
        if !(1..=17).contains(&a) {
            continue;
        }
        let k = a as usize - 1;
        out[k].points += 1;
        if v.is_finite() {
            sum[k] += v;
            finite[k] += 1;
        }
    }
    for k in 0..17 {
        if finite[k] > 0 {
            out[k].mean = Some(sum[k] / finite[k] as f64);
        }
    }
    out
}

/// Checks the panel size and returns the figure size of `cols x rows`
/// panels.
fn figure_size(opts: &FigureOptions, cols: u32, rows: u32) -> Result<(u32, u32), FigureError> {
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    if pw < MIN_PANEL.0 || ph < MIN_PANEL.1 {
        return Err(FigureError::input(
            "ventricle figures",
            format!(
                "panel {pw}x{ph} is smaller than {}x{} pixels",
                MIN_PANEL.0, MIN_PANEL.1
            ),
        ));
    }
    match (pw.checked_mul(cols), ph.checked_mul(rows)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(FigureError::input(
            "ventricle figures",
            format!("panel {pw}x{ph} times {cols}x{rows} is too large"),
        )),
    }
}

/// The layout of the bull's-eye in [`BULLSEYE_PNG`] (left panel, below the
/// title, room for the orientation words around it): mirrored, origin
/// `(0, 0)`, `scale` its radius in pixels.
pub fn bullseye_layout(opts: &FigureOptions) -> Result<DiskLayout, FigureError> {
    figure_size(opts, 2, 1)?;
    let (pw, ph) = (f64::from(opts.panel_width), f64::from(opts.panel_height));
    let top = TITLE_BAND as f64;
    // "anterior" above and "inferior" below: a text line and a gap each;
    // "septal" and "lateral" beside it.
    let r = (0.5 * (ph - top - 2.0 * 16.0 - 6.0))
        .min(0.5 * (pw - 2.0 * (8.0 * 7.0 + 10.0)))
        .floor();
    // The centre at a pixel centre, so that horizontal and vertical
    // borders fall on one row or column.
    Ok(DiskLayout {
        centre: [(0.5 * pw).floor() + 0.5, top + 16.0 + r + 0.5],
        scale: r,
        origin: [0.0, 0.0],
        mirrored: true,
    })
}

/// The layout of the disk in [`DISK_AHA_PNG`] (LV: mirrored, origin
/// `(0, 0)`, `scale` the unit circle's radius in pixels) or
/// [`DISK_ANGLE_PNG`] (RV: not mirrored, origin `(1.75, 0)`, the half disk
/// 1 wide and 2 high). The drawing area of the left panel below the title
/// is rendered with an orthographic camera centred on `origin`, so this is
/// exactly where the renderer puts the disk.
pub fn disk_layout(chamber: Chamber, opts: &FigureOptions) -> Result<DiskLayout, FigureError> {
    let (w, h) = disk_area(chamber, opts)?;
    let (w, h) = (f64::from(w), f64::from(h));
    let top = TITLE_BAND as f64;
    let (scale, origin, mirrored) = match chamber {
        // Room for the orientation words and the landmark labels.
        Chamber::Lv => (
            (0.5 * w - 8.0 * 9.0).min(0.5 * h - 22.0).floor(),
            [0.0, 0.0],
            true,
        ),
        // The half disk spans 1 x 2 units; labels left and right.
        Chamber::Rv => (
            (0.5 * h - 22.0).min(w - 2.0 * 8.0 * 11.0).floor(),
            [RV_CENTRE[0] + 0.5, RV_CENTRE[1]],
            false,
        ),
    };
    Ok(DiskLayout {
        centre: [0.5 * w, top + 0.5 * h],
        scale,
        origin,
        mirrored,
    })
}

/// The size of the rendered area of the disk figure (below the title band;
/// LV: the left panel, RV: the panel without the colour bar column).
fn disk_area(chamber: Chamber, opts: &FigureOptions) -> Result<(u32, u32), FigureError> {
    let cols = if chamber == Chamber::Lv { 2 } else { 1 };
    figure_size(opts, cols, 1)?;
    let h = opts.panel_height - TITLE_BAND as u32;
    let w = match chamber {
        Chamber::Lv => opts.panel_width,
        Chamber::Rv => opts.panel_width - COLORBAR_COLUMN as u32,
    };
    // Odd sides put the camera's centre at a pixel centre.
    Ok((w - 1 + w % 2, h - 1 + h % 2))
}

/// Width of the column holding a colour bar at the right of a panel.
const COLORBAR_COLUMN: i64 = 112;

/// The ventricle figures of `outcome` (see the module documentation):
/// LV `[bullseye.png, disk_aha.png, cylinder.png]`, RV `[disk_angle.png,
/// cylinder.png]`.
///
/// `value` is an optional per-anatomy-point array `(name, values)` for the
/// bull's-eye (one value per point of `outcome.normalized`, i.e. of the
/// anatomy); `None` shows the depth. Each figure is a whole number of
/// `opts` panels (bull's-eye and LV disk 2 x 1, the others 1 x 1).
///
/// # Errors
/// [`FigureError::Input`] when `chamber` is not the outcome's, `value` has
/// the wrong length (the message gives both lengths) or is given for the
/// RV, the outcome's arrays disagree in length, or the panel is smaller
/// than [`MIN_PANEL`]; [`FigureError::Render`] when the renderer refuses
/// something (e.g. non-finite coordinates).
pub fn figures(
    outcome: &Outcome,
    chamber: Chamber,
    value: Option<(&str, &[f64])>,
    opts: &FigureOptions,
) -> Result<Vec<Figure>, FigureError> {
    if chamber != outcome.report.chamber {
        return Err(FigureError::input(
            "ventricle figures",
            format!(
                "the outcome is of the {}, the figures were asked for the {}",
                chamber_name(outcome.report.chamber),
                chamber_name(chamber)
            ),
        ));
    }
    figure_size(opts, 2, 1)?;
    let n = outcome.normalized.positions.len();
    match chamber {
        Chamber::Lv => {
            let depth: Vec<f64>;
            let (name, values, default) = match value {
                Some((name, v)) => (name, v, false),
                None => {
                    depth = outcome.coords.iter().map(|c| c.depth).collect();
                    ("depth", &depth[..], true)
                }
            };
            if values.len() != n {
                return Err(FigureError::input(
                    BULLSEYE_PNG,
                    format!(
                        "the value `{name}` has {} entries, the anatomy has {n} points",
                        values.len()
                    ),
                ));
            }
            if outcome.aha.len() != n {
                return Err(FigureError::input(
                    BULLSEYE_PNG,
                    format!(
                        "the outcome has {} AHA labels for {n} anatomy points",
                        outcome.aha.len()
                    ),
                ));
            }
            Ok(vec![
                bullseye(outcome, name, values, default, opts)?,
                disk_aha(outcome, opts)?,
                cylinder(outcome, chamber, opts)?,
            ])
        }
        Chamber::Rv => {
            if let Some((name, _)) = value {
                return Err(FigureError::input(
                    "ventricle figures",
                    format!(
                        "the value `{name}` is shown on the LV bull's-eye; the RV has no AHA \
                         segments"
                    ),
                ));
            }
            Ok(vec![
                disk_angle(outcome, opts)?,
                cylinder(outcome, chamber, opts)?,
            ])
        }
    }
}

fn chamber_name(c: Chamber) -> &'static str {
    match c {
        Chamber::Lv => "LV",
        Chamber::Rv => "RV",
    }
}

/// Draws `text` at the largest scale (2 or 1) at which it fits in
/// `max_width`, centred at `x`; returns the scale used.
fn title(
    img: &mut Image,
    figure: &str,
    x: i64,
    y: i64,
    text: &str,
    max_width: i64,
) -> Result<u32, FigureError> {
    let scale = if i64::from(text_width(text, 2)) <= max_width {
        2
    } else {
        1
    };
    img.draw_text(x as i32, y as i32, text, scale, INK, Anchor::Center)
        .map_err(FigureError::render(figure))?;
    Ok(scale)
}

/// The title band of a figure: a title and a subtitle, centred.
fn title_band(
    img: &mut Image,
    figure: &str,
    heading: &str,
    subtitle: &str,
) -> Result<(), FigureError> {
    let w = i64::from(img.width());
    title(img, figure, w / 2, 6, heading, w - 12)?;
    let chars = ((w - 12) / 8).max(8) as usize;
    for (k, line) in wrap(subtitle, chars).iter().take(2).enumerate() {
        text(
            img,
            figure,
            w / 2,
            27 + 11 * k as i64,
            line,
            SOFT_INK,
            Anchor::Center,
        )?;
    }
    Ok(())
}

/// Text at scale 1.
fn text(
    img: &mut Image,
    figure: &str,
    x: i64,
    y: i64,
    s: &str,
    ink: Rgba,
    anchor: Anchor,
) -> Result<Rect, FigureError> {
    img.draw_text(clamp32(x), clamp32(y), s, 1, ink, anchor)
        .map_err(FigureError::render(figure))
}

fn clamp32(v: i64) -> i32 {
    v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// Splits `s` into lines of at most `width` characters at spaces (a longer
/// word stays whole).
fn wrap(s: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in s.split_whitespace() {
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// A colour bar in the column `x .. x + COLORBAR_COLUMN` from `y0` to
/// `y1`, under the title lines `heading` (scale 1, centred on the column).
fn colorbar_column(
    img: &mut Image,
    figure: &str,
    x: i64,
    y0: i64,
    y1: i64,
    scale: &ColorScale,
    heading: &[String],
) -> Result<(), FigureError> {
    let mut y = y0;
    for line in heading {
        text(
            img,
            figure,
            x + COLORBAR_COLUMN / 2,
            y,
            line,
            INK,
            Anchor::Center,
        )?;
        y += 11;
    }
    y += 4;
    let h = (y1 - y).max(40);
    draw_colorbar(
        img,
        Rect::new(
            clamp32(x + 16),
            clamp32(y),
            (COLORBAR_COLUMN - 20) as u32,
            h as u32,
        ),
        scale,
        "",
        INK,
        1,
    )
    .map_err(FigureError::render(figure))
}

/// Ink that reads on `fill`.
fn ink_on(fill: Rgb) -> Rgba {
    if fill.luminance() > 0.45 { INK } else { PAPER }
}

/// A filled disk of radius `r` about `c` (a marker).
fn dot(img: &mut Image, c: [f64; 2], r: f64, fill: Rgba) {
    img.fill_polygon(&arc(c, r, 0.0, TAU), FillRule::NonZero, fill);
}

/// The four orientation words around an LV disk drawn with `layout`
/// (radius `layout.scale`): anterior (`+zeta`) up, inferior down, septal
/// (`+xi`) and lateral beside it, on the sides the layout puts them.
fn orientation_words(
    img: &mut Image,
    figure: &str,
    layout: &DiskLayout,
) -> Result<(), FigureError> {
    let at = |u: f64, v: f64| layout.pixel([u, v]);
    let top = at(0.0, 1.0);
    text(
        img,
        figure,
        top[0] as i64,
        (top[1] - 14.0) as i64,
        "anterior",
        INK,
        Anchor::Center,
    )?;
    let bottom = at(0.0, -1.0);
    text(
        img,
        figure,
        bottom[0] as i64,
        (bottom[1] + 6.0) as i64,
        "inferior",
        INK,
        Anchor::Center,
    )?;
    let septal = at(1.0, 0.0);
    let lateral = at(-1.0, 0.0);
    for (p, word) in [(septal, "septal"), (lateral, "lateral")] {
        let left = p[0] < layout.centre[0];
        let (x, anchor) = if left {
            (p[0] - 6.0, Anchor::Right)
        } else {
            (p[0] + 7.0, Anchor::Left)
        };
        text(
            img,
            figure,
            x as i64,
            (p[1] - 4.0) as i64,
            word,
            INK,
            anchor,
        )?;
    }
    Ok(())
}

/// The outline of segment `segment` on a disk drawn with `layout`.
fn segment_outline(layout: &DiskLayout, segment: u8) -> Vec<[f64; 2]> {
    let Some(s) = segment_shape(segment) else {
        return Vec::new();
    };
    let c = layout.centre;
    let r = layout.scale;
    if segment == 17 {
        return arc(c, s.r1 * r, 0.0, TAU);
    }
    let (b0, b1) = (
        layout.screen_angle(s.a0.to_radians()),
        layout.screen_angle(s.a1.to_radians()),
    );
    let (b0, b1) = if b0 <= b1 { (b0, b1) } else { (b1, b0) };
    annular_sector(c, s.r0 * r, s.r1 * r, b0, b1)
}

/// [`BULLSEYE_PNG`].
fn bullseye(
    outcome: &Outcome,
    name: &str,
    values: &[f64],
    default: bool,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = BULLSEYE_PNG;
    let (w, h) = figure_size(opts, 2, 1)?;
    let layout = bullseye_layout(opts)?;
    let means = segment_means(&outcome.aha, values);
    let finite: Vec<f64> = means.iter().filter_map(|m| m.mean).collect();
    let scale = ColorScale::from_values(BULLSEYE_COLORMAP, &finite);
    let fill = |m: &SegmentMean| m.mean.map_or(NAN_COLOR, |v| scale.color(v));
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    let shown = if default {
        "depth (0 = S, 1 = H)".to_string()
    } else {
        name.to_string()
    };
    title_band(
        &mut img,
        F,
        &format!("LV bull's-eye: mean {shown} per AHA segment"),
        "anterior up, septum left; numbers: AHA segments; grey: no value",
    )?;
    // Fills, then borders, then numbers.
    for seg in 1..=17u8 {
        let poly = segment_outline(&layout, seg);
        img.fill_polygon(
            &poly,
            FillRule::NonZero,
            fill(&means[seg as usize - 1]).opaque(),
        );
    }
    for seg in 1..=17u8 {
        img.polyline(&segment_outline(&layout, seg), true, INK);
    }
    let outer = arc(layout.centre, layout.scale + 1.0, 0.0, TAU);
    img.polyline(&outer, true, INK);
    let ts = if layout.scale >= 120.0 { 2 } else { 1 };
    for seg in 1..=17u8 {
        let m = &means[seg as usize - 1];
        let Some(c) = segment_centre(seg) else {
            continue;
        };
        let p = layout.pixel(c);
        let ink = ink_on(fill(m));
        let th = 8.0 * f64::from(ts);
        let y = if m.mean.is_some() {
            p[1] - 0.5 * th
        } else {
            p[1] - 0.5 * th - 5.0
        };
        img.draw_text(
            p[0].round() as i32,
            y.round() as i32,
            &seg.to_string(),
            ts,
            ink,
            Anchor::Center,
        )
        .map_err(FigureError::render(F))?;
        if m.mean.is_none() {
            text(
                &mut img,
                F,
                p[0].round() as i64,
                (y + th + 2.0).round() as i64,
                "n/a",
                ink,
                Anchor::Center,
            )?;
        }
    }
    orientation_words(&mut img, F, &layout)?;

    // Right panel: colour bar and table.
    let x0 = i64::from(opts.panel_width);
    let top = TITLE_BAND + 4;
    let bottom = i64::from(h) - 12;
    let mut heading = vec!["segment mean".to_string()];
    if default {
        heading.extend(["depth".to_string(), "(0 = S, 1 = H)".to_string()]);
    } else {
        heading.extend(wrap(name, 13));
    }
    colorbar_column(&mut img, F, x0, top, bottom, &scale, &heading)?;
    let tx = x0 + COLORBAR_COLUMN + 4;
    let avail = i64::from(w) - 6 - tx;
    let with_names = avail >= 14 + 24 + 8 * 21 + 8 * 7 + 8 * 8;
    let row_h = ((bottom - top) / 20).clamp(9, 16);
    let mut y = top;
    let right = i64::from(w) - 6;
    text(&mut img, F, tx, y, "seg", INK, Anchor::Left)?;
    if with_names {
        text(&mut img, F, tx + 38, y, "name", INK, Anchor::Left)?;
    }
    text(&mut img, F, right - 8 * 9, y, "points", INK, Anchor::Right)?;
    text(&mut img, F, right, y, "mean", INK, Anchor::Right)?;
    y += row_h + 2;
    for seg in 1..=17u8 {
        let m = &means[seg as usize - 1];
        let sw = (row_h - 5).clamp(6, 10);
        img.fill_rect(
            Rect::new(clamp32(tx), clamp32(y - 1), sw as u32, sw as u32),
            fill(m).opaque(),
        );
        img.stroke_rect(
            Rect::new(clamp32(tx), clamp32(y - 1), sw as u32, sw as u32),
            INK,
        );
        text(
            &mut img,
            F,
            tx + 14 + 16,
            y,
            &seg.to_string(),
            INK,
            Anchor::Right,
        )?;
        if with_names {
            text(
                &mut img,
                F,
                tx + 38,
                y,
                AHA_NAMES[seg as usize - 1],
                INK,
                Anchor::Left,
            )?;
        }
        let mean = m.mean.map_or("n/a".to_string(), format_value);
        text(&mut img, F, right, y, &mean, INK, Anchor::Right)?;
        text(
            &mut img,
            F,
            right - 8 * 9,
            y,
            &m.points.to_string(),
            INK,
            Anchor::Right,
        )?;
        y += row_h;
    }
    y += 4;
    let total: usize = means.iter().map(|m| m.points).sum();
    text(
        &mut img,
        F,
        tx,
        y,
        &format!("{total} anatomy points"),
        SOFT_INK,
        Anchor::Left,
    )?;
    Ok(Figure {
        name: F.to_string(),
        image: img,
    })
}

/// An orthographic renderer of a `w x h` area showing the disk plane
/// `z = 0` as `layout` says (centre of the area = `layout.origin`).
fn disk_renderer(
    layout: &DiskLayout,
    w: u32,
    h: u32,
) -> Result<Renderer, unfold_render::RenderError> {
    let target = Point3::new(layout.origin[0], layout.origin[1], 0.0);
    // Looking along +z mirrors (right = -x); along -z does not.
    let f = if layout.mirrored {
        Vector3::z()
    } else {
        -Vector3::z()
    };
    let half_height = 0.5 * f64::from(h) / layout.scale;
    let cam = Camera::orthographic(target - 4.0 * f, target, Vector3::y(), half_height)?;
    Renderer::new(w, h, PAPER, cam)
}

/// How far the wireframe of a disk is moved from the fill colour towards
/// white.
const WIRE_TINT: f64 = 0.25;

/// Whether a disk of `area` (disk units) cut into `triangles` triangles
/// drawn at `scale` pixels per unit gets a wireframe: when its triangles
/// cover 16 pixels or more on average (smaller ones would turn the fill
/// into the wire colour).
fn show_wireframe(area: f64, triangles: usize, scale: f64) -> bool {
    area * scale * scale >= 16.0 * triangles as f64
}

/// A landmark marker: a black dot with a white rim.
fn landmark_marker(img: &mut Image, p: [f64; 2]) {
    dot(img, p, 5.0, PAPER);
    dot(img, p, 4.0, INK);
}

/// The apex marker: a cross in a white square.
fn apex_marker(img: &mut Image, p: [f64; 2]) {
    img.fill_rect(Rect::new(p[0] as i32 - 5, p[1] as i32 - 5, 11, 11), PAPER);
    for d in [-0.5, 0.5] {
        img.line([p[0] - 5.0, p[1] + d], [p[0] + 5.0, p[1] + d], INK);
        img.line([p[0] + d, p[1] - 5.0], [p[0] + d, p[1] + 5.0], INK);
    }
}

/// The disk positions of the landmarks: anterior (first), inferior
/// (second), apex.
fn landmark_positions(outcome: &Outcome) -> Option<[[f64; 2]; 3]> {
    let lm = outcome.chart.landmarks();
    let at = |v: u32| outcome.disk.positions.get(v as usize).map(|p| [p.x, p.y]);
    Some([
        at(*lm.rim.get(lm.anterior)?)?,
        at(*lm.rim.get(lm.inferior)?)?,
        at(lm.apex)?,
    ])
}

/// The `(x, y)` centroid of every triangle of `disk` (NaN where a vertex
/// index is out of range).
fn centroids(disk: &unfold_mesh::TriMesh) -> Vec<[f64; 2]> {
    disk.triangles
        .iter()
        .map(|t| {
            let mut c = [0.0; 2];
            for &v in t {
                let p = disk
                    .positions
                    .get(v as usize)
                    .map_or([f64::NAN; 2], |p| [p.x, p.y]);
                c[0] += p[0] / 3.0;
                c[1] += p[1] / 3.0;
            }
            c
        })
        .collect()
}

/// [`DISK_AHA_PNG`].
fn disk_aha(outcome: &Outcome, opts: &FigureOptions) -> Result<Figure, FigureError> {
    const F: &str = DISK_AHA_PNG;
    let (w, h) = figure_size(opts, 2, 1)?;
    let layout = disk_layout(Chamber::Lv, opts)?;
    let (aw, ah) = disk_area(Chamber::Lv, opts)?;
    let disk = &outcome.disk;
    let labels: Vec<u8> = centroids(disk).into_iter().map(aha_segment).collect();
    let color = |l: u8| {
        if (1..=17).contains(&l) {
            AHA_COLORS[l as usize - 1]
        } else {
            NAN_COLOR
        }
    };
    let colors: Vec<Rgb> = labels.iter().map(|&l| color(l)).collect();
    let mut r = disk_renderer(&layout, aw, ah).map_err(FigureError::render(F))?;
    r.draw_mesh(
        &disk.positions,
        &disk.triangles,
        Coloring::PerTriangle(&colors),
        Shading::Unlit,
    )
    .map_err(FigureError::render(F))?;
    // A light wireframe: each segment's edges in a paler shade of its
    // colour (unless the triangles are too small to show).
    let wire = show_wireframe(PI, disk.triangles.len(), layout.scale);
    for seg in (0..=17u8).filter(|_| wire) {
        let tris: Vec<[u32; 3]> = disk
            .triangles
            .iter()
            .zip(&labels)
            .filter(|(_, l)| **l == seg)
            .map(|(t, _)| *t)
            .collect();
        if tris.is_empty() {
            continue;
        }
        let c = color(seg).lerp(Rgb::WHITE, WIRE_TINT).opaque();
        r.draw_wireframe(&disk.positions, &tris, c)
            .map_err(FigureError::render(F))?;
    }
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    img.blit(r.image(), 0, TITLE_BAND);
    title_band(
        &mut img,
        F,
        "LV disk map of S by AHA segment",
        &format!(
            "displayed disk (r' = r^{}), anterior up, septum left",
            format_value(outcome.report.display_exponent)
        ),
    )?;
    let c = layout.centre;
    img.polyline(&arc(c, layout.scale + 0.5, 0.0, TAU), true, INK);
    // Segment numbers.
    let ts = if layout.scale >= 140.0 { 2 } else { 1 };
    for seg in 1..=17u8 {
        let Some(uv) = segment_centre(seg) else {
            continue;
        };
        // The apex marker is at the centre: 17 goes below it.
        let uv = if seg == 17 { [0.0, -0.14] } else { uv };
        let p = layout.pixel(uv);
        let th = 8.0 * f64::from(ts);
        img.draw_text(
            p[0].round() as i32,
            (p[1] - 0.5 * th).round() as i32,
            &seg.to_string(),
            ts,
            ink_on(AHA_COLORS[seg as usize - 1]),
            Anchor::Center,
        )
        .map_err(FigureError::render(F))?;
    }
    orientation_words(&mut img, F, &layout)?;
    if let Some([ant, inf, apex]) = landmark_positions(outcome) {
        for (uv, word) in [(ant, "ant. RV ins."), (inf, "inf. RV ins.")] {
            let p = layout.pixel(uv);
            landmark_marker(&mut img, p);
            // The label outside the circle, along the landmark's direction.
            let d = [p[0] - c[0], p[1] - c[1]];
            let n = d[0].hypot(d[1]).max(1e-9);
            let q = [
                c[0] + d[0] / n * (layout.scale + 10.0),
                c[1] + d[1] / n * (layout.scale + 10.0),
            ];
            let anchor = if d[0] < 0.0 {
                Anchor::Right
            } else {
                Anchor::Left
            };
            let dy = if d[1] < 0.0 { -10.0 } else { 2.0 };
            text(
                &mut img,
                F,
                q[0] as i64,
                (q[1] + dy) as i64,
                word,
                INK,
                anchor,
            )?;
        }
        apex_marker(&mut img, layout.pixel(apex));
    }
    // The disk's own axes, in a corner.
    axes_glyph(
        &mut img,
        F,
        [f64::from(aw) - 60.0, f64::from(h) - 14.0],
        layout.mirrored,
    )?;

    // Legend panel.
    let x0 = i64::from(opts.panel_width) + 8;
    let mut y = TITLE_BAND + 4;
    let row_h = ((i64::from(h) - y - 70) / 19).clamp(9, 16);
    let mut counts = [0usize; 18];
    for &l in &labels {
        counts[(l as usize).min(17)] += 1;
    }
    text(
        &mut img,
        F,
        x0,
        y,
        "AHA segment (triangles of S)",
        INK,
        Anchor::Left,
    )?;
    y += row_h + 2;
    for seg in 1..=17u8 {
        let sw = (row_h - 5).clamp(6, 10);
        let rect = Rect::new(clamp32(x0), clamp32(y - 1), sw as u32, sw as u32);
        img.fill_rect(rect, AHA_COLORS[seg as usize - 1].opaque());
        img.stroke_rect(rect, INK);
        text(
            &mut img,
            F,
            x0 + 14 + 16,
            y,
            &seg.to_string(),
            INK,
            Anchor::Right,
        )?;
        text(
            &mut img,
            F,
            x0 + 38,
            y,
            &format!("{} ({})", AHA_NAMES[seg as usize - 1], counts[seg as usize]),
            INK,
            Anchor::Left,
        )?;
        y += row_h;
    }
    y += 8;
    landmark_marker(&mut img, [x0 as f64 + 5.0, y as f64 + 4.0]);
    text(
        &mut img,
        F,
        x0 + 16,
        y,
        "RV insertion points (landmarks)",
        INK,
        Anchor::Left,
    )?;
    y += row_h + 2;
    apex_marker(&mut img, [x0 as f64 + 5.0, y as f64 + 4.0]);
    text(&mut img, F, x0 + 16, y, "apex", INK, Anchor::Left)?;
    y += row_h + 2;
    text(
        &mut img,
        F,
        x0,
        y,
        "label of each triangle: its centroid",
        SOFT_INK,
        Anchor::Left,
    )?;
    Ok(Figure {
        name: F.to_string(),
        image: img,
    })
}

/// A small glyph of the disk's axes `+xi` and `+zeta` with its origin at
/// `o` (pixels): `+zeta` up, `+xi` left when mirrored.
fn axes_glyph(
    img: &mut Image,
    figure: &str,
    o: [f64; 2],
    mirrored: bool,
) -> Result<(), FigureError> {
    let len = 26.0;
    let (ox, sx) = if mirrored {
        (o[0] + len + 4.0, -1.0)
    } else {
        (o[0], 1.0)
    };
    let tip_x = ox + sx * len;
    img.line([ox, o[1]], [tip_x, o[1]], SOFT_INK);
    img.line([tip_x, o[1]], [tip_x - sx * 4.0, o[1] - 3.0], SOFT_INK);
    img.line([tip_x, o[1]], [tip_x - sx * 4.0, o[1] + 3.0], SOFT_INK);
    img.line([ox, o[1]], [ox, o[1] - len], SOFT_INK);
    img.line([ox, o[1] - len], [ox - 3.0, o[1] - len + 4.0], SOFT_INK);
    img.line([ox, o[1] - len], [ox + 3.0, o[1] - len + 4.0], SOFT_INK);
    let xi_anchor = if mirrored {
        Anchor::Right
    } else {
        Anchor::Left
    };
    text(
        img,
        figure,
        (tip_x + sx * 3.0) as i64,
        (o[1] - 4.0) as i64,
        "xi",
        SOFT_INK,
        xi_anchor,
    )?;
    text(
        img,
        figure,
        ox as i64,
        (o[1] - len - 11.0) as i64,
        "zeta",
        SOFT_INK,
        Anchor::Center,
    )?;
    Ok(())
}

/// The angle of RV half-disk point `p` about the circle's centre, degrees.
fn rv_angle(p: [f64; 2]) -> f64 {
    (p[1] - RV_CENTRE[1])
        .atan2(p[0] - RV_CENTRE[0])
        .to_degrees()
}

/// [`DISK_ANGLE_PNG`].
fn disk_angle(outcome: &Outcome, opts: &FigureOptions) -> Result<Figure, FigureError> {
    const F: &str = DISK_ANGLE_PNG;
    let (w, h) = figure_size(opts, 1, 1)?;
    let layout = disk_layout(Chamber::Rv, opts)?;
    let (aw, ah) = disk_area(Chamber::Rv, opts)?;
    let disk = &outcome.disk;
    let scale = ColorScale::new(ANGLE_COLORMAP, -90.0, 90.0);
    // Per triangle, at its centroid: the angle is singular at the middle
    // of the septal edge, where vertex colours would smear.
    let angles: Vec<f64> = centroids(disk).into_iter().map(rv_angle).collect();
    let colors = scale.colors(&angles);
    let mut r = disk_renderer(&layout, aw, ah).map_err(FigureError::render(F))?;
    r.draw_mesh(
        &disk.positions,
        &disk.triangles,
        Coloring::PerTriangle(&colors),
        Shading::Unlit,
    )
    .map_err(FigureError::render(F))?;
    // A light wireframe: the edges of the triangles in each 5-degree band
    // in a paler shade of the band's colour (unless the triangles are too
    // small to show).
    let band = |a: f64| ((a + 90.0) / 5.0).floor().clamp(0.0, 35.0) as usize;
    let wire = show_wireframe(0.5 * PI, disk.triangles.len(), layout.scale);
    for b in (0..36).filter(|_| wire) {
        let tris: Vec<[u32; 3]> = disk
            .triangles
            .iter()
            .zip(&angles)
            .filter(|(_, a)| a.is_finite() && band(**a) == b)
            .map(|(t, _)| *t)
            .collect();
        if tris.is_empty() {
            continue;
        }
        let c = scale
            .color(-87.5 + 5.0 * b as f64)
            .lerp(Rgb::WHITE, WIRE_TINT);
        r.draw_wireframe(&disk.positions, &tris, c.opaque())
            .map_err(FigureError::render(F))?;
    }
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    img.blit(r.image(), 0, TITLE_BAND);
    title_band(
        &mut img,
        F,
        "RV half-disk map of S",
        "colour: angle about (1.25, 0) at each triangle's centroid",
    )?;
    // The outline: the half circle and the septal edge.
    let c = layout.pixel(RV_CENTRE);
    let half = arc(c, layout.scale + 0.5, -0.5 * PI, 0.5 * PI);
    img.polyline(&half, false, INK);
    let (a, b) = (
        layout.pixel([RV_CENTRE[0], 1.0]),
        layout.pixel([RV_CENTRE[0], -1.0]),
    );
    img.line([a[0] - 0.5, a[1]], [b[0] - 0.5, b[1]], INK);
    text(
        &mut img,
        F,
        (a[0] - 6.0) as i64,
        (c[1] - 4.0) as i64,
        "septal",
        INK,
        Anchor::Right,
    )?;
    text(
        &mut img,
        F,
        (a[0] - 6.0) as i64,
        (c[1] + 6.0) as i64,
        "edge",
        INK,
        Anchor::Right,
    )?;
    let fw = layout.pixel([RV_CENTRE[0] + 1.0, 0.0]);
    text(
        &mut img,
        F,
        (fw[0] + 6.0) as i64,
        (fw[1] - 4.0) as i64,
        "free",
        INK,
        Anchor::Left,
    )?;
    text(
        &mut img,
        F,
        (fw[0] + 6.0) as i64,
        (fw[1] + 6.0) as i64,
        "wall",
        INK,
        Anchor::Left,
    )?;
    if let Some([first, second, apex]) = landmark_positions(outcome) {
        for (uv, word, dy) in [
            (first, "septal corner 1", -14.0),
            (second, "septal corner 2", 6.0),
        ] {
            let p = layout.pixel(uv);
            landmark_marker(&mut img, p);
            text(
                &mut img,
                F,
                p[0] as i64,
                (p[1] + dy) as i64,
                word,
                INK,
                Anchor::Center,
            )?;
        }
        let p = layout.pixel(apex);
        apex_marker(&mut img, p);
        text(
            &mut img,
            F,
            (p[0] + 8.0) as i64,
            (p[1] + 4.0) as i64,
            "apex",
            INK,
            Anchor::Left,
        )?;
    }
    axes_glyph(
        &mut img,
        F,
        [f64::from(aw) - 60.0, f64::from(h) - 14.0],
        false,
    )?;
    let x0 = i64::from(w) - COLORBAR_COLUMN;
    let heading = vec![
        "angle (deg)".to_string(),
        "-90: corner 2".to_string(),
        "+90: corner 1".to_string(),
    ];
    colorbar_column(
        &mut img,
        F,
        x0,
        TITLE_BAND + 4,
        i64::from(h) - 12,
        &scale,
        &heading,
    )?;
    Ok(Figure {
        name: F.to_string(),
        image: img,
    })
}

/// What of the anatomy is drawn: triangles (surface cells, boundary faces
/// of volume cells), segments (line cells) and lone points.
#[derive(Debug, Default, PartialEq)]
struct Drawable {
    triangles: Vec<[u32; 3]>,
    segments: Vec<[u32; 2]>,
    points: Vec<u32>,
}

/// The faces of a volume cell (VTK point order).
fn cell_faces(t: CellType, vs: &[u32]) -> Vec<Vec<u32>> {
    let f = |idx: &[&[usize]]| -> Vec<Vec<u32>> {
        idx.iter()
            .map(|face| face.iter().map(|&i| vs[i]).collect())
            .collect()
    };
    match t {
        CellType::Tetra => f(&[&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[0, 3, 2]]),
        CellType::Hexahedron => f(&[
            &[0, 3, 2, 1],
            &[4, 5, 6, 7],
            &[0, 1, 5, 4],
            &[1, 2, 6, 5],
            &[2, 3, 7, 6],
            &[3, 0, 4, 7],
        ]),
        CellType::Wedge => f(&[
            &[0, 1, 2],
            &[3, 5, 4],
            &[0, 3, 4, 1],
            &[1, 4, 5, 2],
            &[2, 5, 3, 0],
        ]),
        CellType::Pyramid => f(&[
            &[0, 3, 2, 1],
            &[0, 1, 4],
            &[1, 2, 4],
            &[2, 3, 4],
            &[3, 0, 4],
        ]),
        _ => Vec::new(),
    }
}

/// The drawable parts of `mesh` (checked first): surface cells
/// fan-triangulated, the faces of volume cells that belong to one cell
/// only (the boundary), line cells as segments, and the points in none of
/// those as points. Deterministic: everything in cell order.
fn drawable(mesh: &CellMesh) -> Result<Drawable, String> {
    mesh.check().map_err(|e| e.to_string())?;
    let mut d = Drawable::default();
    let mut used = vec![false; mesh.positions.len()];
    let fan = |poly: &[u32], out: &mut Vec<[u32; 3]>| {
        for k in 1..poly.len().saturating_sub(1) {
            out.push([poly[0], poly[k], poly[k + 1]]);
        }
    };
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut count: HashMap<Vec<u32>, usize> = HashMap::new();
    for (t, vs) in mesh.cells() {
        match t.dimension() {
            3 => {
                for face in cell_faces(t, vs) {
                    let mut key = face.clone();
                    key.sort_unstable();
                    *count.entry(key).or_insert(0) += 1;
                    faces.push(face);
                }
            }
            2 => fan(vs, &mut d.triangles),
            1 => {
                for s in vs.windows(2) {
                    d.segments.push([s[0], s[1]]);
                }
            }
            _ => {}
        }
    }
    for face in faces {
        let mut key = face.clone();
        key.sort_unstable();
        if count.get(&key) == Some(&1) {
            fan(&face, &mut d.triangles);
        }
    }
    for t in &d.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    for s in &d.segments {
        for &v in s {
            used[v as usize] = true;
        }
    }
    // Volume cells' interior points are not drawn.
    for (t, vs) in mesh.cells() {
        if t.dimension() == 3 {
            for &v in vs {
                used[v as usize] = true;
            }
        }
    }
    d.points = (0..mesh.positions.len() as u32)
        .filter(|&v| !used[v as usize])
        .collect();
    Ok(d)
}

/// The cylinder's outline at depth `z`: the unit circle (LV) or the half
/// circle about [`RV_CENTRE`] closed by the septal edge (RV).
fn outline(chamber: Chamber, z: f64) -> Vec<Point3<f64>> {
    let n = 128;
    match chamber {
        Chamber::Lv => (0..n)
            .map(|k| {
                let a = TAU * k as f64 / n as f64;
                Point3::new(a.cos(), a.sin(), z)
            })
            .collect(),
        Chamber::Rv => (0..=n / 2)
            .map(|k| {
                let a = -0.5 * PI + PI * k as f64 / (n / 2) as f64;
                Point3::new(RV_CENTRE[0] + a.cos(), RV_CENTRE[1] + a.sin(), z)
            })
            .collect(),
    }
}

/// [`CYLINDER_PNG`].
fn cylinder(
    outcome: &Outcome,
    chamber: Chamber,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = CYLINDER_PNG;
    let (w, h) = figure_size(opts, 1, 1)?;
    let mesh = &outcome.normalized;
    if mesh.positions.is_empty() {
        return Err(FigureError::input(F, "the anatomy has no points"));
    }
    let d = drawable(mesh)
        .map_err(|e| FigureError::input(F, format!("the normalized anatomy: {e}")))?;
    let depth: Vec<f64> = mesh.positions.iter().map(|p| p.z).collect();
    let scale = ColorScale::from_values(DEPTH_COLORMAP, &depth);
    let colors = scale.colors(&depth);
    // The view, 30 degrees off the disk plane. LV: from the S side (the
    // camera on the depth < 0 side, looking along +zeta and +depth), depth
    // downwards, so that the disk appears as in the bull's-eye (anterior
    // up, septum left). RV: from above (the depth > 1 side), depth upwards,
    // the half disk as in its own axes (septal edge left, first corner up).
    let e = 30f64.to_radians();
    let (f, up) = match chamber {
        Chamber::Lv => (Vector3::new(0.0, e.cos(), e.sin()), -Vector3::z()),
        Chamber::Rv => (Vector3::new(0.0, e.cos(), -e.sin()), Vector3::z()),
    };
    let ring0 = outline(chamber, 0.0);
    let ring1 = outline(chamber, 1.0);
    let (aw, ah) = (
        (i64::from(w) - COLORBAR_COLUMN) as u32,
        (i64::from(h) - TITLE_BAND) as u32,
    );
    // Framed on the cylinder (the anatomy lies inside it): its width across
    // (2 or 1 units) with 64 pixels for labels on either side, its height
    // (2 sin e + cos e units) with 22 above and below.
    let (target, across) = match chamber {
        Chamber::Lv => (Point3::new(0.0, 0.0, 0.5), 2.0),
        Chamber::Rv => (Point3::new(RV_CENTRE[0] + 0.5, 0.0, 0.5), 1.0),
    };
    let px_per_unit = ((f64::from(aw) - 128.0) / across)
        .min((f64::from(ah) - 44.0) / (2.0 * e.sin() + e.cos()))
        .max(1.0);
    let cam = Camera::orthographic(
        target - 4.0 * f,
        target,
        up,
        0.5 * f64::from(ah) / px_per_unit,
    )
    .map_err(FigureError::render(F))?;
    let mut r = Renderer::new(aw, ah, PAPER, cam).map_err(FigureError::render(F))?;
    if !d.triangles.is_empty() {
        r.draw_mesh(
            &mesh.positions,
            &d.triangles,
            Coloring::PerVertex(&colors),
            Shading::Smooth,
        )
        .map_err(FigureError::render(F))?;
    }
    for s in &d.segments {
        let (a, b) = (s[0] as usize, s[1] as usize);
        let c = scale.color(0.5 * (depth[a] + depth[b])).opaque();
        r.draw_polyline_3d(&[mesh.positions[a], mesh.positions[b]], false, c)
            .map_err(FigureError::render(F))?;
    }
    if !d.points.is_empty() {
        // Squares facing the camera, 5 pixels wide, depth-tested.
        let px = match cam.projection() {
            Projection::Orthographic { half_height } => 2.0 * half_height / f64::from(ah),
            Projection::Perspective { .. } => 0.0,
        };
        let (ru, uu) = (cam.right() * 2.5 * px, cam.up() * 2.5 * px);
        let mut pos = Vec::with_capacity(4 * d.points.len());
        let mut tris = Vec::with_capacity(2 * d.points.len());
        let mut cols = Vec::with_capacity(2 * d.points.len());
        for &v in &d.points {
            let p = mesh.positions[v as usize];
            let b = pos.len() as u32;
            pos.extend([p - ru - uu, p + ru - uu, p + ru + uu, p - ru + uu]);
            tris.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
            cols.extend([colors[v as usize]; 2]);
        }
        r.draw_mesh(&pos, &tris, Coloring::PerTriangle(&cols), Shading::Unlit)
            .map_err(FigureError::render(F))?;
    }
    // The outline, depth-tested (hidden behind the anatomy): both rings and
    // the vertical edges of the wall's silhouette (and the RV's corners).
    let outline_ink = Rgba::new(60, 60, 60, 255);
    for ring in [&ring0, &ring1] {
        r.draw_polyline_3d(ring, true, outline_ink)
            .map_err(FigureError::render(F))?;
    }
    let verticals: Vec<[f64; 2]> = match chamber {
        Chamber::Lv => vec![[1.0, 0.0], [-1.0, 0.0]],
        Chamber::Rv => vec![
            [RV_CENTRE[0], 1.0],
            [RV_CENTRE[0], -1.0],
            [RV_CENTRE[0] + 1.0, 0.0],
        ],
    };
    for p in &verticals {
        r.draw_polyline_3d(
            &[Point3::new(p[0], p[1], 0.0), Point3::new(p[0], p[1], 1.0)],
            false,
            outline_ink,
        )
        .map_err(FigureError::render(F))?;
    }
    // Labels, placed from the projections (in figure pixels).
    let proj = |p: Point3<f64>| {
        r.project(&p)
            .map(|q| [q.x, q.y + TITLE_BAND as f64])
            .unwrap_or([f64::NAN; 2])
    };
    let mut labels: Vec<([f64; 2], String, Anchor)> = Vec::new();
    // Beside the vertical edges at mid height.
    let (left, right) = match chamber {
        Chamber::Lv => ("septal", "lateral"),
        Chamber::Rv => ("septal edge", "free wall"),
    };
    let (pl, pr) = match chamber {
        Chamber::Lv => (
            proj(Point3::new(1.0, 0.0, 0.5)),
            proj(Point3::new(-1.0, 0.0, 0.5)),
        ),
        Chamber::Rv => (
            proj(Point3::new(RV_CENTRE[0], 0.0, 0.5)),
            proj(Point3::new(RV_CENTRE[0] + 1.0, 0.0, 0.5)),
        ),
    };
    labels.push(([pl[0] - 6.0, pl[1] - 4.0], left.into(), Anchor::Right));
    labels.push(([pr[0] + 6.0, pr[1] - 4.0], right.into(), Anchor::Left));
    // Above the highest ring and below the lowest one.
    let (upper, lower) = if proj(ring0[0])[1] < proj(ring1[0])[1] {
        (0.0, 1.0)
    } else {
        (1.0, 0.0)
    };
    match chamber {
        Chamber::Lv => {
            let a = proj(Point3::new(0.0, 1.0, upper));
            labels.push(([a[0], a[1] - 13.0], "anterior".into(), Anchor::Center));
            let i = proj(Point3::new(0.0, -1.0, lower));
            labels.push(([i[0], i[1] + 5.0], "inferior".into(), Anchor::Center));
        }
        Chamber::Rv => {
            let a = proj(Point3::new(RV_CENTRE[0], 1.0, upper));
            labels.push(([a[0], a[1] - 13.0], "corner 1".into(), Anchor::Center));
            let i = proj(Point3::new(RV_CENTRE[0], -1.0, lower));
            labels.push(([i[0], i[1] + 5.0], "corner 2".into(), Anchor::Center));
        }
    }
    // The depth of each ring, right of it.
    for (ring, z, words) in [
        (&ring0, 0.0, ["depth 0", "(S)"]),
        (&ring1, 1.0, ["depth 1", "(H)"]),
    ] {
        let x = ring
            .iter()
            .map(|p| proj(*p)[0])
            .fold(f64::NEG_INFINITY, f64::max);
        let c = proj(Point3::new(target.x, 0.0, z));
        labels.push(([x + 6.0, c[1] - 9.0], words[0].into(), Anchor::Left));
        labels.push(([x + 6.0, c[1] + 2.0], words[1].into(), Anchor::Left));
    }
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    img.blit(r.image(), 0, TITLE_BAND);
    let (heading, sub) = match chamber {
        Chamber::Lv => (
            "LV anatomy in the cylinder",
            "across: displayed disk, down: depth; seen from the S side: anterior up, septum left",
        ),
        Chamber::Rv => (
            "RV anatomy in the cylinder",
            "across: half disk, up: depth; seen from above: septal edge left, corner 1 up",
        ),
    };
    title_band(&mut img, F, heading, sub)?;
    for (p, word, anchor) in labels {
        if p[0].is_finite() && p[1].is_finite() {
            text(&mut img, F, p[0] as i64, p[1] as i64, &word, INK, anchor)?;
        }
    }
    let x0 = i64::from(w) - COLORBAR_COLUMN;
    let heading = vec!["depth".to_string(), "(0 = S, 1 = H)".to_string()];
    colorbar_column(
        &mut img,
        F,
        x0,
        TITLE_BAND + 4,
        i64::from(h) - 12,
        &scale,
        &heading,
    )?;
    Ok(Figure {
        name: F.to_string(),
        image: img,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_render::nalgebra::Point3;

    #[test]
    fn segment_centres_carry_their_own_labels() {
        for seg in 1..=17u8 {
            let c = segment_centre(seg).unwrap();
            assert_eq!(aha_segment(c), seg, "segment {seg} at {c:?}");
        }
        assert!(segment_centre(0).is_none() && segment_centre(18).is_none());
    }

    #[test]
    fn the_layouts_put_anterior_up_and_the_lv_septum_left() {
        let opts = FigureOptions::default();
        for l in [
            bullseye_layout(&opts).unwrap(),
            disk_layout(Chamber::Lv, &opts).unwrap(),
        ] {
            let septum = l.pixel([1.0, 0.0]);
            let anterior = l.pixel([0.0, 1.0]);
            assert!(septum[0] < l.centre[0] && (septum[1] - l.centre[1]).abs() < 1e-9);
            assert!(anterior[1] < l.centre[1]);
        }
        let rv = disk_layout(Chamber::Rv, &opts).unwrap();
        assert!(rv.pixel([1.25, 0.0])[0] < rv.pixel([2.25, 0.0])[0]);
    }

    #[test]
    fn volume_cells_are_drawn_by_their_boundary_faces() {
        // Two tets sharing the face (1, 2, 3), a line and a lone point.
        let mut m = CellMesh::from_points(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(1.0, 1.0, 1.0),
            Point3::new(3.0, 0.0, 0.0),
            Point3::new(3.0, 1.0, 0.0),
            Point3::new(5.0, 5.0, 5.0),
        ]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        m.push_cell(CellType::Tetra, &[1, 2, 3, 4]);
        m.push_cell(CellType::Line, &[5, 6]);
        m.push_cell(CellType::Vertex, &[7]);
        let d = drawable(&m).unwrap();
        assert_eq!(d.triangles.len(), 6);
        let mut shared = [1u32, 2, 3];
        shared.sort_unstable();
        assert!(d.triangles.iter().all(|t| {
            let mut s = *t;
            s.sort_unstable();
            s != shared
        }));
        assert_eq!(d.segments, vec![[5, 6]]);
        assert_eq!(d.points, vec![7]);
        // A hexahedron: 6 quads, 12 triangles.
        let mut h = CellMesh::from_points(
            (0..8)
                .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64))
                .collect(),
        );
        h.push_cell(CellType::Hexahedron, &[0, 1, 3, 2, 4, 5, 7, 6]);
        assert_eq!(drawable(&h).unwrap().triangles.len(), 12);
        // Bad indices are an error, not a panic.
        let mut bad = CellMesh::from_points(vec![Point3::origin()]);
        bad.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(drawable(&bad).is_err());
    }

    #[test]
    fn segment_means_skip_unlabelled_points_and_non_finite_values() {
        let m = segment_means(&[1, 1, 2, 0, 17, 3], &[1.0, 3.0, f64::NAN, 5.0, 7.0, 2.0]);
        assert_eq!(
            m[0],
            SegmentMean {
                points: 2,
                mean: Some(2.0)
            }
        );
        assert_eq!(
            m[1],
            SegmentMean {
                points: 1,
                mean: None
            }
        );
        assert_eq!(m[16].mean, Some(7.0));
        assert_eq!(m[3], SegmentMean::default());
    }

    #[test]
    fn wrap_splits_at_spaces() {
        assert_eq!(
            wrap("wall thickness in mm", 10),
            vec!["wall", "thickness", "in mm"]
        );
        assert_eq!(wrap("", 10), Vec::<String>::new());
    }
}
