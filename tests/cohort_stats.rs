//! Template-space statistics of a placenta cohort through the binary
//! (issue 19): constant images give that constant as the mean with a
//! standard deviation of 0; the same subject in two poses has the same
//! template-space image.

use std::path::Path;
use unfold::io::{WriteOptions, read_image, write_image, write_mesh};
use unfold::mesh::nalgebra::{Point3, Rotation3, Vector3};
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::mesh::{CellMesh, TetMesh};

mod common;
#[path = "common/scan.rs"]
mod scan;
use common::*;

const GRID: &str = "-100,100,-100,100,-30,30";

fn slab(cells_radial: usize) -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh
}

/// Writes `dir/<id>/mesh.vtu` and `dir/<id>/t2.nii.gz` (values
/// `value(p)`) and returns the manifest row (the common `--grid`, 4 mm).
fn subject(dir: &Path, id: &str, mesh: &TetMesh, value: impl Fn(&Point3<f64>) -> f64) -> String {
    subject_on(dir, id, mesh, GRID, 4.0, value)
}

/// [`subject`] with the row's `grid` (empty: none, the pull-back covers
/// the subject's own box) and `spacing-mm`.
fn subject_on(
    dir: &Path,
    id: &str,
    mesh: &TetMesh,
    grid: &str,
    spacing: f64,
    value: impl Fn(&Point3<f64>) -> f64,
) -> String {
    let d = dir.join("in").join(id);
    std::fs::create_dir_all(&d).unwrap();
    write_mesh(
        d.join("mesh.vtu"),
        &CellMesh::from(mesh),
        &WriteOptions::default(),
    )
    .unwrap();
    let img = scan::image_around(mesh, [2.0; 3], 1, Vector3::zeros(), |p, _| value(p));
    write_image(d.join("t2.nii.gz"), &img).unwrap();
    format!("{id},placenta,in/{id}/mesh.vtu,in/{id}/t2.nii.gz,\"{grid}\",{spacing},true\n")
}

fn batch(dir: &Path, rows: &[String]) -> std::path::PathBuf {
    batch_with(dir, rows, "").0
}

/// Runs the batch of `rows` with the covariate columns `covariates`
/// (`",group"`: each row ends with its values); the output directory and
/// the batch's stdout.
fn batch_with(dir: &Path, rows: &[String], covariates: &str) -> (std::path::PathBuf, String) {
    let manifest = dir.join("manifest.csv");
    let mut text = format!("id,organ,input,image,grid,spacing-mm,no-figures{covariates}\n");
    for r in rows {
        text.push_str(r);
    }
    std::fs::write(&manifest, text).unwrap();
    let out = dir.join("out");
    let o = unfold(&["batch", &s(&manifest), "-o", &s(&out), "--jobs", "2"]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    (out, stdout(&o))
}

fn values(path: &Path) -> Vec<f32> {
    read_image(path).unwrap().volume.data().to_vec()
}

#[test]
fn constant_images_have_that_mean_and_no_spread() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rows: Vec<String> = [(5, "a"), (6, "b"), (7, "c")]
        .iter()
        .map(|&(n, id)| subject(d, id, &slab(n), |_| 7.0))
        .collect();
    let out = batch(d, &rows);
    let stats = out.join("cohort");
    let (mean, std, count) = (
        values(&stats.join("t2_mean.nii.gz")),
        values(&stats.join("t2_std.nii.gz")),
        values(&stats.join("t2_count.nii.gz")),
    );
    assert!(count.contains(&3.0), "every subject covers some voxel");
    let mut covered = 0;
    for i in 0..mean.len() {
        match count[i] {
            0.0 => assert!(mean[i].is_nan() && std[i].is_nan(), "voxel {i}"),
            c => {
                covered += 1;
                assert!((mean[i] - 7.0).abs() < 1e-4, "voxel {i}: mean {}", mean[i]);
                if c >= 2.0 {
                    assert!(std[i].abs() < 1e-4, "voxel {i}: std {}", std[i]);
                }
            }
        }
    }
    assert!(covered > 100, "{covered} voxels covered");
    // the subjects' shared grid, unchanged
    let grid = grid_json(&stats);
    assert_eq!(grid["t2"]["resampled"], false, "{grid}");
    assert_eq!(grid["t2"]["subjects"], 3, "{grid}");
    assert_eq!(
        grid["t2"]["dims"],
        serde_json::json!([51, 51, 16]),
        "{grid}"
    );
    // no spread: every leave-one-out z is undefined
    for id in ["a", "b", "c"] {
        let z = values(&stats.join("z").join(format!("{id}_t2.nii.gz")));
        assert!(z.iter().all(|v| v.is_nan()), "{id}");
    }
}

#[test]
fn one_subject_in_two_poses_has_one_template_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = slab(6);
    let r = Rotation3::from_euler_angles(0.4, -0.3, 1.1);
    let t = Vector3::new(30.0, -12.0, 55.0);
    let mut moved = mesh.clone();
    for p in &mut moved.positions {
        *p = Point3::from(r * p.coords + t);
    }
    // the same tissue values, carried with the body
    let f = |p: &Point3<f64>| 500.0 + 2.0 * p.x - 1.5 * p.y + 4.0 * p.z;
    let rows = vec![
        subject(d, "still", &mesh, f),
        subject(d, "moved", &moved, move |p| {
            f(&Point3::from(r.inverse() * (p.coords - t)))
        }),
        subject(d, "other", &slab(5), f),
    ];
    let out = batch(d, &rows);
    let a = values(&out.join("still").join("t2_flat.nii.gz"));
    let b = values(&out.join("moved").join("t2_flat.nii.gz"));
    assert_eq!(a.len(), b.len());
    let (mut both, mut diff) = (0usize, 0.0f64);
    for (x, y) in a.iter().zip(&b) {
        if *x != 0.0 && *y != 0.0 {
            both += 1;
            diff += f64::from((x - y).abs());
        }
    }
    assert!(both > 100, "{both} voxels in both");
    let mean_diff = diff / both as f64;
    eprintln!("two poses: mean abs difference {mean_diff:.2e} over {both} voxels");
    // values span about 200 over the slab; trilinear sampling of a linear
    // image is exact, so what differs is the map (solver tolerance)
    assert!(mean_diff < 1.0, "mean |difference| {mean_diff}");
}

fn grid_json(stats: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(stats.join("grid.json")).unwrap()).unwrap()
}

/// Without `--grid` every subject's flat image covers its own box (here
/// also at two spacings): the cohort resamples them onto one grid, the
/// union of the boxes at the finest spacing, and every subject enters.
#[test]
fn subjects_without_a_common_grid_all_enter_on_a_chosen_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sized = |n: usize, length: f64| {
        placenta_slab(&PlacentaParams {
            cells_radial: n,
            cells_through: 2,
            length,
            width: 0.8 * length,
            ..PlacentaParams::default()
        })
        .unwrap()
        .mesh
    };
    let rows = vec![
        subject_on(d, "a", &sized(5, 150.0), "", 4.0, |_| 7.0),
        subject_on(d, "b", &sized(6, 180.0), "", 3.0, |_| 7.0),
        subject_on(d, "c", &sized(5, 210.0), "", 4.0, |_| 7.0),
    ];
    let (out, printed) = batch_with(d, &rows, "");
    let stats = out.join("cohort");
    assert!(!printed.contains("left out"), "{printed}");
    assert!(
        printed.contains("t2 of 3 subjects resampled onto a common grid of"),
        "{printed}"
    );
    let grid = grid_json(&stats);
    let g = &grid["t2"];
    assert_eq!(
        (g["resampled"].as_bool(), g["subjects"].as_u64()),
        (Some(true), Some(3)),
        "{grid}"
    );
    assert_eq!(
        g["spacing_mm"],
        serde_json::json!([3.0, 3.0, 3.0]),
        "{grid}"
    );
    let boxes: Vec<Vec<f32>> = ["a", "b", "c"]
        .iter()
        .map(|id| values(&out.join(id).join("t2_flat.nii.gz")))
        .collect();
    assert!(
        boxes[0].len() != boxes[2].len(),
        "the subjects' grids differ"
    );
    let (mean, count) = (
        values(&stats.join("t2_mean.nii.gz")),
        values(&stats.join("t2_count.nii.gz")),
    );
    let dims: Vec<usize> = serde_json::from_value(g["dims"].clone()).unwrap();
    assert_eq!(mean.len(), dims.iter().product::<usize>());
    assert!(count.contains(&3.0), "every subject covers some voxel");
    let mut covered = 0;
    for i in 0..mean.len() {
        if count[i] > 0.0 {
            covered += 1;
            assert!((mean[i] - 7.0).abs() < 1e-4, "voxel {i}: mean {}", mean[i]);
        } else {
            assert!(mean[i].is_nan(), "voxel {i}");
        }
    }
    assert!(covered > 100, "{covered} voxels covered");
    for id in ["a", "b", "c"] {
        let z = values(&stats.join("z").join(format!("{id}_t2.nii.gz")));
        assert_eq!(z.len(), mean.len(), "{id}'s z on the common grid");
    }
}

/// A deterministic noise value in [-1, 1) of subject `k` at `p` (SplitMix64
/// of the point's rounded coordinates).
fn noise(k: u64, p: &Point3<f64>) -> f64 {
    let mut z = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for c in [p.x, p.y, p.z] {
        z ^= ((c * 8.0).round() as i64) as u64;
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
    }
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Eight placentas of different sizes without `--grid` (so on a common
/// grid chosen by the cohort), noise everywhere; group B (4) brighter by
/// `effect` where scanner x > 0; the columns `group` (A, B), `null` (two
/// groups crossing A and B) and `shade` (B as 1, A as 0). Returns the
/// batch's output.
fn two_group_cohort(dir: &Path, effect: f64) -> std::path::PathBuf {
    let mut rows = Vec::new();
    for k in 0..8u64 {
        let b = k % 2 == 1;
        let mesh = placenta_slab(&PlacentaParams {
            cells_radial: 4,
            cells_through: 2,
            length: 160.0 + 5.0 * k as f64,
            width: 130.0 + 3.0 * k as f64,
            ..PlacentaParams::default()
        })
        .unwrap()
        .mesh;
        let id = format!("p{k}");
        let row = subject_on(dir, &id, &mesh, "", 4.0, move |p| {
            let bright = if b && p.x > 0.0 { effect } else { 0.0 };
            100.0 + bright + noise(k, p)
        });
        let group = if b { "B" } else { "A" };
        let null = if k / 2 % 2 == 0 { "x" } else { "y" };
        rows.push(format!(
            "{},{group},{null},{},s1\n",
            row.trim_end(),
            u8::from(b)
        ));
    }
    batch_with(dir, &rows, ",group,null,shade,site").0
}

fn cohort(out: &Path, extra: &[&str]) -> std::process::Output {
    let o = s(out);
    let mut args = vec!["cohort", o.as_str()];
    args.extend_from_slice(extra);
    unfold(&args)
}

/// A planted effect is found where it was planted (FWE p < 0.05 there, not
/// in the other half); a null column (with the group as a covariate,
/// Freedman-Lane) finds nothing; bad inputs get one line each; one seed
/// gives the same files.
#[test]
fn compare_finds_a_planted_effect_and_no_null_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = two_group_cohort(dir.path(), 4.0);
    let stats = out.join("cohort").join("stats");

    let o = cohort(&out, &["--compare", "group"]);
    assert_ok(&o);
    let printed = stdout(&o);
    assert!(
        printed.contains("compare: placenta image t2: t: B - A (2 groups: A 4, B 4)"),
        "{printed}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(stats.join("compare.json")).unwrap())
            .unwrap();
    assert_eq!(json["kind"], "categorical", "{json}");
    let a = &json["analyses"][0];
    assert_eq!(a["exhaustive"], true, "70 relabelings of 4 + 4: {json}");
    assert_eq!(a["groups"], serde_json::json!({"A": 4, "B": 4}), "{json}");
    let grid = grid_json(&out.join("cohort"));
    assert_eq!(grid["t2"]["resampled"], true, "{grid}");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        page.contains("<h2>Group comparison</h2>"),
        "the report's section"
    );
    assert!(
        page.contains("cohort/figures/compare_t2_group.png"),
        "its figure"
    );
    assert!(out.join("cohort/figures/compare_t2_group.png").is_file());
    let t_img = read_image(stats.join("t2_group_t.nii.gz")).unwrap().volume;
    let pfwe = values(&stats.join("t2_group_pfwe.nii.gz"));
    let t = t_img.data();
    // which template half is brighter: where subject p1 (group B) is
    let b_flat = read_image(out.join("p1").join("t2_flat.nii.gz"))
        .unwrap()
        .volume;
    let (mut bright_x, mut bright_n) = (0.0, 0);
    for (i, &v) in b_flat.data().iter().enumerate() {
        if v > 102.0 {
            let [nx, ny, _, _] = b_flat.dims();
            let q = Point3::new(
                (i % nx) as f64,
                ((i / nx) % ny) as f64,
                (i / (nx * ny)) as f64,
            );
            bright_x += b_flat.voxel_to_world(&q).x;
            bright_n += 1;
        }
    }
    let side = (bright_x / f64::from(bright_n)).signum();
    let [nx, ny, _, _] = t_img.dims();
    let (mut found, mut planted, mut elsewhere) = (0, 0, 0);
    for i in 0..t.len() {
        let q = Point3::new(
            (i % nx) as f64,
            ((i / nx) % ny) as f64,
            (i / (nx * ny)) as f64,
        );
        let x = t_img.voxel_to_world(&q).x * side;
        if !t[i].is_finite() {
            assert_eq!(pfwe[i], 1.0, "untested voxel {i}");
            continue;
        }
        if x > 8.0 {
            planted += 1;
            if pfwe[i] < 0.05 {
                found += 1;
                assert!(t[i] > 0.0, "B is brighter: t {}", t[i]);
            }
        } else if x < -8.0 && pfwe[i] < 0.05 {
            elsewhere += 1;
        }
    }
    println!("planted: {found} of {planted} voxels found, {elsewhere} elsewhere");
    assert!(found * 2 > planted, "{found} of {planted} found");
    assert_eq!(elsewhere, 0);

    // null: groups crossing A and B, the planted group as a covariate
    let o = cohort(
        &out,
        &["--compare", "null", "--covariates", "shade", "--seed", "3"],
    );
    assert_ok(&o);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(stats.join("compare.json")).unwrap())
            .unwrap();
    let a = &json["analyses"][0];
    assert_eq!(a["significant"], 0, "{json}");
    assert_eq!(a["exhaustive"], false, "{json}");
    assert!(!stats.join("t2_group_t.nii.gz").exists(), "replaced");
    let first: Vec<(String, Vec<u8>)> = files_of(&stats);

    // determinism: the same seed, the same files
    assert_ok(&cohort(
        &out,
        &["--compare", "null", "--covariates", "shade", "--seed", "3"],
    ));
    assert_eq!(files_of(&stats), first);

    // bad inputs
    for (args, needle) in [
        (vec!["--compare", "age"], "--compare age: not a column"),
        (vec!["--compare", "site"], "has one level (s1)"),
        (
            vec!["--compare", "group", "--covariates", "shade"],
            "regressor group is collinear",
        ),
        (
            vec!["--compare", "group", "--covariates", "null"],
            "'null' is not numeric",
        ),
        (
            vec!["--compare", "group", "--permutations", "0"],
            "--permutations must be at least 1",
        ),
        (vec!["--covariates", "shade"], "--compare"),
    ] {
        assert_one_line_error(&cohort(&out, &args), needle);
    }
}

/// The files in `dir`, sorted, with their bytes.
fn files_of(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut f: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    f.sort();
    f
}
