//! `unfold ventricle-inverse` through the binary: an `unfold ventricle`
//! run's normalized.vtu carried back onto the same heart (the round trip),
//! a label field drawn on the disk carried onto a heart, and bad inputs
//! (per-point statuses, one-line errors).

use std::path::Path;
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{VentricleParams, ventricle_cup};
use unfold::mesh::{CellMesh, CellType, Field, FieldValues};

mod common;
use common::*;

fn write(path: &Path, mesh: &CellMesh) {
    write_mesh(path, mesh, &WriteOptions::default()).unwrap();
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

fn labels(m: &CellMesh, name: &str) -> Vec<i32> {
    match m.point_data.get(name).expect(name).values() {
        FieldValues::I32(v) => v.clone(),
        other => panic!("{name} is {}", other.type_name()),
    }
}

fn array(m: &CellMesh, name: &str) -> Vec<f64> {
    m.point_data.get(name).expect(name).values().to_f64()
}

#[test]
fn the_normalized_anatomy_maps_back_within_the_round_trip_error() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let h = cup_heart(&surface, &v);
    let out = dir.path().join("out");
    assert_ok(&run_heart(
        "ventricle",
        &anatomy,
        &h,
        &out,
        &["--no-figures"],
    ));
    let max_um = report(&out)["roundtrip_error_um"]["max"].as_f64().unwrap();
    let normalized = out.join("normalized.vtu");
    let n = v.anatomy.positions.len();

    // From the arrays xi, zeta, depth (auto) and from the points (X, Y,
    // depth) on the displayed disk, with three transmural layers.
    for (k, extra) in [vec![], vec!["--coordinates", "points", "--layers", "3"]]
        .iter()
        .enumerate()
    {
        let inv = dir.path().join(format!("inv{k}"));
        let o = run_heart("ventricle-inverse", &normalized, &h, &inv, extra);
        assert_ok(&o);
        assert!(
            stdout(&o).contains(&format!("{n} of {n} points mapped onto")),
            "{}",
            stdout(&o)
        );
        let r = report(&inv);
        assert_eq!(r["points"], n);
        assert_eq!(r["mapped"], n);
        assert_eq!(r["failed"], 0);
        assert_eq!(
            r["inputs"]["coordinates"],
            if k == 0 { "arrays" } else { "points" }
        );
        assert_eq!(r["grid_mm"], 1.5);
        let m = read_mesh(inv.join("mapped.vtu")).unwrap();
        assert_eq!(m.positions.len(), n);
        assert_eq!(m.num_cells(), v.anatomy.triangles.len(), "cells kept");
        // the arrays of normalized.vtu come along
        for name in ["aha", "roundtrip_error_um", "xi", "zeta", "depth"] {
            assert!(m.point_data.get(name).is_some(), "{name}");
        }
        assert!(labels(&m, "inverse_status").iter().all(|&s| s == 0));
        // psi^-1(psi(v)) = v within the reported round trip (the display
        // warp's inversion adds rounding only)
        let tol = max_um * 1e-3 + 1e-7;
        let worst = m
            .positions
            .iter()
            .zip(&v.anatomy.positions)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(worst <= tol, "{worst} mm > {tol} mm");
        if k == 1 {
            let depth = array(&m, "depth");
            for (l, d) in labels(&m, "layer").iter().zip(&depth) {
                assert_eq!(*l, ((d * 3.0).floor() as i32 + 1).clamp(1, 3), "{d}");
            }
        }
    }
}

/// A grid of triangles on the displayed disk at depth 0.5 (the points
/// within radius 0.9), each cell labelled with its quadrant (1..4).
fn disk_label_field() -> CellMesh {
    let k = 12;
    let mut index = vec![u32::MAX; (2 * k + 1) * (2 * k + 1)];
    let mut positions = Vec::new();
    let at = |i: usize, j: usize| {
        let x = (i as f64 - k as f64) / k as f64;
        let y = (j as f64 - k as f64) / k as f64;
        (x, y)
    };
    for i in 0..=2 * k {
        for j in 0..=2 * k {
            let (x, y) = at(i, j);
            if x.hypot(y) <= 0.9 {
                index[i * (2 * k + 1) + j] = positions.len() as u32;
                positions.push(Point3::new(x, y, 0.5));
            }
        }
    }
    let mut m = CellMesh::from_points(positions);
    let mut region = Vec::new();
    for i in 0..2 * k {
        for j in 0..2 * k {
            let id = |a: usize, b: usize| index[a * (2 * k + 1) + b];
            let q = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            if q.contains(&u32::MAX) {
                continue;
            }
            let (x, y) = at(i, j);
            let label = match (x + 0.5 / k as f64 >= 0.0, y + 0.5 / k as f64 >= 0.0) {
                (true, true) => 1,
                (false, true) => 2,
                (false, false) => 3,
                (true, false) => 4,
            };
            m.push_cell(CellType::Triangle, &[q[0], q[1], q[2]]);
            m.push_cell(CellType::Triangle, &[q[0], q[2], q[3]]);
            region.extend([label, label]);
        }
    }
    m.cell_data.insert(Field::labels("region", region));
    m
}

#[test]
fn a_label_field_drawn_on_the_disk_is_carried_onto_the_heart() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (_, surface) = write_cup(dir.path(), &v);
    let h = cup_heart(&surface, &v);
    let field = disk_label_field();
    let input = dir.path().join("regions.vtu");
    write(&input, &field);
    let inv = dir.path().join("inv");
    let o = run_heart("ventricle-inverse", &input, &h, &inv, &["--layers", "2"]);
    assert_ok(&o);
    let r = report(&inv);
    assert_eq!(r["inputs"]["coordinates"], "points");
    assert_eq!(r["failed"], 0);
    let m = read_mesh(inv.join("mapped.vtu")).unwrap();
    assert_eq!(m.num_cells(), field.num_cells());
    assert!(m.cells().eq(field.cells()), "the cells, unchanged");
    assert_eq!(
        m.cell_data.get("region").unwrap().values(),
        field.cell_data.get("region").unwrap().values(),
        "the label field comes along"
    );
    // depth 0.5 is the second of two layers
    assert!(labels(&m, "layer").iter().all(|&l| l == 2));
    // Forward again through `unfold ventricle`: the drawing comes back.
    let fwd = dir.path().join("fwd");
    assert_ok(&run_heart(
        "ventricle",
        &inv.join("mapped.vtu"),
        &h,
        &fwd,
        &["--no-figures"],
    ));
    // (compared on the harmonic disk: the display warp r^(1/3) would
    // magnify the integrator's tolerance at the centre)
    let back = read_mesh(fwd.join("normalized.vtu")).unwrap();
    for name in ["xi", "zeta", "depth"] {
        let worst = array(&back, name)
            .iter()
            .zip(array(&m, name))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "{name}: {worst}");
    }
    assert!(array(&m, "depth").iter().all(|&d| d == 0.5));
}

#[test]
fn points_off_the_cylinder_get_a_status_and_bad_inputs_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (_, surface) = write_cup(dir.path(), &v);
    let h = cup_heart(&surface, &v);

    // A good point, one below H (depth 1.5), one off the disk (X = 1.5),
    // one above S (depth -0.1): statuses 0, 1, 2, 1.
    let pts = CellMesh::from_points(vec![
        Point3::new(0.2, 0.3, 0.5),
        Point3::new(0.2, 0.3, 1.5),
        Point3::new(1.5, 0.0, 0.5),
        Point3::new(0.0, 0.0, -0.1),
    ]);
    let input = dir.path().join("points.vtu");
    write(&input, &pts);
    let inv = dir.path().join("inv");
    let o = run_heart("ventricle-inverse", &input, &h, &inv, &["--layers", "4"]);
    assert_ok(&o);
    assert!(
        stdout(&o).contains("1 of 4 points mapped") && stdout(&o).contains("3 not"),
        "{}",
        stdout(&o)
    );
    let r = report(&inv);
    assert_eq!(r["failed"], 3);
    assert_eq!(r["failures"]["not_on_cylinder"], 2);
    assert_eq!(r["failures"]["off_disk"], 1);
    let listed = r["first_failures"].as_array().unwrap();
    assert_eq!(listed.len(), 3);
    assert_eq!(listed[0]["point"], 1);
    assert!(
        listed[0]["reason"]
            .as_str()
            .unwrap()
            .contains("depth must be in [0, 1]"),
        "{listed:?}"
    );
    assert!(
        listed[1]["reason"]
            .as_str()
            .unwrap()
            .contains("outside the flattened S")
    );
    let m = read_mesh(inv.join("mapped.vtu")).unwrap();
    assert_eq!(labels(&m, "inverse_status"), [0, 1, 2, 1]);
    assert_eq!(labels(&m, "layer"), [3, 0, 0, 0]);
    // the points not mapped sit at the centre of the base, the report says
    let at: Vec<f64> = r["failed_points_at_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let nowhere = Point3::new(at[0], at[1], at[2]);
    assert!(m.positions[1..].iter().all(|p| (p - nowhere).norm() < 1e-9));
    assert!((m.positions[0] - nowhere).norm() > 1.0);
    assert_eq!(m.num_cells(), 4, "a vertex cell per point");

    // Every point off: an error, nothing written.
    let off = CellMesh::from_points(vec![Point3::new(2.0, 0.0, 0.5), Point3::new(0.0, 0.0, 3.0)]);
    let input = dir.path().join("off.vtu");
    write(&input, &off);
    let none = dir.path().join("none");
    let o = run_heart("ventricle-inverse", &input, &h, &none, &[]);
    assert_one_line_error(&o, "none of its 2 points maps onto the heart");
    assert!(!none.exists());

    // One or two of the arrays alone; --coordinates arrays without them.
    let mut partial = pts.clone();
    partial
        .point_data
        .insert(Field::scalars("xi", vec![0.0; 4]));
    partial
        .point_data
        .insert(Field::scalars("depth", vec![0.5; 4]));
    let input = dir.path().join("partial.vtu");
    write(&input, &partial);
    let o = run_heart("ventricle-inverse", &input, &h, &none, &[]);
    assert_one_line_error(
        &o,
        "has the point array(s) xi, depth but not all of xi, zeta, depth",
    );
    let o = run_heart(
        "ventricle-inverse",
        &input,
        &h,
        &none,
        &["--coordinates", "arrays"],
    );
    assert_one_line_error(&o, "no point array zeta");
    // A vector array named depth.
    let mut vector = pts.clone();
    vector.point_data.insert(Field::scalars("xi", vec![0.0; 4]));
    vector
        .point_data
        .insert(Field::scalars("zeta", vec![0.0; 4]));
    vector
        .point_data
        .insert(Field::vectors("depth", &[[0.5; 3]; 4]));
    let input = dir.path().join("vector.vtu");
    write(&input, &vector);
    let o = run_heart("ventricle-inverse", &input, &h, &none, &[]);
    assert_one_line_error(&o, "point array depth has 3 component(s)");

    // Missing file, output clashing with the input, bad flags.
    let missing = dir.path().join("missing.vtu");
    let o = run_heart("ventricle-inverse", &missing, &h, &none, &[]);
    assert_one_line_error(&o, "No such file");
    let clash = dir.path().join("mapped.vtu");
    write(&clash, &pts);
    let o = run_heart("ventricle-inverse", &clash, &h, dir.path(), &[]);
    assert_one_line_error(&o, "would be overwritten");
    let o = run_heart(
        "ventricle-inverse",
        &clash,
        &h,
        &none,
        &["--display-exponent", "0"],
    );
    assert_one_line_error(&o, "--display-exponent must be a finite number > 0");
    let o = run_heart("ventricle-inverse", &clash, &h, &none, &["--layers", "0"]);
    assert_one_line_error(&o, "--layers");
    assert!(!none.exists());
}
