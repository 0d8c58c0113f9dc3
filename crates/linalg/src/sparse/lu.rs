//! [`SparseLu`]: faer's sparse LU of a square, possibly non-symmetric
//! [`Csr`] matrix, factorized once and solved for many right-hand sides.

use crate::{Csr, LinalgError};
use faer::MatMut;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};

/// The sparse LU factorization `P A Q = L U` of a square matrix (faer's
/// fill-reducing column ordering `Q` and partial pivoting `P`).
#[derive(Debug)]
pub struct SparseLu {
    n: usize,
    lu: Lu<usize, f64>,
}

impl SparseLu {
    /// Factorizes `a`: its compressed columns (the transpose of its rows,
    /// rows ascending in every column) are analysed symbolically and then
    /// factorized numerically.
    ///
    /// # Errors
    /// [`LinalgError::NotSquare`]; [`LinalgError::StructurallySingular`]
    /// when no pivot is found; [`LinalgError::Faer`] for faer's own
    /// failures (index overflow, out of memory).
    pub fn factorize(a: &Csr) -> Result<SparseLu, LinalgError> {
        let n = a.n_rows();
        if a.n_cols() != n {
            return Err(LinalgError::NotSquare {
                rows: n,
                cols: a.n_cols(),
            });
        }
        // Compressed columns of A = compressed rows of A^T.
        let columns = a.transpose();
        let col_ptr = columns.row_ptr().to_vec();
        let row_idx: Vec<usize> = columns.col_indices().iter().map(|&r| r as usize).collect();
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let mat = SparseColMatRef::new(symbolic.as_ref(), columns.values());
        let symbolic_lu =
            SymbolicLu::try_new(symbolic.as_ref()).map_err(LinalgError::faer("symbolic LU"))?;
        let lu = Lu::try_new_with_symbolic(symbolic_lu, mat).map_err(|e| match e {
            LuError::SymbolicSingular { index } => LinalgError::StructurallySingular { index },
            LuError::Generic(source) => LinalgError::Faer {
                during: "numeric LU",
                source,
            },
        })?;
        Ok(SparseLu { n, lu })
    }

    /// Matrix size.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Solves `A X = B` in place for the `ncols` right-hand sides stored
    /// one after the other in `b` (column-major `n x ncols`).
    ///
    /// # Errors
    /// [`LinalgError::DimensionMismatch`] when `b.len() != n * ncols`.
    pub fn solve_in_place(&self, b: &mut [f64], ncols: usize) -> Result<(), LinalgError> {
        let expected = self.n.saturating_mul(ncols);
        if b.len() != expected {
            return Err(LinalgError::DimensionMismatch {
                what: "right-hand sides (n per column)",
                expected,
                found: b.len(),
            });
        }
        self.lu
            .solve_in_place(MatMut::from_column_major_slice_mut(b, self.n, ncols));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Rng, dense};
    use nalgebra::DMatrix;

    #[test]
    fn solves_non_symmetric_systems_with_several_right_hand_sides() {
        let mut rng = Rng(17);
        let n = 40;
        // Diagonally dominant, non-symmetric.
        let mut t = Vec::new();
        for i in 0..n as u32 {
            t.push((i, i, 8.0));
            for _ in 0..3 {
                t.push((i, rng.below(n) as u32, rng.sym(1.0)));
            }
        }
        let a = Csr::from_triplets(n, n, &t).unwrap();
        let lu = SparseLu::factorize(&a).unwrap();
        assert_eq!(lu.n(), n);
        let b: Vec<f64> = (0..2 * n).map(|_| rng.sym(3.0)).collect();
        let mut x = b.clone();
        lu.solve_in_place(&mut x, 2).unwrap();
        let d = dense(&a);
        for c in 0..2 {
            let xc = DMatrix::from_column_slice(n, 1, &x[c * n..(c + 1) * n]);
            let r = &d * xc;
            for i in 0..n {
                assert!(
                    (r[i] - b[c * n + i]).abs() < 1e-12,
                    "{} vs {}",
                    r[i],
                    b[c * n + i]
                );
            }
        }
        assert!(matches!(
            lu.solve_in_place(&mut x[..n + 1], 2),
            Err(LinalgError::DimensionMismatch { found, .. }) if found == n + 1
        ));
    }

    #[test]
    fn refuses_rectangular_and_structurally_singular_matrices() {
        let a = Csr::from_triplets(2, 3, &[]).unwrap();
        assert!(matches!(
            SparseLu::factorize(&a),
            Err(LinalgError::NotSquare { rows: 2, cols: 3 })
        ));
        // Column 1 is empty.
        let a = Csr::from_triplets(2, 2, &[(0, 0, 1.0), (1, 0, 1.0)]).unwrap();
        assert!(matches!(
            SparseLu::factorize(&a),
            Err(LinalgError::StructurallySingular { .. })
        ));
    }
}
