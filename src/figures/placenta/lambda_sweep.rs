//! [`LAMBDA_SWEEP_PNG`]: the placenta paper's trade-off curve (its Fig. 3):
//! for each distortion weight `lambda` of a sweep, the map's template error
//! (how flat the sides are) against its Dirichlet excess (how much it
//! distorts), the runs joined in the order of `lambda`, each labelled.

use unfold_render::{Anchor, FillRule, Image, Rgba, arc, format_value};

use crate::figures::cohort::axes::{
    check_panel, line_height, padded_range, text, title_band, xy_frame,
};
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// File name of the figure.
pub const LAMBDA_SWEEP_PNG: &str = "lambda_sweep.png";

/// Colour of the curve.
pub const CURVE: Rgba = Rgba::new(31, 119, 180, 255);

/// One run of a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepPoint {
    /// The distortion weight.
    pub lambda: f64,
    /// Dirichlet excess `(sum V_k D(J_k) - 6) / 6 * 100`, percent.
    pub dirichlet_excess_percent: f64,
    /// Template error `sqrt(sum A_m T(x_m, theta))`, mm.
    pub template_error_mm: f64,
}

/// [`LAMBDA_SWEEP_PNG`]: template error (mm, y) against Dirichlet excess
/// (%, x), one dot per run labelled with its `lambda`, consecutive
/// `lambda`s joined. Runs with a value that is not finite are left out and
/// counted in the subtitle.
///
/// # Errors
/// [`FigureError::Input`] for no run with finite values or a panel too
/// small; the renderer's.
pub fn lambda_sweep_plot(runs: &[SweepPoint], opts: &FigureOptions) -> Result<Figure, FigureError> {
    const F: &str = LAMBDA_SWEEP_PNG;
    check_panel(F, opts)?;
    let mut pts: Vec<SweepPoint> = runs
        .iter()
        .copied()
        .filter(|r| r.dirichlet_excess_percent.is_finite() && r.template_error_mm.is_finite())
        .collect();
    if pts.is_empty() {
        return Err(FigureError::input(F, "no run with finite values to plot"));
    }
    pts.sort_by(|a, b| a.lambda.total_cmp(&b.lambda));
    let img = panel(&pts, runs.len() - pts.len(), opts).map_err(FigureError::render(F))?;
    Ok(Figure::new(F, img))
}

fn panel(
    pts: &[SweepPoint],
    left_out: usize,
    opts: &FigureOptions,
) -> Result<Image, unfold_render::RenderError> {
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut img = Image::new(w, h, PAPER)?;
    let mut subtitle = format!("{} run(s), labelled with lambda", pts.len());
    if left_out > 0 {
        subtitle.push_str(&format!("; {left_out} not finite, not drawn"));
    }
    title_band(&mut img, "template error against distortion", &subtitle)?;
    let lh = line_height();
    let y_range = padded_range(pts.iter().map(|p| p.template_error_mm)).unwrap_or((0.0, 1.0));
    let x_range =
        padded_range(pts.iter().map(|p| p.dirichlet_excess_percent)).unwrap_or((0.0, 1.0));
    let (xa, ya) = xy_frame(
        &mut img,
        x_range,
        y_range,
        "Dirichlet excess (%)",
        "template error (mm)",
    )?;
    let xy: Vec<[f64; 2]> = pts
        .iter()
        .map(|p| {
            [
                xa.pixel(p.dirichlet_excess_percent),
                ya.pixel(p.template_error_mm),
            ]
        })
        .collect();
    for seg in xy.windows(2) {
        img.line(seg[0], seg[1], CURVE);
        img.line(
            [seg[0][0], seg[0][1] + 1.0],
            [seg[1][0], seg[1][1] + 1.0],
            CURVE,
        );
    }
    for (c, p) in xy.iter().zip(pts) {
        img.fill_polygon(
            &arc(*c, 4.0, 0.0, std::f64::consts::TAU),
            FillRule::NonZero,
            CURVE,
        );
        text(
            &mut img,
            c[0] as i64 + 7,
            c[1] as i64 - lh,
            &format_value(p.lambda),
            INK,
            Anchor::Left,
        )?;
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs() -> Vec<SweepPoint> {
        [(10.0, 0.5, 2.0), (0.1, 9.0, 0.1), (1.0, 2.0, 0.6)]
            .iter()
            .map(|&(lambda, x, y)| SweepPoint {
                lambda,
                dirichlet_excess_percent: x,
                template_error_mm: y,
            })
            .collect()
    }

    fn count(img: &Image, c: Rgba) -> usize {
        (0..img.height() as i64)
            .flat_map(|y| (0..img.width() as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get(x, y) == Some(c))
            .count()
    }

    #[test]
    fn the_curve_is_drawn_and_deterministic() {
        let opts = FigureOptions::default();
        let f = lambda_sweep_plot(&runs(), &opts).unwrap();
        assert_eq!(f.name, LAMBDA_SWEEP_PNG);
        assert_eq!(
            (f.image.width(), f.image.height()),
            (opts.panel_width, opts.panel_height)
        );
        assert!(count(&f.image, CURVE) > 100);
        let g = lambda_sweep_plot(&runs(), &opts).unwrap();
        assert_eq!(f.image.as_bytes(), g.image.as_bytes());
        // The order of the runs given does not matter: drawn by lambda.
        let mut reversed = runs();
        reversed.reverse();
        let r = lambda_sweep_plot(&reversed, &opts).unwrap();
        assert_eq!(f.image.as_bytes(), r.image.as_bytes());
    }

    #[test]
    fn no_finite_run_or_a_tiny_panel_is_an_error() {
        let bad = [SweepPoint {
            lambda: 1.0,
            dirichlet_excess_percent: f64::NAN,
            template_error_mm: 1.0,
        }];
        let e = lambda_sweep_plot(&bad, &FigureOptions::default()).unwrap_err();
        assert!(e.to_string().contains("no run"), "{e}");
        let tiny = FigureOptions {
            panel_width: 100,
            panel_height: 100,
        };
        assert!(lambda_sweep_plot(&runs(), &tiny).is_err());
    }
}
