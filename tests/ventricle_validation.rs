//! The validation runs of `unfold ventricle` through the binary (the
//! source paper's §5.1 and §5.4): `--sensitivity MM` (landmarks moved,
//! the spread per anatomy point) and `--grid-sweep` (error, time and memory
//! per grid of the Laplace field).

use std::path::Path;
use std::process::Output;
use unfold::io::read_mesh;
use unfold::mesh::CellMesh;
use unfold::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};

mod common;
use common::*;

/// `unfold ventricle` on the cup (1.5 mm grid) plus `extra`.
fn run(dir: &Path, v: &VentricleShape, out: &Path, extra: &[&str]) -> Output {
    let (anatomy, surface) = write_cup(dir, v);
    run_heart("ventricle", &anatomy, &cup_heart(&surface, v), out, extra)
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

fn array(m: &CellMesh, name: &str) -> Vec<f64> {
    let f = m.point_data.get(name).unwrap_or_else(|| panic!("{name}"));
    assert_eq!(f.components(), 1);
    f.values().to_f64()
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn landmarks_moved_give_each_point_its_spread() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let out = dir.path().join("out");
    assert_ok(&run(dir.path(), &v, &out, &["--sensitivity", "3"]));
    let r = report(&out);
    let sens = &r["sensitivity"];
    assert_eq!(sens["displacement_mm"], 3.0);
    let names: Vec<&str> = sens["perturbations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "anterior +",
            "anterior -",
            "inferior +",
            "inferior -",
            "both towards",
            "both away",
            "apex +t1",
            "apex -t1",
            "apex +t2",
            "apex -t2"
        ]
    );
    for p in sens["perturbations"].as_array().unwrap() {
        let name = p["name"].as_str().unwrap();
        assert!(p.get("error").is_none(), "{name}: {p}");
        assert_eq!(p["points_not_mapped"], 0, "{name}");
        let moved: Vec<f64> = p["moved_mm"].as_array().unwrap().iter().map(f).collect();
        // which landmarks moved: whole rim edges (about 2.3 mm on the
        // cup) or the vertex nearest the moved apex; the others stay
        let expect = [
            name.starts_with("anterior") || name.starts_with("both"),
            name.starts_with("inferior") || name.starts_with("both"),
            name.starts_with("apex"),
        ];
        for (m, e) in moved.iter().zip(expect) {
            if e {
                assert!(*m > 0.5 && *m < 6.0, "{name}: {moved:?}");
            } else {
                assert_eq!(*m, 0.0, "{name}: {moved:?}");
            }
        }
        assert!(
            f(&p["error_mm"]["max"]) > 0.0,
            "{name}: a moved landmark moves the map"
        );
    }
    let n = v.anatomy.positions.len();
    for file in ["normalized.vtu", "anatomy.vtu"] {
        let m = read_mesh(out.join(file)).unwrap();
        let e = array(&m, "sensitivity_mm");
        let d = array(&m, "sensitivity_disk");
        let z = array(&m, "sensitivity_depth");
        assert_eq!((e.len(), d.len(), z.len()), (n, n, n));
        assert!(
            e.iter()
                .chain(&d)
                .chain(&z)
                .all(|x| x.is_finite() && *x >= 0.0)
        );
        // the per-point arrays are what the report summarizes: the
        // largest over the perturbations of each
        let max = e.iter().copied().fold(0.0, f64::max);
        assert!((max - f(&sens["error_mm"]["max"])).abs() <= 1e-12 * max);
        let worst_k = sens["perturbations"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| f(&p["error_mm"]["max"]))
            .fold(0.0, f64::max);
        assert!((max - worst_k).abs() <= 1e-12 * max);
        // 3 mm off moves no point by more than a few times that
        assert!(max > 0.0 && max < 12.0, "{max}");
        assert!(d.iter().all(|&x| x <= 2.0), "on the unit disk");
        assert!(z.iter().all(|&x| x <= 1.0));
    }
    assert!(out.join("figures/sensitivity.png").is_file());

    for bad in ["0", "-3", "nan"] {
        let o = run(
            dir.path(),
            &v,
            &dir.path().join("bad"),
            &["--sensitivity", bad],
        );
        assert_one_line_error(&o, "--sensitivity must be a finite number > 0");
    }
    assert!(!dir.path().join("bad").exists());

    // A displacement under half a rim edge moves no landmark: the run
    // succeeds and says so on stderr.
    let small = dir.path().join("small");
    let o = run(
        dir.path(),
        &v,
        &small,
        &["--sensitivity", "0.1", "--no-figures"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning:") && err.contains("perturbations left every landmark on its vertex"),
        "{err}"
    );
}

#[test]
fn a_grid_sweep_reports_error_time_and_memory_per_grid() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let out = dir.path().join("out");
    let o = run(dir.path(), &v, &out, &["--grid-sweep", "2,1.5"]);
    assert_ok(&o);
    let text = stdout(&o);
    assert!(
        text.contains("grid sweep 2 mm:") && text.contains("grid sweep 1.5 mm:"),
        "{text}"
    );
    let table = std::fs::read_to_string(out.join("grid_sweep.csv")).unwrap();
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header,
        [
            "grid_mm",
            "unknowns",
            "cg_iterations",
            "roundtrip_mean_um",
            "roundtrip_max_um",
            "disk_shift_max",
            "depth_shift_max",
            "seconds",
            "disk_seconds",
            "laplace_seconds",
            "streamlines_seconds",
            "inverse_seconds",
            "estimated_field_bytes",
            "peak_bytes"
        ]
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2);
    let col = |row: &[&str], name: &str| -> f64 {
        let k = header.iter().position(|h| *h == name).unwrap();
        row[k]
            .parse()
            .unwrap_or_else(|_| panic!("{name}: {:?}", row[k]))
    };
    assert_eq!(col(&rows[0], "grid_mm"), 2.0, "in the order given");
    assert_eq!(col(&rows[1], "grid_mm"), 1.5);
    // the 1.5 mm grid is the main run's
    let r = report(&out);
    assert_eq!(r["grid_mm"], 1.5);
    assert_eq!(col(&rows[1], "unknowns"), f(&r["field"]["unknowns"]));
    assert!(col(&rows[1], "unknowns") > 1.5 * col(&rows[0], "unknowns"));
    assert!(col(&rows[1], "estimated_field_bytes") > col(&rows[0], "estimated_field_bytes"));
    for row in &rows {
        let (mean, max) = (col(row, "roundtrip_mean_um"), col(row, "roundtrip_max_um"));
        assert!(0.0 <= mean && mean <= max && max < 5.0, "{row:?}");
        assert!(col(row, "seconds") > 0.0);
        assert!(col(row, "seconds") >= col(row, "laplace_seconds"));
        let peak = row[header.len() - 1];
        assert!(
            peak.is_empty() || peak.parse::<f64>().unwrap() > 0.0,
            "{peak}"
        );
    }
    // shifts against the finest grid: 0 on it, some on the coarser one
    assert_eq!(col(&rows[1], "disk_shift_max"), 0.0);
    assert_eq!(col(&rows[1], "depth_shift_max"), 0.0);
    assert!(col(&rows[0], "disk_shift_max") > 0.0);
    assert!(col(&rows[0], "depth_shift_max") > 0.0);
    assert!(out.join("figures/grid_sweep.png").is_file());

    for (bad, msg) in [
        ("1,-1", "--grid-sweep must be a finite number > 0"),
        ("2,2", "--grid-sweep lists 2 twice"),
    ] {
        let o = run(
            dir.path(),
            &v,
            &dir.path().join("bad"),
            &["--grid-sweep", bad],
        );
        assert_one_line_error(&o, msg);
    }
    assert!(!dir.path().join("bad").exists());
}
