//! Welding coincident vertices: files written as triangle soups (STL, many
//! exporters) repeat a vertex once per element that uses it, so a surface
//! falls apart into separate triangles until the copies are merged.
//!
//! Two vertices are welded when they are within `tolerance` of each other
//! (Euclidean), and welding is transitive (a chain of close vertices becomes
//! one). Candidates are found on a uniform grid of cell size `tolerance`, so
//! the work is linear in the number of vertices for any sensible tolerance.

use crate::MeshError;
use nalgebra::Point3;
use std::collections::HashMap;

/// The relative weld tolerance of [`default_tolerance`]: a millionth of the
/// mean edge length, far below any real edge and above the rounding of
/// coordinates written with 7 or more significant digits.
pub const RELATIVE_TOLERANCE: f64 = 1e-6;

/// The result of [`weld`]: every old vertex's new index, and the old index
/// of each new vertex (the lowest of those welded into it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Welded {
    /// `new_of[old]`: the vertex `old` became.
    pub new_of: Vec<u32>,
    /// `kept[new]`: the old vertex whose position (and point data) the new
    /// vertex takes; increasing.
    pub kept: Vec<usize>,
}

impl Welded {
    /// How many vertices were merged away (`old count - new count`).
    pub fn merged(&self) -> usize {
        self.new_of.len() - self.kept.len()
    }

    /// `elements` renumbered to the welded vertices (an element may now
    /// repeat a vertex; the repair drops it).
    pub fn remap<const K: usize>(&self, elements: &[[u32; K]]) -> Vec<[u32; K]> {
        elements
            .iter()
            .map(|e| e.map(|v| self.new_of[v as usize]))
            .collect()
    }
}

/// The default weld distance: `RELATIVE_TOLERANCE` times the mean edge
/// length of `elements`, but at most a quarter of their shortest non-zero
/// edge, so that no chain of welds shorter than four links can merge two
/// distinct corners of one element of a clean mesh (0 for no element or a
/// mesh whose edges all have length 0).
pub fn default_tolerance<const K: usize>(positions: &[Point3<f64>], elements: &[[u32; K]]) -> f64 {
    let (mut sum, mut count, mut shortest) = (0.0, 0usize, f64::INFINITY);
    for e in elements {
        for i in 0..K {
            for j in i + 1..K {
                let (a, b) = (e[i] as usize, e[j] as usize);
                if let (Some(p), Some(q)) = (positions.get(a), positions.get(b)) {
                    let d = (p - q).norm();
                    if d.is_finite() {
                        sum += d;
                        count += 1;
                        if d > 0.0 {
                            shortest = shortest.min(d);
                        }
                    }
                }
            }
        }
    }
    if count == 0 || sum == 0.0 {
        0.0
    } else {
        (RELATIVE_TOLERANCE * sum / count as f64).min(0.25 * shortest)
    }
}

fn find(parent: &mut [usize], mut v: usize) -> usize {
    while parent[v] != v {
        parent[v] = parent[parent[v]];
        v = parent[v];
    }
    v
}

/// Welds the vertices within `tolerance` of each other (see the module
/// docs); `tolerance = 0` welds exactly equal positions only.
///
/// # Errors
/// [`MeshError::WeldTolerance`] for a negative, NaN or infinite tolerance;
/// [`MeshError::NonFiniteCoordinate`] for a NaN or infinite coordinate.
pub fn weld(positions: &[Point3<f64>], tolerance: f64) -> Result<Welded, MeshError> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(MeshError::WeldTolerance { tolerance });
    }
    crate::geometry::check_finite(positions)?;
    let n = positions.len();
    let mut parent: Vec<usize> = (0..n).collect();
    if tolerance == 0.0 {
        let mut first: HashMap<[u64; 3], usize> = HashMap::with_capacity(n);
        for (v, p) in positions.iter().enumerate() {
            // +0.0 and -0.0 are the same point.
            let key = [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits());
            let r = *first.entry(key).or_insert(v);
            parent[v] = r;
        }
    } else {
        let cell = |p: &Point3<f64>| [p.x, p.y, p.z].map(|c| (c / tolerance).floor() as i64);
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::with_capacity(n);
        for (v, p) in positions.iter().enumerate() {
            let c = cell(p);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(others) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                            continue;
                        };
                        for &u in others {
                            if (positions[u] - p).norm() <= tolerance {
                                let (ru, rv) = (find(&mut parent, u), find(&mut parent, v));
                                if ru != rv {
                                    parent[ru.max(rv)] = ru.min(rv);
                                }
                            }
                        }
                    }
                }
            }
            grid.entry(c).or_default().push(v);
        }
    }
    // Representatives are the lowest index of their class, so they come
    // first in index order: number them, then point every vertex at its
    // representative's number.
    let roots: Vec<usize> = (0..n).map(|v| find(&mut parent, v)).collect();
    let kept: Vec<usize> = (0..n).filter(|&v| roots[v] == v).collect();
    let mut number = vec![u32::MAX; n];
    for (k, &v) in kept.iter().enumerate() {
        number[v] = k as u32;
    }
    let new_of = roots.iter().map(|&r| number[r]).collect();
    Ok(Welded { new_of, kept })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn exact_copies_weld_and_distinct_points_do_not() {
        let p = |x: f64| Point3::new(x, 0.0, 0.0);
        let pts = [p(0.0), p(1.0), p(0.0), p(-0.0), p(1.0 + 1e-9), p(2.0)];
        let w = weld(&pts, 0.0).unwrap();
        assert_eq!(w.kept, vec![0, 1, 4, 5]);
        assert_eq!(w.new_of, vec![0, 1, 0, 0, 2, 3]);
        let w = weld(&pts, 1e-6).unwrap();
        assert_eq!(w.kept, vec![0, 1, 5]);
        assert_eq!(w.merged(), 3);
        assert_eq!(
            w.remap(&[[0u32, 4, 5], [2, 3, 1]]),
            vec![[0, 1, 2], [0, 0, 1]]
        );
    }

    #[test]
    fn the_default_tolerance_never_spans_an_element() {
        // A needle: one edge a billionth of the others.
        let p = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(1.0, 1e-9, 0.0),
        ];
        let t = default_tolerance(&p, &[[0u32, 1, 2]]);
        assert!(t > 0.0 && t <= 0.25e-9, "{t}");
        assert_eq!(weld(&p, t).unwrap().merged(), 0);
        let square = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        let t = default_tolerance(&square, &[[0u32, 1, 2]]);
        assert!((t - RELATIVE_TOLERANCE * (2.0 + 2f64.sqrt()) / 3.0).abs() < 1e-18);
        assert_eq!(default_tolerance::<3>(&square, &[]), 0.0);
    }

    #[test]
    fn bad_tolerances_and_coordinates_are_errors() {
        let pts = [Point3::origin()];
        for t in [-1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                weld(&pts, t),
                Err(MeshError::WeldTolerance { .. })
            ));
        }
        let bad = [Point3::new(f64::NAN, 0.0, 0.0)];
        assert!(weld(&bad, 1e-3).is_err());
    }

    proptest! {
        /// Copies of distinct points, moved by less than the tolerance,
        /// weld back onto the originals, whatever the order.
        #[test]
        fn copies_weld_back(
            coords in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64), 1..40),
            copies in prop::collection::vec((0usize..1000, -1.0..1.0f64), 0..60),
        ) {
            // Distinct points: on a 0.5 grid, duplicates removed.
            let mut base: Vec<Point3<f64>> = coords
                .iter()
                .map(|&(x, y, z)| Point3::new((x * 2.0).round() / 2.0, (y * 2.0).round() / 2.0, (z * 2.0).round() / 2.0))
                .collect();
            base.sort_by(|a, b| a.coords.as_slice().partial_cmp(b.coords.as_slice()).unwrap());
            base.dedup();
            let tol = 1e-3;
            let mut pts = base.clone();
            let mut origin: Vec<usize> = (0..base.len()).collect();
            for &(k, e) in &copies {
                let i = k % base.len();
                pts.push(base[i] + nalgebra::Vector3::new(e, -e, 0.5 * e) * (0.5 * tol / 1.5));
                origin.push(i);
            }
            let w = weld(&pts, tol).unwrap();
            prop_assert_eq!(w.kept.len(), base.len());
            prop_assert_eq!(&w.kept, &(0..base.len()).collect::<Vec<_>>());
            for (v, &o) in origin.iter().enumerate() {
                prop_assert_eq!(w.new_of[v] as usize, o);
            }
        }
    }
}
