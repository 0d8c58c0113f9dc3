//! The injective maximal step (ALGORITHMS 1.3) and backtracking line
//! searches (1.4).
//!
//! # Largest flip-free step
//!
//! Along a search direction `d` the edge matrix of an element moves as
//! `Ds(a) = Ds + a Dd`, so its signed measure is a polynomial in the step
//! `a`: for a tet (the determinant is multilinear in the columns)
//!
//! ```text
//! det(Ds + a Dd) = det(Dd) a^3 + tr(adj(Dd) Ds) a^2 + tr(adj(Ds) Dd) a + det(Ds)
//! ```
//!
//! and for a triangle in the plane `det(Dd) a^2 + tr(adj(Ds) Dd) a + det(Ds)`.
//! The element first flips at the smallest strictly positive real root; the
//! largest admissible step is the minimum over the elements
//! ([`max_step_tets`], [`max_step_tris`]).
//!

use super::roots::{cubic_root_below, smallest_positive_root_quadratic};
use rayon::prelude::*;

/// Minimum number of elements per rayon task.
const PAR_MIN_LEN: usize = 1024;

#[inline]
fn edges3(t: &[u32; 4], x: &[f64]) -> [[f64; 3]; 3] {
    let p = |i: u32| {
        let k = 3 * i as usize;
        [x[k], x[k + 1], x[k + 2]]
    };
    let p0 = p(t[0]);
    let e = |i: usize| {
        let q = p(t[i]);
        [q[0] - p0[0], q[1] - p0[1], q[2] - p0[2]]
    };
    [e(1), e(2), e(3)]
}

#[inline]
fn edges2(t: &[u32; 3], x: &[f64]) -> [[f64; 2]; 2] {
    let p = |i: u32| {
        let k = 2 * i as usize;
        [x[k], x[k + 1]]
    };
    let p0 = p(t[0]);
    let e = |i: usize| {
        let q = p(t[i]);
        [q[0] - p0[0], q[1] - p0[1]]
    };
    [e(1), e(2)]
}

/// Whether `p(a) = sum c_i a^i` (with `c_0 > 0`) is certainly positive on
/// `(0, bound]`: its lower bound `c_0 + sum_{i >= 1} min(c_i, 0) bound^i`
/// exceeds the rounding error of the sum. One pass, no root finding: most
/// elements of a mesh are discarded this way against the running minimum.
#[inline]
fn positive_up_to(c: &[f64], bound: f64) -> bool {
    let mut low = c[0];
    let mut scale = c[0];
    let mut power = 1.0;
    for &ci in &c[1..] {
        power *= bound;
        if ci < 0.0 {
            low += ci * power;
        }
        scale += ci.abs() * power;
    }
    low > 8.0 * f64::EPSILON * scale
}

/// The flip step of one element from its polynomial coefficients
/// (ascending, `c[0] = det Ds`): 0 when already inverted/flat or not
/// finite, `f64::INFINITY` when it does not flip on `(0, bound]` (a bound
/// already known for the minimum over the elements).
#[inline]
fn element_step(c: &[f64], bound: f64, root: impl FnOnce() -> Option<f64>) -> f64 {
    if !c.iter().all(|ci| ci.is_finite()) || c[0] <= 0.0 {
        return 0.0;
    }
    if positive_up_to(c, bound) {
        return f64::INFINITY;
    }
    root().unwrap_or(f64::INFINITY)
}

#[inline]
fn cross(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

#[inline]
fn dot(u: [f64; 3], v: [f64; 3]) -> f64 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// The polynomial `det(Ds + a Dd) - f` of the step, `f = min(floor, det
/// Ds / 2)`: its first root is where the element's measure falls to `f`
/// (the floor, or half its current measure when it is already below the
/// floor), so no accepted step takes an element closer to flat than that.
/// A flat or inverted element (`det Ds <= 0`) is left as it is (it gets
/// step 0).
#[inline]
fn lifted<const N: usize>(mut c: [f64; N], floor: f64) -> [f64; N] {
    if c[0] > 0.0 && floor > 0.0 {
        c[0] -= floor.min(0.5 * c[0]);
    }
    c
}

/// The first positive step at which the tet with edge matrices `Ds`
/// (`a`, columns) and `Dd` (`b`) flips, if it is at most `bound`
/// (`f64::INFINITY` otherwise).
#[inline]
fn tet_flip_step(a: [[f64; 3]; 3], b: [[f64; 3]; 3], bound: f64, floor: f64) -> f64 {
    // The rows of adj(Ds) and adj(Dd) are cross products of columns.
    let adj_a = [cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1])];
    let adj_b = [cross(b[1], b[2]), cross(b[2], b[0]), cross(b[0], b[1])];
    let c = [
        dot(a[0], adj_a[0]),
        dot(b[0], adj_a[0]) + dot(b[1], adj_a[1]) + dot(b[2], adj_a[2]),
        dot(a[0], adj_b[0]) + dot(a[1], adj_b[1]) + dot(a[2], adj_b[2]),
        dot(b[0], adj_b[0]),
    ];
    let c = lifted(c, floor);
    element_step(&c, bound, || cubic_root_below(c, bound))
}

/// The first positive step at which the triangle with edge matrices `Ds`
/// (`a`, columns) and `Dd` (`b`) flips, if it is at most `bound`.
#[inline]
fn tri_flip_step(a: [[f64; 2]; 2], b: [[f64; 2]; 2], bound: f64, floor: f64) -> f64 {
    let det2 = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    let c = [
        det2(a[0], a[1]),
        det2(b[0], a[1]) + det2(a[0], b[1]),
        det2(b[0], b[1]),
    ];
    let c = lifted(c, floor);
    element_step(&c, bound, || {
        smallest_positive_root_quadratic(c[2], c[1], c[0]).filter(|&r| r <= bound)
    })
}

/// The largest step `a_max` such that no tet flips on `[0, a_max)` when the
/// positions move from `x` to `x + a d` (ALGORITHMS 1.3).
///
/// `x` and `d` are flat, 3 coordinates per vertex. For tet `k` with edge
/// matrices `Ds = [x1-x0, x2-x0, x3-x0]` and `Dd` (the same of `d`), six
/// times the signed volume along the line is the cubic
///
/// ```text
/// det(Ds + a Dd) = det(Dd) a^3 + tr(adj(Dd) Ds) a^2 + tr(adj(Ds) Dd) a + det(Ds)
/// ```
///
/// (coefficients formed as sums of mixed triple products), and
/// `a_max = min_k` of its smallest strictly positive root
/// ([`smallest_positive_root_cubic`](super::smallest_positive_root_cubic)); `f64::INFINITY` when no tet ever
/// flips (or there are no tets). A tet that is already inverted or flat at
/// `a = 0` (`det Ds <= 0`), or has non-finite coefficients, gives 0: no
/// positive step is admissible. The step to take is `beta a_max` or less.
/// Parallel over the tets (rayon).
///
/// # Panics
/// If `x` and `d` differ in length or an index is out of range.
pub fn max_step_tets(tets: &[[u32; 4]], x: &[f64], d: &[f64]) -> f64 {
    max_step_tets_above(tets, x, d, &[])
}

/// [`max_step_tets`] keeping every tet's `det(Ds)` (six times its signed
/// volume) at least `floor[k]`: the step at which `det(Ds + a Dd)` falls to
/// `min(floor[k], det(Ds) / 2)` (see the module docs). An empty `floor`
/// is [`max_step_tets`]. A floor keeps "flip-free" meaningful in floating
/// point: without one, a non-barrier energy can step an element ever
/// closer to flat until its sign is rounding noise.
///
/// # Panics
/// As [`max_step_tets`], and if `floor` is neither empty nor one per tet.
pub fn max_step_tets_above(tets: &[[u32; 4]], x: &[f64], d: &[f64], floor: &[f64]) -> f64 {
    assert_eq!(x.len(), d.len(), "positions and direction differ in length");
    assert!(
        floor.is_empty() || floor.len() == tets.len(),
        "one floor per tet"
    );
    let floor_of = |k: usize| floor.get(k).copied().unwrap_or(0.0);
    tets.par_iter()
        .enumerate()
        .with_min_len(PAR_MIN_LEN)
        .fold(
            || f64::INFINITY,
            |best, (k, t)| best.min(tet_flip_step(edges3(t, x), edges3(t, d), best, floor_of(k))),
        )
        .reduce(|| f64::INFINITY, f64::min)
}

/// The largest step `a_max` such that no triangle flips on `[0, a_max)` when
/// the 2D positions move from `x` to `x + a d` (ALGORITHMS 1.3).
///
/// `x` and `d` are flat, 2 coordinates per vertex. With the 2x2 edge
/// matrices `Ds` and `Dd`, twice the signed area along the line is
///
/// ```text
/// det(Ds + a Dd) = det(Dd) a^2 + tr(adj(Ds) Dd) a + det(Ds)
/// ```
///
/// and `a_max = min_k` of its smallest strictly positive root
/// ([`smallest_positive_root_quadratic`]); `f64::INFINITY` when no triangle
/// ever flips. A triangle already inverted or flat at `a = 0`
/// (`det Ds <= 0`), or with non-finite coefficients, gives 0. Parallel over
/// the triangles (rayon).
///
/// # Panics
/// If `x` and `d` differ in length or an index is out of range.
pub fn max_step_tris(tris: &[[u32; 3]], x: &[f64], d: &[f64]) -> f64 {
    max_step_tris_above(tris, x, d, &[])
}

/// [`max_step_tris`] keeping every triangle's `det(Ds)` (twice its signed
/// area) at least `floor[k]` (as [`max_step_tets_above`]).
///
/// # Panics
/// As [`max_step_tris`], and if `floor` is neither empty nor one per
/// triangle.
pub fn max_step_tris_above(tris: &[[u32; 3]], x: &[f64], d: &[f64], floor: &[f64]) -> f64 {
    assert_eq!(x.len(), d.len(), "positions and direction differ in length");
    assert!(
        floor.is_empty() || floor.len() == tris.len(),
        "one floor per triangle"
    );
    let floor_of = |k: usize| floor.get(k).copied().unwrap_or(0.0);
    tris.par_iter()
        .enumerate()
        .with_min_len(PAR_MIN_LEN)
        .fold(
            || f64::INFINITY,
            |best, (k, t)| best.min(tri_flip_step(edges2(t, x), edges2(t, d), best, floor_of(k))),
        )
        .reduce(|| f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linesearch::roots::tests::{det3, log_uniform, rel};
    use proptest::prelude::*;
    use unfold_mesh::shapes::{grid_disk, kuhn_grid};

    /// With a floor, the bound is where the measure falls to the floor (or
    /// to half of it when it starts below), never to 0.
    #[test]
    fn a_floor_keeps_elements_away_from_flat() {
        // One unit tet, its apex moving straight down: det(Ds) = 1 - a.
        let tets = [[0u32, 1, 2, 3]];
        let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let mut d = [0.0; 12];
        d[11] = -1.0;
        assert!((max_step_tets(&tets, &x, &d) - 1.0).abs() < 1e-15);
        let a = max_step_tets_above(&tets, &x, &d, &[1e-3]);
        assert!((a - (1.0 - 1e-3)).abs() < 1e-12, "{a}");
        let b = max_step_tets_above(&tets, &x, &d, &[10.0]);
        assert!((b - 0.5).abs() < 1e-12, "{b}");
        // A triangle: det(Ds) = 1 - a as well.
        let tris = [[0u32, 1, 2]];
        let y = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        let e = [0.0, 0.0, 0.0, 0.0, 0.0, -1.0];
        let c = max_step_tris_above(&tris, &y, &e, &[0.25]);
        assert!((c - 0.75).abs() < 1e-12, "{c}");
    }

    // ----- max step: meshes -----

    fn det3_at(t: &[u32; 4], x: &[f64], d: &[f64], a: f64) -> f64 {
        let p = |i: u32| {
            let k = 3 * i as usize;
            [
                x[k] + a * d[k],
                x[k + 1] + a * d[k + 1],
                x[k + 2] + a * d[k + 2],
            ]
        };
        let (p0, p1, p2, p3) = (p(t[0]), p(t[1]), p(t[2]), p(t[3]));
        let e = |q: [f64; 3]| [q[0] - p0[0], q[1] - p0[1], q[2] - p0[2]];
        det3(e(p1), e(p2), e(p3))
    }

    fn det2_at(t: &[u32; 3], x: &[f64], d: &[f64], a: f64) -> f64 {
        let p = |i: u32| {
            let k = 2 * i as usize;
            [x[k] + a * d[k], x[k + 1] + a * d[k + 1]]
        };
        let (p0, p1, p2) = (p(t[0]), p(t[1]), p(t[2]));
        (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p1[1] - p0[1]) * (p2[0] - p0[0])
    }

    /// Scale of the rounding error of an element's determinant along the
    /// line at `a`: `prod_i (|e_i(x)| + a |e_i(d)|)` over its edges from
    /// vertex 0 (bounds `sum |c_j| a^j`).
    fn element_scale(t: &[u32], x: &[f64], d: &[f64], a: f64, dim: usize) -> f64 {
        let edge_norm = |v: &[f64], i: usize| {
            let (k, k0) = (dim * t[i] as usize, dim * t[0] as usize);
            (0..dim)
                .map(|j| (v[k + j] - v[k0 + j]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        (1..t.len())
            .map(|i| edge_norm(x, i) + a * edge_norm(d, i))
            .product()
    }

    fn tet_scale(t: &[u32; 4], x: &[f64], d: &[f64], a: f64) -> f64 {
        element_scale(t, x, d, a, 3)
    }

    fn tri_scale(t: &[u32; 3], x: &[f64], d: &[f64], a: f64) -> f64 {
        element_scale(t, x, d, a, 2)
    }

    /// First sign change of `f` on `(0, hi]` by dense sampling + bisection.
    fn first_sign_change(f: impl Fn(f64) -> f64, hi: f64) -> Option<f64> {
        let samples = 2000;
        let mut prev = 0.0;
        for i in 1..=samples {
            let x = hi * i as f64 / samples as f64;
            if f(x) <= 0.0 {
                let (mut a, mut b) = (prev, x);
                loop {
                    let m = a + 0.5 * (b - a);
                    if m <= a || m >= b {
                        return Some(b);
                    }
                    if f(m) <= 0.0 {
                        b = m;
                    } else {
                        a = m;
                    }
                }
            }
            prev = x;
        }
        None
    }

    const N3: usize = 2;
    const NV3: usize = (N3 + 1) * (N3 + 1) * (N3 + 1);
    const N2: usize = 4;
    const NV2: usize = (N2 + 1) * (N2 + 1);

    /// A 2x2x2 Kuhn grid (48 tets) with every vertex jittered by up to
    /// 0.08 of the spacing; all tets stay positive.
    fn jittered_tets(jitter: &[f64]) -> (Vec<[u32; 4]>, Vec<f64>) {
        let mesh = kuhn_grid([N3; 3], [1.0; 3]);
        let x: Vec<f64> = mesh
            .positions
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .zip(jitter)
            .map(|(p, j)| p + 0.08 * j)
            .collect();
        let zero = vec![0.0; x.len()];
        for t in &mesh.tets {
            assert!(det3_at(t, &x, &zero, 0.0) > 0.0);
        }
        (mesh.tets, x)
    }

    /// A 4x4 triangulated grid (32 triangles), jittered by up to 0.15.
    fn jittered_tris(jitter: &[f64]) -> (Vec<[u32; 3]>, Vec<f64>) {
        let mesh = grid_disk(N2, N2);
        let x: Vec<f64> = mesh
            .positions
            .iter()
            .flat_map(|p| [p.x, p.y])
            .zip(jitter)
            .map(|(p, j)| p + 0.15 * j)
            .collect();
        let zero = vec![0.0; x.len()];
        for t in &mesh.triangles {
            assert!(det2_at(t, &x, &zero, 0.0) > 0.0);
        }
        (mesh.triangles, x)
    }

    fn unit_vec(n: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(-1.0f64..1.0, n)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn max_step_tets_is_the_first_flip(
            jitter in unit_vec(3 * NV3),
            dir in unit_vec(3 * NV3),
            scale in log_uniform(-2.0, 1.0),
        ) {
            let (tets, x) = jittered_tets(&jitter);
            let d: Vec<f64> = dir.iter().map(|v| v * scale).collect();
            let a_max = max_step_tets(&tets, &x, &d);
            prop_assert!(a_max > 0.0);
            if a_max.is_finite() {
                // (a) nothing inverted just before, something flat at a_max
                let before = 0.999 * a_max;
                for t in &tets {
                    prop_assert!(det3_at(t, &x, &d, before) > 0.0);
                }
                let flattest = tets
                    .iter()
                    .map(|t| det3_at(t, &x, &d, a_max).abs() / tet_scale(t, &x, &d, a_max))
                    .fold(f64::INFINITY, f64::min);
                prop_assert!(flattest < 1e-12, "min relative volume {flattest}");
            }
            // (b) the per-tet first sign change of the exact volume
            let hi = if a_max.is_finite() { 1.5 * a_max } else { 1e3 / scale };
            let reference = tets
                .iter()
                .filter_map(|t| first_sign_change(|a| det3_at(t, &x, &d, a), hi))
                .fold(f64::INFINITY, f64::min);
            if a_max.is_finite() {
                prop_assert!(rel(a_max, reference) <= 1e-9, "a_max {a_max}, reference {reference}");
            } else {
                prop_assert!(reference.is_infinite());
            }
        }

        #[test]
        fn max_step_tris_is_the_first_flip(
            jitter in unit_vec(2 * NV2),
            dir in unit_vec(2 * NV2),
            scale in log_uniform(-2.0, 1.0),
        ) {
            let (tris, x) = jittered_tris(&jitter);
            let d: Vec<f64> = dir.iter().map(|v| v * scale).collect();
            let a_max = max_step_tris(&tris, &x, &d);
            prop_assert!(a_max > 0.0);
            if a_max.is_finite() {
                let before = 0.999 * a_max;
                for t in &tris {
                    prop_assert!(det2_at(t, &x, &d, before) > 0.0);
                }
                let flattest = tris
                    .iter()
                    .map(|t| det2_at(t, &x, &d, a_max).abs() / tri_scale(t, &x, &d, a_max))
                    .fold(f64::INFINITY, f64::min);
                prop_assert!(flattest < 1e-12, "min relative area {flattest}");
            }
            let hi = if a_max.is_finite() { 1.5 * a_max } else { 1e3 / scale };
            let reference = tris
                .iter()
                .filter_map(|t| first_sign_change(|a| det2_at(t, &x, &d, a), hi))
                .fold(f64::INFINITY, f64::min);
            if a_max.is_finite() {
                prop_assert!(rel(a_max, reference) <= 1e-9, "a_max {a_max}, reference {reference}");
            } else {
                prop_assert!(reference.is_infinite());
            }
        }

        /// (c) rigid-ish directions: translations never flip, infinitesimal
        /// rotations (`det(I + a W) = 1 + a^2 |w|^2`) only through rounding
        /// at absurd steps; uniform shrinking flips everything at `1/s`.
        #[test]
        fn max_step_tets_rigid_and_scaling_directions(
            jitter in unit_vec(3 * NV3),
            t in prop::array::uniform3(-1.0f64..1.0),
            w in prop::array::uniform3(-1.0f64..1.0),
            wscale in log_uniform(-4.0, 0.0),
            s in log_uniform(-2.0, 2.0),
        ) {
            let (tets, x) = jittered_tets(&jitter);
            let translate: Vec<f64> = (0..x.len()).map(|i| t[i % 3]).collect();
            prop_assert_eq!(max_step_tets(&tets, &x, &translate), f64::INFINITY);
            let w = [w[0] * wscale, w[1] * wscale, w[2] * wscale];
            let c = 0.5 * N3 as f64;
            let mut rotate = vec![0.0; x.len()];
            let mut shrink = vec![0.0; x.len()];
            for v in 0..NV3 {
                let r = [x[3 * v] - c, x[3 * v + 1] - c, x[3 * v + 2] - c];
                rotate[3 * v] = w[1] * r[2] - w[2] * r[1];
                rotate[3 * v + 1] = w[2] * r[0] - w[0] * r[2];
                rotate[3 * v + 2] = w[0] * r[1] - w[1] * r[0];
                for k in 0..3 {
                    shrink[3 * v + k] = -s * r[k];
                }
            }
            let wn = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            let a_rot = max_step_tets(&tets, &x, &rotate);
            prop_assert!(a_rot >= 1e10 / wn, "rotation step {a_rot}, |w| {wn}");
            let a_shrink = max_step_tets(&tets, &x, &shrink);
            // A triple root at 1/s, split by rounding by ~eps^(1/3).
            prop_assert!(rel(a_shrink, 1.0 / s) < 1e-4, "{a_shrink} vs {}", 1.0 / s);
            prop_assert!(a_shrink <= 1.0 / s * (1.0 + 1e-4));
            let grow: Vec<f64> = shrink.iter().map(|v| -v).collect();
            prop_assert_eq!(max_step_tets(&tets, &x, &grow), f64::INFINITY);
        }

        #[test]
        fn max_step_tris_rigid_and_scaling_directions(
            jitter in unit_vec(2 * NV2),
            t in prop::array::uniform2(-1.0f64..1.0),
            w in log_uniform(-4.0, 0.0),
            s in log_uniform(-2.0, 2.0),
        ) {
            let (tris, x) = jittered_tris(&jitter);
            let translate: Vec<f64> = (0..x.len()).map(|i| t[i % 2]).collect();
            prop_assert_eq!(max_step_tris(&tris, &x, &translate), f64::INFINITY);
            let c = 0.5 * N2 as f64;
            let mut rotate = vec![0.0; x.len()];
            let mut shrink = vec![0.0; x.len()];
            for v in 0..NV2 {
                let r = [x[2 * v] - c, x[2 * v + 1] - c];
                rotate[2 * v] = -w * r[1];
                rotate[2 * v + 1] = w * r[0];
                shrink[2 * v] = -s * r[0];
                shrink[2 * v + 1] = -s * r[1];
            }
            let a_rot = max_step_tris(&tris, &x, &rotate);
            prop_assert!(a_rot >= 1e10 / w, "rotation step {a_rot}, w {w}");
            let a_shrink = max_step_tris(&tris, &x, &shrink);
            // A double root at 1/s.
            prop_assert!(rel(a_shrink, 1.0 / s) < 1e-6, "{a_shrink} vs {}", 1.0 / s);
            let grow: Vec<f64> = shrink.iter().map(|v| -v).collect();
            prop_assert_eq!(max_step_tris(&tris, &x, &grow), f64::INFINITY);
        }
    }

    #[test]
    fn max_step_degenerate_inputs() {
        let tet = [[0u32, 1, 2, 3]];
        let x = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.];
        let zero = [0.0; 12];
        assert_eq!(max_step_tets(&tet, &x, &zero), f64::INFINITY);
        assert_eq!(max_step_tets(&[], &x, &zero), f64::INFINITY);
        // Moving vertex 3 down through the base plane at a = 1/2.
        let mut d = zero;
        d[11] = -2.0;
        assert!(rel(max_step_tets(&tet, &x, &d), 0.5) < 1e-15);
        // Inverted or flat at a = 0: step 0.
        let inverted = [[0u32, 2, 1, 3]];
        assert_eq!(max_step_tets(&inverted, &x, &zero), 0.0);
        let mut flat = x;
        flat[11] = 0.0;
        assert_eq!(max_step_tets(&tet, &flat, &zero), 0.0);
        let mut nan = d;
        nan[0] = f64::NAN;
        assert_eq!(max_step_tets(&tet, &x, &nan), 0.0);
        // Triangles.
        let tri = [[0u32, 1, 2]];
        let y = [0., 0., 1., 0., 0., 1.];
        assert_eq!(max_step_tris(&tri, &y, &[0.0; 6]), f64::INFINITY);
        assert_eq!(max_step_tris(&[[0u32, 2, 1]], &y, &[0.0; 6]), 0.0);
        let e = [0., 0., 0., 0., 0., -4.];
        assert!(rel(max_step_tris(&tri, &y, &e), 0.25) < 1e-15);
    }

    #[test]
    fn max_step_parallel_matches_serial() {
        let mesh = kuhn_grid([12, 12, 12], [1.0; 3]);
        let x: Vec<f64> = mesh
            .positions
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .collect();
        // A smooth twisting direction.
        let d: Vec<f64> = x
            .chunks(3)
            .flat_map(|p| {
                [
                    (p[1] * 0.7).sin(),
                    (p[2] * 0.3).cos() * p[0] * 0.1,
                    -0.05 * p[2],
                ]
            })
            .collect();
        let serial = mesh
            .tets
            .iter()
            .map(|t| tet_flip_step(edges3(t, &x), edges3(t, &d), f64::INFINITY, 0.0))
            .fold(f64::INFINITY, f64::min);
        let parallel = max_step_tets(&mesh.tets, &x, &d);
        assert!(mesh.tets.len() > PAR_MIN_LEN);
        assert_eq!(parallel, serial);
        assert!(parallel.is_finite());
    }
}
