//! The whole mitral pipeline (issue 5): input contract, annulus layout
//! (landmark plane), longitude layout, flip-free symmetric Dirichlet
//! relaxation, maps and measurements; no file I/O.
//!
//! - `mitral/valve_2500`: one valve of about 2,500 vertices
//!   (`annulus_segments = 120`, `depth_segments = 20`: 2,562 vertices);
//! - `mitral/series_10`: a 10-step series of such valves (the generator's
//!   coaptation and commissure gaps varied over the cycle) through
//!   `run_series`, as `unfold mitral --series` runs it: steps in parallel,
//!   the Newton Hessian layout of each leaflet shared by the steps.
//!
//! The summary printed at the end gives, per case, the median of every run
//! criterion made (warm-up included) beside the peak resident memory of a
//! process that generates the valves and runs the case once
//! (`support/peak.rs`).
//!
//! Targets: under 20 ms for the valve and under 200 ms for the series.
//!
//! Run with `cargo bench --bench mitral`.

#[path = "support/peak.rs"]
mod peak;
#[path = "support/summary.rs"]
mod summary;

use criterion::{Criterion, criterion_group};
use summary::{Runs, Summary};
use unfold::mesh::TriMesh;
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{ValveParams, mitral_valve};
use unfold::organs::mitral::{Pipeline, ValveInput};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

struct Valve {
    anterior: TriMesh,
    posterior: TriMesh,
    annulus: Vec<Point3<f64>>,
}

fn valve(step: usize) -> Valve {
    let t = step as f64 / 10.0;
    let s = mitral_valve(&ValveParams {
        annulus_segments: 120,
        depth_segments: 20,
        coaptation_gap: 1.0 + 6.0 * (std::f64::consts::PI * t).sin(),
        commissure_gap: 8.0 + 4.0 * (std::f64::consts::PI * t).sin(),
        ..ValveParams::default()
    })
    .expect("valve");
    Valve {
        anterior: s.anterior,
        posterior: s.posterior,
        annulus: s.annulus,
    }
}

fn solve(v: &Valve) -> f64 {
    let out = Pipeline::new()
        .run(&ValveInput {
            anterior: &v.anterior,
            posterior: &v.posterior,
            annulus: &v.annulus,
        })
        .expect("pipeline");
    assert_eq!(out.report.flipped_triangles, 0);
    out.report.distortion.r#final.angle
}

/// `series_10`: the steps through `run_series`; returns the summed
/// final angle distortions.
fn solve_series(series: &[Valve]) -> f64 {
    let inputs: Vec<ValveInput<'_>> = series
        .iter()
        .map(|v| ValveInput {
            anterior: &v.anterior,
            posterior: &v.posterior,
            annulus: &v.annulus,
        })
        .collect();
    Pipeline::new()
        .run_series(&inputs)
        .into_iter()
        .map(|out| {
            let out = out.expect("pipeline");
            assert_eq!(out.report.flipped_triangles, 0);
            out.report.distortion.r#final.angle
        })
        .sum::<f64>()
}

fn mitral(c: &mut Criterion) {
    let one = valve(0);
    let n = one.anterior.positions.len() + one.posterior.positions.len();
    println!("valve: {n} vertices");
    assert!((2_400..=2_700).contains(&n), "{n}");
    let series: Vec<Valve> = (0..10).map(valve).collect();
    let mut summary = Summary::default();
    let mut g = c.benchmark_group("mitral");
    let mut runs = Runs::default();
    g.bench_function("valve_2500", |b| {
        b.iter_custom(|iters| runs.time(iters, || solve(&one)))
    });
    summary.add("valve_2500", format!("{n} vertices"), &runs);
    let mut runs = Runs::default();
    g.bench_function("series_10", |b| {
        b.iter_custom(|iters| runs.time(iters, || solve_series(&series)))
    });
    let total: usize = series
        .iter()
        .map(|v| v.anterior.positions.len() + v.posterior.positions.len())
        .sum();
    summary.add("series_10", format!("10 valves, {total} vertices"), &runs);
    g.finish();
    summary.print(
        "mitral summary (whole pipeline, no file I/O; median of every run criterion made, \
         warm-up included):",
    );
    println!("  targets: valve < 20 ms, 10-step series < 200 ms");
}

criterion_group!(benches, mitral);

fn main() {
    // A child of `peak::measure`: one run of the named case, then exit.
    peak::serve(|case| match case {
        "valve_2500" => {
            solve(&valve(0));
        }
        "series_10" => {
            solve_series(&(0..10).map(valve).collect::<Vec<_>>());
        }
        _ => panic!("mitral bench: no case {case}"),
    });
    benches();
    Criterion::default().configure_from_args().final_summary();
}
