//! Tutte-style embeddings of disk-topology triangle meshes in the plane
//! (ALGORITHMS 3.2, 4.2).

use super::{Constraints, InitialMap, Initializer};
use crate::flips::check_no_flips;
use crate::{ParamError, ParamMesh};
use nalgebra::Point3;
use unfold_linalg::{
    cotan_laplacian, mean_value_weights, solve_dirichlet, solve_dirichlet_weights,
    uniform_laplacian,
};
use unfold_mesh::TriMesh;
use unfold_mesh::topology::disk_boundary_loop;

/// Edge weights of a [`TutteDisk`] embedding (every free vertex is the
/// weighted mean of its neighbours, `sum_j w_ij (x_i - x_j) = 0`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum TutteWeights {
    /// Mean-value weights (Floater 2003, [`mean_value_weights`]): always
    /// positive, so the embedding is bijective for a convex boundary; close
    /// to the harmonic map. The default.
    #[default]
    MeanValue,
    /// Cotangent weights ([`cotan_laplacian`]): the discrete harmonic map
    /// (ALGORITHMS 3.2). Negative on non-Delaunay edges, where triangles
    /// may flip.
    Cotangent,
    /// `w_ij = 1` (Tutte's barycentric embedding): bijective for a convex
    /// boundary, but ignores the geometry.
    Uniform,
}

/// Boundary positions of a [`TutteDisk`] embedding.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum DiskBoundary {
    /// The boundary loop on the unit circle, by cumulative edge length:
    /// `t_k = 2 pi s_k / s_total`, `q_k = (cos t_k, sin t_k)`, starting at
    /// the first vertex of the (longest) boundary loop, counter-clockwise
    /// for a mesh whose triangles are counter-clockwise (see
    /// [`circle_boundary`]).
    #[default]
    Circle,
    /// Explicit positions of some vertices (e.g. a mitral annulus, an RV
    /// half disk). Bijectivity is guaranteed (positive weights) when they
    /// are the whole boundary loop placed in order, with the mesh's
    /// orientation, on a convex polygon.
    Given(Vec<(u32, [f64; 2])>),
}

/// A Tutte-style embedding of a disk-topology triangle mesh in the plane:
/// the boundary fixed on a convex curve ([`DiskBoundary`]), every interior
/// vertex the weighted mean of its neighbours ([`TutteWeights`]):
///
/// ```text
/// sum_j w_ij (q_i - q_j) = 0   (interior i),     q_b given   (boundary b)
/// ```
///
/// With mean-value or uniform weights and a convex boundary the map is
/// bijective (Tutte 1963, Floater 2003): no triangle flips. With cotangent
/// weights it is the discrete harmonic map (ALGORITHMS 3.2).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TutteDisk {
    /// Edge weights.
    pub weights: TutteWeights,
    /// Boundary positions.
    pub boundary: DiskBoundary,
}

/// Places a boundary loop on the unit circle by cumulative edge length:
/// with `s_k = sum_{m < k} |p_{l_{m+1}} - p_{l_m}|` and `S` the loop's
/// total length (closing edge included), vertex `l_k` goes to
/// `(cos t_k, sin t_k)`, `t_k = 2 pi s_k / S` (so `l_0` is at `(1, 0)` and
/// the loop runs counter-clockwise in its given order).
///
/// # Errors
/// [`ParamError::LoopTooShort`] for fewer than 3 loop vertices,
/// [`ParamError::PinOutOfRange`] for an index out of range,
/// [`ParamError::LoopLength`] for a loop of zero (or non-finite) length.
pub fn circle_boundary(
    positions: &[Point3<f64>],
    boundary: &[u32],
) -> Result<Vec<(u32, [f64; 2])>, ParamError> {
    let m = boundary.len();
    if m < 3 {
        return Err(ParamError::LoopTooShort { found: m });
    }
    if let Some(&v) = boundary.iter().find(|&&v| v as usize >= positions.len()) {
        return Err(ParamError::PinOutOfRange {
            vertex: v,
            vertices: positions.len(),
        });
    }
    let mut s = Vec::with_capacity(m);
    let mut total = 0.0;
    for k in 0..m {
        s.push(total);
        let (a, b) = (boundary[k], boundary[(k + 1) % m]);
        total += (positions[b as usize] - positions[a as usize]).norm();
    }
    if !(total > 0.0 && total.is_finite()) {
        return Err(ParamError::LoopLength { length: total });
    }
    Ok(boundary
        .iter()
        .zip(s)
        .map(|(&v, sk)| {
            let t = std::f64::consts::TAU * sk / total;
            (v, [t.cos(), t.sin()])
        })
        .collect())
}

impl TutteDisk {
    /// Mean-value weights, circle boundary (the default).
    pub fn mean_value() -> Self {
        TutteDisk::default()
    }

    /// The harmonic (cotangent) map onto the unit disk (ALGORITHMS 3.2).
    pub fn harmonic() -> Self {
        TutteDisk {
            weights: TutteWeights::Cotangent,
            boundary: DiskBoundary::Circle,
        }
    }

    /// The planar positions `q_i` of every vertex (no flip check: with
    /// cotangent weights some triangles may flip). Vertices used by no
    /// triangle are put at the origin.
    ///
    /// # Errors
    /// Not a disk ([`disk_boundary_loop`]); [`ParamError::PinOutOfRange`] and the other pin errors for given
    /// boundary vertices out of range, listed twice, unused by any triangle
    /// or not finite; the errors of the solves.
    pub fn layout(&self, mesh: &TriMesh) -> Result<Vec<[f64; 2]>, ParamError> {
        unfold_mesh::geometry::check_finite(&mesh.positions)?;
        let n = mesh.num_vertices();
        let boundary = disk_boundary_loop(mesh)?;
        let mut fixed_pos: Vec<(u32, [f64; 2])> = match &self.boundary {
            DiskBoundary::Circle => circle_boundary(&mesh.positions, &boundary)?,
            DiskBoundary::Given(given) => given.clone(),
        };
        let mut used = vec![false; n];
        for t in &mesh.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let mut is_fixed = vec![false; n];
        for &(v, q) in &fixed_pos {
            let vi = v as usize;
            if vi >= n {
                return Err(ParamError::PinOutOfRange {
                    vertex: v,
                    vertices: n,
                });
            }
            if is_fixed[vi] {
                return Err(ParamError::PinRepeated { vertex: v });
            }
            if !used[vi] {
                return Err(ParamError::PinUnused { vertex: v });
            }
            if !(q[0].is_finite() && q[1].is_finite()) {
                return Err(ParamError::PinNotFinite { vertex: v });
            }
            is_fixed[vi] = true;
        }
        if fixed_pos.is_empty() {
            return Err(ParamError::NoPins {
                piece: "disk boundary",
            });
        }
        // Unused vertices: fixed at the origin (they touch no triangle).
        for (v, &u) in used.iter().enumerate() {
            if !u {
                fixed_pos.push((v as u32, [0.0, 0.0]));
            }
        }
        let fixed: Vec<u32> = fixed_pos.iter().map(|e| e.0).collect();
        let values = vec![
            fixed_pos.iter().map(|e| e.1[0]).collect::<Vec<f64>>(),
            fixed_pos.iter().map(|e| e.1[1]).collect::<Vec<f64>>(),
        ];
        let cols = match self.weights {
            TutteWeights::MeanValue => {
                solve_dirichlet_weights(&mean_value_weights(mesh), &fixed, &values)?
            }
            TutteWeights::Cotangent => solve_dirichlet(&cotan_laplacian(mesh), &fixed, &values)?,
            TutteWeights::Uniform => solve_dirichlet(&uniform_laplacian(mesh), &fixed, &values)?,
        };
        Ok((0..n).map(|i| [cols[0][i], cols[1][i]]).collect())
    }
}

impl Initializer for TutteDisk {
    fn name(&self) -> &'static str {
        match self.weights {
            TutteWeights::MeanValue => "tutte-mean-value",
            TutteWeights::Cotangent => "tutte-cotangent",
            TutteWeights::Uniform => "tutte-uniform",
        }
    }

    /// [`TutteDisk::layout`] flattened (`n * 2`), checked with
    /// [`check_no_flips`]. Pins, when given, are the boundary positions
    /// ([`DiskBoundary::Given`], in place of `self.boundary`).
    ///
    /// # Errors
    /// [`ParamError::WrongElements`] for a tet mesh; those of
    /// [`TutteDisk::layout`]; [`ParamError::InvertedStart`] when a triangle
    /// flips (possible with cotangent weights on non-Delaunay meshes, or a
    /// non-convex boundary).
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        let tris = mesh.triangles("Tutte disk initializer")?;
        let tri_mesh = TriMesh::new(mesh.rest.clone(), tris.to_vec());
        let embedding = if constraints.pins.is_empty() {
            self.layout(&tri_mesh)?
        } else {
            TutteDisk {
                weights: self.weights,
                boundary: DiskBoundary::Given(
                    constraints
                        .pins
                        .iter()
                        .map(|p| (p.vertex, [p.position[0], p.position[1]]))
                        .collect(),
                ),
            }
            .layout(&tri_mesh)?
        };
        let x: Vec<f64> = embedding.iter().flatten().copied().collect();
        check_no_flips(mesh, &x)?;
        Ok(InitialMap::new(x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};
    use proptest::prelude::*;
    use unfold_linalg::test_support::{
        Rng, boundary_mask, lift, orient2, perturbed_grid, random_disk,
    };
    use unfold_mesh::TetMesh;
    use unfold_mesh::shapes::primitives::{grid_disk, uv_sphere};

    /// Every mapped triangle has positive signed area.
    fn assert_flip_free(mesh: &ParamMesh, x: &[f64]) -> Result<(), TestCaseError> {
        let tris = mesh.triangles("test").unwrap();
        for t in tris {
            let q = t.map(|v| Point3::new(x[2 * v as usize], x[2 * v as usize + 1], 0.0));
            prop_assert!(orient2(&q[0], &q[1], &q[2]) > 0.0);
        }
        prop_assert!(check_no_flips(mesh, x).is_ok());
        Ok(())
    }

    fn reversed(m: &TriMesh) -> TriMesh {
        TriMesh::new(
            m.positions.clone(),
            m.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect(),
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The acceptance criterion: Tutte with mean-value weights and a
        /// convex boundary is flip-free (perturbed, sheared grid disks with
        /// random diagonals, lifted to curved surfaces).
        #[test]
        fn tutte_mean_value_is_flip_free_on_perturbed_grid_disks(
            seed in any::<u64>(), nx in 2usize..12, ny in 2usize..12,
            shear in -1.5..1.5f64, amplitude in 0.0..2.0f64,
        ) {
            let mut rng = Rng(seed);
            let mut m = perturbed_grid(nx, ny, shear, &mut rng);
            lift(&mut m, amplitude);
            let pm = ParamMesh::from_triangles(&m).unwrap();
            let x = TutteDisk::mean_value().initialize(&pm, &Constraints::default()).unwrap().x;
            assert_flip_free(&pm, &x)?;
            // Boundary on the unit circle, interior strictly inside.
            let bnd = boundary_mask(&m);
            for (i, q) in x.chunks(2).enumerate() {
                let r = q[0].hypot(q[1]);
                if bnd[i] {
                    prop_assert!((r - 1.0).abs() < 1e-12);
                } else {
                    prop_assert!(r < 1.0);
                }
            }
        }

        /// Same on random triangulated disks (non-convex star boundary,
        /// random splits: thin obtuse triangles, random flips: non-Delaunay),
        /// in both orientations.
        #[test]
        fn tutte_mean_value_is_flip_free_on_random_disks(
            seed in any::<u64>(), boundary in 3usize..30, splits in 0usize..80,
            flips in 0usize..80, amplitude in 0.0..2.0f64,
        ) {
            let mut rng = Rng(seed);
            let mut m = random_disk(&mut rng, boundary, splits, flips);
            lift(&mut m, amplitude);
            for mesh in [m.clone(), reversed(&m)] {
                let pm = ParamMesh::from_triangles(&mesh).unwrap();
                let x = TutteDisk::mean_value().initialize(&pm, &Constraints::default()).unwrap().x;
                assert_flip_free(&pm, &x)?;
            }
            // Uniform weights are positive too.
            let pm = ParamMesh::from_triangles(&m).unwrap();
            let tutte = TutteDisk { weights: TutteWeights::Uniform, boundary: DiskBoundary::Circle };
            let x = tutte.initialize(&pm, &Constraints::default()).unwrap().x;
            assert_flip_free(&pm, &x)?;
            // Cotangent weights may flip here (and, being partly negative, break
            // the maximum principle): only check the solve runs.
            let q = TutteDisk::harmonic().layout(&m).unwrap();
            prop_assert!(q.iter().flatten().all(|v| v.is_finite()));
        }



    }

    #[test]
    fn tutte_mean_value_is_flip_free_on_larger_disks() {
        for seed in 0..4 {
            let mut rng = Rng(seed);
            let mut grid = perturbed_grid(40, 30, 1.2, &mut rng);
            lift(&mut grid, 1.5);
            let mut disk = random_disk(&mut rng, 60, 600, 600);
            lift(&mut disk, 1.0);
            for m in [grid, disk] {
                let pm = ParamMesh::from_triangles(&m).unwrap();
                let x = TutteDisk::mean_value()
                    .initialize(&pm, &Constraints::default())
                    .unwrap()
                    .x;
                assert_flip_free(&pm, &x).unwrap();
            }
        }
    }

    #[test]
    fn circle_boundary_is_arc_length_parameterized_from_the_first_loop_vertex() {
        // A 2 x 1 rectangle: loop 0 -> 1 -> 2 -> 5 -> 4 -> 3 (perimeter 6).
        let m = grid_disk(2, 1);
        let lp = disk_boundary_loop(&m).unwrap();
        assert_eq!(lp, vec![0, 1, 2, 5, 4, 3]);
        let c = circle_boundary(&m.positions, &lp).unwrap();
        for (k, (v, q)) in c.iter().enumerate() {
            assert_eq!(*v, lp[k]);
            let t = std::f64::consts::TAU * k as f64 / 6.0;
            assert!((q[0] - t.cos()).abs() < 1e-12 && (q[1] - t.sin()).abs() < 1e-12);
        }
        assert!(circle_boundary(&m.positions, &lp[..2]).is_err());
        assert!(circle_boundary(&m.positions, &[0, 1, 99]).is_err());
        let same = vec![Point3::origin(); 3];
        assert!(circle_boundary(&same, &[0, 1, 2]).is_err());
    }

    #[test]
    fn given_planar_boundary_with_mean_value_weights_reproduces_a_planar_mesh() {
        // Linear precision of mean-value coordinates in the plane.
        let m = perturbed_grid(7, 5, 0.6, &mut Rng(11));
        let lp = disk_boundary_loop(&m).unwrap();
        let given: Vec<(u32, [f64; 2])> = lp
            .iter()
            .map(|&v| (v, [m.positions[v as usize].x, m.positions[v as usize].y]))
            .collect();
        let tutte = TutteDisk {
            weights: TutteWeights::MeanValue,
            boundary: DiskBoundary::Given(given.clone()),
        };
        let q = tutte.layout(&m).unwrap();
        for (p, q) in m.positions.iter().zip(&q) {
            assert!((p.x - q[0]).abs() < 1e-10 && (p.y - q[1]).abs() < 1e-10);
        }
        let pm = ParamMesh::from_triangles(&m).unwrap();
        assert!(tutte.initialize(&pm, &Constraints::default()).is_ok());
        // Bad given boundaries.
        let bad = |g: Vec<(u32, [f64; 2])>| {
            TutteDisk {
                weights: TutteWeights::MeanValue,
                boundary: DiskBoundary::Given(g),
            }
            .layout(&m)
        };
        assert!(bad(vec![]).is_err());
        assert!(bad(vec![(1000, [0.0, 0.0])]).is_err());
        assert!(bad(vec![(0, [0.0, 0.0]), (0, [1.0, 0.0])]).is_err());
        assert!(bad(vec![(0, [f64::NAN, 0.0])]).is_err());
        // A reflected boundary inverts every triangle: initialize refuses.
        let mirrored: Vec<(u32, [f64; 2])> =
            given.iter().map(|&(v, q)| (v, [-q[0], q[1]])).collect();
        let err = TutteDisk {
            weights: TutteWeights::MeanValue,
            boundary: DiskBoundary::Given(mirrored),
        }
        .initialize(&pm, &Constraints::default())
        .unwrap_err();
        assert!(matches!(err, ParamError::InvertedStart { .. }));
    }

    #[test]
    fn cotangent_tutte_on_a_delaunay_grid_is_the_harmonic_map() {
        // grid_disk: right triangles, Delaunay; the harmonic map is fine.
        let m = grid_disk(6, 6);
        let pm = ParamMesh::from_triangles(&m).unwrap();
        let x = TutteDisk::harmonic()
            .initialize(&pm, &Constraints::default())
            .unwrap()
            .x;
        // Symmetric square -> the centre vertex maps to the disk's centre
        // only up to the boundary parameterization; it is inside the disk.
        let c = 3 + 7 * 3;
        assert!(x[2 * c].hypot(x[2 * c + 1]) < 0.5);
        // L x = 0 on interior rows.
        let l = unfold_linalg::laplacian::cotan_laplacian(&m);
        let bnd = boundary_mask(&m);
        for k in 0..2 {
            let col: Vec<f64> = x.chunks(2).map(|q| q[k]).collect();
            for (i, r) in l.multiply(&col).iter().enumerate() {
                if !bnd[i] {
                    assert!(r.abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn tutte_rejects_meshes_that_are_not_disks() {
        let tutte = TutteDisk::mean_value();
        // Closed.
        let err = tutte.layout(&uv_sphere(6, 8, 1.0)).unwrap_err();
        assert!(err.to_string().contains("closed"), "{err}");
        // Two boundary loops: an annulus (grid with the middle square removed).
        let mut ann = grid_disk(3, 3);
        ann.triangles.retain(|t| {
            let c = t.map(|v| v as usize);
            !(c.iter().all(|&v| matches!(v, 5 | 6 | 9 | 10)))
        });
        let err = tutte.layout(&ann).unwrap_err();
        assert!(err.to_string().contains("2 boundary loops"), "{err}");
        // Two components.
        let a = grid_disk(1, 1);
        let mut two = a.clone();
        two.positions
            .extend(a.positions.iter().map(|p| p + Vector3::new(5.0, 0.0, 0.0)));
        two.triangles
            .extend(a.triangles.iter().map(|t| t.map(|v| v + 4)));
        let err = tutte.layout(&two).unwrap_err();
        assert!(err.to_string().contains("components"), "{err}");
        // Empty.
        assert!(tutte.layout(&TriMesh::default()).is_err());
        let _ = TetMesh::default();
    }

    #[test]
    fn unused_vertices_go_to_the_origin() {
        let mut m = grid_disk(2, 2);
        m.positions.push(Point3::new(9.0, 9.0, 9.0));
        let q = TutteDisk::mean_value().layout(&m).unwrap();
        assert_eq!(q[9], [0.0, 0.0]);
        let pm = ParamMesh::from_triangles(&m).unwrap();
        assert!(
            TutteDisk::mean_value()
                .initialize(&pm, &Constraints::default())
                .is_ok()
        );
        let q = TutteDisk::harmonic().layout(&m).unwrap();
        assert_eq!(q[9], [0.0, 0.0]);
    }
}
