//! A sparse symmetric eigensolver for the few smallest eigenpairs of a
//! positive semidefinite matrix, e.g. the Fiedler vector (second-smallest
//! eigenvector) of the normalized graph Laplacian
//!
//! ```text
//! L = I - D^-1/2 W D^-1/2,      L (D^1/2 1) = 0,
//! ```
//!
//! whose null vector `D^1/2 1` is known and deflated.
//!
//! # Method: shift-invert block Krylov subspace iteration with Rayleigh–Ritz
//!
//! Let `U` (`n x d`) be an orthonormal basis of the deflated vectors and
//! `P = I - U U^T` the projector onto their orthogonal complement; the
//! problem solved is the eigenproblem of `P A P` on `range(P)`.
//!
//! 1. **Shift-invert.** `A + sigma I` is factored once (sparse Cholesky,
//!    [`crate::sparse::SpdPattern`]) with the small positive shift
//!    `sigma = 1e-6 * |A|_est` (so that a PSD `A` with a null vector is
//!    factorizable; if the factorization still fails, the shift is raised
//!    tenfold a few times). `|A|_est = max_i sum_j |a_ij|` is the
//!    Gershgorin bound, `|A|_2 <= |A|_est`. The operator iterated is the
//!    inverse of `P (A + sigma I) P` on `range(P)`:
//!
//!    ```text
//!    S x = T x - T U (U^T T U)^-1 U^T T x,      T = (A + sigma I)^-1,
//!    ```
//!
//!    (`y = S x` is the `y ⊥ U` with `(A + sigma I) y - x ∈ span U`), whose
//!    largest eigenvalues `1 / (lambda_j + sigma)` belong to the smallest
//!    eigenvalues `lambda_j` of `P A P`. When `span U` is invariant (the
//!    usual case, a null vector) this is just `P T`.
//! 2. **Block Krylov basis.** From the current block `X` (`n x b`,
//!    orthonormal, `X ⊥ U`, `b = k + guard` capped by `n - d`) the basis
//!
//!    ```text
//!    V = orth [X, S X, S^2 X]
//!    ```
//!
//!    is built block by block (modified Gram–Schmidt against `U` and all
//!    previous columns, repeated while a pass removes more than half of the
//!    norm, at most three passes; columns that are numerically dependent
//!    are dropped, which happens as the block converges).
//! 3. **Rayleigh–Ritz.** With the small dense `H = V^T A V` and its
//!    eigendecomposition `H = Q Theta Q^T` (ascending `theta`), the new
//!    block is the `b` Ritz vectors `X <- V Q[:, ..b]`.
//! 4. **Convergence.** The `k` wanted Ritz pairs `(theta_j, x_j)` are
//!    accepted once every residual satisfies
//!
//!    ```text
//!    |P (A x_j - theta_j x_j)| <= tol * max(1, |A|_est)
//!    ```
//!
//!    (for an invariant `span U`, `P (A x - theta x) = A x - theta x`).
//!
//! Plain subspace iteration (`V = orth(S X)`) shrinks the error of pair `j`
//! by `(lambda_j + sigma) / (lambda_{b+1} + sigma)` per iteration; the
//! Krylov basis of depth 2 applies the best degree-2 polynomial in `S`
//! instead, which is markedly faster when the wanted eigenvalues are not
//! well separated from the rest, at the cost of `2 b` solves per iteration.
//!
//! The start block is a fixed pseudo-random sequence (SplitMix64) and all
//! reductions run in a fixed order, so results are reproducible bit for bit.
//! Every eigenvector is normalized and its largest-magnitude component is
//! made positive.

use crate::sparse::{SpdFactor, SpdPattern};
use crate::{Csr, LinalgError};
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rayon::prelude::*;

/// The shift `sigma` of `A + sigma I`, relative to `|A|_est`.
const RELATIVE_SHIFT: f64 = 1e-6;
/// How many times the factorization is retried with a tenfold shift.
const SHIFT_TRIES: usize = 8;
/// Number of `S`-blocks appended to `X` in the Krylov basis.
const KRYLOV_DEPTH: usize = 2;
/// A vector whose norm drops below this fraction of its original norm under
/// Gram–Schmidt is numerically dependent and dropped.
const DROP_TOLERANCE: f64 = 1e-10;
/// Seed of the deterministic start block.
const SEED: u64 = 0x5EED_F1ED_1E12_0001;

/// Options of [`smallest_eigenpairs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EigenOptions {
    /// Converged when every wanted pair has `|A v - lambda v| <= tol * max(1, |A|_est)`
    /// (default 1e-8), with `|A|_est = max_i sum_j |a_ij| >= |A|_2`.
    pub tol: f64,
    /// Iteration limit (default 500).
    pub max_iterations: usize,
    /// Extra block vectors beyond `k` (guard vectors that speed convergence; default 4).
    pub guard: usize,
}

impl Default for EigenOptions {
    /// `tol = 1e-8`, `max_iterations = 500`, `guard = 4`.
    fn default() -> Self {
        EigenOptions {
            tol: 1e-8,
            max_iterations: 500,
            guard: 4,
        }
    }
}

/// The result: eigenvalues ascending, unit eigenvectors (orthogonal to each
/// other and to the deflated vectors).
#[derive(Debug, Clone, PartialEq)]
pub struct Eigenpairs {
    /// Eigenvalues `lambda_1 <= ... <= lambda_k` (Ritz values).
    pub values: Vec<f64>,
    /// Unit eigenvectors `v_j` (`|v_j| = 1`, `v_i · v_j = 0`, `v_j ⊥ deflate`),
    /// each with its largest-magnitude component positive.
    pub vectors: Vec<Vec<f64>>,
    /// Residual norms |A v - lambda v| of each pair (projected onto the
    /// complement of the deflated vectors: `|P (A v - lambda v)|`, equal to
    /// `|A v - lambda v|` when the deflated span is invariant).
    pub residuals: Vec<f64>,
    /// Iterations used.
    pub iterations: usize,
}

/// The `k` smallest eigenpairs of the symmetric positive semidefinite matrix `a`
/// (both triangles stored, as [`Csr::from_symmetric_entries`] builds it)
/// restricted to the orthogonal complement of `deflate` (vectors of length n, need not be normalized
/// or orthogonal; they are orthonormalized first; typically the known null vector).
///
/// Solves `P A P v = lambda v`, `v ⊥ deflate`, `P = I - U U^T` with `U` an
/// orthonormal basis of `span(deflate)` (linearly dependent deflation
/// vectors are dropped), by shift-invert block Krylov subspace iteration
/// with Rayleigh–Ritz (module docs): factor `A + sigma I` once
/// (`sigma = 1e-6 |A|_est`, `|A|_est = max_i sum_j |a_ij|`), then repeat
///
/// ```text
/// V = orth [X, S X, S^2 X],   S = (P (A + sigma I) P)^-1 on range(P)
/// V^T A V = Q Theta Q^T,      X <- V Q[:, ..b]     (b = k + guard)
/// ```
///
/// until `|P (A x_j - theta_j x_j)| <= tol * max(1, |A|_est)` for the `k`
/// smallest Ritz pairs.
///
/// `a` need not be exactly semidefinite: the shift is raised until
/// `A + sigma I` factors, and the method then still finds the smallest
/// eigenvalues.
///
/// # Errors
/// - [`LinalgError::NotSquare`] / [`LinalgError::NotSymmetric`] if `a` is
///   not symmetric;
/// - [`LinalgError::EigenpairCount`] if `k == 0` or `k + deflate.len() > n`;
/// - [`LinalgError::InvalidTolerance`] if `tol` is not positive and finite;
/// - [`LinalgError::DimensionMismatch`] if a deflation vector does not have
///   length `n`;
/// - [`LinalgError::NotFinite`] if a matrix entry or deflation vector is
///   not finite (or the iterates become so);
/// - [`LinalgError::NotPositiveDefinite`] if `A + sigma I` cannot be
///   factored even with the raised shifts;
/// - [`LinalgError::NoConvergence`] if the iteration has not converged
///   after `max_iterations` (with the largest residual).
pub fn smallest_eigenpairs(
    a: &Csr,
    k: usize,
    deflate: &[Vec<f64>],
    opts: &EigenOptions,
) -> Result<Eigenpairs, LinalgError> {
    let n = a.n_rows();
    if a.n_cols() != n {
        return Err(LinalgError::NotSquare {
            rows: n,
            cols: a.n_cols(),
        });
    }
    if k == 0 || k + deflate.len() > n {
        return Err(LinalgError::EigenpairCount {
            wanted: k,
            deflated: deflate.len(),
            size: n,
        });
    }
    if !(opts.tol > 0.0 && opts.tol.is_finite()) {
        return Err(LinalgError::InvalidTolerance {
            what: "eigensolver tolerance",
            value: opts.tol,
        });
    }
    for (index, v) in deflate.iter().enumerate() {
        if v.len() != n {
            return Err(LinalgError::DimensionMismatch {
                what: "deflation vector",
                expected: n,
                found: v.len(),
            });
        }
        if !v.iter().all(|x| x.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "deflation vector",
                index,
            });
        }
    }
    a.check_finite("eigensolver matrix value")?;
    a.check_symmetric()?;
    let norm = a.max_row_sum();
    let threshold = opts.tol * norm.max(1.0);

    // Orthonormal basis of span(deflate).
    let mut u: Vec<Vec<f64>> = Vec::with_capacity(deflate.len());
    for v in deflate {
        if let Some(q) = orthonormalize(v.clone(), &[], &u) {
            u.push(q);
        }
    }
    let b = (k + opts.guard).min(n - u.len());

    let op = ShiftInvert::new(a, norm, &u)?;

    // Deterministic start block.
    let mut rng = SplitMix(SEED);
    let mut x: Vec<Vec<f64>> = Vec::with_capacity(b);
    refill(&mut x, n, b, &u, &mut rng)?;

    let mut largest = f64::INFINITY;
    for iteration in 1..=opts.max_iterations {
        // V = orth [X, S X, S^2 X].
        let mut basis = x;
        let mut last = 0..basis.len();
        for _ in 0..KRYLOV_DEPTH {
            let images = basis[last.clone()]
                .par_iter()
                .map(|v| op.apply(v))
                .collect::<Result<Vec<_>, _>>()?;
            let start = basis.len();
            for w in images {
                if let Some(q) = orthonormalize(w, &u, &basis) {
                    basis.push(q);
                }
            }
            if basis.len() == start {
                break;
            }
            last = start..basis.len();
        }

        // Rayleigh–Ritz with H = V^T A V.
        let av: Vec<Vec<f64>> = basis.par_iter().map(|v| a.multiply(v)).collect();
        let m = basis.len();
        let h = DMatrix::from_fn(m, m, |i, j| {
            0.5 * (dot(&basis[i], &av[j]) + dot(&basis[j], &av[i]))
        });
        if let Some(index) = h.iter().position(|v| !v.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "Rayleigh–Ritz matrix entry (column-major)",
                index,
            });
        }
        let eig = SymmetricEigen::try_new(h, f64::EPSILON, 10_000)
            .ok_or(LinalgError::RayleighRitz { size: m })?;
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
        let theta: Vec<f64> = order[..b].iter().map(|&c| eig.eigenvalues[c]).collect();
        let ritz: Vec<Vec<f64>> = order[..b]
            .iter()
            .map(|&c| combine(&basis, eig.eigenvectors.column(c).as_slice()))
            .collect();

        // Residuals of the k wanted pairs, with fresh products.
        let mut vectors = Vec::with_capacity(k);
        let mut residuals = Vec::with_capacity(k);
        for (j, v) in ritz[..k].iter().enumerate() {
            let mut v = v.clone();
            let nv = dot(&v, &v).sqrt();
            v.iter_mut().for_each(|c| *c /= nv);
            let mut r = a.multiply(&v);
            axpy(-theta[j], &v, &mut r);
            project_out(&u, &mut r);
            residuals.push(dot(&r, &r).sqrt());
            vectors.push(v);
        }
        largest = residuals.iter().copied().fold(0.0, f64::max);
        if let Some(index) = residuals.iter().position(|r| !r.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "eigenpair residual",
                index,
            });
        }
        if largest <= threshold {
            for v in &mut vectors {
                fix_sign(v);
            }
            return Ok(Eigenpairs {
                values: theta[..k].to_vec(),
                vectors,
                residuals,
                iterations: iteration,
            });
        }

        // Next block: the b Ritz vectors, re-orthonormalized against U and
        // each other (removes drift; a lost vector is replaced).
        x = Vec::with_capacity(b);
        for v in ritz {
            if let Some(q) = orthonormalize(v, &u, &x) {
                x.push(q);
            }
        }
        refill(&mut x, n, b, &u, &mut rng)?;
    }
    Err(LinalgError::NoConvergence {
        iterations: opts.max_iterations,
        residual: largest,
    })
}

/// `S x = T x - T U (U^T T U)^-1 U^T T x`, `T = (A + sigma I)^-1`: the
/// inverse of `P (A + sigma I) P` on the complement of `U`.
struct ShiftInvert {
    factor: SpdFactor,
    /// `T u_i`.
    tu: Vec<Vec<f64>>,
    /// `U` (orthonormal).
    u: Vec<Vec<f64>>,
    /// Cholesky factor of `U^T T U` (None when `U` is empty).
    gram: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
}

impl ShiftInvert {
    fn new(a: &Csr, norm: f64, u: &[Vec<f64>]) -> Result<Self, LinalgError> {
        let scale = if norm > 0.0 { norm } else { 1.0 };
        let sigma = RELATIVE_SHIFT * scale;
        let pattern = SpdPattern::of_symmetric(a)?;
        let mut values = pattern.values_of(a)?;
        for &s in pattern.diagonal_slots() {
            values[s] += sigma;
        }
        let (factor, _) = pattern.factorize(&values, RELATIVE_SHIFT, SHIFT_TRIES)?;
        let tu = u
            .par_iter()
            .map(|v| {
                let mut t = v.clone();
                factor.solve_in_place(&mut t).map(|()| t)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let gram = if u.is_empty() {
            None
        } else {
            let d = u.len();
            let g = DMatrix::from_fn(d, d, |i, j| 0.5 * (dot(&u[i], &tu[j]) + dot(&u[j], &tu[i])));
            // U^T (A + sigma I)^-1 U
            Some(g.cholesky().ok_or(LinalgError::NotPositiveDefinite {
                size: d,
                last_shift: 0.0,
            })?)
        };
        Ok(ShiftInvert {
            factor,
            tu,
            u: u.to_vec(),
            gram,
        })
    }

    fn apply(&self, x: &[f64]) -> Result<Vec<f64>, LinalgError> {
        let mut y = x.to_vec();
        self.factor.solve_in_place(&mut y)?;
        if let Some(gram) = &self.gram {
            let c = DVector::from_iterator(self.u.len(), self.u.iter().map(|q| dot(q, &y)));
            let z = gram.solve(&c);
            for (t, &zi) in self.tu.iter().zip(z.iter()) {
                axpy(-zi, t, &mut y);
            }
        }
        Ok(y)
    }
}

/// Fills `x` up to `b` orthonormal columns of length `n` (`⊥ U`) with
/// pseudo-random ones.
fn refill(
    x: &mut Vec<Vec<f64>>,
    n: usize,
    b: usize,
    u: &[Vec<f64>],
    rng: &mut SplitMix,
) -> Result<(), LinalgError> {
    let mut tries = 0;
    while x.len() < b {
        if tries > 10 * b + 100 {
            return Err(LinalgError::StartBlock {
                wanted: b,
                built: x.len(),
            });
        }
        tries += 1;
        let v: Vec<f64> = (0..n).map(|_| rng.uniform()).collect();
        if let Some(q) = orthonormalize(v, u, x) {
            x.push(q);
        }
    }
    Ok(())
}

/// Modified Gram–Schmidt of `v` against the orthonormal `u` and `basis`,
/// repeated while a pass removes more than half of the norm (at most three
/// passes), then normalized. `None` when `v` is not finite or numerically
/// in their span (norm below `DROP_TOLERANCE` of the original).
fn orthonormalize(mut v: Vec<f64>, u: &[Vec<f64>], basis: &[Vec<f64>]) -> Option<Vec<f64>> {
    let norm0 = dot(&v, &v).sqrt();
    if !(norm0 > 0.0 && norm0.is_finite()) {
        return None;
    }
    let mut previous = norm0;
    for _ in 0..3 {
        for q in u.iter().chain(basis) {
            let c = dot(q, &v);
            axpy(-c, q, &mut v);
        }
        let norm = dot(&v, &v).sqrt();
        if norm <= DROP_TOLERANCE * norm0 {
            return None;
        }
        let done = norm > 0.5 * previous;
        previous = norm;
        if done {
            break;
        }
    }
    v.iter_mut().for_each(|c| *c /= previous);
    Some(v)
}

/// `r <- P r = r - U U^T r` (`U` orthonormal).
fn project_out(u: &[Vec<f64>], r: &mut [f64]) {
    for q in u {
        let c = dot(q, r);
        axpy(-c, q, r);
    }
}

/// `sum_i c_i v_i`.
fn combine(vs: &[Vec<f64>], c: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; vs.first().map_or(0, Vec::len)];
    for (v, &ci) in vs.iter().zip(c) {
        axpy(ci, v, &mut out);
    }
    out
}

/// Makes the largest-magnitude component (the first one on ties) positive.
fn fix_sign(v: &mut [f64]) {
    let mut best = 0;
    for (i, c) in v.iter().enumerate() {
        if c.abs() > v[best].abs() {
            best = i;
        }
    }
    if v.get(best).is_some_and(|&c| c < 0.0) {
        v.iter_mut().for_each(|c| *c = -*c);
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `y <- y + alpha x`.
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// SplitMix64: a tiny deterministic generator for the start block.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[-1, 1)`.
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::dense;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    impl SplitMix {
        /// Uniform in `[lo, hi)`.
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * 0.5 * (self.uniform() + 1.0)
        }

        /// Uniform in `0..n`.
        fn below(&mut self, n: usize) -> usize {
            (self.next_u64() % n as u64) as usize
        }
    }

    /// The graph Laplacian `D - W` of weighted edges.
    fn laplacian(n: usize, edges: &[(u32, u32, f64)]) -> Csr {
        let mut entries = Vec::new();
        for &(i, j, w) in edges {
            entries.extend([(i, j, -w), (i, i, w), (j, j, w)]);
        }
        Csr::from_symmetric_entries(n, entries).unwrap()
    }

    /// The normalized Laplacian `I - D^-1/2 W D^-1/2` and its null vector
    /// `D^1/2 1`.
    fn normalized_laplacian(n: usize, edges: &[(u32, u32, f64)]) -> (Csr, Vec<f64>) {
        let mut d = vec![0.0; n];
        for &(i, j, w) in edges {
            d[i as usize] += w;
            d[j as usize] += w;
        }
        let s: Vec<f64> = d.iter().map(|x| x.sqrt()).collect();
        let entries = (0..n as u32).map(|i| (i, i, 1.0)).chain(
            edges
                .iter()
                .map(|&(i, j, w)| (i, j, -w / (s[i as usize] * s[j as usize]))),
        );
        (Csr::from_symmetric_entries(n, entries).unwrap(), s)
    }

    /// A random connected graph: a random spanning tree plus `extra * n`
    /// random edges, weights in `[0.1, 10)`.
    fn random_graph(n: usize, extra: usize, seed: u64) -> Vec<(u32, u32, f64)> {
        let mut rng = SplitMix(seed);
        let mut edges = Vec::new();
        for i in 1..n {
            let j = rng.below(i);
            edges.push((j as u32, i as u32, rng.range(0.1, 10.0)));
        }
        for _ in 0..extra * n {
            let (i, j) = (rng.below(n), rng.below(n));
            if i != j {
                edges.push((i as u32, j as u32, rng.range(0.1, 10.0)));
            }
        }
        edges
    }

    /// Ascending eigenvalues and the matching eigenvectors of the dense matrix.
    fn dense_eigen(a: &Csr) -> (Vec<f64>, Vec<Vec<f64>>) {
        let eig: SymmetricEigen<f64, nalgebra::Dyn> = SymmetricEigen::new(dense(a));
        let mut order: Vec<usize> = (0..a.n_rows()).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
        (
            order.iter().map(|&c| eig.eigenvalues[c]).collect(),
            order
                .iter()
                .map(|&c| eig.eigenvectors.column(c).iter().copied().collect())
                .collect(),
        )
    }

    fn unit(mut v: Vec<f64>) -> Vec<f64> {
        let nv = dot(&v, &v).sqrt();
        v.iter_mut().for_each(|c| *c /= nv);
        v
    }

    /// Unit vectors, orthogonal to each other and to `deflate`, residuals
    /// `|P (A v - lambda v)|` recomputed and within `tol * max(1, |A|_est)`, values ascending.
    fn check_invariants(a: &Csr, deflate: &[Vec<f64>], r: &Eigenpairs, tol: f64) {
        let bound = tol * a.max_row_sum().max(1.0);
        let mut u: Vec<Vec<f64>> = Vec::new();
        for d in deflate {
            u.extend(orthonormalize(d.clone(), &[], &u));
        }
        for (j, v) in r.vectors.iter().enumerate() {
            assert!((dot(v, v) - 1.0).abs() < 1e-12);
            for w in &r.vectors[..j] {
                assert!(dot(v, w).abs() < 1e-8, "vectors not orthogonal");
            }
            for d in deflate {
                assert!(dot(v, &unit(d.clone())).abs() < 1e-8, "not deflated");
            }
            let mut res = a.multiply(v);
            axpy(-r.values[j], v, &mut res);
            project_out(&u, &mut res);
            let res = dot(&res, &res).sqrt();
            assert!(res <= bound, "residual {res:e} > {bound:e}");
            assert!(r.residuals[j] <= bound);
            assert!((res - r.residuals[j]).abs() <= 1e-12 * bound.max(1.0));
            let top = v.iter().copied().fold(0.0f64, |m, c| m.max(c.abs()));
            assert!(v.contains(&top), "sign convention");
        }
        for w in r.values.windows(2) {
            assert!(w[0] <= w[1]);
        }
    }

    #[test]
    fn path_graph_matches_closed_form() {
        for n in [50usize, 117, 200] {
            let edges: Vec<_> = (1..n as u32).map(|i| (i - 1, i, 1.0)).collect();
            let a = laplacian(n, &edges);
            let deflate = vec![vec![1.0; n]];
            let opts = EigenOptions::default();
            let r = smallest_eigenpairs(&a, 3, &deflate, &opts).unwrap();
            check_invariants(&a, &deflate, &r, opts.tol);
            for (idx, j) in (1..=3).enumerate() {
                // 2 - 2 cos(pi j / n) without cancellation.
                let exact = 4.0 * (PI * j as f64 / (2.0 * n as f64)).sin().powi(2);
                assert!(
                    (r.values[idx] - exact).abs() <= 1e-8 * exact,
                    "n = {n}, j = {j}: {} vs {exact}",
                    r.values[idx]
                );
                let v = unit(
                    (0..n)
                        .map(|i| (PI * j as f64 * (i as f64 + 0.5) / n as f64).cos())
                        .collect(),
                );
                assert!(dot(&v, &r.vectors[idx]).abs() > 1.0 - 1e-10);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn matches_dense_eigendecomposition(n in 20usize..120, extra in 0usize..4, seed in any::<u64>()) {
            let a = laplacian(n, &random_graph(n, extra, seed));
            let deflate = vec![vec![1.0; n]];
            let opts = EigenOptions::default();
            let r = smallest_eigenpairs(&a, 3, &deflate, &opts).unwrap();
            check_invariants(&a, &deflate, &r, opts.tol);
            let (values, vectors) = dense_eigen(&a);
            let top = values[n - 1];
            for j in 0..3 {
                let l = values[j + 1];
                prop_assert!((r.values[j] - l).abs() <= 1e-7 * top, "{} vs {}", r.values[j], l);
                let gap = (l - values[j]).min(values[j + 2] - l);
                if gap >= 1e-6 {
                    // Davis–Kahan: sin(angle) <= residual / gap.
                    let bound = (2.0 * r.residuals[j] / gap).powi(2);
                    prop_assert!(dot(&vectors[j + 1], &r.vectors[j]).abs() > 1.0 - bound.max(1e-6));
                }
            }
        }
    }

    #[test]
    fn normalized_laplacian_fiedler_value_matches_dense() {
        for (n, extra, seed) in [(40usize, 1usize, 1u64), (97, 2, 2), (150, 3, 3), (64, 0, 4)] {
            let (a, s) = normalized_laplacian(n, &random_graph(n, extra, seed));
            let deflate = vec![s];
            let opts = EigenOptions::default();
            let r = smallest_eigenpairs(&a, 1, &deflate, &opts).unwrap();
            check_invariants(&a, &deflate, &r, opts.tol);
            let (values, _) = dense_eigen(&a);
            assert!(values[0].abs() < 1e-12);
            assert!(
                (r.values[0] - values[1]).abs() <= 1e-9,
                "{} vs {}",
                r.values[0],
                values[1]
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn fiedler_vector_splits_weakly_joined_clusters(
            n1 in 20usize..60, n2 in 20usize..60, bridges in 1usize..4, seed in any::<u64>(),
        ) {
            let n = n1 + n2;
            let mut rng = SplitMix(seed);
            let mut edges = Vec::new();
            for (lo, hi) in [(0, n1), (n1, n)] {
                for i in lo..hi {
                    for j in i + 1..hi {
                        // A path keeps each cluster connected.
                        if j == i + 1 || rng.uniform() < -0.4 {
                            edges.push((i as u32, j as u32, rng.range(0.5, 1.5)));
                        }
                    }
                }
            }
            for _ in 0..bridges {
                let (i, j) = (rng.below(n1), n1 + rng.below(n2));
                edges.push((i as u32, j as u32, 1e-3));
            }
            let (a, s) = normalized_laplacian(n, &edges);
            let deflate = vec![s];
            let opts = EigenOptions::default();
            let r = smallest_eigenpairs(&a, 1, &deflate, &opts).unwrap();
            check_invariants(&a, &deflate, &r, opts.tol);
            let f = &r.vectors[0];
            let first = f[0] > 0.0;
            prop_assert!(f[..n1].iter().all(|&c| (c > 0.0) == first));
            prop_assert!(f[n1..].iter().all(|&c| c != 0.0 && (c > 0.0) != first));
        }
    }

    #[test]
    fn ring_with_three_ring_neighbourhoods_has_double_eigenvalues() {
        // The boundary-loop use case: a cycle whose vertices are joined to
        // their 3-ring. Circulant, so with `W/6` the normalized adjacency,
        // lambda_j = 1 - (1/3) sum_{m=1..3} cos(2 pi j m / n), with the
        // eigenspace of lambda_j = lambda_{n-j} spanned by cos and sin of
        // 2 pi j i / n.
        let n = 2000;
        let mut edges = Vec::new();
        for i in 0..n {
            for m in 1..=3 {
                edges.push((i as u32, ((i + m) % n) as u32, 1.0));
            }
        }
        let (a, s) = normalized_laplacian(n, &edges);
        let deflate = vec![s];
        let opts = EigenOptions::default();
        let r = smallest_eigenpairs(&a, 4, &deflate, &opts).unwrap();
        check_invariants(&a, &deflate, &r, opts.tol);
        for (pair, j) in [(0usize, 1.0f64), (2, 2.0)] {
            let t = 2.0 * PI * j / n as f64;
            // 1 - cos(x) = 2 sin^2(x / 2), without cancellation.
            let exact = (1..=3)
                .map(|m| 2.0 * (0.5 * t * m as f64).sin().powi(2))
                .sum::<f64>()
                / 3.0;
            for value in &r.values[pair..pair + 2] {
                assert!((value - exact).abs() <= 1e-8 * exact, "{value} vs {exact}");
            }
            for f in [f64::cos, f64::sin] {
                let w = unit((0..n).map(|i| f(t * i as f64)).collect());
                let inside: f64 = r.vectors[pair..pair + 2]
                    .iter()
                    .map(|v| dot(v, &w).powi(2))
                    .sum();
                assert!(inside > 1.0 - 1e-10, "{inside}");
            }
        }
    }

    #[test]
    fn scales_to_a_10k_grid() {
        let side = 100u32;
        let id = |x: u32, y: u32| y * side + x;
        let mut edges = Vec::new();
        for y in 0..side {
            for x in 0..side {
                if x + 1 < side {
                    edges.push((id(x, y), id(x + 1, y), 1.0));
                }
                if y + 1 < side {
                    edges.push((id(x, y), id(x, y + 1), 1.0));
                    if x + 1 < side {
                        edges.push((id(x, y), id(x + 1, y + 1), 1.0));
                    }
                    if x > 0 {
                        edges.push((id(x, y), id(x - 1, y + 1), 1.0));
                    }
                }
            }
        }
        let n = (side * side) as usize;
        let (a, s) = normalized_laplacian(n, &edges);
        let deflate = vec![s];
        let opts = EigenOptions::default();
        let r = smallest_eigenpairs(&a, 1, &deflate, &opts).unwrap();
        check_invariants(&a, &deflate, &r, opts.tol);
        assert!(r.residuals[0] <= opts.tol * 2.0);
        assert!(r.values[0] > 0.0 && r.values[0] < 1e-2);
    }

    #[test]
    fn deflates_a_non_invariant_subspace() {
        // P A P on the complement of two arbitrary (non-orthogonal,
        // non-invariant) vectors, against the dense restriction Q^T A Q.
        let n = 60;
        let a = laplacian(n, &random_graph(n, 2, 7));
        let mut rng = SplitMix(99);
        let d1: Vec<f64> = (0..n).map(|_| rng.uniform()).collect();
        let d2: Vec<f64> = d1.iter().map(|c| c + 0.3 * rng.uniform()).collect();
        let deflate = vec![d1, d2, vec![0.0; n]];
        let r = smallest_eigenpairs(&a, 3, &deflate, &EigenOptions::default()).unwrap();
        check_invariants(&a, &deflate[..2], &r, 1e-8);
        // Orthonormal basis of the complement: eigenvectors of P with eigenvalue 1.
        let u = DMatrix::from_fn(n, 2, |i, j| deflate[j][i]).qr().q();
        let p = DMatrix::identity(n, n) - &u * u.transpose();
        let pe = SymmetricEigen::new(p);
        let cols: Vec<usize> = (0..n).filter(|&c| pe.eigenvalues[c] > 0.5).collect();
        assert_eq!(cols.len(), n - 2);
        let q = pe.eigenvectors.select_columns(&cols);
        let mut values: Vec<f64> = SymmetricEigen::new(q.transpose() * dense(&a) * &q)
            .eigenvalues
            .iter()
            .copied()
            .collect();
        values.sort_by(f64::total_cmp);
        for j in 0..3 {
            assert!((r.values[j] - values[j]).abs() < 1e-9 * values[n - 3]);
        }
    }

    #[test]
    fn is_reproducible_and_handles_small_problems() {
        let n = 30;
        let a = laplacian(n, &random_graph(n, 1, 11));
        let ones = vec![vec![1.0; n]];
        let opts = EigenOptions::default();
        let r1 = smallest_eigenpairs(&a, 2, &ones, &opts).unwrap();
        let r2 = smallest_eigenpairs(&a, 2, &ones, &opts).unwrap();
        assert_eq!(r1, r2);
        // The block is the whole complement: exact in one iteration.
        let r = smallest_eigenpairs(&a, n - 1, &ones, &opts).unwrap();
        assert_eq!(r.iterations, 1);
        check_invariants(&a, &ones, &r, opts.tol);
        let (values, _) = dense_eigen(&a);
        for j in 0..n - 1 {
            assert!((r.values[j] - values[j + 1]).abs() < 1e-9 * values[n - 1]);
        }
        // Without deflation the null vector comes first.
        let r = smallest_eigenpairs(&a, 1, &[], &opts).unwrap();
        assert!(r.values[0].abs() < 1e-9);
        let c = 1.0 / (n as f64).sqrt();
        assert!(r.vectors[0].iter().all(|&x| (x - c).abs() < 1e-6));
        // A 1 x 1 matrix.
        let one = Csr::from_symmetric_entries(1, [(0, 0, 3.0)]).unwrap();
        let r = smallest_eigenpairs(&one, 1, &[], &opts).unwrap();
        assert_eq!((r.values[0], r.vectors[0][0]), (3.0, 1.0));
    }

    #[test]
    fn reports_errors() {
        let n = 10;
        let a = laplacian(n, &random_graph(n, 1, 5));
        let ones = vec![vec![1.0; n]];
        let opts = EigenOptions::default();
        let count = |r: Result<Eigenpairs, LinalgError>| match r {
            Err(LinalgError::EigenpairCount {
                wanted,
                deflated,
                size,
            }) => (wanted, deflated, size),
            other => panic!("expected EigenpairCount, got {other:?}"),
        };
        assert_eq!(count(smallest_eigenpairs(&a, 0, &ones, &opts)), (0, 1, 10));
        assert_eq!(
            count(smallest_eigenpairs(&a, 10, &ones, &opts)),
            (10, 1, 10)
        );
        assert_eq!(
            count(smallest_eigenpairs(&a, 1, &vec![vec![1.0; n]; 10], &opts)),
            (1, 10, 10)
        );
        let empty = Csr::from_symmetric_entries(0, []).unwrap();
        assert_eq!(count(smallest_eigenpairs(&empty, 1, &[], &opts)), (1, 0, 0));
        for tol in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                smallest_eigenpairs(&a, 1, &ones, &EigenOptions { tol, ..opts }),
                Err(LinalgError::InvalidTolerance { .. })
            ));
        }
        assert!(matches!(
            smallest_eigenpairs(&a, 1, &[vec![1.0; n - 1]], &opts),
            Err(LinalgError::DimensionMismatch {
                expected: 10,
                found: 9,
                ..
            })
        ));
        let mut nan = ones.clone();
        nan[0][3] = f64::NAN;
        assert!(matches!(
            smallest_eigenpairs(&a, 1, &nan, &opts),
            Err(LinalgError::NotFinite { index: 0, .. })
        ));
        // A non-finite matrix value (only the unchecked mesh-operator
        // constructor lets one in).
        let bad = Csr::symmetric(
            n,
            a.upper_triangle()
                .enumerate()
                .map(|(k, (i, j, v))| (i, j, if k == 2 { f64::INFINITY } else { v })),
        );
        assert!(matches!(
            smallest_eigenpairs(&bad, 1, &ones, &opts),
            Err(LinalgError::NotFinite { .. })
        ));
        // An entry outside the matrix is refused when the matrix is built.
        let entries: Vec<(u32, u32, f64)> = a.upper_triangle().chain([(3, 10, 1.0)]).collect();
        assert!(matches!(
            Csr::from_symmetric_entries(n, entries),
            Err(LinalgError::EntryOutOfRange {
                row: 3,
                col: 10,
                ..
            })
        ));
        // Not symmetric (the upper triangle only), or not square.
        let upper: Vec<(u32, u32, f64)> = a.upper_triangle().collect();
        let half = Csr::from_triplets(n, n, &upper).unwrap();
        assert!(matches!(
            smallest_eigenpairs(&half, 1, &ones, &opts),
            Err(LinalgError::NotSymmetric { .. })
        ));
        let rect = Csr::from_triplets(n, n + 1, &[]).unwrap();
        assert!(matches!(
            smallest_eigenpairs(&rect, 1, &ones, &opts),
            Err(LinalgError::NotSquare { rows: 10, cols: 11 })
        ));
        // Not converged: a tolerance below rounding, or no iterations.
        let big = laplacian(200, &random_graph(200, 2, 6));
        let tight = EigenOptions {
            tol: 1e-300,
            max_iterations: 3,
            ..opts
        };
        match smallest_eigenpairs(&big, 2, &[vec![1.0; 200]], &tight) {
            Err(LinalgError::NoConvergence {
                iterations: 3,
                residual,
            }) => assert!(residual > 0.0 && residual.is_finite(), "{residual}"),
            other => panic!("{other:?}"),
        }
        let none = EigenOptions {
            max_iterations: 0,
            ..opts
        };
        assert!(matches!(
            smallest_eigenpairs(&a, 1, &ones, &none),
            Err(LinalgError::NoConvergence { iterations: 0, .. })
        ));
    }
}
