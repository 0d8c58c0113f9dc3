//! Synthetic scanner images around a mesh, for the placenta tests.

use unfold::io::NiftiImage;
use unfold::mesh::nalgebra::{Matrix4, Point3, Vector3};
use unfold::mesh::{TetMesh, Volume};

/// An axis-aligned image with `frames` frames of voxel spacing `spacing`,
/// covering `mesh` with a 6 mm margin, its origin moved by `offset` mm;
/// voxel values `value(world position, frame)`.
pub fn image_around(
    mesh: &TetMesh,
    spacing: [f64; 3],
    frames: usize,
    offset: Vector3<f64>,
    value: impl Fn(&Point3<f64>, usize) -> f64,
) -> NiftiImage {
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(-f64::INFINITY),
    );
    for p in &mesh.positions {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    lo -= Vector3::repeat(6.0);
    hi += Vector3::repeat(6.0);
    let dims: [usize; 3] =
        std::array::from_fn(|a| ((hi[a] - lo[a]) / spacing[a]).ceil() as usize + 1);
    let mut affine = Matrix4::identity();
    for a in 0..3 {
        affine[(a, a)] = spacing[a];
        affine[(a, 3)] = lo[a] + offset[a];
    }
    let mut data = Vec::with_capacity(dims.iter().product::<usize>() * frames);
    for t in 0..frames {
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                    data.push(value(&p, t) as f32);
                }
            }
        }
    }
    let vol = Volume::new([dims[0], dims[1], dims[2], frames], affine, data).expect("volume");
    NiftiImage::new(vol)
}
