//! The regularized Winslow energy of Garanzha et al. ("Foldover-free maps
//! in 50 lines of code", ACM TOG 40(4), 2021), finite through inverted
//! elements: the energy the untangler ([`crate::untangle`]) minimizes for a
//! decreasing `eps` (ALGORITHMS 1.7).

use nalgebra::{Matrix2, Matrix3};

use super::DistortionEnergy;
use super::symmetric_dirichlet::cofactor3;

/// `psi(s) = (1 - theta) q / chi(D, eps)^(2/d) + theta (D^2 + 1) / chi(D, eps)`
/// with `q = sum s_i^2 = |F|_F^2`, `D = prod s_i = det F`, `d` the dimension
/// and the regularized determinant
///
/// ```text
/// chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2        (> 0 for every D when eps > 0)
/// ```
///
/// (evaluated as `eps^2 / (2 (sqrt(eps^2 + D^2) - D))` for `D < 0`, without
/// cancellation). The first term is the shape (Winslow) term, scale
/// invariant, the second keeps the volume near the rest volume. As
/// `eps -> 0`, `chi -> max(D, 0)` and `psi` becomes a barrier against
/// inversion; for `eps > 0` it is smooth and finite for every `F`, so a
/// tangled map has a finite energy whose minimizers, for small enough
/// `eps`, invert nothing (Garanzha et al., theorem of section 3).
///
/// As a function of `q` and `D` (`phi(q, D)`), with `D_i = prod_{k != i}
/// s_k` and `P_ij = prod_{k != i, j} s_k` (1 in 2D):
///
/// ```text
/// dpsi/ds_i        = 2 phi_q s_i + phi_D D_i
/// d2psi/ds_i ds_j  = 2 phi_qD (s_i D_j + s_j D_i) + phi_DD D_i D_j + phi_D P_ij [i != j] + 2 phi_q [i = j]
/// twist(i, j)      = 2 phi_q + phi_D P_ij,     flip(i, j) = 2 phi_q - phi_D P_ij
/// dpsi/dF          = 2 phi_q F + phi_D cof F
/// ```
///
/// `phi_qq = 0`. Not a barrier: [`DistortionEnergy::admits_inversion`] is
/// true, so solves with it start from tangled maps and take steps through
/// inversions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Untangling {
    /// The regularization `eps > 0`.
    pub eps: f64,
    /// The weight `theta` in `[0, 1)` of the volume term.
    pub theta: f64,
}

impl Untangling {
    /// The volume term's default weight `theta = 1/128`: the shape term
    /// leads, the volume term keeps elements from growing without bound
    /// where nothing holds them.
    pub const DEFAULT_THETA: f64 = 1.0 / 128.0;

    /// The energy at regularization `eps` with the default `theta`.
    pub fn new(eps: f64) -> Self {
        Untangling {
            eps,
            theta: Self::DEFAULT_THETA,
        }
    }

    /// `phi` and its derivatives `(phi, phi_q, phi_D, phi_qD, phi_DD)` at
    /// `(q, D)` in dimension `d`.
    fn parts(&self, q: f64, det: f64, d: usize) -> [f64; 5] {
        let (chi, c1, c2) = chi_derivatives(det, self.eps);
        let a = 2.0 / d as f64;
        // u = chi^-a, v = 1 / chi (chi^(-2/3) through cbrt: no pow).
        let u = if d == 3 {
            1.0 / (chi.cbrt() * chi.cbrt())
        } else {
            chi.powf(-a)
        };
        let u1 = -a * u / chi * c1;
        let u2 = a * (a + 1.0) * u / (chi * chi) * c1 * c1 - a * u / chi * c2;
        let v = 1.0 / chi;
        let v1 = -c1 * v * v;
        let v2 = 2.0 * c1 * c1 * v * v * v - c2 * v * v;
        let (w, t) = (1.0 - self.theta, self.theta);
        let area = det * det + 1.0;
        [
            w * q * u + t * area * v,
            w * u,
            w * q * u1 + t * (2.0 * det * v + area * v1),
            w * u1,
            w * q * u2 + t * (2.0 * v + 4.0 * det * v1 + area * v2),
        ]
    }
}

/// `chi(D, eps)`, `dchi/dD = chi / r` and `d2chi/dD2 = eps^2 / (2 r^3)` with
/// `r = sqrt(eps^2 + D^2)`, all without cancellation.
pub fn chi_derivatives(det: f64, eps: f64) -> (f64, f64, f64) {
    let r = eps.hypot(det);
    let chi = if det >= 0.0 {
        0.5 * (det + r)
    } else {
        0.5 * eps * eps / (r - det)
    };
    (chi, chi / r, 0.5 * eps * eps / (r * r * r))
}

/// `chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2` ([`chi_derivatives`]).
pub fn chi(det: f64, eps: f64) -> f64 {
    chi_derivatives(det, eps).0
}

impl DistortionEnergy for Untangling {
    fn name(&self) -> &'static str {
        "untangling"
    }
    fn value(&self, s: &[f64]) -> f64 {
        let q: f64 = s.iter().map(|x| x * x).sum();
        self.parts(q, s.iter().product(), s.len())[0]
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        let q: f64 = s.iter().map(|x| x * x).sum();
        let [_, pq, pd, _, _] = self.parts(q, s.iter().product(), s.len());
        for i in 0..s.len() {
            out[i] = 2.0 * pq * s[i] + pd * others(s, i, usize::MAX);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        let q: f64 = s.iter().map(|x| x * x).sum();
        let [_, pq, pd, pqd, pdd] = self.parts(q, s.iter().product(), d);
        for i in 0..d {
            let di = others(s, i, usize::MAX);
            for j in 0..d {
                let dj = others(s, j, usize::MAX);
                let mut h = 2.0 * pqd * (s[i] * dj + s[j] * di) + pdd * di * dj;
                if i == j {
                    h += 2.0 * pq;
                } else {
                    h += pd * others(s, i, j);
                }
                out[i * d + j] = h;
            }
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let q: f64 = s.iter().map(|x| x * x).sum();
        let [_, pq, pd, _, _] = self.parts(q, s.iter().product(), s.len());
        2.0 * pq - pd * others(s, i, j)
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let q: f64 = s.iter().map(|x| x * x).sum();
        let [_, pq, pd, _, _] = self.parts(q, s.iter().product(), s.len());
        2.0 * pq + pd * others(s, i, j)
    }
    fn closed_form2(&self, f: &Matrix2<f64>, grad: Option<&mut Matrix2<f64>>) -> Option<f64> {
        let det = f.m11 * f.m22 - f.m12 * f.m21;
        let [value, pq, pd, _, _] = self.parts(f.norm_squared(), det, 2);
        if let Some(g) = grad {
            let cof = Matrix2::new(f.m22, -f.m21, -f.m12, f.m11);
            *g = 2.0 * pq * f + pd * cof;
        }
        Some(value)
    }
    fn closed_form3(&self, f: &Matrix3<f64>, grad: Option<&mut Matrix3<f64>>) -> Option<f64> {
        let det = f.determinant();
        let [value, pq, pd, _, _] = self.parts(f.norm_squared(), det, 3);
        if let Some(g) = grad {
            *g = 2.0 * pq * f + pd * cofactor3(f);
        }
        Some(value)
    }
    /// The value at rotations (`q = d`, `D = 1`) for this `eps`.
    fn minimum(&self, dim: usize) -> f64 {
        self.parts(dim as f64, 1.0, dim)[0]
    }
    fn is_barrier(&self) -> bool {
        false
    }
    fn admits_inversion(&self) -> bool {
        true
    }
}

/// `prod s_k` over `k` other than `i` and `j`.
#[inline]
fn others(s: &[f64], i: usize, j: usize) -> f64 {
    s.iter()
        .enumerate()
        .filter(|&(k, _)| k != i && k != j)
        .map(|(_, x)| x)
        .product()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::test_support::*;
    use crate::energy::{HessianMode, density2, density3, eval2, eval3};
    use proptest::prelude::*;

    /// Any 3x3 matrix with entries in [-2, 2], inverted or not.
    fn any3() -> impl Strategy<Value = Matrix3<f64>> {
        prop::array::uniform9(-2.0f64..2.0).prop_map(|a| Matrix3::from_column_slice(&a))
    }

    fn any2() -> impl Strategy<Value = Matrix2<f64>> {
        prop::array::uniform4(-2.0f64..2.0).prop_map(|a| Matrix2::from_column_slice(&a))
    }

    #[test]
    fn chi_is_the_regularized_determinant_without_cancellation() {
        for (d, eps) in [
            (0.3f64, 0.1f64),
            (-0.3, 0.1),
            (-1e8, 1e-3),
            (0.0, 0.5),
            (2.0, 1e-9),
        ] {
            let direct = 0.5 * (d + (eps * eps + d * d).sqrt());
            let (c, c1, c2) = chi_derivatives(d, eps);
            assert!(c > 0.0, "chi({d}, {eps}) = {c}");
            if d > -1.0 {
                assert!((c - direct).abs() <= 1e-14 * direct.max(1e-300) + 1e-300);
            }
            let h = 1e-6 * (1.0 + d.abs());
            let fd1 = (chi(d + h, eps) - chi(d - h, eps)) / (2.0 * h);
            assert!((c1 - fd1).abs() <= 1e-6 * fd1.abs().max(1e-12), "{d} {eps}");
            if d.abs() < 10.0 {
                let fd2 =
                    (chi_derivatives(d + h, eps).1 - chi_derivatives(d - h, eps).1) / (2.0 * h);
                assert!((c2 - fd2).abs() <= 1e-5 * fd2.abs().max(1e-9), "{d} {eps}");
            }
        }
        // The rule of the schedule: eps = 2 sqrt(mu (mu - D)) gives chi(D, eps) = mu.
        let (d, mu) = (-0.7f64, 0.2f64);
        let eps = 2.0 * (mu * (mu - d)).sqrt();
        assert!((chi(d, eps) - mu).abs() < 1e-15);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Value, gradient and Hessian through the signed SVD against the
        /// closed form and finite differences, inverted elements included.
        #[test]
        fn untangling_derivatives_match_finite_differences(
            f3 in any3(), f2 in any2(), eps in 0.05f64..1.0, theta in 0.0f64..0.9,
        ) {
            let e = Untangling { eps, theta };
            prop_assume!(f3.determinant().abs() > 1e-3 && f2.determinant().abs() > 1e-3);
            check_derivatives3(&e, &f3, 1e-5);
            check_derivatives2(&e, &f2, 1e-5);
            // The closed forms agree with the SVD path.
            let mut g = Matrix3::zeros();
            let v = e.closed_form3(&f3, Some(&mut g)).unwrap();
            let ev = eval3(&e, &f3, HessianMode::None).unwrap();
            prop_assert!((v - ev.value).abs() <= 1e-10 * v.abs().max(1.0));
            assert_close(g.as_slice(), ev.grad.as_slice(), 1e-9, "closed form 3");
            prop_assert!(density3(&e, &f3).is_finite() && density2(&e, &f2).is_finite());
            // The projected Hessian is PSD and equals the exact one when that is.
            let exact = eval3(&e, &f3, HessianMode::Exact).unwrap().hess.unwrap();
            let proj = eval3(&e, &f3, HessianMode::Projected).unwrap().hess.unwrap();
            check_projection(exact.as_slice(), proj.as_slice(), 9, "untangling 3D");
            let exact = eval2(&e, &f2, HessianMode::Exact).unwrap().hess.unwrap();
            let proj = eval2(&e, &f2, HessianMode::Projected).unwrap().hess.unwrap();
            check_projection(exact.as_slice(), proj.as_slice(), 4, "untangling 2D");
        }
    }

    #[test]
    fn inverting_an_element_costs_more_as_eps_falls() {
        let inverted = Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, -0.5));
        let mut last = 0.0;
        for eps in [1.0, 0.1, 0.01, 0.001] {
            let v = density3(&Untangling::new(eps), &inverted);
            assert!(v.is_finite() && v > last, "eps {eps}: {v} after {last}");
            last = v;
        }
        // At rotations the value is the reported minimum.
        let e = Untangling::new(1e-3);
        assert!((density3(&e, &Matrix3::identity()) - e.minimum(3)).abs() < 1e-12);
        assert!((density2(&e, &Matrix2::identity()) - e.minimum(2)).abs() < 1e-12);
    }
}
