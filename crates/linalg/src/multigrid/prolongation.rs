//! Trilinear prolongation `P` from a masked vertex-centred 3D grid
//! coarsened by 2 in each direction to the grid itself: the transfer
//! operator of the multigrid hierarchy ([`super::Multigrid::for_grid`]).

use crate::csr::MAX_DIM;
use crate::{Csr, LinalgError};

/// The 1D trilinear parents of fine coordinate `i`: `i = 2I` has the single
/// parent `I` (weight 1), `i = 2I + 1` has `I` and `I + 1` (weight 1/2 each).
#[inline]
fn parents_1d(i: usize) -> ([(usize, f64); 2], usize) {
    if i.is_multiple_of(2) {
        ([(i / 2, 1.0), (0, 0.0)], 1)
    } else {
        ([(i / 2, 0.5), (i / 2 + 1, 0.5)], 2)
    }
}

/// Trilinear prolongation for a masked vertex-centred 3D grid coarsened by 2
/// in each direction.
///
/// `dims = [nx, ny, nz]` fine nodes, node `(i, j, k)` has linear id
/// `i + nx (j + ny k)`; `index[id]` is the unknown number of that node or
/// `u32::MAX` if the node is not an unknown (the unknown numbers must be
/// `0 .. n_fine`, each used once, in any order).
///
/// Coarse node `(I, J, K)` sits at fine node `(2I, 2J, 2K)`; the coarse dims
/// are `[nx / 2 + 1, ny / 2 + 1, nz / 2 + 1]` (integer division: `(n - 1) / 2 + 1`
/// for odd `n`; for even `n` one more, the last coarse layer at fine
/// position `n`, just outside the grid, because the last fine layer
/// `n - 1` is odd and interpolates from it).
///
/// The row of fine unknown `(i, j, k)` is the tensor product of the 1D
/// weights: an even coordinate `2I` has the parent `I` with weight 1, an odd
/// one `2I + 1` the parents `I`, `I + 1` with weight 1/2 each, so
///
/// ```text
/// p_{(i,j,k),(I,J,K)} = w(i, I) w(j, J) w(k, K)     (1, 1/2, 1/4 or 1/8; rows sum to 1)
/// ```
///
/// A coarse node is active iff some active fine node has it among its
/// parents; active coarse nodes are numbered in order of their linear id
/// `I + cx (J + cy K)`.
///
/// Returns `(P: n_fine x n_coarse, coarse dims, coarse index array with the
/// same convention)`.
///
/// # Errors
/// [`LinalgError::EmptyGrid`] for a zero dimension,
/// [`LinalgError::GridTooLarge`] for a node count that overflows,
/// [`LinalgError::GridNumberOutOfRange`] / [`LinalgError::GridNumberReused`]
/// for unknown numbers that are not `0 .. n_fine` each once,
/// [`LinalgError::TooLarge`] for more than `u32::MAX - 1` coarse unknowns;
/// [`LinalgError::DimensionMismatch`] if `index.len() != nx ny nz`.
pub fn grid_prolongation(
    dims: [usize; 3],
    index: &[u32],
) -> Result<(Csr, [usize; 3], Vec<u32>), LinalgError> {
    let n_nodes = grid_nodes(dims)?;
    if index.len() != n_nodes {
        return Err(LinalgError::DimensionMismatch {
            what: "grid index (one entry per node)",
            expected: n_nodes,
            found: index.len(),
        });
    }
    let node_of = unknown_nodes(index)?;
    let [nx, ny, _] = dims;
    let cdims = dims.map(|d| d / 2 + 1);
    let [cx, cy, cz] = cdims;
    let coarse_id = |ci: usize, cj: usize, ck: usize| ci + cx * (cj + cy * ck);

    // Mark the active coarse nodes, then number them in linear-id order.
    let mut cindex = vec![u32::MAX; cx * cy * cz];
    // The trilinear parents of fine node `id`: (coarse linear id, weight),
    // k outer, i inner, i.e. by ascending coarse linear id.
    let for_each_parent = |id: usize, f: &mut dyn FnMut(usize, f64)| {
        let (i, j, k) = (id % nx, (id / nx) % ny, id / (nx * ny));
        let (pi, ni) = parents_1d(i);
        let (pj, nj) = parents_1d(j);
        let (pk, nk) = parents_1d(k);
        for &(ck, wk) in &pk[..nk] {
            for &(cj, wj) in &pj[..nj] {
                for &(ci, wi) in &pi[..ni] {
                    f(coarse_id(ci, cj, ck), wi * wj * wk);
                }
            }
        }
    };
    for &id in &node_of {
        for_each_parent(id, &mut |c, _| cindex[c] = 0);
    }
    let mut n_coarse = 0usize;
    for c in cindex.iter_mut().filter(|c| **c != u32::MAX) {
        if n_coarse >= MAX_DIM {
            return Err(LinalgError::TooLarge {
                rows: node_of.len(),
                cols: cx * cy * cz,
            });
        }
        *c = n_coarse as u32;
        n_coarse += 1;
    }

    // Rows: parents enumerated k outer, i inner, i.e. by ascending coarse
    // linear id, hence ascending coarse unknown number.
    let mut row_ptr = Vec::with_capacity(node_of.len() + 1);
    row_ptr.push(0);
    let mut col = Vec::with_capacity(node_of.len() * 4);
    let mut val = Vec::with_capacity(node_of.len() * 4);
    for &id in &node_of {
        for_each_parent(id, &mut |c, w| {
            col.push(cindex[c]);
            val.push(w);
        });
        row_ptr.push(col.len());
    }
    let p = Csr::from_sorted_parts(node_of.len(), n_coarse, row_ptr, col, val);
    Ok((p, cdims, cindex))
}

/// `nx ny nz`, every dimension positive, without overflow.
pub(super) fn grid_nodes(dims: [usize; 3]) -> Result<usize, LinalgError> {
    if dims.contains(&0) {
        return Err(LinalgError::EmptyGrid { dims });
    }
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or(LinalgError::GridTooLarge { dims })
}

/// `node_of[u]`: the node id of unknown `u`, checking that the unknown
/// numbers in `index` are `0 .. n` each once.
fn unknown_nodes(index: &[u32]) -> Result<Vec<usize>, LinalgError> {
    let n = index.iter().filter(|&&u| u != u32::MAX).count();
    let mut node_of = vec![usize::MAX; n];
    for (id, &u) in index.iter().enumerate() {
        if u == u32::MAX {
            continue;
        }
        let slot = node_of
            .get_mut(u as usize)
            .ok_or(LinalgError::GridNumberOutOfRange {
                node: id,
                number: u,
                unknowns: n,
            })?;
        if *slot != usize::MAX {
            return Err(LinalgError::GridNumberReused {
                number: u,
                first: *slot,
                second: id,
            });
        }
        *slot = id;
    }
    Ok(node_of)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Rng, assert_structure, dense};
    use nalgebra::DMatrix;
    use proptest::prelude::*;

    #[test]
    fn prolongation_of_a_line_is_linear_interpolation() {
        // Odd size: coarse nodes at fine 0, 2, 4.
        let (p, cd, ci) = grid_prolongation([5, 1, 1], &[0, 1, 2, 3, 4]).unwrap();
        assert_eq!(cd, [3, 1, 1]);
        assert_eq!(ci, vec![0, 1, 2]);
        let expect = DMatrix::from_row_slice(
            5,
            3,
            &[
                1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0,
            ],
        );
        assert_eq!(dense(&p), expect);
        // Even size: the last fine node interpolates from a coarse node at
        // fine position 4, outside the grid.
        let (p, cd, _) = grid_prolongation([4, 1, 1], &[0, 1, 2, 3]).unwrap();
        assert_eq!(cd, [3, 1, 1]);
        assert_eq!(p.row(3), (&[1u32, 2][..], &[0.5, 0.5][..]));
        // A masked line: node 2 out; unknowns numbered in reverse order.
        let (p, _, ci) = grid_prolongation([5, 1, 1], &[3, 2, u32::MAX, 1, 0]).unwrap();
        assert_eq!(ci, vec![0, 1, 2]);
        assert_eq!(p.row(0), (&[2u32][..], &[1.0][..])); // unknown 0 = node 4
        assert_eq!(p.row(1), (&[1u32, 2][..], &[0.5, 0.5][..])); // node 3
        assert_eq!(p.row(3), (&[0u32][..], &[1.0][..])); // node 0
    }

    #[test]
    fn prolongation_of_an_isolated_odd_node_has_eight_parents() {
        let mut index = vec![u32::MAX; 27];
        index[1 + 3 * (1 + 3)] = 0;
        let (p, cd, ci) = grid_prolongation([3, 3, 3], &index).unwrap();
        assert_eq!(cd, [2, 2, 2]);
        assert_eq!(ci, (0..8).collect::<Vec<u32>>());
        assert_eq!(
            p.row(0),
            (&[0u32, 1, 2, 3, 4, 5, 6, 7][..], &[0.125; 8][..])
        );
    }

    #[test]
    fn prolongation_rejects_bad_index() {
        let err = grid_prolongation([2, 2, 2], &[0; 7]).unwrap_err();
        assert!(matches!(
            err,
            LinalgError::DimensionMismatch {
                expected: 8,
                found: 7,
                ..
            }
        ));
        let err = grid_prolongation([2, 0, 2], &[]).unwrap_err();
        assert_eq!(err, LinalgError::EmptyGrid { dims: [2, 0, 2] });
        assert!(err.to_string().contains("at least 1"), "{err}");
        let err = grid_prolongation([3, 1, 1], &[0, 0, 1]).unwrap_err();
        assert_eq!(
            err,
            LinalgError::GridNumberReused {
                number: 0,
                first: 0,
                second: 1
            }
        );
        assert!(err.to_string().contains("used by nodes 0 and 1"), "{err}");
        let err = grid_prolongation([3, 1, 1], &[0, 5, u32::MAX]).unwrap_err();
        assert_eq!(
            err,
            LinalgError::GridNumberOutOfRange {
                node: 1,
                number: 5,
                unknowns: 2
            }
        );
        assert!(err.to_string().contains("only 2 unknowns"), "{err}");
        let err = grid_prolongation([usize::MAX, 2, 1], &[]).unwrap_err();
        assert!(matches!(err, LinalgError::GridTooLarge { .. }));
        assert!(err.to_string().contains("too many nodes"), "{err}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn prolongation_reproduces_constants_and_index_is_consistent(
            nx in 1usize..10, ny in 1usize..10, nz in 1usize..10,
            density in 0.05f64..1.0, seed in any::<u64>(),
        ) {
            let dims = [nx, ny, nz];
            let mut rng = Rng(seed);
            let n_nodes = nx * ny * nz;
            // Random mask, unknowns numbered in a random order.
            let active: Vec<usize> = (0..n_nodes).filter(|_| rng.f64() < density).collect();
            let mut order: Vec<u32> = (0..active.len() as u32).collect();
            for i in (1..order.len()).rev() {
                order.swap(i, rng.below(i + 1));
            }
            let mut index = vec![u32::MAX; n_nodes];
            for (&id, &u) in active.iter().zip(&order) {
                index[id] = u;
            }
            let (p, cd, ci) = grid_prolongation(dims, &index).unwrap();
            assert_structure(&p);
            prop_assert_eq!(cd, [nx / 2 + 1, ny / 2 + 1, nz / 2 + 1]);
            prop_assert_eq!(ci.len(), cd[0] * cd[1] * cd[2]);
            prop_assert_eq!(p.n_rows(), active.len());
            // Coarse numbers: 0..n_cols once each, ascending with the id.
            let numbers: Vec<u32> = ci.iter().copied().filter(|&c| c != u32::MAX).collect();
            prop_assert_eq!(numbers, (0..p.n_cols() as u32).collect::<Vec<_>>());
            let mut coarse_node = vec![usize::MAX; p.n_cols()];
            for (id, &c) in ci.iter().enumerate() {
                if c != u32::MAX {
                    coarse_node[c as usize] = id;
                }
            }
            let mut used = vec![false; p.n_cols()];
            for (&id, &u) in active.iter().zip(&order) {
                let (c, v) = p.row(u as usize);
                let sum: f64 = v.iter().sum();
                prop_assert_eq!(sum, 1.0, "row {} sums to {}", u, sum);
                let f = [id % nx, (id / nx) % ny, id / (nx * ny)];
                for (&cj, &w) in c.iter().zip(v) {
                    used[cj as usize] = true;
                    let cid = coarse_node[cj as usize];
                    let g = [cid % cd[0], (cid / cd[0]) % cd[1], cid / (cd[0] * cd[1])];
                    // Trilinear weight of coarse node g at fine node f.
                    let expect: f64 = (0..3)
                        .map(|a| (1.0 - (f[a] as f64 - 2.0 * g[a] as f64).abs() / 2.0).max(0.0))
                        .product();
                    prop_assert!(expect > 0.0);
                    prop_assert_eq!(w, expect);
                }
                // Every parent with a positive weight is present.
                prop_assert_eq!(
                    c.len(),
                    f.iter().map(|&x| if x % 2 == 0 { 1 } else { 2 }).product::<usize>()
                );
            }
            prop_assert!(used.iter().all(|&u| u), "an active coarse node has no fine child");
        }
    }
}
