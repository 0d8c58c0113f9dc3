//! `unfold placenta` (and the placenta part of `unfold demo`) through the
//! binary: outputs and report on small synthetic slabs for every template
//! and both solvers, images pulled into the template (values checked against
//! the map, 3D and 4D, default and explicit spacing), and every kind of bad
//! input as a one-line error naming the file.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use unfold::io::{
    Datatype, NiftiImage, WriteOptions, read_image, read_mesh, write_image, write_mesh,
};
use unfold::mesh::nalgebra::{Point3, Vector3};
use unfold::mesh::{CellMesh, CellType, TetMesh, Volume};

mod common;
#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::*;
#[path = "common/scan.rs"]
mod scan;
use common::*;

/// The default test slab (6 radial cells, 2 layers: 1296 tets).
fn slab() -> TetMesh {
    slab_mesh(6, 2)
}

/// Writes the default slab to `dir/slab.vtu`.
fn slab_file(dir: &Path) -> PathBuf {
    let p = dir.join("slab.vtu");
    write_tets(&p, &slab());
    p
}

fn report(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json exists");
    serde_json::from_str(&text).expect("report.json is JSON")
}

/// The intensity of the test images: affine in world position, so that
/// trilinear interpolation reproduces it exactly.
fn intensity(p: &Point3<f64>) -> f64 {
    500.0 + 2.0 * p.x - 1.5 * p.y + 4.0 * p.z
}

/// An image with `frames` frames (frame `t` holds `intensity + 100 t`),
/// voxel spacing `spacing`, axis-aligned, covering `mesh` with a 6 mm margin
/// and shifted by `offset`.
fn image_around(mesh: &TetMesh, spacing: [f64; 3], frames: usize, offset: f64) -> NiftiImage {
    scan::image_around(mesh, spacing, frames, Vector3::repeat(offset), |p, t| {
        intensity(p) + 100.0 * t as f64
    })
}

fn field_values(fields: &unfold::mesh::Fields, name: &str) -> Vec<f64> {
    fields
        .get(name)
        .unwrap_or_else(|| panic!("array {name} missing"))
        .values()
        .to_f64()
}

fn assert_summary(v: &serde_json::Value, what: &str) {
    let o = v
        .as_object()
        .unwrap_or_else(|| panic!("{what} is not an object: {v}"));
    for k in ["mean", "std", "p5", "p50", "p95"] {
        assert!(
            o.get(k).and_then(|x| x.as_f64()).is_some(),
            "{what}.{k}: {v}"
        );
    }
}

/// Checks the outputs of a successful run in `out` on `input`.
fn check_outputs(out: &Path, input: &TetMesh) -> serde_json::Value {
    let original = read_mesh(out.join("original.vtu")).expect("original.vtu reads");
    let flat = read_mesh(out.join("flattened.vtu")).expect("flattened.vtu reads");
    for (name, m) in [("original", &original), ("flattened", &flat)] {
        assert_eq!(m.num_points(), input.num_vertices(), "{name}");
        assert_eq!(m.num_cells(), input.num_tets(), "{name}");
        assert!(m.cells().all(|(t, _)| t == CellType::Tetra), "{name}");
        let side: BTreeSet<i64> = field_values(&m.point_data, "side")
            .into_iter()
            .map(|x| x as i64)
            .collect();
        assert_eq!(side, BTreeSet::from([0, 1, 2, 3]), "{name}: side values");
        // The parcellation's Fiedler vector: its sign is the side (maternal
        // positive) off the margin, 0 inside.
        let labels = field_values(&m.point_data, "side");
        let fiedler = field_values(&m.point_data, "fiedler");
        assert_eq!(fiedler.len(), labels.len(), "{name}");
        for (l, f) in labels.iter().zip(&fiedler) {
            match *l as i64 {
                0 => assert_eq!(*f, 0.0, "{name}: interior"),
                1 => assert!(*f < 0.0, "{name}: fetal {f}"),
                2 => assert!(*f > 0.0, "{name}: maternal {f}"),
                _ => assert!(f.is_finite(), "{name}: margin {f}"),
            }
        }
    }
    for name in ["log2_det_j", "sym_dirichlet"] {
        let v = field_values(&flat.cell_data, name);
        assert_eq!(v.len(), input.num_tets(), "{name}");
        assert!(v.iter().all(|x| x.is_finite()), "{name}");
    }
    // Symmetric Dirichlet is at least 6 in 3D.
    assert!(
        field_values(&flat.cell_data, "sym_dirichlet")
            .iter()
            .all(|&d| d >= 6.0 - 1e-9)
    );

    let r = report(out);
    for k in [
        "mesh",
        "images",
        "template",
        "lambda",
        "solver",
        "iterations",
        "seconds",
        "converged",
        "objective",
        "template_error_mm",
        "template_error_voxels",
        "dirichlet_excess_percent",
        "min_det_j",
        "inverted_tets",
        "theta",
        "theta_initial",
        "transform",
    ] {
        assert!(r.get(k).is_some(), "report.json lacks {k}");
    }
    for k in ["log2_det_j", "log2_edge_ratio", "log2_area_ratio"] {
        assert_summary(&r[k], k);
    }
    for k in ["fetal", "maternal", "margin"] {
        assert!(r["boundary"][k].as_u64().unwrap_or(0) > 0, "boundary.{k}");
    }
    assert_eq!(r["inverted_tets"], 0);
    assert!(r["min_det_j"].as_f64().unwrap_or(-1.0) > 0.0);
    assert!(r["dirichlet_excess_percent"].as_f64().unwrap_or(-1.0) >= 0.0);
    assert_eq!(r["input"]["tets"], input.num_tets());
    r
}

#[test]
fn planes_writes_meshes_and_a_full_report() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    let out = dir.path().join("out/nested");
    let o = unfold(&["placenta", &s(&mesh_path), "-o", &s(&out)]);
    assert_ok(&o);
    let r = check_outputs(&out, &slab());
    assert_eq!(r["template"], "planes");
    assert_eq!(r["solver"], "newton");
    assert_eq!(r["lambda"], 1.0);
    assert_eq!(r["converged"], true);
    assert_eq!(r["mesh"], s(&mesh_path));
    assert_eq!(r["images"], serde_json::json!([]));
    assert_eq!(r["input"]["reoriented_tets"], 0);
    let h = r["theta"]["h"].as_f64().expect("theta.h");
    // The slab is 9..25 mm thick: the planes end up in between.
    assert!((3.0..13.0).contains(&h), "h = {h}");
    let text = stdout(&o);
    for needle in [
        "planes template",
        "converged",
        "template error",
        "Dirichlet excess",
        "min det J",
        "0 inverted tets",
        "h ",
        "fetal",
        "report.json",
        "flattened.vtu",
    ] {
        assert!(text.contains(needle), "summary lacks {needle:?}:\n{text}");
    }
    assert!(!text.contains("reoriented"), "{text}");
    // Nothing else in the directory (but the manifest of the set), and no
    // temporary files left behind.
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            unfold::app::run::MANIFEST,
            "figures",
            "flattened.vtu",
            "original.vtu",
            "report.json"
        ]
    );
    // the figures (no image given: no depth slices), PNG of the asked size
    let mut figs: Vec<String> = std::fs::read_dir(out.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    figs.sort();
    assert_eq!(
        figs,
        [
            "distortion.png",
            "flattened_profile.png",
            "meshes_log2_det_j.png",
            "meshes_side.png"
        ]
    );
    let png = std::fs::read(out.join("figures/flattened_profile.png")).unwrap();
    let img = unfold::figures::render::Image::from_png(&png).unwrap();
    assert_eq!((img.width(), img.height()), (960, 400));
    // --no-figures writes none
    let bare = dir.path().join("bare");
    assert_ok(&unfold(&[
        "placenta",
        &s(&mesh_path),
        "-o",
        &s(&bare),
        "--no-figures",
    ]));
    assert!(!bare.join("figures").exists());
}

#[test]
fn ellipsoid_and_single_plane_run() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    for (template, params) in [
        ("ellipsoid", vec!["rx", "ry", "rz"]),
        ("single-plane", vec!["h"]),
    ] {
        let out = dir.path().join(template);
        let o = unfold(&[
            "placenta",
            &s(&mesh_path),
            "-o",
            &s(&out),
            "--template",
            template,
        ]);
        assert_ok(&o);
        let r = check_outputs(&out, &slab());
        assert_eq!(r["template"], template);
        for p in params {
            assert!(
                r["theta"][p].as_f64().is_some_and(|x| x > 0.0),
                "{template}: {p}"
            );
        }
        let stages = r["stages"].as_array().map(Vec::len);
        let want = if template == "single-plane" { 2 } else { 1 };
        assert_eq!(stages, Some(want), "{template}: stages");
        assert!(stdout(&o).contains(&format!("{template} template")));
    }
}

#[test]
fn gradient_descent_with_few_iterations_reports_not_converged() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    let out = dir.path().join("gd");
    let o = unfold(&[
        "placenta",
        &s(&mesh_path),
        "-o",
        &s(&out),
        "--solver",
        "gd",
        "--max-iterations",
        "5",
        "--lambda",
        "0.5",
    ]);
    // outputs written, exit code 3 and one line saying so
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert_one_line_error(
        &o,
        "the placenta's flattening did not converge (max_iterations after 5 iterations)",
    );
    let r = check_outputs(&out, &slab());
    assert_eq!(r["converged"], false);
    assert_eq!(r["solver"], "gd");
    assert_eq!(r["lambda"], 0.5);
    assert_eq!(r["iterations"], 5);
    assert_eq!(r["stop_reason"], "max_iterations");
    assert!(
        stdout(&o).contains("NOT converged (max_iterations)"),
        "{}",
        stdout(&o)
    );
}

/// The tet of `mesh` containing `p` and its barycentric coordinates.
fn locate(mesh: &CellMesh, p: &Point3<f64>) -> Option<(usize, [f64; 4])> {
    let mut best: Option<(usize, [f64; 4], f64)> = None;
    for (k, (_, vs)) in mesh.cells().enumerate() {
        let x: Vec<Point3<f64>> = vs.iter().map(|&v| mesh.positions[v as usize]).collect();
        let ds =
            unfold::mesh::nalgebra::Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        let Some(inv) = ds.try_inverse() else {
            continue;
        };
        let a = inv * (p - x[0]);
        let alpha = [1.0 - a.x - a.y - a.z, a.x, a.y, a.z];
        let worst = alpha.iter().copied().fold(f64::INFINITY, f64::min);
        if best.as_ref().is_none_or(|b| worst > b.2) {
            best = Some((k, alpha, worst));
        }
    }
    best.filter(|b| b.2 > -1e-9).map(|(k, a, _)| (k, a))
}

#[test]
fn images_are_pulled_into_the_template() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = slab();
    let mesh_path = slab_file(dir.path());
    let spacing = [3.0, 2.5, 2.0];
    let t2 = dir.path().join("t2.nii.gz");
    write_image(&t2, &image_around(&mesh, spacing, 1, 0.0)).unwrap();
    let bold = dir.path().join("bold.nii");
    write_image(&bold, &image_around(&mesh, spacing, 3, 0.0)).unwrap();
    let out = dir.path().join("out");
    let o = unfold(&[
        "placenta",
        &s(&mesh_path),
        "-o",
        &s(&out),
        "--image",
        &s(&t2),
        "--image",
        &s(&bold),
    ]);
    assert_ok(&o);
    let r = check_outputs(&out, &mesh);
    let images = r["images"].as_array().expect("images");
    assert_eq!(images.len(), 2);
    assert_eq!(images[0]["input"], s(&t2));
    assert_eq!(images[0]["output"], s(&out.join("t2_flat.nii.gz")));
    assert_eq!(images[1]["output"], s(&out.join("bold_flat.nii.gz")));
    assert_eq!(images[0]["frames"], 1);
    assert_eq!(images[1]["frames"], 3);
    // Per image its depth slices and its sections beside the original's;
    // the 4D series also every frame as a strip (3 thumbnails and the
    // colour bar, half-size panels).
    let mut figs: Vec<String> = std::fs::read_dir(out.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("t2_") || n.starts_with("bold_"))
        .collect();
    figs.sort();
    assert_eq!(
        figs,
        [
            "bold_depths.png",
            "bold_frames.png",
            "bold_sections.png",
            "t2_depths.png",
            "t2_sections.png"
        ]
    );
    let png = std::fs::read(out.join("figures/bold_frames.png")).unwrap();
    let strip = unfold::figures::render::Image::from_png(&png).unwrap();
    assert_eq!((strip.width(), strip.height()), (4 * 240, 200));
    let png = std::fs::read(out.join("figures/t2_sections.png")).unwrap();
    let sections = unfold::figures::render::Image::from_png(&png).unwrap();
    assert_eq!((sections.width(), sections.height()), (4 * 480, 2 * 400));
    // One table for both: same grid.
    assert_eq!(images[0]["dims"], images[1]["dims"]);
    assert_eq!(images[0]["affine"], images[1]["affine"]);
    for i in images {
        assert!(i["inside_mesh"].as_u64().unwrap_or(0) > 100, "{i}");
        assert_eq!(i["sampled"], i["inside_mesh"], "{i}");
        assert_eq!(i["outside_image"], 0, "{i}");
    }

    let flat3 = read_image(out.join("t2_flat.nii.gz")).expect("t2_flat reads");
    let flat4 = read_image(out.join("bold_flat.nii.gz")).expect("bold_flat reads");
    let (v3, v4) = (&flat3.volume, &flat4.volume);
    // Default spacing: the input's own.
    for (got, want) in v3.spacing().iter().zip(spacing) {
        assert!((got - want).abs() < 1e-5, "{:?}", v3.spacing());
    }
    let d3 = v3.dims();
    assert_eq!(d3[3], 1);
    assert_eq!(v4.dims(), [d3[0], d3[1], d3[2], 3]);
    assert!((v3.affine() - v4.affine()).abs().max() < 1e-5);
    let dims: Vec<usize> = images[0]["dims"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect();
    assert_eq!(dims, d3[..3]);

    // Every non-zero voxel holds the intensity at its source point: locate
    // its centre in the flattened mesh and map it to the original.
    let original = read_mesh(out.join("original.vtu")).unwrap();
    let flat = read_mesh(out.join("flattened.vtu")).unwrap();
    let n = v3.frame_len();
    let inside: Vec<usize> = (0..n).filter(|&i| v3.data()[i] != 0.0).collect();
    assert_eq!(
        inside.len() as u64,
        images[0]["inside_mesh"].as_u64().unwrap()
    );
    let step = (inside.len() / 40).max(1);
    let mut checked = 0;
    for &idx in inside.iter().step_by(step) {
        let (i, j, k) = (idx % d3[0], (idx / d3[0]) % d3[1], idx / (d3[0] * d3[1]));
        let p = v3.voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
        let (tet, alpha) = locate(&flat, &p).expect("a voxel with a value lies in the mesh");
        let (_, vs) = original.cell(tet);
        let z = vs.iter().zip(alpha).fold(Vector3::zeros(), |acc, (&v, a)| {
            acc + original.positions[v as usize].coords * a
        });
        let want = intensity(&Point3::from(z));
        let got = f64::from(v3.data()[idx]);
        assert!(
            (got - want).abs() < 1e-3 * want.abs(),
            "voxel {idx}: {got} vs {want}"
        );
        for t in 0..3 {
            let g = f64::from(v4.data()[t * n + idx]);
            let w = want + 100.0 * t as f64;
            assert!(
                (g - w).abs() < 1e-3 * w.abs(),
                "frame {t}, voxel {idx}: {g} vs {w}"
            );
        }
        checked += 1;
    }
    assert!(checked >= 20, "{checked}");
    assert!(stdout(&o).contains("t2_flat.nii.gz"));
}

/// A label map (INT16, labels 1..=5 in 7 mm bands of `x + y`) around `mesh`.
fn labels_around(mesh: &TetMesh) -> NiftiImage {
    let base = image_around(mesh, [2.0, 2.0, 2.0], 1, 0.0);
    let affine = *base.volume.affine();
    let dims = base.volume.dims();
    let mut data = Vec::with_capacity(base.volume.frame_len());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                data.push((1 + ((p.x + p.y + 500.0) / 7.0).floor() as i64 % 5) as f32);
            }
        }
    }
    let vol = Volume::new(dims, affine, data).expect("volume");
    NiftiImage::new(vol).with_datatype(Datatype::Int16)
}

#[test]
fn label_maps_are_pulled_back_by_nearest_neighbour_and_stay_integer() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = slab();
    let mesh_path = slab_file(dir.path());
    let labels = dir.path().join("labels.nii.gz");
    let input = labels_around(&mesh);
    write_image(&labels, &input).unwrap();
    let input = read_image(&labels).unwrap();
    assert_eq!(input.datatype, Datatype::Int16);
    let run = |interp: &str| {
        let out = dir.path().join(interp);
        let o = unfold(&[
            "placenta",
            &s(&mesh_path),
            "-o",
            &s(&out),
            "--image",
            &s(&labels),
            "--interp",
            interp,
            "--no-figures",
        ]);
        assert_ok(&o);
        let r = report(&out);
        assert_eq!(r["images"][0]["interpolation"], interp);
        (
            out.clone(),
            read_image(out.join("labels_flat.nii.gz")).unwrap(),
        )
    };

    let (out, nearest) = run("nearest");
    assert_eq!(nearest.datatype, Datatype::Int16, "kept integer");
    let v = &nearest.volume;
    let values: BTreeSet<i64> = v.data().iter().map(|&x| x as i64).collect();
    assert!(values.iter().all(|x| (0..=5).contains(x)), "{values:?}");
    assert!(
        values.len() >= 4,
        "several labels reach the template: {values:?}"
    );
    // Each voxel holds the label of the input voxel nearest to its source.
    let original = read_mesh(out.join("original.vtu")).unwrap();
    let flat = read_mesh(out.join("flattened.vtu")).unwrap();
    let d = v.dims();
    let inside: Vec<usize> = (0..v.frame_len()).filter(|&i| v.data()[i] != 0.0).collect();
    assert!(inside.len() > 100, "{}", inside.len());
    let mut checked = 0;
    for &idx in inside.iter().step_by((inside.len() / 40).max(1)) {
        let (i, j, k) = (idx % d[0], (idx / d[0]) % d[1], idx / (d[0] * d[1]));
        let p = v.voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
        let (tet, alpha) = locate(&flat, &p).expect("a labelled voxel lies in the mesh");
        let (_, vs) = original.cell(tet);
        let z = vs.iter().zip(alpha).fold(Vector3::zeros(), |acc, (&v, a)| {
            acc + original.positions[v as usize].coords * a
        });
        let want = input
            .volume
            .sample_voxel_nearest(&input.volume.world_to_voxel(&Point3::from(z)), 0)
            .expect("inside the label map");
        assert_eq!(f64::from(v.data()[idx]), want, "voxel {idx}");
        checked += 1;
    }
    assert!(checked >= 20, "{checked}");

    // Trilinear blends labels at the band edges (hence the flag).
    let (_, linear) = run("linear");
    assert_eq!(linear.datatype, Datatype::Float32);
    let blended = linear
        .volume
        .data()
        .iter()
        .filter(|x| (x.fract()).abs() > 1e-3)
        .count();
    assert!(blended > 0, "linear gives in-between values");

    assert_one_line_error(
        &unfold(&[
            "placenta",
            &s(&mesh_path),
            "-o",
            &s(&dir.path().join("x")),
            "--interp",
            "cubic",
        ]),
        "cubic",
    );
}

#[test]
fn spacing_flag_sets_the_template_grid() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = slab();
    let mesh_path = slab_file(dir.path());
    let img = dir.path().join("mri.nii.gz");
    write_image(&img, &image_around(&mesh, [3.0, 3.0, 3.0], 1, 0.0)).unwrap();
    let out = dir.path().join("out");
    let o = unfold(&[
        "placenta",
        &s(&mesh_path),
        "-o",
        &s(&out),
        "--image",
        &s(&img),
        "--spacing-mm",
        "2",
    ]);
    assert_ok(&o);
    let flat = read_image(out.join("mri_flat.nii.gz")).unwrap();
    for a in 0..3 {
        assert!(
            (flat.volume.spacing()[a] - 2.0).abs() < 1e-6,
            "{:?}",
            flat.volume.spacing()
        );
    }
    assert_eq!(
        report(&out)["images"][0]["spacing_mm"],
        serde_json::json!([2.0, 2.0, 2.0])
    );
}

#[test]
fn an_inverted_tet_is_reoriented_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = slab();
    mesh.tets[7].swap(0, 1);
    let p = dir.path().join("inverted.vtu");
    write_tets(&p, &mesh);
    let out = dir.path().join("out");
    let o = unfold(&["placenta", &s(&p), "-o", &s(&out)]);
    assert_ok(&o);
    assert!(stdout(&o).contains("reoriented 1 tet "), "{}", stdout(&o));
    let r = check_outputs(&out, &mesh);
    assert_eq!(r["input"]["reoriented_tets"], 1);
    assert_eq!(r["inverted_tets"], 0);
}

#[test]
fn a_surface_mesh_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let mut tri = CellMesh::from_points(vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(10.0, 0.0, 0.0),
        Point3::new(0.0, 10.0, 0.0),
        Point3::new(0.0, 0.0, 10.0),
    ]);
    for t in [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] {
        tri.push_cell(CellType::Triangle, &t);
    }
    for ext in ["ply", "vtp"] {
        let p = dir.path().join(format!("surface.{ext}"));
        write_mesh(&p, &tri, &WriteOptions::default()).unwrap();
        let out = dir.path().join("out");
        let o = unfold(&["placenta", &s(&p), "-o", &s(&out)]);
        assert_one_line_error(&o, &s(&p));
        assert_one_line_error(&o, "tetrahedral");
        assert!(!out.exists(), "nothing written on bad input");
    }
}

#[test]
fn a_degenerate_tet_is_dropped_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    // The slab and a flat tet on a face of its first tet, its fourth corner
    // (a new vertex) at the face's centroid.
    let mut clean = slab();
    clean.point_data = Default::default();
    let mut mesh = clean.clone();
    let f = mesh.tets[0];
    let c = Point3::from(
        (0..3)
            .map(|k| mesh.positions[f[k] as usize].coords)
            .sum::<Vector3<f64>>()
            / 3.0,
    );
    mesh.positions.push(c);
    let v = (mesh.positions.len() - 1) as u32;
    mesh.tets.push([f[0], f[1], f[2], v]);
    let p = dir.path().join("flat.vtu");
    write_tets(&p, &mesh);
    let out = dir.path().join("out");
    let o = unfold(&["placenta", &s(&p), "-o", &s(&out)]);
    assert_ok(&o);
    let r = check_outputs(&out, &clean);
    assert_eq!(r["repair"]["degenerate_elements"], 1, "{}", r["repair"]);
    assert_eq!(r["repair"]["unused_vertices"], 1);
    assert_eq!(r["repair"]["welded_vertices"], 0);
}

/// Position -> index, exact.
fn index_by_position(m: &CellMesh) -> std::collections::HashMap<[u64; 3], usize> {
    m.positions
        .iter()
        .enumerate()
        .map(|(v, p)| ([p.x, p.y, p.z].map(f64::to_bits), v))
        .collect()
}

#[test]
fn a_tet_soup_with_duplicated_tets_flattens_like_the_clean_mesh() {
    let dir = tempfile::tempdir().unwrap();
    // The slab renumbered in the order its tets first use its vertices:
    // the order welding the soup below gives back (each welded vertex keeps
    // its first copy). The flattening's tangential freedom makes its
    // result depend on the vertex order by ~1.5 mm at the same objective,
    // so the comparison needs the same order.
    let slab = slab();
    let (positions, tets, _) = first_use_order(&slab.positions, &slab.tets);
    let clean = TetMesh::new(positions, tets);
    // Every tet with its own four vertices (as a tet soup exporter writes
    // them), every 5th tet written twice, its copy's corners rotated.
    let mut soup = TetMesh::default();
    let mut duplicates = 0;
    for (t, tet) in clean.tets.iter().enumerate() {
        let copies = if t % 5 == 0 { 2 } else { 1 };
        duplicates += copies - 1;
        for c in 0..copies {
            let base = soup.positions.len() as u32;
            soup.positions
                .extend(tet.iter().map(|&v| clean.positions[v as usize]));
            let mut new = [base, base + 1, base + 2, base + 3];
            if c == 1 {
                new.rotate_left(2);
            }
            soup.tets.push(new);
        }
    }
    let (pc, ps) = (dir.path().join("clean.vtu"), dir.path().join("soup.vtu"));
    write_tets(&pc, &clean);
    write_tets(&ps, &soup);
    let (oc, os) = (dir.path().join("clean"), dir.path().join("soup"));
    assert_ok(&unfold(&["placenta", &s(&pc), "-o", &s(&oc)]));
    assert_ok(&unfold(&["placenta", &s(&ps), "-o", &s(&os)]));
    let r = check_outputs(&os, &clean);
    assert_eq!(
        r["repair"]["welded_vertices"],
        soup.num_vertices() - clean.num_vertices()
    );
    assert_eq!(r["repair"]["duplicate_elements"], duplicates);
    assert_eq!(r["repair"]["unused_vertices"], 0);
    assert_eq!(report(&oc)["repair"]["welded_vertices"], 0);
    // The same flattened position for every vertex, matched by position.
    let (orig_c, orig_s) = (
        read_mesh(oc.join("original.vtu")).unwrap(),
        read_mesh(os.join("original.vtu")).unwrap(),
    );
    let (flat_c, flat_s) = (
        read_mesh(oc.join("flattened.vtu")).unwrap(),
        read_mesh(os.join("flattened.vtu")).unwrap(),
    );
    let index = index_by_position(&orig_c);
    let mut worst: f64 = 0.0;
    for (v, p) in orig_s.positions.iter().enumerate() {
        let c = index[&[p.x, p.y, p.z].map(f64::to_bits)];
        worst = worst.max((flat_s.positions[v] - flat_c.positions[c]).norm());
    }
    // The fit itself is the same.
    let (rc, rs) = (report(&oc), report(&os));
    for k in ["objective", "template_error_mm"] {
        let (x, y) = (rc[k].as_f64().unwrap(), rs[k].as_f64().unwrap());
        assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{k}: {x} vs {y}");
    }
    assert!(worst < 1e-6, "flattened positions differ by {worst} mm");
}

#[test]
fn two_components_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let a = slab_mesh(5, 2);
    let n = a.num_vertices() as u32;
    let mut positions = a.positions.clone();
    positions.extend(
        a.positions
            .iter()
            .map(|p| p + Vector3::new(250.0, 0.0, 0.0)),
    );
    let mut tets = a.tets.clone();
    tets.extend(a.tets.iter().map(|t| t.map(|v| v + n)));
    let p = dir.path().join("twins.vtu");
    write_tets(&p, &TetMesh::new(positions, tets));
    let o = unfold(&["placenta", &s(&p), "-o", &s(&dir.path().join("out"))]);
    assert_one_line_error(&o, &s(&p));
    assert_one_line_error(&o, "2 connected components");
    // the fix the message names: the first twin kept, and it flattens
    assert_one_line_error(&o, "--largest-component");
    let one = dir.path().join("one.vtu");
    let r = unfold(&["repair", &s(&p), "-o", &s(&one), "--largest-component"]);
    assert_ok(&r);
    assert!(
        stdout(&r).contains("kept the largest of 2 components"),
        "{}",
        stdout(&r)
    );
    let kept = read_mesh(&one).unwrap().to_tet_mesh().unwrap();
    assert_eq!(kept.tets, a.tets);
    assert_eq!(kept.positions, a.positions);
    let o = unfold(&[
        "placenta",
        &s(&one),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_ok(&o);
}

#[test]
fn a_nan_coordinate_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nan.vtk");
    std::fs::write(
        &p,
        "# vtk DataFile Version 4.2\nNaN coordinate\nASCII\nDATASET UNSTRUCTURED_GRID\n\
         POINTS 4 double\n0 0 0\n10 0 0\n0 10 0\n0 0 nan\n\
         CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
    )
    .unwrap();
    let o = unfold(&["placenta", &s(&p), "-o", &s(&dir.path().join("out"))]);
    assert_one_line_error(&o, &s(&p));
    assert_one_line_error(&o, "non-finite");
}

#[test]
fn image_problems_are_caught_before_the_optimization() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = slab();
    let mesh_path = slab_file(dir.path());
    let out = dir.path().join("out");
    let run = |images: &[&Path]| {
        let mut args = vec!["placenta".to_string(), s(&mesh_path), "-o".into(), s(&out)];
        for i in images {
            args.push("--image".into());
            args.push(s(i));
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        unfold(&args)
    };

    let far = dir.path().join("far.nii.gz");
    write_image(&far, &image_around(&mesh, [3.0; 3], 1, 1000.0)).unwrap();
    let o = run(&[&far]);
    assert_one_line_error(&o, &s(&far));
    assert_one_line_error(&o, "does not overlap the mesh");
    assert_one_line_error(&o, " mm");

    let missing = dir.path().join("missing.nii.gz");
    assert_one_line_error(&run(&[&missing]), &s(&missing));

    let good = dir.path().join("a/mri.nii.gz");
    let same = dir.path().join("b/mri.nii");
    for p in [&good, &same] {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        write_image(p, &image_around(&mesh, [3.0; 3], 1, 0.0)).unwrap();
    }
    let o = run(&[&good, &same]);
    assert_one_line_error(&o, &s(&same));
    assert_one_line_error(&o, "same name");

    let not_nifti = dir.path().join("mri.vtu");
    assert_one_line_error(&run(&[&not_nifti]), "NIfTI");

    // Fail fast: nothing was created.
    assert!(!out.exists());
}

/// The parcellation's and the template's settings take effect: the
/// margin's start (five voxels without --margin-mm), the affinity's gamma
/// and rings, and --fix-h.
#[test]
fn parcellation_and_template_flags_take_effect() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    let mesh_path_s = s(&mesh_path);
    // Without --margin-mm the margin starts at five voxels, inside the
    // limit at any voxel size (a fixed 15 mm was refused at 1.5 mm voxels,
    // whose limit is 15 mm).
    // The parcellation's affinity is the user's to set: a sharper, smaller
    // neighbourhood gives another Fiedler vector.
    let mut fiedlers = Vec::new();
    for extra in [&[][..], &["--gamma", "5", "--rings", "1"][..]] {
        let d = dir.path().join(format!("affinity{}", extra.len()));
        let mut args = vec!["placenta", &mesh_path_s, "-o"];
        let d_s = s(&d);
        args.push(&d_s);
        args.extend_from_slice(&["--no-figures", "--max-iterations", "1"]);
        args.extend_from_slice(extra);
        let o = unfold(&args);
        assert!(matches!(o.status.code(), Some(0 | 3)), "{}", stderr(&o));
        let m = read_mesh(d.join("original.vtu")).unwrap();
        fiedlers.push(field_values(&m.point_data, "fiedler"));
    }
    let change = fiedlers[0]
        .iter()
        .zip(&fiedlers[1])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(change > 1e-6, "{change}");
    // --fix-h holds h where the template has one.
    for template in ["planes", "single-plane"] {
        let d = dir.path().join(format!("fixed-{template}"));
        let o = unfold(&[
            "placenta",
            &mesh_path_s,
            "-o",
            &s(&d),
            "--template",
            template,
            "--fix-h",
            "4.5",
            "--no-figures",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let r = report(&d);
        assert_eq!(r["theta"]["h"], 4.5, "{template}: {}", r["theta"]);
        assert_eq!(r["theta_initial"]["h"], 4.5, "{template}");
    }
    let d = s(&dir.path().join("fixed-ellipsoid"));
    let o = unfold(&[
        "placenta",
        &mesh_path_s,
        "-o",
        &d,
        "--template",
        "ellipsoid",
        "--fix-h",
        "4.5",
    ]);
    assert_one_line_error(&o, "--fix-h");
    assert!(!dir.path().join("fixed-ellipsoid").exists());
    for (voxel, start) in [("1.5", 7.5), ("3", 15.0)] {
        let dir_v = dir.path().join(format!("v{voxel}"));
        let o = unfold(&[
            "placenta",
            &s(&mesh_path),
            "-o",
            &s(&dir_v),
            "--voxel-mm",
            voxel,
            "--no-figures",
            "--max-iterations",
            "2",
        ]);
        assert!(matches!(o.status.code(), Some(0 | 3)), "{}", stderr(&o));
        let r = report(&dir_v);
        assert_eq!(
            r["boundary"]["parcellation"]["margin_radius_initial_mm"], start,
            "{}",
            r["boundary"]
        );
    }
}

#[test]
fn bad_flag_values_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    let out = s(&dir.path().join("out"));
    for (flag, value) in [
        ("--lambda", "0"),
        ("--lambda", "-2"),
        ("--margin-mm", "-1"),
        ("--gamma", "0"),
        ("--gamma", "nan"),
        ("--rings", "0"),
        ("--rings", "7"),
        ("--fix-h", "0"),
        ("--lambda-sweep", "1,-2"),
        ("--lambda-sweep", "0"),
        ("--fix-h", "-3"),
        ("--voxel-mm", "nan"),
        ("--spacing-mm", "0"),
        ("--tol", "inf"),
        ("--max-iterations", "0"),
    ] {
        let o = unfold(&["placenta", &s(&mesh_path), "-o", &out, flag, value]);
        assert_one_line_error(&o, flag);
    }
    // A margin that the parcellation cannot use (10 voxels or more).
    let o = unfold(&["placenta", &s(&mesh_path), "-o", &out, "--margin-mm", "40"]);
    assert_one_line_error(&o, "margin_mm");
    // What the argument parser itself rejects is one line too (exit 2).
    for (args, needle) in [
        (vec!["--lambda", "abc"], "--lambda"),
        (vec!["--template", "cone"], "possible values"),
        (vec!["--solver", "lbfgs"], "--solver"),
    ] {
        let mut all = vec!["placenta", mesh_path.to_str().unwrap(), "-o", &out];
        all.extend(args);
        let o = unfold(&all);
        assert_one_line_error(&o, needle);
        assert_eq!(o.status.code(), Some(2));
    }
    let o = unfold(&["placenta", &s(&mesh_path)]);
    assert_one_line_error(&o, "--output");
}

#[test]
fn the_output_must_be_a_directory_and_never_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    let file = dir.path().join("taken");
    std::fs::write(&file, "x").unwrap();
    let o = unfold(&["placenta", &s(&mesh_path), "-o", &s(&file)]);
    assert_one_line_error(&o, &s(&file));
    assert_one_line_error(&o, "not a directory");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");

    // The mesh is called original.vtu and -o is its own directory.
    let own = dir.path().join("own");
    std::fs::create_dir(&own).unwrap();
    let input = own.join("original.vtu");
    write_tets(&input, &slab());
    let before = std::fs::read(&input).unwrap();
    let o = unfold(&["placenta", &s(&input), "-o", &s(&own.join("."))]);
    assert_one_line_error(&o, "overwritten");
    assert_eq!(std::fs::read(&input).unwrap(), before);
}

#[test]
fn demo_runs_the_placenta_pipeline() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let o = unfold(&["demo", "-o", &s(&out)]);
    assert_ok(&o);
    let pl = out.join("placenta");
    for f in [
        "original.vtu",
        "flattened.vtu",
        "report.json",
        "placenta_mri_flat.nii.gz",
    ] {
        assert!(pl.join(f).is_file(), "{f} missing");
    }
    let r = report(&pl);
    assert_eq!(r["template"], "planes");
    assert_eq!(r["converged"], true);
    assert_eq!(r["inverted_tets"], 0);
    assert_eq!(r["overlapping_boundary_faces"], 0);
    let tets = r["input"]["tets"].as_u64().unwrap_or(0);
    assert!((9_000..12_000).contains(&tets), "{tets}");
    let img = &r["images"][0];
    assert_eq!(
        img["sampled"], img["inside_mesh"],
        "the MRI covers the slab"
    );
    let flat = read_image(pl.join("placenta_mri_flat.nii.gz")).unwrap();
    assert!(flat.volume.data().iter().any(|&x| x != 0.0));
    assert!(stdout(&o).contains("placenta_mri_flat.nii.gz"));
}

/// `--lambda-sweep`: one row per weight in `lambda_sweep.csv` and the
/// trade-off curve; a larger weight distorts less and fits the template
/// worse (the paper's Fig. 3), and the main outputs are those of --lambda.
#[test]
fn a_lambda_sweep_writes_the_trade_off() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = slab_file(dir.path());
    let out = dir.path().join("out");
    let o = unfold(&[
        "placenta",
        &s(&mesh_path),
        "-o",
        &s(&out),
        "--lambda-sweep",
        "0.2,5",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = std::fs::read_to_string(out.join("lambda_sweep.csv")).unwrap();
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|v| match v {
                    "true" => 1.0,
                    "false" => 0.0,
                    v => v.parse().unwrap(),
                })
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 2, "{table}");
    assert_eq!((rows[0][col("lambda")], rows[1][col("lambda")]), (0.2, 5.0));
    assert!(rows.iter().all(|r| r[col("converged")] == 1.0), "{table}");
    let (excess, error) = (col("dirichlet_excess_percent"), col("template_error_mm"));
    assert!(rows[1][excess] < rows[0][excess], "{table}");
    assert!(rows[1][error] > rows[0][error], "{table}");
    assert!(out.join("figures/lambda_sweep.png").is_file());
    assert_eq!(report(&out)["lambda"], 1.0);
}
