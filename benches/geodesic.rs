//! Geodesic (edge-graph Dijkstra) benchmarks on a ~3,000-vertex closed
//! triangle surface (a UV sphere built here):
//!
//! - `all_pairs_3000`: [`EdgeGraph::all_pairs`] (target: < 2 s on 2 cores);
//! - `single_source`: [`EdgeGraph::distances`] from one vertex;
//! - `single_source_petgraph`: the same with `petgraph::algo::dijkstra`
//!   ([`EdgeGraph::distances_petgraph`]), for comparison.
//!
//! Run with `cargo bench --bench geodesic`.

use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;
use unfold::mesh::{TriMesh, geodesic::EdgeGraph, nalgebra::Point3};

/// A UV sphere of radius `r`: `(n_lat - 1) n_lon + 2` vertices, outward
/// counter-clockwise triangles.
fn uv_sphere(n_lat: usize, n_lon: usize, r: f64) -> TriMesh {
    let mut positions = vec![Point3::new(0.0, 0.0, r)];
    for i in 1..n_lat {
        let th = PI * i as f64 / n_lat as f64;
        for j in 0..n_lon {
            let ph = 2.0 * PI * j as f64 / n_lon as f64;
            positions.push(Point3::new(
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ));
        }
    }
    let south = positions.len() as u32;
    positions.push(Point3::new(0.0, 0.0, -r));
    let ring = |i: usize, j: usize| (1 + (i - 1) * n_lon + j % n_lon) as u32;
    let mut tris = Vec::new();
    for j in 0..n_lon {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..n_lat - 1 {
        for j in 0..n_lon {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j + 1), ring(i + 1, j));
            tris.push([a, d, c]);
            tris.push([a, c, b]);
        }
    }
    for j in 0..n_lon {
        tris.push([south, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
    }
    TriMesh::new(positions, tris)
}

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
