//! Rendering every figure of `unfold demo` (issue 8): the placenta (the
//! demo's 10,368-tet slab and an image pulled back at 2 mm), the LV cup
//! (its inner cup the anatomy, 1 mm grid) and the closed valve; the three
//! pipelines run once outside the timing. Measured: the figures of all
//! three and their PNG encoding, as the command line writes them.
//!
//! - `figures/demo_all`: every figure, made and encoded.
//!
//! Target: under 3 s on this machine.
//!
//! Run with `cargo bench --bench figures`.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use unfold::figures::placenta::FlatImage;
use unfold::figures::{FigureOptions, mitral, placenta, ventricle};
use unfold::mesh::geometry::bounding_box;
use unfold::mesh::nalgebra::{Matrix4, Point3};
use unfold::mesh::shapes::{
    PlacentaParams, ValveParams, VentricleParams, mitral_valve, placenta_slab, ventricle_cup,
};
use unfold::mesh::{CellMesh, Volume};
use unfold::organs::{mitral as mv, placenta as pl, ventricle as lv};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// A 2 mm image around `points`, smooth in position.
fn image(points: &[Point3<f64>]) -> Volume<f32> {
    let bb = bounding_box(points).expect("points");
    let s = 2.0;
    let dims: [usize; 3] =
        std::array::from_fn(|a| ((bb.max[a] - bb.min[a] + 12.0) / s).ceil() as usize + 1);
    let mut affine = Matrix4::identity();
    for a in 0..3 {
        affine[(a, a)] = s;
        affine[(a, 3)] = bb.min[a] - 6.0;
    }
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                data.push((100.0 + 40.0 * (p.x / 20.0).sin() + 2.0 * p.z) as f32);
            }
        }
    }
    Volume::new([dims[0], dims[1], dims[2], 1], affine, data).expect("volume")
}

fn figures(c: &mut Criterion) {
    let slab = placenta_slab(&PlacentaParams {
        cells_radial: 12,
        ..PlacentaParams::default()
    })
    .expect("slab");
    let placenta_out = pl::Pipeline::new()
        .run(&slab.mesh, &[], &mut unfold::organs::Quiet)
        .expect("placenta");
    let scan = image(&slab.mesh.positions);
    let flat = placenta_out
        .pullback_table([2.0; 3])
        .expect("table")
        .apply(&scan)
        .expect("pull-back")
        .0;

    let cup = ventricle_cup(&VentricleParams::default()).expect("cup");
    let mut config = lv::Config::default();
    config.chart.field.grid_mm = 1.0;
    let ventricle_out = lv::Pipeline::new()
        .config(config)
        .run(
            &CellMesh::from(&cup.anatomy),
            &cup.surface,
            &lv::LandmarkPoints {
                anterior: cup.anterior,
                inferior: cup.inferior,
                apex: Some(cup.apex),
                rim_near: None,
            },
        )
        .expect("ventricle");

    let valve = mitral_valve(&ValveParams::default()).expect("valve");
    let mitral_out = mv::Pipeline::new()
        .run(&mv::ValveInput {
            anterior: &valve.anterior,
            posterior: &valve.posterior,
            annulus: &valve.annulus,
        })
        .expect("mitral");

    let opts = FigureOptions::default();
    let all = || {
        let images = [FlatImage {
            name: "placenta_mri",
            volume: &flat,
        }];
        let mut figs = placenta::figures(&placenta_out, &images, &opts).expect("placenta");
        figs.extend(
            ventricle::figures(&ventricle_out, lv::Chamber::Lv, None, &opts).expect("ventricle"),
        );
        figs.extend(mitral::figures(&mitral_out, &opts).expect("mitral"));
        figs.iter()
            .map(|f| f.image.to_png().expect("png").len())
            .sum::<usize>()
    };
    let bytes = all();
    println!("demo figures: {bytes} bytes of PNG");
    let mut g = c.benchmark_group("figures");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("demo_all", |b| b.iter(|| black_box(all())));
    g.finish();
}

criterion_group!(benches, figures);
criterion_main!(benches);
