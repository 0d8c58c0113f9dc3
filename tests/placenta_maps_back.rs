//! The placenta map in both directions through the binary: `unfold placenta
//! --displacement` (the map as an ITK displacement field, checked by
//! resampling the subject image through it, as ITK does) and `unfold
//! pushback` (template-space images back onto the scanner grid), with their
//! bad inputs as one-line errors.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use unfold::io::nifti::INTENT_VECTOR;
use unfold::io::{
    Datatype, NiftiImage, WriteOptions, read_image, read_tet_mesh, write_image, write_mesh,
};
use unfold::mesh::nalgebra::{Point3, Vector3};
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::mesh::spatial::TetLocator;
use unfold::mesh::{CellMesh, TetMesh, Volume};

mod common;
#[path = "common/scan.rs"]
mod scan;
use common::*;

/// A small placenta slab (1296 tets), tilted so that scanner and template
/// axes differ.
fn tilted_slab() -> TetMesh {
    let mut mesh = placenta_slab(&PlacentaParams {
        cells_radial: 6,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .expect("valid slab parameters")
    .mesh;
    let r = unfold::mesh::nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.7);
    for p in &mut mesh.positions {
        *p = Point3::from(r * p.coords + Vector3::new(12.0, -30.0, 45.0));
    }
    mesh
}

/// A scanner image around `mesh` (2 mm voxels, 6 mm margin) with values
/// `f(world position)`.
fn image_around(mesh: &TetMesh, f: impl Fn(&Point3<f64>) -> f64) -> NiftiImage {
    scan::image_around(mesh, [2.0; 3], 1, Vector3::zeros(), |p, _| f(p))
}

/// The intensity of the subject image: smooth, far from 0.
fn intensity(p: &Point3<f64>) -> f64 {
    300.0 + 2.0 * p.x - 1.5 * p.y + 3.0 * p.z + 0.05 * p.x * p.y
}

/// Writes the slab and its image into `dir`, runs `unfold placenta` with
/// `--displacement`, and returns (run dir, image path, displacement path).
fn run_placenta(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let mesh = tilted_slab();
    let mesh_path = dir.join("slab.vtu");
    write_mesh(&mesh_path, &CellMesh::from(&mesh), &WriteOptions::default()).unwrap();
    let image_path = dir.join("mri.nii.gz");
    write_image(&image_path, &image_around(&mesh, intensity)).unwrap();
    let out = dir.join("run");
    let disp = dir.join("warp.nii.gz");
    let o = unfold(&[
        "placenta",
        &s(&mesh_path),
        "--image",
        &s(&image_path),
        "-o",
        &s(&out),
        "--displacement",
        &s(&disp),
        "--no-figures",
    ]);
    assert_ok(&o);
    assert!(stdout(&o).contains("warp.nii.gz"), "{}", stdout(&o));
    (out, image_path, disp)
}

#[test]
fn the_displacement_field_reproduces_the_pull_back() {
    let dir = tempfile::tempdir().unwrap();
    let (out, image_path, disp) = run_placenta(dir.path());
    let flat = read_image(out.join("mri_flat.nii.gz")).unwrap();
    let field = read_image(&disp).unwrap();
    let subject = read_image(&image_path).unwrap();
    assert_eq!(field.intent_code, INTENT_VECTOR);
    let fd = field.volume.dims();
    let d = flat.volume.dims();
    assert_eq!(
        fd,
        [d[0], d[1], d[2], 3],
        "the field is on the flat image's grid"
    );
    assert_eq!(field.volume.affine(), flat.volume.affine());

    // ITK's reading: the template voxel at p (LPS: (-x, -y, z)) comes from
    // the subject point p + d(p) (LPS); in RAS, z = p + (-d_x, -d_y, d_z).
    let n = flat.volume.frame_len();
    let (mut moved, mut worst) = (0usize, 0.0f64);
    for v in 0..n {
        let dv = Vector3::from_fn(|a, _| f64::from(field.volume.data()[a * n + v]));
        let value = f64::from(flat.volume.data()[v]);
        if dv == Vector3::zeros() {
            assert_eq!(value, 0.0, "voxel {v} outside the mesh is 0");
            continue;
        }
        moved += 1;
        let (i, j, k) = (v % d[0], (v / d[0]) % d[1], v / (d[0] * d[1]));
        let p = flat
            .volume
            .voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
        let z = p + Vector3::new(-dv.x, -dv.y, dv.z);
        let want = subject
            .volume
            .sample_world(&z, 0)
            .expect("inside the image");
        worst = worst.max((want - value).abs());
    }
    let r = serde_json::from_str::<serde_json::Value>(
        &std::fs::read_to_string(out.join("report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(r["displacement"]["inside_mesh"], moved);
    assert_eq!(r["images"][0]["sampled"], moved);
    assert!(moved > 500, "{moved}");
    // f32 storage of vectors of ~100 mm: ~1e-5 mm, times a gradient of ~5.
    assert!(
        worst < 1e-3,
        "resampling through the field differs by {worst}"
    );
}

#[test]
fn pushback_returns_template_images_to_the_scanner() {
    let dir = tempfile::tempdir().unwrap();
    let (out, image_path, _) = run_placenta(dir.path());
    let subject = read_image(&image_path).unwrap();

    // A template-space image holding the template coordinates themselves
    // (3 frames: 100 + x, 100 + y, 100 + z; affine, so trilinear sampling
    // is exact) comes back as the map X(z) of every scanner voxel centre z
    // inside the placenta: X(z) = sum_i alpha_i x_i over the original tet
    // containing z.
    let flat = read_image(out.join("mri_flat.nii.gz")).unwrap();
    let fv = &flat.volume;
    let fd = fv.dims();
    let centre = |v: usize, d: [usize; 4], vol: &Volume<f32>| {
        vol.voxel_to_world(&Point3::new(
            (v % d[0]) as f64,
            ((v / d[0]) % d[1]) as f64,
            (v / (d[0] * d[1])) as f64,
        ))
    };
    let n = fv.frame_len();
    let coords: Vec<f32> = (0..3)
        .flat_map(|a| (0..n).map(move |v| (a, v)))
        .map(|(a, v)| (100.0 + centre(v, fd, fv)[a]) as f32)
        .collect();
    let atlas_xyz = dir.path().join("xyz.nii.gz");
    write_image(
        &atlas_xyz,
        &NiftiImage::new(Volume::new([fd[0], fd[1], fd[2], 3], *fv.affine(), coords).unwrap()),
    )
    .unwrap();
    let mapped = dir.path().join("mapped.nii.gz");
    let o = unfold(&[
        "pushback",
        &s(&atlas_xyz),
        "--run",
        &s(&out),
        "--reference",
        &s(&image_path),
        "-o",
        &s(&mapped),
    ]);
    assert_ok(&o);
    assert!(stdout(&o).contains("mapped.nii.gz"), "{}", stdout(&o));
    let mapped = read_image(&mapped).unwrap();
    let md = mapped.volume.dims();
    assert_eq!(
        md,
        [
            subject.volume.dims()[0],
            subject.volume.dims()[1],
            subject.volume.dims()[2],
            3
        ]
    );
    assert_eq!(mapped.volume.affine(), subject.volume.affine());
    let original = read_tet_mesh(out.join("original.vtu")).unwrap();
    let flattened = read_tet_mesh(out.join("flattened.vtu")).unwrap();
    let locator = TetLocator::new(&original);
    let m = mapped.volume.frame_len();
    let (mut inside, mut worst) = (0usize, 0.0f64);
    for v in 0..m {
        let z = centre(v, md, &mapped.volume);
        let got = Vector3::from_fn(|a, _| f64::from(mapped.volume.data()[a * m + v]));
        match locator.locate(&z) {
            Some((t, alpha)) => {
                inside += 1;
                let x = (0..4).fold(Vector3::zeros(), |acc, c| {
                    acc + flattened.positions[original.tets[t][c] as usize].coords * alpha[c]
                });
                worst = worst.max((got - x - Vector3::repeat(100.0)).amax());
            }
            None => assert_eq!(got, Vector3::zeros(), "voxel {v} outside the placenta is 0"),
        }
    }
    assert!(inside > 200, "{inside} voxels inside the placenta");
    assert!(worst < 1e-3, "the map differs by {worst} mm");

    // The pulled-back MRI, pushed back, is the subject image again inside
    // the placenta up to resampling twice: exactly where the template
    // stencil stays inside the mesh, blended with the 0 outside near the
    // boundary; the median voxel is within 1 % of the image's range.
    let back = dir.path().join("back.nii.gz");
    assert_ok(&unfold(&[
        "pushback",
        &s(&out.join("mri_flat.nii.gz")),
        "--run",
        &s(&out),
        "--reference",
        &s(&image_path),
        "-o",
        &s(&back),
    ]));
    let back = read_image(&back).unwrap();
    let mut errors: Vec<f64> = back
        .volume
        .data()
        .iter()
        .zip(subject.volume.data())
        .filter(|(b, _)| **b != 0.0)
        .map(|(b, s)| f64::from(b - s).abs())
        .collect();
    assert_eq!(errors.len(), inside);
    errors.sort_by(f64::total_cmp);
    let range = subject
        .volume
        .value_range()
        .map(|(lo, hi)| hi - lo)
        .unwrap();
    let median = errors[errors.len() / 2];
    assert!(
        median <= 0.01 * range,
        "median error {median} against a range of {range}"
    );

    // A label map drawn on the template (two halves, x < 0 and x >= 0)
    // comes back with nearest-neighbour labels and its integer type.
    let labels: Vec<f32> = (0..fv.frame_len())
        .map(|v| {
            let d = fv.dims();
            let p = fv.voxel_to_world(&Point3::new(
                (v % d[0]) as f64,
                ((v / d[0]) % d[1]) as f64,
                (v / (d[0] * d[1])) as f64,
            ));
            if p.x < 0.0 { 1.0 } else { 2.0 }
        })
        .collect();
    let atlas = dir.path().join("atlas.nii");
    write_image(
        &atlas,
        &NiftiImage::new(Volume::new(fv.dims(), *fv.affine(), labels).unwrap())
            .with_datatype(Datatype::Uint8),
    )
    .unwrap();
    let labelled = dir.path().join("labels.nii.gz");
    assert_ok(&unfold(&[
        "pushback",
        &s(&atlas),
        "--run",
        &s(&out),
        "--reference",
        &s(&image_path),
        "-o",
        &s(&labelled),
        "--interp",
        "nearest",
    ]));
    let labelled = read_image(&labelled).unwrap();
    assert_eq!(labelled.datatype, Datatype::Uint8);
    let values: BTreeSet<u8> = labelled.volume.data().iter().map(|&x| x as u8).collect();
    assert_eq!(values, BTreeSet::from([0, 1, 2]));
    // Exactly the voxels inside the placenta are labelled.
    let labelled_count = labelled.volume.data().iter().filter(|&&x| x != 0.0).count();
    assert_eq!(labelled_count, inside);
}

#[test]
fn bad_inputs_of_the_way_back_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (out, image_path, _) = run_placenta(dir.path());
    let flat = out.join("mri_flat.nii.gz");
    let pushback = |run: &Path, reference: &Path, output: &Path| {
        unfold(&[
            "pushback",
            &s(&flat),
            "--run",
            &s(run),
            "--reference",
            &s(reference),
            "-o",
            &s(output),
        ])
    };
    let target = dir.path().join("t.nii.gz");
    // Not a run directory.
    assert_one_line_error(
        &pushback(dir.path(), &image_path, &target),
        "is not the output directory of an `unfold placenta` run",
    );
    // The output would overwrite an input.
    assert_one_line_error(
        &pushback(&out, &image_path, &image_path),
        "would be overwritten",
    );
    // Not a NIfTI output.
    assert_one_line_error(
        &pushback(&out, &image_path, &dir.path().join("t.vtu")),
        "must be an image (.nii, .nii.gz or .nrrd)",
    );
    // A reference grid nowhere near the placenta.
    let far = dir.path().join("far.nii");
    let mut img = read_image(&image_path).unwrap();
    let mut a = *img.volume.affine();
    a[(0, 3)] += 1000.0;
    img.volume = Volume::new(img.volume.dims(), a, img.volume.data().to_vec()).unwrap();
    write_image(&far, &img).unwrap();
    assert_one_line_error(
        &pushback(&out, &far, &target),
        "no voxel centre of this grid",
    );
    // Meshes of different runs.
    let mismatched = dir.path().join("mismatched");
    std::fs::create_dir(&mismatched).unwrap();
    std::fs::copy(out.join("original.vtu"), mismatched.join("original.vtu")).unwrap();
    let other = placenta_slab(&PlacentaParams {
        cells_radial: 4,
        cells_through: 1,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh;
    write_mesh(
        mismatched.join("flattened.vtu"),
        &CellMesh::from(&other),
        &WriteOptions::default(),
    )
    .unwrap();
    assert_one_line_error(
        &pushback(&mismatched, &image_path, &target),
        "does not match",
    );
    assert!(!target.exists(), "nothing written by a failed run");

    // --displacement: a NIfTI path that is neither an input nor an output.
    let mesh_path = dir.path().join("slab.vtu");
    for (path, needle) in [
        (dir.path().join("warp.vtu"), ".nii or .nii.gz"),
        (image_path.clone(), "would be overwritten by --displacement"),
        (
            dir.path().join("o2").join("mri_flat.nii.gz"),
            "would overwrite the output",
        ),
    ] {
        assert_one_line_error(
            &unfold(&[
                "placenta",
                &s(&mesh_path),
                "--image",
                &s(&image_path),
                "-o",
                &s(&dir.path().join("o2")),
                "--displacement",
                &s(&path),
            ]),
            needle,
        );
    }
    assert!(!dir.path().join("o2").exists(), "nothing created");
}

#[test]
fn the_displacement_field_follows_a_fixed_grid() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = tilted_slab();
    let mesh_path = dir.path().join("slab.vtu");
    write_mesh(&mesh_path, &CellMesh::from(&mesh), &WriteOptions::default()).unwrap();
    let image_path = dir.path().join("mri.nii.gz");
    write_image(&image_path, &image_around(&mesh, intensity)).unwrap();
    let out = dir.path().join("run");
    let disp = dir.path().join("warp.nii");
    assert_ok(&unfold(&[
        "placenta",
        &s(&mesh_path),
        "--image",
        &s(&image_path),
        "-o",
        &s(&out),
        "--grid=-150,150,-150,150,-40,40",
        "--spacing-mm",
        "5",
        "--displacement",
        &s(&disp),
        "--no-figures",
    ]));
    let flat = read_image(out.join("mri_flat.nii.gz")).unwrap();
    let field = read_image(&disp).unwrap();
    let d = flat.volume.dims();
    assert_eq!(d, [61, 61, 17, 1]);
    assert_eq!(field.volume.dims(), [61, 61, 17, 3]);
    assert_eq!(field.volume.affine(), flat.volume.affine());
}
