//! The initial layout of one leaflet below its fixed annulus (ALGORITHMS
//! 4.2): every annulus vertex at its `(u, v)` from the annulus map, the rest
//! of the leaflet below, no triangle flipped.
//!
//! Orientation convention (shared by both layouts): the map shows the
//! leaflet as seen from the atrium, `u` to the right (along the annulus,
//! clockwise seen from the atrium), `v` up, the annulus at the top. A
//! leaflet whose triangles face the atrium (combinatorially: whose boundary
//! loop, taken in the direction its triangles traverse it, runs along the
//! annulus from the *last* annulus vertex to the first, as the generator's
//! leaflets do) comes out with every triangle counter-clockwise, positive
//! signed area in the mesh's own vertex order,
//!
//! ```text
//! A(a, b, c) = ((q_b - q_a) x (q_c - q_a)) / 2 > 0;
//! ```
//!
//! a leaflet whose triangles all face the ventricle gets the same positions
//! with every triangle clockwise (`A < 0` throughout: the mirror convention,
//! which the relaxation accepts by taking the majority orientation as
//! positive). Either way no triangle is flipped relative to the others. A
//! mesh whose own triangles are not consistently oriented is an error.
//!
//! Two layouts:
//!
//! - [`longitude_layout`] (the source's): along each longitude (a vertex
//!   chain from an annulus vertex down to the free edge, [`longitudes`])
//!   `u_i = u_1`, `v_i = v_{i-1} - |p_i - p_{i-1}|`;
//! - [`tutte_layout`]: for any disk-topology leaflet, a mean-value Tutte
//!   embedding below the annulus, with a flip-free homotopy when the annulus
//!   profile is not convex.

use super::annulus::AnnulusMap;
use super::{LayoutError, LayoutKind, Leaflet};
use crate::OrganError;
use std::collections::VecDeque;
use unfold_linalg::{mean_value_weights, solve_dirichlet_weights};
use unfold_mesh::TriMesh;
use unfold_mesh::topology::{Adjacency, vertex_adjacency};
use unfold_param::energy::SymmetricDirichlet;
use unfold_param::initializer::disk_boundary_loop;
use unfold_param::linesearch::max_step_tris;
use unfold_param::{Executor, Objective, ParamMesh, ProjectedNewton, Stopping};

/// The `(u, v)` of every annulus vertex of a leaflet: `q_k =
/// map.at(leaflet.annulus_s[k])` (linear interpolation along the annulus
/// map by 3D arc length, see [`AnnulusMap::at`]). The posterior leaflet's
/// last vertex (`s = L`) gets the closing point, at the right end of the
/// map.
pub fn annulus_uv(leaflet: &Leaflet, map: &AnnulusMap) -> Vec<[f64; 2]> {
    leaflet.annulus_s.iter().map(|&s| map.at(s)).collect()
}

// ---------------------------------------------------------------------------
// Longitudes
// ---------------------------------------------------------------------------

/// Orders the vertices of `row` (hop distance `k` from the annulus) so that
/// position `j` is joined to `prev[j]`; `None` unless the row's own edges
/// form a single path and exactly one of its two directions fits.
fn order_row(
    row: &[u32],
    prev: &[u32],
    adj: &Adjacency,
    hop: &[usize],
    k: usize,
) -> Option<Vec<u32>> {
    let in_row = |w: u32| hop[w as usize] == k;
    let row_degree = |v: u32| {
        adj.neighbors(v as usize)
            .iter()
            .filter(|&&w| in_row(w))
            .count()
    };
    let ends: Vec<u32> = row
        .iter()
        .copied()
        .filter(|&v| row_degree(v) == 1)
        .collect();
    if ends.len() != 2 || row.iter().any(|&v| row_degree(v) > 2) {
        return None;
    }
    // Walk the path from one end.
    let mut path = vec![ends[0]];
    let mut last = u32::MAX;
    let mut cur = ends[0];
    while path.len() < row.len() {
        let next = adj
            .neighbors(cur as usize)
            .iter()
            .copied()
            .find(|&w| in_row(w) && w != last)?;
        last = cur;
        cur = next;
        path.push(cur);
    }
    if cur != ends[1] {
        return None;
    }
    let joined = |a: u32, b: u32| adj.neighbors(a as usize).binary_search(&b).is_ok();
    let fits = |order: &[u32]| order.iter().zip(prev).all(|(&a, &b)| joined(a, b));
    let forward = fits(&path);
    path.reverse();
    let backward = fits(&path);
    match (forward, backward) {
        (true, false) => {
            path.reverse();
            Some(path)
        }
        (false, true) => Some(path),
        _ => None,
    }
}

/// Detects "longitudes": one vertex chain per annulus vertex, from it down
/// to the free edge, as in the source's segmentations (a grid of `m`
/// columns by `R + 1` rows, `m` the number of annulus vertices). Returns the
/// chains (each starting at its annulus vertex, in annulus order) or `None`
/// when the leaflet is not organised that way.
///
/// The rule (a certificate: a `Some` answer is exactly a grid):
///
/// 1. rows by hop distance: `row_k = {i : BFS edge distance from the
///    annulus vertices = k}`; every vertex is reached and every row has
///    exactly `m` vertices (so `n = m (R + 1)`);
/// 2. row 0 is the annulus, and its edges are exactly the path
///    `annulus[0] - annulus[1] - ... - annulus[m-1]`; every other row's own
///    edges form one path, ordered so that its `j`-th vertex is joined to
///    the `j`-th vertex of the row above (exactly one of the two directions
///    must fit); chain `j` is the `j`-th vertex of every row;
/// 3. every triangle lies in one grid cell (two consecutive columns by two
///    consecutive rows) and every cell holds exactly two triangles that
///    cover its four corners and share one of its diagonals.
///
/// The commissural columns (`j = 0` and `j = m - 1`) and the bottom row
/// then form the free edge, as in `unfold_mesh::shapes::mitral_valve`.
/// Anything else (a remeshed leaflet, a flipped grid edge, an extra vertex,
/// columns of different lengths) gives `None`.
pub fn longitudes(leaflet: &Leaflet) -> Option<Vec<Vec<u32>>> {
    let mesh = &leaflet.mesh;
    let n = mesh.positions.len();
    let m = leaflet.annulus.len();
    if m < 2 || n == 0 || mesh.triangles.is_empty() || !n.is_multiple_of(m) {
        return None;
    }
    let nrows = n / m;
    if nrows < 2
        || mesh.triangles.iter().flatten().any(|&v| v as usize >= n)
        || leaflet.annulus.iter().any(|&v| v as usize >= n)
    {
        return None;
    }
    let adj = vertex_adjacency(n, &mesh.triangles);
    // 1. Rows by hop distance.
    let mut hop = vec![usize::MAX; n];
    let mut queue = VecDeque::with_capacity(n);
    for &a in &leaflet.annulus {
        if hop[a as usize] == 0 {
            return None;
        }
        hop[a as usize] = 0;
        queue.push_back(a);
    }
    while let Some(v) = queue.pop_front() {
        let h = hop[v as usize] + 1;
        for &w in adj.neighbors(v as usize) {
            if hop[w as usize] == usize::MAX {
                hop[w as usize] = h;
                queue.push_back(w);
            }
        }
    }
    let mut rows: Vec<Vec<u32>> = vec![Vec::with_capacity(m); nrows];
    for (v, &h) in hop.iter().enumerate() {
        if h >= nrows {
            return None;
        }
        rows[h].push(v as u32);
    }
    if rows.iter().any(|r| r.len() != m) {
        return None;
    }
    // 2. Row order.
    let mut ordered: Vec<Vec<u32>> = Vec::with_capacity(nrows);
    ordered.push(leaflet.annulus.clone());
    for k in 1..nrows {
        let row = order_row(&rows[k], &ordered[k - 1], &adj, &hop, k)?;
        ordered.push(row);
    }
    let mut cell_of = vec![(0usize, 0usize); n];
    for (k, row) in ordered.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            cell_of[v as usize] = (j, k);
        }
    }
    // Every row's own edges are exactly its path (row 0 included).
    for (k, row) in ordered.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            let mut count = 0;
            for &w in adj.neighbors(v as usize) {
                let (jw, kw) = cell_of[w as usize];
                if kw == k {
                    if jw.abs_diff(j) != 1 {
                        return None;
                    }
                    count += 1;
                }
            }
            let expected = if j == 0 || j == m - 1 { 1 } else { 2 };
            if count != expected {
                return None;
            }
        }
    }
    // 3. Cells: two triangles sharing a diagonal, covering all 4 corners.
    let mut masks: Vec<Vec<u8>> = vec![Vec::new(); (m - 1) * (nrows - 1)];
    for t in &mesh.triangles {
        let c = t.map(|v| cell_of[v as usize]);
        let j0 = c.iter().map(|x| x.0).min()?;
        let j1 = c.iter().map(|x| x.0).max()?;
        let k0 = c.iter().map(|x| x.1).min()?;
        let k1 = c.iter().map(|x| x.1).max()?;
        if j1 != j0 + 1 || k1 != k0 + 1 {
            return None;
        }
        let mut mask = 0u8;
        for &(j, k) in &c {
            mask |= 1 << ((j - j0) + 2 * (k - k0));
        }
        if mask.count_ones() != 3 {
            return None;
        }
        masks[k0 * (m - 1) + j0].push(mask);
    }
    for cell in &masks {
        match cell.as_slice() {
            &[a, b] if a | b == 0b1111 && (a & b == 0b1001 || a & b == 0b0110) => {}
            _ => return None,
        }
    }
    Some(
        (0..m)
            .map(|j| ordered.iter().map(|row| row[j]).collect())
            .collect(),
    )
}

/// Longitude layout (the source's, ALGORITHMS 4.2): every vertex of chain
/// `j` gets the `u` of its annulus vertex, and `v` drops by the 3D length of
/// each chain edge,
///
/// ```text
/// q_1 = annulus_uv[j],   u_i = u_1,   v_i = v_{i-1} - |p_i - p_{i-1}|
/// ```
///
/// Returns per-vertex `(u, v)` for the whole leaflet. On a grid from
/// [`longitudes`] with `u` strictly increasing along the annulus every cell
/// is a trapezoid with vertical sides, so no triangle flips (counter-
/// clockwise for a leaflet facing the atrium, see the module docs).
///
/// # Errors
/// A [`LayoutError`] (in [`OrganError::Mitral`]) when `annulus_uv` or
/// `chains` do not have one entry per annulus vertex, a chain does not
/// start at its annulus vertex, a vertex index is out of range, a vertex is
/// on two chains or on none, or a target or length is not finite.
pub fn longitude_layout(
    leaflet: &Leaflet,
    chains: &[Vec<u32>],
    annulus_uv: &[[f64; 2]],
) -> Result<Vec<[f64; 2]>, OrganError> {
    Ok(longitude_positions(leaflet, chains, annulus_uv)?)
}

/// [`longitude_layout`] (which only fails with a [`LayoutError`]).
fn longitude_positions(
    leaflet: &Leaflet,
    chains: &[Vec<u32>],
    annulus_uv: &[[f64; 2]],
) -> Result<Vec<[f64; 2]>, LayoutError> {
    let mesh = &leaflet.mesh;
    let n = mesh.positions.len();
    let m = leaflet.annulus.len();
    if annulus_uv.len() != m {
        return Err(LayoutError::TargetCount {
            layout: LayoutKind::Longitudes,
            targets: annulus_uv.len(),
            annulus_vertices: m,
        });
    }
    if chains.len() != m {
        return Err(LayoutError::LongitudeCount {
            longitudes: chains.len(),
            annulus_vertices: m,
        });
    }
    let mut uv = vec![[f64::NAN; 2]; n];
    let mut seen = vec![false; n];
    for (j, chain) in chains.iter().enumerate() {
        if chain.first() != Some(&leaflet.annulus[j]) {
            return Err(LayoutError::LongitudeStart {
                longitude: j,
                vertex: leaflet.annulus[j],
            });
        }
        let q = annulus_uv[j];
        if !(q[0].is_finite() && q[1].is_finite()) {
            return Err(LayoutError::TargetNotFinite {
                layout: LayoutKind::Longitudes,
                annulus_index: j,
                uv: q,
            });
        }
        let mut prev: Option<usize> = None;
        for &v in chain {
            let vi = v as usize;
            if vi >= n {
                return Err(LayoutError::LongitudeVertexOutOfRange {
                    vertex: v,
                    vertices: n,
                });
            }
            if seen[vi] {
                return Err(LayoutError::VertexOnTwoLongitudes { vertex: v });
            }
            seen[vi] = true;
            uv[vi] = match prev {
                None => q,
                Some(p) => {
                    let d = (mesh.positions[vi] - mesh.positions[p]).norm();
                    if !d.is_finite() {
                        return Err(LayoutError::LongitudeEdgeNotFinite {
                            from: p as u32,
                            to: v,
                        });
                    }
                    [q[0], uv[p][1] - d]
                }
            };
            prev = Some(vi);
        }
    }
    if let Some(vertex) = seen.iter().position(|&s| !s) {
        return Err(LayoutError::VertexOnNoLongitude { vertex });
    }
    Ok(uv)
}

// ---------------------------------------------------------------------------
// Tutte
// ---------------------------------------------------------------------------

/// Relative height of the bump added to the convexified annulus (times the
/// annulus width), which makes its top chain strictly convex.
const BUMP: f64 = 0.02;
/// Steps of the homotopy from the convexified to the true annulus (a few
/// for realistic profiles; tens for needle-like dips on fine meshes).
const MAX_HOMOTOPY_STEPS: usize = 500;
/// Fraction of the first-flip bound taken by a homotopy step that cannot
/// reach the targets at once.
const STEP_FRACTION: f64 = 0.8;
/// Newton iterations relaxing the interior after each homotopy step.
const RELAX_ITERATIONS: usize = 8;
/// A direct embedding is accepted when its smallest triangle area is above
/// this fraction of the mean (else the homotopy runs, which relaxes).
const MIN_AREA_REL: f64 = 1e-8;

/// Twice the signed area of triangle `t` in the layout `q`.
fn signed_area(q: &[[f64; 2]], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| q[v as usize]);
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// `(min, mean |.|)` of twice the signed triangle areas.
fn area_stats(tris: &[[u32; 3]], q: &[[f64; 2]]) -> (f64, f64) {
    let mut min = f64::INFINITY;
    let mut sum = 0.0;
    for t in tris {
        let a = signed_area(q, t);
        min = if a.is_nan() { f64::NAN } else { min.min(a) };
        sum += a.abs();
    }
    (min, sum / tris.len().max(1) as f64)
}

/// Checks the targets: one finite `(u, v)` per annulus vertex, `u` strictly
/// increasing.
fn check_targets(leaflet: &Leaflet, targets: &[[f64; 2]]) -> Result<(), LayoutError> {
    let m = leaflet.annulus.len();
    if targets.len() != m {
        return Err(LayoutError::TargetCount {
            layout: LayoutKind::Tutte,
            targets: targets.len(),
            annulus_vertices: m,
        });
    }
    if m < 2 {
        return Err(LayoutError::TooFewAnnulusVertices {
            annulus_vertices: m,
        });
    }
    if let Some(k) = targets
        .iter()
        .position(|q| !(q[0].is_finite() && q[1].is_finite()))
    {
        return Err(LayoutError::TargetNotFinite {
            layout: LayoutKind::Tutte,
            annulus_index: k,
            uv: targets[k],
        });
    }
    if let Some(k) = targets.windows(2).position(|w| w[1][0] <= w[0][0]) {
        return Err(LayoutError::UNotIncreasing {
            annulus_index: k + 1,
            u: targets[k + 1][0],
            previous_u: targets[k][0],
        });
    }
    Ok(())
}

/// Checks the leaflet mesh (valid indices, finite positions, no repeated
/// corner, every vertex used, consistently oriented manifold disk, the
/// annulus a run of its boundary in annulus order) and returns the free
/// edge (the boundary vertices from the one after the last annulus vertex to
/// the one before the first, taken from the mesh's own boundary loop) and
/// whether the leaflet faces the atrium (its loop runs along the annulus
/// from the last annulus vertex to the first).
fn boundary_of(leaflet: &Leaflet) -> Result<(Vec<u32>, bool), OrganError> {
    let mesh = &leaflet.mesh;
    let n = mesh.positions.len();
    unfold_mesh::geometry::check_finite(&mesh.positions)?;
    unfold_mesh::geometry::check_indices(n, &mesh.triangles)?;
    let mut used = vec![false; n];
    for (i, t) in mesh.triangles.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Err(LayoutError::TriangleRepeatsVertex {
                triangle: i,
                corners: *t,
            }
            .into());
        }
        for &v in t {
            used[v as usize] = true;
        }
    }
    if let Some(vertex) = used.iter().position(|&u| !u) {
        return Err(LayoutError::UnusedVertex { vertex }.into());
    }
    if let Some(&vertex) = leaflet.annulus.iter().find(|&&v| v as usize >= n) {
        return Err(LayoutError::AnnulusVertexOutOfRange {
            vertex,
            vertices: n,
        }
        .into());
    }
    // Consistent orientation: every directed edge at most once, every
    // undirected edge in at most two triangles.
    let mut directed: Vec<(u32, u32)> = mesh
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |i| (t[i], t[(i + 1) % 3])))
        .collect();
    directed.sort_unstable();
    if let Some(w) = directed.windows(2).find(|w| w[0] == w[1]) {
        return Err(LayoutError::InconsistentOrientation {
            edge: [w[0].0, w[0].1],
        }
        .into());
    }
    let loop_ = disk_boundary_loop(mesh)?;
    let nb = loop_.len();
    let m = leaflet.annulus.len();
    let Some(p0) = loop_.iter().position(|&v| v == leaflet.annulus[0]) else {
        return Err(LayoutError::AnnulusOffBoundary {
            vertex: leaflet.annulus[0],
        }
        .into());
    };
    let at = |i: isize| loop_[i.rem_euclid(nb as isize) as usize];
    let p0 = p0 as isize;
    let fits =
        |dir: isize| m <= nb && (0..m).all(|j| at(p0 + dir * j as isize) == leaflet.annulus[j]);
    let dir = if fits(-1) {
        -1
    } else if fits(1) {
        1
    } else {
        return Err(LayoutError::AnnulusNotABoundaryRun.into());
    };
    let m = m as isize;
    let free = (0..nb as isize - m)
        .map(|t| at(p0 + dir * (m + t)))
        .collect();
    Ok((free, dir == -1))
}

/// The free-edge positions on the lower half-ellipse from `b` (the last
/// annulus vertex, `theta = 0`) to `a` (the first, `theta = pi`):
///
/// ```text
/// P(theta) = M + cos(theta) (b - M) + sin(theta) (0, -depth),   M = (a + b) / 2
/// ```
///
/// at `theta_t = pi sigma_t / S`, `sigma_t` the 3D arc length along the
/// free edge from `b` (uniform when the free edge has zero length). With a
/// top chain that is a concave function of `u` above the chord `ab`, the
/// boundary polygon is convex.
fn free_edge_curve(
    mesh: &TriMesh,
    path: &[u32],
    a: [f64; 2],
    b: [f64; 2],
    depth: f64,
) -> Vec<[f64; 2]> {
    // path = [last annulus vertex, free..., first annulus vertex]
    let mut sigma = vec![0.0];
    for w in path.windows(2) {
        let d = (mesh.positions[w[1] as usize] - mesh.positions[w[0] as usize]).norm();
        sigma.push(sigma[sigma.len() - 1] + d);
    }
    let total = sigma[sigma.len() - 1];
    let steps = (path.len() - 1) as f64;
    let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
    (1..path.len() - 1)
        .map(|t| {
            let f = if total > 0.0 {
                sigma[t] / total
            } else {
                t as f64 / steps
            };
            let theta = std::f64::consts::PI * f;
            let (c, s) = (theta.cos(), theta.sin());
            [
                mid[0] + c * (b[0] - mid[0]),
                mid[1] + c * (b[1] - mid[1]) - s * depth,
            ]
        })
        .collect()
}

/// The upper concave envelope of points with strictly increasing `u`,
/// evaluated at each point (`>= v`, equal on the hull).
fn concave_envelope(pts: &[[f64; 2]]) -> Vec<f64> {
    let mut hull: Vec<usize> = Vec::with_capacity(pts.len());
    for (i, p) in pts.iter().enumerate() {
        while hull.len() >= 2 {
            let (a, b) = (pts[hull[hull.len() - 2]], pts[hull[hull.len() - 1]]);
            let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
            if cross >= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(i);
    }
    let mut out = Vec::with_capacity(pts.len());
    let mut h = 0;
    for (i, p) in pts.iter().enumerate() {
        while h + 1 < hull.len() && hull[h + 1] < i {
            h += 1;
        }
        if hull[h] == i {
            out.push(p[1]);
            continue;
        }
        let (a, b) = (pts[hull[h]], pts[hull[h + 1]]);
        let t = (p[0] - a[0]) / (b[0] - a[0]);
        out.push(a[1] + t * (b[1] - a[1]));
    }
    out
}

/// Everything the Tutte solves share.
struct TutteSetup<'a> {
    leaflet: &'a Leaflet,
    weights: Vec<Vec<(u32, f64)>>,
    /// `[last annulus vertex, free edge..., first annulus vertex]`.
    path: Vec<u32>,
    depth: f64,
}

impl<'a> TutteSetup<'a> {
    fn new(leaflet: &'a Leaflet, targets: &[[f64; 2]]) -> Result<Self, OrganError> {
        check_targets(leaflet, targets)?;
        let (free, atrium_facing) = boundary_of(leaflet)?;
        if !atrium_facing {
            return Err(LayoutError::NotFacingAtrium.into());
        }
        let mesh = &leaflet.mesh;
        let m = leaflet.annulus.len();
        let mut path = Vec::with_capacity(free.len() + 2);
        path.push(leaflet.annulus[m - 1]);
        path.extend(&free);
        path.push(leaflet.annulus[0]);
        // Depth of the half-ellipse: its area pi W depth / 4 matches the
        // leaflet's 3D area (at least a tenth of the width W).
        let area: f64 = (0..mesh.num_triangles())
            .map(|t| {
                let [a, b, c] = mesh.triangle_points(t);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum();
        let (a, b) = (targets[0], targets[m - 1]);
        let width = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let depth = (4.0 * area / (std::f64::consts::PI * width)).max(0.1 * width);
        if !depth.is_finite() {
            return Err(LayoutError::AreaNotFinite { area_mm2: area }.into());
        }
        Ok(TutteSetup {
            leaflet,
            weights: mean_value_weights(mesh),
            path,
            depth,
        })
    }

    /// The mean-value Tutte embedding with the annulus at `top` and the free
    /// edge on the half-ellipse below it.
    fn embed(&self, top: &[[f64; 2]]) -> Result<Vec<[f64; 2]>, OrganError> {
        let l = self.leaflet;
        let m = l.annulus.len();
        let curve = free_edge_curve(&l.mesh, &self.path, top[0], top[m - 1], self.depth);
        let free = &self.path[1..self.path.len() - 1];
        let fixed: Vec<u32> = l.annulus.iter().chain(free).copied().collect();
        let pos: Vec<[f64; 2]> = top.iter().chain(&curve).copied().collect();
        let cols = solve_dirichlet_weights(
            &self.weights,
            &fixed,
            &[
                pos.iter().map(|q| q[0]).collect(),
                pos.iter().map(|q| q[1]).collect(),
            ],
        )?;
        let mut q: Vec<[f64; 2]> = (0..cols[0].len())
            .map(|i| [cols[0][i], cols[1][i]])
            .collect();
        // Exactly the given boundary positions.
        for (&v, p) in fixed.iter().zip(&pos) {
            q[v as usize] = *p;
        }
        Ok(q)
    }
}

/// The direct embedding with the true annulus, when it is flip-free (with a
/// margin); `None` otherwise.
fn tutte_direct(
    setup: &TutteSetup<'_>,
    targets: &[[f64; 2]],
) -> Result<Option<Vec<[f64; 2]>>, OrganError> {
    let q = setup.embed(targets)?;
    let (min, mean) = area_stats(&setup.leaflet.mesh.triangles, &q);
    Ok((min > MIN_AREA_REL * mean).then_some(q))
}

/// The flip-free homotopy: a Tutte embedding with the annulus convexified
/// (`v` replaced by its upper concave envelope plus a small concave bump,
/// `u` unchanged), then the annulus moved down to its targets along the
/// vertical shear `d_i = (0, delta(u_i))` (`delta` the piecewise-linear
/// interpolation over `u` of the remaining annulus displacement; affine, so
/// flip-free, on every triangle within one annulus `u` interval): the whole
/// way when no triangle flips on `[0, 1]` (`a_max > 1`, then the annulus is
/// set exactly to its targets), else `0.8 a_max`; each step followed by a
/// few projected Newton iterations of the 2D symmetric Dirichlet energy
/// (annulus fixed, a barrier against flips) that make room for the next.
fn tutte_homotopy(
    setup: &TutteSetup<'_>,
    targets: &[[f64; 2]],
) -> Result<Vec<[f64; 2]>, OrganError> {
    let l = setup.leaflet;
    let mesh = &l.mesh;
    let m = l.annulus.len();
    let (u0, u1) = (targets[0][0], targets[m - 1][0]);
    let width = u1 - u0;
    let envelope = concave_envelope(targets);
    let top: Vec<[f64; 2]> = targets
        .iter()
        .zip(&envelope)
        .map(|(q, e)| {
            let t = (q[0] - u0) / width;
            [q[0], e + BUMP * width * 4.0 * t * (1.0 - t)]
        })
        .collect();
    let start = setup.embed(&top)?;
    let (min, _) = area_stats(&mesh.triangles, &start);
    if min.is_nan() || min <= 0.0 {
        return Err(LayoutError::ConvexEmbeddingFlips {
            min_double_area: min,
        }
        .into());
    }
    let pm = ParamMesh::from_triangles(mesh)?;
    let energy = SymmetricDirichlet;
    let mut fixed = vec![false; mesh.num_vertices()];
    for &v in &l.annulus {
        fixed[v as usize] = true;
    }
    let mut objective = Objective::new(&pm, &energy, 1.0, None, &fixed)?;
    let newton = ProjectedNewton::default();
    let stopping = Stopping {
        max_iterations: RELAX_ITERATIONS,
        grad_tol: 1e-9,
        ..Stopping::default()
    };
    let mut x: Vec<f64> = start.iter().flatten().copied().collect();
    let mut d = vec![0.0; x.len()];
    let us: Vec<f64> = targets.iter().map(|q| q[0]).collect();
    for _ in 0..MAX_HOMOTOPY_STEPS {
        // Remaining vertical displacement of the annulus (u never changes).
        let rest: Vec<f64> = l
            .annulus
            .iter()
            .zip(targets)
            .map(|(&v, q)| q[1] - x[2 * v as usize + 1])
            .collect();
        let delta = |u: f64| {
            let j = us.partition_point(|&x| x <= u);
            if j == 0 {
                rest[0]
            } else if j == m {
                rest[m - 1]
            } else {
                let t = (u - us[j - 1]) / (us[j] - us[j - 1]);
                rest[j - 1] + t * (rest[j] - rest[j - 1])
            }
        };
        for i in 0..mesh.num_vertices() {
            d[2 * i] = 0.0;
            d[2 * i + 1] = delta(x[2 * i]);
        }
        for (&v, r) in l.annulus.iter().zip(&rest) {
            d[2 * v as usize + 1] = *r;
        }
        let a_max = max_step_tris(&mesh.triangles, &x, &d);
        let arrived = a_max > 1.0 && {
            let mut y: Vec<f64> = x.iter().zip(&d).map(|(xi, di)| xi + di).collect();
            for (&v, q) in l.annulus.iter().zip(targets) {
                y[2 * v as usize] = q[0];
                y[2 * v as usize + 1] = q[1];
            }
            let q: Vec<[f64; 2]> = y.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
            let ok = area_stats(&mesh.triangles, &q).0 > 0.0;
            if ok {
                x = y;
            }
            ok
        };
        if !arrived {
            let a = STEP_FRACTION * a_max.min(1.0);
            if a.is_nan() || a <= 1e-12 {
                break;
            }
            for (xi, di) in x.iter_mut().zip(&d) {
                *xi += a * di;
            }
        }
        // Relax the interior and the free edge (never flips; the annulus
        // stays where it is).
        Executor::new(&newton)
            .stopping(stopping)
            .run(&mut objective, &mut x, &mut [])?;
        if arrived {
            let q: Vec<[f64; 2]> = x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
            return Ok(q);
        }
    }
    Err(LayoutError::HomotopyStalled {
        max_steps: MAX_HOMOTOPY_STEPS,
    }
    .into())
}

/// A flip-free layout of any disk-topology leaflet with the annulus
/// vertices exactly at `annulus_uv` (`u` strictly increasing) and every
/// triangle counter-clockwise in the `(u, v)` map (positive signed area in
/// the mesh's own vertex order) for a leaflet facing the atrium, every
/// triangle clockwise for one facing the ventricle (the orientation the
/// longitude layout gives; see the module docs). The positions do not
/// depend on the leaflet's orientation.
///
/// The boundary polygon: the annulus chain on top, the free edge (the rest
/// of the mesh's boundary loop) on the lower half-ellipse between the
/// annulus' two ends,
///
/// ```text
/// P(theta) = M + cos(theta) (q_last - M) - sin(theta) (0, depth),   M = (q_first + q_last) / 2
/// ```
///
/// at `theta = pi sigma / S` (`sigma` the 3D arc length along the free edge
/// from the last annulus vertex), `depth = max(4 A / (pi W), W / 10)` (the
/// half-ellipse's area matches the leaflet's 3D area `A`, `W` the chord
/// length). Every other vertex is the mean-value weighted mean of its
/// neighbours (Floater 2003, positive weights):
/// `sum_j w_ij (q_i - q_j) = 0`.
///
/// When the annulus profile is a concave function of `u` the polygon is
/// convex and this is flip-free by Tutte's theorem. Otherwise (a dip in
/// the saddle) the embedding is tried anyway and kept when flip-free; if
/// not, the annulus is first convexified (upper concave envelope plus a
/// small bump), embedded, and moved down to its targets by a flip-free
/// homotopy (steps bounded by the first flip, symmetric Dirichlet Newton
/// relaxation in between, annulus fixed).
///
/// # Errors
/// A [`LayoutError`] (in [`OrganError::Mitral`]) for targets that do not
/// fit (length, non-finite, `u` not strictly increasing), a mesh that is
/// not a consistently oriented disk whose boundary holds the annulus as a
/// run in annulus order (every vertex used by a triangle), or a homotopy
/// that does not reach the targets; [`OrganError::Mesh`] /
/// [`OrganError::Param`] from the checks and solves.
pub fn tutte_layout(
    leaflet: &Leaflet,
    annulus_uv: &[[f64; 2]],
) -> Result<Vec<[f64; 2]>, OrganError> {
    check_targets(leaflet, annulus_uv)?;
    let (_, atrium_facing) = boundary_of(leaflet)?;
    if !atrium_facing {
        // The same positions serve the mirrored leaflet (all clockwise).
        let mut facing = leaflet.clone();
        for t in &mut facing.mesh.triangles {
            t.swap(1, 2);
        }
        return tutte_layout(&facing, annulus_uv);
    }
    let setup = TutteSetup::new(leaflet, annulus_uv)?;
    if let Some(q) = tutte_direct(&setup, annulus_uv)? {
        return Ok(q);
    }
    tutte_homotopy(&setup, annulus_uv)
}

#[cfg(test)]
mod tests {
    use super::super::annulus::parameterize;
    use super::super::annulus::tests::prepared;
    use super::super::{ANTERIOR, AnnulusMode, POSTERIOR};
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::nalgebra::Point3;
    use unfold_mesh::shapes::{Pose, ValveParams, ValveShape, mitral_valve, uv_sphere};
    use unfold_mesh::topology::boundary_loops;
    use unfold_param::flips::check_no_flips;

    const MODES: [AnnulusMode; 3] = [
        AnnulusMode::Straight,
        AnnulusMode::LeastSquares,
        AnnulusMode::Landmark,
    ];

    /// The layout error of `r`.
    fn layout_err<T: std::fmt::Debug>(r: Result<T, OrganError>) -> LayoutError {
        match r {
            Err(OrganError::Mitral(crate::mitral::MitralError::Layout(e))) => e,
            other => panic!("expected a layout error, got {other:?}"),
        }
    }

    fn shapes() -> Vec<ValveShape> {
        let d = ValveParams::default();
        [
            d.clone(),
            ValveParams {
                annulus_segments: 24,
                depth_segments: 4,
                ..d.clone()
            },
            ValveParams {
                annulus_segments: 240,
                depth_segments: 40,
                ..d.clone()
            },
            ValveParams {
                billow: 0.0,
                saddle_height: 9.0,
                coaptation_depth: 8.0,
                pose: Pose::new([30.0, -70.0, 120.0], [10.0, -200.0, 55.0]),
                ..d.clone()
            },
        ]
        .iter()
        .map(|p| mitral_valve(p).unwrap())
        .collect()
    }

    fn truth(shape: &ValveShape, k: usize) -> &Vec<Vec<u32>> {
        if k == ANTERIOR {
            &shape.anterior_longitudes
        } else {
            &shape.posterior_longitudes
        }
    }

    /// No triangle with non-positive signed area (and the framework agrees).
    fn assert_flip_free(mesh: &TriMesh, q: &[[f64; 2]]) {
        assert_eq!(q.len(), mesh.num_vertices());
        for (i, t) in mesh.triangles.iter().enumerate() {
            let a = signed_area(q, t);
            assert!(a > 0.0, "triangle {i} {t:?} has signed area {a}");
        }
        let pm = ParamMesh::from_triangles(mesh).unwrap();
        let x: Vec<f64> = q.iter().flatten().copied().collect();
        check_no_flips(&pm, &x).unwrap();
    }

    fn assert_annulus_exact(leaflet: &Leaflet, q: &[[f64; 2]], targets: &[[f64; 2]]) {
        for (&v, t) in leaflet.annulus.iter().zip(targets) {
            assert_eq!(q[v as usize], *t, "annulus vertex {v}");
        }
    }

    /// Flips the edge `a-b` shared by two triangles (orientation kept).
    fn flip_edge(mesh: &mut TriMesh, a: u32, b: u32) {
        let find = |mesh: &TriMesh, x: u32, y: u32| {
            mesh.triangles
                .iter()
                .position(|t| (0..3).any(|i| t[i] == x && t[(i + 1) % 3] == y))
        };
        // Either direction of the edge: (a, b) as the first triangle has it.
        let (a, b) = if find(mesh, a, b).is_some() {
            (a, b)
        } else {
            (b, a)
        };
        let (t1, t2) = (find(mesh, a, b).unwrap(), find(mesh, b, a).unwrap());
        let third = |t: [u32; 3]| *t.iter().find(|&&v| v != a && v != b).unwrap();
        let (c, d) = (third(mesh.triangles[t1]), third(mesh.triangles[t2]));
        mesh.triangles[t1] = [a, d, c];
        mesh.triangles[t2] = [d, b, c];
    }

    /// Splits triangle `t` into three at its centroid.
    fn split_triangle(mesh: &mut TriMesh, t: usize) {
        let [a, b, c] = mesh.triangles[t];
        let p = mesh.triangle_points(t);
        let g = Point3::from((p[0].coords + p[1].coords + p[2].coords) / 3.0);
        let s = mesh.positions.len() as u32;
        mesh.positions.push(g);
        mesh.triangles[t] = [a, b, s];
        mesh.triangles.push([b, c, s]);
        mesh.triangles.push([c, a, s]);
    }

    #[test]
    fn mitral_layout_annulus_uv_follows_the_map() {
        let shape = mitral_valve(&ValveParams::default()).unwrap();
        let valve = prepared(&shape);
        let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let ant = annulus_uv(&valve.leaflets[ANTERIOR], &map);
        let post = annulus_uv(&valve.leaflets[POSTERIOR], &map);
        // Generator annulus vertices are ring points: exactly the map's uv.
        for (q, &r) in ant.iter().zip(&shape.anterior_annulus_ring) {
            assert_eq!(*q, map.uv[r]);
        }
        let n = shape.annulus.len();
        for (k, (q, &r)) in post.iter().zip(&shape.posterior_annulus_ring).enumerate() {
            let r = if k == post.len() - 1 { n } else { r };
            assert_eq!(*q, map.uv[r]);
        }
        assert_eq!(ant.last(), post.first());
        assert_eq!(post.last().unwrap()[0], map.u_extent());
    }

    #[test]
    fn mitral_layout_longitudes_match_the_generator() {
        for shape in shapes() {
            let valve = prepared(&shape);
            for k in [ANTERIOR, POSTERIOR] {
                let chains = longitudes(&valve.leaflets[k]).expect("a grid leaflet");
                assert_eq!(&chains, truth(&shape, k));
            }
        }
    }

    #[test]
    fn mitral_layout_longitudes_reject_non_grids() {
        let shape = mitral_valve(&ValveParams {
            annulus_segments: 40,
            depth_segments: 8,
            ..ValveParams::default()
        })
        .unwrap();
        let valve = prepared(&shape);
        let base = &valve.leaflets[ANTERIOR];
        let cols = &shape.anterior_longitudes;
        assert!(longitudes(base).is_some());

        // Flipping a cell's diagonal keeps the grid (and the answer).
        let mut l = base.clone();
        let (c0, c1) = (&cols[5], &cols[6]);
        let diag = if l
            .mesh
            .triangles
            .iter()
            .any(|t| t.contains(&c0[3]) && t.contains(&c1[4]))
        {
            (c0[3], c1[4])
        } else {
            (c0[4], c1[3])
        };
        flip_edge(&mut l.mesh, diag.0, diag.1);
        assert_eq!(longitudes(&l).as_ref(), Some(cols));

        // Flipping a horizontal grid edge breaks it.
        let mut l = base.clone();
        let (a, b) = (cols[5][3], cols[6][3]);
        flip_edge(&mut l.mesh, a, b);
        assert_eq!(longitudes(&l), None);

        // Flipping a vertical grid edge breaks it.
        let mut l = base.clone();
        let (a, b) = (cols[7][3], cols[7][4]);
        flip_edge(&mut l.mesh, a, b);
        assert_eq!(longitudes(&l), None);

        // An extra vertex (a split triangle).
        let mut l = base.clone();
        split_triangle(&mut l.mesh, 37);
        assert_eq!(longitudes(&l), None);

        // A vertex removed: the last one of a middle column, its two bottom
        // triangles replaced by one.
        let mut l = base.clone();
        let gone = *cols[10].last().unwrap();
        let last = l.mesh.positions.len() as u32 - 1;
        let mut fan: Vec<[u32; 3]> = Vec::new();
        l.mesh.triangles.retain(|t| {
            if t.contains(&gone) {
                fan.push(*t);
                false
            } else {
                true
            }
        });
        // The neighbours of `gone` in the bottom row and the row above, in
        // the boundary order: replace its fan by triangles from the middle
        // vertex above.
        let above = cols[10][cols[10].len() - 2];
        for t in &fan {
            let others: Vec<u32> = t.iter().copied().filter(|&v| v != gone).collect();
            if !others.contains(&above) {
                let i = t.iter().position(|&v| v == gone).unwrap();
                let mut nt = *t;
                nt[i] = above;
                l.mesh.triangles.push(nt);
            }
        }
        // Renumber the last vertex into the hole.
        l.mesh.positions.swap(gone as usize, last as usize);
        l.mesh.positions.pop();
        for t in &mut l.mesh.triangles {
            for v in t.iter_mut() {
                if *v == last {
                    *v = gone;
                }
            }
        }
        for v in l.annulus.iter_mut() {
            if *v == last {
                *v = gone;
            }
        }
        assert_eq!(longitudes(&l), None);

        // The other leaflet's annulus does not fit; a shortened annulus does
        // not either.
        let mut l = base.clone();
        l.annulus.pop();
        assert_eq!(longitudes(&l), None);
        let mut l = base.clone();
        l.annulus.swap(3, 4);
        assert_eq!(longitudes(&l), None);

        // A spherical cap (a pole fan, rings of equal size): no grid from a
        // run of its boundary.
        let cap = sphere_cap(8, 12);
        assert_eq!(longitudes(&cap), None);
    }

    /// The southern half of a UV sphere (a disk: a pole fan and rings), with
    /// half of its boundary ring as the annulus, facing "up" like a leaflet
    /// (its loop runs the annulus backwards).
    fn sphere_cap(n_lat: usize, n_lon: usize) -> Leaflet {
        let s = uv_sphere(n_lat, n_lon, 10.0);
        let keep: Vec<bool> = s.positions.iter().map(|p| p.z < 1e-9).collect();
        let mut map = vec![u32::MAX; s.positions.len()];
        let mut positions = Vec::new();
        for (i, p) in s.positions.iter().enumerate() {
            if keep[i] {
                map[i] = positions.len() as u32;
                positions.push(*p);
            }
        }
        let triangles: Vec<[u32; 3]> = s
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&v| keep[v as usize]))
            .map(|t| t.map(|v| map[v as usize]))
            .collect();
        let mesh = TriMesh::new(positions, triangles);
        let lp = boundary_loops(&mesh).unwrap().remove(0);
        let m = lp.len() / 2 + 1;
        let annulus: Vec<u32> = lp[..m].iter().rev().copied().collect();
        let mut annulus_s = vec![0.0];
        for w in annulus.windows(2) {
            let d = (mesh.positions[w[1] as usize] - mesh.positions[w[0] as usize]).norm();
            annulus_s.push(annulus_s[annulus_s.len() - 1] + d);
        }
        let free_edge = lp[m..].iter().rev().copied().collect();
        Leaflet {
            mesh,
            annulus,
            annulus_s,
            free_edge,
        }
    }

    /// Targets for a hand-made leaflet: `u` = arc length, `v` a profile.
    fn targets_of(l: &Leaflet, profile: impl Fn(f64) -> f64) -> Vec<[f64; 2]> {
        let total = *l.annulus_s.last().unwrap();
        l.annulus_s
            .iter()
            .map(|&s| [s, profile(s / total)])
            .collect()
    }

    #[test]
    fn mitral_layout_longitude_layout_is_flip_free() {
        for shape in shapes() {
            let valve = prepared(&shape);
            for mode in MODES {
                let map = parameterize(&valve, mode).unwrap();
                for k in [ANTERIOR, POSTERIOR] {
                    let l = &valve.leaflets[k];
                    let chains = longitudes(l).unwrap();
                    let targets = annulus_uv(l, &map);
                    let q = longitude_layout(l, &chains, &targets).unwrap();
                    assert_annulus_exact(l, &q, &targets);
                    for chain in &chains {
                        let u = q[chain[0] as usize][0];
                        for w in chain.windows(2) {
                            let (a, b) = (q[w[0] as usize], q[w[1] as usize]);
                            assert_eq!(b[0], u);
                            let d = (l.mesh.positions[w[1] as usize]
                                - l.mesh.positions[w[0] as usize])
                                .norm();
                            assert!(b[1] < a[1]);
                            assert!((a[1] - b[1] - d).abs() < 1e-12 * (1.0 + d));
                        }
                    }
                    assert_flip_free(&l.mesh, &q);
                }
            }
        }
    }

    #[test]
    fn mitral_layout_longitude_layout_errors() {
        let shape = mitral_valve(&ValveParams {
            annulus_segments: 24,
            depth_segments: 4,
            ..ValveParams::default()
        })
        .unwrap();
        let valve = prepared(&shape);
        let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let l = &valve.leaflets[ANTERIOR];
        let chains = longitudes(l).unwrap();
        let t = annulus_uv(l, &map);
        let m = l.annulus.len();
        assert_eq!(
            layout_err(longitude_layout(l, &chains, &t[1..])),
            LayoutError::TargetCount {
                layout: LayoutKind::Longitudes,
                targets: m - 1,
                annulus_vertices: m
            }
        );
        assert_eq!(
            layout_err(longitude_layout(l, &chains[1..], &t)),
            LayoutError::LongitudeCount {
                longitudes: m - 1,
                annulus_vertices: m
            }
        );
        let mut c = chains.clone();
        let dropped = c[2].pop().unwrap();
        let e = layout_err(longitude_layout(l, &c, &t));
        assert_eq!(
            e,
            LayoutError::VertexOnNoLongitude {
                vertex: dropped as usize
            }
        );
        assert!(e.to_string().contains("on no longitude"), "{e}");
        let mut c = chains.clone();
        let extra = c[3][2];
        c[2].push(extra);
        let e = layout_err(longitude_layout(l, &c, &t));
        assert!(e.to_string().contains("two longitudes"), "{e}");
        // Longitude 2 ends on vertex `extra` before longitude 3 reaches it.
        assert_eq!(e, LayoutError::VertexOnTwoLongitudes { vertex: extra });
        let mut c = chains.clone();
        c.swap(0, 1);
        assert_eq!(
            layout_err(longitude_layout(l, &c, &t)),
            LayoutError::LongitudeStart {
                longitude: 0,
                vertex: l.annulus[0]
            }
        );
        let mut c = chains.clone();
        c[1].push(99_999);
        assert_eq!(
            layout_err(longitude_layout(l, &c, &t)),
            LayoutError::LongitudeVertexOutOfRange {
                vertex: 99_999,
                vertices: l.mesh.positions.len()
            }
        );
        let mut bad = t.clone();
        bad[1][1] = f64::NAN;
        assert!(matches!(
            layout_err(longitude_layout(l, &chains, &bad)),
            LayoutError::TargetNotFinite {
                layout: LayoutKind::Longitudes,
                annulus_index: 1,
                ..
            }
        ));
        assert!(!e.to_string().contains('\n'));
    }

    #[test]
    fn mitral_layout_tutte_on_generator_leaflets() {
        for shape in shapes() {
            let valve = prepared(&shape);
            for mode in MODES {
                let map = parameterize(&valve, mode).unwrap();
                for k in [ANTERIOR, POSTERIOR] {
                    let l = &valve.leaflets[k];
                    let targets = annulus_uv(l, &map);
                    let q = tutte_layout(l, &targets).unwrap();
                    assert_annulus_exact(l, &q, &targets);
                    assert_flip_free(&l.mesh, &q);
                    // Everything below the annulus' highest point.
                    let top = targets.iter().map(|t| t[1]).fold(f64::MIN, f64::max);
                    assert!(q.iter().all(|p| p[1] <= top + 1e-9));
                }
            }
        }
    }

    #[test]
    fn mitral_layout_tutte_homotopy_on_generator_leaflets() {
        // The fallback path on its own (convexified annulus, then moved).
        let shape = mitral_valve(&ValveParams::default()).unwrap();
        let valve = prepared(&shape);
        for mode in MODES {
            let map = parameterize(&valve, mode).unwrap();
            for k in [ANTERIOR, POSTERIOR] {
                let l = &valve.leaflets[k];
                let targets = annulus_uv(l, &map);
                let setup = TutteSetup::new(l, &targets).unwrap();
                let q = tutte_homotopy(&setup, &targets).unwrap();
                assert_annulus_exact(l, &q, &targets);
                assert_flip_free(&l.mesh, &q);
            }
        }
    }

    /// `v` lowered by a Gaussian dip of `amp` mm around annulus vertex `c`.
    fn with_dip(targets: &[[f64; 2]], c: f64, width: f64, amp: f64) -> Vec<[f64; 2]> {
        targets
            .iter()
            .enumerate()
            .map(|(k, q)| {
                let x = (k as f64 - c) / width;
                [q[0], q[1] - amp * (-x * x).exp()]
            })
            .collect()
    }

    fn is_concave(targets: &[[f64; 2]]) -> bool {
        concave_envelope(targets)
            .iter()
            .zip(targets)
            .all(|(e, q)| (e - q[1]).abs() < 1e-12)
    }

    #[test]
    fn mitral_layout_tutte_with_non_convex_annulus() {
        let shape = mitral_valve(&ValveParams::default()).unwrap();
        let valve = prepared(&shape);
        let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let mut direct_failed = 0;
        for k in [ANTERIOR, POSTERIOR] {
            let l = &valve.leaflets[k];
            let base = annulus_uv(l, &map);
            let m = base.len() as f64;
            for (c, width, amp) in [
                (0.5 * m, 2.0, 4.0),
                (0.25 * m, 1.0, 3.0),
                (0.8 * m, 4.0, 8.0),
                (3.0, 1.5, 2.0),
            ] {
                let targets = with_dip(&base, c, width, amp);
                assert!(!is_concave(&targets));
                let setup = TutteSetup::new(l, &targets).unwrap();
                if tutte_direct(&setup, &targets).unwrap().is_none() {
                    direct_failed += 1;
                }
                let q = tutte_layout(l, &targets).unwrap();
                assert_annulus_exact(l, &q, &targets);
                assert_flip_free(&l.mesh, &q);
                let q = tutte_homotopy(&setup, &targets).unwrap();
                assert_annulus_exact(l, &q, &targets);
                assert_flip_free(&l.mesh, &q);
            }
        }
        // The dips are deep enough that the plain embedding flips somewhere.
        assert!(direct_failed > 0);
        // The posterior annulus in landmark mode is itself not concave.
        let post = annulus_uv(&valve.leaflets[POSTERIOR], &map);
        assert!(!is_concave(&post));
    }

    #[test]
    fn mitral_layout_tutte_on_non_grid_disks() {
        // A hemisphere (pole fan).
        let cap = sphere_cap(10, 24);
        for profile in [
            (|_| 0.0) as fn(f64) -> f64,
            |t| 3.0 * (std::f64::consts::PI * t).sin(),
            |t| -4.0 * (3.0 * std::f64::consts::PI * t).sin().abs(),
        ] {
            let targets = targets_of(&cap, profile);
            let q = tutte_layout(&cap, &targets).unwrap();
            assert_annulus_exact(&cap, &q, &targets);
            assert_flip_free(&cap.mesh, &q);
        }
        // A generator leaflet remeshed irregularly: splits and edge flips.
        let shape = mitral_valve(&ValveParams::default()).unwrap();
        let valve = prepared(&shape);
        let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let mut l = valve.leaflets[POSTERIOR].clone();
        for t in (0..l.mesh.num_triangles()).step_by(7) {
            split_triangle(&mut l.mesh, t);
        }
        // Flip some interior edges between split triangles.
        let mut flipped = 0;
        for t in (0..l.mesh.num_triangles()).step_by(11) {
            let [a, b, _] = l.mesh.triangles[t];
            let boundary = boundary_loops(&l.mesh).unwrap().remove(0);
            let interior = !boundary.contains(&a) || !boundary.contains(&b);
            let twin = l
                .mesh
                .triangles
                .iter()
                .any(|s| (0..3).any(|i| s[i] == b && s[(i + 1) % 3] == a));
            if interior && twin {
                let before = l.mesh.clone();
                flip_edge(&mut l.mesh, a, b);
                let edges = unfold_mesh::topology::edges(&l.mesh.triangles);
                let ok = edges.len() == unfold_mesh::topology::edges(&before.triangles).len();
                if !ok {
                    l.mesh = before;
                } else {
                    flipped += 1;
                }
            }
        }
        assert!(flipped > 10);
        assert_eq!(longitudes(&l), None);
        let targets = annulus_uv(&l, &map);
        let q = tutte_layout(&l, &targets).unwrap();
        assert_annulus_exact(&l, &q, &targets);
        assert_flip_free(&l.mesh, &q);
        let q = tutte_layout(&l, &with_dip(&targets, 20.0, 2.0, 3.0)).unwrap();
        assert_flip_free(&l.mesh, &q);
    }

    #[test]
    fn mitral_layout_tutte_errors() {
        let shape = mitral_valve(&ValveParams {
            annulus_segments: 24,
            depth_segments: 4,
            ..ValveParams::default()
        })
        .unwrap();
        let valve = prepared(&shape);
        let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        let l = &valve.leaflets[ANTERIOR];
        let t = annulus_uv(l, &map);
        let msg = |r: Result<Vec<[f64; 2]>, OrganError>| {
            let e = r.unwrap_err().to_string();
            assert!(!e.contains('\n'), "{e}");
            e
        };
        let m = l.annulus.len();
        msg(tutte_layout(l, &t[1..]));
        assert_eq!(
            layout_err(tutte_layout(l, &t[1..])),
            LayoutError::TargetCount {
                layout: LayoutKind::Tutte,
                targets: m - 1,
                annulus_vertices: m
            }
        );
        msg(tutte_layout(l, &[]));
        let mut bad = t.clone();
        bad[2][0] = f64::NAN;
        msg(tutte_layout(l, &bad));
        assert!(matches!(
            layout_err(tutte_layout(l, &bad)),
            LayoutError::TargetNotFinite {
                layout: LayoutKind::Tutte,
                annulus_index: 2,
                ..
            }
        ));
        let mut bad = t.clone();
        bad[3][0] = bad[2][0];
        assert!(msg(tutte_layout(l, &bad)).contains("increase strictly"));
        assert_eq!(
            layout_err(tutte_layout(l, &bad)),
            LayoutError::UNotIncreasing {
                annulus_index: 3,
                u: bad[2][0],
                previous_u: bad[2][0]
            }
        );
        // Facing the ventricle: the same positions, every triangle
        // clockwise (as its longitude layout).
        let mut r = l.clone();
        for tri in &mut r.mesh.triangles {
            tri.swap(1, 2);
        }
        let q = tutte_layout(&r, &t).unwrap();
        let q0 = tutte_layout(l, &t).unwrap();
        assert_annulus_exact(&r, &q, &t);
        for (a, b) in q.iter().zip(&q0) {
            assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
        }
        assert!(
            r.mesh
                .triangles
                .iter()
                .all(|tri| signed_area(&q, tri) < 0.0)
        );
        let chains = longitudes(&r).unwrap();
        let ql = longitude_layout(&r, &chains, &t).unwrap();
        assert!(
            r.mesh
                .triangles
                .iter()
                .all(|tri| signed_area(&ql, tri) < 0.0)
        );
        // ... also with a dip in the annulus.
        let dip = with_dip(&t, 10.0, 1.0, 6.0);
        let q = tutte_layout(&r, &dip).unwrap();
        assert_annulus_exact(&r, &q, &dip);
        assert!(
            r.mesh
                .triangles
                .iter()
                .all(|tri| signed_area(&q, tri) < 0.0)
        );
        // One triangle reversed.
        let mut r = l.clone();
        r.mesh.triangles[5].swap(1, 2);
        assert!(msg(tutte_layout(&r, &t)).contains("consistently oriented"));
        assert!(matches!(
            layout_err(tutte_layout(&r, &t)),
            LayoutError::InconsistentOrientation { .. }
        ));
        // A hole (two boundary loops): one interior triangle removed.
        let mut r = l.clone();
        let cols = &shape.anterior_longitudes;
        let v = cols[4][2];
        let hole = r
            .mesh
            .triangles
            .iter()
            .position(|tri| tri.contains(&v))
            .unwrap();
        r.mesh.triangles.remove(hole);
        assert!(msg(tutte_layout(&r, &t)).contains("boundary loops"));
        // An unused vertex.
        let mut r = l.clone();
        r.mesh.triangles.retain(|tri| !tri.contains(&v));
        assert!(msg(tutte_layout(&r, &t)).contains("used by no triangle"));
        assert_eq!(
            layout_err(tutte_layout(&r, &t)),
            LayoutError::UnusedVertex { vertex: v as usize }
        );
        // Annulus not a run of the boundary.
        let mut r = l.clone();
        r.annulus.swap(2, 3);
        assert!(msg(tutte_layout(&r, &t)).contains("contiguous run"));
        assert_eq!(
            layout_err(tutte_layout(&r, &t)),
            LayoutError::AnnulusNotABoundaryRun
        );
        // Annulus vertex out of range; a repeated corner.
        let mut r = l.clone();
        r.annulus[1] = 9_999;
        assert_eq!(
            layout_err(tutte_layout(&r, &t)),
            LayoutError::AnnulusVertexOutOfRange {
                vertex: 9_999,
                vertices: r.mesh.positions.len()
            }
        );
        let mut r = l.clone();
        r.mesh.triangles[0][1] = r.mesh.triangles[0][0];
        let corners = r.mesh.triangles[0];
        assert_eq!(
            layout_err(tutte_layout(&r, &t)),
            LayoutError::TriangleRepeatsVertex {
                triangle: 0,
                corners
            }
        );
        // Non-finite positions.
        let mut r = l.clone();
        r.mesh.positions[3].x = f64::INFINITY;
        assert!(tutte_layout(&r, &t).is_err());
    }

    #[test]
    fn mitral_layout_tutte_timing_default_valve() {
        let shape = mitral_valve(&ValveParams::default()).unwrap();
        let valve = prepared(&shape);
        let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
        for k in [ANTERIOR, POSTERIOR] {
            let l = &valve.leaflets[k];
            let targets = annulus_uv(l, &map);
            let t0 = std::time::Instant::now();
            let q = tutte_layout(l, &targets).unwrap();
            let t_layout = t0.elapsed().as_secs_f64();
            let setup = TutteSetup::new(l, &targets).unwrap();
            let t1 = std::time::Instant::now();
            let _ = tutte_homotopy(&setup, &targets).unwrap();
            let t_homotopy = t1.elapsed().as_secs_f64();
            let t2 = std::time::Instant::now();
            let chains = longitudes(l).unwrap();
            let _ = longitude_layout(l, &chains, &targets).unwrap();
            let t_long = t2.elapsed().as_secs_f64();
            eprintln!(
                "leaflet {k}: {} vertices, tutte_layout {:.1} ms, homotopy {:.1} ms, \
                 longitudes + layout {:.2} ms",
                l.mesh.num_vertices(),
                1e3 * t_layout,
                1e3 * t_homotopy,
                1e3 * t_long
            );
            assert_flip_free(&l.mesh, &q);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        #[test]
        fn mitral_layout_longitudes_on_random_valves(
            cd in 24.0..40.0f64,
            ap in 20.0..34.0f64,
            frac in 0.3..0.45f64,
            saddle in 0.0..9.0f64,
            billow in 0.0..1.0f64,
            rows in 2usize..12,
            extra in 0usize..30,
            roll in -180.0..180.0f64,
            pitch in -90.0..90.0f64,
            yaw in -180.0..180.0f64,
            t in prop::array::uniform3(-300.0..300.0f64),
        ) {
            let bp = ap * (1.0 - frac);
            let p = ValveParams {
                commissural_diameter: cd,
                anteroposterior_diameter: ap,
                anterior_fraction: frac,
                saddle_height: saddle,
                coaptation_offset: 0.4 * bp,
                coaptation_depth: 0.5 * saddle + 4.0,
                commissure_gap: (0.3 * bp).min(8.0),
                billow,
                annulus_segments: 6 * rows + extra,
                depth_segments: rows,
                pose: Pose::new([roll, pitch, yaw], t),
                ..ValveParams::default()
            };
            let shape = mitral_valve(&p).unwrap();
            let valve = prepared(&shape);
            let map = parameterize(&valve, AnnulusMode::Landmark).unwrap();
            for k in [ANTERIOR, POSTERIOR] {
                let l = &valve.leaflets[k];
                let chains = longitudes(l);
                prop_assert_eq!(chains.as_ref(), Some(truth(&shape, k)));
                let q = longitude_layout(l, &chains.unwrap(), &annulus_uv(l, &map)).unwrap();
                for t in &l.mesh.triangles {
                    prop_assert!(signed_area(&q, t) > 0.0);
                }
            }
        }

        #[test]
        fn mitral_layout_tutte_random_dips(
            leaflet in 0usize..2,
            c in 0.0..1.0f64,
            width in 0.5..6.0f64,
            amp in -6.0..10.0f64,
            mode in 0usize..3,
        ) {
            let shape = mitral_valve(&ValveParams {
                annulus_segments: 48,
                depth_segments: 8,
                ..ValveParams::default()
            })
            .unwrap();
            let valve = prepared(&shape);
            let map = parameterize(&valve, MODES[mode]).unwrap();
            let l = &valve.leaflets[leaflet];
            let base = annulus_uv(l, &map);
            let targets = with_dip(&base, c * (base.len() - 1) as f64, width, amp);
            let q = tutte_layout(l, &targets).unwrap();
            for (&v, t) in l.annulus.iter().zip(&targets) {
                prop_assert_eq!(q[v as usize], *t);
            }
            for t in &l.mesh.triangles {
                prop_assert!(signed_area(&q, t) > 0.0);
            }
            // The longitude layout of the same targets is flip-free too.
            let chains = longitudes(l).unwrap();
            let q = longitude_layout(l, &chains, &targets).unwrap();
            for t in &l.mesh.triangles {
                prop_assert!(signed_area(&q, t) > 0.0);
            }
        }
    }
}
