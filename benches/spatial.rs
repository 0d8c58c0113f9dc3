//! Spatial query benchmarks: point location in a ~100k-tet structured grid
//! and closest points on a ~20k-triangle sphere (build and 1000 queries each).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{kuhn_grid, uv_sphere};
use unfold::mesh::spatial::{ClosestPointQuery, TetLocator};
use unfold::mesh::{TetMesh, TriMesh};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// `n^3` unit cubes, 6 Kuhn tets each (`6 n^3` tets).
fn tet_grid(n: usize) -> TetMesh {
    kuhn_grid([n; 3], [1.0; 3])
}

/// Latitude-longitude unit sphere: `nu` segments around, `nv` rings
/// (`2 nu (nv - 1)` triangles).
fn sphere(nu: usize, nv: usize) -> TriMesh {
    uv_sphere(nv, nu, 1.0)
}

/// Deterministic pseudo-random points in `[lo, hi]^3`.
fn queries(n: usize, lo: f64, hi: f64) -> Vec<Point3<f64>> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        lo + (hi - lo) * ((state >> 11) as f64 / (1u64 << 53) as f64)
    };
    (0..n)
        .map(|_| Point3::new(next(), next(), next()))
        .collect()
}

fn spatial(c: &mut Criterion) {
    let mut g = c.benchmark_group("spatial");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));

    let grid = tet_grid(26);
    assert_eq!(grid.tets.len(), 105_456);
    let sphere = sphere(100, 101);
    assert_eq!(sphere.triangles.len(), 20_000);
    g.bench_function("tet_locator_build_105k_tets", |b| {
        b.iter(|| TetLocator::new(black_box(&grid)))
    });
    g.bench_function("closest_build_20k_triangles", |b| {
        b.iter(|| ClosestPointQuery::new(black_box(&sphere)))
    });

    // Per-query throughput from here on: 1000 queries per iteration.
    g.throughput(Throughput::Elements(1000));
    let loc = TetLocator::new(&grid);
    let pts = queries(1000, -1.0, 27.0);
    g.bench_function("tet_locate_1000_points_105k_tets", |b| {
        b.iter(|| pts.iter().filter(|p| loc.locate(p).is_some()).count())
    });

    let q = ClosestPointQuery::new(&sphere);
    let closest = |pts: &[Point3<f64>]| {
        pts.iter()
            .map(|p| q.closest(p).map_or(0.0, |c| c.distance))
            .sum::<f64>()
    };
    // Anywhere in the bounding cube (points near the centre are the worst
    // case: all triangles are almost equally far).
    let pts = queries(1000, -1.5, 1.5);
    g.bench_function("closest_point_1000_points_in_cube_20k_triangles", |b| {
        b.iter(|| closest(&pts))
    });
    // Near the surface (radius 0.9 to 1.1), the typical projection use.
    let near: Vec<Point3<f64>> = queries(1000, -1.0, 1.0)
        .iter()
        .zip(queries(1000, 0.9, 1.1).iter().rev())
        .map(|(p, r)| Point3::from(p.coords.normalize() * r.x))
        .collect();
    g.bench_function(
        "closest_point_1000_points_near_surface_20k_triangles",
        |b| b.iter(|| closest(&near)),
    );
    g.finish();
}

criterion_group!(benches, spatial);
criterion_main!(benches);
