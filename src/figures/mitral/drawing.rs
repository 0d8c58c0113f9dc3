//! Drawing helpers shared by the two mitral panels: the mesh in the map's
//! colours, thick and dashed lines, haloed labels and the panel subtitle.

use unfold_render::nalgebra::Point3;
use unfold_render::{Anchor, Camera, Coloring, Image, Renderer, Rgb, Rgba, Shading, text_width};

use super::SUBTITLE_Y;
use super::geometry::Geometry;
use super::specs::{Layout, MapSpec};
use crate::figures::{FigureError, INK, PAPER};

/// A view of `size` pixels through `camera` of the mesh at positions `p`
/// coloured by `spec`.
pub(super) fn colored_view(
    geo: &Geometry<'_>,
    p: &[Point3<f64>],
    spec: &MapSpec,
    camera: Camera,
    size: (u32, u32),
    shading: Shading,
    figure: &str,
) -> Result<Renderer, FigureError> {
    let mut r =
        Renderer::new(size.0, size.1, PAPER, camera).map_err(FigureError::render(figure))?;
    let err = FigureError::render(figure);
    let expected = match spec.layout {
        Layout::Cell => geo.triangles.len(),
        _ => p.len(),
    };
    if spec.colors.len() != expected {
        return Err(FigureError::input(
            figure,
            format!("{} colours for {expected} elements", spec.colors.len()),
        ));
    }
    match spec.layout {
        Layout::Cell => {
            r.draw_mesh(
                p,
                geo.triangles,
                Coloring::PerTriangle(&spec.colors),
                shading,
            )
            .map_err(err)?;
        }
        Layout::Vertex => {
            r.draw_mesh(p, geo.triangles, Coloring::PerVertex(&spec.colors), shading)
                .map_err(err)?;
        }
        Layout::VertexLabels => {
            let q = geo.sub.positions(p);
            let colors: Vec<Rgb> = geo
                .sub
                .corner
                .iter()
                .map(|&v| spec.colors[v as usize])
                .collect();
            r.draw_mesh(
                &q,
                &geo.sub.triangles,
                Coloring::PerTriangle(&colors),
                shading,
            )
            .map_err(err)?;
        }
    }
    Ok(r)
}

/// Draws a line `w` pixels thick (offsets of the 1-pixel line).
pub(super) fn thick_line(img: &mut Image, a: [f64; 2], b: [f64; 2], c: Rgba, w: i32) {
    let lo = -(w - 1) / 2;
    for dx in lo..lo + w {
        for dy in lo..lo + w {
            let (dx, dy) = (f64::from(dx), f64::from(dy));
            img.line([a[0] + dx, a[1] + dy], [b[0] + dx, b[1] + dy], c);
        }
    }
}

/// Draws a dashed vertical line at column `x` from row `y0` to `y1`.
pub(super) fn dashed_vline(img: &mut Image, x: f64, y0: f64, y1: f64, c: Rgba) {
    let mut y = y0;
    while y < y1 {
        let e = (y + 5.0).min(y1);
        img.line([x, y], [x, e], c);
        y += 9.0;
    }
}

/// Text with a one-pixel halo in `halo` around it.
#[allow(clippy::too_many_arguments)]
pub(super) fn halo_text(
    img: &mut Image,
    x: i32,
    y: i32,
    text: &str,
    scale: u32,
    c: Rgba,
    halo: Rgba,
    figure: &str,
) -> Result<(), FigureError> {
    for (dx, dy) in [
        (-1, 0),
        (1, 0),
        (0, -1),
        (0, 1),
        (-1, -1),
        (1, 1),
        (-1, 1),
        (1, -1),
    ] {
        img.draw_text(x + dx, y + dy, text, scale, halo, Anchor::Center)
            .map_err(FigureError::render(figure))?;
    }
    img.draw_text(x, y, text, scale, c, Anchor::Center)
        .map_err(FigureError::render(figure))?;
    Ok(())
}

/// Writes the first of `texts` that fits in `width` pixels, centred over
/// them, on the subtitle row.
pub(super) fn subtitle(
    img: &mut Image,
    width: u32,
    texts: &[&str],
    figure: &str,
) -> Result<(), FigureError> {
    let text = texts
        .iter()
        .find(|t| text_width(t, 1) + 4 <= width)
        .or(texts.last())
        .copied()
        .unwrap_or("");
    img.draw_text(width as i32 / 2, SUBTITLE_Y, text, 1, INK, Anchor::Center)
        .map_err(FigureError::render(figure))?;
    Ok(())
}
