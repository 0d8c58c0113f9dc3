//! The Hessian `d2psi/dF2` of a 3D element as its modes, for assemblies
//! that map it to the element's vertices (the 3D counterpart of
//! [`Eigen2`](super::Eigen2)).
//!
//! With the signed SVD `F = U diag(s) V^T` ([`signed_svd3`]) the Hessian is
//! ([`crate::energy`] docs)
//!
//! ```text
//! d2psi/dF2 = sum_ab hs_ab vec(D_a) vec(D_b)^T + sum_k l_k vec(m_k) vec(m_k)^T
//! D_a = u_a v_a^T                                   (scaling modes)
//! m   = (u_i v_j^T -/+ u_j v_i^T) / sqrt 2          (twist, flip of pair i < j)
//! ```
//!
//! with `hs = d2psi/ds2` (symmetric 3x3; projected to PSD through its
//! eigen-decomposition unless already positive definite) and the pair
//! eigenvalues `l_k` (clamped at 0 when projected), kept as 9 modes;
//! [`eval3`](super::eval3)'s 9x9 Hessian is their sum
//! ([`Eigen3::matrix`]). With `C` the map from the 12 vertex coordinates
//! to `vec(F)`,
//! `C^T H C = sum_ab hs_ab c_a c_b^T + sum_k l_k w_k w_k^T`
//! (`c_a = C^T vec(D_a)`, `w_k = C^T vec(m_k)`, 12-vectors): about 1,100
//! multiply-adds per element instead of the 9x9 product on each side
//! (about 3,000).

use std::f64::consts::FRAC_1_SQRT_2;

use nalgebra::{Matrix3, SMatrix};

use super::eval::{nonpositive_or_nan, project_sym3};
use super::svd::signed_svd3;
use super::{DistortionEnergy, HessianMode, PAIRS};

/// `d2psi/dF2` of a 3D element as its scaling block and pair modes
/// (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eigen3 {
    /// `hs = d2psi/ds2`, symmetrized, PSD-projected when asked for.
    pub scaling: [[f64; 3]; 3],
    /// The scaling modes `D_a = u_a v_a^T`.
    pub scaling_modes: [Matrix3<f64>; 3],
    /// The eigenvalues of the twist and flip modes (pair `k` of
    /// `(0, 1), (0, 2), (1, 2)` at `2 k` and `2 k + 1`), clamped at 0 when
    /// projected.
    pub values: [f64; 6],
    /// The unit twist and flip modes, in the order of `values`.
    pub modes: [Matrix3<f64>; 6],
}

impl Eigen3 {
    /// `sum_ab hs_ab vec(D_a) vec(D_b)^T + sum_k l_k vec(m_k) vec(m_k)^T`
    /// (9x9 over column-major `vec(F)`, entry `F[(i, j)]` at `i + 3 j`).
    pub fn matrix(&self) -> SMatrix<f64, 9, 9> {
        let mut h = SMatrix::<f64, 9, 9>::zeros();
        for a in 0..3 {
            for b in 0..3 {
                let (da, db) = (&self.scaling_modes[a], &self.scaling_modes[b]);
                for c in 0..9 {
                    for r in 0..9 {
                        h[(r, c)] += self.scaling[a][b] * da[r] * db[c];
                    }
                }
            }
        }
        for (l, m) in self.values.iter().zip(&self.modes) {
            for c in 0..9 {
                for r in 0..9 {
                    h[(r, c)] += l * m[r] * m[c];
                }
            }
        }
        h
    }
}

/// The Hessian of `psi` at a 3x3 `F` as its modes ([`Eigen3`]): `None`
/// exactly where [`eval3`](super::eval3) is (`psi(F)` not finite), and then
/// `eigen.matrix()` is `eval3(e, f, mode).hess`. `mode` is
/// `Exact` or `Projected` (`None` gives the projected modes). No heap
/// allocation.
pub fn hessian3_eigen(
    e: &dyn DistortionEnergy,
    f: &Matrix3<f64>,
    mode: HessianMode,
) -> Option<Eigen3> {
    let closed = e.closed_form3(f, None);
    match closed {
        Some(x) if !x.is_finite() => return None,
        None if e.is_barrier() && nonpositive_or_nan(f.determinant()) => return None,
        _ => {}
    }
    let (u, sv, v) = signed_svd3(f);
    let s = [sv[0], sv[1], sv[2]];
    if closed.is_none() && !e.value(&s).is_finite() {
        return None;
    }
    Some(eigen3_at(e, &u, &s, &v, mode != HessianMode::Exact))
}

/// The modes of `d2psi/dF2` at the signed SVD `F = U diag(s) V^T` (module
/// docs), projected (`hs` to PSD, pair eigenvalues clamped at 0) when
/// `project`: the one construction behind [`hessian3_eigen`] and
/// [`eval3`](super::eval3)'s 9x9 Hessian.
pub(super) fn eigen3_at(
    e: &dyn DistortionEnergy,
    u: &Matrix3<f64>,
    s: &[f64; 3],
    v: &Matrix3<f64>,
    project: bool,
) -> Eigen3 {
    let mut h = [0.0; 9];
    e.hessian(s, &mut h);
    let mut scaling = [[0.0; 3]; 3];
    for (i, row) in scaling.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = 0.5 * (h[i * 3 + j] + h[j * 3 + i]);
        }
    }
    if project {
        scaling = project_sym3(scaling);
    }
    let scaling_modes = [0, 1, 2].map(|a| u.column(a) * v.column(a).transpose());
    let mut twist = [0.0; 3];
    let mut flip = [0.0; 3];
    e.pair_eigenvalues(s, &mut twist, &mut flip);
    let mut values = [0.0; 6];
    let mut modes = [Matrix3::zeros(); 6];
    for (k, &(i, j)) in PAIRS.iter().enumerate() {
        let x = u.column(i) * v.column(j).transpose();
        let y = u.column(j) * v.column(i).transpose();
        (values[2 * k], values[2 * k + 1]) = if project {
            (twist[k].max(0.0), flip[k].max(0.0))
        } else {
            (twist[k], flip[k])
        };
        modes[2 * k] = (x - y) * FRAC_1_SQRT_2;
        modes[2 * k + 1] = (x + y) * FRAC_1_SQRT_2;
    }
    Eigen3 {
        scaling,
        scaling_modes,
        values,
        modes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{Arap, Mips, SymmetricDirichlet, Untangling, eval3};
    use proptest::prelude::*;

    fn energies() -> Vec<Box<dyn DistortionEnergy>> {
        vec![
            Box::new(SymmetricDirichlet),
            Box::new(Arap),
            Box::new(Mips),
            Box::new(Untangling {
                eps: 0.1,
                theta: 0.5,
            }),
        ]
    }

    proptest! {
        /// The modes are refused exactly where `eval3` is (and its
        /// 9x9 is their sum); projected, they sum to a positive
        /// semidefinite matrix that equals the exact one wherever the
        /// exact one is already positive semidefinite. (That the exact
        /// sum is `d2psi/dF2` is checked against finite differences of
        /// `eval3`'s gradient, `check_derivatives3`, for every energy.)
        #[test]
        fn projected_modes_are_the_exact_ones_clamped_at_zero(
            entries in proptest::collection::vec(-2.0f64..2.0, 9),
        ) {
            let f = Matrix3::from_column_slice(&entries);
            for e in energies() {
                let exact = hessian3_eigen(e.as_ref(), &f, HessianMode::Exact);
                let projected = hessian3_eigen(e.as_ref(), &f, HessianMode::Projected);
                let evaluated = eval3(e.as_ref(), &f, HessianMode::Projected);
                prop_assert_eq!(exact.is_some(), evaluated.is_some(), "{:?}", e);
                prop_assert_eq!(projected.is_some(), evaluated.is_some(), "{:?}", e);
                let (Some(exact), Some(projected), Some(evaluated)) = (exact, projected, evaluated)
                else {
                    continue;
                };
                let (hx, hp) = (exact.matrix(), projected.matrix());
                prop_assert_eq!(evaluated.hess, Some(hp));
                let scale = hx.norm().max(1.0);
                let lowest = |h: &SMatrix<f64, 9, 9>| {
                    h.symmetric_eigenvalues().iter().copied().fold(f64::INFINITY, f64::min)
                };
                prop_assert!(lowest(&hp) >= -1e-12 * scale, "{:?}: {}", e, lowest(&hp));
                if lowest(&hx) >= 0.0 {
                    let diff = (hx - hp).norm();
                    prop_assert!(diff <= 1e-12 * scale, "{:?}: {} of {}", e, diff, scale);
                }
            }
        }
    }
}
