//! Deterministic test data shared by the tests of this crate and of its
//! dependents (enabled by the `test-support` feature; not part of the
//! stable API): a SplitMix64 generator, dense copies of sparse matrices,
//! random sparse matrices and random planar and tet meshes with their
//! boundaries.

use crate::Csr;
use nalgebra::{DMatrix, Point3};
use unfold_mesh::shapes::primitives::kuhn_grid;
use unfold_mesh::topology::boundary_loops;
use unfold_mesh::{TetMesh, TriMesh};

/// A tiny deterministic generator (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
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
}

/// The dense copy of a sparse matrix.
pub fn dense(a: &Csr) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(a.n_rows(), a.n_cols());
    for i in 0..a.n_rows() {
        let (c, v) = a.row(i);
        for (&j, &x) in c.iter().zip(v) {
            d[(i, j as usize)] += x;
        }
    }
    d
}

/// A random `rows x cols` matrix of `nnz` triplets (duplicates summed),
/// values uniform in [-2, 2).
pub fn random_csr(rows: usize, cols: usize, nnz: usize, rng: &mut Rng) -> Csr {
    let t: Vec<(u32, u32, f64)> = (0..nnz)
        .map(|_| {
            (
                rng.below(rows) as u32,
                rng.below(cols) as u32,
                rng.f64() * 4.0 - 2.0,
            )
        })
        .collect();
    Csr::from_triplets(rows, cols, &t).expect("random triplets are in range")
}

/// Asserts the CSR structure: `n_rows + 1` pointers ending at `nnz`,
/// columns sorted, unique and in range in every row.
pub fn assert_structure(a: &Csr) {
    assert_eq!(a.row_ptr().len(), a.n_rows() + 1);
    assert_eq!(*a.row_ptr().last().unwrap(), a.nnz());
    for i in 0..a.n_rows() {
        let (c, _) = a.row(i);
        assert!(
            c.windows(2).all(|w| w[0] < w[1]),
            "row {i} not sorted/unique"
        );
        assert!(c.iter().all(|&j| (j as usize) < a.n_cols()));
    }
}

/// The signed area of the triangle `abc` projected to the xy plane
/// (positive when counter-clockwise).
pub fn orient2(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x))
}

/// A height field lifting a planar mesh to a curved surface (a graph,
/// so the triangles keep their orientation seen from +z).
pub fn lift(mesh: &mut TriMesh, amplitude: f64) {
    for p in &mut mesh.positions {
        p.z = amplitude * ((1.3 * p.x).sin() * (0.7 * p.y).cos() + 0.2 * p.x * p.x);
    }
}

/// An `nx x ny` unit grid with random diagonals, interior vertices
/// jittered by at most 0.15 (keeps every triangle positive), then
/// sheared by `x += shear * y` (obtuse triangles); planar, ccw.
pub fn perturbed_grid(nx: usize, ny: usize, shear: f64, rng: &mut Rng) -> TriMesh {
    let id = |x: usize, y: usize| (x + (nx + 1) * y) as u32;
    let mut positions = Vec::new();
    for y in 0..=ny {
        for x in 0..=nx {
            let interior = x > 0 && x < nx && y > 0 && y < ny;
            let (dx, dy) = if interior {
                (rng.sym(0.15), rng.sym(0.15))
            } else {
                (0.0, 0.0)
            };
            let (px, py) = (x as f64 + dx, y as f64 + dy);
            positions.push(Point3::new(px + shear * py, py, 0.0));
        }
    }
    let mut tris = Vec::new();
    for y in 0..ny {
        for x in 0..nx {
            let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
            if rng.below(2) == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    let m = TriMesh::new(positions, tris);
    for t in 0..m.num_triangles() {
        let [a, b, c] = m.triangle_points(t);
        assert!(orient2(&a, &b, &c) > 0.0);
    }
    m
}

/// A random planar triangulated disk: a star-shaped (non-convex)
/// polygon fanned from the origin, then random triangle splits at
/// random interior points (thin, obtuse triangles) and random flips of
/// interior edges of strictly convex quads (non-Delaunay). Counter-
/// clockwise.
pub fn random_disk(rng: &mut Rng, boundary: usize, splits: usize, flips: usize) -> TriMesh {
    // With at least 4 boundary vertices and a jitter of 0.2, consecutive
    // angles differ by less than pi: the fan is valid.
    let boundary = boundary.max(4);
    let mut pos = vec![Point3::origin()];
    for k in 0..boundary {
        let t = std::f64::consts::TAU * (k as f64 + rng.sym(0.2)) / boundary as f64;
        let r = 0.6 + 0.8 * rng.f64();
        pos.push(Point3::new(r * t.cos(), r * t.sin(), 0.0));
    }
    let mut tris: Vec<[u32; 3]> = (0..boundary)
        .map(|k| [0, 1 + k as u32, 1 + ((k + 1) % boundary) as u32])
        .collect();
    let area = |pos: &[Point3<f64>], t: [u32; 3]| {
        orient2(
            &pos[t[0] as usize],
            &pos[t[1] as usize],
            &pos[t[2] as usize],
        )
    };
    for _ in 0..splits {
        let k = rng.below(tris.len());
        let t = tris[k];
        let mut w = [0.03 + rng.f64(), 0.03 + rng.f64(), 0.03 + rng.f64()];
        let s = w[0] + w[1] + w[2];
        w.iter_mut().for_each(|x| *x /= s);
        let p = Point3::from(
            pos[t[0] as usize].coords * w[0]
                + pos[t[1] as usize].coords * w[1]
                + pos[t[2] as usize].coords * w[2],
        );
        let v = pos.len() as u32;
        pos.push(p);
        tris[k] = [t[0], t[1], v];
        tris.push([t[1], t[2], v]);
        tris.push([t[2], t[0], v]);
    }
    for _ in 0..flips {
        // Directed edge -> triangle.
        let mut owner = std::collections::HashMap::new();
        for (k, t) in tris.iter().enumerate() {
            for i in 0..3 {
                owner.insert((t[i], t[(i + 1) % 3]), (k, t[(i + 2) % 3]));
            }
        }
        let k1 = rng.below(tris.len());
        let i = rng.below(3);
        let t1 = tris[k1];
        let (a, b, c) = (t1[i], t1[(i + 1) % 3], t1[(i + 2) % 3]);
        let Some(&(k2, d)) = owner.get(&(b, a)) else {
            continue;
        };
        let (n1, n2) = ([c, a, d], [c, d, b]);
        let min = 1e-4 * (area(&pos, t1) + area(&pos, tris[k2]));
        if area(&pos, n1) > min && area(&pos, n2) > min && !owner.contains_key(&(c, d)) {
            tris[k1] = n1;
            tris[k2] = n2;
        }
    }
    let m = TriMesh::new(pos, tris);
    for t in 0..m.num_triangles() {
        let [a, b, c] = m.triangle_points(t);
        assert!(orient2(&a, &b, &c) > 0.0);
    }
    m
}

/// Vertices on the boundary loops.
pub fn boundary_mask(mesh: &TriMesh) -> Vec<bool> {
    let mut b = vec![false; mesh.num_vertices()];
    for lp in boundary_loops(mesh).unwrap() {
        for v in lp {
            b[v as usize] = true;
        }
    }
    b
}

/// A Kuhn grid with its interior vertices jittered (all tets stay
/// positive for `jitter <= 0.1`).
pub fn perturbed_tet_grid(n: usize, rng: &mut Rng, jitter: f64) -> (TetMesh, Vec<bool>) {
    let mut m = kuhn_grid([n, n, n], [1.0, 1.0, 1.0]);
    let mut boundary = Vec::new();
    for p in &mut m.positions {
        let on = [p.x, p.y, p.z]
            .iter()
            .any(|&c| c.abs() < 1e-9 || (c - n as f64).abs() < 1e-9);
        boundary.push(on);
        if !on {
            p.x += rng.sym(jitter);
            p.y += rng.sym(jitter);
            p.z += rng.sym(jitter);
        }
    }
    for t in 0..m.num_tets() {
        let [a, b, c, d] = m.tet_points(t);
        assert!(unfold_mesh::geometry::tet_signed_volume(&a, &b, &c, &d) > 0.0);
    }
    (m, boundary)
}
