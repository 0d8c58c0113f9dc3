//! The enclosing surface S built from the anatomy itself ([PA17] Sec.
//! 4.2.3; ALGORITHMS 3.9), for a user who has no hand-made S:
//! [`enclosing_surface`].
//!
//! 1. **The anatomy's solid.** Its cells as triangles: a tet mesh by its
//!    boundary faces (faces used by one tet), a triangle mesh (closed or
//!    open) as it is; bare points or lines are refused.
//! 2. **The basal plane.** The plane through the two rim landmarks `a`, `i`
//!    (which lie on or near the basal rim) that the anatomy protrudes above
//!    the least: with `l = (i - a) / |i - a|` and `u`, `v` completing it to
//!    an orthonormal frame, the normal `n(theta) = cos(theta) u + sin(theta) v`
//!    minimizing `g(theta) = max_p n(theta) . (p - a)` over the anatomy's
//!    points `p` (exactly: `g` is the support function of the points
//!    projected along `l`, minimized over the edge normals of their 2D convex
//!    hull and the directions opposite its vertices). `n` points towards the
//!    base (the anatomy lies below), `-n` is the long axis towards the apex;
//!    `h* = g(theta*)` is the height of the highest point of the basal rim.
//!    The grid below is aligned with the frame `(l, n x l, n)` at `a`, so a
//!    rigid motion of the input moves S with it.
//! 3. **Voxels and dilation.** On a grid of spacing `h` (the voxel size,
//!    [PA17]: 0.5 mm), the distance `d(x)` from each node to the anatomy's
//!    triangles (exact, within a band `margin + 2 h`), and the field
//!    `f(x) = d(x) - margin`: `f < 0` is the anatomy dilated by `margin`
//!    ([PA17]: 1.0 mm). Nodes with `f >= 0` that cannot be reached from the
//!    grid's border through nodes with `f >= 0` (inside a closed surface or
//!    a tet mesh, farther than `margin` from its boundary) are filled
//!    (`f = -h`): the holes are closed. (`f = 0` counts as outside, as in
//!    the surface extraction, so a layer of nodes exactly at the margin
//!    inside a wall is filled, not left as a sheet of zero thickness.)
//! 4. **Surface.** The zero set of the piecewise-linear `f` by marching
//!    tetrahedra ([`unfold_mesh::marching_tets`]): a closed, oriented
//!    surface at distance `margin` from the anatomy. Every anatomy point `p`
//!    is inside it when `margin > sqrt(3) h`: `f(p) = -margin`, `d` is
//!    1-Lipschitz, so the interpolant at `p` (from the corners of a tet of
//!    diameter `sqrt(3) h`) is at most `-margin + sqrt(3) h < 0`; smaller
//!    margins are refused.
//! 5. **Smoothing.** Taubin's lambda|mu iterations
//!    ([`unfold_mesh::taubin`]; [PA17] uses VTK's windowed sinc, another
//!    non-shrinking low-pass filter).
//! 6. **Cut.** The plane `n . (x - a) = h* + margin / 4` (orthogonal to the
//!    long axis, a quarter of the margin above the highest point of the
//!    basal rim, so every anatomy point is below it) clips the surface
//!    ([`unfold_mesh::clip`]); below it, a cup-shaped anatomy leaves two
//!    pieces, the outer side of its wall and the inner one facing the
//!    cavity. S is the piece enclosing the largest volume with the plane
//!    (`sum_t det(x_a - o, x_b - o, x_c - o) / 6` over its triangles, `o` on
//!    the plane): the outer one. It must be a disk (one boundary loop), and
//!    the point `h + margin / 4` below the centroid of its rim must be
//!    inside it closed by the plane (winding number > 1/2 by solid angles):
//!    where the rim dips more than about `3 margin / 4` below its highest
//!    point, the plane passes over the wall, the two sides stay joined and
//!    the cavity would be outside S; that is refused.
//! 7. **Checks.** Every anatomy point lies inside S (on the inner side of
//!    the triangle closest to it); the smallest distance is reported.
//!
//! The rim landmarks given lie on the anatomy's rim, not on S's (which is
//! a wall thickness plus the margin away): each is carried to the rim
//! vertex of S at the nearest angle about the axis through the rim's
//! centroid (`rim_landmarks`), as [PA17] Sec. 3.1 derives rim points from
//! rays from the rim's centroid.
//!
//! [PA17]: B. Paun et al., "Patient independent representation of the
//! detailed cardiac ventricular anatomy", Medical Image Analysis 35, 2017
//! (the project's seed 003).

use crate::{ConfigError, OrganError, Requirement};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::time::Instant;
use thiserror::Error;
use unfold_mesh::clip::clip_below;
use unfold_mesh::geometry::{convex_hull_2d, winding_number};
use unfold_mesh::marching_tets::isosurface;
use unfold_mesh::nalgebra::{Matrix3, Point3, Vector3};
use unfold_mesh::spatial::{ClosestPointQuery, closest_point_on_triangle};
use unfold_mesh::taubin::{Taubin, taubin_smooth};
use unfold_mesh::topology::{connected_components, disk_boundary_loop};
use unfold_mesh::{CellMesh, CellType, MeshError, TriMesh};

/// Default voxel size, mm ([PA17] Sec. 4.2.3).
pub const DEFAULT_VOXEL_MM: f64 = 0.5;
/// Default dilation, mm ([PA17] Sec. 4.2.3).
pub const DEFAULT_MARGIN_MM: f64 = 1.0;
/// Default Taubin iterations.
pub const DEFAULT_SMOOTHING_ITERATIONS: usize = 10;
/// Largest grid, nodes (a 4-byte value and a 1-byte flag each: 200 MB).
pub const MAX_GRID_NODES: usize = 40_000_000;
/// The cut plane lies this fraction of the margin above the highest point
/// of the basal rim.
pub const CUT_ABOVE_MARGIN: f64 = 0.25;

/// Settings of [`enclosing_surface`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnclosingConfig {
    /// Grid spacing `h`, mm.
    pub voxel_mm: f64,
    /// Dilation, mm (more than `sqrt(3) h`).
    pub margin_mm: f64,
    /// Taubin iterations (0: none).
    pub smoothing_iterations: usize,
}

impl Default for EnclosingConfig {
    fn default() -> Self {
        EnclosingConfig {
            voxel_mm: DEFAULT_VOXEL_MM,
            margin_mm: DEFAULT_MARGIN_MM,
            smoothing_iterations: DEFAULT_SMOOTHING_ITERATIONS,
        }
    }
}

/// What the anatomy's cells are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AnatomyKind {
    /// Tets (their boundary faces are used).
    Tets,
    /// Triangles, every edge shared by two.
    ClosedSurface,
    /// Triangles with a boundary.
    OpenSurface,
}

/// Why S cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum EnclosingError {
    /// No triangle, polygon or tet to voxelize.
    #[error(
        "the anatomy has {points} points and no surface or tet cells ({cells} cells): building \
         S needs a surface or tets (or give S with --surface)"
    )]
    NoCells {
        /// Points of the anatomy.
        points: usize,
        /// Its cells (points, lines).
        cells: usize,
    },
    /// A volume cell other than a tet.
    #[error("cell {cell} of the anatomy is a {kind:?}; building S needs tets or surface cells")]
    UnsupportedCell {
        /// The cell.
        cell: usize,
        /// Its type.
        kind: CellType,
    },
    /// The margin does not exceed `sqrt(3)` voxels.
    #[error(
        "the dilation {margin_mm} mm must exceed sqrt(3) voxels ({min_mm:.4} mm for voxels of \
         {voxel_mm} mm), or anatomy points may fall outside S"
    )]
    MarginBelowVoxels {
        /// The margin, mm.
        margin_mm: f64,
        /// The voxel size, mm.
        voxel_mm: f64,
        /// `sqrt(3)` voxels, mm.
        min_mm: f64,
    },
    /// The two rim landmarks (nearly) coincide.
    #[error("the two rim landmarks are {distance_mm:.3e} mm apart; they must be distinct points")]
    LandmarksCoincide {
        /// Their distance, mm.
        distance_mm: f64,
    },
    /// The anatomy has (almost) no extent along the long axis.
    #[error(
        "the anatomy extends {height_mm:.3} mm from the basal plane towards the apex, less than \
         twice the dilation ({min_mm} mm): a flat anatomy encloses no chamber"
    )]
    Flat {
        /// Its extent below the basal plane, mm.
        height_mm: f64,
        /// The least accepted, mm.
        min_mm: f64,
    },
    /// The given apex lies on the base side of the basal plane.
    #[error(
        "the apex {apex:?} is {height_mm:.3} mm above the basal plane through the rim \
         landmarks; it must be below it, on the anatomy's far side"
    )]
    ApexAboveBase {
        /// The apex, mm.
        apex: [f64; 3],
        /// Its height above the plane, mm.
        height_mm: f64,
    },
    /// The grid would be too large.
    #[error(
        "the voxel grid would have {dims:?} = {nodes} nodes at {voxel_mm} mm, more than {max} \
         ({} MB); give a larger voxel size (about {suggested_mm:.2} mm fits)",
        .max * 5 / 1_000_000
    )]
    GridTooLarge {
        /// Nodes per axis.
        dims: [usize; 3],
        /// Their product.
        nodes: usize,
        /// The largest accepted.
        max: usize,
        /// The voxel size asked for, mm.
        voxel_mm: f64,
        /// A voxel size whose grid fits, mm.
        suggested_mm: f64,
    },
    /// The cut leaves nothing, or no disk.
    #[error(
        "the cut at the basal plane leaves no disk: {0} (a basal rim far from level, or holes in \
         the anatomy; give S with --surface)"
    )]
    NotADisk(#[source] MeshError),
    /// The cut does not separate the wall's two sides.
    #[error(
        "the cut {cut_mm:.3} mm above the landmarks' plane does not separate the outer side of \
         the wall from the cavity (the point {probe:?} below the rim's centroid is outside the \
         kept surface, winding number {winding:.3}): the basal rim dips more than about 3/4 of \
         the dilation below its highest point; give a larger dilation or S itself"
    )]
    NotSeparated {
        /// Height of the cut plane above the landmarks, mm.
        cut_mm: f64,
        /// The point tested, mm.
        probe: [f64; 3],
        /// Its winding number.
        winding: f64,
    },
    /// Anatomy points outside S.
    #[error(
        "{count} anatomy points lie outside the built S (e.g. point {point} at {distance_mm:.4} \
         mm); a finer voxel size or a larger dilation keeps S off the anatomy"
    )]
    AnatomyOutside {
        /// How many.
        count: usize,
        /// The first.
        point: usize,
        /// Its distance to S, mm.
        distance_mm: f64,
    },
    /// A mesh step failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// How S was built (`enclosing_surface` in `report.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnclosingReport {
    /// What the anatomy's cells are.
    pub anatomy: AnatomyKind,
    /// Triangles voxelized (boundary faces of tets).
    pub anatomy_triangles: usize,
    /// Grid spacing, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub voxel_mm: f64,
    /// Dilation, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub margin_mm: f64,
    /// Grid nodes per axis.
    pub grid: [usize; 3],
    /// Nodes filled as enclosed (inside a closed anatomy).
    pub filled_nodes: usize,
    /// Triangles of the closed dilated surface.
    pub closed_surface_triangles: usize,
    /// Taubin iterations.
    pub smoothing_iterations: usize,
    /// Taubin's lambda.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub smoothing_lambda: f64,
    /// Taubin's mu.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub smoothing_mu: f64,
    /// A point of the cut plane (the centroid of S's rim), mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub cut_point_mm: [f64; 3],
    /// The cut plane's unit normal, towards the base (the part removed).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub cut_normal: [f64; 3],
    /// Height of the highest anatomy point above the landmarks' plane, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub highest_point_mm: f64,
    /// Height of the cut above that point, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub cut_above_highest_mm: f64,
    /// Pieces left below the plane (2 for a cup's two sides).
    pub pieces_below_cut: usize,
    /// Vertices of S.
    pub vertices: usize,
    /// Triangles of S.
    pub triangles: usize,
    /// Smallest distance from an anatomy point to S, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub min_clearance_mm: f64,
    /// The rim landmarks given, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub landmarks_given_mm: [[f64; 3]; 2],
    /// The rim vertices of S they were carried to, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub rim_landmarks_mm: [[f64; 3]; 2],
    /// Wall-clock time, s.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
}

/// The result of [`enclosing_surface`].
#[derive(Debug, Clone)]
pub struct Enclosing {
    /// S: a disk, its boundary loop the basal rim, normals outward.
    pub surface: TriMesh,
    /// The rim landmarks on S's rim (anterior, inferior).
    pub rim_landmarks: [Point3<f64>; 2],
    /// How it was built.
    pub report: EnclosingReport,
}

/// The anatomy's triangles (see the module doc, step 1).
fn anatomy_triangles(anatomy: &CellMesh) -> Result<(Vec<[u32; 3]>, AnatomyKind), EnclosingError> {
    let mut tris = Vec::new();
    let mut faces: HashMap<[u32; 3], ([u32; 3], u32)> = HashMap::new();
    let mut tets = false;
    for (c, (t, vs)) in anatomy.cells().enumerate() {
        match t {
            CellType::Tetra => {
                tets = true;
                for f in [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]] {
                    let face = f.map(|k| vs[k]);
                    let mut key = face;
                    key.sort_unstable();
                    faces.entry(key).or_insert((face, 0)).1 += 1;
                }
            }
            t if t.dimension() == 3 => {
                return Err(EnclosingError::UnsupportedCell { cell: c, kind: t });
            }
            t if t.dimension() == 2 => {
                for k in 1..vs.len().saturating_sub(1) {
                    tris.push([vs[0], vs[k], vs[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if tets {
        tris.extend(faces.into_values().filter(|(_, n)| *n == 1).map(|(f, _)| f));
    }
    if tris.is_empty() {
        return Err(EnclosingError::NoCells {
            points: anatomy.num_points(),
            cells: anatomy.num_cells(),
        });
    }
    let kind = if tets {
        AnatomyKind::Tets
    } else {
        // vertices at the same position are one (files often repeat them
        // along seams)
        let mut first: HashMap<[u64; 3], u32> = HashMap::new();
        let same: Vec<u32> = anatomy
            .positions
            .iter()
            .enumerate()
            .map(|(v, p)| {
                *first
                    .entry([p.x, p.y, p.z].map(f64::to_bits))
                    .or_insert(v as u32)
            })
            .collect();
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &tris {
            let t = t.map(|v| same[v as usize]);
            for k in 0..3 {
                let (p, q) = (t[k], t[(k + 1) % 3]);
                *uses.entry((p.min(q), p.max(q))).or_default() += 1;
            }
        }
        if uses.values().all(|&n| n == 2) {
            AnatomyKind::ClosedSurface
        } else {
            AnatomyKind::OpenSurface
        }
    };
    Ok((tris, kind))
}

/// The basal plane through `a` and `i` (module doc, step 2): the unit
/// normal towards the base and the highest height `h*` of a point above it.
///
/// # Errors
/// [`EnclosingError::LandmarksCoincide`].
pub fn basal_plane(
    points: &[Point3<f64>],
    a: &Point3<f64>,
    i: &Point3<f64>,
) -> Result<(Vector3<f64>, f64), EnclosingError> {
    let li = i - a;
    let len = li.norm();
    let scale = points
        .iter()
        .map(|p| (p - a).norm())
        .fold(len, f64::max)
        .max(f64::MIN_POSITIVE);
    if !len.is_finite() || len <= 1e-9 * scale {
        return Err(EnclosingError::LandmarksCoincide { distance_mm: len });
    }
    let l = li / len;
    let seed = if l.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = (seed - l * l.dot(&seed)).normalize();
    let v = l.cross(&u);
    let q: Vec<[f64; 2]> = points
        .iter()
        .map(|p| [(p - a).dot(&u), (p - a).dot(&v)])
        .collect();
    let hull = convex_hull_2d(&q);
    let support = |t: f64| {
        let (c, s) = (t.cos(), t.sin());
        hull.iter()
            .map(|x| c * x[0] + s * x[1])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let mut candidates: Vec<f64> = Vec::new();
    for k in 0..hull.len() {
        let (p, r) = (hull[k], hull[(k + 1) % hull.len()]);
        // outward normal of the counter-clockwise edge p -> r
        let (dx, dy) = (r[0] - p[0], r[1] - p[1]);
        if dx != 0.0 || dy != 0.0 {
            candidates.push((-dx).atan2(dy));
        }
        if p[0] != 0.0 || p[1] != 0.0 {
            candidates.push((-p[1]).atan2(-p[0]));
        }
    }
    if candidates.is_empty() {
        candidates.push(0.0);
    }
    let (best, g) = candidates
        .iter()
        .map(|&t| (t, support(t)))
        .min_by(|x, y| x.1.total_cmp(&y.1))
        .expect("at least one candidate");
    let n = u * best.cos() + v * best.sin();
    Ok((n, g))
}

/// Builds S from the anatomy (module doc). `landmarks` are the anterior
/// and inferior rim landmarks, `apex` an optional apex (checked to lie
/// below the basal plane).
///
/// # Errors
/// [`OrganError::Config`] for a voxel size or margin that is not finite
/// and positive or more than 1000 smoothing iterations; the
/// [`EnclosingError`]s (as [`super::VentricleError::Enclosing`]).
pub fn enclosing_surface(
    anatomy: &CellMesh,
    landmarks: [Point3<f64>; 2],
    apex: Option<Point3<f64>>,
    config: &EnclosingConfig,
) -> Result<Enclosing, OrganError> {
    let start = Instant::now();
    ConfigError::check("surface voxel size", config.voxel_mm, Requirement::Positive)?;
    ConfigError::check("surface dilation", config.margin_mm, Requirement::Positive)?;
    ConfigError::check(
        "surface smoothing iterations",
        config.smoothing_iterations as f64,
        Requirement::CountWithin(0, 1000),
    )?;
    build(anatomy, landmarks, apex, config, start)
        .map_err(|e| super::VentricleError::from(Box::new(e)).into())
}

fn build(
    anatomy: &CellMesh,
    landmarks: [Point3<f64>; 2],
    apex: Option<Point3<f64>>,
    config: &EnclosingConfig,
    start: Instant,
) -> Result<Enclosing, EnclosingError> {
    let (h, margin) = (config.voxel_mm, config.margin_mm);
    let min_margin = 3f64.sqrt() * h;
    if margin <= min_margin {
        return Err(EnclosingError::MarginBelowVoxels {
            margin_mm: margin,
            voxel_mm: h,
            min_mm: min_margin,
        });
    }
    anatomy.check()?;
    let (tris, kind) = anatomy_triangles(anatomy)?;
    let points = &anatomy.positions;
    let [a, i] = landmarks;
    let (n, top) = basal_plane(points, &a, &i)?;
    // the frame (e1, e2, n) at a
    let e1 = (i - a).normalize();
    let e2 = n.cross(&e1);
    let r = Matrix3::from_columns(&[e1, e2, n]);
    let local = |p: &Point3<f64>| Point3::from(r.transpose() * (p - a));
    let world = |q: &Point3<f64>| a + r * q.coords;
    let q: Vec<Point3<f64>> = points.iter().map(local).collect();
    let bottom = q.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
    if top - bottom < 2.0 * margin {
        return Err(EnclosingError::Flat {
            height_mm: top - bottom,
            min_mm: 2.0 * margin,
        });
    }
    if let Some(x) = apex {
        let z = local(&x).z;
        if z >= top {
            return Err(EnclosingError::ApexAboveBase {
                apex: [x.x, x.y, x.z],
                height_mm: z,
            });
        }
    }
    let cut = top + CUT_ABOVE_MARGIN * margin;
    // the grid: the anatomy's box padded by the band and a node
    let band = margin + 2.0 * h;
    let pad = band + h;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &q {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] - pad);
            hi[k] = hi[k].max(p[k] + pad);
        }
    }
    let dims_at = |h: f64| [0, 1, 2].map(|k| ((hi[k] - lo[k]) / h).ceil() as usize + 1);
    let dims = dims_at(h);
    let nodes = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .unwrap_or(usize::MAX);
    if nodes > MAX_GRID_NODES {
        let volume: f64 = (0..3).map(|k| hi[k] - lo[k]).product();
        let mut suggested = (volume / MAX_GRID_NODES as f64).cbrt();
        while dims_at(suggested).iter().product::<usize>() > MAX_GRID_NODES {
            suggested *= 1.05;
        }
        return Err(EnclosingError::GridTooLarge {
            dims,
            nodes,
            max: MAX_GRID_NODES,
            voxel_mm: h,
            suggested_mm: suggested,
        });
    }
    let [nx, ny, nz] = dims;
    let node = |ix: usize, iy: usize, iz: usize| ix + nx * (iy + ny * iz);
    // distances within the band, slabs of z-layers in parallel
    let ranges: Vec<[std::ops::RangeInclusive<usize>; 3]> = tris
        .iter()
        .map(|t| {
            let p = t.map(|v| q[v as usize]);
            [0, 1, 2].map(|k| {
                let a = p[0][k].min(p[1][k]).min(p[2][k]) - band;
                let b = p[0][k].max(p[1][k]).max(p[2][k]) + band;
                let i0 = ((a - lo[k]) / h).floor().max(0.0) as usize;
                let i1 = (((b - lo[k]) / h).ceil().max(0.0) as usize).min(dims[k] - 1);
                i0..=i1
            })
        })
        .collect();
    let mut d = vec![band as f32; nodes];
    let layer = nx * ny;
    let slab = nz.div_ceil(4 * rayon::current_num_threads().max(1)).max(1);
    d.par_chunks_mut(layer * slab)
        .enumerate()
        .for_each(|(c, chunk)| {
            let z0 = c * slab;
            let z1 = z0 + chunk.len() / layer;
            for (t, [rx, ry, rz]) in tris.iter().zip(&ranges) {
                let (za, zb) = ((*rz.start()).max(z0), (*rz.end() + 1).min(z1));
                if za >= zb {
                    continue;
                }
                let [p0, p1, p2] = t.map(|v| q[v as usize]);
                for iz in za..zb {
                    for iy in ry.clone() {
                        for ix in rx.clone() {
                            let x = Point3::new(
                                lo[0] + ix as f64 * h,
                                lo[1] + iy as f64 * h,
                                lo[2] + iz as f64 * h,
                            );
                            let (c, _) = closest_point_on_triangle(&x, &p0, &p1, &p2);
                            let dist = (x - c).norm() as f32;
                            let slot = &mut chunk[ix + nx * (iy + ny * (iz - z0))];
                            if dist < *slot {
                                *slot = dist;
                            }
                        }
                    }
                }
            }
        });
    let mut f: Vec<f32> = d.iter().map(|&x| x - margin as f32).collect();
    drop(d);
    // the outside: nodes with f >= 0 reached from the border
    let mut outside = vec![false; nodes];
    let mut stack: Vec<usize> = Vec::new();
    for iz in 0..nz {
        for iy in 0..ny {
            for ix in 0..nx {
                let border =
                    ix == 0 || iy == 0 || iz == 0 || ix == nx - 1 || iy == ny - 1 || iz == nz - 1;
                let v = node(ix, iy, iz);
                if border && f[v] >= 0.0 && !outside[v] {
                    outside[v] = true;
                    stack.push(v);
                }
            }
        }
    }
    while let Some(v) = stack.pop() {
        let (ix, iy, iz) = (v % nx, (v / nx) % ny, v / (nx * ny));
        let mut visit = |w: usize| {
            if f[w] >= 0.0 && !outside[w] {
                outside[w] = true;
                stack.push(w);
            }
        };
        if ix > 0 {
            visit(v - 1);
        }
        if ix + 1 < nx {
            visit(v + 1);
        }
        if iy > 0 {
            visit(v - nx);
        }
        if iy + 1 < ny {
            visit(v + nx);
        }
        if iz > 0 {
            visit(v - nx * ny);
        }
        if iz + 1 < nz {
            visit(v + nx * ny);
        }
    }
    let mut filled_nodes = 0;
    for (v, x) in f.iter_mut().enumerate() {
        if *x >= 0.0 && !outside[v] {
            *x = -(h as f32);
            filled_nodes += 1;
        }
    }
    drop(outside);
    let mut closed = isosurface(&f, dims)?;
    drop(f);
    for p in &mut closed.positions {
        *p = Point3::new(lo[0] + p.x * h, lo[1] + p.y * h, lo[2] + p.z * h);
    }
    let closed_surface_triangles = closed.num_triangles();
    let smoothing = Taubin {
        iterations: config.smoothing_iterations,
        ..Taubin::default()
    };
    taubin_smooth(&mut closed, &smoothing, &[])?;
    let below = clip_below(
        &closed,
        &Point3::new(0.0, 0.0, cut),
        &Vector3::z(),
        0.05 * h,
    )?;
    drop(closed);
    // the piece enclosing the largest volume with the plane
    let comps = connected_components(below.num_vertices(), &below.triangles);
    let o = Point3::new(0.0, 0.0, cut);
    let mut volume = vec![0.0; comps.count];
    for (t, tri) in below.triangles.iter().enumerate() {
        let [x, y, z] = tri.map(|v| below.positions[v as usize] - o);
        volume[comps.element_label[t] as usize] += x.dot(&y.cross(&z)) / 6.0;
    }
    let Some(keep) = (0..comps.count).max_by(|&x, &y| volume[x].total_cmp(&volume[y])) else {
        return Err(EnclosingError::NotADisk(MeshError::Empty {
            what: "triangles",
        }));
    };
    let kept: Vec<[u32; 3]> = below
        .triangles
        .iter()
        .enumerate()
        .filter(|(t, _)| comps.element_label[*t] as usize == keep)
        .map(|(_, tri)| *tri)
        .collect();
    let c = unfold_mesh::reindex::compact_vertices(
        &below.positions,
        &unfold_mesh::Fields::default(),
        &kept,
    )?;
    let mut s = TriMesh::new(c.positions, c.elements);
    let rim = disk_boundary_loop(&s).map_err(EnclosingError::NotADisk)?;
    let centroid = rim
        .iter()
        .map(|&v| s.positions[v as usize].coords)
        .sum::<Vector3<f64>>()
        / rim.len() as f64;
    let centre = Point3::new(centroid.x, centroid.y, cut);
    // the cavity below the rim's centroid must be inside S closed by the plane
    let probe = centre - Vector3::z() * (h + CUT_ABOVE_MARGIN * margin);
    let mut cap_positions = s.positions.clone();
    cap_positions.push(centre);
    let hub = (cap_positions.len() - 1) as u32;
    let mut capped = s.triangles.clone();
    for k in 0..rim.len() {
        capped.push([rim[(k + 1) % rim.len()], rim[k], hub]);
    }
    let winding = winding_number(&probe, &cap_positions, &capped);
    if winding < 0.5 {
        let p = world(&probe);
        return Err(EnclosingError::NotSeparated {
            cut_mm: cut,
            probe: [p.x, p.y, p.z],
            winding,
        });
    }
    // every anatomy point inside S
    let query = ClosestPointQuery::new(&s);
    let mut min_clearance = f64::INFINITY;
    let mut outside_count = 0;
    let mut first_outside = None;
    for (k, p) in q.iter().enumerate() {
        let Some(cp) = query.closest(p) else { continue };
        min_clearance = min_clearance.min(cp.distance);
        let [x, y, z] = s.triangle_points(cp.triangle);
        let normal = (y - x).cross(&(z - x));
        if (p - cp.point).dot(&normal) > 0.0 {
            outside_count += 1;
            first_outside.get_or_insert((k, cp.distance));
        }
    }
    if let Some((point, distance_mm)) = first_outside {
        return Err(EnclosingError::AnatomyOutside {
            count: outside_count,
            point,
            distance_mm,
        });
    }
    // the landmarks carried to S's rim at the nearest angle about the axis
    let carried = [a, i].map(|l| {
        let dir = {
            let x = local(&l) - centre;
            Vector3::new(x.x, x.y, 0.0)
        };
        let best = rim
            .iter()
            .map(|&v| {
                let x = s.positions[v as usize] - centre;
                let x = Vector3::new(x.x, x.y, 0.0);
                let cos = x.dot(&dir) / (x.norm() * dir.norm()).max(f64::MIN_POSITIVE);
                (v, cos)
            })
            .max_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(v, _)| v)
            .expect("a disk's rim has vertices");
        world(&s.positions[best as usize])
    });
    for p in &mut s.positions {
        *p = world(p);
    }
    let cw = world(&centre);
    let arr = |p: &Point3<f64>| [p.x, p.y, p.z];
    let report = EnclosingReport {
        anatomy: kind,
        anatomy_triangles: tris.len(),
        voxel_mm: h,
        margin_mm: margin,
        grid: dims,
        filled_nodes,
        closed_surface_triangles,
        smoothing_iterations: smoothing.iterations,
        smoothing_lambda: smoothing.lambda,
        smoothing_mu: smoothing.mu,
        cut_point_mm: arr(&cw),
        cut_normal: [n.x, n.y, n.z],
        highest_point_mm: top,
        cut_above_highest_mm: cut - top,
        pieces_below_cut: comps.count,
        vertices: s.num_vertices(),
        triangles: s.num_triangles(),
        min_clearance_mm: min_clearance,
        landmarks_given_mm: [arr(&a), arr(&i)],
        rim_landmarks_mm: carried.map(|p| arr(&p)),
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok(Enclosing {
        surface: s,
        rim_landmarks: carried,
        report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::nalgebra::{Rotation3, Translation3};
    use unfold_mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};

    fn cup() -> VentricleShape {
        ventricle_cup(&VentricleParams {
            rings: 16,
            ..VentricleParams::default()
        })
        .unwrap()
    }

    /// Coarse settings for tests (1.5 mm voxels, 3 mm dilation).
    fn coarse() -> EnclosingConfig {
        EnclosingConfig {
            voxel_mm: 1.5,
            margin_mm: 3.0,
            smoothing_iterations: 10,
        }
    }

    fn built(anatomy: &CellMesh, v: &VentricleShape, config: &EnclosingConfig) -> Enclosing {
        enclosing_surface(anatomy, [v.anterior, v.inferior], Some(v.apex), config).unwrap()
    }

    #[test]
    fn the_cups_open_surface_gets_an_outer_disk_above_its_rim() {
        let v = cup();
        let anatomy = CellMesh::from(&v.surface);
        let e = built(&anatomy, &v, &coarse());
        let r = &e.report;
        assert_eq!(r.anatomy, AnatomyKind::OpenSurface);
        // the rim is at z = 0, the landmarks on it: the plane is z = 0
        assert!(r.highest_point_mm.abs() < 1e-9, "{}", r.highest_point_mm);
        assert!((Vector3::from(r.cut_normal) - Vector3::z()).norm() < 1e-9);
        assert!((r.cut_above_highest_mm - 0.75).abs() < 1e-12);
        // two sides of the wall below the cut; S is the outer one, a disk
        assert_eq!(r.pieces_below_cut, 2);
        let rim = disk_boundary_loop(&e.surface).unwrap();
        for &k in &rim {
            assert!((e.surface.positions[k as usize].z - 0.75).abs() < 1e-9);
        }
        // S stays about the margin outside the anatomy (the cup's radius 25)
        let mean_r = rim
            .iter()
            .map(|&k| {
                let p = e.surface.positions[k as usize];
                (p.x * p.x + p.y * p.y).sqrt()
            })
            .sum::<f64>()
            / rim.len() as f64;
        // the rim circle of the cup's ellipsoid at z = 0 plus the dilation
        // at 3/4 of it: sqrt(9 - 0.75^2) mm outward
        let cup_r = v
            .rim
            .iter()
            .map(|&k| {
                let p = v.surface.positions[k as usize];
                (p.x * p.x + p.y * p.y).sqrt()
            })
            .sum::<f64>()
            / v.rim.len() as f64;
        let expected = cup_r + (9.0f64 - 0.75 * 0.75).sqrt();
        assert!((mean_r - expected).abs() < 0.3, "{mean_r} vs {expected}");
        assert!(
            r.min_clearance_mm > 1.5 && r.min_clearance_mm < 3.5,
            "{}",
            r.min_clearance_mm
        );
        // the landmarks are carried outward at their angle
        for (given, carried) in [v.anterior, v.inferior].iter().zip(&e.rim_landmarks) {
            let a = given.y.atan2(given.x);
            let b = carried.y.atan2(carried.x);
            assert!((a - b).abs() < 0.1, "{a} vs {b}");
        }
        // outward normals: positive volume with the plane
        let o = Point3::new(0.0, 0.0, 0.75);
        let vol: f64 = (0..e.surface.num_triangles())
            .map(|t| {
                let [a, b, c] = e.surface.triangle_points(t).map(|p| p - o);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum();
        assert!(vol > 0.0);
    }

    #[test]
    fn a_closed_wall_is_filled_and_its_outer_side_kept() {
        // the boundary of a hemispherical shell 6 mm thick opening towards
        // +z, its rim at z = 23 between radii 20 and 26
        let shell = unfold_mesh::shapes::bowl_shell(&unfold_mesh::shapes::ShellParams {
            radius: 20.0,
            thickness: 6.0,
            half_angle_deg: 90.0,
            cells_radial: 10,
            cells_through: 2,
            ..Default::default()
        })
        .unwrap();
        let boundary = unfold_mesh::topology::tet_boundary(&shell.mesh)
            .unwrap()
            .surface;
        let anatomy = CellMesh::from(&boundary);
        let at = |deg: f64| {
            let a = deg.to_radians();
            Point3::new(23.0 * a.cos(), 23.0 * a.sin(), 23.0)
        };
        let config = EnclosingConfig {
            voxel_mm: 1.0,
            margin_mm: 2.0,
            smoothing_iterations: 10,
        };
        let e = enclosing_surface(&anatomy, [at(55.0), at(-55.0)], None, &config).unwrap();
        assert_eq!(e.report.anatomy, AnatomyKind::ClosedSurface);
        // the wall's middle is 3 mm from its faces, beyond the 2 mm margin
        assert!(e.report.filled_nodes > 0);
        assert_eq!(e.report.pieces_below_cut, 2);
        assert!(e.report.highest_point_mm.abs() < 1e-9);
        disk_boundary_loop(&e.surface).unwrap();
        // S is the outer side: its rim about 26 + 2 mm from the axis
        for p in &e.surface.positions {
            if (p.z - 23.5).abs() < 1e-9 {
                let r = (p.x * p.x + p.y * p.y).sqrt();
                assert!(r > 27.0 && r < 28.5, "{r}");
            }
        }
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let v = cup();
        let anatomy = CellMesh::from(&v.surface);
        let lm = [v.anterior, v.inferior];
        let err = |a: &CellMesh, lm: [Point3<f64>; 2], apex, c: &EnclosingConfig| {
            match enclosing_surface(a, lm, apex, c).unwrap_err() {
                OrganError::Ventricle(super::super::VentricleError::Enclosing(e)) => *e,
                e => panic!("{e}"),
            }
        };
        let points = CellMesh::from_points(v.surface.positions[..3].to_vec());
        assert!(matches!(
            err(&points, lm, None, &coarse()),
            EnclosingError::NoCells { points: 3, .. }
        ));
        let mut tri = CellMesh::from_points(vec![v.anterior, v.inferior, v.apex]);
        tri.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(matches!(
            err(&tri, lm, None, &coarse()),
            EnclosingError::Flat { .. }
        ));
        assert!(matches!(
            err(&anatomy, [v.anterior, v.anterior], None, &coarse()),
            EnclosingError::LandmarksCoincide { .. }
        ));
        let above = v.base_centre + v.long_axis * 10.0;
        assert!(matches!(
            err(&anatomy, lm, Some(above), &coarse()),
            EnclosingError::ApexAboveBase { .. }
        ));
        let thin = EnclosingConfig {
            margin_mm: 2.5,
            ..coarse()
        };
        assert!(matches!(
            err(&anatomy, lm, None, &thin),
            EnclosingError::MarginBelowVoxels { .. }
        ));
        let fine = EnclosingConfig {
            voxel_mm: 0.02,
            margin_mm: 0.05,
            smoothing_iterations: 0,
        };
        match err(&anatomy, lm, None, &fine) {
            EnclosingError::GridTooLarge {
                nodes,
                suggested_mm,
                ..
            } => {
                assert!(nodes > MAX_GRID_NODES);
                assert!(suggested_mm > 0.02);
            }
            e => panic!("{e}"),
        }
        for bad in [0.0, -1.0, f64::NAN] {
            let c = EnclosingConfig {
                voxel_mm: bad,
                ..coarse()
            };
            assert!(matches!(
                enclosing_surface(&anatomy, lm, None, &c),
                Err(OrganError::Config(_))
            ));
        }
    }

    #[test]
    fn a_rim_with_a_deep_notch_is_not_separated() {
        // the cup's wall cut down to z = -10 on the far side from the
        // landmarks: the plane at the highest point passes over the notch
        let v = cup();
        let notched = unfold_mesh::clip::clip_below(
            &v.surface,
            &Point3::new(-8.0, 0.0, 0.0),
            &Vector3::new(-0.6, 0.0, 1.0),
            1e-9,
        )
        .unwrap();
        let anatomy = CellMesh::from(&notched);
        match enclosing_surface(&anatomy, [v.anterior, v.inferior], None, &coarse()) {
            Err(OrganError::Ventricle(super::super::VentricleError::Enclosing(e))) => match *e {
                EnclosingError::NotSeparated { winding, .. } => assert!(winding < 0.5),
                other => panic!("{other}"),
            },
            other => panic!("{other:?}"),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(6))]
        /// A rigid motion of the anatomy and the landmarks moves S with
        /// them: same counts, same cut height, vertices moved alike.
        #[test]
        fn s_moves_with_the_anatomy(
            ax in -3.2f64..3.2, ay in -1.5f64..1.5, az in -3.2f64..3.2,
            t in proptest::array::uniform3(-50.0f64..50.0),
        ) {
            let v = cup();
            let anatomy = CellMesh::from(&v.surface);
            let e0 = built(&anatomy, &v, &coarse());
            let m = Translation3::new(t[0], t[1], t[2]) * Rotation3::from_euler_angles(ax, ay, az);
            let mut moved = anatomy.clone();
            for p in &mut moved.positions {
                *p = m * *p;
            }
            let lm = [m * v.anterior, m * v.inferior];
            let e1 = enclosing_surface(&moved, lm, Some(m * v.apex), &coarse()).unwrap();
            prop_assert_eq!(e0.surface.num_vertices(), e1.surface.num_vertices());
            prop_assert_eq!(e0.surface.triangles.clone(), e1.surface.triangles.clone());
            prop_assert!((e0.report.highest_point_mm - e1.report.highest_point_mm).abs() < 1e-9);
            let n1 = Vector3::from(e1.report.cut_normal);
            prop_assert!((m.rotation * Vector3::z() - n1).norm() < 1e-9);
            for (p, q) in e0.surface.positions.iter().zip(&e1.surface.positions) {
                prop_assert!((m * p - q).norm() < 1e-6);
            }
        }
    }
}
