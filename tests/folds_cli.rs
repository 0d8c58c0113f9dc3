//! Folds are visible everywhere (point 5): a folded tet mesh (a
//! vertex dragged past its neighbour) and a folded flat triangle mesh are
//! reported by `unfold info` (inverted and folded counts, `valid: no`,
//! `--strict` fails), `unfold repair` refuses them instead of re-orienting
//! their inverted elements (which hid the fold: "flipped 36 elements",
//! then `valid: yes`), while a mirrored mesh (every element turned, nothing
//! overlapping) is still re-oriented and then valid.

use std::path::Path;
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::kuhn_grid;
use unfold::mesh::{CellMesh, TetMesh, TriMesh};

mod common;
use common::*;

/// The unit cube as a 4 x 4 x 4 Kuhn grid.
fn cube() -> TetMesh {
    kuhn_grid([4, 4, 4], [0.25; 3])
}

/// The cube with the interior vertex (1, 2, 2) dragged past (2, 2, 2).
fn folded_cube() -> TetMesh {
    let mut m = cube();
    let id = |i: usize, j: usize, k: usize| i + 5 * (j + 5 * k);
    m.positions[id(1, 2, 2)].x = 0.65;
    m
}

/// A `w x h` grid of unit squares in the plane z = 0.
fn flat_grid(w: u32, h: u32) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..=h {
        for i in 0..=w {
            p.push(Point3::new(i as f64, j as f64, 0.0));
        }
    }
    let mut t = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let a = i + (w + 1) * j;
            t.push([a, a + 1, a + w + 2]);
            t.push([a, a + w + 2, a + w + 1]);
        }
    }
    TriMesh::new(p, t)
}

fn write(path: &Path, mesh: impl Into<CellMesh>) {
    write_mesh(path, &mesh.into(), &WriteOptions::default()).unwrap();
}

fn info_json(path: &Path) -> serde_json::Value {
    let o = unfold(&["info", "--json", &s(path)]);
    assert_ok(&o);
    serde_json::from_str(&stdout(&o)).expect("info --json prints JSON")
}

#[test]
fn a_folded_tet_mesh_is_reported_and_refused_by_repair() {
    let dir = tempfile::tempdir().unwrap();
    let folded = dir.path().join("folded.vtu");
    write(&folded, &folded_cube());
    let v = info_json(&folded);
    assert_eq!(v["valid"], false, "{v}");
    let (inverted, faces) = (
        v["folds"]["inverted"].as_u64().unwrap(),
        v["folds"]["folded"].as_u64().unwrap(),
    );
    assert!(inverted > 0 && faces > 0, "{v}");
    let kinds: Vec<&str> = v["problems"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["kind"].as_str().unwrap())
        .collect();
    assert!(
        kinds.contains(&"inverted_element") && kinds.contains(&"folded_face"),
        "{kinds:?}"
    );
    let text = unfold(&["info", &s(&folded)]);
    assert!(
        stdout(&text).contains(&format!(
            "inverted elements: {inverted}, folded faces: {faces}"
        )),
        "{}",
        stdout(&text)
    );
    assert_one_line_error(&unfold(&["info", "--strict", &s(&folded)]), "inverted");

    let out = dir.path().join("repaired.vtu");
    let o = unfold(&["repair", &s(&folded), "-o", &s(&out)]);
    assert_one_line_error(&o, "the mesh is folded");
    assert!(stderr(&o).contains("re-mesh or untangle"), "{}", stderr(&o));
    assert!(!out.exists(), "nothing written for a refused repair");

    // Turned positive by another tool, the fold is still there.
    let mut oriented = folded_cube();
    assert_eq!(oriented.orient().unwrap() as u64, inverted);
    let path = dir.path().join("oriented.vtu");
    write(&path, &oriented);
    let v = info_json(&path);
    assert_eq!(v["valid"], false, "{v}");
    assert_eq!(v["folds"]["inverted"], 0);
    assert_eq!(v["folds"]["folded"].as_u64().unwrap(), faces);
    assert_one_line_error(&unfold(&["info", "--strict", &s(&path)]), "is folded");
}

#[test]
fn a_mirrored_tet_mesh_is_reoriented_and_then_valid() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = cube();
    for p in &mut m.positions {
        p.x = -p.x;
    }
    let mirrored = dir.path().join("mirrored.vtu");
    write(&mirrored, &m);
    let v = info_json(&mirrored);
    assert_eq!(
        v["folds"]["inverted"].as_u64().unwrap(),
        m.tets.len() as u64
    );
    assert_eq!(v["folds"]["folded"], 0);
    let out = dir.path().join("repaired.vtu");
    let o = unfold(&["repair", &s(&mirrored), "-o", &s(&out)]);
    assert_ok(&o);
    assert!(stdout(&o).contains("flipped"), "{}", stdout(&o));
    let v = info_json(&out);
    assert_eq!(v["valid"], true, "{v}");
    assert_eq!(v["folds"]["inverted"], 0);
    assert!(
        (v["volume_mm3"].as_f64().unwrap() - 1.0).abs() < 1e-12,
        "{v}"
    );
}

#[test]
fn a_folded_flat_triangle_mesh_is_reported_and_refused() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean.vtk");
    write(&clean, &flat_grid(6, 5));
    let v = info_json(&clean);
    assert_eq!(v["valid"], true, "{v}");
    assert_eq!(v["folds"]["inverted"], 0);
    assert_eq!(v["folds"]["folded"], 0);

    let mut m = flat_grid(6, 5);
    // interior vertex (3, 2) = 17 dragged past (4, 2) = 18
    m.positions[17].x = 4.7;
    let folded = dir.path().join("folded.vtk");
    write(&folded, &m);
    let v = info_json(&folded);
    assert_eq!(v["valid"], false, "{v}");
    assert!(v["folds"]["inverted"].as_u64().unwrap() > 0, "{v}");
    assert!(v["folds"]["folded"].as_u64().unwrap() > 0, "{v}");
    assert_one_line_error(
        &unfold(&["info", "--strict", &s(&folded)]),
        "of the planar mesh is inverted",
    );
    let out = dir.path().join("repaired.vtk");
    assert_one_line_error(
        &unfold(&["repair", &s(&folded), "-o", &s(&out)]),
        "folded edges",
    );

    // A surface curved in space is not judged: `folds` is null.
    let mut bent = flat_grid(6, 5);
    for p in &mut bent.positions {
        p.z = 0.1 * p.x * p.x;
    }
    let path = dir.path().join("bent.vtk");
    write(&path, &bent);
    let v = info_json(&path);
    assert!(v["folds"].is_null(), "{v}");
    assert_eq!(v["valid"], true, "{v}");
}
