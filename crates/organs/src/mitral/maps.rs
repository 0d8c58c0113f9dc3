//! Distortion and clinical maps of a laid-out valve, and its measurements
//! (ALGORITHMS 4.4 and 4.5).
//!
//! Inputs are the [`PreparedValve`] (3D leaflets, their annulus vertices,
//! the ring), one 2D position `q_i = (u_i, v_i)` per leaflet vertex (the
//! annulus at the top, `v` decreasing downwards; the anterior leaflet at
//! `u` in `[0, u_pm]` from the anterolateral to the posteromedial
//! commissure, the posterior at `[u_pm, L]` from the posteromedial to the
//! anterolateral commissure, `L` the cut) and the annulus [`Plane`] (normal
//! towards the atrium).
//!
//! # Orientation of the 2D layout
//!
//! The energies come from `unfold_param::metrics` on a
//! [`ParamMesh::from_triangles`] of the 3D leaflet. That rest mesh expresses
//! every 3D triangle in its own orthonormal frame with a positive
//! determinant (`Dm`), so `det J = det(Ds Dm^-1)` is positive exactly when
//! the triangle's 2D image, in the mesh's own winding, is counter-clockwise
//! (`(q1 - q0) x (q2 - q0) > 0`); clockwise images are "inverted" and get
//! `+inf`. For leaflets wound with their normals towards the atrium (as the
//! synthetic valve of `unfold_mesh::shapes::mitral_valve`) and the layout
//! above (the ring clockwise seen from the atrium mapped to increasing `u`,
//! the leaflet hanging to `v < 0`), the 2D triangles come out
//! counter-clockwise: seen from the atrium, "along the ring" and "into the
//! leaflet" form the same turn as `+u` and `-v`. A leaflet wound the other
//! way (normals towards the ventricle) is clockwise in 2D; since every
//! energy here is invariant under the mirror `u -> -u` but `+inf` on a
//! negative area, a leaflet whose layout is clockwise is mirrored before
//! the energies are evaluated. "Clockwise" is decided as in `relax` and
//! `flipped_triangles`: by the majority of the triangles' signed 2D areas
//! `(q1 - q0) x (q2 - q0)` (by count; a tie goes to the sign of their sum,
//! then to counter-clockwise). The triangles of the minority orientation
//! (flipped) keep their `+inf`.

use super::{ANTERIOR, Leaflet, LeafletSide, MapsError, POSTERIOR, Plane, PreparedValve};
use crate::OrganError;
use serde::{Deserialize, Serialize};
use std::ops::Index;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::{majority_sign, twice_signed_areas_2d};
use unfold_mesh::nalgebra::{Point3, Vector3};
use unfold_mesh::spatial::ClosestPointQuery;
use unfold_param::ParamMesh;
use unfold_param::metrics::{angle_energy, area_energy, length_energy};

/// Default coaptation threshold, mm (the source's default).
pub const DEFAULT_COAPTATION_MM: f64 = 2.0;

/// Default side of the checkerboard squares, mm. The checkerboard is stored
/// per vertex, so a square must span a few vertices to be visible: the
/// source's valves (about 2,500 vertices) and the synthetic default valve
/// have vertices 1-1.5 mm apart, and 5 mm squares give about 20 squares
/// along the annulus and 5 down a leaflet.
pub const DEFAULT_CHECKER_MM: f64 = 5.0;

/// Carpentier label of segment A1 (anterior, next to the anterolateral
/// commissure).
pub const A1: i32 = 1;
/// Carpentier label of segment A2 (anterior, middle).
pub const A2: i32 = 2;
/// Carpentier label of segment A3 (anterior, next to the posteromedial
/// commissure).
pub const A3: i32 = 3;
/// Carpentier label of segment P1 (posterior, next to the anterolateral
/// commissure).
pub const P1: i32 = 4;
/// Carpentier label of segment P2 (posterior, middle).
pub const P2: i32 = 5;
/// Carpentier label of segment P3 (posterior, next to the posteromedial
/// commissure).
pub const P3: i32 = 6;

/// Coaptation label: farther than twice the threshold from the other leaflet.
pub const COAPTATION_NONE: i32 = 0;
/// Coaptation label: `threshold <= d < 2 threshold` (the source's yellow).
pub const COAPTATION_NEAR: i32 = 1;
/// Coaptation label: `d < threshold`, in the coaptation zone (green).
pub const COAPTATION_WITHIN: i32 = 2;

/// Settings of [`leaflet_maps`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MapsConfig {
    /// Coaptation threshold `t`, mm (default [`DEFAULT_COAPTATION_MM`] = 2):
    /// a vertex at distance `d` from the other leaflet is in the zone when
    /// `d < t`, near it when `d < 2 t`.
    pub coaptation_mm: f64,
    /// Side `s` of the checkerboard squares in the 2D view, mm (default
    /// [`DEFAULT_CHECKER_MM`] = 5).
    pub checker_mm: f64,
}

impl Default for MapsConfig {
    fn default() -> Self {
        MapsConfig {
            coaptation_mm: DEFAULT_COAPTATION_MM,
            checker_mm: DEFAULT_CHECKER_MM,
        }
    }
}

impl MapsConfig {
    /// Checks both values: finite and `> 0`.
    ///
    /// # Errors
    /// [`OrganError::Config`] naming the offending value.
    pub fn validate(&self) -> Result<(), OrganError> {
        OrganError::check_positive(&[
            ("coaptation_mm", self.coaptation_mm),
            ("checker_mm", self.checker_mm),
        ])
    }
}

/// The maps of one leaflet. Per-vertex arrays follow the leaflet mesh's
/// vertex order, per-triangle arrays its triangle order.
#[derive(Debug, Clone, PartialEq)]
pub struct LeafletMaps {
    /// Leaflet identity: 0 anterior ([`ANTERIOR`]), 1 posterior
    /// ([`POSTERIOR`]); a constant per-vertex array when written.
    pub leaflet: i32,
    /// Per vertex RGB in `[0, 1]` along the normalized `u`
    /// `t = clamp((u - u_first) / (u_last - u_first), 0, 1)` of the leaflet
    /// (`u_first`, `u_last`: its first and last annulus vertex, i.e. its two
    /// commissures): anterior red to green `(1 - t, t, 0)`, posterior green
    /// to blue `(0, 1 - t, t)` (continuous at the posteromedial commissure).
    pub u_gradient: Vec<[f64; 3]>,
    /// Per vertex `0..=7`: `floor(8 (u - u_0) / (u_L - u_0))`, clamped, with
    /// `u_0` the `u` of the anterior leaflet's first annulus vertex (the
    /// anterolateral commissure, 0) and `u_L` that of the posterior leaflet's
    /// last one (the cut, `L`): eight equal `u` intervals of the whole
    /// annulus extent.
    pub u_interval: Vec<i32>,
    /// Per vertex 0 or 1: `(floor(u / s) + floor(v / s)) mod 2`, a
    /// checkerboard of squares of side `s` ([`MapsConfig::checker_mm`]) in
    /// `(u, v)`.
    pub checker: Vec<i32>,
    /// Per vertex Carpentier segment [`A1`]..[`A3`] (1-3) on the anterior
    /// leaflet, [`P1`]..[`P3`] (4-6) on the posterior (see
    /// [`carpentier_label`]).
    pub carpentier: Vec<i32>,
    /// Per triangle area energy `E_A = A/Â + Â/A` (`A` the 2D, `Â` the 3D
    /// area); minimum 2, `+inf` for a flipped triangle.
    pub area_energy: Vec<f64>,
    /// Per triangle angle (MIPS) energy
    /// `E_M = (cot a |a'|^2 + cot b |b'|^2 + cot c |c'|^2) / (2 A')`
    /// (`a, b, c` the 3D angles, `a', b', c'` the opposite 2D edges, `A'` the
    /// 2D area); minimum 2, `+inf` for a flipped triangle.
    pub angle_energy: Vec<f64>,
    /// Per vertex length energy
    /// `E_l(i) = 1/|N_i| sum_j (|q_i - q_j| / |p_i - p_j| + |p_i - p_j| / |q_i - q_j|)`
    /// over its edge neighbours `N_i`; minimum 2, NaN for a vertex in no
    /// triangle.
    pub length_energy: Vec<f64>,
    /// Per vertex [`COAPTATION_WITHIN`] (2) when `d < t`, [`COAPTATION_NEAR`]
    /// (1) when `t <= d < 2 t`, else [`COAPTATION_NONE`] (0); `d` =
    /// [`LeafletMaps::coaptation_distance_mm`], `t` =
    /// [`MapsConfig::coaptation_mm`].
    pub coaptation: Vec<i32>,
    /// Per vertex distance to the closest point of the other leaflet's
    /// surface (any point of its triangles, not only its vertices as in the
    /// source), mm; `+inf` when the other leaflet has no triangle.
    pub coaptation_distance_mm: Vec<f64>,
    /// Per vertex signed distance to the annulus plane `n . (p - o)`, mm:
    /// positive on the atrial side (above the plane: prolapse, or the
    /// annulus' saddle horns), negative below.
    pub tenting_mm: Vec<f64>,
}

/// The clinical maps and distortion energies of both leaflets (ALGORITHMS
/// 4.4 and 4.5), indexed by [`ANTERIOR`] and [`POSTERIOR`].
///
/// `uv[k]` has one `(u, v)` per vertex of leaflet `k`; the annulus of each
/// leaflet must be laid out with increasing `u` from its first to its last
/// annulus vertex. `plane` is the annulus plane (its normal is normalized
/// here; it must point towards the atrium for the tenting sign).
///
/// # Errors
/// [`OrganError::Config`] for a bad `config`; a [`MapsError`] (in
/// [`OrganError::Mitral`]) when a `uv` has the wrong length or a non-finite value, a leaflet has fewer than
/// two annulus vertices or an out-of-range one, its annulus does not
/// increase in `u`, or the plane is not finite / has a zero normal;
/// [`OrganError::Param`] when a 3D leaflet has a degenerate triangle (the
/// energies are undefined).
pub fn leaflet_maps(
    valve: &PreparedValve,
    uv: [&[[f64; 2]]; 2],
    plane: &Plane,
    config: &MapsConfig,
) -> Result<[LeafletMaps; 2], OrganError> {
    config.validate()?;
    let (a, p) = rayon::join(
        || coaptation_distances(valve, ANTERIOR),
        || coaptation_distances(valve, POSTERIOR),
    );
    leaflet_maps_with(valve, uv, plane, config, [a, p])
}

/// Per vertex of leaflet `k`, the distance (mm) to the closest point of the
/// other leaflet's surface: [`LeafletMaps::coaptation_distance_mm`]. It
/// depends on the 3D leaflets only, so a pipeline can compute it while the
/// layouts relax. Exact (a closest-point search over a BVH of the other
/// leaflet), in parallel over the vertices; `+inf` everywhere when the
/// other leaflet has no triangle. Out-of-range `k` gives an empty list.
pub fn coaptation_distances(valve: &PreparedValve, k: usize) -> Vec<f64> {
    use rayon::prelude::*;
    if k > 1 {
        return Vec::new();
    }
    let other = ClosestPointQuery::new(&valve.leaflets[1 - k].mesh);
    valve.leaflets[k]
        .mesh
        .positions
        .par_iter()
        .with_min_len(64)
        .map(|p| other.closest(p).map_or(f64::INFINITY, |c| c.distance))
        .collect()
}

/// [`leaflet_maps`] with the coaptation distances already computed
/// ([`coaptation_distances`] of each leaflet).
///
/// # Errors
/// As [`leaflet_maps`]; [`MapsError::CoaptationDistanceCount`] also when
/// a distance list does not have one value per vertex of its leaflet.
pub fn leaflet_maps_with(
    valve: &PreparedValve,
    uv: [&[[f64; 2]]; 2],
    plane: &Plane,
    config: &MapsConfig,
    coaptation_distances: [Vec<f64>; 2],
) -> Result<[LeafletMaps; 2], OrganError> {
    config.validate()?;
    for (k, d) in coaptation_distances.iter().enumerate() {
        let n = valve.leaflets[k].mesh.positions.len();
        if d.len() != n {
            return Err(MapsError::CoaptationDistanceCount {
                leaflet: LeafletSide::of(k),
                distances: d.len(),
                vertices: n,
            }
            .into());
        }
    }
    let plane = unit_plane(plane)?;
    let mut frames = Vec::with_capacity(2);
    for k in [ANTERIOR, POSTERIOR] {
        check_uv(k, &valve.leaflets[k].mesh, uv[k])?;
        frames.push(LeafletFrame::new(k, &valve.leaflets[k], uv[k])?);
    }
    let u_start = frames[ANTERIOR].u_first;
    let u_end = frames[POSTERIOR].u_last;
    let extent = u_end - u_start;
    if !(extent.is_finite() && extent > 0.0) {
        return Err(MapsError::NoUExtent { u_start, u_end }.into());
    }
    let [dist_a, dist_p] = coaptation_distances;
    let one = |k: usize, coaptation_distance_mm: Vec<f64>| -> Result<LeafletMaps, OrganError> {
        let leaflet = &valve.leaflets[k];
        let q = uv[k];
        let frame = &frames[k];
        let energies = energies(k, &leaflet.mesh, q)?;
        let u_gradient = q
            .iter()
            .map(|p| {
                let t = frame.normalized_u(p[0]).clamp(0.0, 1.0);
                if k == ANTERIOR {
                    [1.0 - t, t, 0.0]
                } else {
                    [0.0, 1.0 - t, t]
                }
            })
            .collect();
        let u_interval = q
            .iter()
            .map(|p| (8.0 * (p[0] - u_start) / extent).floor().clamp(0.0, 7.0) as i32)
            .collect();
        let s = config.checker_mm;
        let checker = q
            .iter()
            .map(|p| {
                let a = (p[0] / s).floor().rem_euclid(2.0);
                let b = (p[1] / s).floor().rem_euclid(2.0);
                (a + b).rem_euclid(2.0) as i32
            })
            .collect();
        let carpentier = q
            .iter()
            .map(|p| {
                carpentier_label(
                    k,
                    frame.normalized_u(p[0]),
                    p[1] - frame.v_top,
                    frame.v_bottom,
                )
            })
            .collect();
        let t = config.coaptation_mm;
        let coaptation = coaptation_distance_mm
            .iter()
            .map(|&d| {
                if d < t {
                    COAPTATION_WITHIN
                } else if d < 2.0 * t {
                    COAPTATION_NEAR
                } else {
                    COAPTATION_NONE
                }
            })
            .collect();
        let tenting_mm = leaflet
            .mesh
            .positions
            .iter()
            .map(|p| plane.signed_distance(p))
            .collect();
        Ok(LeafletMaps {
            leaflet: k as i32,
            u_gradient,
            u_interval,
            checker,
            carpentier,
            area_energy: energies.area,
            angle_energy: energies.angle,
            length_energy: energies.length,
            coaptation,
            coaptation_distance_mm,
            tenting_mm,
        })
    };
    // The leaflets are independent: in parallel.
    let (a, p) = rayon::join(|| one(ANTERIOR, dist_a), || one(POSTERIOR, dist_p));
    Ok([a?, p?])
}

/// The Carpentier segment of a point of leaflet `leaflet` (ALGORITHMS 4.5,
/// the source's texture-based rule) from its normalized coordinates:
///
/// - `u_n`: `u` normalized along the leaflet, `(u - u_first) / (u_last -
///   u_first)` with `u_first`, `u_last` the `u` of its first and last
///   annulus vertex (the anterior leaflet: 0 at the anterolateral, 1 at the
///   posteromedial commissure; the posterior: 0 at the posteromedial, 1 at
///   the anterolateral commissure);
/// - `v_s`: `v` shifted so the leaflet's highest annulus point is at 0;
/// - `v_bottom`: the leaflet's lowest shifted `v` (`< 0`).
///
/// Anterior: with `s = clamp(v_s / v_bottom, 0, 1)` (0 at the top, 1 at the
/// bottom) the boundaries are the lines from `(1/2, 0)` to `(1/3, v_bottom)`
/// and to `(2/3, v_bottom)`, i.e. `u = 1/2 -+ s/6`: [`A1`] when
/// `u_n < 1/2 - s/6` (next to the anterolateral commissure), [`A3`] when
/// `u_n > 1/2 + s/6`, else [`A2`]. Above `v = 0` both boundaries are at
/// `1/2`; with `v_bottom >= 0` (no vertex below the top) `s = 0`.
///
/// Posterior (any `leaflet` other than [`ANTERIOR`]): vertical lines
/// `u_n = 1/3, 2/3`: [`P3`] when `u_n < 1/3` (next to the posteromedial
/// commissure), [`P1`] when `u_n > 2/3` (next to the anterolateral
/// commissure), else [`P2`].
///
/// Points on a boundary go to the middle segment; NaN inputs to the
/// middle segment of the anterior leaflet, to [`P2`] on the posterior.
pub fn carpentier_label(leaflet: usize, u_n: f64, v_s: f64, v_bottom: f64) -> i32 {
    if leaflet == ANTERIOR {
        let s = if v_bottom < 0.0 {
            (v_s / v_bottom).clamp(0.0, 1.0)
        } else {
            0.0
        };
        if u_n < 0.5 - s / 6.0 {
            A1
        } else if u_n > 0.5 + s / 6.0 {
            A3
        } else {
            A2
        }
    } else if u_n < 1.0 / 3.0 {
        P3
    } else if u_n > 2.0 / 3.0 {
        P1
    } else {
        P2
    }
}

/// Leaflet areas, mm^2; serialized as `{"anterior": .., "posterior": ..}`
/// and indexable by [`ANTERIOR`] / [`POSTERIOR`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerLeaflet {
    /// The anterior leaflet's value.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub anterior: f64,
    /// The posterior leaflet's value.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub posterior: f64,
}

impl PerLeaflet {
    /// `[anterior, posterior]`.
    pub fn to_array(self) -> [f64; 2] {
        [self.anterior, self.posterior]
    }
}

impl From<[f64; 2]> for PerLeaflet {
    fn from(v: [f64; 2]) -> Self {
        PerLeaflet {
            anterior: v[ANTERIOR],
            posterior: v[POSTERIOR],
        }
    }
}

impl Index<usize> for PerLeaflet {
    type Output = f64;

    /// `self[ANTERIOR]` or `self[POSTERIOR]`.
    ///
    /// # Panics
    /// For an index other than 0 or 1 (as an array would).
    fn index(&self, k: usize) -> &f64 {
        match k {
            ANTERIOR => &self.anterior,
            POSTERIOR => &self.posterior,
            _ => panic!("leaflet index {k} out of range (0 anterior, 1 posterior)"),
        }
    }
}

/// Measurements the source's surgeons asked for (ALGORITHMS 4.5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Measurements {
    /// 3D area of each leaflet, `sum_t |(p1 - p0) x (p2 - p0)| / 2`, mm^2.
    pub leaflet_area_mm2: PerLeaflet,
    /// Perimeter of the closed ring, `sum_i |r_{i+1} - r_i|` (indices mod
    /// n), mm.
    pub annulus_length_mm: f64,
    /// Height of the highest ring point above the plane,
    /// `max_i n . (r_i - o)`, mm (NaN for an empty ring).
    pub saddle_horn_height_mm: f64,
    /// Leaflet area (both leaflets) strictly on the atrial side of the
    /// plane, every triangle clipped exactly by the plane, mm^2.
    pub area_above_plane_mm2: f64,
    /// Leaflet area (both leaflets) on the ventricular side of the plane or
    /// in it, mm^2; `above + below` is the total leaflet area.
    pub area_below_plane_mm2: f64,
}

/// The measurements of a valve against the annulus plane (ALGORITHMS 4.5).
///
/// Heights are `h(p) = n . (p - o)` with the plane's normal normalized
/// first. A triangle with corner heights `h_0, h_1, h_2` and area `A` is
/// split exactly (heights are affine on it): when one corner `i` is alone on
/// its side, the part on that side is the triangle cut off at the two edge
/// points `p_i + h_i / (h_i - h_j) (p_j - p_i)`, of area
/// `A h_i^2 / ((h_i - h_j)(h_i - h_k))`, and the rest is `A` minus it.
/// "Above" means `h > 0`; a triangle in the plane counts as below.
///
/// Never fails: triangles with out-of-range indices are skipped, and a plane
/// with a zero or non-finite normal or point gives NaN heights and
/// above/below areas (the leaflet areas and annulus length are still
/// computed).
pub fn measurements(valve: &PreparedValve, plane: &Plane) -> Measurements {
    let plane = unit_plane(plane).ok();
    let height = |p: &Point3<f64>| plane.map_or(f64::NAN, |pl| pl.signed_distance(p));
    let mut areas = [0.0; 2];
    let (mut above, mut below) = (0.0, 0.0);
    for k in [ANTERIOR, POSTERIOR] {
        let mesh = &valve.leaflets[k].mesh;
        for t in &mesh.triangles {
            let Some(p) = corners(mesh, t) else { continue };
            let area = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
            areas[k] += area;
            let (a, b) = split_area(area, p.map(|q| height(&q)));
            above += a;
            below += b;
        }
    }
    let n = valve.ring.len();
    let annulus_length_mm = if n < 2 {
        0.0
    } else {
        (0..n)
            .map(|i| (valve.ring[(i + 1) % n] - valve.ring[i]).norm())
            .sum()
    };
    let saddle_horn_height_mm = valve
        .ring
        .iter()
        .map(&height)
        .reduce(|a, b| {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                a.max(b)
            }
        })
        .unwrap_or(f64::NAN);
    Measurements {
        leaflet_area_mm2: PerLeaflet::from(areas),
        annulus_length_mm,
        saddle_horn_height_mm,
        area_above_plane_mm2: above,
        area_below_plane_mm2: below,
    }
}

/// Mean distortion energies of a layout (ALGORITHMS 4.4), for the report
/// (initial and final layout). Plain, unweighted means as the source
/// reports them: over the triangles of both leaflets for the area and angle
/// energies, over the vertices of both leaflets for the length energy (the
/// commissure vertices, which both leaflet meshes have, count once per
/// leaflet). All are at least 2; `+inf` as soon as one triangle is flipped
/// (or has a zero-length 2D edge).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DistortionSummary {
    /// `mean_t E_A(t)`, `E_A = A/Â + Â/A`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub area: f64,
    /// `mean_t E_M(t)`, the MIPS energy `s1/s2 + s2/s1`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub angle: f64,
    /// `mean_i E_l(i)` over the vertices in at least one triangle.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub length: f64,
}

/// The [`DistortionSummary`] of a layout `uv` (one `(u, v)` per vertex of
/// each leaflet; a clockwise leaflet is mirrored first, see the module
/// docs).
///
/// # Errors
/// A [`MapsError`] (in [`OrganError::Mitral`]) when a `uv` has the wrong
/// length or a non-finite value; [`OrganError::Param`] when a 3D leaflet
/// has a degenerate triangle.
pub fn distortion(
    valve: &PreparedValve,
    uv: [&[[f64; 2]]; 2],
) -> Result<DistortionSummary, OrganError> {
    let e = [
        leaflet_energies(&valve.leaflets[ANTERIOR].mesh, ANTERIOR, uv[ANTERIOR])?,
        leaflet_energies(&valve.leaflets[POSTERIOR].mesh, POSTERIOR, uv[POSTERIOR])?,
    ];
    Ok(summarize(e.iter().map(|[a, m, l]| [&a[..], m, l])))
}

/// The area, angle and length energies of leaflet `k`'s layout `uv`
/// (checked), as in its [`LeafletMaps`].
pub(crate) fn leaflet_energies(
    mesh: &TriMesh,
    k: usize,
    uv: &[[f64; 2]],
) -> Result<[Vec<f64>; 3], OrganError> {
    check_uv(k, mesh, uv)?;
    let e = energies(k, mesh, uv)?;
    Ok([e.area, e.angle, e.length])
}

/// The [`DistortionSummary`] of the energy maps of both leaflets (as
/// [`distortion`] of the layout they were computed from).
pub fn summary(maps: &[LeafletMaps; 2]) -> DistortionSummary {
    summarize(
        maps.iter()
            .map(|m| [&m.area_energy[..], &m.angle_energy, &m.length_energy]),
    )
}

/// Plain means of per-leaflet energies `[area, angle, length]` (see
/// [`DistortionSummary`]).
pub(crate) fn summarize<'a>(leaflets: impl Iterator<Item = [&'a [f64]; 3]>) -> DistortionSummary {
    let (mut area, mut angle, mut length) = (0.0, 0.0, 0.0);
    let (mut triangles, mut vertices) = (0usize, 0usize);
    for [a, m, l] in leaflets {
        area += a.iter().sum::<f64>();
        angle += m.iter().sum::<f64>();
        triangles += a.len();
        for l in l.iter().filter(|l| !l.is_nan()) {
            length += l;
            vertices += 1;
        }
    }
    let mean = |sum: f64, n: usize| if n == 0 { f64::NAN } else { sum / n as f64 };
    DistortionSummary {
        area: mean(area, triangles),
        angle: mean(angle, triangles),
        length: mean(length, vertices),
    }
}

// ---------------------------------------------------------------------------
// Helpers

/// The plane with a unit normal; an error for a non-finite plane or a zero
/// normal.
fn unit_plane(plane: &Plane) -> Result<Plane, MapsError> {
    let n: Vector3<f64> = plane.normal;
    let len = n.norm();
    let finite = plane.point.coords.iter().all(|c| c.is_finite()) && len.is_finite();
    if !finite || len == 0.0 {
        let p = plane.point;
        return Err(MapsError::PlaneNotUsable {
            point: [p.x, p.y, p.z],
            normal: [n.x, n.y, n.z],
        });
    }
    Ok(Plane {
        point: plane.point,
        normal: n / len,
    })
}

/// One `(u, v)` per vertex, all finite.
fn check_uv(k: usize, mesh: &TriMesh, uv: &[[f64; 2]]) -> Result<(), MapsError> {
    let leaflet = LeafletSide::of(k);
    if uv.len() != mesh.positions.len() {
        return Err(MapsError::UvCount {
            leaflet,
            vertices: mesh.positions.len(),
            uv_positions: uv.len(),
        });
    }
    if let Some(i) = uv
        .iter()
        .position(|q| !(q[0].is_finite() && q[1].is_finite()))
    {
        return Err(MapsError::UvNotFinite {
            leaflet,
            vertex: i,
            uv: uv[i],
        });
    }
    Ok(())
}

/// The corners of triangle `t`, `None` when an index is out of range.
fn corners(mesh: &TriMesh, t: &[u32; 3]) -> Option<[Point3<f64>; 3]> {
    let p = |i: u32| mesh.positions.get(i as usize).copied();
    Some([p(t[0])?, p(t[1])?, p(t[2])?])
}

/// `(above, below)` parts of a triangle of area `area` with corner heights
/// `h` (see [`measurements`]).
fn split_area(area: f64, h: [f64; 3]) -> (f64, f64) {
    if h.iter().any(|x| x.is_nan()) {
        return (f64::NAN, f64::NAN);
    }
    let positive = h.iter().filter(|&&x| x > 0.0).count();
    // The area of the corner `i` cut off by the plane, when the other two
    // corners are on the other side (or on the plane).
    let cut = |i: usize| {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        area * (h[i] / (h[i] - h[j])) * (h[i] / (h[i] - h[k]))
    };
    match positive {
        0 => (0.0, area),
        3 => (area, 0.0),
        1 => {
            let i = h.iter().position(|&x| x > 0.0).unwrap_or(0);
            let a = cut(i);
            (a, area - a)
        }
        _ => {
            let i = h.iter().position(|&x| x <= 0.0).unwrap_or(0);
            if h[i] == 0.0 {
                (area, 0.0)
            } else {
                let b = cut(i);
                (area - b, b)
            }
        }
    }
}

/// Per leaflet normalization of the 2D layout (Carpentier rule, gradient).
struct LeafletFrame {
    /// `u` of the first annulus vertex (a commissure).
    u_first: f64,
    /// `u` of the last annulus vertex (the other commissure).
    u_last: f64,
    /// Highest `v` of the annulus vertices.
    v_top: f64,
    /// Lowest `v - v_top` of all vertices.
    v_bottom: f64,
}

impl LeafletFrame {
    fn new(k: usize, leaflet: &Leaflet, uv: &[[f64; 2]]) -> Result<Self, MapsError> {
        let side = LeafletSide::of(k);
        let annulus = &leaflet.annulus;
        if annulus.len() < 2 {
            return Err(MapsError::TooFewAnnulusVertices {
                leaflet: side,
                annulus_vertices: annulus.len(),
            });
        }
        if let Some(&v) = annulus.iter().find(|&&v| v as usize >= uv.len()) {
            return Err(MapsError::AnnulusVertexOutOfRange {
                leaflet: side,
                vertex: v,
                vertices: uv.len(),
            });
        }
        let u_first = uv[annulus[0] as usize][0];
        let u_last = uv[annulus[annulus.len() - 1] as usize][0];
        if u_last <= u_first {
            return Err(MapsError::AnnulusNotIncreasing {
                leaflet: side,
                u_first,
                u_last,
            });
        }
        let v_top = annulus
            .iter()
            .map(|&v| uv[v as usize][1])
            .fold(f64::NEG_INFINITY, f64::max);
        let v_bottom = uv.iter().map(|q| q[1] - v_top).fold(0.0, f64::min);
        Ok(LeafletFrame {
            u_first,
            u_last,
            v_top,
            v_bottom,
        })
    }

    fn normalized_u(&self, u: f64) -> f64 {
        (u - self.u_first) / (self.u_last - self.u_first)
    }
}

/// Per element energies of one leaflet's layout.
struct Energies {
    area: Vec<f64>,
    angle: Vec<f64>,
    length: Vec<f64>,
}

/// The energies of leaflet `k`'s `uv` (checked by [`check_uv`]) against the
/// 3D leaflet, mirrored `u -> -u` when most triangles are clockwise (see the
/// module docs).
fn energies(k: usize, mesh: &TriMesh, uv: &[[f64; 2]]) -> Result<Energies, OrganError> {
    let rest = ParamMesh::from_triangles(mesh)?;
    let sign = majority_sign(&twice_signed_areas_2d(uv, &mesh.triangles));
    let x: Vec<f64> = uv.iter().flat_map(|q| [sign * q[0], q[1]]).collect();
    let angle = angle_energy(&rest, &x).ok_or(MapsError::NotATriangleMesh {
        leaflet: LeafletSide::of(k),
    })?;
    Ok(Energies {
        area: area_energy(&rest, &x),
        angle,
        length: length_energy(&rest, &x),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitral::annulus::tests::prepared;
    use unfold_mesh::shapes::Pose;
    use unfold_mesh::shapes::{ValveParams, ValveShape, mitral_valve};

    // -----------------------------------------------------------------------
    // Fixtures

    /// Cumulative arc length along the closed ring: `s[i]` at `ring[i]`,
    /// `s[n] = L`.
    fn ring_arc(ring: &[Point3<f64>]) -> Vec<f64> {
        let n = ring.len();
        let mut s = vec![0.0];
        for i in 0..n {
            let last = s[i];
            s.push(last + (ring[(i + 1) % n] - ring[i]).norm());
        }
        s
    }

    fn longitudes(shape: &ValveShape, k: usize) -> &[Vec<u32>] {
        if k == ANTERIOR {
            &shape.anterior_longitudes
        } else {
            &shape.posterior_longitudes
        }
    }

    /// The longitude layout (ALGORITHMS 4.2 with a straight annulus): a
    /// column's `u` is the ring arc length of its annulus vertex, `v_0 = 0`,
    /// `v_k = v_{k-1} - |p_k - p_{k-1}|`.
    fn longitude_uv(shape: &ValveShape, valve: &PreparedValve, k: usize) -> Vec<[f64; 2]> {
        let leaflet = &valve.leaflets[k];
        let p = &leaflet.mesh.positions;
        let mut uv = vec![[f64::NAN; 2]; p.len()];
        for (col, &u) in longitudes(shape, k).iter().zip(&leaflet.annulus_s) {
            let mut v = 0.0;
            uv[col[0] as usize] = [u, 0.0];
            for w in col.windows(2) {
                v -= (p[w[1] as usize] - p[w[0] as usize]).norm();
                uv[w[1] as usize] = [u, v];
            }
        }
        uv
    }

    /// The landmark plane: through both commissures and the barycentre of
    /// the posterior arc, normal towards the atrium.
    fn landmark_plane(valve: &PreparedValve) -> Plane {
        let pm = valve.posteromedial;
        let (al, pmp) = (valve.ring[0], valve.ring[pm]);
        let post: Vec<Point3<f64>> = valve.ring[pm..]
            .iter()
            .copied()
            .chain([valve.ring[0]])
            .collect();
        let bary = post.iter().fold(Vector3::zeros(), |acc, p| acc + p.coords) / post.len() as f64;
        let mut n = (pmp - al).cross(&(bary - al.coords)).normalize();
        if n.dot(&valve.atrium) < 0.0 {
            n = -n;
        }
        Plane {
            point: al,
            normal: n,
        }
    }

    struct Fixture {
        shape: ValveShape,
        valve: PreparedValve,
        uv: [Vec<[f64; 2]>; 2],
        plane: Plane,
    }

    impl Fixture {
        fn new(params: &ValveParams) -> Self {
            let shape = mitral_valve(params).unwrap();
            let valve = prepared(&shape);
            let uv = [
                longitude_uv(&shape, &valve, ANTERIOR),
                longitude_uv(&shape, &valve, POSTERIOR),
            ];
            let plane = landmark_plane(&valve);
            Fixture {
                shape,
                valve,
                uv,
                plane,
            }
        }

        fn uv(&self) -> [&[[f64; 2]]; 2] {
            [&self.uv[ANTERIOR], &self.uv[POSTERIOR]]
        }

        fn maps(&self) -> [LeafletMaps; 2] {
            leaflet_maps(&self.valve, self.uv(), &self.plane, &MapsConfig::default()).unwrap()
        }

        /// Row (0 at the annulus) of every vertex of leaflet `k`.
        fn rows(&self, k: usize) -> Vec<usize> {
            let mut rows = vec![usize::MAX; self.valve.leaflets[k].mesh.positions.len()];
            for col in longitudes(&self.shape, k) {
                for (r, &v) in col.iter().enumerate() {
                    rows[v as usize] = r;
                }
            }
            rows
        }

        /// Whether a point is farther than `r` from both commissures.
        fn away(&self, p: &Point3<f64>, r: f64) -> bool {
            let v = &self.valve;
            (p - v.ring[0]).norm() > r && (p - v.ring[v.posteromedial]).norm() > r
        }
    }

    fn coarse() -> ValveParams {
        ValveParams {
            annulus_segments: 24,
            depth_segments: 4,
            ..ValveParams::default()
        }
    }

    fn fine() -> ValveParams {
        ValveParams {
            annulus_segments: 240,
            depth_segments: 40,
            ..ValveParams::default()
        }
    }

    /// A planar polar disk of radius 10 in `z = 0`, counter-clockwise seen
    /// from +z, centred at `c`.
    fn disk(c: [f64; 2]) -> TriMesh {
        let (rings, around) = (4usize, 14usize);
        let mut positions = vec![Point3::new(c[0], c[1], 0.0)];
        for r in 1..=rings {
            for j in 0..around {
                // Twisted rings give varied triangle shapes.
                let a = std::f64::consts::TAU * (j as f64 + 0.3 * r as f64) / around as f64;
                let rad = 10.0 * r as f64 / rings as f64;
                positions.push(Point3::new(c[0] + rad * a.cos(), c[1] + rad * a.sin(), 0.0));
            }
        }
        let id = |r: usize, j: usize| (1 + (r - 1) * around + j % around) as u32;
        let mut triangles = Vec::new();
        for j in 0..around {
            triangles.push([0, id(1, j), id(1, j + 1)]);
        }
        for r in 1..rings {
            for j in 0..around {
                let (a, b, c, d) = (id(r, j), id(r + 1, j), id(r + 1, j + 1), id(r, j + 1));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        TriMesh::new(positions, triangles)
    }

    /// A valve of two flat disks with `uv = (sign x, y)`; the annulus of
    /// each is its leftmost and rightmost vertex in `u`.
    fn flat_disks(sign: f64) -> (PreparedValve, [Vec<[f64; 2]>; 2]) {
        // The posterior disk right of the anterior one in u.
        let meshes = [disk([0.0, 0.0]), disk([sign * 40.0, 0.0])];
        let uv: [Vec<[f64; 2]>; 2] = meshes
            .clone()
            .map(|m| m.positions.iter().map(|p| [sign * p.x, p.y]).collect());
        let leaflet = |k: usize| {
            let q = &uv[k];
            let by_u = |a: &usize, b: &usize| q[*a][0].total_cmp(&q[*b][0]);
            let lo = (0..q.len()).min_by(by_u).unwrap() as u32;
            let hi = (0..q.len()).max_by(by_u).unwrap() as u32;
            Leaflet {
                mesh: meshes[k].clone(),
                annulus: vec![lo, hi],
                annulus_s: vec![0.0, 1.0],
                free_edge: Vec::new(),
            }
        };
        let valve = PreparedValve {
            ring: vec![
                Point3::new(-10.0, 0.0, 0.0),
                Point3::new(50.0, 0.0, 0.0),
                Point3::new(20.0, -5.0, 0.0),
            ],
            posteromedial: 1,
            atrium: Vector3::z(),
            leaflets: [leaflet(ANTERIOR), leaflet(POSTERIOR)],
            tolerance_mm: 1e-6,
        };
        (valve, uv)
    }

    fn z_plane(z: f64) -> Plane {
        Plane {
            point: Point3::new(0.0, 0.0, z),
            normal: Vector3::z(),
        }
    }

    // -----------------------------------------------------------------------
    // Energies

    #[test]
    fn maps_isometric_flat_layout_has_minimal_energies() {
        // Mirrored (clockwise) layouts give the same values.
        for sign in [1.0, -1.0] {
            let (valve, uv) = flat_disks(sign);
            let uv = [&uv[ANTERIOR][..], &uv[POSTERIOR][..]];
            let d = distortion(&valve, uv).unwrap();
            for e in [d.area, d.angle, d.length] {
                assert!((e - 2.0).abs() < 1e-9, "{d:?}");
            }
            let maps = leaflet_maps(&valve, uv, &z_plane(0.0), &MapsConfig::default()).unwrap();
            for m in &maps {
                for e in m
                    .area_energy
                    .iter()
                    .chain(&m.angle_energy)
                    .chain(&m.length_energy)
                {
                    assert!((e - 2.0).abs() < 1e-9, "sign {sign}: {e}");
                }
                assert!(m.tenting_mm.iter().all(|&t| t == 0.0));
            }
        }
    }

    #[test]
    fn maps_energies_see_distortion_and_flips() {
        let (valve, mut uv) = flat_disks(1.0);
        // Stretch the anterior layout by 2 in u: E_A = 2 + 1/2, E_M = 2 + 1/2.
        for q in &mut uv[ANTERIOR] {
            q[0] *= 2.0;
        }
        let maps = leaflet_maps(
            &valve,
            [&uv[ANTERIOR], &uv[POSTERIOR]],
            &z_plane(0.0),
            &MapsConfig::default(),
        )
        .unwrap();
        for e in maps[ANTERIOR]
            .area_energy
            .iter()
            .chain(&maps[ANTERIOR].angle_energy)
        {
            assert!((e - 2.5).abs() < 1e-9, "{e}");
        }
        assert!(maps[ANTERIOR].length_energy.iter().all(|&e| e > 2.0));
        // The report's final distortion is summarized from the maps: the
        // same means as `distortion` of the layout.
        let d = distortion(&valve, [&uv[ANTERIOR], &uv[POSTERIOR]]).unwrap();
        assert_eq!(summary(&maps), d);
        assert!(d.area > 2.0 && d.area < 2.5, "{d:?}");
        // Flip one triangle of the posterior layout: move the centre out.
        uv[POSTERIOR][0] = [60.0, 0.0];
        let d = distortion(&valve, [&uv[ANTERIOR], &uv[POSTERIOR]]).unwrap();
        assert_eq!(d.area, f64::INFINITY);
        assert_eq!(d.angle, f64::INFINITY);
        assert!(d.length.is_finite());
    }

    #[test]
    fn maps_longitude_layout_is_counter_clockwise_with_finite_energies() {
        let f = Fixture::new(&ValveParams::default());
        for k in [ANTERIOR, POSTERIOR] {
            let mesh = &f.valve.leaflets[k].mesh;
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|v| f.uv[k][v as usize]);
                let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                assert!(cross > 0.0, "leaflet {k}: a clockwise triangle");
            }
        }
        let maps = f.maps();
        for m in &maps {
            for e in m
                .area_energy
                .iter()
                .chain(&m.angle_energy)
                .chain(&m.length_energy)
            {
                assert!(e.is_finite() && *e >= 2.0 - 1e-12, "{e}");
            }
        }
        let d = distortion(&f.valve, f.uv()).unwrap();
        // The plain means of the per-element maps.
        let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
        let all = |g: fn(&LeafletMaps) -> &Vec<f64>| -> Vec<f64> {
            maps.iter().flat_map(|m| g(m).iter().copied()).collect()
        };
        assert!((d.area - mean(all(|m| &m.area_energy))).abs() < 1e-12);
        assert!((d.angle - mean(all(|m| &m.angle_energy))).abs() < 1e-12);
        assert!((d.length - mean(all(|m| &m.length_energy))).abs() < 1e-12);
        // The longitude layout keeps column lengths but not widths.
        assert!(d.area > 2.0 && d.angle > 2.0 && d.length > 2.0, "{d:?}");
    }

    // -----------------------------------------------------------------------
    // Localization maps

    #[test]
    fn maps_localization_maps_cover_their_ranges() {
        let f = Fixture::new(&ValveParams::default());
        let maps = f.maps();
        let mut intervals = [0usize; 8];
        let mut checker = [0usize; 2];
        for (k, m) in maps.iter().enumerate() {
            let n = f.valve.leaflets[k].mesh.positions.len();
            assert_eq!(m.leaflet, k as i32);
            assert_eq!(m.u_gradient.len(), n);
            assert_eq!(m.coaptation.len(), n);
            assert_eq!(
                m.area_energy.len(),
                f.valve.leaflets[k].mesh.triangles.len()
            );
            for &i in &m.u_interval {
                intervals[i as usize] += 1;
            }
            for &c in &m.checker {
                checker[c as usize] += 1;
            }
            for c in &m.u_gradient {
                assert!(c.iter().all(|x| (0.0..=1.0).contains(x)), "{c:?}");
            }
        }
        assert!(intervals.iter().all(|&c| c > 0), "{intervals:?}");
        assert!(checker[0] > 0 && checker[1] > 0);
        // The gradient's ends: red at the anterolateral commissure, green at
        // the posteromedial one (both leaflets), blue at the cut.
        let ant = &f.valve.leaflets[ANTERIOR].annulus;
        let post = &f.valve.leaflets[POSTERIOR].annulus;
        assert_eq!(maps[ANTERIOR].u_gradient[ant[0] as usize], [1.0, 0.0, 0.0]);
        assert_eq!(
            maps[ANTERIOR].u_gradient[*ant.last().unwrap() as usize],
            [0.0, 1.0, 0.0]
        );
        assert_eq!(
            maps[POSTERIOR].u_gradient[post[0] as usize],
            [0.0, 1.0, 0.0]
        );
        assert_eq!(
            maps[POSTERIOR].u_gradient[*post.last().unwrap() as usize],
            [0.0, 0.0, 1.0]
        );
        // u intervals: first at the start, last at the cut, increasing in u.
        assert_eq!(maps[ANTERIOR].u_interval[ant[0] as usize], 0);
        assert_eq!(
            maps[POSTERIOR].u_interval[*post.last().unwrap() as usize],
            7
        );
    }

    #[test]
    fn maps_checker_alternates_in_squares() {
        let (valve, uv) = flat_disks(1.0);
        let config = MapsConfig {
            checker_mm: 2.5,
            ..MapsConfig::default()
        };
        let maps = leaflet_maps(
            &valve,
            [&uv[ANTERIOR], &uv[POSTERIOR]],
            &z_plane(0.0),
            &config,
        )
        .unwrap();
        for k in [ANTERIOR, POSTERIOR] {
            for (q, &c) in uv[k].iter().zip(&maps[k].checker) {
                let (a, b) = ((q[0] / 2.5).floor() as i64, (q[1] / 2.5).floor() as i64);
                assert_eq!(c as i64, (a + b).rem_euclid(2), "{q:?}");
            }
        }
    }

    // -----------------------------------------------------------------------
    // Carpentier

    #[test]
    fn maps_carpentier_label_rule() {
        // Anterior: apex at (1/2, 0), boundaries to (1/3, -10) and (2/3, -10).
        assert_eq!(carpentier_label(ANTERIOR, 0.49, 0.0, -10.0), A1);
        assert_eq!(carpentier_label(ANTERIOR, 0.5, 0.0, -10.0), A2);
        assert_eq!(carpentier_label(ANTERIOR, 0.51, 0.0, -10.0), A3);
        assert_eq!(carpentier_label(ANTERIOR, 0.34, -10.0, -10.0), A2);
        assert_eq!(carpentier_label(ANTERIOR, 0.33, -10.0, -10.0), A1);
        assert_eq!(carpentier_label(ANTERIOR, 0.66, -10.0, -10.0), A2);
        assert_eq!(carpentier_label(ANTERIOR, 0.67, -10.0, -10.0), A3);
        // Half way down the boundaries are at 1/2 -+ 1/12.
        assert_eq!(
            carpentier_label(ANTERIOR, 0.5 - 1.0 / 12.0 - 1e-9, -5.0, -10.0),
            A1
        );
        assert_eq!(
            carpentier_label(ANTERIOR, 0.5 - 1.0 / 12.0 + 1e-9, -5.0, -10.0),
            A2
        );
        // Above the top both lines are at 1/2; outside [0, 1] still labelled.
        assert_eq!(carpentier_label(ANTERIOR, 0.4, 3.0, -10.0), A1);
        assert_eq!(carpentier_label(ANTERIOR, -0.1, -3.0, -10.0), A1);
        assert_eq!(carpentier_label(ANTERIOR, 1.1, -3.0, -10.0), A3);
        // Posterior: vertical thirds, P1 at the anterolateral end (u_n = 1).
        assert_eq!(carpentier_label(POSTERIOR, 0.1, -1.0, -10.0), P3);
        assert_eq!(carpentier_label(POSTERIOR, 0.5, -9.0, -10.0), P2);
        assert_eq!(carpentier_label(POSTERIOR, 0.9, 0.0, -10.0), P1);
    }

    #[test]
    fn maps_carpentier_segments_are_all_present_and_placed() {
        for params in [coarse(), ValveParams::default(), fine()] {
            let f = Fixture::new(&params);
            let maps = f.maps();
            let (al, pm) = (f.valve.ring[0], f.valve.ring[f.valve.posteromedial]);
            let mut count = [0usize; 7];
            // Mean distance of each segment to the two commissures.
            let mut d_al = [0.0; 7];
            let mut d_pm = [0.0; 7];
            for k in [ANTERIOR, POSTERIOR] {
                for (p, &c) in f.valve.leaflets[k]
                    .mesh
                    .positions
                    .iter()
                    .zip(&maps[k].carpentier)
                {
                    if k == ANTERIOR {
                        assert!((A1..=A3).contains(&c));
                    } else {
                        assert!((P1..=P3).contains(&c));
                    }
                    count[c as usize] += 1;
                    d_al[c as usize] += (p - al).norm();
                    d_pm[c as usize] += (p - pm).norm();
                }
            }
            let segments = params.annulus_segments;
            assert!(count[1..].iter().all(|&c| c > 0), "{segments}: {count:?}");
            let mean = |d: &[f64; 7], c: i32| d[c as usize] / count[c as usize] as f64;
            for (near_al, near_pm) in [(A1, A3), (P1, P3)] {
                assert!(
                    mean(&d_al, near_al) < mean(&d_pm, near_al),
                    "{segments}: {near_al}"
                );
                assert!(
                    mean(&d_pm, near_pm) < mean(&d_al, near_pm),
                    "{segments}: {near_pm}"
                );
            }
            // The middle segments lie between.
            for mid in [A2, P2] {
                let ratio = mean(&d_al, mid) / mean(&d_pm, mid);
                assert!((0.7..1.4).contains(&ratio), "{segments}: {mid} {ratio}");
            }
        }
    }

    #[test]
    fn maps_are_invariant_under_a_rigid_motion() {
        let params = ValveParams {
            pose: Pose::new([20.0, -35.0, 110.0], [4.0, -7.0, 30.0]),
            ..ValveParams::default()
        };
        let moved = Fixture::new(&params);
        let canon = Fixture::new(&ValveParams::default());
        let (a, b) = (moved.maps(), canon.maps());
        // Labels may differ only where a vertex sits on a boundary (e.g. the
        // middle column at exactly u_n = 1/2) and rounding decides.
        let differ = |x: &[i32], y: &[i32]| x.iter().zip(y).filter(|(x, y)| x != y).count();
        for k in [ANTERIOR, POSTERIOR] {
            let n = a[k].carpentier.len();
            assert!(differ(&a[k].carpentier, &b[k].carpentier) * 100 <= n);
            assert!(differ(&a[k].u_interval, &b[k].u_interval) * 100 <= n);
            assert!(differ(&a[k].coaptation, &b[k].coaptation) * 100 <= n);
            for (x, y) in a[k].tenting_mm.iter().zip(&b[k].tenting_mm) {
                assert!((x - y).abs() < 1e-9, "{x} {y}");
            }
            for (x, y) in a[k].angle_energy.iter().zip(&b[k].angle_energy) {
                assert!((x - y).abs() < 1e-9 * y, "{x} {y}");
            }
        }
        let (ma, mb) = (
            measurements(&moved.valve, &moved.plane),
            measurements(&canon.valve, &canon.plane),
        );
        assert!((ma.saddle_horn_height_mm - mb.saddle_horn_height_mm).abs() < 1e-9);
        assert!((ma.area_above_plane_mm2 - mb.area_above_plane_mm2).abs() < 1e-8);
    }

    // -----------------------------------------------------------------------
    // Coaptation

    #[test]
    fn maps_coaptation_runs_along_the_free_edges_of_a_closed_valve() {
        let f = Fixture::new(&ValveParams::default());
        let maps = f.maps();
        let depth = f.shape.params.depth_segments;
        let mut within_away = 0;
        for k in [ANTERIOR, POSTERIOR] {
            let rows = f.rows(k);
            let m = &maps[k];
            for (i, p) in f.valve.leaflets[k].mesh.positions.iter().enumerate() {
                let d = m.coaptation_distance_mm[i];
                let expect = if d < 2.0 {
                    COAPTATION_WITHIN
                } else if d < 4.0 {
                    COAPTATION_NEAR
                } else {
                    COAPTATION_NONE
                };
                assert_eq!(m.coaptation[i], expect);
                if m.coaptation[i] == COAPTATION_WITHIN && f.away(p, 5.0) {
                    within_away += 1;
                    // In the lower part of the leaflet (the 2D map's bottom).
                    assert!(
                        2 * rows[i] >= depth,
                        "leaflet {k} vertex {i} row {}",
                        rows[i]
                    );
                }
            }
            // The commissures are shared: distance 0.
            let ann = &f.valve.leaflets[k].annulus;
            for v in [ann[0], ann[ann.len() - 1]] {
                assert!(m.coaptation_distance_mm[v as usize] < 1e-12);
            }
        }
        assert!(
            within_away > 20,
            "{within_away} vertices in the coaptation zone"
        );
    }

    #[test]
    fn maps_coaptation_is_empty_away_from_the_commissures_of_an_open_valve() {
        let params = ValveParams {
            coaptation_gap: 12.0,
            commissure_gap: 15.0,
            ..ValveParams::default()
        };
        let f = Fixture::new(&params);
        let maps = f.maps();
        let mut near_commissures = 0;
        for k in [ANTERIOR, POSTERIOR] {
            for (i, p) in f.valve.leaflets[k].mesh.positions.iter().enumerate() {
                let c = maps[k].coaptation[i];
                if f.away(p, 5.0) {
                    assert_eq!(c, COAPTATION_NONE, "leaflet {k} vertex {i}");
                } else if c == COAPTATION_WITHIN {
                    near_commissures += 1;
                }
            }
        }
        // The leaflets still meet at the commissures.
        assert!(near_commissures >= 4);
    }

    // -----------------------------------------------------------------------
    // Tenting

    /// Smooth window: 1 for `|t| <= 1/2`, `cos^2(pi (|t| - 1/2))` up to
    /// `|t| = 1`, then 0.
    fn bump(t: f64) -> f64 {
        let a = t.abs();
        if a <= 0.5 {
            1.0
        } else if a < 1.0 {
            (std::f64::consts::PI * (a - 0.5)).cos().powi(2)
        } else {
            0.0
        }
    }

    #[test]
    fn maps_tenting_is_negative_on_the_leaflet_bodies() {
        // The mean plane z = 0 of the canonical pose: the saddle horns
        // (0, b_a, h/2) and (0, -b_p, h/2) are above it, the commissures
        // below.
        let mut f = Fixture::new(&ValveParams::default());
        f.plane = z_plane(0.0);
        let maps = f.maps();
        let depth = f.shape.params.depth_segments;
        let h = f.shape.params.saddle_height;
        let horns = [
            f.valve.ring[f.valve.posteromedial / 2],
            f.valve.ring[(f.valve.posteromedial + f.valve.ring.len()) / 2],
        ];
        for k in [ANTERIOR, POSTERIOR] {
            let rows = f.rows(k);
            let mut above = 0;
            for (i, &t) in maps[k].tenting_mm.iter().enumerate() {
                let p = f.valve.leaflets[k].mesh.positions[i];
                assert_eq!(t, p.z);
                // The lower half of every leaflet is below the plane ...
                if 2 * rows[i] >= depth {
                    assert!(t < 0.0, "leaflet {k} row {} tenting {t}", rows[i]);
                }
                // ... and what is above it hangs from a horn.
                if t > 0.0 {
                    above += 1;
                    let d = horns
                        .iter()
                        .map(|q| (p - q).norm())
                        .fold(f64::INFINITY, f64::min);
                    assert!(d < 12.5, "leaflet {k} vertex {i}: {d} mm from the horns");
                }
            }
            assert!(above > 0);
            // The horn itself is h/2 above the plane.
            assert!(maps[k].tenting_mm.contains(&(0.5 * h)));
        }
        // Against the landmark plane (tilted down towards the anterior
        // horn, which is 8.3 mm above it) the posterior leaflet is below
        // from a third of its depth down, the anterior from 5/8 of it.
        let f = Fixture::new(&ValveParams::default());
        let maps = f.maps();
        for k in [ANTERIOR, POSTERIOR] {
            let rows = f.rows(k);
            for (i, &t) in maps[k].tenting_mm.iter().enumerate() {
                let below = if k == ANTERIOR {
                    8 * rows[i] >= 5 * depth
                } else {
                    3 * rows[i] >= depth
                };
                if below {
                    assert!(t < 0.0, "leaflet {k} row {} tenting {t}", rows[i]);
                }
            }
        }
    }

    #[test]
    fn maps_tenting_shows_a_prolapsing_patch() {
        let mut f = Fixture::new(&ValveParams::default());
        let before = f.maps();
        let before_m = measurements(&f.valve, &f.plane);
        let depth = f.shape.params.depth_segments as f64;
        let cols = f.shape.posterior_longitudes.clone();
        let n = f.plane.normal;
        let up = f.valve.atrium;
        // Lift the middle of the posterior leaflet along the atrium direction
        // so that its core ends 5 mm above the plane, smoothly.
        let mut weight = vec![0.0; f.valve.leaflets[POSTERIOR].mesh.positions.len()];
        for (c, col) in cols.iter().enumerate() {
            let un = c as f64 / (cols.len() - 1) as f64;
            for (r, &v) in col.iter().enumerate() {
                let w = bump((un - 0.5) / 0.2) * bump((r as f64 / depth - 0.5) / 0.4);
                weight[v as usize] = w;
                let p = &mut f.valve.leaflets[POSTERIOR].mesh.positions[v as usize];
                let h = f.plane.signed_distance(p);
                *p += up * (w * (5.0 - h) / n.dot(&up));
            }
        }
        let after = f.maps();
        let mut core = 0;
        for (i, &w) in weight.iter().enumerate() {
            let (t0, t1) = (
                before[POSTERIOR].tenting_mm[i],
                after[POSTERIOR].tenting_mm[i],
            );
            if w == 1.0 {
                // The core: 5 mm above the plane.
                core += 1;
                assert!((t1 - 5.0).abs() < 1e-9, "{t1}");
            } else if w > 0.0 {
                // The rim: higher than before, above the plane where lifted
                // by at least 3/4 (no vertex was more than 15 mm below).
                assert!(t1 > t0);
                if w >= 0.75 {
                    assert!(t1 > 0.0, "w {w}: {t0} -> {t1}");
                }
            } else {
                // Outside the patch: unchanged, so the same sign.
                assert_eq!(t1, t0);
            }
        }
        assert!(core > 10, "{core}");
        assert_eq!(before[ANTERIOR].tenting_mm, after[ANTERIOR].tenting_mm);
        let after_m = measurements(&f.valve, &f.plane);
        assert!(after_m.area_above_plane_mm2 > before_m.area_above_plane_mm2 + 20.0);
    }

    // -----------------------------------------------------------------------
    // Measurements

    fn area_3d(mesh: &TriMesh) -> f64 {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum()
    }

    #[test]
    fn maps_measurements_of_the_default_valve() {
        let f = Fixture::new(&ValveParams::default());
        let h = f.shape.params.saddle_height;
        let m = measurements(&f.valve, &f.plane);
        for k in [ANTERIOR, POSTERIOR] {
            let a = area_3d(&f.valve.leaflets[k].mesh);
            assert!((m.leaflet_area_mm2[k] - a).abs() <= 1e-12 * a);
        }
        let s = ring_arc(&f.valve.ring);
        assert!((m.annulus_length_mm - s[s.len() - 1]).abs() < 1e-12 * m.annulus_length_mm);
        let total = m.leaflet_area_mm2.anterior + m.leaflet_area_mm2.posterior;
        let sum = m.area_above_plane_mm2 + m.area_below_plane_mm2;
        assert!((sum - total).abs() <= 1e-9 * total);
        assert!(m.area_above_plane_mm2 > 0.0 && m.area_below_plane_mm2 > 0.5 * total);

        // The saddle horns: (0, b_a, h/2) and (0, -b_p, h/2), commissures at
        // z = -h/2. Plane z = -h/2 through the commissures: height h exactly.
        let through = measurements(&f.valve, &z_plane(-0.5 * h));
        assert_eq!(through.saddle_horn_height_mm, h);
        // The mean plane z = 0: h/2.
        assert_eq!(
            measurements(&f.valve, &z_plane(0.0)).saddle_horn_height_mm,
            0.5 * h
        );
        // The landmark plane contains the commissural line (along x) and the
        // posterior barycentre (x_b, y_b, z_b) with y_b < 0, z_b > -h/2: it
        // rises towards the posterior, so its normal is (0, sin a, cos a)
        // with tan a = (z_b + h/2) / |y_b|. Heights above it of the horns
        // (0, b_a, h/2) and (0, -b_p, h/2), relative to the commissure
        // (-d/2, 0, -h/2): b_a sin a + h cos a (anterior, the highest) and
        // -b_p sin a + h cos a.
        let pm = f.valve.posteromedial;
        let post: Vec<Point3<f64>> = f.valve.ring[pm..]
            .iter()
            .copied()
            .chain([f.valve.ring[0]])
            .collect();
        let yb = post.iter().map(|p| p.y).sum::<f64>() / post.len() as f64;
        let zb = post.iter().map(|p| p.z).sum::<f64>() / post.len() as f64;
        let a = ((zb + 0.5 * h) / -yb).atan();
        let (ba, bp) = f.shape.params.semi_axes();
        let expect = (ba * a.sin() + h * a.cos()).max(-bp * a.sin() + h * a.cos());
        // Tilted away from the anterior horn, the plane leaves it higher
        // than above the commissural plane z = -h/2.
        assert!(expect > h);
        assert!(
            (m.saddle_horn_height_mm - expect).abs() < 1e-12,
            "{} {expect}",
            m.saddle_horn_height_mm
        );
        // Over the rotated valve with the plane through the commissures and
        // normal along the atrium direction: h again.
        let moved = Fixture::new(&ValveParams {
            pose: Pose::new([30.0, 10.0, -70.0], [1.0, 2.0, 3.0]),
            ..ValveParams::default()
        });
        let plane = Plane {
            point: moved.valve.ring[0],
            normal: moved.valve.atrium,
        };
        assert!((measurements(&moved.valve, &plane).saddle_horn_height_mm - h).abs() < 1e-12);
    }

    #[test]
    fn maps_flat_valve_has_nothing_above_its_plane() {
        let f = Fixture::new(&ValveParams {
            saddle_height: 0.0,
            ..ValveParams::default()
        });
        let m = measurements(&f.valve, &z_plane(0.0));
        assert_eq!(m.area_above_plane_mm2, 0.0);
        assert_eq!(m.saddle_horn_height_mm, 0.0);
        let total = m.leaflet_area_mm2.anterior + m.leaflet_area_mm2.posterior;
        assert!((m.area_below_plane_mm2 - total).abs() <= 1e-12 * total);
    }

    #[test]
    fn maps_split_area_is_exact() {
        // A right triangle (0,0), (2,0), (0,2) (area 2) cut by x = 1
        // (heights 1 - x): the corner at the origin keeps 1/4 of the area.
        let (a, b) = split_area(2.0, [1.0, -1.0, 1.0]);
        assert_eq!((a, b), (1.5, 0.5));
        let (a, b) = split_area(2.0, [1.0, -1.0, -1.0]);
        assert_eq!((a, b), (0.5, 1.5));
        // Through a corner: half and half.
        let (a, b) = split_area(2.0, [1.0, 0.0, -1.0]);
        assert_eq!((a, b), (1.0, 1.0));
        assert_eq!(split_area(2.0, [0.0, 0.0, -1.0]), (0.0, 2.0));
        assert_eq!(split_area(2.0, [0.0, 1.0, 1.0]), (2.0, 0.0));
        assert_eq!(split_area(2.0, [0.0, 0.0, 0.0]), (0.0, 2.0));
        // Against a fine sampling of a random-ish 3D triangle.
        let (p, n, o) = (
            [
                Point3::new(0.3, -1.0, 2.0),
                Point3::new(4.0, 0.5, -1.0),
                Point3::new(-1.0, 3.0, 0.5),
            ],
            Vector3::new(0.2, -0.4, 0.9).normalize(),
            Point3::new(0.5, 0.5, 0.4),
        );
        let area = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
        let (above, below) = split_area(area, p.map(|q| n.dot(&(q - o))));
        let m = 400;
        let mut hits = 0usize;
        for i in 0..m {
            for j in 0..m - i {
                let (s, t) = (
                    (i as f64 + 1.0 / 3.0) / m as f64,
                    (j as f64 + 1.0 / 3.0) / m as f64,
                );
                let q = p[0] + (p[1] - p[0]) * s + (p[2] - p[0]) * t;
                if n.dot(&(q - o)) > 0.0 {
                    hits += 1;
                }
            }
        }
        let sampled = area * hits as f64 / (m * (m + 1) / 2) as f64;
        assert!((above - sampled).abs() < 0.01 * area, "{above} {sampled}");
        assert!((above + below - area).abs() < 1e-12);
    }

    // -----------------------------------------------------------------------
    // Errors and serialization

    /// The maps error inside `e`.
    fn maps_err(e: &OrganError) -> &MapsError {
        match e {
            OrganError::Mitral(crate::mitral::MitralError::Maps(m)) => m,
            other => panic!("expected a maps error, got {other:?}"),
        }
    }

    #[test]
    fn maps_reject_bad_inputs_without_panicking() {
        let f = Fixture::new(&coarse());
        let ok = MapsConfig::default();
        let short: Vec<[f64; 2]> = f.uv[POSTERIOR][1..].to_vec();
        let e = leaflet_maps(&f.valve, [&f.uv[ANTERIOR], &short], &f.plane, &ok).unwrap_err();
        let short_uv = MapsError::UvCount {
            leaflet: LeafletSide::Posterior,
            vertices: short.len() + 1,
            uv_positions: short.len(),
        };
        assert_eq!(e, short_uv.clone().into());
        assert!(e.to_string().contains("posterior"), "{e}");
        assert_eq!(
            distortion(&f.valve, [&f.uv[ANTERIOR], &short]),
            Err(short_uv.into())
        );
        let mut nan = f.uv[ANTERIOR].clone();
        nan[3][1] = f64::NAN;
        let e = leaflet_maps(&f.valve, [&nan, &f.uv[POSTERIOR]], &f.plane, &ok).unwrap_err();
        assert!(
            matches!(
                maps_err(&e),
                MapsError::UvNotFinite {
                    leaflet: LeafletSide::Anterior,
                    vertex: 3,
                    uv,
                } if uv[1].is_nan()
            ),
            "{e}"
        );
        for config in [
            MapsConfig {
                coaptation_mm: 0.0,
                ..ok
            },
            MapsConfig {
                checker_mm: f64::NAN,
                ..ok
            },
            MapsConfig {
                checker_mm: -1.0,
                ..ok
            },
        ] {
            let e = leaflet_maps(&f.valve, f.uv(), &f.plane, &config).unwrap_err();
            assert!(matches!(e, OrganError::Config(_)), "{e}");
        }
        let flat = Plane {
            normal: Vector3::zeros(),
            ..f.plane
        };
        let e = leaflet_maps(&f.valve, f.uv(), &flat, &ok).unwrap_err();
        assert!(
            matches!(maps_err(&e), MapsError::PlaneNotUsable { normal, .. } if *normal == [0.0; 3]),
            "{e}"
        );
        // Precomputed coaptation distances: the same maps; a short list is
        // refused.
        let dist = [
            coaptation_distances(&f.valve, ANTERIOR),
            coaptation_distances(&f.valve, POSTERIOR),
        ];
        assert!(coaptation_distances(&f.valve, 2).is_empty());
        let with = leaflet_maps_with(&f.valve, f.uv(), &f.plane, &ok, dist.clone()).unwrap();
        let plain = leaflet_maps(&f.valve, f.uv(), &f.plane, &ok).unwrap();
        for k in [ANTERIOR, POSTERIOR] {
            assert_eq!(
                with[k].coaptation_distance_mm,
                plain[k].coaptation_distance_mm
            );
            assert_eq!(with[k].coaptation, plain[k].coaptation);
        }
        let mut short_dist = dist;
        short_dist[POSTERIOR].pop();
        let n_post = f.valve.leaflets[POSTERIOR].mesh.positions.len();
        let e = leaflet_maps_with(&f.valve, f.uv(), &f.plane, &ok, short_dist).unwrap_err();
        assert_eq!(
            maps_err(&e),
            &MapsError::CoaptationDistanceCount {
                leaflet: LeafletSide::Posterior,
                distances: n_post - 1,
                vertices: n_post
            }
        );
        assert!(e.to_string().contains("coaptation distances"), "{e}");
        let m = measurements(&f.valve, &flat);
        assert!(m.saddle_horn_height_mm.is_nan() && m.area_above_plane_mm2.is_nan());
        assert!(m.leaflet_area_mm2.anterior > 0.0);
        // A reversed annulus (decreasing u).
        let mut rev = f.valve.clone();
        rev.leaflets[ANTERIOR].annulus.reverse();
        let e = leaflet_maps(&rev, f.uv(), &f.plane, &ok).unwrap_err();
        assert!(
            matches!(
                maps_err(&e),
                MapsError::AnnulusNotIncreasing {
                    leaflet: LeafletSide::Anterior,
                    u_first,
                    u_last,
                } if u_last <= u_first
            ),
            "{e}"
        );
        // An out-of-range annulus vertex.
        let mut bad = f.valve.clone();
        bad.leaflets[POSTERIOR].annulus.push(1_000_000);
        let e = leaflet_maps(&bad, f.uv(), &f.plane, &ok).unwrap_err();
        assert!(
            matches!(
                maps_err(&e),
                MapsError::AnnulusVertexOutOfRange {
                    leaflet: LeafletSide::Posterior,
                    vertex: 1_000_000,
                    ..
                }
            ),
            "{e}"
        );
        // A degenerate 3D triangle.
        let mut degenerate = f.valve.clone();
        let mesh = &mut degenerate.leaflets[ANTERIOR].mesh;
        let t = mesh.triangles[0];
        mesh.positions[t[1] as usize] = mesh.positions[t[0] as usize];
        assert!(leaflet_maps(&degenerate, f.uv(), &f.plane, &ok).is_err());
        // Out-of-range triangle indices are skipped by the measurements.
        let mut broken = f.valve.clone();
        broken.leaflets[ANTERIOR]
            .mesh
            .triangles
            .push([0, 1, 1_000_000]);
        let m = measurements(&broken, &f.plane);
        assert!(m.area_above_plane_mm2.is_finite());
        // Error messages are one line.
        assert!(!e.to_string().contains('\n'));
    }

    #[test]
    fn maps_serialize_as_documented() {
        let f = Fixture::new(&coarse());
        let m = measurements(&f.valve, &f.plane);
        let json = serde_json::to_value(m).unwrap();
        assert!(json["leaflet_area_mm2"]["anterior"].is_f64());
        assert!(json["leaflet_area_mm2"]["posterior"].is_f64());
        assert_eq!(
            m.leaflet_area_mm2[ANTERIOR],
            m.leaflet_area_mm2.to_array()[0]
        );
        let d = distortion(&f.valve, f.uv()).unwrap();
        let json = serde_json::to_value(d).unwrap();
        for key in ["area", "angle", "length"] {
            assert!(json[key].is_f64());
        }
        let c: MapsConfig = serde_json::from_str(r#"{"coaptation_mm": 3}"#).unwrap();
        assert_eq!(
            c,
            MapsConfig {
                coaptation_mm: 3.0,
                checker_mm: DEFAULT_CHECKER_MM
            }
        );
    }
}
