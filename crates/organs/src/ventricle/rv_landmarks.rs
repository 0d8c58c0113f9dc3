//! The LV's rim landmarks from the two RV insertion points (the source
//! paper's §3.1, Paun et al.): the user marks where the RV wall attaches at
//! the base of the RV ridges (`P_LRV`, `P_RRV`); rays from the centroid of
//! the LV's basal rim through them meet the LV's enclosing surface S, and
//! the rim vertices closest to those intersections are the anterior and
//! inferior landmarks. The rays start from the basal rim chosen first
//! ([`super::openings::choose_rim`]: `rim_near`, else the anatomy), so that
//! the landmarks lie on that rim, not on another opening of S.

use super::error::VentricleError;
use super::openings::{RimChoice, RimHint, choose_rim};
use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_mesh::nalgebra::{Point3, Vector3};

/// The rim landmarks derived from two RV insertion points.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FromRv {
    /// Why the rim the landmarks were derived on is the basal rim.
    pub rim_chosen_by: RimChoice,
    /// The RV insertion points given (anterior, inferior).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub rv: [[f64; 3]; 2],
    /// The centroid `c` of the basal rim the rays start from.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub rim_centroid: [f64; 3],
    /// Where each ray `c + t (p - c)`, `t > 0`, meets S: the intersection
    /// nearest the RV point.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub hits: [[f64; 3]; 2],
    /// The rim vertices nearest the hits: the anterior and inferior
    /// landmarks.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub landmarks: [[f64; 3]; 2],
}

/// The anterior and inferior rim landmarks of S from the anterior and
/// inferior RV insertion points `rv` (see the module docs). The basal rim
/// is chosen first by [`choose_rim`] from `rim_near` and `apex` (S may have
/// other openings: the largest facing away from the apex); its centroid is
/// the vertex average.
///
/// # Errors
/// [`choose_rim`]'s (S's boundary does not form loops, openings that tie,
/// a `rim_near` far from every opening);
/// [`VentricleError::EmptyRim`] when S has no boundary;
/// [`VentricleError::LandmarkNotFinite`] for a point that is not finite;
/// [`VentricleError::RvRayMisses`] when a ray from the rim's centroid
/// through a point meets no triangle of S (or the point is the centroid).
pub fn rim_landmarks_from_rv(
    s: &TriMesh,
    rv: [Point3<f64>; 2],
    rim_near: Option<&Point3<f64>>,
    apex: Option<&Point3<f64>>,
    snap_mm: f64,
) -> Result<FromRv, OrganError> {
    const NAMES: [&str; 2] = ["anterior", "inferior"];
    for (p, landmark) in rv.iter().zip(NAMES) {
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(VentricleError::LandmarkNotFinite {
                landmark,
                point: [p.x, p.y, p.z],
            }
            .into());
        }
    }
    let hint = RimHint {
        landmarks: None,
        rim_near: rim_near.copied(),
        apex: apex.copied(),
    };
    let pick = choose_rim(s, &hint, snap_mm)?;
    let rim = &pick.loops[pick.rim];
    if rim.is_empty() {
        return Err(VentricleError::EmptyRim.into());
    }
    let c = Point3::from(
        rim.iter()
            .map(|&v| s.positions[v as usize].coords)
            .sum::<Vector3<f64>>()
            / rim.len() as f64,
    );
    let mut hits = [[0.0; 3]; 2];
    let mut landmarks = [[0.0; 3]; 2];
    for (k, p) in rv.iter().enumerate() {
        let dir = p - c;
        let hit = nearest_hit(s, &c, &dir, 1.0).ok_or(VentricleError::RvRayMisses {
            landmark: NAMES[k],
            point: [p.x, p.y, p.z],
            centroid: [c.x, c.y, c.z],
        })?;
        let q = c + dir * hit;
        let v = rim
            .iter()
            .copied()
            .min_by(|&a, &b| {
                (s.positions[a as usize] - q)
                    .norm()
                    .total_cmp(&(s.positions[b as usize] - q).norm())
            })
            .ok_or(VentricleError::EmptyRim)?;
        let r = s.positions[v as usize];
        hits[k] = [q.x, q.y, q.z];
        landmarks[k] = [r.x, r.y, r.z];
    }
    Ok(FromRv {
        rim_chosen_by: pick.chosen_by,
        rv: rv.map(|p| [p.x, p.y, p.z]),
        rim_centroid: [c.x, c.y, c.z],
        hits,
        landmarks,
    })
}

/// The ray parameter `t > 0` of the intersection of `o + t d` with a
/// triangle of `s` nearest `t = target` (Moller-Trumbore per triangle);
/// `None` when the ray meets none or `d` vanishes.
fn nearest_hit(s: &TriMesh, o: &Point3<f64>, d: &Vector3<f64>, target: f64) -> Option<f64> {
    let length = d.norm();
    if length.is_nan() || length <= 0.0 {
        return None;
    }
    let mut best: Option<f64> = None;
    for t in &s.triangles {
        let [a, b, c] = t.map(|v| s.positions[v as usize]);
        let (e1, e2) = (b - a, c - a);
        let h = d.cross(&e2);
        let det = e1.dot(&h);
        if det.abs() <= 1e-14 * e1.norm() * e2.norm() * d.norm() {
            continue;
        }
        let f = 1.0 / det;
        let sv = o - a;
        let u = f * sv.dot(&h);
        if !(-1e-12..=1.0 + 1e-12).contains(&u) {
            continue;
        }
        let q = sv.cross(&e1);
        let v = f * d.dot(&q);
        if v < -1e-12 || u + v > 1.0 + 1e-12 {
            continue;
        }
        let tt = f * e2.dot(&q);
        if tt > 1e-12 && best.is_none_or(|b| (tt - target).abs() < (b - target).abs()) {
            best = Some(tt);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A cup: the lower half of a sphere of radius `r` (a UV grid), open at
    /// `z = 0`, its rim the circle of radius `r`.
    fn cup(r: f64, rings: usize, segments: usize) -> TriMesh {
        let mut positions = vec![Point3::new(0.0, 0.0, -r)];
        for i in 1..=rings {
            let polar = std::f64::consts::FRAC_PI_2 * i as f64 / rings as f64;
            for j in 0..segments {
                let a = std::f64::consts::TAU * j as f64 / segments as f64;
                positions.push(Point3::new(
                    r * polar.sin() * a.cos(),
                    r * polar.sin() * a.sin(),
                    -r * polar.cos(),
                ));
            }
        }
        let ring = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
        let mut triangles = Vec::new();
        for j in 0..segments {
            triangles.push([0, ring(1, j + 1), ring(1, j)]);
        }
        for i in 1..rings {
            for j in 0..segments {
                triangles.push([ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)]);
                triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)]);
            }
        }
        TriMesh::new(positions, triangles)
    }

    proptest! {
        /// RV points outside the cup, slightly below its rim, at any
        /// angle: the rays from the rim's centre meet the wall just below
        /// the rim at that angle, and the landmark is the rim vertex at
        /// the nearest angle.
        #[test]
        fn the_landmarks_are_the_rim_vertices_in_the_rv_points_directions(
            a0 in 0.0..std::f64::consts::TAU,
            gap in 0.5..2.5f64,
            out in 3.0..15.0f64,
        ) {
            let (r, segments) = (30.0, 48);
            let s = cup(r, 12, segments);
            let a1 = a0 + gap;
            let rv = [a0, a1].map(|a| Point3::new((r + out) * a.cos(), (r + out) * a.sin(), -1.0));
            let f = rim_landmarks_from_rv(&s, rv, None, None, 5.0).unwrap();
            prop_assert!(f.rim_centroid.iter().all(|x| x.abs() < 1e-9));
            for (k, a) in [a0, a1].iter().enumerate() {
                let h = f.hits[k];
                // On the wall, in the direction of the RV point.
                let rad = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
                prop_assert!((rad - r).abs() < 0.5, "{:?}", h);
                let ha = h[1].atan2(h[0]);
                let d = (ha - a).rem_euclid(std::f64::consts::TAU);
                prop_assert!(d.min(std::f64::consts::TAU - d) < 1e-6, "{} vs {}", ha, a);
                // The rim vertex nearest that angle.
                let l = f.landmarks[k];
                prop_assert!(l[2].abs() < 1e-9);
                let la = l[1].atan2(l[0]);
                let step = std::f64::consts::TAU / segments as f64;
                let dl = (la - a).rem_euclid(std::f64::consts::TAU);
                prop_assert!(dl.min(std::f64::consts::TAU - dl) <= 0.5 * step + 1e-9);
            }
        }
    }

    #[test]
    fn a_ray_that_misses_or_a_bad_point_is_an_error() {
        let s = cup(30.0, 8, 24);
        // Straight up from the rim's centre: the cup is below.
        let up = [Point3::new(0.0, 0.0, 10.0), Point3::new(40.0, 0.0, -1.0)];
        let e = rim_landmarks_from_rv(&s, up, None, None, 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("anterior") && e.contains("meets no triangle"),
            "{e}"
        );
        let nan = [
            Point3::new(f64::NAN, 0.0, 0.0),
            Point3::new(40.0, 0.0, -1.0),
        ];
        let e = rim_landmarks_from_rv(&s, nan, None, None, 5.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not finite"), "{e}");
    }
}
