//! Distortion energies as functions of the singular values of the element
//! Jacobian, with values, gradients and PSD-projected Hessians through the
//! analytic eigensystem (ALGORITHMS 1.2).
//!
//! Conventions: `vec(F)` is column-major (nalgebra's storage order), so the
//! 3D Hessian is 9x9 with index `i + 3 j` for `F[(i, j)]`. Signed singular
//! values: `F = U diag(s) V^T` with `U`, `V` proper rotations; the smallest
//! singular value carries the sign of `det F`.
//!
//! What ships here:
//!
//! - the energies [`SymmetricDirichlet`], [`Mips`], [`Arap`] and
//!   [`AreaRatio`] (all defined in 2D and 3D), looked up by name with
//!   [`energy_by_name`];
//! - the signed (rotation-variant) SVDs [`signed_svd2`] and [`signed_svd3`];
//! - the per-element evaluation in `F = J`: [`eval2`] / [`eval3`] (value,
//!   gradient `dpsi/dF`, exact or projected Hessian `d2psi/dF2`) and the
//!   value-only [`density2`] / [`density3`] for line searches.
//!
//! The Hessian uses the analytic eigensystem of Smith, De Goes and Kim
//! ("Analytic Eigensystems for Isotropic Distortion Energies", ACM TOG
//! 38(1), 2019; ALGORITHMS 1.2), valid for every isotropic `psi(s)` (separable or not). With
//! `g = dpsi/ds`, `h = d2psi/ds2` and `u_i`, `v_i` the columns of `U`, `V`,
//! the `d^2` eigenpairs of `d2psi/dF2` are
//!
//! ```text
//! scaling (d of them):  U diag(e_k) V^T, eigenpairs (e_k, l_k) of h
//! twist, pair i < j:    (u_i v_j^T - u_j v_i^T) / sqrt 2,  (g_i + g_j) / (s_i + s_j)
//! flip,  pair i < j:    (u_i v_j^T + u_j v_i^T) / sqrt 2,  (g_i - g_j) / (s_i - s_j)
//! ```
//!
//! so projecting to PSD is clamping these eigenvalues at 0. The SVDs and the
//! element evaluations do not allocate on the heap.
//!
//! One file per idea: the trait and its documented defaults here, one file
//! per energy, the by-name registry, the SVDs (`svd`), the element
//! evaluation (`eval`) and the 3D Hessian's modes for vertex assembly
//! (`eigen3`); everything is re-exported so that
//! `unfold_param::energy::X` is the path to use.

use std::fmt::Debug;

use nalgebra::{Matrix2, Matrix3};

mod arap;
mod area_ratio;
mod eigen3;
mod eval;
mod mips;
mod registry;
mod svd;
mod symmetric_dirichlet;
#[cfg(test)]
mod test_support;
mod untangling;

pub use arap::Arap;
pub use area_ratio::AreaRatio;
pub use eigen3::{Eigen3, hessian3_eigen};
pub use eval::{
    Eigen2, Eval2, Eval3, HessianMode, density2, density3, eval2, eval2_eigen, eval3,
    hessian2_eigen,
};
pub use mips::Mips;
pub use registry::{EnergyKind, energy_by_name};
pub use svd::{signed_svd2, signed_svd3};
pub use symmetric_dirichlet::SymmetricDirichlet;
pub use untangling::{Untangling, chi, chi_derivatives};

/// Largest number of singular values an energy is evaluated on (tets).
const MAX_DIM: usize = 3;

/// Relative gap `|s_i - s_j| / (|s_i| + |s_j|)` below which the default
/// [`DistortionEnergy::flip_eigenvalue`] switches from the divided
/// difference to its limit `psi_ii - psi_ij`. Both have an error of about
/// this size there (rounding of the divided difference vs. truncation of
/// the limit), `sqrt(eps)` balances them.
const FLIP_LIMIT_REL: f64 = 1.5e-8;

/// An isotropic distortion density `psi(s)` of the signed singular values
/// `s` (2 or 3 of them, sorted by decreasing magnitude, the last one signed).
///
/// Implement `value`, `gradient` and `hessian` in `s`; the framework does the
/// SVD, the analytic eigensystem and the projection.
///
/// `psi` must be symmetric under permutations of `s` (isotropy). The slices
/// passed by the framework have length 2 or 3; the default methods use
/// 3-element stack buffers (longer slices panic).
pub trait DistortionEnergy: Send + Sync + Debug {
    /// A short name ("symmetric-dirichlet", ...).
    fn name(&self) -> &'static str;
    /// `psi(s)`; `f64::INFINITY` where the energy is a barrier and `s` is
    /// not admissible (some `s_i <= 0`).
    fn value(&self, s: &[f64]) -> f64;
    /// `dpsi/ds_i` into `out` (same length as `s`).
    fn gradient(&self, s: &[f64], out: &mut [f64]);
    /// `d2psi/(ds_i ds_j)` into `out` (row-major `d x d`).
    fn hessian(&self, s: &[f64], out: &mut [f64]);
    /// The "flip" eigenvalue `(psi_i - psi_j) / (s_i - s_j)` of the pair
    /// `(i, j)`, evaluated stably when `s_i ~ s_j` (its limit is
    /// `psi_ii - psi_ij`). Override with a closed form where one exists.
    ///
    /// The default uses the divided difference of the gradient while
    /// `|s_i - s_j| > 1.5e-8 (|s_i| + |s_j|)` and the limit below that (no
    /// heap allocation; `s.len() <= 3`).
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let d = s.len();
        let mut g = [0.0; MAX_DIM];
        self.gradient(s, &mut g[..d]);
        let ds = s[i] - s[j];
        if ds.abs() > FLIP_LIMIT_REL * (s[i].abs() + s[j].abs()).max(1e-300) {
            (g[i] - g[j]) / ds
        } else {
            let mut h = [0.0; MAX_DIM * MAX_DIM];
            self.hessian(s, &mut h[..d * d]);
            h[i * d + i] - h[i * d + j]
        }
    }
    /// The "twist" eigenvalue `(psi_i + psi_j) / (s_i + s_j)` of the pair
    /// `(i, j)` (the mode `U (e_i e_j^T - e_j e_i^T) V^T / sqrt 2`, the
    /// infinitesimal rotation, which is why it is 0 at rotations).
    ///
    /// With the sign convention of the signed SVD, `s_i + s_j >= 0` always;
    /// it is 0 only for non-barrier energies on flat or inverted elements
    /// with `|s_i| = |s_j|`, where `psi` is not twice differentiable. The
    /// default floors the denominator at `1e-12 (|s_i| + |s_j|)` (and at the
    /// smallest positive normal number), giving a large finite eigenvalue
    /// there. Override with a closed form where one exists.
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let d = s.len();
        let mut g = [0.0; MAX_DIM];
        self.gradient(s, &mut g[..d]);
        (g[i] + g[j]) / twist_denominator(s[i], s[j])
    }
    /// The twist and flip eigenvalues of every pair, in the order
    /// `(0, 1)` (2D), resp. `(0, 1), (0, 2), (1, 2)` (3D), into `twist` and
    /// `flip` (length 1, resp. 3). This is what the framework calls; the
    /// default calls [`twist_eigenvalue`](Self::twist_eigenvalue) and
    /// [`flip_eigenvalue`](Self::flip_eigenvalue) per pair. Override to share
    /// work between the pairs.
    fn pair_eigenvalues(&self, s: &[f64], twist: &mut [f64], flip: &mut [f64]) {
        let npairs = s.len() * (s.len() - 1) / 2;
        for (k, &(i, j)) in PAIRS[..npairs].iter().enumerate() {
            twist[k] = self.twist_eigenvalue(s, i, j);
            flip[k] = self.flip_eigenvalue(s, i, j);
        }
    }
    /// `psi(F)` of a 2x2 `F` in closed form, and `dpsi/dF` into `grad` when
    /// given, for energies with a formula in the entries of `F`: no SVD for
    /// values and gradients (line searches, stopping tests). `None` (the
    /// default) lets the framework go through the singular values. Must
    /// agree with [`value`](Self::value) / [`gradient`](Self::gradient)
    /// through the SVD to rounding, and be `f64::INFINITY` (gradient
    /// unspecified) wherever that value is not finite.
    fn closed_form2(&self, _f: &Matrix2<f64>, _grad: Option<&mut Matrix2<f64>>) -> Option<f64> {
        None
    }
    /// `psi(F)` of a 3x3 `F` in closed form, and `dpsi/dF` into `grad` when
    /// given: like [`closed_form2`](Self::closed_form2), for the 3D line
    /// searches and gradients (a 3x3 SVD costs several Jacobi sweeps).
    /// `None` (the default) goes through the singular values.
    fn closed_form3(&self, _f: &Matrix3<f64>, _grad: Option<&mut Matrix3<f64>>) -> Option<f64> {
        None
    }
    /// The minimum value (at rotations) in dimension `dim`.
    fn minimum(&self, dim: usize) -> f64;
    /// Whether the energy is infinite at `det J -> 0` (a barrier against
    /// inversion). Energies without a barrier rely on the injective line
    /// search alone.
    fn is_barrier(&self) -> bool;
    /// Whether the energy is finite and smooth through inverted elements
    /// and meant to be minimized from tangled maps (the untangler's
    /// [`Untangling`]): the [`Executor`](crate::Executor) then accepts a
    /// start that inverts elements and the solvers' steps are not bounded
    /// by the first flip ([`Objective::max_step`](crate::Objective::max_step)
    /// is infinite). False by default.
    fn admits_inversion(&self) -> bool {
        false
    }
}

/// A boxed energy is an energy (every method forwarded, so an energy's own
/// closed forms are kept): pipelines take `Box<dyn DistortionEnergy>`
/// chosen at run time, e.g. from [`energy_by_name`].
impl<E: DistortionEnergy + ?Sized> DistortionEnergy for Box<E> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn value(&self, s: &[f64]) -> f64 {
        (**self).value(s)
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        (**self).gradient(s, out)
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        (**self).hessian(s, out)
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        (**self).flip_eigenvalue(s, i, j)
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        (**self).twist_eigenvalue(s, i, j)
    }
    fn pair_eigenvalues(&self, s: &[f64], twist: &mut [f64], flip: &mut [f64]) {
        (**self).pair_eigenvalues(s, twist, flip)
    }
    fn closed_form2(&self, f: &Matrix2<f64>, grad: Option<&mut Matrix2<f64>>) -> Option<f64> {
        (**self).closed_form2(f, grad)
    }
    fn closed_form3(&self, f: &Matrix3<f64>, grad: Option<&mut Matrix3<f64>>) -> Option<f64> {
        (**self).closed_form3(f, grad)
    }
    fn minimum(&self, dim: usize) -> f64 {
        (**self).minimum(dim)
    }
    fn is_barrier(&self) -> bool {
        (**self).is_barrier()
    }
    fn admits_inversion(&self) -> bool {
        (**self).admits_inversion()
    }
}

/// `s_i + s_j`, floored at `max(1e-12 (|s_i| + |s_j|), f64::MIN_POSITIVE)`
/// (see [`DistortionEnergy::twist_eigenvalue`]).
#[inline]
fn twist_denominator(si: f64, sj: f64) -> f64 {
    (si + sj)
        .max(1e-12 * (si.abs() + sj.abs()))
        .max(f64::MIN_POSITIVE)
}

/// Whether every `s_i > 0` (false on NaN).
#[inline]
fn all_positive(s: &[f64]) -> bool {
    s.iter().all(|&x| x > 0.0)
}

/// `prod s_i`.
#[inline]
fn product(s: &[f64]) -> f64 {
    s.iter().product()
}

/// The pairs `(i, j)`, `i < j`, of `N` singular values (first 1 in 2D, all
/// 3 in 3D).
const PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;
    use nalgebra::Matrix3;

    /// A boxed energy answers every method exactly as the energy itself,
    /// its closed forms included.
    #[test]
    fn a_boxed_energy_forwards_every_method() {
        let f = nalgebra::Matrix2::new(1.3, 0.2, -0.1, 0.8);
        for &name in <EnergyKind as crate::named::Named>::NAMES {
            let e = energy_by_name(name).unwrap();
            let boxed: Box<Box<dyn DistortionEnergy>> = Box::new(energy_by_name(name).unwrap());
            let s = [1.7, 0.6];
            assert_eq!(boxed.name(), e.name());
            assert_eq!(boxed.value(&s), e.value(&s));
            let (mut a, mut b) = ([0.0; 4], [0.0; 4]);
            boxed.gradient(&s, &mut a[..2]);
            e.gradient(&s, &mut b[..2]);
            assert_eq!(a, b);
            boxed.hessian(&s, &mut a);
            e.hessian(&s, &mut b);
            assert_eq!(a, b);
            let (mut t1, mut f1, mut t2, mut f2) = ([0.0], [0.0], [0.0], [0.0]);
            boxed.pair_eigenvalues(&s, &mut t1, &mut f1);
            e.pair_eigenvalues(&s, &mut t2, &mut f2);
            assert_eq!((t1, f1), (t2, f2));
            assert_eq!(boxed.flip_eigenvalue(&s, 0, 1), e.flip_eigenvalue(&s, 0, 1));
            assert_eq!(
                boxed.twist_eigenvalue(&s, 0, 1),
                e.twist_eigenvalue(&s, 0, 1)
            );
            assert_eq!(boxed.closed_form2(&f, None), e.closed_form2(&f, None));
            let f3 = Matrix3::new(1.2, 0.3, -0.1, 0.2, 0.9, 0.4, -0.3, 0.1, 1.5);
            assert_eq!(boxed.closed_form3(&f3, None), e.closed_form3(&f3, None));
            assert_eq!(boxed.minimum(3), e.minimum(3));
            assert_eq!(boxed.is_barrier(), e.is_barrier());
        }
    }

    #[test]
    fn energy_pair_eigenvalues_match_their_definitions() {
        // Closed-form flip / twist vs (g_i -/+ g_j) / (s_i -/+ s_j).
        for s in [[2.0, 1.3, 0.7], [1.1, 0.9, 0.4], [2.5, 2.0, 0.35]] {
            for e in ENERGIES {
                let mut g = [0.0; 3];
                e.gradient(&s, &mut g);
                for d in [2, 3] {
                    let s = &s[..d];
                    let mut g = [0.0; 3];
                    e.gradient(s, &mut g[..d]);
                    for &(i, j) in &PAIRS[..d * (d - 1) / 2] {
                        let flip = (g[i] - g[j]) / (s[i] - s[j]);
                        let twist = (g[i] + g[j]) / (s[i] + s[j]);
                        let tol = 1e-12 * flip.abs().max(1.0);
                        assert!(
                            (e.flip_eigenvalue(s, i, j) - flip).abs() < tol,
                            "{} flip",
                            e.name()
                        );
                        let tol = 1e-12 * twist.abs().max(1.0);
                        assert!(
                            (e.twist_eigenvalue(s, i, j) - twist).abs() < tol,
                            "{} twist",
                            e.name()
                        );
                    }
                }
            }
        }
        // The batch method agrees with the per-pair ones.
        for e in ENERGIES {
            for d in [2, 3] {
                let s = &[1.9, 1.2, 0.45][..d];
                let (mut t, mut f) = ([0.0; 3], [0.0; 3]);
                let np = d * (d - 1) / 2;
                e.pair_eigenvalues(s, &mut t[..np], &mut f[..np]);
                for (k, &(i, j)) in PAIRS[..np].iter().enumerate() {
                    assert!(
                        (t[k] - e.twist_eigenvalue(s, i, j)).abs() < 1e-14 * t[k].abs().max(1.0)
                    );
                    assert!(
                        (f[k] - e.flip_eigenvalue(s, i, j)).abs() < 1e-14 * f[k].abs().max(1.0)
                    );
                }
            }
        }
        // Symmetric Dirichlet, ALGORITHMS 1.2 verbatim.
        let (a, b) = (1.7f64, 0.6f64);
        let sd = SymmetricDirichlet;
        let flip = 2.0 + 2.0 * (a * a + a * b + b * b) / (a.powi(3) * b.powi(3));
        let twist = 2.0 - 2.0 * (a * a - a * b + b * b) / (a.powi(3) * b.powi(3));
        assert!((sd.flip_eigenvalue(&[a, b], 0, 1) - flip).abs() < 1e-12);
        assert!((sd.twist_eigenvalue(&[a, b], 0, 1) - twist).abs() < 1e-12);
    }

    /// An energy using the trait's default flip / twist eigenvalues.
    #[derive(Debug)]
    struct Defaults<E>(E);

    impl<E: DistortionEnergy> DistortionEnergy for Defaults<E> {
        fn name(&self) -> &'static str {
            self.0.name()
        }
        fn value(&self, s: &[f64]) -> f64 {
            self.0.value(s)
        }
        fn gradient(&self, s: &[f64], out: &mut [f64]) {
            self.0.gradient(s, out)
        }
        fn hessian(&self, s: &[f64], out: &mut [f64]) {
            self.0.hessian(s, out)
        }
        fn minimum(&self, dim: usize) -> f64 {
            self.0.minimum(dim)
        }
        fn is_barrier(&self) -> bool {
            self.0.is_barrier()
        }
    }

    #[test]
    fn energy_default_pair_eigenvalues_match_closed_forms() {
        let wrapped: [&dyn DistortionEnergy; 4] = [
            &Defaults(SymmetricDirichlet),
            &Defaults(Mips),
            &Defaults(Arap),
            &Defaults(AreaRatio),
        ];
        for (w, e) in wrapped.iter().zip(ENERGIES) {
            for gap in [0.5, 1e-3, 1e-7, 1e-9, 1e-13, 0.0] {
                let s = [1.3 * (1.0 + gap), 1.3, 0.8];
                for &(i, j) in &PAIRS {
                    let (a, b) = (w.flip_eigenvalue(&s, i, j), e.flip_eigenvalue(&s, i, j));
                    assert!(
                        (a - b).abs() <= 1e-6 * b.abs().max(1.0),
                        "{} flip {gap} {a} {b}",
                        e.name()
                    );
                    let (a, b) = (w.twist_eigenvalue(&s, i, j), e.twist_eigenvalue(&s, i, j));
                    assert!(
                        (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                        "{} twist {a} {b}",
                        e.name()
                    );
                }
            }
            // Through the whole evaluation.
            let f = Matrix3::new(1.2, 0.3, -0.1, 0.2, 0.9, 0.4, -0.3, 0.1, 1.5);
            let a = eval3(*w, &f, HessianMode::Exact).unwrap().hess.unwrap();
            let b = eval3(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
            assert_close(a.as_slice(), b.as_slice(), 1e-10, e.name());
        }
    }
}
