//! Boundary parcellation into fetal side, maternal side and margin
//! (ALGORITHMS 2.5).
//!
//! 1. Affinity between boundary vertices `i`, `j` within three edges of each
//!    other (the 3-ring, `i` itself included):
//!    `w_ij = exp(gamma <n_i, n_j> l_ij)`, `gamma = 20`, with `n` the
//!    area-weighted unit vertex normals and `l_ij` the Dijkstra distance
//!    along boundary edges normalized by its maximum over all 3-ring pairs
//!    (the paper's Eq. 5 as its code computes it).
//! 2. The normalized Laplacian `L = I - D^-1/2 W D^-1/2`; its second-smallest
//!    eigenvector (the Fiedler vector) splits the boundary at 0. The smallest
//!    eigenvector `D^1/2 1` (eigenvalue 0) is known and deflated, so a sparse
//!    shift-invert eigensolver ([`unfold_linalg::eigen`]) finds the Fiedler
//!    vector directly.
//! 3. Margin: the vertices with a neighbour in the other cluster, grown to
//!    every boundary vertex within geodesic distance `r` of them. `r` adapts
//!    (as the reference implementation): while the margin splits either side
//!    into more than one connected piece, `r` shrinks in steps of a quarter
//!    voxel; if the margin covers less than 25 % of the boundary area, `r`
//!    grows in quarter-voxel steps (never to a radius that splits a side),
//!    always within `0 < r < 10` voxels.
//! 4. The cluster with more vertices on the convex hull of the boundary is
//!    maternal (the maternal side lies on the convex uterine wall).
//!
//! Only the largest connected piece of the boundary surface (the outer
//! surface) is parcellated; the vertices of any other piece (an internal
//! cavity) stay [`side::INTERIOR`] and carry no template term.
//!
//! # Quality gates
//!
//! A split that cannot be right stops the run with one line naming the fix
//! ([`crate::gate`]); every gate is listed in `report.json`:
//!
//! - `sides.eigensolver`: `|L v - lambda_2 v| / (lambda_3 - lambda_2)`, the
//!   Davis–Kahan bound on the sine of the angle between the computed and
//!   the true Fiedler vector, at most [`MAX_FIEDLER_SINE`]. When it is
//!   not, the pair is solved again with the tolerance scaled to the gap
//!   (the fallback, `sides.eigensolver_resolved`), and a split that is
//!   still unsure is refused.
//! - `sides.area_ratio`: fetal over maternal area of the two clusters, in
//!   [`AREA_RATIO_RANGE`].
//! - `sides.fetal_components`, `sides.maternal_components`: each side,
//!   outside the margin, is one connected piece.

use super::error::PlacentaError;
use super::side;
use crate::gate::Gates;
use crate::{ConfigError, OrganError, Requirement};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use unfold_linalg::Csr;
use unfold_linalg::eigen::{EigenOptions, smallest_eigenpairs};
use unfold_mesh::geodesic::EdgeGraph;
use unfold_mesh::geometry::{convex_hull_vertices, vertex_areas, vertex_normals};
use unfold_mesh::topology::{
    Adjacency, TetBoundary, connected_components, tet_boundary, vertex_adjacency,
};
use unfold_mesh::{TetMesh, TriMesh};

/// The fewest vertices the boundary's largest piece may have.
pub const MIN_BOUNDARY_VERTICES: usize = 8;

/// The margin half-width to start from, in voxels of
/// [`ParcellationConfig::voxel_mm`]: the published 15 mm are five 3 mm
/// voxels, half the largest margin ([`ParcellationConfig::max_margin_voxels`]).
/// The command line and the Python package start from this many voxels of
/// the acquisition's voxel size when no margin is given, so that a 1.5 mm
/// mask starts at 7.5 mm inside its 15 mm limit.
pub const DEFAULT_MARGIN_VOXELS: f64 = 5.0;

/// The largest `sides.eigensolver` value: the sine of the angle between
/// the computed Fiedler vector and the true one (Davis–Kahan:
/// `sin angle <= |L v - lambda v| / gap`). At 0.01 the vector is the true
/// one to 1 % of its norm, so only vertices where it is within 1 % of its
/// RMS of zero (those next to the cut, inside the margin) can change
/// side; a converged solve on the demo and test slabs is near 1e-6.
pub const MAX_FIEDLER_SINE: f64 = 0.01;

/// The range of `sides.area_ratio`, fetal over maternal cluster area. The
/// fetal (chorionic) and maternal (basal) plates of a placenta are the two
/// faces of one disc: for a disc of diameter `D` and thickness `t` each
/// cluster is a face (`pi D^2 / 4`) plus about half the rim (`pi D t / 2`),
/// so the ratio is 1 for any flat disc, and a placenta cupped on the
/// uterine wall (its maternal face the outer one) stays within 1.5 of 1
/// even at a curvature radius of its own diameter. A factor of 4 either
/// way is far outside what a right split gives, and far inside what a
/// split that cut off a bump gives (171 against 49,415 vertices in issue
/// 35).
pub const AREA_RATIO_RANGE: (f64, f64) = (0.25, 4.0);

/// What a user can do when the boundary does not split into two faces.
pub const SPLIT_FIX: &str = "the boundary does not split into one fetal and one maternal face: \
    check that the mask holds one placenta and nothing else (`unfold info MESH`), smooth it \
    (`--smooth-voxels 2`) or mesh it coarser (`unfold mesh MASK --size-mm 3 --grade`, or \
    `placenta --seg MASK` with its default size), or start the margin smaller (`--margin-mm`)";

/// Settings of [`parcellate`]; every default from ALGORITHMS 2.5.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParcellationConfig {
    /// `gamma` of the affinity `exp(gamma <n_i, n_j> l_ij)` (default 20).
    pub gamma: f64,
    /// Ring size of the affinity neighbourhood (default 3).
    pub rings: usize,
    /// Margin half-width `r` to start from, mm (default 15: five 3 mm voxels).
    pub margin_mm: f64,
    /// Voxel size, mm: the unit of the margin's adaptive steps (a quarter
    /// voxel) and of its upper limit (default 3).
    pub voxel_mm: f64,
    /// Whether `r` adapts (default true); `false` keeps `margin_mm`.
    pub adaptive_margin: bool,
    /// Below this fraction of the boundary area the margin grows (default 0.25).
    pub min_margin_area_fraction: f64,
    /// Largest margin radius, in voxels (exclusive; default 10).
    pub max_margin_voxels: f64,
}

impl Default for ParcellationConfig {
    fn default() -> Self {
        ParcellationConfig {
            gamma: 20.0,
            rings: 3,
            margin_mm: 15.0,
            voxel_mm: 3.0,
            adaptive_margin: true,
            min_margin_area_fraction: 0.25,
            max_margin_voxels: 10.0,
        }
    }
}

impl ParcellationConfig {
    /// Checks every value; the error names the offending one.
    ///
    /// # Errors
    /// [`ConfigError`] for the first value out of range: `gamma`,
    /// `voxel_mm` and `max_margin_voxels` finite and `> 0`, `rings` in
    /// `1..=6`, `margin_mm` in `(0, max_margin_voxels * voxel_mm)`,
    /// `min_margin_area_fraction` in `[0, 1)`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        ConfigError::check("parcellation gamma", self.gamma, Requirement::Positive)?;
        ConfigError::check(
            "parcellation rings",
            self.rings as f64,
            Requirement::CountWithin(1, 6),
        )?;
        ConfigError::check(
            "parcellation voxel_mm",
            self.voxel_mm,
            Requirement::Positive,
        )?;
        ConfigError::check(
            "parcellation max_margin_voxels",
            self.max_margin_voxels,
            Requirement::Positive,
        )?;
        let max_mm = self.max_margin_voxels * self.voxel_mm;
        ConfigError::check(
            "parcellation margin_mm",
            self.margin_mm,
            Requirement::Between(0.0, max_mm),
        )?;
        ConfigError::check(
            "parcellation min_margin_area_fraction",
            self.min_margin_area_fraction,
            Requirement::WithinHalfOpen(0.0, 1.0),
        )
    }
}

/// The result of [`parcellate`]: per-vertex labels of the *volume* mesh and
/// what was found on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct Parcellation {
    /// Per vertex of the tet mesh: [`side::INTERIOR`] (0), [`side::FETAL`]
    /// (1), [`side::MATERNAL`] (2) or [`side::MARGIN`] (3).
    pub labels: Vec<u8>,
    /// Per vertex of the tet mesh: the Fiedler vector (0 off the
    /// parcellated boundary), signed so that maternal is positive.
    pub fiedler: Vec<f64>,
    /// The boundary surface of the tet mesh (outward), with its map to the
    /// volume vertices.
    pub boundary: TetBoundary,
    /// What the parcellation found.
    pub summary: ParcellationSummary,
    /// The side split's quality gates (module docs), in the order checked.
    pub gates: Gates,
}

/// Figures of a parcellation, for the report.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParcellationSummary {
    /// Fetal vertices (margin excluded).
    pub fetal: usize,
    /// Maternal vertices (margin excluded).
    pub maternal: usize,
    /// Margin vertices.
    pub margin: usize,
    /// Margin half-width the adaptation started from, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub margin_radius_initial_mm: f64,
    /// Margin half-width used, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub margin_radius_mm: f64,
    /// Fraction of the boundary area in the margin.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub margin_area_fraction: f64,
    /// Whether each side is one connected piece outside the margin.
    pub sides_connected: bool,
    /// Connected pieces of the boundary surface (1 for a solid without
    /// cavities; only the largest is parcellated).
    pub boundary_components: usize,
    /// Vertices of the parcellated boundary piece.
    pub boundary_vertices: usize,
    /// Convex-hull vertices of the cluster chosen as maternal.
    pub hull_maternal: usize,
    /// Convex-hull vertices of the cluster chosen as fetal.
    pub hull_fetal: usize,
    /// The Fiedler eigenvalue (second-smallest of `L`).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub fiedler_value: f64,
    /// Iterations of the eigensolver.
    pub eigen_iterations: usize,
}

/// Parcellates the boundary of a valid tet mesh (see the module docs).
///
/// # Errors
/// `Config` for bad settings; `Mesh` when the boundary cannot be extracted;
/// a parcellation variant of [`PlacentaError`] when the boundary is too
/// small, the eigensolver fails, or a cluster is empty (e.g. a sphere has no
/// two sides).
pub fn parcellate(mesh: &TetMesh, config: &ParcellationConfig) -> Result<Parcellation, OrganError> {
    config.validate()?;
    let boundary = tet_boundary(mesh)?;
    let surface = &boundary.surface;
    let ns = surface.positions.len();
    let comps = connected_components(ns, &surface.triangles);
    if comps.count == 0 {
        return Err(PlacentaError::NoBoundary.into());
    }
    // The largest piece (most triangles) is the outer surface.
    let main = (0..comps.count)
        .max_by_key(|&c| comps.element_counts[c])
        .unwrap_or(0) as u32;
    let piece: Vec<u32> = (0..ns as u32)
        .filter(|&v| comps.vertex_label[v as usize] == main)
        .collect();
    if piece.len() < MIN_BOUNDARY_VERTICES {
        return Err(PlacentaError::BoundaryTooSmall {
            vertices: piece.len(),
            needed: MIN_BOUNDARY_VERTICES,
        }
        .into());
    }
    let mut local = vec![u32::MAX; ns];
    for (k, &v) in piece.iter().enumerate() {
        local[v as usize] = k as u32;
    }
    let sub = TriMesh::new(
        piece
            .iter()
            .map(|&v| surface.positions[v as usize])
            .collect(),
        surface
            .triangles
            .iter()
            .filter(|t| comps.vertex_label[t[0] as usize] == main)
            .map(|t| t.map(|v| local[v as usize]))
            .collect(),
    );

    let n = sub.positions.len();
    let adj = vertex_adjacency(n, &sub.triangles);
    let graph = EdgeGraph::from_tri_mesh(&sub);
    let normals = vertex_normals(&sub);
    let laplacian = normalized_affinity_laplacian(&adj, &graph, &normals, config)?;
    let mut gates = Gates::new();
    let pairs = fiedler_pair(&laplacian, &mut gates)?;
    let mut fiedler = pairs.vectors[0].clone();
    let cluster_a: Vec<bool> = fiedler.iter().map(|&f| f > 0.0).collect();
    let count_a = cluster_a.iter().filter(|&&a| a).count();
    if count_a == 0 || count_a == n {
        return Err(PlacentaError::NoSplit {
            vertices: n,
            positive: count_a,
        }
        .into());
    }

    // Maternal = the cluster with more convex-hull vertices.
    let hull = convex_hull_vertices(&sub.positions);
    let hull_a = (0..n).filter(|&i| hull[i] && cluster_a[i]).count();
    let hull_b = (0..n).filter(|&i| hull[i] && !cluster_a[i]).count();
    let a_is_maternal = hull_a >= hull_b;
    let maternal: Vec<bool> = cluster_a.iter().map(|&a| a == a_is_maternal).collect();
    if !a_is_maternal {
        fiedler.iter_mut().for_each(|f| *f = -*f);
    }
    let (hull_maternal, hull_fetal) = if a_is_maternal {
        (hull_a, hull_b)
    } else {
        (hull_b, hull_a)
    };

    // Margin seeds: vertices with a neighbour in the other cluster.
    let seeds: Vec<u32> = (0..n)
        .filter(|&i| {
            adj.neighbors(i)
                .iter()
                .any(|&j| maternal[j as usize] != maternal[i])
        })
        .map(|i| i as u32)
        .collect();
    let seed_distance = graph.distances(&seeds);
    let areas = vertex_areas(&sub);
    let total_area: f64 = areas.iter().sum();
    let maternal_area: f64 = (0..n).filter(|&i| maternal[i]).map(|i| areas[i]).sum();
    gates.check(
        "sides.area_ratio",
        (total_area - maternal_area) / maternal_area,
        Requirement::Within(AREA_RATIO_RANGE.0, AREA_RATIO_RANGE.1),
        SPLIT_FIX,
    )?;
    let margin = choose_margin(&adj, &maternal, &seed_distance, &areas, total_area, config);

    let mut labels = vec![side::INTERIOR; mesh.num_vertices()];
    let mut fiedler_volume = vec![0.0; mesh.num_vertices()];
    let (mut fetal, mut mat, mut marg) = (0, 0, 0);
    for (k, &sv) in piece.iter().enumerate() {
        let v = boundary.to_volume[sv as usize] as usize;
        fiedler_volume[v] = fiedler[k];
        labels[v] = if seed_distance[k] <= margin.radius {
            marg += 1;
            side::MARGIN
        } else if maternal[k] {
            mat += 1;
            side::MATERNAL
        } else {
            fetal += 1;
            side::FETAL
        };
    }
    if fetal == 0 || mat == 0 {
        return Err(PlacentaError::MarginCoversSide {
            fetal,
            maternal: mat,
        }
        .into());
    }
    for (name, pieces) in [
        ("sides.fetal_components", margin.pieces[0]),
        ("sides.maternal_components", margin.pieces[1]),
    ] {
        gates.check(
            name,
            pieces as f64,
            Requirement::CountWithin(1, 1),
            SPLIT_FIX,
        )?;
    }
    Ok(Parcellation {
        labels,
        fiedler: fiedler_volume,
        summary: ParcellationSummary {
            fetal,
            maternal: mat,
            margin: marg,
            margin_radius_initial_mm: config.margin_mm,
            margin_radius_mm: margin.radius,
            margin_area_fraction: margin.area / total_area,
            sides_connected: margin.connected,
            boundary_components: comps.count,
            boundary_vertices: n,
            hull_maternal,
            hull_fetal,
            fiedler_value: pairs.values[0],
            eigen_iterations: pairs.iterations,
        },
        boundary,
        gates,
    })
}

/// `sides.eigensolver` of a pair solve: the Fiedler pair's residual over
/// the gap to the next eigenvalue (NaN when there is no gap).
fn fiedler_sine(pairs: &unfold_linalg::eigen::Eigenpairs) -> f64 {
    let gap = pairs.values[1] - pairs.values[0];
    if gap > 0.0 {
        pairs.residuals[0] / gap
    } else {
        f64::NAN
    }
}

/// The two smallest eigenpairs of `L` beside its null vector (the
/// Fiedler pair and the next, whose gap bounds the Fiedler vector's
/// error), gated by [`MAX_FIEDLER_SINE`]: when the default tolerance
/// leaves the vector unsure, the pair is solved again with the tolerance
/// at a thousandth of the gap (the fallback), and refused if still unsure,
/// if that tolerance is out of reach (below 1e-13) or the re-solve does
/// not converge.
fn fiedler_pair(
    laplacian: &AffinityLaplacian,
    gates: &mut Gates,
) -> Result<unfold_linalg::eigen::Eigenpairs, OrganError> {
    let deflate = [laplacian.sqrt_degree.clone()];
    let solve = |opts: &EigenOptions| {
        smallest_eigenpairs(&laplacian.l, 2, &deflate, opts).map_err(PlacentaError::Fiedler)
    };
    let pairs = solve(&EigenOptions::default())?;
    let requirement = Requirement::Within(0.0, MAX_FIEDLER_SINE);
    let sine = fiedler_sine(&pairs);
    if gates.fallback(
        "sides.eigensolver",
        sine,
        requirement,
        "solved again with the tolerance at a thousandth of the eigengap",
    ) {
        return Ok(pairs);
    }
    // |L|_est <= 2 for a normalized Laplacian, so the solver's threshold
    // tol * max(1, |L|_est) is at most 2 tol. A gap too small for any
    // reachable tolerance (two equally good splits) is refused as is; so
    // is a re-solve that does not converge.
    let gap = pairs.values[1] - pairs.values[0];
    let tol = 5e-4 * gap;
    let again = if tol.is_finite() && tol >= 1e-13 {
        solve(&EigenOptions {
            tol,
            ..EigenOptions::default()
        })
        .ok()
    } else {
        None
    };
    gates.check(
        "sides.eigensolver_resolved",
        again.as_ref().map_or(sine, fiedler_sine),
        requirement,
        SPLIT_FIX,
    )?;
    Ok(again.unwrap_or(pairs))
}

/// The normalized Laplacian of the affinity and `sqrt(d)` (its null vector).
struct AffinityLaplacian {
    l: Csr,
    sqrt_degree: Vec<f64>,
}

/// Builds `L = I - D^-1/2 W D^-1/2` of the module's affinity `W`.
fn normalized_affinity_laplacian(
    adj: &Adjacency,
    graph: &EdgeGraph,
    normals: &[unfold_mesh::nalgebra::Vector3<f64>],
    config: &ParcellationConfig,
) -> Result<AffinityLaplacian, OrganError> {
    let n = adj.num_vertices();
    // Per vertex: (neighbour j > i within the ring, Dijkstra distance).
    let rings: Vec<Vec<(u32, f64)>> = (0..n)
        .into_par_iter()
        .map_init(LocalDijkstra::default, |dj, i| {
            dj.ring_distances(adj, graph, i as u32, config.rings)
        })
        .collect();
    let l_max = rings
        .iter()
        .flat_map(|r| r.iter().map(|&(_, d)| d))
        .fold(0.0, f64::max);
    if !(l_max.is_finite() && l_max > 0.0) {
        return Err(PlacentaError::NoEdgeLength { longest_mm: l_max }.into());
    }
    // W, upper triangle including the diagonal (w_ii = exp(0) = 1).
    let mut w: Vec<(u32, u32, f64)> =
        Vec::with_capacity(n + rings.iter().map(Vec::len).sum::<usize>());
    let mut degree = vec![0.0; n];
    for (i, ring) in rings.iter().enumerate() {
        w.push((i as u32, i as u32, 1.0));
        degree[i] += 1.0;
        for &(j, d) in ring {
            let value = (config.gamma * normals[i].dot(&normals[j as usize]) * d / l_max).exp();
            w.push((i as u32, j, value));
            degree[i] += value;
            degree[j as usize] += value;
        }
    }
    if let Some(vertex) = degree.iter().position(|d| !d.is_finite()) {
        return Err(PlacentaError::AffinityOverflow { vertex }.into());
    }
    let sqrt_degree: Vec<f64> = degree.iter().map(|d| d.sqrt()).collect();
    let l = Csr::from_symmetric_entries(
        n,
        w.into_iter().map(|(i, j, v)| {
            let s = v / (sqrt_degree[i as usize] * sqrt_degree[j as usize]);
            (i, j, if i == j { 1.0 - s } else { -s })
        }),
    )?;
    Ok(AffinityLaplacian { l, sqrt_degree })
}

/// Dijkstra from one vertex, stopped once every vertex of its `k`-ring is
/// settled (distances along edges, exact).
#[derive(Default)]
struct LocalDijkstra {
    dist: Vec<f64>,
    hops: Vec<u8>,
    touched: Vec<u32>,
    heap: BinaryHeap<Item>,
}

#[derive(PartialEq)]
struct Item(f64, u32);

impl Eq for Item {}

impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Item {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on distance, then index (deterministic).
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

impl LocalDijkstra {
    /// `(j, d(i, j))` for every `j > i` within `k` edges of `i`.
    fn ring_distances(
        &mut self,
        adj: &Adjacency,
        graph: &EdgeGraph,
        i: u32,
        k: usize,
    ) -> Vec<(u32, f64)> {
        let n = adj.num_vertices();
        if self.dist.len() != n {
            self.dist = vec![f64::INFINITY; n];
            self.hops = vec![u8::MAX; n];
        }
        // The k-ring by breadth-first search.
        let mut ring = vec![i];
        self.hops[i as usize] = 0;
        self.touched.push(i);
        let mut start = 0;
        for h in 1..=k as u8 {
            let end = ring.len();
            for r in start..end {
                for &j in adj.neighbors(ring[r] as usize) {
                    if self.hops[j as usize] == u8::MAX {
                        self.hops[j as usize] = h;
                        self.touched.push(j);
                        ring.push(j);
                    }
                }
            }
            start = end;
        }
        let mut remaining = ring.len();
        self.dist[i as usize] = 0.0;
        self.heap.clear();
        self.heap.push(Item(0.0, i));
        let mut out = Vec::with_capacity(ring.len());
        while let Some(Item(d, v)) = self.heap.pop() {
            if d > self.dist[v as usize] {
                continue;
            }
            if self.hops[v as usize] != u8::MAX {
                // A ring vertex settled for the first time (its mark is
                // cleared so that it counts once).
                remaining -= 1;
                if v > i {
                    out.push((v, d));
                }
                self.hops[v as usize] = u8::MAX;
                if remaining == 0 {
                    break;
                }
            }
            let (nbrs, lens) = graph.neighbors(v);
            for (&j, &len) in nbrs.iter().zip(lens) {
                let nd = d + len;
                if nd < self.dist[j as usize] {
                    if self.dist[j as usize].is_infinite() {
                        self.touched.push(j);
                    }
                    self.dist[j as usize] = nd;
                    self.heap.push(Item(nd, j));
                }
            }
        }
        for &v in &self.touched {
            self.dist[v as usize] = f64::INFINITY;
            self.hops[v as usize] = u8::MAX;
        }
        self.touched.clear();
        out.sort_unstable_by_key(|&(j, _)| j);
        out
    }
}

/// The margin chosen by the adaptive rule.
struct Margin {
    radius: f64,
    area: f64,
    connected: bool,
    /// Connected pieces of the fetal and the maternal side outside it.
    pieces: [usize; 2],
}

/// The connected pieces (over boundary edges) of the fetal and the
/// maternal side outside the margin `seed_distance <= r`, and the margin's
/// area.
fn evaluate_margin(
    adj: &Adjacency,
    maternal: &[bool],
    seed_distance: &[f64],
    areas: &[f64],
    r: f64,
) -> ([usize; 2], f64) {
    let n = maternal.len();
    let in_margin = |i: usize| seed_distance[i] <= r;
    let area: f64 = (0..n).filter(|&i| in_margin(i)).map(|i| areas[i]).sum();
    let mut seen = vec![false; n];
    let mut pieces = [0usize; 2];
    let mut stack = Vec::new();
    for s in 0..n {
        if seen[s] || in_margin(s) {
            continue;
        }
        pieces[usize::from(maternal[s])] += 1;
        seen[s] = true;
        stack.push(s);
        while let Some(v) = stack.pop() {
            for &j in adj.neighbors(v) {
                let j = j as usize;
                if !seen[j] && !in_margin(j) && maternal[j] == maternal[s] {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
    }
    (pieces, area)
}

/// The adaptive margin radius (module docs, step 3).
fn choose_margin(
    adj: &Adjacency,
    maternal: &[bool],
    seed_distance: &[f64],
    areas: &[f64],
    total_area: f64,
    config: &ParcellationConfig,
) -> Margin {
    let eval = |radius: f64| {
        let (pieces, area) = evaluate_margin(adj, maternal, seed_distance, areas, radius);
        Margin {
            radius,
            area,
            connected: pieces[0] <= 1 && pieces[1] <= 1,
            pieces,
        }
    };
    let r0 = config.margin_mm;
    let first = eval(r0);
    if !config.adaptive_margin {
        return first;
    }
    let step = 0.25 * config.voxel_mm;
    let r_max = config.max_margin_voxels * config.voxel_mm;
    if !first.connected {
        // Shrink while a side is split.
        let mut r = r0 - step;
        while r > 0.0 {
            let m = eval(r);
            if m.connected {
                return m;
            }
            r -= step;
        }
        return first;
    }
    // Grow while the margin is too small and growing splits no side.
    let mut best = first;
    let mut r = r0;
    while best.area < config.min_margin_area_fraction * total_area && r + step < r_max {
        r += step;
        let m = eval(r);
        if !m.connected {
            break;
        }
        best = m;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::shapes::{PlacentaParams, placenta_slab};

    fn slab(cells_radial: usize) -> TetMesh {
        placenta_slab(&PlacentaParams {
            cells_radial,
            ..PlacentaParams::default()
        })
        .unwrap()
        .mesh
    }

    #[test]
    fn ring_distances_equal_full_dijkstra_within_the_ring() {
        let b = tet_boundary(&slab(5)).unwrap();
        let n = b.surface.positions.len();
        let adj = vertex_adjacency(n, &b.surface.triangles);
        let graph = EdgeGraph::from_tri_mesh(&b.surface);
        let mut dj = LocalDijkstra::default();
        for i in [0u32, 7, 40, (n - 1) as u32] {
            let full = graph.distances(&[i]);
            let ring: Vec<u32> = unfold_mesh::topology::k_ring(&adj, i, 3);
            let got = dj.ring_distances(&adj, &graph, i, 3);
            let want: Vec<u32> = ring.iter().copied().filter(|&j| j > i).collect();
            let mut want_sorted = want.clone();
            want_sorted.sort_unstable();
            assert_eq!(got.iter().map(|&(j, _)| j).collect::<Vec<_>>(), want_sorted);
            for (j, d) in got {
                assert!((d - full[j as usize]).abs() < 1e-12);
            }
        }
    }

    /// A path of 20 vertices, `0..10` fetal, `10..20` maternal, unit areas.
    fn path() -> (Adjacency, Vec<bool>, Vec<f64>) {
        let n = 20usize;
        let mut offsets = vec![0usize];
        let mut neighbors = Vec::new();
        for i in 0..n {
            if i > 0 {
                neighbors.push(i as u32 - 1);
            }
            if i + 1 < n {
                neighbors.push(i as u32 + 1);
            }
            offsets.push(neighbors.len());
        }
        let adj = Adjacency { offsets, neighbors };
        let maternal = (0..n).map(|i| i >= 10).collect();
        (adj, maternal, vec![1.0; n])
    }

    #[test]
    fn the_margin_shrinks_while_it_splits_a_side() {
        let (adj, maternal, areas) = path();
        // Vertex 5 (inside the fetal half) is close to a seed; its
        // neighbours are not, so any r >= 1 cuts the fetal side in two.
        let mut d: Vec<f64> = (0..20)
            .map(|i: i32| 10.0 * f64::from((i - 10).abs()))
            .collect();
        d[9] = 0.0;
        d[10] = 0.0;
        d[5] = 1.0;
        let config = ParcellationConfig {
            margin_mm: 3.0,
            voxel_mm: 1.0,
            ..ParcellationConfig::default()
        };
        let m = choose_margin(&adj, &maternal, &d, &areas, 20.0, &config);
        assert!(m.connected);
        assert!(m.radius < 1.0 && m.radius > 0.0, "{}", m.radius);
        assert_eq!(m.radius, 0.75);
        // Without adaptation the split stays and is reported.
        let fixed = ParcellationConfig {
            adaptive_margin: false,
            ..config
        };
        let m = choose_margin(&adj, &maternal, &d, &areas, 20.0, &fixed);
        assert!(!m.connected && m.radius == 3.0);
    }

    #[test]
    fn the_margin_grows_to_a_quarter_of_the_area() {
        let (adj, maternal, areas) = path();
        // Distance to the cut between 9 and 10: |i - 9.5| - 0.5 mm.
        let d: Vec<f64> = (0..20).map(|i| (f64::from(i) - 9.5).abs() - 0.5).collect();
        let config = ParcellationConfig {
            margin_mm: 0.5,
            voxel_mm: 1.0,
            ..ParcellationConfig::default()
        };
        let m = choose_margin(&adj, &maternal, &d, &areas, 20.0, &config);
        // 25 % of 20 vertices = 5: r = 2 gives 6 vertices (d = 0, 1, 2).
        assert!(m.area >= 5.0, "{}", m.area);
        assert_eq!(m.radius, 2.0);
        assert!(m.connected);
        // The upper limit (10 voxels, exclusive) stops the growth.
        let capped = ParcellationConfig {
            max_margin_voxels: 1.2,
            ..config
        };
        let m = choose_margin(&adj, &maternal, &d, &areas, 20.0, &capped);
        assert_eq!(m.radius, 1.0);
    }

    #[test]
    fn bad_settings_name_the_value() {
        for (c, needle) in [
            (
                ParcellationConfig {
                    gamma: 0.0,
                    ..Default::default()
                },
                "gamma",
            ),
            (
                ParcellationConfig {
                    rings: 0,
                    ..Default::default()
                },
                "rings",
            ),
            (
                ParcellationConfig {
                    margin_mm: 30.0,
                    ..Default::default()
                },
                "margin_mm",
            ),
            (
                ParcellationConfig {
                    voxel_mm: f64::NAN,
                    ..Default::default()
                },
                "voxel_mm",
            ),
            (
                ParcellationConfig {
                    min_margin_area_fraction: 1.0,
                    ..Default::default()
                },
                "min_margin_area_fraction",
            ),
        ] {
            let e = c.validate().unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(6))]
        /// Every gate of a slab's split passes, whatever its outline's
        /// aspect, its thickness and its bend: its two faces have alike
        /// areas and the Fiedler vector is sure.
        #[test]
        fn a_slab_of_any_aspect_passes_the_split_gates(
            width in 60.0f64..180.0,
            thickness in 10.0f64..40.0,
            bend in proptest::prop_oneof![proptest::strategy::Just(0.0), 150.0f64..400.0],
        ) {
            let mesh = placenta_slab(&PlacentaParams {
                width,
                thickness_centre: thickness,
                thickness_rim: thickness / 3.0,
                bend_radius: bend,
                cells_radial: 5,
                cells_through: 2,
                ..PlacentaParams::default()
            })
            .unwrap()
            .mesh;
            let p = parcellate(&mesh, &ParcellationConfig::default()).unwrap();
            proptest::prop_assert!(p.gates.all_passed(), "{:?}", p.gates);
            let ratio = p.gates.get("sides.area_ratio").unwrap().value;
            proptest::prop_assert!((0.5..2.0).contains(&ratio), "{}", ratio);
            proptest::prop_assert!(p.gates.get("sides.eigensolver").unwrap().value < 1e-4);
        }
    }

    /// The normalized Laplacian of a cycle of `n` vertices (unit weights):
    /// its eigenvalues `1 - cos(2 pi k / n)` come in equal pairs, so no
    /// Fiedler vector is the one.
    fn cycle(n: usize) -> AffinityLaplacian {
        let entries = (0..n as u32).flat_map(|i| {
            let j = (i + 1) % n as u32;
            [(i, i, 1.0), (i.min(j), i.max(j), -0.5)]
        });
        AffinityLaplacian {
            l: Csr::from_symmetric_entries(n, entries).unwrap(),
            sqrt_degree: vec![2f64.sqrt(); n],
        }
    }

    #[test]
    fn a_boundary_with_two_equally_good_splits_is_refused_after_the_fallback() {
        let mut gates = Gates::new();
        let e = fiedler_pair(&cycle(40), &mut gates).unwrap_err();
        assert!(
            e.to_string()
                .contains("quality gate sides.eigensolver_resolved"),
            "{e}"
        );
        let first = gates.get("sides.eigensolver").unwrap();
        assert!(!first.passed && first.fallback.is_some(), "{first:?}");
    }

    #[test]
    fn the_fiedler_vector_is_positive_on_the_maternal_side() {
        let p = parcellate(&slab(8), &ParcellationConfig::default()).unwrap();
        for (l, f) in p.labels.iter().zip(&p.fiedler) {
            match *l {
                side::MATERNAL => assert!(*f > 0.0),
                side::FETAL => assert!(*f <= 0.0),
                _ => {}
            }
        }
        let s = p.summary;
        assert!(s.hull_maternal > s.hull_fetal);
        assert_eq!(s.boundary_components, 1);
        assert!(s.fiedler_value >= 0.0 && s.fiedler_value < 1e-2);
        assert!(s.margin_area_fraction >= 0.25 - 1e-12);
    }
}
