//! Malformed files: truncated, lying headers, NaN positions, indices out of
//! range, control characters, empty files and directories.

use crate::harness::{Case, args, run, s};
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::CellMesh;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};

fn slab() -> CellMesh {
    CellMesh::from(&placenta_slab(&PlacentaParams::default()).unwrap().mesh)
}

#[test]
fn broken_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = slab();
    let good = d.join("good.vtu");
    write_mesh(&good, &mesh, &WriteOptions::default()).unwrap();
    let bytes = std::fs::read(&good).unwrap();

    let truncated = d.join("truncated.vtu");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();

    let nan_path = d.join("nan.vtk");
    std::fs::write(
        &nan_path,
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
         0 0 0 nan 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
    )
    .unwrap();

    let legacy = d.join("out_of_range.vtk");
    std::fs::write(
        &legacy,
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
         0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 4000000000\nCELL_TYPES 1\n10\n",
    )
    .unwrap();

    let lying = d.join("lying.vtk");
    std::fs::write(
        &lying,
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4000000000000 double\n\
         0 0 0 1 0 0 0 1 0 0 0 1\n",
    )
    .unwrap();

    let escape = d.join("escape.vtk");
    std::fs::write(
        &escape,
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
         0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n\
         POINT_DATA 4\nSCALARS \x1b]0;pwned\x07\x1b[31m float 1\nLOOKUP_TABLE default\n0 1 x 3\n",
    )
    .unwrap();

    let empty = d.join("empty.vtu");
    std::fs::write(&empty, b"").unwrap();

    let out = d.join("out");
    for (name, input, expect) in [
        ("truncated vtu", &truncated, "truncated.vtu"),
        ("NaN position", &nan_path, "NaN"),
        ("index out of range", &legacy, "out_of_range.vtk"),
        ("lying point count", &lying, "lying.vtk"),
        ("escape bytes in an array name", &escape, "escape.vtk"),
        ("empty file", &empty, "empty.vtu"),
        ("a directory", &d.to_path_buf(), ""),
    ] {
        run(&Case {
            name,
            args: args(&["placenta", &s(input), "-o", &s(&out), "--no-figures"]),
            expect,
            max_peak_mib: 150.0,
            inputs: if input.is_file() {
                vec![input.clone()]
            } else {
                vec![]
            },
            output: Some(out.clone()),
        });
    }
}

#[test]
fn lying_image_headers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a NIfTI-1 header declaring 30000^3 float voxels, with 8 bytes of data
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (i, v) in [3i16, 30000, 30000, 30000, 1, 1, 1, 1].iter().enumerate() {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&v.to_le_bytes());
    }
    h[70..72].copy_from_slice(&16i16.to_le_bytes()); // float32
    h[72..74].copy_from_slice(&32i16.to_le_bytes());
    for i in 0..8 {
        h[76 + 4 * i..80 + 4 * i].copy_from_slice(&1f32.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend_from_slice(&[0u8; 8]);
    let img = d.join("lying.nii");
    std::fs::write(&img, &h).unwrap();
    let out = d.join("m.vtu");
    for (name, a) in [
        (
            "lying NIfTI: mesh",
            args(&["mesh", &s(&img), "-o", &s(&out)]),
        ),
        (
            "lying NIfTI: convert",
            args(&["convert", &s(&img), &s(&d.join("x.nrrd"))]),
        ),
    ] {
        run(&Case {
            name,
            args: a,
            expect: "lying.nii",
            max_peak_mib: 100.0,
            inputs: vec![img.clone()],
            output: Some(out.clone()),
        });
    }
}
