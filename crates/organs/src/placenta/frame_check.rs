//! Does the mesh lie in the image's foreground? (ALGORITHMS 2.7, "frame
//! check".) A mesh exported in LPS (ITK, DICOM, 3D Slicer) read as RAS
//! (NIfTI's world frame) is mirrored in x and y: the pull-back then samples
//! the wrong part of the image without any error. Before any work, every
//! image is checked:
//!
//! 1. the foreground threshold `t` is Otsu's on the values of the image's
//!    first frame (256 bins between the smallest and largest finite value):
//!    the threshold maximizing the between-class variance
//!    `w0 w1 (mu0 - mu1)^2`;
//! 2. `f(s)` is the fraction of the mesh volume whose tets have their
//!    centroid `g` in the foreground after the axis flip `s`
//!    (`(s_x g_x, s_y g_y, s_z g_z)`, about the world origin): the image
//!    value at `g` (nearest voxel) is at least `t`; outside the image counts
//!    as background;
//! 3. `f(identity) >= 0.5`: passes. Otherwise, if some flip reaches
//!    `f(s) >= 0.8`, the check fails naming the best one (the flip of x and
//!    y is the LPS <-> RAS confusion); if none does and
//!    `f(identity) < 0.1`, it fails naming none; in between (a weak
//!    foreground, a partial overlap) it passes, and the fraction is
//!    reported.
//!
//! Measured (`tests::clean_foreground`, `tests::noisy_foreground`: a slab
//! away from the origin in a 3 mm image, placenta about 250, background 20):
//! Otsu's threshold falls between the two; `f` is above 0.85 for the slab
//! (nearest-voxel sampling loses part of its thin rim) and below 0.05 for
//! it mirrored in x and y, whose flip scores 0.99; with noise of 25 % of the
//! contrast added, still above 0.85 and below 0.1 (0.054 measured).
//! An image without a placenta foreground (a smooth ramp, a BOLD series of
//! the whole abdomen) can fail the check: the command line's
//! `--no-frame-check` skips it.

use super::error::PlacentaError;
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::{TetMesh, Volume};

/// Fraction of the mesh in the foreground at or above which the check
/// passes.
pub const MIN_INSIDE: f64 = 0.5;
/// Fraction a flip must reach to be named as the likely cause.
pub const FLIP_INSIDE: f64 = 0.8;
/// Fraction below which the check fails even when no flip explains it.
pub const MIN_UNEXPLAINED: f64 = 0.1;

/// An axis flip about the world origin: which axes are negated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Flip {
    /// Negate x, y, z.
    pub axes: [bool; 3],
}

impl Flip {
    /// The seven flips other than the identity, the LPS <-> RAS one (x and
    /// y) first.
    pub fn all() -> [Flip; 7] {
        let f = |x, y, z| Flip { axes: [x, y, z] };
        [
            f(true, true, false),
            f(true, false, false),
            f(false, true, false),
            f(false, false, true),
            f(true, false, true),
            f(false, true, true),
            f(true, true, true),
        ]
    }

    /// Whether this is the flip of x and y (LPS <-> RAS).
    pub fn is_lps_ras(&self) -> bool {
        self.axes == [true, true, false]
    }

    /// `"x and y"`, `"z"`, ...: the axes negated.
    pub fn describe(&self) -> String {
        let names: Vec<&str> = ["x", "y", "z"]
            .iter()
            .zip(self.axes)
            .filter_map(|(n, f)| f.then_some(*n))
            .collect();
        match names.as_slice() {
            [] => "no axis".into(),
            [a] => (*a).into(),
            [a, b] => format!("{a} and {b}"),
            _ => "x, y and z".into(),
        }
    }

    fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        let s = |f: bool| if f { -1.0 } else { 1.0 };
        Point3::new(
            s(self.axes[0]) * p.x,
            s(self.axes[1]) * p.y,
            s(self.axes[2]) * p.z,
        )
    }
}

/// What the check found for one image.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FrameCheck {
    /// Otsu's foreground threshold.
    pub threshold: f64,
    /// Fraction of the mesh volume in the foreground.
    pub inside: f64,
    /// The flip with the largest fraction, and that fraction.
    pub best_flip: Flip,
    /// Its fraction.
    pub best_flip_inside: f64,
}

/// Otsu's threshold of the finite values of the first frame of `image`
/// (256 bins), or `None` when it holds fewer than two distinct values.
pub fn otsu_threshold(image: &Volume<f32>) -> Option<f64> {
    let [nx, ny, nz, _] = image.dims();
    let n = nx * ny * nz;
    let values = image.data().get(..n)?;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in values.iter().filter(|v| v.is_finite()) {
        lo = lo.min(f64::from(v));
        hi = hi.max(f64::from(v));
    }
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    const BINS: usize = 256;
    let width = (hi - lo) / BINS as f64;
    let mut hist = [0usize; BINS];
    for &v in values.iter().filter(|v| v.is_finite()) {
        let b = ((f64::from(v) - lo) / width) as usize;
        hist[b.min(BINS - 1)] += 1;
    }
    let total: f64 = hist.iter().sum::<usize>() as f64;
    let centre = |b: usize| lo + (b as f64 + 0.5) * width;
    let sum_all: f64 = hist
        .iter()
        .enumerate()
        .map(|(b, &c)| c as f64 * centre(b))
        .sum();
    let (mut w0, mut sum0, mut best, mut best_b) = (0.0, 0.0, -1.0, 0);
    for (b, &c) in hist.iter().enumerate().take(BINS - 1) {
        w0 += c as f64;
        sum0 += c as f64 * centre(b);
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (mu0, mu1) = (sum0 / w0, (sum_all - sum0) / w1);
        let between = w0 * w1 * (mu0 - mu1) * (mu0 - mu1);
        if between > best {
            best = between;
            best_b = b;
        }
    }
    Some(lo + (best_b + 1) as f64 * width)
}

/// The fraction of the volume of `mesh` whose tet centroids, moved by
/// `flip`, fall on a voxel of `image` (nearest, first frame) with a value
/// at least `threshold`.
pub fn fraction_inside(mesh: &TetMesh, image: &Volume<f32>, threshold: f64, flip: Flip) -> f64 {
    let inverse = image.affine().try_inverse();
    let Some(inverse) = inverse else {
        return 0.0;
    };
    let [nx, ny, nz, _] = image.dims();
    let data = image.data();
    let (mut inside, mut total) = (0.0, 0.0);
    for t in &mesh.tets {
        let p = t.map(|i| mesh.positions[i as usize]);
        let v = (p[1] - p[0])
            .cross(&(p[2] - p[0]))
            .dot(&(p[3] - p[0]))
            .abs()
            / 6.0;
        let g = Point3::from((p[0].coords + p[1].coords + p[2].coords + p[3].coords) / 4.0);
        total += v;
        let q = inverse.transform_point(&flip.apply(&g));
        let idx = [q.x.round(), q.y.round(), q.z.round()];
        let dims = [nx, ny, nz];
        if (0..3).all(|a| idx[a] >= 0.0 && idx[a] < dims[a] as f64) {
            let [i, j, k] = idx.map(|x| x as usize);
            if data
                .get(i + nx * (j + ny * k))
                .is_some_and(|&x| f64::from(x) >= threshold)
            {
                inside += v;
            }
        }
    }
    if total > 0.0 { inside / total } else { 0.0 }
}

/// Measures `mesh` against the foreground of `image` (see the module
/// documentation); `None` when the image has no contrast.
pub fn measure(mesh: &TetMesh, image: &Volume<f32>) -> Option<FrameCheck> {
    let threshold = otsu_threshold(image)?;
    let identity = Flip {
        axes: [false, false, false],
    };
    let inside = fraction_inside(mesh, image, threshold, identity);
    let (mut best_flip, mut best_flip_inside) = (identity, -1.0);
    for flip in Flip::all() {
        let f = fraction_inside(mesh, image, threshold, flip);
        if f > best_flip_inside + 1e-12 {
            best_flip = flip;
            best_flip_inside = f;
        }
    }
    Some(FrameCheck {
        threshold,
        inside,
        best_flip,
        best_flip_inside,
    })
}

/// The check of image `index` (see the module documentation).
///
/// # Errors
/// [`PlacentaError::MeshFlipped`] when a flip explains a mesh outside the
/// foreground, [`PlacentaError::MeshOutsideForeground`] when nothing does
/// and under 10 % of the mesh is in it.
pub fn check(mesh: &TetMesh, image: &Volume<f32>, index: usize) -> Result<(), PlacentaError> {
    let Some(c) = measure(mesh, image) else {
        return Ok(());
    };
    if c.inside >= MIN_INSIDE {
        return Ok(());
    }
    if c.best_flip_inside >= FLIP_INSIDE {
        return Err(PlacentaError::MeshFlipped {
            index,
            inside: c.inside,
            flip: c.best_flip,
            flipped_inside: c.best_flip_inside,
        });
    }
    if c.inside < MIN_UNEXPLAINED {
        return Err(PlacentaError::MeshOutsideForeground {
            index,
            inside: c.inside,
            threshold: c.threshold,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::nalgebra::Matrix4;
    use unfold_mesh::shapes::{PlacentaParams, Pose, placenta_slab};
    use unfold_mesh::spatial::TetLocator;

    /// A slab away from the origin, as in a scanner, and a 3 mm image of it
    /// (placenta 200 + smooth variation, background 20, plus Gaussian-like
    /// noise of standard deviation `noise`).
    fn scene(noise: f64) -> (TetMesh, Volume<f32>) {
        let mesh = placenta_slab(&PlacentaParams {
            cells_radial: 5,
            cells_through: 2,
            pose: Pose::new([0.0, 0.0, 20.0], [70.0, 40.0, 10.0]),
            ..PlacentaParams::default()
        })
        .unwrap()
        .mesh;
        let loc = TetLocator::new(&mesh);
        let (lo, dims, s) = ([-60.0, -70.0, -40.0], [84usize, 70, 28], 3.0);
        let mut affine = Matrix4::identity();
        for a in 0..3 {
            affine[(a, a)] = s;
            affine[(a, 3)] = lo[a];
        }
        let mut data = Vec::new();
        let mut state = 12345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                    let v = if loc.locate(&p).is_some() {
                        250.0 + 30.0 * (p.x / 20.0).sin()
                    } else {
                        20.0
                    };
                    // Sum of 4 uniforms: roughly Gaussian, sd 1.
                    let n: f64 = (0..4).map(|_| uniform() - 0.5).sum::<f64>() * 3f64.sqrt();
                    data.push((v + noise * n) as f32);
                }
            }
        }
        (
            mesh,
            Volume::new([dims[0], dims[1], dims[2], 1], affine, data).unwrap(),
        )
    }

    fn mirrored(mesh: &TetMesh) -> TetMesh {
        let mut m = mesh.clone();
        for p in &mut m.positions {
            p.x = -p.x;
            p.y = -p.y;
        }
        m
    }

    #[test]
    fn clean_foreground() {
        let (mesh, image) = scene(0.0);
        let c = measure(&mesh, &image).unwrap();
        assert!(c.threshold > 20.0 && c.threshold < 220.0, "{c:?}");
        assert!(c.inside > 0.85, "{c:?}");
        assert!(check(&mesh, &image, 0).is_ok());
        let bad = mirrored(&mesh);
        let c = measure(&bad, &image).unwrap();
        assert!(c.inside < 0.05, "{c:?}");
        assert!(
            c.best_flip.is_lps_ras() && c.best_flip_inside > 0.85,
            "{c:?}"
        );
        let e = check(&bad, &image, 3).unwrap_err();
        assert!(
            matches!(e, PlacentaError::MeshFlipped { index: 3, flip, .. } if flip.is_lps_ras()),
            "{e}"
        );
        let msg = e.to_string();
        assert!(msg.contains("x and y") && !msg.contains('\n'), "{msg}");
    }

    #[test]
    fn noisy_foreground() {
        // Noise of 25 % of the contrast (230 * 0.25).
        let (mesh, image) = scene(57.0);
        let c = measure(&mesh, &image).unwrap();
        assert!(c.inside > 0.85, "{c:?}");
        let c = measure(&mirrored(&mesh), &image).unwrap();
        assert!(c.inside < 0.1 && c.best_flip_inside > 0.85, "{c:?}");
    }

    #[test]
    fn a_mesh_far_from_any_foreground_fails_without_a_flip() {
        let (mut mesh, image) = scene(0.0);
        for p in &mut mesh.positions {
            p.z += 45.0;
        }
        let e = check(&mesh, &image, 0).unwrap_err();
        assert!(
            matches!(e, PlacentaError::MeshOutsideForeground { .. }),
            "{e}"
        );
    }

    #[test]
    fn a_constant_image_is_not_judged() {
        let (mesh, _) = scene(0.0);
        let flat = Volume::new([4, 4, 4, 1], Matrix4::identity(), vec![7.0f32; 64]).unwrap();
        assert!(otsu_threshold(&flat).is_none());
        assert!(check(&mesh, &flat, 0).is_ok());
    }

    #[test]
    fn flips_describe_their_axes() {
        let all = Flip::all();
        assert!(all[0].is_lps_ras());
        assert_eq!(all[0].describe(), "x and y");
        assert_eq!(all[3].describe(), "z");
        assert_eq!(all[6].describe(), "x, y and z");
        let p = Point3::new(1.0, 2.0, 3.0);
        assert_eq!(all[0].apply(&p), Point3::new(-1.0, -2.0, 3.0));
    }
}
