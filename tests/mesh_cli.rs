//! `unfold mesh` and `unfold placenta --seg` through the binary: a
//! voxelized placenta-like slab is meshed (valid for `unfold info
//! --strict`, the mask's volume kept), flattened from the segmentation with
//! a synthetic image whose intensity is a known function of the depth
//! across the slab, and every bad input is a one-line error.

use std::path::Path;
use unfold::io::{NiftiImage, read_image, read_mesh, write_image};
use unfold::mesh::Volume;
use unfold::mesh::nalgebra::{Matrix4, Point3, Rotation3};

mod common;
use common::*;

/// The slab's frame: a tilt, so that nothing is axis-aligned.
fn tilt() -> Rotation3<f64> {
    Rotation3::from_euler_angles(0.25, 0.15, 0.0)
}

/// Signed distance to the slab: the points within `c` of a flat disc of
/// radius `r` through the origin, tilted by [`tilt`].
fn slab_distance(p: &Point3<f64>, r: f64, c: f64) -> f64 {
    let q = tilt().inverse() * p.coords;
    let rho = (q.x * q.x + q.y * q.y).sqrt();
    ((rho - r).max(0.0).powi(2) + q.z * q.z).sqrt() - c
}

/// Depth across the slab: the coordinate along its normal.
fn depth(p: &Point3<f64>) -> f64 {
    (tilt().inverse() * p.coords).z
}

/// The test image's intensity: a linear profile across the slab.
fn intensity(p: &Point3<f64>) -> f64 {
    500.0 + 10.0 * depth(p)
}

/// A grid of `n^3` voxels of `v` mm centred on the origin.
fn grid(n: usize, v: f64) -> Matrix4<f64> {
    let mut a = Matrix4::identity();
    for k in 0..3 {
        a[(k, k)] = v;
        a[(k, 3)] = -v * (n as f64 - 1.0) / 2.0;
    }
    a
}

/// Writes an image of `n^3` voxels of `v` mm filled by `value`.
fn write_volume(
    path: &Path,
    n: usize,
    v: f64,
    frames: usize,
    value: impl Fn(&Point3<f64>, usize) -> f64,
) {
    let a = grid(n, v);
    let mut data = Vec::with_capacity(n * n * n * frames);
    for t in 0..frames {
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = a.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                    data.push(value(&p, t) as f32);
                }
            }
        }
    }
    let vol = Volume::new([n, n, n, frames], a, data).unwrap();
    write_image(path, &NiftiImage::new(vol)).unwrap();
}

/// A slab 2c thick and 2(r + c) wide voxelized at 3 mm (1 inside, 0
/// outside).
fn write_slab_mask(path: &Path, r: f64, c: f64) {
    let n = ((2.0 * (r + c) + 24.0) / 3.0).ceil() as usize;
    write_volume(path, n, 3.0, 1, |p, _| {
        if slab_distance(p, r, c) < 0.0 {
            1.0
        } else {
            0.0
        }
    });
}

fn report(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json exists");
    serde_json::from_str(&text).expect("report.json is JSON")
}

#[test]
fn a_mask_is_meshed_into_a_valid_mesh_that_keeps_its_volume() {
    let dir = tempfile::tempdir().unwrap();
    let mask = dir.path().join("slab.nii.gz");
    let (r, c) = (60.0, 12.0);
    write_slab_mask(&mask, r, c);
    let out = dir.path().join("slab.vtu");
    let o = unfold(&["mesh", &s(&mask), "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("tets") && text.contains("dihedral angles"),
        "{text}"
    );
    // valid for `unfold info --strict`
    let info = unfold(&["info", &s(&out), "--strict", "--json"]);
    assert!(info.status.success(), "{}", stderr(&info));
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["valid"], true, "{v}");
    // the analytic volume (Steiner) within 3 %
    let exact = 2.0 * std::f64::consts::PI * r * r * c
        + std::f64::consts::PI.powi(2) * r * c * c
        + 4.0 / 3.0 * std::f64::consts::PI * c.powi(3);
    let volume = v["volume_mm3"].as_f64().expect("volume in the info");
    assert!((volume / exact - 1.0).abs() < 0.03, "{volume} vs {exact}");
    let m = read_mesh(&out).unwrap();
    assert!(m.num_cells() > 1000);
    // --grade: fewer tets, still valid, the same volume (the boundary is
    // kept)
    let graded = dir.path().join("graded.vtu");
    let o = unfold(&["mesh", &s(&mask), "-o", &s(&graded), "--grade"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("graded:"), "{}", stdout(&o));
    let info = unfold(&["info", &s(&graded), "--strict", "--json"]);
    assert!(info.status.success(), "{}", stderr(&info));
    let g: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let gv = g["volume_mm3"].as_f64().unwrap();
    assert!((gv / volume - 1.0).abs() < 1e-9, "{gv} vs {volume}");
    let cells = read_mesh(&graded).unwrap().num_cells();
    assert!(
        cells < m.num_cells() * 3 / 4,
        "{cells} vs {}",
        m.num_cells()
    );
}

#[test]
fn several_components_keep_the_largest_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mask = dir.path().join("two.nii");
    write_volume(&mask, 40, 1.0, 1, |p, _| {
        let a = (p - Point3::new(-9.0, 0.0, 0.0)).norm() < 8.0;
        let b = (p - Point3::new(10.0, 0.0, 0.0)).norm() < 5.0;
        f64::from(u8::from(a || b))
    });
    let out = dir.path().join("two.vtu");
    let o = unfold(&["mesh", &s(&mask), "-o", &s(&out), "--size-mm", "1.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.starts_with("warning: ")
            && err.contains("2 connected components")
            && err.contains("--keep-all-components"),
        "{err}"
    );
    let one = read_mesh(&out).unwrap().num_cells();
    let o = unfold(&[
        "mesh",
        &s(&mask),
        "-o",
        &s(&out),
        "--size-mm",
        "1.5",
        "--keep-all-components",
    ]);
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));
    let both = read_mesh(&out).unwrap().num_cells();
    assert!(both > one, "{both} vs {one}");
}

/// The help offers as outputs only formats unfold can write (no Gmsh).
#[test]
fn help_offers_only_writable_output_formats() {
    let o = unfold(&["mesh", "--help"]);
    let help = stdout(&o);
    let line = help
        .lines()
        .find(|l| l.trim_start().starts_with("-o, --output"))
        .expect("an --output line");
    assert!(line.contains(".vtu") && !line.contains(".msh"), "{line}");
}

#[test]
fn bad_masks_and_flags_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("m.vtu");
    let empty = d.join("empty.nii");
    write_volume(&empty, 8, 1.0, 1, |_, _| 0.0);
    assert_one_line_error(
        &unfold(&["mesh", &s(&empty), "-o", &s(&out)]),
        "no voxel set",
    );

    // A label map: a ball of label 2 in a shell of label 5. Without a label
    // or threshold, refused naming its values; each label meshes alone.
    let labels = d.join("labels.nii.gz");
    write_volume(&labels, 24, 1.0, 1, |p, _| match p.coords.norm() {
        r if r < 5.0 => 2.0,
        r if r < 9.0 => 5.0,
        _ => 0.0,
    });
    let o = unfold(&["mesh", &s(&labels), "-o", &s(&out)]);
    assert_one_line_error(&o, "the mask holds 2 values besides 0 (2, 5)");
    assert!(
        stderr(&o).contains("(--label N: the voxels equal to N; --threshold T: those above T)"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("labels.nii.gz"), "{}", stderr(&o));
    let o = unfold(&["mesh", &s(&labels), "-o", &s(&out), "--label", "7"]);
    assert_one_line_error(&o, "no voxel of the mask holds the label 7; it holds 2, 5");
    let o = unfold(&[
        "mesh",
        &s(&labels),
        "-o",
        &s(&out),
        "--label",
        "1",
        "--threshold",
        "1",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("cannot be used with"),
        "{}",
        stderr(&o)
    );
    // the ball (4/3 pi 5^3 = 524 mm^3), the shell around it (2,530 mm^3)
    // and both above the threshold 1 (3,054 mm^3), meshed at 1 mm voxels
    let mut volumes = Vec::new();
    for flags in [["--label", "2"], ["--label", "5"], ["--threshold", "1"]] {
        let o = unfold(&["mesh", &s(&labels), "-o", &s(&out), flags[0], flags[1]]);
        assert!(o.status.success(), "{}", stderr(&o));
        let mesh = read_mesh(&out).unwrap().to_tet_mesh().unwrap();
        volumes.push(unfold::mesh::geometry::total_volume(&mesh));
    }
    for (got, want) in volumes.iter().zip([524.0, 2530.0, 3054.0]) {
        assert!((got / want - 1.0).abs() < 0.15, "{volumes:?}");
    }

    // 0 and 255 (or any one value besides 0) is a mask as it is
    let bytes = d.join("bytes.nii.gz");
    write_volume(&bytes, 24, 1.0, 1, |p, _| {
        if p.coords.norm() < 8.0 { 255.0 } else { 0.0 }
    });
    let o = unfold(&["mesh", &s(&bytes), "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));

    let series = d.join("series.nii");
    write_volume(&series, 8, 1.0, 2, |p, _| {
        f64::from(u8::from(p.coords.norm() < 3.0))
    });
    assert_one_line_error(&unfold(&["mesh", &s(&series), "-o", &s(&out)]), "3D image");

    for (flag, value, needle) in [
        ("--size-mm", "0", "--size-mm"),
        ("--smooth-voxels", "-1", "--smooth-voxels"),
        ("--dilate", "2", "--dilate"),
        ("--level", "1.5", "--level"),
        ("--threshold", "nan", "--threshold"),
        ("--label", "nan", "--label must be finite"),
        ("--label", "inf", "--label must be finite"),
    ] {
        let o = unfold(&["mesh", &s(&labels), "-o", &s(&out), flag, value]);
        assert_one_line_error(&o, needle);
    }
    assert_one_line_error(
        &unfold(&["mesh", &s(&labels), "-o", &s(&labels)]),
        "overwrite",
    );
    assert_one_line_error(
        &unfold(&["mesh", &s(&d.join("missing.nii")), "-o", &s(&out)]),
        "missing.nii",
    );
}

/// `placenta --seg` grades the mesh by default (near the published meshes'
/// size); `--dense` meshes the mask uniformly, with more tets and none
/// collapsed, and the report says which.
#[test]
fn placenta_from_a_segmentation_is_graded_unless_dense() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mask = d.join("seg.nii.gz");
    write_slab_mask(&mask, 45.0, 10.0);
    let mask_s = s(&mask);
    let mut tets = Vec::new();
    for (name, extra) in [("graded", &[][..]), ("dense", &["--dense"][..])] {
        let out = d.join(name);
        let out_s = s(&out);
        let mut args = vec!["placenta", "--seg", &mask_s, "-o", &out_s, "--no-figures"];
        args.extend_from_slice(&["--max-iterations", "3"]);
        args.extend_from_slice(extra);
        let o = unfold(&args);
        assert!(matches!(o.status.code(), Some(0 | 3)), "{}", stderr(&o));
        let seg = report(&out)["segmentation"].clone();
        let collapses = seg["graded_collapses"].as_u64().unwrap();
        assert_eq!(seg["graded"], name == "graded", "{seg}");
        assert_eq!(collapses > 0, name == "graded", "{seg}");
        // The default cube side puts `SEG_CUBES` = 5,000 lattice cubes in
        // the mask's volume (here 175 cm^3: 3.27 mm, just coarser than the
        // voxels) and says so; --dense meshes at the voxel size.
        let size = seg["size_mm"].as_f64().unwrap();
        if name == "graded" {
            assert_eq!(seg["size_from"], "mask_volume", "{seg}");
            let voxels = seg["mask_voxels"].as_f64().unwrap();
            let expected = (voxels * 27.0 / 5000.0).cbrt();
            assert!(size > 3.0, "{seg}");
            assert!(
                (size - expected).abs() < 1e-9 * expected,
                "{size} vs {expected}"
            );
            assert!(
                stdout(&o).contains("cube side from the mask's volume"),
                "{}",
                stdout(&o)
            );
        } else {
            assert_eq!(seg["size_from"], "voxel", "{seg}");
            assert_eq!(size, 3.0, "{seg}");
        }
        tets.push(seg["quality"]["tets"].as_u64().unwrap());
    }
    assert!(
        tets[0] < tets[1],
        "graded {} tets, dense {}",
        tets[0],
        tets[1]
    );
    let o = unfold(&[
        "placenta",
        "--seg",
        &s(&mask),
        "-o",
        &s(&d.join("x")),
        "--dense",
        "--grade",
    ]);
    assert_one_line_error(&o, "--dense");
}

/// The published pipeline from images: a voxelized slab and an image whose
/// intensity grows linearly across it. In the template the slab lies
/// between the planes `z = -h` and `z = h`, so the flattened image must
/// grow linearly with `z` (one way or the other: which side is fetal is the
/// parcellation's call) and not with `x` or `y`.
#[test]
fn placenta_from_a_segmentation_flattens_the_image_as_expected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mask = d.join("seg.nii.gz");
    let (r, c) = (45.0, 10.0);
    write_slab_mask(&mask, r, c);
    let bold = d.join("bold.nii.gz");
    let n = ((2.0 * (r + c) + 30.0) / 3.0).ceil() as usize;
    write_volume(&bold, n, 3.0, 2, |p, t| intensity(p) + 50.0 * t as f64);
    let out = d.join("out");
    let o = unfold(&[
        "placenta",
        "--seg",
        &s(&mask),
        "--image",
        &s(&bold),
        "-o",
        &s(&out),
        "--size-mm",
        "6",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stderr.is_empty(), "{}", stderr(&o));
    let rep = report(&out);
    let seg = &rep["segmentation"];
    assert_eq!(seg["mask"], s(&mask));
    assert_eq!(seg["size_mm"], 6.0);
    assert_eq!(seg["size_from"], "given");
    assert!(
        seg["quality"]["min_dihedral_deg"].as_f64().unwrap() >= 10.0,
        "{seg}"
    );
    // the half thickness from the distance transform: within a voxel of c
    let h = seg["half_thickness_mm"].as_f64().unwrap();
    assert!((h - c).abs() <= 3.0, "{h}");
    assert_eq!(rep["estimates"]["thickness_from"], "segmentation");
    assert_eq!(rep["estimates"]["half_thickness_mm"].as_f64(), Some(h));
    assert_eq!(rep["inverted_tets"], 0);
    assert!(out.join("mesh.vtu").exists());
    let mesh = read_mesh(out.join("mesh.vtu")).unwrap();
    let original = read_mesh(out.join("original.vtu")).unwrap();
    assert_eq!(mesh.positions, original.positions);

    let flat = read_image(out.join("bold_flat.nii.gz")).unwrap();
    let v = &flat.volume;
    let dims = v.dims();
    assert_eq!(dims[3], 2);
    let len = v.frame_len();
    // least squares fit of value = a + b x + c y + e z over the voxels inside
    let mut rows = Vec::new();
    for idx in 0..len {
        let val = f64::from(v.data()[idx]);
        if val == 0.0 {
            continue;
        }
        let (i, j, k) = (
            idx % dims[0],
            (idx / dims[0]) % dims[1],
            idx / (dims[0] * dims[1]),
        );
        let p = v.voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
        rows.push((p, val, f64::from(v.data()[len + idx])));
    }
    assert!(rows.len() > 500, "{}", rows.len());
    let mut ata = unfold::mesh::nalgebra::Matrix4::<f64>::zeros();
    let mut atb = unfold::mesh::nalgebra::Vector4::<f64>::zeros();
    for (p, val, _) in &rows {
        let x = unfold::mesh::nalgebra::Vector4::new(1.0, p.x, p.y, p.z);
        ata += x * x.transpose();
        atb += x * *val;
    }
    let coef = ata.try_inverse().unwrap() * atb;
    let (gx, gy, gz) = (coef[1], coef[2], coef[3]);
    // across the slab: 10 per mm (up to the map's stretch); along it: flat
    assert!(gz.abs() > 8.0 && gz.abs() < 12.5, "slope across {gz}");
    assert!(gx.abs() < 0.5 && gy.abs() < 0.5, "slopes along {gx}, {gy}");
    let resid = rows
        .iter()
        .map(|(p, val, _)| (val - (coef[0] + gx * p.x + gy * p.y + gz * p.z)).powi(2))
        .sum::<f64>()
        / rows.len() as f64;
    assert!(resid.sqrt() < 15.0, "rms residual {}", resid.sqrt());
    // the second frame is the first plus 50
    for (_, a, b) in &rows {
        assert!((b - a - 50.0).abs() < 1e-2, "{a} {b}");
    }
    println!(
        "{} tets; flattened image: {} voxels, slopes {gx:.3} {gy:.3} {gz:.3} per mm, rms residual {:.3}",
        seg["quality"]["tets"],
        rows.len(),
        resid.sqrt()
    );
}

#[test]
fn placenta_segmentation_flags_need_seg_and_exclude_a_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mask = d.join("seg.nii");
    write_volume(&mask, 8, 3.0, 1, |_, _| 0.0);
    let out = d.join("out");
    for flag in [
        &["--size-mm", "2"][..],
        &["--grade"],
        &["--dense"],
        &["--dilate", "1"],
        &["--label", "2"],
    ] {
        let mut args = vec!["placenta", "x.vtu", "-o"];
        let o = s(&out);
        args.push(&o);
        args.extend_from_slice(flag);
        assert_one_line_error(&unfold(&args), "apply to --seg");
    }
    let o = unfold(&["placenta", "x.vtu", "--seg", &s(&mask), "-o", &s(&out)]);
    assert_one_line_error(&o, "--seg");
    assert_one_line_error(&unfold(&["placenta", "-o", &s(&out)]), "--seg");
    assert_one_line_error(
        &unfold(&["placenta", "--seg", &s(&mask), "-o", &s(&out)]),
        "no voxel set",
    );
}

/// Smoothing so wide that its working grid cannot be held is refused with
/// the grid's size and what to change, before anything is allocated (it
/// used to overflow the allocator or abort).
#[test]
fn a_huge_smoothing_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let mask = dir.path().join("box.nii");
    let mut data = vec![0.0f32; 12 * 12 * 12];
    for k in 4..8 {
        for j in 4..8 {
            for i in 4..8 {
                data[i + 12 * (j + 12 * k)] = 1.0;
            }
        }
    }
    let vol = unfold::mesh::Volume::new(
        [12, 12, 12, 1],
        unfold::mesh::nalgebra::Matrix4::identity(),
        data,
    )
    .unwrap();
    unfold::io::write_image(&mask, &unfold::io::NiftiImage::new(vol)).unwrap();
    for sigma in ["1e6", "1e4", "200"] {
        let out = dir.path().join(format!("m{sigma}.vtu"));
        let o = unfold(&[
            "mesh",
            &mask.display().to_string(),
            "-o",
            &out.display().to_string(),
            "--smooth-voxels",
            sigma,
        ]);
        assert_one_line_error(&o, "lower --smooth-voxels");
        assert!(!out.exists());
    }
}
