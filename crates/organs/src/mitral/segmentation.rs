//! The two leaflets' atrial surfaces and the annulus ring cut from a label
//! map (a 3D echo or CT segmentation: one label per leaflet, optionally one
//! for the annulus), for [`super::Pipeline`].
//!
//! [`valve_from_labels`] works in six steps; `s` is the grid spacing (the
//! largest voxel spacing unless given).
//!
//! 1. **Labels.** The map is one 3D frame of integer values; the anterior,
//!    posterior (and annulus) labels are distinct and each has voxels.
//! 2. **Annulus plane and atrial side.** The plane through the centroid
//!    `c` of the annulus voxels (without an annulus label: of the leaflet
//!    voxels) with normal `n` their smallest principal axis. The atrium is
//!    the side the leaflets do not hang into: with an annulus label, `n` is
//!    oriented so that the mean height `(p - c)·n` of the leaflet voxels is
//!    negative (the leaflets lie on the ventricular side of the annulus);
//!    without one, so that the leaflet voxels farther from the axis than
//!    their median distance lie higher on average than the nearer ones
//!    (the leaflets funnel from the annulus down into the ventricle).
//! 3. **The atrial view.** Over the plane, a square grid of spacing `s`
//!    (axes `e_0, e_1` with `e_0 × e_1 = n`) covering the leaflet voxels'
//!    projections. From each grid point a ray comes down from the atrium
//!    along `-n` (steps of half the smallest voxel spacing; nearest-voxel
//!    labels). The first leaflet voxel it meets gives the point its
//!    leaflet and its height: the voxel's face found by bisection. The
//!    atrial surface of a leaflet is what a surgeon sees from the atrium:
//!    a height field over the annulus plane. A ray that meets the annulus
//!    label first, inside its centreline (per direction about its centre,
//!    the mean radius of its voxels), takes the centreline's height there
//!    and the leaflet of the nearest leaflet point: the leaflets reach up
//!    to the annulus' centreline, their hinge; outside it, the point is
//!    not part of the valve.
//! 4. **Cleaning on the grid.** The seen points' largest 4-connected
//!    component is kept; holes in it of at most `max(4, 1%)` of its points
//!    are filled (label of the neighbours, height averaged in from the rim;
//!    a larger hole is an open orifice and stays); each leaflet's largest
//!    4-connected component keeps its label, the rest take the other one.
//!    The heights are smoothed lightly (3 sweeps of `h <- (h + mean of the
//!    seen 4-neighbours) / 2`).
//! 5. **Surfaces.** A grid square whose four corners are seen becomes two
//!    triangles (counter-clockwise about `n`, so normals face the atrium),
//!    owned by the majority leaflet of its corners (a tie: its first
//!    corner's). Squares meeting only at a corner are separated (one is
//!    dropped from the valve, or given to the other leaflet), each leaflet
//!    keeps its largest edge-connected piece (the rest goes to the other
//!    leaflet) and takes in the other leaflet's pieces it encloses, until
//!    nothing changes. The leaflets share their seam's vertices (they meet
//!    at the commissures and, in a closed valve, along the coaptation
//!    line); each must be a disk (one boundary loop, `V - E + F = 1`).
//!    Before that, the outline is regularized (up to 5 sweeps: a point not
//!    seen with 3 or 4 seen neighbours is filled, a seen one with at most 1
//!    is dropped), and a staircase corner of the outline (a grid point of
//!    one square) is cut off along the square's diagonal.
//! 6. **Annulus ring.** The outer boundary loop of the two leaflets
//!    together (the loop enclosing the largest area over the plane): the
//!    leaflets' hinge, so every hinge vertex lies on the ring. With an
//!    annulus label its centreline is also measured (the mean of its voxels
//!    in each of 72 directions from its centre) and gated against the ring.

use super::LeafletSide;
use super::error::SegmentationError;
use crate::OrganError;
use crate::Requirement;
use crate::gate::Gates;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeSet, VecDeque};
use unfold_mesh::geometry::pca_frame;
use unfold_mesh::nalgebra::{Point3, Vector3};
use unfold_mesh::topology::{boundary_loops, euler_characteristic};
use unfold_mesh::{TriMesh, Volume};

/// The labels of a valve's parts in a label map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeafletLabels {
    /// The anterior leaflet's label.
    pub anterior: i64,
    /// The posterior leaflet's label.
    pub posterior: i64,
    /// The annulus' label, if the map has one.
    pub annulus: Option<i64>,
}

/// Most grid points over the annulus plane (a 3000 x 3000 grid).
pub const MAX_GRID_POINTS: usize = 9_000_000;

/// Fewest grid points a leaflet must cover seen from the atrium.
pub const MIN_LEAFLET_POINTS: usize = 12;

/// Directions around the annulus label's centre for its centreline.
pub const ANNULUS_BINS: usize = 72;

/// Where the atrial side came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AtrialSideFrom {
    /// The leaflets lie on the ventricular side of the annulus label's
    /// plane.
    AnnulusLabel,
    /// The leaflets funnel down from their outer edge (no annulus label).
    LeafletShape,
}

/// A per-leaflet count (anterior, posterior).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerLeaflet {
    /// The anterior leaflet's.
    pub anterior: usize,
    /// The posterior leaflet's.
    pub posterior: usize,
}

/// How the surfaces were cut from the label map (`segmentation` in
/// `report.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentationReport {
    /// The anterior leaflet's label.
    pub anterior_label: i64,
    /// The posterior leaflet's label.
    pub posterior_label: i64,
    /// The annulus' label, if given.
    pub annulus_label: Option<i64>,
    /// Voxels of each leaflet's label.
    pub leaflet_voxels: PerLeaflet,
    /// Voxels of the annulus label (0 without one).
    pub annulus_voxels: usize,
    /// Grid spacing over the annulus plane, mm.
    pub grid_mm: f64,
    /// Unit normal of the annulus plane towards the atrium (world frame).
    pub atrial_direction: [f64; 3],
    /// How the atrial side was decided.
    pub atrial_side_from: AtrialSideFrom,
    /// Grid points filled in small holes.
    pub filled_points: usize,
    /// Grid points or squares moved from one leaflet to the other (islands,
    /// corner contacts).
    pub relabelled: usize,
    /// Vertices of each leaflet's surface.
    pub vertices: PerLeaflet,
    /// Triangles of each leaflet's surface.
    pub triangles: PerLeaflet,
    /// Vertices the two leaflets share (their seam).
    pub shared_vertices: usize,
    /// Length of the annulus ring (the leaflets' outer edge), mm.
    pub ring_length_mm: f64,
    /// Length of the annulus label's centreline, mm (none without one).
    pub annulus_label_length_mm: Option<f64>,
    /// The quality gates of the cut (`seg.*`).
    pub gates: Gates,
}

/// The valve cut from a label map: the pipeline's inputs and how they were
/// made.
#[derive(Debug, Clone)]
pub struct SegmentedValve {
    /// The anterior leaflet's atrial surface.
    pub anterior: TriMesh,
    /// The posterior leaflet's atrial surface.
    pub posterior: TriMesh,
    /// The annulus ring: the two leaflets' outer edge, in order, not closed.
    pub ring: Vec<Point3<f64>>,
    /// How they were made.
    pub report: SegmentationReport,
}

/// Grid codes: not seen, anterior, posterior.
const NONE: u8 = 0;
const ANT: u8 = 1;
const POST: u8 = 2;
/// The annulus seen first, inside its centreline (before
/// [`Grid::ring_to_leaflets`]).
const RING: u8 = 3;

/// The annulus label's centreline over the plane: its centre `(u, v)` and,
/// per direction ([`ANNULUS_BINS`]), the mean radius and height of its
/// voxels (an empty direction takes its nearest neighbour's).
struct RingProfile {
    centre: (f64, f64),
    bins: Vec<(f64, f64)>,
}

impl RingProfile {
    fn new(
        voxels: &[Point3<f64>],
        c: &Point3<f64>,
        e0: &Vector3<f64>,
        e1: &Vector3<f64>,
        n: &Vector3<f64>,
    ) -> Result<RingProfile, SegmentationError> {
        let local: Vec<(f64, f64, f64)> = voxels
            .iter()
            .map(|p| {
                let d = p - c;
                (d.dot(e0), d.dot(e1), d.dot(n))
            })
            .collect();
        let m = local.len() as f64;
        let centre = (
            local.iter().map(|x| x.0).sum::<f64>() / m,
            local.iter().map(|x| x.1).sum::<f64>() / m,
        );
        let mut sums = vec![(0.0, 0.0, 0usize); ANNULUS_BINS];
        for &(u, v, h) in &local {
            let (du, dv) = (u - centre.0, v - centre.1);
            let b = bin_of(dv.atan2(du));
            sums[b].0 += du.hypot(dv);
            sums[b].1 += h;
            sums[b].2 += 1;
        }
        let empty = sums.iter().filter(|x| x.2 == 0).count();
        if empty * 4 > ANNULUS_BINS {
            return Err(SegmentationError::AnnulusNotRing {
                empty,
                bins: ANNULUS_BINS,
            });
        }
        let bins = (0..ANNULUS_BINS)
            .map(|b| {
                let k = (0..ANNULUS_BINS)
                    .flat_map(|d| {
                        [
                            (b + d) % ANNULUS_BINS,
                            (b + ANNULUS_BINS - d) % ANNULUS_BINS,
                        ]
                    })
                    .find(|&k| sums[k].2 > 0)
                    .unwrap_or(b);
                let w = sums[k].2.max(1) as f64;
                (sums[k].0 / w, sums[k].1 / w)
            })
            .collect();
        Ok(RingProfile { centre, bins })
    }

    /// The centreline's height when `(u, v)` lies inside it.
    fn inside(&self, u: f64, v: f64) -> Option<f64> {
        let (du, dv) = (u - self.centre.0, v - self.centre.1);
        let (r, h) = self.bins[bin_of(dv.atan2(du))];
        (du.hypot(dv) <= r).then_some(h)
    }
}

/// The direction bin of an angle in `[-pi, pi]`.
fn bin_of(angle: f64) -> usize {
    (((angle + std::f64::consts::PI) / std::f64::consts::TAU) * ANNULUS_BINS as f64) as usize
        % ANNULUS_BINS
}

fn other(l: u8) -> u8 {
    if l == ANT { POST } else { ANT }
}

fn side(l: u8) -> LeafletSide {
    if l == ANT {
        LeafletSide::Anterior
    } else {
        LeafletSide::Posterior
    }
}

/// Cuts both leaflets' atrial surfaces and the annulus ring from the label
/// map `labels` (values in mm in the map's world frame), on a grid of
/// `grid_mm` over the annulus plane (none: the largest voxel spacing). See
/// the [module docs](self) for the rules.
///
/// # Errors
/// A [`SegmentationError`] (in [`OrganError::Mitral`]) for a map that is
/// not one frame of integer labels, labels missing or equal, leaflets that
/// do not touch or are not disks seen from the atrium, an annulus label
/// that is not a ring; a [`crate::gate::GateError`] when the ring and the
/// annulus label disagree or the leaflets are seen edge-on.
pub fn valve_from_labels(
    labels: &Volume<f32>,
    which: LeafletLabels,
    grid_mm: Option<f64>,
) -> Result<SegmentedValve, OrganError> {
    if labels.frames() != 1 {
        return Err(SegmentationError::Frames {
            frames: labels.frames(),
        }
        .into());
    }
    check_distinct(which)?;
    let data = labels.data();
    if let Some(voxel) = data.iter().position(|v| !v.is_finite() || v.fract() != 0.0) {
        return Err(SegmentationError::NotLabels {
            voxel,
            value: f64::from(data[voxel]),
        }
        .into());
    }
    // 1. the voxels of each part, in the world frame
    let [nx, ny, _, _] = labels.dims();
    let mut present = BTreeSet::new();
    let (mut ant, mut post, mut ring_voxels) = (Vec::new(), Vec::new(), Vec::new());
    for (i, &v) in data.iter().enumerate() {
        let l = v as i64;
        if present.len() < 64 {
            present.insert(l);
        }
        let part = if l == which.anterior {
            &mut ant
        } else if l == which.posterior {
            &mut post
        } else if Some(l) == which.annulus {
            &mut ring_voxels
        } else {
            continue;
        };
        let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
        part.push(labels.voxel_to_world(&Point3::new(x as f64, y as f64, z as f64)));
    }
    let missing = |role: &'static str, label: i64| {
        let list: Vec<String> = present.iter().take(12).map(|l| l.to_string()).collect();
        SegmentationError::MissingLabel {
            role,
            label,
            present: list.join(", "),
        }
    };
    if ant.is_empty() {
        return Err(missing("anterior leaflet", which.anterior).into());
    }
    if post.is_empty() {
        return Err(missing("posterior leaflet", which.posterior).into());
    }
    if let Some(a) = which.annulus
        && ring_voxels.is_empty()
    {
        return Err(missing("annulus", a).into());
    }
    // 2. the annulus plane and the atrial side
    let leaflet_points: Vec<Point3<f64>> = ant.iter().chain(&post).copied().collect();
    let (plane_points, what) = if ring_voxels.is_empty() {
        (&leaflet_points, "leaflet")
    } else {
        (&ring_voxels, "annulus")
    };
    let frame = pca_frame(plane_points)
        .filter(|f| f.variances[1] > 1e-12 * f.variances[0].max(1e-300))
        .ok_or(SegmentationError::NoPlane {
            what,
            count: plane_points.len(),
        })?;
    let c = frame.centroid;
    let mut n = frame.axis(2);
    let e0 = frame.axis(0);
    let from = if ring_voxels.is_empty() {
        AtrialSideFrom::LeafletShape
    } else {
        AtrialSideFrom::AnnulusLabel
    };
    let below = match from {
        AtrialSideFrom::AnnulusLabel => {
            let mean: f64 = leaflet_points.iter().map(|p| (p - c).dot(&n)).sum::<f64>()
                / leaflet_points.len() as f64;
            mean <= 0.0
        }
        AtrialSideFrom::LeafletShape => outer_is_higher(&leaflet_points, &c, &n),
    };
    if !below {
        n = -n;
    }
    let e1 = n.cross(&e0);
    // 3. the atrial view
    let spacing = labels.spacing();
    let s = grid_mm.unwrap_or_else(|| spacing.iter().copied().fold(0.0, f64::max));
    let step = spacing.iter().copied().fold(f64::INFINITY, f64::min) / 2.0;
    let half_diag = 0.5 * (spacing[0].powi(2) + spacing[1].powi(2) + spacing[2].powi(2)).sqrt();
    let (mut umin, mut umax, mut vmin, mut vmax) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in &leaflet_points {
        let d = p - c;
        let (u, v) = (d.dot(&e0), d.dot(&e1));
        umin = umin.min(u);
        umax = umax.max(u);
        vmin = vmin.min(v);
        vmax = vmax.max(v);
    }
    let (mut hmin, mut hmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in leaflet_points.iter().chain(&ring_voxels) {
        let h = (p - c).dot(&n);
        hmin = hmin.min(h);
        hmax = hmax.max(h);
    }
    let (hmin, hmax) = (hmin - 2.0 * half_diag, hmax + 2.0 * half_diag);
    let (u0, v0) = (umin - 2.0 * s, vmin - 2.0 * s);
    let gu = ((umax - umin) / s).ceil() as usize + 5;
    let gv = ((vmax - vmin) / s).ceil() as usize + 5;
    if gu.saturating_mul(gv) > MAX_GRID_POINTS {
        return Err(SegmentationError::GridTooLarge {
            points: gu.saturating_mul(gv),
            spacing_mm: s,
            max: MAX_GRID_POINTS,
        }
        .into());
    }
    let code_at = |p: &Point3<f64>| -> u8 {
        let v = labels.world_to_voxel(p);
        let idx = [v.x.round(), v.y.round(), v.z.round()];
        let dims = labels.dims();
        if idx
            .iter()
            .zip(&dims)
            .any(|(&x, &d)| x < 0.0 || x >= d as f64)
        {
            return NONE;
        }
        let l =
            data[idx[0] as usize + dims[0] * (idx[1] as usize + dims[1] * idx[2] as usize)] as i64;
        if l == which.anterior {
            ANT
        } else if l == which.posterior {
            POST
        } else if Some(l) == which.annulus {
            RING
        } else {
            NONE
        }
    };
    let leaflet_at = |p: &Point3<f64>| matches!(code_at(p), ANT | POST);
    // the annulus label's centreline over the plane: per direction about
    // its centre, the mean radius and height of its voxels
    let profile = if ring_voxels.is_empty() {
        None
    } else {
        Some(RingProfile::new(&ring_voxels, &c, &e0, &e1, &n)?)
    };
    let base = |a: usize, b: usize| c + e0 * (u0 + a as f64 * s) + e1 * (v0 + b as f64 * s);
    let mut code = vec![NONE; gu * gv];
    let mut height = vec![0.0; gu * gv];
    let steps = ((hmax - hmin) / step).ceil() as usize + 1;
    for b in 0..gv {
        for a in 0..gu {
            let o = base(a, b);
            let mut prev = hmax;
            for k in 0..=steps {
                let t = (hmax - k as f64 * step).max(hmin);
                let l = code_at(&(o + n * t));
                if l == RING {
                    // the annulus seen first: inside its centreline the
                    // valve reaches up to it (the hinge), at its height
                    if let Some(pr) = &profile
                        && let Some(h) = pr.inside(u0 + a as f64 * s, v0 + b as f64 * s)
                    {
                        code[a + gu * b] = RING;
                        height[a + gu * b] = h;
                        break;
                    }
                } else if l != NONE {
                    // the voxel face between prev (not a leaflet) and t
                    let (mut hi, mut lo) = (prev, t);
                    for _ in 0..10 {
                        let mid = 0.5 * (hi + lo);
                        if !leaflet_at(&(o + n * mid)) {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    code[a + gu * b] = l;
                    height[a + gu * b] = 0.5 * (hi + lo);
                    break;
                }
                prev = t;
                if t <= hmin {
                    break;
                }
            }
        }
    }
    // 4. cleaning on the grid
    let grid = Grid { nu: gu, nv: gv };
    grid.ring_to_leaflets(&mut code);
    let raw = code.clone();
    let (filled, mut relabelled) = grid.clean(&mut code, &mut height);
    for l in [ANT, POST] {
        let points = code.iter().filter(|&&x| x == l).count();
        let before = raw.iter().filter(|&&x| x == l).count();
        if points < MIN_LEAFLET_POINTS && before >= MIN_LEAFLET_POINTS {
            // the leaflet was seen, but apart from the other one
            let used = [ANT, POST].map(|m| raw.iter().map(|&x| x == m).collect::<Vec<bool>>());
            return Err(SegmentationError::LeafletsApart {
                gap_mm: grid.gap(&used, s),
            }
            .into());
        }
        if points < MIN_LEAFLET_POINTS {
            return Err(SegmentationError::LeafletTooSmall {
                leaflet: side(l),
                points,
                spacing_mm: s,
                min: MIN_LEAFLET_POINTS,
            }
            .into());
        }
    }
    grid.smooth(&code, &mut height, 3);
    // 5. surfaces
    let mut quads = grid.quads(&code);
    relabelled += grid.untangle(&mut quads);
    let position = |i: usize| base(i % gu, i / gu) + n * height[i];
    let triangles = grid.triangles(&quads);
    let mut meshes = Vec::with_capacity(2);
    let mut used = [vec![false; gu * gv], vec![false; gu * gv]];
    for (k, l) in [ANT, POST].into_iter().enumerate() {
        let mesh = grid.leaflet(&triangles, l, &mut used[k], position);
        let loops = boundary_loops(&mesh).map(|v| v.len()).unwrap_or(0);
        let euler = euler_characteristic(&mesh);
        if mesh.num_triangles() == 0 || loops != 1 || euler != 1 {
            return Err(SegmentationError::LeafletNotDisk {
                leaflet: side(l),
                loops,
                euler,
            }
            .into());
        }
        meshes.push(mesh);
    }
    let shared = (0..gu * gv).filter(|&i| used[0][i] && used[1][i]).count();
    if shared == 0 {
        return Err(SegmentationError::LeafletsApart {
            gap_mm: grid.gap(&used, s),
        }
        .into());
    }
    // 6. the ring: the outer loop of both leaflets together
    let union = grid.leaflet(&triangles, NONE, &mut vec![false; gu * gv], position);
    let ring_ids = outer_loop(&union, &c, &e0, &e1);
    let ring: Vec<Point3<f64>> = ring_ids
        .iter()
        .map(|&v| union.positions[v as usize])
        .collect();
    let ring_length = closed_length(&ring);
    let mut gates = Gates::new();
    let label_length = if ring_voxels.is_empty() {
        None
    } else {
        let centreline = annulus_centreline(&ring_voxels, &e0, &e1)?;
        let length = closed_length(&centreline);
        // The leaflets hinge at the annulus: their outer edge and the
        // annulus label's centreline differ by the annulus' thickness, a
        // few mm on a ring of 80-140 mm, well within 25%. Outside, the
        // leaflet labels stop short of the annulus (or spill past it).
        gates.check(
            "seg.ring_to_annulus_label_length",
            ring_length / length,
            Requirement::Within(0.75, 1.33),
            "the leaflets' outer edge does not follow the annulus label: check that the leaflet \
             labels reach the annulus, or leave --annulus-label out",
        )?;
        Some(length)
    };
    for (k, mesh) in meshes.iter().enumerate() {
        // A closed valve's leaflets, seen from the atrium, slope at most
        // ~60 degrees (area ratio 2); 4 is a mean slope of 75 degrees,
        // reached only by leaflets seen edge-on (an open valve).
        let ratio = area(mesh) / projected_area(mesh, &n);
        gates.check(
            if k == 0 {
                "seg.anterior_area_over_projected"
            } else {
                "seg.posterior_area_over_projected"
            },
            ratio,
            Requirement::Within(1.0 - 1e-9, 4.0),
            "the leaflet is seen edge-on from the atrium (an open valve?): give a closed-valve \
             (systolic) frame of the label map",
        )?;
    }
    let [anterior, posterior]: [TriMesh; 2] = meshes.try_into().expect("two leaflets");
    let report = SegmentationReport {
        anterior_label: which.anterior,
        posterior_label: which.posterior,
        annulus_label: which.annulus,
        leaflet_voxels: PerLeaflet {
            anterior: ant.len(),
            posterior: post.len(),
        },
        annulus_voxels: ring_voxels.len(),
        grid_mm: s,
        atrial_direction: [n.x, n.y, n.z],
        atrial_side_from: from,
        filled_points: filled,
        relabelled,
        vertices: PerLeaflet {
            anterior: anterior.num_vertices(),
            posterior: posterior.num_vertices(),
        },
        triangles: PerLeaflet {
            anterior: anterior.num_triangles(),
            posterior: posterior.num_triangles(),
        },
        shared_vertices: shared,
        ring_length_mm: ring_length,
        annulus_label_length_mm: label_length,
        gates,
    };
    Ok(SegmentedValve {
        anterior,
        posterior,
        ring,
        report,
    })
}

/// Refuses two roles with one label.
fn check_distinct(w: LeafletLabels) -> Result<(), SegmentationError> {
    let mut roles = vec![
        ("anterior leaflet", w.anterior),
        ("posterior leaflet", w.posterior),
    ];
    roles.extend(w.annulus.map(|a| ("annulus", a)));
    for i in 0..roles.len() {
        for j in i + 1..roles.len() {
            if roles[i].1 == roles[j].1 {
                return Err(SegmentationError::SameLabel {
                    label: roles[i].1,
                    first: roles[i].0,
                    second: roles[j].0,
                });
            }
        }
    }
    Ok(())
}

/// Whether the points farther from the axis `(c, n)` than their median
/// distance lie higher along `n`, on average, than the nearer ones.
fn outer_is_higher(points: &[Point3<f64>], c: &Point3<f64>, n: &Vector3<f64>) -> bool {
    let hr: Vec<(f64, f64)> = points
        .iter()
        .map(|p| {
            let d = p - c;
            let h = d.dot(n);
            (h, (d - n * h).norm())
        })
        .collect();
    let mut radii: Vec<f64> = hr.iter().map(|x| x.1).collect();
    radii.sort_by(f64::total_cmp);
    let median = radii[radii.len() / 2];
    let (mut outer, mut inner, mut no, mut ni) = (0.0, 0.0, 0usize, 0usize);
    for (h, r) in hr {
        if r > median {
            outer += h;
            no += 1;
        } else {
            inner += h;
            ni += 1;
        }
    }
    no == 0 || ni == 0 || outer / no as f64 >= inner / ni as f64
}

/// The centreline of the annulus voxels: their mean in each of
/// [`ANNULUS_BINS`] directions about their centre over the plane.
fn annulus_centreline(
    voxels: &[Point3<f64>],
    e0: &Vector3<f64>,
    e1: &Vector3<f64>,
) -> Result<Vec<Point3<f64>>, SegmentationError> {
    let centre = voxels
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.coords)
        / voxels.len() as f64;
    let centre = Point3::from(centre);
    let mut sums = vec![(Vector3::zeros(), 0usize); ANNULUS_BINS];
    for p in voxels {
        let d = p - centre;
        let angle = d.dot(e1).atan2(d.dot(e0));
        let bin = (((angle + std::f64::consts::PI) / std::f64::consts::TAU) * ANNULUS_BINS as f64)
            as usize
            % ANNULUS_BINS;
        sums[bin].0 += p.coords;
        sums[bin].1 += 1;
    }
    let empty = sums.iter().filter(|s| s.1 == 0).count();
    if empty * 4 > ANNULUS_BINS {
        return Err(SegmentationError::AnnulusNotRing {
            empty,
            bins: ANNULUS_BINS,
        });
    }
    Ok(sums
        .iter()
        .filter(|s| s.1 > 0)
        .map(|s| Point3::from(s.0 / s.1 as f64))
        .collect())
}

/// Length of the closed polyline through `points`.
fn closed_length(points: &[Point3<f64>]) -> f64 {
    (0..points.len())
        .map(|i| (points[(i + 1) % points.len()] - points[i]).norm())
        .sum()
}

/// Total area of `mesh`'s triangles.
fn area(mesh: &TriMesh) -> f64 {
    (0..mesh.num_triangles())
        .map(|t| {
            let [a, b, c] = mesh.triangle_points(t);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum()
}

/// Area of `mesh` projected on the plane of normal `n`.
fn projected_area(mesh: &TriMesh, n: &Vector3<f64>) -> f64 {
    (0..mesh.num_triangles())
        .map(|t| {
            let [a, b, c] = mesh.triangle_points(t);
            0.5 * (b - a).cross(&(c - a)).dot(n).abs()
        })
        .sum()
}

/// The boundary loop of `mesh` enclosing the largest area over the plane
/// `(e0, e1)`.
fn outer_loop(mesh: &TriMesh, c: &Point3<f64>, e0: &Vector3<f64>, e1: &Vector3<f64>) -> Vec<u32> {
    let loops = boundary_loops(mesh).unwrap_or_default();
    let enclosed = |l: &Vec<u32>| -> f64 {
        let uv: Vec<(f64, f64)> = l
            .iter()
            .map(|&v| {
                let d = mesh.positions[v as usize] - c;
                (d.dot(e0), d.dot(e1))
            })
            .collect();
        (0..uv.len())
            .map(|i| {
                let (p, q) = (uv[i], uv[(i + 1) % uv.len()]);
                p.0 * q.1 - q.0 * p.1
            })
            .sum::<f64>()
            .abs()
    };
    loops
        .into_iter()
        .max_by(|a, b| enclosed(a).total_cmp(&enclosed(b)))
        .unwrap_or_default()
}

/// The grid over the annulus plane: point `(a, b)` at `a + nu b`; square
/// `(a, b)` (corners `(a, b)`, `(a+1, b)`, `(a+1, b+1)`, `(a, b+1)`) at
/// the same index.
struct Grid {
    nu: usize,
    nv: usize,
}

/// The cells of every component but the largest (the first of the largest
/// on a tie), in component order.
fn all_but_the_largest(comps: Vec<Vec<usize>>) -> Vec<usize> {
    let Some(big) = comps
        .iter()
        .enumerate()
        .max_by(|(i, a), (j, b)| a.len().cmp(&b.len()).then(j.cmp(i)))
        .map(|(i, _)| i)
    else {
        return Vec::new();
    };
    comps
        .into_iter()
        .enumerate()
        .filter(|&(i, _)| i != big)
        .flat_map(|(_, comp)| comp)
        .collect()
}

impl Grid {
    /// The 4-neighbours of point (or square) `i`.
    fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (a, b) = (i % self.nu, i / self.nu);
        [
            (a > 0).then(|| i - 1),
            (a + 1 < self.nu).then(|| i + 1),
            (b > 0).then(|| i - self.nu),
            (b + 1 < self.nv).then(|| i + self.nu),
        ]
        .into_iter()
        .flatten()
    }

    fn on_border(&self, i: usize) -> bool {
        let (a, b) = (i % self.nu, i / self.nu);
        a == 0 || b == 0 || a + 1 == self.nu || b + 1 == self.nv
    }

    /// The 4-connected components of the cells where `member` holds.
    fn components(&self, member: impl Fn(usize) -> bool) -> Vec<Vec<usize>> {
        let len = self.nu * self.nv;
        let mut seen = vec![false; len];
        let mut out = Vec::new();
        for start in 0..len {
            if seen[start] || !member(start) {
                continue;
            }
            seen[start] = true;
            let mut comp = vec![start];
            let mut queue = VecDeque::from([start]);
            while let Some(i) = queue.pop_front() {
                for j in self.neighbours(i) {
                    if !seen[j] && member(j) {
                        seen[j] = true;
                        comp.push(j);
                        queue.push_back(j);
                    }
                }
            }
            out.push(comp);
        }
        out
    }

    /// Annulus points take the leaflet of the nearest leaflet point
    /// (breadth first over the annulus points); those no leaflet reaches
    /// are dropped.
    fn ring_to_leaflets(&self, code: &mut [u8]) {
        let mut queue: VecDeque<usize> = (0..code.len())
            .filter(|&i| matches!(code[i], ANT | POST))
            .collect();
        while let Some(i) = queue.pop_front() {
            let l = code[i];
            for j in self.neighbours(i).collect::<Vec<_>>() {
                if code[j] == RING {
                    code[j] = l;
                    queue.push_back(j);
                }
            }
        }
        for x in code.iter_mut() {
            if *x == RING {
                *x = NONE;
            }
        }
    }

    /// Step 4 of the module docs; returns (points filled, points
    /// relabelled).
    fn clean(&self, code: &mut [u8], height: &mut [f64]) -> (usize, usize) {
        // the seen points' largest component
        for i in all_but_the_largest(self.components(|i| code[i] != NONE)) {
            code[i] = NONE;
        }
        // the outline regularized: notches filled, spurs cut
        let mut filled = 0;
        for _ in 0..5 {
            let mut changes = Vec::new();
            for i in 0..code.len() {
                if self.on_border(i) {
                    continue;
                }
                let rim: Vec<usize> = self.neighbours(i).filter(|&j| code[j] != NONE).collect();
                if code[i] == NONE && rim.len() >= 3 {
                    let h = rim.iter().map(|&j| height[j]).sum::<f64>() / rim.len() as f64;
                    let ants = rim.iter().filter(|&&j| code[j] == ANT).count();
                    changes.push((i, if 2 * ants >= rim.len() { ANT } else { POST }, h));
                } else if code[i] != NONE && rim.len() <= 1 {
                    changes.push((i, NONE, height[i]));
                }
            }
            if changes.is_empty() {
                break;
            }
            for (i, l, h) in changes {
                if l != NONE {
                    filled += 1;
                }
                code[i] = l;
                height[i] = h;
            }
        }
        let seen = code.iter().filter(|&&x| x != NONE).count();
        // small holes
        let max_hole = (seen / 100).max(4);
        for hole in self.components(|i| code[i] == NONE) {
            if hole.len() > max_hole || hole.iter().any(|&i| self.on_border(i)) {
                continue;
            }
            let mut left: Vec<usize> = hole;
            while !left.is_empty() {
                let mut next = Vec::new();
                let mut done = Vec::new();
                for &i in &left {
                    let rim: Vec<usize> = self.neighbours(i).filter(|&j| code[j] != NONE).collect();
                    if rim.is_empty() {
                        next.push(i);
                    } else {
                        let h = rim.iter().map(|&j| height[j]).sum::<f64>() / rim.len() as f64;
                        let ants = rim.iter().filter(|&&j| code[j] == ANT).count();
                        let l = if 2 * ants >= rim.len() { ANT } else { POST };
                        done.push((i, l, h));
                    }
                }
                if done.is_empty() {
                    break;
                }
                for (i, l, h) in done {
                    code[i] = l;
                    height[i] = h;
                    filled += 1;
                }
                left = next;
            }
        }
        // each leaflet's largest component
        let mut relabelled = 0;
        for l in [ANT, POST] {
            let comps = self.components(|i| code[i] == l);
            let Some(big) = comps.iter().map(Vec::len).max() else {
                continue;
            };
            let mut first = true;
            for comp in &comps {
                if comp.len() == big && first {
                    first = false;
                    continue;
                }
                for &i in comp {
                    code[i] = other(l);
                    relabelled += 1;
                }
            }
        }
        (filled, relabelled)
    }

    /// `sweeps` of `h <- (h + mean of the seen 4-neighbours) / 2` on the
    /// seen points.
    fn smooth(&self, code: &[u8], height: &mut [f64], sweeps: usize) {
        for _ in 0..sweeps {
            let prev = height.to_vec();
            for i in 0..code.len() {
                if code[i] == NONE {
                    continue;
                }
                let (mut sum, mut count) = (0.0, 0usize);
                for j in self.neighbours(i) {
                    if code[j] != NONE {
                        sum += prev[j];
                        count += 1;
                    }
                }
                if count > 0 {
                    height[i] = 0.5 * (prev[i] + sum / count as f64);
                }
            }
        }
    }

    /// The corners of square `q`.
    fn corners(&self, q: usize) -> [usize; 4] {
        [q, q + 1, q + 1 + self.nu, q + self.nu]
    }

    /// Each square's leaflet (`NONE`: not all four corners seen).
    fn quads(&self, code: &[u8]) -> Vec<u8> {
        let mut quads = vec![NONE; code.len()];
        for b in 0..self.nv.saturating_sub(1) {
            for a in 0..self.nu.saturating_sub(1) {
                let q = a + self.nu * b;
                let ls = self.corners(q).map(|i| code[i]);
                if ls.contains(&NONE) {
                    continue;
                }
                let ants = ls.iter().filter(|&&l| l == ANT).count();
                quads[q] = match ants {
                    3 | 4 => ANT,
                    0 | 1 => POST,
                    _ => ls[0],
                };
            }
        }
        quads
    }

    /// The squares around grid point `i` that exist: (lower left, lower
    /// right, upper right, upper left) in square indices.
    fn around(&self, i: usize) -> Option<[usize; 4]> {
        let (a, b) = (i % self.nu, i / self.nu);
        if a == 0 || b == 0 || a + 1 >= self.nu || b + 1 >= self.nv {
            return None;
        }
        Some([i - 1 - self.nu, i - self.nu, i, i - 1])
    }

    /// Separates squares that meet only at a corner, keeps connected
    /// pieces; step 5 of the module docs. Returns the squares changed.
    fn untangle(&self, quads: &mut [u8]) -> usize {
        let mut changed = 0;
        for _ in 0..50 {
            let mut round = 0;
            // the valve: squares meeting only at a corner lose one
            round += self.corner_contacts(quads, |l| l != NONE, |_| NONE);
            for q in all_but_the_largest(self.components(|q| quads[q] != NONE)) {
                quads[q] = NONE;
                round += 1;
            }
            for l in [ANT, POST] {
                round += self.corner_contacts(quads, |x| x == l, |_| other(l));
                for q in all_but_the_largest(self.components(|q| quads[q] == l)) {
                    quads[q] = other(l);
                    round += 1;
                }
                // the other leaflet's pieces that `l` encloses
                for comp in self.components(|q| quads[q] == other(l)) {
                    let on_border = comp.iter().any(|&q| self.on_border(q));
                    if !on_border && self.enclosed_by(quads, &comp, l) {
                        for &q in &comp {
                            quads[q] = l;
                            round += 1;
                        }
                    }
                }
            }
            changed += round;
            if round == 0 {
                break;
            }
        }
        changed
    }

    /// Whether every square next to `comp` (outside it) belongs to `l`.
    fn enclosed_by(&self, quads: &[u8], comp: &[usize], l: u8) -> bool {
        let inside: BTreeSet<usize> = comp.iter().copied().collect();
        comp.iter().all(|&q| {
            self.neighbours(q)
                .all(|r| inside.contains(&r) || quads[r] == l)
        })
    }

    /// Where the squares `member` holds meet only at a corner (two diagonal
    /// squares around a point, the other two not members), the first of the
    /// two gets `replace`; returns the squares changed.
    fn corner_contacts(
        &self,
        quads: &mut [u8],
        member: impl Fn(u8) -> bool,
        replace: impl Fn(u8) -> u8,
    ) -> usize {
        let mut changed = 0;
        for i in 0..quads.len() {
            let Some(sq) = self.around(i) else {
                continue;
            };
            let m = sq.map(|q| member(quads[q]));
            let diagonal = (m[0] && m[2] && !m[1] && !m[3]) || (m[1] && m[3] && !m[0] && !m[2]);
            if diagonal {
                let q = if m[0] { sq[0] } else { sq[1] };
                quads[q] = replace(quads[q]);
                changed += 1;
            }
        }
        changed
    }

    /// Each valve square's triangles (grid points, counter-clockwise about
    /// `n`) with its leaflet. A corner that no other square of the valve
    /// has (a staircase corner of the outline) is cut off: its square keeps
    /// the one triangle without it, so the outline runs at 45 degrees there
    /// (a grid staircase is up to 4/pi times longer than the curve it
    /// follows).
    fn triangles(&self, quads: &[u8]) -> Vec<(u8, [usize; 3])> {
        let mut squares_at = vec![0u8; quads.len()];
        for (q, &l) in quads.iter().enumerate() {
            if l != NONE {
                for i in self.corners(q) {
                    squares_at[i] += 1;
                }
            }
        }
        let mut out = Vec::new();
        for (q, &l) in quads.iter().enumerate() {
            if l == NONE {
                continue;
            }
            let c = self.corners(q);
            match (0..4).find(|&k| squares_at[c[k]] == 1) {
                Some(k) => out.push((l, [c[(k + 1) % 4], c[(k + 2) % 4], c[(k + 3) % 4]])),
                None => {
                    out.push((l, [c[0], c[1], c[2]]));
                    out.push((l, [c[0], c[2], c[3]]));
                }
            }
        }
        out
    }

    /// The triangle mesh of the triangles of leaflet `l` (`NONE`: every
    /// one), its vertices marked in `used`.
    fn leaflet(
        &self,
        triangles: &[(u8, [usize; 3])],
        l: u8,
        used: &mut [bool],
        position: impl Fn(usize) -> Point3<f64>,
    ) -> TriMesh {
        let mut index = vec![u32::MAX; used.len()];
        let mut positions = Vec::new();
        let mut out = Vec::new();
        for &(tl, t) in triangles {
            if l != NONE && tl != l {
                continue;
            }
            out.push(t.map(|i| {
                if index[i] == u32::MAX {
                    index[i] = positions.len() as u32;
                    positions.push(position(i));
                    used[i] = true;
                }
                index[i]
            }));
        }
        TriMesh::new(positions, out)
    }

    /// The distance between the nearest grid points of the two leaflets,
    /// mm (grid spacing `s`).
    fn gap(&self, used: &[Vec<bool>; 2], s: f64) -> f64 {
        let pts = |k: usize| -> Vec<(f64, f64)> {
            (0..used[k].len())
                .filter(|&i| used[k][i])
                .map(|i| ((i % self.nu) as f64, (i / self.nu) as f64))
                .collect()
        };
        let (a, b) = (pts(0), pts(1));
        let mut best = f64::INFINITY;
        for p in &a {
            for q in &b {
                best = best.min(((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt());
            }
        }
        best * s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitral::SegmentationError as E;
    use crate::mitral::{MitralError, Pipeline, ValveInput};
    use unfold_mesh::shapes::{ValveLabelParams, valve_labels};

    #[test]
    fn all_but_the_first_largest_component_is_dropped() {
        let comps = vec![vec![1], vec![2, 3, 4], vec![5, 6], vec![7, 8, 9]];
        assert_eq!(all_but_the_largest(comps), vec![1, 5, 6, 7, 8, 9]);
        assert!(all_but_the_largest(Vec::new()).is_empty());
        assert!(all_but_the_largest(vec![vec![1, 2]]).is_empty());
    }

    const LABELS: LeafletLabels = LeafletLabels {
        anterior: 2,
        posterior: 3,
        annulus: Some(1),
    };

    fn seg_error(r: Result<SegmentedValve, OrganError>) -> SegmentationError {
        match r {
            Err(OrganError::Mitral(MitralError::Segmentation(e))) => e,
            other => panic!(
                "expected a segmentation error, got {:?}",
                other.map(|v| v.report)
            ),
        }
    }

    #[test]
    fn the_synthetic_valve_is_cut_into_two_disks_on_its_ring() {
        let p = ValveLabelParams::default();
        let labels = valve_labels(&p);
        for which in [
            LABELS,
            LeafletLabels {
                annulus: None,
                ..LABELS
            },
        ] {
            let v = valve_from_labels(&labels, which, None).unwrap();
            let r = &v.report;
            // the atrium is the valve frame's +z, rotated into the world
            let up = p.rotation * Vector3::z();
            let n = Vector3::from(r.atrial_direction);
            assert!(n.dot(&up) > 0.95, "atrial direction {n:?} vs {up:?}");
            assert!(r.shared_vertices >= 10, "{r:?}");
            let want = p.ring_length_mm();
            assert!(
                (r.ring_length_mm / want - 1.0).abs() < 0.1,
                "ring {} vs {want}",
                r.ring_length_mm
            );
            if let Some(l) = r.annulus_label_length_mm {
                assert!((l / want - 1.0).abs() < 0.05, "label ring {l} vs {want}");
            }
            // every leaflet triangle faces the atrium
            for m in [&v.anterior, &v.posterior] {
                for t in 0..m.num_triangles() {
                    let [a, b, c] = m.triangle_points(t);
                    assert!((b - a).cross(&(c - a)).dot(&n) > 0.0);
                }
            }
            let out = Pipeline::new()
                .run(&ValveInput {
                    anterior: &v.anterior,
                    posterior: &v.posterior,
                    annulus: &v.ring,
                })
                .unwrap();
            assert_eq!(out.report.flipped_triangles, 0);
        }
    }

    #[test]
    fn bad_label_maps_are_refused_with_their_fix() {
        let p = ValveLabelParams::default();
        let labels = valve_labels(&p);
        let e = seg_error(valve_from_labels(
            &labels,
            LeafletLabels {
                anterior: 7,
                ..LABELS
            },
            None,
        ));
        assert!(
            matches!(e, E::MissingLabel { label: 7, .. })
                && e.to_string().contains("holds labels 0, 1, 2, 3"),
            "{e}"
        );
        let e = seg_error(valve_from_labels(
            &labels,
            LeafletLabels {
                posterior: 2,
                ..LABELS
            },
            None,
        ));
        assert!(matches!(e, E::SameLabel { label: 2, .. }), "{e}");
        let grey = labels.map(|v| v * 0.37);
        let e = seg_error(valve_from_labels(&grey, LABELS, None));
        assert!(matches!(e, E::NotLabels { .. }), "{e}");
        // a band cut between the leaflets, annulus left out
        let mut moved = labels.clone();
        let half = p.radius_mm + p.tube_mm + 3.0 * p.voxel_mm;
        let [nx, ny, nz, _] = moved.dims();
        let data = moved.data_mut();
        for k in 0..nz {
            for j in 0..ny {
                let y = -half + j as f64 * p.voxel_mm;
                for i in 0..nx {
                    let at = i + nx * (j + ny * k);
                    if (data[at] == 2.0 || data[at] == 3.0) && (y - p.coaptation_y_mm).abs() < 2.0 {
                        data[at] = 0.0;
                    }
                }
            }
        }
        let e = seg_error(valve_from_labels(
            &moved,
            LeafletLabels {
                annulus: None,
                ..LABELS
            },
            None,
        ));
        assert!(matches!(e, E::LeafletsApart { .. }), "{e}");
    }
}
