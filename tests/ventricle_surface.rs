//! `unfold ventricle ANATOMY` without `--surface` through the binary: S is
//! built from the anatomy (tets, a closed surface, an open surface),
//! written as DIR/surface.vtu and described in report.json; bad inputs are
//! one-line errors.

use std::path::Path;
use std::process::Output;
use unfold::io::{WriteOptions, read_mesh, read_tri_mesh, write_mesh};
use unfold::mesh::nalgebra::{Point3, Vector3};
use unfold::mesh::shapes::{
    ShellParams, VentricleParams, VentricleShape, bowl_shell, ventricle_cup,
};
use unfold::mesh::topology::disk_boundary_loop;
use unfold::mesh::{CellMesh, CellType};

mod common;
use common::*;

fn cup() -> VentricleShape {
    ventricle_cup(&VentricleParams {
        rings: 16,
        ..VentricleParams::default()
    })
    .unwrap()
}

fn write(path: &Path, mesh: &CellMesh) {
    write_mesh(path, mesh, &WriteOptions::default()).unwrap();
}

/// `unfold ventricle ANATOMY --anterior A --inferior I -o OUT` (no
/// `--surface`), with a 1.5 mm Laplace grid, plus `extra`, and 1 mm voxels
/// and a 2 mm dilation unless `extra` sets a `--surface-...` flag.
fn run(anatomy: &Path, a: &Point3<f64>, i: &Point3<f64>, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "ventricle".to_string(),
        s(anatomy),
        "--anterior".into(),
        pt(a),
        "--inferior".into(),
        pt(i),
        "--grid-mm".into(),
        "1.5".into(),
        "--no-figures".into(),
        "-o".into(),
        s(out),
    ];
    if !extra.iter().any(|x| x.starts_with("--surface-")) {
        for x in ["--surface-voxel-mm", "1", "--surface-margin-mm", "2"] {
            args.push(x.into());
        }
    }
    args.extend(extra.iter().map(|x| x.to_string()));
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    unfold(&refs)
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// Checks a run that built S: success, surface.vtu a disk whose normals
/// point away from the anatomy, every anatomy point mapped, the report's
/// section; returns the section.
fn check_built(o: &Output, anatomy: &CellMesh, out: &Path, kind: &str) -> serde_json::Value {
    assert_ok(o);
    let text = stdout(o);
    assert!(text.contains("built S from the anatomy"), "{text}");
    assert!(text.contains(kind), "{text}");
    assert!(
        text.contains("wrote") && text.contains("surface.vtu"),
        "{text}"
    );
    let s = read_tri_mesh(out.join("surface.vtu")).unwrap();
    let rim = disk_boundary_loop(&s).expect("S is a disk");
    assert!(rim.len() > 20);
    let r = report(out);
    let e = r["enclosing_surface"].clone();
    assert_eq!(e["anatomy"], kind.replace(' ', "-"));
    assert_eq!(e["voxel_mm"], 1.0);
    assert_eq!(e["margin_mm"], 2.0);
    assert_eq!(e["vertices"].as_u64().unwrap() as usize, s.num_vertices());
    assert_eq!(e["triangles"].as_u64().unwrap() as usize, s.num_triangles());
    assert!(e["seconds"].as_f64().unwrap() > 0.0);
    assert!(e["min_clearance_mm"].as_f64().unwrap() > 0.5);
    // the rim lies on the cut plane
    let c = Point3::from(Vector3::from_iterator(
        e["cut_point_mm"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap()),
    ));
    let n = Vector3::from_iterator(
        e["cut_normal"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap()),
    );
    for &v in &rim {
        assert!(n.dot(&(s.positions[v as usize] - c)).abs() < 1e-6);
    }
    // every anatomy point mapped, none failed, and below the plane
    assert_eq!(
        r["anatomy_points"].as_u64().unwrap() as usize,
        anatomy.positions.len()
    );
    for p in &anatomy.positions {
        assert!(n.dot(&(p - c)) < 0.0);
    }
    assert!(r["roundtrip_error_um"]["max"].as_f64().unwrap() < 50.0);
    let mapped = read_mesh(out.join("normalized.vtu")).unwrap();
    assert_eq!(mapped.positions.len(), anatomy.positions.len());
    assert!(
        r["inputs"]["surface"]
            .as_str()
            .unwrap()
            .starts_with("S built from")
    );
    e
}

#[test]
fn an_open_surface_gets_s_outside_its_wall() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let anatomy = CellMesh::from(&v.surface);
    let input = dir.path().join("endo.vtp");
    write(&input, &anatomy);
    let out = dir.path().join("out");
    let o = run(&input, &v.anterior, &v.inferior, &out, &[]);
    let e = check_built(&o, &anatomy, &out, "open surface");
    // the wall's two sides separated, the outer one kept
    assert_eq!(e["pieces_below_cut"], 2);
    assert!((e["cut_above_highest_mm"].as_f64().unwrap() - 0.5).abs() < 1e-12);
}

/// A hemispherical shell of tets 6 mm thick, opening towards +z, its rim
/// at z = 23 between radii 20 and 26, and two rim points 110 degrees apart.
fn shell() -> (unfold::mesh::TetMesh, Point3<f64>, Point3<f64>) {
    let shell = bowl_shell(&ShellParams {
        radius: 20.0,
        thickness: 6.0,
        half_angle_deg: 90.0,
        cells_radial: 10,
        cells_through: 2,
        ..ShellParams::default()
    })
    .unwrap();
    let at = |deg: f64| {
        let a = deg.to_radians();
        Point3::new(23.0 * a.cos(), 23.0 * a.sin(), 23.0)
    };
    (shell.mesh, at(55.0), at(-55.0))
}

#[test]
fn a_closed_surface_is_filled() {
    let dir = tempfile::tempdir().unwrap();
    let (tets, a, i) = shell();
    let boundary = unfold::mesh::topology::tet_boundary(&tets).unwrap().surface;
    let anatomy = CellMesh::from(&boundary);
    let input = dir.path().join("wall.ply");
    write(&input, &anatomy);
    let out = dir.path().join("out");
    let o = run(&input, &a, &i, &out, &[]);
    let e = check_built(&o, &anatomy, &out, "closed surface");
    assert!(e["filled_nodes"].as_u64().unwrap() > 0);
    assert_eq!(e["pieces_below_cut"], 2);
}

#[test]
fn tets_are_enclosed_by_their_boundary() {
    let dir = tempfile::tempdir().unwrap();
    let (tets, a, i) = shell();
    let mut anatomy = CellMesh::from_points(tets.positions.clone());
    for t in &tets.tets {
        anatomy.push_cell(CellType::Tetra, t);
    }
    let input = dir.path().join("wall.vtu");
    write(&input, &anatomy);
    let out = dir.path().join("out");
    let o = run(&input, &a, &i, &out, &[]);
    let e = check_built(&o, &anatomy, &out, "tets");
    assert_eq!(e["pieces_below_cut"], 2);
    // the basal plane is the rim's, z = 23
    let n: Vec<f64> = e["cut_normal"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!((n[2] - 1.0).abs() < 1e-9, "{n:?}");
    assert!(e["highest_point_mm"].as_f64().unwrap().abs() < 1e-9);
}

#[test]
fn bad_inputs_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let anatomy = dir.path().join("endo.vtp");
    write(&anatomy, &CellMesh::from(&v.surface));
    let out = dir.path().join("out");
    let (a, i) = (&v.anterior, &v.inferior);
    // three bare points: nothing to enclose
    let three = dir.path().join("three.vtk");
    let pts = CellMesh::from_points(v.surface.positions[..3].to_vec());
    write(&three, &pts);
    assert_one_line_error(&run(&three, a, i, &out, &[]), "no surface or tet cells");
    // a single triangle: flat
    let tri_path = dir.path().join("tri.vtp");
    let mut tri = CellMesh::from_points(vec![*a, *i, v.apex]);
    tri.push_cell(CellType::Triangle, &[0, 1, 2]);
    write(&tri_path, &tri);
    assert_one_line_error(&run(&tri_path, a, i, &out, &[]), "flat anatomy");
    for bad in ["0", "-1", "nan"] {
        let o = run(
            &anatomy,
            a,
            i,
            &out,
            &["--surface-voxel-mm", bad, "--surface-margin-mm", "2"],
        );
        assert_one_line_error(&o, "--surface-voxel-mm must be a finite number > 0");
    }
    let o = run(
        &anatomy,
        a,
        i,
        &out,
        &["--surface-voxel-mm", "1", "--surface-margin-mm", "1.5"],
    );
    assert_one_line_error(&o, "must exceed sqrt(3) voxels");
    let o = run(
        &anatomy,
        a,
        i,
        &out,
        &["--surface-voxel-mm", "0.02", "--surface-margin-mm", "0.05"],
    );
    assert_one_line_error(&o, "give a larger voxel size");
    // with --surface the flags of the built S are refused
    let o = unfold(&[
        "ventricle",
        &s(&anatomy),
        "--surface",
        &s(&anatomy),
        "--anterior",
        &pt(a),
        "--inferior",
        &pt(i),
        "--surface-voxel-mm",
        "1",
        "-o",
        &s(&out),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--surface-voxel-mm"), "{}", stderr(&o));
    // nothing was written by the failures
    assert!(!out.join("surface.vtu").exists());
    // an anatomy inside DIR, which surface.vtu could overwrite
    let own = out.join("surface.vtu");
    std::fs::create_dir_all(&out).unwrap();
    write(&own, &CellMesh::from(&v.surface));
    assert_one_line_error(
        &run(&own, a, i, &out, &[]),
        "is an input and would be replaced by the output",
    );
}
