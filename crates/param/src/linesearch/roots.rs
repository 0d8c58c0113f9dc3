//! Robust smallest positive roots of quadratics and cubics, for the
//! largest flip-free step (ALGORITHMS 1.3).
//!
//!
//! [`smallest_positive_root_cubic`] never uses complex arithmetic (the
//! reference implementation's Cardano formula with a fixed imaginary
//! threshold of 1e-4 misses roots). It
//!
//! 1. scales the coefficients by a power of two (exact) so the largest is of
//!    order one, drops to the quadratic / linear case when the leading
//!    coefficients are zero (and deflates a root at 0);
//! 2. rejects by Descartes' rule of signs (no sign change, no positive root);
//! 3. splits `(0, inf)` at the positive critical points (the roots of the
//!    quadratic derivative, by the same stable formula), on each piece of
//!    which the cubic is monotone;
//! 4. walks the pieces left to right: the first piece whose right end has
//!    the cubic at or past zero holds the root (the last, unbounded piece
//!    ends at Fujiwara's upper bound on the root moduli), found by
//!    safeguarded Newton with bisection down to an ulp. Bisection is
//!    geometric while the bracket spans more than a factor 4, and a bracket
//!    starting at 0 first moves up to Fujiwara's lower bound `L > 0` on the
//!    root moduli, so roots at any scale cost a few dozen evaluations. The
//!    cubic is evaluated by compensated Horner (as if in twice the working
//!    precision).
//!
//! A local minimum that comes within `1e-6` (relative) of zero is located to
//! the ulp by bisection on the derivative's sign before its value is
//! checked, so a tangent (double) root counts whenever the cubic reaches
//! `<= 0` in floating point. Tiny leading coefficients need no threshold:
//! nothing divides by them except the root bounds, so they only create the
//! (correct) huge roots of the given coefficients. A fixed relative
//! threshold would be wrong here: for a short direction `|Dd| = r |Ds|` the
//! coefficients scale as `r^3, r^2, r, 1` and the cubic term is essential.
//!
//! The mesh minimum does not solve every element: against the running
//! minimum `B` of its rayon task, an element is skipped when
//! `c0 + sum_{i >= 1} min(c_i, 0) B^i > 0` (with a rounding margin), and
//! otherwise its root is only searched on `(0, B]`.
//!

/// Local minima of the cubic closer to zero than this (relative to
/// `sum |c_i| a^i`) are located to the ulp before their sign is trusted.
const TANGENT_REL: f64 = 1e-6;

/// Iteration cap of the bracketed solvers (bisection alone needs < 140).
const MAX_BRACKET_ITERS: usize = 400;

/// `(s, e)` with `s = fl(a + b)` and `s + e = a + b` exactly (Knuth).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `sum c[i] x^i` by compensated Horner (Graillat, Langlois, Louvet 2005):
/// as accurate as Horner in twice the working precision. Falls back to plain
/// Horner when an intermediate overflows.
#[inline]
fn horner_comp(c: &[f64], x: f64) -> f64 {
    let n = c.len();
    let mut s = c[n - 1];
    let mut err: f64 = 0.0;
    for i in (0..n - 1).rev() {
        let p = s * x;
        let pe = s.mul_add(x, -p);
        let (t, se) = two_sum(p, c[i]);
        s = t;
        err = err.mul_add(x, pe + se);
    }
    let r = s + err;
    if r.is_finite() {
        r
    } else {
        c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
    }
}

/// `sum |c[i]| x^i` for `x >= 0`: the scale of the rounding error of `p(x)`.
#[inline]
fn abs_scale(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci.abs())
}

/// `x * 2^k` exactly (barring underflow), for any `k` in the exponent range.
fn mul_pow2(x: f64, k: i32) -> f64 {
    if k > 1000 {
        x * 2f64.powi(1000) * 2f64.powi(k - 1000)
    } else if k < -1000 {
        x * 2f64.powi(-1000) * 2f64.powi(k + 1000)
    } else {
        x * 2f64.powi(k)
    }
}

/// Scales `c` by a power of two so that `max |c_i|` is of order one.
/// Returns `false` when a coefficient is not finite or all are zero.
pub(super) fn normalize(c: &mut [f64]) -> bool {
    let mut m: f64 = 0.0;
    for &ci in c.iter() {
        if !ci.is_finite() {
            return false;
        }
        m = m.max(ci.abs());
    }
    if m == 0.0 {
        return false;
    }
    // The binary exponent of m (from its bits when m is normal).
    let e = if m >= f64::MIN_POSITIVE {
        ((m.to_bits() >> 52) & 0x7ff) as i32 - 1023
    } else {
        m.log2().floor() as i32
    };
    for ci in c.iter_mut() {
        *ci = mul_pow2(*ci, -e);
    }
    true
}

/// `b^2 - 4 a c` with both products formed exactly (Kahan): accurate even
/// when the roots nearly coincide and the two terms cancel.
#[inline]
fn discriminant(a: f64, b: f64, c: f64) -> f64 {
    let p = b * b;
    let dp = b.mul_add(b, -p);
    let a4 = 4.0 * a;
    let q = a4 * c;
    let dq = a4.mul_add(c, -q);
    (p - q) + (dp - dq)
}

/// The real roots of `a x^2 + b x + c` (finite coefficients, not all of
/// `a, b` zero), ascending, by the cancellation-free formula
/// `q = -(b + sign(b) sqrt(b^2 - 4ac)) / 2`, roots `q / a` and `c / q`.
/// Non-finite roots (overflow for tiny `a`) are dropped.
fn quadratic_real_roots(a: f64, b: f64, c: f64) -> ([f64; 2], usize) {
    let mut out = [0.0; 2];
    let mut n = 0;
    let mut push = |r: f64| {
        if r.is_finite() {
            out[n] = r;
            n += 1;
        }
    };
    if a == 0.0 {
        if b != 0.0 {
            push(-c / b);
        }
    } else if c == 0.0 {
        push(0.0);
        push(-b / a);
    } else {
        let d = discriminant(a, b, c);
        if d >= 0.0 {
            let q = -0.5 * (b + d.sqrt().copysign(b));
            if q == 0.0 {
                // b = 0 and 4ac underflowed: roots +-sqrt(-c/a).
                let r = (-c / a).sqrt();
                push(-r);
                push(r);
            } else {
                push(q / a);
                push(c / q);
            }
        }
    }
    if n == 2 && out[0] > out[1] {
        out.swap(0, 1);
    }
    (out, n)
}

/// The smallest strictly positive real root of `c2 a^2 + c1 a + c0`, if any.
///
/// Closed form without cancellation: with `D = c1^2 - 4 c2 c0` (both
/// products formed exactly, so `D` is accurate even for nearly double
/// roots) and `q = -(c1 + sign(c1) sqrt(D)) / 2`, the roots are `q / c2` and
/// `c0 / q`. The coefficients are first scaled by a power of two (exact);
/// `c2 = 0` gives the linear root `-c0 / c1`. A double root (`D = 0`) counts.
/// Returns `None` for the zero polynomial, non-finite coefficients, complex
/// roots or no positive root.
pub fn smallest_positive_root_quadratic(c2: f64, c1: f64, c0: f64) -> Option<f64> {
    let mut c = [c0, c1, c2];
    if !normalize(&mut c) {
        return None;
    }
    quadratic_root_scaled(c)
}

/// [`smallest_positive_root_quadratic`] of scaled, finite coefficients
/// (ascending).
pub(super) fn quadratic_root_scaled([c0, c1, c2]: [f64; 3]) -> Option<f64> {
    // Descartes: without a sign change there is no positive root.
    if c0 != 0.0 && signs_agree(c0, &[c1, c2]) {
        return None;
    }
    let (roots, n) = quadratic_real_roots(c2, c1, c0);
    roots[..n].iter().copied().find(|&r| r > 0.0)
}

/// Whether every nonzero entry of `rest` has the sign of `lead` (`lead != 0`).
#[inline]
fn signs_agree(lead: f64, rest: &[f64]) -> bool {
    rest.iter().all(|&r| r == 0.0 || (r > 0.0) == (lead > 0.0))
}

/// The smallest strictly positive real root of
/// `p(a) = c3 a^3 + c2 a^2 + c1 a + c0`, if any.
///
/// Robust for roots at very different scales, tiny leading coefficients and
/// nearly multiple roots (see the module documentation for the method):
/// the coefficients are scaled by a power of two, a zero `c3` (or `c3`
/// and `c2`) drops to [`smallest_positive_root_quadratic`] (or the linear
/// root), `c0 = 0` deflates the root at 0, and otherwise the roots are
/// bracketed between the critical points of `p` (roots of
/// `p'(a) = 3 c3 a^2 + 2 c2 a + c1`) and solved by safeguarded
/// Newton/bisection to an ulp. A tangent root counts when `p` reaches `<= 0`
/// (or `>= 0` for `c0 < 0`) in floating point.
///
/// Returns `None` for the zero polynomial, non-finite coefficients or no
/// positive real root (or one beyond `f64::MAX`).
pub fn smallest_positive_root_cubic(c3: f64, c2: f64, c1: f64, c0: f64) -> Option<f64> {
    cubic_root_below([c0, c1, c2, c3], f64::INFINITY)
}

/// The smallest positive root of the cubic with ascending coefficients `c`
/// if it is at most `bound` (which may be infinite).
pub(super) fn cubic_root_below(mut c: [f64; 4], bound: f64) -> Option<f64> {
    if !normalize(&mut c) {
        return None;
    }
    let below = |r: f64| r <= bound;
    if c[0] == 0.0 {
        // p(a) = a (c3 a^2 + c2 a + c1): the root 0 is not positive.
        return smallest_positive_root_quadratic(c[3], c[2], c[1]).filter(|&r| below(r));
    }
    if c[3] == 0.0 {
        return quadratic_root_scaled([c[0], c[1], c[2]]).filter(|&r| below(r));
    }
    if c[0] < 0.0 {
        for ci in c.iter_mut() {
            *ci = -*ci;
        }
    }
    if signs_agree(c[0], &c[1..]) {
        return None;
    }
    cubic_first_root(&c, bound)
}

/// The first positive root of a scaled cubic (ascending coefficients) with
/// `c[0] > 0` and `c[3] != 0`, the first `a > 0` with `p(a) <= 0`, if it is
/// at most `bound`.
fn cubic_first_root(c: &[f64; 4], bound: f64) -> Option<f64> {
    let p = |x: f64| horner_comp(c, x);
    // Solves on [prev, end] (p(prev) > 0 >= p(end), p monotone). From
    // prev = 0 it first moves up to Fujiwara's lower bound on the root
    // moduli (from the reversed polynomial),
    // |z| >= 1 / (2 max(|c1/c0|, |c2/c0|^(1/2), |c3/(2 c0)|^(1/3))),
    // so bisection can work geometrically whatever the scale of the root.
    let solve = |prev: f64, end: f64| {
        if prev > 0.0 {
            return solve_bracket(c, prev, end);
        }
        let inv = 2.0
            * (c[1] / c[0])
                .abs()
                .max((c[2] / c[0]).abs().sqrt())
                .max((c[3] / (2.0 * c[0])).abs().cbrt());
        let lower = 1.0 / inv;
        if lower > 0.0 && lower < end {
            if p(lower) <= 0.0 {
                solve_bracket(c, 0.0, lower)
            } else {
                solve_bracket(c, lower, end)
            }
        } else {
            solve_bracket(c, 0.0, end)
        }
    };
    let mut prev = 0.0;
    // Critical points: p is monotone between consecutive ones.
    let (crit, n) = quadratic_real_roots(3.0 * c[3], 2.0 * c[2], c[1]);
    for &m0 in &crit[..n] {
        if m0.is_nan() || m0 <= prev {
            continue;
        }
        if m0 >= bound {
            break;
        }
        let mut m = m0;
        let mut f = p(m);
        let local_min = 6.0 * c[3] * m + 2.0 * c[2] > 0.0;
        if f > 0.0 && local_min && f <= TANGENT_REL * abs_scale(c, m) {
            m = polish_minimum(c, m);
            f = p(m);
            if m.is_nan() || m <= prev {
                continue;
            }
        }
        if f <= 0.0 {
            return Some(solve(prev, m));
        }
        prev = m;
    }
    // Last monotone piece [prev, bound] or [prev, inf): p -> sign(c3) inf.
    if bound.is_finite() {
        return (p(bound) <= 0.0).then(|| solve(prev, bound));
    }
    if c[3] > 0.0 {
        return None;
    }
    // Fujiwara's upper bound: |z| <= 2 max(|c2/c3|, |c1/c3|^(1/2), |c0/(2 c3)|^(1/3)).
    let mut hi = 2.0
        * (c[2] / c[3])
            .abs()
            .max((c[1] / c[3]).abs().sqrt())
            .max((c[0] / (2.0 * c[3])).abs().cbrt());
    if !(hi > prev && hi.is_finite()) {
        hi = (2.0 * prev).max(1.0);
    }
    let mut k = 1;
    while p(hi) > 0.0 {
        hi = mul_pow2(hi, k);
        k = (2 * k).min(256);
        if !hi.is_finite() {
            return None;
        }
    }
    Some(solve(prev, hi))
}

/// Locates a local minimum of the cubic near `m` to the ulp: brackets the
/// sign change of `p'` (compensated evaluation) around `m`, bisects it down
/// to adjacent floats, and returns the one where `p` is smaller. Returns `m`
/// when no bracket is found within a relative `~1e-8`.
fn polish_minimum(c: &[f64; 4], m: f64) -> f64 {
    let dc = [c[1], 2.0 * c[2], 3.0 * c[3]];
    let dp = |x: f64| horner_comp(&dc, x);
    let mut h = 4.0 * f64::EPSILON * m.abs().max(f64::MIN_POSITIVE);
    let mut bracket = None;
    for _ in 0..10 {
        let (lo, hi) = (m - h, m + h);
        let (dlo, dhi) = (dp(lo), dp(hi));
        if dlo <= 0.0 && dhi >= 0.0 {
            bracket = Some((lo, hi, dlo, dhi));
            break;
        }
        h *= 8.0;
    }
    let Some((mut lo, mut hi, dlo, dhi)) = bracket else {
        return m;
    };
    if dlo == 0.0 {
        return lo;
    }
    if dhi == 0.0 {
        return hi;
    }
    for _ in 0..MAX_BRACKET_ITERS {
        let mid = lo + 0.5 * (hi - lo);
        if mid <= lo || mid >= hi {
            break;
        }
        let v = dp(mid);
        if v == 0.0 {
            return mid;
        }
        if v < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let candidates = [lo, m, hi];
    candidates
        .into_iter()
        .min_by(|&a, &b| horner_comp(c, a).total_cmp(&horner_comp(c, b)))
        .unwrap_or(m)
}

/// The bisection point of `[lo, hi]`: geometric while the bracket spans more
/// than a factor 4 (roots may live at any scale), arithmetic otherwise.
#[inline]
fn bisection_point(lo: f64, hi: f64) -> f64 {
    if lo > 0.0 && hi > 4.0 * lo {
        lo.sqrt() * hi.sqrt()
    } else {
        lo + 0.5 * (hi - lo)
    }
}

/// A size of the bracket `[lo, hi]` that bisection halves: its logarithmic
/// width `ln(hi / lo)` (the absolute width when `lo = 0`).
#[inline]
fn bracket_size(lo: f64, hi: f64) -> f64 {
    if lo > 0.0 {
        ((hi - lo) / lo).ln_1p()
    } else {
        hi - lo
    }
}

/// The root of the cubic in `[lo, hi]`, given `p(lo) > 0 >= p(hi)` and `p`
/// monotone there: safeguarded Newton with bisection, down to an ulp.
/// A Newton step is taken only inside the bracket and while it shrinks
/// fast: when two iterations have not halved the bracket (geometric width
/// while it spans more than a factor 4), the next point is a bisection, so
/// convergence is never slower than half of bisection's.
fn solve_bracket(c: &[f64; 4], mut lo: f64, mut hi: f64) -> f64 {
    let dc = [c[1], 2.0 * c[2], 3.0 * c[3]];
    let mut f_lo = horner_comp(c, lo);
    let mut f_hi = horner_comp(c, hi);
    if f_hi == 0.0 {
        return hi;
    }
    let mut x = bisection_point(lo, hi);
    let mut size_ref = bracket_size(lo, hi);
    let mut since_check = 0;
    for _ in 0..MAX_BRACKET_ITERS {
        let f = horner_comp(c, x);
        if f == 0.0 {
            return x;
        }
        if f > 0.0 {
            lo = x;
            f_lo = f;
        } else {
            hi = x;
            f_hi = f;
        }
        if hi - lo <= f64::EPSILON * hi {
            break;
        }
        since_check += 1;
        let mut slow = false;
        if since_check == 2 {
            let size = bracket_size(lo, hi);
            slow = size > 0.5 * size_ref;
            size_ref = size;
            since_check = 0;
        }
        let df = dc.iter().rev().fold(0.0, |acc, &ci| acc * x + ci);
        let newton = x - f / df;
        let next = if !slow && newton > lo && newton < hi {
            newton
        } else {
            bisection_point(lo, hi)
        };
        if next <= lo || next >= hi {
            break;
        }
        x = next;
    }
    if f_hi.abs() <= f_lo.abs() { hi } else { lo }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    pub(crate) fn det3(u: [f64; 3], v: [f64; 3], w: [f64; 3]) -> f64 {
        u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0])
    }

    // ----- polynomial references -----

    /// Plain Horner, ascending coefficients.
    fn eval(c: &[f64], x: f64) -> f64 {
        c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
    }

    fn deriv(c: &[f64], x: f64) -> f64 {
        (1..c.len())
            .rev()
            .fold(0.0, |acc, i| acc * x + i as f64 * c[i])
    }

    pub(crate) fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
    }

    /// Condition number of the root `r` w.r.t. relative coefficient
    /// perturbations: `sum |c_i| r^i / |r p'(r)|`.
    fn kappa(c: &[f64], r: f64) -> f64 {
        abs_scale(c, r) / (r * deriv(c, r)).abs()
    }

    /// Reference: the first sign change of `p` on a dense logarithmic grid
    /// spanning Cauchy's root bounds, refined by bisection to adjacent floats.
    fn reference_root(c: &[f64]) -> Option<f64> {
        // Divide out a^k (roots at 0 are not positive).
        let first = c.iter().position(|&x| x != 0.0)?;
        let last = c.iter().rposition(|&x| x != 0.0)?;
        let c = &c[first..=last];
        let n = c.len() - 1;
        let k = 0;
        if n == k {
            return None;
        }
        let upper = 1.0 + (0..n).map(|i| (c[i] / c[n]).abs()).fold(0.0, f64::max);
        let max_hi = (k + 1..=n).map(|i| c[i].abs()).fold(0.0, f64::max);
        let lower = c[k].abs() / (c[k].abs() + max_hi);
        let (lo, hi) = (0.5 * lower, 2.0 * upper);
        let samples = 20_000;
        let (ln_lo, ratio) = (lo.ln(), hi.ln() - lo.ln());
        let mut prev_x = lo;
        let mut prev_f = eval(c, lo);
        if prev_f == 0.0 {
            return Some(lo);
        }
        for i in 1..=samples {
            let x = (ln_lo + ratio * i as f64 / samples as f64).exp();
            let f = eval(c, x);
            if f == 0.0 {
                return Some(x);
            }
            if (f > 0.0) != (prev_f > 0.0) {
                let (mut a, mut b) = (prev_x, x);
                let sa = prev_f > 0.0;
                loop {
                    let m = a + 0.5 * (b - a);
                    if m <= a || m >= b {
                        break;
                    }
                    let fm = eval(c, m);
                    if fm == 0.0 {
                        return Some(m);
                    }
                    if (fm > 0.0) == sa {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return Some(b);
            }
            prev_x = x;
            prev_f = f;
        }
        None
    }

    /// `g` is a genuine (near-)root: `|p(g)|` within rounding of zero.
    fn is_near_root(c: &[f64], g: f64) -> bool {
        eval(c, g).abs() <= 1e-9 * abs_scale(c, g)
    }

    /// Compares a solver answer with the sampling reference.
    fn check_against_reference(c: &[f64], got: Option<f64>) -> Result<(), TestCaseError> {
        // Roots beyond f64::MAX are not roots.
        let expected = reference_root(c).filter(|r| r.is_finite());
        match (got, expected) {
            (Some(g), Some(r)) => {
                prop_assert!(g > 0.0);
                let k = kappa(c, r);
                if k < 1e6 {
                    let tol = 1e-12_f64.max(16.0 * f64::EPSILON * k);
                    prop_assert!(rel(g, r) <= tol, "got {g}, reference {r}, kappa {k}");
                } else {
                    prop_assert!(is_near_root(c, g), "got {g}, reference {r}");
                    prop_assert!(g <= r * (1.0 + 1e-6), "got {g}, reference {r}");
                }
            }
            (None, Some(r)) => {
                let k = kappa(c, r);
                prop_assert!(k > 1e8, "missed root {r} (kappa {k})");
            }
            (Some(g), None) => {
                // Only a tangent root or a pair hidden between samples.
                prop_assert!(is_near_root(c, g), "spurious root {g}");
            }
            (None, None) => {}
        }
        Ok(())
    }

    fn coefficient() -> impl Strategy<Value = f64> {
        prop_oneof![
            6 => (-1.0f64..1.0, -8i32..8).prop_map(|(m, e)| m * 10f64.powi(e)),
            1 => Just(0.0),
            1 => (-1.0f64..1.0, -300i32..-10).prop_map(|(m, e)| m * 10f64.powi(e)),
        ]
    }

    pub(crate) fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
        (lo..hi).prop_map(|u| 10f64.powf(u))
    }

    fn sign() -> impl Strategy<Value = f64> {
        prop_oneof![Just(1.0), Just(-1.0)]
    }

    /// Ascending coefficients of `k (a - r0)(a - r1)(a - r2)`.
    fn from_roots(k: f64, r: [f64; 3]) -> [f64; 4] {
        [
            -k * r[0] * r[1] * r[2],
            k * (r[0] * r[1] + r[0] * r[2] + r[1] * r[2]),
            -k * (r[0] + r[1] + r[2]),
            k,
        ]
    }

    fn cubic(c: &[f64; 4]) -> Option<f64> {
        smallest_positive_root_cubic(c[3], c[2], c[1], c[0])
    }

    // ----- roots: proptests -----

    proptest! {
        #[test]
        fn cubic_random_coefficients_match_reference(
            c0 in coefficient(), c1 in coefficient(), c2 in coefficient(), c3 in coefficient(),
        ) {
            let c = [c0, c1, c2, c3];
            check_against_reference(&c, cubic(&c))?;
        }

        #[test]
        fn quadratic_random_coefficients_match_reference(
            c0 in coefficient(), c1 in coefficient(), c2 in coefficient(),
        ) {
            let c = [c0, c1, c2];
            check_against_reference(&c, smallest_positive_root_quadratic(c2, c1, c0))?;
        }

        #[test]
        fn cubic_roots_at_different_scales(
            m in prop::array::uniform3(log_uniform(-6.0, 6.0)),
            s in prop::array::uniform3(sign()),
            k in log_uniform(-8.0, 8.0),
            ks in sign(),
        ) {
            let r = [m[0] * s[0], m[1] * s[1], m[2] * s[2]];
            for i in 0..3 {
                for j in 0..i {
                    prop_assume!(rel(r[i], r[j]) > 1e-2);
                }
            }
            let c = from_roots(k * ks, r);
            let got = cubic(&c);
            let expected = r.iter().copied().filter(|&x| x > 0.0).fold(f64::INFINITY, f64::min);
            if expected.is_finite() {
                let g = got.expect("a positive root exists");
                prop_assert!(rel(g, expected) <= 1e-9, "got {g}, expected {expected}");
            } else {
                prop_assert_eq!(got, None);
            }
            check_against_reference(&c, got)?;
        }

        #[test]
        fn quadratic_roots_at_different_scales(
            m in prop::array::uniform2(log_uniform(-8.0, 8.0)),
            s in prop::array::uniform2(sign()),
            k in log_uniform(-8.0, 8.0),
            ks in sign(),
        ) {
            let (r0, r1) = (m[0] * s[0], m[1] * s[1]);
            prop_assume!(rel(r0, r1) > 1e-3);
            let k = k * ks;
            let got = smallest_positive_root_quadratic(k, -k * (r0 + r1), k * r0 * r1);
            let expected = [r0, r1].into_iter().filter(|&x| x > 0.0).fold(f64::INFINITY, f64::min);
            if expected.is_finite() {
                let g = got.expect("a positive root exists");
                prop_assert!(rel(g, expected) <= 1e-12, "got {g}, expected {expected}");
            } else {
                prop_assert_eq!(got, None);
            }
        }

        /// Dyadic roots make the coefficients exact, so a double (or triple)
        /// root is a genuine root of the floating-point cubic.
        #[test]
        fn cubic_exact_double_and_triple_roots(
            rm in 1i32..1024, rj in 0i32..10,
            sm in -1024i32..1024, sj in 0i32..10,
            ke in -20i32..20, ks in sign(),
            triple in any::<bool>(),
        ) {
            let r = rm as f64 / 2f64.powi(rj);
            let s = if triple { r } else { sm as f64 / 2f64.powi(sj) };
            let c = from_roots(ks * 2f64.powi(ke), [r, r, s]);
            let expected = if s > 0.0 { r.min(s) } else { r };
            let g = cubic(&c).expect("the double root counts");
            prop_assert!(rel(g, expected) <= 1e-12, "got {g}, expected {expected} ({c:?})");
            // A quadratic with an exact double root.
            let q = smallest_positive_root_quadratic(ks, -2.0 * ks * r, ks * r * r);
            prop_assert_eq!(q, Some(r));
        }

        /// A double root lifted off zero disappears; pushed through zero it
        /// splits into two close simple roots.
        #[test]
        fn cubic_nearly_double_roots(
            r in log_uniform(-3.0, 3.0),
            far in log_uniform(0.5, 3.0),
            w in log_uniform(-5.0, -2.0),
            k in log_uniform(-4.0, 4.0),
            ks in sign(),
        ) {
            let k = k * ks;
            let s = r * (1.0 + far);
            let c = from_roots(k, [r, r, s]);
            // p(r +- x) = k x^2 (r - s) + O(x^3): shift by the depth of the
            // dip at half-width w r.
            let depth = (k * (r - s)).abs() * (w * r).powi(2);
            let toward = -(k * (r - s)).signum();
            let mut split = c;
            split[0] += toward * depth;
            let g = cubic(&split).expect("two roots near r");
            prop_assert!(rel(g, r * (1.0 - w)) <= 2.0 * w * w + 1e-6, "got {g}, r {r}, w {w}");
            // A genuine sign change just before g, and the dip below zero.
            prop_assert!(eval(&split, g).abs() <= 1e-12 * abs_scale(&split, g));
            let sign0 = split[0] > 0.0;
            prop_assert_eq!(eval(&split, g * (1.0 - 1e-9)) > 0.0, sign0);
            prop_assert_eq!(eval(&split, r) > 0.0, !sign0);
            let mut lifted = c;
            lifted[0] -= toward * depth;
            let got = cubic(&lifted);
            // Only the far root s remains.
            let g = got.expect("the far root remains");
            prop_assert!(rel(g, s) <= 1e-6 + 4.0 * w * w, "got {g}, s {s}");
        }

        /// The cubic term negligible where the small roots live: the answer
        /// is the quadratic's root (perturbed by the cubic term).
        #[test]
        fn cubic_tiny_leading_coefficient(
            q in log_uniform(-3.0, 3.0),
            other in log_uniform(-3.0, 3.0),
            e in 12i32..300,
            s in sign(),
        ) {
            prop_assume!(rel(q, other) > 1e-2);
            // (a - q)(a + other) + eps a^3
            let c = [-q * other, other - q, 1.0, s * 10f64.powi(-e)];
            let g = cubic(&c).expect("the quadratic's root survives");
            prop_assert!(rel(g, q) <= 1e-9, "got {g}, q {q}");
            check_against_reference(&c, Some(g))?;
        }
    }

    // ----- roots: fixed cases -----

    #[test]
    fn roots_special_cases() {
        // No positive root: negative roots, complex pairs, constants.
        assert_eq!(cubic(&from_roots(1.0, [-1.0, -2.0, -3.0])), None);
        assert_eq!(smallest_positive_root_cubic(1.0, -1.0, 0.0, 2.0), None); // (a^2-2a+2)(a+1)
        assert_eq!(smallest_positive_root_cubic(0.0, 0.0, 0.0, 1.0), None);
        assert_eq!(smallest_positive_root_cubic(0.0, 0.0, 0.0, 0.0), None);
        assert_eq!(smallest_positive_root_cubic(f64::NAN, 1.0, 1.0, 1.0), None);
        assert_eq!(
            smallest_positive_root_cubic(1.0, f64::INFINITY, 1.0, 1.0),
            None
        );
        assert_eq!(smallest_positive_root_quadratic(1.0, 0.0, 1.0), None);
        assert_eq!(smallest_positive_root_quadratic(0.0, 0.0, 0.0), None);
        // Linear fallbacks.
        assert_eq!(smallest_positive_root_cubic(0.0, 0.0, -2.0, 1.0), Some(0.5));
        assert_eq!(smallest_positive_root_quadratic(0.0, -2.0, 1.0), Some(0.5));
        assert_eq!(smallest_positive_root_quadratic(0.0, 2.0, 1.0), None);
        // A root at zero is not positive; the next one is found.
        let g = smallest_positive_root_cubic(1.0, -3.0, 2.0, 0.0).unwrap(); // a(a-1)(a-2)
        assert!(rel(g, 1.0) < 1e-15);
        assert_eq!(smallest_positive_root_quadratic(1.0, -1.0, 0.0), Some(1.0));
        // The sign of c0 does not matter.
        let p = from_roots(1.0, [0.25, 3.0, -7.0]);
        let n = p.map(|x| -x);
        assert_eq!(cubic(&p), cubic(&n));
        assert!(rel(cubic(&p).unwrap(), 0.25) < 1e-15);
        // Scale invariance in the coefficients (powers of two are exact).
        let big = p.map(|x| x * 2f64.powi(900));
        let small = p.map(|x| x * 2f64.powi(-1000));
        assert_eq!(cubic(&big), cubic(&p));
        assert_eq!(cubic(&small), cubic(&p));
        // Roots twelve orders of magnitude apart.
        let c = from_roots(1.0, [1e-6, 1.0, 1e6]);
        assert!(rel(cubic(&c).unwrap(), 1e-6) < 1e-13);
        let c = from_roots(-3.0, [-1e-6, 2e5, 1e6]);
        assert!(rel(cubic(&c).unwrap(), 2e5) < 1e-13);
        // Stable quadratic: no cancellation for disparate roots.
        let g = smallest_positive_root_quadratic(1.0, -(1e8 + 1e-8), 1.0).unwrap();
        assert!(rel(g, 1e-8) < 1e-15, "{g}");
        // A tiny quadratic coefficient: the linear root, slightly moved.
        let g = smallest_positive_root_quadratic(1e-30, -1.0, 1.0).unwrap();
        assert!(rel(g, 1.0) < 1e-15);
        // Only a huge root, created by a tiny negative cubic coefficient:
        // -1e-20 a^3 + a^2 + 1 = 0 near a = 1e20.
        let g = smallest_positive_root_cubic(-1e-20, 1.0, 0.0, 1.0).unwrap();
        assert!(rel(g, 1e20) < 1e-12, "{g}");
        // A negligible cubic term far from the root, whose critical point is
        // at 1e267: Newton from there must not crawl.
        let g = smallest_positive_root_cubic(
            5.3174253168024286e-263,
            -98095.48340595937,
            0.0,
            77870.58036719631,
        )
        .unwrap();
        assert!(
            rel(g, (77870.58036719631f64 / 98095.48340595937).sqrt()) < 1e-14,
            "{g}"
        );
        // A root beyond f64::MAX is no root.
        assert_eq!(
            smallest_positive_root_quadratic(-2.9026304011082418e-303, 648333.4837773382, 0.0),
            None
        );
        // Three close roots (where complex Cardano with a threshold fails).
        let c = from_roots(1.0, [1.0, 1.001, 1.002]);
        assert!(rel(cubic(&c).unwrap(), 1.0) < 1e-9);
        // A cubic whose Cardano discriminant is tiny: three real roots
        // 1 - 1e-3, 1, 1 + 1e-3 scaled far from 1.
        let c = from_roots(1e-5, [1e3 - 1.0, 1e3, 1e3 + 1.0]);
        assert!(rel(cubic(&c).unwrap(), 999.0) < 1e-9);
    }
}
