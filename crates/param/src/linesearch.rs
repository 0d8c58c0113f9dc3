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
//! # Robust roots
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
//! # Backtracking
//!
//! [`Backtracking`] starts at `a = min(a_init, beta a_max)` and multiplies by
//! `rho` until the objective decreases enough (Armijo) or at all (the
//! placenta paper's rule), giving up after a bounded number of halvings.

use crate::ParamError;
use rayon::prelude::*;

/// The outcome of a line search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSearchResult {
    /// The accepted step (0 when none was found).
    pub step: f64,
    /// The objective at the accepted step (the start value when none).
    pub value: f64,
    /// How many objective evaluations were made.
    pub evaluations: usize,
    /// Whether a step satisfying the acceptance rule was found.
    pub success: bool,
}

/// Picks a step along a search direction.
///
/// `phi(a)` evaluates the objective at `x + a d` (`f64::INFINITY` where it is
/// not admissible); `f0 = phi(0)`, `slope = g · d < 0`; `a_max` is the
/// largest step before some element flips (`f64::INFINITY` if none);
/// `a_init` the solver's preferred first step (1 for Newton).
pub trait LineSearch: Send + Sync + std::fmt::Debug {
    /// Searches for a step.
    fn search(
        &self,
        phi: &mut dyn FnMut(f64) -> f64,
        f0: f64,
        slope: f64,
        a_max: f64,
        a_init: f64,
    ) -> LineSearchResult;
}

// ---------------------------------------------------------------------------
// Polynomial roots
// ---------------------------------------------------------------------------

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
fn normalize(c: &mut [f64]) -> bool {
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
fn quadratic_root_scaled([c0, c1, c2]: [f64; 3]) -> Option<f64> {
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
fn cubic_root_below(mut c: [f64; 4], bound: f64) -> Option<f64> {
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

// ---------------------------------------------------------------------------
// Largest flip-free step
// ---------------------------------------------------------------------------

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

/// The first positive step at which the tet with edge matrices `Ds`
/// (`a`, columns) and `Dd` (`b`) flips, if it is at most `bound`
/// (`f64::INFINITY` otherwise).
#[inline]
fn tet_flip_step(a: [[f64; 3]; 3], b: [[f64; 3]; 3], bound: f64) -> f64 {
    // The rows of adj(Ds) and adj(Dd) are cross products of columns.
    let adj_a = [cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1])];
    let adj_b = [cross(b[1], b[2]), cross(b[2], b[0]), cross(b[0], b[1])];
    let c = [
        dot(a[0], adj_a[0]),
        dot(b[0], adj_a[0]) + dot(b[1], adj_a[1]) + dot(b[2], adj_a[2]),
        dot(a[0], adj_b[0]) + dot(a[1], adj_b[1]) + dot(a[2], adj_b[2]),
        dot(b[0], adj_b[0]),
    ];
    element_step(&c, bound, || cubic_root_below(c, bound))
}

/// The first positive step at which the triangle with edge matrices `Ds`
/// (`a`, columns) and `Dd` (`b`) flips, if it is at most `bound`.
#[inline]
fn tri_flip_step(a: [[f64; 2]; 2], b: [[f64; 2]; 2], bound: f64) -> f64 {
    let det2 = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    let c = [
        det2(a[0], a[1]),
        det2(b[0], a[1]) + det2(a[0], b[1]),
        det2(b[0], b[1]),
    ];
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
/// ([`smallest_positive_root_cubic`]); `f64::INFINITY` when no tet ever
/// flips (or there are no tets). A tet that is already inverted or flat at
/// `a = 0` (`det Ds <= 0`), or has non-finite coefficients, gives 0: no
/// positive step is admissible. The step to take is `beta a_max` or less.
/// Parallel over the tets (rayon).
///
/// # Panics
/// If `x` and `d` differ in length or an index is out of range.
pub fn max_step_tets(tets: &[[u32; 4]], x: &[f64], d: &[f64]) -> f64 {
    assert_eq!(x.len(), d.len(), "positions and direction differ in length");
    tets.par_iter()
        .with_min_len(PAR_MIN_LEN)
        .fold(
            || f64::INFINITY,
            |best, t| best.min(tet_flip_step(edges3(t, x), edges3(t, d), best)),
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
    assert_eq!(x.len(), d.len(), "positions and direction differ in length");
    tris.par_iter()
        .with_min_len(PAR_MIN_LEN)
        .fold(
            || f64::INFINITY,
            |best, t| best.min(tri_flip_step(edges2(t, x), edges2(t, d), best)),
        )
        .reduce(|| f64::INFINITY, f64::min)
}

// ---------------------------------------------------------------------------
// Backtracking
// ---------------------------------------------------------------------------

/// Backtracking line search bounded by the first flip (ALGORITHMS 1.4,
/// Smith & Schaefer 2015).
///
/// Tries `a_0 = min(a_init, beta a_max)`, then `a_j = rho^j a_0`, and accepts
/// the first finite `phi(a_j)` with
///
/// - `armijo = Some(c)`: `phi(a) - phi(0) <= c a (g · d)` and
///   `phi(a) < phi(0)` (sufficient decrease, the default, `c = 1e-4`);
/// - `armijo = None`: `phi(a) < phi(0)` (plain decrease, the placenta
///   paper's rule).
///
/// The strict decrease is also required under Armijo so a step whose gain is
/// below floating-point resolution is not reported as progress. Candidates
/// `>= a_max` (possible only with `beta >= 1`) are skipped, never evaluated
/// nor returned. After `max_halvings` reductions without success it returns
/// `success: false`, step 0 and `value = phi(0)`; at most
/// `max_halvings + 1` evaluations are made.
///
/// Without an admissible start it fails at once (0 evaluations): `a_max <= 0`
/// (an element is already flat), `a_0` not finite (both `a_init` and `a_max`
/// infinite: give a finite `a_init`), `phi(0)` not finite, or, under Armijo,
/// `g · d >= 0` (not a descent direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backtracking {
    /// Fraction of `a_max` for the first step (0.9), in `(0, 1]`.
    pub beta: f64,
    /// Shrink factor per rejection (0.5), in `(0, 1)`.
    pub rho: f64,
    /// Armijo constant `c` in `(0, 1)` (`Some(1e-4)`), or `None` for plain
    /// decrease.
    pub armijo: Option<f64>,
    /// Maximum number of reductions by `rho` before giving up (60).
    pub max_halvings: usize,
}

impl Default for Backtracking {
    /// Armijo backtracking: `beta = 0.9`, `rho = 0.5`, `c = 1e-4`,
    /// 60 halvings.
    fn default() -> Self {
        Backtracking {
            beta: 0.9,
            rho: 0.5,
            armijo: Some(1e-4),
            max_halvings: 60,
        }
    }
}

impl Backtracking {
    /// The placenta paper's rule (Algorithm 1): `a = 0.9 a_max`, halve until
    /// the objective decreases at all (`armijo = None`), 60 halvings.
    pub fn paper() -> Self {
        Backtracking {
            armijo: None,
            ..Self::default()
        }
    }

    /// Checks the parameters: `beta` in `(0, 1]`, `rho` in `(0, 1)`, the
    /// Armijo constant in `(0, 1)`. ([`LineSearch::search`] stays bounded
    /// and below `a_max` with any parameters, but may then never succeed.)
    pub fn validate(&self) -> Result<(), ParamError> {
        if !(self.beta > 0.0 && self.beta <= 1.0) {
            return Err(ParamError::InvalidArgument(format!(
                "backtracking beta must be in (0, 1], got {}",
                self.beta
            )));
        }
        if !(self.rho > 0.0 && self.rho < 1.0) {
            return Err(ParamError::InvalidArgument(format!(
                "backtracking rho must be in (0, 1), got {}",
                self.rho
            )));
        }
        if let Some(c) = self.armijo
            && !(c > 0.0 && c < 1.0)
        {
            return Err(ParamError::InvalidArgument(format!(
                "Armijo constant must be in (0, 1), got {c}"
            )));
        }
        Ok(())
    }
}

impl LineSearch for Backtracking {
    fn search(
        &self,
        phi: &mut dyn FnMut(f64) -> f64,
        f0: f64,
        slope: f64,
        a_max: f64,
        a_init: f64,
    ) -> LineSearchResult {
        let fail = |evaluations| LineSearchResult {
            step: 0.0,
            value: f0,
            evaluations,
            success: false,
        };
        if !f0.is_finite() || a_max.is_nan() || a_max <= 0.0 || a_init.is_nan() || a_init <= 0.0 {
            return fail(0);
        }
        if self.armijo.is_some() && (slope.is_nan() || slope >= 0.0) {
            return fail(0);
        }
        let mut a = a_init.min(self.beta * a_max);
        if !a.is_finite() {
            return fail(0);
        }
        let mut evaluations = 0;
        for _ in 0..=self.max_halvings {
            if a > 0.0 && a < a_max {
                let value = phi(a);
                evaluations += 1;
                let accepted = value.is_finite()
                    && value < f0
                    && self.armijo.is_none_or(|c| value - f0 <= c * a * slope);
                if accepted {
                    return LineSearchResult {
                        step: a,
                        value,
                        evaluations,
                        success: true,
                    };
                }
            } else if a.is_nan() || a <= 0.0 {
                break;
            }
            a *= self.rho;
        }
        fail(evaluations)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::shapes::{grid_disk, kuhn_grid};

    fn det3(u: [f64; 3], v: [f64; 3], w: [f64; 3]) -> f64 {
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

    fn rel(a: f64, b: f64) -> f64 {
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

    fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
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
            .map(|t| tet_flip_step(edges3(t, &x), edges3(t, &d), f64::INFINITY))
            .fold(f64::INFINITY, f64::min);
        let parallel = max_step_tets(&mesh.tets, &x, &d);
        assert!(mesh.tets.len() > PAR_MIN_LEN);
        assert_eq!(parallel, serial);
        assert!(parallel.is_finite());
    }

    // ----- backtracking -----

    #[test]
    fn backtracking_defaults() {
        let b = Backtracking::default();
        assert_eq!(
            (b.beta, b.rho, b.armijo, b.max_halvings),
            (0.9, 0.5, Some(1e-4), 60)
        );
        let p = Backtracking::paper();
        assert_eq!((p.beta, p.rho, p.armijo), (0.9, 0.5, None));
        assert!(b.validate().is_ok() && p.validate().is_ok());
        assert!(Backtracking { rho: 1.0, ..b }.validate().is_err());
        assert!(Backtracking { beta: 0.0, ..b }.validate().is_err());
        assert!(
            Backtracking {
                armijo: Some(1.5),
                ..b
            }
            .validate()
            .is_err()
        );
    }

    #[test]
    fn backtracking_accepts_newton_step() {
        // phi(a) = (a - 1)^2: the full step is optimal.
        let mut phi = |a: f64| (a - 1.0) * (a - 1.0);
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, f64::INFINITY, 1.0);
        assert_eq!(
            r,
            LineSearchResult {
                step: 1.0,
                value: 0.0,
                evaluations: 1,
                success: true
            }
        );
        // Bounded by a_max: starts at 0.9 a_max.
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, 0.3, 1.0);
        assert!(r.success && r.step == 0.9 * 0.3 && r.evaluations == 1);
        // Too long a first step: halved until Armijo holds.
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, f64::INFINITY, 8.0);
        assert!(r.success && r.step == 1.0 && r.evaluations == 4);
    }

    #[test]
    fn backtracking_gives_up_on_a_function_that_never_decreases() {
        for ls in [Backtracking::default(), Backtracking::paper()] {
            let mut calls = 0;
            let mut phi = |a: f64| {
                calls += 1;
                1.0 + a
            };
            let r = ls.search(&mut phi, 1.0, -1.0, 10.0, 1.0);
            assert_eq!(
                r,
                LineSearchResult {
                    step: 0.0,
                    value: 1.0,
                    evaluations: 61,
                    success: false
                }
            );
            assert_eq!(calls, 61);
            // A constant: no decrease at all, even below resolution.
            let r = ls.search(&mut |_| 1.0, 1.0, -1.0, 10.0, 1.0);
            assert!(!r.success && r.step == 0.0);
        }
    }

    #[test]
    fn backtracking_handles_infinity_and_nan() {
        // Admissible only below 0.1 (a barrier energy past a flip).
        let mut phi = |a: f64| {
            if a > 0.1 {
                f64::INFINITY
            } else {
                (a - 1.0).powi(2)
            }
        };
        let r = Backtracking::default().search(&mut phi, 1.0, -2.0, f64::INFINITY, 1.0);
        assert!(r.success && r.step <= 0.1 && r.value.is_finite());
        assert_eq!(r.step, 0.0625);
        let mut phi = |a: f64| if a > 0.3 { f64::NAN } else { 1.0 - a };
        let r = Backtracking::paper().search(&mut phi, 1.0, -1.0, f64::INFINITY, 1.0);
        assert!(r.success && r.step == 0.25);
    }

    #[test]
    fn backtracking_paper_rule_vs_armijo() {
        // A decrease far weaker than the slope promises.
        let mut phi = |a: f64| 1.0 - 1e-9 * a;
        let r = Backtracking::paper().search(&mut phi, 1.0, -1.0, f64::INFINITY, 1.0);
        assert!(r.success && r.step == 1.0);
        let r = Backtracking::default().search(&mut phi, 1.0, -1.0, f64::INFINITY, 1.0);
        assert!(!r.success && r.evaluations == 61);
    }

    #[test]
    fn backtracking_inadmissible_starts() {
        let mut phi = |a: f64| (a - 1.0).powi(2);
        let ls = Backtracking::default();
        let failed = |r: LineSearchResult| !r.success && r.step == 0.0 && r.evaluations == 0;
        assert!(failed(ls.search(&mut phi, 1.0, -2.0, 0.0, 1.0)));
        assert!(failed(ls.search(
            &mut phi,
            1.0,
            -2.0,
            f64::INFINITY,
            f64::INFINITY
        )));
        assert!(failed(ls.search(&mut phi, f64::INFINITY, -2.0, 1.0, 1.0)));
        assert!(failed(ls.search(&mut phi, 1.0, 2.0, 1.0, 1.0)));
        assert!(failed(ls.search(&mut phi, 1.0, f64::NAN, 1.0, 1.0)));
        // beta = 1 never reaches a_max; rho >= 1 stays bounded.
        let r = Backtracking { beta: 1.0, ..ls }.search(&mut phi, 1.0, -2.0, 0.5, 5.0);
        assert!(r.success && r.step == 0.25);
        let r = Backtracking {
            beta: 1.0,
            rho: 1.0,
            max_halvings: 5,
            ..ls
        }
        .search(&mut phi, 1.0, -2.0, 0.5, 5.0);
        assert!(!r.success && r.evaluations == 0);
        let r = Backtracking { rho: 2.0, ..ls }.search(&mut |_| 2.0, 1.0, -2.0, 0.5, 0.1);
        assert!(!r.success && r.evaluations <= 61);
    }

    proptest! {
        #[test]
        fn backtracking_satisfies_its_rule(
            curvature in log_uniform(-3.0, 3.0),
            slope in -10.0f64..-1e-3,
            a_max in prop_oneof![Just(f64::INFINITY), log_uniform(-3.0, 2.0)],
            a_init in log_uniform(-2.0, 2.0),
            barrier in prop_oneof![Just(f64::INFINITY), log_uniform(-3.0, 1.0)],
            armijo in any::<bool>(),
        ) {
            // phi(a) = f0 + slope a + curvature a^2 / 2, infinite past the barrier.
            let f0 = 3.0;
            let mut evals = 0;
            let mut phi = |a: f64| {
                evals += 1;
                if a >= barrier { f64::INFINITY } else { f0 + slope * a + 0.5 * curvature * a * a }
            };
            let ls = if armijo { Backtracking::default() } else { Backtracking::paper() };
            let r = ls.search(&mut phi, f0, slope, a_max, a_init);
            prop_assert_eq!(r.evaluations, evals);
            prop_assert!(r.evaluations <= ls.max_halvings + 1);
            // A descent direction on a smooth function always succeeds.
            prop_assert!(r.success);
            prop_assert!(r.step > 0.0 && r.step < a_max && r.step <= ls.beta * a_max);
            prop_assert!(r.step <= a_init && r.step < barrier);
            prop_assert!(r.value < f0);
            if armijo {
                prop_assert!(r.value - f0 <= 1e-4 * r.step * slope);
            }
            // The previous (doubled) candidate was rejected.
            if r.evaluations > 1 {
                let prev = r.step / ls.rho;
                let v = if prev >= barrier { f64::INFINITY } else { f0 + slope * prev + 0.5 * curvature * prev * prev };
                let ok = v.is_finite() && v < f0 && (!armijo || v - f0 <= 1e-4 * prev * slope);
                prop_assert!(!ok);
            }
        }
    }
}
