//! Initializers: valid (non-inverted) starting maps.

use crate::{ParamError, ParamMesh, RestElements};
use nalgebra::{Matrix2, Matrix3, Point3, Rotation3, Vector3};
use rayon::prelude::*;
use unfold_linalg::{
    cotan_laplacian, mean_value_weights, solve_dirichlet, solve_dirichlet_weights,
    uniform_laplacian,
};
use unfold_mesh::TriMesh;
use unfold_mesh::topology::{boundary_loops, connected_components, euler_characteristic};

/// Produces a starting map for a [`ParamMesh`]: a flat vector of
/// `mesh.dim()` coordinates per vertex in which no element is inverted.
pub trait Initializer: Send + Sync + std::fmt::Debug {
    /// A short name.
    fn name(&self) -> &'static str;
    /// The starting positions.
    fn initialize(&self, mesh: &ParamMesh) -> Result<Vec<f64>, ParamError>;
}

// ---------------------------------------------------------------------------
// Flip check
// ---------------------------------------------------------------------------

/// `det J` of element `e` under the map `x` (flat, `mesh.dim()` coordinates
/// per vertex): `det(Ds) det(Dm^-1)`, with `Ds` the mapped edge matrix
/// (ALGORITHMS 1.1). For a triangle this is the signed area of the mapped
/// triangle over its rest area, for a tet the signed mapped volume over the
/// rest volume. Positive when the element keeps its orientation.
///
/// # Panics
/// If `e` is out of range or `x` is too short.
pub fn jacobian_determinant(mesh: &ParamMesh, x: &[f64], e: usize) -> f64 {
    match &mesh.elements {
        RestElements::Tets { tets, dm_inv } => {
            let t = tets[e];
            let p = |k: usize| {
                let v = t[k] as usize * 3;
                Vector3::new(x[v], x[v + 1], x[v + 2])
            };
            let p0 = p(0);
            let ds = Matrix3::from_columns(&[p(1) - p0, p(2) - p0, p(3) - p0]);
            ds.determinant() * dm_inv[e].determinant()
        }
        RestElements::Tris { tris, dm_inv } => {
            let t = tris[e];
            let p = |k: usize| {
                let v = t[k] as usize * 2;
                [x[v], x[v + 1]]
            };
            let (a, b, c) = (p(0), p(1), p(2));
            let ds = Matrix2::new(b[0] - a[0], c[0] - a[0], b[1] - a[1], c[1] - a[1]);
            ds.determinant() * dm_inv[e].determinant()
        }
    }
}

/// Checks that the map `x` (flat, `mesh.dim()` coordinates per vertex)
/// inverts no element: `det J > 0` for every element (2D: positive signed
/// area of the mapped triangle; 3D: positive signed volume of the mapped
/// tet; see [`jacobian_determinant`]).
///
/// # Errors
/// `Length` when `x.len() != dim * n`; [`ParamError::InvertedStart`] for the
/// first (lowest-index) element with `det J <= 0` (or NaN).
pub fn check_no_flips(mesh: &ParamMesh, x: &[f64]) -> Result<(), ParamError> {
    let expected = mesh.dim() * mesh.num_vertices();
    if x.len() != expected {
        return Err(ParamError::Length {
            what: "mapped positions",
            expected,
            found: x.len(),
        });
    }
    let bad = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| (e, jacobian_determinant(mesh, x, e)))
        .find_first(|&(_, det)| det.is_nan() || det <= 0.0);
    match bad {
        None => Ok(()),
        Some((element, det)) => Err(ParamError::InvertedStart { element, det }),
    }
}

// ---------------------------------------------------------------------------
// Identity and PCA alignment
// ---------------------------------------------------------------------------

/// The identity map `x_i = z_i` (rest positions, flat `n * 3`) of a tet
/// mesh. There is no identity into the plane: for a triangle mesh it fails
/// (use [`TutteDisk`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Identity;

impl Initializer for Identity {
    fn name(&self) -> &'static str {
        "identity"
    }

    /// # Errors
    /// `InvalidArgument` for a triangle mesh.
    fn initialize(&self, mesh: &ParamMesh) -> Result<Vec<f64>, ParamError> {
        match mesh.elements {
            RestElements::Tets { .. } => Ok(mesh.rest_flat()),
            RestElements::Tris { .. } => Err(ParamError::InvalidArgument(
                "identity initializer: a triangle mesh mapped to the plane has no identity \
                 map (3D positions cannot be 2D coordinates); use TutteDisk"
                    .into(),
            )),
        }
    }
}

/// The rigid alignment of ALGORITHMS 2.2: centre at the vertex centroid `c`
/// and rotate to the principal axes,
///
/// ```text
/// x = R (z - c),     z = c + R^T x
/// ```
///
/// with the rows of `R` the principal axes by decreasing variance (largest
/// -> x, smallest -> z) and `det R = +1` (a proper rotation, so no tet
/// inverts). Keep it to report results or sample images in the original
/// (scanner) frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcaTransform {
    /// The vertex centroid `c` (maps to the origin).
    pub centroid: Point3<f64>,
    /// The rotation `R` (rows = principal axes, `det = +1`).
    pub rotation: Rotation3<f64>,
    /// Variances along the new x, y, z (decreasing).
    pub variances: [f64; 3],
}

impl PcaTransform {
    /// The PCA alignment of a point set (`unfold_mesh::geometry::pca_frame`).
    ///
    /// # Errors
    /// `InvalidArgument` for an empty set or non-finite coordinates.
    pub fn of_points(points: &[Point3<f64>]) -> Result<Self, ParamError> {
        let frame = unfold_mesh::geometry::pca_frame(points).ok_or_else(|| {
            ParamError::InvalidArgument(
                "PCA alignment: no points, or a coordinate is not finite".into(),
            )
        })?;
        Ok(PcaTransform {
            centroid: frame.centroid,
            rotation: frame.rotation,
            variances: frame.variances,
        })
    }

    /// The translation `t = -R c`, so that `x = R z + t`.
    pub fn translation(&self) -> Vector3<f64> {
        -(self.rotation * self.centroid.coords)
    }

    /// Aligned coordinates `R (z - c)` of an original point.
    pub fn apply(&self, z: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * (z - self.centroid))
    }

    /// Original position `c + R^T x` of aligned coordinates.
    pub fn inverse(&self, x: &Point3<f64>) -> Point3<f64> {
        self.centroid + self.rotation.inverse() * x.coords
    }

    /// [`Self::apply`] to every point, flattened (`n * 3`).
    pub fn apply_flat(&self, points: &[Point3<f64>]) -> Vec<f64> {
        points
            .iter()
            .flat_map(|p| {
                let q = self.apply(p);
                [q.x, q.y, q.z]
            })
            .collect()
    }

    /// [`Self::inverse`] of flat aligned coordinates (`n * 3`).
    ///
    /// # Errors
    /// `Length` when `x.len()` is not a multiple of 3.
    pub fn inverse_flat(&self, x: &[f64]) -> Result<Vec<Point3<f64>>, ParamError> {
        if !x.len().is_multiple_of(3) {
            return Err(ParamError::Length {
                what: "flat 3D positions",
                expected: x.len() / 3 * 3,
                found: x.len(),
            });
        }
        Ok(x.chunks_exact(3)
            .map(|c| self.inverse(&Point3::new(c[0], c[1], c[2])))
            .collect())
    }
}

/// The PCA alignment ([`PcaTransform`]) of a mesh's rest vertices.
///
/// # Errors
/// As [`PcaTransform::of_points`].
pub fn pca_transform(mesh: &ParamMesh) -> Result<PcaTransform, ParamError> {
    PcaTransform::of_points(&mesh.rest)
}

/// The identity after PCA alignment (ALGORITHMS 2.2, the placenta's
/// initialization): `x_i = R (z_i - c)` with [`pca_transform`]. Tet meshes
/// only. Recover the transform with [`pca_transform`] to map results back.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PcaIdentity;

impl Initializer for PcaIdentity {
    fn name(&self) -> &'static str {
        "pca-identity"
    }

    /// # Errors
    /// `InvalidArgument` for a triangle mesh; `InvertedStart` if a tet
    /// inverts (impossible for a valid [`ParamMesh`]: the rotation is
    /// proper).
    fn initialize(&self, mesh: &ParamMesh) -> Result<Vec<f64>, ParamError> {
        if !matches!(mesh.elements, RestElements::Tets { .. }) {
            return Err(ParamError::InvalidArgument(
                "pca-identity initializer: tet meshes only (a triangle mesh needs a 2D \
                 initializer such as TutteDisk)"
                    .into(),
            ));
        }
        let x = pca_transform(mesh)?.apply_flat(&mesh.rest);
        check_no_flips(mesh, &x)?;
        Ok(x)
    }
}

// ---------------------------------------------------------------------------
// Tutte / harmonic disk embedding
// ---------------------------------------------------------------------------

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

/// The boundary loop of a disk-topology triangle mesh: the mesh must be
/// connected, have exactly one boundary loop and Euler characteristic
/// `V - E + F = 1`.
///
/// # Errors
/// `InvalidArgument` naming what is wrong (closed surface, several loops,
/// several components, handles), or the mesh error of
/// [`boundary_loops`] (non-manifold boundary).
pub fn disk_boundary_loop(mesh: &TriMesh) -> Result<Vec<u32>, ParamError> {
    if mesh.triangles.is_empty() {
        return Err(unfold_mesh::MeshError::Empty { what: "triangles" }.into());
    }
    unfold_mesh::geometry::check_indices(mesh.num_vertices(), &mesh.triangles)?;
    let components = connected_components(mesh.num_vertices(), &mesh.triangles);
    if components.count != 1 {
        return Err(ParamError::InvalidArgument(format!(
            "disk embedding: the mesh has {} connected components, expected 1",
            components.count
        )));
    }
    let mut loops = boundary_loops(mesh)?;
    if loops.len() != 1 {
        return Err(ParamError::InvalidArgument(if loops.is_empty() {
            "disk embedding: the mesh is closed (no boundary loop); cut it open first".into()
        } else {
            format!(
                "disk embedding: the mesh has {} boundary loops (lengths {:?}), expected \
                 exactly 1 (disk topology); fill the holes first",
                loops.len(),
                loops.iter().map(Vec::len).collect::<Vec<_>>()
            )
        }));
    }
    let chi = euler_characteristic(mesh);
    if chi != 1 {
        return Err(ParamError::InvalidArgument(format!(
            "disk embedding: Euler characteristic {chi}, expected 1 for a disk \
             (the surface has handles)"
        )));
    }
    Ok(loops.swap_remove(0))
}

/// Places a boundary loop on the unit circle by cumulative edge length:
/// with `s_k = sum_{m < k} |p_{l_{m+1}} - p_{l_m}|` and `S` the loop's
/// total length (closing edge included), vertex `l_k` goes to
/// `(cos t_k, sin t_k)`, `t_k = 2 pi s_k / S` (so `l_0` is at `(1, 0)` and
/// the loop runs counter-clockwise in its given order).
///
/// # Errors
/// `InvalidArgument` for fewer than 3 loop vertices, an index out of range
/// or a loop of zero (or non-finite) length.
pub fn circle_boundary(
    positions: &[Point3<f64>],
    boundary: &[u32],
) -> Result<Vec<(u32, [f64; 2])>, ParamError> {
    let m = boundary.len();
    if m < 3 {
        return Err(ParamError::InvalidArgument(format!(
            "circle boundary: a loop needs at least 3 vertices, got {m}"
        )));
    }
    if let Some(&v) = boundary.iter().find(|&&v| v as usize >= positions.len()) {
        return Err(ParamError::InvalidArgument(format!(
            "circle boundary: vertex {v} out of range ({} vertices)",
            positions.len()
        )));
    }
    let mut s = Vec::with_capacity(m);
    let mut total = 0.0;
    for k in 0..m {
        s.push(total);
        let (a, b) = (boundary[k], boundary[(k + 1) % m]);
        total += (positions[b as usize] - positions[a as usize]).norm();
    }
    if !(total > 0.0 && total.is_finite()) {
        return Err(ParamError::InvalidArgument(format!(
            "circle boundary: the loop has length {total}"
        )));
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
    /// Not a disk ([`disk_boundary_loop`]); `InvalidArgument` for given
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
                return Err(ParamError::InvalidArgument(format!(
                    "disk boundary: vertex {v} out of range ({n} vertices)"
                )));
            }
            if is_fixed[vi] {
                return Err(ParamError::InvalidArgument(format!(
                    "disk boundary: vertex {v} given twice"
                )));
            }
            if !used[vi] {
                return Err(ParamError::InvalidArgument(format!(
                    "disk boundary: vertex {v} is used by no triangle"
                )));
            }
            if !(q[0].is_finite() && q[1].is_finite()) {
                return Err(ParamError::NotFinite(format!(
                    "disk boundary position of vertex {v}"
                )));
            }
            is_fixed[vi] = true;
        }
        if fixed_pos.is_empty() {
            return Err(ParamError::InvalidArgument(
                "disk boundary: no fixed vertex given".into(),
            ));
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
    /// [`check_no_flips`].
    ///
    /// # Errors
    /// `InvalidArgument` for a tet mesh; those of [`TutteDisk::layout`];
    /// `InvertedStart` when a triangle flips (possible with cotangent
    /// weights on non-Delaunay meshes, or a non-convex given boundary).
    fn initialize(&self, mesh: &ParamMesh) -> Result<Vec<f64>, ParamError> {
        let RestElements::Tris { tris, .. } = &mesh.elements else {
            return Err(ParamError::InvalidArgument(
                "Tutte disk initializer: triangle meshes only".into(),
            ));
        };
        let tri_mesh = TriMesh::new(mesh.rest.clone(), tris.clone());
        let q = self.layout(&tri_mesh)?;
        let x: Vec<f64> = q.iter().flatten().copied().collect();
        check_no_flips(mesh, &x)?;
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Rotation3, Vector3};
    use proptest::prelude::*;
    use unfold_linalg::test_support::{
        Rng, boundary_mask, lift, orient2, perturbed_grid, random_disk,
    };
    use unfold_mesh::TetMesh;
    use unfold_mesh::shapes::primitives::{grid_disk, kuhn_grid, uv_sphere};

    /// Every mapped triangle has positive signed area.
    fn assert_flip_free(mesh: &ParamMesh, x: &[f64]) -> Result<(), TestCaseError> {
        let RestElements::Tris { tris, .. } = &mesh.elements else {
            unreachable!()
        };
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
            let x = TutteDisk::mean_value().initialize(&pm).unwrap();
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
                let x = TutteDisk::mean_value().initialize(&pm).unwrap();
                assert_flip_free(&pm, &x)?;
            }
            // Uniform weights are positive too.
            let pm = ParamMesh::from_triangles(&m).unwrap();
            let tutte = TutteDisk { weights: TutteWeights::Uniform, boundary: DiskBoundary::Circle };
            let x = tutte.initialize(&pm).unwrap();
            assert_flip_free(&pm, &x)?;
            // Cotangent weights may flip here (and, being partly negative, break
            // the maximum principle): only check the solve runs.
            let q = TutteDisk::harmonic().layout(&m).unwrap();
            prop_assert!(q.iter().flatten().all(|v| v.is_finite()));
        }

        #[test]
        fn pca_identity_is_a_proper_rotation_without_inverted_tets(
            angles in prop::array::uniform3(-3.2..3.2f64),
            shift in prop::array::uniform3(-50.0..50.0f64),
        ) {
            // A 4 x 3 x 1 box (distinct variances), rotated and moved.
            let mut m = kuhn_grid([4, 3, 1], [2.0, 1.5, 1.0]);
            let r = Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
            for p in &mut m.positions {
                *p = Point3::from(r * p.coords + Vector3::from(shift));
            }
            let pm = ParamMesh::from_tets(&m).unwrap();
            let x = PcaIdentity.initialize(&pm).unwrap();
            let t = pca_transform(&pm).unwrap();
            prop_assert!((t.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
            prop_assert!(check_no_flips(&pm, &x).is_ok());
            let n = m.num_vertices() as f64;
            let mut mean = Vector3::zeros();
            let mut var = Vector3::zeros();
            for c in x.chunks(3) {
                mean += Vector3::new(c[0], c[1], c[2]);
                var += Vector3::new(c[0] * c[0], c[1] * c[1], c[2] * c[2]);
            }
            prop_assert!(mean.norm() / n < 1e-10);
            prop_assert!(var.x > var.y && var.y > var.z);
            prop_assert!(t.variances[0] >= t.variances[1] && t.variances[1] >= t.variances[2]);
            // Volumes kept; the transform maps back.
            for e in 0..pm.num_elements() {
                let det = jacobian_determinant(&pm, &x, e);
                prop_assert!((det - 1.0).abs() < 1e-9, "tet {} det {}", e, det);
            }
            let back = t.inverse_flat(&x).unwrap();
            for (p, q) in back.iter().zip(&m.positions) {
                prop_assert!((p - q).norm() < 1e-9);
            }
            let moved = t.rotation * m.positions[3].coords + t.translation();
            prop_assert!((moved - Vector3::new(x[9], x[10], x[11])).norm() < 1e-9);
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
                let x = TutteDisk::mean_value().initialize(&pm).unwrap();
                assert_flip_free(&pm, &x).unwrap();
            }
        }
    }

    #[test]
    fn identity_maps_tets_to_their_rest_positions_and_rejects_triangles() {
        let m = kuhn_grid([2, 2, 2], [1.0, 1.0, 1.0]);
        let pm = ParamMesh::from_tets(&m).unwrap();
        let x = Identity.initialize(&pm).unwrap();
        assert_eq!(x, pm.rest_flat());
        assert!(check_no_flips(&pm, &x).is_ok());
        let tri = ParamMesh::from_triangles(&grid_disk(2, 2)).unwrap();
        let err = Identity.initialize(&tri).unwrap_err();
        assert!(err.to_string().contains("TutteDisk"), "{err}");
        assert!(matches!(
            PcaIdentity.initialize(&tri),
            Err(ParamError::InvalidArgument(_))
        ));
        assert!(matches!(
            TutteDisk::mean_value().initialize(&pm),
            Err(ParamError::InvalidArgument(_))
        ));
        assert_eq!(Identity.name(), "identity");
        assert_eq!(PcaIdentity.name(), "pca-identity");
        assert_eq!(TutteDisk::harmonic().name(), "tutte-cotangent");
    }

    #[test]
    fn check_no_flips_reports_the_first_inverted_element() {
        // Triangles.
        let m = grid_disk(3, 3);
        let pm = ParamMesh::from_triangles(&m).unwrap();
        let mut x: Vec<f64> = m.positions.iter().flat_map(|p| [p.x, p.y]).collect();
        assert!(check_no_flips(&pm, &x).is_ok());
        // Push vertex 5 (interior, (1, 1)) across its neighbours.
        x[10] = 2.6;
        x[11] = 2.7;
        let first = (0..pm.num_elements())
            .find(|&e| jacobian_determinant(&pm, &x, e) <= 0.0)
            .unwrap();
        match check_no_flips(&pm, &x) {
            Err(ParamError::InvertedStart { element, det }) => {
                assert_eq!(element, first);
                assert!(det <= 0.0);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            check_no_flips(&pm, &x[1..]),
            Err(ParamError::Length { .. })
        ));
        // A flat (zero-area) triangle counts as inverted; NaN as well.
        let mut y: Vec<f64> = m.positions.iter().flat_map(|p| [p.x, p.y]).collect();
        y[1] = f64::NAN;
        assert!(matches!(
            check_no_flips(&pm, &y),
            Err(ParamError::InvertedStart { .. })
        ));
        // Tets: the identity is fine, a mirror image inverts everything.
        let t = kuhn_grid([1, 1, 1], [1.0, 1.0, 1.0]);
        let pt = ParamMesh::from_tets(&t).unwrap();
        let mut z = pt.rest_flat();
        assert!(check_no_flips(&pt, &z).is_ok());
        for c in z.chunks_mut(3) {
            c[2] = -c[2];
        }
        assert!(matches!(
            check_no_flips(&pt, &z),
            Err(ParamError::InvertedStart { element: 0, det }) if (det + 1.0).abs() < 1e-12
        ));
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
        assert!(tutte.initialize(&pm).is_ok());
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
        .initialize(&pm)
        .unwrap_err();
        assert!(matches!(err, ParamError::InvertedStart { .. }));
    }

    #[test]
    fn cotangent_tutte_on_a_delaunay_grid_is_the_harmonic_map() {
        // grid_disk: right triangles, Delaunay; the harmonic map is fine.
        let m = grid_disk(6, 6);
        let pm = ParamMesh::from_triangles(&m).unwrap();
        let x = TutteDisk::harmonic().initialize(&pm).unwrap();
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
        assert!(TutteDisk::mean_value().initialize(&pm).is_ok());
        let q = TutteDisk::harmonic().layout(&m).unwrap();
        assert_eq!(q[9], [0.0, 0.0]);
    }
}
