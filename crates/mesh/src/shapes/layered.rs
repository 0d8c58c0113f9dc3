//! Layered hexagonal-ring meshes shared by the slab-like generators (the
//! placenta and the bowl shell): every layer of vertices is the same
//! triangulation of a disk, and the prisms between consecutive layers are
//! split into tets.

use super::{check_count, invalid};
use crate::MeshError;

/// Largest number of vertices a layered generator agrees to build.
pub(super) const MAX_VERTICES: usize = 1_000_000;

/// Checks the resolution of a layered generator named `what`: `cells_radial`
/// in `[2, 400]`, `cells_through` in `[1, 100]`, and the resulting
/// `vertices` at most [`MAX_VERTICES`].
pub(super) fn check_layers(
    what: &str,
    cells_radial: usize,
    cells_through: usize,
    vertices: usize,
) -> Result<(), MeshError> {
    check_count(what, "cells_radial", cells_radial, 2, 400)?;
    check_count(what, "cells_through", cells_through, 1, 100)?;
    if vertices > MAX_VERTICES {
        return Err(invalid(format!(
            "{what}: cells_radial = {cells_radial} and cells_through = {cells_through} would give \
             {vertices} vertices (more than {MAX_VERTICES}); lower the resolution"
        )));
    }
    Ok(())
}

/// First vertex index of ring `k` of a hexagonal-ring disk.
#[inline]
pub(super) fn ring_start(k: usize) -> usize {
    if k == 0 { 0 } else { 1 + 3 * k * (k - 1) }
}

/// Triangles of a hexagonal-ring disk with `n` rings: ring `k` has `6k`
/// vertices (`1` for `k = 0`), consecutive rings are joined like the
/// hexagonal lattice (per sector: `k` triangles pointing in, `k - 1`
/// pointing out), `6 n^2` triangles, all counter-clockwise for the
/// equal-angle placement `angle = 2 pi j / (6 k)`.
pub(super) fn hex_disk_triangles(n: usize) -> Vec<[usize; 3]> {
    let mut tris = Vec::with_capacity(6 * n * n);
    for k in 1..=n {
        let outer = |s: usize, t: usize| ring_start(k) + (s * k + t) % (6 * k);
        let inner = |s: usize, t: usize| {
            if k == 1 {
                0
            } else {
                ring_start(k - 1) + (s * (k - 1) + t) % (6 * (k - 1))
            }
        };
        for s in 0..6 {
            for t in 0..k {
                tris.push([outer(s, t), outer(s, t + 1), inner(s, t)]);
                if t + 1 < k {
                    tris.push([inner(s, t), outer(s, t + 1), inner(s, t + 1)]);
                }
            }
        }
    }
    tris
}

/// The tets of `m` layers of prisms over [`hex_disk_triangles`]`(n)`, layer
/// `l` holding vertices `l * ring_start(n + 1) ..`: each prism is split into
/// 3 tets, the diagonal of each quad face joining the lower-indexed vertex
/// of the bottom to the higher-indexed vertex of the top, so neighbouring
/// prisms agree (a conforming mesh); corner orders make every tet
/// positively oriented when the layers stack along the disk's normal.
pub(super) fn prism_tets(n: usize, m: usize) -> Vec<[u32; 4]> {
    let per_layer = ring_start(n + 1);
    let tris = hex_disk_triangles(n);
    let mut tets = Vec::with_capacity(3 * tris.len() * m);
    for tri in &tris {
        let mut s = *tri;
        s.sort_unstable();
        // The disk triangles are counter-clockwise; sorting keeps that iff
        // the sorting permutation is even (a cyclic rotation).
        let ccw = [
            [tri[0], tri[1], tri[2]],
            [tri[1], tri[2], tri[0]],
            [tri[2], tri[0], tri[1]],
        ]
        .contains(&s);
        for l in 0..m {
            let lo = |v: usize| (l * per_layer + v) as u32;
            let hi = |v: usize| ((l + 1) * per_layer + v) as u32;
            let [a0, b0, c0] = [lo(s[0]), lo(s[1]), lo(s[2])];
            let [a1, b1, c1] = [hi(s[0]), hi(s[1]), hi(s[2])];
            for t in [[a0, b0, c0, c1], [a0, b0, c1, b1], [a0, a1, b1, c1]] {
                tets.push(if ccw { t } else { [t[0], t[1], t[3], t[2]] });
            }
        }
    }
    tets
}
