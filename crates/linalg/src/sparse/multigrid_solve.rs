//! The iterative backend of [`super::SpdPattern`]: conjugate gradients
//! preconditioned by a multigrid V-cycle whose coarse levels come from a
//! background grid over the vertices ([`crate::multigrid::point_hierarchy`]),
//! for mesh matrices too large to factorize (docs/DESIGN-NOTES.md,
//! "Newton's linear algebra").
//!
//! The values stay in the pattern's slots (the lower triangle, vertices in
//! their own order); a "factorization" copies them into a matrix storing
//! both triangles (the smoother reads whole rows), adds the shift to its
//! diagonal and builds the Galerkin hierarchy `A_{l+1} = P_l^T A_l P_l`
//! (the prolongations depend on the vertex positions only, so they are
//! built once with the plan). A solve runs [`crate::multigrid::pcg`] from
//! zero to the plan's relative tolerance.

use crate::multigrid::{Multigrid, PcgReport, pcg, point_hierarchy};
use crate::{Csr, LinalgError};
use faer::sparse::SymbolicSparseColMat;

/// How the multigrid backend is set up and when its solves stop.
#[derive(Debug, Clone, PartialEq)]
pub struct MultigridSettings {
    /// Vertex positions (one per vertex of the graph): where the background
    /// grid interpolates from.
    pub points: Vec<[f64; 3]>,
    /// The background grid's spacing (the first coarse level).
    pub spacing: f64,
    /// Levels are added while one has more unknowns than this; the
    /// coarsest is solved densely.
    pub coarsest: usize,
    /// A solve stops at `|b - A x| <= rel_tol |b|`.
    pub rel_tol: f64,
    /// Conjugate-gradient iterations a solve may take before it fails.
    pub max_iterations: usize,
}

impl MultigridSettings {
    /// Settings with the defaults [`MULTIGRID_COARSEST`],
    /// [`MULTIGRID_REL_TOL`] and [`MULTIGRID_MAX_ITERATIONS`].
    pub fn new(points: Vec<[f64; 3]>, spacing: f64) -> Self {
        MultigridSettings {
            points,
            spacing,
            coarsest: MULTIGRID_COARSEST,
            rel_tol: MULTIGRID_REL_TOL,
            max_iterations: MULTIGRID_MAX_ITERATIONS,
        }
    }
}

/// Default coarsest level: at most this many unknowns, solved densely.
pub const MULTIGRID_COARSEST: usize = 1500;

/// Default relative residual of a solve.
pub const MULTIGRID_REL_TOL: f64 = 1e-8;

/// Default iteration limit of a solve (mesh-independent counts of 10-20
/// are usual; the limit only bounds a failing solve).
pub const MULTIGRID_MAX_ITERATIONS: usize = 500;

/// The fixed part of the backend: the rows of the symmetric matrix with
/// each entry's value slot, and the prolongations.
#[derive(Debug)]
pub(super) struct MultigridPlan {
    n: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    /// Value slot (in the pattern's lower triangle) of each entry of `col`.
    slot: Vec<u32>,
    prolongations: Vec<Csr>,
    coarsest: usize,
    rel_tol: f64,
    max_iterations: usize,
}

/// Sizes of a multigrid plan, for memory estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MultigridSizes {
    /// Unknowns.
    pub n: usize,
    /// Entries of the matrix with both triangles stored.
    pub full_nnz: usize,
    /// Entries of all prolongations.
    pub prolongation_nnz: usize,
    /// Unknowns of the first coarse level (0 without one).
    pub first_coarse: usize,
}

impl MultigridPlan {
    /// The plan for the symmetric matrix whose lower triangle (natural
    /// order, compressed columns, rows sorted, the diagonal first) is
    /// `lower`, with `block` unknowns per point.
    pub(super) fn new(
        lower: &SymbolicSparseColMat<usize>,
        block: usize,
        settings: &MultigridSettings,
    ) -> Result<Self, LinalgError> {
        let n = lower.nrows();
        let nv = n / block.max(1);
        if settings.points.len() != nv {
            return Err(LinalgError::DimensionMismatch {
                what: "multigrid: vertex positions (one per vertex)",
                expected: nv,
                found: settings.points.len(),
            });
        }
        if !(settings.spacing > 0.0 && settings.spacing.is_finite()) {
            return Err(LinalgError::InvalidSpacing {
                spacing: settings.spacing,
            });
        }
        if !(settings.rel_tol > 0.0 && settings.rel_tol.is_finite()) {
            return Err(LinalgError::InvalidTolerance {
                what: "multigrid: the relative tolerance",
                value: settings.rel_tol,
            });
        }
        let (ptr, rows) = (lower.col_ptr(), lower.row_idx());
        if rows.len() > u32::MAX as usize || n > u32::MAX as usize {
            return Err(LinalgError::TooLarge { rows: n, cols: n });
        }
        // Both triangles by rows: entry (r, c), r >= c, at slot s is row r's
        // (c, s) and, off the diagonal, row c's (r, s). Filled column by
        // column, each row comes out sorted: row i receives the columns
        // c < i first (ascending c), then at column i its rows r >= i.
        let mut row_ptr = vec![0usize; n + 1];
        for c in 0..n {
            for &r in &rows[ptr[c]..ptr[c + 1]] {
                row_ptr[r + 1] += 1;
                if r != c {
                    row_ptr[c + 1] += 1;
                }
            }
        }
        for i in 0..n {
            row_ptr[i + 1] += row_ptr[i];
        }
        let mut next = row_ptr.clone();
        let mut col = vec![0u32; row_ptr[n]];
        let mut slot = vec![0u32; row_ptr[n]];
        for c in 0..n {
            for (s, &r) in rows.iter().enumerate().take(ptr[c + 1]).skip(ptr[c]) {
                col[next[r]] = c as u32;
                slot[next[r]] = s as u32;
                next[r] += 1;
                if r != c {
                    col[next[c]] = r as u32;
                    slot[next[c]] = s as u32;
                    next[c] += 1;
                }
            }
        }
        let prolongations = if n > settings.coarsest {
            point_hierarchy(&settings.points, block, settings.spacing, settings.coarsest)?
        } else {
            Vec::new()
        };
        Ok(MultigridPlan {
            n,
            row_ptr,
            col,
            slot,
            prolongations,
            coarsest: settings.coarsest,
            rel_tol: settings.rel_tol,
            max_iterations: settings.max_iterations,
        })
    }

    pub(super) fn sizes(&self) -> MultigridSizes {
        MultigridSizes {
            n: self.n,
            full_nnz: self.col.len(),
            prolongation_nnz: self.prolongations.iter().map(Csr::nnz).sum(),
            first_coarse: self.prolongations.first().map_or(0, Csr::n_cols),
        }
    }

    /// The hierarchy of the matrix with these slot values and `shift` added
    /// to its diagonal.
    ///
    /// # Errors
    /// Those of [`Multigrid::with_coarsest`]: a level that is not positive
    /// definite shows as [`LinalgError::NonPositiveDiagonal`],
    /// [`LinalgError::NegativePivot`] or [`LinalgError::NullDirection`].
    pub(super) fn setup(&self, values: &[f64], shift: f64) -> Result<Multigrid, LinalgError> {
        let mut val: Vec<f64> = self.slot.iter().map(|&s| values[s as usize]).collect();
        if shift != 0.0 {
            for i in 0..self.n {
                let (start, end) = (self.row_ptr[i], self.row_ptr[i + 1]);
                if let Ok(k) = self.col[start..end].binary_search(&(i as u32)) {
                    val[start + k] += shift;
                }
            }
        }
        let a = Csr::from_sorted_parts(self.n, self.n, self.row_ptr.clone(), self.col.clone(), val);
        Multigrid::with_coarsest(a, self.prolongations.clone(), self.coarsest)
    }

    /// `x = A^-1 b` in place by conjugate gradients from zero, preconditioned
    /// by `mg` (built by [`MultigridPlan::setup`]; a hierarchy of one dense
    /// level solves exactly).
    ///
    /// # Errors
    /// Those of [`pcg`]: [`LinalgError::NoConvergence`],
    /// [`LinalgError::Breakdown`] (not positive definite).
    pub(super) fn solve(&self, mg: &Multigrid, b: &mut [f64]) -> Result<PcgReport, LinalgError> {
        let Some(a) = mg.matrix() else {
            let rhs = b.to_vec();
            mg.apply(&rhs, b);
            return Ok(PcgReport {
                iterations: 1,
                relative_residual: 0.0,
            });
        };
        let mut x = vec![0.0; self.n];
        let report = pcg(a, b, &mut x, mg, self.rel_tol, self.max_iterations)?;
        b.copy_from_slice(&x);
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::{SpdPattern, VertexSolver};
    use crate::test_support::Rng;
    use proptest::prelude::*;

    /// A jittered `s x s x t` grid of points, its 27-point vertex graph
    /// (upper triangle, diagonal last) and the values of an SPD matrix with
    /// 3x3 blocks in a pattern's slots: per edge `-w (I + 0.1 J)` (J the
    /// ones), per vertex the negated sum of its edges' blocks plus `eps I`.
    struct Problem {
        points: Vec<[f64; 3]>,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        edges: Vec<(usize, usize, f64)>,
        eps: f64,
    }

    impl Problem {
        fn new(s: usize, t: usize, eps: f64, rng: &mut Rng) -> Problem {
            let id = |i: usize, j: usize, k: usize| i + s * (j + s * k);
            let mut points = Vec::new();
            for k in 0..t {
                for j in 0..s {
                    for i in 0..s {
                        points.push([
                            i as f64 + 0.2 * rng.sym(1.0),
                            j as f64 + 0.2 * rng.sym(1.0),
                            k as f64 + 0.2 * rng.sym(1.0),
                        ]);
                    }
                }
            }
            let n = points.len();
            let mut cols: Vec<Vec<usize>> = (0..n).map(|b| vec![b]).collect();
            let mut edges = Vec::new();
            for k in 0..t {
                for j in 0..s {
                    for i in 0..s {
                        for (di, dj, dk) in [
                            (1, 0, 0),
                            (0, 1, 0),
                            (0, 0, 1),
                            (1, 1, 0),
                            (0, 1, 1),
                            (1, 1, 1),
                        ] {
                            if i + di < s && j + dj < s && k + dk < t {
                                let (a, b) = (id(i, j, k), id(i + di, j + dj, k + dk));
                                cols[b].push(a);
                                edges.push((a, b, 0.5 + rng.f64()));
                            }
                        }
                    }
                }
            }
            let mut col_ptr = vec![0];
            let mut row_idx = Vec::new();
            for c in &mut cols {
                c.sort_unstable();
                row_idx.extend_from_slice(c);
                col_ptr.push(row_idx.len());
            }
            Problem {
                points,
                col_ptr,
                row_idx,
                edges,
                eps,
            }
        }

        fn pattern(&self, solver: VertexSolver) -> SpdPattern {
            let n = self.points.len();
            SpdPattern::from_vertex_graph_with(
                n,
                3,
                self.col_ptr.clone(),
                self.row_idx.clone(),
                solver,
            )
            .unwrap()
        }

        fn values(&self, p: &SpdPattern) -> Vec<f64> {
            let mut v = vec![0.0; p.nnz()];
            let entry = |a: usize, b: usize| {
                let (lo, hi) = (self.col_ptr[b], self.col_ptr[b + 1]);
                lo + self.row_idx[lo..hi].binary_search(&a).unwrap()
            };
            for &(a, b, w) in &self.edges {
                for i in 0..3 {
                    for j in 0..3 {
                        let c = w * (if i == j { 1.0 } else { 0.0 } + 0.1);
                        v[p.block_slot(entry(a, b), i, j).unwrap()] -= c;
                        for x in [a, b] {
                            if i <= j {
                                v[p.block_slot(entry(x, x), i, j).unwrap()] += c;
                            }
                        }
                    }
                }
            }
            for x in 0..self.points.len() {
                for i in 0..3 {
                    v[p.block_slot(entry(x, x), i, i).unwrap()] += self.eps;
                }
            }
            v
        }
    }

    fn settings(points: &[[f64; 3]], coarsest: usize) -> MultigridSettings {
        MultigridSettings {
            coarsest,
            rel_tol: 1e-10,
            ..MultigridSettings::new(points.to_vec(), 1.7)
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// The multigrid backend solves the systems the Cholesky backend
        /// solves (several levels, or only the dense one), to its
        /// tolerance, in a few tens of iterations.
        #[test]
        fn multigrid_solves_like_cholesky(
            seed in any::<u64>(),
            s in 3usize..9,
            t in 2usize..5,
            coarsest in prop::sample::select(vec![12usize, 60, 5000]),
        ) {
            let mut rng = Rng(seed);
            let prob = Problem::new(s, t, 1e-3, &mut rng);
            let mg = prob.pattern(VertexSolver::Multigrid(settings(&prob.points, coarsest)));
            let ch = prob.pattern(VertexSolver::CholeskyNestedDissection);
            let sizes = mg.multigrid_sizes().unwrap();
            prop_assert_eq!(sizes.n, 3 * s * s * t);
            prop_assert_eq!(mg.factor_nnz(), 0);
            prop_assert!(ch.multigrid_sizes().is_none());
            let (vm, vc) = (prob.values(&mg), prob.values(&ch));
            let (fm, shift) = mg.factorize(&vm, 1e-12, 4).unwrap();
            prop_assert_eq!(shift, 0.0);
            let (fc, _) = ch.factorize(&vc, 0.0, 0).unwrap();
            let b: Vec<f64> = (0..sizes.n).map(|_| rng.sym(1.0)).collect();
            let (mut xm, mut xc) = (b.clone(), b.clone());
            let report = fm.solve_reporting(&mut xm).unwrap().unwrap();
            prop_assert!(report.relative_residual <= 1e-10);
            prop_assert!(report.iterations <= 60, "{} iterations", report.iterations);
            prop_assert!(fc.solve_reporting(&mut xc).unwrap().is_none());
            let scale = xc.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (a, c) in xm.iter().zip(&xc) {
                prop_assert!((a - c).abs() <= 1e-6 * scale, "{} vs {}", a, c);
            }
        }
    }

    #[test]
    fn an_indefinite_matrix_is_shifted_or_refused() {
        let prob = Problem::new(6, 3, -0.5, &mut Rng(3));
        let p = prob.pattern(VertexSolver::Multigrid(settings(&prob.points, 30)));
        let v = prob.values(&p);
        assert!(matches!(
            p.factorize(&v, 0.0, 0),
            Err(LinalgError::NotPositiveDefinite { size: 324, .. })
        ));
        // The shift grows tenfold until the hierarchy builds (the matrix
        // is then positive definite: its smallest eigenvalue is -0.5).
        let (f, shift) = p.factorize(&v, 1e-6, 12).unwrap();
        assert!(shift > 0.5, "{shift}");
        let mut x = vec![1.0; 324];
        f.solve_in_place(&mut x).unwrap();
        // A factor of another backend is refused.
        let ch = prob.pattern(VertexSolver::CholeskyAmd);
        let mut g = ch.new_factor();
        assert_eq!(
            p.refactorize(&mut g, &v, 0.0, 0),
            Err(LinalgError::ForeignFactor)
        );
        assert_eq!(
            p.new_factor().solve_in_place(&mut x),
            Err(LinalgError::NotFactorized)
        );
    }

    #[test]
    fn bad_settings_are_refused() {
        let prob = Problem::new(3, 2, 1.0, &mut Rng(1));
        let n = prob.points.len();
        let build = |settings: MultigridSettings| {
            SpdPattern::from_vertex_graph_with(
                n,
                3,
                prob.col_ptr.clone(),
                prob.row_idx.clone(),
                VertexSolver::Multigrid(settings),
            )
            .unwrap_err()
        };
        let e = build(MultigridSettings::new(prob.points[1..].to_vec(), 1.0));
        assert_eq!(
            e,
            LinalgError::DimensionMismatch {
                what: "multigrid: vertex positions (one per vertex)",
                expected: 18,
                found: 17
            }
        );
        let e = build(MultigridSettings {
            rel_tol: 0.0,
            ..settings(&prob.points, 10)
        });
        assert!(matches!(e, LinalgError::InvalidTolerance { .. }), "{e:?}");
        let e = build(MultigridSettings::new(prob.points.clone(), -1.0));
        assert_eq!(e, LinalgError::InvalidSpacing { spacing: -1.0 });
    }
}
