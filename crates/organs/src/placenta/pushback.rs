//! The way back (template -> scanner): a template-space image (an atlas, a
//! label map drawn on the flat template, a cohort mean) resampled onto a
//! subject's scanner grid through the inverse of the flattening map.
//!
//! The flattening map is piecewise linear on the tets, so its inverse is
//! too: for every voxel centre `z` of the scanner grid (the reference
//! image's own grid, any orientation),
//!
//! 1. the tet `k` of the original mesh `Z` containing `z` and its
//!    barycentric coordinates `alpha` (`[a2 a3 a4]^T = Ds^-1 (z - z0)`,
//!    `Ds = [z1 - z0 | z2 - z0 | z3 - z0]`, `a1 = 1 - a2 - a3 - a4`);
//! 2. the template point `x = sum_i alpha_i x_i` (the same combination of
//!    the flattened positions);
//! 3. the template image at `x`, trilinearly or by the nearest voxel.
//!
//! This is [`PullbackTable`] with the roles of the meshes swapped, built on a
//! [`ScannerGrid`]: a voxel outside the original mesh, or whose template
//! point lies outside the template image, gets 0.

use super::error::PullbackError;
use super::pullback::{Interpolation, MAX_VOXELS, PullbackStats, PullbackTable, VoxelGrid, fits};
use nalgebra::{Matrix4, Point3};
use unfold_mesh::Volume;

/// A scanner image's voxel grid: voxel `(i, j, k)` has its centre at
/// `A (i, j, k, 1)^T`, `A` the image's voxel-to-world affine (RAS, mm; any
/// rotation, shear or flip).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScannerGrid {
    /// The voxel-to-world affine `A`.
    pub affine: Matrix4<f64>,
    /// Number of voxels along i, j and k.
    pub dims: [usize; 3],
}

impl ScannerGrid {
    /// The grid of `image` (its first three dimensions and its affine).
    pub fn of(image: &Volume<f32>) -> Self {
        let d = image.dims();
        ScannerGrid {
            affine: *image.affine(),
            dims: [d[0], d[1], d[2]],
        }
    }
}

impl VoxelGrid for ScannerGrid {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn centre(&self, i: usize, j: usize, k: usize) -> Point3<f64> {
        self.affine
            .transform_point(&Point3::new(i as f64, j as f64, k as f64))
    }

    fn affine(&self) -> Matrix4<f64> {
        self.affine
    }

    fn validate(&self) -> Result<(), PullbackError> {
        if !fits(self.dims) {
            return Err(PullbackError::ReferenceGridSize {
                dims: self.dims,
                limit: MAX_VOXELS,
            });
        }
        if !self.affine.iter().all(|x| x.is_finite()) {
            return Err(PullbackError::ReferenceAffine);
        }
        Ok(())
    }
}

/// Resamples `template_image` (template frame) onto the grid of `reference`
/// (a scanner image of the subject) through the inverse of the map
/// `original -> flattened` (same tets).
///
/// Output: dims `[nx, ny, nz, template frames]` of the reference grid, its
/// affine, f32; voxels outside the original mesh and voxels whose template
/// point lies outside `template_image` are 0.
///
/// # Errors
/// As [`PullbackTable::new`] (mismatched or non-finite meshes, a grid of more
/// than [`MAX_VOXELS`] voxels) and [`PullbackTable::apply_with`]
/// ([`PullbackError::EmptyTable`] when no reference voxel centre lies in
/// the mesh, [`PullbackError::NoOverlap`] when no template point falls in
/// the template image).
pub fn push_back(
    original: &[Point3<f64>],
    tets: &[[u32; 4]],
    flattened: &[Point3<f64>],
    reference: &Volume<f32>,
    template_image: &Volume<f32>,
    interpolation: Interpolation,
) -> Result<(Volume<f32>, PullbackStats), PullbackError> {
    let table = PullbackTable::new(ScannerGrid::of(reference), original, tets, flattened)?;
    table.apply_with(template_image, interpolation)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::placenta::pullback::TemplateGrid;
    use nalgebra::{Rotation3, Vector3};
    use proptest::prelude::*;
    use unfold_mesh::shapes::kuhn_grid;

    /// A smooth injective map of the unit-box mesh: a shear and a bend.
    fn bend(p: &Point3<f64>) -> Point3<f64> {
        Point3::new(
            1.3 * p.x + 0.2 * p.y,
            0.9 * p.y + 0.15 * p.x * p.x,
            0.8 * p.z + 0.1 * p.y,
        )
    }

    /// An image on `grid`-like dims with the given affine, values `f`.
    fn image(
        dims: [usize; 3],
        affine: Matrix4<f64>,
        f: impl Fn(&Point3<f64>) -> f64,
    ) -> Volume<f32> {
        let mut data = Vec::with_capacity(dims.iter().product());
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                    data.push(f(&p) as f32);
                }
            }
        }
        Volume::new([dims[0], dims[1], dims[2], 1], affine, data).unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// Pushing back a template image that is an affine function of the
        /// template point, `g(x) = c + b . x`, gives at every scanner voxel
        /// inside the mesh `g(X(z))`, where `X` is the piecewise linear map:
        /// trilinear interpolation reproduces affine functions, so the only
        /// error is round-off. The reference grid is oblique (any rotation).
        #[test]
        fn an_affine_template_image_comes_back_as_its_composition(
            angles in prop::array::uniform3(-3.0f64..3.0),
            b in prop::array::uniform3(-2.0f64..2.0),
        ) {
            let box_mesh = kuhn_grid([4, 4, 4], [0.25; 3]);
            let original: Vec<Point3<f64>> = box_mesh.positions.clone();
            let flattened: Vec<Point3<f64>> = original.iter().map(bend).collect();
            let g = |x: &Point3<f64>| 50.0 + b[0] * x.x + b[1] * x.y + b[2] * x.z;
            let tgrid = TemplateGrid::covering(&flattened, [0.05; 3]).unwrap();
            let d = tgrid.dims;
            let template = image(d, tgrid.affine(), g);
            let r = Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
            let mut affine = Matrix4::identity();
            affine.fixed_view_mut::<3, 3>(0, 0).copy_from(&(r.matrix() * 0.09));
            let origin = Vector3::new(0.5, 0.5, 0.5) - r * Vector3::new(6.0, 6.0, 6.0) * 0.09;
            affine.fixed_view_mut::<3, 1>(0, 3).copy_from(&origin);
            let reference = image([13, 13, 13], affine, |_| 0.0);
            let (out, stats) = push_back(
                &original, &box_mesh.tets, &flattened, &reference, &template,
                Interpolation::Linear,
            ).unwrap();
            prop_assert!(stats.inside_mesh > 100, "{stats:?}");
            prop_assert_eq!(stats.sampled, stats.inside_mesh);
            let table = PullbackTable::new(
                ScannerGrid::of(&reference), &original, &box_mesh.tets, &flattened,
            ).unwrap();
            for (&v, x) in table.voxel_indices().iter().zip(table.sources()) {
                let got = f64::from(out.data()[v as usize]);
                prop_assert!((got - g(x)).abs() < 1e-3, "{got} vs {}", g(x));
                // and x is the image of the voxel centre under the map
                // (the map is exact on vertices; inside a tet it is the
                // barycentric combination, within the bend's curvature)
                let [nx, ny, _] = table.grid().dims;
                let vi = v as usize;
                let z = table.grid().centre(vi % nx, (vi / nx) % ny, vi / (nx * ny));
                prop_assert!((x - bend(&z)).norm() < 0.02, "{x} vs {}", bend(&z));
            }
            // voxels outside the mesh are 0
            let inside: std::collections::HashSet<u32> =
                table.voxel_indices().iter().copied().collect();
            for (i, &val) in out.data().iter().enumerate() {
                if !inside.contains(&(i as u32)) {
                    prop_assert_eq!(val, 0.0);
                }
            }
        }
    }

    #[test]
    fn a_reference_grid_away_from_the_mesh_is_an_error() {
        let m = kuhn_grid([2, 2, 2], [1.0, 1.0, 1.0]);
        let template = image([4, 4, 4], Matrix4::new_scaling(0.5), |_| 1.0);
        let far = image(
            [3, 3, 3],
            Matrix4::new_translation(&Vector3::new(50.0, 0.0, 0.0)),
            |_| 0.0,
        );
        let e = push_back(
            &m.positions,
            &m.tets,
            &m.positions,
            &far,
            &template,
            Interpolation::Nearest,
        )
        .unwrap_err();
        assert!(matches!(e, PullbackError::EmptyTable { .. }), "{e}");
    }
}
