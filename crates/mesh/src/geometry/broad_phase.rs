//! Broad phase: the pairs of axis-aligned boxes that meet, on a uniform grid.
//!
//! Every box is entered in the grid cells its extent covers; two boxes are
//! compared only when they share a cell, and a meeting pair is kept only in
//! the cell holding the lowest corner of their common box,
//! `m_a = max(min1_a, min2_a)`, so that it is reported once. The cell size
//! `h` is the mean longest side of the boxes, raised until the grid has at
//! most `4 n + 64` cells (`n` boxes), so a mesh of evenly sized elements
//! costs `O(n log n)` (the sort of the cell entries) whatever its shape.
//! A box over more than 64 cells (a sliver across the mesh) is compared
//! with every box instead, so that a few of them cost `O(n)` each rather
//! than filling the grid.

use super::Aabb;
use rayon::prelude::*;

/// The pairs `[i, j]`, `i < j`, of boxes that meet (closed boxes: touching
/// counts), in ascending order. Empty boxes and boxes with a non-finite
/// bound take part in no pair.
pub fn overlapping_box_pairs(boxes: &[Aabb]) -> Vec<[u32; 2]> {
    let mut pairs = filter_box_pairs(boxes, |i, j| Some([i, j]));
    pairs.par_sort_unstable();
    pairs
}

/// `keep(i, j)` for every pair `i < j` of boxes that meet (as
/// [`overlapping_box_pairs`]), in parallel, without listing the pairs:
/// the `Some` values, in an order that depends only on the boxes (grid
/// cell by cell).
pub(crate) fn filter_box_pairs<T: Send>(
    boxes: &[Aabb],
    keep: impl Fn(u32, u32) -> Option<T> + Sync,
) -> Vec<T> {
    let usable: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| {
            let b = &boxes[i as usize];
            !b.is_empty() && (0..3).all(|a| b.min[a].is_finite() && b.max[a].is_finite())
        })
        .collect();
    if usable.len() < 2 {
        return Vec::new();
    }
    let total = usable
        .iter()
        .fold(Aabb::empty(), |acc, &i| acc.union(&boxes[i as usize]));
    let grid = Grid::new(&total, boxes, &usable);

    // (cell, box) entries, grouped by cell; boxes over more than
    // LARGE_CELLS cells are compared with every box instead (a few slivers
    // across the mesh must not fill the grid).
    let mut entries: Vec<(u64, u32)> = Vec::with_capacity(2 * usable.len());
    let mut large: Vec<u32> = Vec::new();
    for &i in &usable {
        let b = &boxes[i as usize];
        let (lo, hi) = (grid.cell(&b.min), grid.cell(&b.max));
        if (0..3).map(|a| hi[a] - lo[a] + 1).product::<u64>() > LARGE_CELLS {
            large.push(i);
            continue;
        }
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    entries.push((grid.key([x, y, z]), i));
                }
            }
        }
    }
    entries.par_sort_unstable();
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    while s < entries.len() {
        let mut e = s + 1;
        while e < entries.len() && entries[e].0 == entries[s].0 {
            e += 1;
        }
        if e - s > 1 {
            groups.push((s, e));
        }
        s = e;
    }
    let chunk = groups
        .len()
        .div_ceil(4 * rayon::current_num_threads())
        .max(64);
    groups
        .par_chunks(chunk)
        .flat_map_iter(|chunk| {
            let mut found = Vec::new();
            for &(s, e) in chunk {
                let cell = entries[s].0;
                let group = &entries[s..e];
                for (k, &(_, i)) in group.iter().enumerate() {
                    let bi = &boxes[i as usize];
                    for &(_, j) in &group[k + 1..] {
                        let bj = &boxes[j as usize];
                        if !meet(bi, bj) {
                            continue;
                        }
                        let corner = nalgebra::Point3::new(
                            bi.min.x.max(bj.min.x),
                            bi.min.y.max(bj.min.y),
                            bi.min.z.max(bj.min.z),
                        );
                        if grid.key(grid.cell(&corner)) == cell
                            && let Some(x) = keep(i, j)
                        {
                            found.push(x);
                        }
                    }
                }
            }
            found
        })
        .chain(large.par_iter().flat_map_iter(|&l| {
            let bl = &boxes[l as usize];
            let is_large = |j: u32| large.binary_search(&j).is_ok();
            usable
                .iter()
                .filter(move |&&j| {
                    j != l && !(is_large(j) && j < l) && meet(bl, &boxes[j as usize])
                })
                .filter_map(|&j| keep(l.min(j), l.max(j)))
                .collect::<Vec<_>>()
        }))
        .collect()
}

/// Boxes over more cells than this are compared with every box.
const LARGE_CELLS: u64 = 64;

/// Whether two closed boxes meet.
#[inline]
fn meet(a: &Aabb, b: &Aabb) -> bool {
    (0..3).all(|k| a.min[k] <= b.max[k] && b.min[k] <= a.max[k])
}

/// A uniform grid of cubic cells of side `h` from `origin`, `dims` cells
/// along each axis.
struct Grid {
    origin: [f64; 3],
    h: f64,
    dims: [u64; 3],
}

impl Grid {
    /// The grid over `total` for the boxes `usable` (see the module notes).
    fn new(total: &Aabb, boxes: &[Aabb], usable: &[u32]) -> Grid {
        let n = usable.len() as f64;
        let mean_side = usable
            .iter()
            .map(|&i| boxes[i as usize].extent().max())
            .sum::<f64>()
            / n;
        let ext = total.extent();
        let max_cells = 4.0 * n + 64.0;
        let mut h = mean_side;
        if !(h.is_finite() && h > 0.0) {
            h = ext.max() / n.cbrt();
        }
        let cells = |h: f64| (0..3).map(|a| (ext[a] / h).floor() + 1.0).product::<f64>();
        if !(h.is_finite() && h > 0.0) {
            // every box is one and the same point
            return Grid {
                origin: [total.min.x, total.min.y, total.min.z],
                h: 1.0,
                dims: [1, 1, 1],
            };
        }
        while cells(h) > max_cells {
            h *= (cells(h) / max_cells).cbrt().max(1.01);
        }
        let dims = std::array::from_fn(|a| ((ext[a] / h).floor() as u64 + 1).max(1));
        Grid {
            origin: [total.min.x, total.min.y, total.min.z],
            h,
            dims,
        }
    }

    /// The cell holding `p`: `floor((p_a - origin_a) / h)`, clamped to the
    /// grid (monotone in `p`, which the pair rule relies on).
    fn cell(&self, p: &nalgebra::Point3<f64>) -> [u64; 3] {
        std::array::from_fn(|a| {
            let c = ((p[a] - self.origin[a]) / self.h).floor();
            if c > 0.0 {
                (c as u64).min(self.dims[a] - 1)
            } else {
                0
            }
        })
    }

    /// The cell's linear index.
    fn key(&self, c: [u64; 3]) -> u64 {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use proptest::prelude::*;

    fn brute(boxes: &[Aabb]) -> Vec<[u32; 2]> {
        let mut out = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (&boxes[i], &boxes[j]);
                if (0..3).all(|k| a.min[k] <= b.max[k] && b.min[k] <= a.max[k]) {
                    out.push([i as u32, j as u32]);
                }
            }
        }
        out
    }

    proptest! {
        /// The grid finds exactly the pairs that a comparison of every pair
        /// finds, once each, in order, for boxes of mixed sizes (a few
        /// large ones among many small ones, some flat, some touching).
        #[test]
        fn grid_pairs_match_all_pairs(
            raw in prop::collection::vec(
                (prop::array::uniform3(-20.0f64..20.0), prop::array::uniform3(0.0f64..3.0), any::<bool>()),
                0..120,
            ),
        ) {
            let boxes: Vec<Aabb> = raw
                .iter()
                .enumerate()
                .map(|(k, (c, e, big))| {
                    let s = if *big && k % 7 == 0 { 10.0 } else { 1.0 };
                    // every fifth box is flat in z, every third snaps to a
                    // whole number so that boxes touch exactly
                    let (c, e) = if k % 3 == 0 {
                        (c.map(f64::round), e.map(f64::round))
                    } else {
                        (*c, *e)
                    };
                    let ez = if k % 5 == 0 { 0.0 } else { e[2] };
                    Aabb {
                        min: Point3::new(c[0], c[1], c[2]),
                        max: Point3::new(c[0] + s * e[0], c[1] + s * e[1], c[2] + s * ez),
                    }
                })
                .collect();
            prop_assert_eq!(overlapping_box_pairs(&boxes), brute(&boxes));
        }
    }

    /// Slivers across the whole domain (each over far more than 64 cells,
    /// compared with every box) among a thousand unit boxes: the same
    /// pairs as comparing every pair, a sliver meeting another sliver
    /// once.
    #[test]
    fn slivers_across_the_grid() {
        let mut boxes: Vec<Aabb> = (0..1000)
            .map(|k| {
                let f = k as f64;
                let c = Point3::new(
                    (f * 7.31).sin() * 50.0 + 50.0,
                    (f * 3.17).cos() * 50.0 + 50.0,
                    (f * 1.93).sin() * 50.0 + 50.0,
                );
                Aabb::from_points(&[c, c + nalgebra::Vector3::repeat(1.0)])
            })
            .collect();
        for k in [3, 500, 501, 998] {
            let o = k as f64 * 0.01;
            boxes[k] =
                Aabb::from_points(&[Point3::new(o, 0.0, o), Point3::new(100.0, 100.0 - o, 100.0)]);
        }
        let pairs = overlapping_box_pairs(&boxes);
        assert_eq!(pairs, brute(&boxes));
        assert!(pairs.contains(&[3, 500]) && pairs.contains(&[501, 998]));
    }

    #[test]
    fn degenerate_inputs() {
        assert!(overlapping_box_pairs(&[]).is_empty());
        let p = Aabb::from_points(&[Point3::new(1.0, 2.0, 3.0)]);
        // the same point three times, an empty box, a NaN box
        let nan = Aabb {
            min: Point3::new(f64::NAN, 0.0, 0.0),
            max: Point3::new(1.0, 1.0, 1.0),
        };
        let pairs = overlapping_box_pairs(&[p, p, Aabb::empty(), nan, p]);
        assert_eq!(pairs, vec![[0, 1], [0, 4], [1, 4]]);
    }
}
