//! `convert` between every writable format pair: A -> read -> B -> read keeps
//! positions exactly (binary, and ASCII written in shortest round-trip form),
//! the cells, and the arrays wherever both formats hold arrays.

use proptest::prelude::*;
use unfold::io::{MeshFormat, WriteOptions};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::{CellMesh, CellType, Field, FieldValues};

fn writable() -> Vec<MeshFormat> {
    MeshFormat::ALL
        .into_iter()
        .filter(|f| f.writable())
        .collect()
}

/// Option sets to exercise: binary defaults and all-ASCII.
fn option_sets() -> [WriteOptions; 2] {
    [WriteOptions::default(), WriteOptions::ascii()]
}

/// A random triangle surface where every vertex is used (STL cannot keep
/// unused vertices) and coordinates are f32-representable when `f32_only`.
fn surface(coords: &[[f64; 3]], tris: &[[u32; 3]], f32_only: bool) -> CellMesh {
    let positions: Vec<Point3<f64>> = coords
        .iter()
        .map(|c| {
            let p = Point3::new(c[0], c[1], c[2]);
            if f32_only {
                p.map(|x| x as f32 as f64)
            } else {
                p
            }
        })
        .collect();
    let mut m = CellMesh::from_points(positions);
    for t in tris {
        m.push_cell(CellType::Triangle, t);
    }
    m
}

fn with_arrays(mut m: CellMesh) -> CellMesh {
    let n = m.num_points();
    let c = m.num_cells();
    let vec: Vec<f64> = (0..3 * n).map(|i| (i as f64).sin() * 1e3).collect();
    m.add_point_field(Field::new("displacement", 3, FieldValues::F64(vec)).unwrap())
        .unwrap();
    m.add_cell_field(Field::labels(
        "label",
        (0..c as i32).map(|i| i % 7 - 3).collect(),
    ))
    .unwrap();
    m
}

/// Cells as coordinate lists (index-free: STL re-indexes vertices).
fn cell_coords(m: &CellMesh) -> Vec<(CellType, Vec<[f64; 3]>)> {
    m.cells()
        .map(|(t, vs)| {
            let ps = vs
                .iter()
                .map(|&v| {
                    let p = m.positions[v as usize];
                    [p.x, p.y, p.z]
                })
                .collect();
            (t, ps)
        })
        .collect()
}

fn assert_close(a: &[(CellType, Vec<[f64; 3]>)], b: &[(CellType, Vec<[f64; 3]>)], rel: f64) {
    assert_eq!(a.len(), b.len(), "cell count");
    for ((ta, pa), (tb, pb)) in a.iter().zip(b) {
        assert_eq!(ta, tb);
        assert_eq!(pa.len(), pb.len());
        for (x, y) in pa.iter().zip(pb) {
            for k in 0..3 {
                let tol = rel * x[k].abs().max(1e-300);
                assert!(
                    (x[k] - y[k]).abs() <= tol,
                    "coordinate {} vs {} (rel tol {rel})",
                    x[k],
                    y[k]
                );
            }
        }
    }
}

fn field_values(m: &CellMesh, point: bool, name: &str) -> Option<(usize, Vec<f64>)> {
    let fs = if point { &m.point_data } else { &m.cell_data };
    fs.get(name).map(|f| (f.components(), f.values().to_f64()))
}

fn roundtrip(src: &CellMesh, a: MeshFormat, b: MeshFormat, opts: &WriteOptions) -> CellMesh {
    let bytes = a
        .write_bytes(src, opts)
        .unwrap_or_else(|e| panic!("write {a:?}: {e}"));
    let m1 = a
        .read_bytes(&bytes)
        .unwrap_or_else(|e| panic!("read {a:?}: {e}"));
    let bytes = b
        .write_bytes(&m1, opts)
        .unwrap_or_else(|e| panic!("write {b:?} after {a:?}: {e}"));
    b.read_bytes(&bytes)
        .unwrap_or_else(|e| panic!("read {b:?} after {a:?}: {e}"))
}

fn check_pair(src: &CellMesh, a: MeshFormat, b: MeshFormat, opts: &WriteOptions) {
    let out = roundtrip(src, a, b, opts);
    // Shortest round-trip ASCII is exact too; the issue allows 1e-12 relative.
    let rel = if opts.ascii { 1e-12 } else { 0.0 };
    assert_close(&cell_coords(src), &cell_coords(&out), rel);
    if a != MeshFormat::Stl && b != MeshFormat::Stl {
        assert_eq!(out.num_points(), src.num_points(), "{a:?} -> {b:?}");
        assert_eq!(out.connectivity, src.connectivity, "{a:?} -> {b:?}");
    }
    if a.holds_arrays() && b.holds_arrays() {
        for (point, name) in [(true, "displacement"), (false, "label")] {
            let want = field_values(src, point, name).unwrap();
            let got = field_values(&out, point, name)
                .unwrap_or_else(|| panic!("{a:?} -> {b:?} lost array {name}"));
            assert_eq!(got.0, want.0, "{name} components");
            for (x, y) in want.1.iter().zip(&got.1) {
                assert!((x - y).abs() <= 1e-12 * x.abs(), "{name}: {x} vs {y}");
            }
        }
    }
}

fn mesh_strategy() -> impl Strategy<Value = (Vec<[f64; 3]>, Vec<[u32; 3]>)> {
    (4usize..24).prop_flat_map(|n| {
        let coord = prop_oneof![-1e3..1e3f64, -1e-3..1e-3f64, -1e6..1e6f64];
        let coords = prop::collection::vec([coord.clone(), coord.clone(), coord], n);
        let tri = (0..n as u32, 1..n as u32, 1..n as u32).prop_filter_map(
            "distinct corners",
            move |(a, b, c)| {
                let (b, c) = ((a + b) % n as u32, (a + c) % n as u32);
                (b != c).then_some([a, b, c])
            },
        );
        let extra = prop::collection::vec(tri, 1..30);
        (coords, extra).prop_map(move |(coords, mut tris)| {
            // Make every vertex used: a fan through all vertices comes first.
            let mut all: Vec<[u32; 3]> = (1..n as u32 - 1).map(|i| [0, i, i + 1]).collect();
            all.append(&mut tris);
            (coords, all)
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Every writable format pair on a triangle surface with arrays.
    #[test]
    fn surface_roundtrips_between_every_pair((coords, tris) in mesh_strategy()) {
        for opts in option_sets() {
            for a in writable() {
                for b in writable() {
                    let f32_only = a.single_precision() || b.single_precision();
                    let src = with_arrays(surface(&coords, &tris, f32_only));
                    check_pair(&src, a, b, &opts);
                }
            }
        }
    }

    /// Every pair of tet-capable formats on a tet mesh with arrays.
    #[test]
    fn tets_roundtrip_between_volume_formats(
        coords in prop::collection::vec([-50.0..50.0f64, -50.0..50.0f64, -50.0..50.0f64], 5..20),
        seed in 0u32..1000,
    ) {
        let n = coords.len() as u32;
        let mut src = CellMesh::from_points(
            coords.iter().map(|c| Point3::new(c[0], c[1], c[2])).collect(),
        );
        for i in 0..n - 3 {
            let s = (seed + i) % 2;
            let t = if s == 0 { [i, i + 1, i + 2, i + 3] } else { [i + 3, i + 1, i + 2, i] };
            src.push_cell(CellType::Tetra, &t);
        }
        let src = with_arrays(src);
        let volume: Vec<MeshFormat> = writable().into_iter().filter(|f| f.holds_volume_cells()).collect();
        prop_assert!(volume.len() >= 3);
        for opts in option_sets() {
            for &a in &volume {
                for &b in &volume {
                    check_pair(&src, a, b, &opts);
                }
            }
        }
    }
}

/// Writing cells a format cannot hold is a clear error, not a panic or a
/// silent loss.
#[test]
fn impossible_conversions_are_errors() {
    let mut m = CellMesh::from_points(vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, 0.0, 1.0),
    ]);
    m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
    for f in writable() {
        if !f.holds_volume_cells() {
            let e = f.write_bytes(&m, &WriteOptions::default());
            assert!(e.is_err(), "{f:?} accepted a tet mesh");
        }
    }
}
