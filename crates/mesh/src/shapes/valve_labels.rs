//! A synthetic mitral valve label map ([`valve_labels`]): a saddle-shaped
//! annulus ring and two leaflet slabs below it meeting at a coaptation
//! line, on a grid with any voxel size and a rotated, moved affine (what a
//! 3D echo segmentation gives, built from scratch for tests and demos).

use crate::Volume;
use nalgebra::{Matrix4, Point3, Rotation3, Vector3};

/// The label map's shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValveLabelParams {
    /// Voxel size, mm (isotropic).
    pub voxel_mm: f64,
    /// Annulus radius `R`, mm.
    pub radius_mm: f64,
    /// Saddle height `a`: the ring is `(R cos t, R sin t, a cos 2t)`, mm.
    pub saddle_mm: f64,
    /// Tenting `T`: the leaflets' mid-surface is
    /// `z = a cos(2t) (r/R)^2 - T (1 - (r/R)^2)`, mm.
    pub tenting_mm: f64,
    /// Leaflet thickness along z, mm.
    pub thickness_mm: f64,
    /// Annulus tube radius, mm.
    pub tube_mm: f64,
    /// The coaptation line `y = c`: anterior for `y > c`, posterior below,
    /// mm.
    pub coaptation_y_mm: f64,
    /// Rotation of the valve's frame into the world (the affine's).
    pub rotation: Rotation3<f64>,
    /// World position of voxel `(0, 0, 0)`, mm.
    pub offset: Vector3<f64>,
    /// Labels: annulus, anterior, posterior.
    pub labels: [f32; 3],
}

impl Default for ValveLabelParams {
    /// A 28 mm ring with a 2 mm saddle, 6 mm tenting, 1.5 mm leaflets,
    /// 0.75 mm voxels, labels 1 (annulus), 2 (anterior), 3 (posterior),
    /// rotated by 30 degrees about x and 20 about z and moved.
    fn default() -> Self {
        ValveLabelParams {
            voxel_mm: 0.75,
            radius_mm: 14.0,
            saddle_mm: 2.0,
            tenting_mm: 6.0,
            thickness_mm: 1.5,
            tube_mm: 1.2,
            coaptation_y_mm: -4.0,
            rotation: Rotation3::from_euler_angles(std::f64::consts::FRAC_PI_6, 0.0, 0.3491),
            offset: Vector3::new(10.0, -20.0, 35.0),
            labels: [1.0, 2.0, 3.0],
        }
    }
}

impl ValveLabelParams {
    /// Length of the annulus ring's centreline, mm (the closed curve
    /// sampled at 3600 points).
    pub fn ring_length_mm(&self) -> f64 {
        let p = |t: f64| {
            Point3::new(
                self.radius_mm * t.cos(),
                self.radius_mm * t.sin(),
                self.saddle_mm * (2.0 * t).cos(),
            )
        };
        let n = 3600;
        (0..n)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / n as f64;
                let u = std::f64::consts::TAU * (i + 1) as f64 / n as f64;
                (p(u) - p(t)).norm()
            })
            .sum()
    }
}

/// The label map of `p`: the annulus tube (voxels within `tube_mm` of the
/// ring, sampled at 720 points), else the leaflets (voxels within half the
/// thickness of the mid-surface along z, `r <= R`), else 0. The grid
/// covers the valve with a margin of 3 voxels.
pub fn valve_labels(p: &ValveLabelParams) -> Volume<f32> {
    let h = p.voxel_mm;
    let half = p.radius_mm + p.tube_mm + 3.0 * h;
    let zlo = -p.tenting_mm - p.saddle_mm - p.thickness_mm - 3.0 * h;
    let zhi = p.saddle_mm + p.tube_mm + 3.0 * h;
    let n = (2.0 * half / h).ceil() as usize + 1;
    let nz = ((zhi - zlo) / h).ceil() as usize + 1;
    let ring: Vec<Point3<f64>> = (0..720)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / 720.0;
            Point3::new(
                p.radius_mm * t.cos(),
                p.radius_mm * t.sin(),
                p.saddle_mm * (2.0 * t).cos(),
            )
        })
        .collect();
    let mut data = vec![0.0f32; n * n * nz];
    for k in 0..nz {
        for j in 0..n {
            for i in 0..n {
                let q = Point3::new(
                    -half + i as f64 * h,
                    -half + j as f64 * h,
                    zlo + k as f64 * h,
                );
                let r = (q.x * q.x + q.y * q.y).sqrt();
                let label = if r > p.radius_mm - 2.0 * p.tube_mm
                    && ring.iter().any(|c| (q - c).norm() <= p.tube_mm)
                {
                    p.labels[0]
                } else if r <= p.radius_mm {
                    let t = q.y.atan2(q.x);
                    let rr = (r / p.radius_mm).powi(2);
                    let mid = p.saddle_mm * (2.0 * t).cos() * rr - p.tenting_mm * (1.0 - rr);
                    if (q.z - mid).abs() <= p.thickness_mm / 2.0 {
                        if q.y > p.coaptation_y_mm {
                            p.labels[1]
                        } else {
                            p.labels[2]
                        }
                    } else {
                        0.0
                    }
                } else {
                    0.0
                };
                data[i + n * (j + n * k)] = label;
            }
        }
    }
    // voxel (i, j, k) -> R (h (i, j, k) - (half, half, -zlo)) + offset
    let m = p.rotation.matrix() * h;
    let t = p.offset - p.rotation * Vector3::new(half, half, -zlo);
    let mut affine = Matrix4::identity();
    affine.fixed_view_mut::<3, 3>(0, 0).copy_from(&m);
    affine.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
    Volume::new([n, n, nz, 1], affine, data).expect("the grid's dims match its data")
}
