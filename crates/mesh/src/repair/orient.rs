//! Orientation: tets made positive, triangle patches made consistent (and
//! closed ones outward).

use super::work::Work;
use crate::{MeshError, TetMesh, geometry::tet_signed_volume};
use std::collections::VecDeque;

impl TetMesh {
    /// Makes every tet positively oriented, `(b-a)·((c-a)×(d-a)) > 0`, by
    /// swapping its last two corners where the signed volume is negative
    /// (zero and NaN volumes are left alone). Returns the number of tets
    /// flipped.
    ///
    /// Fails with [`MeshError::IndexOutOfRange`] (changing nothing) when a
    /// tet refers to a vertex that does not exist.
    pub fn orient(&mut self) -> Result<usize, MeshError> {
        crate::geometry::check_indices(self.positions.len(), &self.tets)?;
        let mut flipped = 0;
        for t in 0..self.tets.len() {
            let [a, b, c, d] = self.tet_points(t);
            if tet_signed_volume(&a, &b, &c, &d) < 0.0 {
                self.tets[t].swap(2, 3);
                flipped += 1;
            }
        }
        Ok(flipped)
    }
}

/// Where a patch cannot be oriented: triangles `t` and `u` (current
/// numbering) meet across `edge` and no choice of flips makes them agree.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Twist {
    /// The triangle the search came from.
    pub t: usize,
    /// The triangle it contradicts.
    pub u: usize,
    /// The shared edge (current vertex numbers).
    pub edge: [u32; 2],
}

/// Orients every *patch* (triangles connected through edges with exactly
/// two triangles) consistently: breadth-first from the patch's first
/// triangle, which keeps its orientation, flipping `[a, b, c] -> [a, c, b]`
/// each neighbour that traverses the shared edge in the same direction. A
/// closed patch (all its edges shared by two triangles) is then flipped as a
/// whole if its enclosed signed volume `Σ (a-o)·((b-o)×(c-o)) / 6` is
/// negative, so its normals point outward. Returns the number of triangles
/// flipped.
///
/// Fails with the first contradiction met (a Möbius strip, a Klein bottle):
/// such a surface cannot be repaired by flipping.
pub(crate) fn orient_triangles(w: &mut Work<3>) -> Result<usize, Twist> {
    let flip = orientation_flips(w)?;
    let mut flipped = 0;
    for (t, f) in w.elements.iter_mut().zip(&flip) {
        if *f {
            t.swap(1, 2);
            flipped += 1;
        }
    }
    Ok(flipped)
}

fn orientation_flips(w: &Work<3>) -> Result<Vec<bool>, Twist> {
    let (positions, tris) = (&w.positions, &w.elements);
    let n = tris.len();
    // (min, max, triangle, traversed min -> max)
    let mut half: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * n);
    for (t, tri) in tris.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            half.push((a.min(b), a.max(b), t as u32, a < b));
        }
    }
    half.sort_unstable();
    // Per triangle: up to 3 manifold neighbours (neighbour, same direction, edge).
    type Nbr = (u32, bool, [u32; 2]);
    let mut nbrs: Vec<[Nbr; 3]> = vec![[(u32::MAX, false, [0, 0]); 3]; n];
    let mut deg = vec![0u8; n];
    let mut open = vec![false; n]; // has a boundary or non-manifold edge
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 && half[j].1 == half[i].1 {
            j += 1;
        }
        if j - i == 2 {
            let (t, u) = (half[i].2, half[i + 1].2);
            let same = half[i].3 == half[i + 1].3;
            let edge = [half[i].0, half[i].1];
            nbrs[t as usize][deg[t as usize] as usize] = (u, same, edge);
            deg[t as usize] += 1;
            nbrs[u as usize][deg[u as usize] as usize] = (t, same, edge);
            deg[u as usize] += 1;
        } else {
            for h in &half[i..j] {
                open[h.2 as usize] = true;
            }
        }
        i = j;
    }

    let mut flip = vec![false; n];
    let mut visited = vec![false; n];
    let mut queue = VecDeque::new();
    let mut patch = Vec::new();
    for seed in 0..n {
        if visited[seed] {
            continue;
        }
        visited[seed] = true;
        queue.push_back(seed);
        patch.clear();
        while let Some(t) = queue.pop_front() {
            patch.push(t);
            for &(u, same, edge) in &nbrs[t][..deg[t] as usize] {
                let want = flip[t] ^ same;
                let u = u as usize;
                if !visited[u] {
                    visited[u] = true;
                    flip[u] = want;
                    queue.push_back(u);
                } else if flip[u] != want {
                    return Err(Twist { t, u, edge });
                }
            }
        }
        if patch.iter().any(|&t| open[t]) {
            continue;
        }
        // Closed: make the enclosed volume positive.
        let o = positions[tris[patch[0]][0] as usize];
        let volume: f64 = patch
            .iter()
            .map(|&t| {
                let [a, b, c] = tris[t].map(|v| positions[v as usize] - o);
                let v = a.dot(&b.cross(&c));
                if flip[t] { -v } else { v }
            })
            .sum();
        if volume < 0.0 {
            for &t in &patch {
                flip[t] = !flip[t];
            }
        }
    }
    Ok(flip)
}
