//! Surfaces with several openings (ALGORITHMS 3.1): a user's S may have
//! the basal rim and further holes (inflow and outflow tracts, cut-outs).
//! One boundary loop is the basal rim; every other one is capped, so that
//! S becomes a disk before it is flattened and the Laplace field is solved.
//!
//! **Which loop is the rim.** With a point `r` named as near the rim
//! (`rim_near`), the loop whose polyline is nearest `r`; otherwise the loop
//! nearest the two rim landmarks `a`, `i` (which lie on the rim), by the
//! mean distance `(d(a, L) + d(i, L)) / 2`, where `d(p, L)` is the distance
//! from `p` to the closed polyline of loop `L`. The choice is refused as
//! ambiguous unless the second-nearest loop is at least twice as far and at
//! least the snap distance farther: `d2 >= 2 d1` and `d2 - d1 >= snap`.
//! A `rim_near` point farther than the snap distance from every loop is
//! refused too. A surface with one loop is left as it is.
//!
//! **Caps.** Each other loop `b_0 .. b_{m-1}` (in the direction of its
//! boundary half-edges) is closed by a fan from its centroid
//! `c = sum_k |e_k| (b_k + b_{k+1}) / 2 / sum_k |e_k|` (the polyline's
//! length-weighted centroid, one new vertex): triangles
//! `(b_{k+1}, b_k, c)`, which traverse each loop edge against S's half-edge
//! and so keep S consistently oriented. The fan is accepted when it is
//! star-shaped seen along the loop's Newell normal
//! `n = sum_k (b_k - c) x (b_{k+1} - c)`: every spoke triangle turns the
//! same way, `((b_k - c) x (b_{k+1} - c)) . n > 0`, and when it crosses no
//! triangle of S (every triangle near the cap that touches no loop vertex:
//! its edges against the fan, the fan's spokes against it; the field's
//! inside/outside test needs S and its caps to bound one region). Each cap adds one
//! vertex, `m` edges and `m` triangles, so the Euler characteristic rises
//! by one per cap: a sphere with `k` holes (`chi = 2 - k`) becomes a disk
//! (`chi = 1`). The caps are part of S for the field and the streamlines
//! (the domain is inside S, caps included, closed by the rim's base), and
//! interior parts of the disk for `phi`; anatomy points between a cap and
//! the missing wall lie outside S.

use super::error::VentricleError;
use super::landmarks::check_finite_landmark;
use crate::OrganError;
use serde::{Deserialize, Serialize};
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::{point_segment_distance, segment_crosses_triangle};
use unfold_mesh::nalgebra::{Point3, Vector3};
use unfold_mesh::topology::boundary_loops;

/// Why the rim is the loop it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RimChoice {
    /// S has one boundary loop.
    Only,
    /// The loop nearest the two rim landmarks.
    Landmarks,
    /// The loop nearest the given `rim_near` point.
    RimNear,
}

/// One boundary loop of S as given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Opening {
    /// Vertices of the loop.
    pub vertices: usize,
    /// Length of its closed polyline, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub perimeter_mm: f64,
    /// Its length-weighted centroid, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub centroid_mm: [f64; 3],
    /// The distance the rim was chosen by, mm: the mean distance of the two
    /// rim landmarks to the polyline, or that of the `rim_near` point (0
    /// when S has one loop).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub distance_mm: f64,
    /// Whether this loop is the basal rim.
    pub rim: bool,
    /// Triangles added to cap it (0 for the rim).
    pub cap_triangles: usize,
}

/// The openings of S and what was done with them (`openings` in
/// `report.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Openings {
    /// Every boundary loop, longest first.
    pub loops: Vec<Opening>,
    /// Index in `loops` of the basal rim.
    pub rim: usize,
    /// Why that loop.
    pub chosen_by: RimChoice,
    /// Triangles added by capping, in all.
    pub cap_triangles: usize,
    /// Vertices added by capping (one per cap).
    pub cap_vertices: usize,
}

/// S with every opening but the rim capped.
#[derive(Debug, Clone)]
pub struct Capped {
    /// S, its vertices and triangles first, then each cap's centre and fan
    /// (S itself, its arrays kept, when it has one opening; with caps, its
    /// point and cell arrays are dropped).
    pub surface: TriMesh,
    /// What was found and done.
    pub openings: Openings,
}

/// Distance from `p` to the closed polyline through `loop_`'s vertices.
pub fn loop_distance(positions: &[Point3<f64>], loop_: &[u32], p: &Point3<f64>) -> f64 {
    let m = loop_.len();
    (0..m)
        .map(|k| {
            point_segment_distance(
                p,
                &positions[loop_[k] as usize],
                &positions[loop_[(k + 1) % m] as usize],
            )
        })
        .fold(f64::INFINITY, f64::min)
}

/// Perimeter and length-weighted centroid of a closed polyline.
fn perimeter_centroid(positions: &[Point3<f64>], loop_: &[u32]) -> (f64, Point3<f64>) {
    let m = loop_.len();
    let mut length = 0.0;
    let mut sum = Vector3::zeros();
    for k in 0..m {
        let a = positions[loop_[k] as usize];
        let b = positions[loop_[(k + 1) % m] as usize];
        let l = (b - a).norm();
        length += l;
        sum += (a.coords + b.coords) * (0.5 * l);
    }
    let c = if length > 0.0 {
        sum / length
    } else {
        loop_
            .iter()
            .map(|&v| positions[v as usize].coords)
            .sum::<Vector3<f64>>()
            / m.max(1) as f64
    };
    (length, Point3::from(c))
}

/// Finds S's boundary loops, picks the basal rim (nearest `rim_near` when
/// given, else nearest the rim landmarks `anterior`, `inferior`) and caps
/// every other loop by a fan from its centroid (see the module notes).
///
/// # Errors
/// - [`VentricleError::NotADisk`] for a closed S or a non-manifold boundary;
/// - [`VentricleError::LandmarkNotFinite`] for a non-finite point used to
///   choose the rim;
/// - [`VentricleError::RimNearFar`] when `rim_near` is farther than
///   `snap_mm` from every loop, [`VentricleError::AmbiguousRim`] when two
///   loops are about equally near;
/// - [`VentricleError::OpeningNotCappable`] when a loop is not star-shaped
///   about its centroid, [`VentricleError::CapCrossesSurface`] when its cap
///   would cross S;
/// - `Config` for a `snap_mm` that is not finite and `> 0`.
pub fn cap_openings(
    surface: &TriMesh,
    anterior: &Point3<f64>,
    inferior: &Point3<f64>,
    rim_near: Option<&Point3<f64>>,
    snap_mm: f64,
) -> Result<Capped, OrganError> {
    OrganError::check_positive(&[("landmark snap distance (mm)", snap_mm)])?;
    let loops = boundary_loops(surface).map_err(VentricleError::NotADisk)?;
    if loops.is_empty() {
        return Err(VentricleError::NotADisk(unfold_mesh::MeshError::ClosedSurface).into());
    }
    let pos = &surface.positions;
    let shape: Vec<(f64, Point3<f64>)> = loops.iter().map(|l| perimeter_centroid(pos, l)).collect();
    let finite = check_finite_landmark;
    let (chosen_by, distances) = if loops.len() == 1 {
        (RimChoice::Only, vec![0.0])
    } else if let Some(r) = rim_near {
        finite("rim-near", r)?;
        let d: Vec<f64> = loops.iter().map(|l| loop_distance(pos, l, r)).collect();
        (RimChoice::RimNear, d)
    } else {
        finite("anterior", anterior)?;
        finite("inferior", inferior)?;
        let d: Vec<f64> = loops
            .iter()
            .map(|l| 0.5 * (loop_distance(pos, l, anterior) + loop_distance(pos, l, inferior)))
            .collect();
        (RimChoice::Landmarks, d)
    };
    let mut order: Vec<usize> = (0..loops.len()).collect();
    order.sort_by(|&a, &b| distances[a].total_cmp(&distances[b]));
    let rim = order[0];
    if loops.len() > 1 {
        let (d1, d2) = (distances[order[0]], distances[order[1]]);
        if chosen_by == RimChoice::RimNear && d1 > snap_mm {
            return Err(VentricleError::RimNearFar {
                distances_mm: distances,
                snap_mm,
            }
            .into());
        }
        if d2 < 2.0 * d1 || d2 - d1 < snap_mm {
            return Err(VentricleError::AmbiguousRim {
                by: chosen_by,
                nearest: [order[0], order[1]],
                distances_mm: distances,
                snap_mm,
            }
            .into());
        }
    }
    let mut positions = pos.clone();
    let mut triangles = surface.triangles.clone();
    let mut openings = Vec::with_capacity(loops.len());
    let mut cap_triangles = 0;
    for (j, l) in loops.iter().enumerate() {
        let (perimeter, c) = shape[j];
        let added = if j == rim {
            0
        } else {
            let added = fan(pos, l, &c, j, &mut positions, &mut triangles)?;
            check_crossing(surface, l, &c, j)?;
            added
        };
        cap_triangles += added;
        openings.push(Opening {
            vertices: l.len(),
            perimeter_mm: perimeter,
            centroid_mm: [c.x, c.y, c.z],
            distance_mm: distances[j],
            rim: j == rim,
            cap_triangles: added,
        });
    }
    let capped = if loops.len() == 1 {
        surface.clone()
    } else {
        TriMesh::new(positions, triangles)
    };
    Ok(Capped {
        surface: capped,
        openings: Openings {
            loops: openings,
            rim,
            chosen_by,
            cap_triangles,
            cap_vertices: loops.len() - 1,
        },
    })
}

/// Appends the fan closing loop `l` (number `index`) from its centroid `c`;
/// returns the triangles added.
fn fan(
    pos: &[Point3<f64>],
    l: &[u32],
    c: &Point3<f64>,
    index: usize,
    positions: &mut Vec<Point3<f64>>,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<usize, VentricleError> {
    let m = l.len();
    let spoke = |k: usize| -> Vector3<f64> {
        let a = pos[l[k] as usize] - c;
        let b = pos[l[(k + 1) % m] as usize] - c;
        a.cross(&b)
    };
    let n: Vector3<f64> = (0..m).map(spoke).sum();
    let bad = (0..m).filter(|&k| spoke(k).dot(&n) <= 0.0).count();
    if m < 3 || n.norm() == 0.0 || bad > 0 {
        return Err(VentricleError::OpeningNotCappable {
            opening: index,
            vertices: m,
            folded: bad,
        });
    }
    let centre = positions.len() as u32;
    positions.push(*c);
    for k in 0..m {
        triangles.push([l[(k + 1) % m], l[k], centre]);
    }
    Ok(m)
}

/// Refuses the fan of loop `l` (number `index`) from `c` when it crosses a
/// triangle of S that touches no loop vertex: every edge of such a triangle
/// near the cap against every fan triangle, and every spoke `c b_k` against
/// every such triangle (two triangles that cross meet along a segment whose
/// ends lie on edges of one or the other).
fn check_crossing(
    surface: &TriMesh,
    l: &[u32],
    c: &Point3<f64>,
    index: usize,
) -> Result<(), VentricleError> {
    let pos = &surface.positions;
    let m = l.len();
    let radius = l
        .iter()
        .map(|&v| (pos[v as usize] - c).norm())
        .fold(0.0, f64::max);
    let on_loop: std::collections::HashSet<u32> = l.iter().copied().collect();
    for (t, tri) in surface.triangles.iter().enumerate() {
        if tri.iter().any(|v| on_loop.contains(v)) {
            continue;
        }
        let [a, b, d] = tri.map(|v| pos[v as usize]);
        let centre = Point3::from((a.coords + b.coords + d.coords) / 3.0);
        let reach = [a, b, d]
            .iter()
            .map(|p| (p - centre).norm())
            .fold(0.0, f64::max);
        if (centre - c).norm() > radius + reach {
            continue;
        }
        let crossing = (0..m).any(|k| {
            let (b0, b1) = (pos[l[k] as usize], pos[l[(k + 1) % m] as usize]);
            segment_crosses_triangle(c, &b0, &a, &b, &d)
                || [(a, b), (b, d), (d, a)]
                    .iter()
                    .any(|(p, q)| segment_crosses_triangle(p, q, &b1, &b0, c))
        });
        if crossing {
            return Err(VentricleError::CapCrossesSurface {
                opening: index,
                triangle: t,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::repair::repair_tri_mesh;
    use unfold_mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
    use unfold_mesh::topology::{disk_boundary_loop, euler_characteristic};

    fn cup() -> VentricleShape {
        ventricle_cup(&VentricleParams::default()).unwrap()
    }

    /// The cup with the triangles around each centre removed (every
    /// triangle with a vertex within `radius` of it).
    fn holed(s: &TriMesh, centres: &[Point3<f64>], radius: f64) -> TriMesh {
        let near = |v: u32| {
            centres
                .iter()
                .any(|c| (s.positions[v as usize] - c).norm() < radius)
        };
        let triangles = s
            .triangles
            .iter()
            .filter(|t| !t.iter().any(|&v| near(v)))
            .copied()
            .collect();
        TriMesh::new(s.positions.clone(), triangles)
    }

    /// The cup's wall point at azimuth `az` and height `z` (mm below the
    /// rim): the nearest vertex.
    fn wall(s: &TriMesh, az: f64, z: f64) -> Point3<f64> {
        let r = 25.0;
        let p = Point3::new(r * az.cos(), r * az.sin(), z);
        *s.positions
            .iter()
            .min_by(|a, b| (*a - p).norm().total_cmp(&(*b - p).norm()))
            .unwrap()
    }

    /// The loop `l` as positions, rotated to start at its smallest vertex
    /// position (lexicographic) and run towards the smaller neighbour (a
    /// cyclic sequence, either direction).
    fn as_points(s: &TriMesh, l: &[u32]) -> Vec<[f64; 3]> {
        let mut p: Vec<[f64; 3]> = l
            .iter()
            .map(|&v| {
                let q = s.positions[v as usize];
                [q.x, q.y, q.z]
            })
            .collect();
        let k = (0..p.len())
            .min_by(|&a, &b| p[a].partial_cmp(&p[b]).unwrap())
            .unwrap();
        p.rotate_left(k);
        if p.len() > 2 && p[p.len() - 1] < p[1] {
            p[1..].reverse();
        }
        p
    }

    /// Every invariant of a capped surface: a disk, consistently oriented,
    /// whose one loop is the rim loop, S kept first, one fan per cap.
    fn check(s: &TriMesh, c: &Capped, rim: &[[f64; 3]]) {
        let o = &c.openings;
        let m = &c.surface;
        assert_eq!(euler_characteristic(m), 1);
        let l = disk_boundary_loop(m).unwrap();
        assert_eq!(as_points(m, &l), rim);
        let (_, report) = repair_tri_mesh(m).unwrap();
        assert_eq!(report.flipped, 0, "{report:?}");
        assert_eq!(report.components, 1);
        assert_eq!(&m.positions[..s.positions.len()], &s.positions[..]);
        assert_eq!(&m.triangles[..s.triangles.len()], &s.triangles[..]);
        let k = o.loops.len();
        assert_eq!(o.cap_vertices, k - 1);
        assert_eq!(m.positions.len(), s.positions.len() + k - 1);
        let holes: usize = o.loops.iter().filter(|x| !x.rim).map(|x| x.vertices).sum();
        assert_eq!(o.cap_triangles, holes);
        assert_eq!(m.triangles.len(), s.triangles.len() + holes);
        assert_eq!(o.loops.iter().filter(|x| x.rim).count(), 1);
        assert!(o.loops[o.rim].rim);
        for x in &o.loops {
            assert_eq!(x.cap_triangles, if x.rim { 0 } else { x.vertices });
            assert!(x.perimeter_mm > 0.0);
        }
    }

    #[test]
    fn one_loop_is_the_rim_and_nothing_is_added() {
        let v = cup();
        let c = cap_openings(&v.surface, &v.anterior, &v.inferior, None, 5.0).unwrap();
        assert_eq!(c.surface.positions, v.surface.positions);
        assert_eq!(c.surface.triangles, v.surface.triangles);
        let o = &c.openings;
        assert_eq!(o.chosen_by, RimChoice::Only);
        assert_eq!((o.rim, o.cap_triangles, o.cap_vertices), (0, 0, 0));
        assert_eq!(o.loops.len(), 1);
        assert_eq!(o.loops[0].vertices, v.rim.len());
        // the default cup's rim: a sampled circle at z = 0
        let r0 = v.surface.positions[v.rim[0] as usize].coords.norm();
        let r = o.loops[0].perimeter_mm / std::f64::consts::TAU;
        assert!(r < r0 && r > 0.99 * r0, "{r} vs {r0}");
        assert!(o.loops[0].centroid_mm.iter().all(|x| x.abs() < 1e-9));
    }

    #[test]
    fn two_holes_are_capped_and_the_base_stays_the_rim() {
        let v = cup();
        let centres = [wall(&v.surface, 1.0, -25.0), wall(&v.surface, 3.5, -20.0)];
        let s = holed(&v.surface, &centres, 6.0);
        let rim = as_points(&v.surface, &v.rim);
        let c = cap_openings(&s, &v.anterior, &v.inferior, None, 5.0).unwrap();
        check(&s, &c, &rim);
        let o = &c.openings;
        assert_eq!(o.loops.len(), 3);
        assert_eq!(o.chosen_by, RimChoice::Landmarks);
        assert_eq!(o.loops[o.rim].vertices, v.rim.len());
        assert!(o.loops[o.rim].distance_mm < 1e-9);
        // the caps' centres near the holes' centres (inside the wall)
        for x in o.loops.iter().filter(|x| !x.rim) {
            let c = Point3::from(x.centroid_mm);
            let d = centres
                .iter()
                .map(|p| (p - c).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(d < 3.0, "{d}");
        }
        // the same rim named by a point near it
        let near = v.anterior + Vector3::new(1.0, 0.0, -1.0);
        let r = cap_openings(&s, &v.anterior, &v.inferior, Some(&near), 5.0).unwrap();
        check(&s, &r, &rim);
        assert_eq!(r.openings.chosen_by, RimChoice::RimNear);
    }

    #[test]
    fn rim_near_names_another_loop() {
        let v = cup();
        let centre = wall(&v.surface, 2.0, -25.0);
        let s = holed(&v.surface, &[centre], 6.0);
        let loops = boundary_loops(&s).unwrap();
        let hole = loops.iter().find(|l| l.len() != v.rim.len()).unwrap();
        let near = s.positions[hole[0] as usize];
        let c = cap_openings(&s, &v.anterior, &v.inferior, Some(&near), 5.0).unwrap();
        check(&s, &c, &as_points(&s, hole));
        let o = &c.openings;
        assert_eq!(o.loops[o.rim].vertices, hole.len());
        assert_eq!(o.loops[o.rim].distance_mm, 0.0);
        assert_eq!(o.cap_triangles, v.rim.len());
    }

    #[test]
    fn a_far_rim_near_point_is_refused_naming_the_distances() {
        let v = cup();
        let s = holed(&v.surface, &[wall(&v.surface, 2.0, -25.0)], 6.0);
        let far = Point3::new(0.0, 0.0, -20.0);
        match cap_openings(&s, &v.anterior, &v.inferior, Some(&far), 5.0) {
            Err(OrganError::Ventricle(e @ VentricleError::RimNearFar { .. })) => {
                let VentricleError::RimNearFar {
                    distances_mm,
                    snap_mm,
                } = &e
                else {
                    unreachable!()
                };
                assert_eq!(*snap_mm, 5.0);
                assert_eq!(distances_mm.len(), 2);
                assert!(distances_mm.iter().all(|&d| d > 5.0), "{distances_mm:?}");
                let m = e.to_string();
                assert!(m.contains("rim-near") && m.contains("opening 0"), "{m}");
                assert!(!m.contains('\n'));
            }
            other => panic!("{other:?}"),
        }
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        assert!(matches!(
            cap_openings(&s, &v.anterior, &v.inferior, Some(&nan), 5.0),
            Err(OrganError::Ventricle(
                VentricleError::LandmarkNotFinite { .. }
            ))
        ));
    }

    #[test]
    fn two_loops_about_equally_near_are_ambiguous() {
        let v = cup();
        // a hole just below the rim, whose loop comes within a few mm of it
        let centre = wall(&v.surface, 0.3, -9.0);
        let s = holed(&v.surface, &[centre], 6.0);
        let loops = boundary_loops(&s).unwrap();
        assert_eq!(loops.len(), 2);
        let gap = loops[1]
            .iter()
            .map(|&w| loop_distance(&s.positions, &loops[0], &s.positions[w as usize]))
            .fold(f64::INFINITY, f64::min);
        assert!(gap > 0.5 && gap < 5.0, "{gap}");
        // a point midway between the two loops
        let (a, b) = loops[1]
            .iter()
            .flat_map(|&w| loops[0].iter().map(move |&u| (u, w)))
            .min_by(|x, y| {
                let d =
                    |(u, w): (u32, u32)| (s.positions[u as usize] - s.positions[w as usize]).norm();
                d(*x).total_cmp(&d(*y))
            })
            .unwrap();
        let mid =
            Point3::from((s.positions[a as usize].coords + s.positions[b as usize].coords) / 2.0);
        for (by, r) in [
            (
                RimChoice::RimNear,
                cap_openings(&s, &v.anterior, &v.inferior, Some(&mid), 5.0),
            ),
            (
                RimChoice::Landmarks,
                cap_openings(&s, &mid, &mid, None, 5.0),
            ),
        ] {
            match r {
                Err(OrganError::Ventricle(e @ VentricleError::AmbiguousRim { .. })) => {
                    let VentricleError::AmbiguousRim {
                        by: got,
                        nearest,
                        distances_mm,
                        ..
                    } = &e
                    else {
                        unreachable!()
                    };
                    assert_eq!(*got, by);
                    assert_eq!(distances_mm.len(), 2);
                    let mut n = *nearest;
                    n.sort();
                    assert_eq!(n, [0, 1]);
                    let m = e.to_string();
                    assert!(m.contains("ambiguous") && m.contains("mm"), "{m}");
                }
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn a_closed_surface_and_a_fold_are_refused() {
        let v = cup();
        let closed = TriMesh::new(
            vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(0.0, 0.0, 1.0),
            ],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        );
        assert!(matches!(
            cap_openings(&closed, &v.anterior, &v.inferior, None, 5.0),
            Err(OrganError::Ventricle(VentricleError::NotADisk(_)))
        ));
        // a loop that is not star-shaped about its centroid: an annulus
        // whose inner loop is an L shape folded over itself in projection
        let mut pos = Vec::new();
        let outer: Vec<(f64, f64)> = (0..8)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 8.0;
                (10.0 * t.cos(), 10.0 * t.sin())
            })
            .collect();
        // a thin crescent: far from star-shaped about its centroid
        let inner: Vec<(f64, f64)> = vec![
            (-5.0, 1.0),
            (-4.0, -2.0),
            (0.0, -4.0),
            (4.0, -2.0),
            (5.0, 1.0),
            (3.5, -1.0),
            (0.0, -2.8),
            (-3.5, -1.0),
        ];
        for &(x, y) in outer.iter().chain(&inner) {
            pos.push(Point3::new(x, y, 0.0));
        }
        let mut tris = Vec::new();
        for k in 0..8u32 {
            let (o0, o1, i0, i1) = (k, (k + 1) % 8, 8 + k, 8 + (k + 1) % 8);
            tris.push([o0, o1, i1]);
            tris.push([o0, i1, i0]);
        }
        let s = TriMesh::new(pos, tris);
        let loops = boundary_loops(&s).unwrap();
        assert_eq!(loops.len(), 2);
        let a = Point3::new(10.0, 0.0, 0.0);
        let i = Point3::new(0.0, 10.0, 0.0);
        match cap_openings(&s, &a, &i, None, 1.0) {
            Err(OrganError::Ventricle(e @ VentricleError::OpeningNotCappable { .. })) => {
                assert!(e.to_string().contains("star-shaped"), "{e}")
            }
            other => panic!("{other:?}"),
        }
    }

    /// A tube whose wall folds in below its bottom opening: the bottom's
    /// cap would cross the wall, and is refused.
    #[test]
    fn a_cap_that_would_cross_s_is_refused() {
        let rings: [(f64, f64); 4] = [(10.0, 0.0), (10.0, 2.0), (3.0, -3.0), (3.0, 10.0)];
        let n = 24u32;
        let mut pos = Vec::new();
        for &(r, z) in &rings {
            for k in 0..n {
                let t = k as f64 * std::f64::consts::TAU / n as f64;
                pos.push(Point3::new(r * t.cos(), r * t.sin(), z));
            }
        }
        let mut tris = Vec::new();
        for i in 0..rings.len() as u32 - 1 {
            for k in 0..n {
                let (a, b) = (i * n + k, i * n + (k + 1) % n);
                let (c, d) = (a + n, b + n);
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        let s = TriMesh::new(pos, tris);
        let top = s.positions[3 * n as usize];
        let other = s.positions[3 * n as usize + 8];
        match cap_openings(&s, &top, &other, None, 1.0) {
            Err(OrganError::Ventricle(e @ VentricleError::CapCrossesSurface { .. })) => {
                let VentricleError::CapCrossesSurface { opening, triangle } = e else {
                    unreachable!()
                };
                // the bottom loop (longer, so opening 0) and a triangle of
                // the fold between rings 1 and 2
                assert_eq!(opening, 0);
                assert!(
                    (2 * n as usize..4 * n as usize).contains(&triangle),
                    "{triangle}"
                );
                assert!(e.to_string().contains("would cross triangle"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        // without the fold the same tube is capped
        let mut straight = s.clone();
        for k in 0..n as usize {
            let p = &mut straight.positions[2 * n as usize + k];
            *p = Point3::new(p.x * 10.0 / 3.0, p.y * 10.0 / 3.0, 5.0);
        }
        let c = cap_openings(&straight, &top, &other, None, 1.0).unwrap();
        assert_eq!(c.openings.cap_triangles, n as usize);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// One or two holes anywhere on the wall between rim and apex:
        /// capped, S is a disk whose one loop is the cup's rim.
        #[test]
        fn holes_anywhere_on_the_wall_are_capped_to_a_disk(
            az1 in 0.0..std::f64::consts::TAU,
            z1 in -40.0..-18.0f64,
            dz in 0.0..std::f64::consts::PI,
            two in any::<bool>(),
            radius in 3.0..7.0f64,
        ) {
            let v = cup();
            let mut centres = vec![wall(&v.surface, az1, z1)];
            if two {
                centres.push(wall(&v.surface, az1 + std::f64::consts::PI * 0.5 + dz, z1 + 5.0));
            }
            let s = holed(&v.surface, &centres, radius);
            let loops = boundary_loops(&s).unwrap();
            prop_assume!(loops.len() == 1 + centres.len());
            let c = cap_openings(&s, &v.anterior, &v.inferior, None, 5.0).unwrap();
            check(&s, &c, &as_points(&v.surface, &v.rim));
            prop_assert_eq!(c.openings.chosen_by, RimChoice::Landmarks);
        }
    }
}
