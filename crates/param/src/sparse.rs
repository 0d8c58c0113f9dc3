//! Sparse symmetric positive definite solves: faer's supernodal Cholesky
//! behind one module (faer changes its API often).
//!
//! The pattern (upper triangle, CSC) is analysed once ([`SpdPattern`]: AMD
//! ordering and symbolic factorization), then refactorized for every new set
//! of values ([`SpdPattern::factorize`]), as projected Newton needs: the
//! Hessian's sparsity never changes between iterations.

use crate::ParamError;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{MatMut, Side};

/// A fixed sparsity pattern of a symmetric `n x n` matrix (its upper
/// triangle, diagonal included), with the symbolic Cholesky analysis done
/// once, and the slot of every entry in the value array.
#[derive(Debug, Clone)]
pub struct SpdPattern {
    n: usize,
    symbolic: SymbolicSparseColMat<usize>,
    llt: SymbolicLlt<usize>,
    diagonal: Vec<usize>,
}

impl SpdPattern {
    /// The pattern of the given entries (`(i, j)` pairs in any order and
    /// either triangle; duplicates merged); the diagonal is always included.
    pub fn new(
        n: usize,
        entries: impl IntoIterator<Item = (u32, u32)>,
    ) -> Result<Self, ParamError> {
        let mut cols: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, j) in entries {
            let (r, c) = if i <= j { (i, j) } else { (j, i) };
            if c as usize >= n {
                return Err(ParamError::InvalidArgument(format!(
                    "sparse entry ({i}, {j}) outside a {n} x {n} matrix"
                )));
            }
            cols[c as usize].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut diagonal = Vec::with_capacity(n);
        col_ptr.push(0usize);
        for (c, rows) in cols.iter_mut().enumerate() {
            rows.push(c as u32);
            rows.sort_unstable();
            rows.dedup();
            for &r in rows.iter() {
                if r as usize == c {
                    diagonal.push(row_idx.len());
                }
                row_idx.push(r as usize);
            }
            col_ptr.push(row_idx.len());
        }
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let llt = SymbolicLlt::try_new(symbolic.as_ref(), Side::Upper)
            .map_err(|e| ParamError::Factorization(format!("symbolic analysis: {e:?}")))?;
        Ok(SpdPattern {
            n,
            symbolic,
            llt,
            diagonal,
        })
    }

    /// Matrix size.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored (upper-triangle) entries.
    pub fn nnz(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// The value slot of entry `(i, j)` (either order), if in the pattern:
    /// a binary search among the sorted rows of column `max(i, j)`.
    pub fn slot(&self, i: u32, j: u32) -> Option<usize> {
        let (r, c) = if i <= j { (i, j) } else { (j, i) };
        let c = c as usize;
        if c >= self.n {
            return None;
        }
        let col_ptr = self.symbolic.col_ptr();
        let (start, end) = (col_ptr[c], col_ptr[c + 1]);
        self.symbolic.row_idx()[start..end]
            .binary_search(&(r as usize))
            .ok()
            .map(|k| start + k)
    }

    /// The value slots of the diagonal entries.
    pub fn diagonal_slots(&self) -> &[usize] {
        &self.diagonal
    }

    /// `y = A x` for the symmetric matrix with these (upper triangle) values.
    pub fn multiply(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        let col_ptr = self.symbolic.col_ptr();
        let row_idx = self.symbolic.row_idx();
        for c in 0..self.n {
            for s in col_ptr[c]..col_ptr[c + 1] {
                let (r, v) = (row_idx[s], values[s]);
                y[r] += v * x[c];
                if r != c {
                    y[c] += v * x[r];
                }
            }
        }
        y
    }

    /// Numeric Cholesky factorization of the matrix with these (upper
    /// triangle) values. When it fails (not positive definite), retries with
    /// the diagonal shifted by `shift * max|diag|`, multiplying the shift by
    /// 10 up to `max_tries` times (ALGORITHMS 1.5). Returns the factor and
    /// the shift used (0 when none).
    pub fn factorize(
        &self,
        values: &[f64],
        shift: f64,
        max_tries: usize,
    ) -> Result<(SpdFactor, f64), ParamError> {
        if values.len() != self.nnz() {
            return Err(ParamError::Length {
                what: "sparse values",
                expected: self.nnz(),
                found: values.len(),
            });
        }
        if !values.iter().all(|v| v.is_finite()) {
            return Err(ParamError::NotFinite("matrix values".into()));
        }
        let scale = self
            .diagonal
            .iter()
            .map(|&s| values[s].abs())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut shifted;
        let mut current = values;
        let mut used = 0.0;
        let mut delta = shift;
        for attempt in 0..=max_tries {
            let mat = SparseColMatRef::new(self.symbolic.as_ref(), current);
            match Llt::try_new_with_symbolic(self.llt.clone(), mat, Side::Upper) {
                Ok(llt) => return Ok((SpdFactor { n: self.n, llt }, used)),
                Err(e) if attempt == max_tries => {
                    return Err(ParamError::Factorization(format!(
                        "{e:?} (after diagonal shift {used:e})"
                    )));
                }
                Err(_) => {
                    used = delta * scale;
                    shifted = values.to_vec();
                    for &s in &self.diagonal {
                        shifted[s] += used;
                    }
                    current = &shifted;
                    delta *= 10.0;
                }
            }
        }
        Err(ParamError::Factorization("no attempt made".into()))
    }
}

/// A numeric Cholesky factor `A = L L^T` (with a fill-reducing ordering).
#[derive(Debug, Clone)]
pub struct SpdFactor {
    n: usize,
    llt: Llt<usize, f64>,
}

impl SpdFactor {
    /// Solves `A x = b` in place (`b` has length `n`).
    pub fn solve_in_place(&self, b: &mut [f64]) -> Result<(), ParamError> {
        if b.len() != self.n {
            return Err(ParamError::Length {
                what: "right-hand side",
                expected: self.n,
                found: b.len(),
            });
        }
        let rhs = MatMut::from_column_major_slice_mut(b, self.n, 1);
        self.llt.solve_in_place(rhs);
        Ok(())
    }
}

/// Solves the SPD system given as triplets `(i, j, value)` (entries of both
/// triangles may be given; each upper-triangle position sums the values
/// given for it and its mirror only once, so give each off-diagonal entry
/// once) for the right-hand side `b`. A one-shot convenience over
/// [`SpdPattern`].
pub fn solve_spd(
    n: usize,
    triplets: &[(u32, u32, f64)],
    b: &[f64],
) -> Result<Vec<f64>, ParamError> {
    let pattern = SpdPattern::new(n, triplets.iter().map(|&(i, j, _)| (i, j)))?;
    let mut values = vec![0.0; pattern.nnz()];
    for &(i, j, v) in triplets {
        if let Some(s) = pattern.slot(i, j) {
            values[s] += v;
        }
    }
    let (factor, _) = pattern.factorize(&values, 0.0, 0)?;
    let mut x = b.to_vec();
    factor.solve_in_place(&mut x)?;
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The 1D Laplacian plus identity: tridiagonal SPD.
    fn tridiagonal(n: usize) -> Vec<(u32, u32, f64)> {
        let mut t = Vec::new();
        for i in 0..n as u32 {
            t.push((i, i, 3.0));
            if i + 1 < n as u32 {
                t.push((i, i + 1, -1.0));
            }
        }
        t
    }

    fn multiply(n: usize, t: &[(u32, u32, f64)], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; n];
        for &(i, j, v) in t {
            y[i as usize] += v * x[j as usize];
            if i != j {
                y[j as usize] += v * x[i as usize];
            }
        }
        y
    }

    proptest! {
        #[test]
        fn solves_spd_systems(n in 1usize..60, b in prop::collection::vec(-10.0..10.0f64, 60)) {
            let t = tridiagonal(n);
            let x = solve_spd(n, &t, &b[..n]).unwrap();
            let r = multiply(n, &t, &x);
            for i in 0..n {
                prop_assert!((r[i] - b[i]).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn refactorizes_with_new_values_and_shifts_indefinite_ones() {
        let n = 5;
        let t = tridiagonal(n);
        let p = SpdPattern::new(n, t.iter().map(|&(i, j, _)| (j, i))).unwrap();
        let mut v = vec![0.0; p.nnz()];
        for &(i, j, x) in &t {
            v[p.slot(i, j).unwrap()] += x;
        }
        let (f, shift) = p.factorize(&v, 1e-8, 8).unwrap();
        assert_eq!(shift, 0.0);
        let ones = vec![1.0; n];
        assert_eq!(p.multiply(&v, &ones), multiply(n, &t, &ones));
        let mut b = vec![1.0; n];
        f.solve_in_place(&mut b).unwrap();
        assert!((multiply(n, &t, &b)[2] - 1.0).abs() < 1e-12);
        // An indefinite matrix needs a diagonal shift.
        for &s in p.diagonal_slots() {
            v[s] = -1.0;
        }
        let (_, shift) = p.factorize(&v, 1e-8, 12).unwrap();
        assert!(shift > 0.0);
        assert!(p.factorize(&v, 1e-8, 0).is_err());
        assert!(p.factorize(&v[1..], 1e-8, 0).is_err());
        assert!(SpdPattern::new(2, [(0, 5)]).is_err());
    }
}
