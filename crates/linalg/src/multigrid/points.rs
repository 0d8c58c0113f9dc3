//! The first coarse level of an unstructured mesh: a vertex-centred
//! background grid over the points' bounding box, the points interpolated
//! from it trilinearly ([`point_prolongation`]); the grid's own levels follow
//! by [`super::grid_prolongation`]. Each scalar prolongation is expanded to
//! `d` unknowns per point or node ([`block_prolongation`]) for vector
//! problems (docs/DESIGN-NOTES.md, "Newton's linear algebra").

use super::prolongation::grid_nodes;
use crate::csr::MAX_DIM;
use crate::{Csr, LinalgError};

/// Trilinear interpolation `P` from a background grid of spacing `h` to
/// the points: node `(i, j, k)` sits at `o + h (i, j, k)`, `o` the
/// componentwise minimum of the points, and the grid has
/// `floor(extent / h) + 2` nodes per axis. Point `x` with cell coordinates
/// `t = (x - o) / h`, `b = floor(t)`, `f = t - b`, takes
///
/// ```text
/// p_{x,(b + e)} = prod_a (e_a f_a + (1 - e_a)(1 - f_a)),   e in {0, 1}^3
/// ```
///
/// (rows sum to 1; linear functions are reproduced exactly). Weights below
/// `1e-12` are left out (a point on a cell face or edge takes 4 or 2 nodes).
/// A node is active iff some point takes it; active nodes are numbered in
/// order of their linear id `i + nx (j + ny k)`.
///
/// Returns `(P: points x active nodes, grid dims, index of the grid's nodes
/// in the convention of [`super::grid_prolongation`])`.
///
/// # Errors
/// [`LinalgError::InvalidSpacing`] for `h` not positive and finite;
/// [`LinalgError::NotFinite`] for a point with a non-finite coordinate;
/// [`LinalgError::GridTooLarge`] when the grid's node count overflows;
/// [`LinalgError::TooLarge`] for more than `u32::MAX` points or nodes.
pub fn point_prolongation(
    points: &[[f64; 3]],
    h: f64,
) -> Result<(Csr, [usize; 3], Vec<u32>), LinalgError> {
    if !(h.is_finite() && h > 0.0) {
        return Err(LinalgError::InvalidSpacing { spacing: h });
    }
    if let Some(index) = points.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
        return Err(LinalgError::NotFinite {
            what: "point coordinate",
            index,
        });
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    if points.is_empty() {
        (lo, hi) = ([0.0; 3], [0.0; 3]);
    }
    let mut dims = [0usize; 3];
    for a in 0..3 {
        let cells = ((hi[a] - lo[a]) / h).floor();
        if cells > MAX_DIM as f64 {
            return Err(LinalgError::GridTooLarge {
                dims: [usize::MAX; 3],
            });
        }
        dims[a] = cells as usize + 2;
    }
    let n_nodes = grid_nodes(dims)?;
    if points.len() > MAX_DIM {
        return Err(LinalgError::TooLarge {
            rows: points.len(),
            cols: n_nodes,
        });
    }
    let [nx, ny, _] = dims;
    // The parents of each point: (node id, weight), node ids ascending.
    let parents = |p: &[f64; 3], f: &mut dyn FnMut(usize, f64)| {
        let mut b = [0usize; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            let c = (p[a] - lo[a]) / h;
            // (the last point of an axis may sit on the last node but one)
            b[a] = (c.floor().max(0.0) as usize).min(dims[a] - 2);
            t[a] = (c - b[a] as f64).clamp(0.0, 1.0);
        }
        for ek in 0..2 {
            for ej in 0..2 {
                for ei in 0..2 {
                    let w1 = |e: usize, t: f64| if e == 1 { t } else { 1.0 - t };
                    let w = w1(ei, t[0]) * w1(ej, t[1]) * w1(ek, t[2]);
                    if w >= 1e-12 {
                        f(b[0] + ei + nx * (b[1] + ej + ny * (b[2] + ek)), w);
                    }
                }
            }
        }
    };
    let mut index = vec![u32::MAX; n_nodes];
    for p in points {
        parents(p, &mut |id, _| index[id] = 0);
    }
    let mut n_active = 0usize;
    for u in index.iter_mut().filter(|u| **u != u32::MAX) {
        if n_active >= MAX_DIM {
            return Err(LinalgError::TooLarge {
                rows: points.len(),
                cols: n_nodes,
            });
        }
        *u = n_active as u32;
        n_active += 1;
    }
    let mut row_ptr = Vec::with_capacity(points.len() + 1);
    let mut col = Vec::with_capacity(8 * points.len());
    let mut val = Vec::with_capacity(8 * points.len());
    row_ptr.push(0);
    for p in points {
        // Normalized so that roundoff cannot leave a row sum off 1.
        let start = col.len();
        parents(p, &mut |id, w| {
            col.push(index[id]);
            val.push(w);
        });
        let sum: f64 = val[start..].iter().sum();
        val[start..].iter_mut().for_each(|w| *w /= sum);
        row_ptr.push(col.len());
    }
    Ok((
        Csr::from_sorted_parts(points.len(), n_active, row_ptr, col, val),
        dims,
        index,
    ))
}

/// The prolongations of a multigrid hierarchy for `d` unknowns per point:
/// [`point_prolongation`] onto a background grid of spacing `h`, then
/// [`super::grid_prolongation`] (the grid coarsened by 2) while a level has
/// more than `coarsest` unknowns and coarsening still reduces it, each
/// expanded by [`block_prolongation`]. For [`super::Multigrid::with_coarsest`]
/// with the same `coarsest`.
///
/// # Errors
/// Those of [`point_prolongation`], [`super::grid_prolongation`] and
/// [`block_prolongation`].
pub fn point_hierarchy(
    points: &[[f64; 3]],
    d: usize,
    h: f64,
    coarsest: usize,
) -> Result<Vec<Csr>, LinalgError> {
    let (p0, mut dims, mut index) = point_prolongation(points, h)?;
    let mut n = p0.n_cols();
    let mut out = vec![block_prolongation(&p0, d)?];
    while d * n > coarsest {
        let (p, cd, ci) = super::grid_prolongation(dims, &index)?;
        if p.n_cols() >= n {
            break;
        }
        n = p.n_cols();
        out.push(block_prolongation(&p, d)?);
        (dims, index) = (cd, ci);
    }
    Ok(out)
}

/// `P (x) I_d`: each entry `p_ij` of `p` becomes the `d x d` block
/// `p_ij I` (unknown `d i + c` of the fine level takes unknown `d j + c` of
/// the coarse one), for `d` unknowns per point or node.
///
/// # Errors
/// [`LinalgError::TooLarge`] when `d` times a dimension exceeds `u32::MAX`.
pub fn block_prolongation(p: &Csr, d: usize) -> Result<Csr, LinalgError> {
    let (rows, cols) = (p.n_rows().saturating_mul(d), p.n_cols().saturating_mul(d));
    if rows > MAX_DIM || cols > MAX_DIM {
        return Err(LinalgError::TooLarge { rows, cols });
    }
    let mut row_ptr = Vec::with_capacity(rows + 1);
    let mut col = Vec::with_capacity(p.nnz() * d);
    let mut val = Vec::with_capacity(p.nnz() * d);
    row_ptr.push(0);
    for i in 0..p.n_rows() {
        let (c, v) = p.row(i);
        for k in 0..d {
            for (&j, &w) in c.iter().zip(v) {
                col.push((d * j as usize + k) as u32);
                val.push(w);
            }
            row_ptr.push(col.len());
        }
    }
    Ok(Csr::from_sorted_parts(rows, cols, row_ptr, col, val))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Rng, assert_structure};
    use proptest::prelude::*;

    #[test]
    fn a_point_on_a_node_takes_it_alone() {
        let pts = [
            [0.0, 0.0, 0.0],
            [2.0, 1.0, 1.0],
            [1.5, 0.5, 0.5],
            [1.0, 0.5, 0.5],
        ];
        let (p, dims, index) = point_prolongation(&pts, 1.0).unwrap();
        assert_eq!(dims, [4, 3, 3]);
        assert_structure(&p);
        assert_eq!(p.row(0).1, &[1.0]);
        assert_eq!(p.row(1).1, &[1.0]);
        // a cell's centre takes its 8 corners, a face's centre 4
        assert_eq!(p.row(2).1, &[0.125; 8]);
        assert_eq!(p.row(3).1, &[0.25; 4]);
        assert_eq!(index.iter().filter(|&&u| u != u32::MAX).count(), p.n_cols());
    }

    #[test]
    fn bad_spacings_and_points_are_refused() {
        for h in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = point_prolongation(&[[0.0; 3]], h).unwrap_err();
            assert!(matches!(e, LinalgError::InvalidSpacing { .. }), "{e:?}");
            assert!(e.to_string().contains("spacing"), "{e}");
        }
        let e = point_prolongation(&[[0.0; 3], [0.0, f64::NAN, 0.0]], 1.0).unwrap_err();
        assert_eq!(
            e,
            LinalgError::NotFinite {
                what: "point coordinate",
                index: 1
            }
        );
        let e = point_prolongation(&[[0.0; 3], [1e300, 0.0, 0.0]], 1e-300).unwrap_err();
        assert!(matches!(e, LinalgError::GridTooLarge { .. }), "{e:?}");
    }

    proptest! {
        /// Rows sum to 1, weights are positive, and linear functions of the
        /// node positions interpolate to their values at the points; the
        /// block expansion acts on each component alike.
        #[test]
        fn linear_functions_are_reproduced(
            seed in any::<u64>(),
            n in 1usize..60,
            h in 0.3f64..3.0,
            coef in prop::array::uniform4(-2.0f64..2.0),
        ) {
            let mut rng = Rng(seed);
            let pts: Vec<[f64; 3]> = (0..n)
                .map(|_| [10.0 * rng.f64() - 3.0, 4.0 * rng.f64(), rng.f64()])
                .collect();
            let (p, dims, index) = point_prolongation(&pts, h).unwrap();
            assert_structure(&p);
            let lo: Vec<f64> = (0..3)
                .map(|a| pts.iter().map(|q| q[a]).fold(f64::INFINITY, f64::min))
                .collect();
            let mut node_value = vec![0.0; p.n_cols()];
            for (id, &u) in index.iter().enumerate() {
                if u != u32::MAX {
                    let g = [id % dims[0], (id / dims[0]) % dims[1], id / (dims[0] * dims[1])];
                    let x: Vec<f64> = (0..3).map(|a| lo[a] + h * g[a] as f64).collect();
                    node_value[u as usize] = coef[0] + coef[1] * x[0] + coef[2] * x[1] + coef[3] * x[2];
                }
            }
            let at = p.multiply(&node_value);
            for (q, v) in pts.iter().zip(&at) {
                let exact = coef[0] + coef[1] * q[0] + coef[2] * q[1] + coef[3] * q[2];
                prop_assert!((v - exact).abs() < 1e-9 * (1.0 + exact.abs()), "{v} vs {exact}");
            }
            for i in 0..n {
                let (_, w) = p.row(i);
                prop_assert!(w.iter().all(|&x| x > 0.0));
                prop_assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            }
            let p3 = block_prolongation(&p, 3).unwrap();
            assert_structure(&p3);
            let v3: Vec<f64> = node_value.iter().flat_map(|&v| [v, -2.0 * v, 0.5]).collect();
            let at3 = p3.multiply(&v3);
            for i in 0..n {
                prop_assert!((at3[3 * i] - at[i]).abs() < 1e-12 * (1.0 + at[i].abs()));
                prop_assert!((at3[3 * i + 1] + 2.0 * at[i]).abs() < 1e-12 * (1.0 + at[i].abs()));
                prop_assert!((at3[3 * i + 2] - 0.5).abs() < 1e-12);
            }
        }
    }
}
