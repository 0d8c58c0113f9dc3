//! The ventricle pipeline end to end on Cobiveco geo2 (issue 6): S =
//! `heart_epi.ply` (11,321 vertices), the anatomy = the 6,309 vertices of
//! `heart_endo_lv.ply`; mesh repair, landmarks, disk map, the Laplace field
//! at 1 mm (multigrid CG), the forward map of every anatomy point and the
//! inverse map back (the round trip); no file I/O.
//!
//! - `ventricle/geo2_1mm`: the whole [`run`];
//! - `ventricle/geo2_chart_1mm`: only the chart (disk map and field).
//!
//! Target: the whole run under 10 s on this machine.
//!
//! Run with `cargo bench --bench ventricle` (reads `tests/data/cobiveco-geo2`).

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use unfold::io::{read_mesh, read_tri_mesh};
use unfold::organs::ventricle::{Chart, Config, LandmarkPoints, Pipeline};
use unfold::param::initializer::disk_boundary_loop;

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn ventricle(c: &mut Criterion) {
    let s = read_tri_mesh("tests/data/cobiveco-geo2/heart_epi.ply").expect("S");
    let anatomy = read_mesh("tests/data/cobiveco-geo2/heart_endo_lv.ply").expect("anatomy");
    assert_eq!(anatomy.positions.len(), 6_309);
    // two rim points a third of the loop apart stand in for the RV
    // insertion points (the data set does not mark them)
    let rim = disk_boundary_loop(&s).expect("disk");
    let landmarks = LandmarkPoints {
        anterior: s.positions[rim[0] as usize],
        inferior: s.positions[rim[rim.len() / 3] as usize],
        apex: None,
        rim_near: None,
    };
    let mut config = Config::default();
    config.chart.field.grid_mm = 1.0;
    let once = Pipeline::new()
        .config(config)
        .run(&anatomy, &s, &landmarks)
        .expect("pipeline");
    println!(
        "geo2 at 1 mm: round trip um {:?}, seconds {:?}, field {:?}",
        once.report.roundtrip_error_um, once.report.seconds, once.report.field
    );
    let mut g = c.benchmark_group("ventricle");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(60));
    g.bench_function("geo2_1mm", |b| {
        b.iter(|| {
            let out = Pipeline::new()
                .config(config)
                .run(&anatomy, &s, &landmarks)
                .expect("pipeline");
            black_box(out.report.roundtrip_error_um.max)
        })
    });
    g.bench_function("geo2_chart_1mm", |b| {
        b.iter(|| {
            let chart = Chart::new(
                &s,
                &landmarks.anterior,
                &landmarks.inferior,
                None,
                &config.chart,
            )
            .expect("chart");
            black_box(chart.field().stats().unknowns)
        })
    });
    g.finish();
    println!("target: geo2 end to end (disk, Laplace at 1 mm, forward and inverse map) < 10 s");
}

criterion_group!(benches, ventricle);
criterion_main!(benches);
