//! `report.json` says where its results come from (issue 19, point 4):
//! the unfold version, the command line, every parameter, the inputs'
//! SHA-256 and the start time, and one run hash that changes with the
//! inputs and options but not with the output directory.

use sha2::{Digest, Sha256};
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::CellMesh;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};

mod common;
use common::*;

fn report(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn a_report_names_its_version_command_inputs_and_run_hash() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = placenta_slab(&PlacentaParams::default()).unwrap().mesh;
    let input = dir.path().join("slab.vtu");
    write_mesh(&input, &CellMesh::from(&mesh), &WriteOptions::default()).unwrap();
    let run = |out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        let mut args = vec!["placenta", &s(&input), "-o", &s(&out), "--no-figures"]
            .into_iter()
            .map(String::from)
            .collect::<Vec<_>>();
        args.extend(extra.iter().map(|x| x.to_string()));
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_ok(&unfold(&refs));
        report(&out)["provenance"].clone()
    };
    let p = run("a", &[]);
    assert_eq!(p["unfold_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(p["command_line"][1], "placenta");
    assert!(
        p["parameters"].as_str().unwrap().contains("Placenta"),
        "{p}"
    );
    let sha: String = Sha256::digest(std::fs::read(&input).unwrap())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(p["inputs"][0]["path"], s(&input));
    assert_eq!(p["inputs"][0]["sha256"], sha);
    assert!(p["started"].as_str().unwrap().ends_with('Z'), "{p}");
    // another output directory: the same run hash; another option: another
    let q = run("b", &[]);
    assert_eq!(p["run_hash"], q["run_hash"]);
    assert_eq!(p["run_hash"].as_str().unwrap().len(), 64);
    let r = run("c", &["--template", "ellipsoid"]);
    assert_ne!(p["run_hash"], r["run_hash"]);
}
