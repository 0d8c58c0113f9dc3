//! Geodesic distances along mesh edges (Dijkstra).
//!
//! [`EdgeGraph`] stores the mesh's edge graph as a petgraph
//! [`Csr`] (undirected, `u32` indices, edge weight = the
//! Euclidean edge length `|p_a - p_b|`). The shortest-path searches run
//! Dijkstra directly on the CSR slices
//! ([`Csr::neighbors_slice`](petgraph::csr::Csr::neighbors_slice) /
//! [`Csr::edges_slice`](petgraph::csr::Csr::edges_slice)) with an indexed
//! 4-ary heap, writing into a dense `Vec<f64>` and reusing the heap across
//! the sources of [`EdgeGraph::all_pairs`]. petgraph's own
//! [`petgraph::algo::dijkstra()`] returns a `HashMap` of scores (one hash per
//! relaxation, one map per source, then a copy into a vector): on the
//! 3,000-vertex sphere of `benches/geodesic.rs` it measured about 1.5× the
//! time per source (≈380 µs vs ≈250 µs of CPU time), and it has no
//! multi-source variant. [`EdgeGraph::distances_petgraph`] keeps it
//! available as a reference; the tests check that both agree.
//!
//! Edge-graph distances over-estimate the geodesic distance on the
//! triangulated surface (paths are restricted to edges and zig-zag across
//! the triangles), typically by a few percent on regular meshes.

use crate::{TetMesh, TriMesh, topology::vertex_adjacency};
use nalgebra::Point3;
use petgraph::{Undirected, csr::Csr};
use rayon::prelude::*;

/// The edge graph of a mesh with Euclidean edge lengths as weights, see the
/// [module documentation](self).
#[derive(Debug, Clone)]
pub struct EdgeGraph {
    graph: Csr<(), f64, Undirected, u32>,
    num_edges: usize,
}

impl EdgeGraph {
    /// The edge graph of a simplex mesh with `K` corners per element (every
    /// pair of corners of an element is an edge). Edge `(a, b)` weighs
    /// `|positions[a] - positions[b]|`. Vertices used by no element are
    /// isolated (unreachable from everything else).
    ///
    /// # Panics
    /// If an element refers to a vertex `>= positions.len()`.
    pub fn new<const K: usize>(positions: &[Point3<f64>], elements: &[[u32; K]]) -> Self {
        let n = positions.len();
        let adj = vertex_adjacency(n, elements);
        let mut arcs = Vec::with_capacity(adj.neighbors.len());
        for a in 0..n {
            for &b in adj.neighbors(a) {
                arcs.push((a as u32, b, (positions[a] - positions[b as usize]).norm()));
            }
        }
        let mut graph = Csr::from_sorted_edges(&arcs)
            .expect("vertex_adjacency yields sorted, unique neighbour lists");
        // `from_sorted_edges` stops at the largest vertex with an edge.
        while graph.node_count() < n {
            graph.add_node(());
        }
        EdgeGraph {
            graph,
            num_edges: arcs.len() / 2,
        }
    }

    /// The edge graph of a triangle mesh (see [`EdgeGraph::new`]).
    pub fn from_tri_mesh(mesh: &TriMesh) -> Self {
        EdgeGraph::new(&mesh.positions, &mesh.triangles)
    }

    /// The edge graph of a tet mesh, interior edges included (see
    /// [`EdgeGraph::new`]).
    pub fn from_tet_mesh(mesh: &TetMesh) -> Self {
        EdgeGraph::new(&mesh.positions, &mesh.tets)
    }

    /// Number of vertices (graph nodes).
    pub fn num_vertices(&self) -> usize {
        self.graph.node_count()
    }

    /// Number of undirected edges.
    pub fn num_edges(&self) -> usize {
        self.num_edges
    }

    /// The neighbours of `v` (sorted) and the lengths of the edges to them.
    pub fn neighbors(&self, v: u32) -> (&[u32], &[f64]) {
        (self.graph.neighbors_slice(v), self.graph.edges_slice(v))
    }

    /// The underlying petgraph graph (undirected CSR, weights = lengths),
    /// for use with other `petgraph::algo` functions.
    pub fn graph(&self) -> &Csr<(), f64, Undirected, u32> {
        &self.graph
    }

    /// Multi-source shortest edge-path distances: `d[v] = min over sources s
    /// of (length of the shortest edge path s -> v)`, with `d[s] = 0` for
    /// every source and `f64::INFINITY` where no source reaches `v`. A single
    /// source is a one-element slice; no sources gives all infinity.
    ///
    /// Dijkstra with an indexed 4-ary heap (decrease-key),
    /// `O((V + E) log V)`.
    ///
    /// # Panics
    /// If a source is `>= num_vertices()`.
    pub fn distances(&self, sources: &[u32]) -> Vec<f64> {
        let mut dist = vec![f64::INFINITY; self.num_vertices()];
        self.dijkstra_into(sources, &mut dist, &mut IndexedHeap::default());
        dist
    }

    /// Single-source distances computed with [`petgraph::algo::dijkstra()`]
    /// (a reference for [`EdgeGraph::distances`], which is faster; same
    /// result up to rounding), `f64::INFINITY` where unreachable.
    ///
    /// # Panics
    /// If `source >= num_vertices()`.
    pub fn distances_petgraph(&self, source: u32) -> Vec<f64> {
        assert!(
            (source as usize) < self.num_vertices(),
            "source {source} out of range"
        );
        let scores = petgraph::algo::dijkstra(&self.graph, source, None, |e| *e.weight());
        let mut dist = vec![f64::INFINITY; self.num_vertices()];
        for (v, d) in scores {
            dist[v as usize] = d;
        }
        dist
    }

    /// All-pairs distances as a row-major `n × n` matrix: entry `i * n + j`
    /// is the shortest edge-path length between `i` and `j`
    /// (`f64::INFINITY` across components, 0 on the diagonal). One Dijkstra
    /// per source, in parallel over sources (rayon), each writing straight
    /// into its row. The result is made exactly symmetric by taking
    /// `min(d_ij, d_ji)` (the two can differ in the last bit because the
    /// path lengths are summed in opposite orders).
    ///
    /// Memory: `8 n²` bytes (72 MB for 3,000 vertices).
    pub fn all_pairs(&self) -> Vec<f64> {
        let n = self.num_vertices();
        if n == 0 {
            return Vec::new();
        }
        let mut out = vec![f64::INFINITY; n * n];
        out.par_chunks_mut(n)
            .enumerate()
            .for_each_init(IndexedHeap::default, |heap, (s, row)| {
                self.dijkstra_into(&[s as u32], row, heap);
            });
        // Symmetrize in square tiles to stay cache-friendly.
        const TILE: usize = 64;
        for bi in (0..n).step_by(TILE) {
            for bj in (bi..n).step_by(TILE) {
                for i in bi..(bi + TILE).min(n) {
                    for j in bj.max(i + 1)..(bj + TILE).min(n) {
                        let m = out[i * n + j].min(out[j * n + i]);
                        out[i * n + j] = m;
                        out[j * n + i] = m;
                    }
                }
            }
        }
        out
    }

    /// Dijkstra from `sources` into `dist` (overwritten; `dist.len()` must
    /// be `num_vertices()`), reusing the scratch `heap`.
    fn dijkstra_into(&self, sources: &[u32], dist: &mut [f64], heap: &mut IndexedHeap) {
        let n = self.num_vertices();
        assert_eq!(dist.len(), n);
        dist.fill(f64::INFINITY);
        heap.reset(n);
        for &s in sources {
            assert!((s as usize) < n, "source {s} out of range ({n} vertices)");
            if dist[s as usize] > 0.0 {
                dist[s as usize] = 0.0;
                heap.push_or_decrease(s, 0.0);
            }
        }
        while let Some((d, v)) = heap.pop() {
            let (nbrs, lens) = self.neighbors(v);
            for (&w, &len) in nbrs.iter().zip(lens) {
                let nd = d + len;
                if nd < dist[w as usize] {
                    dist[w as usize] = nd;
                    heap.push_or_decrease(w, nd);
                }
            }
        }
    }
}

/// An indexed 4-ary min-heap of `(key, vertex)` with decrease-key: every
/// vertex is in the heap at most once, so a search does at most `V` pops
/// (a lazy-deletion `BinaryHeap` pops up to `E` stale entries), and the
/// 4-ary layout halves the tree depth. Reused across searches.
#[derive(Debug, Default)]
struct IndexedHeap {
    /// The heap array.
    items: Vec<(f64, u32)>,
    /// Position of each vertex in `items`, `NONE` when not in the heap.
    pos: Vec<u32>,
}

const NONE: u32 = u32::MAX;

impl IndexedHeap {
    fn reset(&mut self, n: usize) {
        for &(_, v) in &self.items {
            self.pos[v as usize] = NONE;
        }
        self.items.clear();
        if self.pos.len() != n {
            self.pos.clear();
            self.pos.resize(n, NONE);
        }
    }

    /// Inserts `v` with `key`, or lowers its key if it is in the heap.
    #[inline]
    fn push_or_decrease(&mut self, v: u32, key: f64) {
        let i = match self.pos[v as usize] {
            NONE => {
                self.items.push((key, v));
                self.items.len() - 1
            }
            p => {
                self.items[p as usize].0 = key;
                p as usize
            }
        };
        self.sift_up(i);
    }

    #[inline]
    fn pop(&mut self) -> Option<(f64, u32)> {
        let top = *self.items.first()?;
        self.pos[top.1 as usize] = NONE;
        let last = self.items.pop().expect("non-empty");
        if !self.items.is_empty() {
            self.items[0] = last;
            self.sift_down(0);
        }
        Some(top)
    }

    #[inline]
    fn sift_up(&mut self, mut i: usize) {
        let item = self.items[i];
        while i > 0 {
            let parent = (i - 1) / 4;
            let p = self.items[parent];
            if p.0 <= item.0 {
                break;
            }
            self.items[i] = p;
            self.pos[p.1 as usize] = i as u32;
            i = parent;
        }
        self.items[i] = item;
        self.pos[item.1 as usize] = i as u32;
    }

    #[inline]
    fn sift_down(&mut self, mut i: usize) {
        let item = self.items[i];
        let len = self.items.len();
        loop {
            let first = 4 * i + 1;
            if first >= len {
                break;
            }
            let mut best = first;
            for c in first + 1..(first + 4).min(len) {
                if self.items[c].0 < self.items[best].0 {
                    best = c;
                }
            }
            let b = self.items[best];
            if item.0 <= b.0 {
                break;
            }
            self.items[i] = b;
            self.pos[b.1 as usize] = i as u32;
            i = best;
        }
        self.items[i] = item;
        self.pos[item.1 as usize] = i as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::*;
    use crate::topology::edges;
    use proptest::prelude::*;

    /// Floyd–Warshall over the mesh edges with Euclidean weights.
    fn floyd_warshall<const K: usize>(
        positions: &[Point3<f64>],
        elements: &[[u32; K]],
    ) -> Vec<f64> {
        let n = positions.len();
        let mut d = vec![f64::INFINITY; n * n];
        for i in 0..n {
            d[i * n + i] = 0.0;
        }
        for [a, b] in edges(elements) {
            let (a, b) = (a as usize, b as usize);
            let w = (positions[a] - positions[b]).norm();
            d[a * n + b] = w;
            d[b * n + a] = w;
        }
        for k in 0..n {
            for i in 0..n {
                for j in 0..n {
                    let via = d[i * n + k] + d[k * n + j];
                    if via < d[i * n + j] {
                        d[i * n + j] = via;
                    }
                }
            }
        }
        d
    }

    fn close(a: f64, b: f64) -> bool {
        (a.is_infinite() && b.is_infinite() && a == b) || (a - b).abs() <= 1e-9 * (1.0 + a.abs())
    }

    fn random_mesh(seed: u64, n: usize, ntri: usize) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let mut rng = SplitMix(seed);
        let positions = (0..n)
            .map(|_| Point3::new(rng.sym(3.0), rng.sym(3.0), rng.sym(3.0)))
            .collect();
        let tris = (0..ntri)
            .map(|_| {
                let a = rng.below(n);
                let b = (a + 1 + rng.below(n - 1)) % n;
                let mut c = rng.below(n);
                while c == a || c == b {
                    c = rng.below(n);
                }
                [a as u32, b as u32, c as u32]
            })
            .collect();
        (positions, tris)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn dijkstra_matches_floyd_warshall(seed: u64, n in 3usize..16, ntri in 0usize..14) {
            let (positions, tris) = random_mesh(seed, n, ntri);
            let g = EdgeGraph::new(&positions, &tris);
            prop_assert_eq!(g.num_vertices(), n);
            prop_assert_eq!(g.num_edges(), edges(&tris).len());
            let fw = floyd_warshall(&positions, &tris);
            let ap = g.all_pairs();
            prop_assert_eq!(ap.len(), n * n);
            for s in 0..n {
                let d = g.distances(&[s as u32]);
                let dp = g.distances_petgraph(s as u32);
                for v in 0..n {
                    prop_assert!(close(d[v], fw[s * n + v]), "{} -> {}: {} vs {}", s, v, d[v], fw[s * n + v]);
                    prop_assert!(close(dp[v], d[v]));
                    prop_assert!(close(ap[s * n + v], d[v]));
                }
            }
            // Exactly symmetric, zero diagonal, triangle inequality.
            for i in 0..n {
                prop_assert_eq!(ap[i * n + i], 0.0);
                for j in 0..n {
                    prop_assert_eq!(ap[i * n + j], ap[j * n + i]);
                    for k in 0..n {
                        prop_assert!(ap[i * n + k] <= ap[i * n + j] + ap[j * n + k] + 1e-9);
                    }
                }
            }
        }

        #[test]
        fn multi_source_is_min_of_single_sources(
            seed: u64, n in 3usize..30, ntri in 0usize..30, nsrc in 0usize..5,
        ) {
            let (positions, tris) = random_mesh(seed, n, ntri);
            let g = EdgeGraph::new(&positions, &tris);
            let mut rng = SplitMix(seed ^ 0xABCD);
            let sources: Vec<u32> = (0..nsrc).map(|_| rng.below(n) as u32).collect();
            let multi = g.distances(&sources);
            let singles: Vec<Vec<f64>> = sources.iter().map(|&s| g.distances(&[s])).collect();
            for (v, &got) in multi.iter().enumerate() {
                let m = singles.iter().map(|d| d[v]).fold(f64::INFINITY, f64::min);
                prop_assert!(close(got, m), "{} vs {}", got, m);
            }
            for &s in &sources {
                prop_assert_eq!(multi[s as usize], 0.0);
            }
        }
    }

    #[test]
    fn unreachable_and_isolated_vertices_are_infinite() {
        let positions: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new(i as f64, (i * i) as f64, 0.0))
            .collect();
        let g = EdgeGraph::new(&positions, &[[0u32, 1, 2], [4, 5, 6]]);
        assert_eq!(g.num_vertices(), 8);
        let d = g.distances(&[0]);
        assert_eq!(d[0], 0.0);
        assert!((d[1] - 2f64.sqrt()).abs() < 1e-12);
        assert!(d[3].is_infinite() && d[4].is_infinite() && d[7].is_infinite());
        assert_eq!(g.distances(&[7])[7], 0.0);
        assert!(g.distances(&[]).iter().all(|x| x.is_infinite()));
        assert!(g.distances_petgraph(0)[5].is_infinite());
        let ap = g.all_pairs();
        assert!(ap[3 * 8 + 7].is_infinite());
        assert_eq!(ap[7 * 8 + 7], 0.0);
        assert!(EdgeGraph::new::<3>(&[], &[]).all_pairs().is_empty());
    }

    #[test]
    fn sphere_pole_to_pole_is_close_to_half_circumference() {
        let r = 2.0;
        let m = uv_sphere(40, 48, r);
        let g = EdgeGraph::from_tri_mesh(&m);
        let d = g.distances(&[0]);
        let south = m.num_vertices() - 1;
        let exact = std::f64::consts::PI * r;
        // Meridian edges are chords: slightly shorter than the arc, and the
        // edge path can only follow meridians here.
        assert!(
            d[south] <= exact && d[south] > 0.999 * exact,
            "{}",
            d[south]
        );
    }

    #[test]
    fn tet_mesh_graph_includes_interior_edges() {
        let m = tet_grid([2, 2, 2], false, [0.0; 3]);
        let g = EdgeGraph::from_tet_mesh(&m);
        assert_eq!(g.num_edges(), edges(&m.tets).len());
        // The Kuhn split has the cube diagonal (0,0,0)-(1,1,1) as an edge.
        let d = g.distances(&[0]);
        let far = m.num_vertices() - 1; // (2, 2, 2)
        assert!((d[far] - 2.0 * 3f64.sqrt()).abs() < 1e-12);
        let (nb, w) = g.neighbors(0);
        assert_eq!(nb.len(), w.len());
        assert_eq!(g.graph().node_count(), m.num_vertices());
    }
}
