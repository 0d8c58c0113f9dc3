//! Deterministic synthetic shapes for tests, examples, benchmarks and
//! `unfold demo`: a placenta, a heart ventricle and a mitral valve.
//!
//! Every generator takes a parameter struct (`Default` gives an anatomically
//! plausible shape, all lengths in millimetres), validates it
//! ([`MeshError::InvalidArgument`] with a message on nonsense), builds the
//! shape in closed form (no randomness: the same parameters give a
//! bit-identical result) in a canonical frame, and finally applies a rigid
//! [`Pose`] so invariance to rotations and translations can be tested.
//!
//! - [`placenta_slab`]: a curved, tapered, elliptical tet-mesh slab with
//!   fetal / maternal / rim labels ([`PlacentaShape`]).
//! - [`ventricle_cup`]: a truncated prolate ellipsoid surface with disk
//!   topology (the basal rim is its one boundary loop), anatomy inside it and
//!   landmarks ([`VentricleShape`]).
//! - [`mitral_valve`]: a saddle-shaped D annulus with two longitude-structured
//!   leaflets that coapt without intersecting ([`ValveShape`]).
//! - [`tangled_case`]: an untangling problem that is feasible by
//!   construction: a planar, surface or tet rest mesh, a known injective
//!   map of it, and a tangled start that agrees with it at the handles
//!   ([`TangledCase`]). Its randomness is a seeded [`SplitMix64`], so it too
//!   is deterministic.

mod layered;
mod placenta;
pub mod primitives;
mod shell;
mod tangled;
mod valve;
mod valve_labels;
mod ventricle;

#[cfg(test)]
mod test_util;

pub use placenta::{PlacentaParams, PlacentaShape, placenta_slab, side};
pub use primitives::{grid_disk, kuhn_grid, uv_sphere};
pub use shell::{ShellParams, ShellShape, bowl_shell};
pub use tangled::{Handles, SplitMix64, TangledCase, TangledKind, TangledParams, tangled_case};
pub use valve::{ValveParams, ValveShape, mitral_valve};
pub use valve_labels::{ValveLabelParams, valve_labels};
pub use ventricle::{VentricleParams, VentricleShape, ventricle_cup};

use crate::MeshError;
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A rigid motion applied to a generated shape after it has been built in
/// its canonical frame: first the rotation, then the translation,
/// `p' = R p + t`.
///
/// The rotation is given by three angles in degrees about the fixed x, y and
/// z axes, applied in that order (roll, then pitch, then yaw):
/// `R = Rz(yaw) Ry(pitch) Rx(roll)` (nalgebra's
/// `Rotation3::from_euler_angles`). The default is the identity.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Pose {
    /// Rotation angles `[roll, pitch, yaw]` in degrees about x, y and z.
    pub rotation_deg: [f64; 3],
    /// Translation in mm, applied after the rotation.
    pub translation: [f64; 3],
}

impl Pose {
    /// The identity (no rotation, no translation).
    pub fn identity() -> Self {
        Pose::default()
    }

    /// A pose from `[roll, pitch, yaw]` in degrees and a translation in mm.
    pub fn new(rotation_deg: [f64; 3], translation: [f64; 3]) -> Self {
        Pose {
            rotation_deg,
            translation,
        }
    }

    /// The rotation `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn rotation(&self) -> Rotation3<f64> {
        let [r, p, y] = self.rotation_deg;
        Rotation3::from_euler_angles(r.to_radians(), p.to_radians(), y.to_radians())
    }

    /// The rigid motion `p -> R p + t` as an nalgebra isometry.
    pub fn isometry(&self) -> Isometry3<f64> {
        let [tx, ty, tz] = self.translation;
        Isometry3::from_parts(
            Translation3::new(tx, ty, tz),
            UnitQuaternion::from_rotation_matrix(&self.rotation()),
        )
    }

    /// Applies the pose to a point: `R p + t`.
    #[inline]
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        let [tx, ty, tz] = self.translation;
        self.rotation() * p + Vector3::new(tx, ty, tz)
    }

    /// Applies the rotation only (for directions): `R v`.
    #[inline]
    pub fn apply_vector(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.rotation() * v
    }

    /// Applies the pose to every point in place (one rotation matrix for all).
    pub fn apply_all(&self, points: &mut [Point3<f64>]) {
        if *self == Pose::identity() {
            return;
        }
        let r = self.rotation();
        let [tx, ty, tz] = self.translation;
        let t = Vector3::new(tx, ty, tz);
        for p in points {
            *p = r * *p + t;
        }
    }

    /// Fails unless every angle and offset is finite.
    pub(crate) fn check(&self, what: &str) -> Result<(), MeshError> {
        if self
            .rotation_deg
            .iter()
            .chain(self.translation.iter())
            .all(|x| x.is_finite())
        {
            Ok(())
        } else {
            Err(invalid(format!(
                "{what}: pose angles and translation must be finite (got {:?}, {:?})",
                self.rotation_deg, self.translation
            )))
        }
    }
}

/// An [`MeshError::InvalidArgument`] with `msg`.
pub(crate) fn invalid(msg: impl Into<String>) -> MeshError {
    MeshError::InvalidArgument(msg.into())
}

/// Fails unless `value` is finite and `> 0`.
pub(crate) fn check_positive(what: &str, name: &str, value: f64) -> Result<(), MeshError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(format!(
            "{what}: {name} must be a finite positive number, got {value}"
        )))
    }
}

/// Fails unless `value` is finite and within `[lo, hi]`.
pub(crate) fn check_range(
    what: &str,
    name: &str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<(), MeshError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(invalid(format!(
            "{what}: {name} must lie in [{lo}, {hi}], got {value}"
        )))
    }
}

/// Fails unless the resolution `value` lies within `[lo, hi]`.
pub(crate) fn check_count(
    what: &str,
    name: &str,
    value: usize,
    lo: usize,
    hi: usize,
) -> Result<(), MeshError> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(invalid(format!(
            "{what}: {name} must lie in [{lo}, {hi}], got {value}"
        )))
    }
}

/// A curve `t -> f(t)` on `[t0, t1]` sampled densely, for arc-length
/// reparameterization: `param_at(s)` is the `t` at arc length `s` (chord
/// lengths of the samples, linear interpolation in between).
pub(crate) struct ArcTable {
    t: Vec<f64>,
    s: Vec<f64>,
}

impl ArcTable {
    /// Samples `f` at `samples + 1` equally spaced parameters.
    pub(crate) fn new(f: impl Fn(f64) -> Point3<f64>, t0: f64, t1: f64, samples: usize) -> Self {
        let samples = samples.max(1);
        let mut t = Vec::with_capacity(samples + 1);
        let mut s = Vec::with_capacity(samples + 1);
        let mut prev = f(t0);
        let mut acc = 0.0;
        for i in 0..=samples {
            let ti = t0 + (t1 - t0) * i as f64 / samples as f64;
            let p = f(ti);
            acc += (p - prev).norm();
            prev = p;
            t.push(ti);
            s.push(acc);
        }
        ArcTable { t, s }
    }

    /// Total length.
    pub(crate) fn length(&self) -> f64 {
        self.s[self.s.len() - 1]
    }

    /// The parameter at arc length `s` (clamped to the curve).
    pub(crate) fn param_at(&self, s: f64) -> f64 {
        let n = self.s.len();
        if s <= 0.0 {
            return self.t[0];
        }
        if s >= self.s[n - 1] {
            return self.t[n - 1];
        }
        // First index with s[i] > s, at least 1.
        let i = self.s.partition_point(|&x| x <= s).clamp(1, n - 1);
        let (s0, s1) = (self.s[i - 1], self.s[i]);
        let w = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
        self.t[i - 1] + w * (self.t[i] - self.t[i - 1])
    }

    /// The parameter at the fraction `u` in `[0, 1]` of the total length.
    pub(crate) fn param_at_fraction(&self, u: f64) -> f64 {
        self.param_at(u * self.length())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn pose_matches_isometry_and_preserves_distances() {
        let pose = Pose::new([10.0, -35.0, 120.0], [5.0, -3.0, 40.0]);
        let iso = pose.isometry();
        let a = Point3::new(1.0, 2.0, 3.0);
        let b = Point3::new(-4.0, 0.5, 7.0);
        assert_relative_eq!(pose.apply(&a), iso * a, epsilon = 1e-12);
        assert_relative_eq!(
            (pose.apply(&a) - pose.apply(&b)).norm(),
            (a - b).norm(),
            epsilon = 1e-12
        );
        let mut pts = vec![a, b];
        pose.apply_all(&mut pts);
        assert_relative_eq!(pts[1], pose.apply(&b), epsilon = 1e-12);
        assert!(
            Pose::new([f64::NAN, 0.0, 0.0], [0.0; 3])
                .check("x")
                .is_err()
        );
    }

    #[test]
    fn arc_table_inverts_arc_length_of_a_circle() {
        let table = ArcTable::new(
            |t| Point3::new(10.0 * t.cos(), 10.0 * t.sin(), 0.0),
            0.0,
            std::f64::consts::PI,
            4096,
        );
        assert_relative_eq!(table.length(), 10.0 * std::f64::consts::PI, epsilon = 1e-3);
        assert_relative_eq!(
            table.param_at_fraction(0.25),
            std::f64::consts::FRAC_PI_4,
            epsilon = 1e-6
        );
        assert_eq!(table.param_at(-1.0), 0.0);
        assert_eq!(table.param_at(1e9), std::f64::consts::PI);
    }
}
