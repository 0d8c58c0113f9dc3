//! The annulus ring found from the two leaflets alone (ALGORITHMS 4.9),
//! for valves given without an annulus file.
//!
//! The two leaflets meet at the commissures: there their boundaries touch
//! (a shared vertex, or a shared run of vertices when the segmentation cut
//! both leaflets from one surface). Those places split each leaflet's
//! boundary loop into arcs: the attached (hinge) arc on the annulus and the
//! free side (the commissural sides and the free edge). The annulus is the
//! hinge arc of the anterior leaflet followed by the hinge arc of the
//! posterior one.
//!
//! [`annulus_from_leaflets`] works in four steps, `tol` the tolerance (mm):
//!
//! 1. **Boundaries.** Both leaflets are repaired as the pipeline repairs
//!    them (coincident vertices welded) and must be disks (one boundary
//!    loop each, the contract's checks).
//! 2. **Shared vertices.** A boundary vertex of one leaflet is shared when
//!    its distance to the other leaflet's boundary polyline (the closed
//!    loop of its boundary edges) is at most `tol`. Along each loop the
//!    shared vertices form maximal cyclic runs (the places where the
//!    leaflets meet); each leaflet needs at least two, and some vertex that
//!    is not shared.
//! 3. **Arcs.** Between two consecutive runs lies an arc: the vertices that
//!    are not shared, with the run vertex on either side as its ends. An arc
//!    `a` of the anterior and an arc `p` of the posterior leaflet *close*
//!    when each end of `a` lies within `tol + h` of an end of `p` (the
//!    other end of `a` to the other end of `p`), `h` the longest boundary
//!    edge at the two ends compared (two leaflets sampled differently along
//!    a shared seam stop up to one edge apart).
//! 4. **Choice.** Of the closing pairs, the one whose ring encloses the
//!    largest area wins: the magnitude of the vector area
//!    `|1/2 sum_i p_i x p_{i+1}|` of the closed polygon (independent of
//!    the origin). The annulus is the widest part of the valve: the
//!    leaflets funnel from it into the ventricle, and their free edges,
//!    which meet (closed valve) or hang apart below it (open valve), bound
//!    less. At each junction the ring gets one point, the midpoint of the
//!    two arcs' ends.
//!
//! The ring is then an ordinary annulus ring for [`super::contract::prepare`]
//! (which finds the commissures, the order and the atrial side again).

use super::{ANTERIOR, ContractError, LeafletSide, POSTERIOR};
use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::point_segment_distance;
use unfold_mesh::nalgebra::{Point3, Vector3};

/// The annulus found from the leaflets, with how it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundAnnulus {
    /// The ring: the anterior hinge arc, then the posterior one (one point
    /// per junction), not closed (the first point is not repeated).
    pub ring: Vec<Point3<f64>>,
    /// Places where the leaflets' boundaries meet, per leaflet (anterior,
    /// posterior): 2 for two leaflets that touch only at the commissures.
    pub places: [usize; 2],
    /// Area enclosed by the ring (the magnitude of its vector area), mm^2.
    pub area_mm2: f64,
}

/// The annulus ring of two leaflets from the places where their boundaries
/// meet (see the [module docs](self) for the rule).
///
/// # Errors
/// [`OrganError::Config`] for a tolerance that is not finite and positive;
/// [`ContractError::LeafletMesh`] / [`ContractError::BoundaryLoops`] /
/// [`ContractError::EulerCharacteristic`] for a leaflet that is not a
/// disk; [`ContractError::NoSharedBoundary`] when the boundaries do not
/// touch; [`ContractError::SharedBoundaryPlaces`] when they touch in one
/// place only (or along a leaflet's whole boundary);
/// [`ContractError::NoClosingArcs`] when no arc of one leaflet closes a
/// ring with an arc of the other.
pub fn annulus_from_leaflets(
    anterior: &TriMesh,
    posterior: &TriMesh,
    tolerance_mm: f64,
) -> Result<FoundAnnulus, OrganError> {
    let tol = tolerance_mm;
    OrganError::check_positive(&[("tolerance_mm", tol)])?;
    let ([a, p], _) = super::leaflet_repair::repair_leaflets(anterior, posterior)?;
    let meshes = [&a, &p];
    let loops = [ANTERIOR, POSTERIOR].map(|k| {
        super::contract::disk_boundary(LeafletSide::of(k), meshes[k]).map(|l| {
            l.iter()
                .map(|&v| meshes[k].positions[v as usize])
                .collect::<Vec<_>>()
        })
    });
    let [la, lp] = loops;
    let loops = [la?, lp?];
    let d = [
        distances_to_loop(&loops[ANTERIOR], &loops[POSTERIOR]),
        distances_to_loop(&loops[POSTERIOR], &loops[ANTERIOR]),
    ];
    let closest = d[ANTERIOR].iter().copied().fold(f64::INFINITY, f64::min);
    if closest.is_nan() || closest > tol {
        return Err(ContractError::NoSharedBoundary {
            closest_mm: closest,
            tolerance_mm: tol,
        }
        .into());
    }
    let mut arcs: [Vec<Vec<Point3<f64>>>; 2] = [Vec::new(), Vec::new()];
    let mut places = [0; 2];
    for k in [ANTERIOR, POSTERIOR] {
        let shared: Vec<bool> = d[k].iter().map(|&x| x <= tol).collect();
        let found = arcs_between(&loops[k], &shared);
        places[k] = found.len();
        if found.len() < 2 {
            return Err(ContractError::SharedBoundaryPlaces {
                leaflet: LeafletSide::of(k),
                places: found.len(),
                shared_vertices: shared.iter().filter(|&&s| s).count(),
                boundary_vertices: shared.len(),
                tolerance_mm: tol,
            }
            .into());
        }
        arcs[k] = found;
    }
    let mut best: Option<(f64, Vec<Point3<f64>>)> = None;
    for arc_a in &arcs[ANTERIOR] {
        for arc_p in &arcs[POSTERIOR] {
            let Some(ring) = closed_ring(arc_a, arc_p, tol) else {
                continue;
            };
            let area = vector_area(&ring).norm();
            if best.as_ref().is_none_or(|(b, _)| area > *b) {
                best = Some((area, ring));
            }
        }
    }
    let Some((area_mm2, ring)) = best else {
        return Err(ContractError::NoClosingArcs {
            places,
            tolerance_mm: tol,
        }
        .into());
    };
    Ok(FoundAnnulus {
        ring,
        places,
        area_mm2,
    })
}

/// Per point of `points`, its distance to the closed polyline `ring`.
fn distances_to_loop(points: &[Point3<f64>], ring: &[Point3<f64>]) -> Vec<f64> {
    let n = ring.len();
    points
        .iter()
        .map(|q| {
            (0..n)
                .map(|i| point_segment_distance(q, &ring[i], &ring[(i + 1) % n]))
                .fold(f64::INFINITY, f64::min)
        })
        .collect()
}

/// The arcs of a boundary loop between its runs of shared vertices: each
/// the unshared vertices between two runs with the bounding run vertices
/// as its ends, in loop order; no arc when every vertex (or none) is
/// shared.
fn arcs_between(boundary: &[Point3<f64>], shared: &[bool]) -> Vec<Vec<Point3<f64>>> {
    let n = boundary.len();
    // Start just after a shared vertex that ends a run.
    let Some(start) = (0..n).find(|&i| shared[i] && !shared[(i + 1) % n]) else {
        return Vec::new();
    };
    let mut arcs = Vec::new();
    let mut k = 0;
    while k < n {
        let i = (start + k) % n;
        if shared[i] && !shared[(i + 1) % n] {
            // An arc from run vertex `i` to the next shared vertex.
            let mut arc = vec![boundary[i]];
            let mut j = 1;
            while !shared[(i + j) % n] {
                arc.push(boundary[(i + j) % n]);
                j += 1;
            }
            arc.push(boundary[(i + j) % n]);
            arcs.push(arc);
            k += j;
        } else {
            k += 1;
        }
    }
    arcs
}

/// The ring of arcs `a` and `p` when they close (module docs, step 3):
/// `a`, then `p` in the direction that continues it, one midpoint per
/// junction.
fn closed_ring(a: &[Point3<f64>], p: &[Point3<f64>], tol: f64) -> Option<Vec<Point3<f64>>> {
    let (a0, a1) = (a[0], a[a.len() - 1]);
    let end_edge = |arc: &[Point3<f64>], first: bool| {
        let m = arc.len();
        if first {
            (arc[1] - arc[0]).norm()
        } else {
            (arc[m - 1] - arc[m - 2]).norm()
        }
    };
    let meets =
        |x: &Point3<f64>, xe: f64, y: &Point3<f64>, ye: f64| (x - y).norm() <= tol + xe.max(ye);
    let (ha0, ha1) = (end_edge(a, true), end_edge(a, false));
    let (hp0, hp1) = (end_edge(p, true), end_edge(p, false));
    let (p0, p1) = (p[0], p[p.len() - 1]);
    // `a` ends where `p` starts (then `p` runs on) or where it ends (then
    // `p` runs backwards).
    let forward = meets(&a1, ha1, &p0, hp0) && meets(&p1, hp1, &a0, ha0);
    let backward = meets(&a1, ha1, &p1, hp1) && meets(&p0, hp0, &a0, ha0);
    let p: Vec<Point3<f64>> = if forward
        && (!backward || (a1 - p0).norm() + (a0 - p1).norm() <= (a1 - p1).norm() + (a0 - p0).norm())
    {
        p.to_vec()
    } else if backward {
        p.iter().rev().copied().collect()
    } else {
        return None;
    };
    let mid = |x: &Point3<f64>, y: &Point3<f64>| Point3::from((x.coords + y.coords) * 0.5);
    let mut ring = Vec::with_capacity(a.len() + p.len() - 2);
    ring.push(mid(&a[0], &p[p.len() - 1]));
    ring.extend_from_slice(&a[1..a.len() - 1]);
    ring.push(mid(&a[a.len() - 1], &p[0]));
    ring.extend_from_slice(&p[1..p.len() - 1]);
    Some(ring)
}

/// The vector area `1/2 sum_i p_i x p_{i+1}` of the closed polygon
/// `ring` (independent of the origin; its norm is the area enclosed by a
/// planar ring).
fn vector_area(ring: &[Point3<f64>]) -> Vector3<f64> {
    let n = ring.len();
    (0..n)
        .map(|i| ring[i].coords.cross(&ring[(i + 1) % n].coords))
        .sum::<Vector3<f64>>()
        * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::shapes::{Pose, ValveParams, mitral_valve};

    /// Largest distance from a point of `a` to the closed polyline `b`.
    fn one_sided(a: &[Point3<f64>], b: &[Point3<f64>]) -> f64 {
        distances_to_loop(a, b).into_iter().fold(0.0, f64::max)
    }

    /// The symmetric Hausdorff distance of two closed polylines' vertices.
    fn hausdorff(a: &[Point3<f64>], b: &[Point3<f64>]) -> f64 {
        one_sided(a, b).max(one_sided(b, a))
    }

    #[test]
    fn the_synthetic_valves_annulus_is_found_exactly() {
        let v = mitral_valve(&ValveParams::default()).unwrap();
        let f = annulus_from_leaflets(&v.anterior, &v.posterior, 0.5).unwrap();
        assert_eq!(f.places, [2, 2]);
        assert_eq!(f.ring.len(), v.annulus.len());
        // Every given ring point is a found one and vice versa.
        for q in &v.annulus {
            assert!(f.ring.iter().any(|r| r == q), "{q}");
        }
        assert_eq!(hausdorff(&f.ring, &v.annulus), 0.0);
    }

    /// Against an annulus drawn finer than the leaflets (the same curve at
    /// 4 times the points), the found ring is off by the chords' sag only.
    /// Prints the distances (`cargo test -p unfold-organs --lib
    /// found_ring_against_a_finer -- --nocapture`).
    #[test]
    fn found_ring_against_a_finer_annulus_is_off_by_the_chord_sag() {
        for segments in [40, 96] {
            let params = |n| ValveParams {
                annulus_segments: n,
                ..ValveParams::default()
            };
            let v = mitral_valve(&params(segments)).unwrap();
            let fine = mitral_valve(&params(4 * segments)).unwrap();
            let f = annulus_from_leaflets(&v.anterior, &v.posterior, 0.5).unwrap();
            let (to_fine, from_fine) = (
                one_sided(&f.ring, &fine.annulus),
                one_sided(&fine.annulus, &f.ring),
            );
            eprintln!(
                "{segments} segments: found ring to a {}-point annulus {to_fine:.4} mm, back \
                 {from_fine:.4} mm; to the given ring {:.4} mm",
                4 * segments,
                hausdorff(&f.ring, &v.annulus)
            );
            assert!(to_fine < 0.05 && from_fine < 0.2, "{to_fine} {from_fine}");
        }
    }

    /// The case proptest found: free edges 0.5 mm apart, the tolerance,
    /// meet in a third place; the widest ring is still the annulus.
    #[test]
    fn a_closed_valve_s_free_edges_meeting_leave_the_ring() {
        for gap in [0.3, 0.5, 0.7, 1.0] {
            let v = mitral_valve(&ValveParams {
                coaptation_gap: gap,
                commissure_gap: 8.0,
                saddle_height: 0.0,
                billow: 0.0,
                annulus_segments: 24,
                depth_segments: 6,
                pose: Pose::new([0.0, 30.0, 0.0], [10.0, -20.0, 5.0]),
                ..ValveParams::default()
            })
            .unwrap();
            let f = annulus_from_leaflets(&v.anterior, &v.posterior, 0.5).unwrap();
            assert_eq!(f.ring.len(), v.annulus.len(), "gap {gap}: {:?}", f.places);
            let h = hausdorff(&f.ring, &v.annulus);
            assert!(h <= 1e-9, "gap {gap}: {h} ({:?})", f.places);
        }
    }

    #[test]
    fn vector_area_of_a_unit_square_is_its_normal() {
        let sq = [
            Point3::new(5.0, 5.0, 1.0),
            Point3::new(6.0, 5.0, 1.0),
            Point3::new(6.0, 6.0, 1.0),
            Point3::new(5.0, 6.0, 1.0),
        ];
        assert!((vector_area(&sq) - Vector3::z()).norm() < 1e-12);
        assert_eq!(point_segment_distance(&sq[2], &sq[0], &sq[1]), 1.0);
    }

    #[test]
    fn leaflets_that_do_not_touch_are_an_error_with_the_gap() {
        let v = mitral_valve(&ValveParams::default()).unwrap();
        let mut far = v.posterior.clone();
        for p in &mut far.positions {
            p.z -= 3.0;
        }
        let e = annulus_from_leaflets(&v.anterior, &far, 0.5).unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("share no boundary") && s.contains("0.5 mm"),
            "{s}"
        );
        let e = annulus_from_leaflets(&v.anterior, &v.posterior, f64::NAN).unwrap_err();
        assert!(e.to_string().contains("tolerance_mm"), "{e}");
    }

    #[test]
    fn leaflets_meeting_once_are_an_error() {
        let v = mitral_valve(&ValveParams::default()).unwrap();
        // The posterior leaflet loses its last column: it ends one ring
        // segment short of the anterolateral commissure.
        let mut short = v.posterior.clone();
        let last: Vec<u32> = v.posterior_longitudes.last().unwrap().clone();
        short
            .triangles
            .retain(|t| !t.iter().any(|x| last.contains(x)));
        let used: std::collections::BTreeSet<u32> =
            short.triangles.iter().flatten().copied().collect();
        let map: std::collections::HashMap<u32, u32> = used
            .iter()
            .enumerate()
            .map(|(i, &v)| (v, i as u32))
            .collect();
        let short = TriMesh::new(
            used.iter().map(|&v| short.positions[v as usize]).collect(),
            short.triangles.iter().map(|t| t.map(|x| map[&x])).collect(),
        );
        let e = annulus_from_leaflets(&v.anterior, &short, 0.5).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("meet in 1 place"), "{s}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// Whatever the valve's shape, pose and state (open or closed), and
        /// with the posterior leaflet's commissure points moved off the
        /// anterior's by less than the tolerance, the found ring is the
        /// given one up to that move. Free edges closer than the tolerance
        /// (a coaptation gap near it) meet too, in more places than the two
        /// commissures; the ring is found all the same (step 4).
        #[test]
        fn the_found_ring_is_the_given_one(
            gap in 0.5f64..8.0,
            saddle in 0.0f64..10.0,
            billow in 0.0f64..1.0,
            segments in 24usize..80,
            roll in 0.0f64..360.0,
            yaw in 0.0f64..360.0,
            shift in 0.0f64..0.3,
        ) {
            let v = mitral_valve(&ValveParams {
                coaptation_gap: gap,
                commissure_gap: gap.max(8.0),
                saddle_height: saddle,
                billow,
                annulus_segments: segments,
                depth_segments: 6,
                pose: Pose::new([roll, 30.0, yaw], [10.0, -20.0, 5.0]),
                ..ValveParams::default()
            })
            .unwrap();
            let mut post = v.posterior.clone();
            let moved = [v.posterior_annulus[0], *v.posterior_annulus.last().unwrap()];
            for m in moved {
                post.positions[m as usize].x += shift;
            }
            let f = annulus_from_leaflets(&v.anterior, &post, 0.5).unwrap();
            if gap > 1.0 {
                prop_assert_eq!(f.places, [2, 2]);
            } else {
                prop_assert!(f.places.iter().all(|&p| p >= 2), "{:?}", f.places);
            }
            prop_assert_eq!(f.ring.len(), v.annulus.len());
            let h = hausdorff(&f.ring, &v.annulus);
            prop_assert!(h <= 0.5 * shift + 1e-9, "{} > {}", h, 0.5 * shift);
        }
    }
}
