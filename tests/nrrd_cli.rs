//! NRRD images through the binary: `unfold convert` between NIfTI and NRRD
//! (both ways and NRRD -> NRRD) keeps values, data type and affine; `unfold
//! info` reads NRRD; `unfold placenta --seg MASK.seg.nrrd --image IMG.nrrd`
//! (a Slicer-style LPS header built by hand) gives the same outputs as the
//! NIfTI files; `unfold mesh MASK.nrrd` works; bad NRRD files are one-line
//! errors.

use std::path::Path;
use unfold::io::{Datatype, NiftiImage, read_image, read_mesh, write_image};
use unfold::mesh::Volume;
use unfold::mesh::nalgebra::{Matrix4, Point3, Rotation3, Vector3};

mod common;
use common::*;

/// A rotated, anisotropic, translated affine (nothing axis-aligned).
fn oblique() -> Matrix4<f64> {
    let r = Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5));
    let s = [0.7, 1.1, 2.5];
    let mut a = Matrix4::identity();
    for i in 0..3 {
        for j in 0..3 {
            a[(i, j)] = r[(i, j)] * s[j];
        }
    }
    a[(0, 3)] = -12.5;
    a[(1, 3)] = 40.25;
    a[(2, 3)] = 7.0;
    a
}

fn image(dims: [usize; 4], datatype: Datatype) -> NiftiImage {
    let n: usize = dims.iter().product();
    let data = (0..n).map(|i| ((i * 37) % 251) as f32 - 100.0).collect();
    NiftiImage::new(Volume::new(dims, oblique(), data).unwrap()).with_datatype(datatype)
}

#[test]
fn convert_nifti_to_nrrd_and_back_keeps_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (dims, dt) in [
        ([4, 3, 5, 1], Datatype::Int16),
        ([3, 4, 2, 3], Datatype::Float32),
        ([2, 2, 2, 1], Datatype::Float64),
    ] {
        let src = d.join("a.nii.gz");
        write_image(&src, &image(dims, dt)).unwrap();
        let orig = read_image(&src).unwrap();
        let nrrd = d.join("a.nrrd");
        let o = unfold(&["convert", &s(&src), &s(&nrrd)]);
        assert_ok(&o);
        assert!(stdout(&o).contains(dt.name()), "{}", stdout(&o));
        let again = d.join("b.nrrd");
        assert_ok(&unfold(&["convert", &s(&nrrd), &s(&again)]));
        let back = d.join("b.nii");
        assert_ok(&unfold(&["convert", &s(&again), &s(&back)]));
        for p in [&nrrd, &again, &back] {
            let img = read_image(p).unwrap();
            assert_eq!(img.datatype, dt, "{}", p.display());
            assert_eq!(img.volume, orig.volume, "{}", p.display());
        }
        // The NRRD file is gzip-encoded with an LPS header.
        let bytes = std::fs::read(&nrrd).unwrap();
        let end = bytes.windows(2).position(|w| w == b"\n\n").unwrap();
        let text = String::from_utf8_lossy(&bytes[..=end]);
        assert!(text.starts_with("NRRD0004\n"), "{text}");
        assert!(text.contains("space: left-posterior-superior\n"), "{text}");
        assert!(text.contains("encoding: gzip\n"), "{text}");
    }
}

#[test]
fn info_shows_a_nrrd_header() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("img.nrrd");
    write_image(&p, &image([4, 3, 5, 1], Datatype::Uint8)).unwrap();
    let o = unfold(&["info", &s(&p)]);
    assert_ok(&o);
    let out = stdout(&o);
    assert!(out.contains("dims: [4, 3, 5, 1]"), "{out}");
    assert!(out.contains("data type: uint8"), "{out}");
    assert!(out.contains("affine (spacedirections)"), "{out}");
    let o = unfold(&["info", &s(&p), "--json"]);
    assert_ok(&o);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let a = oblique();
    for r in 0..3 {
        for c in 0..4 {
            // serde_json parses decimals to within an ulp or so.
            let x = v["affine"][r][c].as_f64().unwrap();
            assert!((x - a[(r, c)]).abs() <= 1e-12, "{r},{c}: {x}");
        }
    }
}

/// The slab's frame: a tilt, so that nothing is axis-aligned.
fn tilt() -> Rotation3<f64> {
    Rotation3::from_euler_angles(0.25, 0.15, 0.0)
}

/// A grid of `n^3` voxels of `v` mm centred on the origin (RAS affine).
fn grid(n: usize, v: f64) -> Matrix4<f64> {
    let mut a = Matrix4::identity();
    for k in 0..3 {
        a[(k, k)] = v;
        a[(k, 3)] = -v * (n as f64 - 1.0) / 2.0;
    }
    a
}

/// Values on the `n^3` grid of [`grid`] (x fastest), `frames` frames.
fn values(n: usize, v: f64, frames: usize, f: impl Fn(&Point3<f64>, usize) -> f64) -> Vec<f32> {
    let a = grid(n, v);
    let mut data = Vec::with_capacity(n * n * n * frames);
    for t in 0..frames {
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = a.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                    data.push(f(&p, t) as f32);
                }
            }
        }
    }
    data
}

/// A tilted slab 2c thick and 2(r + c) wide at 3 mm: 1 inside, 0 outside.
fn slab_mask(r: f64, c: f64) -> (usize, Vec<f32>) {
    let n = ((2.0 * (r + c) + 24.0) / 3.0).ceil() as usize;
    let data = values(n, 3.0, 1, |p, _| {
        let q = tilt().inverse() * p.coords;
        let rho = (q.x * q.x + q.y * q.y).sqrt();
        let d = ((rho - r).max(0.0).powi(2) + q.z * q.z).sqrt() - c;
        if d < 0.0 { 1.0 } else { 0.0 }
    });
    (n, data)
}

/// The mask as Slicer writes a one-layer `.seg.nrrd`: LPS directions and
/// origin (the RAS grid with x and y negated), uchar, segment keys; raw
/// data (Slicer compresses by default; gzip is covered by the other tests).
fn write_slicer_seg(path: &Path, n: usize, data: &[f32]) {
    let h = 3.0 * (n as f64 - 1.0) / 2.0;
    let header = format!(
        "NRRD0004\n# Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n\
         type: unsigned char\ndimension: 3\nspace: left-posterior-superior\n\
         sizes: {n} {n} {n}\nspace directions: (-3,0,0) (0,-3,0) (0,0,3)\n\
         kinds: domain domain domain\nencoding: raw\nspace origin: ({h},{h},{})\n\
         Segment0_Color:=0.5 0.7 0.3\nSegment0_ID:=Segment_1\nSegment0_LabelValue:=1\n\
         Segment0_Layer:=0\nSegment0_Name:=placenta\n\n",
        -h
    );
    let raw: Vec<u8> = data.iter().map(|&x| x as u8).collect();
    let mut bytes = header.into_bytes();
    bytes.extend_from_slice(&raw);
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn placenta_from_a_slicer_segmentation_matches_the_nifti_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (r, c) = (30.0, 8.0);
    let (n, mask) = slab_mask(r, c);
    let mask_nii = d.join("mask.nii.gz");
    let vol = Volume::new([n, n, n, 1], grid(n, 3.0), mask.clone()).unwrap();
    write_image(
        &mask_nii,
        &NiftiImage::new(vol).with_datatype(Datatype::Uint8),
    )
    .unwrap();
    let mask_seg = d.join("mask.seg.nrrd");
    write_slicer_seg(&mask_seg, n, &mask);
    // The same mask either way.
    assert_eq!(
        read_image(&mask_seg).unwrap().volume,
        read_image(&mask_nii).unwrap().volume
    );

    let m = n + 2;
    let img = values(m, 3.0, 2, |p, t| {
        500.0 + 10.0 * (tilt().inverse() * p.coords).z + 50.0 * t as f64
    });
    let img_nii = d.join("bold.nii.gz");
    write_image(
        &img_nii,
        &NiftiImage::new(Volume::new([m, m, m, 2], grid(m, 3.0), img).unwrap()),
    )
    .unwrap();
    let img_nrrd = d.join("bold.nrrd");
    assert_ok(&unfold(&["convert", &s(&img_nii), &s(&img_nrrd)]));

    let run = |seg: &Path, image: &Path, out: &Path| {
        let o = unfold(&[
            "placenta",
            "--seg",
            &s(seg),
            "--image",
            &s(image),
            "-o",
            &s(out),
            "--size-mm",
            "6",
            "--no-figures",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let (out_nii, out_nrrd) = (d.join("nii"), d.join("nrrd"));
    run(&mask_nii, &img_nii, &out_nii);
    run(&mask_seg, &img_nrrd, &out_nrrd);
    for name in ["mesh.vtu", "flattened.vtu"] {
        let a = read_mesh(out_nii.join(name)).unwrap();
        let b = read_mesh(out_nrrd.join(name)).unwrap();
        assert!(a.num_cells() > 100, "{name}: {} cells", a.num_cells());
        assert_eq!(a.positions, b.positions, "{name}");
        assert_eq!(a.connectivity, b.connectivity, "{name}");
    }
    // `bold.nrrd` is written as `bold_flat.nii.gz`, as `bold.nii.gz` is.
    let a = read_image(out_nii.join("bold_flat.nii.gz")).unwrap();
    let b = read_image(out_nrrd.join("bold_flat.nii.gz")).unwrap();
    assert_eq!(a.volume, b.volume);
    assert_eq!(a.volume.dims()[3], 2);
    assert!(a.volume.data().iter().filter(|&&x| x > 0.0).count() > 100);
}

#[test]
fn mesh_reads_a_nrrd_mask() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (n, mask) = slab_mask(20.0, 7.0);
    let vol = Volume::new([n, n, n, 1], grid(n, 3.0), mask).unwrap();
    let nii = d.join("m.nii.gz");
    let nrrd = d.join("m.nrrd");
    write_image(&nii, &NiftiImage::new(vol.clone())).unwrap();
    write_image(&nrrd, &NiftiImage::new(vol)).unwrap();
    let (a, b) = (d.join("a.vtu"), d.join("b.vtu"));
    for (mask, out) in [(&nii, &a), (&nrrd, &b)] {
        let o = unfold(&["mesh", &s(mask), "-o", &s(out), "--size-mm", "6"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let (a, b) = (read_mesh(&a).unwrap(), read_mesh(&b).unwrap());
    assert!(a.num_cells() > 0);
    assert_eq!(a.positions, b.positions);
}

#[test]
fn bad_nrrd_files_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = d.join("good.nrrd");
    write_image(&good, &image([6, 5, 4, 1], Datatype::Float32)).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let out = d.join("out.nii.gz");

    // Truncated gzip data.
    let cut = d.join("cut.nrrd");
    std::fs::write(&cut, &bytes[..bytes.len() - 40]).unwrap();
    assert_one_line_error(&unfold(&["convert", &s(&cut), &s(&out)]), "cut.nrrd");
    assert_one_line_error(&unfold(&["info", &s(&cut)]), "cut.nrrd");
    // Hostile sizes (more than the compressed data can hold).
    let text = String::from_utf8_lossy(&bytes).replace("sizes: 6 5 4", "sizes: 32767 32767 9");
    let huge = d.join("huge.nrrd");
    std::fs::write(&huge, text.as_bytes()).unwrap();
    let o = unfold(&["mesh", &s(&huge), "-o", &s(&d.join("m.vtu"))]);
    assert_one_line_error(&o, "huge.nrrd");
    // A header that never ends, with a long binary line.
    let endless = d.join("endless.nrrd");
    let mut b = b"NRRD0004\ntype: float\n".to_vec();
    b.extend(std::iter::repeat_n(0x41u8, 2 << 20));
    std::fs::write(&endless, &b).unwrap();
    assert_one_line_error(&unfold(&["info", &s(&endless)]), "longer than");
    // A detached header whose data file is missing.
    let nhdr = d.join("x.nhdr");
    std::fs::write(
        &nhdr,
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: x.raw\n",
    )
    .unwrap();
    assert_one_line_error(&unfold(&["convert", &s(&nhdr), &s(&out)]), "x.raw");
    // Writing .nhdr is refused with what to do.
    assert_one_line_error(
        &unfold(&["convert", &s(&good), &s(&d.join("o.nhdr"))]),
        "write .nrrd",
    );
    // A multi-layer Slicer segmentation, as --seg.
    let layered = d.join("layers.seg.nrrd");
    let mut b = b"NRRD0004\ntype: uchar\ndimension: 4\nsizes: 2 2 2 2\nencoding: raw\n\
                  space: RAS\nspace directions: none (1,0,0) (0,1,0) (0,0,1)\n\
                  kinds: list domain domain domain\nSegment0_Layer:=0\nSegment1_Layer:=1\n\n"
        .to_vec();
    b.extend_from_slice(&[1u8; 16]);
    std::fs::write(&layered, &b).unwrap();
    let o = unfold(&["placenta", "--seg", &s(&layered), "-o", &s(&d.join("p"))]);
    assert_one_line_error(&o, "label map");
    // An --image name that is not an image.
    let o = unfold(&[
        "placenta",
        "--seg",
        &s(&good),
        "--image",
        "x.png",
        "-o",
        &s(&d.join("p")),
    ]);
    assert_one_line_error(&o, ".seg.nrrd");
}
