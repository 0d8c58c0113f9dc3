//! The convex hull of points in the plane (Andrew's monotone chain); the
//! hull of points in space is [`super::convex_hull_vertices`].
//!
//! The points are sorted by `(x, y)` (total order) and exact duplicates
//! dropped; the lower chain is built left to right and the upper one right
//! to left, each popping its last point while the turn
//!
//! ```text
//! cross(o, a, b) = (a - o) x (b - o) = (ax - ox)(by - oy) - (ay - oy)(bx - ox)
//! ```
//!
//! of the last two points `o, a` and the new point `b` is `<= 0` (clockwise
//! or collinear). So the hull is counter-clockwise, starts at the smallest
//! `(x, y)`, and keeps only strict corners: points on a hull edge are
//! dropped (up to the rounding of `cross`, which is not an exact predicate).

/// The convex hull of `points`, counter-clockwise from the smallest
/// `(x, y)`, strict corners only (module doc). Fewer than three distinct
/// points are returned as they are, sorted and deduplicated (all collinear
/// points give the two ends). Points with a NaN coordinate are not
/// supported (they sort last but break the turn test).
pub fn convex_hull_2d(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &x in iter {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], x) <= 0.0 {
                h.pop();
            }
            h.push(x);
        }
        h.pop();
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::orient2d_exact;
    use proptest::prelude::*;

    #[test]
    fn square_with_inner_and_edge_points() {
        let pts = [
            [1.0, 1.0],
            [0.0, 0.0],
            [0.5, 0.0], // on an edge: dropped
            [1.0, 0.0],
            [0.3, 0.4], // inside
            [0.0, 1.0],
            [0.0, 0.0], // duplicate
        ];
        assert_eq!(
            convex_hull_2d(&pts),
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        );
        assert!(convex_hull_2d(&[]).is_empty());
        assert_eq!(convex_hull_2d(&[[2.0, 1.0], [2.0, 1.0]]), vec![[2.0, 1.0]]);
        // collinear: the two ends
        assert_eq!(
            convex_hull_2d(&[[0.0, 0.0], [2.0, 2.0], [1.0, 1.0]]),
            vec![[0.0, 0.0], [2.0, 2.0]]
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Against brute force on integer points (exact arithmetic): the
        /// hull is counter-clockwise and strictly convex, every point is on
        /// its closed side of every edge, and the hull's corners are
        /// exactly the points that are no convex combination of the others
        /// (some point strictly outside a supporting edge otherwise).
        #[test]
        fn hull_matches_brute_force(
            pts in prop::collection::vec(prop::array::uniform2(-20i32..20), 0..40),
        ) {
            let pts: Vec<[f64; 2]> = pts.iter().map(|q| [q[0] as f64, q[1] as f64]).collect();
            let h = convex_hull_2d(&pts);
            for q in &h {
                prop_assert!(pts.contains(q));
            }
            if h.len() >= 3 {
                let n = h.len();
                for k in 0..n {
                    let (a, b, c) = (h[k], h[(k + 1) % n], h[(k + 2) % n]);
                    prop_assert!(orient2d_exact(a, b, c) > 0.0, "not strictly convex");
                    for q in &pts {
                        prop_assert!(orient2d_exact(a, b, *q) >= 0.0, "point outside");
                    }
                }
                // Brute force: a point is a corner iff some direction makes
                // it the unique extreme point; for integer points checking
                // the directions perpendicular to all point pairs suffices,
                // so test instead: q is a corner iff q is not inside or on
                // the boundary of the hull of the other points.
                for q in &pts {
                    let others: Vec<[f64; 2]> =
                        pts.iter().filter(|r| *r != q).copied().collect();
                    let ho = convex_hull_2d(&others);
                    let covered = if ho.len() >= 3 {
                        (0..ho.len()).all(|k| {
                            orient2d_exact(ho[k], ho[(k + 1) % ho.len()], *q) >= 0.0
                        })
                    } else if ho.len() == 2 {
                        orient2d_exact(ho[0], ho[1], *q) == 0.0
                            && (0..2).all(|i| {
                                q[i] >= ho[0][i].min(ho[1][i]) && q[i] <= ho[0][i].max(ho[1][i])
                            })
                    } else {
                        ho.first() == Some(q)
                    };
                    prop_assert_eq!(h.contains(q), !covered, "point {:?}", q);
                }
            } else {
                // all distinct points collinear (or fewer than three)
                let mut d = pts.clone();
                d.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
                d.dedup();
                for q in &d {
                    prop_assert!(orient2d_exact(d[0], d[d.len() - 1], *q) == 0.0);
                }
            }
        }
    }
}
