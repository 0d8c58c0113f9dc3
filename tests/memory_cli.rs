//! Bounded, predicted memory (issue 18) through the binary: each big stage
//! (the mesher's lattice, the placenta's factor, the ventricle's field, the
//! deformation's factor) is estimated before it allocates; a run whose
//! predicted peak passes `--max-memory` (or what the machine has) is refused
//! in one line with the estimate and what to change, without allocating;
//! and the estimate is compared with the peak the kernel measured.

#![cfg(target_os = "linux")]

use std::path::{Path, PathBuf};
use unfold::io::{NiftiImage, WriteOptions, write_image, write_mesh};
use unfold::mesh::nalgebra::{Matrix4, Point3};
use unfold::mesh::shapes::{PlacentaParams, VentricleParams, placenta_slab, ventricle_cup};
use unfold::mesh::{CellMesh, Volume};

mod common;
#[path = "common/measured.rs"]
mod measured;
use common::*;
use measured::unfold_measured;

const MIB: f64 = 1024.0 * 1024.0;

/// A ball of radius `r` voxels in a cube of `n` voxels of `spacing` mm.
fn ball_mask(dir: &Path, n: usize, r: f64, spacing: [f64; 3]) -> PathBuf {
    let c = (n as f64 - 1.0) / 2.0;
    let mut data = vec![0.0f32; n * n * n];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let d2 = [i, j, k]
                    .iter()
                    .map(|&x| (x as f64 - c).powi(2))
                    .sum::<f64>();
                if d2 <= r * r {
                    data[i + n * (j + n * k)] = 1.0;
                }
            }
        }
    }
    let mut a = Matrix4::identity();
    for (i, s) in spacing.iter().enumerate() {
        a[(i, i)] = *s;
    }
    let path = dir.join("ball.nii.gz");
    let vol = Volume::new([n, n, n, 1], a, data).unwrap();
    write_image(&path, &NiftiImage::new(vol)).unwrap();
    path
}

/// `measured <= predicted <= factor x measured`.
fn assert_bounds(what: &str, predicted: f64, measured: f64, factor: f64) {
    eprintln!(
        "{what}: predicted {:.1} MiB, measured {:.1} MiB, ratio {:.2}",
        predicted / MIB,
        measured / MIB,
        predicted / measured
    );
    assert!(
        measured <= predicted,
        "{what}: measured {measured} above the prediction {predicted}"
    );
    assert!(
        predicted <= factor * measured,
        "{what}: prediction {predicted} more than {factor} times the measured {measured}"
    );
}

#[test]
fn the_mesher_predicts_its_peak() {
    let dir = tempfile::tempdir().unwrap();
    let mask = ball_mask(dir.path(), 44, 18.0, [1.0; 3]);
    let out = dir.path().join("ball.vtu");
    let args = ["mesh", &s(&mask), "--size-mm", "0.8", "-o", &s(&out)];
    // the prediction, from a refusal under a limit the image fits and the
    // mesher does not ...
    let mut refused = args.to_vec();
    refused.extend(["--max-memory", "64M"]);
    let (o, _) = unfold_measured(&refused);
    assert_one_line_error(&o, "meshing the mask would need about");
    assert!(!out.exists(), "nothing written when refused");
    let predicted = predicted_peak(&stderr(&o));
    // ... against the measured peak of the run itself
    let (o, peak) = unfold_measured(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_bounds("mesh 0.8 mm", predicted, peak as f64, 2.5);
}

#[test]
fn runaway_mesher_flags_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let mask = ball_mask(dir.path(), 24, 10.0, [1.0; 3]);
    let out = dir.path().join("m.vtu");
    // a 0.01 mm lattice over a 20 mm ball: terabytes
    for cmd in [
        vec!["mesh", &s(&mask), "--size-mm", "0.01", "-o", &s(&out)],
        vec![
            "placenta",
            "--seg",
            &s(&mask),
            "--size-mm",
            "0.01",
            "-o",
            &s(&dir.path().join("p")),
        ],
    ] {
        let (o, peak) = unfold_measured(&cmd);
        assert_one_line_error(&o, "meshing the mask would need about");
        assert!(stderr(&o).contains("TiB"), "{}", stderr(&o));
        assert!(stderr(&o).contains("raise --size-mm"), "{}", stderr(&o));
        assert!((peak as f64) < 200.0 * MIB, "peak {peak} B");
    }
    assert!(!out.exists());
    // an anisotropic mask (voxels 1000 x 1 x 1 mm): `placenta --seg
    // --dense` would mesh at the smallest spacing, a lattice spanning
    // metres at 1 mm; an organ 20 m across is refused before any
    // prediction or meshing (the prediction's own refusal:
    // placenta_gates.rs)
    let mask = ball_mask(dir.path(), 24, 10.0, [1000.0, 1.0, 1.0]);
    let (o, peak) = unfold_measured(&[
        "placenta",
        "--seg",
        &s(&mask),
        "-o",
        &s(&dir.path().join("p")),
        "--dense",
        "--max-memory",
        "2G",
    ]);
    assert_one_line_error(&o, "larger than any organ unfold maps");
    assert!(
        stderr(&o).contains("check the voxel size"),
        "{}",
        stderr(&o)
    );
    assert!((peak as f64) < 200.0 * MIB, "peak {peak} B");
}

fn slab_file(dir: &Path, cells_radial: usize, cells_through: usize) -> PathBuf {
    let mesh = placenta_slab(&PlacentaParams {
        cells_radial,
        cells_through,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh;
    let p = dir.join("slab.vtu");
    write_mesh(&p, &CellMesh::from(&mesh), &WriteOptions::default()).unwrap();
    p
}

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn the_placenta_predicts_its_peak_and_refuses_what_does_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    let slab = slab_file(dir.path(), 14, 4);
    let out = dir.path().join("out");
    let (o, peak) = unfold_measured(&["placenta", &s(&slab), "-o", &s(&out), "--no-figures"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = &report(&out)["memory"];
    let predicted = m["predicted_peak_bytes"].as_f64().unwrap();
    let reported = m["peak_bytes"].as_f64().unwrap();
    assert!(reported <= peak as f64, "{reported} {peak}");
    assert_eq!(m["limit_source"], "available");
    assert_bounds("placenta 14x4 slab", predicted, peak as f64, 2.5);

    let out = dir.path().join("small");
    let (o, _) = unfold_measured(&[
        "placenta",
        &s(&slab),
        "-o",
        &s(&out),
        "--no-figures",
        "--max-memory",
        "40M",
    ]);
    assert_one_line_error(&o, "flattening the placenta would need about");
    let e = stderr(&o);
    assert!(
        e.contains("factor") && e.contains("--max-memory") && e.contains("coarsen the mesh"),
        "{e}"
    );
    assert!(!out.join("report.json").exists());
}

#[test]
fn the_placenta_multigrid_solve_predicts_its_peak() {
    // 24,605 vertices (115,200 tets): at least MULTIGRID_MIN_VERTICES, so
    // Newton's systems are solved by multigrid, whose estimate has no
    // factor but the multigrid's matrix, prolongations and vectors.
    let dir = tempfile::tempdir().unwrap();
    let slab = slab_file(dir.path(), 40, 4);
    let out = dir.path().join("out");
    let (o, peak) = unfold_measured(&["placenta", &s(&slab), "-o", &s(&out), "--no-figures"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = &report(&out)["memory"];
    let predicted = m["predicted_peak_bytes"].as_f64().unwrap();
    assert_bounds(
        "placenta 40x4 slab (multigrid)",
        predicted,
        peak as f64,
        2.5,
    );
    let (o, _) = unfold_measured(&[
        "placenta",
        &s(&slab),
        "-o",
        &s(&dir.path().join("small")),
        "--no-figures",
        "--max-memory",
        "100M",
    ]);
    assert_one_line_error(&o, "flattening the placenta would need about");
    let e = stderr(&o);
    assert!(
        e.contains("multigrid matrix") && e.contains("prolongations") && !e.contains("factor"),
        "{e}"
    );
}

#[test]
fn the_ventricle_field_predicts_its_peak_and_refuses_a_runaway_grid() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let surface = dir.path().join("surface.vtp");
    let anatomy = dir.path().join("anatomy.vtp");
    write_mesh(
        &surface,
        &CellMesh::from(&v.surface),
        &WriteOptions::default(),
    )
    .unwrap();
    write_mesh(
        &anatomy,
        &CellMesh::from(&v.anatomy),
        &WriteOptions::default(),
    )
    .unwrap();
    let pt = |p: &Point3<f64>| format!("{:?},{:?},{:?}", p.x, p.y, p.z);
    let run = |grid: &str, out: &Path, extra: &[&str]| {
        let mut args = vec![
            "ventricle".to_string(),
            s(&anatomy),
            "--surface".into(),
            s(&surface),
            "--anterior".into(),
            pt(&v.anterior),
            "--inferior".into(),
            pt(&v.inferior),
            "--apex".into(),
            pt(&v.apex),
            "--grid-mm".into(),
            grid.into(),
            "--no-figures".into(),
            "-o".into(),
            s(out),
        ];
        args.extend(extra.iter().map(|x| x.to_string()));
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        unfold_measured(&refs)
    };
    let out = dir.path().join("v");
    let (o, peak) = run("0.6", &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = &report(&out)["memory"];
    assert_bounds(
        "ventricle 0.6 mm",
        m["predicted_peak_bytes"].as_f64().unwrap(),
        peak as f64,
        2.5,
    );
    let out = dir.path().join("fine");
    let (o, peak) = run("0.1", &out, &["--max-memory", "1G"]);
    assert_one_line_error(&o, "the Laplace field at a 0.1 mm grid");
    assert!(stderr(&o).contains("raise --grid-mm"), "{}", stderr(&o));
    assert!((peak as f64) < 200.0 * MIB, "peak {peak} B");
    assert!(!out.join("report.json").exists());
}

#[test]
fn bad_memory_limits_are_usage_errors() {
    for bad in ["4X", "-1G", "0", "lots"] {
        let flag = format!("--max-memory={bad}");
        let o = unfold(&["info", "Cargo.toml", &flag]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--max-memory"), "{}", stderr(&o));
    }
}

/// The predicted peak in a refusal `... a peak of 1.2 GiB: ...`, bytes.
pub fn predicted_peak(message: &str) -> f64 {
    let rest = message
        .split("a peak of ")
        .nth(1)
        .unwrap_or_else(|| panic!("no predicted peak in {message:?}"));
    let mut words = rest.split_whitespace();
    let value: f64 = words.next().and_then(|w| w.parse().ok()).expect("a number");
    let unit = words.next().expect("a unit").trim_end_matches(':');
    let scale = match unit {
        "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1024.0 * 1024.0,
        "GiB" => 1024.0 * 1024.0 * 1024.0,
        "TiB" => 1024.0f64.powi(4),
        u => panic!("unit {u}"),
    };
    value * scale
}
