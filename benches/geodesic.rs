//! Geodesic (edge-graph Dijkstra) benchmarks on a ~3,000-vertex closed
//! triangle surface (a UV sphere):
//!
//! - `all_pairs_3000`: [`EdgeGraph::all_pairs`] (target: < 2 s on 2 cores);
//! - `single_source`: [`EdgeGraph::distances`] from one vertex;
//! - `single_source_petgraph`: the same with `petgraph::algo::dijkstra`
//!   ([`EdgeGraph::distances_petgraph`]), for comparison.
//!
//! Run with `cargo bench --bench geodesic`.

use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use unfold::mesh::{geodesic::EdgeGraph, shapes::uv_sphere};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn geodesic(c: &mut Criterion) {
    // 49 rings of 61 vertices + 2 poles = 2,991 vertices.
    let mesh = uv_sphere(50, 61, 50.0);
    let graph = EdgeGraph::from_tri_mesh(&mesh);
    assert!((2_900..=3_100).contains(&graph.num_vertices()));

    let mut g = c.benchmark_group("geodesic");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    g.bench_function("single_source", |b| {
        b.iter(|| black_box(graph.distances(black_box(&[17]))))
    });
    g.bench_function("single_source_petgraph", |b| {
        b.iter(|| black_box(graph.distances_petgraph(black_box(17))))
    });
    g.sampling_mode(SamplingMode::Flat);
    g.bench_function("all_pairs_3000", |b| {
        b.iter(|| black_box(graph.all_pairs()))
    });
    g.finish();
}

criterion_group!(benches, geodesic);
criterion_main!(benches);
