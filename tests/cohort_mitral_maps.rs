//! The mitral cohort maps (issue 19): every valve's flat map, and every
//! step of a series, on one normalised `(u, v)` grid, with the mean, std
//! and count of each scalar array in `OUT/cohort/mitral_<array>_*.nii.gz`;
//! and the batch rerun of a mitral series (skipped when done before with
//! the same inputs, rerun when one changes).

use std::path::{Path, PathBuf};
use unfold::io::{WriteOptions, read_image, read_mesh, write_mesh};
use unfold::mesh::CellMesh;
use unfold::mesh::raster::{Coverage, Grid2};
use unfold::mesh::shapes::{ValveParams, mitral_valve};

mod common;
use common::*;

/// The grid of the maps as the documentation gives it: 256 x 128 cells over
/// `u' in [0, 1]`, `v' in [-1/2, 0]`.
const NU: usize = 256;
const NV: usize = 128;

/// Writes a synthetic valve scaled by `scale` as `<stem>_anterior.vtu`,
/// `<stem>_posterior.vtu`, `<stem>_annulus.csv` in `dir`.
fn write_valve(dir: &Path, stem: &str, params: &ValveParams, scale: f64) {
    let v = mitral_valve(params).unwrap();
    let opts = WriteOptions::default();
    for (what, mut mesh) in [("anterior", v.anterior), ("posterior", v.posterior)] {
        for p in &mut mesh.positions {
            *p = (p.coords * scale).into();
        }
        write_mesh(
            dir.join(format!("{stem}_{what}.vtu")),
            &CellMesh::from(&mesh),
            &opts,
        )
        .unwrap();
    }
    let ring: String = v
        .annulus
        .iter()
        .map(|p| format!("{},{},{}\n", p.x * scale, p.y * scale, p.z * scale))
        .collect();
    std::fs::write(dir.join(format!("{stem}_annulus.csv")), ring).unwrap();
}

/// A manifest of single valves `(id, stem)` in `dir`.
fn manifest(dir: &Path, name: &str, valves: &[(&str, &str)]) -> PathBuf {
    let mut csv = String::from("id,organ,anterior,posterior,annulus,no-figures\n");
    for (id, stem) in valves {
        csv.push_str(&format!(
            "{id},mitral,{stem}_anterior.vtu,{stem}_posterior.vtu,{stem}_annulus.csv,true\n"
        ));
    }
    let path = dir.join(name);
    std::fs::write(&path, csv).unwrap();
    path
}

fn batch(manifest: &Path, out: &Path) -> String {
    let o = unfold(&["batch", &s(manifest), "-o", &s(out), "--jobs", "2"]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    stdout(&o)
}

/// `OUT/cohort/mitral_<array>_<what>.nii.gz` as values.
fn image(out: &Path, array: &str, what: &str) -> Vec<f32> {
    let img = read_image(
        out.join("cohort")
            .join(format!("mitral_{array}_{what}.nii.gz")),
    )
    .unwrap();
    assert_eq!(img.volume.dims(), [NU, NV, 1, 1]);
    img.volume.data().to_vec()
}

/// One map's array on the grid, computed here from its `valve2d.vtu` and
/// `report.json` by the documented normalisation `u' = u / U`,
/// `v' = (v - v_top) / U`.
fn own_map(dir: &Path, array: &str) -> Vec<Option<f64>> {
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let extent = report["u_extent_mm"].as_f64().unwrap();
    let mesh = read_mesh(dir.join("valve2d.vtu"))
        .unwrap()
        .to_tri_mesh()
        .unwrap();
    let top = mesh.positions.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    let uv: Vec<[f64; 2]> = mesh
        .positions
        .iter()
        .map(|p| [p.x / extent, (p.y - top) / extent])
        .collect();
    let grid = Grid2::new([0.0, -0.5], [1.0 / NU as f64, 0.5 / NV as f64], [NU, NV]).unwrap();
    let cov = Coverage::new(&uv, &mesh.triangles, &grid).unwrap();
    let r = if let Some(f) = mesh.point_data.get(array) {
        cov.point_field(&f.values().to_f64()).unwrap()
    } else {
        let f = mesh.cell_data.get(array).unwrap();
        cov.cell_field(&f.values().to_f64()).unwrap()
    };
    r.into_iter().map(|x| x.filter(|x| x.is_finite())).collect()
}

/// The arrays averaged: the floating-point scalars of `valve2d.vtu`.
const ARRAYS: [&str; 5] = [
    "area_energy",
    "angle_energy",
    "length_energy",
    "coaptation_distance_mm",
    "tenting_mm",
];

#[test]
fn the_same_valve_twice_has_std_zero_and_its_own_map_as_mean() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_valve(d, "v", &ValveParams::default(), 1.0);
    for what in ["anterior", "posterior"] {
        std::fs::copy(
            d.join(format!("v_{what}.vtu")),
            d.join(format!("w_{what}.vtu")),
        )
        .unwrap();
    }
    std::fs::copy(d.join("v_annulus.csv"), d.join("w_annulus.csv")).unwrap();
    let one = d.join("one");
    let text = batch(&manifest(d, "one.csv", &[("a", "v")]), &one);
    assert!(
        text.contains("15 mitral map images over 1 flat maps"),
        "{text}"
    );
    let two = d.join("two");
    let text = batch(&manifest(d, "two.csv", &[("a", "v"), ("b", "w")]), &two);
    assert!(
        text.contains("15 mitral map images over 2 flat maps"),
        "{text}"
    );
    for array in ARRAYS {
        let own = own_map(&one.join("a"), array);
        let covered = own.iter().filter(|x| x.is_some()).count();
        // the default valve fills a good part of the box
        assert!(covered > NU * NV / 5, "{array}: {covered} cells");
        let (mean1, count1) = (image(&one, array, "mean"), image(&one, array, "count"));
        let (mean2, std2, count2) = (
            image(&two, array, "mean"),
            image(&two, array, "std"),
            image(&two, array, "count"),
        );
        for k in 0..NU * NV {
            match own[k] {
                Some(x) => {
                    assert_eq!(mean1[k], x as f32, "{array} cell {k}");
                    assert_eq!(mean2[k], x as f32, "{array} cell {k}");
                    assert_eq!(count1[k], 1.0);
                    assert_eq!(count2[k], 2.0);
                    assert_eq!(std2[k], 0.0, "{array} cell {k}");
                }
                None => {
                    assert!(mean1[k].is_nan() && mean2[k].is_nan() && std2[k].is_nan());
                    assert_eq!((count1[k], count2[k]), (0.0, 0.0));
                }
            }
        }
    }

    // a map that cannot be used is named and left out; the cohort goes on
    let report = two.join("b").join("report.json");
    let text = std::fs::read_to_string(&report).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["u_extent_mm"] = serde_json::json!(0.0);
    std::fs::write(&report, v.to_string()).unwrap();
    std::fs::write(two.join("a").join("valve2d.vtu"), b"<VTKFile").unwrap();
    let o = unfold(&["cohort", &s(&two)]);
    assert_ok(&o);
    let text = stdout(&o);
    assert!(
        text.contains("cohort: b: left out of the mitral maps: its report's u_extent_mm is 0"),
        "{text}"
    );
    assert!(
        text.contains("cohort: a: left out of the mitral maps: ") && text.contains("valve2d.vtu"),
        "{text}"
    );
    assert!(!text.contains("mitral map images"), "{text}");
}

#[test]
fn scaled_copies_of_a_valve_land_on_the_same_normalised_map() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let params = ValveParams::default();
    write_valve(d, "v", &params, 1.0);
    write_valve(d, "big", &params, 1.2);
    // a third, different valve: the count is per cell
    let other = ValveParams {
        commissural_diameter: 36.0,
        anteroposterior_diameter: 24.0,
        ..ValveParams::default()
    };
    write_valve(d, "other", &other, 1.0);
    let out = d.join("out");
    batch(
        &manifest(
            d,
            "m.csv",
            &[("small", "v"), ("big", "big"), ("other", "other")],
        ),
        &out,
    );
    for array in ARRAYS {
        let maps: Vec<Vec<Option<f64>>> = ["small", "big", "other"]
            .iter()
            .map(|id| own_map(&out.join(id), array))
            .collect();
        let count = image(&out, array, "count");
        let mean = image(&out, array, "mean");
        let mut both = 0;
        let mut compared = Vec::new();
        for k in 0..NU * NV {
            // the count is the number of maps covering the cell
            let n = maps.iter().filter(|m| m[k].is_some()).count();
            assert_eq!(count[k], n as f32, "{array} cell {k}");
            if let (Some(a), Some(b)) = (maps[0][k], maps[1][k]) {
                both += 1;
                // mm arrays scale with the valve; energies do not
                let b = if array.ends_with("_mm") { b / 1.2 } else { b };
                compared.push((a - b).abs() / a.abs().max(1.0));
            }
            if n > 0 {
                // the mean image is f32: relative rounding 2^-24
                let m = maps.iter().filter_map(|m| m[k]).sum::<f64>() / n as f64;
                assert!(
                    (f64::from(mean[k]) - m).abs() <= 1e-6 * m.abs().max(1.0),
                    "{array} cell {k}: {} vs {m}",
                    mean[k]
                );
            }
        }
        let in_one = (0..NU * NV)
            .filter(|&k| maps[0][k].is_some() != maps[1][k].is_some())
            .count();
        // the two maps cover the same cells but for a few along the outline
        assert!(
            in_one * 100 <= both,
            "{array}: {in_one} cells in one, {both} in both"
        );
        // The pipeline is scale-equivariant: the annulus layout exactly,
        // the relaxation to its stopping rule (a Newton decrement below
        // 1e-7 |phi|, phi scale-free), so the two normalised maps agree to
        // far better than 1e-6 (measured: below 1e-14); a centre within that
        // of a triangle edge could still fall in the neighbouring triangle of
        // the other map, hence the outline allowance above and a median
        // besides the bound on all.
        compared.sort_by(f64::total_cmp);
        let median = compared[compared.len() / 2];
        let max = compared[compared.len() - 1];
        eprintln!(
            "{array}: {both} cells in both, {in_one} in one; relative difference median {median:e}, max {max:e}"
        );
        assert!(
            median <= 1e-9,
            "{array}: median relative difference {median:e}"
        );
        assert!(max <= 1e-6, "{array}: largest relative difference {max:e}");
    }
}

#[test]
fn a_mitral_series_is_skipped_on_rerun_and_rerun_when_an_input_changes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let series = d.join("series");
    std::fs::create_dir(&series).unwrap();
    for step in 0..2 {
        let p = ValveParams {
            coaptation_gap: 1.0 + 3.0 * step as f64,
            ..ValveParams::default()
        };
        write_valve(&series, &format!("t{step:02}"), &p, 1.0);
    }
    let manifest = d.join("m.csv");
    std::fs::write(
        &manifest,
        "id,organ,series,no-figures,group\ns1,mitral,series,true,x\n",
    )
    .unwrap();
    let out = d.join("out");
    let text = batch(&manifest, &out);
    assert!(
        text.contains("1 run") && text.contains("0 skipped"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("s1").join("series.json")).unwrap())
            .unwrap();
    assert_eq!(json["steps"].as_array().unwrap().len(), 2);
    assert_eq!(json["provenance"]["run_hash"].as_str().unwrap().len(), 64);
    assert_eq!(json["provenance"]["inputs"].as_array().unwrap().len(), 6);
    let table = std::fs::read_to_string(out.join("cohort.csv")).unwrap();
    assert!(table.contains("s1,mitral,series,"), "{table}");
    // each step is a map of its own
    let count = image(&out, "area_energy", "count");
    assert_eq!(count.iter().cloned().fold(0.0f32, f32::max), 2.0);

    let text = batch(&manifest, &out);
    assert!(
        text.contains("0 run") && text.contains("1 skipped"),
        "{text}"
    );
    let table = std::fs::read_to_string(out.join("cohort.csv")).unwrap();
    assert!(table.contains("s1,mitral,series,"), "{table}");

    // one step's leaflet changes: the series runs again
    let p = ValveParams {
        coaptation_gap: 2.0,
        ..ValveParams::default()
    };
    write_valve(&series, "t01", &p, 1.0);
    let text = batch(&manifest, &out);
    assert!(
        text.contains("1 run") && text.contains("0 skipped"),
        "{text}"
    );
    let again: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("s1").join("series.json")).unwrap())
            .unwrap();
    assert_ne!(
        again["provenance"]["run_hash"],
        json["provenance"]["run_hash"]
    );
}
