//! [`GRID_SWEEP_PNG`]: `unfold ventricle --grid-sweep`, the source
//! paper's Fig. 11: for each grid spacing of the Laplace field, the
//! round-trip error (mean and max, um; left panel) and the seconds (the
//! whole map and the Laplace field alone; right panel) against the spacing
//! (mm), the grids joined in order of spacing. Drawn with the cohort
//! figures' axes, like the placenta's lambda sweep.

use unfold_render::{Anchor, FillRule, Image, RenderError, Rgba, arc};

use crate::figures::cohort::axes::{
    TITLE_BAND, check_panel, line_height, padded_range, text, title_band, xy_frame,
};
use crate::figures::{Figure, FigureError, FigureOptions, PAPER};

/// File name of the figure.
pub const GRID_SWEEP_PNG: &str = "grid_sweep.png";

/// Colour of the first curve of a panel (mean error, whole map).
pub const FIRST: Rgba = Rgba::new(31, 119, 180, 255);
/// Colour of the second curve (max error, Laplace field).
pub const SECOND: Rgba = Rgba::new(214, 39, 40, 255);

/// One grid of a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridPoint {
    /// Grid spacing, mm.
    pub grid_mm: f64,
    /// Mean round-trip error, um.
    pub mean_um: f64,
    /// Largest round-trip error, um.
    pub max_um: f64,
    /// Seconds for the whole map (chart, forward and inverse).
    pub seconds: f64,
    /// Seconds for the Laplace field.
    pub laplace_seconds: f64,
}

/// [`GRID_SWEEP_PNG`] (2 x 1 panels): error and time against the grid.
/// Grids with a value that is not finite are left out of that curve.
///
/// # Errors
/// [`FigureError::Input`] for no grid or a panel too small; the
/// renderer's.
pub fn grid_sweep_plot(runs: &[GridPoint], opts: &FigureOptions) -> Result<Figure, FigureError> {
    const F: &str = GRID_SWEEP_PNG;
    check_panel(F, opts)?;
    let mut pts: Vec<GridPoint> = runs
        .iter()
        .copied()
        .filter(|r| r.grid_mm.is_finite())
        .collect();
    if pts.is_empty() {
        return Err(FigureError::input(F, "no grid to plot"));
    }
    pts.sort_by(|a, b| a.grid_mm.total_cmp(&b.grid_mm));
    let pw = opts.panel_width;
    let mut img = Image::new(2 * pw, opts.panel_height, PAPER).map_err(FigureError::render(F))?;
    let error = panel(
        opts,
        "round-trip error",
        "|v - psi^-1(psi(v))|",
        "error (um)",
        [
            ("mean", FIRST, pts.iter().map(|p| p.mean_um).collect()),
            ("max", SECOND, pts.iter().map(|p| p.max_um).collect()),
        ],
        &pts,
    )
    .map_err(FigureError::render(F))?;
    let time = panel(
        opts,
        "time",
        "chart, forward and inverse map; Laplace field alone",
        "seconds",
        [
            ("map", FIRST, pts.iter().map(|p| p.seconds).collect()),
            (
                "Laplace",
                SECOND,
                pts.iter().map(|p| p.laplace_seconds).collect(),
            ),
        ],
        &pts,
    )
    .map_err(FigureError::render(F))?;
    img.blit(&error, 0, 0);
    img.blit(&time, i64::from(pw), 0);
    Ok(Figure::new(F, img))
}

/// One panel: two curves against the grid spacing.
fn panel(
    opts: &FigureOptions,
    title: &str,
    subtitle: &str,
    y_label: &str,
    series: [(&str, Rgba, Vec<f64>); 2],
    pts: &[GridPoint],
) -> Result<Image, RenderError> {
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut img = Image::new(w, h, PAPER)?;
    title_band(&mut img, title, subtitle)?;
    let y_range = padded_range(series.iter().flat_map(|s| s.2.iter().copied()))
        .map(|(lo, hi)| (lo.max(0.0), hi))
        .unwrap_or((0.0, 1.0));
    let x_range = padded_range(pts.iter().map(|p| p.grid_mm)).unwrap_or((0.0, 1.0));
    let (xa, ya) = xy_frame(&mut img, x_range, y_range, "grid spacing (mm)", y_label)?;
    // the legend's corner: the frame's top right (see `xy_frame`)
    let lh = line_height();
    let (right, top) = (i64::from(w) - 16, TITLE_BAND + lh);
    for (k, (name, color, values)) in series.iter().enumerate() {
        let xy: Vec<[f64; 2]> = pts
            .iter()
            .zip(values)
            .filter(|(_, v)| v.is_finite())
            .map(|(p, v)| [xa.pixel(p.grid_mm), ya.pixel(*v)])
            .collect();
        for seg in xy.windows(2) {
            img.line(seg[0], seg[1], *color);
            img.line(
                [seg[0][0], seg[0][1] + 1.0],
                [seg[1][0], seg[1][1] + 1.0],
                *color,
            );
        }
        for c in &xy {
            img.fill_polygon(
                &arc(*c, 4.0, 0.0, std::f64::consts::TAU),
                FillRule::NonZero,
                *color,
            );
        }
        // the legend, top right inside the frame
        text(
            &mut img,
            right - 8,
            top + 6 + k as i64 * (lh + 2),
            name,
            *color,
            Anchor::Right,
        )?;
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs() -> Vec<GridPoint> {
        [
            (2.0, 0.3, 1.0, 0.5, 0.1),
            (0.5, 0.1, 0.4, 4.0, 3.0),
            (1.0, 0.2, 0.6, 1.0, 0.6),
        ]
        .iter()
        .map(
            |&(grid_mm, mean_um, max_um, seconds, laplace_seconds)| GridPoint {
                grid_mm,
                mean_um,
                max_um,
                seconds,
                laplace_seconds,
            },
        )
        .collect()
    }

    fn count(img: &Image, c: Rgba) -> usize {
        (0..img.height() as i64)
            .flat_map(|y| (0..img.width() as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get(x, y) == Some(c))
            .count()
    }

    #[test]
    fn both_panels_are_drawn_in_order_of_the_grid() {
        let opts = FigureOptions::default();
        let f = grid_sweep_plot(&runs(), &opts).unwrap();
        assert_eq!(f.name, GRID_SWEEP_PNG);
        assert_eq!(
            (f.image.width(), f.image.height()),
            (2 * opts.panel_width, opts.panel_height)
        );
        // each colour in both panels
        let half = |img: &Image, right: bool, c: Rgba| {
            let w = opts.panel_width as i64;
            (0..img.height() as i64)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .filter(|&(x, y)| img.get(x + if right { w } else { 0 }, y) == Some(c))
                .count()
        };
        for c in [FIRST, SECOND] {
            assert!(half(&f.image, false, c) > 50 && half(&f.image, true, c) > 50);
        }
        let mut reversed = runs();
        reversed.reverse();
        let g = grid_sweep_plot(&reversed, &opts).unwrap();
        assert_eq!(f.image.as_bytes(), g.image.as_bytes());
        assert!(count(&f.image, FIRST) > 100);
    }

    #[test]
    fn no_grid_or_a_tiny_panel_is_an_error() {
        let e = grid_sweep_plot(&[], &FigureOptions::default()).unwrap_err();
        assert!(e.to_string().contains("no grid"), "{e}");
        let tiny = FigureOptions {
            panel_width: 100,
            panel_height: 100,
        };
        assert!(grid_sweep_plot(&runs(), &tiny).is_err());
    }
}
