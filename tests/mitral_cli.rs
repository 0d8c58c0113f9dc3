//! `unfold mitral` through the binary: outputs, a time series, and one-line
//! errors for inputs that do not fit the contract.

use std::path::{Path, PathBuf};
use std::process::Output;
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::reindex::compact_vertices;
use unfold::mesh::shapes::{ValveParams, mitral_valve};
use unfold::mesh::{CellMesh, CellType, TriMesh};

mod common;
#[path = "common/fixtures.rs"]
mod fixtures;
use common::*;
use fixtures::*;

/// `unfold mitral` on the valve files.
fn run_files(files: &[PathBuf; 3], out: &Path, extra: &[&str]) -> Output {
    mitral_on_files(files, out, extra)
}

#[test]
fn a_valve_gives_both_maps_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let files = write_valve(dir.path(), "", &v.anterior, &v.posterior, &v.annulus);
    let out = dir.path().join("out");
    let o = run_files(&files, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let n = v.anterior.positions.len() + v.posterior.positions.len();
    // the figures, one per map, as PNG of the default size
    for name in [
        "map_carpentier.png",
        "map_coaptation.png",
        "map_tenting_mm.png",
    ] {
        let png = std::fs::read(out.join("figures").join(name)).unwrap();
        let img = unfold::figures::render::Image::from_png(&png).unwrap();
        assert_eq!((img.width(), img.height()), (960, 400), "{name}");
    }
    for name in ["valve3d.vtu", "valve2d.vtu"] {
        let m = read_mesh(out.join(name)).unwrap();
        assert_eq!(m.positions.len(), n, "{name}");
        for array in [
            "leaflet",
            "u_gradient",
            "u_interval",
            "checker",
            "carpentier",
            "length_energy",
            "coaptation",
            "tenting_mm",
            "uv",
        ] {
            assert!(m.point_data.get(array).is_some(), "{name}: {array}");
        }
        for array in ["area_energy", "angle_energy"] {
            assert!(m.cell_data.get(array).is_some(), "{name}: {array}");
        }
    }
    let flat = read_mesh(out.join("valve2d.vtu")).unwrap();
    assert!(flat.positions.iter().all(|p| p.z == 0.0));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for key in [
        "annulus_length_mm",
        "u_extent_mm",
        "saddle_horn_height_mm",
        "area_above_plane_mm2",
        "flipped_triangles",
        "relax",
        "seconds",
    ] {
        assert!(r.get(key).is_some(), "{key}");
    }
    assert_eq!(r["flipped_triangles"], 0);
    assert_eq!(r["relax"], "sd");
    for k in ["anterior", "posterior"] {
        assert!(r["leaflet_area_mm2"][k].as_f64().unwrap() > 0.0);
    }
    for stage in ["initial", "final"] {
        for e in ["area", "angle", "length"] {
            assert!(r["distortion"][stage][e].is_f64(), "{stage}.{e}");
        }
    }
    // Straight mode: the u extent is the annulus length.
    let out2 = dir.path().join("straight");
    let o = run_files(
        &files,
        &out2,
        &["--annulus-mode", "straight", "--relax", "spring"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out2.join("report.json")).unwrap()).unwrap();
    let (u, l) = (
        r["u_extent_mm"].as_f64().unwrap(),
        r["annulus_length_mm"].as_f64().unwrap(),
    );
    assert!((u - l).abs() < 1e-9 * l, "{u} {l}");
    assert_eq!(r["relax"], "spring");
}

#[test]
fn the_ring_may_be_a_text_file_in_any_order() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let files = write_valve(dir.path(), "", &v.anterior, &v.posterior, &v.annulus);
    let n = v.annulus.len();
    let mut text = String::from("x,y,z\n");
    for i in (0..n).rev() {
        let p = v.annulus[(i + 7) % n];
        text.push_str(&format!("{:?},{:?},{:?}\n", p.x, p.y, p.z));
    }
    let ring = dir.path().join("ring.csv");
    std::fs::write(&ring, text).unwrap();
    let out = dir.path().join("out");
    let o = run_files(
        &[files[0].clone(), files[1].clone(), ring],
        &out,
        &["--no-figures"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!out.join("figures").exists(), "--no-figures writes none");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    // The anterolateral commissure found from the geometry alone.
    let c = &r["commissures_mm"][0];
    let al = v.annulus[0];
    let d = ((c[0].as_f64().unwrap() - al.x).powi(2)
        + (c[1].as_f64().unwrap() - al.y).powi(2)
        + (c[2].as_f64().unwrap() - al.z).powi(2))
    .sqrt();
    assert!(d < 1e-9, "{d}");
}

#[test]
fn a_series_gives_one_set_per_step_and_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    for step in 0..3 {
        let v = mitral_valve(&ValveParams {
            annulus_segments: 32,
            depth_segments: 6,
            coaptation_gap: 1.0 + 3.0 * step as f64,
            commissure_gap: 8.0 + step as f64,
            ..ValveParams::default()
        })
        .unwrap();
        write_valve(
            &series,
            &format!("t{step:02}_"),
            &v.anterior,
            &v.posterior,
            &v.annulus,
        );
    }
    let out = dir.path().join("out");
    let o = unfold(&["mitral", "--series", &s(&series), "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    for step in 0..3 {
        let d = out.join(format!("step_{step:03}"));
        for f in ["valve3d.vtu", "valve2d.vtu", "report.json"] {
            assert!(d.join(f).is_file(), "{}", d.join(f).display());
        }
    }
    let csv = std::fs::read_to_string(out.join("series.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4, "{csv}");
    assert!(lines[0].starts_with("step,"));
    assert!(lines[1].contains("t00_anterior"));
    // The coaptation zone shrinks as the valve opens.
    let col = lines[0]
        .split(',')
        .position(|h| h == "coaptation_vertices")
        .unwrap();
    let counts: Vec<usize> = lines[1..]
        .iter()
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect();
    assert!(counts[0] > counts[2], "{counts:?}");

    // A step missing its annulus file (when the others have one) is a
    // clear error naming it.
    std::fs::remove_file(series.join("t01_annulus.vtp")).unwrap();
    let o = unfold(&["mitral", "--series", &s(&series), "-o", &s(&out)]);
    assert_one_line_error(&o, "t01_anterior.vtp: step 't01' has no annulus file");
}

#[test]
fn inputs_that_do_not_fit_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let out = dir.path().join("out");

    // A leaflet that does not touch the ring.
    let mut far = v.posterior.clone();
    for p in &mut far.positions {
        *p -= v.atrium_direction * 6.0;
    }
    let files = write_valve(dir.path(), "far_", &v.anterior, &far, &v.annulus);
    let o = run_files(&files, &out, &[]);
    assert_one_line_error(&o, "does not touch the annulus ring");

    // A ring with only one junction: the posterior leaflet loses the
    // triangles along one end of its annulus, so the arcs meet once.
    let mut short = v.posterior.clone();
    let strip: Vec<u32> = v.posterior_longitudes[..2]
        .iter()
        .flatten()
        .copied()
        .collect();
    short
        .triangles
        .retain(|t| !t.iter().any(|x| strip.contains(x)));
    let short = compact(&short);
    let files = write_valve(dir.path(), "short_", &v.anterior, &short, &v.annulus);
    let o = run_files(&files, &out, &[]);
    assert_one_line_error(&o, "commissures");

    // A leaflet with a small hole: closed by the repair, and counted.
    let mut holed = v.anterior.clone();
    let centre = v.anterior_longitudes[v.anterior_longitudes.len() / 2][4];
    holed.triangles.retain(|t| !t.contains(&centre));
    let holed = compact(&holed);
    let files = write_valve(dir.path(), "holed_", &holed, &v.posterior, &v.annulus);
    let o = run_files(&files, &out, &["--no-figures"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        r["repair"]["anterior"]["holes_filled"], 1,
        "{}",
        r["repair"]
    );
    assert_eq!(
        r["repair"]["posterior"]["holes_filled"], 0,
        "{}",
        r["repair"]
    );
    assert_eq!(r["flipped_triangles"], 0);

    // A leaflet with an opening too large to be a hole (not a disk).
    let cols = v.anterior_longitudes.len();
    let rows = v.anterior_longitudes[0].len();
    let inside: Vec<u32> = (2..cols - 2)
        .flat_map(|c| (2..rows - 2).map(move |r| (c, r)))
        .map(|(c, r)| v.anterior_longitudes[c][r])
        .collect();
    let mut frame = v.anterior.clone();
    frame
        .triangles
        .retain(|t| !t.iter().any(|x| inside.contains(x)));
    let frame = compact(&frame);
    let files = write_valve(dir.path(), "frame_", &frame, &v.posterior, &v.annulus);
    let o = run_files(&files, &dir.path().join("out_frame"), &[]);
    assert_one_line_error(&o, "boundary loops");

    // Bad options.
    let files = write_valve(dir.path(), "ok_", &v.anterior, &v.posterior, &v.annulus);
    for (flag, value) in [
        ("--coaptation-mm", "0"),
        ("--tolerance-mm", "nan"),
        ("--step-scale", "0"),
    ] {
        let o = run_files(&files, &out, &[flag, value]);
        assert_one_line_error(&o, flag);
    }
    let o = run_files(&files, &out, &["--init", "sideways"]);
    assert_one_line_error(&o, "--init");
    // A ring file with two polylines.
    let mut two = ring_mesh(&v.annulus);
    two.push_cell(CellType::PolyLine, &[0, 1, 2]);
    let ring2 = dir.path().join("two.vtp");
    write_mesh(&ring2, &two, &WriteOptions::default()).unwrap();
    let o = run_files(&[files[0].clone(), files[1].clone(), ring2], &out, &[]);
    assert_one_line_error(&o, "2 polylines");
}

/// Drops the vertices no triangle uses (keeping the order of the rest).
fn compact(m: &TriMesh) -> TriMesh {
    let c = compact_vertices(&m.positions, &m.point_data, &m.triangles).unwrap();
    TriMesh::new(c.positions, c.elements)
}

#[test]
fn the_demo_runs_the_mitral_pipeline() {
    let dir = tempfile::tempdir().unwrap();
    let o = unfold(&["demo", "-o", &s(dir.path())]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["valve3d.vtu", "valve2d.vtu", "report.json"] {
        assert!(dir.path().join("mitral").join(f).is_file(), "{f}");
    }
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("mitral/report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(r["flipped_triangles"], 0);
    assert_eq!(r["folded_edges"], 0);
    assert_eq!(r["overlapping_boundary_edges"], 0);
}

/// An annulus given as separate 2-point line segments (as meshio and many
/// tools write a curve), in shuffled order, gives the same valve as the
/// one poly-line; segments that do not form one ring are a one-line error.
#[test]
fn an_annulus_of_line_segments_is_chained_into_the_ring() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let files = write_valve(dir.path(), "", &v.anterior, &v.posterior, &v.annulus);
    let n = v.annulus.len() as u32;
    let segments = |order: &mut dyn Iterator<Item = u32>| {
        let mut m = CellMesh::from_points(v.annulus.clone());
        for i in order {
            m.push_cell(CellType::Line, &[i, (i + 1) % n]);
        }
        m
    };
    let seg_path = dir.path().join("ring_segments.vtu");
    // every third segment first, then the rest: same ring, another order
    let mut order = (0..n)
        .filter(|i| i % 3 == 0)
        .chain((0..n).filter(|i| i % 3 != 0));
    write_mesh(&seg_path, &segments(&mut order), &WriteOptions::default()).unwrap();
    let polyline_out = dir.path().join("polyline");
    let segments_out = dir.path().join("segments");
    assert_ok(&run_files(&files, &polyline_out, &["--no-figures"]));
    let seg_files = [files[0].clone(), files[1].clone(), seg_path];
    assert_ok(&run_files(&seg_files, &segments_out, &["--no-figures"]));
    for f in ["valve3d.vtu", "valve2d.vtu"] {
        let a = read_mesh(polyline_out.join(f)).unwrap();
        let b = read_mesh(segments_out.join(f)).unwrap();
        assert_eq!(a.positions, b.positions, "{f}");
    }
    // A branch is refused with its vertex named.
    let mut branched = segments(&mut (0..n));
    branched.push_cell(CellType::Line, &[0, n / 2]);
    let bad = dir.path().join("branched.vtu");
    write_mesh(&bad, &branched, &WriteOptions::default()).unwrap();
    let bad_files = [files[0].clone(), files[1].clone(), bad];
    assert_one_line_error(
        &run_files(&bad_files, &dir.path().join("bad"), &["--no-figures"]),
        "is used by 3 segments",
    );
}

/// `m` renumbered in the order its triangles first use its vertices (the
/// order welding its soup gives back).
fn first_use_order(m: &TriMesh) -> TriMesh {
    let (positions, triangles, _) = common::first_use_order(&m.positions, &m.triangles);
    TriMesh::new(positions, triangles)
}

/// `m` as a triangle soup, every 4th triangle written twice.
fn soup_with_duplicates(m: &TriMesh) -> (TriMesh, usize) {
    let (mut out, mut dups) = (TriMesh::default(), 0);
    for (t, tri) in m.triangles.iter().enumerate() {
        let copies = if t % 4 == 0 { 2 } else { 1 };
        dups += copies - 1;
        for _ in 0..copies {
            let base = out.positions.len() as u32;
            out.positions
                .extend(tri.iter().map(|&v| m.positions[v as usize]));
            out.triangles.push([base, base + 1, base + 2]);
        }
    }
    (out, dups)
}

#[test]
fn a_leaflet_given_as_a_triangle_soup_maps_like_the_clean_one() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let anterior = first_use_order(&v.anterior);
    let (soup, dups) = soup_with_duplicates(&anterior);
    let clean = write_valve(dir.path(), "clean_", &anterior, &v.posterior, &v.annulus);
    let messy = write_valve(dir.path(), "soup_", &soup, &v.posterior, &v.annulus);
    let (oc, os) = (dir.path().join("clean"), dir.path().join("soup"));
    for (files, out) in [(&clean, &oc), (&messy, &os)] {
        let o = run_files(files, out, &["--no-figures"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(os.join("report.json")).unwrap()).unwrap();
    let ra = &r["repair"]["anterior"];
    assert_eq!(
        ra["welded_vertices"],
        soup.positions.len() - anterior.positions.len(),
        "{ra}"
    );
    assert_eq!(ra["duplicate_elements"], dups, "{ra}");
    assert_eq!(r["repair"]["posterior"]["welded_vertices"], 0);
    let (a, b) = (
        read_mesh(oc.join("valve2d.vtu")).unwrap(),
        read_mesh(os.join("valve2d.vtu")).unwrap(),
    );
    assert_eq!(a.positions.len(), b.positions.len());
    let worst = a
        .positions
        .iter()
        .zip(&b.positions)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-6, "valve2d differs by {worst} mm");
}
