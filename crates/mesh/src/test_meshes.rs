//! Synthetic meshes and a tiny random generator for the tests of this crate
//! (topology, validation, repair, geodesic, geometry, spatial, coarsening).

use crate::{TetMesh, TriMesh};
use nalgebra::Point3;

/// A tiny deterministic generator (SplitMix64).
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [-h, h).
    pub fn sym(&mut self, h: f64) -> f64 {
        (2.0 * self.f64() - 1.0) * h
    }
    /// Uniform in 0..n.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    pub fn coin(&mut self, p: f64) -> bool {
        self.f64() < p
    }
    /// Standard normal (Box–Muller).
    pub fn gaussian(&mut self) -> f64 {
        let u1 = self.f64().max(1e-300);
        let u2 = self.f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// An `nx × ny × nz` grid of unit cubes at `origin`, each split into 6
/// (Kuhn) or 5 (alternating) tets; orientation as constructed (mixed).
pub fn tet_grid(n: [usize; 3], five: bool, origin: [f64; 3]) -> TetMesh {
    let [nx, ny, nz] = n;
    let id = |x: usize, y: usize, z: usize| (x + (nx + 1) * (y + (ny + 1) * z)) as u32;
    let mut positions = Vec::new();
    for z in 0..=nz {
        for y in 0..=ny {
            for x in 0..=nx {
                positions.push(Point3::new(
                    origin[0] + x as f64,
                    origin[1] + y as f64,
                    origin[2] + z as f64,
                ));
            }
        }
    }
    let mut tets = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let c = |dx: usize, dy: usize, dz: usize| id(x + dx, y + dy, z + dz);
                if five {
                    // Mirror x on odd cubes so face diagonals match.
                    let odd = (x + y + z) % 2 == 1;
                    let m = |dx: usize, dy: usize, dz: usize| {
                        if odd {
                            c(1 - dx, dy, dz)
                        } else {
                            c(dx, dy, dz)
                        }
                    };
                    let (o, a, b, cc) = (m(0, 0, 0), m(1, 1, 0), m(1, 0, 1), m(0, 1, 1));
                    tets.push([o, a, b, cc]);
                    tets.push([m(1, 0, 0), o, a, b]);
                    tets.push([m(0, 1, 0), o, a, cc]);
                    tets.push([m(0, 0, 1), o, b, cc]);
                    tets.push([m(1, 1, 1), a, b, cc]);
                } else {
                    for p in [
                        [0, 1, 2],
                        [0, 2, 1],
                        [1, 0, 2],
                        [1, 2, 0],
                        [2, 0, 1],
                        [2, 1, 0],
                    ] {
                        let mut cur = [0usize; 3];
                        let mut t = [c(0, 0, 0); 4];
                        for (k, &axis) in p.iter().enumerate() {
                            cur[axis] = 1;
                            t[k + 1] = c(cur[0], cur[1], cur[2]);
                        }
                        tets.push(t);
                    }
                }
            }
        }
    }
    TetMesh::new(positions, tets)
}

/// Appends `b` to `a` (indices shifted, no fields).
pub fn merge_tets(a: &TetMesh, b: &TetMesh) -> TetMesh {
    let off = a.positions.len() as u32;
    let mut m = a.clone();
    m.positions.extend_from_slice(&b.positions);
    m.tets.extend(b.tets.iter().map(|t| t.map(|v| v + off)));
    m
}

pub use crate::shapes::primitives::{grid_disk, uv_sphere};

/// A planar annulus with `rings` bands of `around` quads (split in two),
/// counter-clockwise seen from +z.
pub fn annulus(rings: usize, around: usize) -> TriMesh {
    let mut positions = Vec::new();
    for i in 0..=rings {
        let r = 1.0 + i as f64;
        for j in 0..around {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / around as f64;
            positions.push(Point3::new(r * ph.cos(), r * ph.sin(), 0.0));
        }
    }
    let id = |i: usize, j: usize| (i * around + j % around) as u32;
    let mut tris = Vec::new();
    for i in 0..rings {
        for j in 0..around {
            let (a, b) = (id(i, j), id(i + 1, j));
            let (c, d) = (id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    TriMesh::new(positions, tris)
}

/// Signed volume enclosed by a closed triangle surface,
/// `Σ (a·(b×c)) / 6`.
pub fn enclosed_volume(m: &TriMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize].coords);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}
