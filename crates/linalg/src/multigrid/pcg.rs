//! Preconditioned conjugate gradients with a [`Multigrid`] V-cycle as the
//! preconditioner.

use super::Multigrid;
use crate::csr::{PAR_MIN, ROW_CHUNK};
use crate::{Csr, LinalgError};
use rayon::prelude::*;

/// Outcome of [`pcg`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgReport {
    /// Conjugate-gradient iterations done (each one product with `A` and one
    /// preconditioner application).
    pub iterations: usize,
    /// The achieved `|b - A x| / |b|`, recomputed from `x` (0 for `b = 0`).
    pub relative_residual: f64,
}

/// `sum_i a_i b_i`, in parallel chunks for long vectors (chunk sums added
/// in order, so the result does not depend on the thread count: runs are
/// reproducible to the bit).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() < PAR_MIN {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    } else {
        let parts: Vec<f64> = a
            .par_chunks(ROW_CHUNK)
            .zip(b.par_chunks(ROW_CHUNK))
            .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum())
            .collect();
        parts.iter().sum()
    }
}

/// `y += alpha x`.
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    if y.len() < PAR_MIN {
        y.iter_mut().zip(x).for_each(|(yi, &xi)| *yi += alpha * xi);
    } else {
        y.par_iter_mut()
            .zip(x.par_iter())
            .for_each(|(yi, &xi)| *yi += alpha * xi);
    }
}

/// `y = x + beta y`.
fn xpby(x: &[f64], beta: f64, y: &mut [f64]) {
    if y.len() < PAR_MIN {
        y.iter_mut()
            .zip(x)
            .for_each(|(yi, &xi)| *yi = xi + beta * *yi);
    } else {
        y.par_iter_mut()
            .zip(x.par_iter())
            .for_each(|(yi, &xi)| *yi = xi + beta * *yi);
    }
}

/// Preconditioned conjugate gradients on `A x = b` from the initial `x`,
/// preconditioner `M^{-1}` = one [`Multigrid::apply`]:
///
/// ```text
/// r = b - A x,  z = M^{-1} r,  p = z
/// repeat:  alpha = r.z / p.A p,  x += alpha p,  r -= alpha A p,
///          stop if |r| <= rel_tol |b|,
///          z' = M^{-1} r,  beta = r.z' / r.z,  p = z' + beta p
/// ```
///
/// until `|b - A x| <= rel_tol |b|`. When the recurrence residual reaches
/// the tolerance the true residual `b - A x` is recomputed; if rounding made
/// them drift apart the iteration restarts from the true residual. The
/// report gives the true relative residual reached. `b = 0` gives `x = 0`.
///
/// # Errors
/// [`LinalgError::DimensionMismatch`] for lengths that do not match `A`
/// (or the preconditioner); [`LinalgError::NotSquare`] if `A` is not
/// square; [`LinalgError::InvalidTolerance`] if `rel_tol` is not positive
/// and finite; [`LinalgError::NotFinite`] if `b`, `x` or the initial
/// residual has a non-finite entry; [`LinalgError::NoConvergence`] (with
/// the relative residual reached) if the iteration did not converge within
/// `max_iter` iterations; [`LinalgError::Breakdown`] on a breakdown
/// (`p^T A p <= 0` or NaN, `r^T M^{-1} r <= 0` or NaN, a non-finite
/// residual: `A` or `M` is not positive definite).
pub fn pcg(
    a: &Csr,
    b: &[f64],
    x: &mut [f64],
    m: &Multigrid,
    rel_tol: f64,
    max_iter: usize,
) -> Result<PcgReport, LinalgError> {
    let n = a.n_rows();
    if a.n_cols() != n {
        return Err(LinalgError::NotSquare {
            rows: n,
            cols: a.n_cols(),
        });
    }
    for (what, len) in [
        ("pcg: right-hand side b", b.len()),
        ("pcg: initial guess x", x.len()),
        ("pcg: preconditioner size", m.size()),
    ] {
        if len != n {
            return Err(LinalgError::DimensionMismatch {
                what,
                expected: n,
                found: len,
            });
        }
    }
    if !(rel_tol > 0.0 && rel_tol.is_finite()) {
        return Err(LinalgError::InvalidTolerance {
            what: "pcg: the relative tolerance",
            value: rel_tol,
        });
    }
    for (what, v) in [
        ("pcg: right-hand side b, entry", b),
        ("pcg: initial guess x, entry", &*x),
    ] {
        if let Some(index) = v.iter().position(|t| !t.is_finite()) {
            return Err(LinalgError::NotFinite { what, index });
        }
    }
    let b_norm = dot(b, b).sqrt();
    if b_norm == 0.0 {
        x.fill(0.0);
        return Ok(PcgReport {
            iterations: 0,
            relative_residual: 0.0,
        });
    }
    let target = rel_tol * b_norm;
    let mut r = vec![0.0; n];
    a.residual(b, x, &mut r);
    let mut r_norm = dot(&r, &r).sqrt();
    if !r_norm.is_finite() {
        let index = r.iter().position(|t| !t.is_finite()).unwrap_or(0);
        return Err(LinalgError::NotFinite {
            what: "pcg: the initial residual b - A x, entry",
            index,
        });
    }
    if r_norm <= target {
        return Ok(PcgReport {
            iterations: 0,
            relative_residual: r_norm / b_norm,
        });
    }
    let mut z = vec![0.0; n];
    let mut p = vec![0.0; n];
    let mut q = vec![0.0; n];
    let restart = |r: &[f64], z: &mut [f64], p: &mut [f64], it: usize| {
        m.apply(r, z);
        p.copy_from_slice(z);
        let rz = dot(r, z);
        if rz > 0.0 && rz.is_finite() {
            Ok(rz)
        } else {
            Err(breakdown_rz(it, rz))
        }
    };
    let mut rz = restart(&r, &mut z, &mut p, 0)?;
    for it in 1..=max_iter {
        a.mul_vec(&p, &mut q);
        let pq = dot(&p, &q);
        if !(pq > 0.0 && pq.is_finite()) {
            return Err(LinalgError::Breakdown {
                iteration: it,
                quantity: "p^T A p",
                value: pq,
            });
        }
        let alpha = rz / pq;
        axpy(alpha, &p, x);
        axpy(-alpha, &q, &mut r);
        r_norm = dot(&r, &r).sqrt();
        if !r_norm.is_finite() {
            return Err(LinalgError::Breakdown {
                iteration: it,
                quantity: "|r|",
                value: r_norm,
            });
        }
        if r_norm <= target {
            a.residual(b, x, &mut r);
            r_norm = dot(&r, &r).sqrt();
            if r_norm <= target {
                return Ok(PcgReport {
                    iterations: it,
                    relative_residual: r_norm / b_norm,
                });
            }
            rz = restart(&r, &mut z, &mut p, it)?;
            continue;
        }
        m.apply(&r, &mut z);
        let rz_new = dot(&r, &z);
        if !(rz_new > 0.0 && rz_new.is_finite()) {
            return Err(breakdown_rz(it, rz_new));
        }
        xpby(&z, rz_new / rz, &mut p);
        rz = rz_new;
    }
    Err(LinalgError::NoConvergence {
        iterations: max_iter,
        residual: r_norm / b_norm,
    })
}

fn breakdown_rz(it: usize, rz: f64) -> LinalgError {
    LinalgError::Breakdown {
        iteration: it,
        quantity: "r^T M^-1 r",
        value: rz,
    }
}
