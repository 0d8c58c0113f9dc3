//! The right panel: the 3D valve seen from the atrium with the annulus, the
//! names of the commissures, leaflets and segments, and the legend.

use unfold_organs::mitral::maps::A1;
use unfold_organs::mitral::{ANTERIOR, POSTERIOR};
use unfold_render::nalgebra::Point3;
use unfold_render::{Image, Shading};

use super::drawing::{colored_view, halo_text, subtitle, thick_line};
use super::geometry::Geometry;
use super::legend::draw_legend;
use super::specs::{MapSpec, array_values};
use super::{ANNULUS_COLOR, OUTLINE_COLOR, VIEW_TOP};
use crate::figures::{FigureError, INK, PAPER};

/// The right panel: the 3D view and the legend.
pub(super) fn panel_3d(
    geo: &Geometry<'_>,
    spec: &MapSpec,
    figure: &str,
) -> Result<Image, FigureError> {
    let err = || FigureError::render(figure);
    let mut img = Image::new(geo.pw, geo.ph, PAPER).map_err(err())?;
    let (w, h) = geo.view;
    let mut r = colored_view(
        geo,
        geo.p3,
        spec,
        geo.cam3d,
        (w, h),
        Shading::Smooth,
        figure,
    )?;
    for e in &geo.free_edges {
        r.draw_polyline_3d(
            &[geo.p3[e[0] as usize], geo.p3[e[1] as usize]],
            false,
            OUTLINE_COLOR,
        )
        .map_err(err())?;
    }
    // The annulus, thick where visible (segment midpoints depth-tested).
    let bias = r.depth_bias();
    let mut segments = Vec::new();
    for ring in &geo.annulus {
        for w2 in ring.windows(2) {
            let (a, b) = (geo.p3[w2[0] as usize], geo.p3[w2[1] as usize]);
            let m = Point3::from((a.coords + b.coords) * 0.5);
            let (Some(pa), Some(pb), Some(pm)) = (r.project(&a), r.project(&b), r.project(&m))
            else {
                continue;
            };
            let visible = r
                .depth_at(pm.x.floor() as i64, pm.y.floor() as i64)
                .is_none_or(|z| pm.depth <= z + 4.0 * bias);
            if visible {
                segments.push(([pa.x, pa.y], [pb.x, pb.y]));
            }
        }
    }
    let view_img = r.image_mut();
    for (a, b) in segments {
        thick_line(view_img, a, b, ANNULUS_COLOR, 3);
    }

    // Segment names at the vertex nearest each segment's 2D centroid.
    let mut labels: Vec<([f64; 2], String, u32)> = Vec::new();
    if spec.segment_names {
        let carpentier = array_values(&geo.outcome.valve2d, "carpentier", false, 1, figure)?;
        for (k, name) in ["A1", "A2", "A3", "P1", "P2", "P3"].iter().enumerate() {
            let label = f64::from(A1) + k as f64;
            let ids: Vec<u32> = (0..carpentier.len() as u32)
                .filter(|&i| carpentier[i as usize] == label)
                .collect();
            if ids.is_empty() {
                continue;
            }
            let n = ids.len() as f64;
            let c = ids.iter().fold([0.0; 2], |s, &i| {
                let q = geo.uv(i);
                [s[0] + q[0] / n, s[1] + q[1] / n]
            });
            let best = ids.iter().copied().min_by(|&i, &j| {
                let d = |v: u32| {
                    let q = geo.uv(v);
                    (q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)
                };
                d(i).total_cmp(&d(j))
            });
            if let Some(p) = best.and_then(|v| r.project(&geo.p3[v as usize])) {
                labels.push(([p.x, p.y], (*name).to_string(), 2));
            }
        }
    }
    // Commissures and leaflets, pushed outwards from the ring's centre.
    let centre = {
        let pts: Vec<[f64; 2]> = geo
            .annulus
            .iter()
            .flatten()
            .filter_map(|&v| r.project(&geo.p3[v as usize]))
            .map(|p| [p.x, p.y])
            .collect();
        let n = pts.len().max(1) as f64;
        pts.iter()
            .fold([0.0; 2], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n])
    };
    let out = |v: u32, by: f64| -> Option<[f64; 2]> {
        let p = r.project(&geo.p3[v as usize])?;
        let d = [p.x - centre[0], p.y - centre[1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-9);
        Some([p.x + by * d[0] / l, p.y + by * d[1] / l])
    };
    let ant = &geo.annulus[ANTERIOR];
    let post = &geo.annulus[POSTERIOR];
    for (v, name) in [(ant[0], "AL"), (*ant.last().unwrap_or(&0), "PM")] {
        if let Some(p) = out(v, 16.0) {
            labels.push((p, name.to_string(), 1));
        }
    }
    // The leaflet names above and below the whole valve, over the middle
    // of their annulus arcs.
    let rows: Vec<f64> = geo
        .p3
        .iter()
        .filter_map(|p| r.project(p))
        .map(|p| p.y)
        .collect();
    let top = rows.iter().copied().fold(f64::INFINITY, f64::min);
    let low = rows.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    for (v, name, y) in [
        (ant[ant.len() / 2], "anterior", top - 8.0),
        (post[post.len() / 2], "posterior", low + 10.0),
    ] {
        if let (Some(p), true) = (r.project(&geo.p3[v as usize]), y.is_finite()) {
            labels.push(([p.x, y], name.to_string(), 1));
        }
    }
    let view_img = r.image_mut();
    for (p, name, scale) in &labels {
        let half = 4 * *scale as i32;
        halo_text(
            view_img,
            p[0] as i32,
            p[1] as i32 - half,
            name,
            *scale,
            INK,
            PAPER,
            figure,
        )?;
    }
    img.blit(r.image(), 0, i64::from(VIEW_TOP));
    subtitle(
        &mut img,
        w,
        &[
            "3D, from the atrium, anterior up",
            "3D, from the atrium",
            "3D",
        ],
        figure,
    )?;
    draw_legend(
        &mut img,
        &spec.legend,
        (w + 6) as i32,
        VIEW_TOP + 4,
        geo.legend_w - 10,
        geo.ph as i32 - VIEW_TOP - 10,
        figure,
    )?;
    Ok(img)
}
