//! The exact solve on the coarsest multigrid level: a dense Cholesky
//! factorization of a symmetric positive *semi*definite matrix that drops
//! (fixes to zero) every unknown whose pivot vanishes, as masked grids make
//! the coarse levels rank deficient (see [`super`]).

use crate::{Csr, LinalgError};

/// A coarsest-level pivot `s_j <= PIVOT_TOL a_jj` counts as zero (the unknown
/// is linearly dependent on the earlier ones).
const PIVOT_TOL: f64 = 1e-10;

/// A dense Cholesky factor `A_KK = L_KK L_KK^T` of the coarsest operator on
/// its kept unknowns `K` (the others are dropped: fixed to zero).
#[derive(Debug, Clone)]
pub(super) struct DenseCholesky {
    pub(super) n: usize,
    /// Column-major `n x n`; the lower triangle holds `L`. Columns of
    /// dropped unknowns are zero; their rows hold `L_jk`, `k < j`, which
    /// define their null vectors.
    l: Vec<f64>,
    kept: Vec<bool>,
}

impl DenseCholesky {
    /// Right-looking Cholesky of a symmetric positive semidefinite `a`
    /// (lower triangle read): at step `j` the pivot is
    /// `s_j = a_jj - sum_{k<j} l_jk^2`; if `s_j > PIVOT_TOL a_jj` then
    /// `l_jj = sqrt(s_j)`, else if `s_j >= -PIVOT_TOL a_jj` unknown `j` is
    /// linearly dependent on the earlier kept ones and dropped, else `a` is
    /// not positive semidefinite (an error).
    /// Returns the factor and the dropped unknowns.
    pub(super) fn factor(a: &Csr) -> Result<(DenseCholesky, Vec<usize>), LinalgError> {
        let n = a.n_rows();
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            let (c, v) = a.row(i);
            for (&j, &x) in c.iter().zip(v) {
                if (j as usize) <= i {
                    l[i + n * j as usize] = x;
                }
            }
        }
        let diag0: Vec<f64> = (0..n).map(|j| l[j + n * j]).collect();
        let mut kept = vec![true; n];
        let mut dropped = Vec::new();
        for j in 0..n {
            let s = l[j + n * j];
            let scale = diag0[j].abs();
            if !s.is_finite() {
                return Err(LinalgError::NotFinite {
                    what: "coarsest-level Cholesky pivot",
                    index: j,
                });
            }
            if s > PIVOT_TOL * scale && s > 0.0 {
                let d = s.sqrt();
                let (left, right) = l.split_at_mut(n * (j + 1));
                let colj = &mut left[n * j..];
                colj[j] = d;
                for x in &mut colj[j + 1..] {
                    *x /= d;
                }
                for k in j + 1..n {
                    let lkj = colj[k];
                    if lkj == 0.0 {
                        continue;
                    }
                    let colk = &mut right[n * (k - j - 1)..n * (k - j)];
                    for (x, &y) in colk[k..].iter_mut().zip(&colj[k..]) {
                        *x -= lkj * y;
                    }
                }
            } else if s >= -PIVOT_TOL * scale {
                kept[j] = false;
                dropped.push(j);
                l[n * j + j..n * (j + 1)].fill(0.0);
            } else {
                return Err(LinalgError::NegativePivot {
                    index: j,
                    pivot: s,
                    diagonal: diag0[j],
                });
            }
        }
        Ok((DenseCholesky { n, l, kept }, dropped))
    }

    /// `x = E_K A_KK^{-1} E_K^T b` (dropped unknowns zero): forward
    /// substitution `L w = b`, back substitution `L^T x = w`, on `K`.
    pub(super) fn solve(&self, b: &[f64], x: &mut [f64]) {
        let n = self.n;
        x.copy_from_slice(b);
        for j in 0..n {
            if !self.kept[j] {
                x[j] = 0.0;
                continue;
            }
            let col = &self.l[n * j..n * (j + 1)];
            let xj = x[j] / col[j];
            x[j] = xj;
            for (xi, &lij) in x[j + 1..].iter_mut().zip(&col[j + 1..]) {
                *xi -= lij * xj;
            }
        }
        for j in (0..n).rev() {
            if !self.kept[j] {
                x[j] = 0.0;
                continue;
            }
            let col = &self.l[n * j..n * (j + 1)];
            let s: f64 = col[j + 1..]
                .iter()
                .zip(&x[j + 1..])
                .map(|(&lij, &xi)| lij * xi)
                .sum();
            x[j] = (x[j] - s) / col[j];
        }
    }

    /// The null vector of dropped unknown `j`: `n_j = 1`, `n_K<j = -c` with
    /// `L_KK^T c = (l_jk)_{k in K, k < j}`, zero elsewhere, so that
    /// `A n = 0` up to the dropped pivot.
    pub(super) fn null_vector(&self, j: usize) -> Vec<f64> {
        let n = self.n;
        let mut c = vec![0.0; n];
        for k in (0..j).rev() {
            if !self.kept[k] {
                continue;
            }
            let col = &self.l[n * k..n * (k + 1)];
            let s: f64 = col[k + 1..j]
                .iter()
                .zip(&c[k + 1..j])
                .map(|(&lik, &ci)| lik * ci)
                .sum();
            c[k] = (col[j] - s) / col[k];
        }
        c.iter_mut().for_each(|x| *x = -*x);
        c[j] = 1.0;
        c
    }
}
