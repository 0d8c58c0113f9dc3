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
//!   ([`NAN_COLOR`](unfold_render::NAN_COLOR)) and marked `n/a`.
//!   The right panel holds the colour bar and a table (segment, name,
//!   points, mean).
//! - [`DISK_AHA_PNG`] (2 x 1 panels): S flattened (the displayed disk
//!   `outcome.disk`), each triangle in the [`AHA_COLORS`] colour of the
//!   segment of its centroid (the rule the pipeline uses for anatomy
//!   points, [`aha_segment`](unfold_organs::ventricle::aha::aha_segment) on the displayed disk), a light wireframe (when
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
//! - [`ANATOMY_AHA_PNG`] (3 x 1 panels): the anatomy in the scanner frame
//!   coloured by AHA segment, seen from the septum and from the lateral
//!   wall (base up), and the legend (`anatomy.rs`, [`heart_view`]).
//!
//! With a transfer, [`transfer_figure`] makes [`TRANSFER_PNG`]: the anatomy
//! beside its image in the second heart or on the hemisphere, in the same
//! colours (AHA for the LV, depth for the RV).
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
//!
//! One file per figure family: the bull's-eye (`bullseye.rs`), the disk
//! figures (`disk.rs`), the cylinder (`cylinder.rs`), the anatomy in 3D
//! (`anatomy.rs`); beside them the AHA
//! segments (`segments.rs`), where the disk drawings sit (`disk_layout.rs`)
//! and the drawing helpers the figures share (`drawing.rs`). Text layout is
//! [`crate::figures::layout`]'s.

use unfold_organs::ventricle::{Chamber, Outcome};
use unfold_render::{Colormap, Rgb, Rgba};

use super::{Figure, FigureError, FigureOptions};

mod anatomy;
mod bullseye;
mod cylinder;
mod disk;
mod disk_layout;
mod drawing;
mod grid_sweep;
mod segments;
mod sensitivity;

pub use anatomy::{ANATOMY_AHA_PNG, HeartView, TRANSFER_PNG, heart_view, transfer_figure};
use bullseye::bullseye;
pub use bullseye::{Bullseye, bullseye_figure};
use cylinder::cylinder;
use disk::{disk_aha, disk_angle};
pub use disk_layout::{DiskLayout, bullseye_layout, disk_layout};
pub use grid_sweep::{GRID_SWEEP_PNG, GridPoint, grid_sweep_plot};
pub use segments::{SegmentMean, SegmentShape, segment_centre, segment_means, segment_shape};
pub use sensitivity::{SENSITIVITY_COLORMAP, SENSITIVITY_PNG, sensitivity_figure};

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

pub(super) const SOFT_INK: Rgba = Rgba::new(90, 90, 90, 255);

/// Height of the title band (a title at text scale 2 and up to two lines
/// of subtitle).
pub(super) const TITLE_BAND: i64 = 52;

/// Width of the column holding a colour bar at the right of a panel.
pub(super) const COLORBAR_COLUMN: i64 = 112;

/// Width a colour bar's heading lines wrap at, pixels (the column less a
/// margin).
pub(crate) const COLORBAR_HEADING_PX: u32 = COLORBAR_COLUMN as u32 - 8;

/// The ventricle figures of `outcome` (see the module documentation):
/// LV `[bullseye.png, disk_aha.png, cylinder.png, anatomy_aha.png]`, RV
/// `[disk_angle.png, cylinder.png]`.
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
                anatomy::anatomy_aha(outcome, opts)?,
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

/// The AHA segments that label at least one point, ascending.
pub(super) fn segments_present(aha: &[u8]) -> Vec<u8> {
    let mut seen = [false; 256];
    for &l in aha {
        seen[l as usize] = true;
    }
    (0..=255u8).filter(|&l| seen[l as usize]).collect()
}

fn chamber_name(c: Chamber) -> &'static str {
    match c {
        Chamber::Lv => "LV",
        Chamber::Rv => "RV",
    }
}

/// Checks the panel size and returns the figure size of `cols x rows`
/// panels.
pub(super) fn figure_size(
    opts: &FigureOptions,
    cols: u32,
    rows: u32,
) -> Result<(u32, u32), FigureError> {
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
