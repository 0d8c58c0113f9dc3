//! A 2D thin-plate spline `f: R^2 -> R^2` interpolating values at centres
//! (the ventricle's apex warp, ALGORITHMS 3.2):
//!
//! ```text
//! f(p) = a + A p + sum_i w_i phi(|p - c_i|),   phi(r) = r^2 log r,
//! sum_i w_i = 0,   sum_i w_i c_i^T = 0          (side conditions)
//! ```
//!
//! the minimizer of the bending energy among the interpolants, found by one
//! dense saddle-point solve.

use crate::LinalgError;
use nalgebra::DMatrix;
use rayon::prelude::*;

/// The thin-plate radial basis `phi(r) = r^2 log r` (`phi(0) = 0`), from
/// the squared distance: `phi = r2 log(r2) / 2`.
#[inline]
fn tps_phi(r2: f64) -> f64 {
    if r2 > 0.0 { 0.5 * r2 * r2.ln() } else { 0.0 }
}

/// A 2D thin-plate spline `f: R^2 -> R^2` interpolating values at centres:
///
/// ```text
/// f(p) = a + A p + sum_i w_i phi(|p - c_i|),   phi(r) = r^2 log r,
/// sum_i w_i = 0,   sum_i w_i c_i^T = 0          (side conditions)
/// ```
///
/// the minimizer of the bending energy
/// `integral |d2f/dx2|^2 + 2 |d2f/dxdy|^2 + |d2f/dy2|^2` among the
/// interpolants of the data. It reproduces affine maps exactly (`w = 0`).
///
/// Internally the centres are centred and scaled (`q = (p - m) / s`); the
/// spline is invariant under similarities, so this only improves the
/// conditioning (`a`, `A`, `w` are stored in the normalized coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct ThinPlateSpline2 {
    /// Normalized centres `(c_i - m) / s`.
    centers: Vec<[f64; 2]>,
    /// Radial weights `w_i` (one 2-vector per centre).
    weights: Vec<[f64; 2]>,
    /// Affine part per output coordinate `k`: `f_k = aff[k][0] +
    /// aff[k][1] q_x + aff[k][2] q_y + ...`.
    affine: [[f64; 3]; 2],
    /// Normalization: `q = (p - shift) / scale`.
    shift: [f64; 2],
    scale: f64,
}

impl ThinPlateSpline2 {
    /// Fits the spline with `f(c_i) = v_i` by solving the dense saddle-point
    /// system (nalgebra LU)
    ///
    /// ```text
    /// [ K   P ] [w]   [v]      K_ij = phi(|c_i - c_j|),
    /// [ P^T 0 ] [a] = [0],     P = [1, c_x, c_y]   (n x 3)
    /// ```
    ///
    /// Cost `O(n^3)`: meant for up to a few thousand centres.
    ///
    /// # Errors
    /// [`LinalgError::DimensionMismatch`] when `values.len() !=
    /// centers.len()`; [`LinalgError::NotFinite`] for a non-finite
    /// coordinate (the index of the centre or value);
    /// [`LinalgError::TooFewPoints`] with fewer than 3 centres;
    /// [`LinalgError::CoincidentPoints`] for two centres closer than
    /// `1e-10` times the spread of the centres (duplicates);
    /// [`LinalgError::Collinear`] when all centres are (nearly) collinear
    /// (the affine part is then not determined); [`LinalgError::Singular`]
    /// when the LU fails, [`LinalgError::NotFinite`] when its solution is
    /// not finite.
    pub fn fit(centers: &[[f64; 2]], values: &[[f64; 2]]) -> Result<Self, LinalgError> {
        let n = centers.len();
        if values.len() != n {
            return Err(LinalgError::DimensionMismatch {
                what: "thin-plate spline values (one per centre)",
                expected: n,
                found: values.len(),
            });
        }
        if let Some(index) =
            (0..n).find(|&i| !centers[i].iter().chain(&values[i]).all(|v| v.is_finite()))
        {
            return Err(LinalgError::NotFinite {
                what: "thin-plate spline centre or value",
                index,
            });
        }
        if n < 3 {
            return Err(LinalgError::TooFewPoints {
                needed: 3,
                found: n,
            });
        }
        let shift = {
            let (sx, sy) = centers
                .iter()
                .fold((0.0, 0.0), |(x, y), c| (x + c[0], y + c[1]));
            [sx / n as f64, sy / n as f64]
        };
        let scale = centers
            .iter()
            .map(|c| ((c[0] - shift[0]).powi(2) + (c[1] - shift[1]).powi(2)).sqrt())
            .fold(0.0, f64::max);
        // (scale is finite and >= 0: the centres are finite.)
        if scale <= 0.0 {
            return Err(LinalgError::CoincidentPoints {
                first: 0,
                second: 1,
            });
        }
        let q: Vec<[f64; 2]> = centers
            .iter()
            .map(|c| [(c[0] - shift[0]) / scale, (c[1] - shift[1]) / scale])
            .collect();
        // Duplicates: sweep along x.
        let tol = 1e-10;
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| q[a][0].total_cmp(&q[b][0]));
        for (s, &a) in order.iter().enumerate() {
            for &b in &order[s + 1..] {
                if q[b][0] - q[a][0] > tol {
                    break;
                }
                if (q[b][1] - q[a][1]).abs() <= tol {
                    return Err(LinalgError::CoincidentPoints {
                        first: a.min(b),
                        second: a.max(b),
                    });
                }
            }
        }
        // Collinearity: the smallest eigenvalue of the 2x2 covariance.
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for c in &q {
            sxx += c[0] * c[0];
            sxy += c[0] * c[1];
            syy += c[1] * c[1];
        }
        let (sxx, sxy, syy) = (sxx / n as f64, sxy / n as f64, syy / n as f64);
        let tr = sxx + syy;
        let disc = ((sxx - syy).powi(2) + 4.0 * sxy * sxy).sqrt();
        let lmin = 0.5 * (tr - disc);
        let lmax = 0.5 * (tr + disc);
        if lmin.is_nan() || lmin <= 1e-12 * lmax {
            return Err(LinalgError::Collinear { count: n });
        }
        let size = n + 3;
        let mut m = DMatrix::<f64>::zeros(size, size);
        for i in 0..n {
            for j in i + 1..n {
                let r2 = (q[i][0] - q[j][0]).powi(2) + (q[i][1] - q[j][1]).powi(2);
                let k = tps_phi(r2);
                m[(i, j)] = k;
                m[(j, i)] = k;
            }
            let p = [1.0, q[i][0], q[i][1]];
            for (c, &pc) in p.iter().enumerate() {
                m[(i, n + c)] = pc;
                m[(n + c, i)] = pc;
            }
        }
        let mut rhs = DMatrix::<f64>::zeros(size, 2);
        for (i, v) in values.iter().enumerate() {
            rhs[(i, 0)] = v[0];
            rhs[(i, 1)] = v[1];
        }
        let sol = m.clone().lu().solve(&rhs).ok_or(LinalgError::Singular {
            what: "thin-plate spline system",
        })?;
        if let Some(index) = sol.iter().position(|v| !v.is_finite()) {
            return Err(LinalgError::NotFinite {
                what: "thin-plate spline solution (column-major)",
                index,
            });
        }
        let weights = (0..n).map(|i| [sol[(i, 0)], sol[(i, 1)]]).collect();
        let affine = [
            [sol[(n, 0)], sol[(n + 1, 0)], sol[(n + 2, 0)]],
            [sol[(n, 1)], sol[(n + 1, 1)], sol[(n + 2, 1)]],
        ];
        Ok(ThinPlateSpline2 {
            centers: q,
            weights,
            affine,
            shift,
            scale,
        })
    }

    /// Normalized coordinates of `p`.
    #[inline]
    fn normalize(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.shift[0]) / self.scale,
            (p[1] - self.shift[1]) / self.scale,
        ]
    }

    /// `f(p) = a + A p + sum_i w_i phi(|p - c_i|)`; interpolates the centres
    /// (`f(c_i) = v_i` up to round-off).
    pub fn eval(&self, p: [f64; 2]) -> [f64; 2] {
        let q = self.normalize(p);
        let mut f = self.affine.map(|a| a[0] + a[1] * q[0] + a[2] * q[1]);
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let phi = tps_phi((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2));
            f[0] += w[0] * phi;
            f[1] += w[1] * phi;
        }
        f
    }

    /// [`Self::eval`] at many points (in parallel).
    pub fn eval_many(&self, points: &[[f64; 2]]) -> Vec<[f64; 2]> {
        points.par_iter().map(|&p| self.eval(p)).collect()
    }

    /// The Jacobian `df/dp` at `p` (row `k` = gradient of `f_k`):
    ///
    /// ```text
    /// df/dp = A + sum_i w_i (2 log r_i + 1) (p - c_i)^T,   r_i = |p - c_i|
    /// ```
    ///
    /// since `grad phi(|p - c|) = phi'(r)/r (p - c)` with
    /// `phi'(r)/r = 2 log r + 1` (the term vanishes at `r = 0`). Evaluated in
    /// the normalized coordinates and scaled by `dq/dp = 1/s`. Its
    /// determinant tells whether the warp folds at `p`.
    pub fn jacobian(&self, p: [f64; 2]) -> [[f64; 2]; 2] {
        let q = self.normalize(p);
        let mut j = [[0.0; 2]; 2];
        for (k, row) in j.iter_mut().enumerate() {
            row[0] = self.affine[k][1];
            row[1] = self.affine[k][2];
        }
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let d = [q[0] - c[0], q[1] - c[1]];
            let r2 = d[0] * d[0] + d[1] * d[1];
            if r2 > 0.0 {
                let g = r2.ln() + 1.0; // 2 log r + 1
                for k in 0..2 {
                    j[k][0] += w[k] * g * d[0];
                    j[k][1] += w[k] * g * d[1];
                }
            }
        }
        // dq/dp = 1/s.
        for row in j.iter_mut() {
            row[0] /= self.scale;
            row[1] /= self.scale;
        }
        j
    }

    /// The radial weights `w_i` (in the normalized coordinates; all zero
    /// when the data are affine).
    pub fn weights(&self) -> &[[f64; 2]] {
        &self.weights
    }

    /// Number of centres.
    pub fn num_centers(&self) -> usize {
        self.centers.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn tps_interpolates_its_centres(
            pts in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64, -5.0..5.0f64, -5.0..5.0f64), 3..40),
        ) {
            let centers: Vec<[f64; 2]> = pts.iter().map(|p| [p.0, p.1]).collect();
            let values: Vec<[f64; 2]> = pts.iter().map(|p| [p.2, p.3]).collect();
            match ThinPlateSpline2::fit(&centers, &values) {
                Ok(tps) => {
                    for (c, v) in centers.iter().zip(&values) {
                        let f = tps.eval(*c);
                        prop_assert!((f[0] - v[0]).abs() < 1e-7 && (f[1] - v[1]).abs() < 1e-7,
                            "f({:?}) = {:?}, expected {:?}", c, f, v);
                    }
                    let many = tps.eval_many(&centers);
                    prop_assert_eq!(many[0], tps.eval(centers[0]));
                }
                // Random centres may (rarely) nearly coincide or line up.
                Err(LinalgError::CoincidentPoints { .. } | LinalgError::Collinear { .. }) => {}
                Err(e) => prop_assert!(false, "{e}"),
            }
        }

        #[test]
        fn tps_reproduces_affine_maps(
            pts in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64), 4..30),
            aff in prop::array::uniform6(-3.0..3.0f64),
            probe in prop::array::uniform2(-15.0..15.0f64),
        ) {
            let centers: Vec<[f64; 2]> = pts.iter().map(|p| [p.0, p.1]).collect();
            let map = |p: [f64; 2]| [aff[0] + aff[1] * p[0] + aff[2] * p[1],
                                     aff[3] + aff[4] * p[0] + aff[5] * p[1]];
            let values: Vec<[f64; 2]> = centers.iter().map(|&c| map(c)).collect();
            if let Ok(tps) = ThinPlateSpline2::fit(&centers, &values) {
                let scale = 1.0 + aff.iter().fold(0.0f64, |m, v| m.max(v.abs())) * 30.0;
                for w in tps.weights() {
                    prop_assert!(w[0].abs() < 1e-8 * scale && w[1].abs() < 1e-8 * scale, "{:?}", w);
                }
                let (f, e) = (tps.eval(probe), map(probe));
                prop_assert!((f[0] - e[0]).abs() < 1e-7 * scale && (f[1] - e[1]).abs() < 1e-7 * scale);
                let j = tps.jacobian(probe);
                prop_assert!((j[0][0] - aff[1]).abs() < 1e-7 * scale && (j[1][1] - aff[5]).abs() < 1e-7 * scale);
            }
        }
    }

    #[test]
    fn tps_rejects_duplicate_collinear_and_too_few_centres() {
        let v3 = [[0.0, 0.0]; 3];
        let dup = ThinPlateSpline2::fit(
            &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
            &[[0.0; 2]; 4],
        );
        assert!(
            matches!(
                dup,
                Err(LinalgError::CoincidentPoints {
                    first: 1,
                    second: 3
                })
            ),
            "{dup:?}"
        );
        let line = ThinPlateSpline2::fit(
            &[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]],
            &[[0.0; 2]; 4],
        );
        assert!(
            matches!(line, Err(LinalgError::Collinear { count: 4 })),
            "{line:?}"
        );
        assert!(matches!(
            ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0]], &[[0.0; 2]; 2]),
            Err(LinalgError::TooFewPoints {
                needed: 3,
                found: 2
            })
        ));
        assert!(matches!(
            ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &v3[..2]),
            Err(LinalgError::DimensionMismatch {
                expected: 3,
                found: 2,
                ..
            })
        ));
        assert!(matches!(
            ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0], [0.0, f64::NAN]], &v3),
            Err(LinalgError::NotFinite { index: 2, .. })
        ));
        assert!(ThinPlateSpline2::fit(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &v3).is_ok());
    }

    #[test]
    fn tps_moves_an_interior_point_keeping_the_boundary_and_its_jacobian_is_exact() {
        // The ventricle use: boundary circle fixed, apex image moved to 0.
        let mut centers: Vec<[f64; 2]> = (0..24)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 24.0;
                [t.cos(), t.sin()]
            })
            .collect();
        let mut values = centers.clone();
        centers.push([0.2, -0.1]);
        values.push([0.0, 0.0]);
        let tps = ThinPlateSpline2::fit(&centers, &values).unwrap();
        let f = tps.eval([0.2, -0.1]);
        assert!(f[0].abs() < 1e-12 && f[1].abs() < 1e-12);
        assert!((tps.eval([1.0, 0.0])[0] - 1.0).abs() < 1e-12);
        assert_eq!(tps.num_centers(), 25);
        let h = 1e-6;
        for p in [[0.3, 0.4], [-0.5, 0.1], [0.2, -0.1], [0.0, 0.9]] {
            let j = tps.jacobian(p);
            for d in 0..2 {
                let mut pp = p;
                let mut pm = p;
                pp[d] += h;
                pm[d] -= h;
                let (fp, fm) = (tps.eval(pp), tps.eval(pm));
                for k in 0..2 {
                    let fd = (fp[k] - fm[k]) / (2.0 * h);
                    assert!(
                        (j[k][d] - fd).abs() < 1e-6,
                        "J[{k}][{d}] = {} vs {fd}",
                        j[k][d]
                    );
                }
            }
            // This mild warp does not fold.
            assert!(j[0][0] * j[1][1] - j[0][1] * j[1][0] > 0.0);
        }
    }
}
