//! `Volume<T>`: a 3D or 4D image on a regular grid with its voxel-to-world
//! affine (NIfTI sform/qform), in millimetres.

use crate::MeshError;
use nalgebra::{Matrix4, Point3, Vector3};

/// A 3D image (`dims[3] == 1`) or a 4D series of 3D frames on a regular grid.
///
/// Voxel `(i, j, k, t)` is stored at `i + nx (j + ny (k + nz t))` (x fastest,
/// as NIfTI). Its centre is at world position `affine * (i, j, k, 1)^T`.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume<T> {
    dims: [usize; 4],
    affine: Matrix4<f64>,
    inverse: Matrix4<f64>,
    data: Vec<T>,
}

impl<T: Copy> Volume<T> {
    /// A volume of `dims = [nx, ny, nz, nt]` voxels; fails when a dimension is
    /// 0, the data length is not their product, or the affine is singular or
    /// not of the form `[A t; 0 0 0 1]`.
    pub fn new(dims: [usize; 4], affine: Matrix4<f64>, data: Vec<T>) -> Result<Self, MeshError> {
        if dims.contains(&0) {
            return Err(MeshError::Image(format!("a dimension is zero: {dims:?}")));
        }
        let n = dims
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .ok_or_else(|| MeshError::Image(format!("dimensions {dims:?} overflow")))?;
        if data.len() != n {
            return Err(MeshError::Image(format!(
                "{} values for dimensions {dims:?} ({n} voxels)",
                data.len()
            )));
        }
        if !affine.iter().all(|x| x.is_finite())
            || affine[(3, 0)] != 0.0
            || affine[(3, 1)] != 0.0
            || affine[(3, 2)] != 0.0
            || affine[(3, 3)] != 1.0
        {
            return Err(MeshError::Image(
                "the voxel-to-world affine must be finite with last row (0, 0, 0, 1)".into(),
            ));
        }
        let inverse = affine
            .try_inverse()
            .filter(|m| m.iter().all(|x| x.is_finite()))
            .ok_or_else(|| MeshError::Image("the voxel-to-world affine is singular".into()))?;
        Ok(Volume {
            dims,
            affine,
            inverse,
            data,
        })
    }

    /// A volume filled with `value`.
    pub fn filled(dims: [usize; 4], affine: Matrix4<f64>, value: T) -> Result<Self, MeshError> {
        let n = dims.iter().product();
        Volume::new(dims, affine, vec![value; n])
    }

    /// `[nx, ny, nz, nt]`.
    pub fn dims(&self) -> [usize; 4] {
        self.dims
    }

    /// Number of 3D frames (`nt`).
    pub fn frames(&self) -> usize {
        self.dims[3]
    }

    /// Voxels per frame (`nx ny nz`).
    pub fn frame_len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// The voxel-to-world affine.
    pub fn affine(&self) -> &Matrix4<f64> {
        &self.affine
    }

    /// Voxel spacing: the lengths of the affine's first three columns (mm).
    pub fn spacing(&self) -> [f64; 3] {
        let c = |j: usize| {
            Vector3::new(
                self.affine[(0, j)],
                self.affine[(1, j)],
                self.affine[(2, j)],
            )
            .norm()
        };
        [c(0), c(1), c(2)]
    }

    /// All values (x fastest, then y, z, t).
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// All values, mutable.
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the volume, returning its values.
    pub fn into_data(self) -> Vec<T> {
        self.data
    }

    /// Linear index of voxel `(i, j, k)` in frame `t`.
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize, t: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * (k + self.dims[2] * t))
    }

    /// Value of voxel `(i, j, k)` in frame `t`, `None` outside the grid.
    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize, t: usize) -> Option<T> {
        if i < self.dims[0] && j < self.dims[1] && k < self.dims[2] && t < self.dims[3] {
            Some(self.data[self.index(i, j, k, t)])
        } else {
            None
        }
    }

    /// World position of continuous voxel coordinates `v`: `affine * (v, 1)`.
    #[inline]
    pub fn voxel_to_world(&self, v: &Point3<f64>) -> Point3<f64> {
        self.affine.transform_point(v)
    }

    /// Continuous voxel coordinates of world point `p`: `affine^-1 * (p, 1)`.
    #[inline]
    pub fn world_to_voxel(&self, p: &Point3<f64>) -> Point3<f64> {
        self.inverse.transform_point(p)
    }

    /// Maps every value through `f`, keeping the grid.
    pub fn map<U: Copy>(&self, f: impl Fn(T) -> U) -> Volume<U> {
        Volume {
            dims: self.dims,
            affine: self.affine,
            inverse: self.inverse,
            data: self.data.iter().map(|&x| f(x)).collect(),
        }
    }
}

impl<T: Copy + Into<f64>> Volume<T> {
    /// Trilinear interpolation of frame `t` at continuous voxel coordinates
    /// `v`: `sum_{corners c} w_c f(c)` with `w_c = prod_axis (1 - |v_a - c_a|)`.
    /// Points up to half a voxel beyond the outer voxel centres are clamped to
    /// the border; farther out the result is `None`.
    pub fn sample_voxel(&self, v: &Point3<f64>, t: usize) -> Option<f64> {
        if t >= self.dims[3] {
            return None;
        }
        let mut lo = [0usize; 3];
        let mut frac = [0.0f64; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let x = v[a];
            if !x.is_finite() || x < -0.5 || x > n as f64 - 0.5 {
                return None;
            }
            let x = x.clamp(0.0, (n - 1) as f64);
            let f = x.floor();
            lo[a] = (f as usize).min(n.saturating_sub(2));
            frac[a] = x - lo[a] as f64;
        }
        let mut acc = 0.0;
        for corner in 0..8usize {
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            for a in 0..3 {
                let up = (corner >> a) & 1 == 1;
                let n = self.dims[a];
                if n == 1 {
                    if up {
                        w = 0.0;
                    }
                    idx[a] = 0;
                    continue;
                }
                idx[a] = lo[a] + usize::from(up);
                w *= if up { frac[a] } else { 1.0 - frac[a] };
            }
            if w != 0.0 {
                acc += w * self.data[self.index(idx[0], idx[1], idx[2], t)].into();
            }
        }
        Some(acc)
    }

    /// The value of frame `t` at the voxel whose centre is nearest to the
    /// continuous voxel coordinates `v` (`round(v_a)`, halves away from
    /// zero, clamped to the grid): no value is blended, so labels stay
    /// labels. The same domain as [`Volume::sample_voxel`]: up to half a
    /// voxel beyond the outer voxel centres, `None` farther out.
    pub fn sample_voxel_nearest(&self, v: &Point3<f64>, t: usize) -> Option<f64> {
        if t >= self.dims[3] {
            return None;
        }
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let x = v[a];
            if !x.is_finite() || x < -0.5 || x > n as f64 - 0.5 {
                return None;
            }
            idx[a] = (x.round().max(0.0) as usize).min(n - 1);
        }
        Some(self.data[self.index(idx[0], idx[1], idx[2], t)].into())
    }

    /// Trilinear interpolation of frame `t` at world point `p`.
    pub fn sample_world(&self, p: &Point3<f64>, t: usize) -> Option<f64> {
        self.sample_voxel(&self.world_to_voxel(p), t)
    }

    /// Smallest and largest value (`None` for an all-NaN image).
    pub fn value_range(&self) -> Option<(f64, f64)> {
        let mut r: Option<(f64, f64)> = None;
        for &x in &self.data {
            let x: f64 = x.into();
            if x.is_nan() {
                continue;
            }
            r = Some(match r {
                None => (x, x),
                Some((lo, hi)) => (lo.min(x), hi.max(x)),
            });
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn affine() -> Matrix4<f64> {
        let mut a = Matrix4::identity();
        a[(0, 0)] = 2.0;
        a[(1, 1)] = 0.5;
        a[(2, 2)] = 3.0;
        a[(0, 3)] = -10.0;
        a[(1, 3)] = 4.0;
        a
    }

    #[test]
    fn rejects_bad_shapes() {
        assert!(Volume::new([2, 2, 2, 1], affine(), vec![0.0f32; 7]).is_err());
        assert!(Volume::new([0, 2, 2, 1], affine(), Vec::<f32>::new()).is_err());
        assert!(Volume::new([1, 1, 1, 1], Matrix4::zeros(), vec![0.0f32]).is_err());
    }

    proptest! {
        /// Nearest-neighbour sampling returns a stored value, the one of the
        /// voxel whose centre is nearest, and nothing off the grid: on a
        /// label image every sample is a label.
        #[test]
        fn nearest_returns_the_nearest_stored_value(
            labels in prop::collection::vec(0u8..6, 4 * 5 * 3),
            x in -0.5..3.5f64, y in -0.5..4.5f64, z in -0.5..2.5f64,
            off in 0.51..3.0f64,
        ) {
            let v = Volume::new([4, 5, 3, 1], affine(), labels.clone()).unwrap();
            let got = v.sample_voxel_nearest(&Point3::new(x, y, z), 0).unwrap();
            let (i, j, k) = (
                x.round().clamp(0.0, 3.0) as usize,
                y.round().clamp(0.0, 4.0) as usize,
                z.round().clamp(0.0, 2.0) as usize,
            );
            prop_assert_eq!(got, f64::from(labels[i + 4 * (j + 5 * k)]));
            // That centre is within half a voxel on every axis.
            for (c, n) in [(x, i), (y, j), (z, k)] {
                prop_assert!((c - n as f64).abs() <= 0.5 + 1e-12);
            }
            prop_assert!(v.sample_voxel_nearest(&Point3::new(-off, y, z), 0).is_none());
            prop_assert!(v.sample_voxel_nearest(&Point3::new(x, 4.0 + off, z), 0).is_none());
            prop_assert!(v.sample_voxel_nearest(&Point3::new(x, y, z), 1).is_none());
        }

        /// Trilinear interpolation reproduces an affine function exactly.
        #[test]
        fn trilinear_is_exact_on_linear_functions(
            a in -3.0..3.0f64, b in -3.0..3.0f64, c in -3.0..3.0f64, d in -5.0..5.0f64,
            x in 0.0..3.0f64, y in 0.0..4.0f64, z in 0.0..2.0f64,
        ) {
            let dims = [4, 5, 3, 2];
            let mut data = Vec::new();
            for t in 0..2 { for k in 0..3 { for j in 0..5 { for i in 0..4 {
                data.push(a * i as f64 + b * j as f64 + c * k as f64 + d + t as f64);
            }}}}
            let v = Volume::new(dims, affine(), data).unwrap();
            let p = Point3::new(x, y, z);
            let w = v.voxel_to_world(&p);
            assert_relative_eq!(v.world_to_voxel(&w), p, epsilon = 1e-9);
            let s = v.sample_world(&w, 1).unwrap();
            prop_assert!((s - (a * x + b * y + c * z + d + 1.0)).abs() < 1e-9);
        }
    }

    #[test]
    fn outside_is_none() {
        let v = Volume::new([2, 2, 2, 1], Matrix4::identity(), vec![1.0f64; 8]).unwrap();
        assert_eq!(v.sample_voxel(&Point3::new(1.4, 0.0, 0.0), 0), Some(1.0));
        assert_eq!(v.sample_voxel(&Point3::new(1.6, 0.0, 0.0), 0), None);
        assert_eq!(v.sample_voxel(&Point3::new(0.0, 0.0, 0.0), 1), None);
        assert_eq!(v.spacing(), [1.0, 1.0, 1.0]);
    }
}
