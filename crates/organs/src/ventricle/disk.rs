//! The LV disk map `phi: S -> D` (ALGORITHMS 3.2): S flattened onto the
//! unit disk with its rim on the unit circle by cumulative edge length, the
//! landmarks' bisector along +x (anterior on the +y side), and a thin-plate
//! spline warp that keeps the rim and moves the apex to the centre.

use super::error::VentricleError;
use super::harmonic_disk::{ANTERIOR, APEX, INFERIOR, wrap};
use super::landmarks::Landmarks;
use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::flipped_triangles;
use unfold_param::initializer::circle_boundary;
use unfold_param::{Constraints, Initializer, ParamError, ParamMesh, Pin};

/// The LV disk map of S.
#[derive(Debug, Clone, PartialEq)]
pub struct DiskMap {
    /// Disk position of every vertex of S (the origin for vertices in no
    /// triangle).
    pub uv: Vec<[f64; 2]>,
    /// Triangles whose orientation differs from the majority, or with zero
    /// or NaN area, after the apex warp (0 for a bijective map; the tie rule
    /// of [`unfold_mesh::geometry::flipped_triangles`]).
    pub flipped_triangles: usize,
    /// The weights of the embedding: `"cotangent"` (the harmonic map), or
    /// `"mean-value"` when the harmonic map flipped triangles (mean-value
    /// weights are positive, so that embedding is bijective).
    pub weights: &'static str,
    /// Whether the disk was mirrored to put the anterior landmark on +y.
    pub mirrored: bool,
    /// The apex warp used: `"thin-plate spline"` (the rim kept in place), or
    /// `"mobius"` when the spline folded triangles (see [`lv_disk`]).
    pub apex_warp: &'static str,
    /// Whether folds left by the warp were untangled with every pin fixed
    /// (ALGORITHMS 1.7): `"yes"`, `"no"` (nothing folded) or `"failed"`
    /// (the folds are counted in `flipped_triangles`).
    pub untangled: &'static str,
}

/// The LV disk map (ALGORITHMS 3.2), by the disk initializer `disk`
/// ([`HarmonicDisk`] by default, see [`super::harmonic_disk`] for what it
/// is handed):
///
/// 1. the rim on the unit circle by cumulative edge length, mirrored if
///    needed so that the anterior landmark follows the inferior one
///    counter-clockwise along their shorter arc, and turned so that the
///    bisector of that arc points along +x (the septum; the anterior
///    landmark on the +y side): the rim pins;
/// 2. the apex pinned at the centre;
/// 3. `disk` maps S with those pins (the harmonic map, a thin-plate spline
///    taking the apex to the centre, a Mobius warp where that folds).
///
/// The result's flips are counted ([`DiskMap::flipped_triangles`]).
///
/// # Errors
/// `Ventricle` for landmarks that do not fit S ([`Landmarks::check`]);
/// `Param` / `Mesh` when S cannot be embedded (not a disk, degenerate), and
/// the initializer's own errors.
pub fn lv_disk(
    surface: &TriMesh,
    landmarks: &Landmarks,
    disk: &dyn Initializer,
) -> Result<DiskMap, OrganError> {
    landmarks.check(surface)?;
    let rim = &landmarks.rim;
    let mut circle = circle_boundary(&surface.positions, rim)?;
    let angle = |q: [f64; 2]| q[1].atan2(q[0]);
    let (ta, ti) = (
        angle(circle[landmarks.anterior].1),
        angle(circle[landmarks.inferior].1),
    );
    let mirrored = wrap(ta - ti) < 0.0;
    let (ta, ti) = if mirrored { (-ta, -ti) } else { (ta, ti) };
    let bisector = ti + 0.5 * wrap(ta - ti);
    let (c, s) = ((-bisector).cos(), (-bisector).sin());
    for (_, q) in &mut circle {
        if mirrored {
            q[1] = -q[1];
        }
        *q = [c * q[0] - s * q[1], s * q[0] + c * q[1]];
    }
    let mut pins: Vec<Pin> = circle.iter().map(|&(v, q)| Pin::planar(v, q)).collect();
    pins.push(Pin::planar(landmarks.apex, [0.0, 0.0]));
    map_disk(surface, landmarks, &pins, mirrored, disk)
}

/// Runs the disk initializer with the pins and the landmark labels.
fn map_disk(
    surface: &TriMesh,
    landmarks: &Landmarks,
    pins: &[Pin],
    mirrored: bool,
    disk: &dyn Initializer,
) -> Result<DiskMap, OrganError> {
    let pm = ParamMesh::from_triangles(surface)?;
    let mut labels = vec![0u8; surface.num_vertices()];
    labels[landmarks.rim[landmarks.anterior] as usize] = ANTERIOR;
    labels[landmarks.rim[landmarks.inferior] as usize] = INFERIOR;
    labels[landmarks.apex as usize] = APEX;
    let start = disk
        .initialize(
            &pm,
            &Constraints {
                pins,
                labels: &labels,
                weights: &[],
            },
        )
        .map_err(OrganError::from_param)?;
    let n = surface.num_vertices();
    if start.x.len() != 2 * n {
        return Err(ParamError::Length {
            what: "disk map",
            expected: 2 * n,
            found: start.x.len(),
        }
        .into());
    }
    let uv: Vec<[f64; 2]> = start.x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    Ok(DiskMap {
        flipped_triangles: flipped_triangles(&uv, &surface.triangles),
        uv,
        weights: start.detail("weights").unwrap_or(disk.name()),
        mirrored,
        apex_warp: start.detail("apex warp").unwrap_or(disk.name()),
        untangled: start.detail("untangled").unwrap_or("no"),
    })
}

/// Centre of the RV half disk's circle (ALGORITHMS 3.2).
pub const RV_CENTRE: [f64; 2] = [1.25, 0.0];

/// The RV half disk (ALGORITHMS 3.2): the unit circle centred at
/// [`RV_CENTRE`], the part with `x >= 1.25`. The septal arc of the rim (the
/// shorter of its two arcs between the two septal corners) goes to the
/// straight edge, the first corner (`landmarks.anterior`) at `(1.25, 1)`,
/// the second (`landmarks.inferior`) at `(1.25, -1)`, by cumulative edge
/// length; the rest of the rim to the half circle through `(2.25, 0)`, by
/// cumulative edge length: the rim pins; the apex pinned at `(1.75, 0)`.
/// `disk` maps S with those pins ([`HarmonicDisk`]: the harmonic map,
/// mean-value weights when it flips a triangle, the half disk being convex,
/// then the thin-plate spline that keeps the rim and moves the apex).
/// Flips are counted, not repaired.
///
/// # Errors
/// As [`lv_disk`].
pub fn rv_half_disk(
    surface: &TriMesh,
    landmarks: &Landmarks,
    disk: &dyn Initializer,
) -> Result<DiskMap, OrganError> {
    landmarks.check(surface)?;
    let rim = &landmarks.rim;
    let m = rim.len();
    let pos = &surface.positions;
    let edge = |k: usize| (pos[rim[(k + 1) % m] as usize] - pos[rim[k] as usize]).norm();
    // The two arcs from the first corner to the second: forward along the
    // loop, or backward. The shorter is septal.
    let (a, b) = (landmarks.anterior, landmarks.inferior);
    let walk = |from: usize, to: usize, step: isize| -> (Vec<usize>, Vec<f64>) {
        let mut ks = vec![from];
        let mut s = vec![0.0];
        let mut k = from;
        while k != to {
            let next = (k as isize + step).rem_euclid(m as isize) as usize;
            let e = if step > 0 { edge(k) } else { edge(next) };
            s.push(s[s.len() - 1] + e);
            ks.push(next);
            k = next;
        }
        (ks, s)
    };
    let (fwd, sf) = walk(a, b, 1);
    let (bwd, sb) = walk(a, b, -1);
    let (septal, ss, free, sfree) = if sf[sf.len() - 1] <= sb[sb.len() - 1] {
        (fwd, sf, bwd, sb)
    } else {
        (bwd, sb, fwd, sf)
    };
    let (ls, lf) = (ss[ss.len() - 1], sfree[sfree.len() - 1]);
    if !(ls > 0.0 && lf > 0.0 && ls.is_finite() && lf.is_finite()) {
        return Err(VentricleError::ZeroRimArc {
            septal_mm: ls,
            free_mm: lf,
        }
        .into());
    }
    let mut given: Vec<(u32, [f64; 2])> = Vec::with_capacity(m);
    for (k, s) in septal.iter().zip(&ss) {
        given.push((rim[*k], [RV_CENTRE[0], 1.0 - 2.0 * s / ls]));
    }
    // The free arc from the first corner (angle pi/2) to the second (-pi/2)
    // through angle 0, corners excluded (already placed).
    for (k, s) in free.iter().zip(&sfree).skip(1).take(free.len() - 2) {
        let t = std::f64::consts::FRAC_PI_2 - std::f64::consts::PI * s / lf;
        given.push((rim[*k], [RV_CENTRE[0] + t.cos(), RV_CENTRE[1] + t.sin()]));
    }
    let mut pins: Vec<Pin> = given.iter().map(|&(v, q)| Pin::planar(v, q)).collect();
    pins.push(Pin::planar(
        landmarks.apex,
        [RV_CENTRE[0] + 0.5, RV_CENTRE[1]],
    ));
    map_disk(surface, landmarks, &pins, false, disk)
}

/// The display warp `r' = r^n` (angle kept) of disk positions, `n` finite
/// and `> 0` (ALGORITHMS 3.2: `n = 1/3` spreads the apical region).
///
/// # Errors
/// `Config` for a bad exponent.
pub fn display_warp(uv: &[[f64; 2]], exponent: f64) -> Result<Vec<[f64; 2]>, OrganError> {
    OrganError::check_positive(&[("display exponent", exponent)])?;
    Ok(uv
        .iter()
        .map(|q| {
            let r = q[0].hypot(q[1]);
            if r > 0.0 {
                let k = r.powf(exponent) / r;
                [k * q[0], k * q[1]]
            } else {
                [0.0, 0.0]
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ventricle::harmonic_disk::{HarmonicDisk, mobius};
    use crate::ventricle::landmarks::DEFAULT_SNAP_MM;
    use unfold_mesh::shapes::{Pose, VentricleParams, ventricle_cup};

    fn disk_of(p: &VentricleParams) -> (unfold_mesh::shapes::VentricleShape, Landmarks, DiskMap) {
        let cup = ventricle_cup(p).unwrap();
        let l = Landmarks::resolve(
            &cup.surface,
            &cup.anterior,
            &cup.inferior,
            None,
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        let d = lv_disk(&cup.surface, &l, &HarmonicDisk).unwrap();
        (cup, l, d)
    }

    #[test]
    fn the_cup_flattens_with_rings_on_circles_and_the_landmarks_in_place() {
        let (cup, l, d) = disk_of(&VentricleParams::default());
        assert_eq!(d.flipped_triangles, 0);
        assert_eq!(d.weights, "cotangent");
        assert_eq!(d.uv[l.apex as usize], [0.0, 0.0]);
        for &v in &l.rim {
            let q = d.uv[v as usize];
            assert!((q[0].hypot(q[1]) - 1.0).abs() < 1e-12);
        }
        // Landmarks symmetric about +x, anterior on +y (the cup puts them at
        // +-55 degrees about its septal +x direction).
        let (qa, qi) = (
            d.uv[l.rim[l.anterior] as usize],
            d.uv[l.rim[l.inferior] as usize],
        );
        assert!(qa[1] > 0.0 && qi[1] < 0.0);
        let (ta, ti) = (qa[1].atan2(qa[0]), qi[1].atan2(qi[0]));
        assert!((ta + ti).abs() < 1e-9, "{ta} {ti}");
        assert!((ta.to_degrees() - 55.0).abs() < 2.0, "{}", ta.to_degrees());
        // S's vertex rings (constant height) map to circles.
        let mut rings: Vec<(f64, Vec<usize>)> = Vec::new();
        for (v, p) in cup.surface.positions.iter().enumerate() {
            match rings.iter_mut().find(|(z, _)| (z - p.z).abs() < 1e-9) {
                Some((_, r)) => r.push(v),
                None => rings.push((p.z, vec![v])),
            }
        }
        let mut checked = 0;
        for (_, ring) in rings.iter().filter(|(_, r)| r.len() >= 6) {
            let radii: Vec<f64> = ring.iter().map(|&v| d.uv[v][0].hypot(d.uv[v][1])).collect();
            let mean = radii.iter().sum::<f64>() / radii.len() as f64;
            let spread = radii.iter().fold(0.0f64, |s, r| s.max((r - mean).abs()));
            assert!(spread < 0.02 * mean, "ring at r = {mean}: spread {spread}");
            checked += 1;
        }
        assert!(checked >= 20, "{checked} rings");
    }

    #[test]
    fn the_disk_does_not_depend_on_the_pose() {
        let (_, _, d0) = disk_of(&VentricleParams::default());
        let posed = VentricleParams {
            pose: Pose {
                rotation_deg: [20.0, -35.0, 110.0],
                translation: [12.0, -4.0, 30.0],
            },
            ..VentricleParams::default()
        };
        let (_, _, d1) = disk_of(&posed);
        for (a, b) in d0.uv.iter().zip(&d1.uv) {
            assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
        }
    }

    #[test]
    fn a_mirrored_surface_gives_a_mirror_free_disk() {
        // Reversing every triangle reverses the rim's direction: the disk
        // is mirrored back so that the anterior landmark stays on +y.
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let mut s = cup.surface.clone();
        for t in &mut s.triangles {
            t.swap(1, 2);
        }
        let l =
            Landmarks::resolve(&s, &cup.anterior, &cup.inferior, None, DEFAULT_SNAP_MM).unwrap();
        let d = lv_disk(&s, &l, &HarmonicDisk).unwrap();
        let (_, _, d0) = disk_of(&VentricleParams::default());
        assert_ne!(d.mirrored, d0.mirrored);
        for (a, b) in d.uv.iter().zip(&d0.uv) {
            assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
        }
    }

    /// The default cup with a given apex a few rings below its rim (the
    /// vertex a twentieth of the way down the heights).
    fn cup_with_apex_near_the_rim() -> (unfold_mesh::shapes::VentricleShape, Landmarks) {
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let s = &cup.surface;
        let mut by_height: Vec<(f64, usize)> = s
            .positions
            .iter()
            .enumerate()
            .map(|(v, p)| (p.z, v))
            .collect();
        by_height.sort_by(|a, b| b.0.total_cmp(&a.0));
        let apex = s.positions[by_height[by_height.len() / 20].1];
        let l = Landmarks::resolve(
            s,
            &cup.anterior,
            &cup.inferior,
            Some(&apex),
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        (cup, l)
    }

    #[test]
    fn an_apex_near_the_rim_falls_back_to_the_mobius_warp() {
        // A given apex a few rings below the rim: the spline that keeps the
        // rim and pulls it to the centre folds; the Mobius warp does not.
        let (cup, l) = cup_with_apex_near_the_rim();
        let s = &cup.surface;
        let d = lv_disk(s, &l, &HarmonicDisk).unwrap();
        assert_eq!(d.apex_warp, "mobius");
        assert_eq!(d.flipped_triangles, 0);
        assert_eq!(d.uv[l.apex as usize], [0.0, 0.0]);
        for &v in &l.rim {
            let q = d.uv[v as usize];
            assert!((q[0].hypot(q[1]) - 1.0).abs() < 1e-9);
        }
        let (qa, qi) = (
            d.uv[l.rim[l.anterior] as usize],
            d.uv[l.rim[l.inferior] as usize],
        );
        let (ta, ti) = (qa[1].atan2(qa[0]), qi[1].atan2(qi[0]));
        assert!(ta > 0.0 && ti < 0.0 && (ta + ti).abs() < 1e-9, "{ta} {ti}");
        // The default apex keeps the spline.
        let (_, _, d0) = disk_of(&VentricleParams::default());
        assert_eq!(d0.apex_warp, "thin-plate spline");
    }

    #[test]
    fn the_rv_half_disk_puts_the_septal_arc_on_the_straight_edge() {
        // The cup as an RV: its landmarks (110 degrees apart) bound the
        // shorter, septal arc.
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let s = &cup.surface;
        let l = Landmarks::resolve(s, &cup.anterior, &cup.inferior, None, DEFAULT_SNAP_MM).unwrap();
        let d = rv_half_disk(s, &l, &HarmonicDisk).unwrap();
        assert_eq!(d.flipped_triangles, 0);
        let at = |v: u32| d.uv[v as usize];
        assert_eq!(at(l.rim[l.anterior]), [1.25, 1.0]);
        assert!((at(l.rim[l.inferior])[1] + 1.0).abs() < 1e-12);
        assert_eq!(at(l.apex), [1.75, 0.0]);
        let mut straight = 0;
        for &v in &l.rim {
            let q = at(v);
            assert!(q[0] >= 1.25 - 1e-12);
            let on_edge = (q[0] - 1.25).abs() < 1e-12 && q[1].abs() <= 1.0 + 1e-12;
            let on_arc = ((q[0] - 1.25).hypot(q[1]) - 1.0).abs() < 1e-12;
            assert!(on_edge || on_arc, "{q:?}");
            if on_edge {
                straight += 1;
            }
        }
        // 110 of 360 degrees of the rim on the straight edge.
        let frac = straight as f64 / l.rim.len() as f64;
        assert!((frac - 110.0 / 360.0).abs() < 0.03, "{frac}");
        // Every vertex inside the half disk.
        for q in &d.uv {
            assert!(
                q[0] >= 1.25 - 1e-9 && (q[0] - 1.25).hypot(q[1]) <= 1.0 + 1e-9,
                "{q:?}"
            );
        }
    }

    #[test]
    fn an_rv_apex_near_the_rim_is_untangled_with_every_pin_in_place() {
        // No Mobius warp for the half disk: the spline that pulls an apex
        // a few rings below the rim to (1.75, 0) folds, and the untangler
        // makes the map flip-free with the rim and the apex exact.
        let (cup, l) = cup_with_apex_near_the_rim();
        let s = &cup.surface;
        let d = rv_half_disk(s, &l, &HarmonicDisk).unwrap();
        assert_eq!(d.apex_warp, "thin-plate spline");
        assert_eq!(d.untangled, "yes");
        assert_eq!(d.flipped_triangles, 0);
        assert_eq!(d.uv[l.apex as usize], [1.75, 0.0]);
        assert_eq!(d.uv[l.rim[l.anterior] as usize], [1.25, 1.0]);
        for &v in &l.rim {
            let q = d.uv[v as usize];
            let on_edge = (q[0] - 1.25).abs() < 1e-12 && q[1].abs() <= 1.0 + 1e-12;
            let on_arc = ((q[0] - 1.25).hypot(q[1]) - 1.0).abs() < 1e-12;
            assert!(on_edge || on_arc, "{q:?}");
        }
        // The default apex needs no untangling.
        let l0 =
            Landmarks::resolve(s, &cup.anterior, &cup.inferior, None, DEFAULT_SNAP_MM).unwrap();
        assert_eq!(rv_half_disk(s, &l0, &HarmonicDisk).unwrap().untangled, "no");
    }

    #[test]
    fn mobius_maps_the_disk_onto_itself_and_a_to_the_centre() {
        let a = [0.3, -0.5];
        let m = mobius(a, a);
        assert!(m[0].abs() < 1e-15 && m[1].abs() < 1e-15);
        for k in 0..12 {
            let t = k as f64 * 0.5;
            let q = mobius([t.cos(), t.sin()], a);
            assert!((q[0].hypot(q[1]) - 1.0).abs() < 1e-12);
        }
        let q = mobius([0.1, 0.2], a);
        assert!(q[0].hypot(q[1]) < 1.0);
    }

    #[test]
    fn the_display_warp_keeps_angles_and_the_unit_circle() {
        let uv = [[0.5, 0.0], [0.0, -0.125], [0.6, 0.8], [0.0, 0.0]];
        let w = display_warp(&uv, 1.0 / 3.0).unwrap();
        assert!((w[0][0] - 0.5f64.powf(1.0 / 3.0)).abs() < 1e-15 && w[0][1] == 0.0);
        assert!((w[1][1] + 0.5).abs() < 1e-15);
        assert!((w[2][0] - 0.6).abs() < 1e-15 && (w[2][1] - 0.8).abs() < 1e-15);
        assert_eq!(w[3], [0.0, 0.0]);
        for bad in [0.0, -1.0, f64::NAN] {
            assert!(matches!(display_warp(&uv, bad), Err(OrganError::Config(_))));
        }
    }
}
