//! `unfold repair` on meshes made messy programmatically from clean ones: a
//! triangle soup (every triangle with its own vertices, as STL and many
//! exporters store it) with reversed and repeated triangles is repaired into
//! a surface that maps exactly like the clean one.

use std::path::Path;
use std::process::Output;
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
use unfold::mesh::{CellMesh, TriMesh};

mod common;
use common::*;

/// `m` as a soup: own vertices per triangle, every 3rd triangle reversed,
/// every 5th repeated.
fn soup(m: &TriMesh) -> TriMesh {
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for (t, tri) in m.triangles.iter().enumerate() {
        for _ in 0..if t % 5 == 0 { 2 } else { 1 } {
            let base = positions.len() as u32;
            positions.extend(tri.iter().map(|&v| m.positions[v as usize]));
            let mut new = [base, base + 1, base + 2];
            if t % 3 == 0 {
                new.swap(1, 2);
            }
            triangles.push(new);
        }
    }
    TriMesh::new(positions, triangles)
}

fn write(path: &Path, mesh: &TriMesh) {
    write_mesh(path, &CellMesh::from(mesh), &WriteOptions::default()).unwrap();
}

fn pt(p: &Point3<f64>) -> String {
    format!("{:?},{:?},{:?}", p.x, p.y, p.z)
}

/// `unfold ventricle` on the cup's anatomy with `surface`.
fn ventricle(v: &VentricleShape, anatomy: &Path, surface: &Path, out: &Path) -> Output {
    unfold(&[
        "ventricle",
        &s(anatomy),
        "--surface",
        &s(surface),
        "--anterior",
        &pt(&v.anterior),
        "--inferior",
        &pt(&v.inferior),
        "--apex",
        &pt(&v.apex),
        "--grid-mm",
        "1.5",
        "--no-figures",
        "-o",
        &s(out),
    ])
}

fn array(m: &CellMesh, name: &str) -> Vec<f64> {
    m.point_data.get(name).unwrap().values().to_f64()
}

#[test]
fn a_triangle_soup_is_repaired_into_the_surface_that_maps_like_the_clean_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (clean, messy, fixed, anatomy) = (
        d.join("clean.vtu"),
        d.join("messy.vtu"),
        d.join("fixed.vtu"),
        d.join("anatomy.vtu"),
    );
    write(&clean, &v.surface);
    let bad = soup(&v.surface);
    write(&messy, &bad);
    write(&anatomy, &v.anatomy);
    let before = std::fs::read(&messy).unwrap();

    // As exported, the surface is refused.
    let o = ventricle(&v, &anatomy, &messy, &d.join("refused"));
    assert!(!o.status.success());
    assert_eq!(stderr(&o).trim_end().lines().count(), 1, "{}", stderr(&o));

    let o = unfold(&["repair", &s(&messy), "-o", &s(&fixed), "--json"]);
    assert_ok(&o);
    assert_eq!(std::fs::read(&messy).unwrap(), before, "input untouched");
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let (nv, nt) = (v.surface.positions.len(), v.surface.triangles.len());
    let dups = nt.div_ceil(5);
    assert_eq!(j["elements"], "triangles");
    assert_eq!(j["vertices"], nv);
    assert_eq!(j["cells"], nt);
    let r = &j["repair"];
    assert_eq!(r["welded_vertices"], bad.positions.len() - nv);
    assert_eq!(r["duplicate_elements"], dups);
    assert_eq!(r["unused_vertices"], 0);
    assert_eq!(r["components"], 1);
    assert!(r["flipped"].as_u64().unwrap() > 0);
    let info = unfold(&["info", &s(&fixed), "--json"]);
    let info: serde_json::Value = serde_json::from_str(&stdout(&info)).unwrap();
    assert_eq!(info["problems"].as_array().map(Vec::len), Some(0), "{info}");

    // Repaired, it maps exactly like the clean surface.
    let (a, b) = (d.join("from_clean"), d.join("from_fixed"));
    assert_ok(&ventricle(&v, &anatomy, &clean, &a));
    assert_ok(&ventricle(&v, &anatomy, &fixed, &b));
    let (ma, mb) = (
        read_mesh(a.join("normalized.vtu")).unwrap(),
        read_mesh(b.join("normalized.vtu")).unwrap(),
    );
    for name in ["xi", "zeta", "depth"] {
        let worst = array(&ma, name)
            .iter()
            .zip(array(&mb, name))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "{name}: {worst}");
    }

    // Without welding the soup stays apart (every triangle its own piece).
    let o = unfold(&[
        "repair",
        &s(&messy),
        "-o",
        &s(&d.join("apart.vtu")),
        "--no-weld",
    ]);
    assert_ok(&o);
    assert!(stdout(&o).contains("components"), "{}", stdout(&o));
}

#[test]
fn a_tet_mesh_with_copied_vertices_and_tets_is_repaired() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cube = unfold::mesh::shapes::kuhn_grid([2, 2, 2], [1.0, 1.0, 1.0]);
    // Every tet with its own vertices, and the first tet twice.
    let (mut positions, mut tets) = (Vec::new(), Vec::new());
    for (t, tet) in cube.tets.iter().chain(&cube.tets[..1]).enumerate() {
        let base = positions.len() as u32;
        positions.extend(tet.iter().map(|&v| cube.positions[v as usize]));
        let mut new = [base, base + 1, base + 2, base + 3];
        if t % 2 == 0 {
            new.swap(2, 3);
        }
        tets.push(new);
    }
    let messy = unfold::mesh::TetMesh::new(positions, tets);
    let (input, output) = (d.join("messy.vtu"), d.join("fixed.vtu"));
    write_mesh(&input, &CellMesh::from(&messy), &WriteOptions::default()).unwrap();
    let o = unfold(&["repair", &s(&input), "-o", &s(&output), "--json"]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["elements"], "tets");
    assert_eq!(j["vertices"], cube.positions.len());
    assert_eq!(j["cells"], cube.tets.len());
    assert_eq!(j["repair"]["duplicate_elements"], 1);
    let fixed = read_mesh(&output).unwrap().to_tet_mesh().unwrap();
    for t in 0..fixed.tets.len() {
        let [a, b, c, e] = fixed.tet_points(t);
        assert!(
            (b - a).dot(&(c - a).cross(&(e - a))) > 0.0,
            "tet {t} positive"
        );
    }
}

#[test]
fn bad_repair_requests_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = d.join("m.vtu");
    write(
        &m,
        &ventricle_cup(&VentricleParams::default()).unwrap().surface,
    );
    let out = s(&d.join("o.vtu"));
    assert_one_line_error(
        &unfold(&["repair", &s(&m), "-o", &out, "--weld-mm", "-1"]),
        "--weld-mm",
    );
    assert_one_line_error(
        &unfold(&["repair", &s(&m), "-o", &out, "--weld-mm", "1", "--no-weld"]),
        "--no-weld",
    );
    assert_one_line_error(
        &unfold(&["repair", &s(&m), "-o", &s(&m)]),
        "refusing to overwrite",
    );
    assert_one_line_error(
        &unfold(&["repair", "/no/such/mesh.vtu", "-o", &out]),
        "/no/such/mesh.vtu",
    );
    assert!(!d.join("o.vtu").exists());
}
