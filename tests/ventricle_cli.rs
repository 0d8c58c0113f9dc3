//! `unfold ventricle` (and the ventricle part of `unfold demo`) through the
//! binary: outputs on the built-in cup, bare-point anatomy, a transfer to a
//! second heart, and one-line errors for inputs that do not fit the
//! contract.

use std::path::Path;
use std::process::Output;
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::nalgebra::{Point3, Vector3};
use unfold::mesh::shapes::{Pose, VentricleParams, VentricleShape, uv_sphere, ventricle_cup};
use unfold::mesh::{CellMesh, CellType, FieldValues, TriMesh};

mod common;
use common::*;

fn cup() -> VentricleShape {
    ventricle_cup(&VentricleParams::default()).unwrap()
}

fn write(path: &Path, mesh: &CellMesh) {
    write_mesh(path, mesh, &WriteOptions::default()).unwrap();
}

/// Runs `unfold ventricle` on `anatomy` in `surface` with the cup's
/// landmarks (`--grid-mm 1.5`), plus `extra`.
fn run(anatomy: &Path, surface: &Path, v: &VentricleShape, out: &Path, extra: &[&str]) -> Output {
    run_heart("ventricle", anatomy, &cup_heart(surface, v), out, extra)
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// A one-component point array as f64.
fn array(m: &CellMesh, name: &str) -> Vec<f64> {
    let f = m
        .point_data
        .get(name)
        .unwrap_or_else(|| panic!("no point array {name}"));
    assert_eq!(f.components(), 1, "{name}");
    assert_eq!(f.tuples(), m.positions.len(), "{name}");
    f.values().to_f64()
}

/// The `aha` labels (an integer array).
fn aha_labels(m: &CellMesh) -> Vec<i32> {
    match m.point_data.get("aha").expect("array aha").values() {
        FieldValues::I32(v) => v.clone(),
        other => panic!("aha is {}", other.type_name()),
    }
}

#[test]
fn the_cup_gives_the_cylinder_the_disk_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let out = dir.path().join("out");
    let o = run(&anatomy, &surface, &v, &out, &[]);
    assert_ok(&o);
    let n = v.anatomy.positions.len();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains(&format!("{n} points, round trip mean"))
            && stdout.contains("17/17 AHA segments non-empty"),
        "{stdout}"
    );
    assert!(stdout.contains(&format!("wrote {}", s(&out.join("report.json")))));
    for f in [
        "normalized.vtu",
        "anatomy.vtu",
        "disk.vtu",
        "aha_segments.csv",
        "report.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(!out.join("transferred.vtu").exists());

    let r = report(&out);
    assert_eq!(r["chamber"], "lv");
    assert_eq!(r["anatomy_points"], n);
    assert_eq!(r["flipped_disk_triangles"], 0);
    assert_eq!(r["folded_disk_edges"], 0);
    assert_eq!(r["overlapping_disk_boundary_edges"], 0);
    let max = r["roundtrip_error_um"]["max"].as_f64().unwrap();
    assert!(max < 5.0, "round trip max {max} um");
    assert_eq!(r["grid_mm"], 1.5);
    assert_eq!(r["inputs"]["anatomy"], s(&anatomy));
    assert_eq!(r["inputs"]["surface"], s(&surface));
    assert!(r.get("transfer").is_none());
    let aha: Vec<u64> = r["aha_points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .collect();
    assert_eq!(aha.len(), 17);
    assert_eq!(aha.iter().sum::<u64>(), n as u64);
    assert_eq!(
        aha.iter().filter(|&&c| c > 0).count(),
        17,
        "the inner cup covers every segment: {aha:?}"
    );

    let norm = read_mesh(out.join("normalized.vtu")).unwrap();
    assert_eq!(norm.positions.len(), n);
    assert_eq!(norm.num_cells(), v.anatomy.triangles.len(), "cells kept");
    let depth = array(&norm, "depth");
    assert!(
        depth.iter().all(|d| (0.0..=1.0).contains(d)),
        "depth in [0, 1]"
    );
    // The anatomy is 4 mm inside S: strictly between S and H.
    assert!(depth.iter().all(|&d| d > 0.0 && d < 1.0));
    for (p, d) in norm.positions.iter().zip(&depth) {
        assert!((p.z - d).abs() < 1e-12, "z is the depth");
        assert!(p.x.hypot(p.y) <= 1.0 + 1e-9, "inside the unit disk: {p}");
    }
    let (xi, zeta) = (array(&norm, "xi"), array(&norm, "zeta"));
    // Each point's round trip, summarized by the report.
    let roundtrip = array(&norm, "roundtrip_error_um");
    assert_eq!(roundtrip.len(), n);
    let r = report(&out);
    let max = roundtrip.iter().copied().fold(0.0, f64::max);
    let mean = roundtrip.iter().sum::<f64>() / n as f64;
    assert!(
        (max - r["roundtrip_error_um"]["max"].as_f64().unwrap()).abs() <= 1e-9 * max.max(1e-12)
    );
    assert!(
        (mean - r["roundtrip_error_um"]["mean"].as_f64().unwrap()).abs()
            <= 1e-9 * mean.max(1e-12) + 1e-15
    );
    assert_eq!((xi.len(), zeta.len()), (n, n));
    let seg = aha_labels(&norm);
    assert!(seg.iter().all(|a| (1..=17).contains(a)));

    let anat = read_mesh(out.join("anatomy.vtu")).unwrap();
    assert_eq!(anat.num_cells(), v.anatomy.triangles.len());
    for (a, b) in anat.positions.iter().zip(&v.anatomy.positions) {
        assert!((a - b).norm() < 1e-9, "the input points, unchanged");
    }
    assert_eq!(array(&anat, "depth"), depth);
    assert_eq!(aha_labels(&anat), seg);

    // aha_segments.csv: per segment, its points and the mean of every
    // scalar array of the anatomy over them, recomputed here.
    let table = std::fs::read_to_string(out.join("aha_segments.csv")).unwrap();
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[..2], ["segment", "points"]);
    let d_col = header.iter().position(|h| *h == "depth").unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 17);
    for (k, row) in rows.iter().enumerate() {
        let label = k as i32 + 1;
        assert_eq!(row[0], label.to_string());
        let members: Vec<f64> = seg
            .iter()
            .zip(&depth)
            .filter(|(a, _)| **a == label)
            .map(|(_, d)| *d)
            .collect();
        assert_eq!(row[1], members.len().to_string(), "segment {label}");
        if members.is_empty() {
            assert_eq!(row[d_col], "", "segment {label}");
        } else {
            let mean = members.iter().sum::<f64>() / members.len() as f64;
            let got: f64 = row[d_col].parse().unwrap();
            assert!(
                (got - mean).abs() < 1e-12,
                "segment {label}: {got} vs {mean}"
            );
        }
    }

    let disk = read_mesh(out.join("disk.vtu")).unwrap();
    assert!(disk.positions.len() >= v.surface.positions.len());
    assert!(
        disk.positions
            .iter()
            .all(|p| p.z == 0.0 && p.x.hypot(p.y) <= 1.0 + 1e-9)
    );
    assert!(disk.point_data.get("xi").is_some() && disk.point_data.get("zeta").is_some());
}

#[test]
fn bare_points_are_mapped_and_written_as_vertex_cells() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (_, surface) = write_cup(dir.path(), &v);
    let n = v.anatomy_points.len();
    // A PLY without faces (no cells at all) and a legacy VTK with VERTICES.
    let ply = dir.path().join("points.ply");
    write(&ply, &CellMesh::from_points(v.anatomy_points.clone()));
    assert_eq!(read_mesh(&ply).unwrap().num_cells(), 0);
    let vtk = dir.path().join("points.vtk");
    let mut with_vertices = CellMesh::from_points(v.anatomy_points.clone());
    for i in 0..n as u32 {
        with_vertices.push_cell(CellType::Vertex, &[i]);
    }
    write(&vtk, &with_vertices);
    for (k, input) in [ply, vtk].iter().enumerate() {
        let out = dir.path().join(format!("out{k}"));
        let o = run(input, &surface, &v, &out, &[]);
        assert_ok(&o);
        let r = report(&out);
        assert_eq!(r["anatomy_points"], n);
        assert!(r["roundtrip_error_um"]["max"].as_f64().unwrap() < 5.0);
        for f in ["normalized.vtu", "anatomy.vtu"] {
            let m = read_mesh(out.join(f)).unwrap();
            assert_eq!(m.positions.len(), n, "{f}");
            assert_eq!(m.num_cells(), n, "{f}: one vertex cell per point");
            assert!(
                m.cells()
                    .enumerate()
                    .all(|(i, (t, vs))| t == CellType::Vertex && vs == [i as u32])
            );
            let depth = array(&m, "depth");
            // 1.5 mm inside S: close to S, never on H.
            assert!(depth.iter().all(|&d| d > 0.0 && d < 0.5), "{f}");
        }
    }
}

#[test]
fn a_transfer_carries_the_anatomy_into_a_moved_heart() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    // The same heart moved by a translation: the transfer is that motion
    // (the chart is built in S's basal frame, so the moved heart gets the
    // same grid; what is left is the streamline integrator's tolerance).
    let shift = Vector3::new(12.0, -7.0, 5.0);
    let moved = ventricle_cup(&VentricleParams {
        pose: Pose::new([0.0; 3], shift.into()),
        ..VentricleParams::default()
    })
    .unwrap();
    let s2 = dir.path().join("surface2.vtp");
    write(&s2, &CellMesh::from(&moved.surface));
    let out = dir.path().join("out");
    let o = run(
        &anatomy,
        &surface,
        &v,
        &out,
        &[
            "--to-surface",
            &s(&s2),
            "--to-anterior",
            // Spaces after the commas are accepted.
            &pt(&moved.anterior).replace(',', ", "),
            "--to-inferior",
            &pt(&moved.inferior),
        ],
    );
    assert_ok(&o);
    let t = read_mesh(out.join("transferred.vtu")).unwrap();
    assert_eq!(t.positions.len(), v.anatomy.positions.len());
    assert_eq!(t.num_cells(), v.anatomy.triangles.len());
    let worst = t
        .positions
        .iter()
        .zip(&v.anatomy.positions)
        .map(|(a, b)| (a - (b + shift)).norm())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.01,
        "transferred points off the moved anatomy by {worst} mm"
    );
    let anat = read_mesh(out.join("anatomy.vtu")).unwrap();
    for name in ["xi", "zeta", "depth"] {
        assert_eq!(array(&t, name), array(&anat, name), "{name}");
    }
    assert_eq!(aha_labels(&t), aha_labels(&anat));
    let r = report(&out);
    let tr = &r["transfer"];
    assert!(tr["seconds"].as_f64().unwrap() > 0.0, "{tr}");
    assert_eq!(tr["points"], v.anatomy.positions.len());
    assert_eq!(tr["surface"], s(&s2));
    // The apex found without --to-apex is the moved apex.
    let apex: Vec<f64> = tr["apex_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let a = Point3::new(apex[0], apex[1], apex[2]);
    assert!((a - moved.apex).norm() < 1e-9, "{a} vs {}", moved.apex);
}

/// `--to-hemisphere R`: on a hemisphere the streamlines are radial, so a
/// point of depth `d` lands at `R - d (R - r_H)` from the base centre.
#[test]
fn a_transfer_onto_a_hemisphere_is_radial_in_depth() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let out = dir.path().join("out");
    let o = run(&anatomy, &surface, &v, &out, &["--to-hemisphere", "30"]);
    assert_ok(&o);
    let t = read_mesh(out.join("transferred.vtu")).unwrap();
    assert_eq!(t.positions.len(), v.anatomy.positions.len());
    let depth = array(&t, "depth");
    // the CLI documents the hemisphere's base centre at the origin
    let h = ventricle_cup(&VentricleParams {
        radius: 30.0,
        length: 30.0,
        base_above_equator: 0.0,
        anatomy_point_depth: 1.5,
        anatomy_surface_depth: 3.0,
        rings: 40,
        ..VentricleParams::default()
    })
    .unwrap();
    assert!(h.base_centre.coords.norm() < 1e-9, "{}", h.base_centre);
    let mut worst: f64 = 0.0;
    for (p, d) in t.positions.iter().zip(&depth) {
        let want = 30.0 - d * (30.0 - 5.0);
        worst = worst.max((p.coords.norm() - want).abs());
    }
    assert!(worst < 0.1, "radius off by {worst} mm");
    assert_eq!(
        report(&out)["transfer"]["surface"],
        "the hemisphere of radius 30 mm"
    );
    // The figures: the anatomy by AHA segment, and the anatomy beside its
    // transfer (3 panels each); both hearts' panels show most segments'
    // colours.
    for name in ["anatomy_aha.png", "transfer.png"] {
        let png = std::fs::read(out.join("figures").join(name)).unwrap();
        let img = unfold::figures::render::Image::from_png(&png).unwrap();
        assert_eq!((img.width(), img.height()), (3 * 480, 400), "{name}");
        for panel in 0..2u32 {
            let mut seen = [false; 17];
            for y in 60..400 {
                for x in panel * 480..(panel + 1) * 480 {
                    let c = img.get(i64::from(x), i64::from(y)).unwrap().rgb();
                    // Shading scales a colour by a light factor k.
                    if let Some(k) = unfold::figures::ventricle::AHA_COLORS
                        .iter()
                        .position(|a| shade_of([c.r, c.g, c.b], [a.r, a.g, a.b]))
                    {
                        seen[k] = true;
                    }
                }
            }
            let n = seen.iter().filter(|&&b| b).count();
            assert!(n >= 10, "{name}, panel {panel}: {n} AHA colours");
        }
    }
    // not both targets at once, and a positive radius
    let o = run(
        &anatomy,
        &surface,
        &v,
        &dir.path().join("o2"),
        &["--to-hemisphere", "30", "--to-surface", &s(&surface)],
    );
    assert!(!o.status.success());
    let o = run(
        &anatomy,
        &surface,
        &v,
        &dir.path().join("o3"),
        &["--to-hemisphere", "-2"],
    );
    assert_one_line_error(&o, "--to-hemisphere must be a finite number > 0");
}

#[test]
fn surfaces_that_are_not_disks_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, _) = write_cup(dir.path(), &v);

    // A hole at the apex: two boundary loops; the one nearest the rim
    // landmarks is the rim, the other is capped (tests/ventricle_openings.rs)
    // and the given apex snaps to the cap's centre.
    let holed = TriMesh::new(
        v.surface.positions.clone(),
        v.surface
            .triangles
            .iter()
            .filter(|t| !t.contains(&(v.apex_index as u32)))
            .copied()
            .collect(),
    );
    let p = dir.path().join("holed.vtp");
    write(&p, &CellMesh::from(&holed));
    let out = dir.path().join("out_holed");
    let o = run(&anatomy, &p, &v, &out, &[]);
    assert_ok(&o);
    let r = report(&out);
    assert_eq!(r["openings"]["loops"].as_array().unwrap().len(), 2);
    assert_eq!(r["openings"]["chosen_by"], "landmarks");
    assert_eq!(r["openings"]["cap_vertices"], 1);

    // Two cups side by side: the second cup's rim is capped, but S is still
    // two pieces.
    let mut two = v.surface.clone();
    let n = two.positions.len() as u32;
    two.positions.extend(
        v.surface
            .positions
            .iter()
            .map(|p| p + Vector3::new(200.0, 0.0, 0.0)),
    );
    two.triangles
        .extend(v.surface.triangles.iter().map(|t| t.map(|i| i + n)));
    let p = dir.path().join("two.vtp");
    write(&p, &CellMesh::from(&two));
    let out = dir.path().join("out_two");
    let o = run(&anatomy, &p, &v, &out, &[]);
    assert_one_line_error(&o, "2 connected components");
    assert_one_line_error(&o, "S is not a disk");
    assert!(!out.join("report.json").exists());

    // A closed surface: no boundary loop.
    let sphere = uv_sphere(16, 32, 40.0);
    let p = dir.path().join("sphere.vtp");
    write(&p, &CellMesh::from(&sphere));
    let out = dir.path().join("out_sphere");
    let o = run(&anatomy, &p, &v, &out, &[]);
    assert_one_line_error(&o, "closed (no boundary loop)");
    assert!(!out.join("report.json").exists());
}

#[test]
fn anatomy_outside_s_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (_, surface) = write_cup(dir.path(), &v);
    let mut shifted = v.anatomy.clone();
    for p in &mut shifted.positions {
        p.x += 100.0;
    }
    let p = dir.path().join("shifted.vtp");
    write(&p, &CellMesh::from(&shifted));
    let out = dir.path().join("out");
    let o = run(&p, &surface, &v, &out, &[]);
    let n = v.anatomy.positions.len();
    assert_one_line_error(&o, &format!("{n} of {n} anatomy points cannot be mapped"));
    assert_one_line_error(&o, "lies outside S");
    assert!(!out.join("report.json").exists());
}

#[test]
fn a_landmark_off_the_rim_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    // 20 mm outward from the rim, in the basal plane.
    let a = v.anterior;
    let outward = Vector3::new(a.x, a.y, 0.0).normalize();
    let off = a + 20.0 * outward;
    let out = dir.path().join("out");
    let o = unfold(&[
        "ventricle",
        &s(&anatomy),
        "--surface",
        &s(&surface),
        "--anterior",
        &pt(&off),
        "--inferior",
        &pt(&v.inferior),
        "--grid-mm",
        "1.5",
        "-o",
        &s(&out),
    ]);
    assert_one_line_error(&o, "anterior landmark");
    assert_one_line_error(&o, "it must lie on the basal rim");
    assert_one_line_error(&o, "20.000 mm from the nearest vertex of S's boundary loop");
    assert!(!out.join("report.json").exists());
}

#[test]
fn bad_flags_and_files_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let out = dir.path().join("out");
    let base = |anatomy: &Path, anterior: &str, extra: &[&str]| {
        let mut args = vec![
            "ventricle".to_string(),
            s(anatomy),
            "--surface".into(),
            s(&surface),
            "--anterior".into(),
            anterior.to_string(),
            "--inferior".into(),
            pt(&v.inferior),
            "-o".into(),
            s(&out),
        ];
        args.extend(extra.iter().map(|x| x.to_string()));
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        unfold(&refs)
    };
    let good = pt(&v.anterior);

    // Malformed landmarks (the argument parser: exit code 2).
    for bad in ["1,2", "1,2,3,4", "a,b,c", "1;2;3"] {
        let o = base(&anatomy, bad, &[]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert_one_line_error(&o, "expected X,Y,Z");
        assert_one_line_error(&o, "--anterior");
    }
    let o = base(&anatomy, "1,nan,3", &[]);
    assert_one_line_error(&o, "not finite");

    // Missing files.
    let missing = dir.path().join("no_such_anatomy.vtp");
    let o = base(&missing, &good, &[]);
    assert_one_line_error(&o, &s(&missing));
    assert_one_line_error(&o, "No such file");
    let o = base(
        &anatomy,
        &good,
        &[
            "--to-surface",
            "/nonexistent/s2.vtp",
            "--to-anterior",
            "0,0,0",
            "--to-inferior",
            "1,0,0",
        ],
    );
    assert_one_line_error(&o, "/nonexistent/s2.vtp");

    // Non-positive settings.
    for g in ["0", "-1", "nan"] {
        let o = base(&anatomy, &good, &["--grid-mm", g]);
        assert_one_line_error(&o, "--grid-mm must be a finite number > 0");
    }
    let o = base(&anatomy, &good, &["--display-exponent", "0"]);
    assert_one_line_error(&o, "--display-exponent must be a finite number > 0");
    let o = base(&anatomy, &good, &["--snap-mm", "-5"]);
    assert_one_line_error(&o, "--snap-mm must be a finite number > 0");

    // A transfer without its landmarks.
    let o = base(&anatomy, &good, &["--to-surface", &s(&surface)]);
    assert_one_line_error(&o, "--to-surface needs --to-anterior and --to-inferior");

    // An output that would overwrite an input.
    let clash = dir.path().join("anatomy.vtu");
    write(&clash, &CellMesh::from(&v.anatomy));
    let o = unfold(&[
        "ventricle",
        &s(&clash),
        "--surface",
        &s(&surface),
        "--anterior",
        &good,
        "--inferior",
        &pt(&v.inferior),
        "-o",
        &s(dir.path()),
    ]);
    assert_one_line_error(&o, "would be overwritten");
    assert!(!out.exists(), "no failed run created the output directory");
}

#[test]
fn the_demo_runs_the_ventricle_pipeline() {
    let dir = tempfile::tempdir().unwrap();
    let o = unfold(&["demo", "-o", &s(dir.path())]);
    assert_ok(&o);
    let out = dir.path().join("ventricle");
    for f in ["normalized.vtu", "anatomy.vtu", "disk.vtu", "report.json"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let r = report(&out);
    assert_eq!(r["flipped_disk_triangles"], 0);
    assert_eq!(r["grid_mm"], 1.0);
    assert!(r["roundtrip_error_um"]["max"].as_f64().unwrap() < 5.0);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("built-in ventricle cup: ") && l.contains("17/17 AHA segments")),
        "{stdout}"
    );
}

#[test]
fn figures_are_written_unless_asked_not_to() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = (dir.path().join("anatomy.vtp"), dir.path().join("s.vtp"));
    write(&anatomy, &CellMesh::from(&v.anatomy));
    write(&surface, &CellMesh::from(&v.surface));
    let out = dir.path().join("out");
    assert_ok(&run(&anatomy, &surface, &v, &out, &[]));
    for name in ["bullseye.png", "disk_aha.png", "cylinder.png"] {
        let png = std::fs::read(out.join("figures").join(name)).unwrap();
        let img = unfold::figures::render::Image::from_png(&png).unwrap();
        assert!(img.width() >= 480 && img.height() == 400, "{name}");
    }
    let bare = dir.path().join("bare");
    assert_ok(&run(&anatomy, &surface, &v, &bare, &["--no-figures"]));
    assert!(!bare.join("figures").exists());
    // A missing array is refused before any work: nothing is written.
    let fresh = dir.path().join("fresh");
    assert_one_line_error(
        &run(
            &anatomy,
            &surface,
            &v,
            &fresh,
            &["--bullseye-array", "nope"],
        ),
        "no point array \"nope\"",
    );
    assert!(
        !fresh.exists(),
        "nothing written for a bad --bullseye-array"
    );
    // With --no-figures it would draw nothing: a usage error, not ignored.
    let o = run(
        &anatomy,
        &surface,
        &v,
        &fresh,
        &["--bullseye-array", "nope", "--no-figures"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--no-figures"), "{}", stderr(&o));
}

/// `--rv-landmarks`: RV insertion points outside the cup, below its rim in
/// the directions of its rim landmarks, give those landmarks back (the rays
/// from the rim's centroid meet S below them), so the same map as
/// `--anterior`/`--inferior`; the report says how they were found.
#[test]
fn rv_insertion_points_give_the_rim_landmarks() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let given = dir.path().join("given");
    assert_ok(&run(&anatomy, &surface, &v, &given, &[]));
    let rim = unfold::mesh::topology::boundary_loops(&v.surface).unwrap();
    let rim = &rim[0];
    let c = rim
        .iter()
        .map(|&i| v.surface.positions[i as usize].coords)
        .sum::<Vector3<f64>>()
        / rim.len() as f64;
    let c = Point3::from(c);
    let down = (v.apex - c).normalize();
    let rv = |p: &Point3<f64>| c + (p - c) * 1.3 + down * 2.0;
    let derived = dir.path().join("derived");
    let o = unfold(&[
        "ventricle",
        &s(&anatomy),
        "--surface",
        &s(&surface),
        "--rv-landmarks",
        &pt(&rv(&v.anterior)),
        &pt(&rv(&v.inferior)),
        "--apex",
        &pt(&v.apex),
        "--grid-mm",
        "1.5",
        "-o",
        &s(&derived),
    ]);
    assert_ok(&o);
    let r = report(&derived);
    let found = &r["inputs"]["rv_landmarks"]["landmarks"];
    for (k, p) in [v.anterior, v.inferior].iter().enumerate() {
        let q: Vec<f64> = (0..3).map(|i| found[k][i].as_f64().unwrap()).collect();
        assert!(
            (Point3::new(q[0], q[1], q[2]) - p).norm() < 1e-9,
            "landmark {k}: {q:?} vs {p}"
        );
    }
    let a = read_mesh(given.join("normalized.vtu")).unwrap();
    let b = read_mesh(derived.join("normalized.vtu")).unwrap();
    for (p, q) in a.positions.iter().zip(&b.positions) {
        assert!((p - q).norm() < 1e-9, "{p} vs {q}");
    }
    // With --anterior, or for the RV, or with one point: one-line errors.
    let bad = |extra: &[&str]| {
        let mut args = vec![
            "ventricle".to_string(),
            s(&anatomy),
            "--surface".into(),
            s(&surface),
            "-o".into(),
            s(&dir.path().join("bad")),
        ];
        args.extend(extra.iter().map(|x| x.to_string()));
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        unfold(&refs)
    };
    let (ra, ri) = (pt(&rv(&v.anterior)), pt(&rv(&v.inferior)));
    assert_one_line_error(
        &bad(&["--rv-landmarks", &ra, &ri, "--anterior", &pt(&v.anterior)]),
        "--rv-landmarks",
    );
    assert_one_line_error(
        &bad(&["--rv-landmarks", &ra, &ri, "--chamber", "rv"]),
        "--rv-landmarks",
    );
    assert_one_line_error(&bad(&["--rv-landmarks", &ra]), "--rv-landmarks");
    // A ray that meets nothing: straight up out of the cup.
    let up = pt(&(c - down * 30.0));
    assert_one_line_error(&bad(&["--rv-landmarks", &up, &ri]), "meets no triangle");
    assert!(!dir.path().join("bad").exists());
}

/// `--layers 3`: each point's transmural layer from its depth, 1 at S to 3
/// at H, in both meshes; no layer column in the segment table.
#[test]
fn layers_label_the_depth_in_equal_bands() {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let out = dir.path().join("out");
    assert_ok(&run(&anatomy, &surface, &v, &out, &["--layers", "3"]));
    let norm = read_mesh(out.join("normalized.vtu")).unwrap();
    let depth = array(&norm, "depth");
    for name in ["normalized.vtu", "anatomy.vtu"] {
        let m = read_mesh(out.join(name)).unwrap();
        let layer = match m.point_data.get("layer").expect("array layer").values() {
            FieldValues::I32(v) => v.clone(),
            other => panic!("layer is {}", other.type_name()),
        };
        for (l, d) in layer.iter().zip(&depth) {
            let expected = ((d * 3.0).floor() as i32 + 1).clamp(1, 3);
            assert_eq!(*l, expected, "{name}: depth {d}");
        }
    }
    let table = std::fs::read_to_string(out.join("aha_segments.csv")).unwrap();
    assert!(!table.lines().next().unwrap().contains("layer"), "{table}");
    for bad in ["0", "101", "x"] {
        let o = run(
            &anatomy,
            &surface,
            &v,
            &dir.path().join("bad"),
            &["--layers", bad],
        );
        assert_one_line_error(&o, "--layers");
    }
}

/// Whether `c` is `base` scaled by a light factor in [0.35, 1] (to within
/// 3 per channel, the rounding of smooth shading).
fn shade_of(c: [u8; 3], base: [u8; 3]) -> bool {
    let (c, b) = (c.map(f64::from), base.map(f64::from));
    let k = (0..3).map(|i| c[i] * b[i]).sum::<f64>() / (0..3).map(|i| b[i] * b[i]).sum::<f64>();
    (0.35..=1.01).contains(&k) && (0..3).all(|i| (c[i] - k * b[i]).abs() <= 3.0)
}
