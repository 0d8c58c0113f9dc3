//! Resolving pinches of a tet mesh's boundary (ALGORITHMS 2.8):
//! the places where a mesh cut from a lattice touches itself, which
//! [`crate::stuffing::check_closed_manifold`] refuses.
//!
//! A *pinched vertex* `v` has boundary triangles forming more than one
//! fan; a *pinched edge* has more than two boundary triangles. In the tet
//! mesh, around a vertex the tets containing it fall into *groups*
//! (connected through faces containing `v`), and around an edge into
//! *fans* (connected through faces containing the edge). A lattice cut of
//! two blobs touching at a corner (or a neck thinner than a cube) gives
//! exactly these: two groups sharing a vertex, two fans sharing an edge.
//!
//! [`resolve_pinches`] repeats, to a fixed point (at most [`MAX_ROUNDS`]
//! rounds), three steps in this order:
//!
//! 1. **Split** every vertex with more than one group: the group with the
//!    most tets (ties: the one holding the smallest tet index) keeps the
//!    vertex, every other group gets its own copy (same position). A face
//!    shared by two tets that contains `v` puts them in the same group, so
//!    no face is torn: the result is a conforming tet mesh with the same
//!    tets, the same volume, and every vertex's group unique. Coincident
//!    copies are where the object touches itself; the pieces a split
//!    disconnects become components (the mesher keeps the largest, or all).
//! 2. **Open** every edge still pinched (its ends have one group each but
//!    the tets around the edge form several fans, e.g. a ring of tets
//!    around a vertex closing back on itself through one edge): the fan
//!    with the most tets (ties: the smallest tet index) is kept, the tets
//!    of the other fans *that contain the edge* are removed.
//! 3. **Open** every vertex still pinched (one group, but its boundary
//!    triangles form several fans: the tets around it form a ring, like a
//!    solid torus whose hole closes to a point): the tets containing it
//!    are removed.
//!
//! Splitting keeps every tet, so it is taken first and alone when it
//! suffices (the common case: touching blobs, diagonal voxel chains).
//! Removal takes tets only at the pinch, a volume of the order of a few
//! cubes of the lattice (recorded); it can make a new pinch next to the
//! old one, hence the rounds. The rule uses only counts and indices, so it
//! is deterministic. When the rounds run out the boundary is still pinched
//! and [`MeshError::Pinched`] names where and what to change.

use crate::geometry::tet_signed_volume;
use crate::{Fields, MeshError, TetMesh};
use serde::{Deserialize, Serialize};

/// Rounds of [`resolve_pinches`] before it gives up (one round resolves
/// every pinch of a stuffed mask met so far; a removal can expose one more
/// next to it, and eight rounds bound the work to a few passes).
pub const MAX_ROUNDS: usize = 8;

/// What [`resolve_pinches`] did: counts over all rounds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinchRepair {
    /// Pinched vertices split (more than one tet group around them).
    pub vertices_split: usize,
    /// Vertex copies added by the splits.
    pub vertex_copies: usize,
    /// Pinched edges opened (the tets of their smaller fans removed).
    pub edges_opened: usize,
    /// Pinched vertices with one tet group opened (their tets removed).
    pub vertices_opened: usize,
    /// Tets removed by the openings.
    pub tets_removed: usize,
    /// Their volume, in the mesh's units cubed (mm^3).
    #[serde(with = "crate::nan_as_null")]
    pub volume_removed: f64,
    /// Rounds that changed the mesh.
    pub rounds: usize,
}

impl PinchRepair {
    /// Whether anything was changed.
    pub fn changed(&self) -> bool {
        self.vertex_copies > 0 || self.tets_removed > 0
    }

    /// Adds the counts of `other`.
    pub fn add(&mut self, other: &PinchRepair) {
        self.vertices_split += other.vertices_split;
        self.vertex_copies += other.vertex_copies;
        self.edges_opened += other.edges_opened;
        self.vertices_opened += other.vertices_opened;
        self.tets_removed += other.tets_removed;
        self.volume_removed += other.volume_removed;
        self.rounds += other.rounds;
    }
}

/// Vertex-to-tet incidence (compressed rows): the tets of vertex `v` are
/// `tets[start[v] .. start[v + 1]]`, ascending.
struct Incidence {
    start: Vec<usize>,
    tets: Vec<u32>,
}

impl Incidence {
    fn new(num_vertices: usize, tets: &[[u32; 4]]) -> Incidence {
        let mut start = vec![0usize; num_vertices + 1];
        for t in tets {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for v in 0..num_vertices {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; start[num_vertices]];
        for (i, t) in tets.iter().enumerate() {
            for &v in t {
                list[fill[v as usize]] = i as u32;
                fill[v as usize] += 1;
            }
        }
        Incidence { start, tets: list }
    }

    fn of(&self, v: u32) -> &[u32] {
        &self.tets[self.start[v as usize]..self.start[v as usize + 1]]
    }
}

/// Union-find over `0..n` (small, local).
fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb);
    }
}

/// The groups of `items` (indices into it) joined when they share a key:
/// `keys(i)` lists item `i`'s keys. Groups are ordered by size, largest
/// first, ties by their smallest item.
fn groups<K: Ord + Copy>(n: usize, keys: impl Fn(usize) -> Vec<K>) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..n).collect();
    let mut all: Vec<(K, usize)> = (0..n)
        .flat_map(|i| keys(i).into_iter().map(move |k| (k, i)))
        .collect();
    all.sort_unstable();
    for w in all.windows(2) {
        if w[0].0 == w[1].0 {
            union(&mut parent, w[0].1, w[1].1);
        }
    }
    let mut by_root: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        let r = find(&mut parent, i);
        by_root[r].push(i);
    }
    let mut out: Vec<Vec<usize>> = by_root.into_iter().filter(|g| !g.is_empty()).collect();
    out.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
    out
}

/// The vertices of `t` other than those in `skip`.
fn others(t: &[u32; 4], skip: &[u32]) -> Vec<u32> {
    t.iter().copied().filter(|v| !skip.contains(v)).collect()
}

/// Step 1: splits every vertex whose tets form more than one group.
/// Returns the vertices split and the copies added.
fn split_vertices(mesh: &mut TetMesh) -> (usize, usize) {
    let inc = Incidence::new(mesh.positions.len(), &mesh.tets);
    let mut renames: Vec<(u32, u32, u32)> = Vec::new(); // (tet, old, new)
    let (mut split, mut copies) = (0, 0);
    let n0 = mesh.positions.len();
    for v in 0..n0 as u32 {
        let ts = inc.of(v);
        if ts.len() < 2 {
            continue;
        }
        let g = groups(ts.len(), |i| {
            let o = others(&mesh.tets[ts[i] as usize], &[v]);
            vec![
                (o[0].min(o[1]), o[0].max(o[1])),
                (o[0].min(o[2]), o[0].max(o[2])),
                (o[1].min(o[2]), o[1].max(o[2])),
            ]
        });
        if g.len() < 2 {
            continue;
        }
        split += 1;
        for group in &g[1..] {
            let copy = mesh.positions.len() as u32;
            mesh.positions.push(mesh.positions[v as usize]);
            copies += 1;
            for &i in group {
                renames.push((ts[i], v, copy));
            }
        }
    }
    for (t, old, new) in renames {
        for x in &mut mesh.tets[t as usize] {
            if *x == old {
                *x = new;
            }
        }
    }
    (split, copies)
}

/// The boundary faces of `tets` (faces of one tet), as sorted triples.
fn boundary_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut faces: Vec<[u32; 3]> = Vec::with_capacity(4 * tets.len());
    for t in tets {
        for skip in 0..4 {
            let mut f = [0u32; 3];
            let mut k = 0;
            for (i, &v) in t.iter().enumerate() {
                if i != skip {
                    f[k] = v;
                    k += 1;
                }
            }
            f.sort_unstable();
            faces.push(f);
        }
    }
    faces.sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < faces.len() {
        let mut j = i + 1;
        while j < faces.len() && faces[j] == faces[i] {
            j += 1;
        }
        if j - i == 1 {
            out.push(faces[i]);
        }
        i = j;
    }
    out
}

/// The edges of `faces` shared by more than two of them, ascending.
fn pinched_edges(faces: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut edges: Vec<(u32, u32)> = faces
        .iter()
        .flat_map(|f| [(f[0], f[1]), (f[0], f[2]), (f[1], f[2])])
        .collect();
    edges.sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i > 2 {
            out.push(edges[i]);
        }
        i = j;
    }
    out
}

/// The vertices of `faces` whose faces form more than one fan (joined
/// through edges at the vertex), ascending.
fn pinched_vertices(num_vertices: usize, faces: &[[u32; 3]]) -> Vec<u32> {
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); num_vertices];
    for (i, f) in faces.iter().enumerate() {
        for &v in f {
            at[v as usize].push(i);
        }
    }
    let mut out = Vec::new();
    for (v, fs) in at.iter().enumerate() {
        if fs.len() < 2 {
            continue;
        }
        let g = groups(fs.len(), |i| others3(&faces[fs[i]], v as u32));
        if g.len() > 1 {
            out.push(v as u32);
        }
    }
    out
}

/// The two vertices of triangle `f` other than `v`.
fn others3(f: &[u32; 3], v: u32) -> Vec<u32> {
    f.iter().copied().filter(|&x| x != v).collect()
}

/// Steps 2 and 3 on the current mesh: the tets to remove, with the counts
/// of edges and vertices opened.
fn openings(mesh: &TetMesh) -> (Vec<bool>, usize, usize) {
    let faces = boundary_faces(&mesh.tets);
    let inc = Incidence::new(mesh.positions.len(), &mesh.tets);
    let mut remove = vec![false; mesh.tets.len()];
    let edges = pinched_edges(&faces);
    for &(a, b) in &edges {
        let ts: Vec<u32> = inc
            .of(a)
            .iter()
            .copied()
            .filter(|&t| mesh.tets[t as usize].contains(&b))
            .collect();
        let g = groups(ts.len(), |i| others(&mesh.tets[ts[i] as usize], &[a, b]));
        for group in &g[1..] {
            for &i in group {
                remove[ts[i] as usize] = true;
            }
        }
    }
    if !edges.is_empty() {
        return (remove, edges.len(), 0);
    }
    let vertices = pinched_vertices(mesh.positions.len(), &faces);
    for &v in &vertices {
        for &t in inc.of(v) {
            remove[t as usize] = true;
        }
    }
    (remove, 0, vertices.len())
}

/// Resolves the pinches of `mesh`'s boundary (see the module doc); the
/// result has no unused vertices, and its boundary passes
/// [`crate::stuffing::check_closed_manifold`]'s fan and edge tests.
///
/// # Errors
/// [`MeshError::Pinched`] when the boundary is still pinched after
/// [`MAX_ROUNDS`] rounds; `Empty` when the openings removed every tet.
pub fn resolve_pinches(mesh: &TetMesh) -> Result<(TetMesh, PinchRepair), MeshError> {
    let mut m = mesh.clone();
    let mut r = PinchRepair::default();
    for _ in 0..MAX_ROUNDS {
        let (split, copies) = split_vertices(&mut m);
        r.vertices_split += split;
        r.vertex_copies += copies;
        let (remove, edges, vertices) = openings(&m);
        let removed = remove.iter().filter(|&&x| x).count();
        if copies == 0 && removed == 0 {
            return finish(m, r);
        }
        r.rounds += 1;
        r.edges_opened += edges;
        r.vertices_opened += vertices;
        r.tets_removed += removed;
        let mut kept = Vec::with_capacity(m.tets.len() - removed);
        for (t, &gone) in m.tets.iter().zip(&remove) {
            if gone {
                let p = t.map(|v| m.positions[v as usize]);
                r.volume_removed += tet_signed_volume(&p[0], &p[1], &p[2], &p[3]).abs();
            } else {
                kept.push(*t);
            }
        }
        if kept.is_empty() {
            return Err(MeshError::Empty {
                what: "tets (resolving the boundary's pinches removed them all)",
            });
        }
        m.tets = kept;
    }
    // the last round changed the mesh: is it clean now?
    let faces = boundary_faces(&m.tets);
    let edges = pinched_edges(&faces);
    let vertices = pinched_vertices(m.positions.len(), &faces);
    let at = match (edges.first(), vertices.first()) {
        (Some(&(a, _)), _) => Some(a),
        (None, Some(&v)) => Some(v),
        (None, None) => None,
    };
    if let Some(v) = at {
        let p = m.positions[v as usize];
        return Err(MeshError::Pinched {
            at: [p.x, p.y, p.z],
            edges: edges.len(),
            vertices: vertices.len(),
            rounds: MAX_ROUNDS,
            hint: "smooth or close the shape there, or mesh at another element size",
        });
    }
    finish(m, r)
}

/// Drops unused vertices.
fn finish(m: TetMesh, r: PinchRepair) -> Result<(TetMesh, PinchRepair), MeshError> {
    if !r.changed() {
        return Ok((m, r));
    }
    let c = crate::reindex::compact_vertices(&m.positions, &Fields::new(), &m.tets)?;
    Ok((TetMesh::new(c.positions, c.elements), r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stuffing::check_closed_manifold;
    use nalgebra::Point3;

    fn p(x: f64, y: f64, z: f64) -> Point3<f64> {
        Point3::new(x, y, z)
    }

    /// Positive tets, no vertex unused, conforming (each face in at most
    /// two tets): what the resolver must keep (a split may leave several
    /// components, which the mesher then chooses among).
    fn sound(m: &TetMesh) {
        let mut used = vec![false; m.num_vertices()];
        for t in 0..m.num_tets() {
            let q = m.tet_points(t);
            assert!(
                tet_signed_volume(&q[0], &q[1], &q[2], &q[3]) > 0.0,
                "tet {t}"
            );
            for &v in &m.tets[t] {
                used[v as usize] = true;
            }
        }
        assert!(used.iter().all(|&u| u), "unused vertices");
        let comps = crate::topology::connected_components(m.num_vertices(), &m.tets);
        for c in 0..comps.count as u32 {
            let tets: Vec<[u32; 4]> = (0..m.num_tets())
                .filter(|&t| comps.element_label[t] == c)
                .map(|t| m.tets[t])
                .collect();
            let k = crate::reindex::compact_vertices(&m.positions, &Fields::new(), &tets).unwrap();
            TetMesh::new(k.positions, k.elements).validate().unwrap();
        }
    }

    /// The corner tet of the unit cube at the origin, and its mirror
    /// through the origin: two tets sharing vertex 0 only.
    fn vertex_pinch() -> TetMesh {
        let pos = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(-1.0, 0.0, 0.0),
            p(0.0, -1.0, 0.0),
            p(0.0, 0.0, -1.0),
        ];
        TetMesh::new(pos, vec![[0, 1, 2, 3], [0, 4, 6, 5]])
    }

    #[test]
    fn a_vertex_pinch_is_split_keeping_every_tet() {
        let m = vertex_pinch();
        assert!(check_closed_manifold(&m).is_err());
        let (out, r) = resolve_pinches(&m).unwrap();
        check_closed_manifold(&out).unwrap();
        sound(&out);
        assert_eq!(out.num_tets(), 2);
        assert_eq!(out.num_vertices(), 8);
        assert_eq!(
            (r.vertices_split, r.vertex_copies, r.tets_removed),
            (1, 1, 0)
        );
        assert_eq!(r.volume_removed, 0.0);
        // the copy sits where the vertex was
        assert_eq!(out.positions[7], p(0.0, 0.0, 0.0));
    }

    #[test]
    fn an_edge_pinch_is_split_at_its_ends() {
        // two tets sharing the edge (0, 1) only
        let pos = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(0.0, -1.0, 0.0),
            p(0.0, 0.0, -1.0),
        ];
        let m = TetMesh::new(pos, vec![[0, 1, 2, 3], [0, 1, 5, 4]]);
        let (out, r) = resolve_pinches(&m).unwrap();
        check_closed_manifold(&out).unwrap();
        assert_eq!(
            (r.vertices_split, r.vertex_copies, r.tets_removed),
            (2, 2, 0)
        );
        assert_eq!(out.num_tets(), 2);
    }

    /// Two fans of two tets around the edge (0, 1) (from (0,0,0) to
    /// (0,0,1), ring points at z = 0.5), joined at each end through three
    /// tets to a point below (at vertex 0) and above (at vertex 1): both
    /// ends have one group, the edge has two fans and four boundary
    /// triangles. Splitting cannot help; the fan with the smaller tet
    /// indices is kept, the other's two tets are removed.
    #[test]
    fn an_edge_pinch_with_connected_ends_is_opened() {
        let mut pos = vec![p(0.0, 0.0, 0.0), p(0.0, 0.0, 1.0)];
        for k in 0..6 {
            let a = (k as f64) * std::f64::consts::PI / 3.0;
            pos.push(p(a.cos(), a.sin(), 0.5));
        }
        pos.push(p(0.0, 0.0, -1.0)); // 8
        pos.push(p(0.0, 0.0, 2.0)); // 9
        let wedge = |k: u32| [0, 1, 2 + k, 2 + (k + 1) % 6];
        let mut tets = vec![wedge(0), wedge(1), wedge(3), wedge(4)];
        for (end, far) in [(0, 8), (1, 9)] {
            tets.extend([[end, 3, 4, far], [end, 4, 5, far], [end, 5, 6, far]]);
        }
        let mut m = TetMesh::new(pos, tets);
        for t in &mut m.tets {
            let q = t.map(|v| m.positions[v as usize]);
            if tet_signed_volume(&q[0], &q[1], &q[2], &q[3]) < 0.0 {
                t.swap(2, 3);
            }
        }
        let e = check_closed_manifold(&m).unwrap_err();
        assert!(
            matches!(
                e,
                MeshError::NonManifoldEdge {
                    a: 0,
                    b: 1,
                    faces: 4
                }
            ),
            "{e}"
        );
        let (out, r) = resolve_pinches(&m).unwrap();
        check_closed_manifold(&out).unwrap();
        sound(&out);
        // opening (0, 1) leaves the bridges' tets meeting at edges (5, 6)
        // alone: a second round resolves those
        assert!(r.edges_opened >= 1 && r.rounds >= 1, "{r:?}");
        assert!(r.tets_removed >= 2 && r.volume_removed > 0.0, "{r:?}");
        assert!(out.num_tets() <= 8);
    }

    #[test]
    fn a_clean_mesh_is_left_alone() {
        let m = TetMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.0, 1.0, 0.0),
                p(0.0, 0.0, 1.0),
            ],
            vec![[0, 1, 2, 3]],
        );
        let (out, r) = resolve_pinches(&m).unwrap();
        assert_eq!(out.tets, m.tets);
        assert_eq!(r, PinchRepair::default());
    }
}
