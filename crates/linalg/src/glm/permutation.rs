//! Max-statistic permutation inference with Freedman-Lane relabeling
//! (ALGORITHMS 5.3).
//!
//! For each relabeling `P` (the identity first): `y* = P e + H_Z y` with
//! `e = (I - H_Z) y`, and the statistic of every column of `y*` under the
//! full model (see [`fit`](super::fit)). With `s_j` the observed statistic
//! of column `j`, `s*_j` its value under a relabeling and `P` relabelings:
//!
//! - `p_uncorrected(j) = #{relabelings: |s*_j| >= |s_j|} / P`
//!   (F is never negative, so the absolute value changes nothing there);
//! - `max_null[k] = max_j |s*_j|` under relabeling `k`;
//! - `p_fwe(j) = #{k: max_null[k] >= |s_j|} / P`, the family-wise
//!   corrected p of Westfall & Young's single-step max-T (Nichols & Holmes,
//!   Human Brain Mapping 2002).
//!
//! A comparison `a >= b` counts `a >= b (1 - 1e-10)`, so relabelings whose
//! statistic equals the observed one mathematically (the identity,
//! exchanges of equal values) count whatever the rounding.
//!
//! Speed and memory: `Q'(P e) = (P'Q)' e`, so a relabeling permutes the
//! rows of the small `n x p` basis instead of the data; a batch of
//! relabelings becomes one `(batch p) x n` matrix multiplied by a chunk of
//! residual columns (faer). Columns are processed in chunks in parallel
//! (rayon), each chunk running every relabeling; memory holds `y`, one
//! residual chunk and its products per thread, one counter per column and
//! the `P` maxima, never `P x columns`.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;
use serde::Serialize;

use super::design::{Design, StatisticKind};
use super::error::GlmError;
use super::fit::{nuisance_residuals, statistic};
use super::shuffles::Shuffles;

/// How many relabelings to run and the seed of the random ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PermutationSettings {
    /// Relabelings to run, the identity included (1000 by default). When
    /// the distinct relabelings are no more than this, all of them are run
    /// instead (exhaustive).
    pub permutations: usize,
    /// Seed of the random relabelings (0 by default): the result is the
    /// same for a seed whatever the thread count.
    pub seed: u64,
}

impl Default for PermutationSettings {
    fn default() -> Self {
        PermutationSettings {
            permutations: 1000,
            seed: 0,
        }
    }
}

/// The statistics and p-values of every tested column.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestResult {
    /// t or F.
    pub kind: StatisticKind,
    /// Per column of `y`: t (signed) or F.
    pub statistic: Vec<f64>,
    /// Per column: the two-sided permutation p.
    pub p_uncorrected: Vec<f64>,
    /// Per column: the two-sided family-wise corrected p from the
    /// distribution of the maximum statistic.
    pub p_fwe: Vec<f64>,
    /// The maximum `|t|` (or F) over the columns under each relabeling,
    /// the identity first.
    pub max_null: Vec<f64>,
    /// Relabelings run, the identity included.
    pub permutations: usize,
    /// Whether every distinct relabeling was enumerated.
    pub exhaustive: bool,
    /// `(k, n - p)`, as [`Design::degrees_of_freedom`].
    pub degrees_of_freedom: (f64, f64),
}

/// The most relabelings one test runs (80 MB of maxima per thread).
pub const MAX_PERMUTATIONS: usize = 10_000_000;
/// Relative tolerance of the `>=` counts.
const TIE: f64 = 1e-10;
/// Columns per parallel chunk.
const COLUMN_CHUNK: usize = 256;
/// Relabelings per matrix product.
const BATCH: usize = 32;

/// Tests every column of `y` against `design` by Freedman-Lane permutation
/// with the max-statistic family-wise correction (ALGORITHMS 5.3).
///
/// `y`: subjects x columns, column-major: column `j` (a voxel or a segment)
/// is `y[j*n .. (j+1)*n]`, `n = design.subjects()`. Every value must be
/// finite (the caller selects the covered columns).
///
/// Errors: zero permutations, more than [`MAX_PERMUTATIONS`], `y`'s length not a multiple of `n`, an empty
/// `y`, a non-finite value (its column and subject).
pub fn permutation_test(
    design: &Design,
    y: &[f64],
    settings: &PermutationSettings,
) -> Result<TestResult, GlmError> {
    if settings.permutations == 0 {
        return Err(GlmError::ZeroPermutations);
    }
    if settings.permutations > MAX_PERMUTATIONS {
        return Err(GlmError::TooManyPermutations {
            asked: settings.permutations,
            max: MAX_PERMUTATIONS,
        });
    }
    let n = design.subjects();
    if !y.len().is_multiple_of(n) {
        return Err(GlmError::LengthNotMultiple {
            len: y.len(),
            subjects: n,
        });
    }
    if y.is_empty() {
        return Err(GlmError::NoColumns);
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(GlmError::NonFiniteValue {
            column: i / n,
            subject: i % n,
        });
    }
    let shuffles = Shuffles::plan(
        n,
        design.relabeling_only(),
        settings.permutations,
        settings.seed,
    );
    Ok(run(design, y, &shuffles))
}

/// The test under the given relabelings (validated input).
pub(crate) fn run(design: &Design, y: &[f64], shuffles: &Shuffles) -> TestResult {
    let n = design.subjects();
    let columns = y.len() / n;
    let perms = shuffles.len();
    let mut statistic = vec![0.0; columns];
    let mut counts = vec![0usize; columns];
    let max_null = y
        .par_chunks(n * COLUMN_CHUNK)
        .zip(statistic.par_chunks_mut(COLUMN_CHUNK))
        .zip(counts.par_chunks_mut(COLUMN_CHUNK))
        .fold(
            || vec![0.0f64; perms],
            |mut maxes, ((yc, sc), cc)| {
                chunk_pass(design, shuffles, yc, sc, cc, &mut maxes);
                maxes
            },
        )
        .reduce(
            || vec![0.0f64; perms],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x = x.max(*y);
                }
                a
            },
        );
    let total = perms as f64;
    let p_uncorrected = counts.iter().map(|&c| c as f64 / total).collect();
    let mut sorted = max_null.clone();
    sorted.sort_unstable_by(f64::total_cmp);
    let p_fwe = statistic
        .iter()
        .map(|s: &f64| {
            let threshold = s.abs() * (1.0 - TIE);
            let below = sorted.partition_point(|&m| m < threshold);
            (perms - below) as f64 / total
        })
        .collect();
    TestResult {
        kind: design.kind(),
        statistic,
        p_uncorrected,
        p_fwe,
        max_null,
        permutations: perms,
        exhaustive: shuffles.exhaustive(),
        degrees_of_freedom: design.degrees_of_freedom(),
    }
}

/// Runs every relabeling on one chunk of columns: writes the observed
/// statistics and the `>=` counts, and raises the per-relabeling maxima.
fn chunk_pass(
    design: &Design,
    shuffles: &Shuffles,
    y: &[f64],
    observed: &mut [f64],
    counts: &mut [usize],
    maxes: &mut [f64],
) {
    let n = design.subjects();
    let q = design.nuisance_columns();
    let p = q + design.interest_columns();
    let df = design.degrees_of_freedom().1;
    let kind = design.kind();
    let basis = design.basis();
    let cols = y.len() / n;
    let perms = shuffles.len();

    let mut e = vec![0.0; y.len()];
    let mut ee = vec![0.0; cols];
    nuisance_residuals(basis, n, q, y, &mut e, &mut ee);
    let residuals = MatRef::from_column_major_slice(&e, n, cols);

    let batch = BATCH.min(perms);
    let mut lhs = vec![0.0; batch * p * n];
    let mut out = vec![0.0; batch * p * cols];
    let mut src = vec![0u32; n];
    let mut threshold = vec![0.0; cols];
    for start in (0..perms).step_by(batch) {
        let count = batch.min(perms - start);
        let rows = count * p;
        for b in 0..count {
            shuffles.fill(start + b, &mut src);
            for (j, &s) in src.iter().enumerate() {
                let row = &mut lhs[j * rows + b * p..j * rows + (b + 1) * p];
                for (r, v) in row.iter_mut().enumerate() {
                    *v = basis[r * n + s as usize];
                }
            }
        }
        let l = MatRef::from_column_major_slice(&lhs[..rows * n], rows, n);
        let o = MatMut::from_column_major_slice_mut(&mut out[..rows * cols], rows, cols);
        matmul(o, Accum::Replace, l, residuals, 1.0, Par::Seq);
        for c in 0..cols {
            let column = &out[c * rows..(c + 1) * rows];
            for (b, a) in column.chunks_exact(p).enumerate() {
                let s = statistic(kind, a, q, ee[c], df);
                let k = start + b;
                let m = s.abs();
                if k == 0 {
                    observed[c] = s;
                    threshold[c] = m * (1.0 - TIE);
                }
                if m >= threshold[c] {
                    counts[c] += 1;
                }
                if m > maxes[k] {
                    maxes[k] = m;
                }
            }
        }
    }
}
