//! Inputs in metres or centimetres: an organ command that fails on a mesh
//! smaller than the organ says that unfold reads millimetres, which unit the
//! file is likely in (from the organ's size) and how to scale it, and
//! `unfold convert --scale` scales it. Inputs are the built-in shapes,
//! written in metres or centimetres.

use std::path::{Path, PathBuf};
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{
    PlacentaParams, ValveParams, VentricleParams, mitral_valve, placenta_slab, ventricle_cup,
};
use unfold::mesh::{CellMesh, CellType, Field};

mod common;
use common::*;

/// `mesh` with every coordinate divided by 1000 (millimetres to metres),
/// written to `dir/name`.
fn write_in_metres(dir: &Path, name: &str, mesh: &CellMesh) -> PathBuf {
    write_divided(dir, name, mesh, 1000.0)
}

/// `mesh` with every coordinate divided by `by`, written to `dir/name`.
fn write_divided(dir: &Path, name: &str, mesh: &CellMesh, by: f64) -> PathBuf {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        p.coords /= by;
    }
    let path = dir.join(name);
    write_mesh(&path, &m, &WriteOptions::default()).unwrap();
    path
}

/// The placenta slab (1,296 tets), in millimetres.
fn slab() -> CellMesh {
    let slab = placenta_slab(&PlacentaParams {
        cells_radial: 6,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .unwrap();
    CellMesh::from(&slab.mesh)
}

/// Checks the note of a failed organ command on `small`.
fn assert_units_note(o: &std::process::Output, small: &Path) {
    assert_one_line_error(o, "reads coordinates as millimetres");
    let err = stderr(o);
    assert!(
        err.contains(&format!("note: {} is only", small.display())),
        "{err}"
    );
    assert!(err.contains("if it is in metres"), "{err}");
    assert!(err.contains("--scale 1000`"), "{err}");
}

#[test]
fn a_placenta_in_metres_is_named_and_scaled_back() {
    let dir = tempfile::tempdir().unwrap();
    let metres = write_in_metres(dir.path(), "slab_m.vtu", &slab());
    let o = unfold(&[
        "placenta",
        &s(&metres),
        "-o",
        &s(&dir.path().join("out_m")),
        "--no-figures",
    ]);
    assert_units_note(&o, &metres);
    assert!(!dir.path().join("out_m/report.json").exists());

    // scaled by convert, the same file runs
    let mm = dir.path().join("slab_mm.vtu");
    let o = unfold(&["convert", &s(&metres), &s(&mm), "--scale", "1000"]);
    assert_ok(&o);
    let o = unfold(&[
        "placenta",
        &s(&mm),
        "-o",
        &s(&dir.path().join("out_mm")),
        "--no-figures",
    ]);
    assert_ok(&o);
    assert!(dir.path().join("out_mm/report.json").exists());
}

#[test]
fn a_failure_on_a_millimetre_input_gets_no_units_note() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("slab.vtu");
    write_mesh(&path, &slab(), &WriteOptions::default()).unwrap();
    // a margin wider than the slab: fails on the input, but not for its size
    let o = unfold(&[
        "placenta",
        &s(&path),
        "--margin-mm",
        "1000",
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_one_line_error(&o, "margin");
    assert!(!stderr(&o).contains("note:"), "{}", stderr(&o));
}

#[test]
fn a_mitral_valve_in_metres_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let v = mitral_valve(&ValveParams {
        annulus_segments: 40,
        depth_segments: 8,
        ..ValveParams::default()
    })
    .unwrap();
    let mut ring = CellMesh::from_points(v.annulus.clone());
    let mut ids: Vec<u32> = (0..v.annulus.len() as u32).collect();
    ids.push(0);
    ring.push_cell(CellType::PolyLine, &ids);
    let a = write_in_metres(dir.path(), "al.vtp", &CellMesh::from(&v.anterior));
    let p = write_in_metres(dir.path(), "pl.vtp", &CellMesh::from(&v.posterior));
    let r = write_in_metres(dir.path(), "ring.vtp", &ring);
    let o = unfold(&[
        "mitral",
        "--anterior",
        &s(&a),
        "--posterior",
        &s(&p),
        "--annulus",
        &s(&r),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_units_note(&o, &a);
}

#[test]
fn a_ventricle_in_metres_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let anatomy = write_in_metres(dir.path(), "anatomy.vtp", &CellMesh::from(&v.anatomy));
    let surface = write_in_metres(dir.path(), "surface.vtp", &CellMesh::from(&v.surface));
    let metres = |p: &Point3<f64>| pt(&Point3::from(p.coords / 1000.0));
    let o = unfold(&[
        "ventricle",
        &s(&anatomy),
        "--surface",
        &s(&surface),
        "--anterior",
        &metres(&v.anterior),
        "--inferior",
        &metres(&v.inferior),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_units_note(&o, &anatomy);
}

#[test]
fn a_ventricle_in_centimetres_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let anatomy = write_divided(dir.path(), "anatomy.vtp", &CellMesh::from(&v.anatomy), 10.0);
    let surface = write_divided(dir.path(), "surface.vtp", &CellMesh::from(&v.surface), 10.0);
    let cm = |p: &Point3<f64>| pt(&Point3::from(p.coords / 10.0));
    let o = unfold(&[
        "ventricle",
        &s(&anatomy),
        "--surface",
        &s(&surface),
        "--anterior",
        &cm(&v.anterior),
        "--inferior",
        &cm(&v.inferior),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_one_line_error(&o, "reads coordinates as millimetres");
    let err = stderr(&o);
    assert!(err.contains("if it is in centimetres"), "{err}");
    assert!(err.contains("--scale 10`"), "{err}");
    assert!(!err.contains("--scale 1000"), "{err}");
}

#[test]
fn a_placenta_in_centimetres_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let cm = write_divided(dir.path(), "slab_cm.vtu", &slab(), 10.0);
    let o = unfold(&[
        "placenta",
        &s(&cm),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_one_line_error(&o, "if it is in centimetres");
    assert!(stderr(&o).contains("--scale 10`"), "{}", stderr(&o));
}

#[test]
fn convert_scales_the_points_and_keeps_the_arrays() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = slab();
    let n = mesh.positions.len();
    mesh.point_data
        .insert(Field::scalars("id", (0..n).map(|i| i as f64).collect()));
    let metres = write_in_metres(dir.path(), "slab_m.vtu", &mesh);
    let back = dir.path().join("slab.vtk");
    let o = unfold(&["convert", &s(&metres), &s(&back), "--scale", "1000"]);
    assert_ok(&o);
    let read = read_mesh(&back).unwrap();
    assert_eq!(read.positions.len(), n);
    for (p, q) in read.positions.iter().zip(&mesh.positions) {
        assert!(
            (p - q).norm() <= 1e-9 * (1.0 + q.coords.norm()),
            "{p} vs {q}"
        );
    }
    assert_eq!(read.point_data, mesh.point_data);
    assert_eq!(read.num_cells(), mesh.num_cells());
}

#[test]
fn bad_scales_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_in_metres(dir.path(), "slab_m.vtu", &slab());
    let out = dir.path().join("out.vtu");
    for bad in ["0", "-1000", "nan", "inf"] {
        let o = unfold(&["convert", &s(&input), &s(&out), "--scale", bad]);
        assert_one_line_error(&o, "--scale must be a finite number > 0");
        assert!(!out.exists());
    }
    // an image's spacing is its header's (refused before the file is read)
    let image = dir.path().join("mask.nii");
    let o = unfold(&[
        "convert",
        &s(&image),
        &s(&dir.path().join("b.nii")),
        "--scale",
        "2",
    ]);
    assert_one_line_error(&o, "--scale applies to meshes");
}

#[test]
fn info_notes_a_mesh_smaller_than_an_organ() {
    let dir = tempfile::tempdir().unwrap();
    let metres = write_in_metres(dir.path(), "slab_m.vtu", &slab());
    let o = unfold(&["info", &s(&metres)]);
    assert_ok(&o);
    assert!(
        stdout(&o).contains("reads coordinates as millimetres"),
        "{}",
        stdout(&o)
    );
    let o = unfold(&["info", &s(&metres), "--json"]);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!(
        j["units_note"].as_str().unwrap().contains("--scale 1000`"),
        "{j}"
    );
    // 3.6 across (the 178 mm slab divided by 50): info knows no organ, and
    // 36 mm is an organ's size where 3.6 m is none
    let small = write_divided(dir.path(), "small.vtu", &slab(), 50.0);
    let o = unfold(&["info", &s(&small), "--json"]);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let note = j["units_note"].as_str().unwrap();
    assert!(note.contains("if it is in centimetres"), "{note}");
    // in millimetres: no note
    let mm = dir.path().join("slab.vtu");
    write_mesh(&mm, &slab(), &WriteOptions::default()).unwrap();
    let o = unfold(&["info", &s(&mm), "--json"]);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!(j.get("units_note").is_none(), "{j}");
}

/// A mask of 1000 x 1 x 1 mm voxels whose organ is 16 voxels long (16 m)
/// is refused at once with one line naming the extent and the voxel size,
/// and nothing is meshed or written.
#[test]
fn a_placenta_mask_over_a_metre_is_refused_before_meshing() {
    use unfold::io::{NiftiImage, write_image};
    use unfold::mesh::Volume;
    use unfold::mesh::nalgebra::Matrix4;
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny, nz) = (20, 12, 12);
    let mut data = vec![0f32; nx * ny * nz];
    for k in 2..10 {
        for j in 2..10 {
            for i in 2..18 {
                data[i + nx * (j + ny * k)] = 1.0;
            }
        }
    }
    let affine = Matrix4::new_nonuniform_scaling(&[1000.0, 1.0, 1.0].into());
    let vol = Volume::new([nx, ny, nz, 1], affine, data).unwrap();
    let mask = dir.path().join("long.nii.gz");
    write_image(&mask, &NiftiImage::new(vol)).unwrap();
    let out = dir.path().join("p");
    let o = unfold(&[
        "placenta",
        "--seg",
        &s(&mask),
        "-o",
        &s(&out),
        "--no-figures",
    ]);
    assert_one_line_error(&o, "the organ is 16000 mm across");
    let err = stderr(&o);
    assert!(err.contains(&s(&mask)), "{err}");
    assert!(
        err.contains("check the voxel size in the image's header (1000 x 1 x 1 mm"),
        "{err}"
    );
    assert!(!out.exists());
}

/// A placenta mesh 100 times too large (in tenths of a millimetre, about
/// 13 m across) is refused before the run with one line naming its units.
#[test]
fn a_placenta_mesh_over_a_metre_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let big = write_divided(dir.path(), "slab_big.vtu", &slab(), 0.01);
    let out = dir.path().join("p");
    let o = unfold(&["placenta", &s(&big), "-o", &s(&out), "--no-figures"]);
    assert_one_line_error(&o, "larger than any organ unfold maps (1000 mm)");
    assert!(
        stderr(&o).contains("check the file's units"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}
