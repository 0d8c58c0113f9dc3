//! Every energy of the registry is reachable from every command that
//! minimizes one (`placenta`, `mitral`, `deform`): each name of
//! [`EnergyKind::NAMES`] runs, the report names the energy it minimized, the
//! map is flip-free, and the energy made a difference (the conformal MIPS
//! energy gives the mitral map its smallest angle distortion, the area-ratio
//! energy its smallest area distortion).

use std::path::Path;
use unfold::param::Named;
use unfold::param::energy::EnergyKind;

mod common;
#[path = "common/fixtures.rs"]
mod fixtures;
use common::*;
use fixtures::*;

fn report(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).expect("report written");
    serde_json::from_str(&text).expect("report is JSON")
}

fn write_slab(dir: &Path) -> String {
    let path = dir.join("slab.vtu");
    write_tets(&path, &slab_mesh(4, 2));
    s(&path)
}

#[test]
fn the_registry_names_four_energies() {
    assert_eq!(
        EnergyKind::NAMES,
        ["symmetric-dirichlet", "mips", "arap", "area-ratio"]
    );
}

#[test]
fn the_placenta_minimizes_every_energy_flip_free() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = write_slab(dir.path());
    for &name in EnergyKind::NAMES {
        let out = dir.path().join(name);
        let o = unfold(&[
            "placenta",
            &mesh,
            "-o",
            &s(&out),
            "--energy",
            name,
            "--no-figures",
        ]);
        assert_ok(&o);
        let r = report(&out.join("report.json"));
        assert_eq!(r["pieces"]["energy"], name, "the report names the energy");
        assert_eq!(r["inverted_tets"], 0, "{name}: flip-free");
        assert!(r["min_det_j"].as_f64().unwrap() > 0.0, "{name}: {r}");
        assert!(
            r["iterations"].as_u64().unwrap() > 0,
            "{name}: the solve moved"
        );
    }
}

#[test]
fn the_mitral_relaxation_minimizes_every_energy_and_each_shows() {
    let dir = tempfile::tempdir().unwrap();
    let v = small_valve();
    let [a, p, ring] = write_valve(dir.path(), "", &v.anterior, &v.posterior, &v.annulus);
    let mut finals = Vec::new();
    for &name in EnergyKind::NAMES {
        let out = dir.path().join(name);
        let o = unfold(&[
            "mitral",
            "--anterior",
            &s(&a),
            "--posterior",
            &s(&p),
            "--annulus",
            &s(&ring),
            "-o",
            &s(&out),
            "--energy",
            name,
            "--no-figures",
        ]);
        assert_ok(&o);
        let r = report(&out.join("report.json"));
        assert_eq!(r["pieces"]["energy"], name, "the report names the energy");
        assert_eq!(r["flipped_triangles"], 0, "{name}: flip-free");
        assert_eq!(r["folded_edges"], 0, "{name}: no folds");
        let d = &r["distortion"]["final"];
        finals.push((
            name,
            d["angle"].as_f64().unwrap(),
            d["area"].as_f64().unwrap(),
        ));
    }
    let least = |key: fn(&(&str, f64, f64)) -> f64| {
        finals
            .iter()
            .min_by(|x, y| key(x).total_cmp(&key(y)))
            .unwrap()
            .0
    };
    assert_eq!(
        least(|f| f.1),
        "mips",
        "conformal: least angle distortion {finals:?}"
    );
    assert_eq!(
        least(|f| f.2),
        "area-ratio",
        "least area distortion {finals:?}"
    );
}

#[test]
fn an_unknown_energy_is_refused_naming_all_four() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = write_slab(dir.path());
    for command in [
        vec!["placenta", mesh.as_str()],
        vec!["mitral", "--anterior", "a.vtp", "--posterior", "p.vtp"],
    ] {
        let mut args = command.clone();
        let out = s(&dir.path().join("never"));
        args.extend(["-o", &out, "--energy", "dirichlet"]);
        let o = unfold(&args);
        assert!(!o.status.success(), "{command:?}");
        let err = stderr(&o);
        for name in EnergyKind::NAMES {
            assert!(err.contains(name), "{command:?} names {name}: {err}");
        }
        assert!(!dir.path().join("never").exists());
    }
}
