//! The annulus laid out in 2D (ALGORITHMS 4.1): the ring is cut at the
//! anterolateral commissure (`ring[0] -> (0, 0)`) and unrolled to the right,
//! keeping its 3D arc length; its height above a reference plane becomes
//! `v`.
//!
//! With `p_0 .. p_{n-1}` the ring (clockwise seen from the atrium, from the
//! anterolateral commissure) and `p_n = p_0` the closing point (the same
//! commissure at the other end of the cut):
//!
//! ```text
//! straight:      v_i = 0,                     u_i = u_{i-1} + |p_i - p_{i-1}|
//! plane P, n:    v_i = n . (p_i - proj_P(p_i)),
//!                u_i = u_{i-1} + sqrt(max(0, |p_i - p_{i-1}|^2 - (v_i - v_{i-1})^2))
//! u_0 = 0,       s_i = s_{i-1} + |p_i - p_{i-1}|,  s_0 = 0,  s_n = L
//! ```
//!
//! so every segment keeps its 3D length in 2D whenever `|v_i - v_{i-1}| <=
//! |p_i - p_{i-1}|` (always true: `v` is a 1-Lipschitz function of the
//! position), and the saddle shape shows as heights.

use super::{AnnulusError, AnnulusMode, Plane, PreparedValve};
use crate::OrganError;
use unfold_mesh::nalgebra::{Matrix3, Point3, Vector3};

/// Relative tolerance below which landmark points count as collinear (the
/// sine of the angle between `B - A` and `C - A`) and ring points as lying
/// on a line (ratio of the two largest principal variances).
const COLLINEAR_REL: f64 = 1e-9;

/// The annulus laid out in 2D.
#[derive(Debug, Clone, PartialEq)]
pub struct AnnulusMap {
    /// The plane heights are measured from (None in straight mode).
    pub plane: Option<Plane>,
    /// Arc length along the ring at each ring point, `s[0] = 0`, plus the
    /// closing point: `len = ring.len() + 1`, last `= L`.
    pub s: Vec<f64>,
    /// `(u, v)` of each ring point plus the closing point (the anterolateral
    /// commissure again, at the end of the cut): `len = ring.len() + 1`.
    pub uv: Vec<[f64; 2]>,
    /// The ring's 3D length `L`, mm.
    pub length: f64,
}

impl AnnulusMap {
    /// `(u, v)` at arc length `s` in `[0, L]`: linear interpolation between
    /// the ring points around it,
    ///
    /// ```text
    /// q(s) = q_k + (s - s_k) / (s_{k+1} - s_k) (q_{k+1} - q_k),   s_k <= s < s_{k+1}
    /// ```
    ///
    /// (`q_k` exactly at `s = s_k`; the last point at `s >= L`, the first at
    /// `s <= 0`). `NaN` (or an empty map) gives `[NaN, NaN]`.
    pub fn at(&self, s: f64) -> [f64; 2] {
        let n = self.uv.len().min(self.s.len());
        if n == 0 || s.is_nan() {
            return [f64::NAN; 2];
        }
        // Number of ring points at or before s.
        let j = self.s[..n].partition_point(|&x| x <= s);
        if j == 0 {
            return self.uv[0];
        }
        if j == n {
            return self.uv[n - 1];
        }
        let (s0, s1) = (self.s[j - 1], self.s[j]);
        let (a, b) = (self.uv[j - 1], self.uv[j]);
        let t = (s - s0) / (s1 - s0);
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    }

    /// The u extent `u_n - u_0` (the 2D width of the unrolled annulus; the
    /// ring length `L` in straight mode, less when the ring has heights).
    /// 0 for an empty map.
    pub fn u_extent(&self) -> f64 {
        match (self.uv.first(), self.uv.last()) {
            (Some(a), Some(b)) => b[0] - a[0],
            _ => 0.0,
        }
    }
}

/// Checks what every mode needs: at least 3 finite ring points, the
/// posteromedial commissure strictly inside the ring, a finite non-zero
/// atrial direction. Returns the unit atrial direction.
fn check_valve(valve: &PreparedValve) -> Result<Vector3<f64>, AnnulusError> {
    let n = valve.ring.len();
    if n < 3 {
        return Err(AnnulusError::TooFewPoints { count: n });
    }
    if let Some((index, p)) = valve
        .ring
        .iter()
        .enumerate()
        .find(|(_, p)| !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(AnnulusError::PointNotFinite {
            index,
            point: [p.x, p.y, p.z],
        });
    }
    if valve.posteromedial == 0 || valve.posteromedial >= n {
        return Err(AnnulusError::PosteromedialOutOfRange {
            index: valve.posteromedial,
            ring_points: n,
        });
    }
    let norm = valve.atrium.norm();
    if !(norm.is_finite() && norm > 0.0) {
        let a = valve.atrium;
        return Err(AnnulusError::AtriumNotUsable {
            atrium: [a.x, a.y, a.z],
        });
    }
    Ok(valve.atrium / norm)
}

/// Orients `normal` (unit) like `atrium`; an error when it is (nearly)
/// perpendicular to it.
fn orient(
    normal: Vector3<f64>,
    atrium: &Vector3<f64>,
    mode: AnnulusMode,
) -> Result<Vector3<f64>, AnnulusError> {
    let c = normal.dot(atrium);
    if c.is_nan() || c.abs() <= 1e-9 {
        return Err(AnnulusError::NormalPerpendicularToAtrium {
            mode,
            normal: [normal.x, normal.y, normal.z],
        });
    }
    Ok(if c > 0.0 { normal } else { -normal })
}

/// The reference plane of a mode (normal oriented like `valve.atrium`,
/// towards the atrium):
///
/// - `Straight`: `None`.
/// - `LeastSquares`: through the centroid `c = (1/n) sum p_i` of the ring
///   points, normal the eigenvector of the smallest eigenvalue of their
///   covariance `sum (p_i - c)(p_i - c)^T` (the plane minimizing the sum of
///   squared distances).
/// - `Landmark`: through the anterolateral commissure `A = ring[0]`, the
///   posteromedial commissure `B = ring[posteromedial]` and the barycentre
///   `C` of the posterior annulus points *strictly between* the commissures,
///   `ring[posteromedial + 1 ..]` (the commissures already fix the plane's
///   axis `AB`; counting them again would pull `C` towards that axis and
///   make it depend on how finely the posterior arc is sampled); normal
///   `(B - A) x (C - A)`, normalized, point `A`. Both commissures get
///   `v = 0`.
///
/// # Errors
/// An [`AnnulusError`] (in [`OrganError::Mitral`]) for an unusable ring
/// (fewer than 3 points, non-finite points, posteromedial index out of
/// `1..n`, zero atrial direction), a posterior arc without points between
/// the commissures, collinear landmarks (`|(B - A) x (C - A)| <= 1e-9 |B -
/// A| |C - A|`), ring points on a line (least squares), or a plane normal
/// perpendicular to the atrial direction.
pub fn plane(valve: &PreparedValve, mode: AnnulusMode) -> Result<Option<Plane>, OrganError> {
    let atrium = check_valve(valve)?;
    let ring = &valve.ring;
    match mode {
        AnnulusMode::Straight => Ok(None),
        AnnulusMode::LeastSquares => {
            let n = ring.len() as f64;
            let c = Point3::from(ring.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n);
            let mut cov = Matrix3::zeros();
            for p in ring {
                let d = p - c;
                cov += d * d.transpose();
            }
            let eig = cov.symmetric_eigen();
            let mut idx = [0usize, 1, 2];
            idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
            let (l_mid, l_max) = (eig.eigenvalues[idx[1]], eig.eigenvalues[idx[2]]);
            if !(l_max > 0.0 && l_mid > COLLINEAR_REL * l_max) {
                return Err(AnnulusError::PointsOnALine {
                    spreads_mm2: [l_mid, l_max],
                }
                .into());
            }
            let normal = eig.eigenvectors.column(idx[0]).into_owned();
            let normal = orient(normal.normalize(), &atrium, mode)?;
            Ok(Some(Plane { point: c, normal }))
        }
        AnnulusMode::Landmark => {
            let a = ring[0];
            let b = ring[valve.posteromedial];
            let posterior = &ring[valve.posteromedial + 1..];
            if posterior.is_empty() {
                return Err(AnnulusError::NoPosteriorPoints.into());
            }
            let c = Point3::from(
                posterior.iter().map(|p| p.coords).sum::<Vector3<f64>>() / posterior.len() as f64,
            );
            let (ab, ac) = (b - a, c - a);
            let cross = ab.cross(&ac);
            let scale = ab.norm() * ac.norm();
            if !(scale > 0.0 && cross.norm() > COLLINEAR_REL * scale) {
                return Err(AnnulusError::LandmarksCollinear {
                    landmarks: [a, b, c].map(|p| [p.x, p.y, p.z]),
                }
                .into());
            }
            let normal = orient(cross.normalize(), &atrium, mode)?;
            Ok(Some(Plane { point: a, normal }))
        }
    }
}

/// Lays out the ring of a prepared valve (ring clockwise from the atrium
/// starting at the anterolateral commissure, `posteromedial` its index,
/// `atrium` the unit normal to the atrium side) with the formulas of the
/// module docs: `u_0 = 0` at `ring[0]`, running over `ring[1..]` and back to
/// `ring[0]` (the closing point gets `u = ` the total), `v` the signed
/// distance to [`plane`] (0 in straight mode), `s` the 3D arc length.
///
/// # Errors
/// Those of [`plane`]; [`AnnulusError::Length`] when the ring has zero or
/// non-finite length, [`AnnulusError::LayoutNotFinite`] when a `(u, v)` is
/// not finite.
pub fn parameterize(valve: &PreparedValve, mode: AnnulusMode) -> Result<AnnulusMap, OrganError> {
    let plane = plane(valve, mode)?;
    let ring = &valve.ring;
    let n = ring.len();
    let height = |p: &Point3<f64>| plane.as_ref().map_or(0.0, |pl| pl.signed_distance(p));
    let mut s = Vec::with_capacity(n + 1);
    let mut uv = Vec::with_capacity(n + 1);
    s.push(0.0);
    uv.push([0.0, height(&ring[0])]);
    for i in 1..=n {
        let (p0, p1) = (&ring[i - 1], &ring[i % n]);
        let d = (p1 - p0).norm();
        let v = height(p1);
        let [u0, v0] = uv[i - 1];
        let dv = v - v0;
        let du = (d * d - dv * dv).max(0.0).sqrt();
        s.push(s[i - 1] + d);
        uv.push([u0 + du, v]);
    }
    let length = s[n];
    if !(length.is_finite() && length > 0.0) {
        return Err(AnnulusError::Length { length_mm: length }.into());
    }
    if let Some(index) = uv
        .iter()
        .position(|q| !(q[0].is_finite() && q[1].is_finite()))
    {
        return Err(AnnulusError::LayoutNotFinite { index }.into());
    }
    Ok(AnnulusMap {
        plane,
        s,
        uv,
        length,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::{ANTERIOR, Leaflet, POSTERIOR};
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::shapes::{Pose, ValveParams, ValveShape, mitral_valve};

    /// Arc length of each ring point from `ring[0]` (`len = n + 1`, the last
    /// the total).
    fn ring_arc(ring: &[Point3<f64>]) -> Vec<f64> {
        let n = ring.len();
        let mut s = vec![0.0];
        for i in 1..=n {
            s.push(s[i - 1] + (ring[i % n] - ring[i - 1]).norm());
        }
        s
    }

    /// The free edge of a generator leaflet: the last column down (without
    /// its annulus vertex), the bottom row back, the first column up.
    fn free_edge(cols: &[Vec<u32>]) -> Vec<u32> {
        let last = &cols[cols.len() - 1];
        let mut out: Vec<u32> = last[1..].to_vec();
        for c in cols[1..cols.len() - 1].iter().rev() {
            out.push(*c.last().unwrap());
        }
        out.extend(cols[0][1..].iter().rev());
        out
    }

    /// A prepared valve straight from the generator (the ring is already in
    /// contract order).
    pub(crate) fn prepared(shape: &ValveShape) -> PreparedValve {
        let arc = ring_arc(&shape.annulus);
        let n = shape.annulus.len();
        let leaflet = |mesh: &unfold_mesh::TriMesh,
                       annulus: &[u32],
                       ring: &[usize],
                       cols: &[Vec<u32>],
                       posterior: bool| {
            let m = ring.len();
            let annulus_s = ring
                .iter()
                .enumerate()
                .map(|(k, &r)| {
                    if posterior && k == m - 1 {
                        arc[n]
                    } else {
                        arc[r]
                    }
                })
                .collect();
            Leaflet {
                mesh: mesh.clone(),
                annulus: annulus.to_vec(),
                annulus_s,
                free_edge: free_edge(cols),
            }
        };
        PreparedValve {
            ring: shape.annulus.clone(),
            posteromedial: shape.commissures[1],
            atrium: shape.atrium_direction,
            leaflets: [
                leaflet(
                    &shape.anterior,
                    &shape.anterior_annulus,
                    &shape.anterior_annulus_ring,
                    &shape.anterior_longitudes,
                    false,
                ),
                leaflet(
                    &shape.posterior,
                    &shape.posterior_annulus,
                    &shape.posterior_annulus_ring,
                    &shape.posterior_longitudes,
                    true,
                ),
            ],
            tolerance_mm: 1e-6,
        }
    }

    pub(crate) fn default_valve() -> (ValveShape, PreparedValve) {
        let shape = mitral_valve(&ValveParams::default()).unwrap();
        let valve = prepared(&shape);
        (shape, valve)
    }

    const MODES: [AnnulusMode; 3] = [
        AnnulusMode::Straight,
        AnnulusMode::LeastSquares,
        AnnulusMode::Landmark,
    ];

    #[test]
    fn mitral_annulus_helper_is_consistent() {
        let (shape, valve) = default_valve();
        for k in [ANTERIOR, POSTERIOR] {
            let l = &valve.leaflets[k];
            assert_eq!(l.annulus.len(), l.annulus_s.len());
            assert!(l.annulus_s.windows(2).all(|w| w[0] < w[1]));
            let nb = l.annulus.len() + l.free_edge.len();
            assert_eq!(
                nb,
                2 * (l.annulus.len() - 1) + 2 * shape.params.depth_segments
            );
        }
        let len = ring_arc(&shape.annulus)[shape.annulus.len()];
        assert_eq!(*valve.leaflets[POSTERIOR].annulus_s.last().unwrap(), len);
        assert_eq!(valve.leaflets[ANTERIOR].annulus_s[0], 0.0);
    }

    #[test]
    fn mitral_annulus_shapes_and_lengths() {
        let (shape, valve) = default_valve();
        let n = shape.annulus.len();
        let len = ring_arc(&shape.annulus)[n];
        for mode in MODES {
            let m = parameterize(&valve, mode).unwrap();
            assert_eq!(m.s.len(), n + 1);
            assert_eq!(m.uv.len(), n + 1);
            assert_eq!(m.s[0], 0.0);
            assert_eq!(m.uv[0][0], 0.0);
            assert!((m.length - len).abs() <= 1e-12 * len);
            assert_eq!(*m.s.last().unwrap(), m.length);
            // Closing point: same height as ring[0].
            assert_eq!(m.uv[n][1], m.uv[0][1]);
            assert_eq!(m.plane.is_none(), mode == AnnulusMode::Straight);
            assert_eq!(m.u_extent(), m.uv[n][0]);
            if mode == AnnulusMode::Straight {
                assert!((m.u_extent() - len).abs() <= 1e-9 * len);
                assert!(m.uv.iter().all(|q| q[1] == 0.0));
            } else {
                // Heights shorten the u extent.
                assert!(m.u_extent() < len - 0.1, "{mode:?}: {}", m.u_extent());
            }
        }
    }

    #[test]
    fn mitral_annulus_plane_modes_keep_segment_lengths() {
        let (shape, valve) = default_valve();
        let n = shape.annulus.len();
        for mode in [AnnulusMode::LeastSquares, AnnulusMode::Landmark] {
            let m = parameterize(&valve, mode).unwrap();
            let plane = m.plane.unwrap();
            assert!((plane.normal.norm() - 1.0).abs() < 1e-12);
            assert!(plane.normal.dot(&shape.atrium_direction) > 0.0);
            for i in 1..=n {
                let (p0, p1) = (shape.annulus[i - 1], shape.annulus[i % n]);
                let d = (p1 - p0).norm();
                let (q0, q1) = (m.uv[i - 1], m.uv[i]);
                let (du, dv) = (q1[0] - q0[0], q1[1] - q0[1]);
                assert!(du > 0.0, "{mode:?}: u not increasing at {i}");
                assert!(dv.abs() <= d * (1.0 + 1e-12));
                assert!(((du * du + dv * dv).sqrt() - d).abs() <= 1e-12 * (1.0 + d));
                // v is the signed distance to the plane.
                assert!((q1[1] - plane.signed_distance(&p1)).abs() < 1e-12);
                assert!((m.s[i] - m.s[i - 1] - d).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn mitral_annulus_landmark_plane_on_default_valve() {
        let (shape, valve) = default_valve();
        let m = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let pm = shape.commissures[1];
        // Both commissures on the plane.
        assert!(m.uv[0][1].abs() < 1e-12);
        assert!(m.uv[pm][1].abs() < 1e-12);
        assert!(m.uv[shape.annulus.len()][1].abs() < 1e-12);
        // The saddle horns (anterior and posterior midpoints) above it.
        let n = shape.annulus.len();
        let ant_horn = pm / 2;
        let post_horn = pm + (n - pm) / 2;
        assert!(m.uv[ant_horn][1] > 3.0, "{}", m.uv[ant_horn][1]);
        assert!(m.uv[post_horn][1] > 0.0, "{}", m.uv[post_horn][1]);
        // The anterior horn is the highest point.
        let top = m.uv.iter().map(|q| q[1]).fold(f64::MIN, f64::max);
        assert_eq!(top, m.uv[ant_horn][1]);
        // The plane passes through the posterior barycentre: the posterior
        // heights strictly between the commissures average to 0.
        let mean = m.uv[pm + 1..n].iter().map(|q| q[1]).sum::<f64>() / (n - pm - 1) as f64;
        assert!(mean.abs() < 1e-12, "{mean}");
        // Canonical pose: the plane contains the commissural line (the x
        // axis at z = -h/2), so its normal has no x component.
        let plane = m.plane.unwrap();
        assert!(plane.normal.x.abs() < 1e-12);
    }

    /// A ring whose posterior arc is flat at the commissures' height and
    /// whose anterior arc rises to `h`: the landmark plane is that flat
    /// plane, and `max v - min v` is the saddle height.
    #[test]
    fn mitral_annulus_landmark_recovers_saddle_height() {
        let h = 6.0;
        let (shape, mut valve) = default_valve();
        let pm = shape.commissures[1];
        let n = shape.annulus.len();
        for (i, p) in valve.ring.iter_mut().enumerate() {
            let t = if i <= pm {
                std::f64::consts::PI * i as f64 / pm as f64
            } else {
                0.0
            };
            p.z = h * t.sin();
        }
        let m = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let vs: Vec<f64> = m.uv.iter().map(|q| q[1]).collect();
        let range = vs.iter().copied().fold(f64::MIN, f64::max)
            - vs.iter().copied().fold(f64::MAX, f64::min);
        assert!((range - h).abs() < 1e-9, "{range}");
        assert!(vs[pm + 1..n].iter().all(|v| v.abs() < 1e-12));
        // On the generator's own saddle the landmark plane is tilted about
        // the commissural line (the posterior barycentre is at mid-height),
        // so its range is not the saddle height; the distance along the
        // atrial direction is.
        let m = parameterize(&default_valve().1, AnnulusMode::Landmark).unwrap();
        let up = shape.atrium_direction;
        let hs: Vec<f64> = shape.annulus.iter().map(|p| p.coords.dot(&up)).collect();
        let range = hs.iter().copied().fold(f64::MIN, f64::max)
            - hs.iter().copied().fold(f64::MAX, f64::min);
        assert!((range - shape.params.saddle_height).abs() < 1e-9);
        let vs: Vec<f64> = m.uv.iter().map(|q| q[1]).collect();
        let vrange = vs.iter().copied().fold(f64::MIN, f64::max)
            - vs.iter().copied().fold(f64::MAX, f64::min);
        assert!(vrange > shape.params.saddle_height);
    }

    #[test]
    fn mitral_annulus_at_interpolates_and_clamps() {
        let (_, valve) = default_valve();
        let m = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        for k in 0..m.s.len() {
            // Exact at ring points (a zero-length segment never occurs here).
            assert_eq!(m.at(m.s[k]), m.uv[k]);
        }
        let mid = 0.5 * (m.s[3] + m.s[4]);
        let q = m.at(mid);
        for (c, qc) in q.iter().enumerate() {
            assert!((qc - 0.5 * (m.uv[3][c] + m.uv[4][c])).abs() < 1e-12);
        }
        assert_eq!(m.at(-5.0), m.uv[0]);
        assert_eq!(m.at(m.length + 5.0), *m.uv.last().unwrap());
        assert_eq!(m.at(f64::INFINITY), *m.uv.last().unwrap());
        assert!(m.at(f64::NAN)[0].is_nan());
        let empty = AnnulusMap {
            plane: None,
            s: vec![],
            uv: vec![],
            length: 0.0,
        };
        assert!(empty.at(1.0)[0].is_nan());
        assert_eq!(empty.u_extent(), 0.0);
        // Leaflet annulus vertices: the anterior's end and the posterior's
        // start are both the posteromedial commissure.
        let a = &valve.leaflets[ANTERIOR];
        let p = &valve.leaflets[POSTERIOR];
        assert_eq!(m.at(*a.annulus_s.last().unwrap()), m.at(p.annulus_s[0]));
        assert_eq!(m.at(*p.annulus_s.last().unwrap()), *m.uv.last().unwrap());
    }

    fn small_ring(points: &[[f64; 3]], pm: usize) -> PreparedValve {
        let (_, mut valve) = default_valve();
        valve.ring = points
            .iter()
            .map(|p| Point3::new(p[0], p[1], p[2]))
            .collect();
        valve.posteromedial = pm;
        valve.atrium = Vector3::z();
        valve
    }

    /// The annulus error of `r`.
    fn annulus_err<T: std::fmt::Debug>(r: Result<T, OrganError>) -> AnnulusError {
        match r {
            Err(OrganError::Mitral(crate::mitral::MitralError::Annulus(e))) => e,
            other => panic!("expected an annulus error, got {other:?}"),
        }
    }

    #[test]
    fn mitral_annulus_errors() {
        use AnnulusError as E;
        // The only posterior point lies on the commissural line.
        let v = small_ring(
            &[
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.2],
                [1.0, 0.0, 0.0],
                [0.2, 0.0, 0.0],
            ],
            2,
        );
        let e = annulus_err(plane(&v, AnnulusMode::Landmark));
        assert!(
            matches!(e, E::LandmarksCollinear { landmarks } if landmarks[0] == [-1.0, 0.0, 0.0]
                && landmarks[1] == [1.0, 0.0, 0.0] && landmarks[2] == [0.2, 0.0, 0.0]),
            "{e:?}"
        );
        assert!(e.to_string().contains("collinear"), "{e}");
        assert!(matches!(
            annulus_err(parameterize(&v, AnnulusMode::Landmark)),
            E::LandmarksCollinear { .. }
        ));
        // The other modes still work there.
        assert!(parameterize(&v, AnnulusMode::LeastSquares).is_ok());
        assert!(parameterize(&v, AnnulusMode::Straight).is_ok());
        // Posterior barycentre collinear with the commissures (symmetric
        // posterior points).
        let v = small_ring(
            &[
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, -1.0, 0.3],
                [-0.5, 1.0, -0.3],
            ],
            2,
        );
        assert!(matches!(
            annulus_err(plane(&v, AnnulusMode::Landmark)),
            E::LandmarksCollinear { .. }
        ));
        // All ring points on a line.
        let v = small_ring(
            &[
                [-1.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
            ],
            2,
        );
        assert!(matches!(
            annulus_err(plane(&v, AnnulusMode::LeastSquares)),
            E::PointsOnALine { .. }
        ));
        assert!(matches!(
            annulus_err(plane(&v, AnnulusMode::Landmark)),
            E::LandmarksCollinear { .. }
        ));
        // No posterior point between the commissures.
        let v = small_ring(&[[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]], 2);
        assert_eq!(
            annulus_err(plane(&v, AnnulusMode::Landmark)),
            E::NoPosteriorPoints
        );
        assert!(parameterize(&v, AnnulusMode::Straight).is_ok());
        // Bad inputs.
        let good = [
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
        ];
        for mode in MODES {
            assert_eq!(
                annulus_err(parameterize(&small_ring(&good[..2], 1), mode)),
                E::TooFewPoints { count: 2 }
            );
            for pm in [0, 4] {
                assert_eq!(
                    annulus_err(parameterize(&small_ring(&good, pm), mode)),
                    E::PosteromedialOutOfRange {
                        index: pm,
                        ring_points: 4
                    }
                );
            }
            let mut bad = good;
            bad[1][2] = f64::NAN;
            assert!(matches!(
                annulus_err(parameterize(&small_ring(&bad, 2), mode)),
                E::PointNotFinite { index: 1, .. }
            ));
            let mut v = small_ring(&good, 2);
            v.atrium = Vector3::zeros();
            assert_eq!(
                annulus_err(parameterize(&v, mode)),
                E::AtriumNotUsable {
                    atrium: [0.0, 0.0, 0.0]
                }
            );
            // All points equal: zero length (no plane either).
            let same = [[1.0, 2.0, 3.0]; 4];
            let e = annulus_err(parameterize(&small_ring(&same, 2), mode));
            assert!(
                match mode {
                    AnnulusMode::Straight => matches!(e, E::Length { length_mm: 0.0 }),
                    AnnulusMode::LeastSquares => matches!(e, E::PointsOnALine { .. }),
                    AnnulusMode::Landmark => matches!(e, E::LandmarksCollinear { .. }),
                },
                "{mode:?}: {e:?}"
            );
        }
        // A normal perpendicular to the atrial direction.
        let mut v = small_ring(&good, 2);
        v.atrium = Vector3::x();
        let e = annulus_err(parameterize(&v, AnnulusMode::Landmark));
        assert!(
            matches!(
                e,
                E::NormalPerpendicularToAtrium {
                    mode: AnnulusMode::Landmark,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("perpendicular"), "{e}");
        // Messages are one line.
        assert!(!e.to_string().contains('\n'));
        assert_eq!(
            E::AtriumNotUsable {
                atrium: [0.0, 0.0, 0.0]
            }
            .to_string(),
            "the atrial direction [0.0, 0.0, 0.0] is not a finite non-zero vector"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        #[test]
        fn mitral_annulus_straight_u_extent_is_ring_length(
            cd in 24.0..40.0f64,
            ap in 20.0..34.0f64,
            saddle in 0.0..9.0f64,
            segments in 12usize..200,
            roll in -180.0..180.0f64,
            pitch in -90.0..90.0f64,
            yaw in -180.0..180.0f64,
            t in prop::array::uniform3(-300.0..300.0f64),
        ) {
            let p = ValveParams {
                commissural_diameter: cd,
                anteroposterior_diameter: ap,
                saddle_height: saddle,
                coaptation_offset: 0.3 * ap * 0.64,
                coaptation_depth: 0.5 * saddle + 4.0,
                commissure_gap: (0.3 * ap * 0.64).min(8.0),
                annulus_segments: segments,
                depth_segments: 3,
                pose: Pose::new([roll, pitch, yaw], t),
                ..ValveParams::default()
            };
            let shape = mitral_valve(&p).unwrap();
            let valve = prepared(&shape);
            let len = ring_arc(&shape.annulus)[shape.annulus.len()];
            let m = parameterize(&valve, AnnulusMode::Straight).unwrap();
            prop_assert!((m.u_extent() - len).abs() <= 1e-9 * len);
            prop_assert!((m.length - len).abs() <= 1e-12 * len);
            // Rigid motions do not change the layout (any mode).
            let base = prepared(&mitral_valve(&ValveParams { pose: Pose::identity(), ..p.clone() }).unwrap());
            for mode in MODES {
                let a = parameterize(&base, mode).unwrap();
                let b = parameterize(&valve, mode).unwrap();
                for (qa, qb) in a.uv.iter().zip(&b.uv) {
                    prop_assert!((qa[0] - qb[0]).abs() < 1e-9 && (qa[1] - qb[1]).abs() < 1e-9,
                        "{:?}: {:?} vs {:?}", mode, qa, qb);
                }
                // u never decreases; plane modes keep every segment length.
                for w in b.uv.windows(2) {
                    prop_assert!(w[1][0] >= w[0][0]);
                }
            }
        }
    }
}
