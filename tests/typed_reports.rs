//! Reports read back typed: every `report.json` a real
//! small run writes (placenta with an image, ventricle, mitral valve and
//! series, deform) reads back as its type and writes the same text again;
//! and a cohort whose subject's report has a renamed field stops with one
//! line naming the file and the field, where it used to leave the value out.

use std::path::{Path, PathBuf};
use unfold::app::cohort::{SubjectReport, read_report};
use unfold::io::write_image;
use unfold::mesh::nalgebra::Vector3;
use unfold::mesh::shapes::{ShellParams, VentricleParams, bowl_shell, ventricle_cup};

mod common;
#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::*;
#[path = "common/scan.rs"]
mod scan;
use common::*;

/// The report at `path` read as `organ`'s and written again: the same text.
fn round_trip(path: &Path, organ: &str) -> SubjectReport {
    let text = std::fs::read_to_string(path).unwrap();
    let report = read_report(path, organ).unwrap_or_else(|e| panic!("{e}"));
    let again = match &report {
        SubjectReport::Placenta(r) => r.to_json(),
        SubjectReport::Ventricle(r) => r.to_json(),
        SubjectReport::Mitral(r) => r.to_json(),
    }
    .unwrap();
    assert_eq!(again, text, "{} written again differs", path.display());
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(report.to_value().unwrap(), value);
    report
}

#[test]
fn a_placenta_report_with_an_image_reads_back_to_the_same_text() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = slab_mesh(6, 2);
    let input = dir.path().join("slab.vtu");
    write_tets(&input, &mesh);
    let image = dir.path().join("t2.nii.gz");
    let scan = scan::image_around(&mesh, [2.0; 3], 1, Vector3::zeros(), |p, _| p.z);
    write_image(&image, &scan).unwrap();
    let out = dir.path().join("out");
    let o = unfold(&[
        "placenta",
        &s(&input),
        "--image",
        &s(&image),
        "--no-figures",
        "-o",
        &s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = round_trip(&out.join("report.json"), "placenta");
    let SubjectReport::Placenta(r) = &report else {
        panic!("not a placenta report");
    };
    assert_eq!(r.report.images.len(), 1);
    assert_eq!(r.report.template, "planes");
    assert!(report.convergence().is_some_and(|c| c.converged));
    // a placenta report is no other organ's
    for organ in ["ventricle", "mitral"] {
        let e = read_report(&out.join("report.json"), organ).unwrap_err();
        assert!(e.to_string().contains("missing field"), "{e}");
    }
}

#[test]
fn a_ventricle_report_reads_back_to_the_same_text() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (anatomy, surface) = write_cup(dir.path(), &v);
    let out = dir.path().join("out");
    let o = run_heart(
        "ventricle",
        &anatomy,
        &cup_heart(&surface, &v),
        &out,
        &["--no-figures"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report = round_trip(&out.join("report.json"), "ventricle");
    assert!(matches!(report, SubjectReport::Ventricle(_)));
    assert!(report.convergence().is_none());
}

#[test]
fn a_mitral_report_and_a_series_read_back_to_the_same_text() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let files = write_valve(dir.path(), "", &v.anterior, &v.posterior, &v.annulus);
    let out = dir.path().join("out");
    let o = unfold(&[
        "mitral",
        "--anterior",
        &s(&files[0]),
        "--posterior",
        &s(&files[1]),
        "--annulus",
        &s(&files[2]),
        "--no-figures",
        "-o",
        &s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = round_trip(&out.join("report.json"), "mitral");
    let SubjectReport::Mitral(r) = &report else {
        panic!("not a mitral report");
    };
    assert!(r.report.u_extent_mm > 0.0);

    // a series of two steps: each step's report, and series.json
    let series = dir.path().join("series");
    std::fs::create_dir_all(&series).unwrap();
    for step in 0..2 {
        write_valve(
            &series,
            &format!("t{step:02}_"),
            &v.anterior,
            &v.posterior,
            &v.annulus,
        );
    }
    let out = dir.path().join("series_out");
    let o = unfold(&[
        "mitral",
        "--series",
        &s(&series),
        "--no-figures",
        "-o",
        &s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for step in ["step_000", "step_001"] {
        round_trip(&out.join(step).join("report.json"), "mitral");
    }
    let text = std::fs::read_to_string(out.join("series.json")).unwrap();
    let table: unfold::app::mitral::series::table::SeriesReport =
        serde_json::from_str(&text).unwrap();
    assert_eq!(table.steps.len(), 2);
    assert_eq!(table.to_json().unwrap(), text);
}

#[test]
fn a_deform_report_reads_back_to_the_same_text() {
    let shape = bowl_shell(&ShellParams {
        cells_radial: 4,
        cells_through: 1,
        ..ShellParams::default()
    })
    .unwrap();
    let p = &shape.mesh.positions;
    let mut targets = String::from("vertex,x,y,z\n");
    for (vs, z) in [(&shape.top, 4.0), (&shape.bottom, -4.0)] {
        for &v in vs.iter() {
            let q = p[v as usize];
            targets += &format!("{v},{},{},{z}\n", q.x, q.y);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("bowl.vtu");
    write_tets(&mesh, &shape.mesh);
    let tfile = dir.path().join("targets.csv");
    std::fs::write(&tfile, targets).unwrap();
    let out = dir.path().join("flat.vtu");
    let o = unfold(&["deform", &s(&mesh), "--targets", &s(&tfile), "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let path = dir.path().join("flat.vtu.report.json");
    let text = std::fs::read_to_string(&path).unwrap();
    let report: unfold::app::deform::report::DeformRunReport = serde_json::from_str(&text).unwrap();
    assert_eq!(report.to_json().unwrap(), text);
    assert_eq!(report.report.solver, "newton");
}

/// A batch of two placentas and a valve in `dir/out` (all done).
fn cohort(dir: &Path) -> PathBuf {
    write_tets(&dir.join("s1.vtu"), &slab_mesh(5, 2));
    let v = small_valve();
    let files = write_valve(dir, "", &v.anterior, &v.posterior, &v.annulus);
    let name = |p: &Path| p.file_name().unwrap().to_str().unwrap().to_string();
    std::fs::write(
        dir.join("manifest.csv"),
        format!(
            "id,organ,input,anterior,posterior,annulus,no-figures,age\n\
             s1,placenta,s1.vtu,,,,true,30\n\
             s2,placenta,s1.vtu,,,,true,31\n\
             v1,mitral,,{},{},{},true,40\n",
            name(&files[0]),
            name(&files[1]),
            name(&files[2])
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let o = unfold(&["batch", &s(&dir.join("manifest.csv")), "-o", &s(&out)]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    out
}

/// Replaces the first `"from":` key of `path` by `"to":`.
fn rename_key(path: &Path, from: &str, to: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    let key = format!("\"{from}\":");
    assert!(text.contains(&key), "{from} in {}", path.display());
    std::fs::write(path, text.replacen(&key, &format!("\"{to}\":"), 1)).unwrap();
}

#[test]
fn a_renamed_field_stops_the_cohort_with_one_line_naming_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let out = cohort(dir.path());
    let o = unfold(&["cohort", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = std::fs::read_to_string(out.join("cohort.csv")).unwrap();
    assert!(table.lines().next().unwrap().contains(",converged,"));

    // a required field renamed: serde names the missing field
    let s1 = out.join("s1").join("report.json");
    let kept = std::fs::read_to_string(&s1).unwrap();
    rename_key(&s1, "converged", "has_converged");
    let o = unfold(&["cohort", &s(&out)]);
    assert_one_line_error(&o, &s(&s1));
    assert_one_line_error(&o, "missing field `converged`");
    assert_one_line_error(&o, "unfold batch");

    // an optional field renamed (serde alone would read it as absent)
    std::fs::write(&s1, &kept).unwrap();
    rename_key(&s1, "log2_det_j", "log2_det_jacobian");
    let o = unfold(&["cohort", &s(&out)]);
    assert_one_line_error(&o, &s(&s1));
    assert_one_line_error(&o, "unknown field `log2_det_jacobian`");

    // an optional field inside a section that denies unknown fields
    let v1 = out.join("v1").join("report.json");
    std::fs::write(&s1, &kept).unwrap();
    rename_key(&v1, "layout_plane", "plane_of_layout");
    let o = unfold(&["cohort", &s(&out)]);
    assert_one_line_error(&o, &s(&v1));
    assert_one_line_error(&o, "plane_of_layout");

    // a retyped field (a number as text): serde names it, with line and column
    let text = std::fs::read_to_string(&v1).unwrap();
    let text = text.replacen("\"plane_of_layout\":", "\"layout_plane\":", 1);
    let start = text.find("\"u_extent_mm\": ").unwrap() + "\"u_extent_mm\": ".len();
    let end = start + text[start..].find(',').unwrap();
    let text = format!(
        "{}\"{}\"{}",
        &text[..start],
        &text[start..end],
        &text[end..]
    );
    std::fs::write(&v1, text).unwrap();
    let o = unfold(&["cohort", &s(&out)]);
    assert_one_line_error(&o, &s(&v1));
    assert_one_line_error(&o, "invalid type: string");
    assert_one_line_error(&o, "line ");

    // the batch runs the subject again (its report does not count as done),
    // and the cohort reads again
    let o = unfold(&[
        "batch",
        &s(&dir.path().join("manifest.csv")),
        "-o",
        &s(&out),
    ]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    round_trip(&v1, "mitral");
    assert_eq!(
        std::fs::read_to_string(&s1).unwrap(),
        kept,
        "s1 was skipped"
    );
    let o = unfold(&["cohort", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
}
