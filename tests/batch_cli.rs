//! `unfold batch` and `unfold cohort` through the binary (issue 19): a
//! manifest with a broken subject finishes the others and reports the
//! broken one; a rerun skips the subjects done with the same inputs and
//! options and runs the ones whose options changed; the cohort table has a
//! row per subject with its covariates and report scalars; bad manifests
//! are refused in one line before anything runs.

use std::path::Path;
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::CellMesh;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};

mod common;
use common::*;

fn slab(dir: &Path, name: &str, cells_radial: usize) {
    let mesh = placenta_slab(&PlacentaParams {
        cells_radial,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh;
    write_mesh(
        dir.join(name),
        &CellMesh::from(&mesh),
        &WriteOptions::default(),
    )
    .unwrap();
}

fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_path(path)
        .unwrap();
    r.records()
        .map(|x| x.unwrap().iter().map(str::to_string).collect())
        .collect()
}

#[test]
fn a_cohort_runs_reports_failures_and_reruns_only_what_changed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("meshes")).unwrap();
    slab(&d.join("meshes"), "s1.vtu", 5);
    slab(&d.join("meshes"), "s3.vtu", 6);
    let manifest = d.join("cohort.csv");
    let write_manifest = |s3_template: &str| {
        std::fs::write(
            &manifest,
            format!(
                "id,organ,input,template,no-figures,grid,spacing-mm,solver,max-iterations,\
                 ga_weeks,group\n\
                 s1,placenta,meshes/s1.vtu,,true,,,,,31,twin\n\
                 s2,placenta,meshes/missing.vtu,,true,,,,,28,singleton\n\
                 s3,placenta,meshes/s3.vtu,{s3_template},yes,\"-80,80,-80,80,-30,30\",4,,,35,\
                 singleton\n\
                 s4,placenta,meshes/s1.vtu,,true,,,gd,3,30,twin\n"
            ),
        )
        .unwrap();
    };
    write_manifest("");
    let out = d.join("out");
    let run = || unfold(&["batch", &s(&manifest), "-o", &s(&out), "--jobs", "2"]);

    let o = run();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_one_line_error(&o, "1 of 4 subjects failed (first: s2)");
    let text = stdout(&o);
    assert!(text.contains("s1 (placenta): done"), "{text}");
    assert!(text.contains("s3 (placenta): done"), "{text}");
    assert!(text.contains("s2 (placenta): failed"), "{text}");
    // a solver stopped early: outputs kept, not a failure, marked in the table
    assert!(text.contains("s4 (placenta): not converged"), "{text}");
    assert!(text.contains("1 not converged"), "{text}");
    assert!(out.join("s4").join("report.json").is_file());
    for id in ["s1", "s3"] {
        assert!(out.join(id).join("report.json").is_file(), "{id}");
        assert!(out.join("logs").join(format!("{id}.log")).is_file(), "{id}");
    }
    assert!(!out.join("s2").exists());
    let failures = csv_rows(&out.join("failures.csv"));
    assert_eq!(failures.len(), 2, "{failures:?}");
    assert_eq!(failures[1][0], "s2");
    assert_eq!(failures[1][2], "1");
    assert!(failures[1][3].contains("missing.vtu"), "{failures:?}");

    let cohort = csv_rows(&out.join("cohort.csv"));
    assert_eq!(cohort.len(), 5, "a header and four subjects");
    let col = |name: &str| cohort[0].iter().position(|h| h == name).unwrap();
    assert_eq!(
        &cohort[0][..5],
        ["id", "organ", "status", "ga_weeks", "group"]
    );
    assert_eq!(cohort[1][col("ga_weeks")], "31");
    assert_eq!(cohort[2][col("status")], "missing");
    assert_eq!(cohort[3][col("group")], "singleton");
    assert_eq!(cohort[1][col("inverted_tets")], "0");
    assert_eq!(cohort[3][col("folded_faces")], "0");
    assert!(!cohort[0].iter().any(|h| h.starts_with("provenance")));
    assert_eq!(cohort[1][col("converged")], "1");
    assert_eq!(cohort[4][col("converged")], "0");

    // a rerun skips the subjects done with the same inputs and options
    let before = std::fs::read(out.join("s1").join("report.json")).unwrap();
    let o = run();
    assert_eq!(o.status.code(), Some(1));
    let text = stdout(&o);
    assert!(text.contains("s1 (placenta): skipped"), "{text}");
    assert!(text.contains("s3 (placenta): skipped"), "{text}");
    assert!(text.contains("s4 (placenta): skipped"), "{text}");
    assert!(text.contains("3 skipped"), "{text}");
    assert_eq!(
        std::fs::read(out.join("s1").join("report.json")).unwrap(),
        before
    );

    // an option changed: that subject runs again
    write_manifest("ellipsoid");
    let o = run();
    let text = stdout(&o);
    assert!(text.contains("s1 (placenta): skipped"), "{text}");
    assert!(text.contains("s3 (placenta): done"), "{text}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("s3").join("report.json")).unwrap())
            .unwrap();
    assert!(
        r["provenance"]["command_line"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a == "--template=ellipsoid")
    );

    // `unfold cohort` alone rebuilds the table
    std::fs::remove_file(out.join("cohort.csv")).unwrap();
    let o = unfold(&["cohort", &s(&out)]);
    assert_ok(&o);
    assert_eq!(csv_rows(&out.join("cohort.csv")).len(), 5);
}

#[test]
fn bad_manifests_are_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out");
    for (name, text, needle) in [
        (
            "no_id.csv",
            "organ,input\nplacenta,a.vtu\n",
            "no 'id' column",
        ),
        (
            "organ.csv",
            "id,organ\ns1,liver\n",
            "organ 'liver' is not one of",
        ),
        (
            "twice.csv",
            "id,organ\ns1,mitral\ns1,mitral\n",
            "appears twice",
        ),
        (
            "path.csv",
            "id,organ\n../x,mitral\n",
            "not a usable directory name",
        ),
        (
            "option.csv",
            "id,organ,input,surface\ns1,placenta,a.vtu,s.vtu\n",
            "'surface' is not an option of unfold placenta",
        ),
        (
            "switch.csv",
            "id,organ,input,no-figures\ns1,placenta,a.vtu,maybe\n",
            "'no-figures' is a switch",
        ),
        ("empty.csv", "id,organ\n", "no subject rows"),
        // as spreadsheets export them
        (
            "semicolons.csv",
            "id;organ;input\ns1;placenta;a.vtu\n",
            "separated by semicolons, and a manifest's by commas",
        ),
        (
            "tabs.csv",
            "id\torgan\tinput\ns1\tplacenta\ta.vtu\n",
            "separated by tabs",
        ),
        (
            "capitals.csv",
            "ID,Organ,Input\ns1,placenta,a.vtu\n",
            "column names are lower case ('id', not 'ID')",
        ),
    ] {
        let m = d.join(name);
        std::fs::write(&m, text).unwrap();
        let o = unfold(&["batch", &s(&m), "-o", &s(&out)]);
        assert_one_line_error(&o, needle);
        assert!(!out.exists(), "{name}: nothing made");
    }
    let o = unfold(&["batch", &s(&d.join("none.csv")), "-o", &s(&out)]);
    assert_one_line_error(&o, "none.csv");
    let o = unfold(&["cohort", &s(&out)]);
    assert_one_line_error(&o, "subjects.csv");
}

/// A manifest as a spreadsheet saves it: a byte-order mark, CRLF line
/// ends, blank trailing lines, spaces around cells and in a path. It runs.
#[test]
fn a_spreadsheet_export_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("sub one")).unwrap();
    slab(&d.join("sub one"), "mesh.vtu", 5);
    let manifest = d.join("cohort.csv");
    std::fs::write(
        &manifest,
        "\u{feff}id,organ,input,no-figures, ga_weeks \r\n\
         s1 , placenta , sub one/mesh.vtu , true , 31\r\n\r\n",
    )
    .unwrap();
    let out = d.join("out");
    let o = unfold(&["batch", &s(&manifest), "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("s1/report.json").is_file());
    let rows = csv_rows(&out.join("cohort.csv"));
    let col = rows[0]
        .iter()
        .position(|c| c == "ga_weeks")
        .expect("ga_weeks");
    assert_eq!(rows[1][col], "31");
}
