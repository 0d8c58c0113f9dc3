//! Rigid alignment to the template frame (ALGORITHMS 2.2 and 2.5 step 5):
//! centre at the vertex centroid, rotate to the principal axes (largest
//! variance -> x, smallest -> z), then, if the fetal side faces down, turn
//! the mesh 180 degrees about x (a rotation, never a reflection).
//!
//! [`PcaAlignment`] is the placenta pipeline's default [`Initializer`]: the
//! aligned rest positions. Whatever initializer starts the pipeline, the
//! report's transform is the rigid motion that best fits its start
//! ([`Alignment::fit`]; for this one, exactly the alignment) followed by
//! the canonical motion applied after the optimization
//! ([`super::canonical`]), so that it maps the input into the frame the
//! flattened mesh is written in.

use super::error::PlacentaError;
use super::side;
use crate::OrganError;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use unfold_mesh::nalgebra::{Matrix3, Matrix4, Point3, Rotation3, Vector3};
use unfold_param::initializer::{Constraints, InitialMap, Initializer, PcaTransform};
use unfold_param::{Elements, ParamError, ParamMesh, RestElements};

/// A rigid transform from the input (scanner) frame to the template frame,
///
/// ```text
/// x = Q (z - c) + m = Q z + t,   t = m - Q c
/// ```
///
/// with `c` the input's vertex centroid, `Q` a proper rotation
/// (`det Q = +1`, so no tet inverts) and `m` the centroid in the template
/// frame (0 for [`align`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// `Q`.
    pub rotation: Rotation3<f64>,
    /// `c`, the input's vertex centroid.
    pub centroid: Point3<f64>,
    /// `m`, where `c` goes.
    pub offset: Vector3<f64>,
}

/// The transform in the report: `x = rotation z + translation`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformReport {
    /// `x_template = rotation * z_input + translation` (mm).
    pub convention: Cow<'static, str>,
    /// `Q`, row-major.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub rotation: [[f64; 3]; 3],
    /// `t = m - Q c`, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub translation: [f64; 3],
    /// The 4x4 homogeneous matrix `[Q t; 0 1]`, row-major.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub matrix: [[f64; 4]; 4],
    /// The vertex centroid `c` of the input, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub centroid: [f64; 3],
}

impl Alignment {
    /// The rotation `Q`.
    pub fn rotation(&self) -> Rotation3<f64> {
        self.rotation
    }

    /// The translation `t = m - Q c`.
    pub fn translation(&self) -> Vector3<f64> {
        self.offset - self.rotation * self.centroid.coords
    }

    /// Template-frame coordinates `Q (z - c) + m` of an input point.
    pub fn apply(&self, z: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * (z - self.centroid) + self.offset)
    }

    /// Input-frame point `c + Q^T (x - m)` of template-frame coordinates.
    pub fn inverse(&self, x: &Point3<f64>) -> Point3<f64> {
        self.centroid + self.rotation.inverse() * (x.coords - self.offset)
    }

    /// The homogeneous matrix `[Q t; 0 1]`.
    pub fn matrix(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(self.rotation.matrix());
        m.fixed_view_mut::<3, 1>(0, 3)
            .copy_from(&self.translation());
        m
    }

    /// This motion followed by `next`: `x'' = Qn (Q (z - c) + m - cn) + mn`,
    /// i.e. rotation `Qn Q`, centroid `c`, offset `Qn (m - cn) + mn`.
    pub fn then(&self, next: &Alignment) -> Alignment {
        Alignment {
            rotation: next.rotation * self.rotation,
            centroid: self.centroid,
            offset: next.rotation * (self.offset - next.centroid.coords) + next.offset,
        }
    }

    /// The transform as written to `report.json`.
    pub fn report(&self) -> TransformReport {
        let q = self.rotation;
        let m = self.matrix();
        let t = self.translation();
        let c = self.centroid;
        TransformReport {
            convention: "x_template = rotation * z_input + translation".into(),
            rotation: std::array::from_fn(|i| std::array::from_fn(|j| q[(i, j)])),
            translation: [t.x, t.y, t.z],
            matrix: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
            centroid: [c.x, c.y, c.z],
        }
    }

    /// The rigid motion that best maps `input` onto `mapped` in least
    /// squares (Kabsch): with centroids `c`, `m` and
    /// `H = sum (z_i - c)(x_i - m)^T = U S V^T`,
    /// `Q = V diag(1, 1, det(V U^T)) U^T`. Exact when `mapped` is a rigid
    /// motion of `input`.
    ///
    /// # Errors
    /// [`PlacentaError::NoRigidFit`] for no points, different counts or
    /// non-finite coordinates.
    pub fn fit(input: &[Point3<f64>], mapped: &[Point3<f64>]) -> Result<Self, PlacentaError> {
        let n = input.len();
        let finite = |p: &Point3<f64>| p.iter().all(|v| v.is_finite());
        if n == 0 || mapped.len() != n || !input.iter().chain(mapped).all(finite) {
            return Err(PlacentaError::NoRigidFit {
                input: n,
                mapped: mapped.len(),
            });
        }
        let centroid = |ps: &[Point3<f64>]| {
            Point3::from(ps.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n as f64)
        };
        let (c, m) = (centroid(input), centroid(mapped));
        let mut h = Matrix3::zeros();
        for (z, x) in input.iter().zip(mapped) {
            h += (z - c) * (x - m).transpose();
        }
        let svd = h.svd(true, true);
        let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
            return Err(PlacentaError::NoRigidFit {
                input: n,
                mapped: n,
            });
        };
        let v = v_t.transpose();
        let d = (v * u.transpose()).determinant().signum();
        let q = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
        Ok(Alignment {
            rotation: Rotation3::from_matrix_unchecked(q),
            centroid: c,
            offset: m.coords,
        })
    }
}

/// The placenta's default initializer (ALGORITHMS 2.2): the rest positions
/// aligned by [`align`] (PCA frame, fetal side up). It needs the side labels
/// and boundary weights in the [`Constraints`]; pins are not supported.
/// Details: `("fetal side", "turned up")` when the half turn was applied,
/// `("fetal side", "up")` otherwise.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PcaAlignment;

impl Initializer for PcaAlignment {
    fn name(&self) -> &'static str {
        "pca-alignment"
    }

    /// # Errors
    /// [`ParamError::WrongElements`] for a triangle mesh,
    /// [`ParamError::PinsUnsupported`] for pins, [`ParamError::Length`] when
    /// the labels or weights do not cover the vertices, and the alignment's
    /// errors as [`ParamError::Piece`] (a side without weight).
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        if let RestElements::Tris { .. } = mesh.elements {
            return Err(ParamError::WrongElements {
                piece: self.name(),
                needs: Elements::Tets,
                found: Elements::Triangles,
                hint: "",
            });
        }
        if !constraints.pins.is_empty() {
            return Err(ParamError::PinsUnsupported {
                initializer: self.name(),
                pins: constraints.pins.len(),
            });
        }
        let n = mesh.num_vertices();
        for (what, len) in [
            ("side labels", constraints.labels.len()),
            ("boundary weights", constraints.weights.len()),
        ] {
            if len != n {
                return Err(ParamError::Length {
                    what,
                    expected: n,
                    found: len,
                });
            }
        }
        let (alignment, half_turn) =
            align_with_turn(&mesh.rest, constraints.labels, constraints.weights)
                .map_err(|e| ParamError::piece("pca-alignment", e))?;
        let x = mesh
            .rest
            .iter()
            .flat_map(|p| {
                let q = alignment.apply(p);
                [q.x, q.y, q.z]
            })
            .collect();
        let mut start = InitialMap::new(x);
        start
            .details
            .push(("fetal side", if half_turn { "turned up" } else { "up" }));
        Ok(start)
    }
}

/// The alignment of `positions` (input frame) with the fetal side up:
/// after the PCA rotation, the weighted mean z of the fetal vertices
/// (`labels` [`side::FETAL`], weights `weights`) must exceed that of the
/// maternal vertices, else the half turn is applied.
///
/// # Errors
/// `Param` for no points or non-finite coordinates (the PCA fails);
/// [`PlacentaError::SideWithoutArea`] when a side has no weight.
pub fn align(
    positions: &[Point3<f64>],
    labels: &[u8],
    weights: &[f64],
) -> Result<Alignment, OrganError> {
    Ok(align_with_turn(positions, labels, weights)?.0)
}

/// [`align`] and whether the half turn was applied.
fn align_with_turn(
    positions: &[Point3<f64>],
    labels: &[u8],
    weights: &[f64],
) -> Result<(Alignment, bool), OrganError> {
    let pca = PcaTransform::of_points(positions)?;
    let mut mean = [(0.0, 0.0); 2];
    for ((p, &label), &w) in positions.iter().zip(labels).zip(weights) {
        let side = match label {
            side::FETAL => 0,
            side::MATERNAL => 1,
            _ => continue,
        };
        mean[side].0 += w * pca.apply(p).z;
        mean[side].1 += w;
    }
    if mean.iter().any(|&(_, w)| w.is_nan() || w <= 0.0) {
        return Err(PlacentaError::SideWithoutArea {
            fetal_area: mean[0].1,
            maternal_area: mean[1].1,
        }
        .into());
    }
    let fetal_z = mean[0].0 / mean[0].1;
    let maternal_z = mean[1].0 / mean[1].1;
    let half_turn = fetal_z < maternal_z;
    let rotation = if half_turn {
        Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI) * pca.rotation
    } else {
        pca.rotation
    };
    Ok((
        Alignment {
            rotation,
            centroid: pca.centroid,
            offset: Vector3::zeros(),
        },
        half_turn,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::nalgebra::Rotation3;

    /// A flattened cloud: fetal points at z = +2, maternal at z = -2, spread
    /// in x (largest) and y, then rotated and shifted.
    fn cloud(rot: &Rotation3<f64>, shift: Vector3<f64>) -> (Vec<Point3<f64>>, Vec<u8>) {
        let mut pts = Vec::new();
        let mut labels = Vec::new();
        for i in 0..12 {
            for j in 0..6 {
                for (z, l) in [(2.0, side::FETAL), (-2.0, side::MATERNAL)] {
                    let p = Point3::new(i as f64 * 3.0 - 16.5, j as f64 * 2.0 - 5.0, z);
                    pts.push(rot * p + shift);
                    labels.push(l);
                }
            }
        }
        (pts, labels)
    }

    proptest! {
        #[test]
        fn alignment_is_proper_round_trips_and_puts_fetal_up(
            angles in prop::array::uniform3(-3.2..3.2f64),
            shift in prop::array::uniform3(-100.0..100.0f64),
        ) {
            let rot = Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
            let (pts, labels) = cloud(&rot, Vector3::from(shift));
            let w = vec![1.0; pts.len()];
            let a = align(&pts, &labels, &w).unwrap();
            let q = a.rotation();
            prop_assert!((q.matrix().determinant() - 1.0).abs() < 1e-12);
            for (p, &l) in pts.iter().zip(&labels) {
                let x = a.apply(p);
                prop_assert!((a.inverse(&x) - p).norm() < 1e-9);
                // Fetal up, at |z| = 2 (thickness on z).
                let want = if l == side::FETAL { 2.0 } else { -2.0 };
                prop_assert!((x.z - want).abs() < 1e-9, "{} vs {}", x.z, want);
                // The homogeneous matrix agrees with apply().
                let h = a.matrix() * p.to_homogeneous();
                prop_assert!((h.xyz() - x.coords).norm() < 1e-9);
            }
        }
    }

    #[test]
    fn a_side_without_weight_is_an_error() {
        let (pts, mut labels) = cloud(&Rotation3::identity(), Vector3::zeros());
        labels.iter_mut().for_each(|l| *l = side::FETAL);
        let e = align(&pts, &labels, &vec![1.0; pts.len()]).unwrap_err();
        assert!(
            matches!(
                e,
                OrganError::Placenta(PlacentaError::SideWithoutArea { maternal_area, .. })
                    if maternal_area == 0.0
            ),
            "{e}"
        );
        let e = align(&[], &[], &[]).unwrap_err();
        assert!(matches!(e, OrganError::Param(_)), "{e}");
    }
}
