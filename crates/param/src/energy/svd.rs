//! Signed (rotation-variant) SVDs of 2x2 and 3x3 matrices: `F = U diag(s) V^T`
//! with `U`, `V` proper rotations and the sign of `det F` on the smallest
//! singular value.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// `sqrt(a^2 + b^2)`: the plain formula (several times faster than
/// `f64::hypot`), falling back to `hypot` where the squares overflow or
/// underflow.
#[inline]
pub(super) fn norm2(a: f64, b: f64) -> f64 {
    let r = (a * a + b * b).sqrt();
    if r.is_finite() && r > 1e-150 {
        r
    } else {
        a.hypot(b)
    }
}

/// Principal square root of the unit complex number `(x, y)`, i.e.
/// `(cos(a/2), sin(a/2))` for `a = atan2(y, x)` in `(-pi, pi]`, without
/// trigonometry and without cancellation.
#[inline]
fn half_angle(x: f64, y: f64) -> (f64, f64) {
    if x >= 0.0 {
        let c = (0.5 * (1.0 + x)).sqrt();
        (c, y / (2.0 * c))
    } else {
        let s = (0.5 * (1.0 - x))
            .sqrt()
            .copysign(if y < 0.0 { -1.0 } else { 1.0 });
        (y / (2.0 * s), s)
    }
}

/// Signed SVD of a 2x2 matrix, `F = U diag(s) V^T`, in closed form.
///
/// `U`, `V` are rotations (det +1), `s1 >= |s2|`, and `s2 < 0` iff
/// `det F < 0`. With `e = (f11 + f22)/2`, `f = (f11 - f22)/2`,
/// `g = (f21 + f12)/2`, `h = (f21 - f12)/2` (so `F = e I + h J + f K + g L`
/// with `J` the 90° rotation and `K`, `L` the two reflections):
///
/// ```text
/// q = |(e, h)|, r = |(f, g)|, a1 = atan2(g, f), a2 = atan2(h, e)
/// s1 = q + r,  s2 = det F / s1 (= q - r)
/// U = Rot((a2 + a1) / 2),  V = Rot((a2 - a1) / 2)^T
/// ```
///
/// evaluated with half-angle square roots instead of trigonometric calls.
/// Exact for repeated (`F` a scaled rotation: `r = 0`) and zero singular
/// values. Non-finite input gives non-finite output.
pub fn signed_svd2(f: &Matrix2<f64>) -> (Matrix2<f64>, Vector2<f64>, Matrix2<f64>) {
    let (m11, m12, m21, m22) = (f.m11, f.m12, f.m21, f.m22);
    let e = 0.5 * (m11 + m22);
    let ff = 0.5 * (m11 - m22);
    let g = 0.5 * (m21 + m12);
    let h = 0.5 * (m21 - m12);
    let q = norm2(e, h);
    let r = norm2(ff, g);
    // Unit complex numbers z1 = e^{i a1}, z2 = e^{i a2} (1 when undefined).
    let (c1, s1n) = if r > 0.0 { (ff / r, g / r) } else { (1.0, 0.0) };
    let (c2, s2n) = if q > 0.0 { (e / q, h / q) } else { (1.0, 0.0) };
    // e^{i phi} = sqrt(z1 z2) (phi = (a1 + a2)/2), e^{i theta} = e^{i phi} / z1.
    let (cp, sp) = half_angle(c1 * c2 - s1n * s2n, c1 * s2n + s1n * c2);
    let (ct, st) = (cp * c1 + sp * s1n, sp * c1 - cp * s1n);
    let u = Matrix2::new(cp, -sp, sp, cp);
    // V^T = Rot(theta), so V = Rot(-theta).
    let v = Matrix2::new(ct, st, -st, ct);
    let sv1 = q + r;
    let det = m11.mul_add(m22, -(m12 * m21));
    let sv2 = if sv1 > 0.0 { det / sv1 } else { 0.0 };
    (u, Vector2::new(sv1, sv2), v)
}

/// Signed SVD of a 3x3 matrix, `F = U diag(s) V^T`.
///
/// `U`, `V` are rotations (det +1), `s1 >= s2 >= |s3|` and `s3 < 0` iff
/// `det F < 0`. Computed by one-sided (Hestenes) Jacobi on the columns of
/// `F` (never forming `F^T F`), so all singular values are accurate to a few
/// ulps of `|F|` (nalgebra's special 3x3 path, eigenvectors of `F^T F` plus
/// QR, is off by up to ~1e-8 relative on ill-conditioned input, and slower):
///
/// ```text
/// B = F, V = I; sweep the pairs (p, q) until all columns are orthogonal:
///   a = |b_p|^2, b = |b_q|^2, c = b_p . b_q,  skip if c^2 <= eps^2 a b
///   z = (b - a) / (2 c), t = sign(z) / (|z| + sqrt(1 + z^2)),
///   cs = 1 / sqrt(1 + t^2), sn = t cs
///   [b_p, b_q] <- [cs b_p - sn b_q, sn b_p + cs b_q], same for V (det V stays 1)
/// sort the columns by |b_k| (swap + negate one column, det V stays 1)
/// u1 = b1 / |b1|, u2 = b2 - (u1.b2) u1 normalized, u3 = u1 x u2
/// s = (|b1|, |b2 - (u1.b2) u1|, u3.b3)   (det U = 1: s3 carries sign(det F))
/// ```
///
/// Robust for repeated singular values (any orthonormal basis of a repeated
/// subspace is returned; a rotation `F` gives `s = (1, 1, 1)`, `U V^T = F`) and zero ones
/// (the missing columns of `U` are completed orthonormally). Extreme
/// magnitudes are rescaled by a power of two first; non-finite input gives
/// `U = V = I`, `s = NaN`. No heap allocation.
#[allow(clippy::needless_range_loop)]
pub fn signed_svd3(f: &Matrix3<f64>) -> (Matrix3<f64>, Vector3<f64>, Matrix3<f64>) {
    if !f.iter().all(|x| x.is_finite()) {
        return (
            Matrix3::identity(),
            Vector3::repeat(f64::NAN),
            Matrix3::identity(),
        );
    }
    let amax = f.amax();
    if amax == 0.0 {
        return (Matrix3::identity(), Vector3::zeros(), Matrix3::identity());
    }
    // Power-of-two rescaling keeps the squared column norms in range.
    let scale = if (1e-50..=1e50).contains(&amax) {
        1.0
    } else {
        2f64.powi(-(amax.log2().round() as i32))
    };
    // Columns of B = F V and V as arrays (column-major).
    let mut b = [[0.0; 3]; 3];
    for c in 0..3 {
        for r in 0..3 {
            b[c][r] = f[(r, c)] * scale;
        }
    }
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let dot = |x: &[f64; 3], y: &[f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    {
        let [b0, b1, b2] = &mut b;
        let [v0, v1, v2] = &mut v;
        for _sweep in 0..JACOBI_MAX_SWEEPS {
            let r01 = jacobi_rotate(b0, b1, v0, v1);
            let r02 = jacobi_rotate(b0, b2, v0, v2);
            let r12 = jacobi_rotate(b1, b2, v1, v2);
            if !(r01 || r02 || r12) {
                break;
            }
        }
    }
    // Sort by decreasing column norm; a swap negates one column so that
    // det V stays +1 (B = F V still holds).
    let mut n = [dot(&b[0], &b[0]), dot(&b[1], &b[1]), dot(&b[2], &b[2])];
    for (p, q) in [(0, 1), (1, 2), (0, 1)] {
        if n[p] < n[q] {
            n.swap(p, q);
            b.swap(p, q);
            v.swap(p, q);
            for r in 0..3 {
                b[q][r] = -b[q][r];
                v[q][r] = -v[q][r];
            }
        }
    }
    // U from the orthogonal columns of B, completed to a rotation.
    let s1 = n[0].sqrt();
    let u1 = if s1 > 0.0 {
        [b[0][0] / s1, b[0][1] / s1, b[0][2] / s1]
    } else {
        [1.0, 0.0, 0.0]
    };
    let k = dot(&u1, &b[1]);
    let mut u2 = [
        b[1][0] - k * u1[0],
        b[1][1] - k * u1[1],
        b[1][2] - k * u1[2],
    ];
    let mut m2 = dot(&u2, &u2).sqrt();
    if m2 > f64::MIN_POSITIVE {
        for x in &mut u2 {
            *x /= m2;
        }
    } else {
        m2 = 0.0;
        u2 = any_orthogonal(&u1);
    }
    let u3 = [
        u1[1] * u2[2] - u1[2] * u2[1],
        u1[2] * u2[0] - u1[0] * u2[2],
        u1[0] * u2[1] - u1[1] * u2[0],
    ];
    // Rounding can leave |s3| or s2 a few ulps above the previous value
    // (equal singular values); clamp to keep the order exact.
    let s2 = m2.min(s1);
    let s3 = dot(&u3, &b[2]);
    let s3 = if s3.abs() > s2 { s2.copysign(s3) } else { s3 };
    let s = Vector3::new(s1, s2, s3) / scale;
    let u = Matrix3::new(
        u1[0], u2[0], u3[0], //
        u1[1], u2[1], u3[1], //
        u1[2], u2[2], u3[2],
    );
    let v = Matrix3::new(
        v[0][0], v[1][0], v[2][0], //
        v[0][1], v[1][1], v[2][1], //
        v[0][2], v[1][2], v[2][2],
    );
    (u, s, v)
}

/// One Jacobi rotation of [`signed_svd3`] orthogonalizing the columns `bp`,
/// `bq` (and rotating `vp`, `vq` alike); false if already orthogonal to
/// rounding (`(bp.bq)^2 <= eps^2 |bp|^2 |bq|^2`).
#[inline(always)]
fn jacobi_rotate(
    bp: &mut [f64; 3],
    bq: &mut [f64; 3],
    vp: &mut [f64; 3],
    vq: &mut [f64; 3],
) -> bool {
    let alpha = bp[0] * bp[0] + bp[1] * bp[1] + bp[2] * bp[2];
    let beta = bq[0] * bq[0] + bq[1] * bq[1] + bq[2] * bq[2];
    let gamma = bp[0] * bq[0] + bp[1] * bq[1] + bp[2] * bq[2];
    if gamma == 0.0 || gamma * gamma <= f64::EPSILON * f64::EPSILON * alpha * beta {
        return false;
    }
    // t = sign(z) / (|z| + sqrt(1 + z^2)) with z = (beta - alpha) / (2 gamma),
    // rewritten with one division (shorter latency chain).
    let (dd, g2) = (beta - alpha, 2.0 * gamma);
    let t = g2 / (dd + (dd * dd + g2 * g2).sqrt().copysign(dd));
    let cs = 1.0 / (1.0 + t * t).sqrt();
    let sn = cs * t;
    for r in 0..3 {
        let (x, y) = (bp[r], bq[r]);
        bp[r] = cs * x - sn * y;
        bq[r] = sn * x + cs * y;
        let (x, y) = (vp[r], vq[r]);
        vp[r] = cs * x - sn * y;
        vq[r] = sn * x + cs * y;
    }
    true
}

/// Sweeps of [`signed_svd3`]'s Jacobi iteration before it stops anyway
/// (convergence is quadratic; 4 to 6 sweeps are typical).
pub(super) const JACOBI_MAX_SWEEPS: usize = 30;

/// A unit vector orthogonal to the unit vector `a`.
fn any_orthogonal(a: &[f64; 3]) -> [f64; 3] {
    // Cross with the axis least aligned with a.
    let (x, y, z) = (a[0].abs(), a[1].abs(), a[2].abs());
    let w = if x <= y && x <= z {
        [0.0, -a[2], a[1]]
    } else if y <= z {
        [a[2], 0.0, -a[0]]
    } else {
        [-a[1], a[0], 0.0]
    };
    let m = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    [w[0] / m, w[1] / m, w[2] / m]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::test_support::*;
    use proptest::prelude::*;

    fn check_svd3(f: &Matrix3<f64>) {
        let (u, s, v) = signed_svd3(f);
        let rec = u * Matrix3::from_diagonal(&s) * v.transpose();
        let scale = f.norm().max(1e-300);
        assert!(
            (rec - f).norm() <= 1e-12 * scale,
            "reconstruction {f} {rec}"
        );
        assert!((u.determinant() - 1.0).abs() < 1e-12, "det U");
        assert!((v.determinant() - 1.0).abs() < 1e-12, "det V");
        assert!((u.transpose() * u - Matrix3::identity()).norm() < 1e-12);
        assert!((v.transpose() * v - Matrix3::identity()).norm() < 1e-12);
        assert!(s[0] >= 0.0 && s[1] >= 0.0, "{s}");
        assert!(s[0] >= s[1] && s[1] >= s[2].abs(), "order {s}");
        let det = f.determinant();
        if det.abs() > 1e-10 * scale.powi(3) {
            assert_eq!(s[2] < 0.0, det < 0.0, "sign {s} det {det}");
        }
    }

    fn check_svd2(f: &Matrix2<f64>) {
        let (u, s, v) = signed_svd2(f);
        let rec = u * Matrix2::from_diagonal(&s) * v.transpose();
        let scale = f.norm().max(1e-300);
        assert!(
            (rec - f).norm() <= 1e-12 * scale,
            "reconstruction {f} {rec}"
        );
        assert!((u.determinant() - 1.0).abs() < 1e-12, "det U");
        assert!((v.determinant() - 1.0).abs() < 1e-12, "det V");
        assert!((u.transpose() * u - Matrix2::identity()).norm() < 1e-12);
        assert!((v.transpose() * v - Matrix2::identity()).norm() < 1e-12);
        assert!(s[0] >= s[1].abs(), "order {s}");
        let det = f.determinant();
        if det.abs() > 1e-10 * scale.powi(2) {
            assert_eq!(s[1] < 0.0, det < 0.0, "sign {s} det {det}");
        }
    }

    #[test]
    fn energy_signed_svd3_special_matrices() {
        let r = rot3([0.3, -0.5, 0.7, 0.2]);
        let cases = [
            Matrix3::identity(),
            r,
            -r,
            Matrix3::from_diagonal(&Vector3::new(2.0, 2.0, 1.0)),
            Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 2.0)),
            Matrix3::from_diagonal(&Vector3::new(1.0, -2.0, 3.0)),
            Matrix3::from_diagonal(&Vector3::new(-1.0, -1.0, -1.0)),
            r * Matrix3::from_diagonal(&Vector3::new(2.0, 2.0, 1.0)) * r.transpose(),
            Matrix3::from_diagonal(&Vector3::new(1.0, 0.0, 0.0)),
            Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)),
            Matrix3::zeros(),
            Matrix3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0),
            Matrix3::new(1.0, 1e-9, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0 + 1e-12),
            r * 1e120,
            r * 1e-120,
            r * 1e60,
            r * 3e49,
            r * 1e-60,
            Matrix3::from_diagonal(&Vector3::new(1e90, 1.0, -1e-90)),
            Matrix3::from_diagonal(&Vector3::new(1e-300, 1e-310, 0.0)),
            Matrix3::from_diagonal(&Vector3::new(1.0, 1e-8, -1e-9)),
        ];
        for f in cases {
            check_svd3(&f);
        }
        let (u, s, v) = signed_svd3(&r);
        assert_close(s.as_slice(), &[1.0, 1.0, 1.0], 1e-14, "rotation");
        assert!((u * v.transpose() - r).norm() < 1e-13);
        let (_, s, _) = signed_svd3(&Matrix3::from_diagonal(&Vector3::new(2.0, 2.0, 1.0)));
        assert_close(s.as_slice(), &[2.0, 2.0, 1.0], 1e-14, "diag(2,2,1)");
        let (_, s, _) = signed_svd3(&Matrix3::from_diagonal(&Vector3::new(1.0, -2.0, 3.0)));
        assert_close(s.as_slice(), &[3.0, 2.0, -1.0], 1e-14, "diag(1,-2,3)");
        let (_, s, _) = signed_svd3(&(-r));
        assert_close(s.as_slice(), &[1.0, 1.0, -1.0], 1e-14, "minus rotation");
        let (u, s, v) = signed_svd3(&Matrix3::from_element(f64::NAN));
        assert!(s.iter().all(|x| x.is_nan()));
        assert_eq!((u, v), (Matrix3::identity(), Matrix3::identity()));
    }

    #[test]
    fn energy_signed_svd2_special_matrices() {
        let r = rot2(0.7);
        let cases = [
            Matrix2::identity(),
            r,
            -r,
            r * 2.0,
            Matrix2::new(1.0, 0.0, 0.0, -1.0),
            Matrix2::new(0.0, 1.0, 1.0, 0.0),
            Matrix2::new(-1.0, 0.0, 0.0, 1.0),
            Matrix2::new(2.0, 0.0, 0.0, 1.0),
            Matrix2::new(-2.0, 0.0, 0.0, -1.0),
            Matrix2::new(1.0, 0.0, 0.0, 0.0),
            Matrix2::new(0.0, 0.0, 0.0, 1.0),
            Matrix2::new(1.0, 2.0, 2.0, 4.0),
            Matrix2::new(-1.0, 0.0, 1e-300, -1.0),
            Matrix2::zeros(),
            Matrix2::new(1.0, 2.0, 3.0, 4.0),
        ];
        for f in cases {
            check_svd2(&f);
        }
        let (_, s, _) = signed_svd2(&Matrix2::new(1.0, 0.0, 0.0, -1.0));
        assert_close(s.as_slice(), &[1.0, -1.0], 1e-15, "reflection");
        let (_, s, _) = signed_svd2(&(-r));
        assert_close(s.as_slice(), &[1.0, 1.0], 1e-15, "minus rotation");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn energy_signed_svd3_reconstructs(m in prop::array::uniform9(-2.0f64..2.0)) {
            check_svd3(&Matrix3::from_column_slice(&m));
        }

        #[test]
        fn energy_signed_svd3_agrees_with_nalgebra(m in prop::array::uniform9(-2.0f64..2.0)) {
            let f = Matrix3::from_column_slice(&m);
            let (_, s, _) = signed_svd3(&f);
            let reference = f.singular_values();
            let abs = s.map(f64::abs);
            assert_close(abs.as_slice(), reference.as_slice(), 1e-13, "singular values");
        }

        #[test]
        fn energy_signed_svd2_reconstructs(m in prop::array::uniform4(-2.0f64..2.0)) {
            check_svd2(&Matrix2::from_column_slice(&m));
        }

        #[test]
        fn energy_signed_svd_recovers_singular_values((f, s) in well_shaped3(), (f2, s2) in well_shaped2()) {
            let (_, sv, _) = signed_svd3(&f);
            let mut want = s;
            want.sort_by(|a, b| b.total_cmp(a));
            assert_close(sv.as_slice(), &want, 1e-12, "svd3");
            let (_, sv, _) = signed_svd2(&f2);
            let mut want = s2;
            want.sort_by(|a, b| b.total_cmp(a));
            assert_close(sv.as_slice(), &want, 1e-12, "svd2");
        }
    }
}
