//! Simple closed-form meshes for tests, benchmarks and examples: a UV sphere,
//! a planar grid disk and a structured tet grid.

use crate::{TetMesh, TriMesh};
use nalgebra::Point3;
use std::f64::consts::PI;

/// A UV sphere of radius `r` centred at the origin, with `n_lat` latitude
/// bands and `n_lon` longitudes: `(n_lat - 1) n_lon + 2` vertices and
/// `2 n_lon (n_lat - 1)` triangles, counter-clockwise seen from outside.
/// Vertex `(i, j)` (ring `i` in `1..n_lat`) is at polar angle
/// `pi i / n_lat` and azimuth `2 pi j / n_lon`. Needs `n_lat >= 2` and
/// `n_lon >= 3` (smaller values are raised to those).
pub fn uv_sphere(n_lat: usize, n_lon: usize, r: f64) -> TriMesh {
    let (n_lat, n_lon) = (n_lat.max(2), n_lon.max(3));
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
    let mut tris = Vec::with_capacity(2 * n_lon * (n_lat - 1));
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

/// A planar `nx x ny` grid of unit squares in `z = 0` with its corner at the
/// origin, each square split in two along its `(x, y) -> (x+1, y+1)`
/// diagonal, counter-clockwise seen from +z: a disk with
/// `(nx + 1)(ny + 1)` vertices and `2 nx ny` triangles.
pub fn grid_disk(nx: usize, ny: usize) -> TriMesh {
    let id = |x: usize, y: usize| (x + (nx + 1) * y) as u32;
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for y in 0..=ny {
        for x in 0..=nx {
            positions.push(Point3::new(x as f64, y as f64, 0.0));
        }
    }
    let mut tris = Vec::with_capacity(2 * nx * ny);
    for y in 0..ny {
        for x in 0..nx {
            let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    TriMesh::new(positions, tris)
}

/// A structured grid of `n[0] x n[1] x n[2]` boxes of size `spacing` with
/// its corner at the origin, each box split into the 6 Kuhn tets around its
/// main diagonal (a conforming triangulation): `6 n0 n1 n2` tets, all
/// positively oriented.
///
/// The Kuhn tet of the axis permutation `(a, b, c)` is
/// `[v, v + e_a, v + e_a + e_b, v + e_a + e_b + e_c]`; its edge matrix has
/// determinant `sign(a, b, c) * prod(spacing)`, so the last two corners are
/// swapped for odd permutations.
pub fn kuhn_grid(n: [usize; 3], spacing: [f64; 3]) -> TetMesh {
    let id = |i: usize, j: usize, k: usize| (i + (n[0] + 1) * (j + (n[1] + 1) * k)) as u32;
    let mut positions = Vec::with_capacity((n[0] + 1) * (n[1] + 1) * (n[2] + 1));
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                positions.push(Point3::new(
                    i as f64 * spacing[0],
                    j as f64 * spacing[1],
                    k as f64 * spacing[2],
                ));
            }
        }
    }
    // (permutation, is odd)
    let perms = [
        ([0, 1, 2], false),
        ([1, 2, 0], false),
        ([2, 0, 1], false),
        ([0, 2, 1], true),
        ([1, 0, 2], true),
        ([2, 1, 0], true),
    ];
    let mut tets = Vec::with_capacity(6 * n[0] * n[1] * n[2]);
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                for (perm, odd) in perms {
                    let mut c = [i, j, k];
                    let mut t = [id(i, j, k); 4];
                    for (s, &axis) in perm.iter().enumerate() {
                        c[axis] += 1;
                        t[s + 1] = id(c[0], c[1], c[2]);
                    }
                    if odd {
                        t.swap(2, 3);
                    }
                    tets.push(t);
                }
            }
        }
    }
    TetMesh::new(positions, tets)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{enclosed_volume, tet_volumes, total_area};
    use crate::topology::{boundary_loops, euler_characteristic, tet_boundary};

    #[test]
    fn sphere_is_closed_outward_and_valid() {
        let s = uv_sphere(20, 30, 2.0);
        assert_eq!(s.num_vertices(), 19 * 30 + 2);
        assert_eq!(s.num_triangles(), 2 * 30 * 19);
        assert!(s.validate().is_ok());
        assert_eq!(euler_characteristic(&s), 2);
        let v = enclosed_volume(&s);
        let exact = 4.0 / 3.0 * PI * 8.0;
        assert!(v > 0.95 * exact && v < exact, "{v} vs {exact}");
    }

    #[test]
    fn grid_disk_is_one_ccw_disk() {
        let d = grid_disk(4, 3);
        assert!(d.validate().is_ok());
        assert_eq!(euler_characteristic(&d), 1);
        assert_eq!(boundary_loops(&d).unwrap().len(), 1);
        assert!((total_area(&d) - 12.0).abs() < 1e-12);
    }

    #[test]
    fn kuhn_grid_is_positive_conforming_and_fills_the_box() {
        let g = kuhn_grid([3, 2, 4], [1.0, 0.5, 2.0]);
        assert_eq!(g.num_tets(), 6 * 24);
        assert!(g.validate().is_ok());
        let vols = tet_volumes(&g);
        assert!(vols.iter().all(|&v| (v - 1.0 / 6.0).abs() < 1e-12));
        let b = tet_boundary(&g).unwrap();
        assert_eq!(euler_characteristic(&b.surface), 2);
        assert!((enclosed_volume(&b.surface) - 24.0).abs() < 1e-9);
    }
}
