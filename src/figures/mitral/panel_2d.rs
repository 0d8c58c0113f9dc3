//! The left panel: the 2D map with the annulus, the commissures, the
//! leaflet names, a scale bar and the valve's measurements.

use unfold_organs::mitral::maps::A1;
use unfold_organs::mitral::{ANTERIOR, POSTERIOR};
use unfold_render::{Anchor, Image, Shading, format_value};

use super::drawing::{colored_view, dashed_vline, halo_text, subtitle, thick_line};
use super::geometry::Geometry;
use super::specs::{MapSpec, array_values};
use super::{ANNULUS_COLOR, LABEL_Y, MAP_SIDE, OUTLINE_COLOR};
use crate::figures::layout::wrap;
use crate::figures::{FigureError, INK, PAPER};

/// A "nice" scale bar length in mm for `scale` pixels per mm and a map
/// `width` pixels wide: 10 mm when that is 25 px to half the width, else
/// the longest of 1, 2, 5, 10, 20, 50, 100 mm within a quarter of it.
fn scale_bar_mm(scale: f64, width: f64) -> f64 {
    if (25.0..=0.5 * width).contains(&(10.0 * scale)) {
        return 10.0;
    }
    [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
        .into_iter()
        .rev()
        .find(|&l| l * scale <= 0.25 * width)
        .unwrap_or(1.0)
}

/// The left panel: the 2D map.
pub(super) fn panel_2d(
    geo: &Geometry<'_>,
    spec: &MapSpec,
    figure: &str,
) -> Result<Image, FigureError> {
    let err = || FigureError::render(figure);
    let mut img = Image::new(geo.pw, geo.ph, PAPER).map_err(err())?;
    let map = geo.map;
    let size = (map.size[0], map.size[1]);
    let r = colored_view(geo, geo.p2, spec, geo.cam2d, size, Shading::Unlit, figure)?;
    img.blit(
        r.image(),
        i64::from(map.origin[0]),
        i64::from(map.origin[1]),
    );
    let px = |i: u32| {
        let q = geo.uv(i);
        map.panel_xy(q[0], q[1])
    };
    // Outline, then the annulus over it.
    for e in &geo.free_edges {
        img.line(px(e[0]), px(e[1]), OUTLINE_COLOR);
    }
    for ring in &geo.annulus {
        for w in ring.windows(2) {
            thick_line(&mut img, px(w[0]), px(w[1]), ANNULUS_COLOR, 3);
        }
    }

    // The subtitle, the commissures and u = 0.
    subtitle(
        &mut img,
        geo.pw,
        &["2D map (u along the annulus, mm)", "2D map (mm)"],
        figure,
    )?;
    let al = px(geo.annulus[ANTERIOR][0]);
    let pm = px(*geo.annulus[ANTERIOR].last().unwrap_or(&0));
    let pm_p = px(geo.annulus[POSTERIOR][0]);
    let al_end = px(*geo.annulus[POSTERIOR].last().unwrap_or(&0));
    let bottom = f64::from(map.bottom());
    let tick_top = f64::from(LABEL_Y[1] + 10);
    dashed_vline(&mut img, al[0], tick_top, bottom, INK);
    img.draw_text(al[0] as i32, LABEL_Y[0], "u = 0", 1, INK, Anchor::Center)
        .map_err(err())?;
    let pm_x = 0.5 * (pm[0] + pm_p[0]);
    for (x, name) in [(al[0], "AL"), (pm_x, "PM"), (al_end[0], "AL")] {
        img.draw_text(x as i32, LABEL_Y[1], name, 1, INK, Anchor::Center)
            .map_err(err())?;
    }
    for (x, y) in [(pm[0], pm[1]), (pm_p[0], pm_p[1]), (al_end[0], al_end[1])] {
        img.line([x, tick_top], [x, y - 3.0], INK);
    }

    // Segment names at their centroids.
    if spec.segment_names {
        let carpentier = array_values(&geo.outcome.valve2d, "carpentier", false, 1, figure)?;
        for (k, name) in ["A1", "A2", "A3", "P1", "P2", "P3"].iter().enumerate() {
            let label = f64::from(A1) + k as f64;
            let (mut s, mut n) = ([0.0; 2], 0.0);
            for (i, &c) in carpentier.iter().enumerate() {
                if c == label {
                    let q = geo.uv(i as u32);
                    s[0] += q[0];
                    s[1] += q[1];
                    n += 1.0;
                }
            }
            if n > 0.0 {
                let c = map.panel_xy(s[0] / n, s[1] / n);
                halo_text(
                    &mut img,
                    c[0] as i32,
                    c[1] as i32 - 8,
                    name,
                    2,
                    INK,
                    PAPER,
                    figure,
                )?;
            }
        }
    }

    // Leaflet names below the map.
    let y = map.bottom() + 4;
    for (x, name) in [
        (0.5 * (al[0] + pm[0]), "anterior leaflet"),
        (0.5 * (pm_p[0] + al_end[0]), "posterior leaflet"),
    ] {
        img.draw_text(x as i32, y, name, 1, INK, Anchor::Center)
            .map_err(err())?;
    }

    // Scale bar.
    let len = scale_bar_mm(map.scale, f64::from(map.size[0]));
    let (x0, yb) = (f64::from(MAP_SIDE), f64::from(y + 26));
    let x1 = x0 + len * map.scale;
    thick_line(&mut img, [x0, yb], [x1, yb], INK, 2);
    img.line([x0, yb - 4.0], [x0, yb + 4.0], INK);
    img.line([x1, yb - 4.0], [x1, yb + 4.0], INK);
    img.draw_text(
        (x1 + 8.0) as i32,
        yb as i32 - 4,
        &format!("{} mm", format_value(len)),
        1,
        INK,
        Anchor::Left,
    )
    .map_err(err())?;

    // Measurements.
    let rep = &geo.outcome.report;
    let lines = [
        format!(
            "annulus {} mm, saddle horn {} mm",
            format_value(rep.annulus_length_mm),
            format_value(rep.saddle_horn_height_mm)
        ),
        format!(
            "leaflet area: anterior {}, posterior {} mm^2",
            format_value(rep.leaflet_area_mm2.anterior),
            format_value(rep.leaflet_area_mm2.posterior)
        ),
        format!(
            "area above / below annulus plane: {} / {} mm^2",
            format_value(rep.area_above_plane_mm2),
            format_value(rep.area_below_plane_mm2)
        ),
    ];
    let mut ty = yb as i32 + 14;
    let room = geo.pw.saturating_sub(2 * MAP_SIDE as u32);
    let lh = unfold_render::text_height(1) as i32;
    for line in lines.iter().flat_map(|l| wrap(l, room, 1)) {
        if ty + lh > geo.ph as i32 - 2 {
            break;
        }
        img.draw_text(MAP_SIDE, ty, &line, 1, INK, Anchor::Left)
            .map_err(err())?;
        ty += lh + 1;
    }
    Ok(img)
}
