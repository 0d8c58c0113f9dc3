//! The Laplace field `f` between S and the hemisphere H (ALGORITHMS 3.3), on
//! a grid, and the one continuous interpolant of `grad f` the streamlines of
//! both directions follow.
//!
//! **Frame.** The basal plane is fitted to the rim of S (least squares); its
//! normal `e3` points to the apex. The plane is moved along `e3` to the most
//! basal rim vertex, so all of S's rim lies on the apical side (`z >= 0`).
//! S is closed by the plane (the basal cap) and, where the rim rises above
//! it, by a vertical zero-flux wall from the rim down to it. The pipeline
//! hands this solver S closed by [`super::base::close_base`], whose rim is
//! planar: there is no wall, and the zero-flux cap lies on a grid plane.
//!
//! **Domain.** `U` = inside the closed surface, `z >= 0`, outside the ball
//! `|x - h0| < r_H` whose centre `h0` is the rim's centroid projected on the
//! cap plane (so H is a hemisphere on the cap bulging into the chamber).
//!
//! **Discretization.** Grid nodes `(x0 + i h, y0 + j h, k h)` in the basal
//! frame, the plane `k = 0` on the cap. Each unknown node has the 7-point
//! finite-volume Laplacian (nodes on the cap have half a control volume; the
//! zero-flux cap is exact, as the mirror image of the field). A link that
//! leaves U through S or H at the fraction `theta` of its length couples to
//! the boundary value there (Gibou et al. 2002, symmetric and second order):
//! `(u_n - u_b) / theta` in place of `u_n - u_m`. A link that leaves through
//! the skirt carries no flux. The system is solved by conjugate gradients
//! preconditioned by a matrix-free geometric multigrid V-cycle
//! (`field/geometric.rs`): no matrix is stored for the grid itself.
//!
//! **Gradient.** At each unknown node, `df/dx_a` is the second-order
//! three-point derivative on the two (possibly shortened) arms of axis `a`,
//! `(a^2 u_+ - b^2 u_- + (b^2 - a^2) u_0) / (a b (a + b))` for arms `b` (+)
//! and `a` (-), or one-sided with one arm; `df/dz = 0` on the cap. Nodes
//! within [`EXTENSION_LAYERS`] of U (beyond S, inside H, beyond the skirt)
//! get the mean gradient of their neighbours, layer by layer, so that the
//! interpolant is defined where streamlines cross S and H. `grad f` at any
//! point is the trilinear interpolation of the nodal gradients: one
//! continuous field, mirrored across the cap (`g_z(x, y, -z) = -g_z(x, y, z)`).

mod geometric;

use super::error::VentricleError;
use super::landmarks::Landmarks;
use crate::OrganError;
use geometric::Hierarchy;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use unfold_linalg::Csr;
use unfold_mesh::TriMesh;
use unfold_mesh::memory::MemoryEstimate;
use unfold_mesh::nalgebra::{Matrix3, Point3, Vector3};

/// Default grid spacing, mm (`--grid-mm`).
pub const DEFAULT_GRID_MM: f64 = 0.5;
/// Default radius of the hemisphere H, mm (ALGORITHMS 3.3).
pub const DEFAULT_HEMISPHERE_MM: f64 = 5.0;
/// Layers of nodes beyond U that get an extended gradient.
pub const EXTENSION_LAYERS: usize = 3;
/// Largest number of grid nodes (the bounding box of S), beyond which the
/// grid is refused as too fine for memory.
pub const MAX_GRID_NODES: usize = 250_000_000;

/// Conjugate-gradient iterations before the solve is a failure (about 12
/// are needed at any spacing).
const MAX_ITERATIONS: usize = 500;
/// Nodes of padding around S's bounding box.
const PAD: usize = EXTENSION_LAYERS + 2;
/// Boundary links shorter than this fraction of `h` are lengthened to it
/// (moves the boundary by at most `THETA_MIN h`; keeps the system well
/// conditioned).
const THETA_MIN: f64 = 1e-2;
/// Offsets of the ray-casting lines from the grid lines, in units of `h`
/// (irrational-looking, so that no line passes through a vertex or an edge
/// of S in practice).
const JITTER: [f64; 3] = [3.1415926e-7, 2.7182818e-7, 1.4142135e-7];

/// Settings of the Laplace field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FieldConfig {
    /// Grid spacing `h`, mm.
    pub grid_mm: f64,
    /// Radius of the hemisphere H, mm.
    pub hemisphere_mm: f64,
    /// Relative residual `|b - A f| / |b|` at which conjugate gradients stop.
    pub tolerance: f64,
    /// The most memory the field may allocate, bytes
    /// ([`LaplaceField::estimate_memory`] is checked against it before the
    /// grid is allocated); `None`: no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_memory_bytes: Option<f64>,
}

impl Default for FieldConfig {
    fn default() -> Self {
        FieldConfig {
            grid_mm: DEFAULT_GRID_MM,
            hemisphere_mm: DEFAULT_HEMISPHERE_MM,
            tolerance: 1e-10,
            max_memory_bytes: None,
        }
    }
}

/// The basal frame: `local(p) = R (p - origin)` with rows `e1, e2, e3` of `R`;
/// `e3` is the basal plane's normal toward the apex and `origin` the rim's
/// centroid projected on the cap plane (the most basal rim height).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BasalFrame {
    /// The centre of H, on the cap plane.
    pub origin: Point3<f64>,
    /// Rows `e1, e2, e3`.
    pub rotation: Matrix3<f64>,
}

impl BasalFrame {
    /// The frame of S: least-squares plane of the rim (smallest eigenvector
    /// of the rim's covariance), `e3` toward the apex, `e1` in that plane
    /// toward the anterior landmark (so the frame, and the field's grid,
    /// move with the heart), origin at the rim centroid moved along `e3` to
    /// the smallest rim height.
    ///
    /// # Errors
    /// [`VentricleError::CollinearRim`] when the rim is degenerate
    /// (collinear), [`VentricleError::FlatCup`] when the apex lies in the
    /// rim's plane.
    pub fn new(surface: &TriMesh, landmarks: &Landmarks) -> Result<BasalFrame, VentricleError> {
        let pos = &surface.positions;
        let rim: Vec<Point3<f64>> = landmarks.rim.iter().map(|&v| pos[v as usize]).collect();
        let n = rim.len() as f64;
        let c = rim.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
        let mut cov = Matrix3::zeros();
        for p in &rim {
            let d = p.coords - c;
            cov += d * d.transpose();
        }
        let eig = cov.symmetric_eigen();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let l2 = eig.eigenvalues[order[2]];
        if l2.is_nan() || l2 <= 0.0 || eig.eigenvalues[order[1]] <= 1e-12 * l2 {
            return Err(VentricleError::CollinearRim {
                variances: order.map(|k| eig.eigenvalues[k]),
            });
        }
        let mut e3: Vector3<f64> = eig.eigenvectors.column(order[0]).into();
        let apex = pos[landmarks.apex as usize].coords - c;
        let along = apex.dot(&e3);
        if along.abs() <= 1e-9 * apex.norm().max(1e-300) {
            return Err(VentricleError::FlatCup { height_mm: along });
        }
        if along < 0.0 {
            e3 = -e3;
        }
        // In the plane, toward the anterior landmark: the rim's largest
        // eigenvector is arbitrary for a round rim (and its sign always),
        // and the grid laid along it would turn with the pose.
        let toward = |d: Vector3<f64>| {
            let d = d - e3 * d.dot(&e3);
            d.try_normalize(1e-9 * d.norm().max(1e-300))
        };
        let e1 = toward(rim[landmarks.anterior.min(rim.len() - 1)].coords - c)
            .or_else(|| toward(eig.eigenvectors.column(order[2]).into()))
            .ok_or(VentricleError::CollinearRim {
                variances: order.map(|k| eig.eigenvalues[k]),
            })?;
        let e2 = e3.cross(&e1);
        let rotation = Matrix3::from_rows(&[e1.transpose(), e2.transpose(), e3.transpose()]);
        let zmin = rim
            .iter()
            .map(|p| (p.coords - c).dot(&e3))
            .fold(f64::INFINITY, f64::min);
        Ok(BasalFrame {
            origin: Point3::from(c + e3 * zmin),
            rotation,
        })
    }

    /// Basal-frame coordinates of a world point.
    #[inline]
    pub fn local(&self, p: &Point3<f64>) -> [f64; 3] {
        let q = self.rotation * (p - self.origin);
        [q.x, q.y, q.z]
    }

    /// The world point of basal-frame coordinates.
    #[inline]
    pub fn world(&self, q: [f64; 3]) -> Point3<f64> {
        self.origin + self.rotation.transpose() * Vector3::new(q[0], q[1], q[2])
    }
}

/// Node states.
const OUT: u8 = 0;
const IN_H: u8 = 1;
const UNKNOWN: u8 = 2;

/// The crossings of S with the grid lines along one axis, per line, sorted.
struct AxisCrossings {
    /// Line index -> start in `coords`.
    start: Vec<u32>,
    coords: Vec<f64>,
}

impl AxisCrossings {
    fn line(&self, l: usize) -> &[f64] {
        &self.coords[self.start[l] as usize..self.start[l + 1] as usize]
    }
}

/// The grid geometry.
#[derive(Debug, Clone, Copy)]
struct Grid {
    h: f64,
    origin: [f64; 3],
    dims: [usize; 3],
}

impl Grid {
    #[inline]
    fn id(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }
    #[inline]
    fn ijk(&self, id: usize) -> [usize; 3] {
        let i = id % self.dims[0];
        let r = id / self.dims[0];
        [i, r % self.dims[1], r / self.dims[1]]
    }
    #[inline]
    fn coord(&self, a: usize, i: usize) -> f64 {
        self.origin[a] + i as f64 * self.h
    }
    #[inline]
    fn stride(&self, a: usize) -> usize {
        match a {
            0 => 1,
            1 => self.dims[0],
            _ => self.dims[0] * self.dims[1],
        }
    }
    /// The two axes other than `a`, in increasing order.
    #[inline]
    fn others(a: usize) -> [usize; 2] {
        match a {
            0 => [1, 2],
            1 => [0, 2],
            _ => [0, 1],
        }
    }
    /// The line along axis `a` through node `ijk`.
    #[inline]
    fn line(&self, a: usize, ijk: [usize; 3]) -> usize {
        let [u, v] = Self::others(a);
        ijk[u] + self.dims[u] * ijk[v]
    }
}

/// Where the link from an unknown node along one axis direction leads.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Link {
    /// Another unknown node (its unknown number).
    Node(u32),
    /// The boundary S (`-1`) or H (`+1`) at the fraction `theta` of the link.
    Boundary { theta: f64, value: f64 },
    /// No flux (the skirt).
    Wall,
    /// The mirror image across the cap (the `-z` link of a cap node).
    Mirror,
}

/// Solver statistics of a [`LaplaceField`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FieldStats {
    /// Grid nodes in the bounding box.
    pub grid_nodes: usize,
    /// Unknown nodes (inside U, connected to H).
    pub unknowns: usize,
    /// Multigrid levels.
    pub levels: usize,
    /// Conjugate-gradient iterations.
    pub iterations: usize,
    /// Relative residual reached.
    pub relative_residual: f64,
    /// The memory predicted for the field before it was allocated, bytes
    /// ([`LaplaceField::estimate_memory`]).
    pub estimated_bytes: f64,
}

/// The corner gradients of the cell a [`LaplaceField::gradient_cached`]
/// read last (none at first).
#[derive(Debug, Clone, Copy)]
pub struct GradientCache {
    /// The cell's first corner (box node), `usize::MAX` for none.
    id: usize,
    grad: [[f64; 3]; 8],
}

impl Default for GradientCache {
    fn default() -> Self {
        GradientCache {
            id: usize::MAX,
            grad: [[0.0; 3]; 8],
        }
    }
}

/// The solved Laplace field and the interpolant of its gradient.
#[derive(Debug, Clone)]
pub struct LaplaceField {
    frame: BasalFrame,
    grid: Grid,
    radius: f64,
    /// Box node -> slot in `grad`/`value`, `u32::MAX` without a gradient.
    slot: Vec<u32>,
    grad: Vec<[f64; 3]>,
    value: Vec<f64>,
    stats: FieldStats,
}

impl LaplaceField {
    /// Solves the Laplace field of S (with its landmarks' rim and apex).
    ///
    /// # Errors
    /// - `Config` for a grid spacing or radius that is not finite and `> 0`;
    /// - [`VentricleError::GridTooLarge`] for a grid of more than
    ///   [`MAX_GRID_NODES`] nodes;
    /// - [`VentricleError::HemisphereDoesNotFit`] when H does not fit inside
    ///   S (a vertex of S is within the hemisphere's radius of its centre),
    ///   [`VentricleError::NoUnknowns`] when U has no node;
    /// - `Ventricle` for landmarks that do not fit S or a degenerate rim
    ///   ([`Landmarks::check`], [`BasalFrame::new`]);
    /// - `Param` when the solver fails.
    pub fn solve(
        surface: &TriMesh,
        landmarks: &Landmarks,
        config: &FieldConfig,
    ) -> Result<LaplaceField, OrganError> {
        OrganError::check_positive(&[
            ("grid spacing (mm)", config.grid_mm),
            ("hemisphere radius (mm)", config.hemisphere_mm),
            ("field tolerance", config.tolerance),
        ])?;
        landmarks.check(surface)?;
        let frame = BasalFrame::new(surface, landmarks)?;
        let h = config.grid_mm;
        let radius = config.hemisphere_mm;
        let local: Vec<[f64; 3]> = surface.positions.iter().map(|p| frame.local(p)).collect();
        let used = used_vertices(surface);
        if let Some((v, d)) = local
            .iter()
            .enumerate()
            .filter(|(v, _)| used[*v])
            .map(|(v, q)| (v, (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            && d <= radius
        {
            return Err(VentricleError::HemisphereDoesNotFit {
                radius_mm: radius,
                vertex: v,
                distance_mm: d,
            }
            .into());
        }
        let (dims_f, origin) = grid_box(&local, &used, h);
        let dims = dims_f.map(|d| d.min(usize::MAX as f64) as usize);
        let estimate = field_estimate(dims_f);
        if let Some(limit) = config.max_memory_bytes
            && !matches!(
                estimate.total().partial_cmp(&limit),
                Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
            )
        {
            return Err(VentricleError::FieldMemory {
                grid_mm: h,
                nodes: dims_f.iter().product(),
                estimate: estimate.total(),
                limit,
            }
            .into());
        }
        let total = match dims_f.iter().product::<f64>() {
            t if t <= MAX_GRID_NODES as f64 => t as usize,
            _ => {
                return Err(VentricleError::GridTooLarge {
                    grid_mm: h,
                    dims,
                    limit: MAX_GRID_NODES,
                }
                .into());
            }
        };
        let grid = Grid { h, origin, dims };
        let crossings = all_crossings(&grid, &local, &surface.triangles);
        let rim2: Vec<[f64; 2]> = landmarks
            .rim
            .iter()
            .map(|&v| [local[v as usize][0], local[v as usize][1]])
            .collect();
        let mut state = classify(&grid, &crossings[2], &rim2, radius);
        let mut index = connected_unknowns(&grid, &mut state);
        // red unknowns first: the multigrid's red-black smoother works on
        // the two halves of one vector
        let n_red = geometric::colour_numbering(&grid, &mut index);
        let unknowns = index.iter().filter(|&&x| x != u32::MAX).count();
        if unknowns == 0 {
            return Err(VentricleError::NoUnknowns { grid_mm: h }.into());
        }
        let ctx = Ctx {
            grid: &grid,
            state: &state,
            index: &index,
            crossings: &crossings,
            radius,
        };
        // the hierarchy and the solver's vectors live in this block only:
        // they are freed before the gradients are allocated
        let (f, levels, iterations, relative_residual, ids) = {
            let (hierarchy, mut r) =
                Hierarchy::new(&ctx, n_red, &local, &surface.triangles, &rim2)?;
            let (f, iterations, relative_residual) = geometric::pcg(
                &hierarchy,
                &mut r,
                config.tolerance,
                MAX_ITERATIONS,
                unknowns / 4,
            )?;
            drop(r);
            let depth = hierarchy.depth();
            (
                f,
                depth,
                iterations,
                relative_residual,
                hierarchy.into_finest_ids(),
            )
        };
        let grad = ctx.unknown_gradients(&f, &ids);
        drop(ids);
        let (slot, grad, value) = extend(&grid, &state, index, grad, f);
        Ok(LaplaceField {
            frame,
            grid,
            radius,
            slot,
            grad,
            value,
            stats: FieldStats {
                grid_nodes: total,
                unknowns,
                levels,
                iterations,
                relative_residual,
                estimated_bytes: estimate.total(),
            },
        })
    }

    /// The memory [`LaplaceField::solve`] will allocate on `surface`, before
    /// it allocates: per grid node (`n` nodes of the box around the surface
    /// in the basal frame, see `grid_box`) its state, unknown number, axis
    /// crossings and the coarse levels' (12 B), and per unknown (taken as
    /// `0.55 n`, a cup or an ellipsoid fills about half its box) the
    /// solver's box node and four and a half vectors, the coarse levels'
    /// and the allocator's slack (48 B; the gradients, 40 B, come after the
    /// solver's memory is freed), and 128 MiB besides (the pipeline's other
    /// steps while the field is alive): 38.4 B per box node. Measured on
    /// whole runs (`unfold ventricle`, `VmHWM`; predicted: the estimate
    /// plus the resident size before the field): Cobiveco geo2 at 1 mm
    /// (2.06 M nodes) 235.7 MiB against peaks of 201 to 206 MiB, at 0.5 mm
    /// (14.7 M nodes) 700 against 471 to 527 MiB, the demo cup at 0.6 mm
    /// (`tests/memory_cli.rs`) 183 against 129 to 133 MiB: 1.15 to 1.5
    /// times the peak.
    ///
    /// # Errors
    /// The landmark and frame errors of [`LaplaceField::solve`].
    pub fn estimate_memory(
        surface: &TriMesh,
        landmarks: &Landmarks,
        config: &FieldConfig,
    ) -> Result<MemoryEstimate, OrganError> {
        OrganError::check_positive(&[("grid spacing (mm)", config.grid_mm)])?;
        landmarks.check(surface)?;
        let frame = BasalFrame::new(surface, landmarks)?;
        let local: Vec<[f64; 3]> = surface.positions.iter().map(|p| frame.local(p)).collect();
        let (dims, _) = grid_box(&local, &used_vertices(surface), config.grid_mm);
        Ok(field_estimate(dims))
    }

    /// The basal frame the field lives in.
    pub fn frame(&self) -> &BasalFrame {
        &self.frame
    }

    /// Grid spacing, mm.
    pub fn grid_mm(&self) -> f64 {
        self.grid.h
    }

    /// Radius of H, mm (its centre is the frame's origin).
    pub fn hemisphere_radius(&self) -> f64 {
        self.radius
    }

    /// Solver statistics.
    pub fn stats(&self) -> FieldStats {
        self.stats
    }

    /// The cell containing `q` (mirrored to `z >= 0`): its first corner's
    /// box node and the trilinear coordinates in it; `None` outside the
    /// grid.
    #[inline]
    fn locate(&self, q: [f64; 3]) -> Option<(usize, [f64; 3])> {
        let g = &self.grid;
        let mut base = [0usize; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            let x = if a == 2 { q[2].abs() } else { q[a] };
            let s = (x - g.origin[a]) / g.h;
            if s.is_nan() || s < 0.0 {
                return None;
            }
            let i = (s as usize).min(g.dims[a].saturating_sub(2));
            if i + 1 >= g.dims[a] {
                return None;
            }
            base[a] = i;
            t[a] = s - i as f64;
            if t[a] > 1.0 + 1e-9 {
                return None;
            }
        }
        Some((g.id(base[0], base[1], base[2]), t))
    }

    /// The slots of the eight corners of the cell whose first corner is box
    /// node `id`; `None` when one has no gradient (far outside U).
    #[inline]
    fn corners(&self, id: usize) -> Option<[u32; 8]> {
        let g = &self.grid;
        let (sx, sy, sz) = (1, g.dims[0], g.dims[0] * g.dims[1]);
        let ids = [
            id,
            id + sx,
            id + sy,
            id + sx + sy,
            id + sz,
            id + sx + sz,
            id + sy + sz,
            id + sx + sy + sz,
        ];
        let mut slots = [0u32; 8];
        for (s, &i) in slots.iter_mut().zip(&ids) {
            *s = self.slot[i];
            if *s == u32::MAX {
                return None;
            }
        }
        Some(slots)
    }

    /// Corner slots and trilinear weights of the cell containing `q`
    /// (mirrored to `z >= 0`); `None` outside the field.
    #[inline]
    fn cell(&self, q: [f64; 3]) -> Option<([u32; 8], [f64; 3])> {
        let (id, t) = self.locate(q)?;
        Some((self.corners(id)?, t))
    }

    /// `grad f` at basal-frame point `q`: the trilinear interpolation of the
    /// nodal gradients; `None` where the field is not defined (far outside U).
    #[inline]
    pub fn gradient(&self, q: [f64; 3]) -> Option<[f64; 3]> {
        self.gradient_cached(q, &mut GradientCache::default())
    }

    /// [`LaplaceField::gradient`] with the corner gradients of the last
    /// cell kept in `cache`: a streamline's steps end at the cells' faces,
    /// so a step's seven stages read one cell (the same values in the same
    /// order: the result is the uncached one's to the bit).
    #[inline]
    pub fn gradient_cached(&self, q: [f64; 3], cache: &mut GradientCache) -> Option<[f64; 3]> {
        let (id, t) = self.locate(q)?;
        if cache.id != id {
            let s = self.corners(id)?;
            for (c, &k) in cache.grad.iter_mut().zip(&s) {
                *c = self.grad[k as usize];
            }
            cache.id = id;
        }
        let w = trilinear_weights(t);
        let mut g = [0.0; 3];
        for (wc, n) in w.iter().zip(&cache.grad) {
            g[0] += wc * n[0];
            g[1] += wc * n[1];
            g[2] += wc * n[2];
        }
        if q[2] < 0.0 {
            g[2] = -g[2];
        }
        Some(g)
    }

    /// `f` at basal-frame point `q` (trilinear; `-1` beyond S and `+1` in H
    /// at the nodes); `None` where the field is not defined.
    pub fn value(&self, q: [f64; 3]) -> Option<f64> {
        let (s, t) = self.cell(q)?;
        let w = trilinear_weights(t);
        Some((0..8).map(|c| w[c] * self.value[s[c] as usize]).sum())
    }

    /// Distance along the unit direction `d` from `q` to the face where the
    /// straight line leaves the grid cell ahead of it, plus `1e-7 h` (a
    /// point within `1e-7 h` of a face counts as on it and looks to the next
    /// one). Inside a cell the interpolant is a polynomial; the streamline
    /// integrator ends its steps here so that no step straddles a face,
    /// where `grad f` has a kink the error estimate would not see.
    #[inline]
    pub fn face_distance(&self, q: [f64; 3], d: [f64; 3]) -> f64 {
        let g = &self.grid;
        let mut best = f64::INFINITY;
        for a in 0..3 {
            let (x, da) = if a == 2 && q[2] < 0.0 {
                (-q[2], -d[2])
            } else {
                (q[a], d[a])
            };
            if da.abs() < 1e-12 {
                continue;
            }
            let s = (x - g.origin[a]) / g.h;
            let face = if da > 0.0 {
                (s + 1e-7).floor() + 1.0
            } else {
                (s - 1e-7).ceil() - 1.0
            };
            best = best.min((face - s) * g.h / da);
        }
        best + 1e-7 * g.h
    }

    /// Signed distance-like test for H: `|q| - r_H` (negative inside the
    /// hemisphere's ball).
    #[inline]
    pub fn hemisphere_level(&self, q: [f64; 3]) -> f64 {
        (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt() - self.radius
    }
}

#[inline]
fn trilinear_weights(t: [f64; 3]) -> [f64; 8] {
    let (x, y, z) = (t[0], t[1], t[2]);
    let (a, b, c) = (1.0 - x, 1.0 - y, 1.0 - z);
    [
        a * b * c,
        x * b * c,
        a * y * c,
        x * y * c,
        a * b * z,
        x * b * z,
        a * y * z,
        x * y * z,
    ]
}

/// Crossings of the triangles with the (jittered) grid lines along axis `a`.
fn axis_crossings(grid: &Grid, local: &[[f64; 3]], tris: &[[u32; 3]], a: usize) -> AxisCrossings {
    let [u, v] = Grid::others(a);
    let (nu, nv) = (grid.dims[u], grid.dims[v]);
    let h = grid.h;
    let line_u = |i: usize| grid.coord(u, i) + JITTER[u] * h;
    let line_v = |j: usize| grid.coord(v, j) + JITTER[v] * h;
    let mut hits: Vec<(u32, f64)> = Vec::new();
    for t in tris {
        let p = t.map(|x| local[x as usize]);
        let (mut umin, mut umax, mut vmin, mut vmax) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for q in &p {
            umin = umin.min(q[u]);
            umax = umax.max(q[u]);
            vmin = vmin.min(q[v]);
            vmax = vmax.max(q[v]);
        }
        let i0 = (((umin - grid.origin[u]) / h).floor().max(0.0)) as usize;
        let i1 = ((((umax - grid.origin[u]) / h).ceil()) as usize).min(nu - 1);
        let j0 = (((vmin - grid.origin[v]) / h).floor().max(0.0)) as usize;
        let j1 = ((((vmax - grid.origin[v]) / h).ceil()) as usize).min(nv - 1);
        let (ax, ay) = (p[0][u], p[0][v]);
        let (e1u, e1v) = (p[1][u] - ax, p[1][v] - ay);
        let (e2u, e2v) = (p[2][u] - ax, p[2][v] - ay);
        let det = e1u * e2v - e1v * e2u;
        if det == 0.0 {
            continue;
        }
        for j in j0..=j1 {
            let y = line_v(j) - ay;
            for i in i0..=i1 {
                let x = line_u(i) - ax;
                let b1 = (x * e2v - y * e2u) / det;
                let b2 = (e1u * y - e1v * x) / det;
                let b0 = 1.0 - b1 - b2;
                if b0 >= 0.0 && b1 >= 0.0 && b2 >= 0.0 {
                    let c = b0 * p[0][a] + b1 * p[1][a] + b2 * p[2][a];
                    hits.push(((i + nu * j) as u32, c));
                }
            }
        }
    }
    hits.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    let mut start = vec![0u32; nu * nv + 1];
    for &(l, _) in &hits {
        start[l as usize + 1] += 1;
    }
    for l in 0..nu * nv {
        start[l + 1] += start[l];
    }
    AxisCrossings {
        start,
        coords: hits.into_iter().map(|x| x.1).collect(),
    }
}

/// The crossings along the three axes ([`axis_crossings`]), in parallel.
fn all_crossings(grid: &Grid, local: &[[f64; 3]], tris: &[[u32; 3]]) -> [AxisCrossings; 3] {
    let (x, (y, z)) = rayon::join(
        || axis_crossings(grid, local, tris, 0),
        || {
            rayon::join(
                || axis_crossings(grid, local, tris, 1),
                || axis_crossings(grid, local, tris, 2),
            )
        },
    );
    [x, y, z]
}

/// Whether `p` is inside the polygon (crossing number).
fn in_polygon(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for k in 0..n {
        let a = poly[k];
        let b = poly[(k + 1) % n];
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Node states: inside the closed S (parity along the z-columns, starting
/// inside where the column meets the cap polygon), in H, or out. Node
/// `(i, j, k)` is inside when the column's start is inside the cap polygon
/// and an even number of the column's crossings lie below its height (`1e-9
/// h` for the cap), or the start is outside and the number is odd; planes of
/// constant `k` are filled in parallel.
fn classify(grid: &Grid, zc: &AxisCrossings, rim2: &[[f64; 2]], radius: f64) -> Vec<u8> {
    let [nx, ny, nz] = grid.dims;
    let h = grid.h;
    let plane = nx * ny;
    // the columns' starting parity, inside the cap polygon
    let start: Vec<bool> = (0..plane)
        .into_par_iter()
        .map(|l| {
            let (i, j) = (l % nx, l / nx);
            let p = [
                grid.coord(0, i) + JITTER[0] * h,
                grid.coord(1, j) + JITTER[1] * h,
            ];
            in_polygon(rim2, p)
        })
        .collect();
    let mut state = vec![OUT; plane * nz];
    state
        .par_chunks_mut(plane)
        .enumerate()
        .for_each(|(k, out)| {
            let z = if k == 0 { 1e-9 * h } else { k as f64 * h };
            for (l, st) in out.iter_mut().enumerate() {
                let (x, y) = (grid.coord(0, l % nx), grid.coord(1, l / nx));
                if x * x + y * y + z * z < radius * radius {
                    *st = IN_H;
                } else {
                    let below = zc.line(l).partition_point(|&c| c < z);
                    if start[l] ^ (below % 2 == 1) {
                        *st = UNKNOWN;
                    }
                }
            }
        });
    state
}

/// Unknown numbers of the unknown nodes connected (through unknown nodes) to
/// a node next to H; other unknown nodes become `OUT`.
fn connected_unknowns(grid: &Grid, state: &mut [u8]) -> Vec<u32> {
    let n = state.len();
    let [nx, ny, nz] = grid.dims;
    let plane = nx * ny;
    // no unknown on a box face but the cap (the box is padded around S):
    // then the six neighbours need no bounds checks but `k > 0`
    let on_side = |id: usize| {
        let [i, j, k] = grid.ijk(id);
        i == 0 || j == 0 || i + 1 == nx || j + 1 == ny || k + 1 == nz
    };
    let padded = !(0..n)
        .into_par_iter()
        .any(|id| state[id] == UNKNOWN && on_side(id));
    let neighbours = |id: usize| -> [Option<usize>; 6] {
        if padded {
            return [
                Some(id - 1),
                Some(id + 1),
                Some(id - nx),
                Some(id + nx),
                (id >= plane).then(|| id - plane),
                Some(id + plane),
            ];
        }
        let ijk = grid.ijk(id);
        let mut out = [None; 6];
        for a in 0..3 {
            let s = grid.stride(a);
            if ijk[a] > 0 {
                out[2 * a] = Some(id - s);
            }
            if ijk[a] + 1 < grid.dims[a] {
                out[2 * a + 1] = Some(id + s);
            }
        }
        out
    };
    let mut seen = vec![false; n];
    // seeds: the unknowns next to H (found from H's nodes, a few thousand)
    let mut stack: Vec<u32> = Vec::new();
    for id in 0..n {
        if state[id] != IN_H {
            continue;
        }
        let ijk = grid.ijk(id);
        for (a, (&i, &d)) in ijk.iter().zip(&grid.dims).enumerate() {
            let s = grid.stride(a);
            for m in [(i > 0).then(|| id - s), (i + 1 < d).then(|| id + s)]
                .into_iter()
                .flatten()
            {
                if state[m] == UNKNOWN && !seen[m] {
                    seen[m] = true;
                    stack.push(m as u32);
                }
            }
        }
    }
    while let Some(id) = stack.pop() {
        for m in neighbours(id as usize).into_iter().flatten() {
            if state[m] == UNKNOWN && !seen[m] {
                seen[m] = true;
                stack.push(m as u32);
            }
        }
    }
    let mut index = vec![u32::MAX; n];
    let mut next = 0u32;
    for id in 0..n {
        if state[id] == UNKNOWN {
            if seen[id] {
                index[id] = next;
                next += 1;
            } else {
                state[id] = OUT;
            }
        }
    }
    index
}

/// Shared read-only state of the assembly and the gradients.
struct Ctx<'a> {
    grid: &'a Grid,
    state: &'a [u8],
    index: &'a [u32],
    crossings: &'a [AxisCrossings; 3],
    radius: f64,
}

impl Ctx<'_> {
    /// The link from unknown node `id` along axis `a`, direction `dir` (+1 / -1).
    fn link(&self, id: usize, a: usize, dir: i32) -> Link {
        let g = self.grid;
        let ijk = g.ijk(id);
        if a == 2 && dir < 0 && ijk[2] == 0 {
            return Link::Mirror;
        }
        let s = g.stride(a);
        let m = if dir > 0 { id + s } else { id - s };
        match self.state[m] {
            UNKNOWN => Link::Node(self.index[m]),
            IN_H => {
                // |p + t d| = r along the link, t in (0, h]
                let p = [0, 1, 2].map(|b| g.coord(b, ijk[b]));
                let pa = p[a];
                let rest = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] - pa * pa;
                let r2 = self.radius * self.radius - rest;
                let target = if r2 > 0.0 { r2.sqrt() } else { 0.0 };
                // the crossing nearest p on the node's side
                let t = if dir > 0 { -target - pa } else { pa - target };
                let theta = (t / g.h).clamp(THETA_MIN, 1.0);
                Link::Boundary { theta, value: 1.0 }
            }
            _ => {
                let c = g.coord(a, ijk[a]);
                let line = self.crossings[a].line(g.line(a, ijk));
                let hit = if dir > 0 {
                    let k = line.partition_point(|&x| x <= c);
                    line.get(k).filter(|&&x| x <= c + g.h).map(|&x| x - c)
                } else {
                    let k = line.partition_point(|&x| x < c);
                    (k > 0)
                        .then(|| line[k - 1])
                        .filter(|&x| x >= c - g.h)
                        .map(|x| c - x)
                };
                match hit {
                    Some(d) => Link::Boundary {
                        theta: (d / g.h).clamp(THETA_MIN, 1.0),
                        value: -1.0,
                    },
                    None => Link::Wall,
                }
            }
        }
    }

    /// The finite-volume system `A f = b` over the unknowns (CSR, sorted).
    fn assemble(&self) -> Result<(Csr, Vec<f64>), OrganError> {
        let g = self.grid;
        let n = self.index.iter().filter(|&&x| x != u32::MAX).count();
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col: Vec<u32> = Vec::with_capacity(7 * n);
        let mut val = Vec::with_capacity(7 * n);
        let mut b = vec![0.0; n];
        row_ptr.push(0usize);
        for (id, &row) in self.index.iter().enumerate() {
            if row == u32::MAX {
                continue;
            }
            let cap = g.ijk(id)[2] == 0;
            let mut diag = 0.0;
            let mut offs: [(u32, f64); 6] = [(u32::MAX, 0.0); 6];
            let mut k = 0;
            for a in [2usize, 1, 0] {
                for dir in [-1, 1] {
                    let w = if cap && a != 2 { 0.5 } else { 1.0 };
                    match self.link(id, a, dir) {
                        Link::Node(m) => {
                            diag += w;
                            offs[k] = (m, -w);
                            k += 1;
                        }
                        Link::Boundary { theta, value } => {
                            diag += w / theta;
                            b[row as usize] += w / theta * value;
                        }
                        Link::Wall | Link::Mirror => {}
                    }
                }
            }
            let mut entries: Vec<(u32, f64)> = offs[..k].to_vec();
            entries.push((row, diag));
            entries.sort_unstable_by_key(|e| e.0);
            for (c, v) in entries {
                col.push(c);
                val.push(v);
            }
            row_ptr.push(col.len());
        }
        let a = Csr::from_raw(n, n, row_ptr, col, val)?;
        Ok((a, b))
    }

    /// Nodal gradients of the unknowns, in unknown order (`ids`: each
    /// colour's box nodes in that order, red first), with room for the
    /// extension layers; in parallel.
    fn unknown_gradients(&self, f: &[f64], ids: &[Vec<u32>; 2]) -> Vec<[f64; 3]> {
        let mut grad = Vec::with_capacity(f.len() + f.len() / 4);
        for colour in ids {
            grad.par_extend(
                colour
                    .par_iter()
                    .map(|&id| self.node_gradient(id as usize, f)),
            );
        }
        grad
    }

    /// `grad f` at unknown box node `id` (the module docs' three-point
    /// derivatives).
    fn node_gradient(&self, id: usize, f: &[f64]) -> [f64; 3] {
        let g = self.grid;
        let u0 = f[self.index[id] as usize];
        let cap = g.ijk(id)[2] == 0;
        let mut gr = [0.0; 3];
        for (a, ga) in gr.iter_mut().enumerate() {
            if a == 2 && cap {
                continue;
            }
            let arm = |dir: i32| -> Option<(f64, f64)> {
                match self.link(id, a, dir) {
                    Link::Node(m) => Some((g.h, f[m as usize])),
                    Link::Boundary { theta, value } => Some((theta * g.h, value)),
                    Link::Wall | Link::Mirror => None,
                }
            };
            *ga = match (arm(-1), arm(1)) {
                (Some((da, ua)), Some((db, ub))) => {
                    (da * da * ub - db * db * ua + (db * db - da * da) * u0) / (da * db * (da + db))
                }
                (Some((da, ua)), None) => (u0 - ua) / da,
                (None, Some((db, ub))) => (ub - u0) / db,
                (None, None) => 0.0,
            };
        }
        gr
    }
}

/// The extension layers (see the module docs) appended to the unknowns'
/// gradients `grad` and values `f`: `index` (box node -> unknown) becomes
/// box node -> slot in `grad`/`value` (`u32::MAX` where there is none), so
/// no second box-sized array is allocated.
fn extend(
    g: &Grid,
    state: &[u8],
    mut slot: Vec<u32>,
    mut grad: Vec<[f64; 3]>,
    mut value: Vec<f64>,
) -> (Vec<u32>, Vec<[f64; 3]>, Vec<f64>) {
    let n = state.len();
    // the layer before (all of U for the first layer, not stored)
    let mut defined: Option<Vec<usize>> = None;
    for _ in 0..EXTENSION_LAYERS {
        let slot_ref = &slot;
        let around = |ids: &mut dyn Iterator<Item = usize>| -> Vec<usize> {
            let mut out = Vec::new();
            for id in ids {
                for_each_neighbour26(g, id, |m| {
                    if slot_ref[m] == u32::MAX {
                        out.push(m);
                    }
                });
            }
            out
        };
        let mut frontier: Vec<usize> = match &defined {
            Some(layer) => layer
                .par_chunks(1 << 14)
                .map(|c| around(&mut c.iter().copied()))
                .flatten_iter()
                .collect(),
            None => (0..n)
                .into_par_iter()
                .step_by(1 << 16)
                .map(|start| {
                    around(
                        &mut (start..(start + (1 << 16)).min(n))
                            .filter(|&id| slot_ref[id] != u32::MAX),
                    )
                })
                .flatten_iter()
                .collect(),
        };
        frontier.par_sort_unstable();
        frontier.dedup();
        let new: Vec<[f64; 3]> = frontier
            .par_iter()
            .map(|&id| {
                let mut s = [0.0; 3];
                let mut c = 0usize;
                for_each_neighbour26(g, id, |m| {
                    let k = slot_ref[m];
                    if k != u32::MAX {
                        let q = grad[k as usize];
                        s[0] += q[0];
                        s[1] += q[1];
                        s[2] += q[2];
                        c += 1;
                    }
                });
                let inv = 1.0 / c.max(1) as f64;
                let mut q = [s[0] * inv, s[1] * inv, s[2] * inv];
                if g.ijk(id)[2] == 0 {
                    q[2] = 0.0;
                }
                q
            })
            .collect();
        for (&id, q) in frontier.iter().zip(new) {
            slot[id] = grad.len() as u32;
            grad.push(q);
            value.push(if state[id] == IN_H { 1.0 } else { -1.0 });
        }
        defined = Some(frontier);
    }
    (slot, grad, value)
}

fn for_each_neighbour26(g: &Grid, id: usize, mut f: impl FnMut(usize)) {
    let [i, j, k] = g.ijk(id);
    let [nx, ny, nz] = g.dims;
    for dk in -1i64..=1 {
        let kk = k as i64 + dk;
        if kk < 0 || kk >= nz as i64 {
            continue;
        }
        for dj in -1i64..=1 {
            let jj = j as i64 + dj;
            if jj < 0 || jj >= ny as i64 {
                continue;
            }
            for di in -1i64..=1 {
                let ii = i as i64 + di;
                if ii < 0 || ii >= nx as i64 || (di == 0 && dj == 0 && dk == 0) {
                    continue;
                }
                f(g.id(ii as usize, jj as usize, kk as usize));
            }
        }
    }
}

/// The estimate of [`LaplaceField::estimate_memory`] for a grid of `dims`
/// nodes.
fn field_estimate(dims: [f64; 3]) -> MemoryEstimate {
    let nodes: f64 = dims.iter().product();
    MemoryEstimate::new()
        .with("base", 1.0, 128.0 * 1024.0 * 1024.0)
        .with("field grid", nodes, 12.0)
        .with("field unknowns", 0.55 * nodes, 48.0)
}

/// Which vertices of `surface` a triangle uses.
fn used_vertices(surface: &TriMesh) -> Vec<bool> {
    let mut used = vec![false; surface.positions.len()];
    for t in &surface.triangles {
        for &v in t {
            if let Some(u) = used.get_mut(v as usize) {
                *u = true;
            }
        }
    }
    used
}

/// The field grid around the used vertices `local` (basal frame) at
/// spacing `h`: nodes per axis (reals: a tiny `h` may not fit an integer)
/// and origin; `PAD` nodes beyond the surface across, the apex side in
/// `z` from the basal plane.
fn grid_box(local: &[[f64; 3]], used: &[bool], h: f64) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for q in local.iter().zip(used).filter(|(_, u)| **u).map(|x| x.0) {
        for a in 0..3 {
            lo[a] = lo[a].min(q[a]);
            hi[a] = hi[a].max(q[a]);
        }
    }
    let mut dims = [0.0; 3];
    let mut origin = [0.0; 3];
    for a in 0..2 {
        dims[a] = ((hi[a] - lo[a]) / h).ceil() + (2 * PAD + 1) as f64;
        origin[a] = lo[a] - PAD as f64 * h;
    }
    dims[2] = (hi[2].max(0.0) / h).ceil() + (PAD + 1) as f64;
    (dims, origin)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ventricle::landmarks::DEFAULT_SNAP_MM;
    use proptest::prelude::*;
    use std::f64::consts::TAU;
    use std::sync::OnceLock;
    use unfold_mesh::shapes::{Pose, VentricleParams, VentricleShape, ventricle_cup};

    /// Radius of the hemispherical S, mm.
    const R: f64 = 20.0;

    /// S a hemisphere of radius `R`: the cup with `length == radius` cut at
    /// its equator.
    fn hemisphere() -> VentricleShape {
        ventricle_cup(&VentricleParams {
            radius: R,
            length: R,
            base_above_equator: 0.0,
            ..VentricleParams::default()
        })
        .unwrap()
    }

    /// The cup's landmarks; the apex given (every vertex of a hemisphere is
    /// equally far from the rim's centre) or found.
    fn landmarks_of(cup: &VentricleShape, give_apex: bool) -> Landmarks {
        Landmarks::resolve(
            &cup.surface,
            &cup.anterior,
            &cup.inferior,
            give_apex.then_some(&cup.apex),
            DEFAULT_SNAP_MM,
        )
        .unwrap()
    }

    fn config(grid_mm: f64) -> FieldConfig {
        FieldConfig {
            grid_mm,
            ..FieldConfig::default()
        }
    }

    struct Hemi {
        cup: VentricleShape,
        landmarks: Landmarks,
        field: LaplaceField,
    }

    /// The hemisphere's field on a 1 mm grid, solved once.
    fn hemi() -> &'static Hemi {
        static H: OnceLock<Hemi> = OnceLock::new();
        H.get_or_init(|| {
            let cup = hemisphere();
            let landmarks = landmarks_of(&cup, true);
            let field = LaplaceField::solve(&cup.surface, &landmarks, &config(1.0)).unwrap();
            Hemi {
                cup,
                landmarks,
                field,
            }
        })
    }

    /// The concentric-spheres solution `f = A + B / rho` with `f(R) = -1`,
    /// `f(r) = 1`: `B = 2 r R / (R - r)`, `A = -1 - B / R`; and `B`.
    fn analytic(rho: f64, r: f64) -> (f64, f64) {
        let b = 2.0 * r * R / (R - r);
        (-1.0 - b / R + b / rho, b)
    }

    fn norm(q: [f64; 3]) -> f64 {
        (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()
    }

    /// Angle between two vectors, degrees.
    fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
        let c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (norm(a) * norm(b));
        c.clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// The basal-frame point at radius `rho`, polar angle `polar` from the
    /// long axis `e3` and azimuth `az`.
    fn spherical(rho: f64, polar: f64, az: f64) -> [f64; 3] {
        [
            rho * polar.sin() * az.cos(),
            rho * polar.sin() * az.sin(),
            rho * polar.cos(),
        ]
    }

    fn err_of(r: Result<LaplaceField, OrganError>) -> OrganError {
        match r {
            Err(e) => e,
            Ok(f) => panic!("expected an error, got a field with {:?}", f.stats()),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// For any rigid pose of the cup: the rotation is orthonormal and
        /// right-handed, `world(local(p)) = p` and `local(world(q)) = q`,
        /// `e3` is the cup's long axis toward the apex, the origin is the
        /// rim centre, the apex is `length` above the base and the (planar)
        /// rim at height 0; heights do not depend on the pose.
        #[test]
        fn the_basal_frame_is_rigid_and_points_to_the_apex(
            angles in prop::array::uniform3(-180.0..180.0f64),
            shift in prop::array::uniform3(-200.0..200.0f64),
            points in prop::collection::vec(prop::array::uniform3(-500.0..500.0f64), 1..16),
        ) {
            let params = VentricleParams {
                pose: Pose::new(angles, shift),
                ..VentricleParams::default()
            };
            let cup = ventricle_cup(&params).unwrap();
            let frame = BasalFrame::new(&cup.surface, &landmarks_of(&cup, false)).unwrap();
            let r = frame.rotation;
            let ortho = (r * r.transpose() - Matrix3::identity()).abs().max();
            prop_assert!(ortho < 1e-12, "R R^T - I = {ortho}");
            prop_assert!((r.determinant() - 1.0).abs() < 1e-12);
            let o = frame.origin;
            for p in &points {
                let p = Point3::new(p[0], p[1], p[2]);
                let scale = p.coords.norm() + o.coords.norm();
                let back = frame.world(frame.local(&p));
                prop_assert!((back - p).norm() <= 1e-12 * scale, "{p:?} -> {back:?}");
                let q = [p.x, p.y, p.z];
                let again = frame.local(&frame.world(q));
                let d = norm([again[0] - q[0], again[1] - q[1], again[2] - q[2]]);
                prop_assert!(d <= 1e-12 * scale, "{q:?} -> {again:?}");
                let l = frame.local(&p);
                prop_assert!((norm(l) - (p - o).norm()).abs() <= 1e-12 * scale);
            }
            prop_assert!((o - cup.base_centre).norm() < 1e-9, "{o:?} vs {:?}", cup.base_centre);
            let e3: Vector3<f64> = r.row(2).transpose();
            prop_assert!((e3 + cup.long_axis).norm() < 1e-9, "e3 {e3:?}");
            let apex = frame.local(&cup.apex);
            prop_assert!(apex[2] > 0.0);
            prop_assert!((apex[2] - params.length).abs() < 1e-9, "apex height {}", apex[2]);
            for &v in &cup.rim {
                let z = frame.local(&cup.surface.positions[v as usize])[2];
                prop_assert!((-1e-9..1e-9).contains(&z), "rim height {z}");
            }
            let plain = ventricle_cup(&VentricleParams::default()).unwrap();
            let f0 = BasalFrame::new(&plain.surface, &landmarks_of(&plain, false)).unwrap();
            for (p, p0) in cup.surface.positions.iter().zip(&plain.surface.positions) {
                prop_assert!((frame.local(p)[2] - f0.local(p0)[2]).abs() < 1e-9);
            }
        }
    }

    /// A tilted, non-planar rim: every rim vertex on the apical side of the
    /// frame's base plane (`z >= 0`), the lowest one on it.
    #[test]
    fn every_rim_vertex_is_on_the_apical_side_of_the_base() {
        let cup = ventricle_cup(&VentricleParams {
            pose: Pose::new([30.0, -20.0, 75.0], [5.0, 6.0, -7.0]),
            ..VentricleParams::default()
        })
        .unwrap();
        let mut s = cup.surface.clone();
        let axis = cup.long_axis;
        let centre = cup.base_centre;
        for &v in &cup.rim {
            let p = s.positions[v as usize];
            // a height that is not a plane: 2 mm * sin(3 * azimuth)
            let d = p - centre;
            let az = d.y.atan2(d.x);
            s.positions[v as usize] = p + axis * (2.0 * (3.0 * az).sin());
        }
        let l = Landmarks::resolve(
            &s,
            &s.positions[cup.anterior_index],
            &s.positions[cup.inferior_index],
            None,
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        let frame = BasalFrame::new(&s, &l).unwrap();
        let heights: Vec<f64> = l
            .rim
            .iter()
            .map(|&v| frame.local(&s.positions[v as usize])[2])
            .collect();
        let lo = heights.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(lo.abs() <= 1e-9, "lowest rim height {lo}");
        assert!(hi > 2.0, "highest rim height {hi}");
        assert!(frame.local(&s.positions[l.apex as usize])[2] > hi);
    }

    #[test]
    fn a_degenerate_rim_or_a_flat_cup_is_refused_with_a_clear_error() {
        let tris = vec![[0, 1, 3], [1, 2, 3]];
        let hand = |rim: Vec<u32>| Landmarks {
            rim,
            anterior: 0,
            inferior: 1,
            apex: 3,
            snap_distances_mm: [0.0; 3],
        };
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        // collinear rim vertices
        let line = TriMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(2.0, 0.0, 0.0),
                p(1.0, 1.0, -3.0),
            ],
            tris.clone(),
        );
        // all rim vertices at one point
        let point = TriMesh::new(
            vec![
                p(1.0, 1.0, 1.0),
                p(1.0, 1.0, 1.0),
                p(1.0, 1.0, 1.0),
                p(1.0, 1.0, -3.0),
            ],
            tris.clone(),
        );
        for s in [&line, &point] {
            for e in [
                BasalFrame::new(s, &hand(vec![0, 1, 2])).unwrap_err().into(),
                err_of(LaplaceField::solve(s, &hand(vec![0, 1, 2]), &config(1.0))),
            ] {
                match e {
                    OrganError::Ventricle(e @ VentricleError::CollinearRim { .. }) => {
                        assert!(e.to_string().contains("collinear"), "{e}")
                    }
                    e => panic!("{e:?}"),
                }
            }
        }
        // the apex in the rim's plane
        let flat = TriMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.0, 1.0, 0.0),
                p(1.0, 1.0, 0.0),
            ],
            tris,
        );
        match BasalFrame::new(&flat, &hand(vec![0, 1, 2])).unwrap_err() {
            e @ VentricleError::FlatCup { height_mm } => {
                assert!(height_mm.abs() < 1e-9, "{height_mm}");
                assert!(e.to_string().contains("not a cup"), "{e}")
            }
            e => panic!("{e:?}"),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// On the hemisphere the field is the concentric-spheres solution:
        /// values within 0.02, gradient directions within 2 degrees and
        /// magnitudes within 5 % at points 2 mm or more from S and H.
        #[test]
        fn the_hemisphere_field_is_the_concentric_spheres_solution(
            u in 0.0..1.0f64,
            polar in 0.0..1.5f64,
            az in 0.0..TAU,
        ) {
            let h = hemi();
            let r = h.field.hemisphere_radius();
            let rho = r + 2.0 + u * (R - r - 4.0);
            let q = spherical(rho, polar, az);
            let (want, b) = analytic(rho, r);
            let f = h.field.value(q).unwrap();
            prop_assert!((f - want).abs() < 0.02, "f({rho}) = {f}, want {want}");
            let g = h.field.gradient(q).unwrap();
            let inward = [-q[0], -q[1], -q[2]];
            let a = angle_deg(g, inward);
            prop_assert!(a < 2.0, "gradient {g:?} at {q:?}: {a} degrees off");
            let mag = b / (rho * rho);
            prop_assert!((norm(g) / mag - 1.0).abs() < 0.05, "|g| = {}, want {mag}", norm(g));
        }

        /// The gradient is mirrored across the cap: `g_z = 0` on it,
        /// `g(x, y, -z) = (g_x, g_y, -g_z)(x, y, z)` exactly, and the value
        /// is even in `z`.
        #[test]
        fn the_gradient_is_mirrored_across_the_cap(
            u in 0.0..1.0f64,
            polar in 0.0..1.57f64,
            az in 0.0..TAU,
        ) {
            let h = hemi();
            let r = h.field.hemisphere_radius();
            let rho = r + 0.5 + u * (R - r - 1.0);
            let q = spherical(rho, polar, az);
            let g = h.field.gradient(q).unwrap();
            let m = h.field.gradient([q[0], q[1], -q[2]]).unwrap();
            prop_assert_eq!([m[0], m[1]], [g[0], g[1]]);
            prop_assert_eq!(m[2], -g[2]);
            prop_assert_eq!(h.field.value([q[0], q[1], -q[2]]), h.field.value(q));
            let c = h.field.gradient([q[0], q[1], 0.0]).unwrap();
            prop_assert_eq!(c[2], 0.0);
        }

        /// The cached gradient is the uncached one to the bit, along a
        /// walk of short steps (most in the last cell, some into the
        /// next, some mirrored below the cap) and after a point outside
        /// the field.
        #[test]
        fn the_cached_gradient_is_the_gradient(
            u in 0.0..1.0f64,
            polar in 0.0..1.57f64,
            az in 0.0..TAU,
            steps in proptest::collection::vec((-0.4..0.4f64, -0.4..0.4f64, -0.4..0.4f64), 1..40),
        ) {
            let h = hemi();
            let r = h.field.hemisphere_radius();
            let mut q = spherical(r + 0.5 + u * (R - r - 1.0), polar, az);
            let mut cache = GradientCache::default();
            for (k, d) in steps.iter().enumerate() {
                q = [q[0] + d.0, q[1] + d.1, q[2] + d.2];
                prop_assert_eq!(h.field.gradient_cached(q, &mut cache), h.field.gradient(q));
                if k == 3 {
                    let far = [10.0 * R, 0.0, 0.0];
                    prop_assert_eq!(h.field.gradient_cached(far, &mut cache), None);
                }
            }
        }

        /// The planes-in-parallel classification is the column-by-column
        /// walk it replaced (each column's crossings counted as its height
        /// grows) on the hemisphere at any spacing.
        #[test]
        fn the_classification_is_the_column_walk(h in 0.7..2.5f64) {
            let hm = hemi();
            let frame = BasalFrame::new(&hm.cup.surface, &hm.landmarks).unwrap();
            let local: Vec<[f64; 3]> =
                hm.cup.surface.positions.iter().map(|p| frame.local(p)).collect();
            let (dims, origin) = grid_box(&local, &used_vertices(&hm.cup.surface), h);
            let grid = Grid { h, origin, dims: dims.map(|d| d as usize) };
            let crossings = all_crossings(&grid, &local, &hm.cup.surface.triangles);
            let rim2: Vec<[f64; 2]> = hm
                .landmarks
                .rim
                .iter()
                .map(|&v| [local[v as usize][0], local[v as usize][1]])
                .collect();
            let radius = DEFAULT_HEMISPHERE_MM;
            let fast = classify(&grid, &crossings[2], &rim2, radius);
            let [nx, ny, nz] = grid.dims;
            let mut walk = vec![OUT; nx * ny * nz];
            for j in 0..ny {
                for i in 0..nx {
                    let (x, y) = (grid.coord(0, i), grid.coord(1, j));
                    let mut inside = in_polygon(&rim2, [x + JITTER[0] * h, y + JITTER[1] * h]);
                    let line = crossings[2].line(i + nx * j);
                    let mut next = 0;
                    for k in 0..nz {
                        let z = if k == 0 { 1e-9 * h } else { k as f64 * h };
                        while next < line.len() && line[next] < z {
                            inside = !inside;
                            next += 1;
                        }
                        let id = grid.id(i, j, k);
                        if x * x + y * y + z * z < radius * radius {
                            walk[id] = IN_H;
                        } else if inside {
                            walk[id] = UNKNOWN;
                        }
                    }
                }
            }
            prop_assert!(fast.contains(&UNKNOWN) && fast.contains(&IN_H));
            prop_assert!(fast == walk);
        }
    }

    #[test]
    fn the_field_is_undefined_far_outside_s() {
        let h = hemi();
        for q in [
            [10.0 * R, 0.0, 0.0],
            [0.0, -10.0 * R, 1.0],
            [0.0, 0.0, 10.0 * R],
            [0.0, 0.0, -10.0 * R],
            [-10.0 * R, 3.0 * R, 2.0 * R],
            [f64::NAN, 0.0, 5.0],
            [0.0, f64::INFINITY, 5.0],
        ] {
            assert!(h.field.gradient(q).is_none(), "{q:?}");
            assert!(h.field.value(q).is_none(), "{q:?}");
        }
        // just inside S it is defined, and near -1
        let f = h.field.value([0.0, 0.0, R - 0.2]).unwrap();
        assert!((f + 1.0).abs() < 0.05, "{f}");
    }

    #[test]
    fn the_hemisphere_frame_and_solver_statistics() {
        let h = hemi();
        let frame = h.field.frame();
        assert!(frame.origin.coords.norm() < 1e-9, "{:?}", frame.origin);
        assert_eq!(h.field.grid_mm(), 1.0);
        assert_eq!(h.field.hemisphere_radius(), DEFAULT_HEMISPHERE_MM);
        assert!((h.field.hemisphere_level([3.0, 0.0, 4.0])).abs() < 1e-15);
        assert!((h.field.hemisphere_level([0.0, 0.0, 9.0]) - 4.0).abs() < 1e-15);
        let s = h.field.stats();
        let tol = FieldConfig::default().tolerance;
        assert!(s.relative_residual <= tol, "{s:?}");
        assert!(s.iterations >= 1 && s.iterations <= 30, "{s:?}");
        assert!(s.levels >= 2, "{s:?}");
        assert!(s.unknowns < s.grid_nodes, "{s:?}");
        // the unknowns fill the half shell between H and S (the nodes on
        // the cap count too): volume / h^3 plus half the cap's nodes
        let r = h.field.hemisphere_radius();
        let shell = TAU / 3.0 * (R.powi(3) - r.powi(3));
        let cap = 0.5 * std::f64::consts::PI * (R * R - r * r);
        let expect = shell + cap;
        let ratio = s.unknowns as f64 / expect;
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "{} unknowns, expected {expect}",
            s.unknowns
        );
        // the apex given to the field is the cup's
        let apex = h.cup.surface.positions[h.landmarks.apex as usize];
        assert!((frame.local(&apex)[2] - R).abs() < 1e-9);
    }

    /// Unknowns connected to H are numbered in box order; a pocket cut off
    /// by a wall of outside nodes becomes outside; both neighbour paths
    /// (a padded box, and unknowns on the box's faces).
    #[test]
    fn only_the_unknowns_connected_to_h_are_numbered() {
        for (dims, lo, hi) in [([8, 8, 6], 1, 6), ([6, 6, 5], 0, 5)] {
            let grid = Grid {
                h: 1.0,
                origin: [0.0; 3],
                dims,
            };
            let n = dims.iter().product();
            let mut state = vec![OUT; n];
            for k in 0..dims[2] - 1 {
                for j in lo..=hi.min(dims[1] - 1) {
                    for i in lo..=hi.min(dims[0] - 1) {
                        // the wall at i = 3 cuts off i > 3
                        if i != 3 {
                            state[grid.id(i, j, k)] = UNKNOWN;
                        }
                    }
                }
            }
            state[grid.id(2, 2, 0)] = IN_H;
            let index = connected_unknowns(&grid, &mut state);
            let mut next = 0;
            for (id, &q) in index.iter().enumerate() {
                let [i, _, _] = grid.ijk(id);
                if state[id] == UNKNOWN {
                    assert!(i < 3, "{id} {:?}", grid.ijk(id));
                    assert_eq!(q, next);
                    next += 1;
                } else {
                    assert_eq!(q, u32::MAX);
                }
            }
            let kept = (dims[2] - 1) * (hi.min(dims[1] - 1) - lo + 1) * (3 - lo) - 1;
            assert_eq!(next as usize, kept, "{dims:?}");
        }
    }

    #[test]
    fn bad_field_settings_are_refused_with_a_clear_error() {
        let h = hemi();
        let (s, l) = (&h.cup.surface, &h.landmarks);
        let solve = |c: FieldConfig| err_of(LaplaceField::solve(s, l, &c));
        let config_error = |e: OrganError, want: &str| match e {
            e @ (OrganError::Config(_)
            | OrganError::Ventricle(VentricleError::GridTooLarge { .. })) => {
                assert!(e.to_string().contains(want), "{e}")
            }
            e => panic!("expected a Config error about {want}, got {e:?}"),
        };
        let input_error = |e: OrganError, want: &str| match e {
            OrganError::Ventricle(e) => assert!(e.to_string().contains(want), "{e}"),
            e => panic!("expected a Ventricle error about {want}, got {e:?}"),
        };
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            config_error(solve(config(bad)), "grid spacing");
            config_error(
                solve(FieldConfig {
                    hemisphere_mm: bad,
                    ..config(1.0)
                }),
                "hemisphere radius",
            );
            config_error(
                solve(FieldConfig {
                    tolerance: bad,
                    ..config(1.0)
                }),
                "field tolerance",
            );
        }
        // 4011 x 4011 x 2006 nodes
        let e = solve(config(0.01));
        assert!(
            matches!(
                e,
                OrganError::Ventricle(VentricleError::GridTooLarge {
                    dims: [4011, 4011, 2006],
                    limit: MAX_GRID_NODES,
                    ..
                })
            ),
            "{e:?}"
        );
        config_error(e, "coarser grid");
        let e = solve(FieldConfig {
            hemisphere_mm: 1000.0,
            ..config(1.0)
        });
        assert!(
            matches!(
                e,
                OrganError::Ventricle(VentricleError::HemisphereDoesNotFit { radius_mm, .. })
                    if radius_mm == 1000.0
            ),
            "{e:?}"
        );
        input_error(e, "does not fit");
        // H as large as S: the nearest vertex is R from the centre
        let e = solve(FieldConfig {
            hemisphere_mm: R,
            ..config(1.0)
        });
        assert!(
            matches!(
                e,
                OrganError::Ventricle(VentricleError::HemisphereDoesNotFit { distance_mm, .. })
                    if (distance_mm - R).abs() < 1e-9
            ),
            "{e:?}"
        );
        input_error(e, "does not fit");
        // a grid far coarser than S: no node between S and H
        let e = solve(config(100.0));
        assert_eq!(
            e,
            OrganError::Ventricle(VentricleError::NoUnknowns { grid_mm: 100.0 })
        );
        input_error(e, "finer grid");
        // landmarks that do not fit S
        let two = Landmarks {
            rim: vec![l.rim[0], l.rim[1]],
            ..l.clone()
        };
        let e = err_of(LaplaceField::solve(s, &two, &config(1.0)));
        assert_eq!(
            e,
            OrganError::Ventricle(VentricleError::RimTooShort { rim: 2 })
        );
        input_error(e, "landmarks");
    }
}
