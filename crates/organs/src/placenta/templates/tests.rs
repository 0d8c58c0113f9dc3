//! Tests of the placenta templates.

use super::*;
use crate::ConfigError;
use crate::placenta::side;
use proptest::prelude::*;
use unfold_param::template::check::template_derivatives;
use unfold_param::template::{weighted_theta_gradient, weighted_value};

const LABELS: [u8; 4] = [side::INTERIOR, side::FETAL, side::MATERNAL, side::MARGIN];

// `|a - b| <= rel * max(scale, 1)` componentwise.
fn assert_close(a: &[f64], b: &[f64], rel: f64, what: &str) {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().chain(b).fold(1.0f64, |m, v| m.max(v.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= rel * scale,
            "{what}[{i}]: {x} vs {y} (scale {scale})"
        );
    }
}

fn step(v: f64) -> f64 {
    1e-5 * v.abs().max(1.0)
}

/// Row-major FD Hessian from the analytic gradient.
fn fd_hessian(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) -> Vec<f64> {
    let d = x.len();
    let mut out = vec![0.0; d * d];
    let (mut gp, mut gm) = (vec![0.0; d], vec![0.0; d]);
    for j in 0..d {
        let h = step(x[j]);
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        t.gradient(v, label, &xp, theta, &mut gp);
        t.gradient(v, label, &xm, theta, &mut gm);
        for i in 0..d {
            out[i * d + j] = (gp[i] - gm[i]) / (2.0 * h);
        }
    }
    out
}

fn analytic(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) -> [Vec<f64>; 3] {
    let d = x.len();
    let mut g = vec![0.0; d];
    let mut h = vec![0.0; d * d];
    let mut gt = vec![0.0; theta.len()];
    t.gradient(v, label, x, theta, &mut g);
    t.hessian(v, label, x, theta, &mut h);
    t.theta_gradient(v, label, x, theta, &mut gt);
    [g, h, gt]
}

/// The derivative check of `unfold_param::template::check`, as a test
/// assertion.
fn check_template(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) {
    if let Err(m) = template_derivatives(t, v, label, x, theta, 1e-6) {
        panic!(
            "{} at label {label}, x {x:?}, theta {theta:?}: {m}",
            t.name()
        );
    }
}

fn label_strategy() -> impl Strategy<Value = u8> {
    prop::sample::select(LABELS.to_vec())
}

fn point3(r: f64) -> impl Strategy<Value = [f64; 3]> {
    [-r..r, -r..r, -r..r]
}

#[test]
fn template_trait_objects_describe_themselves() {
    let ts: Vec<Box<dyn Template>> = vec![
        Box::new(ParallelPlanes::new()),
        Box::new(ParallelPlanes::single_plane()),
        Box::new(Ellipsoid::new()),
    ];
    let names: Vec<_> = ts.iter().map(|t| t.name()).collect();
    assert_eq!(names, ["planes", "single-plane", "ellipsoid",]);
    let n: Vec<_> = ts.iter().map(|t| t.parameter_names().len()).collect();
    assert_eq!(n, [1, 1, 3]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn template_planes_derivatives_match_fd(
        x in point3(50.0), h in -30.0..30.0f64, label in label_strategy(),
        fw in 0.0..3.0f64, mw in 0.0..3.0f64,
    ) {
        let t = ParallelPlanes::with_weights(fw, mw).unwrap();
        check_template(&t, 0, label, &x, &[h]);
        check_template(&SinglePlane { maternal_weight: mw, optimize_h: false }, 0, label, &x, &[h]);
    }

    #[test]
    fn template_ellipsoid_derivatives_match_fd(
        x in point3(30.0), r in [3.0..20.0f64, 3.0..20.0f64, 3.0..20.0f64],
        label in label_strategy(), margin in any::<bool>(),
    ) {
        let t = Ellipsoid { include_margin: margin };
        check_template(&t, 0, label, &x, &r);
        // The unprojected Hessian matches FD everywhere.
        if t.applies(label) {
            let fd_h = fd_hessian(&t, 0, label, &x, &r);
            let exact = Ellipsoid::exact_hessian(&x, &r);
            let exact: Vec<f64> = (0..9).map(|k| exact[(k / 3, k % 3)]).collect();
            assert_close(&exact, &fd_h, 1e-6, "exact d2T/dx2");
        }
    }

    #[test]
    fn template_ellipsoid_projection_is_exact_outside(
        dir in point3(1.0), s in 1.0..3.0f64, r in [3.0..20.0f64, 3.0..20.0f64, 3.0..20.0f64],
    ) {
        // Points with q >= 1: the exact Hessian is PSD and kept as is.
        let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        prop_assume!(n > 1e-3);
        let x: Vec<f64> = (0..3).map(|i| s * r[i] * dir[i] / n).collect();
        let t = Ellipsoid::new();
        let [_, h, _] = analytic(&t, 0, side::FETAL, &x, &r);
        let exact = Ellipsoid::exact_hessian(&x, &r);
        let exact: Vec<f64> = (0..9).map(|k| exact[(k / 3, k % 3)]).collect();
        assert_close(&h, &exact, 1e-12, "projected = exact");
    }

    #[test]
    fn template_ellipsoid_is_zero_on_its_surface(
        phi in 0.0..std::f64::consts::PI, psi in 0.0..std::f64::consts::TAU,
        r in [1.0..50.0f64, 1.0..50.0f64, 1.0..50.0f64], label in 1u8..4,
    ) {
        let x = [r[0] * phi.sin() * psi.cos(), r[1] * phi.sin() * psi.sin(), r[2] * phi.cos()];
        let t = Ellipsoid::new();
        prop_assert!(t.value(0, label, &x, &r) < 1e-24);
        let [g, _, gt] = analytic(&t, 0, label, &x, &r);
        prop_assert!(g.iter().chain(&gt).all(|v| v.abs() < 1e-10));
    }

    #[test]
    fn template_planes_are_zero_on_their_planes(
        xy in [-50.0..50.0f64, -50.0..50.0f64], z in -50.0..50.0f64, h in -30.0..30.0f64,
    ) {
        let t = ParallelPlanes::new();
        let fetal = [xy[0], xy[1], h];
        let maternal = [xy[0], xy[1], -h];
        let other = [xy[0], xy[1], z];
        for (label, x) in [(side::FETAL, fetal), (side::MATERNAL, maternal),
                           (side::MARGIN, other), (side::INTERIOR, other)] {
            prop_assert_eq!(t.value(0, label, &x, &[h]), 0.0);
            let [g, _, gt] = analytic(&t, 0, label, &x, &[h]);
            prop_assert!(g.iter().chain(&gt).all(|v| *v == 0.0));
        }
        // The single plane ignores the fetal side wherever it is.
        prop_assert_eq!(SinglePlane::new().value(0, side::FETAL, &other, &[h]), 0.0);
        prop_assert_eq!(SinglePlane::new().value(0, side::MATERNAL, &maternal, &[h]), 0.0);
    }

    #[test]
    fn template_planes_update_is_the_exact_minimizer(
        pts in prop::collection::vec((point3(40.0), label_strategy(), 0.0..1.0f64), 1..40),
        fw in 0.0..2.0f64, mw in 0.0..2.0f64,
    ) {
        let labels: Vec<u8> = pts.iter().map(|p| p.1).collect();
        let xs: Vec<f64> = pts.iter().flat_map(|p| p.0).collect();
        let weights: Vec<f64> = pts.iter().map(|p| p.2).collect();
        let t = ParallelPlanes { fetal_weight: fw, maternal_weight: mw };
        let den: f64 = pts.iter().map(|p| match p.1 {
            side::FETAL => fw * p.2, side::MATERNAL => mw * p.2, _ => 0.0 }).sum();
        let mut theta = [7.0];
        let updated = t.update_theta(&labels, &xs, 3, &weights, &mut theta);
        prop_assert_eq!(updated, den > 1e-9);
        prop_assume!(den > 1e-3);
        let h = theta[0];
        // Stationary ...
        let g = weighted_theta_gradient(&t, &labels, &xs, 3, &weights, &theta)[0];
        let f = |h: f64| weighted_value(&t, &labels, &xs, 3, &weights, &[h]);
        prop_assert!(g.abs() <= 1e-9 * (1.0 + den * 40.0), "dphi/dh = {}", g);
        // ... and the same as a brute-force golden-section search.
        let (mut a, mut b) = (-60.0f64, 60.0f64);
        let ratio = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..200 {
            let (c, d) = (b - ratio * (b - a), a + ratio * (b - a));
            if f(c) < f(d) { b = d } else { a = c }
        }
        let brute = 0.5 * (a + b);
        prop_assert!((brute - h).abs() <= 1e-5, "{} vs {}", brute, h);
        prop_assert!(f(h) <= f(brute) + 1e-12 * (1.0 + f(brute)));
    }

    #[test]
    fn template_ellipsoid_update_decreases_and_is_stationary(
        pts in prop::collection::vec(
            ([0.0..std::f64::consts::PI, 0.0..std::f64::consts::TAU], -0.2..0.2f64,
             1u8..4, 0.1..1.0f64), 12..60),
        r in [5.0..30.0f64, 5.0..30.0f64, 3.0..15.0f64],
        start in [0.5..2.0f64, 0.5..2.0f64, 0.5..2.0f64],
    ) {
        let labels: Vec<u8> = pts.iter().map(|p| p.2).collect();
        let weights: Vec<f64> = pts.iter().map(|p| p.3).collect();
        let xs: Vec<f64> = pts.iter().flat_map(|([phi, psi], noise, _, _)| {
            let s = 1.0 + noise;
            [s * r[0] * phi.sin() * psi.cos(), s * r[1] * phi.sin() * psi.sin(),
             s * r[2] * phi.cos()]
        }).collect();
        let t = Ellipsoid::new();
        let mut theta: Vec<f64> = (0..3).map(|i| r[i] * start[i]).collect();
        let before = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
        prop_assert!(t.update_theta(&labels, &xs, 3, &weights, &mut theta));
        prop_assert!(theta.iter().all(|r| r.is_finite() && *r > 0.0));
        let after = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
        prop_assert!(after <= before * (1.0 + 1e-12), "{} -> {}", before, after);
        let mut again = theta.clone();
        t.update_theta(&labels, &xs, 3, &weights, &mut again);
        let after2 = weighted_value(&t, &labels, &xs, 3, &weights, &again);
        prop_assert!(after2 <= after * (1.0 + 1e-12));
        // In a = r^-2 the penalty is linear least squares,
        // sum w (q . a - 1)^2 with q = (x1^2, x2^2, x3^2). When its
        // minimizer is interior (every a_i > 0, well-determined) the
        // update reaches it and dphi/dtheta vanishes; otherwise the
        // minimizer lies at a radius -> infinity, which the update
        // rightly stops short of (only the decrease is asserted).
        let mut m = nalgebra::Matrix3::<f64>::zeros();
        let mut b = nalgebra::Vector3::<f64>::zeros();
        for (k, w) in weights.iter().enumerate() {
            let q = nalgebra::Vector3::new(xs[3 * k].powi(2), xs[3 * k + 1].powi(2), xs[3 * k + 2].powi(2));
            m += *w * q * q.transpose();
            b += *w * q;
        }
        let eig = m.symmetric_eigenvalues();
        let well_posed = eig.min() > 1e-8 * eig.max();
        let interior = well_posed && m.lu().solve(&b).is_some_and(|a| a.iter().all(|&ai| ai > 0.0));
        if interior {
            let g = weighted_theta_gradient(&t, &labels, &xs, 3, &weights, &again);
            let scale: f64 = weights.iter().sum::<f64>() / theta.iter().fold(f64::INFINITY, |a, b| a.min(*b));
            prop_assert!(g.iter().all(|g| g.abs() <= 1e-6 * scale), "{:?}", g);
        }
    }
}

#[test]
fn template_ellipsoid_update_recovers_radii() {
    let r = [40.0, 25.0, 12.0];
    let mut labels = Vec::new();
    let mut xs = Vec::new();
    for i in 0..10 {
        for j in 0..20 {
            let (phi, psi) = (0.1 + 0.3 * i as f64, 0.31 * j as f64);
            xs.extend([
                r[0] * phi.sin() * psi.cos(),
                r[1] * phi.sin() * psi.sin(),
                r[2] * phi.cos(),
            ]);
            labels.push(LABELS[1 + (i + j) % 3]);
        }
    }
    // An interior vertex far away must not count.
    labels.push(side::INTERIOR);
    xs.extend([500.0, 0.0, 0.0]);
    let weights = vec![1.0 / labels.len() as f64; labels.len()];
    let mut theta = [10.0, 60.0, 30.0];
    assert!(Ellipsoid::new().update_theta(&labels, &xs, 3, &weights, &mut theta));
    for i in 0..3 {
        assert!((theta[i] - r[i]).abs() < 1e-9 * r[i], "{theta:?}");
    }
}

#[test]
fn template_ellipsoid_update_keeps_unconstrained_radii() {
    // All points in z = 0: rz is not determined and must stay.
    let labels = vec![side::FETAL; 8];
    let xs: Vec<f64> = (0..8)
        .flat_map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 8.0;
            [20.0 * a.cos(), 10.0 * a.sin(), 0.0]
        })
        .collect();
    let weights = vec![1.0; 8];
    let mut theta = [15.0, 15.0, 7.0];
    let t = Ellipsoid::new();
    let before = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
    assert!(t.update_theta(&labels, &xs, 3, &weights, &mut theta));
    assert!(weighted_value(&t, &labels, &xs, 3, &weights, &theta) < 1e-20 * before);
    assert!((theta[0] - 20.0).abs() < 1e-9 && (theta[1] - 10.0).abs() < 1e-9);
    assert!((theta[2] - 7.0).abs() < 1e-9);
}

#[test]
fn template_ellipsoid_update_stays_positive_when_the_fit_is_not_an_ellipsoid() {
    // Points on a hyperboloid x^2/10^2 + y^2/10^2 - z^2/5^2 = 1: the
    // unconstrained least-squares fit has a negative a_z.
    let mut xs = Vec::new();
    for i in 0..6 {
        for j in 0..12 {
            let (u, v) = (-1.0 + 0.4 * i as f64, 0.5 * j as f64);
            xs.extend([
                10.0 * u.cosh() * v.cos(),
                10.0 * u.cosh() * v.sin(),
                5.0 * u.sinh(),
            ]);
        }
    }
    let n = xs.len() / 3;
    let labels = vec![side::MATERNAL; n];
    let weights = vec![1.0; n];
    let t = Ellipsoid::new();
    let mut theta = [10.0, 10.0, 5.0];
    let mut last = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
    for _ in 0..5 {
        assert!(t.update_theta(&labels, &xs, 3, &weights, &mut theta));
        assert!(theta.iter().all(|r| r.is_finite() && *r > 0.0), "{theta:?}");
        let now = weighted_value(&t, &labels, &xs, 3, &weights, &theta);
        assert!(now <= last * (1.0 + 1e-12));
        last = now;
    }
}

#[test]
fn template_update_rejects_inconsistent_arguments() {
    let labels = [side::FETAL, side::MATERNAL];
    let xs = [0.0, 0.0, 1.0, 0.0, 0.0, -1.0];
    let w = [1.0, 1.0];
    let mut h = [0.0];
    assert!(!ParallelPlanes::new().update_theta(&labels, &xs[..5], 3, &w, &mut h));
    assert!(!ParallelPlanes::new().update_theta(&labels, &xs, 3, &w[..1], &mut h));
    assert!(!ParallelPlanes::new().update_theta(&labels, &xs, 2, &w, &mut [0.0; 1]));
    assert!(!ParallelPlanes::new().update_theta(&labels, &xs, 3, &[0.0, 0.0], &mut h));
    assert!(ParallelPlanes::new().update_theta(&labels, &xs, 3, &w, &mut h));
    assert_eq!(h, [1.0]);
    let mut r = [1.0, 1.0, -1.0];
    assert!(!Ellipsoid::new().update_theta(&labels, &xs, 3, &w, &mut r));
    assert!(!Ellipsoid::new().update_theta(&labels, &xs, 3, &w, &mut [1.0, 1.0]));
    assert!(!Ellipsoid::new().update_theta(&[0, 0], &xs, 3, &w, &mut [1.0; 3]));
}

#[test]
fn template_single_plane_keeps_h_unless_asked() {
    let labels = [side::FETAL, side::MATERNAL, side::MATERNAL, side::MARGIN];
    let xs = [
        0.0, 0.0, 9.0, 0.0, 0.0, -4.0, 1.0, 0.0, -6.0, 0.0, 0.0, 100.0,
    ];
    let w = [1.0, 1.0, 3.0, 1.0];
    let mut h = [5.5];
    assert!(!SinglePlane::new().update_theta(&labels, &xs, 3, &w, &mut h));
    assert_eq!(h, [5.5]);
    let free = SinglePlane {
        optimize_h: true,
        ..SinglePlane::new()
    };
    assert!(free.update_theta(&labels, &xs, 3, &w, &mut h));
    assert!((h[0] - (4.0 + 18.0) / 4.0).abs() < 1e-12);
    // Parallel planes on the same data: (9 - (-4 - 18)) / 5.
    assert!(ParallelPlanes::new().update_theta(&labels, &xs, 3, &w, &mut h));
    assert!((h[0] - 31.0 / 5.0).abs() < 1e-12);
}

#[test]
fn template_ellipsoid_margin_switch() {
    let x = [1.0, 2.0, 3.0];
    let r = [4.0, 5.0, 6.0];
    assert!(Ellipsoid::new().value(0, side::MARGIN, &x, &r) > 0.0);
    assert_eq!(Ellipsoid::new().value(0, side::INTERIOR, &x, &r), 0.0);
    let no_margin = Ellipsoid {
        include_margin: false,
    };
    assert_eq!(no_margin.value(0, side::MARGIN, &x, &r), 0.0);
    assert!(no_margin.value(0, side::FETAL, &x, &r) > 0.0);
}

#[test]
fn template_planes_weights_are_validated() {
    assert!(matches!(
        ParallelPlanes::with_weights(-1.0, 1.0),
        Err(ConfigError {
            name: "fetal_weight",
            ..
        })
    ));
    assert!(ParallelPlanes::with_weights(1.0, f64::INFINITY).is_err());
    assert_eq!(
        ParallelPlanes::with_weights(1.0, 1.0).unwrap(),
        ParallelPlanes::new()
    );
    assert_eq!(ParallelPlanes::single_plane().planes().fetal_weight, 0.0);
}
