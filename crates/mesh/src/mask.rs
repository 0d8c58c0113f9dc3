//! Binary masks on a voxel grid, as segmentations come (ALGORITHMS 2.4,
//! 2.8): padding, box dilation, separable Gaussian smoothing and the exact
//! Euclidean distance transform. The first steps of meshing a mask
//! (issue 7); the distance transform gives the placenta's thickness.
//!
//! All work on the first frame of a [`Volume`] (`dims[3]` must be 1) and
//! keep its voxel-to-world affine (shifted by the padding). Distances use
//! the voxel spacing per axis (the affine's column lengths), exact for the
//! usual axis-aligned or rotated grids with orthogonal columns.

use crate::{MeshError, Volume};
use nalgebra::Vector4;

/// The 3D dims of `v`, or an error for a 4D series.
fn dims3<T: Copy>(v: &Volume<T>, what: &str) -> Result<[usize; 3], MeshError> {
    let d = v.dims();
    if d[3] != 1 {
        return Err(MeshError::Image(format!(
            "{what} needs a 3D image, got {} frames",
            d[3]
        )));
    }
    Ok([d[0], d[1], d[2]])
}

/// `v` with `n` voxels of `fill` added on every side; the affine is moved so
/// that every voxel keeps its world position.
///
/// # Errors
/// `Image` for a 4D volume.
pub fn pad<T: Copy>(v: &Volume<T>, n: usize, fill: T) -> Result<Volume<T>, MeshError> {
    let [nx, ny, nz] = dims3(v, "padding")?;
    let (mx, my, mz) = (nx + 2 * n, ny + 2 * n, nz + 2 * n);
    let mut data = vec![fill; mx * my * mz];
    let src = v.data();
    for k in 0..nz {
        for j in 0..ny {
            let s = nx * (j + ny * k);
            let d = n + mx * (j + n + my * (k + n));
            data[d..d + nx].copy_from_slice(&src[s..s + nx]);
        }
    }
    let mut affine = *v.affine();
    let shift = affine * Vector4::new(-(n as f64), -(n as f64), -(n as f64), 1.0);
    affine[(0, 3)] = shift.x;
    affine[(1, 3)] = shift.y;
    affine[(2, 3)] = shift.z;
    Volume::new([mx, my, mz, 1], affine, data)
}

/// Dilation by the 3x3x3 box: a voxel is set when it or any of its 26
/// neighbours is (as the reference pipeline, ALGORITHMS 2.8). Separable:
/// the running maximum along x, then y, then z.
///
/// # Errors
/// `Image` for a 4D volume.
pub fn dilate_box(mask: &Volume<bool>) -> Result<Volume<bool>, MeshError> {
    let dims = dims3(mask, "dilation")?;
    let mut data = mask.data().to_vec();
    for axis in 0..3 {
        let stride = [1, dims[0], dims[0] * dims[1]][axis];
        let n = dims[axis];
        let src = data.clone();
        for (id, out) in data.iter_mut().enumerate() {
            let i = (id / stride) % n;
            let mut v = src[id];
            if i > 0 {
                v |= src[id - stride];
            }
            if i + 1 < n {
                v |= src[id + stride];
            }
            *out = v;
        }
    }
    Volume::new([dims[0], dims[1], dims[2], 1], *mask.affine(), data)
}

/// Gaussian smoothing with standard deviation `sigma` voxels (the same in
/// every direction, as the reference's `sigma = 1.5`): the normalized kernel
/// `w_m = exp(-m^2 / (2 sigma^2)) / sum_m' exp(-m'^2 / (2 sigma^2))`,
/// `|m| <= ceil(3 sigma)`, applied along x, y and z. Values beyond the
/// volume count as 0 (pad a mask first so that its level sets stay inside).
///
/// # Errors
/// `Image` for a 4D volume; `InvalidArgument` for a `sigma` that is not
/// finite and `>= 0` (0 returns the input).
pub fn gaussian_smooth(v: &Volume<f64>, sigma: f64) -> Result<Volume<f64>, MeshError> {
    let dims = dims3(v, "smoothing")?;
    if !(sigma.is_finite() && sigma >= 0.0) {
        return Err(MeshError::InvalidArgument(format!(
            "the smoothing sigma must be finite and >= 0 voxels, got {sigma}"
        )));
    }
    if sigma == 0.0 {
        return Ok(v.clone());
    }
    let r = (3.0 * sigma).ceil() as i64;
    let mut w: Vec<f64> = (-r..=r)
        .map(|m| (-(m * m) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = w.iter().sum();
    w.iter_mut().for_each(|x| *x /= total);
    let mut data = v.data().to_vec();
    for axis in 0..3 {
        let stride = [1, dims[0], dims[0] * dims[1]][axis];
        let n = dims[axis] as i64;
        let src = data.clone();
        for (id, out) in data.iter_mut().enumerate() {
            let i = ((id / stride) as i64) % n;
            let mut s = 0.0;
            for (k, &wk) in w.iter().enumerate() {
                let j = i + k as i64 - r;
                if (0..n).contains(&j) {
                    s += wk * src[(id as i64 + (j - i) * stride as i64) as usize];
                }
            }
            *out = s;
        }
    }
    Volume::new([dims[0], dims[1], dims[2], 1], *v.affine(), data)
}

/// One-dimensional squared distance transform (Felzenszwalb & Huttenlocher
/// 2012): `d(q) = min_p ((q - p)^2 h^2 + f(p))` over the lower envelope of
/// parabolas; `f` may hold `+inf`.
fn dt1(f: &[f64], h: f64, out: &mut [f64], v: &mut Vec<usize>, z: &mut Vec<f64>) {
    let n = f.len();
    v.clear();
    z.clear();
    let h2 = h * h;
    for q in 0..n {
        if f[q].is_infinite() {
            continue;
        }
        loop {
            match v.last() {
                None => {
                    v.push(q);
                    z.push(f64::NEG_INFINITY);
                    break;
                }
                Some(&p) => {
                    let (qf, pf) = (q as f64, p as f64);
                    let s =
                        ((f[q] + h2 * qf * qf) - (f[p] + h2 * pf * pf)) / (2.0 * h2 * (qf - pf));
                    if s <= *z.last().unwrap_or(&f64::NEG_INFINITY) {
                        v.pop();
                        z.pop();
                    } else {
                        v.push(q);
                        z.push(s);
                        break;
                    }
                }
            }
        }
    }
    if v.is_empty() {
        out.iter_mut().for_each(|x| *x = f64::INFINITY);
        return;
    }
    let mut k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        let qf = q as f64;
        while k + 1 < v.len() && z[k + 1] < qf {
            k += 1;
        }
        let p = v[k] as f64;
        *o = h2 * (qf - p) * (qf - p) + f[v[k]];
    }
}

/// The exact Euclidean distance, mm, from the centre of every voxel to the
/// nearest voxel centre outside the mask (0 outside; `+inf` everywhere when
/// the mask has no outside voxel): separable squared transforms along x, y
/// and z with the voxel spacing.
///
/// # Errors
/// `Image` for a 4D volume.
pub fn distance_transform(mask: &Volume<bool>) -> Result<Volume<f64>, MeshError> {
    let dims = dims3(mask, "the distance transform")?;
    let spacing = mask.spacing();
    let mut d: Vec<f64> = mask
        .data()
        .iter()
        .map(|&m| if m { f64::INFINITY } else { 0.0 })
        .collect();
    let (mut v, mut z) = (Vec::new(), Vec::new());
    for axis in 0..3 {
        let stride = [1, dims[0], dims[0] * dims[1]][axis];
        let n = dims[axis];
        let mut line = vec![0.0; n];
        let mut out = vec![0.0; n];
        for start in 0..d.len() {
            if (start / stride) % n != 0 {
                continue;
            }
            for (i, x) in line.iter_mut().enumerate() {
                *x = d[start + i * stride];
            }
            dt1(&line, spacing[axis], &mut out, &mut v, &mut z);
            for (i, x) in out.iter().enumerate() {
                d[start + i * stride] = *x;
            }
        }
    }
    d.iter_mut().for_each(|x| *x = x.sqrt());
    Volume::new([dims[0], dims[1], dims[2], 1], *mask.affine(), d)
}

/// The `q`-quantile (`q` in `[0, 1]`, nearest rank) of the distance
/// transform over the mask's voxels: with `q = 0.95` the placenta's
/// half-thickness `h` (ALGORITHMS 2.4). `None` for an empty mask.
///
/// # Errors
/// As [`distance_transform`]; `InvalidArgument` for `q` outside `[0, 1]`.
pub fn inside_distance_quantile(mask: &Volume<bool>, q: f64) -> Result<Option<f64>, MeshError> {
    if !(0.0..=1.0).contains(&q) {
        return Err(MeshError::InvalidArgument(format!(
            "a quantile must be in [0, 1], got {q}"
        )));
    }
    let d = distance_transform(mask)?;
    let mut inside: Vec<f64> = d
        .data()
        .iter()
        .zip(mask.data())
        .filter(|(_, m)| **m)
        .map(|(x, _)| *x)
        .collect();
    if inside.is_empty() {
        return Ok(None);
    }
    inside.sort_by(|a, b| a.total_cmp(b));
    let k = ((q * inside.len() as f64).ceil() as usize).clamp(1, inside.len()) - 1;
    Ok(Some(inside[k]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix4, Point3};
    use proptest::prelude::*;

    fn mask(dims: [usize; 3], spacing: [f64; 3], bits: &[bool]) -> Volume<bool> {
        let mut a = Matrix4::identity();
        for k in 0..3 {
            a[(k, k)] = spacing[k];
        }
        a[(0, 3)] = 10.0;
        a[(1, 3)] = -4.0;
        a[(2, 3)] = 2.5;
        Volume::new([dims[0], dims[1], dims[2], 1], a, bits.to_vec()).unwrap()
    }

    fn ijk(dims: [usize; 3], id: usize) -> [usize; 3] {
        [
            id % dims[0],
            (id / dims[0]) % dims[1],
            id / (dims[0] * dims[1]),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// The separable transform equals the brute-force minimum over all
        /// outside voxels, with anisotropic spacing.
        #[test]
        fn distance_transform_is_exact(
            dims in prop::array::uniform3(1usize..7),
            spacing in prop::array::uniform3(0.3f64..3.0),
            seed in prop::collection::vec(any::<bool>(), 216),
        ) {
            let n = dims[0] * dims[1] * dims[2];
            let bits: Vec<bool> = seed[..n].to_vec();
            let m = mask(dims, spacing, &bits);
            let d = distance_transform(&m).unwrap();
            for id in 0..n {
                let a = ijk(dims, id);
                let brute = (0..n)
                    .filter(|&o| !bits[o])
                    .map(|o| {
                        let b = ijk(dims, o);
                        (0..3)
                            .map(|k| ((a[k] as f64 - b[k] as f64) * spacing[k]).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    })
                    .fold(f64::INFINITY, f64::min);
                let got = d.data()[id];
                if brute.is_infinite() {
                    prop_assert!(got.is_infinite());
                } else {
                    prop_assert!((got - brute).abs() <= 1e-9 * (1.0 + brute), "{got} vs {brute}");
                }
            }
        }

        /// Box dilation equals the brute-force 26-neighbourhood test.
        #[test]
        fn dilation_is_the_box_neighbourhood(
            dims in prop::array::uniform3(1usize..7),
            seed in prop::collection::vec(prop::bool::weighted(0.15), 216),
        ) {
            let n = dims[0] * dims[1] * dims[2];
            let m = mask(dims, [1.0; 3], &seed[..n]);
            let d = dilate_box(&m).unwrap();
            for id in 0..n {
                let a = ijk(dims, id);
                let want = (0..n).any(|o| {
                    let b = ijk(dims, o);
                    seed[o] && (0..3).all(|k| a[k].abs_diff(b[k]) <= 1)
                });
                prop_assert_eq!(d.data()[id], want);
            }
        }
    }

    #[test]
    fn padding_keeps_world_positions() {
        let m = mask([3, 4, 5], [0.5, 1.0, 2.0], &[true; 60]);
        let p = pad(&m, 2, false).unwrap();
        assert_eq!(p.dims(), [7, 8, 9, 1]);
        for (i, j, k) in [(0, 0, 0), (2, 3, 4), (1, 2, 3)] {
            let a = m.voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
            let b = p.voxel_to_world(&Point3::new(i as f64 + 2.0, j as f64 + 2.0, k as f64 + 2.0));
            assert!((a - b).norm() < 1e-12);
            assert_eq!(p.get(i + 2, j + 2, k + 2, 0), Some(true));
        }
        assert_eq!(p.get(0, 0, 0, 0), Some(false));
        assert_eq!(p.data().iter().filter(|&&x| x).count(), 60);
    }

    #[test]
    fn smoothing_keeps_mass_and_symmetry_and_matches_the_kernel() {
        // a single voxel in the middle of a padded volume
        let dims = [21, 21, 21];
        let mut bits = vec![0.0; 21 * 21 * 21];
        let c = 10 + 21 * (10 + 21 * 10);
        bits[c] = 1.0;
        let v = Volume::new([21, 21, 21, 1], Matrix4::identity(), bits).unwrap();
        let s = gaussian_smooth(&v, 1.5).unwrap();
        let total: f64 = s.data().iter().sum();
        assert!((total - 1.0).abs() < 1e-12, "mass {total}");
        // the value at offset (a, b, c) is the product of normalized 1D
        // kernels; check the ratio to the centre
        let at = |i: usize, j: usize, k: usize| s.data()[i + dims[0] * (j + dims[1] * k)];
        let ratio = at(12, 10, 9) / at(10, 10, 10);
        let want = (-(4.0 + 1.0) / (2.0 * 1.5 * 1.5f64)).exp();
        assert!((ratio - want).abs() < 1e-12, "{ratio} vs {want}");
        assert!((at(12, 10, 9) - at(8, 10, 11)).abs() < 1e-15);
        assert_eq!(gaussian_smooth(&v, 0.0).unwrap(), v);
    }

    #[test]
    fn thickness_of_a_slab() {
        // a wide slab 9 voxels thick (1 mm): distances 1..5 mm, with the
        // middle layer (d = 5 away from the sides) 6.9 % of the voxels, so
        // the 95th percentile is 5 mm and the 90th 4 mm
        let dims = [40, 40, 11];
        let bits: Vec<bool> = (0..40 * 40 * 11)
            .map(|id| {
                let [i, j, k] = ijk(dims, id);
                (1..10).contains(&k) && (1..39).contains(&i) && (1..39).contains(&j)
            })
            .collect();
        let m = mask(dims, [1.0; 3], &bits);
        let q = inside_distance_quantile(&m, 0.95).unwrap().unwrap();
        assert!((q - 5.0).abs() < 1e-12, "{q}");
        let q90 = inside_distance_quantile(&m, 0.90).unwrap().unwrap();
        assert!((q90 - 4.0).abs() < 1e-12, "{q90}");
        let none = mask([2, 2, 2], [1.0; 3], &[false; 8]);
        assert_eq!(inside_distance_quantile(&none, 0.95).unwrap(), None);
    }

    #[test]
    fn bad_arguments_are_errors() {
        let m = mask([2, 2, 2], [1.0; 3], &[true; 8]);
        let v = m.map(|b| if b { 1.0 } else { 0.0 });
        for s in [-1.0, f64::NAN, f64::INFINITY] {
            let e = gaussian_smooth(&v, s).unwrap_err().to_string();
            assert!(e.contains("sigma"), "{e}");
        }
        let e = inside_distance_quantile(&m, 1.5).unwrap_err().to_string();
        assert!(e.contains("quantile"), "{e}");
        let four = Volume::new([2, 2, 2, 2], Matrix4::identity(), vec![true; 16]).unwrap();
        for e in [
            dilate_box(&four).unwrap_err().to_string(),
            distance_transform(&four).unwrap_err().to_string(),
            pad(&four, 1, false).unwrap_err().to_string(),
        ] {
            assert!(e.contains("3D image"), "{e}");
        }
        // no outside voxel: infinite distances
        let d = distance_transform(&m).unwrap();
        assert!(d.data().iter().all(|x| x.is_infinite()));
    }
}
