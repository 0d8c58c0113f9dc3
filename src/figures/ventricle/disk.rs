//! The disk figures: [`DISK_AHA_PNG`] (the LV disk by AHA segment, with a
//! legend) and [`DISK_ANGLE_PNG`] (the RV half disk by angle).

use std::f64::consts::{PI, TAU};

use unfold_mesh::TriMesh;
use unfold_organs::ventricle::aha::aha_segment;
use unfold_organs::ventricle::disk::RV_CENTRE;
use unfold_organs::ventricle::{Chamber, Outcome};
use unfold_render::{
    Anchor, ColorScale, Coloring, Image, NAN_COLOR, RenderError, Renderer, Rgb, Shading, arc,
    format_value,
};

use super::disk_layout::{DiskLayout, disk_area, disk_renderer};
use super::drawing::{
    aha_rows, apex_marker, axes_glyph, colorbar_column, ink_on, landmark_marker, orientation_words,
    text, title_band,
};
use super::{
    AHA_COLORS, ANGLE_COLORMAP, COLORBAR_COLUMN, DISK_AHA_PNG, DISK_ANGLE_PNG, SOFT_INK,
    TITLE_BAND, disk_layout, figure_size, segment_centre,
};
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

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

/// The disk rendered into the `area` (pixels) of a disk figure as `layout`
/// says: each triangle in its colour (`colors`) and, unless the triangles
/// are too small ([`show_wireframe`] for a disk of `units` square units), a
/// light wireframe: group by group in increasing order, the edges of the
/// triangles of group `g` (`groups[t] == Some(g)`) in `wire_color(g)`
/// moved towards white by [`WIRE_TINT`].
fn render_disk(
    disk: &TriMesh,
    layout: &DiskLayout,
    area: (u32, u32),
    units: f64,
    colors: &[Rgb],
    groups: &[Option<usize>],
    wire_color: impl Fn(usize) -> Rgb,
) -> Result<Renderer, RenderError> {
    let mut r = disk_renderer(layout, area.0, area.1)?;
    r.draw_mesh(
        &disk.positions,
        &disk.triangles,
        Coloring::PerTriangle(colors),
        Shading::Unlit,
    )?;
    if !show_wireframe(units, disk.triangles.len(), layout.scale) {
        return Ok(r);
    }
    let count = groups.iter().flatten().max().map_or(0, |g| g + 1);
    for g in 0..count {
        let tris: Vec<[u32; 3]> = disk
            .triangles
            .iter()
            .zip(groups)
            .filter(|(_, k)| **k == Some(g))
            .map(|(t, _)| *t)
            .collect();
        if !tris.is_empty() {
            let c = wire_color(g).lerp(Rgb::WHITE, WIRE_TINT).opaque();
            r.draw_wireframe(&disk.positions, &tris, c)?;
        }
    }
    Ok(r)
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
pub(super) fn disk_aha(outcome: &Outcome, opts: &FigureOptions) -> Result<Figure, FigureError> {
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
    // The wireframe: each segment's edges in a paler shade of its colour.
    let groups: Vec<Option<usize>> = labels.iter().map(|&l| Some(usize::from(l))).collect();
    let r = render_disk(disk, &layout, (aw, ah), PI, &colors, &groups, |seg| {
        color(seg as u8)
    })
    .map_err(FigureError::render(F))?;
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
    y = aha_rows(&mut img, F, x0, y, row_h, &counts)?;
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
    Ok(Figure::new(F, img))
}

/// The angle of RV half-disk point `p` about the circle's centre, degrees.
fn rv_angle(p: [f64; 2]) -> f64 {
    (p[1] - RV_CENTRE[1])
        .atan2(p[0] - RV_CENTRE[0])
        .to_degrees()
}

/// [`DISK_ANGLE_PNG`].
pub(super) fn disk_angle(outcome: &Outcome, opts: &FigureOptions) -> Result<Figure, FigureError> {
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
    // The wireframe: the edges of the triangles in each 5-degree band in a
    // paler shade of the band's colour.
    let band = |a: f64| ((a + 90.0) / 5.0).floor().clamp(0.0, 35.0) as usize;
    let groups: Vec<Option<usize>> = angles
        .iter()
        .map(|&a| a.is_finite().then(|| band(a)))
        .collect();
    let r = render_disk(disk, &layout, (aw, ah), 0.5 * PI, &colors, &groups, |b| {
        scale.color(-87.5 + 5.0 * b as f64)
    })
    .map_err(FigureError::render(F))?;
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
    let heading = ["angle (deg)", "-90: corner 2", "+90: corner 1"];
    colorbar_column(
        &mut img,
        F,
        i64::from(w) - COLORBAR_COLUMN,
        &scale,
        &heading,
    )?;
    Ok(Figure::new(F, img))
}
