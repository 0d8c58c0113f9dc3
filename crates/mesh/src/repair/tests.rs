//! Repair tests across the steps: damaged clean meshes come back clean.

use super::work::Work;
use super::*;
use crate::Field;
use crate::geometry::tet_signed_volume;
use crate::test_meshes::*;
use crate::topology::{boundary_loops, euler_characteristic};
use crate::validate::{ValidationOptions, check_tri_mesh};
use nalgebra::Point3;
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
        let options = RepairOptions {
            weld: Weld::Relative,
            ..Default::default()
        };
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
fn a_mobius_strip_is_refused_with_its_twisted_edge() {
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
    let err = repair_tri_mesh(&m).unwrap_err();
    let MeshError::NonOrientable { vertices, at, .. } = &err else {
        panic!("{err:?}");
    };
    for (v, p) in vertices.iter().zip(at) {
        let q = m.positions[*v];
        assert_eq!(*p, [q.x, q.y, q.z]);
    }
    let msg = err.to_string();
    assert!(msg.contains("not orientable"), "{msg}");
    assert!(msg.contains(&format!("vertex {}", vertices[0])), "{msg}");
    assert!(!msg.contains('\n'));
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

/// What [`glue`] added.
#[derive(Debug, Default)]
struct Glued {
    fins: usize,
    slivers: usize,
}

/// Adds to a clean, consistently oriented mesh: `fins` triangles standing
/// on interior edges (each with its own new apex), and `slivers` T-junctions
/// (a triangle `[a, b, c]` split at the midpoint `m` of its interior edge
/// `a-b` into `[a, m, c]`, `[m, b, c]`, the crack closed by the zero-area
/// `[a, b, m]`); then reverses about half the triangles. Carries the "orig"
/// fields of [`damage`] (the split halves keep their triangle's; new
/// vertices and triangles get -1).
fn glue(clean: &TriMesh, seed: u64, fins: usize, slivers: usize) -> (TriMesh, Glued) {
    let mut rng = SplitMix(seed);
    let mut positions = clean.positions.clone();
    let mut vorig: Vec<f64> = (0..positions.len()).map(|v| v as f64).collect();
    let mut tris: Vec<([u32; 3], i32)> = clean
        .triangles
        .iter()
        .enumerate()
        .map(|(t, &tri)| (tri, t as i32))
        .collect();
    // Interior edges: (triangle, corner i) with edge tri[i] -> tri[i+1].
    let mut count = std::collections::HashMap::new();
    for tri in &clean.triangles {
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let interior = |a: u32, b: u32| count.get(&(a.min(b), a.max(b))) == Some(&2);
    let mut used_vertex = vec![false; positions.len()];
    let mut g = Glued::default();
    for _ in 0..4 * (fins + slivers) + 8 {
        if g.fins == fins && g.slivers == slivers {
            break;
        }
        let t = rng.below(clean.num_triangles());
        let i = rng.below(3);
        let tri = clean.triangles[t];
        let (a, b, c) = (tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]);
        if !interior(a, b) || [a, b, c].iter().any(|&v| used_vertex[v as usize]) {
            continue;
        }
        for v in [a, b, c] {
            used_vertex[v as usize] = true;
        }
        let (pa, pb) = (positions[a as usize], positions[b as usize]);
        let mid = Point3::from((pa.coords + pb.coords) / 2.0);
        let new = positions.len() as u32;
        if g.fins < fins {
            let n = crate::geometry::triangle_normal(&pa, &pb, &positions[c as usize])
                .unwrap()
                .into_inner();
            positions.push(mid + n * (pb - pa).norm());
            vorig.push(-1.0);
            tris.push(([a, b, new], -1));
            g.fins += 1;
        } else {
            positions.push(mid);
            vorig.push(-1.0);
            let row = tris[t].1;
            tris[t].0 = [a, new, c];
            tris.push(([new, b, c], row));
            tris.push(([a, b, new], -1));
            g.slivers += 1;
        }
    }
    for (tri, _) in &mut tris {
        if rng.coin(0.5) {
            tri.swap(1, 2);
        }
    }
    let mut m = TriMesh::new(positions, tris.iter().map(|t| t.0).collect());
    m.add_point_field(Field::scalars("orig", vorig)).unwrap();
    m.add_cell_field(Field::labels("orig", tris.iter().map(|t| t.1).collect()))
        .unwrap();
    (m, g)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Fins and T-junction slivers on a sphere or a disk, half the
    /// triangles reversed: the repair gives back the clean mesh (through the
    /// "orig" fields), counts what was injected, and a second repair
    /// changes nothing.
    #[test]
    fn fins_and_slivers_are_removed(
        n in 4usize..8, sphere: bool, seed: u64, fins in 0usize..4, slivers in 0usize..4,
    ) {
        let clean = if sphere { uv_sphere(n, n + 1, 2.0) } else { grid_disk(n, n - 1) };
        let (messy, g) = glue(&clean, seed, fins, slivers);
        let (out, r) = repair_tri_mesh(&messy).unwrap();
        prop_assert_eq!(r.fin_triangles, g.fins);
        prop_assert_eq!(r.unused_vertices, g.fins);
        prop_assert_eq!(r.collapsed_vertices, g.slivers);
        prop_assert_eq!(r.degenerate_elements, 2 * g.slivers);
        prop_assert_eq!(r.duplicate_elements, 0);
        prop_assert_eq!(r.non_manifold_vertices_split, 0);
        prop_assert_eq!(r.components, 1);
        prop_assert!(check_tri_mesh(&out, &ValidationOptions::default()).is_empty());
        check_fields(&clean, &out);
        if sphere {
            prop_assert!((enclosed_volume(&out) - enclosed_volume(&clean)).abs() < 1e-9);
        }
        let (again, r2) = repair_tri_mesh(&out).unwrap();
        prop_assert!(r2.is_clean(), "{}", r2);
        prop_assert_eq!(again, out);
    }

    /// A sphere with its triangles around some vertices removed, filled
    /// with `fill_holes` above the holes' perimeters: closed again, the
    /// area of the clean sphere up to the caps' flattening, outward.
    #[test]
    fn small_holes_are_filled_and_large_ones_kept(n in 4usize..8, holes in 1usize..3) {
        let clean = uv_sphere(n, n + 2, 1.0);
        // Remove the fans of `holes` vertices of the equator, far apart.
        let mut m = clean.clone();
        let step = (n + 2) / holes.max(1);
        let ring = (n / 2 - 1) * (n + 2);
        let centres: Vec<u32> = (0..holes).map(|h| (1 + ring + h * step) as u32).collect();
        m.triangles.retain(|t| !t.iter().any(|v| centres.contains(v)));
        let removed = clean.num_triangles() - m.num_triangles();
        let (kept, r0) = repair_tri_mesh(&m).unwrap();
        prop_assert_eq!(r0.holes_filled, 0);
        prop_assert_eq!(r0.unused_vertices, holes);
        let loops = boundary_loops(&kept).unwrap();
        prop_assert_eq!(loops.len(), holes);
        let perimeters: Vec<f64> = loops
            .iter()
            .map(|l| holes::perimeter(&l.iter().map(|&v| kept.positions[v as usize]).collect::<Vec<_>>()))
            .collect();
        let longest = perimeters.iter().copied().fold(0.0, f64::max);
        let options = RepairOptions { fill_holes: Some(longest * 1.0001), ..Default::default() };
        let (filled, r) = repair_tri_mesh_with(&m, &options).unwrap();
        prop_assert_eq!(r.holes_filled, holes);
        prop_assert_eq!(r.hole_triangles, removed - 2 * holes);
        prop_assert!(boundary_loops(&filled).unwrap().is_empty());
        prop_assert!(check_tri_mesh(&filled, &ValidationOptions::default()).is_empty());
        prop_assert!(enclosed_volume(&filled) > 0.0);
        // Below the perimeter, nothing is filled.
        let d = longest * 0.999;
        let options = RepairOptions { fill_holes: Some(d), ..Default::default() };
        let (_, r) = repair_tri_mesh_with(&m, &options).unwrap();
        prop_assert_eq!(r.holes_filled, perimeters.iter().filter(|&&p| p <= d).count());
        prop_assert!(r.holes_filled < holes);
    }
}

#[test]
fn two_sheets_touching_at_a_vertex_are_split_there() {
    let a = grid_disk(2, 2);
    let mut m = a.clone();
    let off = a.num_vertices() as u32;
    // The second sheet's corner 0 is the first sheet's corner 8.
    m.positions.extend(
        a.positions
            .iter()
            .map(|p| p + nalgebra::Vector3::new(2.0, 2.0, 0.0)),
    );
    m.triangles.extend(
        a.triangles
            .iter()
            .map(|t| t.map(|v| if v == 0 { 8 } else { v + off })),
    );
    let (out, r) = repair_tri_mesh(&m).unwrap();
    assert_eq!(r.non_manifold_vertices_split, 1);
    assert_eq!(r.unused_vertices, 1); // the second sheet's own corner 0
    assert_eq!(out.num_vertices(), 2 * a.num_vertices());
    assert_eq!(r.components, 2);
    assert_eq!(boundary_loops(&out).unwrap().len(), 2);
    let (_, r2) = repair_tri_mesh(&out).unwrap();
    assert!(r2.is_clean(), "{r2}");
}

#[test]
fn flat_and_duplicate_tets_are_dropped_from_a_tet_soup() {
    let clean = tet_grid([2, 2, 1], false, [0.0; 3]);
    let mut soup = TetMesh::default();
    for (t, tet) in clean.tets.iter().enumerate() {
        for _ in 0..if t % 4 == 0 { 2 } else { 1 } {
            let base = soup.positions.len() as u32;
            soup.positions
                .extend(tet.iter().map(|&v| clean.positions[v as usize]));
            soup.tets.push([base, base + 1, base + 2, base + 3]);
        }
    }
    // A flat tet on one face.
    let f = clean.tets[0];
    let base = soup.positions.len() as u32;
    let [a, b, c] = [f[0], f[1], f[2]].map(|v| clean.positions[v as usize]);
    soup.positions.extend([
        a,
        b,
        c,
        Point3::from((a.coords + b.coords + c.coords) / 3.0),
    ]);
    soup.tets.push([base, base + 1, base + 2, base + 3]);
    let options = RepairOptions {
        weld: Weld::Relative,
        keep_tet_orientation: true,
        ..Default::default()
    };
    let (out, r) = repair_tet_mesh_with(&soup, &options).unwrap();
    assert_eq!(r.duplicate_elements, clean.num_tets().div_ceil(4));
    assert_eq!(r.degenerate_elements, 1);
    assert_eq!(r.flipped, 0);
    assert_eq!(r.unused_vertices, 1); // the flat tet's centroid
    assert_eq!(out.num_vertices(), clean.num_vertices());
    assert_eq!(out.num_tets(), clean.num_tets());
    assert_eq!(
        r.welded_vertices,
        soup.num_vertices() - clean.num_vertices() - 1
    );
    let (again, r2) = repair_tet_mesh_with(&out, &options).unwrap();
    assert!(r2.is_clean(), "{r2}");
    assert_eq!(again, out);
}

#[test]
fn a_clean_mesh_comes_back_unchanged() {
    for m in [uv_sphere(5, 7, 3.0), grid_disk(4, 3), annulus(2, 8)] {
        let options = RepairOptions {
            weld: Weld::Relative,
            fill_holes: None,
            ..Default::default()
        };
        let (out, r) = repair_tri_mesh_with(&m, &options).unwrap();
        assert!(r.is_clean(), "{r}");
        assert_eq!(out, m);
    }
}

#[test]
fn glue_injects_what_it_is_asked_for() {
    let clean = uv_sphere(8, 9, 2.0);
    let (m, g) = glue(&clean, 7, 3, 3);
    assert_eq!((g.fins, g.slivers), (3, 3));
    assert_eq!(m.num_triangles(), clean.num_triangles() + 3 + 2 * 3);
    assert_eq!(m.num_vertices(), clean.num_vertices() + 6);
    let (out, r) = repair_tri_mesh(&m).unwrap();
    assert_eq!((r.fin_triangles, r.collapsed_vertices), (3, 3));
    check_fields(&clean, &out);
}

proptest! {
    /// Every input vertex of a damaged mesh that survives maps to a repaired
    /// vertex at its own position (welded copies: within the tolerance).
    #[test]
    fn traced_vertices_keep_their_positions(
        n in 3usize..7, seed: u64, fins in 0usize..3, slivers in 0usize..3,
    ) {
        let clean = uv_sphere(n, n + 1, 2.0);
        let (messy, _) = glue(&soup(&clean, 3, 4, 0.0), seed, fins, slivers);
        let options = RepairOptions { weld: Weld::Relative, ..Default::default() };
        let t = repair_tri_mesh_traced(&messy, &options).unwrap();
        prop_assert_eq!(t.vertex_of_input.len(), messy.num_vertices());
        for (i, v) in t.vertex_of_input.iter().enumerate() {
            if let Some(v) = v {
                prop_assert!((t.mesh.positions[*v as usize] - messy.positions[i]).norm() < 1e-5
                    || t.report.collapsed_vertices > 0);
            }
        }
        let used: std::collections::HashSet<u32> = t.vertex_of_input.iter().flatten().copied().collect();
        prop_assert_eq!(used.len(), t.mesh.num_vertices());
    }
}

#[test]
fn relative_welding_never_merges_two_corners_of_one_element() {
    // A big triangle (sets the mean edge), a tiny one of side l, and a
    // chain of tiny triangles whose corners step by less than l/4 from the
    // tiny triangle's corner 0 to its corner 1; l is so small that the
    // default tolerance is l/4.
    let l = 1e-6;
    let mut p = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(l, 0.0, 0.0),
        Point3::new(0.0, l, 0.0),
        Point3::new(100.0, 0.0, 0.0),
        Point3::new(0.0, 100.0, 0.0),
        Point3::new(0.0, 0.0, 100.0),
    ];
    let mut tris = vec![[0u32, 1, 2], [3, 4, 5]];
    for k in 1..5 {
        let base = p.len() as u32;
        let x = l * k as f64 / 4.2;
        p.push(Point3::new(x, 0.0, 0.0));
        p.push(Point3::new(x, -l, 0.0));
        p.push(Point3::new(x, 0.0, -l));
        tris.push([base, base + 1, base + 2]);
    }
    let m = TriMesh::new(p, tris);
    let options = RepairOptions {
        weld: Weld::Relative,
        ..Default::default()
    };
    assert_eq!(
        crate::weld::default_tolerance(&m.positions, &m.triangles),
        l / 4.0
    );
    // At that tolerance the chain would merge corners 0 and 1 of the tiny
    // triangle; the weld step welds exact copies only instead.
    let chained = crate::weld::weld(&m.positions, l / 4.0).unwrap();
    assert_eq!(chained.new_of[0], chained.new_of[1]);
    let mut w = Work::new(&m.positions, &m.triangles);
    assert_eq!(weld_step(&mut w, options.weld).unwrap(), 0);
    assert_eq!(w.elements, m.triangles);
    // An explicit distance is the user's choice: the chain welds.
    let mut w = Work::new(&m.positions, &m.triangles);
    assert!(weld_step(&mut w, Weld::Within(l / 4.0)).unwrap() >= 4);
}
