//! Figures of the mitral valve pipeline (ALGORITHMS 4.4 and 4.5): one
//! figure per map the pipeline writes, `map_<array>.png`.
//!
//! Every figure has two panels of [`FigureOptions`] size side by side (so it
//! is exactly `2 panel_width x panel_height`):
//!
//! - left, the 2D map (`valve2d`): an orthographic top view with `u` to the
//!   right and `v` up, in mm (the annulus along the top, the leaflets
//!   below), unlit colours; the annulus as a thick dark line
//!   ([`ANNULUS_COLOR`]), the rest of the leaflets' boundary in grey, a
//!   dashed vertical line at `u = 0` (the anterolateral commissure, where
//!   the ring is cut), the commissures named above the annulus (AL, PM,
//!   AL), the leaflets named below the map, a scale bar in mm and the
//!   valve's measurements;
//! - right, the 3D valve (`valve3d`) in perspective, seen from the atrium
//!   with the anterior leaflet up and the anterolateral commissure on the
//!   left (as in the surgeon's view), tilted by 20 degrees towards the
//!   anterior side so the posterior leaflet and the coaptation zone along
//!   its free edge face the viewer; smooth shading, the same colours, the
//!   annulus highlighted where visible, the commissures and leaflets named;
//!   and the legend: a colour bar (array name, unit, ticks, mean and range)
//!   or, for label maps, one swatch per label with its count where known.
//!
//! Label maps (leaflet, u intervals, checkerboard, Carpentier segments,
//! coaptation) use categorical colours and are drawn crisply: every
//! triangle is split into the three regions nearest its corners, each in
//! its corner's label colour, so no colour between two labels appears.
//! Continuous per-vertex maps are interpolated, per-triangle maps constant
//! per triangle. Colours follow ALGORITHMS 4.4 / 4.5: energies white at 2
//! and red at the source's thresholds (the area energy blue where the
//! triangle shrank, red where it grew), tenting white at <= -3 mm, yellow at
//! 0 and red at >= +3 mm, coaptation green (zone) / yellow (near) / white,
//! the anterior leaflet blue and the posterior red, the distance to the
//! other leaflet on viridis.
//!
//! One file per idea: the checked meshes, cameras and 2D layout
//! (`geometry.rs`), the split of the triangles for label maps
//! (`subdivision.rs`), how each map is coloured and explained (`specs.rs`),
//! the two panels (`panel_2d.rs`, `panel_3d.rs`), the legend (`legend.rs`)
//! and the drawing helpers they share (`drawing.rs`). A series' plot over
//! the cardiac cycle is [`series`]. Text layout is
//! [`crate::figures::layout`]'s.

use unfold_organs::mitral::Outcome;
use unfold_render::{Anchor, Image, Rgb, Rgba, text_height};

use super::layout::{self, fit_scale};
use super::{Figure, FigureError, FigureOptions, INK};

mod drawing;
mod geometry;
mod legend;
mod panel_2d;
mod panel_3d;
pub mod series;
mod specs;
mod subdivision;

use geometry::Geometry;
use panel_2d::panel_2d;
use panel_3d::panel_3d;
use specs::{MapSpec, map_specs};

/// Colour of the annulus highlight in both panels (a thick dark navy line).
/// Not a grey: anti-aliased black text over white paper is grey, so the
/// annulus stays tellable from the labels' edges.
pub const ANNULUS_COLOR: Rgba = Rgba::new(25, 25, 90, 255);

/// Colour of the rest of the leaflets' boundary (free edges, commissure
/// sides): a slightly blue grey, so that it is not one of the greys of
/// anti-aliased text.
pub const OUTLINE_COLOR: Rgba = Rgba::new(118, 128, 142, 255);

/// Coaptation colours by label ([`COAPTATION_NONE`](unfold_organs::mitral::maps::COAPTATION_NONE), `COAPTATION_NEAR`,
/// `COAPTATION_WITHIN`): white, yellow, green (ALGORITHMS 4.5).
pub const COAPTATION_COLORS: [Rgb; 3] = [
    Rgb::new(255, 255, 255),
    Rgb::new(250, 200, 20),
    Rgb::new(30, 160, 70),
];

/// Carpentier segment colours, A1, A2, A3 (anterior, cool colours) then
/// P1, P2, P3 (posterior, warm colours).
pub const CARPENTIER_COLORS: [Rgb; 6] = [
    Rgb::new(78, 121, 167),
    Rgb::new(118, 183, 178),
    Rgb::new(89, 161, 79),
    Rgb::new(225, 87, 89),
    Rgb::new(242, 142, 43),
    Rgb::new(237, 201, 72),
];

/// Leaflet colours: anterior blue, posterior red (ALGORITHMS 4.5).
pub const LEAFLET_COLORS: [Rgb; 2] = [Rgb::new(40, 100, 200), Rgb::new(210, 40, 40)];

/// Checkerboard colours (labels 0 and 1).
pub const CHECKER_COLORS: [Rgb; 2] = [Rgb::new(235, 235, 235), Rgb::new(80, 80, 80)];

/// Smallest accepted panel, pixels (the legends and labels need room).
pub const MIN_PANEL: (u32, u32) = (300, 240);

/// Top band of each panel left for the figure title.
pub(super) const TITLE_BAND: i32 = 24;

/// Row of the panel subtitles.
pub(super) const SUBTITLE_Y: i32 = 28;

/// Rows of the labels above the 2D annulus.
pub(super) const LABEL_Y: [i32; 2] = [39, 52];

/// Top of the 2D map area.
pub(super) const MAP_TOP: i32 = 66;

/// Left and right margin of the 2D map area.
pub(super) const MAP_SIDE: i32 = 22;

/// Room kept below the 2D map (leaflet names, scale bar, measurements).
pub(super) const BELOW_MAP: i32 = 86;

/// Top of the 3D view area.
pub(super) const VIEW_TOP: i32 = 40;

/// Tilt of the 3D view from the atrial normal towards the anterior side,
/// degrees.
pub(super) const VIEW_TILT_DEG: f64 = 20.0;

/// All figures of one mitral outcome: `map_<array>.png` for the
/// distortion maps of ALGORITHMS 4.4 (`area_energy`, `angle_energy`,
/// `length_energy`) and the clinical maps of 4.5 (`leaflet`, `u_gradient`,
/// `u_interval`, `checker`, `carpentier`, `coaptation`,
/// `coaptation_distance_mm`, `tenting_mm`), in that order. Each is
/// `2 panel_width x panel_height`: the 2D map beside the 3D view (see the
/// module documentation).
///
/// # Errors
/// [`FigureError::Input`] when a panel is smaller than [`MIN_PANEL`], the
/// 2D and 3D meshes do not match the leaflets, an array is missing or has
/// the wrong length, or the annulus has fewer than two vertices per
/// leaflet; [`FigureError::Render`] when the renderer refuses something
/// (non-finite positions, sizes above its limit).
pub fn figures(outcome: &Outcome, opts: &FigureOptions) -> Result<Vec<Figure>, FigureError> {
    let geo = Geometry::new(outcome, opts)?;
    let specs = map_specs(outcome, &geo)?;
    specs
        .into_iter()
        .map(|spec| {
            let name = format!("map_{}.png", spec.array);
            let image = compose(&geo, &spec, &name)?;
            Ok(Figure { name, image })
        })
        .collect()
}

/// The whole figure: the 2D map beside the 3D view, the title over both.
fn compose(geo: &Geometry<'_>, spec: &MapSpec, figure: &str) -> Result<Image, FigureError> {
    let err = || FigureError::render(figure);
    let panels = [panel_2d(geo, spec, figure)?, panel_3d(geo, spec, figure)?];
    let opts = FigureOptions {
        panel_width: geo.pw,
        panel_height: geo.ph,
    };
    let mut fig = layout::compose(&panels, 2, &opts).map_err(err())?;
    let scale = fit_scale(&spec.title, 2, fig.width().saturating_sub(8));
    let ty = (TITLE_BAND - text_height(scale) as i32) / 2;
    fig.draw_text(
        geo.pw as i32,
        ty.max(0),
        &spec.title,
        scale,
        INK,
        Anchor::Center,
    )
    .map_err(err())?;
    Ok(fig)
}
