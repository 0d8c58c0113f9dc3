//! Rasterising a scalar field on a planar triangle mesh onto a regular 2D
//! grid: the value at each grid cell's centre, or none where no triangle
//! covers it.
//!
//! A [`Grid2`] has `nx x ny` cells; cell `(i, j)` has its centre at
//!
//! ```text
//! c_ij = origin + ((i + 1/2) s_x, (j + 1/2) s_y)
//! ```
//!
//! and index `i + nx j` (x fastest). [`Coverage::new`] finds, once, which
//! triangle covers each centre and the centre's barycentric coordinates in
//! it; [`Coverage::point_field`] and [`Coverage::cell_field`] then sample any
//! number of fields on that coverage:
//!
//! - a per-vertex field `f` is interpolated linearly in the triangle
//!   `(a, b, c)` covering `p`:
//!
//!   ```text
//!   f(p) = (E_bc(p) f_a + E_ca(p) f_b + E_ab(p) f_c) / (E_bc(p) + E_ca(p) + E_ab(p))
//!   E_xy(p) = (y - x) x (p - x)     (twice the signed area of (x, y, p))
//!   ```
//!
//!   which reproduces a linear field exactly (up to rounding);
//! - a per-triangle field is constant on its triangle.
//!
//! **Which triangle covers a centre.** `p` is in triangle `(a, b, c)` of
//! orientation `s = sign E_ab(c)` when `s E_xy(p) > 0` for its three edges
//! `xy`, the signs taken with exact predicates (`robust::orient2d`). A centre
//! exactly on an edge or a vertex is decided as if it were moved by
//! `(e, e^2)` for an infinitely small `e > 0` (simulation of simplicity): on
//! an edge where `E_xy(p) = 0` it counts as inside when
//! `s (-(y_y - x_y))` is positive, or, for a horizontal edge, `s (y_x - x_x)`.
//! So the triangles of a mesh that does not overlap itself cover each centre
//! at most once, whatever their order and the rotation of their vertices,
//! and a centre outside every triangle is never covered. Degenerate
//! triangles (zero area) cover nothing. Where triangles overlap (a flipped
//! layout) a centre takes the mean over the triangles covering it.
//!
//! Cost: `O(T + C)` for `T` triangles whose bounding boxes hold `C` cell
//! centres in all; memory, one entry per covered centre.

use crate::MeshError;

/// A regular 2D grid of cells (module doc): `dims = [nx, ny]` cells of
/// size `spacing`, the corner of cell `(0, 0)` at `origin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid2 {
    /// The corner of the grid (lowest x and y).
    pub origin: [f64; 2],
    /// Cell size along x and y (> 0).
    pub spacing: [f64; 2],
    /// Number of cells along x and y (>= 1).
    pub dims: [usize; 2],
}

impl Grid2 {
    /// A grid of `dims` cells of size `spacing` from `origin`.
    ///
    /// # Errors
    /// [`MeshError::RasterGrid`] when a dimension is 0, a spacing is not a
    /// finite number > 0, or the origin is not finite.
    pub fn new(origin: [f64; 2], spacing: [f64; 2], dims: [usize; 2]) -> Result<Self, MeshError> {
        let ok = dims.iter().all(|&d| d >= 1)
            && dims[0].checked_mul(dims[1]).is_some()
            && spacing.iter().all(|s| s.is_finite() && *s > 0.0)
            && origin.iter().all(|o| o.is_finite());
        if ok {
            Ok(Grid2 {
                origin,
                spacing,
                dims,
            })
        } else {
            Err(MeshError::RasterGrid {
                origin,
                spacing,
                dims,
            })
        }
    }

    /// Number of cells, `nx ny`.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1]
    }

    /// Whether the grid has no cell (never, for a grid from [`Grid2::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The centre of cell `(i, j)`: `origin + ((i + 1/2) s_x, (j + 1/2) s_y)`.
    pub fn centre(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.origin[0] + (i as f64 + 0.5) * self.spacing[0],
            self.origin[1] + (j as f64 + 0.5) * self.spacing[1],
        ]
    }
}

/// One triangle covering one cell centre: the triangle and the centre's
/// barycentric weights of its three vertices (in the triangle's order).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Hit {
    triangle: u32,
    vertices: [u32; 3],
    weights: [f64; 3],
}

/// Which triangles of a planar mesh cover each centre of a [`Grid2`], with
/// the barycentric weights (module doc); built once, sampled per field.
#[derive(Debug, Clone)]
pub struct Coverage {
    grid: Grid2,
    num_points: usize,
    num_triangles: usize,
    /// `hits[offsets[k]..offsets[k + 1]]` cover cell `k`.
    offsets: Vec<usize>,
    hits: Vec<Hit>,
}

fn coord(p: [f64; 2]) -> robust::Coord<f64> {
    robust::Coord { x: p[0], y: p[1] }
}

/// The exact sign of `E_xy(p) = (y - x) x (p - x)`, with the tie on the
/// line broken by moving `p` by `(e, e^2)`: `-(y_y - x_y)`, then `y_x - x_x`.
/// Antisymmetric in `x, y` exactly.
fn side(x: [f64; 2], y: [f64; 2], p: [f64; 2]) -> f64 {
    let o = robust::orient2d(coord(x), coord(y), coord(p));
    if o != 0.0 {
        return o.signum();
    }
    let dy = y[1] - x[1];
    if dy != 0.0 {
        return -dy.signum();
    }
    let dx = y[0] - x[0];
    if dx != 0.0 { dx.signum() } else { 0.0 }
}

/// `x + y + z` summed in increasing order, so that the result does not
/// depend on the order the three are given in (a triangle's vertices may
/// come in any rotation).
fn sum3(mut v: [f64; 3]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[0] + v[1] + v[2]
}

/// `E_xy(p)` in floating point (for the weights).
fn edge(x: [f64; 2], y: [f64; 2], p: [f64; 2]) -> f64 {
    (y[0] - x[0]) * (p[1] - x[1]) - (y[1] - x[1]) * (p[0] - x[0])
}

impl Coverage {
    /// The coverage of `grid` by the triangles over `points` (module doc).
    ///
    /// # Errors
    /// [`MeshError::IndexOutOfRange`] for a triangle naming a vertex
    /// `>= points.len()`; [`MeshError::NonFiniteCoordinate`] for a point
    /// with a NaN or infinite coordinate (reported with `z = 0`).
    pub fn new(
        points: &[[f64; 2]],
        triangles: &[[u32; 3]],
        grid: &Grid2,
    ) -> Result<Self, MeshError> {
        if let Some((vertex, p)) = points
            .iter()
            .enumerate()
            .find(|(_, p)| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(MeshError::NonFiniteCoordinate {
                vertex,
                x: p[0],
                y: p[1],
                z: 0.0,
            });
        }
        let n = points.len();
        for (element, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&v| v as usize >= n) {
                return Err(MeshError::IndexOutOfRange {
                    element,
                    index,
                    vertex_count: n,
                });
            }
        }
        let [nx, ny] = grid.dims;
        let mut found: Vec<(usize, Hit)> = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|v| points[v as usize]);
            let s = robust::orient2d(coord(a), coord(b), coord(c)).signum();
            if s == 0.0 {
                continue;
            }
            // the centres in the bounding box, one cell of margin
            let range = |axis: usize, count: usize| {
                let lo = a[axis].min(b[axis]).min(c[axis]);
                let hi = a[axis].max(b[axis]).max(c[axis]);
                let to_index = |x: f64| (x - grid.origin[axis]) / grid.spacing[axis] - 0.5;
                let first = (to_index(lo).floor() - 1.0).max(0.0);
                let last = (to_index(hi).ceil() + 1.0).min(count as f64 - 1.0);
                if last < first {
                    None
                } else {
                    Some((first as usize, last as usize))
                }
            };
            let (Some((i0, i1)), Some((j0, j1))) = (range(0, nx), range(1, ny)) else {
                continue;
            };
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let p = grid.centre(i, j);
                    if s * side(a, b, p) > 0.0 && s * side(b, c, p) > 0.0 && s * side(c, a, p) > 0.0
                    {
                        let e = [edge(b, c, p), edge(c, a, p), edge(a, b, p)];
                        let total = sum3(e);
                        if total == 0.0 || !total.is_finite() {
                            continue;
                        }
                        found.push((
                            i + nx * j,
                            Hit {
                                triangle: t as u32,
                                vertices: *tri,
                                weights: e.map(|x| x / total),
                            },
                        ));
                    }
                }
            }
        }
        found.sort_by_key(|(k, h)| (*k, h.triangle));
        let mut offsets = vec![0usize; grid.len() + 1];
        for (k, _) in &found {
            offsets[k + 1] += 1;
        }
        for k in 0..grid.len() {
            offsets[k + 1] += offsets[k];
        }
        Ok(Coverage {
            grid: *grid,
            num_points: n,
            num_triangles: triangles.len(),
            offsets,
            hits: found.into_iter().map(|(_, h)| h).collect(),
        })
    }

    /// The grid.
    pub fn grid(&self) -> &Grid2 {
        &self.grid
    }

    /// Number of triangles covering cell `k` (`i + nx j`); 0 outside the
    /// grid.
    pub fn count(&self, k: usize) -> usize {
        if k < self.grid.len() {
            self.offsets[k + 1] - self.offsets[k]
        } else {
            0
        }
    }

    fn sample(&self, per_hit: impl Fn(&Hit) -> f64) -> Vec<Option<f64>> {
        (0..self.grid.len())
            .map(|k| {
                let hits = &self.hits[self.offsets[k]..self.offsets[k + 1]];
                match hits {
                    [] => None,
                    [h] => Some(per_hit(h)),
                    _ => Some(hits.iter().map(&per_hit).sum::<f64>() / hits.len() as f64),
                }
            })
            .collect()
    }

    /// A per-vertex field sampled at every cell centre, interpolated
    /// linearly in the covering triangle (module doc); `None` where no
    /// triangle covers the centre.
    ///
    /// # Errors
    /// [`MeshError::FieldLength`] when `values` does not have one value per
    /// point.
    pub fn point_field(&self, values: &[f64]) -> Result<Vec<Option<f64>>, MeshError> {
        if values.len() != self.num_points {
            return Err(MeshError::FieldLength {
                name: "point values".into(),
                expected: self.num_points,
                found: values.len(),
            });
        }
        Ok(self.sample(|h| {
            let [a, b, c] = h.vertices.map(|v| values[v as usize]);
            sum3([h.weights[0] * a, h.weights[1] * b, h.weights[2] * c])
        }))
    }

    /// A per-triangle field sampled at every cell centre (the covering
    /// triangle's value); `None` where no triangle covers the centre.
    ///
    /// # Errors
    /// [`MeshError::FieldLength`] when `values` does not have one value per
    /// triangle.
    pub fn cell_field(&self, values: &[f64]) -> Result<Vec<Option<f64>>, MeshError> {
        if values.len() != self.num_triangles {
            return Err(MeshError::FieldLength {
                name: "triangle values".into(),
                expected: self.num_triangles,
                found: values.len(),
            });
        }
        Ok(self.sample(|h| values[h.triangle as usize]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A jittered lattice of `m x n` points (spacing 1, jitter below 0.3,
    /// so no triangle overlaps another) split into two triangles per
    /// quad along the diagonal `diag[q]` picks.
    fn lattice(
        m: usize,
        n: usize,
        jitter: &[[f64; 2]],
        diag: &[bool],
    ) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut pts = Vec::new();
        for j in 0..n {
            for i in 0..m {
                let k = i + m * j;
                let on_edge = i == 0 || j == 0 || i == m - 1 || j == n - 1;
                let d = if on_edge {
                    [0.0, 0.0]
                } else {
                    jitter[k % jitter.len()]
                };
                pts.push([i as f64 + d[0], j as f64 + d[1]]);
            }
        }
        let mut tris = Vec::new();
        for j in 0..n - 1 {
            for i in 0..m - 1 {
                let v = |a: usize, b: usize| (a + m * b) as u32;
                let (p00, p10, p01, p11) = (v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1));
                if diag[(i + m * j) % diag.len()] {
                    tris.push([p00, p10, p11]);
                    tris.push([p00, p11, p01]);
                } else {
                    tris.push([p00, p10, p01]);
                    tris.push([p10, p11, p01]);
                }
            }
        }
        (pts, tris)
    }

    /// Barycentric coordinates of `p` in `(a, b, c)`, plain floating point.
    fn bary(a: [f64; 2], b: [f64; 2], c: [f64; 2], p: [f64; 2]) -> [f64; 3] {
        let t = edge(a, b, c);
        [edge(b, c, p) / t, edge(c, a, p) / t, edge(a, b, p) / t]
    }

    fn grid() -> Grid2 {
        // over [-1, 6] x [-1, 5]: cells outside the 5 x 4 lattice too
        Grid2::new([-1.0, -1.0], [7.0 / 40.0, 6.0 / 30.0], [40, 30]).unwrap()
    }

    proptest! {
        #[test]
        fn raster_reproduces_a_linear_field_at_covered_centres(
            jitter in prop::collection::vec([-0.29f64..0.29, -0.29f64..0.29], 30),
            diag in prop::collection::vec(any::<bool>(), 12),
            coef in [-100.0f64..100.0, -100.0f64..100.0, -100.0f64..100.0],
        ) {
            let (pts, tris) = lattice(6, 5, &jitter, &diag);
            let g = grid();
            let f = |p: [f64; 2]| coef[0] + coef[1] * p[0] + coef[2] * p[1];
            let values: Vec<f64> = pts.iter().map(|&p| f(p)).collect();
            let cov = Coverage::new(&pts, &tris, &g).unwrap();
            let r = cov.point_field(&values).unwrap();
            let scale = 1e-9 * (coef[0].abs() + 6.0 * (coef[1].abs() + coef[2].abs()) + 1.0);
            let mut covered = 0;
            for j in 0..g.dims[1] {
                for i in 0..g.dims[0] {
                    if let Some(x) = r[i + g.dims[0] * j] {
                        covered += 1;
                        prop_assert!((x - f(g.centre(i, j))).abs() <= scale, "cell ({i}, {j}): {x}");
                    }
                }
            }
            // the lattice covers [0, 5] x [0, 4]: 20 of the 42 area units
            prop_assert!(covered > 0);
        }

        #[test]
        fn raster_covers_exactly_the_centres_inside_a_triangle(
            jitter in prop::collection::vec([-0.29f64..0.29, -0.29f64..0.29], 30),
            diag in prop::collection::vec(any::<bool>(), 12),
        ) {
            let (pts, tris) = lattice(6, 5, &jitter, &diag);
            let g = grid();
            let cov = Coverage::new(&pts, &tris, &g).unwrap();
            let cells: Vec<f64> = (0..tris.len()).map(|t| t as f64).collect();
            let r = cov.cell_field(&cells).unwrap();
            for j in 0..g.dims[1] {
                for i in 0..g.dims[0] {
                    let k = i + g.dims[0] * j;
                    let p = g.centre(i, j);
                    // the triangles containing p, with a margin either way
                    let inside = |margin: f64| {
                        tris.iter()
                            .enumerate()
                            .filter(|(_, t)| {
                                let [a, b, c] = t.map(|v| pts[v as usize]);
                                bary(a, b, c, p).iter().all(|&w| w > margin)
                            })
                            .map(|(t, _)| t)
                            .collect::<Vec<_>>()
                    };
                    let strictly = inside(1e-9);
                    let loosely = inside(-1e-9);
                    // a non-overlapping mesh covers a centre at most once
                    prop_assert!(cov.count(k) <= 1);
                    match r[k] {
                        None => prop_assert!(strictly.is_empty(), "({i}, {j}) inside {strictly:?}"),
                        Some(t) => prop_assert!(loosely.contains(&(t as usize)), "({i}, {j}) in {t}"),
                    }
                    if !strictly.is_empty() {
                        prop_assert_eq!(r[k], Some(strictly[0] as f64));
                    }
                    // outside the lattice's box nothing is covered
                    if p[0] < 0.0 || p[0] > 5.0 || p[1] < 0.0 || p[1] > 4.0 {
                        prop_assert_eq!(r[k], None);
                    }
                }
            }
        }

        #[test]
        fn raster_does_not_depend_on_the_triangle_order(
            jitter in prop::collection::vec([-0.29f64..0.29, -0.29f64..0.29], 30),
            diag in prop::collection::vec(any::<bool>(), 12),
            values in prop::collection::vec(-10.0f64..10.0, 30),
            order in Just((0..40usize).collect::<Vec<_>>()).prop_shuffle(),
            rotations in prop::collection::vec(0usize..3, 40),
        ) {
            let (pts, tris) = lattice(6, 5, &jitter, &diag);
            let g = grid();
            let moved: Vec<[u32; 3]> = order
                .iter()
                .map(|&t| {
                    let [a, b, c] = tris[t];
                    match rotations[t] {
                        0 => [a, b, c],
                        1 => [b, c, a],
                        _ => [c, a, b],
                    }
                })
                .collect();
            let cell_values: Vec<f64> = (0..tris.len()).map(|t| values[t % values.len()]).collect();
            let moved_cells: Vec<f64> = order.iter().map(|&t| cell_values[t]).collect();
            let a = Coverage::new(&pts, &tris, &g).unwrap();
            let b = Coverage::new(&pts, &moved, &g).unwrap();
            prop_assert_eq!(a.point_field(&values).unwrap(), b.point_field(&values).unwrap());
            prop_assert_eq!(a.cell_field(&cell_values).unwrap(), b.cell_field(&moved_cells).unwrap());
        }
    }

    #[test]
    fn raster_centres_on_a_shared_diagonal_are_covered_once() {
        // the unit square split along y = x, through the centres (i, i)
        let pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let g = Grid2::new([0.0, 0.0], [0.25, 0.25], [4, 4]).unwrap();
        for tris in [[[0, 1, 2], [0, 2, 3]], [[0, 2, 3], [2, 1, 0]]] {
            let cov = Coverage::new(&pts, &tris, &g).unwrap();
            for k in 0..g.len() {
                assert_eq!(cov.count(k), 1, "cell {k}");
            }
        }
    }

    #[test]
    fn raster_overlapping_triangles_average_and_degenerate_ones_cover_nothing() {
        let pts = [[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [1.0, 0.0]];
        let g = Grid2::new([0.0, 0.0], [0.5, 0.5], [4, 4]).unwrap();
        // the same triangle twice (once reversed) and a degenerate one
        let tris = [[0, 1, 2], [0, 2, 1], [0, 3, 1]];
        let cov = Coverage::new(&pts, &tris, &g).unwrap();
        assert_eq!(cov.count(0), 2);
        let r = cov.cell_field(&[1.0, 3.0, 100.0]).unwrap();
        assert_eq!(r[0], Some(2.0));
        // (0.75, 0.75) is inside (x + y = 1.5 < 2); (1.25, 1.25) is not
        assert_eq!(r[1 + 4], Some(2.0));
        assert_eq!(r[2 + 4 * 2], None);
    }

    #[test]
    fn raster_refuses_bad_inputs_with_their_numbers() {
        assert!(matches!(
            Grid2::new([0.0, 0.0], [1.0, 0.0], [2, 2]),
            Err(MeshError::RasterGrid { .. })
        ));
        assert!(matches!(
            Grid2::new([0.0, f64::NAN], [1.0, 1.0], [2, 2]),
            Err(MeshError::RasterGrid { .. })
        ));
        let e = Grid2::new([0.0, 0.0], [1.0, 1.0], [0, 2]).unwrap_err();
        assert!(e.to_string().contains("0 x 2 cells"), "{e}");
        let g = Grid2::new([0.0, 0.0], [1.0, 1.0], [2, 2]).unwrap();
        let pts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(
            Coverage::new(&pts, &[[0, 1, 3]], &g).unwrap_err(),
            MeshError::IndexOutOfRange {
                element: 0,
                index: 3,
                vertex_count: 3
            }
        );
        let bad = [[0.0, 0.0], [f64::INFINITY, 0.0], [0.0, 1.0]];
        assert!(matches!(
            Coverage::new(&bad, &[[0, 1, 2]], &g),
            Err(MeshError::NonFiniteCoordinate { vertex: 1, .. })
        ));
        let cov = Coverage::new(&pts, &[[0, 1, 2]], &g).unwrap();
        assert_eq!(
            cov.point_field(&[1.0, 2.0]).unwrap_err(),
            MeshError::FieldLength {
                name: "point values".into(),
                expected: 3,
                found: 2
            }
        );
        assert!(matches!(
            cov.cell_field(&[]),
            Err(MeshError::FieldLength {
                expected: 1,
                found: 0,
                ..
            })
        ));
    }
}
