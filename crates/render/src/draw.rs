//! 2D drawing in pixel space: lines, polylines, filled polygons, arcs.
//!
//! Coordinates are `[x, y]` in pixels, y down; pixel `(i, j)` has its centre
//! at `(i + 0.5, j + 0.5)`. Every primitive clips to the image, and a
//! primitive with a non-finite coordinate draws nothing (a documented no-op,
//! never a panic).

use crate::{Image, Rgba};

/// How [`Image::fill_polygon`] decides which pixels are inside.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum FillRule {
    /// Inside where a ray crosses the boundary an odd number of times (a
    /// second ring inside the first makes a hole whatever its orientation).
    #[default]
    EvenOdd,
    /// Inside where the winding number is not zero.
    NonZero,
}

/// Walks the pixels of the segment `p0 -> p1`, one per column (x-major) or
/// per row (y-major), calling `f(x, y, t)` with `t` in [0, 1] the position of
/// the sample along the segment.
///
/// The segment is first clipped to the `width x height` image (plus one
/// pixel), so a long segment costs only what it covers. A segment that
/// crosses no pixel centre along its major axis plots the pixel holding its
/// midpoint.
pub(crate) fn walk_line(
    p0: [f64; 2],
    p1: [f64; 2],
    width: u32,
    height: u32,
    mut f: impl FnMut(i64, i64, f64),
) {
    if !(p0[0].is_finite() && p0[1].is_finite() && p1[0].is_finite() && p1[1].is_finite()) {
        return;
    }
    let (dx, dy) = (p1[0] - p0[0], p1[1] - p0[1]);
    // Liang-Barsky against [-1, w + 1] x [-1, h + 1].
    let (mut ta, mut tb) = (0.0f64, 1.0f64);
    let bounds = [
        (-dx, p0[0] + 1.0),
        (dx, f64::from(width) + 1.0 - p0[0]),
        (-dy, p0[1] + 1.0),
        (dy, f64::from(height) + 1.0 - p0[1]),
    ];
    for (p, q) in bounds {
        if p == 0.0 {
            if q < 0.0 {
                return;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                ta = ta.max(r);
            } else {
                tb = tb.min(r);
            }
        }
    }
    if ta > tb {
        return;
    }
    let x_major = dx.abs() >= dy.abs();
    let (d_major, start) = if x_major { (dx, p0[0]) } else { (dy, p0[1]) };
    let at = |t: f64| [p0[0] + t * dx, p0[1] + t * dy];
    if d_major == 0.0 {
        let p = at(ta);
        f(p[0].floor() as i64, p[1].floor() as i64, ta);
        return;
    }
    let (a, b) = (start + ta * d_major, start + tb * d_major);
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    let first = (lo - 0.5).ceil() as i64;
    let last = (hi - 0.5).floor() as i64;
    if first > last {
        let t = 0.5 * (ta + tb);
        let p = at(t);
        f(p[0].floor() as i64, p[1].floor() as i64, t);
        return;
    }
    for k in first..=last {
        let c = k as f64 + 0.5;
        let t = ((c - start) / d_major).clamp(0.0, 1.0);
        let p = at(t);
        if x_major {
            f(k, p[1].floor() as i64, t);
        } else {
            f(p[0].floor() as i64, k, t);
        }
    }
}

impl Image {
    /// Draws a 1-pixel line from `p0` to `p1` (both ends included): one pixel
    /// per column for lines closer to horizontal, one per row otherwise, the
    /// pixel whose square holds the line at the column's (row's) centre.
    pub fn line(&mut self, p0: [f64; 2], p1: [f64; 2], c: Rgba) {
        let (w, h) = (self.width(), self.height());
        walk_line(p0, p1, w, h, |x, y, _| {
            self.put(x, y, c);
        });
    }

    /// Draws the 1-pixel polyline through `points`, closing it back to the
    /// first point if `closed`. Fewer than two points draw at most one
    /// pixel (a single point draws the pixel holding it).
    pub fn polyline(&mut self, points: &[[f64; 2]], closed: bool, c: Rgba) {
        match points {
            [] => {}
            [p] => self.line(*p, *p, c),
            _ => {
                for w in points.windows(2) {
                    self.line(w[0], w[1], c);
                }
                if closed {
                    self.line(points[points.len() - 1], points[0], c);
                }
            }
        }
    }

    /// Fills the polygon `points` (implicitly closed) with `c`; see
    /// [`Image::fill_rings`].
    pub fn fill_polygon(&mut self, points: &[[f64; 2]], rule: FillRule, c: Rgba) {
        self.fill_rings(&[points], rule, c);
    }

    /// Fills the region bounded by one or more closed rings (e.g. an outer
    /// boundary and holes) with `c`.
    ///
    /// Scanline fill with pixel-centre sampling: pixel `(i, j)` is filled when
    /// its centre `(i + 0.5, j + 0.5)` is inside under `rule`. An edge from
    /// `y_a` to `y_b` counts for the rows with `min(y_a, y_b) <= y_c <
    /// max(y_a, y_b)`, and a crossing at `x` turns on the pixels with centre
    /// `>= x`, so two polygons sharing an edge cover each pixel exactly once.
    /// Rings with a non-finite point make the call a no-op.
    pub fn fill_rings(&mut self, rings: &[&[[f64; 2]]], rule: FillRule, c: Rgba) {
        // Edges (top point, bottom point, winding direction).
        let mut edges: Vec<([f64; 2], [f64; 2], i32)> = Vec::new();
        for ring in rings {
            if ring.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
                return;
            }
            for (k, &a) in ring.iter().enumerate() {
                let b = ring[(k + 1) % ring.len()];
                if a[1] < b[1] {
                    edges.push((a, b, 1));
                } else if a[1] > b[1] {
                    edges.push((b, a, -1));
                }
            }
        }
        if edges.is_empty() {
            return;
        }
        let ymin = edges.iter().map(|e| e.0[1]).fold(f64::INFINITY, f64::min);
        let ymax = edges
            .iter()
            .map(|e| e.1[1])
            .fold(f64::NEG_INFINITY, f64::max);
        let row0 = ((ymin - 0.5).ceil() as i64).max(0);
        let row1 = ((ymax - 0.5).ceil() as i64).min(i64::from(self.height()));
        let w = i64::from(self.width());
        let mut xs: Vec<(f64, i32)> = Vec::new();
        for j in row0..row1 {
            let yc = j as f64 + 0.5;
            xs.clear();
            for &(a, b, dir) in &edges {
                if a[1] <= yc && yc < b[1] {
                    let x = a[0] + (yc - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                    xs.push((x, dir));
                }
            }
            xs.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
            let mut winding = 0i32;
            for k in 0..xs.len() {
                winding += match rule {
                    FillRule::EvenOdd => 1,
                    FillRule::NonZero => xs[k].1,
                };
                let inside = match rule {
                    FillRule::EvenOdd => winding % 2 != 0,
                    FillRule::NonZero => winding != 0,
                };
                if inside && k + 1 < xs.len() {
                    let i0 = ((xs[k].0 - 0.5).ceil() as i64).max(0);
                    let i1 = ((xs[k + 1].0 - 0.5).ceil() as i64).min(w);
                    for i in i0..i1 {
                        self.put(i, j, c);
                    }
                }
            }
        }
    }
}

/// Points of the circular arc of radius `r` about `centre` from angle `a0` to
/// `a1` (radians), both ends included:
/// `p(a) = (c_x + r cos a, c_y - r sin a)`, so angles grow counter-clockwise
/// on screen (y down) and 0 points right.
///
/// The arc is cut into `n = ceil(|a1 - a0| / (2 acos(1 - 0.25 / r)))` chords
/// (at most a quarter pixel from the circle), `1 <= n <= 4096`. Non-finite
/// input or a negative radius gives an empty vector.
pub fn arc(centre: [f64; 2], r: f64, a0: f64, a1: f64) -> Vec<[f64; 2]> {
    if !(centre[0].is_finite()
        && centre[1].is_finite()
        && r.is_finite()
        && a0.is_finite()
        && a1.is_finite())
        || r < 0.0
    {
        return Vec::new();
    }
    let step = if r > 0.25 {
        2.0 * (1.0 - 0.25 / r).acos()
    } else {
        std::f64::consts::PI
    };
    let n = ((a1 - a0).abs() / step).ceil().clamp(1.0, 4096.0) as usize;
    (0..=n)
        .map(|k| {
            let a = a0 + (a1 - a0) * k as f64 / n as f64;
            [centre[0] + r * a.cos(), centre[1] - r * a.sin()]
        })
        .collect()
}

/// The closed outline of the annular sector `r_inner <= r <= r_outer`,
/// `a0 <= a <= a1` about `centre` (angles as in [`arc`]): the outer arc from
/// `a0` to `a1` then the inner arc back. With `r_inner == 0` the inner arc is
/// the centre alone (a pie slice). Fill it with [`Image::fill_polygon`]; for
/// a full ring use two circles and [`Image::fill_rings`] instead. Invalid
/// input (non-finite, `r_inner < 0`, `r_outer < r_inner`) gives an empty
/// vector.
pub fn annular_sector(
    centre: [f64; 2],
    r_inner: f64,
    r_outer: f64,
    a0: f64,
    a1: f64,
) -> Vec<[f64; 2]> {
    if !(r_inner.is_finite() && r_outer.is_finite()) || r_inner < 0.0 || r_outer < r_inner {
        return Vec::new();
    }
    let mut pts = arc(centre, r_outer, a0, a1);
    if pts.is_empty() {
        return pts;
    }
    if r_inner == 0.0 {
        pts.push(centre);
    } else {
        let mut inner = arc(centre, r_inner, a0, a1);
        inner.reverse();
        pts.extend(inner);
    }
    pts
}
