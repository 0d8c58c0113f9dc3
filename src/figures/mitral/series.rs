//! [`SERIES_PNG`]: a valve series over the cardiac cycle, its mean
//! distortion energies (initial layout and relaxed map) and its coaptation
//! counts against the step, one panel each (2 x 2).

use unfold_render::{Anchor, FillRule, Image, Rect, Rgba, arc};

use crate::figures::cohort::axes::{
    Axis, SOFT_INK, TITLE_BAND, check_panel, clamp32, draw_frame, label_width, line_height,
    nice_ticks, padded_range, text, title_band,
};
use crate::figures::layout::compose;
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// File name of the figure.
pub const SERIES_PNG: &str = "series.png";

/// Colour of the relaxed map's energies and of the coaptation zone count.
pub const FINAL: Rgba = Rgba::new(31, 119, 180, 255);

/// Colour of the initial layout's energies.
pub const INITIAL: Rgba = Rgba::new(150, 150, 150, 255);

/// Colour of the coaptation zone count (the zone's green of the map).
pub const ZONE: Rgba = Rgba::new(44, 160, 44, 255);

/// Colour of the "near the zone" count (the map's yellow, darkened to read
/// on white).
pub const NEAR: Rgba = Rgba::new(200, 160, 0, 255);

/// One step of a series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesPoint {
    /// Mean area, angle and length energies of the initial layout.
    pub initial: [f64; 3],
    /// The same of the relaxed map.
    pub r#final: [f64; 3],
    /// Vertices in the coaptation zone and near it.
    pub coaptation: [usize; 2],
}

/// One panel: curves `(label, colour, y per step)` against the step.
struct Curves<'a> {
    title: &'a str,
    y_label: &'a str,
    curves: Vec<(&'a str, Rgba, Vec<f64>)>,
}

/// [`SERIES_PNG`]: area, angle and length energy (initial grey, relaxed
/// blue) and the coaptation counts (zone green, near yellow) against the
/// step (`0 .. n - 1`, as `step_NNN`), each step a dot, consecutive steps
/// joined.
///
/// # Errors
/// [`FigureError::Input`] for no step or a panel too small; the renderer's.
pub fn series_plot(steps: &[SeriesPoint], opts: &FigureOptions) -> Result<Figure, FigureError> {
    const F: &str = SERIES_PNG;
    check_panel(F, opts)?;
    if steps.is_empty() {
        return Err(FigureError::input(F, "no step to plot"));
    }
    let energy = |k: usize, title: &'static str, label: &'static str| Curves {
        title,
        y_label: label,
        curves: vec![
            (
                "initial",
                INITIAL,
                steps.iter().map(|s| s.initial[k]).collect(),
            ),
            (
                "relaxed",
                FINAL,
                steps.iter().map(|s| s.r#final[k]).collect(),
            ),
        ],
    };
    let count = |k: usize| -> Vec<f64> { steps.iter().map(|s| s.coaptation[k] as f64).collect() };
    let panels = [
        energy(0, "area energy over the cycle", "area_energy (mean)"),
        energy(1, "angle energy over the cycle", "angle_energy (mean)"),
        energy(2, "length energy over the cycle", "length_energy (mean)"),
        Curves {
            title: "coaptation over the cycle",
            y_label: "vertices",
            curves: vec![("in the zone", ZONE, count(0)), ("near it", NEAR, count(1))],
        },
    ];
    let imgs = panels
        .iter()
        .map(|p| panel(p, steps.len(), opts))
        .collect::<Result<Vec<_>, _>>()
        .map_err(FigureError::render(F))?;
    let img = compose(&imgs, 2, opts).map_err(FigureError::render(F))?;
    Ok(Figure::new(F, img))
}

/// One panel of [`series_plot`] over `n` steps.
fn panel(
    p: &Curves<'_>,
    n: usize,
    opts: &FigureOptions,
) -> Result<Image, unfold_render::RenderError> {
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut img = Image::new(w, h, PAPER)?;
    let subtitle = format!("{n} step(s); 2 is an undistorted map");
    let subtitle = if p.y_label == "vertices" {
        format!("{n} step(s)")
    } else {
        subtitle
    };
    title_band(&mut img, p.title, &subtitle)?;
    let lh = line_height();
    // Legend row under the title band.
    let mut x = 12i64;
    for (label, colour, _) in &p.curves {
        img.fill_rect(
            Rect::new(clamp32(x), clamp32(TITLE_BAND + lh / 2 - 1), 14, 3),
            *colour,
        );
        let r = text(&mut img, x + 18, TITLE_BAND, label, INK, Anchor::Left)?;
        x += 18 + i64::from(r.width) + 16;
    }
    let top = TITLE_BAND + 2 * lh + 12;
    let bottom = i64::from(h) - 2 * lh - 22;
    let ys = p.curves.iter().flat_map(|c| c.2.iter().copied());
    let (ylo, yhi) = padded_range(ys).unwrap_or((0.0, 1.0));
    let rows = (bottom - top).max(20);
    let y_ticks = nice_ticks(ylo, yhi, (rows / 40).clamp(2, 8) as usize);
    let left = 12 + label_width(&y_ticks);
    let right = i64::from(w) - 16;
    let cols = (right - left).max(20);
    let last = (n.max(1) - 1) as f64;
    let x_ticks: Vec<f64> = if n == 1 {
        vec![-1.0, 0.0, 1.0]
    } else {
        let step = nice_ticks(0.0, last, (cols / 60).clamp(2, 10) as usize);
        // Whole steps only.
        step.into_iter()
            .filter(|t| t.fract() == 0.0 && *t >= 0.0 && *t <= last)
            .collect()
    };
    let area = Rect::new(clamp32(left), clamp32(top), cols as u32, rows as u32);
    let ya = Axis::over(&y_ticks, (area.bottom() - 1) as f64, top as f64);
    // A margin of half a step on both sides so the end dots are inside.
    let xa = Axis {
        lo: -0.5,
        hi: last + 0.5,
        p0: left as f64,
        p1: (area.right() - 1) as f64,
    };
    draw_frame(
        &mut img,
        area,
        &ya,
        &y_ticks,
        Some((&xa, &x_ticks)),
        p.y_label,
        "step",
    )?;
    for (_, colour, ys) in &p.curves {
        let pts: Vec<[f64; 2]> = ys
            .iter()
            .enumerate()
            .filter(|(_, y)| y.is_finite())
            .map(|(i, &y)| [xa.pixel(i as f64), ya.pixel(y)])
            .collect();
        for w in pts.windows(2) {
            img.line(w[0], w[1], *colour);
            img.line([w[0][0], w[0][1] + 1.0], [w[1][0], w[1][1] + 1.0], *colour);
        }
        for c in &pts {
            img.fill_polygon(
                &arc(*c, 4.0, 0.0, std::f64::consts::TAU),
                FillRule::NonZero,
                *colour,
            );
        }
    }
    let missing = p
        .curves
        .iter()
        .map(|c| c.2.iter().filter(|y| !y.is_finite()).count())
        .sum::<usize>();
    if missing > 0 {
        text(
            &mut img,
            right,
            TITLE_BAND,
            &format!("{missing} value(s) not finite, not drawn"),
            SOFT_INK,
            Anchor::Right,
        )?;
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steps(n: usize) -> Vec<SeriesPoint> {
        (0..n)
            .map(|i| SeriesPoint {
                initial: [2.5 + 0.1 * i as f64, 3.0, 2.3],
                r#final: [2.1, 2.4 - 0.01 * i as f64, 2.05],
                coaptation: [100 - 10 * i, 20 + i],
            })
            .collect()
    }

    /// Pixels of exactly `c` in `img`.
    fn count(img: &Image, c: Rgba) -> usize {
        (0..img.height() as i64)
            .flat_map(|y| (0..img.width() as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get(x, y) == Some(c))
            .count()
    }

    #[test]
    fn the_plot_has_four_panels_with_every_curve() {
        let opts = FigureOptions::default();
        let f = series_plot(&steps(5), &opts).unwrap();
        assert_eq!(f.name, SERIES_PNG);
        assert_eq!(
            (f.image.width(), f.image.height()),
            (2 * opts.panel_width, 2 * opts.panel_height)
        );
        for c in [FINAL, INITIAL, ZONE, NEAR] {
            assert!(count(&f.image, c) > 50, "{c:?}");
        }
        // Deterministic.
        let g = series_plot(&steps(5), &opts).unwrap();
        assert_eq!(f.image.as_bytes(), g.image.as_bytes());
        // One step is drawn too.
        assert!(count(&series_plot(&steps(1), &opts).unwrap().image, ZONE) > 20);
    }

    #[test]
    fn no_step_or_a_tiny_panel_is_an_error() {
        let e = series_plot(&[], &FigureOptions::default()).unwrap_err();
        assert!(e.to_string().contains("no step"), "{e}");
        let tiny = FigureOptions {
            panel_width: 100,
            panel_height: 100,
        };
        assert!(series_plot(&steps(3), &tiny).is_err());
    }
}
