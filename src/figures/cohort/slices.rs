//! The mid-depth slices of the placenta cohort's mean and standard
//! deviation images (template space): side by side, each with its colour
//! bar and axes in mm.

use unfold_render::{ColorScale, Colormap, Image, Rgba, draw_colorbar};

use super::axes::{check_panel, map_frame, title_band};
use crate::figures::layout::compose;
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};
use crate::mesh::Volume;
use crate::mesh::nalgebra::Point3;

/// Colour map of the mean image.
pub const MEAN_COLORMAP: Colormap = Colormap::Viridis;

/// Colour map of the standard deviation image.
pub const STD_COLORMAP: Colormap = Colormap::Magma;

/// Colour of the voxels no subject covers.
pub const EMPTY: Rgba = Rgba::new(235, 235, 235, 255);

/// The file name of the slices of image `image`: `placenta_<image>_slices.png`.
pub fn slices_name(image: &str) -> String {
    format!("placenta_{image}_slices.png")
}

/// The cohort statistics of one image on the template grid.
#[derive(Debug, Clone, Copy)]
pub struct ImageStatistics<'a> {
    /// The image's name (`t2`, ...).
    pub image: &'a str,
    /// Voxel-wise mean over the subjects.
    pub mean: &'a Volume<f32>,
    /// Voxel-wise standard deviation.
    pub std: &'a Volume<f32>,
    /// Voxel-wise number of subjects (`None`: the mean's finite non-zero
    /// voxels count as covered).
    pub count: Option<&'a Volume<f32>>,
}

impl ImageStatistics<'_> {
    /// Whether voxel `(i, j, k)` is covered: count `> 0`, or without a count
    /// image a finite non-zero mean.
    fn covered(&self, i: usize, j: usize, k: usize) -> bool {
        match self.count {
            Some(c) => c.get(i, j, k, 0).is_some_and(|n| n > 0.0),
            None => self
                .mean
                .get(i, j, k, 0)
                .is_some_and(|v| v.is_finite() && v != 0.0),
        }
    }
}

/// The mid-depth slice index: the middle `floor((k_min + k_max) / 2)` of
/// the slices `k` holding a covered voxel, or the middle `floor(n_z / 2)`
/// of the grid when none does.
pub fn mid_depth(stats: &ImageStatistics<'_>) -> usize {
    let [nx, ny, nz, _] = stats.mean.dims();
    let covered: Vec<usize> = (0..nz)
        .filter(|&k| (0..ny).any(|j| (0..nx).any(|i| stats.covered(i, j, k))))
        .collect();
    match (covered.first(), covered.last()) {
        (Some(a), Some(b)) => (a + b) / 2,
        _ => nz / 2,
    }
}

/// The figure [`slices_name`] (2 x 1 panels): slice `k =` [`mid_depth`] of
/// the mean (left, [`MEAN_COLORMAP`]) and of the standard deviation (right,
/// [`STD_COLORMAP`]), each over the covered voxels' extent in that slice
/// (two voxels of margin; the whole slice when none is covered), nearest
/// voxel, uncovered voxels in [`EMPTY`], template x right and y up in mm
/// with equal scales, and a colour bar over the covered values.
///
/// # Errors
/// [`FigureError::Input`] when the three images are not on one grid or the
/// panel is too small; the renderer's.
pub fn mean_std_slices(
    stats: &ImageStatistics<'_>,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    let name = slices_name(stats.image);
    check_panel(&name, opts)?;
    let d = stats.mean.dims();
    let same = |v: &Volume<f32>| {
        v.dims()[..3] == d[..3]
            && (v.affine() - stats.mean.affine())
                .iter()
                .all(|x| x.abs() <= 1e-6)
    };
    if !same(stats.std) || !stats.count.is_none_or(same) {
        return Err(FigureError::input(
            &name,
            format!(
                "the mean, std and count images of `{}` are not on one grid",
                stats.image
            ),
        ));
    }
    let k = mid_depth(stats);
    let [nx, ny, nz, _] = d;
    // Covered voxels of the slice and their index box.
    let (mut i0, mut i1, mut j0, mut j1) = (usize::MAX, 0, usize::MAX, 0);
    for j in 0..ny {
        for i in 0..nx {
            if stats.covered(i, j, k) {
                (i0, i1, j0, j1) = (i0.min(i), i1.max(i), j0.min(j), j1.max(j));
            }
        }
    }
    if i0 == usize::MAX {
        (i0, i1, j0, j1) = (0, nx - 1, 0, ny - 1);
    } else {
        (i0, i1) = (i0.saturating_sub(2), (i1 + 2).min(nx - 1));
        (j0, j1) = (j0.saturating_sub(2), (j1 + 2).min(ny - 1));
    }
    // World extent of that box (voxel edges), x and y.
    let corner = |i: f64, j: f64| stats.mean.voxel_to_world(&Point3::new(i, j, k as f64));
    let (a, b) = (
        corner(i0 as f64 - 0.5, j0 as f64 - 0.5),
        corner(i1 as f64 + 0.5, j1 as f64 + 0.5),
    );
    let (xlo, xhi) = (a.x.min(b.x), a.x.max(b.x));
    let (ylo, yhi) = (a.y.min(b.y), a.y.max(b.y));
    let z_mm = corner(0.0, 0.0).z;
    let max_count = stats.count.map(|c| {
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (i, j)))
            .filter_map(|(i, j)| c.get(i, j, k, 0))
            .fold(0.0f32, f32::max)
    });
    let subtitle = |what: &str| {
        let mut s = format!(
            "{what} at template z = {} mm (slice {} of {nz})",
            unfold_render::format_value(z_mm),
            k + 1
        );
        if let Some(n) = max_count {
            s.push_str(&format!(", up to {n} placentas per voxel"));
        }
        s.push_str("; grey: none");
        s
    };
    let panels = [
        (
            stats.mean,
            MEAN_COLORMAP,
            format!("cohort mean of {}", stats.image),
            subtitle("voxel-wise mean"),
            "mean",
        ),
        (
            stats.std,
            STD_COLORMAP,
            format!("cohort std of {}", stats.image),
            subtitle("voxel-wise standard deviation"),
            "std",
        ),
    ];
    let err = || FigureError::render(&name);
    let mut imgs = Vec::with_capacity(2);
    for (vol, map, title, sub, bar_title) in panels {
        let mut img = Image::new(opts.panel_width, opts.panel_height, PAPER).map_err(err())?;
        title_band(&mut img, &title, &sub).map_err(err())?;
        let values: Vec<f64> = (j0..=j1)
            .flat_map(|j| (i0..=i1).map(move |i| (i, j)))
            .filter(|&(i, j)| stats.covered(i, j, k))
            .filter_map(|(i, j)| vol.get(i, j, k, 0).map(f64::from))
            .filter(|v| v.is_finite())
            .collect();
        let scale = ColorScale::from_values(map, &values);
        // Equal mm scales: the box fits the free area, centred.
        let frame = map_frame(&mut img, opts, (xlo, xhi), (ylo, yhi)).map_err(err())?;
        // The slice over the grid lines the frame drew, then the frame again.
        for py in 0..frame.height {
            for px in 0..frame.width {
                let (x, y) = frame.point(xlo, yhi, px, py);
                let v = stats.mean.world_to_voxel(&Point3::new(x, y, z_mm));
                let (i, j) = (v.x.round(), v.y.round());
                let c = if i < 0.0 || j < 0.0 {
                    EMPTY
                } else {
                    let (i, j) = (i as usize, j as usize);
                    match vol.get(i, j, k, 0) {
                        Some(val) if stats.covered(i, j, k) && val.is_finite() => {
                            scale.color(f64::from(val)).opaque()
                        }
                        _ => EMPTY,
                    }
                };
                img.put(frame.x0 + px, frame.y0 + py, c);
            }
        }
        img.stroke_rect(frame.area, INK);
        draw_colorbar(&mut img, frame.bar, &scale, bar_title, INK, 1).map_err(err())?;
        imgs.push(img);
    }
    let img = compose(&imgs, 2, opts).map_err(err())?;
    Ok(Figure::new(name, img))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::nalgebra::Matrix4;

    fn grid(f: impl Fn(usize, usize, usize) -> f32) -> Volume<f32> {
        let (nx, ny, nz) = (12, 10, 6);
        let mut data = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    data.push(f(i, j, k));
                }
            }
        }
        let mut a = Matrix4::identity() * 2.0;
        a[(3, 3)] = 1.0;
        a[(0, 3)] = -12.0;
        Volume::new([nx, ny, nz, 1], a, data).unwrap()
    }

    #[test]
    fn the_middle_of_the_covered_slices_and_a_deterministic_figure() {
        let inside = |i: usize, j: usize, k: usize| {
            (2..9).contains(&i) && (3..7).contains(&j) && (1..4).contains(&k)
        };
        let count = grid(|i, j, k| if inside(i, j, k) { 3.0 } else { 0.0 });
        let mean = grid(|i, j, k| {
            if inside(i, j, k) {
                i as f32 + j as f32
            } else {
                0.0
            }
        });
        let std = grid(|i, _, k| if k < 6 { 0.1 * i as f32 } else { 0.0 });
        let stats = ImageStatistics {
            image: "t2",
            mean: &mean,
            std: &std,
            count: Some(&count),
        };
        assert_eq!(mid_depth(&stats), 2);
        let no_count = ImageStatistics {
            count: None,
            ..stats
        };
        assert_eq!(mid_depth(&no_count), 2);
        let opts = FigureOptions::default();
        let a = mean_std_slices(&stats, &opts).unwrap();
        let b = mean_std_slices(&stats, &opts).unwrap();
        assert_eq!(a.name, "placenta_t2_slices.png");
        assert_eq!(a.image.to_png().unwrap(), b.image.to_png().unwrap());
        assert_eq!(a.image.width(), 2 * opts.panel_width);
        // Both ends of the mean's map appear (its smallest and largest
        // covered values).
        let has = |c: Rgba| {
            (0..a.image.height()).any(|y| {
                (0..opts.panel_width).any(|x| a.image.get(i64::from(x), i64::from(y)) == Some(c))
            })
        };
        assert!(has(MEAN_COLORMAP.eval(0.0).opaque()));
        assert!(has(MEAN_COLORMAP.eval(1.0).opaque()));
        assert!(has(EMPTY));
        // Another grid for the std is refused.
        let other = Volume::new([2, 2, 2, 1], Matrix4::identity(), vec![0.0; 8]).unwrap();
        let bad = ImageStatistics {
            std: &other,
            ..stats
        };
        assert!(matches!(
            mean_std_slices(&bad, &opts),
            Err(FigureError::Input { .. })
        ));
    }
}
