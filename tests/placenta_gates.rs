//! The placenta's quality gates through the binary: a boundary
//! that splits into a tiny and a huge side is refused naming the fix, a
//! solve that ends where it began is refused, a right run lists every gate
//! with its value in report.json; and `--seg` predicts its tets before
//! meshing (against the mesher's count) and is refused before meshing when
//! the prediction passes `--max-memory`.

use unfold::mesh::TetMesh;
use unfold::mesh::Volume;
use unfold::mesh::mesher::{MaskMeshOptions, mesh_mask};
use unfold::mesh::nalgebra::{Matrix4, Point3};
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};

mod common;
#[path = "common/fixtures.rs"]
mod fixtures;
use common::*;
use fixtures::{slab_mesh, write_tets};

fn report(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// A cone `height` mm tall over a flat disc of radius 40 mm: its flat base
/// and its steep side meet at a sharp rim, so the side split cuts there,
/// and the side has `sqrt(1 + (height / 40)^2)` times the base's area
/// (the split's area ratio measured 0.39 at 100 mm, 0.26 at 160 mm, 0.249
/// at 170 mm; taller, the split cuts across the side instead and the
/// margin covers its tip, refused as before).
fn cone(height: f64) -> TetMesh {
    let (radius, rim) = (40.0, 2.0);
    let mut mesh = placenta_slab(&PlacentaParams {
        length: 2.0 * radius,
        width: 2.0 * radius,
        thickness_centre: 4.0,
        thickness_rim: 4.0,
        bend_radius: 0.0,
        lobe: 0.0,
        cells_radial: 8,
        cells_through: 4,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh;
    // z in [-2, 2] -> u in [0, 1], lifted onto the cone (a positive
    // scaling of each vertical column: no tet turns over).
    for p in &mut mesh.positions {
        let r = (p.x.hypot(p.y) / radius).min(1.0);
        let u = (p.z + 2.0) / 4.0;
        p.z = u * (rim + height * (1.0 - r));
    }
    mesh
}

#[test]
fn a_side_split_with_a_tiny_side_is_refused_naming_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("cone.vtu");
    write_tets(&mesh, &cone(170.0));
    let o = unfold(&[
        "placenta",
        &s(&mesh),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    println!("{}", stderr(&o));
    assert_one_line_error(&o, "quality gate sides.area_ratio: 0.24");
    assert_one_line_error(&o, "unfold mesh MASK --size-mm 3");
    assert!(!dir.path().join("out/report.json").exists());
}

#[test]
fn a_solve_that_ends_where_it_began_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("slab.vtu");
    write_tets(&mesh, &slab_mesh(5, 2));
    // A tolerance no gradient is above: the solver stops at its start.
    let o = unfold(&[
        "placenta",
        &s(&mesh),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
        "--tol",
        "1e12",
    ]);
    println!("{}", stderr(&o));
    assert_one_line_error(
        &o,
        "quality gate solve.moved: 0 is not finite and >= 0.0001",
    );
    assert_one_line_error(&o, "--max-iterations");
}

#[test]
fn report_json_lists_every_gate_with_its_value() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("slab.vtu");
    write_tets(&mesh, &slab_mesh(5, 2));
    let out = dir.path().join("out");
    let o = unfold(&["placenta", &s(&mesh), "-o", &s(&out), "--no-figures"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    let gates = r["gates"].as_array().unwrap();
    let names: Vec<&str> = gates.iter().map(|g| g["name"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "sides.eigensolver",
            "sides.area_ratio",
            "sides.fetal_components",
            "sides.maternal_components",
            "solve.template_error_start_voxels",
            "solve.moved",
            "solve.min_det_j",
        ]
    );
    for g in gates {
        println!("{g}");
        assert_eq!(g["passed"], true, "{g}");
        assert!(g["value"].as_f64().unwrap().is_finite(), "{g}");
        assert!(
            g["requirement"].is_string() && g.get("fallback").is_none(),
            "{g}"
        );
    }
    let ratio = gates[1]["value"].as_f64().unwrap();
    assert!(
        (0.5..2.0).contains(&ratio),
        "a slab's faces are alike: {ratio}"
    );
}

/// A flattened ellipsoid (semi-axes 40, 40, 10 mm) voxelized at `v` mm.
fn disc_mask(v: f64) -> Volume<bool> {
    let n = (100.0 / v).ceil() as usize;
    let nz = (30.0 / v).ceil() as usize;
    let mut a = Matrix4::identity();
    for k in 0..3 {
        a[(k, k)] = v;
    }
    let mut bits = Vec::with_capacity(n * n * nz);
    for k in 0..nz {
        for j in 0..n {
            for i in 0..n {
                let p = Point3::new(
                    i as f64 * v - 50.0,
                    j as f64 * v - 50.0,
                    k as f64 * v - 15.0,
                );
                bits.push((p.x * p.x + p.y * p.y) / 1600.0 + p.z * p.z / 100.0 <= 1.0);
            }
        }
    }
    Volume::new([n, n, nz, 1], a, bits).unwrap()
}

#[test]
fn the_seg_prediction_is_the_meshers_count_within_a_factor() {
    use unfold::app::placenta::seg_prediction::SegPrediction;
    let mask = disc_mask(2.0);
    for (size, grade, factor) in [(5.0, false, 1.3), (4.0, true, 2.0)] {
        let predicted = SegPrediction::of(&mask, size, grade).tets;
        let opts = MaskMeshOptions {
            size_mm: Some(size),
            grade,
            ..MaskMeshOptions::default()
        };
        let made = mesh_mask(&mask, &opts).unwrap().mesh.num_tets() as f64;
        println!("size {size} graded {grade}: predicted {predicted:.0}, made {made}");
        assert!(
            predicted / made < factor && made / predicted < factor,
            "predicted {predicted} made {made}"
        );
    }
}

#[test]
fn a_seg_run_past_the_memory_budget_is_refused_before_meshing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("disc.nii.gz");
    let image = unfold::io::NiftiImage::new(disc_mask(2.0).map(|b| if b { 1.0f32 } else { 0.0 }));
    unfold::io::write_image(&path, &image).unwrap();
    let out = dir.path().join("out");
    let o = unfold(&[
        "placenta",
        "--seg",
        &s(&path),
        "--size-mm",
        "0.2",
        "-o",
        &s(&out),
        "--max-memory",
        "256M",
    ]);
    println!("{}", stderr(&o));
    assert_one_line_error(
        &o,
        "flattening the placenta (predicted from the mask before meshing)",
    );
    assert_one_line_error(&o, "raise --size-mm");
    assert!(!out.join("mesh.vtu").exists());
}
