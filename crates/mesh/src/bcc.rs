//! The body-centred cubic (BCC) lattice of isosurface stuffing (Labelle &
//! Shewchuk 2007; ALGORITHMS 2.8), the background mesh a mask or an
//! implicit function is cut from (issue 7).
//!
//! Black vertices sit at the cube corners `o + (i, j, k) h`, red vertices
//! at the cube centres `o + (i + 1/2, j + 1/2, k + 1/2) h`. Every pair of
//! face-adjacent cubes gives a red edge (length `h`); with the four edges of
//! the square face they share it spans four tetrahedra, each with two red
//! and two black vertices, volume `h^3 / 12`, dihedral angles 60 degrees
//! (four) and 90 degrees (two). Twelve tets per cube; the lattice is
//! conforming (a face is shared by at most two tets).

use crate::geometry::tet_signed_volume;
use crate::{MeshError, TetMesh};
use nalgebra::Point3;

/// A BCC lattice of `n[0] x n[1] x n[2]` cubes of side `h` from `origin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BccLattice {
    /// The first black vertex (the cubes' lowest corner).
    pub origin: Point3<f64>,
    /// Cube side, mm.
    pub h: f64,
    /// Cubes per axis.
    pub n: [usize; 3],
}

impl BccLattice {
    /// The lattice; `h` finite and `> 0`, at least one cube per axis, and
    /// fewer than `2^31` vertices.
    ///
    /// # Errors
    /// `InvalidArgument` naming the bad value.
    pub fn new(origin: Point3<f64>, h: f64, n: [usize; 3]) -> Result<BccLattice, MeshError> {
        if !(h.is_finite() && h > 0.0 && origin.coords.iter().all(|x| x.is_finite())) {
            return Err(MeshError::InvalidArgument(format!(
                "a BCC lattice needs a finite origin and a spacing > 0, got {h}"
            )));
        }
        if n.contains(&0) {
            return Err(MeshError::InvalidArgument(format!(
                "a BCC lattice needs at least one cube per axis, got {n:?}"
            )));
        }
        let l = BccLattice { origin, h, n };
        let total = (n[0] + 1)
            .checked_mul(n[1] + 1)
            .and_then(|x| x.checked_mul(n[2] + 1))
            .and_then(|b| b.checked_add(n[0] * n[1] * n[2]));
        match total {
            Some(t) if t < (1 << 31) => Ok(l),
            _ => Err(MeshError::InvalidArgument(format!(
                "a BCC lattice of {n:?} cubes has too many vertices"
            ))),
        }
    }

    /// Number of black vertices, `(n_x + 1)(n_y + 1)(n_z + 1)`.
    pub fn num_black(&self) -> usize {
        (self.n[0] + 1) * (self.n[1] + 1) * (self.n[2] + 1)
    }

    /// Number of red vertices, `n_x n_y n_z`.
    pub fn num_red(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// Vertex id of black vertex `(i, j, k)` (ids `0 .. num_black`).
    #[inline]
    pub fn black(&self, i: usize, j: usize, k: usize) -> u32 {
        (i + (self.n[0] + 1) * (j + (self.n[1] + 1) * k)) as u32
    }

    /// Vertex id of the red vertex of cube `(i, j, k)` (ids after the black
    /// ones).
    #[inline]
    pub fn red(&self, i: usize, j: usize, k: usize) -> u32 {
        (self.num_black() + i + self.n[0] * (j + self.n[1] * k)) as u32
    }

    /// Positions of all vertices, black then red.
    pub fn positions(&self) -> Vec<Point3<f64>> {
        let [nx, ny, nz] = self.n;
        let h = self.h;
        let o = self.origin;
        let mut p = Vec::with_capacity(self.num_black() + self.num_red());
        for k in 0..=nz {
            for j in 0..=ny {
                for i in 0..=nx {
                    p.push(Point3::new(
                        o.x + i as f64 * h,
                        o.y + j as f64 * h,
                        o.z + k as f64 * h,
                    ));
                }
            }
        }
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    p.push(Point3::new(
                        o.x + (i as f64 + 0.5) * h,
                        o.y + (j as f64 + 0.5) * h,
                        o.z + (k as f64 + 0.5) * h,
                    ));
                }
            }
        }
        p
    }

    /// The tetrahedra, positively oriented: for every red edge (cube
    /// `(i, j, k)` to its neighbour along axis `a`), the four tets
    /// `[r_0, r_1, b_m, b_{m+1}]` over the edges of the shared face.
    pub fn tets(&self) -> Vec<[u32; 4]> {
        let positions = self.positions();
        let mut out = Vec::with_capacity(12 * self.num_red());
        for k in 0..self.n[2] {
            self.for_each_tet_in_slab(k, |mut t| {
                let p = t.map(|x| positions[x as usize]);
                if tet_signed_volume(&p[0], &p[1], &p[2], &p[3]) < 0.0 {
                    t.swap(2, 3);
                }
                out.push(t);
            });
        }
        out
    }

    /// Calls `visit` with the tets `[r_0, r_1, b_m, b_{m+1}]` of the red
    /// edges from the cubes of layer `k` (`r_0` in cube `(i, j, k)`, `r_1`
    /// in the next cube along x, y or z), in the order of
    /// [`BccLattice::tets`] but not oriented. The layers `0 .. n[2]` visit
    /// every tet once.
    pub fn for_each_tet_in_slab(&self, k: usize, mut visit: impl FnMut([u32; 4])) {
        let [nx, ny, _] = self.n;
        for j in 0..ny {
            for i in 0..nx {
                let r0 = self.red(i, j, k);
                for a in 0..3 {
                    let c = [i, j, k];
                    if c[a] + 1 >= self.n[a] {
                        continue;
                    }
                    let mut d = c;
                    d[a] += 1;
                    let r1 = self.red(d[0], d[1], d[2]);
                    // the shared face: corner coordinate c[a] + 1 along a
                    let (u, v) = match a {
                        0 => (1, 2),
                        1 => (0, 2),
                        _ => (0, 1),
                    };
                    let corner = |du: usize, dv: usize| {
                        let mut q = c;
                        q[a] += 1;
                        q[u] += du;
                        q[v] += dv;
                        self.black(q[0], q[1], q[2])
                    };
                    let ring = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    for m in 0..4 {
                        visit([r0, r1, ring[m], ring[(m + 1) % 4]]);
                    }
                }
            }
        }
    }

    /// The lattice as a tet mesh (black vertices on the lattice's border
    /// that no tet uses are kept, so ids match [`BccLattice::black`]).
    pub fn to_tet_mesh(&self) -> TetMesh {
        TetMesh::new(self.positions(), self.tets())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tet_dihedral_angles;
    use proptest::prelude::*;
    use std::collections::HashMap;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// Every tet is positive with volume `h^3 / 12` and dihedral angles
        /// of 60 and 90 degrees; every face is shared by at most two tets,
        /// and the tets fill `(n_x - 1)(n_y - 1)(n_z - 1)` cubes' worth of
        /// volume plus the border layers (`h^3 / 3` per red edge).
        #[test]
        fn the_lattice_is_a_conforming_mesh_of_congruent_tets(
            n in prop::array::uniform3(1usize..5),
            h in 0.1f64..3.0,
            o in prop::array::uniform3(-10.0f64..10.0),
        ) {
            let l = BccLattice::new(Point3::new(o[0], o[1], o[2]), h, n).unwrap();
            let m = l.to_tet_mesh();
            let red_edges = (n[0] - 1) * n[1] * n[2] + n[0] * (n[1] - 1) * n[2] + n[0] * n[1] * (n[2] - 1);
            prop_assert_eq!(m.tets.len(), 4 * red_edges);
            let mut faces: HashMap<[u32; 3], usize> = HashMap::new();
            for t in 0..m.tets.len() {
                let p = m.tet_points(t);
                let v = tet_signed_volume(&p[0], &p[1], &p[2], &p[3]);
                prop_assert!((v - h * h * h / 12.0).abs() < 1e-9 * h * h * h, "{}", v);
                let mut angles = tet_dihedral_angles(&p).map(f64::to_degrees);
                angles.sort_by(|a, b| a.total_cmp(b));
                for (k, a) in angles.iter().enumerate() {
                    let want = if k < 4 { 60.0 } else { 90.0 };
                    prop_assert!((a - want).abs() < 1e-6, "{:?}", angles);
                }
                let q = m.tets[t];
                for f in [[q[0], q[1], q[2]], [q[0], q[1], q[3]], [q[0], q[2], q[3]], [q[1], q[2], q[3]]] {
                    let mut f = f;
                    f.sort_unstable();
                    *faces.entry(f).or_default() += 1;
                }
            }
            prop_assert!(faces.values().all(|&c| c <= 2));
            let opts = crate::validate::ValidationOptions {
                allow_unused_vertices: true,
                ..Default::default()
            };
            let problems = crate::validate::check_tet_mesh(&m, &opts);
            let bad = problems.iter().any(|p| {
                matches!(
                    p.error,
                    MeshError::InvertedElement { .. }
                        | MeshError::NonManifoldFace { .. }
                        | MeshError::DegenerateElement { .. }
                )
            });
            prop_assert!(!bad, "{:?}", problems);
        }
    }

    #[test]
    fn dihedral_angles_of_known_tets() {
        let regular = [
            Point3::new(1.0, 1.0, 1.0),
            Point3::new(1.0, -1.0, -1.0),
            Point3::new(-1.0, 1.0, -1.0),
            Point3::new(-1.0, -1.0, 1.0),
        ];
        for a in tet_dihedral_angles(&regular) {
            assert!((a - (1.0f64 / 3.0).acos()).abs() < 1e-12, "{a}");
        }
        let corner = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
        ];
        let a = tet_dihedral_angles(&corner).map(f64::to_degrees);
        let slant = (1.0f64 / 3.0f64.sqrt()).acos().to_degrees();
        for (k, want) in [90.0, 90.0, 90.0, slant, slant, slant].iter().enumerate() {
            assert!((a[k] - want).abs() < 1e-9, "{a:?}");
        }
        // the orientation does not matter
        let mut flipped = corner;
        flipped.swap(0, 1);
        let b = tet_dihedral_angles(&flipped).map(f64::to_degrees);
        let (mut x, mut y) = (a.to_vec(), b.to_vec());
        x.sort_by(|p, q| p.total_cmp(q));
        y.sort_by(|p, q| p.total_cmp(q));
        for (p, q) in x.iter().zip(&y) {
            assert!((p - q).abs() < 1e-9);
        }
    }

    #[test]
    fn ids_and_positions_agree() {
        let l = BccLattice::new(Point3::new(1.0, 2.0, 3.0), 0.5, [3, 2, 4]).unwrap();
        let p = l.positions();
        assert_eq!(p.len(), 4 * 3 * 5 + 24);
        assert_eq!(p[l.black(2, 1, 3) as usize], Point3::new(2.0, 2.5, 4.5));
        assert_eq!(p[l.red(2, 1, 3) as usize], Point3::new(2.25, 2.75, 4.75));
    }

    #[test]
    fn bad_lattices_are_errors() {
        let o = Point3::origin();
        for h in [0.0, -1.0, f64::NAN] {
            let e = BccLattice::new(o, h, [1, 1, 1]).unwrap_err().to_string();
            assert!(e.contains("spacing"), "{e}");
        }
        let e = BccLattice::new(o, 1.0, [0, 1, 1]).unwrap_err().to_string();
        assert!(e.contains("at least one cube"), "{e}");
        let e = BccLattice::new(o, 1.0, [1 << 20, 1 << 20, 4])
            .unwrap_err()
            .to_string();
        assert!(e.contains("too many"), "{e}");
    }
}
