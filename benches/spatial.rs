//! Spatial query benchmarks: point location in a ~100k-tet structured grid
//! and closest points on a ~20k-triangle sphere (build and 1000 queries each).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::spatial::{ClosestPointQuery, TetLocator};
use unfold::mesh::{TetMesh, TriMesh};

/// `n^3` unit cubes, 6 Kuhn tets each (`6 n^3` tets).
fn tet_grid(n: usize) -> TetMesh {
    let id = |i: usize, j: usize, k: usize| (i + (n + 1) * (j + (n + 1) * k)) as u32;
    let mut positions = Vec::with_capacity((n + 1).pow(3));
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                positions.push(Point3::new(i as f64, j as f64, k as f64));
            }
        }
    }
    let mut tets = Vec::with_capacity(6 * n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                for perm in [
                    [0, 1, 2],
                    [0, 2, 1],
                    [1, 0, 2],
                    [1, 2, 0],
                    [2, 0, 1],
                    [2, 1, 0],
                ] {
                    let mut c = [i, j, k];
                    let mut tet = [id(i, j, k); 4];
                    for (s, &axis) in perm.iter().enumerate() {
                        c[axis] += 1;
                        tet[s + 1] = id(c[0], c[1], c[2]);
                    }
                    tets.push(tet);
                }
            }
        }
    }
    TetMesh::new(positions, tets)
}

/// Latitude-longitude unit sphere: `nu` segments around, `nv` rings
/// (`2 nu (nv - 1)` triangles).
fn uv_sphere(nu: usize, nv: usize) -> TriMesh {
    let mut positions = vec![Point3::new(0.0, 0.0, 1.0)];
    for r in 1..nv {
        let th = std::f64::consts::PI * r as f64 / nv as f64;
        for s in 0..nu {
            let ph = std::f64::consts::TAU * s as f64 / nu as f64;
            positions.push(Point3::new(
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
            ));
        }
    }
    positions.push(Point3::new(0.0, 0.0, -1.0));
    let ring = |r: usize, s: usize| (1 + (r - 1) * nu + s % nu) as u32;
    let south = positions.len() as u32 - 1;
    let mut tris = Vec::new();
    for s in 0..nu {
        tris.push([0, ring(1, s), ring(1, s + 1)]);
        tris.push([south, ring(nv - 1, s + 1), ring(nv - 1, s)]);
    }
    for r in 1..nv - 1 {
        for s in 0..nu {
            tris.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
            tris.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
        }
    }
    TriMesh::new(positions, tris)
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
    let sphere = uv_sphere(100, 101);
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
