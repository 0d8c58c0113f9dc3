//! Where a drawing of the disk sits in a figure: the layouts of the
//! bull's-eye and of the disk figures, and the renderer that draws the disk
//! plane as its layout says.

use std::f64::consts::PI;

use unfold_organs::ventricle::Chamber;
use unfold_organs::ventricle::disk::RV_CENTRE;
use unfold_render::nalgebra::{Point3, Vector3};
use unfold_render::{Camera, Renderer};

use super::{COLORBAR_COLUMN, TITLE_BAND, figure_size};
use crate::figures::{FigureError, FigureOptions, PAPER};

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
    pub(super) fn screen_angle(&self, a: f64) -> f64 {
        if self.mirrored { PI - a } else { a }
    }
}

/// The layout of the bull's-eye in [`BULLSEYE_PNG`](super::BULLSEYE_PNG) (left panel, below the
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

/// The layout of the disk in [`DISK_AHA_PNG`](super::DISK_AHA_PNG) (LV: mirrored, origin
/// `(0, 0)`, `scale` the unit circle's radius in pixels) or
/// [`DISK_ANGLE_PNG`](super::DISK_ANGLE_PNG) (RV: not mirrored, origin `(1.75, 0)`, the half disk
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
pub(super) fn disk_area(chamber: Chamber, opts: &FigureOptions) -> Result<(u32, u32), FigureError> {
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

/// An orthographic renderer of a `w x h` area showing the disk plane
/// `z = 0` as `layout` says (centre of the area = `layout.origin`).
pub(super) fn disk_renderer(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
