//! The flattening map as a displacement field, for registration tools.
//!
//! On a template grid, the pull-back table ([`PullbackTable`]) holds for
//! every voxel centre `p` inside the flattened mesh its source point `z(p)`
//! in the scanner frame. The map template -> scanner is then the
//! displacement field
//!
//! ```text
//! d(p) = z(p) - p        (mm; 0 for voxels outside the mesh)
//! ```
//!
//! so that `z = p + d(p)`: resampling a subject image `I` at `p + d(p)` for
//! every template voxel reproduces the pull-back. This is the convention of
//! ITK's `DisplacementFieldTransform` (and ANTs, SimpleITK): the field lives
//! on the fixed (template) grid and points into the moving (subject) image.
//! ITK's physical space is LPS, and ITK stores displacement vectors in NIfTI
//! files as they are in its physical space (it converts the grid's affine
//! from RAS, not the vectors); [`VectorFrame::Lps`] writes them that way:
//! `(-d_x, -d_y, d_z)` of the RAS vector.

use super::error::PullbackError;
use super::pullback::{PullbackTable, VoxelGrid};
use nalgebra::Point3;
use unfold_mesh::Volume;

/// The frame the displacement vectors' components are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VectorFrame {
    /// RAS (NIfTI world, unfold's frame): `d = z - p`.
    Ras,
    /// LPS (ITK, ANTs, SimpleITK, DICOM): `(-d_x, -d_y, d_z)`. The default,
    /// since displacement files are read by ITK-based tools.
    #[default]
    Lps,
}

/// The displacement field of a pull-back table: a volume on the table's grid
/// (its dims and affine) with 3 frames, the components of `d(p) = z(p) - p`
/// in `frame` (0 outside the mesh).
///
/// # Errors
/// [`PullbackError::Output`] when the grid cannot hold a volume (a grid the
/// table was built on always can).
pub fn displacement_field<G: VoxelGrid>(
    table: &PullbackTable<G>,
    frame: VectorFrame,
) -> Result<Volume<f32>, PullbackError> {
    let grid = table.grid();
    let [nx, ny, nz] = grid.dims();
    let n = nx * ny * nz;
    let sign = match frame {
        VectorFrame::Ras => [1.0, 1.0, 1.0],
        VectorFrame::Lps => [-1.0, -1.0, 1.0],
    };
    let mut data = vec![0.0f32; 3 * n];
    for (&v, z) in table.voxel_indices().iter().zip(table.sources()) {
        let v = v as usize;
        let p: Point3<f64> = grid.centre(v % nx, (v / nx) % ny, v / (nx * ny));
        let d = z - p;
        for a in 0..3 {
            data[a * n + v] = (sign[a] * d[a]) as f32;
        }
    }
    Volume::new([nx, ny, nz, 3], grid.affine(), data).map_err(PullbackError::Output)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::placenta::pullback::TemplateGrid;
    use nalgebra::Vector3;
    use proptest::prelude::*;
    use unfold_mesh::shapes::kuhn_grid;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// For an affine map `z = M x + t` of a box mesh, every voxel inside
        /// the mesh gets `d(p) = M p + t - p`, in RAS; in LPS the first two
        /// components are negated; outside the mesh the field is 0.
        #[test]
        fn the_field_of_an_affine_map_is_affine(
            m in prop::array::uniform9(-0.3f64..0.3),
            t in prop::array::uniform3(-5.0f64..5.0),
        ) {
            let mesh = kuhn_grid([3, 3, 3], [1.0; 3]);
            let mm = nalgebra::Matrix3::from_row_slice(&m) + nalgebra::Matrix3::identity();
            let tv = Vector3::from(t);
            let source: Vec<Point3<f64>> =
                mesh.positions.iter().map(|x| Point3::from(mm * x.coords + tv)).collect();
            let grid = TemplateGrid::covering(&mesh.positions, [0.4; 3]).unwrap();
            let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &source).unwrap();
            let ras = displacement_field(&table, VectorFrame::Ras).unwrap();
            let lps = displacement_field(&table, VectorFrame::Lps).unwrap();
            let n = grid.num_voxels();
            prop_assert_eq!(ras.dims(), [grid.dims[0], grid.dims[1], grid.dims[2], 3]);
            prop_assert!(table.len() > 10);
            let inside: std::collections::HashSet<u32> =
                table.voxel_indices().iter().copied().collect();
            for v in 0..n {
                let [i, j, k] = grid.voxel(v);
                let p = grid.centre(i, j, k);
                let want = if inside.contains(&(v as u32)) {
                    mm * p.coords + tv - p.coords
                } else {
                    Vector3::zeros()
                };
                for a in 0..3 {
                    let r = f64::from(ras.data()[a * n + v]);
                    let l = f64::from(lps.data()[a * n + v]);
                    prop_assert!((r - want[a]).abs() < 1e-4, "{r} vs {}", want[a]);
                    let s = if a < 2 { -1.0 } else { 1.0 };
                    prop_assert_eq!(l, s * r);
                }
            }
        }
    }
}
