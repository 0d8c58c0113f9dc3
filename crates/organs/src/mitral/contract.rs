//! The mitral valve input contract (ALGORITHMS 4): from two leaflet
//! surfaces and an annulus ring in any order to a [`PreparedValve`] whose
//! ring runs clockwise seen from the atrium from the anterolateral
//! commissure, with each leaflet's annulus vertices, their positions along
//! the ring and its free edge.
//!
//! [`prepare`] works in six steps. `L` is the ring length, `tol` the
//! tolerance (mm), `eps = 1e-9 L`.
//!
//! 1. **Validation.** `tol` is finite and `> 0` ([`OrganError::Config`]).
//!    The ring (after dropping one closing point equal to the first) has at
//!    least 6 points, all finite, no two consecutive ones equal (the last
//!    and the first included), and does not lie on a line. Each leaflet
//!    passes [`TriMesh::validate`] (default options: **unused vertices are
//!    rejected**, as are degenerate triangles, several components and
//!    inconsistent orientation; reported as
//!    [`ContractError::LeafletMesh`] naming the leaflet) and is a disk: exactly one boundary
//!    loop ([`boundary_loops`]) and Euler characteristic
//!    `χ = V - E + F = 1` ([`euler_characteristic`]).
//! 2. **Annulus vertices.** The ring is the closed polyline
//!    `p_0 p_1 ... p_{n-1} p_0` with cumulative lengths
//!    `c_0 = 0, c_{i+1} = c_i + |p_{i+1} - p_i|`, `L = c_n`. A point `q` is
//!    projected on every segment, `t_i = clamp((q - p_i)·(p_{i+1} - p_i) /
//!    |p_{i+1} - p_i|^2, 0, 1)`, and the closest one gives the distance
//!    `d(q) = |q - p_i - t_i (p_{i+1} - p_i)|` and the ring position
//!    `s(q) = c_i + t_i |p_{i+1} - p_i|` (`O(n)` per point). A leaflet's
//!    annulus vertices are its boundary-loop vertices with `d <= tol`; they
//!    must form exactly one contiguous stretch of the cyclic loop, of at
//!    least 2 vertices and not the whole loop.
//! 3. **Progress.** Along the stretch the steps `Δ_j = wrap(s_{j+1} - s_j)`,
//!    `wrap(x) = x - L round(x / L)`, give the direction: the stretch is
//!    reversed when `Σ Δ_j < 0`. Its ends are then trimmed where the
//!    boundary leaves the ring: while at least 2 vertices remain, an end
//!    vertex `w` whose neighbour one step inside is `u` moves to the free
//!    edge when `Δ(u, w) <= max(d(w) - d(u), 0)`, `Δ(u, w)` the step along
//!    the ring outwards from `u` to `w` in the stretch's direction: it does
//!    not advance along the ring by more than it moves away from it (the
//!    side of a leaflet leaving a commissure nearly perpendicular to the
//!    ring stays within `tol` of it for a vertex or two on a fine mesh, and
//!    projects back onto the leaflet's own arc). Then every step must be
//!    `>= -tol` (small back-steps of a noisy boundary are tolerated and
//!    removed in step 6) and the covered arc, from `s_first` of extent
//!    `e = Σ Δ_j`, must satisfy `tol < e < L`.
//! 4. **Junctions (commissures).** With the anterior arc `[a_0, a_1 = a_0 +
//!    e_A]` and the posterior arc `[p_0, p_1 = p_0 + e_P]` (all modulo `L`),
//!    the two candidate junctions are (end of anterior, start of posterior)
//!    and (end of posterior, start of anterior). Each gets the tolerance
//!    `tol_J = max(tol, 1.5 h)`, `h` the longest of: the ring segments next
//!    to either end (the segment holding the position, and its neighbour
//!    when the position is within `eps` of a ring vertex) and the two
//!    leaflets' annulus edges at that end (the leaflets' own sampling along
//!    the ring). So two leaflets that stop one ring segment (or one of their
//!    own edges) short of each other still meet. With `x = (p_0 - a_0) mod
//!    L` (in `[0, L)`), the signed gap from the end of the anterior arc to
//!    the start of the posterior one is `g = x - e_A`:
//!    - `g < 0`: the posterior arc starts inside the anterior one, and both
//!      claim `min(-g, e_P)` mm of ring; more than `tol_J` is an error
//!      (overlapping arcs);
//!    - the junction is matched when `|g| <= tol_J`.
//!
//!    Likewise with the roles swapped for the other junction.
//!    Exactly two junctions must match. The commissure is the midpoint of
//!    the matched ends on the ring, `a_1 + g / 2` (resp. `p_1 + g / 2`).
//! 5. **Atrial side.** `atrium` is the smallest-variance axis of the PCA of
//!    the ring points (the normal of their least-squares plane), oriented so
//!    that the mean `m` of both leaflets' free-edge vertices lies on its
//!    negative side: `atrium · (m - c) < 0`, `c` the ring's vertex mean.
//!    (The free edges hang deepest into the ventricle; the leaflets' area
//!    centroid would follow a prolapsing leaflet through the plane.)
//! 6. **Order.** The signed area about the atrium,
//!    `A = 1/2 Σ_i ((p_i - c) × (p_{i+1} - c)) · atrium`, is negative for a
//!    ring clockwise seen from the atrium; the ring is reversed when
//!    `A > 0`. The anterolateral commissure is the one that the anterior arc
//!    follows going clockwise. Each commissure is inserted into its segment
//!    unless it lies within `eps` (along the ring) of a ring vertex, which
//!    then stands for it; the ring is rotated to start at the anterolateral
//!    commissure, so `ring[0]` and `ring[posteromedial]` are exactly the
//!    commissures. Each annulus vertex is projected again on its own arc of
//!    the new ring (anterior: segments `0..posteromedial`, posterior:
//!    `posteromedial..n`), positions within `eps` of a ring vertex are
//!    snapped to it (so a vertex at the anterolateral commissure gets 0 on
//!    the anterior leaflet and `L` on the posterior one), and a running
//!    maximum makes `annulus_s` non-decreasing.
//!
//! The leaflets' boundary loops may run either way: each leaflet's
//! `annulus` is listed in ring order (anterior from the anterolateral to the
//! posteromedial commissure, posterior from the posteromedial to the
//! anterolateral one), and its `free_edge` continues the loop in that same
//! direction, so `annulus` followed by `free_edge` is the whole boundary
//! loop.

use super::{ANTERIOR, ContractError, Leaflet, LeafletSide, POSTERIOR, PreparedValve, ValveInput};
use crate::OrganError;
use std::ops::Range;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::{PcaFrame, closest_point_on_segment, pca_frame};
use unfold_mesh::nalgebra::{Point3, Vector3};
use unfold_mesh::topology::{boundary_loops, euler_characteristic};

/// Default tolerance for "a leaflet boundary vertex lies on the ring", mm.
pub const DEFAULT_TOLERANCE_MM: f64 = 0.5;

/// Minimum number of (distinct) ring points.
const MIN_RING_POINTS: usize = 6;

/// Positions along the ring closer than `SNAP_REL × L` are the same.
const SNAP_REL: f64 = 1e-9;

/// A junction's tolerance in units of the longest segment next to it.
const JUNCTION_FACTOR: f64 = 1.5;

/// Checks and orders the valve: validates the inputs, finds each leaflet's
/// annulus vertices on the ring, the two commissures and the atrial side,
/// and reorders the ring clockwise seen from the atrium from the
/// anterolateral commissure (see the [module docs](self) for the rules).
///
/// `tolerance_mm` is how far a leaflet boundary vertex may be from the ring
/// and still count as attached to it ([`DEFAULT_TOLERANCE_MM`]).
///
/// # Errors
/// [`OrganError::Config`] for a tolerance that is not finite and positive;
/// a [`ContractError`] (in [`OrganError::Mitral`]) for everything that does
/// not fit: a leaflet that fails mesh validation
/// ([`ContractError::LeafletMesh`], naming the leaflet), a ring too short or
/// not finite, a leaflet that is not a disk or does not touch the ring in
/// exactly one stretch, arcs that overlap or do not meet at two
/// commissures, an undecidable atrial side.
pub fn prepare(input: &ValveInput<'_>, tolerance_mm: f64) -> Result<PreparedValve, OrganError> {
    let tol = tolerance_mm;
    OrganError::check_positive(&[("tolerance_mm", tol)])?;
    let ring = Ring::new(ring_points(input.annulus)?)?;
    let frame = ring_frame(&ring)?;
    let meshes = [input.anterior, input.posterior];
    // Each leaflet's checks and attachment to the ring, in parallel (the
    // anterior leaflet's error first when both fail).
    let one = |k: usize| -> Result<Attachment, ContractError> {
        let leaflet = LeafletSide::of(k);
        let lp = disk_boundary(leaflet, meshes[k])?;
        attach(leaflet, meshes[k], &lp, &ring, tol)
    };
    let (a, p) = rayon::join(|| one(ANTERIOR), || one(POSTERIOR));
    let att = [a?, p?];
    let [c1, c2] = commissures(&att, &ring, tol)?;
    let (atrium, clockwise) = atrial_side(&ring, &frame, &meshes, &att)?;

    // c2 ends the posterior arc and starts the anterior one (in input order).
    let (al, pm) = if clockwise { (c2, c1) } else { (c1, c2) };
    let (out, posteromedial) = reorder(&ring, al, pm, clockwise)?;
    let out = Ring::new(out)?;
    let n = out.pts.len();
    let ranges = [0..posteromedial, posteromedial..n];
    let leaflets = [ANTERIOR, POSTERIOR].map(|k| {
        let a = &att[k];
        let (mut annulus, mut free_edge) = (a.cycle[..a.run].to_vec(), a.cycle[a.run..].to_vec());
        if !clockwise {
            annulus.reverse();
            free_edge.reverse();
        }
        let mut annulus_s: Vec<f64> = annulus
            .iter()
            .map(|&v| out.position_on(&meshes[k].positions[v as usize], ranges[k].clone()))
            .collect();
        for j in 1..annulus_s.len() {
            annulus_s[j] = annulus_s[j].max(annulus_s[j - 1]);
        }
        Leaflet {
            mesh: meshes[k].clone(),
            annulus,
            annulus_s,
            free_edge,
        }
    });
    Ok(PreparedValve {
        ring: out.pts,
        posteromedial,
        atrium,
        leaflets,
        tolerance_mm: tol,
    })
}

/// The ring points after the checks of step 1 (closing point dropped).
fn ring_points(points: &[Point3<f64>]) -> Result<Vec<Point3<f64>>, ContractError> {
    if let Some((index, p)) = points
        .iter()
        .enumerate()
        .find(|(_, p)| !p.coords.iter().all(|x| x.is_finite()))
    {
        return Err(ContractError::RingPointNotFinite {
            index,
            point: [p.x, p.y, p.z],
        });
    }
    let mut pts = points.to_vec();
    let closed = pts.len() > 1 && pts.first() == pts.last();
    if closed {
        pts.pop();
    }
    if pts.len() < MIN_RING_POINTS {
        return Err(ContractError::TooFewRingPoints {
            count: pts.len(),
            min: MIN_RING_POINTS,
            closing_point_dropped: closed,
        });
    }
    let n = pts.len();
    for i in 0..n {
        let j = (i + 1) % n;
        if pts[i] == pts[j] {
            let p = pts[i];
            return Err(ContractError::EqualConsecutiveRingPoints {
                first: i,
                second: j,
                point: [p.x, p.y, p.z],
            });
        }
    }
    Ok(pts)
}

/// The closed annulus polyline with its cumulative arc lengths.
struct Ring {
    /// The points (not closed).
    pts: Vec<Point3<f64>>,
    /// `lens[i] = |pts[i + 1] - pts[i]|` (cyclic).
    lens: Vec<f64>,
    /// `cum[0] = 0`, `cum[i + 1] = cum[i] + lens[i]`; `cum[n] = L`.
    cum: Vec<f64>,
}

impl Ring {
    /// The ring over `pts` (at least 2 distinct consecutive points each).
    fn new(pts: Vec<Point3<f64>>) -> Result<Self, ContractError> {
        let n = pts.len();
        let lens: Vec<f64> = (0..n).map(|i| (pts[(i + 1) % n] - pts[i]).norm()).collect();
        let mut cum = Vec::with_capacity(n + 1);
        cum.push(0.0);
        for (i, l) in lens.iter().enumerate() {
            cum.push(cum[i] + l);
        }
        let ring = Ring { pts, lens, cum };
        let len = ring.length();
        if !(len.is_finite() && len > 0.0) {
            return Err(ContractError::RingLength { length_mm: len });
        }
        Ok(ring)
    }

    fn n(&self) -> usize {
        self.pts.len()
    }

    /// `L`.
    fn length(&self) -> f64 {
        self.cum[self.n()]
    }

    /// `eps = SNAP_REL × L`.
    fn eps(&self) -> f64 {
        SNAP_REL * self.length()
    }

    /// `x mod L` in `[0, L)`.
    fn modulo(&self, x: f64) -> f64 {
        let l = self.length();
        let r = x.rem_euclid(l);
        if r >= l { 0.0 } else { r }
    }

    /// `x - L round(x / L)`, in `[-L/2, L/2]`.
    fn wrap(&self, x: f64) -> f64 {
        let l = self.length();
        x - l * (x / l).round()
    }

    /// The closest point of `q` on the segments `segs`: `(distance,
    /// segment, t)`.
    fn closest(&self, q: &Point3<f64>, segs: Range<usize>) -> (f64, usize, f64) {
        let n = self.n();
        let mut best = (f64::INFINITY, segs.start, 0.0);
        for i in segs {
            let (c, t) = closest_point_on_segment(q, &self.pts[i], &self.pts[(i + 1) % n]);
            let dist = (q - c).norm();
            if dist < best.0 {
                best = (dist, i, t);
            }
        }
        best
    }

    /// Distance to the whole ring and position `s` in `[0, L)`.
    fn project(&self, q: &Point3<f64>) -> (f64, f64) {
        let (dist, i, t) = self.closest(q, 0..self.n());
        (dist, self.modulo(self.cum[i] + t * self.lens[i]))
    }

    /// Position of `q` projected on the segments `segs`, snapped to a ring
    /// vertex within `eps` (to `cum[i + 1]`, up to `L`, at a segment's end).
    fn position_on(&self, q: &Point3<f64>, segs: Range<usize>) -> f64 {
        let (_, i, t) = self.closest(q, segs);
        let off = t * self.lens[i];
        if off <= self.eps() {
            self.cum[i]
        } else if self.lens[i] - off <= self.eps() {
            self.cum[i + 1]
        } else {
            self.cum[i] + off
        }
    }

    /// The segment holding position `s` in `[0, L)`.
    fn segment_of(&self, s: f64) -> usize {
        let i = self.cum.partition_point(|&c| c <= s);
        i.saturating_sub(1).min(self.n() - 1)
    }

    /// The longest ring segment next to position `s`: its own segment, and
    /// the neighbouring one when `s` is within `eps` of a ring vertex.
    fn segments_near(&self, s: f64) -> f64 {
        let n = self.n();
        let i = self.segment_of(s);
        let mut h = self.lens[i];
        if s - self.cum[i] <= self.eps() {
            h = h.max(self.lens[(i + n - 1) % n]);
        }
        if self.cum[i + 1] - s <= self.eps() {
            h = h.max(self.lens[(i + 1) % n]);
        }
        h
    }
}

/// Step 1 for a leaflet: valid mesh and disk topology; its boundary loop.
pub(super) fn disk_boundary(
    leaflet: LeafletSide,
    mesh: &TriMesh,
) -> Result<Vec<u32>, ContractError> {
    mesh.validate()
        .map_err(|source| ContractError::LeafletMesh { leaflet, source })?;
    let loops = boundary_loops(mesh)
        .map_err(|source| ContractError::LeafletBoundary { leaflet, source })?;
    if loops.len() != 1 {
        return Err(ContractError::BoundaryLoops {
            leaflet,
            loop_sizes: loops.iter().map(Vec::len).collect(),
        });
    }
    let chi = euler_characteristic(mesh);
    if chi != 1 {
        return Err(ContractError::EulerCharacteristic {
            leaflet,
            euler_characteristic: chi,
        });
    }
    Ok(loops.into_iter().next().unwrap_or_default())
}

/// How a leaflet sits on the ring (steps 2 and 3), in the input ring's
/// parameter.
struct Attachment {
    /// The boundary loop oriented so that the annulus stretch runs towards
    /// increasing ring position, rotated to start with it.
    cycle: Vec<u32>,
    /// Number of annulus vertices (`cycle[..run]`).
    run: usize,
    /// Ring position of the first annulus vertex, `[0, L)`.
    start: f64,
    /// Arc length covered, `0 < extent < L`.
    extent: f64,
    /// 3D lengths of the first and the last annulus edge.
    end_edges: [f64; 2],
}

/// Steps 2 and 3 for one leaflet.
fn attach(
    leaflet: LeafletSide,
    mesh: &TriMesh,
    lp: &[u32],
    ring: &Ring,
    tol: f64,
) -> Result<Attachment, ContractError> {
    let m = lp.len();
    let pos = |v: u32| mesh.positions[v as usize];
    let proj: Vec<(f64, f64)> = lp.iter().map(|&v| ring.project(&pos(v))).collect();
    let on: Vec<bool> = proj.iter().map(|&(d, _)| d <= tol).collect();
    let count = on.iter().filter(|&&b| b).count();
    if count == 0 {
        let closest = proj.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
        return Err(ContractError::LeafletOffRing {
            leaflet,
            closest_mm: closest,
            tolerance_mm: tol,
        });
    }
    if count == m {
        return Err(ContractError::NoFreeEdge {
            leaflet,
            boundary_vertices: m,
            tolerance_mm: tol,
        });
    }
    let starts: Vec<usize> = (0..m).filter(|&i| on[i] && !on[(i + m - 1) % m]).collect();
    let run_len = |s: usize| (0..m).take_while(|&j| on[(s + j) % m]).count();
    if starts.len() > 1 {
        return Err(ContractError::SeveralStretches {
            leaflet,
            stretches: starts.iter().map(|&s| run_len(s)).collect(),
            tolerance_mm: tol,
        });
    }
    let start = starts[0];
    let run = run_len(start);
    if run < 2 {
        return Err(ContractError::SingleVertexOnRing {
            leaflet,
            vertex: lp[start],
            tolerance_mm: tol,
        });
    }
    let mut cycle: Vec<u32> = (0..m).map(|j| lp[(start + j) % m]).collect();
    let mut s: Vec<f64> = (0..run).map(|j| proj[(start + j) % m].1).collect();
    let mut d: Vec<f64> = (0..run).map(|j| proj[(start + j) % m].0).collect();
    let total: f64 = s.windows(2).map(|w| ring.wrap(w[1] - w[0])).sum();
    if total < 0.0 {
        cycle[..run].reverse();
        cycle[run..].reverse();
        s.reverse();
        d.reverse();
    }
    // Trim ends that leave the ring: the end vertex `w` next to `u` (one
    // step inside) is dropped when it does not advance along the ring by
    // more than it moves away from it.
    let leaves = |w: usize, u: usize, along: f64| along <= (d[w] - d[u]).max(0.0);
    let (mut lo, mut hi) = (0, run);
    while hi - lo > 2 && leaves(lo, lo + 1, ring.wrap(s[lo + 1] - s[lo])) {
        lo += 1;
    }
    while hi - lo > 2 && leaves(hi - 1, hi - 2, ring.wrap(s[hi - 1] - s[hi - 2])) {
        hi -= 1;
    }
    cycle.rotate_left(lo);
    let s = &s[lo..hi];
    let run = hi - lo;
    let mut extent = 0.0;
    for j in 0..run - 1 {
        let step = ring.wrap(s[j + 1] - s[j]);
        if step < -tol {
            return Err(ContractError::AnnulusStepsBack {
                leaflet,
                from: cycle[j],
                to: cycle[j + 1],
                back_mm: -step,
                tolerance_mm: tol,
            });
        }
        extent += step;
    }
    let l = ring.length();
    if extent <= tol {
        return Err(ContractError::ArcTooShort {
            leaflet,
            annulus_vertices: run,
            extent_mm: extent,
            tolerance_mm: tol,
        });
    }
    if extent >= l {
        return Err(ContractError::ArcTooLong {
            leaflet,
            extent_mm: extent,
            ring_length_mm: l,
        });
    }
    let edge = |a: u32, b: u32| (pos(a) - pos(b)).norm();
    Ok(Attachment {
        end_edges: [
            edge(cycle[0], cycle[1]),
            edge(cycle[run - 2], cycle[run - 1]),
        ],
        cycle,
        run,
        start: s[0],
        extent,
    })
}

/// Step 4: the two commissures as input ring positions `[c1, c2]`: `c1`
/// ends the anterior arc (in increasing position) and starts the posterior
/// one, `c2` ends the posterior arc and starts the anterior one.
fn commissures(att: &[Attachment; 2], ring: &Ring, tol: f64) -> Result<[f64; 2], ContractError> {
    // Junction k: the end of arc `from` meets the start of arc `to`.
    let mut gaps = [0.0; 2];
    let mut tols = [0.0; 2];
    let mut mids = [0.0; 2];
    for (k, (from, to)) in [(ANTERIOR, POSTERIOR), (POSTERIOR, ANTERIOR)]
        .into_iter()
        .enumerate()
    {
        let (f, t) = (&att[from], &att[to]);
        let end = ring.modulo(f.start + f.extent);
        let h = ring
            .segments_near(end)
            .max(ring.segments_near(t.start))
            .max(f.end_edges[1])
            .max(t.end_edges[0]);
        tols[k] = tol.max(JUNCTION_FACTOR * h);
        // Signed gap from the end of `from` to the start of `to`: negative
        // when `to` starts inside `from`.
        let x = ring.modulo(t.start - f.start);
        let gap = x - f.extent;
        if gap < 0.0 {
            let overlap = (-gap).min(t.extent);
            if overlap > tols[k] {
                return Err(ContractError::ArcsOverlap {
                    overlap_mm: overlap,
                    allowed_mm: tols[k],
                });
            }
        }
        gaps[k] = gap;
        mids[k] = ring.modulo(end + 0.5 * gap);
    }
    let matched = (0..2).filter(|&k| gaps[k].abs() <= tols[k]).count();
    if matched != 2 {
        return Err(ContractError::CommissureCount {
            matched,
            gaps_mm: gaps,
            allowed_mm: tols,
        });
    }
    Ok(mids)
}

/// The ring's principal axes (step 1 checks that it is not a line).
fn ring_frame(ring: &Ring) -> Result<PcaFrame, ContractError> {
    let frame = pca_frame(&ring.pts).ok_or(ContractError::RingPlaneUndefined)?;
    let [v0, v1, _] = frame.variances;
    if v1.is_nan() || v1 <= 1e-12 * v0 {
        return Err(ContractError::RingOnALine {
            spreads_mm: [v0.sqrt(), v1.sqrt()],
        });
    }
    Ok(frame)
}

/// Step 5 and the direction test of step 6: the unit normal towards the
/// atrium and whether the input ring runs clockwise seen from it.
fn atrial_side(
    ring: &Ring,
    frame: &PcaFrame,
    meshes: &[&TriMesh; 2],
    att: &[Attachment; 2],
) -> Result<(Vector3<f64>, bool), ContractError> {
    let v0 = frame.variances[0];
    let mut n = frame.axis(2);
    let c = frame.centroid;
    // The free edges (the leaflets' boundary off the ring) hang deepest into
    // the ventricle; their mean is a steadier cue than the leaflets' area
    // centroid, which a prolapsing (billowing) leaflet can lift through the
    // annulus plane.
    let mut count = 0usize;
    let mut acc = Vector3::zeros();
    for (mesh, a) in meshes.iter().zip(att) {
        for &v in &a.cycle[a.run..] {
            acc += mesh.positions[v as usize].coords;
            count += 1;
        }
    }
    let side = if count > 0 {
        (acc / count as f64 - c.coords).dot(&n)
    } else {
        f64::NAN
    };
    let scale = v0.sqrt();
    if side.is_nan() || side.abs() <= 1e-9 * scale {
        return Err(ContractError::AtrialSideUndecided {
            mean_offset_mm: side,
        });
    }
    if side > 0.0 {
        n = -n;
    }
    let k = ring.n();
    let area: f64 = 0.5
        * (0..k)
            .map(|i| {
                (ring.pts[i] - c)
                    .cross(&(ring.pts[(i + 1) % k] - c))
                    .dot(&n)
            })
            .sum::<f64>();
    let l = ring.length();
    if area.is_nan() || area.abs() <= 1e-9 * l * l {
        return Err(ContractError::RingEnclosesNoArea {
            signed_area_mm2: area,
        });
    }
    Ok((n, area < 0.0))
}

/// Step 6: the ring with the commissures at positions `al` and `pm`
/// (input ring positions) inserted or snapped, clockwise from `al`; also
/// the index of `pm`.
fn reorder(
    ring: &Ring,
    al: f64,
    pm: f64,
    clockwise: bool,
) -> Result<(Vec<Point3<f64>>, usize), ContractError> {
    let n = ring.n();
    let eps = ring.eps();
    // (position, point, commissure tag: 0 = AL, 1 = PM)
    let mut entries: Vec<(f64, Point3<f64>, [bool; 2])> = (0..n)
        .map(|i| (ring.cum[i], ring.pts[i], [false; 2]))
        .collect();
    for (tag, s) in [al, pm].into_iter().enumerate() {
        let i = ring.segment_of(s);
        let off = s - ring.cum[i];
        let at = if off <= eps {
            Some(i)
        } else if ring.cum[i + 1] - s <= eps {
            Some((i + 1) % n)
        } else {
            None
        };
        match at {
            Some(v) => entries[v].2[tag] = true,
            None => {
                let a = ring.pts[i];
                let d = ring.pts[(i + 1) % n] - a;
                let mut flags = [false; 2];
                flags[tag] = true;
                entries.push((s, a + d * (off / ring.lens[i]), flags));
            }
        }
    }
    entries.sort_by(|a, b| a.0.total_cmp(&b.0));
    let find = |tag: usize| entries.iter().position(|e| e.2[tag]);
    let (Some(ial), Some(ipm)) = (find(0), find(1)) else {
        return Err(ContractError::CommissuresNotPlaced);
    };
    if ial == ipm {
        return Err(ContractError::CommissuresCoincide { ring_point: ial });
    }
    let m = entries.len();
    let order: Vec<usize> = if clockwise {
        (0..m).map(|j| (ial + j) % m).collect()
    } else {
        (0..m).map(|j| (ial + m - j) % m).collect()
    };
    let posteromedial = order.iter().position(|&e| e == ipm).unwrap_or(0);
    Ok((order.iter().map(|&e| entries[e].1).collect(), posteromedial))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitral::MitralError;
    use proptest::prelude::*;
    use unfold_mesh::MeshError;
    use unfold_mesh::shapes::{Pose, ValveParams, ValveShape, mitral_valve};

    fn valve(p: ValveParams) -> ValveShape {
        mitral_valve(&p).unwrap()
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
            annulus_segments: 192,
            depth_segments: 24,
            ..ValveParams::default()
        }
    }

    /// The generator's ring rotated to start at `rot`, reversed and / or
    /// closed with a repeated first point.
    fn given_ring(shape: &ValveShape, rot: usize, reverse: bool, close: bool) -> Vec<Point3<f64>> {
        let n = shape.annulus.len();
        let mut r: Vec<Point3<f64>> = (0..n).map(|i| shape.annulus[(rot + i) % n]).collect();
        if reverse {
            r.reverse();
        }
        if close {
            r.push(r[0]);
        }
        r
    }

    fn run(
        anterior: &TriMesh,
        posterior: &TriMesh,
        ring: &[Point3<f64>],
    ) -> Result<PreparedValve, OrganError> {
        prepare(
            &ValveInput {
                anterior,
                posterior,
                annulus: ring,
            },
            DEFAULT_TOLERANCE_MM,
        )
    }

    /// The contract error of `r` and its message (one line).
    fn contract_err(r: Result<PreparedValve, OrganError>) -> (ContractError, String) {
        match r {
            Err(OrganError::Mitral(MitralError::Contract(e))) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n'), "{msg}");
                (e, msg)
            }
            other => panic!("expected a contract error, got {other:?}"),
        }
    }

    /// True when `seq` is the cyclic sequence `lp`, in either direction.
    fn same_cycle(seq: &[u32], lp: &[u32]) -> bool {
        let m = lp.len();
        if seq.len() != m {
            return false;
        }
        let Some(i) = lp.iter().position(|&v| v == seq[0]) else {
            return false;
        };
        let fwd = (0..m).all(|j| seq[j] == lp[(i + j) % m]);
        let bwd = (0..m).all(|j| seq[j] == lp[(i + m - j) % m]);
        fwd || bwd
    }

    /// Checks everything `prepare` promises against the generator's ground
    /// truth.
    fn check_against(shape: &ValveShape, v: &PreparedValve) {
        assert_eq!(v.ring, shape.annulus);
        assert_eq!(v.posteromedial, shape.commissures[1]);
        let angle = v.atrium.angle(&shape.atrium_direction).to_degrees();
        assert!(angle < 2.0, "atrium {angle} degrees off");
        assert!((v.atrium.norm() - 1.0).abs() < 1e-12);
        assert_eq!(v.leaflets[ANTERIOR].annulus, shape.anterior_annulus);
        assert_eq!(v.leaflets[POSTERIOR].annulus, shape.posterior_annulus);
        let n = v.ring.len();
        let mut cum = vec![0.0];
        for i in 0..n {
            let last = cum[i];
            cum.push(last + (v.ring[(i + 1) % n] - v.ring[i]).norm());
        }
        let l = cum[n];
        let truth = [
            (&shape.anterior, &shape.anterior_annulus_ring),
            (&shape.posterior, &shape.posterior_annulus_ring),
        ];
        for (k, lf) in v.leaflets.iter().enumerate() {
            let (mesh, ring_idx) = truth[k];
            assert_eq!(&lf.mesh, mesh);
            assert_eq!(lf.annulus_s.len(), lf.annulus.len());
            assert!(lf.annulus_s.windows(2).all(|w| w[0] <= w[1]));
            for (j, (&s, &r)) in lf.annulus_s.iter().zip(ring_idx.iter()).enumerate() {
                let expect = if k == POSTERIOR && j + 1 == ring_idx.len() {
                    l
                } else {
                    cum[r]
                };
                assert!((s - expect).abs() < 1e-9, "{k} {j}: {s} vs {expect}");
            }
            let lp = boundary_loops(mesh).unwrap().remove(0);
            let mut seq = lf.annulus.clone();
            seq.extend_from_slice(&lf.free_edge);
            assert!(same_cycle(&seq, &lp), "annulus + free edge is not the loop");
        }
        assert_eq!(v.leaflets[ANTERIOR].annulus_s[0], 0.0);
        assert_eq!(*v.leaflets[POSTERIOR].annulus_s.last().unwrap(), l);
        assert_eq!(
            v.leaflets[ANTERIOR].annulus_s.last(),
            v.leaflets[POSTERIOR].annulus_s.first()
        );
        assert_eq!(v.tolerance_mm, DEFAULT_TOLERANCE_MM);
    }

    #[test]
    fn mitral_contract_recovers_default_valve_in_any_ring_order() {
        let shape = valve(ValveParams::default());
        let n = shape.annulus.len();
        for (rot, reverse, close) in [
            (0, false, false),
            (0, true, false),
            (17, false, true),
            (n - 1, true, true),
            (shape.commissures[1], true, false),
        ] {
            let ring = given_ring(&shape, rot, reverse, close);
            let v = run(&shape.anterior, &shape.posterior, &ring).unwrap();
            check_against(&shape, &v);
        }
    }

    #[test]
    fn mitral_contract_recovers_coarse_and_fine_valves() {
        for p in [coarse(), fine()] {
            let shape = valve(p);
            let ring = given_ring(&shape, 5, true, false);
            let v = run(&shape.anterior, &shape.posterior, &ring).unwrap();
            check_against(&shape, &v);
        }
    }

    #[test]
    fn mitral_contract_atrium_is_the_lsq_normal() {
        // The saddle is symmetric about x = 0 but not about y = 0, so the
        // least-squares normal tilts slightly in the y-z plane.
        let shape = valve(ValveParams::default());
        let v = run(&shape.anterior, &shape.posterior, &shape.annulus).unwrap();
        let frame = pca_frame(&shape.annulus).unwrap();
        assert!((v.atrium.dot(&frame.axis(2)).abs() - 1.0).abs() < 1e-12);
        assert!(v.atrium.z > 0.99 && v.atrium.x.abs() < 1e-9);
        // Independently: no direction has a smaller sum of squared
        // distances `sum ((p - c) . e)^2` than the atrium.
        let c = unfold_mesh::geometry::centroid(&shape.annulus).unwrap();
        let spread = |e: &Vector3<f64>| -> f64 {
            let e = e.normalize();
            shape.annulus.iter().map(|p| (p - c).dot(&e).powi(2)).sum()
        };
        let best = spread(&v.atrium);
        for i in 0..200 {
            let (a, b) = (i as f64 * 0.7, i as f64 * 1.3);
            let e = Vector3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos());
            assert!(best <= spread(&e) + 1e-9, "{e:?}");
        }
        assert!(best < spread(&Vector3::z()));
    }

    #[test]
    fn mitral_contract_swapped_leaflets_start_at_the_other_commissure() {
        let shape = valve(ValveParams::default());
        let ring = given_ring(&shape, 11, true, false);
        let v = run(&shape.posterior, &shape.anterior, &ring).unwrap();
        let n = shape.annulus.len();
        let pm = shape.commissures[1];
        assert_eq!(v.ring[0], shape.annulus[pm]);
        assert_eq!(v.posteromedial, n - pm);
        assert_eq!(v.ring[v.posteromedial], shape.annulus[0]);
        // Still clockwise seen from the atrium: same cyclic order.
        let expect: Vec<Point3<f64>> = (0..n).map(|i| shape.annulus[(pm + i) % n]).collect();
        assert_eq!(v.ring, expect);
        assert_eq!(v.leaflets[ANTERIOR].annulus, shape.posterior_annulus);
        assert_eq!(v.leaflets[POSTERIOR].annulus, shape.anterior_annulus);
        assert_eq!(v.leaflets[ANTERIOR].mesh, shape.posterior);
        let l: f64 = (0..n)
            .map(|i| (shape.annulus[(i + 1) % n] - shape.annulus[i]).norm())
            .sum();
        assert_eq!(v.leaflets[ANTERIOR].annulus_s[0], 0.0);
        assert!((v.leaflets[POSTERIOR].annulus_s.last().unwrap() - l).abs() < 1e-9);
        assert!(v.atrium.angle(&shape.atrium_direction).to_degrees() < 2.0);
    }

    /// The leaflet without the `strips` column strips at its end (the last
    /// columns in ring order), vertices compacted.
    fn drop_last_columns(mesh: &TriMesh, longitudes: &[Vec<u32>], strips: usize) -> TriMesh {
        let cols = longitudes.len();
        let gone: std::collections::HashSet<u32> = longitudes[cols - strips..]
            .iter()
            .flatten()
            .copied()
            .collect();
        let tris: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .filter(|t| {
                // A triangle of a dropped strip has a vertex on a dropped column.
                !t.iter().any(|v| gone.contains(v))
            })
            .copied()
            .collect();
        compact(mesh, tris)
    }

    fn compact(mesh: &TriMesh, tris: Vec<[u32; 3]>) -> TriMesh {
        let mut new = vec![u32::MAX; mesh.num_vertices()];
        let mut positions = Vec::new();
        for t in &tris {
            for &v in t {
                if new[v as usize] == u32::MAX {
                    new[v as usize] = 0;
                }
            }
        }
        for (v, slot) in new.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = positions.len() as u32;
                positions.push(mesh.positions[v]);
            }
        }
        let triangles = tris.iter().map(|t| t.map(|v| new[v as usize])).collect();
        TriMesh::new(positions, triangles)
    }

    #[test]
    fn mitral_contract_gap_of_one_segment_is_a_junction() {
        let shape = valve(ValveParams::default());
        let post = drop_last_columns(&shape.posterior, &shape.posterior_longitudes, 1);
        let v = run(&shape.anterior, &post, &shape.annulus).unwrap();
        let n = shape.annulus.len();
        // The anterolateral commissure is inserted halfway between the
        // posterior leaflet's new end (ring point n - 1) and ring point 0.
        assert_eq!(v.ring.len(), n + 1);
        let mid = Point3::from((shape.annulus[n - 1].coords + shape.annulus[0].coords) * 0.5);
        assert!((v.ring[0] - mid).norm() < 1e-9);
        assert_eq!(v.ring[1..], shape.annulus[..]);
        assert_eq!(v.posteromedial, shape.commissures[1] + 1);
        let ant = &v.leaflets[ANTERIOR];
        assert_eq!(ant.annulus, shape.anterior_annulus);
        let half = 0.5 * (shape.annulus[n - 1] - shape.annulus[0]).norm();
        assert!((ant.annulus_s[0] - half).abs() < 1e-9);
        let post_s = &v.leaflets[POSTERIOR].annulus_s;
        let ring_len: f64 = (0..=n)
            .map(|i| (v.ring[(i + 1) % (n + 1)] - v.ring[i]).norm())
            .sum();
        assert!((post_s.last().unwrap() - (ring_len - half)).abs() < 1e-9);
    }

    #[test]
    fn mitral_contract_short_posterior_leaflet_gives_one_junction() {
        let shape = valve(ValveParams::default());
        let post = drop_last_columns(&shape.posterior, &shape.posterior_longitudes, 3);
        let (e, msg) = contract_err(run(&shape.anterior, &post, &shape.annulus));
        assert!(
            matches!(e, ContractError::CommissureCount { matched: 1, .. }),
            "{e:?}"
        );
        assert!(
            msg.starts_with("the leaflets' annulus arcs meet at 1 point(s) on the annulus ring")
                && msg.contains("a mitral annulus has 2 commissures"),
            "{msg}"
        );
    }

    #[test]
    fn mitral_contract_rejects_a_leaflet_off_the_ring() {
        let shape = valve(ValveParams::default());
        let mut ant = shape.anterior.clone();
        for p in &mut ant.positions {
            *p -= shape.atrium_direction * 5.0;
        }
        let (e, msg) = contract_err(run(&ant, &shape.posterior, &shape.annulus));
        // The annulus vertices are 5 mm off; the commissural curtains hang
        // a little closer to the ring.
        let ContractError::LeafletOffRing {
            leaflet: LeafletSide::Anterior,
            closest_mm,
            tolerance_mm: DEFAULT_TOLERANCE_MM,
        } = e
        else {
            panic!("{e:?}");
        };
        assert!(closest_mm > 4.0 && closest_mm <= 5.0, "{closest_mm}");
        let prefix = "the anterior leaflet does not touch the annulus ring: its closest \
                      boundary vertex is ";
        let suffix = " mm away (tolerance 0.5 mm)";
        assert!(msg.starts_with(prefix) && msg.ends_with(suffix), "{msg}");
        let d: f64 = msg[prefix.len()..msg.len() - suffix.len()].parse().unwrap();
        assert!(d > 4.0 && d <= 5.0, "{msg}");
    }

    #[test]
    fn mitral_contract_rejects_a_ring_without_its_posterior_arc() {
        let shape = valve(ValveParams::default());
        let ring = shape.annulus[..=shape.commissures[1]].to_vec();
        let (e, msg) = contract_err(run(&shape.anterior, &shape.posterior, &ring));
        // The posterior leaflet touches the closing chord only at its two
        // ends, next to the commissures.
        assert!(
            matches!(
                &e,
                ContractError::SeveralStretches { leaflet: LeafletSide::Posterior, stretches, .. }
                    if stretches.len() == 2
            ),
            "{e:?}"
        );
        assert!(msg.contains("posterior leaflet"), "{msg}");
    }

    #[test]
    fn mitral_contract_rejects_overlapping_arcs() {
        let shape = valve(ValveParams::default());
        let (e, msg) = contract_err(run(&shape.anterior, &shape.anterior, &shape.annulus));
        assert!(matches!(e, ContractError::ArcsOverlap { .. }), "{e:?}");
        assert!(
            msg.starts_with("the anterior and posterior leaflets' annulus arcs overlap"),
            "{msg}"
        );
    }

    #[test]
    fn mitral_contract_rejects_a_leaflet_with_a_hole() {
        let shape = valve(coarse());
        // An interior vertex: middle of a middle column.
        let cols = &shape.posterior_longitudes;
        let v = cols[cols.len() / 2][2];
        let tris: Vec<[u32; 3]> = shape
            .posterior
            .triangles
            .iter()
            .filter(|t| !t.contains(&v))
            .copied()
            .collect();
        let holed = compact(&shape.posterior, tris);
        let (e, msg) = contract_err(run(&shape.anterior, &holed, &shape.annulus));
        assert!(
            matches!(
                &e,
                ContractError::BoundaryLoops { leaflet: LeafletSide::Posterior, loop_sizes }
                    if loop_sizes.len() == 2
            ),
            "{e:?}"
        );
        assert!(
            msg.starts_with("the posterior leaflet is not a disk: 2 boundary loops"),
            "{msg}"
        );
        // Keeping the now unused vertex is a mesh validation error.
        let mut unused = shape.posterior.clone();
        unused.triangles.retain(|t| !t.contains(&v));
        let (e, msg) = contract_err(run(&shape.anterior, &unused, &shape.annulus));
        assert!(
            matches!(
                e,
                ContractError::LeafletMesh {
                    leaflet: LeafletSide::Posterior,
                    source: MeshError::UnusedVertices { count: 1, first },
                } if first == v as usize
            ),
            "{e:?}"
        );
        assert!(
            msg.starts_with("posterior leaflet: ") && msg.contains("used by no element"),
            "{msg}"
        );
    }

    #[test]
    fn mitral_contract_rejects_a_closed_leaflet() {
        let shape = valve(coarse());
        // A tetrahedron surface: no boundary at all.
        let tet = TriMesh::new(
            vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(0.0, 0.0, 1.0),
            ],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        );
        let (e, msg) = contract_err(run(&tet, &shape.posterior, &shape.annulus));
        assert!(
            matches!(
                &e,
                ContractError::BoundaryLoops { leaflet: LeafletSide::Anterior, loop_sizes }
                    if loop_sizes.is_empty()
            ),
            "{e:?}"
        );
        assert!(
            msg.starts_with("the anterior leaflet is not a disk: 0 boundary loops"),
            "{msg}"
        );
    }

    #[test]
    fn mitral_contract_rejects_a_leaflet_touching_the_ring_twice() {
        let shape = valve(ValveParams::default());
        let mut ant = shape.anterior.clone();
        // Put the middle of the free edge onto the posterior saddle horn.
        let cols = &shape.anterior_longitudes;
        let tip = *cols[cols.len() / 2].last().unwrap();
        let horn = shape.commissures[1] + (shape.annulus.len() - shape.commissures[1]) / 2;
        ant.positions[tip as usize] = shape.annulus[horn];
        let (e, msg) = contract_err(run(&ant, &shape.posterior, &shape.annulus));
        assert!(
            matches!(
                &e,
                ContractError::SeveralStretches { leaflet: LeafletSide::Anterior, stretches, .. }
                    if stretches.len() == 2
            ),
            "{e:?}"
        );
        assert!(
            msg.starts_with("the anterior leaflet touches the annulus ring in 2 separate places"),
            "{msg}"
        );
    }

    #[test]
    fn mitral_contract_rejects_bad_rings_and_tolerances() {
        let shape = valve(coarse());
        let (a, p) = (&shape.anterior, &shape.posterior);
        let mut nan = shape.annulus.clone();
        nan[3].y = f64::NAN;
        let (e, msg) = contract_err(run(a, p, &nan));
        assert!(
            matches!(e, ContractError::RingPointNotFinite { index: 3, point } if point[1].is_nan()),
            "{e:?}"
        );
        assert!(
            msg.starts_with("annulus ring: point 3 has a non-finite coordinate"),
            "{msg}"
        );
        let (e, msg) = contract_err(run(a, p, &shape.annulus[..3]));
        assert_eq!(
            e,
            ContractError::TooFewRingPoints {
                count: 3,
                min: 6,
                closing_point_dropped: false
            }
        );
        assert_eq!(msg, "the annulus ring has 3 point(s); expected at least 6");
        let closed = [shape.annulus[0], shape.annulus[1], shape.annulus[0]];
        let (_, msg) = contract_err(run(a, p, &closed));
        assert_eq!(
            msg,
            "the annulus ring has 2 point(s) (after dropping the repeated closing point); \
             expected at least 6"
        );
        let mut dup = shape.annulus.clone();
        dup.insert(5, dup[4]);
        let (e, msg) = contract_err(run(a, p, &dup));
        assert!(
            matches!(
                e,
                ContractError::EqualConsecutiveRingPoints {
                    first: 4,
                    second: 5,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            msg.starts_with("annulus ring: points 4 and 5 are equal"),
            "{msg}"
        );
        let line: Vec<Point3<f64>> = (0..8).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let (e, msg) = contract_err(run(a, p, &line));
        assert!(matches!(e, ContractError::RingOnALine { .. }), "{e:?}");
        assert!(msg.starts_with("the annulus ring is degenerate"), "{msg}");
        let input = ValveInput {
            anterior: a,
            posterior: p,
            annulus: &shape.annulus,
        };
        for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            match prepare(&input, t) {
                Err(OrganError::Config(e)) => assert_eq!(e.name, "tolerance_mm", "{e}"),
                other => panic!("{t}: {other:?}"),
            }
        }
    }

    #[test]
    fn mitral_contract_rejects_invalid_leaflet_meshes() {
        let shape = valve(coarse());
        let mut bad = shape.anterior.clone();
        bad.positions[0].x = f64::INFINITY;
        let (e, msg) = contract_err(run(&bad, &shape.posterior, &shape.annulus));
        assert!(
            matches!(
                e,
                ContractError::LeafletMesh {
                    leaflet: LeafletSide::Anterior,
                    source: MeshError::NonFiniteCoordinate { vertex: 0, .. },
                }
            ),
            "{e:?}"
        );
        assert!(msg.starts_with("anterior leaflet: vertex 0"), "{msg}");
    }

    #[test]
    fn mitral_contract_free_edge_may_start_within_the_tolerance() {
        // The commissural columns leave the ring nearly perpendicularly:
        // their first vertices are within 0.5 mm of the ring and project
        // back onto their own arc. They belong to the free edge.
        let shape = valve(ValveParams::default());
        let v = run(&shape.anterior, &shape.posterior, &shape.annulus).unwrap();
        check_against(&shape, &v);
        let ring = Ring::new(shape.annulus.clone()).unwrap();
        for lf in &v.leaflets {
            for w in [lf.free_edge[0], *lf.free_edge.last().unwrap()] {
                let (d, _) = ring.project(&lf.mesh.positions[w as usize]);
                assert!(d < DEFAULT_TOLERANCE_MM, "{w}: {d}");
            }
        }
    }

    #[test]
    fn mitral_contract_handles_either_leaflet_orientation() {
        let shape = valve(ValveParams::default());
        let flip = |m: &TriMesh| {
            let mut m = m.clone();
            for t in &mut m.triangles {
                t.swap(1, 2);
            }
            m
        };
        let (fa, fp) = (flip(&shape.anterior), flip(&shape.posterior));
        let base = run(&shape.anterior, &shape.posterior, &shape.annulus).unwrap();
        for (a, p) in [(&fa, &fp), (&fa, &shape.posterior), (&shape.anterior, &fp)] {
            let v = run(a, p, &shape.annulus).unwrap();
            assert_eq!(v.ring, base.ring);
            assert_eq!(v.posteromedial, base.posteromedial);
            assert!((v.atrium - base.atrium).norm() < 1e-12);
            for k in [ANTERIOR, POSTERIOR] {
                assert_eq!(v.leaflets[k].annulus, base.leaflets[k].annulus);
                assert_eq!(v.leaflets[k].annulus_s, base.leaflets[k].annulus_s);
                assert_eq!(v.leaflets[k].free_edge, base.leaflets[k].free_edge);
            }
        }
    }

    #[test]
    fn mitral_contract_rejects_annulus_vertices_out_of_order() {
        let shape = valve(ValveParams::default());
        let mut ant = shape.anterior.clone();
        // Annulus vertex 10 moved back onto ring point 7 (about 1.9 mm).
        let v = shape.anterior_annulus[10];
        ant.positions[v as usize] = shape.annulus[shape.anterior_annulus_ring[7]];
        let (e, msg) = contract_err(run(&ant, &shape.posterior, &shape.annulus));
        assert!(
            matches!(
                e,
                ContractError::AnnulusStepsBack {
                    leaflet: LeafletSide::Anterior,
                    to,
                    back_mm,
                    ..
                } if to == v && back_mm > DEFAULT_TOLERANCE_MM
            ),
            "{e:?}"
        );
        assert!(
            msg.starts_with(
                "the anterior leaflet's annulus vertices do not progress monotonically around \
                 the annulus ring"
            ) && msg.contains(&format!(" to {v} they step back "))
                && msg.ends_with("mm along the ring (tolerance 0.5 mm)"),
            "{msg}"
        );
    }

    #[test]
    fn mitral_contract_rejects_a_leaflet_without_free_edge() {
        let shape = valve(coarse());
        // A fan whose rim is the whole ring.
        let n = shape.annulus.len();
        let mut positions = shape.annulus.clone();
        let c = unfold_mesh::geometry::centroid(&positions).unwrap();
        positions.push(c - shape.atrium_direction * 5.0);
        let triangles = (0..n as u32)
            .map(|i| [i, (i + 1) % n as u32, n as u32])
            .collect();
        let fan = TriMesh::new(positions, triangles);
        let (e, msg) = contract_err(run(&shape.anterior, &fan, &shape.annulus));
        assert_eq!(
            e,
            ContractError::NoFreeEdge {
                leaflet: LeafletSide::Posterior,
                boundary_vertices: n,
                tolerance_mm: DEFAULT_TOLERANCE_MM
            }
        );
        assert_eq!(
            msg,
            format!(
                "the posterior leaflet's whole boundary ({n} vertices) lies on the annulus ring \
                 (within 0.5 mm); a leaflet needs a free edge off the ring"
            )
        );
    }

    #[test]
    fn mitral_contract_rejects_a_holed_torus() {
        let shape = valve(coarse());
        // A torus with one quad removed: one boundary loop, χ = -1.
        let (nu, nv) = (8u32, 6u32);
        let mut positions = Vec::new();
        for i in 0..nu {
            for j in 0..nv {
                let (u, w) = (
                    std::f64::consts::TAU * i as f64 / nu as f64,
                    std::f64::consts::TAU * j as f64 / nv as f64,
                );
                let r = 10.0 + 3.0 * w.cos();
                positions.push(Point3::new(r * u.cos(), r * u.sin(), 3.0 * w.sin()));
            }
        }
        let id = |i: u32, j: u32| (i % nu) * nv + (j % nv);
        let mut triangles = Vec::new();
        for i in 0..nu {
            for j in 0..nv {
                if (i, j) == (0, 0) {
                    continue;
                }
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        let torus = TriMesh::new(positions, triangles);
        let (e, msg) = contract_err(run(&torus, &shape.posterior, &shape.annulus));
        assert_eq!(
            e,
            ContractError::EulerCharacteristic {
                leaflet: LeafletSide::Anterior,
                euler_characteristic: -1
            }
        );
        assert_eq!(
            msg,
            "the anterior leaflet is not a disk: Euler characteristic -1 (V - E + F); a disk \
             has 1"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn mitral_contract_recovers_posed_valves(
            angles in prop::array::uniform3(-180.0..180.0f64),
            shift in prop::array::uniform3(-200.0..200.0f64),
            rot in 0usize..1000,
            reverse in any::<bool>(),
            close in any::<bool>(),
            res in 0usize..3,
        ) {
            let base = [coarse(), ValveParams::default(), fine()][res].clone();
            let shape = valve(ValveParams { pose: Pose::new(angles, shift), ..base });
            let ring = given_ring(&shape, rot % shape.annulus.len(), reverse, close);
            let v = run(&shape.anterior, &shape.posterior, &ring).unwrap();
            check_against(&shape, &v);
        }
    }
}
