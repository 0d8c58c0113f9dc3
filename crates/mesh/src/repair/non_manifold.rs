//! Non-manifold triangle meshes: edges with more than two triangles (fins)
//! and vertices whose triangles form several fans (bow-ties).
//!
//! **Fins.** A *patch* is a maximal set of triangles connected through
//! manifold edges (edges with exactly two triangles). Patches are visited
//! largest first (ties: the one with the lowest triangle); a patch is kept
//! when, at every edge with more than two triangles, the triangles already
//! kept there plus its own are at most two. Otherwise it is a *fin* — an
//! extra triangle or patch glued onto the sheet along such an edge — and all
//! its triangles are dropped. A patch that conflicts only with itself (a
//! triangle glued on an edge and, through another edge, part of the same
//! patch) is kept, and only its triangles beyond two at that edge are
//! dropped (the highest-numbered ones). This repeats until every edge has at
//! most two triangles (dropping may make further edges manifold). Where the
//! non-manifold edge itself cuts the sheet into patches (a strip one
//! triangle wide), the pieces compete by size like fins do; on a real
//! surface the sheet stays one patch around such an edge.
//!
//! **Fans.** Around a vertex `v`, two triangles are in the same fan when they
//! share an edge `v-w` (with no other triangle). A vertex with `k > 1` fans
//! gets `k - 1` copies (same position, same point data); the triangles of
//! the 2nd, 3rd, ... fan (in the order of their first triangle) use a copy.

use super::work::Work;
use petgraph::unionfind::UnionFind;

/// Half-edges `(min, max, triangle)` sorted by edge.
type HalfEdges = Vec<(u32, u32, u32)>;

/// The triangles around each undirected edge: the sorted half-edges and the
/// `[i, j)` runs of them that share an edge.
fn edge_runs(tris: &[[u32; 3]]) -> (HalfEdges, Vec<(usize, usize)>) {
    let mut half: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            half.push((a.min(b), a.max(b), t as u32));
        }
    }
    half.sort_unstable();
    let mut runs = Vec::new();
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 && half[j].1 == half[i].1 {
            j += 1;
        }
        runs.push((i, j));
        i = j;
    }
    (half, runs)
}

/// One pass of the fin removal (see the module docs); returns the triangles
/// to drop.
fn fin_pass(tris: &[[u32; 3]]) -> Vec<bool> {
    let n = tris.len();
    let (half, runs) = edge_runs(tris);
    let mut uf = UnionFind::<u32>::new(n);
    for &(i, j) in &runs {
        if j - i == 2 {
            uf.union(half[i].2, half[i + 1].2);
        }
    }
    let label = uf.into_labeling();
    let mut size = vec![0usize; n];
    for &l in &label {
        size[l as usize] += 1;
    }
    // Non-manifold runs touched by each patch root.
    let mut touches: Vec<Vec<usize>> = vec![Vec::new(); n];
    let bad: Vec<usize> = (0..runs.len())
        .filter(|&r| runs[r].1 - runs[r].0 > 2)
        .collect();
    for &r in &bad {
        let (i, j) = runs[r];
        for h in &half[i..j] {
            let p = label[h.2 as usize] as usize;
            if touches[p].last() != Some(&r) {
                touches[p].push(r);
            }
        }
    }
    // A patch may meet a run more than once, not consecutively.
    for t in &mut touches {
        t.sort_unstable();
        t.dedup();
    }
    // Patches by size (desc), then by their lowest triangle.
    let mut first = vec![usize::MAX; n];
    for t in (0..n).rev() {
        first[label[t] as usize] = t;
    }
    let mut patches: Vec<usize> = (0..n).filter(|&p| !touches[p].is_empty()).collect();
    patches.sort_by_key(|&p| (std::cmp::Reverse(size[p]), first[p]));
    let mut kept_at = vec![0usize; runs.len()];
    let mut drop = vec![false; n];
    let mut dropped_patch = vec![false; n];
    for &p in &patches {
        let own = |r: usize| {
            let (i, j) = runs[r];
            half[i..j]
                .iter()
                .filter(|h| label[h.2 as usize] as usize == p)
                .count()
        };
        let conflict_with_others = touches[p]
            .iter()
            .any(|&r| kept_at[r] > 0 && kept_at[r] + own(r) > 2);
        if conflict_with_others {
            dropped_patch[p] = true;
            continue;
        }
        for &r in &touches[p] {
            let (i, j) = runs[r];
            let mut mine: Vec<u32> = half[i..j]
                .iter()
                .filter(|h| label[h.2 as usize] as usize == p)
                .map(|h| h.2)
                .collect();
            mine.sort_unstable();
            mine.dedup();
            for &t in mine.iter().skip(2) {
                drop[t as usize] = true;
            }
            kept_at[r] += mine.len().min(2);
        }
    }
    for t in 0..n {
        if dropped_patch[label[t] as usize] {
            drop[t] = true;
        }
    }
    drop
}

/// Drops fins until every edge has at most two triangles (see the module
/// docs); returns how many triangles were dropped.
pub(crate) fn drop_fins(w: &mut Work<3>) -> usize {
    let mut total = 0;
    loop {
        let drop = fin_pass(&w.elements);
        let dropped = w.retain(|t| !drop[t]);
        if dropped == 0 {
            return total;
        }
        total += dropped;
    }
}

/// Gives every extra fan of a vertex its own copy of the vertex (see the
/// module docs); returns how many vertices were split. Every edge must have
/// at most two triangles ([`drop_fins`] first).
pub(crate) fn split_fans(w: &mut Work<3>) -> usize {
    let n = w.elements.len();
    let (half, runs) = edge_runs(&w.elements);
    // Corner 3t + i is vertex tris[t][i] seen from triangle t.
    let corner = |t: u32, v: u32| -> u32 {
        let tri = w.elements[t as usize];
        let i = tri.iter().position(|&x| x == v).unwrap_or(0);
        3 * t + i as u32
    };
    let mut uf = UnionFind::<u32>::new(3 * n);
    for &(i, j) in &runs {
        if j - i == 2 {
            let (a, b, t, u) = (half[i].0, half[i].1, half[i].2, half[i + 1].2);
            uf.union(corner(t, a), corner(u, a));
            uf.union(corner(t, b), corner(u, b));
        }
    }
    let label = uf.into_labeling();
    // For each vertex, the fan label that keeps it; others get copies.
    let nv = w.positions.len();
    let mut keeper = vec![u32::MAX; nv];
    let mut copy_of_fan: std::collections::HashMap<u32, u32> = Default::default();
    let mut split = vec![false; nv];
    for t in 0..n {
        for i in 0..3 {
            let v = w.elements[t][i] as usize;
            let fan = label[3 * t + i];
            if keeper[v] == u32::MAX {
                keeper[v] = fan;
            } else if keeper[v] != fan {
                let copy = *copy_of_fan.entry(fan).or_insert_with(|| {
                    w.positions.push(w.positions[v]);
                    w.origin.push(w.origin[v]);
                    (w.positions.len() - 1) as u32
                });
                split[v] = true;
                w.elements[t][i] = copy;
            }
        }
    }
    split.iter().filter(|&&s| s).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    fn pts(n: usize) -> Vec<Point3<f64>> {
        (0..n)
            .map(|i| Point3::new(i as f64, (i * i % 7) as f64, (i % 3) as f64))
            .collect()
    }

    #[test]
    fn a_glued_triangle_is_a_fin() {
        // A strip 0-1-2-3 / 4-5-6-7 of 6 triangles, a fin [1, 5, 8] on the
        // interior edge 1-5.
        let tris = vec![
            [0u32, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [1, 5, 8],
        ];
        let mut w = Work::new(&pts(9), &tris);
        assert_eq!(drop_fins(&mut w), 1);
        assert_eq!(w.rows, (0..6).collect::<Vec<_>>());
        assert_eq!(drop_fins(&mut w), 0);
        assert_eq!(split_fans(&mut w), 0);
    }

    #[test]
    fn a_fin_patch_is_dropped_whole_and_the_sheet_kept() {
        // A 3 x 3 grid; a 2-triangle fin, listed first, on the interior
        // edge 5-6, standing up out of the plane.
        let g = crate::shapes::primitives::grid_disk(3, 3);
        let mut p = g.positions.clone();
        p.push(Point3::new(1.5, 1.0, 1.0)); // 16
        p.push(Point3::new(1.0, 1.0, 1.0)); // 17
        let mut tris = vec![[5u32, 6, 16], [5, 16, 17]];
        tris.extend(&g.triangles);
        let mut w = Work::new(&p, &tris);
        assert_eq!(drop_fins(&mut w), 2);
        assert_eq!(w.elements, g.triangles);
        assert_eq!(w.rows, (2..20).collect::<Vec<_>>());
        assert_eq!(split_fans(&mut w), 0);
    }

    #[test]
    fn two_fins_on_one_edge_between_the_sheet_triangles() {
        // Fins listed between the sheet's two triangles at edge 5-6, so
        // the sheet meets that edge's run twice, not consecutively.
        let g = crate::shapes::primitives::grid_disk(3, 3);
        let mut p = g.positions.clone();
        p.push(Point3::new(1.5, 1.0, 1.0)); // 16
        p.push(Point3::new(1.5, 1.0, -1.0)); // 17
        let at_edge: Vec<usize> = (0..g.triangles.len())
            .filter(|&t| g.triangles[t].contains(&5) && g.triangles[t].contains(&6))
            .collect();
        assert_eq!(at_edge.len(), 2);
        let mut tris = g.triangles.clone();
        tris.insert(at_edge[1], [5, 6, 16]);
        tris.insert(at_edge[1], [6, 5, 17]);
        let mut w = Work::new(&p, &tris);
        assert_eq!(drop_fins(&mut w), 2);
        assert_eq!(w.elements, g.triangles);
    }

    #[test]
    fn a_bow_tie_vertex_is_split() {
        // Two triangles touching at vertex 0 only, then a third fan.
        let tris = vec![[0u32, 1, 2], [0, 3, 4], [0, 5, 6], [0, 6, 7]];
        let mut w = Work::new(&pts(8), &tris);
        assert_eq!(drop_fins(&mut w), 0);
        assert_eq!(split_fans(&mut w), 1);
        assert_eq!(w.positions.len(), 10);
        assert_eq!(w.origin[8], 0);
        assert_eq!(w.origin[9], 0);
        assert_eq!(w.elements[0][0], 0);
        assert_eq!(w.elements[1][0], 8);
        assert_eq!(w.elements[2][0], 9);
        assert_eq!(w.elements[3][0], 9);
        assert_eq!(split_fans(&mut w), 0);
    }
}
