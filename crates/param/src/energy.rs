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
//! The Hessian uses the analytic eigensystem of Smith, Goldstein and Sifakis
//! (2019), valid for every isotropic `psi(s)` (separable or not). With
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

use std::f64::consts::FRAC_1_SQRT_2;
use std::fmt::Debug;

use nalgebra::{Matrix2, Matrix3, Matrix4, SMatrix, Vector2, Vector3};

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
    /// The minimum value (at rotations) in dimension `dim`.
    fn minimum(&self, dim: usize) -> f64;
    /// Whether the energy is infinite at `det J -> 0` (a barrier against
    /// inversion). Energies without a barrier rely on the injective line
    /// search alone.
    fn is_barrier(&self) -> bool;
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

// ---------------------------------------------------------------------------
// Energies
// ---------------------------------------------------------------------------

/// Symmetric Dirichlet, `psi(s) = sum_i s_i^2 + s_i^-2 = |F|_F^2 + |F^-1|_F^2`.
///
/// Minimum `2 d` at rotations (4 in 2D, 6 in 3D); a barrier (infinite for
/// any `s_i <= 0`). Separable with `f(s) = s^2 + s^-2`:
///
/// ```text
/// dpsi/ds_i  = 2 s_i - 2 s_i^-3            (dpsi/dF = 2 F - 2 F^-T F^-1 F^-T)
/// d2psi/ds_i^2 = 2 + 6 s_i^-4              (off-diagonal 0)
/// twist(i,j) = 2 - 2 (s_i^2 - s_i s_j + s_j^2) / (s_i^3 s_j^3)   (can be < 0)
/// flip(i,j)  = 2 + 2 (s_i^2 + s_i s_j + s_j^2) / (s_i^3 s_j^3)
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct SymmetricDirichlet;

impl DistortionEnergy for SymmetricDirichlet {
    fn name(&self) -> &'static str {
        "symmetric-dirichlet"
    }
    fn value(&self, s: &[f64]) -> f64 {
        if !all_positive(s) {
            return f64::INFINITY;
        }
        s.iter()
            .map(|&x| {
                let x2 = x * x;
                x2 + 1.0 / x2
            })
            .sum()
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(s) {
            *o = 2.0 * x - 2.0 / (x * x * x);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        out[..d * d].fill(0.0);
        for (i, &x) in s.iter().enumerate() {
            let x2 = x * x;
            out[i * d + i] = 2.0 + 6.0 / (x2 * x2);
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (a, b) = (s[i], s[j]);
        let ab = a * b;
        2.0 + 2.0 * (a * a + ab + b * b) / (ab * ab * ab)
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (a, b) = (s[i], s[j]);
        let ab = a * b;
        2.0 - 2.0 * (a * a - ab + b * b) / (ab * ab * ab)
    }
    /// With `I2 = |F|_F^2`, `I3 = det F`: `psi = I2 (1 + I3^-2)` and
    /// `dpsi/dF = 2 (1 + I3^-2) F - 2 I2 I3^-3 cof F`,
    /// `cof F = [[f22, -f21], [-f12, f11]]`; infinite for `I3 <= 0`.
    fn closed_form2(&self, f: &Matrix2<f64>, grad: Option<&mut Matrix2<f64>>) -> Option<f64> {
        let det = f.m11 * f.m22 - f.m12 * f.m21;
        if det.is_nan() || det <= 0.0 {
            return Some(f64::INFINITY);
        }
        let i2 = f.m11 * f.m11 + f.m12 * f.m12 + f.m21 * f.m21 + f.m22 * f.m22;
        let r = 1.0 / (det * det);
        let value = i2 * (1.0 + r);
        if !value.is_finite() {
            return Some(f64::INFINITY);
        }
        if let Some(g) = grad {
            let k = 2.0 * (1.0 + r);
            let c = 2.0 * i2 * r / det;
            *g = Matrix2::new(
                k * f.m11 - c * f.m22,
                k * f.m12 + c * f.m21,
                k * f.m21 + c * f.m12,
                k * f.m22 - c * f.m11,
            );
        }
        Some(value)
    }
    fn minimum(&self, dim: usize) -> f64 {
        2.0 * dim as f64
    }
    fn is_barrier(&self) -> bool {
        true
    }
}

/// MIPS (most isometric parameterization), the conformal (angle) distortion
/// `psi(s) = |F|_F^2 / (det F)^(2/d) = (sum_i s_i^2) / (prod_i s_i)^(2/d)`.
///
/// In 2D this is `s1/s2 + s2/s1` (ALGORITHMS 1.2), minimum 2. In 3D it is the
/// same scale-invariant formula, `(s1^2 + s2^2 + s3^2) / (s1 s2 s3)^(2/3)`,
/// minimum 3 (so `minimum(d) = d`; divide by `d` for the variant with
/// minimum 1). A barrier (infinite for any `s_i <= 0`). Not convex: the
/// twist eigenvalues are `<= 0`. With `S = sum s_k^2`, `c = (prod s_k)^(-2/d)`:
///
/// ```text
/// dpsi/ds_i  = c (2 s_i - (2/d) S / s_i)
/// d2psi/ds_i ds_j = c [ 2 d_ij + (2/d) d_ij S / s_i^2
///                       - (4/d) (s_i / s_j + s_j / s_i) + (4/d^2) S / (s_i s_j) ]
/// twist(i,j) = c (2 - (2/d) S / (s_i s_j))
/// flip(i,j)  = c (2 + (2/d) S / (s_i s_j))
/// ```
///
/// (2D: twist `-(s1 - s2)^2 / (s1 s2)^2`, flip `(s1 + s2)^2 / (s1 s2)^2`.)
#[derive(Debug, Clone, Copy, Default)]
pub struct Mips;

impl Mips {
    /// `(S, c) = (sum s_k^2, (prod s_k)^(-2/d))`.
    #[inline]
    fn parts(s: &[f64]) -> (f64, f64) {
        let sum2: f64 = s.iter().map(|&x| x * x).sum();
        let p = product(s);
        let c = match s.len() {
            2 => 1.0 / p,
            3 => {
                let r = p.cbrt();
                1.0 / (r * r)
            }
            d => p.powf(-2.0 / d as f64),
        };
        (sum2, c)
    }
}

impl DistortionEnergy for Mips {
    fn name(&self) -> &'static str {
        "mips"
    }
    fn value(&self, s: &[f64]) -> f64 {
        if !all_positive(s) {
            return f64::INFINITY;
        }
        let (sum2, c) = Mips::parts(s);
        sum2 * c
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        for (o, &x) in out.iter_mut().zip(s) {
            *o = c * (2.0 * x - k * sum2 / x);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / d as f64;
        for i in 0..d {
            for j in 0..d {
                let (a, b) = (s[i], s[j]);
                let mut h = -2.0 * k * (a / b + b / a) + k * k * sum2 / (a * b);
                if i == j {
                    h += 2.0 + k * sum2 / (a * a);
                }
                out[i * d + j] = c * h;
            }
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        c * (2.0 + k * sum2 / (s[i] * s[j]))
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        c * (2.0 - k * sum2 / (s[i] * s[j]))
    }
    fn pair_eigenvalues(&self, s: &[f64], twist: &mut [f64], flip: &mut [f64]) {
        let (sum2, c) = Mips::parts(s);
        let k = 2.0 / s.len() as f64;
        let npairs = s.len() * (s.len() - 1) / 2;
        for (m, &(i, j)) in PAIRS[..npairs].iter().enumerate() {
            let x = k * sum2 / (s[i] * s[j]);
            twist[m] = c * (2.0 - x);
            flip[m] = c * (2.0 + x);
        }
    }
    fn minimum(&self, dim: usize) -> f64 {
        dim as f64
    }
    fn is_barrier(&self) -> bool {
        true
    }
}

/// As-rigid-as-possible, `psi(s) = sum_i (s_i - 1)^2 = min_R |F - R|_F^2`
/// over rotations `R` (signed singular values, so inverted elements are
/// measured against the closest *rotation*).
///
/// Minimum 0 at rotations; no barrier (finite for inverted elements, so it
/// relies on the injective line search). Separable with `f(s) = (s - 1)^2`:
///
/// ```text
/// dpsi/ds_i  = 2 (s_i - 1)                 (dpsi/dF = 2 (F - R), R = U V^T)
/// d2psi/ds2  = 2 I
/// twist(i,j) = 2 - 4 / (s_i + s_j)         (< 0 when s_i + s_j < 2)
/// flip(i,j)  = 2
/// ```
///
/// The twist eigenvalue is unbounded as `s_i + s_j -> 0` (flat or inverted
/// elements with `|s_i| = |s_j|`, where the closest rotation is not unique);
/// see [`DistortionEnergy::twist_eigenvalue`] for the floor used there.
#[derive(Debug, Clone, Copy, Default)]
pub struct Arap;

impl DistortionEnergy for Arap {
    fn name(&self) -> &'static str {
        "arap"
    }
    fn value(&self, s: &[f64]) -> f64 {
        s.iter().map(|&x| (x - 1.0) * (x - 1.0)).sum()
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(s) {
            *o = 2.0 * (x - 1.0);
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        out[..d * d].fill(0.0);
        for i in 0..d {
            out[i * d + i] = 2.0;
        }
    }
    fn flip_eigenvalue(&self, _s: &[f64], _i: usize, _j: usize) -> f64 {
        2.0
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        2.0 - 4.0 / twist_denominator(s[i], s[j])
    }
    fn minimum(&self, _dim: usize) -> f64 {
        0.0
    }
    fn is_barrier(&self) -> bool {
        false
    }
}

/// Area ratio (2D) / volume ratio (3D), `psi(s) = P + 1/P` with
/// `P = prod_i s_i = det F` (`A/Â + Â/A`, resp. `V/V̂ + V̂/V`).
///
/// Minimum 2 wherever `det F = 1` (in particular at rotations); a barrier
/// (infinite for `P <= 0`, i.e. any `s_i <= 0`). Measures only the change of
/// measure, not the shape, so its Hessian has a `d^2 - 1` dimensional
/// kernel-or-negative part: pair it with a shape energy. With `P = prod s_k`:
///
/// ```text
/// dpsi/ds_i  = (P - 1/P) / s_i
/// d2psi/ds_i^2 = 2 / (P s_i^2),  d2psi/ds_i ds_j = (P + 1/P) / (s_i s_j)  (i != j)
/// twist(i,j) =  (P - 1/P) / (s_i s_j)
/// flip(i,j)  = -(P - 1/P) / (s_i s_j)
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct AreaRatio;

impl DistortionEnergy for AreaRatio {
    fn name(&self) -> &'static str {
        "area-ratio"
    }
    fn value(&self, s: &[f64]) -> f64 {
        let p = product(s);
        if !all_positive(s) || p <= 0.0 {
            return f64::INFINITY;
        }
        p + 1.0 / p
    }
    fn gradient(&self, s: &[f64], out: &mut [f64]) {
        let p = product(s);
        let a = p - 1.0 / p;
        for (o, &x) in out.iter_mut().zip(s) {
            *o = a / x;
        }
    }
    fn hessian(&self, s: &[f64], out: &mut [f64]) {
        let d = s.len();
        let p = product(s);
        let b = p + 1.0 / p;
        for i in 0..d {
            for j in 0..d {
                out[i * d + j] = if i == j {
                    2.0 / (p * s[i] * s[i])
                } else {
                    b / (s[i] * s[j])
                };
            }
        }
    }
    fn flip_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let p = product(s);
        -(p - 1.0 / p) / (s[i] * s[j])
    }
    fn twist_eigenvalue(&self, s: &[f64], i: usize, j: usize) -> f64 {
        let p = product(s);
        (p - 1.0 / p) / (s[i] * s[j])
    }
    fn minimum(&self, _dim: usize) -> f64 {
        2.0
    }
    fn is_barrier(&self) -> bool {
        true
    }
}

/// The names [`energy_by_name`] accepts, in a stable order.
pub const ENERGY_NAMES: [&str; 4] = ["symmetric-dirichlet", "mips", "arap", "area-ratio"];

/// The energy called `name`: `"symmetric-dirichlet"` ([`SymmetricDirichlet`]),
/// `"mips"` ([`Mips`]), `"arap"` ([`Arap`]) or `"area-ratio"` ([`AreaRatio`]);
/// `None` for anything else (see [`ENERGY_NAMES`]).
pub fn energy_by_name(name: &str) -> Option<Box<dyn DistortionEnergy>> {
    match name {
        "symmetric-dirichlet" => Some(Box::new(SymmetricDirichlet)),
        "mips" => Some(Box::new(Mips)),
        "arap" => Some(Box::new(Arap)),
        "area-ratio" => Some(Box::new(AreaRatio)),
        _ => None,
    }
}

// ---------------------------------------------------------------------------
// Signed SVD
// ---------------------------------------------------------------------------

/// `sqrt(a^2 + b^2)`: the plain formula (several times faster than
/// `f64::hypot`), falling back to `hypot` where the squares overflow or
/// underflow.
#[inline]
fn norm2(a: f64, b: f64) -> f64 {
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
const JACOBI_MAX_SWEEPS: usize = 30;

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

// ---------------------------------------------------------------------------
// Element evaluation in F = J
// ---------------------------------------------------------------------------

/// Which Hessian [`eval2`] / [`eval3`] compute (default: `Projected`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum HessianMode {
    /// Value and gradient only.
    None,
    /// `d2psi/dF2` assembled from the analytic eigensystem with the raw
    /// eigenvalues (may be indefinite).
    Exact,
    /// The same with every eigenvalue clamped at 0 (PSD), for Newton.
    #[default]
    Projected,
}

/// A 2D element evaluation: `psi(F)`, `dpsi/dF` (2x2) and optionally
/// `d2psi/dF2` (4x4 over column-major `vec(F)`, entry `F[(i, j)]` at
/// index `i + 2 j`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eval2 {
    /// `psi(s(F))`.
    pub value: f64,
    /// `dpsi/dF = U diag(dpsi/ds) V^T`.
    pub grad: Matrix2<f64>,
    /// `d2psi/dF2` (exact or projected), if requested.
    pub hess: Option<Matrix4<f64>>,
}

/// A 3D element evaluation: `psi(F)`, `dpsi/dF` (3x3) and optionally
/// `d2psi/dF2` (9x9 over column-major `vec(F)`, entry `F[(i, j)]` at
/// index `i + 3 j`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eval3 {
    /// `psi(s(F))`.
    pub value: f64,
    /// `dpsi/dF = U diag(dpsi/ds) V^T`.
    pub grad: Matrix3<f64>,
    /// `d2psi/dF2` (exact or projected), if requested.
    pub hess: Option<SMatrix<f64, 9, 9>>,
}

/// PSD projection of a symmetric 3x3 matrix: unchanged when diagonal
/// (clamped) or positive definite (Cholesky succeeds), else eigenvalues
/// clamped at 0 through [`sym_eigen3`].
#[allow(clippy::needless_range_loop)]
fn project_sym3(h: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let off = h[0][1].abs() + h[0][2].abs() + h[1][2].abs();
    if off == 0.0 {
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            out[i][i] = h[i][i].max(0.0);
        }
        return out;
    }
    let m = Matrix3::from_fn(|i, j| h[i][j]);
    if !m.iter().all(|x| x.is_finite()) || m.cholesky().is_some() {
        return h;
    }
    let (l, w) = sym_eigen3(h);
    let mut out = [[0.0; 3]; 3];
    for k in 0..3 {
        if l[k] > 0.0 {
            for i in 0..3 {
                for j in 0..3 {
                    out[i][j] += l[k] * w[k][i] * w[k][j];
                }
            }
        }
    }
    out
}

/// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi
/// rotations `A <- J^T A J` (quadratic convergence, stops when every
/// off-diagonal entry is below `1e-18 |A|_F`): eigenvalues `l` and unit
/// eigenvectors `w[k]`, `A = sum_k l_k w_k w_k^T`. Accurate to `eps |A|`
/// also for repeated eigenvalues.
#[allow(clippy::needless_range_loop)]
fn sym_eigen3(h: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut a = h;
    let mut w = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let fro = a.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    let tol = 1e-18 * fro;
    for _sweep in 0..JACOBI_MAX_SWEEPS {
        let mut rotated = false;
        for &(p, q) in &PAIRS {
            let apq = a[p][q];
            if apq.abs() <= tol {
                continue;
            }
            rotated = true;
            let (dd, g2) = (a[q][q] - a[p][p], 2.0 * apq);
            let t = g2 / (dd + (dd * dd + g2 * g2).sqrt().copysign(dd));
            let c = 1.0 / (1.0 + t * t).sqrt();
            let s = c * t;
            // A J (columns p, q), then J^T (A J) (rows p, q).
            for k in 0..3 {
                let (x, y) = (a[k][p], a[k][q]);
                a[k][p] = c * x - s * y;
                a[k][q] = s * x + c * y;
            }
            for k in 0..3 {
                let (x, y) = (a[p][k], a[q][k]);
                a[p][k] = c * x - s * y;
                a[q][k] = s * x + c * y;
            }
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            // W J: eigenvectors as w[k] (columns of W).
            let (wp, wq) = (w[p], w[q]);
            for k in 0..3 {
                w[p][k] = c * wp[k] - s * wq[k];
                w[q][k] = s * wp[k] + c * wq[k];
            }
        }
        if !rotated {
            break;
        }
    }
    ([a[0][0], a[1][1], a[2][2]], w)
}

/// The pairs `(i, j)`, `i < j`, of `N` singular values (first 1 in 2D, all
/// 3 in 3D).
const PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];

/// `d2psi/dF2` over column-major `vec(F)` (`M = N^2`) from the signed SVD,
/// the (already projected, if requested) scaling block `hs = d2psi/ds2` and
/// the pair eigenvalues:
///
/// ```text
/// H = D hs D^T + sum_pairs l_twist t t^T + l_flip f f^T
/// D = [vec(u_a v_a^T)]_a,  t, f = vec(u_i v_j^T -/+ u_j v_i^T) / sqrt 2
/// ```
#[inline]
#[allow(clippy::needless_range_loop)]
fn assemble_hessian<const N: usize, const M: usize>(
    e: &dyn DistortionEnergy,
    u: &SMatrix<f64, N, N>,
    s: &[f64; N],
    v: &SMatrix<f64, N, N>,
    hs: &[[f64; N]; N],
    project: bool,
) -> SMatrix<f64, M, M> {
    debug_assert_eq!(M, N * N);
    // Scaling modes D (M x N) and P = D hs.
    let mut d = [[0.0; N]; M];
    for c in 0..N {
        for r in 0..N {
            for a in 0..N {
                d[r + N * c][a] = u[(r, a)] * v[(c, a)];
            }
        }
    }
    let mut p = [[0.0; N]; M];
    for r in 0..M {
        for b in 0..N {
            let mut x = 0.0;
            for a in 0..N {
                x += d[r][a] * hs[a][b];
            }
            p[r][b] = x;
        }
    }
    // Twist and flip modes, scaled so that H += l w w^T.
    let npairs = N * (N - 1) / 2;
    let mut twist = [0.0; 3];
    let mut flip = [0.0; 3];
    e.pair_eigenvalues(s, &mut twist[..npairs], &mut flip[..npairs]);
    let mut modes = [[0.0; M]; 6];
    let mut lam = [0.0; 6];
    for (k, &(i, j)) in PAIRS[..npairs].iter().enumerate() {
        let mut lt = twist[k];
        let mut lf = flip[k];
        if project {
            lt = lt.max(0.0);
            lf = lf.max(0.0);
        }
        lam[2 * k] = lt;
        lam[2 * k + 1] = lf;
        for c in 0..N {
            for r in 0..N {
                let x = u[(r, i)] * v[(c, j)];
                let y = u[(r, j)] * v[(c, i)];
                modes[2 * k][r + N * c] = FRAC_1_SQRT_2 * (x - y);
                modes[2 * k + 1][r + N * c] = FRAC_1_SQRT_2 * (x + y);
            }
        }
    }
    let nmodes = 2 * npairs;
    let mut out = SMatrix::<f64, M, M>::zeros();
    for col in 0..M {
        for row in 0..=col {
            let mut x = 0.0;
            for b in 0..N {
                x += p[row][b] * d[col][b];
            }
            for k in 0..nmodes {
                x += lam[k] * modes[k][row] * modes[k][col];
            }
            out[(row, col)] = x;
            out[(col, row)] = x;
        }
    }
    out
}

/// The Hessian `d2psi/dF2` of a 2D element as its eigensystem:
///
/// ```text
/// d2psi/dF2 = sum_k values[k] vec(modes[k]) vec(modes[k])^T
/// ```
///
/// with four Frobenius-orthonormal 2x2 `modes` (signed SVD
/// `F = U diag(s) V^T`): the two scaling modes `U diag(w) V^T` (`w` the unit
/// eigenvectors of `d2psi/ds2`, whose eigenvalues they carry), the twist
/// `U [[0, -1], [1, 0]] V^T / sqrt 2` and the flip
/// `U [[0, 1], [1, 0]] V^T / sqrt 2` (module docs). Projected, every
/// eigenvalue is clamped at 0.
///
/// A rank-one sum is what a vertex Hessian wants: with `C` the map from the
/// 6 vertex coordinates to `vec(F)`, `C^T H C = sum_k l_k (C^T m_k)(C^T m_k)^T`,
/// four 6-vectors instead of a 4x4 product on each side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eigen2 {
    /// The eigenvalues `l_k` (clamped at 0 when projected).
    pub values: [f64; 4],
    /// The unit eigenvectors `m_k` as 2x2 matrices.
    pub modes: [Matrix2<f64>; 4],
}

impl Eigen2 {
    /// `sum_k l_k vec(m_k) vec(m_k)^T` (4x4 over column-major `vec(F)`).
    pub fn matrix(&self) -> Matrix4<f64> {
        let mut h = Matrix4::zeros();
        for (l, m) in self.values.iter().zip(&self.modes) {
            let v = [m[(0, 0)], m[(1, 0)], m[(0, 1)], m[(1, 1)]];
            for c in 0..4 {
                for r in 0..4 {
                    h[(r, c)] += l * v[r] * v[c];
                }
            }
        }
        h
    }
}

/// Value, gradient and Hessian eigensystem of `psi` at a 2x2 `F`: the
/// common part of [`eval2`] (value and gradient from the closed form where
/// the energy has one), for callers that want the Hessian as a sum of
/// rank-one terms ([`Eigen2`]). `mode` is `Exact` or `Projected` (`None`
/// is taken as `Projected`). `None` when `psi(F)` is not finite. No heap
/// allocation.
pub fn eval2_eigen(
    e: &dyn DistortionEnergy,
    f: &Matrix2<f64>,
    mode: HessianMode,
) -> Option<(f64, Matrix2<f64>, Eigen2)> {
    let mut grad = Matrix2::zeros();
    let closed = e.closed_form2(f, Some(&mut grad));
    match closed {
        Some(x) if !x.is_finite() => return None,
        None if e.is_barrier() && nonpositive_or_nan(f.determinant()) => return None,
        _ => {}
    }
    let (u, sv, v) = signed_svd2(f);
    let s = [sv[0], sv[1]];
    let value = match closed {
        Some(x) => x,
        None => {
            let x = e.value(&s);
            if !x.is_finite() {
                return None;
            }
            let mut g = [0.0; 2];
            e.gradient(&s, &mut g);
            grad = grad2(&u, &g, &v);
            x
        }
    };
    Some((value, grad, eigen_from_svd(e, &u, &s, &v, mode)))
}

/// The Hessian eigensystem alone ([`Eigen2`]), for assemblies that take
/// value and gradient elsewhere: `None` exactly where [`eval2_eigen`] is
/// (`psi(F)` not finite), the same eigensystem otherwise.
pub fn hessian2_eigen(
    e: &dyn DistortionEnergy,
    f: &Matrix2<f64>,
    mode: HessianMode,
) -> Option<Eigen2> {
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return None;
    }
    let (u, sv, v) = signed_svd2(f);
    let s = [sv[0], sv[1]];
    let admissible = match e.closed_form2(f, None) {
        Some(x) => x.is_finite(),
        None => e.value(&s).is_finite(),
    };
    admissible.then(|| eigen_from_svd(e, &u, &s, &v, mode))
}

/// The eigensystem of [`Eigen2`] from the signed SVD.
#[inline]
fn eigen_from_svd(
    e: &dyn DistortionEnergy,
    u: &Matrix2<f64>,
    s: &[f64; 2],
    v: &Matrix2<f64>,
    mode: HessianMode,
) -> Eigen2 {
    let (u0, u1) = (u.column(0), u.column(1));
    let (v0, v1) = (v.column(0), v.column(1));
    let project = mode != HessianMode::Exact;
    // Scaling block: a Jacobi rotation diagonalizes the symmetric 2x2
    // d2psi/ds2 = [[a, b], [b, c]] (t = tan of the angle, the smaller root
    // of t^2 + 2 z t - 1 = 0, z = (c - a) / 2b).
    let mut h = [0.0; 4];
    e.hessian(s, &mut h);
    let (a, b, c) = (h[0], 0.5 * (h[1] + h[2]), h[3]);
    let (l0, l1, cs, sn) = if b == 0.0 {
        (a, c, 1.0, 0.0)
    } else {
        let z = (c - a) / (2.0 * b);
        let t = (1.0f64).copysign(z) / (z.abs() + norm2(1.0, z));
        let cs = 1.0 / norm2(1.0, t);
        (a - t * b, c + t * b, cs, t * cs)
    };
    let mut twist = [0.0; 1];
    let mut flip = [0.0; 1];
    e.pair_eigenvalues(s, &mut twist, &mut flip);
    let mut values = [l0, l1, twist[0], flip[0]];
    if project {
        for l in &mut values {
            *l = l.max(0.0);
        }
    }
    // Eigenvectors (cs, -sn) and (sn, cs) of the scaling block.
    let p0 = u0 * v0.transpose();
    let p1 = u1 * v1.transpose();
    let x = u0 * v1.transpose();
    let y = u1 * v0.transpose();
    let modes = [
        p0 * cs - p1 * sn,
        p0 * sn + p1 * cs,
        (y - x) * FRAC_1_SQRT_2,
        (x + y) * FRAC_1_SQRT_2,
    ];
    Eigen2 { values, modes }
}

/// `dpsi/dF = U diag(g) V^T` from `g = dpsi/ds`.
#[inline]
fn grad2(u: &Matrix2<f64>, g: &[f64; 2], v: &Matrix2<f64>) -> Matrix2<f64> {
    Matrix2::from_fn(|r, c| u[(r, 0)] * g[0] * v[(c, 0)] + u[(r, 1)] * g[1] * v[(c, 1)])
}

/// Value, gradient and (optionally) Hessian of `psi` at a 2x2 `F`.
///
/// `None` when `psi(F)` is not finite (barrier energies at `det F <= 0`,
/// non-finite `F`). Otherwise, with the signed SVD `F = U diag(s) V^T`
/// ([`signed_svd2`]): value `psi(s)`, gradient `U diag(dpsi/ds) V^T` (or
/// both from the energy's [`closed_form2`](DistortionEnergy::closed_form2),
/// without the SVD when no Hessian is asked for), and the
/// Hessian from the analytic eigensystem ([`eval2_eigen`]): 2 scaling modes
/// from the 2x2 `d2psi/ds2`, one twist and one flip mode;
/// [`HessianMode::Projected`] clamps their eigenvalues at 0. No heap
/// allocation.
pub fn eval2(e: &dyn DistortionEnergy, f: &Matrix2<f64>, mode: HessianMode) -> Option<Eval2> {
    if mode == HessianMode::None {
        let mut grad = Matrix2::zeros();
        if let Some(value) = e.closed_form2(f, Some(&mut grad)) {
            return value.is_finite().then_some(Eval2 {
                value,
                grad,
                hess: None,
            });
        }
        if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
            return None;
        }
        let (u, sv, v) = signed_svd2(f);
        let s = [sv[0], sv[1]];
        let value = e.value(&s);
        if !value.is_finite() {
            return None;
        }
        let mut g = [0.0; 2];
        e.gradient(&s, &mut g);
        let grad = grad2(&u, &g, &v);
        return Some(Eval2 {
            value,
            grad,
            hess: None,
        });
    }
    let (value, grad, eigen) = eval2_eigen(e, f, mode)?;
    Some(Eval2 {
        value,
        grad,
        hess: Some(eigen.matrix()),
    })
}

/// Value, gradient and (optionally) Hessian of `psi` at a 3x3 `F`.
///
/// `None` when `psi(F)` is not finite (barrier energies at `det F <= 0`,
/// non-finite `F`). Otherwise, with the signed SVD `F = U diag(s) V^T`
/// ([`signed_svd3`]): value `psi(s)`, gradient `U diag(dpsi/ds) V^T`, and the
/// 9x9 Hessian from the analytic eigensystem (module docs): 3 scaling modes
/// from the 3x3 `d2psi/ds2` (projected through its eigen-decomposition
/// unless it is already positive definite), 3 twist and 3 flip modes;
/// [`HessianMode::Projected`] clamps every eigenvalue at 0. No heap
/// allocation.
pub fn eval3(e: &dyn DistortionEnergy, f: &Matrix3<f64>, mode: HessianMode) -> Option<Eval3> {
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return None;
    }
    let (u, sv, v) = signed_svd3(f);
    let s = [sv[0], sv[1], sv[2]];
    let value = e.value(&s);
    if !value.is_finite() {
        return None;
    }
    let mut g = [0.0; 3];
    e.gradient(&s, &mut g);
    let grad = Matrix3::from_fn(|r, c| {
        u[(r, 0)] * g[0] * v[(c, 0)] + u[(r, 1)] * g[1] * v[(c, 1)] + u[(r, 2)] * g[2] * v[(c, 2)]
    });
    let hess = match mode {
        HessianMode::None => None,
        HessianMode::Exact | HessianMode::Projected => {
            let project = mode == HessianMode::Projected;
            let mut h = [0.0; 9];
            e.hessian(&s, &mut h);
            let mut hs = [[0.0; 3]; 3];
            for (i, row) in hs.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    *x = 0.5 * (h[i * 3 + j] + h[j * 3 + i]);
                }
            }
            if project {
                hs = project_sym3(hs);
            }
            Some(assemble_hessian::<3, 9>(e, &u, &s, &v, &hs, project))
        }
    };
    Some(Eval3 { value, grad, hess })
}

/// `psi(F)` for a 2x2 `F` (value only, no gradient or Hessian): the
/// energy's closed form ([`DistortionEnergy::closed_form2`]) where it has
/// one, else `psi(s)` of the signed singular values; `f64::INFINITY` when
/// not admissible (barrier energies at `det F <= 0`, which skip the SVD) or
/// not finite. Equal to `eval2(e, f, _).value` where that is `Some`.
pub fn density2(e: &dyn DistortionEnergy, f: &Matrix2<f64>) -> f64 {
    if let Some(x) = e.closed_form2(f, None) {
        return if x.is_finite() { x } else { f64::INFINITY };
    }
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return f64::INFINITY;
    }
    let (_, s, _) = signed_svd2(f);
    let x = e.value(&[s[0], s[1]]);
    if x.is_finite() { x } else { f64::INFINITY }
}

/// `psi(F)` for a 3x3 `F` (value only, no gradient or Hessian): `psi(s)` of
/// the signed singular values, `f64::INFINITY` when not admissible (barrier
/// energies at `det F <= 0`, which skip the SVD) or not finite. Equal to
/// `eval3(e, f, _).value` where that is `Some`.
pub fn density3(e: &dyn DistortionEnergy, f: &Matrix3<f64>) -> f64 {
    if e.is_barrier() && nonpositive_or_nan(f.determinant()) {
        return f64::INFINITY;
    }
    let (_, s, _) = signed_svd3(f);
    let x = e.value(&[s[0], s[1], s[2]]);
    if x.is_finite() { x } else { f64::INFINITY }
}

/// `x <= 0` or NaN.
#[inline]
fn nonpositive_or_nan(x: f64) -> bool {
    x.is_nan() || x <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, Quaternion, Rotation2, UnitQuaternion};
    use proptest::prelude::*;

    const ENERGIES: [&dyn DistortionEnergy; 4] = [&SymmetricDirichlet, &Mips, &Arap, &AreaRatio];

    // ---- helpers -----------------------------------------------------------

    fn rot3(q: [f64; 4]) -> Matrix3<f64> {
        let q = Quaternion::new(q[0], q[1], q[2], q[3]);
        let q = if q.norm() < 1e-3 {
            Quaternion::identity()
        } else {
            q
        };
        UnitQuaternion::from_quaternion(q)
            .to_rotation_matrix()
            .into_inner()
    }

    fn rot2(a: f64) -> Matrix2<f64> {
        Rotation2::new(a).into_inner()
    }

    fn compose3(q1: [f64; 4], s: [f64; 3], q2: [f64; 4]) -> Matrix3<f64> {
        rot3(q1) * Matrix3::from_diagonal(&Vector3::from(s)) * rot3(q2)
    }

    fn compose2(a1: f64, s: [f64; 2], a2: f64) -> Matrix2<f64> {
        rot2(a1) * Matrix2::from_diagonal(&Vector2::from(s)) * rot2(a2)
    }

    fn quat() -> impl Strategy<Value = [f64; 4]> {
        prop::array::uniform4(-1.0f64..1.0).prop_filter("quaternion away from 0", |q| {
            q.iter().map(|x| x * x).sum::<f64>() > 0.01
        })
    }

    fn angle() -> impl Strategy<Value = f64> {
        -std::f64::consts::PI..std::f64::consts::PI
    }

    /// Well-shaped 3D F = R1 diag(s) R2 with s in [0.3, 3], and its s.
    fn well_shaped3() -> impl Strategy<Value = (Matrix3<f64>, [f64; 3])> {
        (quat(), prop::array::uniform3(0.3f64..3.0), quat())
            .prop_map(|(q1, s, q2)| (compose3(q1, s, q2), s))
    }

    fn well_shaped2() -> impl Strategy<Value = (Matrix2<f64>, [f64; 2])> {
        (angle(), prop::array::uniform2(0.3f64..3.0), angle())
            .prop_map(|(a1, s, a2)| (compose2(a1, s, a2), s))
    }

    /// Inverted 3D F (det < 0) whose smallest singular value is clearly
    /// below the middle one, so ARAP is smooth there.
    fn inverted3() -> impl Strategy<Value = (Matrix3<f64>, [f64; 3])> {
        (quat(), 0.3f64..3.0, 0.3f64..3.0, 0.1f64..0.7, quat()).prop_map(|(q1, a, b, t, q2)| {
            let (a, b) = (a.max(b), a.min(b));
            let s = [a, b, -t * b];
            (compose3(q1, s, q2), s)
        })
    }

    fn inverted2() -> impl Strategy<Value = (Matrix2<f64>, [f64; 2])> {
        (angle(), 0.3f64..3.0, 0.1f64..0.7, angle()).prop_map(|(a1, a, t, a2)| {
            let s = [a, -t * a];
            (compose2(a1, s, a2), s)
        })
    }

    fn max_abs(x: &[f64]) -> f64 {
        x.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// `max |a - b| <= tol * max(1, max |b|)`.
    fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
        assert_eq!(a.len(), b.len());
        let scale = max_abs(b).max(1.0);
        let err = a
            .iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            err <= tol * scale,
            "{what}: error {err:e} > {tol:e} * {scale:e}\n got {a:?}\nwant {b:?}"
        );
    }

    const H: f64 = 1e-6;

    /// Central differences of `phi` at `x`.
    fn fd_gradient(x: &[f64], phi: impl Fn(&[f64]) -> f64) -> Vec<f64> {
        (0..x.len())
            .map(|k| {
                let mut p = x.to_vec();
                let mut m = x.to_vec();
                p[k] += H;
                m[k] -= H;
                (phi(&p) - phi(&m)) / (2.0 * H)
            })
            .collect()
    }

    /// Central differences of the vector function `grad` at `x`, column `k`
    /// is `d grad / d x_k` (column-major like the Hessians).
    fn fd_jacobian(x: &[f64], grad: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
        let n = x.len();
        let mut out = vec![0.0; n * n];
        for k in 0..n {
            let mut p = x.to_vec();
            let mut m = x.to_vec();
            p[k] += H;
            m[k] -= H;
            let (gp, gm) = (grad(&p), grad(&m));
            for r in 0..n {
                out[r + n * k] = (gp[r] - gm[r]) / (2.0 * H);
            }
        }
        out
    }

    fn check_derivatives3(e: &dyn DistortionEnergy, f: &Matrix3<f64>, tol: f64) {
        let ev = eval3(e, f, HessianMode::Exact).expect("admissible");
        let x = f.as_slice();
        let g_fd = fd_gradient(x, |y| density3(e, &Matrix3::from_column_slice(y)));
        assert_close(ev.grad.as_slice(), &g_fd, tol, e.name());
        let h_fd = fd_jacobian(x, |y| {
            eval3(e, &Matrix3::from_column_slice(y), HessianMode::None)
                .expect("admissible")
                .grad
                .as_slice()
                .to_vec()
        });
        let hess = ev.hess.expect("requested");
        assert!(hess.iter().all(|v| v.is_finite()), "{}", e.name());
        assert_close(hess.as_slice(), &h_fd, tol, e.name());
    }

    fn check_derivatives2(e: &dyn DistortionEnergy, f: &Matrix2<f64>, tol: f64) {
        let ev = eval2(e, f, HessianMode::Exact).expect("admissible");
        let x = f.as_slice();
        let g_fd = fd_gradient(x, |y| density2(e, &Matrix2::from_column_slice(y)));
        assert_close(ev.grad.as_slice(), &g_fd, tol, e.name());
        let h_fd = fd_jacobian(x, |y| {
            eval2(e, &Matrix2::from_column_slice(y), HessianMode::None)
                .expect("admissible")
                .grad
                .as_slice()
                .to_vec()
        });
        let hess = ev.hess.expect("requested");
        assert!(hess.iter().all(|v| v.is_finite()), "{}", e.name());
        assert_close(hess.as_slice(), &h_fd, tol, e.name());
    }

    fn eigenvalues(h: &[f64], n: usize) -> Vec<f64> {
        let m = DMatrix::from_column_slice(n, n, h);
        let mut l: Vec<f64> = m.symmetric_eigenvalues().iter().copied().collect();
        l.sort_by(f64::total_cmp);
        l
    }

    /// Projected is PSD; equals Exact when Exact is PSD.
    fn check_projection(exact: &[f64], proj: &[f64], n: usize, what: &str) {
        let lp = eigenvalues(proj, n);
        let top = lp[n - 1].abs().max(1e-300);
        assert!(lp[0] >= -1e-9 * top, "{what}: projected eigenvalues {lp:?}");
        let le = eigenvalues(exact, n);
        if le[0] >= 0.0 {
            assert_close(proj, exact, 1e-10, what);
        }
    }

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

    /// Closed forms in F of the four energies (SD, MIPS, area ratio) and
    /// ARAP from the known signed singular values.
    fn reference_value(
        e: &dyn DistortionEnergy,
        f_norm2: f64,
        det: f64,
        inv_norm2: f64,
        s: &[f64],
    ) -> f64 {
        let d = s.len() as f64;
        match e.name() {
            "symmetric-dirichlet" => f_norm2 + inv_norm2,
            "mips" => f_norm2 / det.powf(2.0 / d),
            "area-ratio" => det + 1.0 / det,
            "arap" => s.iter().map(|x| (x - 1.0) * (x - 1.0)).sum(),
            other => panic!("unknown {other}"),
        }
    }

    // ---- properties --------------------------------------------------------

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn energy_values_match_closed_forms_3d((f, s) in well_shaped3()) {
            let inv = f.try_inverse().unwrap();
            for e in ENERGIES {
                let want = reference_value(e, f.norm_squared(), f.determinant(), inv.norm_squared(), &s);
                let got = eval3(e, &f, HessianMode::None).unwrap().value;
                prop_assert!((got - want).abs() <= 1e-10 * want.abs().max(1.0), "{} {got} {want}", e.name());
                prop_assert_eq!(density3(e, &f), got);
            }
        }

        #[test]
        fn energy_values_match_closed_forms_2d((f, s) in well_shaped2()) {
            let inv = f.try_inverse().unwrap();
            for e in ENERGIES {
                let want = reference_value(e, f.norm_squared(), f.determinant(), inv.norm_squared(), &s);
                let got = eval2(e, &f, HessianMode::None).unwrap().value;
                prop_assert!((got - want).abs() <= 1e-10 * want.abs().max(1.0), "{} {got} {want}", e.name());
                prop_assert_eq!(density2(e, &f), got);
            }
        }

        #[test]
        fn energy_gradient_and_exact_hessian_match_fd_3d((f, _s) in well_shaped3()) {
            for e in ENERGIES {
                check_derivatives3(e, &f, 1e-5);
            }
        }

        #[test]
        fn energy_gradient_and_exact_hessian_match_fd_2d((f, _s) in well_shaped2()) {
            for e in ENERGIES {
                check_derivatives2(e, &f, 1e-5);
            }
        }

        #[test]
        fn energy_arap_inverted_matches_fd_3d((f, s) in inverted3()) {
            let ev = eval3(&Arap, &f, HessianMode::Exact).unwrap();
            let want: f64 = s.iter().map(|x| (x - 1.0) * (x - 1.0)).sum();
            prop_assert!((ev.value - want).abs() <= 1e-10 * want.max(1.0));
            check_derivatives3(&Arap, &f, 1e-5);
            let p = eval3(&Arap, &f, HessianMode::Projected).unwrap().hess.unwrap();
            check_projection(ev.hess.unwrap().as_slice(), p.as_slice(), 9, "arap inverted");
        }

        #[test]
        fn energy_arap_inverted_matches_fd_2d((f, s) in inverted2()) {
            let ev = eval2(&Arap, &f, HessianMode::Exact).unwrap();
            let want: f64 = s.iter().map(|x| (x - 1.0) * (x - 1.0)).sum();
            prop_assert!((ev.value - want).abs() <= 1e-10 * want.max(1.0));
            check_derivatives2(&Arap, &f, 1e-5);
            let p = eval2(&Arap, &f, HessianMode::Projected).unwrap().hess.unwrap();
            check_projection(ev.hess.unwrap().as_slice(), p.as_slice(), 4, "arap inverted");
        }

        #[test]
        fn energy_rotation_invariance_3d((f, _s) in well_shaped3(), q in quat()) {
            let r = rot3(q);
            for e in ENERGIES {
                let v = density3(e, &f);
                for g in [r * f, f * r] {
                    let w = density3(e, &g);
                    prop_assert!((v - w).abs() <= 1e-11 * v.abs().max(1.0), "{} {v} {w}", e.name());
                }
            }
        }

        #[test]
        fn energy_rotation_invariance_2d((f, _s) in well_shaped2(), a in angle()) {
            let r = rot2(a);
            for e in ENERGIES {
                let v = density2(e, &f);
                for g in [r * f, f * r] {
                    let w = density2(e, &g);
                    prop_assert!((v - w).abs() <= 1e-11 * v.abs().max(1.0), "{} {v} {w}", e.name());
                }
            }
        }

        #[test]
        fn energy_minimum_at_rotations(q in quat(), a in angle()) {
            let (r3, r2) = (rot3(q), rot2(a));
            for e in ENERGIES {
                let ev = eval3(e, &r3, HessianMode::Exact).unwrap();
                prop_assert!((ev.value - e.minimum(3)).abs() < 1e-12, "{} {}", e.name(), ev.value);
                prop_assert!(ev.grad.amax() < 1e-12, "{} {}", e.name(), ev.grad);
                let ev = eval2(e, &r2, HessianMode::Exact).unwrap();
                prop_assert!((ev.value - e.minimum(2)).abs() < 1e-12, "{} {}", e.name(), ev.value);
                prop_assert!(ev.grad.amax() < 1e-12, "{} {}", e.name(), ev.grad);
            }
        }

        #[test]
        fn energy_projected_hessian_is_psd_3d((f, _s) in well_shaped3()) {
            for e in ENERGIES {
                let ex = eval3(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
                let pr = eval3(e, &f, HessianMode::Projected).unwrap().hess.unwrap();
                check_projection(ex.as_slice(), pr.as_slice(), 9, e.name());
            }
        }

        #[test]
        fn energy_projected_hessian_is_psd_2d((f, _s) in well_shaped2()) {
            for e in ENERGIES {
                let ex = eval2(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
                let pr = eval2(e, &f, HessianMode::Projected).unwrap().hess.unwrap();
                check_projection(ex.as_slice(), pr.as_slice(), 4, e.name());
            }
        }

        /// Stretched elements (s in [1, 3]): symmetric Dirichlet and ARAP
        /// are convex there, so Projected must equal Exact.
        #[test]
        fn energy_projected_equals_exact_when_convex(q1 in quat(), s in prop::array::uniform3(1.05f64..3.0), q2 in quat()) {
            let f = compose3(q1, s, q2);
            for e in [&SymmetricDirichlet as &dyn DistortionEnergy, &Arap] {
                let ex = eval3(e, &f, HessianMode::Exact).unwrap().hess.unwrap();
                let pr = eval3(e, &f, HessianMode::Projected).unwrap().hess.unwrap();
                prop_assert!(eigenvalues(ex.as_slice(), 9)[0] > 0.0);
                assert_close(pr.as_slice(), ex.as_slice(), 1e-12, e.name());
            }
        }

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

        /// Nearly equal singular values (relative gaps down to 0): finite
        /// Hessians matching finite differences (no 0/0 in the flip modes).
        #[test]
        fn energy_near_equal_singular_values_match_fd(
            q1 in quat(), q2 in quat(), sigma in 0.5f64..2.0, t in 0.3f64..0.9,
            a1 in angle(), a2 in angle(),
        ) {
            for gap in [0.0, 1e-15, 1e-12, 1e-9, 1e-7, 1e-5] {
                let f = compose3(q1, [sigma * (1.0 + gap), sigma, t * sigma], q2);
                let g = compose3(q1, [sigma, t * sigma * (1.0 + gap), t * sigma], q2);
                let h = compose2(a1, [sigma * (1.0 + gap), sigma], a2);
                for e in ENERGIES {
                    check_derivatives3(e, &f, 1e-5);
                    check_derivatives3(e, &g, 1e-5);
                    check_derivatives2(e, &h, 1e-5);
                }
            }
        }
    }

    // ---- fixed cases -------------------------------------------------------

    #[test]
    fn energy_sym_eigen3_decomposes() {
        let cases = [
            [[2.0, 1.0, 0.5], [1.0, -1.0, 0.3], [0.5, 0.3, 0.0]],
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
            [[0.0, 1e-20, 0.0], [1e-20, 0.0, 1.0], [0.0, 1.0, 0.0]],
            [[1e8, 1.0, 0.0], [1.0, 1e-8, 1e-8], [0.0, 1e-8, -3.0]],
        ];
        for h in cases {
            let (l, w) = sym_eigen3(h);
            let m = Matrix3::from_fn(|i, j| h[i][j]);
            let mut rec = Matrix3::zeros();
            for k in 0..3 {
                let v = Vector3::from(w[k]);
                assert!((v.norm() - 1.0).abs() < 1e-14);
                rec += l[k] * v * v.transpose();
            }
            assert!((rec - m).norm() <= 1e-14 * m.norm(), "{h:?}");
            let p = Matrix3::from_fn(|i, j| project_sym3(h)[i][j]);
            let lp = eigenvalues(p.as_slice(), 3);
            assert!(lp[0] >= -1e-14 * lp[2].abs().max(1e-300), "{h:?} {lp:?}");
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

    #[test]
    fn energy_derivatives_at_repeated_singular_values() {
        let r = rot3([0.1, 0.8, -0.3, 0.4]);
        let q = rot3([-0.6, 0.2, 0.5, 0.1]);
        for f in [
            Matrix3::identity(),
            r,
            r * Matrix3::from_diagonal(&Vector3::new(2.0, 2.0, 1.0)) * q,
            r * Matrix3::from_diagonal(&Vector3::new(2.0, 1.0, 1.0)) * q,
            r * 1.7,
        ] {
            for e in ENERGIES {
                check_derivatives3(e, &f, 1e-5);
            }
        }
        let a = rot2(0.4);
        for f in [
            Matrix2::identity(),
            a,
            a * 1.7,
            a * Matrix2::new(2.0, 0.0, 0.0, 1.0),
        ] {
            for e in ENERGIES {
                check_derivatives2(e, &f, 1e-5);
            }
        }
    }

    #[test]
    fn energy_symmetric_dirichlet_gradient_matches_matrix_formula() {
        // dD/dJ = 2 J - 2 J^-T J^-1 J^-T (ALGORITHMS 1.2).
        let f = Matrix3::new(1.2, 0.3, -0.1, 0.2, 0.9, 0.4, -0.3, 0.1, 1.5);
        let inv = f.try_inverse().unwrap();
        let want = 2.0 * f - 2.0 * inv.transpose() * inv * inv.transpose();
        let got = eval3(&SymmetricDirichlet, &f, HessianMode::None)
            .unwrap()
            .grad;
        assert_close(got.as_slice(), want.as_slice(), 1e-13, "sd gradient");
    }

    #[test]
    fn energy_barriers_reject_inverted_and_flat_elements() {
        let inverted3 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -0.5));
        let flat3 = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0));
        let inverted2 = Matrix2::new(1.0, 0.0, 0.0, -0.5);
        let flat2 = Matrix2::new(1.0, 0.0, 0.0, 0.0);
        for e in ENERGIES {
            for mode in [
                HessianMode::None,
                HessianMode::Exact,
                HessianMode::Projected,
            ] {
                assert_eq!(eval3(e, &inverted3, mode).is_none(), e.is_barrier());
                assert_eq!(eval3(e, &flat3, mode).is_none(), e.is_barrier());
                assert_eq!(eval2(e, &inverted2, mode).is_none(), e.is_barrier());
                assert_eq!(eval2(e, &flat2, mode).is_none(), e.is_barrier());
            }
            assert_eq!(density3(e, &inverted3) == f64::INFINITY, e.is_barrier());
            assert_eq!(density2(e, &flat2) == f64::INFINITY, e.is_barrier());
            let nan3 = Matrix3::from_element(f64::NAN);
            assert!(eval3(e, &nan3, HessianMode::Projected).is_none());
            assert_eq!(density3(e, &nan3), f64::INFINITY);
            assert!(eval2(e, &Matrix2::from_element(f64::NAN), HessianMode::Exact).is_none());
            assert_eq!(e.value(&[1.0, 1.0, -1.0]).is_infinite(), e.is_barrier());
        }
        // ARAP on a flat / exactly reflected element: finite, projected PSD.
        let arap = eval3(&Arap, &flat3, HessianMode::Projected).unwrap();
        assert_eq!(arap.value, 1.0);
        let l = eigenvalues(arap.hess.unwrap().as_slice(), 9);
        assert!(l.iter().all(|x| x.is_finite()) && l[0] >= -1e-9 * l[8]);
        let refl = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        let arap = eval3(&Arap, &refl, HessianMode::Projected).unwrap();
        assert_eq!(arap.value, 4.0);
        assert!(arap.hess.unwrap().iter().all(|x| x.is_finite()));
    }

    proptest! {
        /// The symmetric Dirichlet closed form in `F` (no SVD) agrees with
        /// the singular-value path, and is infinite for `det F <= 0`.
        #[test]
        fn symmetric_dirichlet_closed_form_matches_the_svd_path(
            a in -3.0..3.0f64, b in -3.0..3.0f64, c in -3.0..3.0f64, d in -3.0..3.0f64,
        ) {
            let f = Matrix2::new(a, b, c, d);
            let mut g = Matrix2::zeros();
            let x = SymmetricDirichlet.closed_form2(&f, Some(&mut g)).unwrap();
            prop_assert_eq!(SymmetricDirichlet.closed_form2(&f, None), Some(x));
            if f.determinant() <= 1e-3 {
                if f.determinant() <= 0.0 {
                    prop_assert_eq!(x, f64::INFINITY);
                }
                return Ok(());
            }
            let (u, sv, v) = signed_svd2(&f);
            let s = [sv[0], sv[1]];
            let y = SymmetricDirichlet.value(&s);
            let mut gs = [0.0; 2];
            SymmetricDirichlet.gradient(&s, &mut gs);
            let gy = grad2(&u, &gs, &v);
            prop_assert!((x - y).abs() <= 1e-12 * y, "{} vs {}", x, y);
            let scale = gy.norm().max(1.0);
            prop_assert!((g - gy).norm() <= 1e-11 * scale, "{} vs {}", g, gy);
        }
    }

    #[test]
    fn the_hessian_eigensystem_alone_is_eval2_eigens() {
        let fs = [
            Matrix2::new(1.2, 0.3, -0.2, 0.7),
            Matrix2::new(0.4, -0.9, 0.8, 0.3),
            Matrix2::new(-1.0, 0.0, 0.0, 1.0),
            Matrix2::new(1.0, 2.0, 0.5, 1.0),
            Matrix2::from_element(f64::NAN),
        ];
        for e in ENERGIES {
            for f in &fs {
                for mode in [HessianMode::Exact, HessianMode::Projected] {
                    assert_eq!(
                        hessian2_eigen(e, f, mode),
                        eval2_eigen(e, f, mode).map(|x| x.2),
                        "{} at {f}",
                        e.name()
                    );
                }
            }
        }
    }

    #[test]
    fn energy_modes_agree_on_value_and_gradient() {
        let f = Matrix3::new(1.2, 0.3, -0.1, 0.2, 0.9, 0.4, -0.3, 0.1, 1.5);
        let f2 = Matrix2::new(1.2, 0.3, -0.2, 0.7);
        for e in ENERGIES {
            let a = eval3(e, &f, HessianMode::None).unwrap();
            assert!(a.hess.is_none());
            for mode in [HessianMode::Exact, HessianMode::Projected] {
                let b = eval3(e, &f, mode).unwrap();
                assert_eq!((a.value, a.grad), (b.value, b.grad));
                assert!(b.hess.is_some());
            }
            let a = eval2(e, &f2, HessianMode::None).unwrap();
            assert!(a.hess.is_none());
            let b = eval2(e, &f2, HessianMode::Projected).unwrap();
            assert_eq!((a.value, a.grad), (b.value, b.grad));
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

    #[test]
    fn energy_by_name_finds_every_energy() {
        for name in ENERGY_NAMES {
            let e = energy_by_name(name).expect(name);
            assert_eq!(e.name(), name);
        }
        assert!(energy_by_name("dirichlet").is_none());
        let expected = [
            ("symmetric-dirichlet", 4.0, 6.0, true),
            ("mips", 2.0, 3.0, true),
            ("arap", 0.0, 0.0, false),
            ("area-ratio", 2.0, 2.0, true),
        ];
        for (name, m2, m3, barrier) in expected {
            let e = energy_by_name(name).unwrap();
            assert_eq!(
                (e.minimum(2), e.minimum(3), e.is_barrier()),
                (m2, m3, barrier)
            );
        }
    }

    #[test]
    fn energy_hessian_is_symmetric_and_indexed_column_major() {
        // psi = ARAP at F = diag(2, 1.5, 1.2): dpsi/dF = 2 (F - I), and the
        // Hessian is 2 I on the diagonal block of each entry F[(i, i)].
        let f = Matrix3::from_diagonal(&Vector3::new(2.0, 1.5, 1.2));
        let ev = eval3(&Arap, &f, HessianMode::Exact).unwrap();
        let h = ev.hess.unwrap();
        assert_close(h.as_slice(), h.transpose().as_slice(), 0.0, "symmetry");
        for i in 0..3 {
            let k = i + 3 * i;
            assert!((h[(k, k)] - 2.0).abs() < 1e-12);
        }
        // Off-diagonal entry F[(0, 1)] (index 3) couples with F[(1, 0)]
        // (index 1): twist/flip of pair (0, 1) = (2 - 4/3.5 -/+ 2) / 2.
        let lt = 2.0 - 4.0 / 3.5;
        assert!((h[(3, 3)] - 0.5 * (lt + 2.0)).abs() < 1e-12);
        assert!((h[(1, 3)] - 0.5 * (2.0 - lt)).abs() < 1e-12);
    }
}
