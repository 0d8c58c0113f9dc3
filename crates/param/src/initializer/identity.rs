//! The identity map and the identity after PCA alignment (ALGORITHMS 2.2).

use super::{Constraints, InitialMap, Initializer};
use crate::error::Elements;
use crate::flips::check_no_flips;
use crate::{ParamError, ParamMesh, RestElements};
use nalgebra::{Point3, Rotation3, Vector3};

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
    /// [`ParamError::WrongElements`] for a triangle mesh (a map into the
    /// plane has no identity); [`ParamError::PinsUnsupported`] when vertices
    /// are pinned.
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        tets_without_pins(self.name(), mesh, constraints)?;
        Ok(InitialMap::new(mesh.rest_flat()))
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
    /// [`ParamError::PcaUndefined`] for an empty set or non-finite
    /// coordinates.
    pub fn of_points(points: &[Point3<f64>]) -> Result<Self, ParamError> {
        let frame = unfold_mesh::geometry::pca_frame(points).ok_or(ParamError::PcaUndefined {
            points: points.len(),
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
    /// As [`Identity`]; [`ParamError::InvertedStart`] if a tet inverts
    /// (impossible for a valid [`ParamMesh`]: the rotation is proper).
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        tets_without_pins(self.name(), mesh, constraints)?;
        let x = pca_transform(mesh)?.apply_flat(&mesh.rest);
        check_no_flips(mesh, &x)?;
        Ok(InitialMap::new(x))
    }
}

/// Refuses a triangle mesh and pins (the identity has no prescribed
/// positions).
fn tets_without_pins(
    piece: &'static str,
    mesh: &ParamMesh,
    constraints: &Constraints<'_>,
) -> Result<(), ParamError> {
    if let RestElements::Tris { .. } = mesh.elements {
        return Err(ParamError::WrongElements {
            piece,
            needs: Elements::Tets,
            found: Elements::Triangles,
            hint: "; a map into the plane has no identity, use TutteDisk",
        });
    }
    if !constraints.pins.is_empty() {
        return Err(ParamError::PinsUnsupported {
            initializer: piece,
            pins: constraints.pins.len(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flips::jacobian_determinant;
    use crate::initializer::TutteDisk;
    use proptest::prelude::*;
    use unfold_mesh::shapes::primitives::{grid_disk, kuhn_grid};

    proptest! {
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
            let x = PcaIdentity.initialize(&pm, &Constraints::default()).unwrap().x;
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
    fn identity_maps_tets_to_their_rest_positions_and_rejects_triangles() {
        let m = kuhn_grid([2, 2, 2], [1.0, 1.0, 1.0]);
        let pm = ParamMesh::from_tets(&m).unwrap();
        let x = Identity.initialize(&pm, &Constraints::default()).unwrap().x;
        assert_eq!(x, pm.rest_flat());
        assert!(check_no_flips(&pm, &x).is_ok());
        let tri = ParamMesh::from_triangles(&grid_disk(2, 2)).unwrap();
        let none = Constraints::default();
        let err = Identity.initialize(&tri, &none).unwrap_err();
        assert!(err.to_string().contains("TutteDisk"), "{err}");
        assert!(matches!(
            PcaIdentity.initialize(&tri, &none),
            Err(ParamError::WrongElements {
                needs: Elements::Tets,
                ..
            })
        ));
        assert!(matches!(
            TutteDisk::mean_value().initialize(&pm, &none),
            Err(ParamError::WrongElements {
                needs: Elements::Triangles,
                ..
            })
        ));
        let pins = [crate::initializer::Pin {
            vertex: 0,
            position: [0.0; 3],
        }];
        let pinned = Constraints {
            pins: &pins,
            ..Constraints::default()
        };
        assert!(matches!(
            Identity.initialize(&pm, &pinned),
            Err(ParamError::PinsUnsupported { pins: 1, .. })
        ));
        assert_eq!(Identity.name(), "identity");
        assert_eq!(PcaIdentity.name(), "pca-identity");
        assert_eq!(TutteDisk::harmonic().name(), "tutte-cotangent");
    }
}
