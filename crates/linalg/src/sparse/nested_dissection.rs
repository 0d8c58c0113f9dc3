//! A nested-dissection ordering of a graph (George 1973), for the Cholesky
//! factors of mesh matrices (docs/DESIGN-NOTES.md, "Newton's linear
//! algebra").
//!
//! A vertex separator `S` splits a connected graph into parts `A` and `B`
//! with no edge between them; ordering `A`, then `B`, then `S` confines the
//! fill of the Cholesky factor to `A`, `B` and the dense block of `S`, and
//! the two parts are ordered the same way, recursively. Below
//! [`LEAF_VERTICES`] vertices a part is ordered by AMD.
//!
//! Separators come from the graph alone, by distances (no coordinates):
//! with `r` a pseudo-peripheral vertex and `r'` the vertex farthest from it
//! (the ends of a long path through the part), the keys
//!
//! ```text
//! k1(v) = d(r, v)                 (the level structure rooted at r)
//! k2(v) = d(r, v) - d(r', v)      (level sets near the bisector of r and r')
//! ```
//!
//! each cut at a threshold `t` (`A0 = {k <= t}`, `B0 = {k > t}`) give a
//! separator: the vertices of `B0` with a neighbour in `A0`. It is then
//! thinned (a separator vertex without a neighbour in `B` joins `A`, and
//! the other way round), and the cut with the least ratio
//! `|S| / (|A| |B|)` over a few thresholds around the median of each key
//! wins. On a mesh, the level sets of `k1` are spheres around `r` and
//! those of `k2` are nearly planes across the part's long axis, which is
//! what a coordinate bisection would cut.

use crate::LinalgError;
use faer::dyn_stack::MemStack;
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::amd;
use std::collections::VecDeque;
use std::mem::MaybeUninit;

/// Parts of at most this many vertices are ordered by AMD instead of being
/// dissected further.
pub const LEAF_VERTICES: usize = 96;

/// Thresholds tried on each side of a key's median.
const THRESHOLDS_AROUND_MEDIAN: i64 = 3;

/// At most this many searches for a pseudo-peripheral vertex (each
/// restarts from the far end of the last while the eccentricity grows).
const PERIPHERAL_ROUNDS: usize = 6;

/// Marks "not reached" in the distance arrays.
const UNSEEN: i32 = i32::MIN;

/// A symmetric graph in compressed rows: the neighbours of `v` are
/// `adj[ptr[v] .. ptr[v + 1]]` (no self loops; each edge listed from both
/// ends).
#[derive(Debug, Clone)]
pub struct Graph {
    ptr: Vec<usize>,
    adj: Vec<u32>,
}

impl Graph {
    /// The graph of the off-diagonal entries of a symmetric pattern given as
    /// its upper triangle in compressed columns (column `c` holds the rows
    /// `row_idx[col_ptr[c] .. col_ptr[c + 1]]`, all `<= c`; the diagonal is
    /// ignored).
    ///
    /// # Errors
    /// [`LinalgError::DimensionMismatch`] for a pointer array of the wrong
    /// length; [`LinalgError::IndexOutOfRange`] for a row `>= n`.
    pub fn from_upper(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Result<Self, LinalgError> {
        if col_ptr.len() != n + 1 || col_ptr[n] > row_idx.len() {
            return Err(LinalgError::DimensionMismatch {
                what: "graph: column pointers (columns + 1)",
                expected: n + 1,
                found: col_ptr.len(),
            });
        }
        if n > u32::MAX as usize {
            return Err(LinalgError::TooLarge { rows: n, cols: n });
        }
        let mut degree = vec![0usize; n + 1];
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                if r >= n {
                    return Err(LinalgError::IndexOutOfRange {
                        what: "graph row",
                        index: r,
                        len: n,
                    });
                }
                if r != c {
                    degree[r + 1] += 1;
                    degree[c + 1] += 1;
                }
            }
        }
        for v in 0..n {
            degree[v + 1] += degree[v];
        }
        let ptr = degree;
        let mut next = ptr.clone();
        let mut adj = vec![0u32; ptr[n]];
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                if r != c {
                    adj[next[r]] = c as u32;
                    next[r] += 1;
                    adj[next[c]] = r as u32;
                    next[c] += 1;
                }
            }
        }
        Ok(Graph { ptr, adj })
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.ptr.len() - 1
    }

    /// Whether the graph has no vertex.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The neighbours of `v`.
    pub fn neighbours(&self, v: usize) -> &[u32] {
        &self.adj[self.ptr[v]..self.ptr[v + 1]]
    }
}

/// The nested-dissection ordering of `graph` (see the module docs):
/// `fwd[k]` is the vertex eliminated `k`-th.
///
/// # Errors
/// [`LinalgError::Faer`] when faer's AMD fails on a leaf.
pub fn nested_dissection(graph: &Graph) -> Result<Vec<usize>, LinalgError> {
    let n = graph.len();
    let mut nd = Dissection {
        graph,
        member: vec![0; n],
        stamp: 0,
        d1: vec![UNSEEN; n],
        d2: vec![UNSEEN; n],
        side: vec![Side::A; n],
        queue: VecDeque::new(),
        fwd: vec![0; n],
    };
    // Parts still to order: their vertices and their first position.
    let mut work: Vec<(Vec<u32>, usize)> = vec![((0..n as u32).collect(), 0)];
    while let Some((part, start)) = work.pop() {
        nd.split(part, start, &mut work)?;
    }
    Ok(nd.fwd)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    A,
    B,
    Separator,
}

/// The state of one dissection: membership stamps, two distance arrays
/// (reset after each use, so each costs the part's size), the sides of the
/// current cut and the ordering being filled.
struct Dissection<'g> {
    graph: &'g Graph,
    /// `member[v] == stamp`: `v` belongs to the part being split.
    member: Vec<u32>,
    stamp: u32,
    d1: Vec<i32>,
    d2: Vec<i32>,
    side: Vec<Side>,
    queue: VecDeque<u32>,
    fwd: Vec<usize>,
}

/// A cut of a part: the sizes of its sides and its key and threshold.
#[derive(Debug, Clone, Copy)]
struct Cut {
    key: Key,
    threshold: i64,
    a: usize,
    b: usize,
    separator: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Key {
    Level,
    Bisector,
}

impl Cut {
    /// `|S| / (|A| |B|)`: small separators, balanced parts.
    fn ratio(&self) -> f64 {
        if self.a == 0 || self.b == 0 {
            f64::INFINITY
        } else {
            self.separator as f64 / (self.a as f64 * self.b as f64)
        }
    }
}

impl Dissection<'_> {
    /// Orders `part` into `fwd[start ..]`: a leaf by AMD, several components
    /// each on its own, a connected part by a separator (placed last) and
    /// its two sides (pushed onto `work`).
    fn split(
        &mut self,
        part: Vec<u32>,
        start: usize,
        work: &mut Vec<(Vec<u32>, usize)>,
    ) -> Result<(), LinalgError> {
        if part.len() <= LEAF_VERTICES {
            return self.leaf(&part, start);
        }
        self.enter(&part);
        let reached = self.bfs(part[0], true);
        if reached.len() < part.len() {
            self.clear(&reached, true);
            return self.components(&part, start, work);
        }
        self.clear(&reached, true);
        // A pseudo-peripheral vertex r (George and Liu's iteration) and the
        // farthest vertex r' from it.
        let mut root = part[0];
        let mut eccentricity = -1;
        for _ in 0..PERIPHERAL_ROUNDS {
            let order = self.bfs(root, true);
            let last = *order.last().unwrap_or(&root);
            let ecc = self.d1[last as usize];
            let far = self.farthest_min_degree(&order, ecc);
            self.clear(&order, true);
            if ecc <= eccentricity {
                break;
            }
            eccentricity = ecc;
            root = far;
        }
        // d1 from the root, d2 from the far end.
        let order = self.bfs(root, true);
        let last = *order.last().unwrap_or(&root);
        let far = self.farthest_min_degree(&order, self.d1[last as usize]);
        let _ = self.bfs(far, false);
        let mut best: Option<Cut> = None;
        for key in [Key::Level, Key::Bisector] {
            let median = self.median_key(&part, key);
            for dt in -THRESHOLDS_AROUND_MEDIAN..=THRESHOLDS_AROUND_MEDIAN {
                let cut = self.cut(&part, key, median + dt);
                if best.is_none_or(|b| cut.ratio() < b.ratio()) {
                    best = Some(cut);
                }
            }
        }
        let best = best.filter(|c| c.ratio().is_finite());
        let Some(best) = best else {
            // No cut with two non-empty sides (a clique-like part): AMD.
            self.clear(&order, true);
            self.clear(&order, false);
            return self.leaf(&part, start);
        };
        let cut = self.cut(&part, best.key, best.threshold);
        self.clear(&order, true);
        self.clear(&order, false);
        let (mut a, mut b, mut s) = (
            Vec::with_capacity(cut.a),
            Vec::with_capacity(cut.b),
            Vec::with_capacity(cut.separator),
        );
        for &v in &part {
            match self.side[v as usize] {
                Side::A => a.push(v),
                Side::B => b.push(v),
                Side::Separator => s.push(v),
            }
        }
        let sep_start = start + a.len() + b.len();
        for (k, &v) in s.iter().enumerate() {
            self.fwd[sep_start + k] = v as usize;
        }
        let b_start = start + a.len();
        work.push((a, start));
        work.push((b, b_start));
        Ok(())
    }

    /// Stamps `part` as the current part.
    fn enter(&mut self, part: &[u32]) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.member.iter_mut().for_each(|m| *m = 0);
            self.stamp = 1;
        }
        for &v in part {
            self.member[v as usize] = self.stamp;
        }
    }

    /// Breadth-first search from `root` inside the current part, distances
    /// into `d1` (`first`) or `d2`: the vertices reached, in order.
    fn bfs(&mut self, root: u32, first: bool) -> Vec<u32> {
        let dist = if first { &mut self.d1 } else { &mut self.d2 };
        let mut order = Vec::new();
        dist[root as usize] = 0;
        self.queue.clear();
        self.queue.push_back(root);
        while let Some(v) = self.queue.pop_front() {
            order.push(v);
            let dv = dist[v as usize];
            for &w in self.graph.neighbours(v as usize) {
                let wu = w as usize;
                if self.member[wu] == self.stamp && dist[wu] == UNSEEN {
                    dist[wu] = dv + 1;
                    self.queue.push_back(w);
                }
            }
        }
        order
    }

    /// Resets the distances of `vertices`.
    fn clear(&mut self, vertices: &[u32], first: bool) {
        let dist = if first { &mut self.d1 } else { &mut self.d2 };
        for &v in vertices {
            dist[v as usize] = UNSEEN;
        }
    }

    /// The vertex of least degree at distance `ecc` (in `d1`) in a BFS
    /// order.
    fn farthest_min_degree(&self, order: &[u32], ecc: i32) -> u32 {
        let degree = |v: u32| self.graph.neighbours(v as usize).len();
        order
            .iter()
            .rev()
            .take_while(|&&v| self.d1[v as usize] == ecc)
            .copied()
            .min_by_key(|&v| degree(v))
            .unwrap_or(order[0])
    }

    fn key(&self, v: u32, key: Key) -> i64 {
        let d1 = i64::from(self.d1[v as usize]);
        match key {
            Key::Level => d1,
            Key::Bisector => d1 - i64::from(self.d2[v as usize]),
        }
    }

    /// The median of `key` over `part`.
    fn median_key(&self, part: &[u32], key: Key) -> i64 {
        let mut keys: Vec<i64> = part.iter().map(|&v| self.key(v, key)).collect();
        let mid = keys.len() / 2;
        *keys.select_nth_unstable(mid).1
    }

    /// Sides of the cut of `key` at `threshold`, written into `side`: the
    /// vertices of `{k > t}` next to `{k <= t}` are the separator, then
    /// thinned (see the module docs).
    fn cut(&mut self, part: &[u32], key: Key, threshold: i64) -> Cut {
        for &v in part {
            self.side[v as usize] = if self.key(v, key) <= threshold {
                Side::A
            } else {
                Side::B
            };
        }
        let mut separator = Vec::new();
        for &v in part {
            if self.side[v as usize] == Side::B
                && self.graph.neighbours(v as usize).iter().any(|&w| {
                    self.member[w as usize] == self.stamp && self.key(w, key) <= threshold
                })
            {
                separator.push(v);
            }
        }
        for &v in &separator {
            self.side[v as usize] = Side::Separator;
        }
        // Thinning: a separator vertex with no neighbour on one side joins
        // the other.
        let mut kept = 0;
        for &v in &separator {
            let (mut in_a, mut in_b) = (false, false);
            for &w in self.graph.neighbours(v as usize) {
                if self.member[w as usize] == self.stamp {
                    match self.side[w as usize] {
                        Side::A => in_a = true,
                        Side::B => in_b = true,
                        Side::Separator => {}
                    }
                }
            }
            if !in_b {
                self.side[v as usize] = Side::A;
            } else if !in_a {
                self.side[v as usize] = Side::B;
            } else {
                kept += 1;
            }
        }
        let a = part
            .iter()
            .filter(|&&v| self.side[v as usize] == Side::A)
            .count();
        Cut {
            key,
            threshold,
            a,
            b: part.len() - a - kept,
            separator: kept,
        }
    }

    /// A part of several components: each large one pushed on its own, the
    /// small ones ordered together by AMD. `part` is stamped.
    fn components(
        &mut self,
        part: &[u32],
        start: usize,
        work: &mut Vec<(Vec<u32>, usize)>,
    ) -> Result<(), LinalgError> {
        let mut small = Vec::new();
        let mut large = Vec::new();
        for &v in part {
            if self.d1[v as usize] == UNSEEN {
                let comp = self.bfs(v, true);
                if comp.len() <= LEAF_VERTICES {
                    small.extend_from_slice(&comp);
                } else {
                    large.push(comp);
                }
            }
        }
        self.clear(part, true);
        let mut at = start;
        if !small.is_empty() {
            self.leaf(&small, at)?;
            at += small.len();
        }
        for comp in large {
            let len = comp.len();
            work.push((comp, at));
            at += len;
        }
        Ok(())
    }

    /// AMD on the subgraph induced by `part`, into `fwd[start ..]`.
    fn leaf(&mut self, part: &[u32], start: usize) -> Result<(), LinalgError> {
        let m = part.len();
        if m <= 2 {
            for (k, &v) in part.iter().enumerate() {
                self.fwd[start + k] = v as usize;
            }
            return Ok(());
        }
        // Local indices through `d2` (free between splits), pattern of the
        // induced subgraph in compressed columns (rows sorted, the diagonal
        // included).
        for (k, &v) in part.iter().enumerate() {
            self.d2[v as usize] = k as i32;
        }
        let mut col_ptr = Vec::with_capacity(m + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0usize);
        for (k, &v) in part.iter().enumerate() {
            let begin = row_idx.len();
            row_idx.push(k);
            for &w in self.graph.neighbours(v as usize) {
                let l = self.d2[w as usize];
                if l != UNSEEN && part.get(l as usize) == Some(&w) {
                    row_idx.push(l as usize);
                }
            }
            row_idx[begin..].sort_unstable();
            col_ptr.push(row_idx.len());
        }
        for &v in part {
            self.d2[v as usize] = UNSEEN;
        }
        let nnz = row_idx.len();
        let pattern = SymbolicSparseColMatRef::new_checked(m, m, &col_ptr, None, &row_idx);
        let mut perm = vec![0usize; m];
        let mut perm_inv = vec![0usize; m];
        let mut scratch = vec![
            MaybeUninit::uninit();
            amd::order_scratch::<usize>(m, nnz).unaligned_bytes_required()
        ];
        amd::order(
            &mut perm,
            &mut perm_inv,
            pattern,
            amd::Control::default(),
            MemStack::new(&mut scratch),
        )
        .map_err(LinalgError::faer("AMD ordering of a dissection leaf"))?;
        for (k, &p) in perm.iter().enumerate() {
            self.fwd[start + k] = part[p] as usize;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::{SpdPattern, VertexSolver};
    use proptest::prelude::*;

    /// The upper triangle (diagonal last) of the graph with these edges.
    fn upper(n: usize, edges: &[(usize, usize)]) -> (Vec<usize>, Vec<usize>) {
        let mut cols: Vec<Vec<usize>> = (0..n).map(|b| vec![b]).collect();
        for &(a, b) in edges {
            let (a, b) = (a % n, b % n);
            cols[a.max(b)].push(a.min(b));
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        (col_ptr, row_idx)
    }

    /// The 27-point (all neighbours) graph of an `s x s x t` grid: the
    /// vertex graph of a hexahedral mesh split into tets, fully coupled.
    fn grid_graph(s: usize, t: usize) -> (usize, Vec<(usize, usize)>) {
        let id = |i: usize, j: usize, k: usize| i + s * (j + s * k);
        let mut edges = Vec::new();
        for k in 0..t {
            for j in 0..s {
                for i in 0..s {
                    for (di, dj, dk) in [
                        (1, 0, 0),
                        (0, 1, 0),
                        (0, 0, 1),
                        (1, 1, 0),
                        (1, 0, 1),
                        (0, 1, 1),
                        (1, 1, 1),
                    ] {
                        if i + di < s && j + dj < s && k + dk < t {
                            edges.push((id(i, j, k), id(i + di, j + dj, k + dk)));
                        }
                    }
                }
            }
        }
        (s * s * t, edges)
    }

    proptest! {
        /// Any graph (several components, isolated vertices, cliques)
        /// gets a permutation of its vertices.
        #[test]
        fn the_ordering_is_a_permutation(
            n in 1usize..400,
            edges in prop::collection::vec((0usize..400, 0usize..400), 0..1500),
        ) {
            let (col_ptr, row_idx) = upper(n, &edges);
            let g = Graph::from_upper(n, &col_ptr, &row_idx).unwrap();
            prop_assert_eq!(g.len(), n);
            let fwd = nested_dissection(&g).unwrap();
            let mut seen = vec![false; n];
            for &v in &fwd {
                prop_assert!(!seen[v], "vertex {} twice", v);
                seen[v] = true;
            }
            prop_assert_eq!(fwd.len(), n);
        }
    }

    #[test]
    fn a_separator_comes_after_the_parts_it_separates() {
        // A path of 400 vertices: its first separator, one vertex near the
        // middle, is eliminated last.
        let n = 400;
        let edges: Vec<(usize, usize)> = (0..n - 1).map(|i| (i, i + 1)).collect();
        let (col_ptr, row_idx) = upper(n, &edges);
        let fwd = nested_dissection(&Graph::from_upper(n, &col_ptr, &row_idx).unwrap()).unwrap();
        let last = fwd[n - 1];
        assert!((150..250).contains(&last), "last vertex {last}");
    }

    #[test]
    fn a_thick_grid_fills_less_than_with_amd() {
        // A 24 x 24 x 6 slab of 3-unknown vertices, as the placenta's tet
        // meshes: the Cholesky factor after nested dissection holds fewer
        // entries than after AMD (on the placenta meshes 0.46 to 0.63 of
        // them).
        let (n, edges) = grid_graph(24, 6);
        let (col_ptr, row_idx) = upper(n, &edges);
        let nnz = |solver| {
            SpdPattern::from_vertex_graph_with(n, 3, col_ptr.clone(), row_idx.clone(), solver)
                .unwrap()
                .factor_nnz()
        };
        let (amd, nd) = (
            nnz(VertexSolver::CholeskyAmd),
            nnz(VertexSolver::CholeskyNestedDissection),
        );
        assert!(nd < amd, "nested dissection {nd}, AMD {amd}");
    }

    #[test]
    fn malformed_graphs_are_refused() {
        assert!(matches!(
            Graph::from_upper(3, &[0, 1], &[0]),
            Err(LinalgError::DimensionMismatch {
                expected: 4,
                found: 2,
                ..
            })
        ));
        assert_eq!(
            Graph::from_upper(2, &[0, 1, 3], &[0, 5, 1]).unwrap_err(),
            LinalgError::IndexOutOfRange {
                what: "graph row",
                index: 5,
                len: 2
            }
        );
        let empty = Graph::from_upper(0, &[0], &[]).unwrap();
        assert!(empty.is_empty());
        assert_eq!(nested_dissection(&empty).unwrap(), Vec::<usize>::new());
    }
}
