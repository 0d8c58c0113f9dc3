//! Topology: vertex adjacency (CSR), unique edges, k-rings, the boundary
//! surface of a tet mesh, boundary loops of a triangle mesh, connected
//! components and the Euler characteristic.
//!
//! Everything here works on index arrays only (no geometry), except
//! [`tet_boundary`], which needs positions to orient faces outward.
//! The functions that take raw `elements` expect every index to be smaller
//! than the vertex count; use [`crate::validate`] first on untrusted input.

use crate::{MeshError, TetMesh, TriMesh, geometry::tet_signed_volume};
use petgraph::unionfind::UnionFind;

/// Vertex adjacency in compressed sparse row form: the neighbours of vertex
/// `v` are `neighbors[offsets[v]..offsets[v + 1]]`, sorted ascending, without
/// duplicates and without `v` itself. `offsets.len() == num_vertices + 1`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Adjacency {
    /// Row starts; `offsets[0] == 0`, `offsets[n] == neighbors.len()`.
    pub offsets: Vec<usize>,
    /// Concatenated sorted neighbour lists.
    pub neighbors: Vec<u32>,
}

impl Adjacency {
    /// The sorted neighbours of vertex `v`.
    #[inline]
    pub fn neighbors(&self, v: usize) -> &[u32] {
        &self.neighbors[self.offsets[v]..self.offsets[v + 1]]
    }

    /// Number of vertices (rows), `offsets.len() - 1`.
    #[inline]
    pub fn num_vertices(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of neighbours of `v` (its valence).
    #[inline]
    pub fn degree(&self, v: usize) -> usize {
        self.offsets[v + 1] - self.offsets[v]
    }
}

/// The vertex adjacency of a mesh whose elements are simplices with `K`
/// corners (every pair of corners of an element is an edge: `K = 2` lines,
/// `3` triangles, `4` tets). Vertices used by no element have no neighbours;
/// repeated corners do not create self-loops.
///
/// Runs in `O(Σ deg log deg)`: every vertex first gets a bucket of
/// `(K - 1) × (elements using it)` slots, which are then sorted, deduplicated
/// and compacted.
///
/// # Panics
/// If an element refers to a vertex `>= num_vertices`.
pub fn vertex_adjacency<const K: usize>(num_vertices: usize, elements: &[[u32; K]]) -> Adjacency {
    let mut start = vec![0usize; num_vertices + 1];
    for el in elements {
        for &v in el {
            start[v as usize + 1] += K - 1;
        }
    }
    for i in 0..num_vertices {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut buf = vec![0u32; start[num_vertices]];
    for el in elements {
        for (i, &a) in el.iter().enumerate() {
            for (j, &b) in el.iter().enumerate() {
                if i != j {
                    let slot = &mut fill[a as usize];
                    buf[*slot] = b;
                    *slot += 1;
                }
            }
        }
    }
    let mut offsets = Vec::with_capacity(num_vertices + 1);
    offsets.push(0);
    let mut neighbors = Vec::with_capacity(buf.len() / 2);
    for v in 0..num_vertices {
        let row = &mut buf[start[v]..fill[v]];
        row.sort_unstable();
        let mut last = None;
        for &b in row.iter() {
            if b as usize != v && last != Some(b) {
                neighbors.push(b);
                last = Some(b);
            }
        }
        offsets.push(neighbors.len());
    }
    Adjacency { offsets, neighbors }
}

/// The unique undirected edges of a simplex mesh (`K` corners per element,
/// every pair of corners an edge): `[a, b]` with `a < b`, sorted
/// lexicographically. Pairs of equal corners are skipped.
pub fn edges<const K: usize>(elements: &[[u32; K]]) -> Vec<[u32; 2]> {
    let mut out = Vec::with_capacity(elements.len() * K * (K - 1) / 2);
    for el in elements {
        for i in 0..K {
            for j in i + 1..K {
                let (a, b) = (el[i], el[j]);
                if a != b {
                    out.push([a.min(b), a.max(b)]);
                }
            }
        }
    }
    sort_dedup_pairs(&mut out);
    out
}

/// Sorts `pairs` lexicographically and removes repeats, in `O(n + m)` for
/// `m` the largest first entry ([`bucket_sort`] by the first entry). Same
/// result as `sort_unstable(); dedup()`.
pub fn sort_dedup_pairs(pairs: &mut Vec<[u32; 2]>) {
    bucket_sort(pairs, |p| p[0]);
    pairs.dedup();
}

/// Sorts `items` (ascending, as `sort_unstable`) when `key` is the leading
/// part of their order (`key(a) < key(b)` implies `a < b`), such as a
/// vertex index first in a tuple: a counting sort by `key` into buckets,
/// then each bucket sorted in place (mesh items have a handful per
/// vertex). `O(n + m)` for `m` the largest key; falls back to
/// `sort_unstable` when the keys are sparse (`m > 4 n + 1024`) or `n < 64`.
pub fn bucket_sort<T: Ord + Copy>(items: &mut [T], key: impl Fn(&T) -> u32) {
    let n = items.len();
    let m = items.iter().map(|t| key(t) as usize + 1).max().unwrap_or(0);
    if n < 64 || m > 4 * n + 1024 {
        items.sort_unstable();
        return;
    }
    let mut start = vec![0usize; m + 1];
    for t in items.iter() {
        start[key(t) as usize + 1] += 1;
    }
    for k in 0..m {
        start[k + 1] += start[k];
    }
    let mut next = start.clone();
    let mut sorted: Vec<T> = Vec::with_capacity(n);
    // Fill with a placeholder, then place each item at its bucket slot.
    sorted.resize(n, items[0]);
    for t in items.iter() {
        let k = key(t) as usize;
        sorted[next[k]] = *t;
        next[k] += 1;
    }
    for k in 0..m {
        sorted[start[k]..start[k + 1]].sort_unstable();
    }
    items.copy_from_slice(&sorted);
}

/// The vertices at most `k` edges away from `v`, excluding `v` itself
/// (breadth-first search). The result is ordered by ring (hop distance
/// `1, 2, ..., k`) and, within a ring, by vertex index. `k = 0` gives an
/// empty list.
///
/// # Panics
/// If `v >= adj.num_vertices()`.
pub fn k_ring(adj: &Adjacency, v: u32, k: usize) -> Vec<u32> {
    assert!(
        (v as usize) < adj.num_vertices(),
        "k_ring: vertex {v} out of range"
    );
    let mut seen = std::collections::HashSet::new();
    seen.insert(v);
    let mut out = Vec::new();
    let mut ring = vec![v];
    for _ in 0..k {
        let mut next = Vec::new();
        for &u in &ring {
            for &w in adj.neighbors(u as usize) {
                if seen.insert(w) {
                    next.push(w);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        next.sort_unstable();
        out.extend_from_slice(&next);
        ring = next;
    }
    out
}

/// The boundary surface of a tet mesh, see [`tet_boundary`].
#[derive(Debug, Clone, PartialEq)]
pub struct TetBoundary {
    /// The boundary triangles (outward normals) on compacted vertices, with
    /// the volume's point data restricted to them and the volume's cell data
    /// copied from each face's tet.
    pub surface: TriMesh,
    /// Surface vertex `i` is volume vertex `to_volume[i]` (ascending).
    pub to_volume: Vec<u32>,
    /// Surface triangle `f` is a face of tet `face_tet[f]`.
    pub face_tet: Vec<u32>,
}

/// The boundary of a tet mesh: every face used by exactly one tet.
///
/// Each face is oriented outward: its counter-clockwise normal points away
/// from the tet's vertex `d` opposite it, i.e. `tet_signed_volume(p, q, r, d) < 0`
/// for the face `(p, q, r)`. For a positive tet `[a, b, c, d]` these are
/// `(b, c, d)`, `(a, d, c)`, `(a, b, d)`, `(a, c, b)`; for a tet with
/// negative signed volume each face is reversed, so inverted tets give
/// outward faces too (a tet with zero volume keeps the index-based order).
///
/// Faces are listed by tet index, then by the corner they are opposite to.
/// Surface vertices are the volume vertices the faces use, in ascending order
/// (`to_volume`); the volume's point data is restricted to them
/// ([`crate::Fields::select`]) and its cell data is copied from each face's
/// tet (`face_tet`).
///
/// # Errors
/// [`MeshError::IndexOutOfRange`], [`MeshError::FieldLength`] for invalid
/// input, [`MeshError::NonManifoldFace`] (the smallest such face) when a face
/// is shared by more than two tets.
pub fn tet_boundary(mesh: &TetMesh) -> Result<TetBoundary, MeshError> {
    crate::geometry::check_indices(mesh.positions.len(), &mesh.tets)?;
    mesh.point_data.check_tuples(mesh.positions.len())?;
    mesh.cell_data.check_tuples(mesh.tets.len())?;

    // Outward faces of a positive tet [a, b, c, d], opposite a, b, c, d.
    const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
    // (sorted face, tet, local face)
    let mut all: Vec<([u32; 3], u32, u8)> = Vec::with_capacity(mesh.tets.len() * 4);
    for (t, tet) in mesh.tets.iter().enumerate() {
        for (f, idx) in FACES.iter().enumerate() {
            let mut key = [tet[idx[0]], tet[idx[1]], tet[idx[2]]];
            key.sort_unstable();
            all.push((key, t as u32, f as u8));
        }
    }
    all.sort_unstable();
    let mut boundary: Vec<(u32, u8)> = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let mut j = i + 1;
        while j < all.len() && all[j].0 == all[i].0 {
            j += 1;
        }
        match j - i {
            1 => boundary.push((all[i].1, all[i].2)),
            2 => {}
            n => {
                return Err(MeshError::NonManifoldFace {
                    face: all[i].0,
                    tets: n,
                });
            }
        }
        i = j;
    }
    boundary.sort_unstable();

    let mut triangles = Vec::with_capacity(boundary.len());
    let mut face_tet = Vec::with_capacity(boundary.len());
    for &(t, f) in &boundary {
        let tet = mesh.tets[t as usize];
        let [a, b, c, d] = mesh.tet_points(t as usize);
        let idx = FACES[f as usize];
        let mut tri = [tet[idx[0]], tet[idx[1]], tet[idx[2]]];
        if tet_signed_volume(&a, &b, &c, &d) < 0.0 {
            tri.swap(1, 2);
        }
        triangles.push(tri);
        face_tet.push(t);
    }
    let compact = crate::reindex::compact_vertices(&mesh.positions, &mesh.point_data, &triangles)?;
    let rows: Vec<usize> = face_tet.iter().map(|&t| t as usize).collect();
    Ok(TetBoundary {
        surface: TriMesh {
            positions: compact.positions,
            triangles: compact.elements,
            point_data: compact.point_data,
            cell_data: mesh.cell_data.select(&rows),
        },
        to_volume: compact.to_old,
        face_tet,
    })
}

/// The boundary of a triangle mesh as closed vertex loops.
///
/// A boundary edge is an edge used by exactly one triangle; it is taken in
/// the direction its triangle traverses it, so for a counter-clockwise disk
/// seen from its normal side the loop is counter-clockwise (and the inner
/// loops of an annulus are clockwise). Each loop lists its vertices once
/// (the closing edge back to the first vertex is implied) and starts at its
/// smallest vertex index. Loops are ordered longest first, ties by their
/// first vertex. A closed surface has no loops.
///
/// # Errors
/// [`MeshError::InvalidArgument`] when a vertex has several outgoing boundary
/// edges (a non-manifold "bow-tie" vertex where two loops touch) or when the
/// boundary edges do not chain into closed loops (inconsistently oriented
/// triangles along the boundary).
pub fn boundary_loops(mesh: &TriMesh) -> Result<Vec<Vec<u32>>, MeshError> {
    // (undirected key, directed edge)
    let mut all: Vec<([u32; 2], [u32; 2])> = Vec::with_capacity(mesh.triangles.len() * 3);
    for t in &mesh.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            if a != b {
                all.push(([a.min(b), a.max(b)], [a, b]));
            }
        }
    }
    bucket_sort(&mut all, |e| e.0[0]);
    let mut bnd: Vec<[u32; 2]> = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let mut j = i + 1;
        while j < all.len() && all[j].0 == all[i].0 {
            j += 1;
        }
        if j - i == 1 {
            bnd.push(all[i].1);
        }
        i = j;
    }
    if bnd.is_empty() {
        return Ok(Vec::new());
    }
    bucket_sort(&mut bnd, |e| e[0]);
    for w in bnd.windows(2) {
        if w[0][0] == w[1][0] {
            let v = w[0][0];
            let n = bnd.iter().filter(|e| e[0] == v).count();
            return Err(MeshError::InvalidArgument(format!(
                "boundary vertex {v} has {n} outgoing boundary edges (non-manifold vertex)"
            )));
        }
    }
    // bnd is sorted by start vertex and starts are unique: binary search.
    let next_of = |v: u32| -> Option<usize> { bnd.binary_search_by(|e| e[0].cmp(&v)).ok() };
    let mut used = vec![false; bnd.len()];
    let mut loops = Vec::new();
    for s in 0..bnd.len() {
        if used[s] {
            continue;
        }
        let first = bnd[s][0];
        let mut lp = vec![first];
        let mut e = s;
        loop {
            used[e] = true;
            let to = bnd[e][1];
            if to == first {
                break;
            }
            match next_of(to) {
                Some(n) if !used[n] => {
                    lp.push(to);
                    e = n;
                }
                _ => {
                    return Err(MeshError::InvalidArgument(format!(
                        "boundary edges do not form closed loops at vertex {to} \
                         (inconsistent triangle orientation along the boundary?)"
                    )));
                }
            }
        }
        loops.push(lp);
    }
    loops.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
    Ok(loops)
}

/// Connected components of a simplex mesh (elements sharing a vertex are
/// connected), see [`connected_components`].
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Components {
    /// Number of components (of elements; unused vertices form none).
    pub count: usize,
    /// Component of each vertex; `u32::MAX` for vertices used by no element.
    pub vertex_label: Vec<u32>,
    /// Component of each element.
    pub element_label: Vec<u32>,
    /// Number of elements in each component.
    pub element_counts: Vec<usize>,
}

/// Connected components through shared vertices, by union–find
/// ([`petgraph::unionfind::UnionFind`]). Labels are numbered in the order of
/// each component's first element: element 0 is in component 0, the first
/// element not in component 0 is in component 1, and so on.
///
/// # Panics
/// If an element refers to a vertex `>= num_vertices`.
pub fn connected_components<const K: usize>(
    num_vertices: usize,
    elements: &[[u32; K]],
) -> Components {
    let mut uf = UnionFind::<u32>::new(num_vertices);
    let mut used = vec![false; num_vertices];
    for el in elements {
        for &v in el {
            used[v as usize] = true;
        }
        for w in el.windows(2) {
            uf.union(w[0], w[1]);
        }
    }
    let root = uf.into_labeling();
    let mut label_of_root = vec![u32::MAX; num_vertices];
    let mut element_label = Vec::with_capacity(elements.len());
    let mut element_counts = Vec::new();
    for el in elements {
        let Some(&v) = el.first() else {
            element_label.push(u32::MAX);
            continue;
        };
        let r = root[v as usize] as usize;
        if label_of_root[r] == u32::MAX {
            label_of_root[r] = element_counts.len() as u32;
            element_counts.push(0);
        }
        let l = label_of_root[r];
        element_counts[l as usize] += 1;
        element_label.push(l);
    }
    let vertex_label = (0..num_vertices)
        .map(|v| {
            if used[v] {
                label_of_root[root[v] as usize]
            } else {
                u32::MAX
            }
        })
        .collect();
    Components {
        count: element_counts.len(),
        vertex_label,
        element_label,
        element_counts,
    }
}

/// The Euler characteristic `χ = V - E + F` of a triangle mesh, counting only
/// the vertices used by some triangle (`V`), the unique edges (`E`, see
/// [`edges`]) and the triangles (`F`). A closed orientable surface of genus
/// `g` has `χ = 2 - 2g`; a disk has `χ = 1`.
pub fn euler_characteristic(mesh: &TriMesh) -> i64 {
    let mut used = vec![false; mesh.positions.len()];
    let mut extra = Vec::new();
    for &v in mesh.triangles.iter().flatten() {
        match used.get_mut(v as usize) {
            Some(u) => *u = true,
            // Out of range (an invalid mesh): counted apart.
            None => extra.push(v),
        }
    }
    extra.sort_unstable();
    extra.dedup();
    let nv = used.iter().filter(|&&u| u).count() + extra.len();
    nv as i64 - edges(&mesh.triangles).len() as i64 + mesh.triangles.len() as i64
}

/// Breadth-first hop distance from `v` (`usize::MAX` where unreachable).
/// The boundary loop of a disk-topology triangle mesh: the mesh must be
/// connected, have exactly one boundary loop and Euler characteristic
/// `V - E + F = 1`.
///
/// # Errors
/// [`MeshError::Empty`] without triangles, [`MeshError::IndexOutOfRange`],
/// [`MeshError::MultipleComponents`], [`MeshError::ClosedSurface`],
/// [`MeshError::BoundaryLoops`], [`MeshError::NotADisk`] (handles), or the
/// error of [`boundary_loops`] (a non-manifold boundary).
pub fn disk_boundary_loop(mesh: &TriMesh) -> Result<Vec<u32>, MeshError> {
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty { what: "triangles" });
    }
    crate::geometry::check_indices(mesh.num_vertices(), &mesh.triangles)?;
    let components = connected_components(mesh.num_vertices(), &mesh.triangles);
    if components.count != 1 {
        return Err(MeshError::MultipleComponents {
            count: components.count,
        });
    }
    let mut loops = boundary_loops(mesh)?;
    match loops.len() {
        0 => return Err(MeshError::ClosedSurface),
        1 => {}
        _ => {
            return Err(MeshError::BoundaryLoops {
                lengths: loops.iter().map(Vec::len).collect(),
            });
        }
    }
    let euler = euler_characteristic(mesh);
    if euler != 1 {
        return Err(MeshError::NotADisk { euler });
    }
    Ok(loops.swap_remove(0))
}

#[cfg(test)]
pub(crate) fn hop_distances(adj: &Adjacency, v: u32) -> Vec<usize> {
    let mut d = vec![usize::MAX; adj.num_vertices()];
    d[v as usize] = 0;
    let mut q = std::collections::VecDeque::from([v]);
    while let Some(u) = q.pop_front() {
        for &w in adj.neighbors(u as usize) {
            if d[w as usize] == usize::MAX {
                d[w as usize] = d[u as usize] + 1;
                q.push_back(w);
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::*;
    use crate::{Field, geometry::tet_signed_volume};
    use proptest::prelude::*;

    /// Number of triangles per undirected edge, and whether each pair of
    /// triangles sharing an edge traverses it in opposite directions.
    fn edge_face_counts(m: &TriMesh) -> std::collections::HashMap<[u32; 2], (usize, i32)> {
        let mut h = std::collections::HashMap::new();
        for t in &m.triangles {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let e = h.entry([a.min(b), a.max(b)]).or_insert((0, 0));
                e.0 += 1;
                e.1 += if a < b { 1 } else { -1 };
            }
        }
        h
    }

    fn random_grid(n: [usize; 3], five: bool, seed: u64, two: bool, flip_p: f64) -> TetMesh {
        let mut rng = SplitMix(seed);
        let mut m = tet_grid(n, five, [0.0; 3]);
        if two {
            let n2 = [n[2], n[0], n[1]];
            m = merge_tets(&m, &tet_grid(n2, !five, [20.0, 1.0, -3.0]));
        }
        for p in &mut m.positions {
            p.x += rng.sym(0.1);
            p.y += rng.sym(0.1);
            p.z += rng.sym(0.1);
        }
        for t in &mut m.tets {
            if rng.coin(flip_p) {
                t.swap(0, 1);
            }
        }
        m
    }

    #[test]
    fn tet_grid_is_conforming_and_positive_after_orient() {
        for five in [false, true] {
            let m = tet_grid([2, 3, 2], five, [0.0; 3]);
            let vol: f64 = (0..m.num_tets())
                .map(|t| {
                    let [a, b, c, d] = m.tet_points(t);
                    tet_signed_volume(&a, &b, &c, &d).abs()
                })
                .sum();
            assert!((vol - 12.0).abs() < 1e-9);
            let b = tet_boundary(&m).unwrap();
            // 2 (2·3 + 3·2 + 2·2) squares, 2 triangles each.
            assert_eq!(b.surface.num_triangles(), 2 * 2 * (6 + 6 + 4));
        }
    }

    proptest! {
        /// The counting sort equals `sort_unstable` + `dedup`, dense (mesh
        /// edges) or sparse (the comparison-sort fallback) first entries.
        #[test]
        fn sort_dedup_pairs_matches_sort_and_dedup(
            raw in prop::collection::vec((0u32..300, 0u32..300), 0..2000),
            sparse in any::<bool>(),
        ) {
            let mut pairs: Vec<[u32; 2]> = raw
                .iter()
                .map(|&(a, b)| [if sparse { a.wrapping_mul(9_999_991) } else { a }, b])
                .collect();
            let mut expect = pairs.clone();
            expect.sort_unstable();
            expect.dedup();
            sort_dedup_pairs(&mut pairs);
            prop_assert_eq!(pairs, expect);
        }

        /// The bucket sort equals `sort_unstable` on tuples led by the key.
        #[test]
        fn bucket_sort_matches_sort_unstable(
            raw in prop::collection::vec((0u32..200, 0u32..5, any::<bool>()), 0..1500),
            sparse in any::<bool>(),
        ) {
            let mut items: Vec<(u32, u32, bool)> = raw
                .iter()
                .map(|&(a, b, c)| (if sparse { a.wrapping_mul(9_999_991) } else { a }, b, c))
                .collect();
            let mut expect = items.clone();
            expect.sort_unstable();
            bucket_sort(&mut items, |t| t.0);
            prop_assert_eq!(items, expect);
        }

        /// The Euler characteristic counts used vertices, edges and faces.
        #[test]
        fn euler_characteristic_counts_used_vertices(
            tris in prop::collection::vec((0u32..40, 0u32..40, 0u32..40), 1..60),
        ) {
            let triangles: Vec<[u32; 3]> = tris.iter().map(|&(a, b, c)| [a, b, c]).collect();
            let mesh = TriMesh::new(vec![nalgebra::Point3::origin(); 30], triangles.clone());
            let mut used: Vec<u32> = triangles.iter().flatten().copied().collect();
            used.sort_unstable();
            used.dedup();
            let expect = used.len() as i64 - edges(&triangles).len() as i64 + triangles.len() as i64;
            prop_assert_eq!(euler_characteristic(&mesh), expect);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn tet_boundary_is_closed_manifold_and_outward(
            nx in 1usize..4, ny in 1usize..4, nz in 1usize..4,
            five: bool, two: bool, seed: u64, flip in 0.0f64..0.6,
        ) {
            let mut m = random_grid([nx, ny, nz], five, seed, two, flip);
            let ids: Vec<f64> = (0..m.num_vertices()).map(|v| v as f64).collect();
            m.add_point_field(Field::scalars("id", ids)).unwrap();
            let tet_ids: Vec<i32> = (0..m.num_tets() as i32).collect();
            m.add_cell_field(Field::labels("tet", tet_ids)).unwrap();
            let b = tet_boundary(&m).unwrap();
            let s = &b.surface;
            // Closed, manifold and consistently oriented.
            for (e, (n, dir)) in edge_face_counts(s) {
                prop_assert_eq!(n, 2, "edge {:?}", e);
                prop_assert_eq!(dir, 0, "edge {:?}", e);
            }
            // Outward: enclosed volume equals the tet volume sum.
            let vol: f64 = (0..m.num_tets())
                .map(|t| {
                    let [a, b, c, d] = m.tet_points(t);
                    tet_signed_volume(&a, &b, &c, &d).abs()
                })
                .sum();
            let enclosed = enclosed_volume(s);
            prop_assert!(enclosed > 0.0);
            prop_assert!((enclosed - vol).abs() < 1e-9 * vol.max(1.0), "{} vs {}", enclosed, vol);
            // Each face is outward with respect to its own tet.
            for (f, tri) in s.triangles.iter().enumerate() {
                let t = m.tets[b.face_tet[f] as usize];
                let fv = tri.map(|v| b.to_volume[v as usize]);
                let d = *t.iter().find(|v| !fv.contains(v)).unwrap();
                let [p, q, r] = fv.map(|v| m.positions[v as usize]);
                prop_assert!(tet_signed_volume(&p, &q, &r, &m.positions[d as usize]) < 0.0);
            }
            let comps = if two { 2 } else { 1 };
            prop_assert_eq!(euler_characteristic(s), 2 * comps);
            prop_assert_eq!(connected_components(s.num_vertices(), &s.triangles).count, comps as usize);
            prop_assert!(boundary_loops(s).unwrap().is_empty());
            // Point data follows the vertices, cell data the faces' tets.
            let id = s.point_data.get("id").unwrap();
            for (i, &v) in b.to_volume.iter().enumerate() {
                prop_assert_eq!(id.get(i, 0), Some(v as f64));
                prop_assert_eq!(s.positions[i], m.positions[v as usize]);
            }
            let tet = s.cell_data.get("tet").unwrap();
            for (f, &t) in b.face_tet.iter().enumerate() {
                prop_assert_eq!(tet.get(f, 0), Some(t as f64));
            }
        }

        #[test]
        fn k_ring_matches_bfs(seed: u64, n in 2usize..30, ntri in 1usize..40, k in 0usize..5) {
            let mut rng = SplitMix(seed);
            let tris: Vec<[u32; 3]> = (0..ntri)
                .map(|_| [rng.below(n) as u32, rng.below(n) as u32, rng.below(n) as u32])
                .collect();
            let adj = vertex_adjacency(n, &tris);
            let v = rng.below(n) as u32;
            let d = hop_distances(&adj, v);
            let mut expect: Vec<(usize, u32)> = (0..n as u32)
                .filter(|&w| w != v && d[w as usize] <= k)
                .map(|w| (d[w as usize], w))
                .collect();
            expect.sort_unstable();
            let expect: Vec<u32> = expect.into_iter().map(|(_, w)| w).collect();
            prop_assert_eq!(k_ring(&adj, v, k), expect);
        }

        #[test]
        fn adjacency_matches_edges(seed: u64, n in 1usize..30, ntet in 0usize..30) {
            let mut rng = SplitMix(seed);
            let tets: Vec<[u32; 4]> = (0..ntet)
                .map(|_| [0; 4].map(|_: u32| rng.below(n) as u32))
                .collect();
            let adj = vertex_adjacency(n, &tets);
            prop_assert_eq!(adj.num_vertices(), n);
            let es = edges(&tets);
            let mut from_adj = Vec::new();
            for v in 0..n {
                let row = adj.neighbors(v);
                prop_assert!(row.windows(2).all(|w| w[0] < w[1]));
                prop_assert!(!row.contains(&(v as u32)));
                for &w in row {
                    prop_assert!(adj.neighbors(w as usize).contains(&(v as u32)));
                    if (v as u32) < w {
                        from_adj.push([v as u32, w]);
                    }
                }
            }
            prop_assert_eq!(from_adj, es);
        }
    }

    #[test]
    fn adjacency_edges_and_k_ring_of_a_strip() {
        // 0-1-2
        // |/|/|
        // 3-4-5
        let tris = [[0, 3, 1], [1, 3, 4], [1, 4, 2], [2, 4, 5]];
        let adj = vertex_adjacency(7, &tris);
        assert_eq!(adj.neighbors(1), &[0, 2, 3, 4]);
        assert_eq!(adj.neighbors(6), &[] as &[u32]);
        assert_eq!(adj.degree(4), 4);
        assert_eq!(
            edges(&tris),
            vec![
                [0, 1],
                [0, 3],
                [1, 2],
                [1, 3],
                [1, 4],
                [2, 4],
                [2, 5],
                [3, 4],
                [4, 5]
            ]
        );
        assert_eq!(k_ring(&adj, 0, 1), vec![1, 3]);
        assert_eq!(k_ring(&adj, 0, 2), vec![1, 3, 2, 4]);
        assert_eq!(k_ring(&adj, 0, 9), vec![1, 3, 2, 4, 5]);
        assert_eq!(k_ring(&adj, 6, 3), Vec::<u32>::new());
    }

    fn signed_area_2d(m: &TriMesh, lp: &[u32]) -> f64 {
        let mut a = 0.0;
        for i in 0..lp.len() {
            let p = m.positions[lp[i] as usize];
            let q = m.positions[lp[(i + 1) % lp.len()] as usize];
            a += p.x * q.y - q.x * p.y;
        }
        a / 2.0
    }

    #[test]
    fn boundary_loop_of_a_disk_is_one_ccw_loop() {
        let m = grid_disk(4, 3);
        let loops = boundary_loops(&m).unwrap();
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].len(), 2 * (4 + 3));
        assert_eq!(loops[0][..3], [0, 1, 2]);
        assert!((signed_area_2d(&m, &loops[0]) - 12.0).abs() < 1e-12);
        assert_eq!(euler_characteristic(&m), 1);
        // Flipping every triangle reverses the loop.
        let mut r = m.clone();
        for t in &mut r.triangles {
            t.swap(1, 2);
        }
        let loops = boundary_loops(&r).unwrap();
        assert!((signed_area_2d(&r, &loops[0]) + 12.0).abs() < 1e-12);
    }

    #[test]
    fn boundary_loops_of_an_annulus_and_a_closed_mesh() {
        let m = annulus(2, 12);
        let loops = boundary_loops(&m).unwrap();
        assert_eq!(loops.len(), 2);
        assert_eq!(loops[0].len(), 12);
        assert_eq!(loops[1].len(), 12);
        // Outer loop (radius 3) ccw, inner loop (radius 1) cw.
        let areas: Vec<f64> = loops.iter().map(|l| signed_area_2d(&m, l)).collect();
        assert!(areas.iter().any(|&a| a > 20.0), "{areas:?}");
        assert!(areas.iter().any(|&a| a < 0.0 && a > -4.0), "{areas:?}");
        assert_eq!(euler_characteristic(&m), 0);

        let s = uv_sphere(6, 8, 1.0);
        assert!(boundary_loops(&s).unwrap().is_empty());
        assert_eq!(euler_characteristic(&s), 2);
        assert!(enclosed_volume(&s) > 0.0);
    }

    #[test]
    fn boundary_loops_longest_first_and_bow_tie_error() {
        // A big disk and, separately, a single triangle.
        let mut m = grid_disk(2, 2);
        let n = m.num_vertices() as u32;
        m.positions.extend([
            nalgebra::Point3::new(9.0, 0.0, 0.0),
            nalgebra::Point3::new(10.0, 0.0, 0.0),
            nalgebra::Point3::new(9.0, 1.0, 0.0),
        ]);
        m.triangles.insert(0, [n, n + 1, n + 2]);
        let loops = boundary_loops(&m).unwrap();
        assert_eq!(loops.len(), 2);
        assert_eq!(loops[0].len(), 8);
        assert_eq!(loops[1], vec![n, n + 1, n + 2]);

        // Two triangles touching at vertex 0.
        let p = nalgebra::Point3::origin();
        let bow = TriMesh::new(vec![p; 5], vec![[0, 1, 2], [0, 3, 4]]);
        assert!(matches!(
            boundary_loops(&bow),
            Err(MeshError::InvalidArgument(_))
        ));
        // Two triangles traversing their shared edge the same way.
        let bad = TriMesh::new(vec![p; 4], vec![[0, 1, 2], [0, 1, 3]]);
        assert!(boundary_loops(&bad).is_err());
    }

    #[test]
    fn components_are_labelled_by_first_element() {
        let tris = [[5, 6, 7], [0, 1, 2], [2, 3, 4], [7, 8, 5]];
        let c = connected_components(10, &tris);
        assert_eq!(c.count, 2);
        assert_eq!(c.element_label, vec![0, 1, 1, 0]);
        assert_eq!(c.element_counts, vec![2, 2]);
        assert_eq!(c.vertex_label[9], u32::MAX);
        assert_eq!(c.vertex_label[4], 1);
        assert_eq!(c.vertex_label[8], 0);
        let empty = connected_components::<3>(3, &[]);
        assert_eq!(empty.count, 0);
        assert_eq!(empty.vertex_label, vec![u32::MAX; 3]);
    }

    #[test]
    fn non_manifold_face_is_an_error() {
        let p = nalgebra::Point3::new;
        let m = TetMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.0, 1.0, 0.0),
                p(0.0, 0.0, 1.0),
                p(0.0, 0.0, -1.0),
                p(1.0, 1.0, 1.0),
            ],
            vec![[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]],
        );
        assert_eq!(
            tet_boundary(&m),
            Err(MeshError::NonManifoldFace {
                face: [0, 1, 2],
                tets: 3
            })
        );
        let single = TetMesh::new(m.positions.clone(), vec![[0, 2, 1, 3]]);
        let b = tet_boundary(&single).unwrap();
        assert_eq!(b.to_volume, vec![0, 1, 2, 3]);
        assert_eq!(b.surface.num_triangles(), 4);
        assert!(enclosed_volume(&b.surface) > 0.0);
        let out_of_range = TetMesh::new(m.positions.clone(), vec![[0, 1, 2, 9]]);
        assert!(matches!(
            tet_boundary(&out_of_range),
            Err(MeshError::IndexOutOfRange { index: 9, .. })
        ));
    }
}
