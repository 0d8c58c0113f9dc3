//! Rigid alignment to the template frame (ALGORITHMS 2.2 and 2.5 step 5):
//! centre at the vertex centroid, rotate to the principal axes (largest
//! variance -> x, smallest -> z), then, if the fetal side faces down, turn
//! the mesh 180 degrees about x (a rotation, never a reflection).

use super::error::PlacentaError;
use crate::OrganError;
use serde::Serialize;
use unfold_mesh::nalgebra::{Matrix4, Point3, Rotation3, Vector3};
use unfold_param::initializer::PcaTransform;
use unfold_param::template::{LABEL_FETAL, LABEL_MATERNAL};

/// The rigid transform from the input (scanner) frame to the template
/// frame,
///
/// ```text
/// x = Q (z - c) = Q z + t,   Q = F R,   t = -Q c
/// ```
///
/// with `c` the vertex centroid, `R` the PCA rotation (rows = principal
/// axes by decreasing variance, `det R = +1`) and `F = diag(1, -1, -1)` (the
/// half turn about x) when the fetal side would otherwise face -z, else the
/// identity. `det Q = +1`, so no tet inverts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// The PCA part (`c`, `R`, variances).
    pub pca: PcaTransform,
    /// Whether the half turn `F` about x was applied (fetal side up).
    pub half_turn: bool,
}

/// The transform in the report: `x = rotation z + translation`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TransformReport {
    /// `x_template = rotation * z_input + translation` (mm).
    pub convention: &'static str,
    /// `Q`, row-major.
    pub rotation: [[f64; 3]; 3],
    /// `t = -Q c`, mm.
    pub translation: [f64; 3],
    /// The 4x4 homogeneous matrix `[Q t; 0 1]`, row-major.
    pub matrix: [[f64; 4]; 4],
    /// The vertex centroid `c` of the input, mm.
    pub centroid: [f64; 3],
    /// Whether the fetal side was turned up by a half turn about x.
    pub half_turn: bool,
}

impl Alignment {
    /// The rotation `Q = F R`.
    pub fn rotation(&self) -> Rotation3<f64> {
        if self.half_turn {
            Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI) * self.pca.rotation
        } else {
            self.pca.rotation
        }
    }

    /// The translation `t = -Q c`.
    pub fn translation(&self) -> Vector3<f64> {
        -(self.rotation() * self.pca.centroid.coords)
    }

    /// Template-frame coordinates `Q (z - c)` of an input point.
    pub fn apply(&self, z: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation() * (z - self.pca.centroid))
    }

    /// Input-frame point `c + Q^T x` of template-frame coordinates.
    pub fn inverse(&self, x: &Point3<f64>) -> Point3<f64> {
        self.pca.centroid + self.rotation().inverse() * x.coords
    }

    /// The homogeneous matrix `[Q t; 0 1]`.
    pub fn matrix(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(self.rotation().matrix());
        m.fixed_view_mut::<3, 1>(0, 3)
            .copy_from(&self.translation());
        m
    }

    /// The transform as written to `report.json`.
    pub fn report(&self) -> TransformReport {
        let q = self.rotation();
        let m = self.matrix();
        let t = self.translation();
        let c = self.pca.centroid;
        TransformReport {
            convention: "x_template = rotation * z_input + translation",
            rotation: std::array::from_fn(|i| std::array::from_fn(|j| q[(i, j)])),
            translation: [t.x, t.y, t.z],
            matrix: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
            centroid: [c.x, c.y, c.z],
            half_turn: self.half_turn,
        }
    }
}

/// The alignment of `positions` (input frame) with the fetal side up:
/// after the PCA rotation, the weighted mean z of the fetal vertices
/// (`labels` [`LABEL_FETAL`], weights `weights`) must exceed that of the
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
    let pca = PcaTransform::of_points(positions)?;
    let mut mean = [(0.0, 0.0); 2];
    for ((p, &label), &w) in positions.iter().zip(labels).zip(weights) {
        let side = match label {
            LABEL_FETAL => 0,
            LABEL_MATERNAL => 1,
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
    Ok(Alignment {
        pca,
        half_turn: fetal_z < maternal_z,
    })
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
                for (z, l) in [(2.0, LABEL_FETAL), (-2.0, LABEL_MATERNAL)] {
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
                let want = if l == LABEL_FETAL { 2.0 } else { -2.0 };
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
        labels.iter_mut().for_each(|l| *l = LABEL_FETAL);
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
