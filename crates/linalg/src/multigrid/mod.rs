//! Multigrid-preconditioned conjugate gradients for large sparse symmetric
//! positive definite systems, made for grid Laplacians on irregular masked 3D
//! grids (the Laplace field of a heart chamber: 0.3-3 million unknowns).
//!
//! The pieces:
//!
//! - [`Csr`] (the crate's sparse matrix): the products multigrid needs
//!   (`y = A x` in parallel, `A^T`, the Galerkin product `P^T A P`).
//! - [`grid_prolongation`] (`prolongation.rs`): trilinear interpolation `P` from the grid
//!   coarsened by 2 in each direction to the masked fine grid.
//! - [`Multigrid`]: the hierarchy `A_0 = A`, `A_{l+1} = P_l^T A_l P_l`
//!   (Galerkin coarse operators) and one symmetric V(1,1) cycle as the
//!   preconditioner `z = M^{-1} r`: a forward Gauss-Seidel sweep before the
//!   coarse correction, a backward sweep after it, an exact dense solve on the
//!   coarsest level (`coarsest.rs`).
//! - [`pcg`] (`pcg.rs`): preconditioned conjugate gradients with that preconditioner.
//!   With a good hierarchy the iteration count does not grow with the grid
//!   size (about ten iterations for `1e-10` on 7-point Laplacians).
//!
//! Masked grids make the coarse levels rank deficient: a coarse node whose
//! own fine node is outside the mask has a basis function built from its
//! fine neighbours only, and such functions can be linearly dependent (an
//! isolated fine node at an odd position has 8 coarse parents with the same
//! column in `P`). Then `A_{l+1}` is only semidefinite, with null space
//! `null(P_0 ... P_l)`. This is harmless for the V-cycle (the coarse right
//! hand sides are orthogonal to that null space, and null-space components
//! of a coarse correction vanish on the fine grid), provided the smoother
//! skips zero diagonals and the coarsest solve handles a semidefinite matrix:
//! it is a Cholesky factorization that drops (fixes to zero) every unknown
//! whose pivot vanishes, and each dropped direction `n` is checked to satisfy
//! `Q n = 0` for the composite prolongation `Q` (else `A` itself is singular,
//! an error).

mod coarsest;
mod pcg;
mod points;
mod prolongation;

pub use pcg::{PcgReport, dot, pcg};
pub use points::{block_prolongation, point_hierarchy, point_prolongation};
pub use prolongation::grid_prolongation;

use crate::csr::spgemm;
use crate::{Csr, LinalgError};
use coarsest::DenseCholesky;
use prolongation::grid_nodes;

/// Default size of the coarsest level: [`Multigrid::new`] stops coarsening
/// once a level has at most this many unknowns.
pub const COARSEST: usize = 1000;

/// Largest coarsest level solved by the dense Cholesky factorization
/// (`8 n^2` bytes, `n^3 / 3` multiply-adds); a larger one is an error.
pub const MAX_DENSE: usize = 4000;

/// A dropped coarsest-level direction `n` is a null vector of the
/// prolongations when `|Q n|^2 <= NULL_TOL sum_i n_i^2 |Q e_i|^2`.
const NULL_TOL: f64 = 1e-8;

/// One level above the coarsest: its operator, the smoother's inverse
/// diagonal, the prolongation from the next level and its transpose (the
/// restriction).
#[derive(Debug, Clone)]
struct Level {
    a: Csr,
    inv_diag: Vec<f64>,
    p: Csr,
    r: Csr,
}

/// A multigrid V-cycle preconditioner: levels `A_0 = A`,
/// `A_{l+1} = P_l^T A_l P_l`, symmetric Gauss-Seidel smoothing on every
/// level but the coarsest, which is solved by a dense Cholesky
/// factorization (see the module docs for semidefinite coarse levels).
#[derive(Debug, Clone)]
pub struct Multigrid {
    levels: Vec<Level>,
    coarsest: DenseCholesky,
}

impl Multigrid {
    /// The hierarchy `A_0 = a`, `A_{l+1} = P_l^T A_l P_l` with
    /// `prolongations[l]` mapping level `l + 1` to level `l`; stops adding
    /// levels early once a level has at most [`COARSEST`] unknowns. The
    /// coarsest level is factorized by a dense Cholesky.
    ///
    /// # Errors
    /// [`LinalgError::NotSquare`], [`LinalgError::NotFinite`],
    /// [`LinalgError::NotSymmetric`] (`|a_ij - a_ji| > 1e-12 max |a|`) or
    /// [`LinalgError::NonPositiveDiagonal`] for such an `a`;
    /// [`LinalgError::NullDirection`] (singular) or
    /// [`LinalgError::NegativePivot`] (indefinite), found on the coarsest
    /// level; [`LinalgError::CoarsestTooLarge`] if the coarsest level has
    /// more than [`MAX_DENSE`] unknowns; [`LinalgError::DimensionMismatch`]
    /// if a prolongation has the wrong number of rows.
    pub fn new(a: Csr, prolongations: Vec<Csr>) -> Result<Multigrid, LinalgError> {
        Self::with_coarsest(a, prolongations, COARSEST)
    }

    /// [`Multigrid::new`] with another coarsest-level size: levels are
    /// added while the current one has more than `coarsest` unknowns (and
    /// prolongations remain). Errors as [`Multigrid::new`].
    pub fn with_coarsest(
        a: Csr,
        prolongations: Vec<Csr>,
        coarsest: usize,
    ) -> Result<Multigrid, LinalgError> {
        if a.n_rows() != a.n_cols() {
            return Err(LinalgError::NotSquare {
                rows: a.n_rows(),
                cols: a.n_cols(),
            });
        }
        a.check_finite("multigrid matrix value")?;
        a.check_symmetric()?;
        if let Some((i, d)) = a
            .diagonal()
            .into_iter()
            .enumerate()
            .find(|&(_, d)| !(d > 0.0 && d.is_finite()))
        {
            return Err(LinalgError::NonPositiveDiagonal { index: i, value: d });
        }
        let mut levels = Vec::new();
        let mut cur = a;
        for p in prolongations {
            if cur.n_rows() <= coarsest {
                break;
            }
            if p.n_rows() != cur.n_rows() {
                return Err(LinalgError::DimensionMismatch {
                    what: "multigrid: rows of a prolongation (unknowns of its fine level)",
                    expected: cur.n_rows(),
                    found: p.n_rows(),
                });
            }
            let r = p.transpose();
            let next = cur.galerkin_with_transpose(&p, &r)?;
            let inv_diag = smoother_diagonal(&cur);
            levels.push(Level {
                a: cur,
                inv_diag,
                p,
                r,
            });
            cur = next;
        }
        if cur.n_rows() > MAX_DENSE {
            return Err(LinalgError::CoarsestTooLarge {
                size: cur.n_rows(),
                max: MAX_DENSE,
            });
        }
        let (coarsest_factor, dropped) = DenseCholesky::factor(&cur)?;
        let mg = Multigrid {
            levels,
            coarsest: coarsest_factor,
        };
        if !dropped.is_empty() {
            mg.check_null_directions(&dropped)?;
        }
        Ok(mg)
    }

    /// The finest operator `A_0` when it is a smoothed level (`None` when
    /// the whole problem is the coarsest level, solved densely): lets a
    /// caller hand its matrix over instead of keeping a copy.
    pub fn matrix(&self) -> Option<&Csr> {
        self.levels.first().map(|l| &l.a)
    }

    /// Each dropped coarsest-level direction `n` must vanish on the fine
    /// grid: `|Q n|^2 = n^T G n <= NULL_TOL sum_i n_i^2 G_ii` with
    /// `Q = P_0 ... P_{L-1}` and `G = Q^T Q` (built like the Galerkin
    /// operators: `G_1 = P_0^T P_0`, `G_{l+1} = P_l^T G_l P_l`). Otherwise
    /// `A Q n = 0` with `Q n != 0`: `A` is singular.
    fn check_null_directions(&self, dropped: &[usize]) -> Result<(), LinalgError> {
        let m = self.coarsest.n;
        let g = match self.levels.split_first() {
            None => Csr::identity(m),
            Some((first, rest)) => {
                let mut g = spgemm(&first.r, &first.p);
                for lev in rest {
                    g = g.galerkin(&lev.p)?;
                }
                g
            }
        };
        let gd = g.diagonal();
        let mut gn = vec![0.0; m];
        for &j in dropped {
            let nv = self.coarsest.null_vector(j);
            g.mul_vec(&nv, &mut gn);
            let ngn: f64 = nv.iter().zip(&gn).map(|(a, b)| a * b).sum();
            let scale: f64 = nv.iter().zip(&gd).map(|(a, d)| a * a * d).sum();
            if ngn.is_nan() || ngn > NULL_TOL * scale {
                return Err(LinalgError::NullDirection {
                    unknown: j,
                    size: m,
                    norm2: ngn,
                    scale,
                });
            }
        }
        Ok(())
    }

    /// Convenience: the hierarchy of a masked grid (conventions of
    /// [`grid_prolongation`]; `a` is the operator on the unknowns numbered
    /// by `index`), calling [`grid_prolongation`] repeatedly until a level
    /// has at most [`COARSEST`] unknowns or coarsening no longer reduces the
    /// unknown count.
    ///
    /// # Errors
    /// Those of [`grid_prolongation`] and [`Multigrid::new`];
    /// [`LinalgError::DimensionMismatch`] if `index` does not number
    /// `a.n_rows()` unknowns.
    pub fn for_grid(a: Csr, dims: [usize; 3], index: &[u32]) -> Result<Multigrid, LinalgError> {
        Self::for_grid_with_coarsest(a, dims, index, COARSEST)
    }

    /// [`Multigrid::for_grid`] with another coarsest-level size (see
    /// [`Multigrid::with_coarsest`]).
    pub fn for_grid_with_coarsest(
        a: Csr,
        dims: [usize; 3],
        index: &[u32],
        coarsest: usize,
    ) -> Result<Multigrid, LinalgError> {
        let n_nodes = grid_nodes(dims)?;
        if index.len() != n_nodes {
            return Err(LinalgError::DimensionMismatch {
                what: "grid index (one entry per node)",
                expected: n_nodes,
                found: index.len(),
            });
        }
        let n_active = index.iter().filter(|&&u| u != u32::MAX).count();
        if n_active != a.n_rows() {
            return Err(LinalgError::DimensionMismatch {
                what: "multigrid: unknowns in the grid index (rows of the matrix)",
                expected: a.n_rows(),
                found: n_active,
            });
        }
        let mut prolongations = Vec::new();
        let mut d = dims;
        let mut coarse_index: Option<Vec<u32>> = None;
        let mut n = n_active;
        while n > coarsest {
            let (p, cd, ci) = grid_prolongation(d, coarse_index.as_deref().unwrap_or(index))?;
            if p.n_cols() >= n {
                break;
            }
            n = p.n_cols();
            prolongations.push(p);
            d = cd;
            coarse_index = Some(ci);
        }
        Self::with_coarsest(a, prolongations, coarsest)
    }

    /// Number of levels, the coarsest included (1: a dense solve of `A`).
    pub fn levels(&self) -> usize {
        self.levels.len() + 1
    }

    /// Unknowns per level, finest first.
    pub fn level_sizes(&self) -> Vec<usize> {
        self.levels
            .iter()
            .map(|l| l.a.n_rows())
            .chain(std::iter::once(self.coarsest.n))
            .collect()
    }

    /// Number of unknowns of the finest level (the size of `A`).
    pub fn size(&self) -> usize {
        self.levels
            .first()
            .map_or(self.coarsest.n, |l| l.a.n_rows())
    }

    /// `z = M^{-1} r`, one symmetric V(1,1) cycle. On level `l` with right
    /// hand side `b` (`b = r` on level 0):
    ///
    /// ```text
    /// x = 0
    /// x_i += (b_i - (A_l x)_i) / a_ii,  i = 0, 1, ..., n-1      (forward Gauss-Seidel)
    /// x  += P_l V_{l+1}(P_l^T (b - A_l x))                       (coarse correction)
    /// x_i += (b_i - (A_l x)_i) / a_ii,  i = n-1, ..., 1, 0      (backward Gauss-Seidel)
    /// ```
    ///
    /// and `V_L(b) = A_L^{-1} b` (dense Cholesky) on the coarsest level. The
    /// backward sweep is the adjoint of the forward one, so `M^{-1}` is
    /// symmetric positive definite. `z` need not be zeroed by the caller.
    ///
    /// # Panics
    /// If `r` or `z` does not have [`Multigrid::size`] entries.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = self.size();
        assert_eq!(r.len(), n, "Multigrid::apply: r has the wrong length");
        assert_eq!(z.len(), n, "Multigrid::apply: z has the wrong length");
        self.cycle(0, r, z);
    }

    fn cycle(&self, l: usize, b: &[f64], x: &mut [f64]) {
        let Some(lev) = self.levels.get(l) else {
            self.coarsest.solve(b, x);
            return;
        };
        x.fill(0.0);
        gauss_seidel(&lev.a, &lev.inv_diag, b, x, false);
        let mut res = vec![0.0; b.len()];
        lev.a.residual(b, x, &mut res);
        let mut bc = vec![0.0; lev.p.n_cols()];
        lev.r.mul_vec(&res, &mut bc);
        drop(res);
        let mut xc = vec![0.0; lev.p.n_cols()];
        self.cycle(l + 1, &bc, &mut xc);
        lev.p.mul_vec_add(&xc, x);
        gauss_seidel(&lev.a, &lev.inv_diag, b, x, true);
    }
}

/// `1 / a_ii` for the Gauss-Seidel smoother, `0` (the unknown is left
/// alone) where `a_ii <= 1e-14 max_i a_ii`: on a semidefinite coarse level
/// such an unknown lies in the null space.
fn smoother_diagonal(a: &Csr) -> Vec<f64> {
    let d = a.diagonal();
    let max = d.iter().copied().fold(0.0f64, f64::max);
    d.iter()
        .map(|&x| if x > 1e-14 * max { 1.0 / x } else { 0.0 })
        .collect()
}

/// One Gauss-Seidel sweep `x_i += (b_i - sum_j a_ij x_j) inv_diag_i`,
/// rows ascending, or descending if `backward`.
fn gauss_seidel(a: &Csr, inv_diag: &[f64], b: &[f64], x: &mut [f64], backward: bool) {
    let step = |i: usize, x: &mut [f64]| {
        let (c, v) = a.row(i);
        let mut s = b[i];
        for (&j, &aij) in c.iter().zip(v) {
            s -= aij * x[j as usize];
        }
        x[i] += s * inv_diag[i];
    };
    if backward {
        for i in (0..x.len()).rev() {
            step(i, x);
        }
    } else {
        for i in 0..x.len() {
            step(i, x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::pcg::dot;
    use super::*;
    use crate::test_support::{Rng, dense};
    use nalgebra::DVector;
    use proptest::prelude::*;
    use std::time::Instant;

    /// Numbering of the `true` nodes in linear-id order.
    fn numbering(mask: &[bool]) -> Vec<u32> {
        let mut k = 0;
        mask.iter()
            .map(|&m| {
                if m {
                    k += 1;
                    k - 1
                } else {
                    u32::MAX
                }
            })
            .collect()
    }

    /// 7-point Laplacian on the unknowns of `index`: diagonal 6, -1 between
    /// neighbouring unknowns (masked-out neighbours and the outside are
    /// Dirichlet 0). With `neumann`, the diagonal is the neighbour count
    /// instead (singular: constants are in the kernel).
    fn laplacian(dims: [usize; 3], index: &[u32], neumann: bool) -> Csr {
        let [nx, ny, nz] = dims;
        let mut t = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let u = index[i + nx * (j + ny * k)];
                    if u == u32::MAX {
                        continue;
                    }
                    let mut deg = 0.0;
                    let nb = [
                        (i > 0).then(|| (i - 1, j, k)),
                        (i + 1 < nx).then_some((i + 1, j, k)),
                        (j > 0).then(|| (i, j - 1, k)),
                        (j + 1 < ny).then_some((i, j + 1, k)),
                        (k > 0).then(|| (i, j, k - 1)),
                        (k + 1 < nz).then_some((i, j, k + 1)),
                    ];
                    for (a, b, c) in nb.into_iter().flatten() {
                        let v = index[a + nx * (b + ny * c)];
                        if v != u32::MAX {
                            t.push((u, v, -1.0));
                            deg += 1.0;
                        }
                    }
                    t.push((u, u, if neumann { deg } else { 6.0 }));
                }
            }
        }
        let n = index.iter().filter(|&&u| u != u32::MAX).count();
        Csr::from_triplets(n, n, &t).unwrap()
    }

    fn rel_residual(a: &Csr, b: &[f64], x: &[f64]) -> f64 {
        let mut r = vec![0.0; b.len()];
        a.residual(b, x, &mut r);
        dot(&r, &r).sqrt() / dot(b, b).sqrt()
    }

    /// Full box of `s^3` unknowns, `b = 1`; (iterations, seconds, levels).
    fn solve_box(s: usize) -> (PcgReport, f64, Vec<usize>) {
        let dims = [s, s, s];
        let index: Vec<u32> = (0..(s * s * s) as u32).collect();
        let a = laplacian(dims, &index, false);
        let start = Instant::now();
        let mg = Multigrid::for_grid(a.clone(), dims, &index).unwrap();
        let setup = start.elapsed().as_secs_f64();
        let b = vec![1.0; a.n_rows()];
        let mut x = vec![0.0; a.n_rows()];
        let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 100).unwrap();
        let total = start.elapsed().as_secs_f64();
        assert!(rel_residual(&a, &b, &x) <= 1e-10);
        assert_eq!(rep.relative_residual, rel_residual(&a, &b, &x));
        println!(
            "{s}^3 = {} unknowns: {} iterations, relative residual {:.2e}, levels {:?}, \
             setup {setup:.3} s, total {total:.3} s",
            a.n_rows(),
            rep.iterations,
            rep.relative_residual,
            mg.level_sizes()
        );
        (rep, total, mg.level_sizes())
    }

    #[test]
    fn iteration_count_is_mesh_independent() {
        let (r33, _, l33) = solve_box(33);
        let (r65, _, l65) = solve_box(65);
        assert_eq!(l33, vec![35_937, 4_913, 729]);
        assert_eq!(l65, vec![274_625, 35_937, 4_913, 729]);
        assert!(r33.iterations < 25, "33^3: {} iterations", r33.iterations);
        assert!(r65.iterations < 25, "65^3: {} iterations", r65.iterations);
        assert!(
            r65.iterations <= r33.iterations + 3,
            "33^3: {}, 65^3: {} iterations",
            r33.iterations,
            r65.iterations
        );
    }

    fn random_mask(dims: [usize; 3], density: f64, rng: &mut Rng) -> Vec<bool> {
        (0..dims.iter().product::<usize>())
            .map(|_| rng.f64() < density)
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        #[test]
        fn pcg_on_random_masks_matches_dense_solve(density in 0.3f64..1.0, seed in any::<u64>()) {
            let dims = [9, 10, 11];
            let mut rng = Rng(seed);
            let index = numbering(&random_mask(dims, density, &mut rng));
            let a = laplacian(dims, &index, false);
            let n = a.n_rows();
            prop_assume!(n > 0);
            // A small coarsest level: several (rank-deficient) levels.
            let mg = Multigrid::for_grid_with_coarsest(a.clone(), dims, &index, 20).unwrap();
            prop_assert!(mg.levels() >= 3, "levels {:?}", mg.level_sizes());
            let b: Vec<f64> = (0..n).map(|_| rng.f64() - 0.3).collect();
            let mut x: Vec<f64> = (0..n).map(|_| rng.f64()).collect();
            let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 60).unwrap();
            prop_assert!(rep.relative_residual <= 1e-10);
            prop_assert!((rep.relative_residual - rel_residual(&a, &b, &x)).abs() < 1e-14);
            prop_assert!(rep.iterations <= 20, "{} iterations", rep.iterations);
            let exact = dense(&a).cholesky().unwrap().solve(&DVector::from_column_slice(&b));
            let scale = exact.amax();
            for i in 0..n {
                prop_assert!(
                    (x[i] - exact[i]).abs() <= 1e-8 * scale,
                    "x[{}] = {} vs {}", i, x[i], exact[i]
                );
            }
        }

        #[test]
        fn preconditioner_is_symmetric_positive_definite(density in 0.3f64..1.0, seed in any::<u64>()) {
            let dims = [9, 10, 11];
            let mut rng = Rng(seed);
            let index = numbering(&random_mask(dims, density, &mut rng));
            let a = laplacian(dims, &index, false);
            let n = a.n_rows();
            prop_assume!(n > 0);
            let mg = Multigrid::for_grid_with_coarsest(a, dims, &index, 20).unwrap();
            let r1: Vec<f64> = (0..n).map(|_| rng.f64() - 0.5).collect();
            let r2: Vec<f64> = (0..n).map(|_| rng.f64() - 0.5).collect();
            let (mut z1, mut z2) = (vec![f64::NAN; n], vec![7.0; n]);
            mg.apply(&r1, &mut z1);
            mg.apply(&r2, &mut z2);
            let (a12, a21) = (dot(&z1, &r2), dot(&z2, &r1));
            prop_assert!((a12 - a21).abs() <= 1e-12 * (dot(&z1, &r1) + dot(&z2, &r2)), "{} vs {}", a12, a21);
            prop_assert!(dot(&z1, &r1) > 0.0 && dot(&z2, &r2) > 0.0);
        }
    }

    #[test]
    fn small_system_is_solved_exactly_by_the_coarsest_level() {
        let dims = [6, 7, 8];
        let mut rng = Rng(5);
        let index = numbering(&random_mask(dims, 0.7, &mut rng));
        let a = laplacian(dims, &index, false);
        let mg = Multigrid::for_grid(a.clone(), dims, &index).unwrap();
        assert_eq!(mg.levels(), 1);
        assert_eq!(mg.size(), a.n_rows());
        let b: Vec<f64> = (0..a.n_rows()).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut x = vec![0.0; a.n_rows()];
        let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 5).unwrap();
        assert_eq!(rep.iterations, 1);
        assert!(rep.relative_residual < 1e-13);
    }

    #[test]
    fn rank_deficient_prolongation_is_handled() {
        // One unknown at the odd node (1,1,1): P is 1 x 8 (all columns
        // equal), A_1 = P^T A P has rank 1; 7 coarse directions are dropped
        // and verified to vanish under P.
        let a = Csr::from_triplets(1, 1, &[(0, 0, 6.0)]).unwrap();
        let mut index = vec![u32::MAX; 27];
        index[13] = 0;
        let (p, _, _) = grid_prolongation([3, 3, 3], &index).unwrap();
        let mg = Multigrid::with_coarsest(a, vec![p], 0).unwrap();
        assert_eq!(mg.level_sizes(), vec![1, 8]);
        let mut z = [0.0];
        mg.apply(&[3.0], &mut z);
        // Gauss-Seidel alone is exact here: z = 3/6, the coarse correction 0.
        assert!((z[0] - 0.5).abs() < 1e-15, "{}", z[0]);
    }

    #[test]
    fn singular_matrix_is_an_error() {
        // Neumann Laplacian: constants are in the kernel, and P reproduces them.
        let dims = [12, 12, 12];
        let index: Vec<u32> = (0..1728).collect();
        let a = laplacian(dims, &index, true);
        let err = Multigrid::for_grid_with_coarsest(a, dims, &index, 30).unwrap_err();
        assert!(matches!(err, LinalgError::NullDirection { .. }), "{err:?}");
        assert!(err.to_string().contains("singular"), "{err}");
        // Also without coarse levels.
        let a = Csr::from_triplets(
            2,
            2,
            &[(0, 0, 1.0), (0, 1, -1.0), (1, 0, -1.0), (1, 1, 1.0)],
        )
        .unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(
            matches!(err, LinalgError::NullDirection { size: 2, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("singular"), "{err}");
        // Indefinite.
        let a = Csr::from_triplets(2, 2, &[(0, 0, 1.0), (0, 1, 2.0), (1, 0, 2.0), (1, 1, 1.0)])
            .unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert!(
            matches!(err, LinalgError::NegativePivot { index: 1, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("not positive definite"), "{err}");
    }

    #[test]
    fn multigrid_rejects_bad_matrices() {
        let a = Csr::from_triplets(2, 2, &[(0, 0, 2.0), (0, 1, -1.0), (1, 1, 2.0)]).unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert_eq!(
            err,
            LinalgError::NotSymmetric {
                row: 0,
                col: 1,
                value: -1.0,
                mirror: 0.0
            }
        );
        assert!(err.to_string().contains("not symmetric"), "{err}");
        let a = Csr::from_triplets(2, 2, &[(0, 0, 2.0), (1, 1, 0.0)]).unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert_eq!(
            err,
            LinalgError::NonPositiveDiagonal {
                index: 1,
                value: 0.0
            }
        );
        assert!(err.to_string().contains("diagonal entry 1"), "{err}");
        let a = Csr::from_triplets(2, 3, &[]).unwrap();
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert_eq!(err, LinalgError::NotSquare { rows: 2, cols: 3 });
        assert!(err.to_string().contains("square"), "{err}");
        // A non-finite value (only the mesh operators' constructor lets one in).
        let a = Csr::symmetric(2, [(0, 0, 2.0), (0, 1, f64::NAN), (1, 1, 2.0)]);
        assert!(matches!(
            Multigrid::new(a, vec![]),
            Err(LinalgError::NotFinite { index: 1, .. })
        ));
        // Prolongation with the wrong number of rows.
        let dims = [11, 11, 11];
        let index: Vec<u32> = (0..1331).collect();
        let a = laplacian(dims, &index, false);
        let p = Csr::from_triplets(1000, 10, &[]).unwrap();
        let err = Multigrid::new(a.clone(), vec![p]).unwrap_err();
        assert!(matches!(
            err,
            LinalgError::DimensionMismatch {
                expected: 1331,
                found: 1000,
                ..
            }
        ));
        // Grid index that does not number the matrix's unknowns.
        let err = Multigrid::for_grid(a.clone(), [11, 11, 10], &index[..1210]).unwrap_err();
        assert!(matches!(
            err,
            LinalgError::DimensionMismatch {
                expected: 1331,
                found: 1210,
                ..
            }
        ));
        // Coarsest level too large for the dense solve.
        let dims = [17, 17, 17];
        let index: Vec<u32> = (0..4913).collect();
        let a = laplacian(dims, &index, false);
        let err = Multigrid::new(a, vec![]).unwrap_err();
        assert_eq!(
            err,
            LinalgError::CoarsestTooLarge {
                size: 4913,
                max: MAX_DENSE
            }
        );
        assert!(err.to_string().contains("dense solve"), "{err}");
    }

    #[test]
    fn pcg_rejects_bad_input() {
        let dims = [12, 12, 12];
        let index: Vec<u32> = (0..1728).collect();
        let a = laplacian(dims, &index, false);
        let mg = Multigrid::for_grid(a.clone(), dims, &index).unwrap();
        assert_eq!(mg.levels(), 2);
        let n = a.n_rows();
        let b = vec![1.0; n];
        let mut x = vec![0.0; n];
        let err = pcg(&a, &b[..n - 1], &mut x, &mg, 1e-10, 50).unwrap_err();
        assert!(matches!(
            err,
            LinalgError::DimensionMismatch {
                expected: 1728,
                found: 1727,
                ..
            }
        ));
        let mut short = vec![0.0; n + 1];
        let err = pcg(&a, &b, &mut short, &mg, 1e-10, 50).unwrap_err();
        assert!(matches!(
            err,
            LinalgError::DimensionMismatch {
                expected: 1728,
                found: 1729,
                ..
            }
        ));
        let small = laplacian([3, 3, 3], &(0..27).collect::<Vec<_>>(), false);
        let err = pcg(&small, &b[..27], &mut x[..27], &mg, 1e-10, 50).unwrap_err();
        assert!(
            matches!(
                err,
                LinalgError::DimensionMismatch {
                    expected: 27,
                    found: 1728,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("preconditioner"), "{err}");
        let mut bad = b.clone();
        bad[5] = f64::NAN;
        let err = pcg(&a, &bad, &mut x, &mg, 1e-10, 50).unwrap_err();
        assert!(
            matches!(err, LinalgError::NotFinite { index: 5, .. }),
            "{err:?}"
        );
        assert!(
            err.to_string().contains("b, entry 5 is not finite"),
            "{err}"
        );
        let mut xbad = vec![0.0; n];
        xbad[7] = f64::INFINITY;
        let err = pcg(&a, &b, &mut xbad, &mg, 1e-10, 50).unwrap_err();
        assert!(
            matches!(err, LinalgError::NotFinite { index: 7, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("x, entry 7"), "{err}");
        let err = pcg(&a, &b, &mut x, &mg, 0.0, 50).unwrap_err();
        assert!(
            matches!(err, LinalgError::InvalidTolerance { .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("tolerance"), "{err}");
        let err = pcg(&a, &b, &mut x, &mg, 1e-10, 2).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("did not converge in 2 iterations"), "{msg}");
        // The residual reached is reported, and it is above the tolerance.
        let LinalgError::NoConvergence {
            iterations: 2,
            residual: reached,
        } = err
        else {
            panic!("{err:?}")
        };
        assert!(reached > 1e-10 && reached < 1.0, "{msg}");
        // Then converges, starting from where it stopped; b = 0 gives x = 0.
        let rep = pcg(&a, &b, &mut x, &mg, 1e-10, 50).unwrap();
        assert!(rep.relative_residual <= 1e-10);
        let rep = pcg(&a, &vec![0.0; n], &mut x, &mg, 1e-10, 50).unwrap();
        assert_eq!(
            rep,
            PcgReport {
                iterations: 0,
                relative_residual: 0.0
            }
        );
        assert!(x.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn pcg_reports_breakdown_on_an_indefinite_matrix() {
        // The preconditioner is built from an SPD matrix, pcg is run on the
        // negative definite -I of the same size: p^T A p < 0 at once.
        let dims = [12, 12, 12];
        let index: Vec<u32> = (0..1728).collect();
        let spd = laplacian(dims, &index, false);
        let mg = Multigrid::for_grid(spd, dims, &index).unwrap();
        let t: Vec<(u32, u32, f64)> = (0..1728u32).map(|i| (i, i, -1.0)).collect();
        let a = Csr::from_triplets(1728, 1728, &t).unwrap();
        let b = vec![1.0; 1728];
        let mut x = vec![0.0; 1728];
        let err = pcg(&a, &b, &mut x, &mg, 1e-10, 50).unwrap_err();
        assert!(
            matches!(
                err,
                LinalgError::Breakdown {
                    iteration: 1,
                    quantity: "p^T A p",
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("breakdown"), "{err}");
    }
}
