//! Principal component analysis of a point set: the principal-axes frame.

use super::centroid;
use nalgebra::{Matrix3, Point3, Rotation3, SymmetricEigen, Vector3};

/// A principal-axes frame of a point set (see [`pca_frame`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcaFrame {
    /// The vertex mean `c`.
    pub centroid: Point3<f64>,
    /// Rows are the principal axes `e_0, e_1, e_2` by decreasing variance, so
    /// `rotation * (p - c)` has the largest variance on x and the smallest on
    /// z. A proper rotation (`det = +1`, `e_2 = e_0 × e_1`).
    pub rotation: Rotation3<f64>,
    /// Variances along the axes, `lambda_0 >= lambda_1 >= lambda_2 >= 0`
    /// (eigenvalues of the covariance, tiny negative round-off clamped to 0).
    pub variances: [f64; 3],
}

impl PcaFrame {
    /// Coordinates of `p` in the frame: `R (p - c)`.
    pub fn to_local(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * (p - self.centroid))
    }

    /// World position of local coordinates `q`: `c + R^T q`.
    pub fn to_world(&self, q: &Point3<f64>) -> Point3<f64> {
        self.centroid + self.rotation.inverse() * q.coords
    }

    /// The `i`-th principal axis (unit vector, `i < 3`), row `i` of `rotation`.
    pub fn axis(&self, i: usize) -> Vector3<f64> {
        self.rotation.matrix().row(i).transpose()
    }
}

/// Flips `v` so that its largest-magnitude component (the first one on ties)
/// is positive.
fn canonical_sign(v: Vector3<f64>) -> Vector3<f64> {
    let i = v.iamax();
    if v[i] < 0.0 { -v } else { v }
}

/// Principal component analysis of a point set.
///
/// With `c` the vertex mean and the (population) covariance
/// `C = (1/n) sum_i (p_i - c)(p_i - c)^T`, the eigen-decomposition
/// `C = sum_k lambda_k e_k e_k^T` (nalgebra's `SymmetricEigen`) gives the
/// axes, ordered so that `lambda_0 >= lambda_1 >= lambda_2`.
///
/// Signs are made deterministic, independent of the eigen solver: `e_0` and
/// `e_1` are flipped so that their largest-magnitude component (the first one
/// on exact ties) is positive, and `e_2 = e_0 × e_1`, which makes `rotation` a
/// proper rotation (`det = +1`). When eigenvalues coincide (e.g. an isotropic
/// cloud) the axes within that eigenspace are whatever the solver returns.
///
/// `None` for an empty slice or when a coordinate is not finite.
pub fn pca_frame(points: &[Point3<f64>]) -> Option<PcaFrame> {
    let c = centroid(points)?;
    if !c.coords.iter().all(|x| x.is_finite()) {
        return None;
    }
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - c;
        cov += d * d.transpose();
    }
    cov /= points.len() as f64;
    if !cov.iter().all(|x| x.is_finite()) {
        return None;
    }
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));

    let e0 = eig.eigenvectors.column(order[0]).into_owned();
    let e0 = canonical_sign(e0.try_normalize(0.0).unwrap_or_else(Vector3::x));
    let e1 = eig.eigenvectors.column(order[1]).into_owned();
    let e1 = e1 - e0 * e0.dot(&e1);
    let e1 = match e1.try_normalize(1e-12) {
        Some(e1) => e1,
        // Not reachable for an orthonormal eigenbasis; any perpendicular will do.
        None => {
            let helper = if e0.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            e0.cross(&helper).normalize()
        }
    };
    let e1 = canonical_sign(e1);
    let e2 = e0.cross(&e1).normalize();
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_rows(&[
        e0.transpose(),
        e1.transpose(),
        e2.transpose(),
    ]));
    let var = |k: usize| eig.eigenvalues[order[k]].max(0.0);
    Some(PcaFrame {
        centroid: c,
        rotation,
        variances: [var(0), var(1), var(2)],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::strategies::point;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    use crate::test_meshes::SplitMix as Rng;

    fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
            .prop_filter("non-zero quaternion", |q| {
                q.0 * q.0 + q.1 * q.1 + q.2 * q.2 + q.3 * q.3 > 0.05
            })
            .prop_map(|(w, x, y, z)| {
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
                    .to_rotation_matrix()
            })
    }

    fn cloud(
        seed: u64,
        n: usize,
        sigma: [f64; 3],
        rot: &Rotation3<f64>,
        shift: Vector3<f64>,
    ) -> Vec<Point3<f64>> {
        let mut rng = Rng(seed);
        (0..n)
            .map(|_| {
                let z = Vector3::new(
                    sigma[0] * rng.gaussian(),
                    sigma[1] * rng.gaussian(),
                    sigma[2] * rng.gaussian(),
                );
                Point3::from(rot * z + shift)
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Always a proper rotation with orthonormal rows, sorted variances and
        /// the documented sign convention.
        #[test]
        fn pca_frame_is_proper_and_sorted(
            seed in any::<u64>(), n in 1usize..200,
            s0 in 0.0..5.0f64, s1 in 0.0..5.0f64, s2 in 0.0..5.0f64,
            rot in rotation(), shift in point(),
        ) {
            let pts = cloud(seed, n, [s0, s1, s2], &rot, shift.coords);
            let f = pca_frame(&pts).unwrap();
            let m = f.rotation.matrix();
            prop_assert!((m.determinant() - 1.0).abs() < 1e-12);
            prop_assert!((m * m.transpose() - Matrix3::identity()).norm() < 1e-12);
            prop_assert!(f.variances[0] >= f.variances[1] && f.variances[1] >= f.variances[2]);
            prop_assert!(f.variances[2] >= 0.0);
            for i in 0..2 {
                let a = f.axis(i);
                prop_assert!(a[a.iamax()] > 0.0);
            }
            // Local coordinates have the variances on x, y, z and zero mean.
            let local: Vec<_> = pts.iter().map(|p| f.to_local(p)).collect();
            let scale = 1.0 + f.variances[0];
            for a in 0..3 {
                let mean = local.iter().map(|q| q[a]).sum::<f64>() / n as f64;
                let var = local.iter().map(|q| q[a] * q[a]).sum::<f64>() / n as f64;
                prop_assert!(mean.abs() < 1e-9 * (1.0 + shift.coords.norm()));
                prop_assert!((var - f.variances[a]).abs() < 1e-9 * scale);
            }
            prop_assert!((f.to_world(&local[0]) - pts[0]).norm() < 1e-9 * (1.0 + shift.coords.norm()));
        }

        /// Well-separated variances: the axes are the generating ones up to
        /// sign, the variances close to sigma^2.
        #[test]
        fn pca_recovers_generating_axes(
            seed in any::<u64>(), s0 in 3.0..5.0f64, r1 in 0.25..0.5f64, r2 in 0.25..0.5f64,
            rot in rotation(), shift in point(),
        ) {
            let sigma = [s0, s0 * r1, s0 * r1 * r2];
            let pts = cloud(seed, 4000, sigma, &rot, shift.coords);
            let f = pca_frame(&pts).unwrap();
            for (i, s) in sigma.iter().enumerate() {
                let truth = rot.matrix().column(i).into_owned();
                prop_assert!(f.axis(i).dot(&truth).abs() > 0.98, "axis {} off", i);
                prop_assert!((f.variances[i] / (s * s) - 1.0).abs() < 0.15);
            }
        }

        /// Rigid motions change neither the variances nor (up to the motion)
        /// the centroid.
        #[test]
        fn pca_variances_invariant_under_rigid_motion(
            seed in any::<u64>(), s0 in 0.1..5.0f64, s1 in 0.1..5.0f64, s2 in 0.1..5.0f64,
            rot in rotation(), motion in rotation(), t in point(),
        ) {
            let pts = cloud(seed, 300, [s0, s1, s2], &rot, Vector3::zeros());
            let moved: Vec<_> = pts.iter().map(|p| motion * p + t.coords).collect();
            let (f, g) = (pca_frame(&pts).unwrap(), pca_frame(&moved).unwrap());
            for k in 0..3 {
                prop_assert!((f.variances[k] - g.variances[k]).abs() < 1e-9 * (1.0 + f.variances[0]));
            }
            prop_assert!((motion * f.centroid + t.coords - g.centroid).norm() < 1e-9);
        }
    }

    #[test]
    fn pca_degenerate_inputs() {
        assert!(pca_frame(&[]).is_none());
        assert!(pca_frame(&[Point3::new(f64::NAN, 0.0, 0.0)]).is_none());
        let one = pca_frame(&[Point3::new(1.0, 2.0, 3.0)]).unwrap();
        assert_eq!(one.variances, [0.0; 3]);
        assert_relative_eq!(one.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
        // Points on a line along y: first axis is +y.
        let line: Vec<_> = (0..10).map(|i| Point3::new(1.0, i as f64, 2.0)).collect();
        let f = pca_frame(&line).unwrap();
        assert_relative_eq!(f.axis(0), Vector3::y(), epsilon = 1e-12);
        assert_relative_eq!(f.variances[0], 8.25, epsilon = 1e-12);
        assert!(f.variances[1].abs() < 1e-12);
        assert_relative_eq!(f.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
    }
}
