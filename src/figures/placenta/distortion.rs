//! [`DISTORTION_FIGURE`]: histograms of `log2 det J`, of the `log2` edge
//! length ratios and of the `log2` boundary area ratios.

use unfold_render::{
    Anchor, HistogramStyle, Image, Rect, draw_histogram, format_value, text_height,
};

use super::drawing::{GUIDE, panel, title_scale};
use super::meshes::Meshes;
use super::numbers::{ceil_2, percentile};
use super::{DISTORTION_FIGURE, HISTOGRAM_COLOR, TITLE_BAND};
use crate::figures::layout::{compose, text_fit};
use crate::figures::{FigureError, FigureOptions, INK};
use crate::mesh::nalgebra::Point3;
use crate::mesh::topology::edges;

/// Histograms of the three distortion measures.
pub(super) fn distortion(m: &Meshes<'_>, opts: &FigureOptions) -> Result<Image, FigureError> {
    let name = DISTORTION_FIGURE;
    let err = FigureError::render;
    let (o, f) = (m.original, m.flattened);
    let edge_ratio: Vec<f64> = edges(m.tets)
        .iter()
        .map(|&[a, b]| {
            let (a, b) = (a as usize, b as usize);
            ((f[a] - f[b]).norm() / (o[a] - o[b]).norm()).log2()
        })
        .collect();
    let area = |p: &[Point3<f64>], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(&(c - a)).norm()
    };
    let area_ratio: Vec<f64> = m
        .tris
        .iter()
        .map(|t| (area(f, t) / area(o, t)).log2())
        .collect();
    let measures: [(&str, &str, &[f64], &str); 3] = [
        ("log2 det J", "per tet; bars: tets", &m.log2_det_j, "tets"),
        (
            "log2 edge ratio",
            "flat / original length; bars: edges",
            &edge_ratio,
            "edges",
        ),
        (
            "log2 area ratio",
            "per boundary triangle; bars: triangles",
            &area_ratio,
            "triangles",
        ),
    ];
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    let mut panels = Vec::with_capacity(3);
    let ts = title_scale(opts, &measures.map(|m| m.0));
    for (title, subtitle, values, unit) in measures {
        let mut img = panel(opts, title, subtitle, ts).map_err(err(name))?;
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let half = ceil_2(sorted.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-3));
        let n = sorted.len();
        let mean = if n > 0 {
            sorted.iter().sum::<f64>() / n as f64
        } else {
            f64::NAN
        };
        let sd = if n > 1 {
            (sorted.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let p = |q| percentile(&sorted, q).map_or("-".into(), format_value);
        let mut lines = vec![
            format!("n = {} {unit}", values.len()),
            format!("mean {}   sd {}", format_value(mean), format_value(sd)),
            format!("median {}", p(0.5)),
            format!("5% to 95%: {} to {}", p(0.05), p(0.95)),
        ];
        if values.len() > n {
            lines.push(format!("{} non-finite (inverted)", values.len() - n));
        }
        let step = text_height(1) + 1;
        let stats_h = step * lines.len() as u32 + 4;
        let rect = Rect::new(
            10,
            TITLE_BAND as i32 + 4,
            pw - 20,
            ph - TITLE_BAND - 8 - stats_h,
        );
        let style = HistogramStyle {
            bar: HISTOGRAM_COLOR,
            ..HistogramStyle::default()
        };
        draw_histogram(&mut img, rect, values, 41, Some((-half, half)), "", &style)
            .map_err(err(name))?;
        // The zero line and its label (the layout of draw_histogram: plot
        // columns axis_x + 1 ..= right - 1, the axis 12 rows above the bottom).
        let lh = i64::from(text_height(1));
        let axis_x = i64::from(rect.x) + 1;
        let plot_w = rect.right() - 1 - axis_x;
        let x_zero = axis_x + 1 + plot_w / 2;
        let plot_top = i64::from(rect.y) + lh + 2;
        let axis_y = rect.bottom() - 1 - lh - 3;
        for y in plot_top..axis_y {
            if (y - plot_top) % 6 < 3 {
                img.put(x_zero, y, GUIDE);
            }
        }
        img.draw_text(
            x_zero as i32,
            (axis_y + 3) as i32,
            "0",
            1,
            INK,
            Anchor::Center,
        )
        .map_err(err(name))?;
        let y0 = (ph - stats_h) as i32;
        for (k, line) in lines.iter().enumerate() {
            text_fit(
                &mut img,
                (pw / 2) as i32,
                y0 + (step * k as u32) as i32,
                line,
                1,
                pw - 8,
                Anchor::Center,
            )
            .map_err(err(name))?;
        }
        panels.push(img);
    }
    compose(&panels, 3, opts).map_err(err(name))
}
