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
#[path = "common/scan.rs"]
mod scan;
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

/// The BIDS file-name pattern `sub-<label>(_<key>-<value>)*_<suffix>.<ext>`
/// (labels, values and the suffix alphanumeric).
fn is_bids_name(name: &str) -> bool {
    let alnum = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric());
    let Some((stem, ext)) = name.split_once('.') else {
        return false;
    };
    let parts: Vec<&str> = stem.split('_').collect();
    let Some((suffix, entities)) = parts.split_last() else {
        return false;
    };
    alnum(suffix)
        && ext.split('.').all(alnum)
        && entities.first().is_some_and(|e| e.starts_with("sub-"))
        && entities
            .iter()
            .all(|e| e.split_once('-').is_some_and(|(k, v)| alnum(k) && alnum(v)))
}

/// `unfold batch --layout bids`: two placentas with a T2w image give a
/// BIDS derivative dataset: `dataset_description.json` with its required
/// keys, every subject's files named by the BIDS pattern (the pulled-back
/// image, the meshes, the report, the displacement field as an `xfm`
/// file holding what `--displacement` writes), the group maps at the top,
/// the default layout's files in `OUT/work/`.
#[test]
fn a_bids_batch_writes_a_derivative_dataset() {
    use unfold::mesh::nalgebra::Vector3;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let grid = "-100,100,-100,100,-30,30";
    let mut manifest_text = "id,organ,input,image,grid,spacing-mm,no-figures\n".to_string();
    for (id, n) in [("p-1", 5), ("p_2", 6)] {
        let sd = d.join("in").join(id);
        std::fs::create_dir_all(&sd).unwrap();
        slab(&sd, "mesh.vtu", n);
        let mesh = unfold::io::read_tet_mesh(sd.join("mesh.vtu")).unwrap();
        let img = scan::image_around(&mesh, [2.0; 3], 1, Vector3::zeros(), |p, _| p.x);
        unfold::io::write_image(sd.join("t2w.nii.gz"), &img).unwrap();
        manifest_text.push_str(&format!(
            "{id},placenta,in/{id}/mesh.vtu,in/{id}/t2w.nii.gz,\"{grid}\",4,true\n"
        ));
    }
    let manifest = d.join("m.csv");
    std::fs::write(&manifest, &manifest_text).unwrap();
    let out = d.join("out");
    let o = unfold(&[
        "batch",
        &s(&manifest),
        "-o",
        &s(&out),
        "--jobs",
        "2",
        "--layout",
        "bids",
    ]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    let desc: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("dataset_description.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(desc["BIDSVersion"], "1.9.0");
    assert_eq!(desc["DatasetType"], "derivative");
    assert!(desc["Name"].is_string());
    assert_eq!(desc["GeneratedBy"][0]["Name"], "unfold");
    assert_eq!(desc["GeneratedBy"][0]["Version"], env!("CARGO_PKG_VERSION"));
    assert!(
        desc["GeneratedBy"][0]["Description"]
            .as_str()
            .unwrap()
            .contains("--layout bids")
    );
    for label in ["p1", "p2"] {
        let sub = out.join(format!("sub-{label}"));
        for f in [
            "desc-unfold_report.json",
            "desc-original_mesh.vtu",
            "space-placentaTemplate_desc-flattened_mesh.vtu",
            "space-placentaTemplate_T2w.nii.gz",
            "space-placentaTemplate_desc-t2wZ_stat.nii.gz",
            "from-native_to-placentaTemplate_mode-image_xfm.nii.gz",
        ] {
            let p = sub.join(format!("sub-{label}_{f}"));
            assert!(p.is_file(), "{}", p.display());
        }
        for e in std::fs::read_dir(&sub).unwrap() {
            let name = e.unwrap().file_name().into_string().unwrap();
            assert!(name.starts_with('.') || is_bids_name(&name), "{name}");
            assert!(name.starts_with('.') || name.starts_with(&format!("sub-{label}_")));
        }
    }
    for stat in ["Mean", "Std", "Count"] {
        let p = out
            .join("group")
            .join(format!("space-placentaTemplate_desc-t2w{stat}_stat.nii.gz"));
        assert!(p.is_file(), "{}", p.display());
    }
    // a rerun skips both (the displacement field is an output, not an
    // input of the run hash) and writes the tree again
    let again = unfold(&[
        "batch",
        &s(&manifest),
        "-o",
        &s(&out),
        "--jobs",
        "2",
        "--layout",
        "bids",
    ]);
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(stdout(&again).contains("2 skipped"), "{}", stdout(&again));
    assert!(
        out.join("sub-p1")
            .join("sub-p1_desc-unfold_report.json")
            .is_file()
    );
    // the default layout's files in OUT/work/
    assert!(out.join("work").join("p-1").join("report.json").is_file());
    assert!(out.join("work").join("cohort.csv").is_file());
    assert!(!out.join("p-1").exists());
    // the xfm is what `unfold placenta --displacement` writes
    let single = d.join("single");
    let field = d.join("field.nii.gz");
    let sd = d.join("in").join("p-1");
    let o = unfold(&[
        "placenta",
        &s(&sd.join("mesh.vtu")),
        "--image",
        &s(&sd.join("t2w.nii.gz")),
        "--grid",
        grid,
        "--spacing-mm",
        "4",
        "--no-figures",
        "--displacement",
        &s(&field),
        "-o",
        &s(&single),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let xfm = out
        .join("sub-p1")
        .join("sub-p1_from-native_to-placentaTemplate_mode-image_xfm.nii.gz");
    let (a, b) = (
        unfold::io::read_image(&xfm).unwrap().volume,
        unfold::io::read_image(&field).unwrap().volume,
    );
    assert_eq!(a.dims(), b.dims());
    assert_eq!(a.affine(), b.affine());
    assert_eq!(a.data(), b.data());
}

/// A bad `--layout` and ids whose BIDS labels collide (or are empty) are
/// refused in one line before anything runs.
#[test]
fn bad_layouts_and_colliding_labels_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let manifest = d.join("m.csv");
    std::fs::write(&manifest, "id,organ,input\np1,placenta,a.vtu\n").unwrap();
    let out = d.join("out");
    let o = unfold(&["batch", &s(&manifest), "-o", &s(&out), "--layout", "bidz"]);
    assert_one_line_error(&o, "bidz");
    assert!(stderr(&o).contains("bids"), "{}", stderr(&o));
    for (rows, needle) in [
        (
            "p_1,placenta,a.vtu\np-1,placenta,a.vtu\n",
            "subject ids 'p_1' and 'p-1' both become sub-p1",
        ),
        (
            "__,placenta,a.vtu\n",
            "subject id '__' has no letter or digit",
        ),
    ] {
        std::fs::write(&manifest, format!("id,organ,input\n{rows}")).unwrap();
        let o = unfold(&["batch", &s(&manifest), "-o", &s(&out), "--layout", "bids"]);
        assert_one_line_error(&o, needle);
        assert!(!out.exists());
    }
}
