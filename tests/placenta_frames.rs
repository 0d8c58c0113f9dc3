//! Scanner frames and the canonical template frame of `unfold placenta`,
//! through the binary: a mesh mirrored in x and y (LPS read as RAS) fails
//! the foreground check naming `--mesh-frame lps` and passes with it (or
//! with Slicer's `SPACE=LPS` header and `--mesh-frame auto`), giving the
//! same flattened image; five rigid poses of one placenta give the same
//! template coordinates; `--grid` gives one grid for every pose.

use std::path::{Path, PathBuf};
use unfold::io::{NiftiImage, WriteOptions, read_image, read_mesh, write_image, write_mesh};
use unfold::mesh::nalgebra::{Matrix4, Point3, Rotation3, Vector3};
use unfold::mesh::shapes::{PlacentaParams, Pose, placenta_slab};
use unfold::mesh::spatial::TetLocator;
use unfold::mesh::{CellMesh, TetMesh, Volume};

mod common;
use common::*;

/// The demo's placenta shape, coarse, where the demo puts it in the scanner
/// (away from the origin).
fn placenta() -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial: 6,
        cells_through: 2,
        pose: Pose::new([0.0, 0.0, 20.0], [70.0, 40.0, 10.0]),
        ..PlacentaParams::default()
    })
    .expect("slab")
    .mesh
}

fn intensity(p: &Point3<f64>) -> f64 {
    200.0 + 40.0 * (p.x / 15.0).sin() + 30.0 * (p.y / 20.0).cos() + 2.0 * p.z
}

/// A 3 mm MRI of `mesh` (smooth values inside, 20 outside), axis-aligned,
/// covering it with a 12 mm margin.
fn mri(mesh: &TetMesh) -> NiftiImage {
    let loc = TetLocator::new(mesh);
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for p in &mesh.positions {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    lo -= Vector3::repeat(12.0);
    hi += Vector3::repeat(12.0);
    let s = 3.0;
    let dims: [usize; 3] = std::array::from_fn(|a| ((hi[a] - lo[a]) / s).ceil() as usize + 1);
    let mut affine = Matrix4::identity();
    for a in 0..3 {
        affine[(a, a)] = s;
        affine[(a, 3)] = lo[a];
    }
    let mut data = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                let v = if loc.locate(&p).is_some() {
                    intensity(&p)
                } else {
                    20.0
                };
                data.push(v as f32);
            }
        }
    }
    NiftiImage::new(Volume::new([dims[0], dims[1], dims[2], 1], affine, data).unwrap())
}

fn write_tets(path: &Path, mesh: &TetMesh) {
    write_mesh(path, &CellMesh::from(mesh), &WriteOptions::default()).expect("mesh written");
}

fn moved(mesh: &TetMesh, f: impl Fn(&Point3<f64>) -> Point3<f64>) -> TetMesh {
    TetMesh::new(mesh.positions.iter().map(f).collect(), mesh.tets.clone())
}

fn lps(p: &Point3<f64>) -> Point3<f64> {
    Point3::new(-p.x, -p.y, p.z)
}

fn flattened(dir: &Path) -> Vec<Point3<f64>> {
    read_mesh(dir.join("flattened.vtu")).unwrap().positions
}

fn run(args: &[&str]) -> std::process::Output {
    let mut all = vec!["placenta"];
    all.extend_from_slice(args);
    all.push("--no-figures");
    unfold(&all)
}

/// Largest difference of two images' values, and the values' range.
fn compare(a: &NiftiImage, b: &NiftiImage) -> (f64, f64) {
    assert_eq!(a.volume.dims(), b.volume.dims());
    assert_eq!(a.volume.affine(), b.volume.affine());
    let mut diff = 0.0f64;
    let mut range = 0.0f64;
    for (x, y) in a.volume.data().iter().zip(b.volume.data()) {
        diff = diff.max(f64::from((x - y).abs()));
        range = range.max(f64::from(x.abs()));
    }
    (diff, range)
}

#[test]
fn a_mesh_in_lps_fails_clearly_and_passes_with_mesh_frame_lps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = placenta();
    let img = d.join("mri.nii.gz");
    write_image(&img, &mri(&mesh)).unwrap();
    let ras = d.join("ras.vtu");
    write_tets(&ras, &mesh);
    let mirrored = d.join("lps.vtu");
    write_tets(&mirrored, &moved(&mesh, lps));

    let out_ras = d.join("out_ras");
    assert_ok(&run(&[&s(&ras), "-o", &s(&out_ras), "--image", &s(&img)]));

    // Read as RAS, the mirrored mesh misses the placenta: a one-line error
    // naming the fractions and the fix, and nothing written.
    let out_bad = d.join("out_bad");
    let o = run(&[&s(&mirrored), "-o", &s(&out_bad), "--image", &s(&img)]);
    assert_one_line_error(&o, "--mesh-frame lps");
    let e = stderr(&o);
    assert!(
        e.contains("mirrored in x and y") && e.contains("LPS"),
        "{e}"
    );
    assert!(!out_bad.join("report.json").exists());
    let o = run(&[
        &s(&mirrored),
        "-o",
        &s(&out_bad),
        "--image",
        &s(&img),
        "--mesh-frame",
        "ras",
    ]);
    assert_one_line_error(&o, "--mesh-frame lps");

    // Declared LPS: the same flattened image as the RAS run.
    let out_lps = d.join("out_lps");
    let o = run(&[
        &s(&mirrored),
        "-o",
        &s(&out_lps),
        "--image",
        &s(&img),
        "--mesh-frame",
        "lps",
    ]);
    assert_ok(&o);
    let a = read_image(out_ras.join("mri_flat.nii.gz")).unwrap();
    let b = read_image(out_lps.join("mri_flat.nii.gz")).unwrap();
    let (diff, range) = compare(&a, &b);
    assert!(diff <= 1e-3 * range, "{diff} of {range}");
    // The original is written in RAS: the input's coordinates, unmirrored.
    let orig = read_mesh(out_lps.join("original.vtu")).unwrap().positions;
    for (p, q) in orig.iter().zip(&mesh.positions) {
        assert!((p - q).norm() < 1e-9, "{p} vs {q}");
    }

    // The same mirrored mesh with Slicer's header: auto reads it as LPS.
    let vtk = d.join("slicer.vtk");
    write_mesh(
        &vtk,
        &CellMesh::from(&moved(&mesh, lps)),
        &WriteOptions::default(),
    )
    .unwrap();
    let text = std::fs::read(&vtk).unwrap();
    let first = text.iter().position(|&b| b == b'\n').unwrap();
    let second = first + 1 + text[first + 1..].iter().position(|&b| b == b'\n').unwrap();
    let mut slicer = text[..=first].to_vec();
    slicer.extend_from_slice(b"3D Slicer output. SPACE=LPS");
    slicer.extend_from_slice(&text[second..]);
    std::fs::write(&vtk, slicer).unwrap();
    let out_auto = d.join("out_auto");
    assert_ok(&run(&[
        &s(&vtk),
        "-o",
        &s(&out_auto),
        "--image",
        &s(&img),
        "--mesh-frame",
        "auto",
    ]));
    let c = read_image(out_auto.join("mri_flat.nii.gz")).unwrap();
    let (diff, range) = compare(&a, &c);
    assert!(diff <= 1e-3 * range, "{diff} of {range}");

    // The escape hatch: no check, the (wrong) run goes through.
    let out_unchecked = d.join("out_unchecked");
    assert_ok(&run(&[
        &s(&mirrored),
        "-o",
        &s(&out_unchecked),
        "--image",
        &s(&img),
        "--no-frame-check",
    ]));

    // Bad values of the flags are one-line errors.
    let o = run(&[&s(&ras), "-o", &s(&out_bad), "--mesh-frame", "xyz"]);
    assert!(!o.status.success());
    let o = run(&[
        &s(&ras),
        "-o",
        &s(&out_bad),
        "--image",
        &s(&img),
        "--spacing-mm",
        "2",
        "--grid",
        "10,0,-5,5,-5,5",
    ]);
    assert_one_line_error(&o, "--grid");
    let o = run(&[&s(&ras), "-o", &s(&out_bad), "--grid", "0,1,0,1,0,1"]);
    assert!(!o.status.success(), "--grid needs --spacing-mm");
}

/// A rigid pose from a seed: rotation about a random axis, translation up
/// to 60 mm.
fn pose(seed: u64) -> (Rotation3<f64>, Vector3<f64>) {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let axis = Vector3::new(next(), next(), next());
    let angle = std::f64::consts::PI * next();
    let t = Vector3::new(60.0 * next(), 60.0 * next(), 60.0 * next());
    (
        Rotation3::from_axis_angle(&unfold::mesh::nalgebra::Unit::new_normalize(axis), angle),
        t,
    )
}

/// The image moved by the pose: the same voxels, the affine `P A`.
fn moved_image(img: &NiftiImage, r: &Rotation3<f64>, t: &Vector3<f64>) -> NiftiImage {
    let mut p = Matrix4::identity();
    p.fixed_view_mut::<3, 3>(0, 0).copy_from(r.matrix());
    p.fixed_view_mut::<3, 1>(0, 3).copy_from(t);
    let v = &img.volume;
    NiftiImage::new(Volume::new(v.dims(), p * v.affine(), v.data().to_vec()).unwrap())
}

#[test]
fn five_poses_give_the_same_template_coordinates_and_grid() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = placenta();
    let img = mri(&mesh);
    let mut runs: Vec<PathBuf> = Vec::new();
    for k in 0..5u64 {
        let (r, t) = if k == 0 {
            (Rotation3::identity(), Vector3::zeros())
        } else {
            pose(k)
        };
        let m = moved(&mesh, |p| r * p + t);
        let mp = d.join(format!("pose{k}.vtu"));
        write_tets(&mp, &m);
        let ip = d.join(format!("mri{k}.nii.gz"));
        write_image(&ip, &moved_image(&img, &r, &t)).unwrap();
        let out = d.join(format!("out{k}"));
        let o = run(&[
            &s(&mp),
            "-o",
            &s(&out),
            "--image",
            &s(&ip),
            "--spacing-mm",
            "3",
            "--grid",
            "-110,110,-90,90,-20,20",
            "--mesh-frame",
            "ras",
        ]);
        assert_ok(&o);
        runs.push(out);
    }
    let base = flattened(&runs[0]);
    let base_img = read_image(runs[0].join(format!("mri{}_flat.nii.gz", 0))).unwrap();
    for (k, out) in runs.iter().enumerate().skip(1) {
        let x = flattened(out);
        let worst = base
            .iter()
            .zip(&x)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        println!("pose {k}: largest vertex distance {worst:.2e} mm");
        assert!(worst < 0.5, "pose {k}: {worst} mm");
        // One grid for every pose; nearly the same values.
        let flat = read_image(out.join(format!("mri{k}_flat.nii.gz"))).unwrap();
        let (diff, range) = compare(&base_img, &flat);
        println!("pose {k}: largest voxel difference {diff:.3} of {range:.1}");
        assert!(diff <= 0.05 * range, "pose {k}: {diff} of {range}");
    }
    // The canonical frame: centred on the mid-surface, x the major axis.
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(runs[0].join("report.json")).unwrap())
            .unwrap();
    assert_eq!(r["canonical_frame"]["symmetry"], "in-plane");
    assert_eq!(r["images"][0]["vertices_outside_grid"], 0);
    let (mut sx, mut sy) = (0.0, 0.0);
    for p in &base {
        sx += p.x * p.x;
        sy += p.y * p.y;
    }
    assert!(sx > sy, "{sx} {sy}");
}

#[test]
fn a_grid_smaller_than_the_placenta_is_counted_and_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = placenta();
    let mp = d.join("p.vtu");
    write_tets(&mp, &mesh);
    let ip = d.join("mri.nii.gz");
    write_image(&ip, &mri(&mesh)).unwrap();
    let out = d.join("out");
    let o = run(&[
        &s(&mp),
        "-o",
        &s(&out),
        "--image",
        &s(&ip),
        "--spacing-mm",
        "4",
        "--grid",
        "-40,40,-30,30,-20,20",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("outside the --grid box"),
        "{}",
        stderr(&o)
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let outside = r["images"][0]["vertices_outside_grid"].as_u64().unwrap();
    assert!(outside > 0);
    let img = read_image(out.join("mri_flat.nii.gz")).unwrap();
    assert_eq!(&img.volume.dims()[..3], &[21, 16, 11]);
    assert_eq!(img.volume.affine()[(0, 3)], -40.0);
    assert_eq!(img.volume.affine()[(1, 1)], 4.0);
}

/// A placenta smaller than the demo's (so a 2.5 mm mask meshes into a few
/// thousand tets) with a clear major axis (120 by 80 mm) and a strong lobe
/// (a distinct third moment), in its own frame.
fn seg_shape() -> TetMesh {
    placenta_slab(&PlacentaParams {
        length: 120.0,
        width: 80.0,
        thickness_centre: 20.0,
        thickness_rim: 10.0,
        bend_radius: 150.0,
        lobe: 0.3,
        cells_radial: 10,
        cells_through: 3,
        ..PlacentaParams::default()
    })
    .expect("slab")
    .mesh
}

/// A binary mask (0 and 1) of `mesh` on an axis-aligned grid of `voxel`
/// mm covering it with a margin of three voxels.
fn mask_of(mesh: &TetMesh, voxel: f64) -> NiftiImage {
    let loc = TetLocator::new(mesh);
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for p in &mesh.positions {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    lo -= Vector3::repeat(3.0 * voxel);
    hi += Vector3::repeat(3.0 * voxel);
    let dims: [usize; 3] = std::array::from_fn(|a| ((hi[a] - lo[a]) / voxel).ceil() as usize + 1);
    let mut affine = Matrix4::identity();
    for a in 0..3 {
        affine[(a, a)] = voxel;
        affine[(a, 3)] = lo[a];
    }
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                data.push(if loc.locate(&p).is_some() { 1.0 } else { 0.0 });
            }
        }
    }
    NiftiImage::new(Volume::new([dims[0], dims[1], dims[2], 1], affine, data).unwrap())
}

/// The template coordinates of the world point `p` in the run written to
/// `dir`: located in `original.vtu`, mapped with the same barycentric
/// coordinates through `flattened.vtu`.
struct TemplateMap {
    locator: TetLocator,
    tets: Vec<[u32; 4]>,
    flat: Vec<Point3<f64>>,
}

impl TemplateMap {
    fn new(dir: &Path) -> TemplateMap {
        let original = read_mesh(dir.join("original.vtu"))
            .unwrap()
            .volume_tets()
            .unwrap();
        let flat = flattened(dir);
        assert_eq!(flat.len(), original.positions.len());
        TemplateMap {
            locator: TetLocator::new(&original),
            tets: original.tets.clone(),
            flat,
        }
    }

    fn map(&self, p: &Point3<f64>) -> Option<Point3<f64>> {
        let (t, b) = self.locator.locate(p)?;
        let v = self.tets[t];
        Some(Point3::from((0..4).fold(Vector3::zeros(), |a, i| {
            a + b[i] * self.flat[v[i] as usize].coords
        })))
    }
}

#[test]
fn five_poses_of_a_mask_give_the_same_template_coordinates_and_grid() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shape = seg_shape();
    let mask = mask_of(&shape, 2.5);
    // The material points: the centroids of the shape's tets (its own
    // frame).
    let points: Vec<Point3<f64>> = (0..shape.num_tets())
        .map(|t| {
            let p = shape.tet_points(t);
            Point3::from((p[0].coords + p[1].coords + p[2].coords + p[3].coords) / 4.0)
        })
        .collect();
    let mut maps: Vec<(Rotation3<f64>, Vector3<f64>, TemplateMap)> = Vec::new();
    let mut runs: Vec<PathBuf> = Vec::new();
    for k in 0..5u64 {
        let (r, t) = if k == 0 {
            (Rotation3::identity(), Vector3::zeros())
        } else {
            pose(k)
        };
        // The mask's voxel grid turned and moved with the pose: the world
        // geometry is the posed shape.
        let mp = d.join(format!("mask{k}.nii.gz"));
        write_image(&mp, &moved_image(&mask, &r, &t)).unwrap();
        let out = d.join(format!("out{k}"));
        let o = run(&[
            "--seg",
            &s(&mp),
            "-o",
            &s(&out),
            "--size-mm",
            "5",
            // The uniform lattice: the graded default collapses interior
            // vertices in an order that follows the pose, which moves the
            // map by up to 0.57 mm here (0.5 mm is this test's bound).
            "--dense",
            "--image",
            &s(&mp),
            "--spacing-mm",
            "5",
            "--grid",
            "-90,90,-70,70,-25,25",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        maps.push((r, t, TemplateMap::new(&out)));
        runs.push(out);
    }
    // Template coordinates of every material point found in every run.
    let mut coords: Vec<Vec<Point3<f64>>> = vec![Vec::new(); maps.len()];
    let mut missed = 0;
    for p in &points {
        let mapped: Option<Vec<Point3<f64>>> =
            maps.iter().map(|(r, t, m)| m.map(&(r * p + t))).collect();
        match mapped {
            Some(x) => {
                for (c, q) in coords.iter_mut().zip(x) {
                    c.push(q);
                }
            }
            None => missed += 1,
        }
    }
    println!("{} material points, {missed} outside a mesh", points.len());
    assert!(
        missed * 10 < points.len(),
        "{missed} of {} points outside a mesh",
        points.len()
    );
    let mut worst_all = 0.0f64;
    for (k, c) in coords.iter().enumerate().skip(1) {
        let dist: Vec<f64> = c
            .iter()
            .zip(&coords[0])
            .map(|(p, q)| (p - q).norm())
            .collect();
        let worst = dist.iter().cloned().fold(0.0, f64::max);
        let mean = dist.iter().sum::<f64>() / dist.len() as f64;
        println!("pose {k}: template coordinates differ by max {worst:.3e} mm, mean {mean:.3e} mm");
        worst_all = worst_all.max(worst);
    }
    // The flattened mask: one grid for every pose (`compare` checks the
    // dimensions and the affine), nearly the same values (a binary image:
    // counted are the voxels whose value differs by more than a half).
    let base = read_image(runs[0].join("mask0_flat.nii.gz")).unwrap();
    for (k, out) in runs.iter().enumerate().skip(1) {
        let flat = read_image(out.join(format!("mask{k}_flat.nii.gz"))).unwrap();
        let (diff, _) = compare(&base, &flat);
        let (a, b) = (base.volume.data(), flat.volume.data());
        let flipped = a
            .iter()
            .zip(b)
            .filter(|(x, y)| (*x - *y).abs() > 0.5)
            .count();
        let inside = a.iter().filter(|x| **x > 0.5).count();
        println!(
            "pose {k}: flattened mask: {flipped} of {inside} inside voxels differ by > 0.5 \
             (largest difference {diff:.3})"
        );
        assert!(
            inside > 0 && flipped * 100 <= inside,
            "pose {k}: {flipped} of {inside}"
        );
    }
    assert!(
        worst_all < 0.5,
        "template coordinates differ by {worst_all} mm"
    );
}
