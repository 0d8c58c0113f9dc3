//! The ordinary-least-squares statistics of the full model, from the
//! projections of a column onto the orthonormal basis `Q = [Q_Z | Q_X]`
//! (ALGORITHMS 5.2).
//!
//! For a column `u` whose projection onto `Z` is removed or irrelevant
//! (the nuisance residuals `e = (I - H_Z) y`, or a relabeling `P e` of
//! them), with `a = Q' u` split into `a_Z` (q values) and `a_X` (k values):
//!
//! - residual sum of squares of the full model
//!   `RSS = |u|^2 - |a_Z|^2 - |a_X|^2`, `s^2 = RSS / (n - p)`;
//! - t (k = 1): `t = a_X / s`. By Frisch-Waugh-Lovell this is
//!   `c'b / sqrt(s^2 c'(M'M)^-1 c)` with `c` picking the interest's
//!   coefficient: `b_X = x_r'y / |x_r|^2` and `var(b_X) = s^2 / |x_r|^2`
//!   for `x_r = (I - H_Z) x`, and `q_X = x_r / |x_r|`. Its sign is the
//!   sign of `b_X`: for two groups, second level minus first;
//! - F (k >= 2): `F = (|a_X|^2 / k) / s^2`, the partial F of `X` given
//!   `Z`, since `RSS_Z - RSS_M = |Q_X' u|^2`.
//!
//! Freedman-Lane (Freedman & Lane, J. Bus. Econ. Stat. 1983; Winkler et al.,
//! NeuroImage 2014): `y* = P e + H_Z y`. As `H_Z y` lies in the span of
//! `Z` inside the span of `M`, it changes neither `Q_X' y*` nor the full
//! model's residuals, so the statistic of `y*` is the statistic above of
//! `u = P e`, and `|P e| = |e|`.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};

use super::design::StatisticKind;

/// The statistic of one column from `a = Q'u` (`a[..q]` the nuisance part,
/// `a[q..]` the interest part) and `ee = |u|^2`, with `df = n - p`.
///
/// A column without residual variance under the nuisance model (`ee == 0`,
/// e.g. a constant column) has statistic 0. `RSS` is kept at least
/// `1e-14 ee` so a perfect fit gives a large finite statistic.
#[inline]
pub(crate) fn statistic(kind: StatisticKind, a: &[f64], q: usize, ee: f64, df: f64) -> f64 {
    if ee <= 0.0 {
        return 0.0;
    }
    let nuisance: f64 = a[..q].iter().map(|v| v * v).sum();
    let interest: f64 = a[q..].iter().map(|v| v * v).sum();
    let rss = (ee - nuisance - interest).max(ee * 1e-14);
    let s2 = rss / df;
    match kind {
        StatisticKind::T => a[q] / s2.sqrt(),
        StatisticKind::F => interest / (a.len() - q) as f64 / s2,
    }
}

/// The nuisance residuals `E = Y - Q_Z (Q_Z' Y)` of `cols` columns of `n`
/// subjects (column-major), written into `e`; `ee[c] = |E_c|^2`.
pub(crate) fn nuisance_residuals(
    basis: &[f64],
    n: usize,
    q: usize,
    y: &[f64],
    e: &mut [f64],
    ee: &mut [f64],
) {
    let cols = y.len() / n;
    let qz = MatRef::from_column_major_slice(&basis[..n * q], n, q);
    let yv = MatRef::from_column_major_slice(y, n, cols);
    let mut a = faer::Mat::<f64>::zeros(q, cols);
    matmul(
        a.as_mut(),
        Accum::Replace,
        qz.transpose(),
        yv,
        1.0,
        Par::Seq,
    );
    e.copy_from_slice(y);
    let ev = MatMut::from_column_major_slice_mut(e, n, cols);
    matmul(ev, Accum::Add, qz, a.as_ref(), -1.0, Par::Seq);
    for (c, out) in ee.iter_mut().enumerate() {
        *out = e[c * n..(c + 1) * n].iter().map(|v| v * v).sum();
    }
}
