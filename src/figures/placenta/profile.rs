//! [`PROFILE_FIGURE`]: the aligned original and the flattened mesh seen
//! along the template's y axis, with the template's levels dashed.

use unfold_render::{Anchor, Coloring, Image, Renderer, Shading, format_value};

use super::depths::Depths;
use super::drawing::{GUIDE, dashed, ortho, panel, scale_bar, title_scale};
use super::meshes::Meshes;
use super::numbers::nice_length;
use super::{PROFILE_COLOR, PROFILE_FIGURE, TITLE_BAND};
use crate::figures::layout::{compose, text_fit};
use crate::figures::{FigureError, FigureOptions, PAPER};
use crate::mesh::nalgebra::{Point3, Vector3};

/// The aligned original and the flattened mesh seen along the template's y
/// axis (x right, z up), same scale, the template's levels (`z = +-h`)
/// dashed behind the meshes.
pub(super) fn profile(
    m: &Meshes<'_>,
    depths: &Depths,
    opts: &FigureOptions,
) -> Result<Image, FigureError> {
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
        let mut img = panel(opts, title, "view along y (x right, z up)", ts).map_err(err(name))?;
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
