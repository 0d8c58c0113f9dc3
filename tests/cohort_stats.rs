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
/// `value(p)`) and returns the manifest row.
fn subject(dir: &Path, id: &str, mesh: &TetMesh, value: impl Fn(&Point3<f64>) -> f64) -> String {
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
    format!("{id},placenta,in/{id}/mesh.vtu,in/{id}/t2.nii.gz,\"{GRID}\",4,true\n")
}

fn batch(dir: &Path, rows: &[String]) -> std::path::PathBuf {
    let manifest = dir.join("manifest.csv");
    let mut text = "id,organ,input,image,grid,spacing-mm,no-figures\n".to_string();
    for r in rows {
        text.push_str(r);
    }
    std::fs::write(&manifest, text).unwrap();
    let out = dir.join("out");
    let o = unfold(&["batch", &s(&manifest), "-o", &s(&out), "--jobs", "2"]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    out
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
