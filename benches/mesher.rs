//! Meshing a segmentation (issue 7): a 128^3 mask at 3 mm voxels (a 384 mm
//! field of view, as placenta MRI) holding a placenta-like shape, a curved
//! disc 175 mm wide and 25 mm thick, tilted; default options (smoothing 1.5
//! voxels, the volume-preserving level, 3 mm lattice), and at 1.5 mm.
//!
//! - `mesher/placenta_128_3mm`: [`mesh_mask`] with the defaults;
//! - `mesher/placenta_128_1.5mm`: the same at `--size-mm 1.5`;
//! - `mesher/placenta_128_3mm_graded`: the default with `--grade`.
//!
//! The summary printed at the end gives, per case, the median of every run
//! criterion made (warm-up included) beside the peak resident memory of a
//! process that makes the mask and meshes it once (`support/peak.rs`).
//!
//! Target: the default under 3 s on this machine.
//!
//! Run with `cargo bench --bench mesher`.

#[path = "support/peak.rs"]
mod peak;
#[path = "support/summary.rs"]
mod summary;

use criterion::{Criterion, criterion_group};
use std::time::Duration;
use summary::{Runs, Summary};
use unfold::mesh::Volume;
use unfold::mesh::mesher::{MaskMeshOptions, MeshQuality, mesh_mask};
use unfold::mesh::nalgebra::{Matrix4, Point3, Rotation3};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// 128^3 voxels of 3 mm centred on the origin; inside: within 12.5 mm of
/// the bowl `z = rho^2 / 600` over a disc of radius 75 mm, tilted.
fn placenta_mask() -> Volume<bool> {
    let n = 128;
    let mut a = Matrix4::identity();
    for k in 0..3 {
        a[(k, k)] = 3.0;
        a[(k, 3)] = -3.0 * (n as f64 - 1.0) / 2.0;
    }
    let tilt = Rotation3::from_euler_angles(0.3, -0.2, 0.4).inverse();
    let mut bits = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = a.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                let q = tilt * p.coords;
                let rho = (q.x * q.x + q.y * q.y).sqrt();
                let z = q.z - rho.min(75.0).powi(2) / 600.0;
                bits.push(((rho - 75.0).max(0.0).powi(2) + z * z).sqrt() < 12.5);
            }
        }
    }
    Volume::new([n, n, n, 1], a, bits).expect("mask")
}

/// The cases: their names and options.
fn cases() -> [(&'static str, MaskMeshOptions); 3] {
    let fine = MaskMeshOptions {
        size_mm: Some(1.5),
        ..MaskMeshOptions::default()
    };
    let graded = MaskMeshOptions {
        grade: true,
        ..MaskMeshOptions::default()
    };
    [
        ("placenta_128_3mm", MaskMeshOptions::default()),
        ("placenta_128_1.5mm", fine),
        ("placenta_128_3mm_graded", graded),
    ]
}

fn mesher(c: &mut Criterion) {
    let mask = placenta_mask();
    let mut summary = Summary::default();
    for (name, opts) in cases() {
        let out = mesh_mask(&mask, &opts).expect("mesh");
        let q = MeshQuality::of(&out.mesh).expect("quality");
        println!(
            "{name}: {} tets, {} vertices, {} boundary triangles, volume {:.0} mm^3 \
             ({:+.2} % of the mask's), dihedral {:.2} .. {:.2} degrees, level {:.3}",
            q.tets,
            q.vertices,
            q.boundary_triangles,
            q.volume_mm3,
            100.0 * (q.volume_mm3 / out.mask_volume_mm3 - 1.0),
            q.min_dihedral_deg,
            q.max_dihedral_deg,
            out.level
        );
        let mut g = c.benchmark_group("mesher");
        g.sample_size(10).measurement_time(Duration::from_secs(20));
        let mut runs = Runs::default();
        g.bench_function(name, |b| {
            b.iter_custom(|iters| runs.time(iters, || mesh_mask(&mask, &opts).expect("mesh")))
        });
        g.finish();
        summary.add(name, format!("128^3 mask, {} tets", q.tets), &runs);
    }
    summary.print(
        "mesher summary (mask to tets; median of every run criterion made, warm-up included):",
    );
}

criterion_group!(benches, mesher);

fn main() {
    // A child of `peak::measure`: one meshing of the named case, then exit.
    peak::serve(|case| {
        let (_, opts) = cases()
            .into_iter()
            .find(|(name, _)| *name == case)
            .unwrap_or_else(|| panic!("mesher bench: no case {case}"));
        mesh_mask(&placenta_mask(), &opts).expect("mesh");
    });
    benches();
    Criterion::default().configure_from_args().final_summary();
}
