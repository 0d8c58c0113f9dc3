//! The two 2 x 2 mesh figures ([`SIDE_FIGURE`](super::SIDE_FIGURE),
//! [`LOG2_DET_J_FIGURE`](super::LOG2_DET_J_FIGURE)): the original and the
//! flattened mesh seen from the fetal and the maternal side, coloured by
//! boundary side or by `log2 det J`, with a legend or a colour bar and
//! notes.

use std::collections::BTreeSet;

use unfold_render::{
    Anchor, ColorScale, Coloring, Image, Lighting, NAN_COLOR, Rect, RenderError, Renderer, Rgb,
    Shading, format_value,
};

use super::drawing::{bounds, colour_bar, ortho, panel, title_scale};
use super::meshes::Meshes;
use super::numbers::percentile;
use super::{OTHER_LABEL_COLOR, SIDE_COLORS, SIDE_NAMES, TITLE_BAND};
use crate::figures::layout::{compose, text_fit};
use crate::figures::{FigureError, FigureOptions, INK, PAPER};
use crate::mesh::nalgebra::{Point3, Vector3};

/// How the boundary is coloured.
pub(super) enum Paint<'a> {
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
pub(super) fn mesh_views(
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
            let mut img = panel(opts, title, subtitle, ts).map_err(err(name))?;
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

/// The name of a `side` label, as in the legend (`label 7` for others).
fn side_name(label: u8) -> String {
    SIDE_NAMES
        .get(usize::from(label))
        .map_or_else(|| format!("label {label}"), |s| s.to_string())
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
        let name = side_name(l);
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
        let name = side_name(l);
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
