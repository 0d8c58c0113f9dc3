//! Repair: orientation, duplicate / degenerate-index element removal, unused
//! vertex removal and largest-component extraction, with point data and cell
//! data carried along.

/// Kept here for the `repair::compact_vertices` path; the code lives in
/// [`crate::reindex`].
pub use crate::reindex::{Compacted, compact_vertices};
use crate::{
    Fields, MeshError, TetMesh, TriMesh,
    geometry::{check_finite, check_indices, tet_signed_volume},
    topology::connected_components,
};
use nalgebra::Point3;
use serde::Serialize;
use std::borrow::Cow;
use std::collections::{HashSet, VecDeque};
use std::fmt;

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

    /// The connected component (through shared vertices) with the most
    /// tets (the first such on ties), compacted: cell data of its tets and
    /// point data of its vertices are carried over. The returned `Vec` maps
    /// new vertex -> old vertex. An empty mesh gives an empty mesh.
    ///
    /// Fails when an element refers to a vertex that does not exist or a
    /// field's length does not fit the mesh.
    pub fn largest_component(&self) -> Result<(TetMesh, Vec<u32>), MeshError> {
        crate::geometry::check_indices(self.positions.len(), &self.tets)?;
        self.cell_data.check_tuples(self.tets.len())?;
        let rows = largest(&self.tets, self.positions.len());
        let tets: Vec<[u32; 4]> = rows.iter().map(|&t| self.tets[t]).collect();
        let k = compact_vertices(&self.positions, &self.point_data, &tets)?;
        Ok((
            TetMesh {
                positions: k.positions,
                tets: k.elements,
                point_data: k.point_data,
                cell_data: self.cell_data.select(&rows),
            },
            k.to_old,
        ))
    }
}

impl TriMesh {
    /// The connected component (through shared vertices) with the most
    /// triangles (the first such on ties), compacted: cell data of its
    /// triangles and point data of its vertices are carried over. The
    /// returned `Vec` maps new vertex -> old vertex. An empty mesh gives an
    /// empty mesh.
    ///
    /// Fails when an element refers to a vertex that does not exist or a
    /// field's length does not fit the mesh.
    pub fn largest_component(&self) -> Result<(TriMesh, Vec<u32>), MeshError> {
        crate::geometry::check_indices(self.positions.len(), &self.triangles)?;
        self.cell_data.check_tuples(self.triangles.len())?;
        let rows = largest(&self.triangles, self.positions.len());
        let tris: Vec<[u32; 3]> = rows.iter().map(|&t| self.triangles[t]).collect();
        let k = compact_vertices(&self.positions, &self.point_data, &tris)?;
        Ok((
            TriMesh {
                positions: k.positions,
                triangles: k.elements,
                point_data: k.point_data,
                cell_data: self.cell_data.select(&rows),
            },
            k.to_old,
        ))
    }
}

/// Element rows of the largest component (the first on ties).
fn largest<const K: usize>(elements: &[[u32; K]], n: usize) -> Vec<usize> {
    let c = connected_components(n, elements);
    let Some(best) = (0..c.count).max_by(|&a, &b| {
        c.element_counts[a]
            .cmp(&c.element_counts[b])
            .then(b.cmp(&a))
    }) else {
        return Vec::new();
    };
    (0..elements.len())
        .filter(|&e| c.element_label[e] == best as u32)
        .collect()
}

/// How a repair welds coincident vertices ([`crate::weld`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Weld {
    /// No welding ([`repair_tri_mesh`] and [`repair_tet_mesh`]).
    #[default]
    Off,
    /// Within [`crate::weld::RELATIVE_TOLERANCE`] times the mean edge length.
    Relative,
    /// Within this distance, mm (0: exactly equal positions only).
    Within(f64),
}

/// Settings of [`repair_tri_mesh_with`] and [`repair_tet_mesh_with`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RepairOptions {
    /// Welding of coincident vertices, before anything else.
    pub weld: Weld,
}

/// What [`repair_tri_mesh`] / [`repair_tet_mesh`] changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct RepairReport {
    /// Vertices merged into a coincident one (welding).
    pub welded_vertices: usize,
    /// Elements removed because an earlier element has the same vertex set.
    pub duplicate_elements: usize,
    /// Elements removed because they use a vertex more than once.
    pub repeated_vertex_elements: usize,
    /// Vertices removed because no (remaining) element uses them.
    pub unused_vertices: usize,
    /// Elements whose orientation was reversed.
    pub flipped: usize,
    /// Connected components of the repaired mesh.
    pub components: usize,
    /// Edge-connected patches that cannot be oriented consistently (Möbius
    /// strips, Klein bottles); always 0 for tet meshes.
    pub non_orientable_components: usize,
}

impl RepairReport {
    /// True when the repair changed nothing.
    pub fn is_clean(&self) -> bool {
        self.welded_vertices == 0
            && self.duplicate_elements == 0
            && self.repeated_vertex_elements == 0
            && self.unused_vertices == 0
            && self.flipped == 0
    }
}

impl fmt::Display for RepairReport {
    /// One line, e.g. `removed 2 duplicate elements, 1 unused vertex;
    /// flipped 3 elements; 1 component`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn n(count: usize, one: &str, many: &str) -> String {
            format!("{count} {}", if count == 1 { one } else { many })
        }
        let mut removed = Vec::new();
        if self.welded_vertices > 0 {
            removed.push(format!(
                "{} (welded)",
                n(
                    self.welded_vertices,
                    "coincident vertex",
                    "coincident vertices"
                )
            ));
        }
        if self.duplicate_elements > 0 {
            removed.push(n(
                self.duplicate_elements,
                "duplicate element",
                "duplicate elements",
            ));
        }
        if self.repeated_vertex_elements > 0 {
            removed.push(n(
                self.repeated_vertex_elements,
                "element with a repeated vertex",
                "elements with a repeated vertex",
            ));
        }
        if self.unused_vertices > 0 {
            removed.push(n(self.unused_vertices, "unused vertex", "unused vertices"));
        }
        let mut parts = Vec::new();
        if !removed.is_empty() {
            parts.push(format!("removed {}", removed.join(", ")));
        }
        if self.flipped > 0 {
            parts.push(format!(
                "flipped {}",
                n(self.flipped, "element", "elements")
            ));
        }
        if parts.is_empty() {
            parts.push("nothing to repair".into());
        }
        parts.push(n(self.components, "component", "components"));
        if self.non_orientable_components > 0 {
            parts.push(format!("{} non-orientable", self.non_orientable_components));
        }
        write!(f, "{}", parts.join("; "))
    }
}

/// Checks indices, coordinates and field lengths before a repair.
fn check_input<const K: usize>(
    positions: &[Point3<f64>],
    elements: &[[u32; K]],
    point_data: &Fields,
    cell_data: &Fields,
) -> Result<(), MeshError> {
    check_indices(positions.len(), elements)?;
    check_finite(positions)?;
    point_data.check_tuples(positions.len())?;
    cell_data.check_tuples(elements.len())
}

/// The rows of the elements to keep: no repeated vertex, and no earlier
/// element with the same vertex set. Returns (rows, repeated, duplicates).
fn keep_rows<const K: usize>(elements: &[[u32; K]]) -> (Vec<usize>, usize, usize) {
    let mut seen = HashSet::with_capacity(elements.len());
    let (mut repeated, mut dups) = (0, 0);
    let mut rows = Vec::with_capacity(elements.len());
    for (e, el) in elements.iter().enumerate() {
        let mut key = *el;
        key.sort_unstable();
        if key.windows(2).any(|w| w[0] == w[1]) {
            repeated += 1;
        } else if !seen.insert(key) {
            dups += 1;
        } else {
            rows.push(e);
        }
    }
    (rows, repeated, dups)
}

/// Repairs a triangle mesh:
///
/// 1. drops triangles that use a vertex twice, and triangles whose vertex
///    set (in any order) equals that of an earlier triangle (the first is
///    kept);
/// 2. orients every *patch* (triangles connected through manifold edges,
///    i.e. edges with exactly two triangles) consistently: breadth-first from
///    the patch's first triangle, which keeps its orientation, flipping
///    `[a, b, c] -> [a, c, b]` each neighbour that traverses the shared edge
///    in the same direction. A patch where this meets a contradiction is
///    non-orientable and counted in `non_orientable_components` (its
///    triangles keep whatever the search gave them). A closed orientable
///    patch (all its edges manifold) is then flipped as a whole if its
///    enclosed signed volume `Σ (a-o)·((b-o)×(c-o)) / 6` is negative, so its
///    normals point outward;
/// 3. removes unused vertices ([`compact_vertices`]), carrying point data
///    and the cell data of the kept triangles.
///
/// `flipped` counts the triangles whose final orientation differs from the
/// input; `components` is the number of vertex-connected components of the
/// result.
///
/// # Errors
/// [`MeshError::IndexOutOfRange`], [`MeshError::NonFiniteCoordinate`], and
/// [`MeshError::FieldLength`] when a field does not match its mesh.
pub fn repair_tri_mesh(mesh: &TriMesh) -> Result<(TriMesh, RepairReport), MeshError> {
    repair_tri_mesh_with(mesh, &RepairOptions::default())
}

/// A mesh's vertices after welding, with its elements renumbered.
struct WeldedMesh<'a, const K: usize> {
    positions: Cow<'a, [Point3<f64>]>,
    point_data: Cow<'a, Fields>,
    elements: Cow<'a, [[u32; K]]>,
    /// Vertices merged away.
    merged: usize,
}

/// The vertices of `positions` welded as `weld` says: each welded vertex
/// takes the position and point data of the lowest of its copies. Without
/// welding the input is borrowed, not copied.
fn welded<'a, const K: usize>(
    positions: &'a [Point3<f64>],
    point_data: &'a Fields,
    elements: &'a [[u32; K]],
    weld: Weld,
) -> Result<WeldedMesh<'a, K>, MeshError> {
    let tolerance = match weld {
        Weld::Off => {
            return Ok(WeldedMesh {
                positions: Cow::Borrowed(positions),
                point_data: Cow::Borrowed(point_data),
                elements: Cow::Borrowed(elements),
                merged: 0,
            });
        }
        Weld::Relative => crate::weld::default_tolerance(positions, elements),
        Weld::Within(t) => t,
    };
    let w = crate::weld::weld(positions, tolerance)?;
    Ok(WeldedMesh {
        positions: Cow::Owned(w.kept.iter().map(|&v| positions[v]).collect()),
        point_data: Cow::Owned(point_data.select(&w.kept)),
        elements: Cow::Owned(w.remap(elements)),
        merged: w.merged(),
    })
}

/// [`repair_tri_mesh`] with settings: with [`Weld::Relative`] or
/// [`Weld::Within`], coincident vertices are welded first (a triangle soup
/// becomes a connected surface; triangles that collapse onto a repeated
/// vertex are then dropped as such).
///
/// # Errors
/// As [`repair_tri_mesh`]; [`MeshError::WeldTolerance`] for a bad distance.
pub fn repair_tri_mesh_with(
    mesh: &TriMesh,
    options: &RepairOptions,
) -> Result<(TriMesh, RepairReport), MeshError> {
    check_input(
        &mesh.positions,
        &mesh.triangles,
        &mesh.point_data,
        &mesh.cell_data,
    )?;
    let WeldedMesh {
        positions,
        point_data,
        elements: triangles,
        merged: welded_vertices,
    } = welded(
        &mesh.positions,
        &mesh.point_data,
        &mesh.triangles,
        options.weld,
    )?;
    let (rows, repeated, dups) = keep_rows(&triangles);
    let mut tris: Vec<[u32; 3]> = rows.iter().map(|&t| triangles[t]).collect();
    let (flip, non_orientable) = orientation_flips(&positions, &tris);
    let mut flipped = 0;
    for (t, f) in tris.iter_mut().zip(&flip) {
        if *f {
            t.swap(1, 2);
            flipped += 1;
        }
    }
    let k = compact_vertices(&positions, &point_data, &tris)?;
    let components = connected_components(k.positions.len(), &k.elements).count;
    let report = RepairReport {
        welded_vertices,
        duplicate_elements: dups,
        repeated_vertex_elements: repeated,
        unused_vertices: positions.len() - k.positions.len(),
        flipped,
        components,
        non_orientable_components: non_orientable,
    };
    Ok((
        TriMesh {
            positions: k.positions,
            triangles: k.elements,
            point_data: k.point_data,
            cell_data: mesh.cell_data.select(&rows),
        },
        report,
    ))
}

/// Which triangles to flip for consistent, outward orientation (see
/// [`repair_tri_mesh`]), and the number of non-orientable patches. The
/// triangles must have distinct corners and distinct vertex sets.
fn orientation_flips(positions: &[Point3<f64>], tris: &[[u32; 3]]) -> (Vec<bool>, usize) {
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
    // Per triangle: up to 3 manifold neighbours (neighbour, same direction).
    let mut nbrs: Vec<[(u32, bool); 3]> = vec![[(u32::MAX, false); 3]; n];
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
            nbrs[t as usize][deg[t as usize] as usize] = (u, same);
            deg[t as usize] += 1;
            nbrs[u as usize][deg[u as usize] as usize] = (t, same);
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
    let mut non_orientable = 0;
    let mut queue = VecDeque::new();
    let mut patch = Vec::new();
    for seed in 0..n {
        if visited[seed] {
            continue;
        }
        visited[seed] = true;
        queue.push_back(seed);
        patch.clear();
        let mut orientable = true;
        while let Some(t) = queue.pop_front() {
            patch.push(t);
            for &(u, same) in &nbrs[t][..deg[t] as usize] {
                let want = flip[t] ^ same;
                let u = u as usize;
                if !visited[u] {
                    visited[u] = true;
                    flip[u] = want;
                    queue.push_back(u);
                } else if flip[u] != want {
                    orientable = false;
                }
            }
        }
        if !orientable {
            non_orientable += 1;
            continue;
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
    (flip, non_orientable)
}

/// Repairs a tet mesh: drops tets that use a vertex twice and tets whose
/// vertex set equals that of an earlier tet (the first is kept), removes
/// unused vertices ([`compact_vertices`]; point data and the kept tets' cell
/// data are carried over) and makes every tet positive
/// ([`TetMesh::orient`]).
///
/// # Errors
/// [`MeshError::IndexOutOfRange`], [`MeshError::NonFiniteCoordinate`], and
/// [`MeshError::FieldLength`] when a field does not match its mesh.
pub fn repair_tet_mesh(mesh: &TetMesh) -> Result<(TetMesh, RepairReport), MeshError> {
    repair_tet_mesh_with(mesh, &RepairOptions::default())
}

/// [`repair_tet_mesh`] with settings: coincident vertices welded first as
/// `options.weld` says (see [`repair_tri_mesh_with`]).
///
/// # Errors
/// As [`repair_tet_mesh`]; [`MeshError::WeldTolerance`] for a bad distance.
pub fn repair_tet_mesh_with(
    mesh: &TetMesh,
    options: &RepairOptions,
) -> Result<(TetMesh, RepairReport), MeshError> {
    check_input(
        &mesh.positions,
        &mesh.tets,
        &mesh.point_data,
        &mesh.cell_data,
    )?;
    let WeldedMesh {
        positions,
        point_data,
        elements: all_tets,
        merged: welded_vertices,
    } = welded(&mesh.positions, &mesh.point_data, &mesh.tets, options.weld)?;
    let (rows, repeated, dups) = keep_rows(&all_tets);
    let tets: Vec<[u32; 4]> = rows.iter().map(|&t| all_tets[t]).collect();
    let k = compact_vertices(&positions, &point_data, &tets)?;
    let mut out = TetMesh {
        positions: k.positions,
        tets: k.elements,
        point_data: k.point_data,
        cell_data: mesh.cell_data.select(&rows),
    };
    let flipped = out.orient()?;
    let components = connected_components(out.positions.len(), &out.tets).count;
    let report = RepairReport {
        welded_vertices,
        duplicate_elements: dups,
        repeated_vertex_elements: repeated,
        unused_vertices: positions.len() - out.positions.len(),
        flipped,
        components,
        non_orientable_components: 0,
    };
    Ok((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Field;
    use crate::test_meshes::*;
    use crate::topology::{boundary_loops, euler_characteristic};
    use crate::validate::{ValidationOptions, check_tri_mesh};
    use proptest::prelude::*;

    /// What was done to a clean mesh, to compare with the report.
    #[derive(Debug, Default)]
    struct Injected {
        flipped: Vec<bool>,
        duplicates: usize,
        repeated: usize,
        unused: usize,
    }

    /// Damages a clean, consistently oriented triangle mesh: flips
    /// triangles, appends duplicates (rotated, maybe flipped), inserts
    /// triangles with a repeated vertex, adds unused vertices and shuffles
    /// the vertex numbering. Adds a point field "orig" (original vertex) and
    /// a cell field "orig" (original triangle, -1 for injected ones).
    fn damage(
        clean: &TriMesh,
        seed: u64,
        flip_p: f64,
        dups: usize,
        reps: usize,
        unused: usize,
    ) -> (TriMesh, Injected) {
        let mut rng = SplitMix(seed);
        let nv = clean.num_vertices();
        let nt = clean.num_triangles();
        let mut inj = Injected::default();
        let mut tris: Vec<([u32; 3], i32)> = Vec::new();
        for (t, tri) in clean.triangles.iter().enumerate() {
            let mut tri = *tri;
            let f = rng.coin(flip_p);
            if f {
                tri.swap(0, 2);
            }
            inj.flipped.push(f);
            tris.push((tri, t as i32));
        }
        for _ in 0..dups {
            let mut tri = clean.triangles[rng.below(nt)];
            tri.rotate_left(rng.below(3));
            if rng.coin(0.5) {
                tri.swap(0, 1);
            }
            tris.push((tri, -1));
            inj.duplicates += 1;
        }
        for _ in 0..reps {
            let a = rng.below(nv) as u32;
            let b = rng.below(nv) as u32;
            let at = 1 + rng.below(tris.len());
            tris.insert(at, ([a, b, a], -1));
            inj.repeated += 1;
        }
        let mut positions = clean.positions.clone();
        for _ in 0..unused {
            positions.push(Point3::new(rng.sym(5.0), rng.sym(5.0), rng.sym(5.0)));
            inj.unused += 1;
        }
        // Shuffle vertex numbers: new index perm[old].
        let n = positions.len();
        let mut perm: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            perm.swap(i, rng.below(i + 1));
        }
        let mut shuffled = vec![Point3::origin(); n];
        let mut orig = vec![0.0; n];
        for old in 0..n {
            shuffled[perm[old] as usize] = positions[old];
            orig[perm[old] as usize] = old as f64;
        }
        let mut m = TriMesh::new(
            shuffled,
            tris.iter()
                .map(|(t, _)| t.map(|v| perm[v as usize]))
                .collect(),
        );
        m.add_point_field(Field::scalars("orig", orig)).unwrap();
        m.add_cell_field(Field::labels("orig", tris.iter().map(|t| t.1).collect()))
            .unwrap();
        (m, inj)
    }

    fn sorted(mut t: [u32; 3]) -> [u32; 3] {
        t.sort_unstable();
        t
    }

    /// The repaired mesh, mapped back through the "orig" fields, has the
    /// clean mesh's triangles (as vertex sets) and positions.
    fn check_fields(clean: &TriMesh, out: &TriMesh) {
        let pv = out.point_data.get("orig").unwrap();
        let cv = out.cell_data.get("orig").unwrap();
        assert_eq!(out.num_triangles(), clean.num_triangles());
        for (t, tri) in out.triangles.iter().enumerate() {
            let o = cv.get(t, 0).unwrap();
            assert!(o >= 0.0);
            let back = tri.map(|v| pv.get(v as usize, 0).unwrap() as u32);
            assert_eq!(sorted(back), sorted(clean.triangles[o as usize]));
        }
        for v in 0..out.num_vertices() {
            let o = pv.get(v, 0).unwrap() as usize;
            assert_eq!(out.positions[v], clean.positions[o]);
        }
    }

    /// A triangle soup of `m` (every triangle with its own three vertices,
    /// as STL stores it), every `reverse`-th triangle reversed and every
    /// `dup`-th triangle repeated, the copies moved by up to `jitter`.
    fn soup(m: &TriMesh, reverse: usize, dup: usize, jitter: f64) -> TriMesh {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for (t, tri) in m.triangles.iter().enumerate() {
            let copies = if t % dup == 0 { 2 } else { 1 };
            for c in 0..copies {
                let base = positions.len() as u32;
                for (k, &v) in tri.iter().enumerate() {
                    let e = jitter * (((t * 3 + k + c) % 7) as f64 / 7.0 - 0.5);
                    positions.push(m.positions[v as usize] + nalgebra::Vector3::new(e, -e, e));
                }
                let mut new = [base, base + 1, base + 2];
                if t % reverse == 0 {
                    new.swap(1, 2);
                }
                triangles.push(new);
            }
        }
        TriMesh::new(positions, triangles)
    }

    proptest! {
        /// A triangle soup with reversed and repeated triangles, its copies
        /// a little apart, welds back into the clean surface: the same
        /// vertices and triangles, consistently oriented, with its boundary.
        #[test]
        fn a_welded_soup_is_the_clean_mesh(
            nx in 2usize..7, ny in 2usize..7, sphere in any::<bool>(),
            reverse in 2usize..5, dup in 3usize..9,
        ) {
            let clean = if sphere {
                crate::shapes::primitives::uv_sphere(nx + 1, ny + 2, 10.0)
            } else {
                crate::shapes::primitives::grid_disk(nx, ny)
            };
            let messy = soup(&clean, reverse, dup, 1e-9);
            let options = RepairOptions { weld: Weld::Relative };
            let (fixed, r) = repair_tri_mesh_with(&messy, &options).unwrap();
            prop_assert_eq!(fixed.positions.len(), clean.positions.len());
            prop_assert_eq!(fixed.triangles.len(), clean.triangles.len());
            prop_assert_eq!(r.welded_vertices, messy.positions.len() - clean.positions.len());
            prop_assert_eq!(r.duplicate_elements, messy.triangles.len() - clean.triangles.len());
            prop_assert_eq!(r.components, 1);
            prop_assert!(
                check_tri_mesh(&fixed, &ValidationOptions::default()).is_empty(),
                "{:?}", check_tri_mesh(&fixed, &ValidationOptions::default())
            );
            prop_assert_eq!(euler_characteristic(&fixed), euler_characteristic(&clean));
            prop_assert_eq!(
                boundary_loops(&fixed).unwrap().len(),
                boundary_loops(&clean).unwrap().len()
            );
            // Without welding the soup stays apart.
            let (apart, r0) = repair_tri_mesh(&messy).unwrap();
            prop_assert_eq!(r0.welded_vertices, 0);
            prop_assert!(apart.positions.len() > clean.positions.len());
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn repair_sphere(
            n_lat in 3usize..8, n_lon in 3usize..9, seed: u64, flip in 0.0f64..0.7,
            dups in 0usize..5, reps in 0usize..4, unused in 0usize..5,
        ) {
            let clean = uv_sphere(n_lat, n_lon, 1.5);
            let (bad, inj) = damage(&clean, seed, flip, dups, reps, unused);
            let (out, report) = repair_tri_mesh(&bad).unwrap();
            prop_assert_eq!(out.validate(), Ok(()));
            prop_assert!(enclosed_volume(&out) > 0.0);
            prop_assert!((enclosed_volume(&out) - enclosed_volume(&clean)).abs() < 1e-9);
            prop_assert_eq!(report.duplicate_elements, inj.duplicates);
            prop_assert_eq!(report.repeated_vertex_elements, inj.repeated);
            prop_assert_eq!(report.unused_vertices, inj.unused);
            prop_assert_eq!(report.flipped, inj.flipped.iter().filter(|f| **f).count());
            prop_assert_eq!(report.components, 1);
            prop_assert_eq!(report.non_orientable_components, 0);
            check_fields(&clean, &out);
            // Repairing again changes nothing.
            let (again, r2) = repair_tri_mesh(&out).unwrap();
            prop_assert!(r2.is_clean(), "{}", r2);
            prop_assert_eq!(again, out);
        }

        #[test]
        fn repair_disk(
            nx in 1usize..6, ny in 1usize..6, seed: u64, flip in 0.0f64..0.7,
            dups in 0usize..5, reps in 0usize..4, unused in 0usize..5,
        ) {
            let clean = grid_disk(nx, ny);
            let (bad, inj) = damage(&clean, seed, flip, dups, reps, unused);
            let (out, report) = repair_tri_mesh(&bad).unwrap();
            prop_assert!(check_tri_mesh(&out, &ValidationOptions::default()).is_empty());
            prop_assert_eq!(report.duplicate_elements, inj.duplicates);
            prop_assert_eq!(report.repeated_vertex_elements, inj.repeated);
            prop_assert_eq!(report.unused_vertices, inj.unused);
            // The disk follows its first triangle.
            let k = inj.flipped.iter().filter(|f| **f).count();
            let expect = if inj.flipped[0] { clean.num_triangles() - k } else { k };
            prop_assert_eq!(report.flipped, expect);
            prop_assert_eq!(boundary_loops(&out).unwrap().len(), 1);
            prop_assert_eq!(euler_characteristic(&out), 1);
            check_fields(&clean, &out);
        }

        #[test]
        fn repair_tets(
            nx in 1usize..4, ny in 1usize..3, five: bool, seed: u64,
            dups in 0usize..4, reps in 0usize..3, unused in 0usize..4,
        ) {
            let mut rng = SplitMix(seed);
            let mut m = tet_grid([nx, ny, 2], five, [0.0; 3]);
            let mut clean = m.clone();
            clean.orient().unwrap();
            let nt = m.num_tets();
            let n_neg = (0..nt)
                .filter(|&t| {
                    let [a, b, c, d] = m.tet_points(t);
                    tet_signed_volume(&a, &b, &c, &d) < 0.0
                })
                .count();
            for _ in 0..dups {
                let mut t = m.tets[rng.below(nt)];
                t.rotate_left(1 + rng.below(3));
                m.tets.push(t);
            }
            for _ in 0..reps {
                let a = rng.below(m.num_vertices()) as u32;
                m.tets.insert(rng.below(nt), [a, 0, a, 1]);
            }
            for _ in 0..unused {
                m.positions.push(Point3::new(9.0, rng.f64(), 0.0));
            }
            let ids: Vec<i32> = (0..m.num_tets() as i32).collect();
            m.add_cell_field(Field::labels("id", ids)).unwrap();
            let (out, report) = repair_tet_mesh(&m).unwrap();
            prop_assert_eq!(out.validate(), Ok(()));
            prop_assert_eq!(report.duplicate_elements, dups);
            prop_assert_eq!(report.repeated_vertex_elements, reps);
            prop_assert_eq!(report.unused_vertices, unused);
            prop_assert_eq!(report.flipped, n_neg);
            prop_assert_eq!(report.components, 1);
            prop_assert_eq!(out.num_tets(), nt);
            prop_assert_eq!(&out.positions, &clean.positions);
            let mut got: Vec<[u32; 4]> = out.tets.iter().map(|t| { let mut t = *t; t.sort_unstable(); t }).collect();
            let mut want: Vec<[u32; 4]> = clean.tets.iter().map(|t| { let mut t = *t; t.sort_unstable(); t }).collect();
            got.sort_unstable();
            want.sort_unstable();
            prop_assert_eq!(got, want);
            prop_assert_eq!(out.cell_data.get("id").unwrap().tuples(), nt);
        }
    }

    #[test]
    fn inward_sphere_is_turned_outward() {
        let mut m = uv_sphere(4, 6, 1.0);
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
        let (out, report) = repair_tri_mesh(&m).unwrap();
        assert_eq!(report.flipped, m.num_triangles());
        assert!(enclosed_volume(&out) > 0.0);
        assert_eq!(out.validate(), Ok(()));
    }

    #[test]
    fn two_spheres_are_oriented_separately() {
        let a = uv_sphere(4, 5, 1.0);
        let mut m = a.clone();
        let off = a.num_vertices() as u32;
        m.positions.extend(
            a.positions
                .iter()
                .map(|p| p + nalgebra::Vector3::new(5.0, 0.0, 0.0)),
        );
        // The second sphere inward.
        m.triangles.extend(
            a.triangles
                .iter()
                .map(|t| [t[0] + off, t[2] + off, t[1] + off]),
        );
        let (out, report) = repair_tri_mesh(&m).unwrap();
        assert_eq!(report.components, 2);
        assert_eq!(report.flipped, a.num_triangles());
        assert!((enclosed_volume(&out) - 2.0 * enclosed_volume(&a)).abs() < 1e-9);
    }

    #[test]
    fn mobius_strip_is_counted_not_looped() {
        // A strip of 6 quads whose ends are glued with a half twist.
        let n = 6usize;
        let mut positions = Vec::new();
        for i in 0..n {
            let u = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            for s in [-0.3, 0.3] {
                let r = 1.0 + s * (u / 2.0).cos();
                positions.push(Point3::new(r * u.cos(), r * u.sin(), s * (u / 2.0).sin()));
            }
        }
        let mut tris = Vec::new();
        for i in 0..n {
            let (a, b) = (2 * i as u32, 2 * i as u32 + 1);
            let (c, d) = if i + 1 < n {
                (2 * (i + 1) as u32, 2 * (i + 1) as u32 + 1)
            } else {
                (1, 0) // the twist
            };
            tris.push([a, c, d]);
            tris.push([a, d, b]);
        }
        let m = TriMesh::new(positions, tris);
        let (out, report) = repair_tri_mesh(&m).unwrap();
        assert_eq!(report.non_orientable_components, 1);
        assert_eq!(report.components, 1);
        assert_eq!(out.num_triangles(), 2 * n);
        assert!(report.to_string().contains("1 non-orientable"), "{report}");
    }

    #[test]
    fn repair_errors_only_for_bad_indices_and_coordinates() {
        let mut m = uv_sphere(3, 4, 1.0);
        m.triangles.push([0, 1, 100]);
        assert!(matches!(
            repair_tri_mesh(&m),
            Err(MeshError::IndexOutOfRange { index: 100, .. })
        ));
        let mut m = uv_sphere(3, 4, 1.0);
        m.positions[2].z = f64::NAN;
        assert!(matches!(
            repair_tri_mesh(&m),
            Err(MeshError::NonFiniteCoordinate { vertex: 2, .. })
        ));
        let mut t = tet_grid([1, 1, 1], false, [0.0; 3]);
        t.tets.push([0, 1, 2, 100]);
        assert!(matches!(
            repair_tet_mesh(&t),
            Err(MeshError::IndexOutOfRange { .. })
        ));
        let (empty, r) = repair_tri_mesh(&TriMesh::default()).unwrap();
        assert_eq!(empty.num_vertices(), 0);
        assert_eq!(r, RepairReport::default());
    }

    #[test]
    fn orient_flips_negative_tets_only() {
        let mut m = tet_grid([2, 1, 1], false, [0.0; 3]);
        let before = m.clone();
        let neg = (0..m.num_tets())
            .filter(|&t| {
                let [a, b, c, d] = m.tet_points(t);
                tet_signed_volume(&a, &b, &c, &d) < 0.0
            })
            .count();
        assert!(neg > 0);
        assert_eq!(m.orient().unwrap(), neg);
        assert_eq!(m.orient().unwrap(), 0);
        for (t, (x, y)) in m.tets.iter().zip(&before.tets).enumerate() {
            let [a, b, c, d] = m.tet_points(t);
            assert!(tet_signed_volume(&a, &b, &c, &d) > 0.0);
            let (mut x, mut y) = (*x, *y);
            x.sort_unstable();
            y.sort_unstable();
            assert_eq!(x, y);
        }
    }

    #[test]
    fn largest_component_carries_fields() {
        let small = uv_sphere(3, 4, 1.0);
        let big = uv_sphere(5, 6, 1.0);
        let mut m = small.clone();
        let off = small.num_vertices() as u32;
        m.positions.extend(
            big.positions
                .iter()
                .map(|p| p + nalgebra::Vector3::new(5.0, 0.0, 0.0)),
        );
        m.triangles
            .extend(big.triangles.iter().map(|t| t.map(|v| v + off)));
        m.positions.push(Point3::new(50.0, 0.0, 0.0)); // unused
        let ids: Vec<f64> = (0..m.num_vertices()).map(|v| v as f64).collect();
        m.add_point_field(Field::scalars("id", ids)).unwrap();
        let tids: Vec<i32> = (0..m.num_triangles() as i32).collect();
        m.add_cell_field(Field::labels("tid", tids)).unwrap();
        let (l, to_old) = m.largest_component().unwrap();
        assert_eq!(l.num_triangles(), big.num_triangles());
        assert_eq!(l.num_vertices(), big.num_vertices());
        assert_eq!(
            to_old,
            (off..off + big.num_vertices() as u32).collect::<Vec<_>>()
        );
        assert_eq!(l.triangles, big.triangles);
        let id = l.point_data.get("id").unwrap();
        for (i, &o) in to_old.iter().enumerate() {
            assert_eq!(id.get(i, 0), Some(o as f64));
        }
        assert_eq!(
            l.cell_data.get("tid").unwrap().get(0, 0),
            Some(small.num_triangles() as f64)
        );

        let g = crate::test_meshes::merge_tets(
            &tet_grid([1, 1, 1], false, [0.0; 3]),
            &tet_grid([2, 1, 1], true, [5.0, 0.0, 0.0]),
        );
        let (lt, map) = g.largest_component().unwrap();
        assert_eq!(lt.num_tets(), 10);
        assert_eq!(lt.num_vertices(), 12);
        assert_eq!(map[0], 8);
        assert_eq!(
            TriMesh::default().largest_component().unwrap().0,
            TriMesh::default()
        );
    }

    #[test]
    fn report_display_is_one_line() {
        let r = RepairReport {
            welded_vertices: 0,
            duplicate_elements: 2,
            repeated_vertex_elements: 1,
            unused_vertices: 1,
            flipped: 3,
            components: 1,
            non_orientable_components: 0,
        };
        assert_eq!(
            r.to_string(),
            "removed 2 duplicate elements, 1 element with a repeated vertex, 1 unused vertex; \
             flipped 3 elements; 1 component"
        );
        let clean = RepairReport {
            components: 2,
            ..Default::default()
        };
        assert_eq!(clean.to_string(), "nothing to repair; 2 components");
        let welded = RepairReport {
            welded_vertices: 5,
            components: 1,
            ..Default::default()
        };
        assert_eq!(
            welded.to_string(),
            "removed 5 coincident vertices (welded); 1 component"
        );
        assert!(!r.to_string().contains('\n'));
    }

    #[test]
    fn orient_and_largest_component_reject_bad_indices() {
        let p = vec![Point3::origin(); 3];
        let mut t = TetMesh::new(p.clone(), vec![[0, 1, 2, 7]]);
        assert!(matches!(
            t.orient(),
            Err(MeshError::IndexOutOfRange { index: 7, .. })
        ));
        assert_eq!(t.tets, vec![[0, 1, 2, 7]]);
        assert!(t.largest_component().is_err());
        let m = TriMesh::new(p, vec![[0, 1, 5]]);
        assert!(matches!(
            m.largest_component(),
            Err(MeshError::IndexOutOfRange { index: 5, .. })
        ));
    }
}
