//! `unfold mitral` with the source's naming (`AL_01.vtp`, `PL_01.vtp`) and
//! without an annulus file (issue 22): the ring found from the leaflets,
//! `series.csv` with initial and final energies and coaptation counts, the
//! plot over the cycle, and one-line errors for messy series directories.

use std::path::Path;
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::shapes::{ValveParams, ValveShape, mitral_valve};
use unfold::mesh::{CellMesh, CellType, TriMesh};

mod common;
use common::*;

fn valve(step: usize) -> ValveShape {
    mitral_valve(&ValveParams {
        annulus_segments: 32,
        depth_segments: 6,
        coaptation_gap: 1.0 + 3.0 * step as f64,
        commissure_gap: 8.0 + step as f64,
        ..ValveParams::default()
    })
    .unwrap()
}

fn write(path: &Path, m: &TriMesh) {
    write_mesh(path, &CellMesh::from(m), &WriteOptions::default()).unwrap();
}

fn write_ring(path: &Path, v: &ValveShape) {
    let mut m = CellMesh::from_points(v.annulus.clone());
    let mut ids: Vec<u32> = (0..v.annulus.len() as u32).collect();
    ids.push(0);
    m.push_cell(CellType::PolyLine, &ids);
    write_mesh(path, &m, &WriteOptions::default()).unwrap();
}

fn mitral(args: &[&str]) -> std::process::Output {
    let mut all = vec!["mitral"];
    all.extend(args);
    unfold(&all)
}

#[test]
fn a_series_named_al_pl_without_annulus_files_gives_the_table_and_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    // Steps 1, 2, 10: ordered by number, not by text.
    for (i, step) in [1usize, 2, 10].into_iter().enumerate() {
        let v = valve(i);
        write(&series.join(format!("AL_{step}.vtp")), &v.anterior);
        write(&series.join(format!("PL_{step}.vtp")), &v.posterior);
    }
    std::fs::write(series.join("notes.txt"), "ignored").unwrap();
    let out = dir.path().join("out");
    let o = mitral(&["--series", &s(&series), "-o", &s(&out)]);
    assert_ok(&o);
    let csv = std::fs::read_to_string(out.join("series.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4, "{csv}");
    let header: Vec<&str> = lines[0].split(',').collect();
    // The columns before issue 22 keep their places (the cohort reads them by name).
    assert_eq!(header[..3], ["step", "anterior_file", "annulus_length_mm"]);
    assert_eq!(header[13], "seconds");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let cells = |l: &str| l.split(',').map(str::to_string).collect::<Vec<_>>();
    let rows: Vec<Vec<String>> = lines[1..].iter().map(|l| cells(l)).collect();
    assert!(rows[0][col("anterior_file")].ends_with("AL_1.vtp"));
    assert!(rows[1][col("anterior_file")].ends_with("AL_2.vtp"));
    assert!(rows[2][col("anterior_file")].ends_with("AL_10.vtp"));
    assert!(rows[0][col("posterior_file")].ends_with("PL_1.vtp"));
    assert_eq!(rows[0][col("annulus_file")], "from the leaflets");
    let f = |r: &Vec<String>, c: &str| r[col(c)].parse::<f64>().unwrap();
    for r in &rows {
        // The relaxation lowers the length energy; every energy is >= 2.
        for e in ["area", "angle", "length"] {
            assert!(f(r, &format!("initial_{e}_energy")) >= 2.0);
            assert!(f(r, &format!("{e}_energy")) >= 2.0);
        }
        assert!(f(r, "length_energy") <= f(r, "initial_length_energy"));
        assert_eq!(f(r, "coaptation_threshold_mm"), 2.0);
        assert!(f(r, "coaptation_near_vertices") >= 0.0);
    }
    // The report of each step agrees with its row.
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("step_001/report.json")).unwrap())
            .unwrap();
    assert_eq!(
        report["distortion"]["initial"]["angle"].as_f64().unwrap(),
        f(&rows[1], "initial_angle_energy")
    );
    assert_eq!(
        report["coaptation_vertices"]["near"].as_f64().unwrap(),
        f(&rows[1], "coaptation_near_vertices")
    );
    assert!(
        report["inputs"]
            .as_str()
            .unwrap()
            .contains("annulus from the leaflets")
    );
    // The coaptation zone shrinks as the valve opens (step 1 closed, 10 open).
    assert!(f(&rows[0], "coaptation_vertices") > f(&rows[2], "coaptation_vertices"));
    // The plot over the cycle: 2 x 2 panels.
    let png = std::fs::read(out.join("figures/series.png")).unwrap();
    let img = unfold::figures::render::Image::from_png(&png).unwrap();
    assert_eq!((img.width(), img.height()), (960, 800));
    // --no-figures writes no plot.
    let out2 = dir.path().join("out2");
    assert_ok(&mitral(&[
        "--series",
        &s(&series),
        "-o",
        &s(&out2),
        "--no-figures",
    ]));
    assert!(!out2.join("figures").exists());
}

#[test]
fn a_valve_without_its_annulus_maps_as_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let v = valve(0);
    let (a, p, r) = (
        dir.path().join("anterior.vtp"),
        dir.path().join("posterior.vtp"),
        dir.path().join("annulus.vtp"),
    );
    write(&a, &v.anterior);
    write(&p, &v.posterior);
    write_ring(&r, &v);
    let (with, without) = (dir.path().join("with"), dir.path().join("without"));
    let base = ["--anterior", &s(&a), "--posterior", &s(&p), "--no-figures"];
    let mut args = base.to_vec();
    let (rs, ws) = (s(&r), s(&with));
    args.extend(["--annulus", &rs, "-o", &ws]);
    assert_ok(&mitral(&args));
    let mut args = base.to_vec();
    let wos = s(&without);
    args.extend(["-o", &wos]);
    assert_ok(&mitral(&args));
    for f in ["valve2d.vtu", "valve3d.vtu"] {
        let (x, y) = (
            read_mesh(with.join(f)).unwrap(),
            read_mesh(without.join(f)).unwrap(),
        );
        let worst = x
            .positions
            .iter()
            .zip(&y.positions)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "{f} differs by {worst} mm");
    }
}

#[test]
fn messy_series_directories_are_one_line_errors_naming_the_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = |d: &Path| mitral(&["--series", &s(d), "-o", &s(&out), "--no-figures"]);
    let v = valve(0);

    // A leaflet without its partner.
    let d = dir.path().join("missing");
    std::fs::create_dir(&d).unwrap();
    for step in ["01", "02"] {
        write(&d.join(format!("AL_{step}.vtp")), &v.anterior);
    }
    write(&d.join("PL_01.vtp"), &v.posterior);
    assert_one_line_error(
        &run(&d),
        "AL_02.vtp: has no posterior partner in the series: expected a PL file for step '02'",
    );

    // Both namings in one directory.
    let d = dir.path().join("ambiguous");
    std::fs::create_dir(&d).unwrap();
    write(&d.join("AL_01.vtp"), &v.anterior);
    write(&d.join("PL_01.vtp"), &v.posterior);
    write(&d.join("anterior_01.vtp"), &v.anterior);
    let o = run(&d);
    assert_one_line_error(&o, "not both");
    let e = stderr(&o);
    assert!(
        e.contains("AL_01.vtp") && e.contains("anterior_01.vtp"),
        "{e}"
    );

    // Two files for one leaflet of one step.
    let d = dir.path().join("twice");
    std::fs::create_dir(&d).unwrap();
    write(&d.join("AL_01.vtp"), &v.anterior);
    write(&d.join("AL-01.vtu"), &v.anterior);
    write(&d.join("PL_01.vtp"), &v.posterior);
    assert_one_line_error(&run(&d), "two anterior files for step '01'");

    // One file naming two roles.
    let d = dir.path().join("both");
    std::fs::create_dir(&d).unwrap();
    write(&d.join("AL_posterior.vtp"), &v.anterior);
    assert_one_line_error(&run(&d), "AL_posterior.vtp: names more than one");

    // Leaflets that share no boundary, the annulus omitted.
    let d = dir.path().join("apart");
    std::fs::create_dir(&d).unwrap();
    let mut far = v.posterior.clone();
    for q in &mut far.positions {
        *q -= v.atrium_direction * 4.0;
    }
    write(&d.join("AL_01.vtp"), &v.anterior);
    write(&d.join("PL_01.vtp"), &far);
    let o = run(&d);
    assert_one_line_error(&o, "the leaflets share no boundary");
    let e = stderr(&o);
    assert!(e.contains("AL_01.vtp") && e.contains("PL_01.vtp"), "{e}");
    // The same for one valve.
    let o = mitral(&[
        "--anterior",
        &s(&d.join("AL_01.vtp")),
        "--posterior",
        &s(&d.join("PL_01.vtp")),
        "-o",
        &s(&out),
    ]);
    assert_one_line_error(&o, "share no boundary");

    // No leaflet at all.
    let d = dir.path().join("empty");
    std::fs::create_dir(&d).unwrap();
    write_ring(&d.join("annulus_01.vtp"), &v);
    assert_one_line_error(&run(&d), "no leaflet files");
}
