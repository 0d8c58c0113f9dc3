//! Surfaces with several openings (ALGORITHMS 3.1): a user's S may have
//! the basal rim and further holes (inflow and outflow tracts, cut-outs).
//! One boundary loop is the basal rim; every other one is capped, so that
//! S becomes a disk before it is flattened and the Laplace field is solved.
//!
//! **An opening's shape.** Loop `L = b_0 .. b_{m-1}`: its perimeter
//! `p = sum_k |e_k|`, its length-weighted centroid
//! `c = sum_k |e_k| (b_k + b_{k+1}) / 2 / p`, its Newell normal
//! `n = sum_k (b_k - c) x (b_{k+1} - c)`, and its *disk*, the fan of
//! triangles `(c, b_k, b_{k+1})` (the cap it gets when it is not the rim).
//! With an apex `x`, the opening *faces away from the apex* when
//! `|n . (c - x)| / (|n| |c - x|) >= 1/2` (its plane within 60 degrees of
//! square to the line from the apex: the mitral ring of an LV, seen from
//! its apex; a hole in the side wall is seen edge-on).
//!
//! **Which loop is the rim**, in this order:
//!
//! 1. A point `r` named as near the rim (`rim_near`): the loop whose disk is
//!    nearest `r`, `d(r, L) = min_k dist(r, (c, b_k, b_{k+1}))`, so that a
//!    point on the ring and a point at the opening's centre both name it
//!    (`chosen_by: rim-near`).
//! 2. Otherwise the rim landmarks `a`, `i` (which lie on the rim): the loop
//!    nearest them by `(d(a, L) + d(i, L)) / 2`, `d(p, L)` the distance to
//!    the closed polyline, when that is unambiguous (below). With an apex,
//!    the landmarks must agree with the anatomy (3.): when they name
//!    another opening, the run is refused naming both and `--rim-near`
//!    (`chosen_by: landmarks`).
//! 3. The anatomy (the landmarks ambiguous, or none yet: the rim the
//!    landmarks from RV insertion points are derived on): the basal rim of
//!    an LV is the largest opening (perimeter) facing away from the apex
//!    (every opening when the apex is not known, or none faces away); when
//!    the second largest of those is within 15 % of it
//!    (`p_2 >= 0.85 p_1`) the choice is refused naming each opening
//!    (vertices, perimeter, centre) and `--rim-near` (`chosen_by:
//!    anatomy`). Rim landmarks that tie are settled by the anatomy.
//!
//! A nearest loop is unambiguous when the second nearest is at least twice
//! as far and at least the snap distance farther: `d2 >= 2 d1` and
//! `d2 - d1 >= snap`; a `rim_near` point that is not is refused as
//! ambiguous, and so is one farther than the snap distance from every
//! opening's disk. A surface with one loop is left as it is.
//!
//! **Gate.** `base.rim_agrees` records the rim's perimeter over that of the
//! anatomy's choice (the largest opening facing away from the apex, or the
//! largest one without an apex): 1 when they agree, in `[0.85, 1]` for a
//! tie the landmarks settled. A rim named by `--rim-near` (or by landmarks
//! without an apex to check them) below that is kept and the gate records
//! the fallback, so the report shows the run went against the anatomy.
//!
//! **Caps.** Each other loop `b_0 .. b_{m-1}` (in the direction of its
//! boundary half-edges) is closed by a fan from its centroid `c`, one new
//! vertex: triangles `(b_{k+1}, b_k, c)`, which traverse each loop edge
//! against S's half-edge and so keep S consistently oriented. The fan is
//! accepted when it is star-shaped seen along the loop's Newell normal
//! `n`: every spoke triangle turns the same way,
//! `((b_k - c) x (b_{k+1} - c)) . n > 0`, and when it crosses no
//! triangle of S (every triangle near the cap that touches no loop vertex:
//! its edges against the fan, the fan's spokes against it; the field's
//! inside/outside test needs S and its caps to bound one region). Each cap adds one
//! vertex, `m` edges and `m` triangles, so the Euler characteristic rises
//! by one per cap: a sphere with `k` holes (`chi = 2 - k`) becomes a disk
//! (`chi = 1`). The caps are part of S for the field and the streamlines
//! (the domain is inside S, caps included, closed by the rim's base), and
//! interior parts of the disk for `phi`; anatomy points between a cap and
//! the missing wall lie outside S.

use super::error::{OpeningSize, VentricleError};
use super::landmarks::check_finite_landmark;
use crate::gate::Gates;
use crate::{OrganError, Requirement};
use serde::{Deserialize, Serialize};
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::{point_segment_distance, segment_crosses_triangle};
use unfold_mesh::nalgebra::{Point3, Vector3};
use unfold_mesh::spatial::closest_point_on_triangle;
use unfold_mesh::topology::boundary_loops;

/// Smallest `|cos|` between an opening's normal and the line from the apex
/// to its centre for it to face away from the apex (60 degrees).
pub const FACING_MIN: f64 = 0.5;
/// Two openings whose perimeters are within this ratio (`p_2 >= RATIO
/// p_1`) are the same size for the anatomy's choice: a real LV's mitral
/// ring is about 1.5-2 times its aortic ring's perimeter (the failing case
/// of an MRI-fitted LV: 108 against 62 mm), so 0.85 leaves a wide margin on both
/// sides.
pub const SAME_SIZE_RATIO: f64 = 0.85;

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
    /// The largest opening facing away from the apex.
    Anatomy,
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
    /// rim landmarks to the polyline, or that of the `rim_near` point to
    /// the opening's disk (0 when S has one loop; NaN when the anatomy
    /// chose without landmarks).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub distance_mm: f64,
    /// `|cos|` of the angle between its Newell normal and the line from the
    /// apex to its centroid (NaN without an apex): `>= 0.5` faces away from
    /// the apex.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub facing_apex: f64,
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
    /// The gate `base.rim_agrees` (module notes).
    pub gates: Gates,
}

/// What names the basal rim: any of the rim landmarks, a point near it, the
/// apex (for the anatomy).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RimHint {
    /// The anterior and inferior rim landmarks (none: not known yet).
    pub landmarks: Option<[Point3<f64>; 2]>,
    /// A point on the rim or in its opening.
    pub rim_near: Option<Point3<f64>>,
    /// The apex.
    pub apex: Option<Point3<f64>>,
}

/// S's boundary loops and which is the basal rim.
#[derive(Debug, Clone, PartialEq)]
pub struct RimPick {
    /// Every boundary loop (vertices of S), longest first.
    pub loops: Vec<Vec<u32>>,
    /// Index of the rim in `loops`.
    pub rim: usize,
    /// Why that loop.
    pub chosen_by: RimChoice,
    /// Each loop's distance the rim was chosen by, mm (see
    /// [`Opening::distance_mm`]).
    pub distances_mm: Vec<f64>,
    /// Each loop's perimeter, mm, and centroid.
    pub shapes: Vec<(f64, Point3<f64>)>,
    /// Each loop's `facing_apex` (see [`Opening::facing_apex`]).
    pub facing: Vec<f64>,
    /// The anatomy's choice, `Err` when two openings tie (`None` with one
    /// loop).
    pub anatomy: Option<Result<usize, [usize; 2]>>,
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

/// Distance from `p` to the disk of `loop_` (the fan of triangles
/// `(c, b_k, b_{k+1})` from its centroid `c`): 0 on the ring and at the
/// centre.
pub fn disk_distance(
    positions: &[Point3<f64>],
    loop_: &[u32],
    c: &Point3<f64>,
    p: &Point3<f64>,
) -> f64 {
    let m = loop_.len();
    (0..m)
        .map(|k| {
            let a = &positions[loop_[k] as usize];
            let b = &positions[loop_[(k + 1) % m] as usize];
            (closest_point_on_triangle(p, c, a, b).0 - p).norm()
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

/// Newell normal `sum_k (b_k - c) x (b_{k+1} - c)` of a loop about `c`.
fn newell_normal(positions: &[Point3<f64>], loop_: &[u32], c: &Point3<f64>) -> Vector3<f64> {
    let m = loop_.len();
    (0..m)
        .map(|k| {
            let a = positions[loop_[k] as usize] - c;
            let b = positions[loop_[(k + 1) % m] as usize] - c;
            a.cross(&b)
        })
        .sum()
}

/// The sizes of the openings `which`, for messages.
fn sizes(shapes: &[(f64, Point3<f64>)], loops: &[Vec<u32>], which: &[usize]) -> Vec<OpeningSize> {
    which
        .iter()
        .map(|&j| OpeningSize {
            index: j,
            vertices: loops[j].len(),
            perimeter_mm: shapes[j].0,
            centroid_mm: [shapes[j].1.x, shapes[j].1.y, shapes[j].1.z],
        })
        .collect()
}

/// The nearest of `distances` when it is unambiguous (`d2 >= 2 d1` and
/// `d2 - d1 >= snap`): `Ok(nearest)`, else `Err([nearest, second])`.
fn nearest(distances: &[f64], snap_mm: f64) -> Result<usize, [usize; 2]> {
    let mut order: Vec<usize> = (0..distances.len()).collect();
    order.sort_by(|&a, &b| distances[a].total_cmp(&distances[b]));
    if order.len() < 2 {
        return Ok(order[0]);
    }
    let (d1, d2) = (distances[order[0]], distances[order[1]]);
    if d2 >= 2.0 * d1 && d2 - d1 >= snap_mm {
        Ok(order[0])
    } else {
        Err([order[0], order[1]])
    }
}

/// The anatomy's choice: the largest opening (perimeter) facing away from
/// the apex (all of them without an apex, or when none does); `Err` with
/// the two largest when the second is within [`SAME_SIZE_RATIO`].
fn anatomy_choice(shapes: &[(f64, Point3<f64>)], facing: &[f64]) -> Result<usize, [usize; 2]> {
    let mut candidates: Vec<usize> = (0..shapes.len())
        .filter(|&j| facing[j] >= FACING_MIN)
        .collect();
    if candidates.is_empty() {
        candidates = (0..shapes.len()).collect();
    }
    candidates.sort_by(|&a, &b| shapes[b].0.total_cmp(&shapes[a].0));
    match candidates[..] {
        [a, b, ..] if shapes[b].0 >= SAME_SIZE_RATIO * shapes[a].0 => Err([a, b]),
        _ => Ok(candidates[0]),
    }
}

/// Finds S's boundary loops and picks the basal rim from `hint` (module
/// notes: `rim_near`, else the rim landmarks checked against the anatomy,
/// else the anatomy).
///
/// # Errors
/// - [`VentricleError::NotADisk`] for a closed S or a non-manifold boundary;
/// - [`VentricleError::LandmarkNotFinite`] for a non-finite point;
/// - [`VentricleError::RimNearFar`] when `rim_near` is farther than
///   `snap_mm` from every opening's disk, [`VentricleError::AmbiguousRim`]
///   when two openings are about equally near it;
/// - [`VentricleError::RimDisagrees`] when the landmarks name another
///   opening than the anatomy, [`VentricleError::OpeningsTie`] when the
///   anatomy cannot tell two openings apart and nothing else names one;
/// - `Config` for a `snap_mm` that is not finite and `> 0`.
pub fn choose_rim(surface: &TriMesh, hint: &RimHint, snap_mm: f64) -> Result<RimPick, OrganError> {
    OrganError::check_positive(&[("landmark snap distance (mm)", snap_mm)])?;
    let loops = boundary_loops(surface).map_err(VentricleError::NotADisk)?;
    if loops.is_empty() {
        return Err(VentricleError::NotADisk(unfold_mesh::MeshError::ClosedSurface).into());
    }
    let pos = &surface.positions;
    let finite = check_finite_landmark;
    let shapes: Vec<(f64, Point3<f64>)> =
        loops.iter().map(|l| perimeter_centroid(pos, l)).collect();
    if let Some(x) = &hint.apex {
        finite("apex", x)?;
    }
    let facing: Vec<f64> = loops
        .iter()
        .zip(&shapes)
        .map(|(l, (_, c))| match &hint.apex {
            Some(x) => {
                let n = newell_normal(pos, l, c);
                let u = c - x;
                (n.dot(&u) / (n.norm() * u.norm())).abs()
            }
            None => f64::NAN,
        })
        .collect();
    let pick = |rim, chosen_by, distances_mm, anatomy| RimPick {
        loops: loops.clone(),
        rim,
        chosen_by,
        distances_mm,
        shapes: shapes.clone(),
        facing: facing.clone(),
        anatomy,
    };
    if loops.len() == 1 {
        return Ok(pick(0, RimChoice::Only, vec![0.0], None));
    }
    let anatomy = anatomy_choice(&shapes, &facing);
    let tie = |[a, b]: [usize; 2]| -> OrganError {
        let s = sizes(&shapes, &loops, &[a.min(b), a.max(b)]);
        VentricleError::OpeningsTie {
            openings: Box::new([s[0], s[1]]),
            apex: hint.apex.is_some(),
        }
        .into()
    };
    if let Some(r) = &hint.rim_near {
        finite("rim-near", r)?;
        let d: Vec<f64> = loops
            .iter()
            .zip(&shapes)
            .map(|(l, (_, c))| disk_distance(pos, l, c, r))
            .collect();
        let d1 = d.iter().copied().fold(f64::INFINITY, f64::min);
        if d1 > snap_mm {
            return Err(VentricleError::RimNearFar {
                distances_mm: d,
                snap_mm,
            }
            .into());
        }
        return match nearest(&d, snap_mm) {
            Ok(j) => Ok(pick(j, RimChoice::RimNear, d, Some(anatomy))),
            Err(pair) => Err(ambiguous(
                RimChoice::RimNear,
                pair,
                d,
                snap_mm,
                &shapes,
                &loops,
            )),
        };
    }
    let Some([a, i]) = &hint.landmarks else {
        return match anatomy {
            Ok(j) => Ok(pick(
                j,
                RimChoice::Anatomy,
                vec![f64::NAN; loops.len()],
                Some(anatomy),
            )),
            Err(pair) => Err(tie(pair)),
        };
    };
    finite("anterior", a)?;
    finite("inferior", i)?;
    let d: Vec<f64> = loops
        .iter()
        .map(|l| 0.5 * (loop_distance(pos, l, a) + loop_distance(pos, l, i)))
        .collect();
    match (nearest(&d, snap_mm), anatomy) {
        // without an apex the anatomy is only a fallback
        (Ok(l), _) if hint.apex.is_none() => Ok(pick(l, RimChoice::Landmarks, d, Some(anatomy))),
        (Ok(l), Ok(x)) if l == x => Ok(pick(l, RimChoice::Landmarks, d, Some(anatomy))),
        (Ok(l), Ok(x)) => {
            let s = sizes(&shapes, &loops, &[l, x]);
            Err(VentricleError::RimDisagrees {
                landmarks: Box::new(s[0]),
                anatomy: Box::new(s[1]),
            }
            .into())
        }
        (Ok(l), Err(pair)) if pair.contains(&l) => {
            Ok(pick(l, RimChoice::Landmarks, d, Some(anatomy)))
        }
        (Ok(_), Err(pair)) => Err(tie(pair)),
        (Err(_), Ok(x)) => Ok(pick(x, RimChoice::Anatomy, d, Some(anatomy))),
        (Err(pair), Err(_)) => Err(ambiguous(
            RimChoice::Landmarks,
            pair,
            d,
            snap_mm,
            &shapes,
            &loops,
        )),
    }
}

/// [`VentricleError::AmbiguousRim`] for the openings `pair`.
fn ambiguous(
    by: RimChoice,
    pair: [usize; 2],
    distances_mm: Vec<f64>,
    snap_mm: f64,
    shapes: &[(f64, Point3<f64>)],
    loops: &[Vec<u32>],
) -> OrganError {
    let s = sizes(shapes, loops, &pair);
    VentricleError::AmbiguousRim {
        by,
        nearest: pair,
        openings: Box::new([s[0], s[1]]),
        distances_mm,
        snap_mm,
    }
    .into()
}

/// Finds S's boundary loops, picks the basal rim ([`choose_rim`]: nearest
/// `rim_near` when given, else the rim landmarks `anterior`, `inferior`
/// checked against the anatomy seen from `apex`) and caps every other loop
/// by a fan from its centroid (see the module notes); records the gate
/// `base.rim_agrees`.
///
/// # Errors
/// [`choose_rim`]'s; [`VentricleError::OpeningNotCappable`] when a loop is
/// not star-shaped about its centroid,
/// [`VentricleError::CapCrossesSurface`] when its cap would cross S.
pub fn cap_openings(
    surface: &TriMesh,
    anterior: &Point3<f64>,
    inferior: &Point3<f64>,
    rim_near: Option<&Point3<f64>>,
    apex: Option<&Point3<f64>>,
    snap_mm: f64,
) -> Result<Capped, OrganError> {
    let hint = RimHint {
        landmarks: Some([*anterior, *inferior]),
        rim_near: rim_near.copied(),
        apex: apex.copied(),
    };
    let RimPick {
        loops,
        rim,
        chosen_by,
        distances_mm: distances,
        shapes: shape,
        facing,
        anatomy,
    } = choose_rim(surface, &hint, snap_mm)?;
    let mut gates = Gates::new();
    // The rim's perimeter over the anatomy's choice's (the larger of a tie).
    let reference = match anatomy {
        None => rim,
        Some(Ok(j)) | Some(Err([j, _])) => j,
    };
    let agrees = shape[rim].0 / shape[reference].0;
    gates.fallback(
        "base.rim_agrees",
        agrees,
        Requirement::Within(SAME_SIZE_RATIO, 1.0),
        match chosen_by {
            RimChoice::RimNear => "kept the opening --rim-near names",
            _ => "kept the opening the rim landmarks name (no --apex to check them against)",
        },
    );
    let pos = &surface.positions;
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
            facing_apex: facing[j],
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
        gates,
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
        let c = cap_openings(&v.surface, &v.anterior, &v.inferior, None, None, 5.0).unwrap();
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
        let c = cap_openings(&s, &v.anterior, &v.inferior, None, Some(&v.apex), 5.0).unwrap();
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
        let r = cap_openings(&s, &v.anterior, &v.inferior, Some(&near), None, 5.0).unwrap();
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
        let c = cap_openings(&s, &v.anterior, &v.inferior, Some(&near), None, 5.0).unwrap();
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
        match cap_openings(&s, &v.anterior, &v.inferior, Some(&far), None, 5.0) {
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
            cap_openings(&s, &v.anterior, &v.inferior, Some(&nan), None, 5.0),
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
        match cap_openings(&s, &v.anterior, &v.inferior, Some(&mid), None, 5.0) {
            Err(OrganError::Ventricle(e @ VentricleError::AmbiguousRim { .. })) => {
                let VentricleError::AmbiguousRim {
                    by,
                    nearest,
                    distances_mm,
                    openings,
                    ..
                } = &e
                else {
                    unreachable!()
                };
                assert_eq!(*by, RimChoice::RimNear);
                assert_eq!(distances_mm.len(), 2);
                let mut n = *nearest;
                n.sort();
                assert_eq!(n, [0, 1]);
                assert_eq!(openings[0].index, nearest[0]);
                let m = e.to_string();
                assert!(m.contains("ambiguous") && m.contains("mm around"), "{m}");
                assert!(m.contains("--rim-near") && !m.contains('\n'), "{m}");
            }
            other => panic!("{other:?}"),
        }
        // rim landmarks there are ambiguous too, and the anatomy settles
        // them: the base is far the larger opening
        let c = cap_openings(&s, &mid, &mid, None, None, 5.0).unwrap();
        assert_eq!(c.openings.chosen_by, RimChoice::Anatomy);
        assert_eq!(c.openings.loops[c.openings.rim].vertices, v.rim.len());
        assert!(c.gates.all_passed());
    }

    /// The cup with a hole in its wall: rim landmarks on the hole name it
    /// (the base is capped) without an apex, are refused against the
    /// anatomy with one, and without landmarks the anatomy picks the base.
    #[test]
    fn the_anatomy_checks_the_landmarks_and_picks_the_base_without_them() {
        let v = cup();
        let s = holed(&v.surface, &[wall(&v.surface, 2.0, -25.0)], 6.0);
        let loops = boundary_loops(&s).unwrap();
        let hole = loops.iter().find(|l| l.len() != v.rim.len()).unwrap();
        let (a, i) = (s.positions[hole[0] as usize], s.positions[hole[3] as usize]);
        let c = cap_openings(&s, &a, &i, None, None, 5.0).unwrap();
        assert_eq!(c.openings.chosen_by, RimChoice::Landmarks);
        assert_eq!(c.openings.loops[c.openings.rim].vertices, hole.len());
        // no apex to check them: kept, and the gate records it
        let g = c.gates.get("base.rim_agrees").unwrap();
        assert!(!g.passed && g.fallback.is_some() && g.value < 0.5, "{g:?}");
        match cap_openings(&s, &a, &i, None, Some(&v.apex), 5.0) {
            Err(OrganError::Ventricle(e @ VentricleError::RimDisagrees { .. })) => {
                let m = e.to_string();
                assert!(m.contains("--rim-near") && m.contains("opening 0 ("), "{m}");
                assert!(m.contains(&format!("{} vertices", v.rim.len())), "{m}");
            }
            other => panic!("{other:?}"),
        }
        let hint = RimHint {
            apex: Some(v.apex),
            ..RimHint::default()
        };
        let p = choose_rim(&s, &hint, 5.0).unwrap();
        assert_eq!(p.chosen_by, RimChoice::Anatomy);
        assert_eq!(p.loops[p.rim].len(), v.rim.len());
        // the base faces away from the apex, the hole in the wall does not
        assert!(p.facing[p.rim] > 0.99, "{:?}", p.facing);
        assert!(p.facing[1 - p.rim] < FACING_MIN, "{:?}", p.facing);
        // the rim landmarks on the base agree with the anatomy
        let c = cap_openings(&s, &v.anterior, &v.inferior, None, Some(&v.apex), 5.0).unwrap();
        assert_eq!(c.openings.chosen_by, RimChoice::Landmarks);
        assert_eq!(c.gates.get("base.rim_agrees").unwrap().value, 1.0);
    }

    /// An open tube: two openings of one size, both facing away from an
    /// apex on the axis; without a landmark the choice is refused naming
    /// both and `--rim-near`.
    #[test]
    fn two_openings_of_one_size_are_refused_without_a_landmark() {
        let n = 24u32;
        let mut pos = Vec::new();
        for z in [0.0, 5.0, 10.0] {
            for k in 0..n {
                let t = k as f64 * std::f64::consts::TAU / n as f64;
                pos.push(Point3::new(10.0 * t.cos(), 10.0 * t.sin(), z));
            }
        }
        let mut tris = Vec::new();
        for i in 0..2 {
            for k in 0..n {
                let (a, b) = (i * n + k, i * n + (k + 1) % n);
                tris.push([a, b, b + n]);
                tris.push([a, b + n, a + n]);
            }
        }
        let s = TriMesh::new(pos, tris);
        let hint = RimHint {
            apex: Some(Point3::new(0.0, 0.0, 4.0)),
            ..RimHint::default()
        };
        match choose_rim(&s, &hint, 1.0) {
            Err(OrganError::Ventricle(e @ VentricleError::OpeningsTie { .. })) => {
                let m = e.to_string();
                assert!(m.contains("opening 0 (24 vertices") && m.contains("opening 1 ("));
                assert!(m.contains("--rim-near") && m.contains("face away"), "{m}");
                assert!(m.contains("centre ") && !m.contains('\n'), "{m}");
            }
            other => panic!("{other:?}"),
        }
        // the centre of one opening names it
        let hint = RimHint {
            rim_near: Some(Point3::new(0.0, 0.0, 10.0)),
            ..hint
        };
        let p = choose_rim(&s, &hint, 1.0).unwrap();
        assert_eq!(p.chosen_by, RimChoice::RimNear);
        assert!((p.shapes[p.rim].1.z - 10.0).abs() < 1e-9);
        assert!(p.distances_mm[p.rim] < 1e-9);
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
            cap_openings(&closed, &v.anterior, &v.inferior, None, None, 5.0),
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
        match cap_openings(&s, &a, &i, None, None, 1.0) {
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
        match cap_openings(&s, &top, &other, None, None, 1.0) {
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
        let c = cap_openings(&straight, &top, &other, None, None, 1.0).unwrap();
        assert_eq!(c.openings.cap_triangles, n as usize);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// A point on the disk one opening spans (anywhere between its
        /// centre and its ring), moved by less than a millimetre, names
        /// that opening.
        #[test]
        fn a_point_on_an_openings_disk_names_it(
            which in 0usize..2,
            k in 0usize..1000,
            s in 0.0..1.0f64,
            t in 0.0..1.0f64,
            off in prop::array::uniform3(-0.5..0.5f64),
        ) {
            let v = cup();
            let surface = holed(&v.surface, &[wall(&v.surface, 2.0, -25.0)], 6.0);
            let pos = &surface.positions;
            let loops = boundary_loops(&surface).unwrap();
            let l = &loops[which];
            let (_, c) = perimeter_centroid(pos, l);
            let (a, b) = (pos[l[k % l.len()] as usize], pos[l[(k + 1) % l.len()] as usize]);
            // a point of the fan triangle (c, a, b)
            let (s, t) = if s + t > 1.0 { (1.0 - s, 1.0 - t) } else { (s, t) };
            let p = c + (a - c) * s + (b - c) * t + Vector3::from(off);
            let hint = RimHint { rim_near: Some(p), apex: Some(v.apex), ..RimHint::default() };
            let pick = choose_rim(&surface, &hint, 5.0).unwrap();
            prop_assert_eq!(pick.rim, which);
            prop_assert_eq!(pick.chosen_by, RimChoice::RimNear);
            prop_assert!(pick.distances_mm[which] < 0.9);
        }

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
            let c = cap_openings(&s, &v.anterior, &v.inferior, None, None, 5.0).unwrap();
            check(&s, &c, &as_points(&v.surface, &v.rim));
            prop_assert_eq!(c.openings.chosen_by, RimChoice::Landmarks);
        }
    }
}
