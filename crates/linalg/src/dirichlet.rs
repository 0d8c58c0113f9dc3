//! Dirichlet (harmonic) solves on meshes (ALGORITHMS 1.6, 3.2): every free
//! vertex satisfies the discrete Laplace equation of an operator, the fixed
//! vertices keep given values.
//!
//! - [`solve_dirichlet`]: a symmetric positive semidefinite operator `A`
//!   (a [`crate::laplacian`] matrix): `A_FF x_F = -A_FC x_C`, by sparse
//!   Cholesky ([`crate::sparse::SpdPattern`]).
//! - [`solve_dirichlet_weights`]: non-symmetric averaging weights (e.g.
//!   [`crate::laplacian::mean_value_weights`]):
//!   `(I - Lambda_FF) x_F = Lambda_FC x_C`, by sparse LU
//!   ([`crate::sparse::SparseLu`]).
//!
//! Both share one skeleton (`Partition`): the fixed set and the value
//! columns are checked, the fixed values placed in full columns, every free
//! vertex must be coupled to a fixed one, and the free values are filled in
//! by the solve, one column per coordinate, with one factorization for all.

use crate::sparse::{SparseLu, SpdPattern};
use crate::{Csr, LinalgError};

/// The unknowns of a Dirichlet problem: the free vertices, numbered in
/// order, and the full solution columns with the fixed values in place.
struct Partition {
    /// Per vertex: its index among the free vertices (`u32::MAX` for fixed
    /// ones).
    local: Vec<u32>,
    /// The free vertices, ascending.
    free: Vec<u32>,
    /// One full column of length `n` per value column: the fixed entries
    /// at their values, the free ones 0 until [`Partition::set_free`].
    columns: Vec<Vec<f64>>,
}

impl Partition {
    /// Checks the fixed set (in range, each once) and the value columns
    /// (one finite value per fixed vertex each), and places the fixed
    /// values.
    fn new(n: usize, fixed: &[u32], values: &[Vec<f64>]) -> Result<Self, LinalgError> {
        let mut local = vec![0u32; n];
        for &f in fixed {
            let f = f as usize;
            if f >= n {
                return Err(LinalgError::IndexOutOfRange {
                    what: "fixed vertex",
                    index: f,
                    len: n,
                });
            }
            if local[f] == u32::MAX {
                return Err(LinalgError::DuplicateIndex {
                    what: "fixed vertex",
                    index: f,
                });
            }
            local[f] = u32::MAX;
        }
        for col in values {
            if col.len() != fixed.len() {
                return Err(LinalgError::DimensionMismatch {
                    what: "Dirichlet values (one per fixed vertex)",
                    expected: fixed.len(),
                    found: col.len(),
                });
            }
            if let Some(index) = col.iter().position(|v| !v.is_finite()) {
                return Err(LinalgError::NotFinite {
                    what: "Dirichlet value",
                    index,
                });
            }
        }
        let mut free = Vec::with_capacity(n - fixed.len());
        for (v, l) in local.iter_mut().enumerate() {
            if *l != u32::MAX {
                *l = free.len() as u32;
                free.push(v as u32);
            }
        }
        let columns = values
            .iter()
            .map(|col| {
                let mut x = vec![0.0; n];
                for (&f, &v) in fixed.iter().zip(col) {
                    x[f as usize] = v;
                }
                x
            })
            .collect();
        Ok(Partition {
            local,
            free,
            columns,
        })
    }

    /// Whether vertex `v` is fixed.
    #[inline]
    fn is_fixed(&self, v: u32) -> bool {
        self.local[v as usize] == u32::MAX
    }

    /// Fails when a free vertex is not connected, through non-zero
    /// couplings (`neighbors(v)`), to any fixed vertex: its block of the
    /// system would be singular.
    fn check_reaches_fixed<I: Iterator<Item = u32>>(
        &self,
        neighbors: impl Fn(usize) -> I,
    ) -> Result<(), LinalgError> {
        let n = self.local.len();
        let mut seen: Vec<bool> = self.local.iter().map(|&l| l == u32::MAX).collect();
        let mut stack: Vec<usize> = (0..n).filter(|&v| seen[v]).collect();
        while let Some(v) = stack.pop() {
            for w in neighbors(v) {
                let w = w as usize;
                if !seen[w] {
                    seen[w] = true;
                    stack.push(w);
                }
            }
        }
        match seen.iter().position(|s| !s) {
            None => Ok(()),
            Some(vertex) => Err(LinalgError::NotAnchored { vertex }),
        }
    }

    /// Column `c` with its free entries set to `x_free` (in the order of
    /// the free vertices).
    fn set_free(&mut self, c: usize, x_free: &[f64]) {
        let column = &mut self.columns[c];
        for (&v, &x) in self.free.iter().zip(x_free) {
            column[v as usize] = x;
        }
    }
}

/// Solves the Dirichlet problem of a symmetric positive semidefinite
/// operator `A` (a Laplacian / stiffness matrix): with `F` the free and `C`
/// the fixed vertices,
///
/// ```text
/// A_FF x_F = -A_FC x_C,      x_C = the given values
/// ```
///
/// i.e. `(A x)_i = 0` on every free row: the discrete harmonic extension of
/// the boundary values. `A_FF` is factorized once (sparse Cholesky,
/// [`crate::sparse`]) and reused for every column of `values` (one column
/// per coordinate, each with one value per entry of `fixed`, in that
/// order). Returns one full column of length `n` per input column (fixed
/// entries set to their values).
///
/// # Errors
/// [`LinalgError::IndexOutOfRange`] / [`LinalgError::DuplicateIndex`] for
/// a fixed index out of range or listed twice;
/// [`LinalgError::DimensionMismatch`] when a column does not have
/// `fixed.len()` values; [`LinalgError::NotFinite`] for a value, a matrix
/// entry or a solution that is not finite; [`LinalgError::NotSquare`] /
/// [`LinalgError::NotSymmetric`] for a matrix that is not symmetric;
/// [`LinalgError::NotAnchored`] for a free vertex not coupled (through
/// non-zero entries) to any fixed vertex;
/// [`LinalgError::NotPositiveDefinite`] when `A_FF` is not positive
/// definite.
pub fn solve_dirichlet(
    matrix: &Csr,
    fixed: &[u32],
    values: &[Vec<f64>],
) -> Result<Vec<Vec<f64>>, LinalgError> {
    let mut problem = Partition::new(matrix.n_rows(), fixed, values)?;
    matrix.check_finite("Dirichlet matrix value")?;
    matrix.check_symmetric()?;
    if problem.free.is_empty() {
        return Ok(problem.columns);
    }
    problem.check_reaches_fixed(|v| {
        let (cols, vals) = matrix.row(v);
        cols.iter()
            .zip(vals)
            .filter(move |&(&j, &a)| j as usize != v && a != 0.0)
            .map(|(&j, _)| j)
    })?;

    let free_block = matrix.principal_submatrix(&problem.local)?;
    let pattern = SpdPattern::of_symmetric(&free_block)?;
    let (factor, _) = pattern.factorize(&pattern.values_of(&free_block)?, 0.0, 0)?;
    for c in 0..problem.columns.len() {
        // rhs_F = -A_FC x_C, each row's fixed columns in ascending order.
        let x = &problem.columns[c];
        let mut rhs = vec![0.0; problem.free.len()];
        for (r, &i) in rhs.iter_mut().zip(&problem.free) {
            let (cols, vals) = matrix.row(i as usize);
            for (&j, &a) in cols.iter().zip(vals) {
                if problem.is_fixed(j) {
                    *r -= a * x[j as usize];
                }
            }
        }
        factor.solve_in_place(&mut rhs)?;
        if let Some(index) = rhs.iter().position(|v| !v.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "Dirichlet solution (free vertex)",
                index,
            });
        }
        problem.set_free(c, &rhs);
    }
    Ok(problem.columns)
}

/// Solves the Dirichlet problem of a (possibly non-symmetric) weighted
/// averaging operator, e.g. [`crate::laplacian::mean_value_weights`]: every
/// free vertex is the weighted mean of its neighbours,
///
/// ```text
/// sum_j w_ij (x_i - x_j) = 0   <=>   x_i = sum_j lambda_ij x_j,
/// lambda_ij = w_ij / sum_k w_ik
/// ```
///
/// with the fixed vertices at the given values. The rows are normalized
/// (unit diagonal) and the sparse system `(I - Lambda_FF) x_F =
/// Lambda_FC x_C` is solved by sparse LU ([`SparseLu`], factorized once
/// for all columns of `values`), followed by one step of iterative
/// refinement. For positive weights the matrix is an irreducibly
/// diagonally dominant M-matrix when every free vertex is connected to a
/// fixed one, hence non-singular. `weights[i]` lists `(j, w_ij)`;
/// self-references are ignored and repeated neighbours summed; rows of
/// fixed vertices are not used. Returns one full column of length
/// `weights.len()` per value column.
///
/// # Errors
/// As [`solve_dirichlet`] for the fixed set and the values; also
/// [`LinalgError::IndexOutOfRange`] for a neighbour index out of range,
/// [`LinalgError::NotFinite`] for a weight that is not finite (the index of
/// its vertex) or a solution that is not, [`LinalgError::NoNeighbours`]
/// for a free vertex without neighbours, [`LinalgError::ZeroWeightSum`]
/// for a free row whose weights sum to 0, [`LinalgError::NotAnchored`] for
/// a free vertex that depends on no fixed one, the LU's errors, and
/// [`LinalgError::IllConditioned`] when the solution has a large residual.
pub fn solve_dirichlet_weights(
    weights: &[Vec<(u32, f64)>],
    fixed: &[u32],
    values: &[Vec<f64>],
) -> Result<Vec<Vec<f64>>, LinalgError> {
    let n = weights.len();
    let mut problem = Partition::new(n, fixed, values)?;
    if problem.free.is_empty() {
        return Ok(problem.columns);
    }
    // Normalized rows of the free vertices.
    let mut rows: Vec<Vec<(u32, f64)>> = Vec::with_capacity(problem.free.len());
    for &i in &problem.free {
        let mut sum = 0.0;
        let mut row = Vec::with_capacity(weights[i as usize].len());
        for &(j, w) in &weights[i as usize] {
            if j as usize >= n {
                return Err(LinalgError::IndexOutOfRange {
                    what: "neighbour in the weights",
                    index: j as usize,
                    len: n,
                });
            }
            if !w.is_finite() {
                return Err(LinalgError::NotFinite {
                    what: "weight of vertex",
                    index: i as usize,
                });
            }
            if j != i && w != 0.0 {
                sum += w;
                row.push((j, w));
            }
        }
        if row.is_empty() {
            return Err(LinalgError::NoNeighbours { vertex: i as usize });
        }
        if sum == 0.0 || !sum.is_finite() {
            return Err(LinalgError::ZeroWeightSum {
                vertex: i as usize,
                sum,
            });
        }
        for e in row.iter_mut() {
            e.1 /= sum;
        }
        rows.push(row);
    }
    // x_i depends on x_j when lambda_ij > 0: every free vertex needs a
    // chain of dependencies ending at a fixed vertex (then I - Lambda_FF is
    // weakly chained diagonally dominant, hence non-singular, for positive
    // weights). Search from the fixed vertices along reversed dependencies.
    let mut dependents: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (k, row) in rows.iter().enumerate() {
        for &(j, _) in row {
            dependents[j as usize].push(problem.free[k]);
        }
    }
    problem.check_reaches_fixed(|v| dependents[v].iter().copied())?;

    let nf = problem.free.len();
    // I - Lambda_FF (repeated neighbours summed).
    let mut entries: Vec<(u32, u32, f64)> =
        Vec::with_capacity(nf + rows.iter().map(Vec::len).sum::<usize>());
    for (k, row) in rows.iter().enumerate() {
        entries.push((k as u32, k as u32, 1.0));
        for &(j, l) in row {
            let lj = problem.local[j as usize];
            if lj != u32::MAX {
                entries.push((k as u32, lj, -l));
            }
        }
    }
    let matrix = Csr::from_triplets(nf, nf, &entries)?;
    let lu = SparseLu::factorize(&matrix)?;

    let ncols = values.len();
    let mut rhs = vec![0.0; nf * ncols];
    for (c, x) in problem.columns.iter().enumerate() {
        for (k, row) in rows.iter().enumerate() {
            rhs[c * nf + k] = row
                .iter()
                .filter(|e| problem.is_fixed(e.0))
                .map(|&(j, l)| l * x[j as usize])
                .sum();
        }
    }
    let mut sol = rhs.clone();
    lu.solve_in_place(&mut sol, ncols)?;
    // One step of iterative refinement: x += A^-1 (b - A x).
    let mut resid = vec![0.0; nf * ncols];
    let mut ax = vec![0.0; nf];
    for c in 0..ncols {
        matrix.mul_vec(&sol[c * nf..(c + 1) * nf], &mut ax);
        for k in 0..nf {
            resid[c * nf + k] = rhs[c * nf + k] - ax[k];
        }
    }
    lu.solve_in_place(&mut resid, ncols)?;
    for (s, d) in sol.iter_mut().zip(&resid) {
        *s += d;
    }
    if let Some(index) = sol.iter().position(|v| !v.is_finite()) {
        return Err(LinalgError::NotFinite {
            what: "sparse LU solution (column-major)",
            index,
        });
    }
    for c in 0..ncols {
        let x = &sol[c * nf..(c + 1) * nf];
        matrix.mul_vec(x, &mut ax);
        let b = &rhs[c * nf..(c + 1) * nf];
        let scale = b
            .iter()
            .chain(x)
            .fold(0.0f64, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let worst = ax
            .iter()
            .zip(b)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        if worst > 1e-8 * scale {
            return Err(LinalgError::IllConditioned {
                residual: worst,
                scale,
            });
        }
        problem.set_free(c, x);
    }
    Ok(problem.columns)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::laplacian::{cotan_laplacian, mean_value_weights, p1_stiffness};
    use crate::test_support::{Rng, boundary_mask, perturbed_tet_grid, random_disk};
    use nalgebra::Point3;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn harmonic_solve_reproduces_linear_functions(
            seed in any::<u64>(), a in -2.0..2.0f64, b in -2.0..2.0f64,
        ) {
            let mut rng = Rng(seed);
            // Triangles: cotangent Laplacian of a planar mesh.
            let m = random_disk(&mut rng, 11, 30, 30);
            let bnd = boundary_mask(&m);
            let fixed: Vec<u32> = (0..m.num_vertices() as u32).filter(|&v| bnd[v as usize]).collect();
            let f = |p: &Point3<f64>| [p.x, p.y, a * p.x + b * p.y + 1.0];
            let values: Vec<Vec<f64>> = (0..3)
                .map(|k| fixed.iter().map(|&v| f(&m.positions[v as usize])[k]).collect())
                .collect();
            let sol = solve_dirichlet(&cotan_laplacian(&m), &fixed, &values).unwrap();
            // The mean-value solve (non-symmetric LU) has linear precision too.
            let mv = solve_dirichlet_weights(&mean_value_weights(&m), &fixed, &values).unwrap();
            for (i, p) in m.positions.iter().enumerate() {
                let e = f(p);
                for k in 0..3 {
                    prop_assert!((sol[k][i] - e[k]).abs() < 1e-9, "cotan {} {}", i, k);
                    prop_assert!((mv[k][i] - e[k]).abs() < 1e-9, "mean value {} {}", i, k);
                }
            }
            // Tets: P1 stiffness of a perturbed grid.
            let (t, boundary) = perturbed_tet_grid(3, &mut rng, 0.1);
            let fixed: Vec<u32> = (0..t.num_vertices() as u32).filter(|&v| boundary[v as usize]).collect();
            let g = |p: &Point3<f64>| a * p.x - b * p.y + 0.5 * p.z - 2.0;
            let values = vec![fixed.iter().map(|&v| g(&t.positions[v as usize])).collect::<Vec<_>>()];
            let sol = solve_dirichlet(&p1_stiffness(&t), &fixed, &values).unwrap();
            for (i, p) in t.positions.iter().enumerate() {
                prop_assert!((sol[0][i] - g(p)).abs() < 1e-9);
            }
        }

    }

    #[test]
    fn dirichlet_solves_reject_bad_input() {
        let m = random_disk(&mut Rng(3), 8, 5, 0);
        let l = cotan_laplacian(&m);
        let w = mean_value_weights(&m);
        let n = m.num_vertices() as u32;
        let bnd: Vec<u32> = (1..9).collect();
        let vals = vec![vec![1.0; 8]];
        assert!(solve_dirichlet(&l, &bnd, &vals).is_ok());
        // Out of range, duplicate, wrong length, not finite.
        let mut bad = bnd.clone();
        bad[0] = n;
        let out_of_range = LinalgError::IndexOutOfRange {
            what: "fixed vertex",
            index: n as usize,
            len: n as usize,
        };
        assert_eq!(solve_dirichlet(&l, &bad, &vals), Err(out_of_range.clone()));
        assert_eq!(solve_dirichlet_weights(&w, &bad, &vals), Err(out_of_range));
        let mut dup = bnd.clone();
        dup[1] = dup[0];
        assert!(matches!(
            solve_dirichlet(&l, &dup, &vals),
            Err(LinalgError::DuplicateIndex { index: 1, .. })
        ));
        assert!(matches!(
            solve_dirichlet(&l, &bnd, &[vec![1.0; 7]]),
            Err(LinalgError::DimensionMismatch {
                expected: 8,
                found: 7,
                ..
            })
        ));
        assert!(matches!(
            solve_dirichlet_weights(&w, &bnd, &[vec![f64::NAN; 8]]),
            Err(LinalgError::NotFinite { index: 0, .. })
        ));
        // No fixed vertex: singular.
        assert_eq!(
            solve_dirichlet(&l, &[], &[vec![]]),
            Err(LinalgError::NotAnchored { vertex: 0 })
        );
        assert_eq!(
            solve_dirichlet_weights(&w, &[], &[vec![]]),
            Err(LinalgError::NotAnchored { vertex: 0 })
        );
        // An isolated vertex that is free.
        let mut m2 = m.clone();
        m2.positions.push(Point3::new(5.0, 5.0, 0.0));
        let err = solve_dirichlet(&cotan_laplacian(&m2), &bnd, &vals).unwrap_err();
        assert_eq!(err, LinalgError::NotAnchored { vertex: n as usize });
        assert!(err.to_string().contains("not connected"), "{err}");
        assert_eq!(
            solve_dirichlet_weights(&mean_value_weights(&m2), &bnd, &vals),
            Err(LinalgError::NoNeighbours { vertex: n as usize })
        );
        // Everything fixed: the values come back.
        let all: Vec<u32> = (0..n).collect();
        let v: Vec<f64> = (0..n).map(f64::from).collect();
        assert_eq!(
            solve_dirichlet(&l, &all, std::slice::from_ref(&v)).unwrap()[0],
            v
        );
        assert_eq!(
            solve_dirichlet_weights(&w, &all, std::slice::from_ref(&v)).unwrap()[0],
            v
        );
    }

    #[test]
    fn dirichlet_solves_reject_bad_matrices_and_weights() {
        let vals = vec![vec![0.0, 1.0]];
        // Not symmetric.
        let a = Csr::from_triplets(3, 3, &[(0, 0, 2.0), (0, 1, -1.0), (1, 1, 2.0), (2, 2, 1.0)])
            .unwrap();
        assert!(matches!(
            solve_dirichlet(&a, &[0, 2], &vals),
            Err(LinalgError::NotSymmetric { row: 0, col: 1, .. })
        ));
        // Not square.
        let a = Csr::from_triplets(3, 4, &[]).unwrap();
        assert!(matches!(
            solve_dirichlet(&a, &[0, 2], &vals),
            Err(LinalgError::NotSquare { rows: 3, cols: 4 })
        ));
        // A non-finite value of a mesh operator (overflowing geometry).
        let mut l =
            Csr::from_symmetric_entries(3, [(0, 1, -1.0), (1, 2, -1.0), (1, 1, 2.0)]).unwrap();
        assert!(solve_dirichlet(&l, &[0, 2], &vals).is_ok());
        l = Csr::symmetric(3, [(0, 1, -1.0), (1, 2, f64::INFINITY), (1, 1, 2.0)]);
        assert!(matches!(
            solve_dirichlet(&l, &[0, 2], &vals),
            Err(LinalgError::NotFinite { .. })
        ));
        // Not positive definite on the free block.
        let l = Csr::from_symmetric_entries(3, [(0, 1, -1.0), (1, 2, -1.0), (1, 1, -2.0)]).unwrap();
        assert!(matches!(
            solve_dirichlet(&l, &[0, 2], &vals),
            Err(LinalgError::NotPositiveDefinite { size: 1, .. })
        ));
        // Weights: a neighbour out of range, a weight that is not finite,
        // weights summing to zero.
        let w = |row: Vec<(u32, f64)>| vec![vec![], row, vec![]];
        assert!(matches!(
            solve_dirichlet_weights(&w(vec![(0, 1.0), (3, 1.0)]), &[0, 2], &vals),
            Err(LinalgError::IndexOutOfRange {
                index: 3,
                len: 3,
                ..
            })
        ));
        assert!(matches!(
            solve_dirichlet_weights(&w(vec![(0, f64::NAN)]), &[0, 2], &vals),
            Err(LinalgError::NotFinite { index: 1, .. })
        ));
        assert!(matches!(
            solve_dirichlet_weights(&w(vec![(0, 1.0), (2, -1.0)]), &[0, 2], &vals),
            Err(LinalgError::ZeroWeightSum { vertex: 1, .. })
        ));
        // The midpoint, by both solves.
        let near = |x: &[Vec<f64>]| {
            x.len() == 1
                && x[0]
                    .iter()
                    .zip([0.0, 0.5, 1.0])
                    .all(|(a, b)| (a - b).abs() < 1e-15)
        };
        let mid = solve_dirichlet_weights(&w(vec![(0, 1.0), (2, 1.0)]), &[0, 2], &vals).unwrap();
        assert!(near(&mid), "{mid:?}");
        let l = Csr::from_symmetric_entries(3, [(0, 1, -1.0), (1, 2, -1.0), (1, 1, 2.0)]).unwrap();
        let harmonic = solve_dirichlet(&l, &[0, 2], &vals).unwrap();
        assert!(near(&harmonic), "{harmonic:?}");
    }
}
