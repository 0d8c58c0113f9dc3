//! Sampling the images the placenta figures show: a pulled-back image
//! (zeros outside the mesh) and an original image (every voxel data).

use crate::mesh::Volume;
use crate::mesh::nalgebra::Point3;

/// Frame `t` of a pulled-back image `vol` at world point `p`: the trilinear
/// interpolation over the corner voxels that hold data (finite and
/// non-zero), renormalized,
///
/// ```text
/// v(p) = sum_c w_c x_c / sum_c w_c   over the corners c with x_c finite, != 0
/// ```
///
/// `None` when those carry less than half the weight (outside the mesh) or
/// `p` is more than half a voxel outside the grid.
pub(super) fn sample_masked(vol: &Volume<f32>, p: &Point3<f64>, t: usize) -> Option<f64> {
    let v = vol.world_to_voxel(p);
    let d = vol.dims();
    let mut base = [0usize; 3];
    let mut frac = [0.0f64; 3];
    for a in 0..3 {
        let n = d[a];
        let x = v[a];
        if !x.is_finite() || x < -0.5 || x > n as f64 - 0.5 {
            return None;
        }
        if n == 1 {
            continue;
        }
        let x = x.clamp(0.0, (n - 1) as f64);
        base[a] = (x.floor() as usize).min(n - 2);
        frac[a] = x - base[a] as f64;
    }
    let (mut acc, mut wsum) = (0.0, 0.0);
    for corner in 0..8usize {
        let mut w = 1.0;
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let up = (corner >> a) & 1 == 1;
            if d[a] == 1 {
                if up {
                    w = 0.0;
                }
                continue;
            }
            idx[a] = base[a] + usize::from(up);
            w *= if up { frac[a] } else { 1.0 - frac[a] };
        }
        if w <= 0.0 {
            continue;
        }
        if let Some(x) = vol.get(idx[0], idx[1], idx[2], t) {
            let x = f64::from(x);
            if x.is_finite() && x != 0.0 {
                acc += w * x;
                wsum += w;
            }
        }
    }
    (wsum >= 0.5).then(|| acc / wsum)
}

/// Frame 0 of an original image at the continuous voxel position `v`
/// (trilinear, [`Volume::sample_voxel`]); `None` outside the grid or where
/// the value is not finite.
pub(super) fn sample_original(vol: &Volume<f32>, v: &Point3<f64>) -> Option<f64> {
    vol.sample_voxel(v, 0).filter(|x| x.is_finite())
}
