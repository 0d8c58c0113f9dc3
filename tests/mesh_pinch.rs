//! `unfold mesh` on a mask whose two blocks touch at a voxel corner (issue
//! 35): at every element size from 1.5 to 3 voxels it exits 0 with a mesh
//! `unfold info --strict` finds valid; at 3 voxels, where the cut touches
//! itself at a lattice vertex, the line printed says the pinch was split.

use unfold::io::{NiftiImage, write_image};
use unfold::mesh::Volume;
use unfold::mesh::nalgebra::Matrix4;

mod common;
use common::*;

/// Two blocks of 6 voxels (1 mm) touching at the corner of voxels
/// (9, 9, 9) and (10, 10, 10), in a grid of 20^3.
fn write_touching_blocks(path: &std::path::Path) {
    let n = 20usize;
    let mut data = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let a = [i, j, k].iter().all(|&x| (4..10).contains(&x));
                let b = [i, j, k].iter().all(|&x| (10..16).contains(&x));
                data.push(if a || b { 1.0f32 } else { 0.0 });
            }
        }
    }
    let vol = Volume::new([n, n, n, 1], Matrix4::identity(), data).unwrap();
    write_image(path, &NiftiImage::new(vol)).unwrap();
}

#[test]
fn blocks_touching_at_a_corner_mesh_at_every_size() {
    let dir = tempfile::tempdir().unwrap();
    let mask = dir.path().join("touching.nii");
    write_touching_blocks(&mask);
    for size in ["1.5", "2", "3"] {
        let out = dir.path().join(format!("touching-{size}.vtu"));
        let o = unfold(&[
            "mesh",
            &s(&mask),
            "-o",
            &s(&out),
            "--size-mm",
            size,
            "--smooth-voxels",
            "1",
        ]);
        assert!(o.status.success(), "{size}: {}", stderr(&o));
        if size == "3" {
            assert!(
                stdout(&o).contains("pinches resolved: 1 vertices split"),
                "{}",
                stdout(&o)
            );
        }
        let info = unfold(&["info", &s(&out), "--strict", "--json"]);
        assert!(info.status.success(), "{size}: {}", stderr(&info));
        let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        assert_eq!(v["valid"], true, "{size}: {v}");
    }
}
