//! Rendering every figure of `unfold demo` (issue 8): the placenta (the
//! demo's 10,368-tet slab and an image pulled back at 2 mm), the LV cup
//! (its inner cup the anatomy, 1 mm grid) and the closed valve; the three
//! pipelines run once outside the timing. Measured: the figures of all
//! three and their PNG encoding, as the command line writes them.
//!
//! - `figures/demo_all`: every figure, made and encoded.
//!
//! The summary printed at the end gives the median of every run criterion
//! made (warm-up included) beside the peak resident memory of a process
//! that makes the inputs, runs the three pipelines and then makes and
//! encodes every figure once (`support/peak.rs`): the pipelines' peak is
//! part of it.
//!
//! Target: under 3 s on this machine.
//!
//! Run with `cargo bench --bench figures`.

#[path = "support/peak.rs"]
mod peak;
#[path = "support/summary.rs"]
mod summary;

use criterion::{Criterion, criterion_group};
use std::time::Duration;
use summary::{Runs, Summary};
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

/// The three pipelines' outcomes and the pulled-back image.
struct Outcomes {
    placenta: pl::Outcome,
    scan: Volume<f32>,
    flat: Volume<f32>,
    ventricle: lv::Outcome,
    mitral: mv::Outcome,
}

impl Outcomes {
    /// Runs the three pipelines (outside the timing).
    fn run() -> Outcomes {
        let slab = placenta_slab(&PlacentaParams {
            cells_radial: 12,
            ..PlacentaParams::default()
        })
        .expect("slab");
        let placenta = pl::Pipeline::new()
            .run(&slab.mesh, &[], &mut unfold::organs::Quiet)
            .expect("placenta");
        let scan = image(&slab.mesh.positions);
        let flat = placenta
            .pullback_table([2.0; 3])
            .expect("table")
            .apply(&scan)
            .expect("pull-back")
            .0;

        let cup = ventricle_cup(&VentricleParams::default()).expect("cup");
        let mut config = lv::Config::default();
        config.chart.field.grid_mm = 1.0;
        let ventricle = lv::Pipeline::new()
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
        let mitral = mv::Pipeline::new()
            .run(&mv::ValveInput {
                anterior: &valve.anterior,
                posterior: &valve.posterior,
                annulus: &valve.annulus,
            })
            .expect("mitral");
        Outcomes {
            placenta,
            scan,
            flat,
            ventricle,
            mitral,
        }
    }

    /// `demo_all`: every figure, made and PNG-encoded; returns the PNG
    /// bytes and the figure count.
    fn figures(&self) -> (usize, usize) {
        let opts = FigureOptions::default();
        let images = [FlatImage {
            name: "placenta_mri",
            volume: &self.flat,
            original: Some(&self.scan),
        }];
        let mut figs = placenta::figures(&self.placenta, &images, &opts).expect("placenta");
        figs.extend(
            ventricle::figures(&self.ventricle, lv::Chamber::Lv, None, &opts).expect("ventricle"),
        );
        figs.extend(mitral::figures(&self.mitral, &opts).expect("mitral"));
        let bytes = figs
            .iter()
            .map(|f| f.image.to_png().expect("png").len())
            .sum::<usize>();
        (bytes, figs.len())
    }
}

fn figures(c: &mut Criterion) {
    let outcomes = Outcomes::run();
    let (bytes, count) = outcomes.figures();
    println!("demo figures: {count} figures, {bytes} bytes of PNG");
    let mut g = c.benchmark_group("figures");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    let mut runs = Runs::default();
    g.bench_function("demo_all", |b| {
        b.iter_custom(|iters| runs.time(iters, || outcomes.figures()))
    });
    g.finish();
    let mut summary = Summary::default();
    summary.add(
        "demo_all",
        format!("{count} PNGs, {:.2} MB", bytes as f64 / 1e6),
        &runs,
    );
    summary.print(
        "figures summary (figures made and encoded; median of every run criterion made, \
         warm-up included; the peak includes the three pipelines' runs):",
    );
}

criterion_group!(benches, figures);

fn main() {
    // A child of `peak::measure`: the pipelines and the figures once, then exit.
    peak::serve(|case| {
        assert_eq!(case, "demo_all", "figures bench: no case {case}");
        Outcomes::run().figures();
    });
    benches();
    Criterion::default().configure_from_args().final_summary();
}
