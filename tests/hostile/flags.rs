//! Runaway flags: values that would make a stage allocate without bound
//! are refused before it allocates, with what to change.

use crate::harness::{Case, args, run, s};
use unfold::io::{NiftiImage, WriteOptions, write_image, write_mesh};
use unfold::mesh::nalgebra::{Matrix4, Point3};
use unfold::mesh::shapes::{PlacentaParams, VentricleParams, placenta_slab, ventricle_cup};
use unfold::mesh::{CellMesh, Volume};

/// A ball mask of radius 8 voxels in 20^3 voxels of `spacing` mm.
fn mask(path: &std::path::Path, spacing: [f64; 3]) {
    let n = 20;
    let mut data = vec![0.0f32; n * n * n];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let d2: f64 = [i, j, k].iter().map(|&x| (x as f64 - 9.5).powi(2)).sum();
                if d2 <= 64.0 {
                    data[i + n * (j + n * k)] = 1.0;
                }
            }
        }
    }
    let mut a = Matrix4::identity();
    for (i, s) in spacing.iter().enumerate() {
        a[(i, i)] = *s;
    }
    let vol = Volume::new([n, n, n, 1], a, data).unwrap();
    write_image(path, &NiftiImage::new(vol)).unwrap();
}

#[test]
fn mesher_flags() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("mask.nii.gz");
    mask(&m, [1.0; 3]);
    let out = dir.path().join("m.vtu");
    for (name, extra, expect) in [
        (
            "mesh --size-mm 0.001",
            vec!["--size-mm", "0.001"],
            "raise --size-mm",
        ),
        (
            "mesh --smooth-voxels 1e6",
            vec!["--smooth-voxels", "1e6"],
            "--smooth-voxels",
        ),
        (
            "mesh --smooth-voxels 1e4",
            vec!["--smooth-voxels", "1e4"],
            "--smooth-voxels",
        ),
        (
            "mesh --size-mm 1e-300",
            vec!["--size-mm", "1e-300"],
            "--size-mm",
        ),
        ("mesh --dilate 1000", vec!["--dilate", "1000"], "dilat"),
        (
            "mesh --max-memory 1K",
            vec!["--max-memory", "1K"],
            "--max-memory",
        ),
    ] {
        let mut a = args(&["mesh", &s(&m), "-o", &s(&out)]);
        a.extend(extra.iter().map(|x| x.to_string()));
        run(&Case {
            name,
            args: a,
            expect,
            max_peak_mib: 150.0,
            inputs: vec![m.clone()],
            output: Some(out.clone()),
        });
    }
    // the case: --size-mm 0.1 on a 42 mm mask (about 32 GiB)
    let big = dir.path().join("big.nii.gz");
    mask(&big, [2.1; 3]);
    run(&Case {
        name: "mesh --size-mm 0.1 on a 42 mm mask",
        args: args(&[
            "mesh",
            &s(&big),
            "-o",
            &s(&out),
            "--size-mm",
            "0.1",
            "--max-memory",
            "8G",
        ]),
        expect: "raise --size-mm",
        max_peak_mib: 150.0,
        inputs: vec![big.clone()],
        output: Some(out.clone()),
    });
    // a mask of 1000 x 1 x 1 mm voxels (a ball 16 voxels across: 16 m)
    let wide = dir.path().join("wide.nii.gz");
    mask(&wide, [1000.0, 1.0, 1.0]);
    let p = dir.path().join("p");
    run(&Case {
        name: "placenta --seg anisotropic mask",
        args: args(&[
            "placenta",
            "--seg",
            &s(&wide),
            "-o",
            &s(&p),
            // --dense meshes at the smallest spacing (the default size
            // follows the mask's volume and thickness)
            "--dense",
            "--max-memory",
            "2G",
        ]),
        // refused before meshing: a 16 m organ (its voxel size is wrong)
        expect: "the organ is 16000 mm across",
        max_peak_mib: 150.0,
        inputs: vec![wide.clone()],
        output: Some(p),
    });
}

#[test]
fn placenta_flags() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = placenta_slab(&PlacentaParams::default()).unwrap().mesh;
    let input = dir.path().join("slab.vtu");
    write_mesh(&input, &CellMesh::from(&mesh), &WriteOptions::default()).unwrap();
    let out = dir.path().join("out");
    for (name, extra, expect) in [
        (
            "placenta --grid a kilometre box",
            vec!["--grid=-5e5,5e5,-5e5,5e5,-5e5,5e5", "--spacing-mm", "1"],
            "shrink the --grid box",
        ),
        (
            "placenta --margin-mm 1e12",
            vec!["--margin-mm", "1e12"],
            "--margin-mm",
        ),
        (
            // (without --margin-mm the margin starts at five such voxels,
            // a valid if meaningless run)
            "placenta --voxel-mm 1e-9 --margin-mm 15",
            vec!["--voxel-mm", "1e-9", "--margin-mm", "15"],
            "voxel",
        ),
        (
            "placenta --max-memory 20M",
            vec!["--max-memory", "20M"],
            "coarsen the mesh",
        ),
    ] {
        let mut a = args(&["placenta", &s(&input), "-o", &s(&out), "--no-figures"]);
        a.extend(extra.iter().map(|x| x.to_string()));
        run(&Case {
            name,
            args: a,
            expect,
            max_peak_mib: 200.0,
            inputs: vec![input.clone()],
            output: Some(out.clone()),
        });
    }
}

#[test]
fn ventricle_flags() {
    let dir = tempfile::tempdir().unwrap();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let surface = dir.path().join("surface.vtp");
    write_mesh(
        &surface,
        &CellMesh::from(&v.surface),
        &WriteOptions::default(),
    )
    .unwrap();
    let pt = |p: &Point3<f64>| format!("{:?},{:?},{:?}", p.x, p.y, p.z);
    let out = dir.path().join("v");
    for (name, extra, expect) in [
        (
            "ventricle --grid-mm 0.001",
            vec!["--grid-mm", "0.001"],
            "raise --grid-mm",
        ),
        (
            "ventricle --grid-mm 0.1 --max-memory 1G",
            vec!["--grid-mm", "0.1", "--max-memory", "1G"],
            "raise --grid-mm",
        ),
        (
            "ventricle --hemisphere-mm 1e9",
            vec!["--hemisphere-mm", "1e9"],
            "hemisphere",
        ),
    ] {
        let mut a = args(&[
            "ventricle",
            &s(&surface),
            "--surface",
            &s(&surface),
            "--anterior",
            &pt(&v.anterior),
            "--inferior",
            &pt(&v.inferior),
            "--no-figures",
            "-o",
            &s(&out),
        ]);
        a.extend(extra.iter().map(|x| x.to_string()));
        run(&Case {
            name,
            args: a,
            expect,
            max_peak_mib: 200.0,
            inputs: vec![surface.clone()],
            output: Some(out.clone()),
        });
    }
}
