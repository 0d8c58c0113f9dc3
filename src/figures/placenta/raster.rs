//! The image area of a placenta panel that shows a section of an image:
//! where it sits in the panel and how its pixels map to millimetres.

use unfold_render::{ColorScale, Image, Rect};

use super::TITLE_BAND;
use super::drawing::{PANEL_EDGE, scale_bar};
use crate::figures::FigureOptions;
use unfold_render::RenderError;

/// The image area of a panel: `ax, ay` its top-left corner, `aw x ah` its
/// size in pixels, below the title band and above a 34-pixel strip for the
/// scale bar.
#[derive(Debug, Clone, Copy)]
pub(super) struct Area {
    pub(super) ax: u32,
    pub(super) ay: u32,
    pub(super) aw: u32,
    pub(super) ah: u32,
}

impl Area {
    /// The area of a panel of `opts`' size.
    pub(super) fn of(opts: &FigureOptions) -> Area {
        let bottom = 34;
        let ax = 8;
        Area {
            ax,
            ay: TITLE_BAND,
            aw: opts.panel_width - 2 * ax,
            ah: opts.panel_height - TITLE_BAND - bottom,
        }
    }

    /// The largest scale (pixels per mm) at which a section of
    /// `width x height` mm fits the area.
    pub(super) fn fit(&self, width: f64, height: f64) -> f64 {
        (f64::from(self.aw) / width.max(1e-6)).min(f64::from(self.ah) / height.max(1e-6))
    }

    /// The section's coordinates `(u, v)` in mm (u to the right, v up) at
    /// the centre of pixel `(i, j)`, the section's centre `(cu, cv)` at the
    /// area's centre, at `s` pixels per mm:
    /// `u = cu + (i + 1/2 - aw/2) / s`, `v = cv - (j + 1/2 - ah/2) / s`.
    pub(super) fn mm(&self, (cu, cv): (f64, f64), s: f64, i: u32, j: u32) -> (f64, f64) {
        (
            cu + (f64::from(i) + 0.5 - 0.5 * f64::from(self.aw)) / s,
            cv - (f64::from(j) + 0.5 - 0.5 * f64::from(self.ah)) / s,
        )
    }

    /// Paints `values` (row-major over the area, `None` left white) in
    /// `scale`'s colours, outlines the area and draws a scale bar of `bar`
    /// mm at `s` pixels per mm.
    pub(super) fn paint(
        &self,
        p: &mut Image,
        values: &[Option<f64>],
        scale: &ColorScale,
        bar: f64,
        s: f64,
    ) -> Result<(), RenderError> {
        for j in 0..self.ah {
            for i in 0..self.aw {
                if let Some(v) = values[(j * self.aw + i) as usize] {
                    p.put(
                        i64::from(self.ax + i),
                        i64::from(self.ay + j),
                        scale.color(v).opaque(),
                    );
                }
            }
        }
        p.stroke_rect(
            Rect::new(
                self.ax as i32 - 1,
                self.ay as i32 - 1,
                self.aw + 2,
                self.ah + 2,
            ),
            PANEL_EDGE,
        );
        let bottom = f64::from(self.ay + self.ah) + 24.0;
        scale_bar(p, f64::from(self.ax) + 4.0, bottom, bar, s)
    }

    /// `f(u, v)` at every pixel of the area (row-major), the section's centre
    /// `centre` at the area's centre, at `s` pixels per mm.
    pub(super) fn sample(
        &self,
        centre: (f64, f64),
        s: f64,
        f: impl Fn(f64, f64) -> Option<f64>,
    ) -> Vec<Option<f64>> {
        let mut out = Vec::with_capacity((self.aw * self.ah) as usize);
        for j in 0..self.ah {
            for i in 0..self.aw {
                let (u, v) = self.mm(centre, s, i, j);
                out.push(f(u, v));
            }
        }
        out
    }
}
