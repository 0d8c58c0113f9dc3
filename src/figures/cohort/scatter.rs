//! A measurement against a covariate: the subjects as points (coloured by
//! a categorical covariate when given, with a legend), the least-squares
//! line `y = a + b x` ([`least_squares`]) and a label with `b`, `r^2` and
//! `n`.

use unfold_render::{Anchor, Colormap, FillRule, Image, Rect, Rgba, arc, format_value, text_width};

use super::axes::{
    Axis, SOFT_INK, TITLE_BAND, check_panel, clamp32, draw_frame, label_width, line_height,
    nice_ticks, padded_range, text, title_band,
};
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// Colour of the points when there is no categorical covariate, and of the
/// fitted line.
pub const POINT: Rgba = Rgba::new(31, 119, 180, 255);

/// Colour of the fitted line.
pub const FIT_LINE: Rgba = Rgba::new(214, 39, 40, 255);

/// The colours of the categories, in their sorted order.
pub const CATEGORY_COLORMAP: Colormap = Colormap::Tableau10;

/// A least-squares line `y = a + b x` and how well it fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Intercept `a = mean(y) - b mean(x)`.
    pub a: f64,
    /// Slope `b = S_xy / S_xx` with `S_xy = sum (x - mean x)(y - mean y)`
    /// and `S_xx = sum (x - mean x)^2`.
    pub b: f64,
    /// Coefficient of determination `r^2 = S_xy^2 / (S_xx S_yy)`, 1 when
    /// every `y` is the same (`S_yy = 0`: the line goes through every point).
    pub r2: f64,
    /// Number of points fitted.
    pub n: usize,
}

/// The least-squares line through the points `(x, y)` whose coordinates
/// are both finite; `None` with fewer than 2 such points or when all their
/// `x` are equal (`S_xx = 0`: no line is defined).
pub fn least_squares(points: &[(f64, f64)]) -> Option<LineFit> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let n = p.len();
    if n < 2 {
        return None;
    }
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n as f64;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for &(x, y) in &p {
        let (dx, dy) = (x - mx, y - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if sxx <= 0.0 {
        return None;
    }
    let b = sxy / sxx;
    let r2 = if syy > 0.0 {
        (sxy * sxy / (sxx * syy)).min(1.0)
    } else {
        1.0
    };
    Some(LineFit {
        a: my - b * mx,
        b,
        r2,
        n,
    })
}

/// One subject in a scatter plot.
#[derive(Debug, Clone, PartialEq)]
pub struct ScatterPoint {
    /// Covariate value.
    pub x: f64,
    /// Measurement.
    pub y: f64,
    /// Category (of the colouring covariate), when there is one.
    pub category: Option<String>,
}

/// What a scatter plot shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Scatter {
    /// The measurement (y axis).
    pub measure: String,
    /// The covariate (x axis).
    pub covariate: String,
    /// The categorical covariate colouring the points, if any.
    pub colour_by: Option<String>,
    /// The points (non-finite ones are left out).
    pub points: Vec<ScatterPoint>,
}

/// The label of a least-squares fit: `y = a + b x: a = ..., b = ..., r^2 = ...,
/// n = ...`.
pub fn fit_label(fit: &LineFit) -> String {
    format!(
        "y = a + b x: a = {}, b = {}, r^2 = {}, n = {}",
        format_value(fit.a),
        format_value(fit.b),
        format_value(fit.r2),
        fit.n
    )
}

/// The scatter figure `name` (one panel): `measure` against `covariate`,
/// the points coloured by category ([`CATEGORY_COLORMAP`], categories in
/// sorted order, legend under the title) or all [`POINT`], the
/// least-squares line across the x range in [`FIT_LINE`], and the fit's
/// label ([`fit_label`]) as subtitle.
///
/// # Errors
/// [`FigureError::Input`] for a panel smaller than the cohort figures'
/// minimum or fewer than 2 points with distinct `x`; the renderer's.
pub fn scatter(name: &str, s: &Scatter, opts: &FigureOptions) -> Result<Figure, FigureError> {
    check_panel(name, opts)?;
    let err = || FigureError::render(name);
    let pts: Vec<&ScatterPoint> = s
        .points
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .collect();
    let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.x, p.y)).collect();
    let fit = least_squares(&xy).ok_or_else(|| {
        FigureError::input(
            name,
            format!(
                "{} point(s) with distinct {} values are too few for a line",
                xy.len(),
                s.covariate
            ),
        )
    })?;
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut img = Image::new(w, h, PAPER).map_err(err())?;
    title_band(
        &mut img,
        &format!("{} against {}", s.measure, s.covariate),
        &fit_label(&fit),
    )
    .map_err(err())?;
    let lh = line_height();
    // Legend row under the title band.
    let mut cats: Vec<&str> = pts.iter().filter_map(|p| p.category.as_deref()).collect();
    cats.sort_unstable();
    cats.dedup();
    let colour = |c: Option<&str>| match c.and_then(|c| cats.iter().position(|k| *k == c)) {
        Some(i) => CATEGORY_COLORMAP.label(i).opaque(),
        None if cats.is_empty() => POINT,
        None => SOFT_INK,
    };
    let mut y0 = TITLE_BAND;
    if let (Some(by), false) = (&s.colour_by, cats.is_empty()) {
        let mut x = 12i64;
        let r = text(&mut img, x, y0, &format!("{by}:"), SOFT_INK, Anchor::Left).map_err(err())?;
        x += i64::from(r.width) + 10;
        for c in &cats {
            let tw = i64::from(text_width(c, 1));
            if x + 12 + tw > i64::from(w) - 8 {
                break;
            }
            dot(
                &mut img,
                [x as f64 + 4.0, (y0 + lh / 2) as f64],
                4.0,
                colour(Some(c)),
            );
            text(&mut img, x + 12, y0, c, INK, Anchor::Left).map_err(err())?;
            x += 12 + tw + 14;
        }
        y0 += lh + 6;
    }
    let top = y0 + lh + 10;
    let bottom = i64::from(h) - 2 * lh - 22;
    let (ylo, yhi) = padded_range(xy.iter().map(|p| p.1)).unwrap_or((0.0, 1.0));
    let (xlo, xhi) = padded_range(xy.iter().map(|p| p.0)).unwrap_or((0.0, 1.0));
    let rows = (bottom - top).max(20);
    let y_ticks = nice_ticks(ylo, yhi, (rows / 40).clamp(2, 8) as usize);
    let left = 12 + label_width(&y_ticks);
    let right = i64::from(w) - 16;
    let cols = (right - left).max(20);
    let x_ticks = nice_ticks(xlo, xhi, (cols / 70).clamp(2, 8) as usize);
    let area = Rect::new(clamp32(left), clamp32(top), cols as u32, rows as u32);
    let ya = Axis::over(&y_ticks, (area.bottom() - 1) as f64, top as f64);
    let xa = Axis::over(&x_ticks, left as f64, (area.right() - 1) as f64);
    draw_frame(
        &mut img,
        area,
        &ya,
        &y_ticks,
        Some((&xa, &x_ticks)),
        &s.measure,
        &s.covariate,
    )
    .map_err(err())?;
    // The line, clipped to the frame by sampling it densely.
    let (x_a, x_b) = (xa.lo, xa.hi);
    let steps = cols.max(1);
    let mut prev: Option<[f64; 2]> = None;
    for k in 0..=steps {
        let xv = x_a + (x_b - x_a) * k as f64 / steps as f64;
        let yv = fit.a + fit.b * xv;
        let p = [xa.pixel(xv), ya.pixel(yv)];
        let inside = p[1] >= f64::from(area.y) && p[1] <= (area.bottom() - 1) as f64;
        if let (Some(q), true) = (prev, inside) {
            img.line(q, p, FIT_LINE);
            img.line([q[0], q[1] + 1.0], [p[0], p[1] + 1.0], FIT_LINE);
        }
        prev = inside.then_some(p);
    }
    // Points in a fixed order (sorted by x, y, category) so that the
    // picture does not depend on the order of the subjects.
    let mut order: Vec<&&ScatterPoint> = pts.iter().collect();
    order.sort_by(|a, b| {
        a.x.total_cmp(&b.x)
            .then(a.y.total_cmp(&b.y))
            .then(a.category.cmp(&b.category))
    });
    for p in order {
        let c = [xa.pixel(p.x), ya.pixel(p.y)];
        dot(&mut img, c, 5.0, PAPER);
        dot(&mut img, c, 4.0, colour(p.category.as_deref()));
    }
    Ok(Figure::new(name, img))
}

/// A filled disk of radius `r` about `c`.
fn dot(img: &mut Image, c: [f64; 2], r: f64, fill: Rgba) {
    img.fill_polygon(
        &arc(c, r, 0.0, std::f64::consts::TAU),
        FillRule::NonZero,
        fill,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn points() -> Vec<ScatterPoint> {
        (0..6)
            .map(|k| ScatterPoint {
                x: f64::from(k),
                y: 2.0 * f64::from(k) + if k % 2 == 0 { 0.5 } else { -0.5 },
                category: Some(if k < 3 { "a" } else { "b" }.to_string()),
            })
            .collect()
    }

    #[test]
    fn the_plot_is_deterministic_and_independent_of_the_order() {
        let opts = FigureOptions::default();
        let s = Scatter {
            measure: "m".into(),
            covariate: "c".into(),
            colour_by: Some("g".into()),
            points: points(),
        };
        let mut r = s.clone();
        r.points.reverse();
        let a = scatter("s.png", &s, &opts).unwrap().image.to_png().unwrap();
        let b = scatter("s.png", &s, &opts).unwrap().image.to_png().unwrap();
        let c = scatter("s.png", &r, &opts).unwrap().image.to_png().unwrap();
        assert_eq!(a, b);
        assert_eq!(a, c);
        let img = scatter("s.png", &s, &opts).unwrap().image;
        let has = |c: Rgba| {
            (0..img.height())
                .any(|y| (0..img.width()).any(|x| img.get(i64::from(x), i64::from(y)) == Some(c)))
        };
        assert!(has(FIT_LINE));
        assert!(has(CATEGORY_COLORMAP.label(0).opaque()));
        assert!(has(CATEGORY_COLORMAP.label(1).opaque()));
        let one = Scatter {
            points: points().into_iter().take(1).collect(),
            ..s
        };
        assert!(matches!(
            scatter("s.png", &one, &opts),
            Err(FigureError::Input { .. })
        ));
    }

    #[test]
    fn a_known_fit() {
        // mean x = 1.5, mean y = 4, S_xy = 8, S_xx = 5: b = 1.6, a = 1.6.
        let f = least_squares(&[(0.0, 2.0), (1.0, 2.0), (2.0, 6.0), (3.0, 6.0)]).unwrap();
        assert!((f.b - 1.6).abs() < 1e-12, "{f:?}");
        assert!((f.a - 1.6).abs() < 1e-12, "{f:?}");
        // S_yy = 16: r^2 = 64 / 80.
        assert!((f.r2 - 0.8).abs() < 1e-12, "{f:?}");
        assert_eq!(f.n, 4);
        assert_eq!(least_squares(&[(1.0, 2.0)]), None);
        assert_eq!(least_squares(&[(1.0, 2.0), (1.0, 3.0)]), None);
        assert_eq!(
            least_squares(&[(0.0, 1.0), (1.0, f64::NAN), (2.0, 1.0)])
                .unwrap()
                .n,
            2
        );
    }

    proptest! {
        #[test]
        fn points_on_a_line_give_the_line_back_with_r2_one(
            a in -1e3f64..1e3,
            b in -1e2f64..1e2,
            xs in proptest::collection::btree_set(-1000i32..1000, 2..30),
        ) {
            let pts: Vec<(f64, f64)> = xs
                .iter()
                .map(|&x| (f64::from(x) / 10.0, a + b * f64::from(x) / 10.0))
                .collect();
            let f = least_squares(&pts).unwrap();
            let tol = 1e-9 * (1.0 + a.abs() + 100.0 * b.abs());
            prop_assert!((f.b - b).abs() <= 1e-9 * (1.0 + b.abs()), "{:?}", f);
            prop_assert!((f.a - a).abs() <= tol, "{:?}", f);
            prop_assert!((f.r2 - 1.0).abs() <= 1e-9, "{:?}", f);
            prop_assert_eq!(f.n, pts.len());
        }
    }
}
