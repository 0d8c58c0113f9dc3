//! A group comparison's statistic over the template: one slice of the t
//! (or F) image, the voxels with a family-wise p below the level outlined.

use unfold_render::{ColorScale, Colormap, Image, draw_colorbar};

use super::axes::{check_panel, map_frame, title_band};
use super::slices::EMPTY;
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};
use crate::mesh::Volume;
use crate::mesh::nalgebra::Point3;

/// The file name of the comparison figure of image `image` and column
/// `column` (both file-name safe): `compare_<image>_<column>.png`.
pub fn statistic_name(image: &str, column: &str) -> String {
    format!("compare_{image}_{column}.png")
}

/// A comparison's maps of one image on its common grid.
#[derive(Debug, Clone, Copy)]
pub struct StatisticMaps<'a> {
    /// The image's name (`t2`, ...).
    pub image: &'a str,
    /// The compared column.
    pub column: &'a str,
    /// `t` or `F`.
    pub statistic_name: &'a str,
    /// The statistic (NaN where untested).
    pub statistic: &'a Volume<f32>,
    /// The family-wise p (1 where untested).
    pub p_fwe: &'a Volume<f32>,
    /// The family-wise level outlined.
    pub alpha: f64,
}

impl StatisticMaps<'_> {
    fn tested(&self, i: usize, j: usize, k: usize) -> bool {
        self.statistic
            .get(i, j, k, 0)
            .is_some_and(|v| v.is_finite())
    }

    fn significant(&self, i: usize, j: usize, k: usize) -> bool {
        self.tested(i, j, k)
            && self
                .p_fwe
                .get(i, j, k, 0)
                .is_some_and(|p| f64::from(p) < self.alpha)
    }
}

/// The slice shown: the one holding the smallest family-wise p among the
/// tested voxels (the lowest such slice on ties), or the middle slice when
/// none is tested.
pub fn chosen_slice(maps: &StatisticMaps<'_>) -> usize {
    let [nx, ny, nz, _] = maps.statistic.dims();
    let mut best: Option<(f32, usize)> = None;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if !maps.tested(i, j, k) {
                    continue;
                }
                let p = maps.p_fwe.get(i, j, k, 0).unwrap_or(1.0);
                if best.is_none_or(|(b, _)| p < b) {
                    best = Some((p, k));
                }
            }
        }
    }
    best.map_or(nz / 2, |(_, k)| k)
}

/// The figure [`statistic_name`]: slice [`chosen_slice`] of the statistic
/// (t: blue-red symmetric about 0; F: magma from its range) over the tested
/// voxels' extent (two voxels of margin), untested voxels in
/// [`EMPTY`], the voxels with `p_fwe < alpha` outlined in black, template x
/// right and y up in mm with equal scales, and a colour bar.
///
/// # Errors
/// [`FigureError::Input`] when the two maps are not on one grid or the
/// panel is too small; the renderer's.
pub fn statistic_slice(
    maps: &StatisticMaps<'_>,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    let name = statistic_name(maps.image, maps.column);
    check_panel(&name, opts)?;
    let d = maps.statistic.dims();
    if maps.p_fwe.dims()[..3] != d[..3]
        || (maps.p_fwe.affine() - maps.statistic.affine())
            .iter()
            .any(|x| x.abs() > 1e-6)
    {
        return Err(FigureError::input(
            &name,
            "the statistic and p_fwe images are not on one grid",
        ));
    }
    let k = chosen_slice(maps);
    let [nx, ny, nz, _] = d;
    let (mut i0, mut i1, mut j0, mut j1) = (usize::MAX, 0, usize::MAX, 0);
    let mut values = Vec::new();
    let mut significant = 0usize;
    for j in 0..ny {
        for i in 0..nx {
            if maps.tested(i, j, k) {
                (i0, i1, j0, j1) = (i0.min(i), i1.max(i), j0.min(j), j1.max(j));
                values.push(f64::from(maps.statistic.get(i, j, k, 0).unwrap_or(0.0)));
                significant += usize::from(maps.significant(i, j, k));
            }
        }
    }
    if i0 == usize::MAX {
        (i0, i1, j0, j1) = (0, nx - 1, 0, ny - 1);
    } else {
        (i0, i1) = (i0.saturating_sub(2), (i1 + 2).min(nx - 1));
        (j0, j1) = (j0.saturating_sub(2), (j1 + 2).min(ny - 1));
    }
    let corner = |i: f64, j: f64| maps.statistic.voxel_to_world(&Point3::new(i, j, k as f64));
    let (a, b) = (
        corner(i0 as f64 - 0.5, j0 as f64 - 0.5),
        corner(i1 as f64 + 0.5, j1 as f64 + 0.5),
    );
    let (xlo, xhi) = (a.x.min(b.x), a.x.max(b.x));
    let (ylo, yhi) = (a.y.min(b.y), a.y.max(b.y));
    let z_mm = corner(0.0, 0.0).z;
    let scale = if maps.statistic_name == "t" {
        ColorScale::symmetric(Colormap::BlueRed, &values)
    } else {
        ColorScale::from_values(Colormap::Magma, &values)
    };
    let err = || FigureError::render(&name);
    let mut img = Image::new(opts.panel_width, opts.panel_height, PAPER).map_err(err())?;
    title_band(
        &mut img,
        &format!(
            "{} of {} by {}",
            maps.statistic_name, maps.image, maps.column
        ),
        &format!(
            "template z = {} mm (slice {} of {nz}); outlined: p_fwe < {} ({significant} voxels \
             in this slice); grey: untested",
            unfold_render::format_value(z_mm),
            k + 1,
            maps.alpha
        ),
    )
    .map_err(err())?;
    let frame = map_frame(&mut img, opts, (xlo, xhi), (ylo, yhi)).map_err(err())?;
    // The voxel under each pixel, then the slice and the outline.
    let voxel = |px: i64, py: i64| -> Option<(usize, usize)> {
        let (x, y) = frame.point(xlo, yhi, px, py);
        let v = maps.statistic.world_to_voxel(&Point3::new(x, y, z_mm));
        let (i, j) = (v.x.round(), v.y.round());
        (i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny)
            .then_some((i as usize, j as usize))
    };
    let sig = |px: i64, py: i64| voxel(px, py).is_some_and(|(i, j)| maps.significant(i, j, k));
    for py in 0..frame.height {
        for px in 0..frame.width {
            let c = match voxel(px, py) {
                Some((i, j)) if maps.tested(i, j, k) => {
                    let v = maps.statistic.get(i, j, k, 0).unwrap_or(0.0);
                    if sig(px, py)
                        && [(-1, 0), (1, 0), (0, -1), (0, 1)]
                            .iter()
                            .any(|(dx, dy)| !sig(px + dx, py + dy))
                    {
                        INK
                    } else {
                        scale.color(f64::from(v)).opaque()
                    }
                }
                _ => EMPTY,
            };
            img.put(frame.x0 + px, frame.y0 + py, c);
        }
    }
    img.stroke_rect(frame.area, INK);
    draw_colorbar(&mut img, frame.bar, &scale, maps.statistic_name, INK, 1).map_err(err())?;
    Ok(Figure::new(name, img))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::nalgebra::Matrix4;

    fn grid(f: impl Fn(usize, usize, usize) -> f32) -> Volume<f32> {
        let (nx, ny, nz) = (12, 10, 5);
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
        Volume::new([nx, ny, nz, 1], a, data).unwrap()
    }

    #[test]
    fn the_slice_of_the_smallest_p_and_an_outlined_region() {
        let tested = |i: usize, j: usize| (1..11).contains(&i) && (1..9).contains(&j);
        let stat = grid(|i, j, _| {
            if tested(i, j) {
                i as f32 - 5.0
            } else {
                f32::NAN
            }
        });
        let p = grid(|i, j, k| {
            if tested(i, j) && i >= 8 && k == 3 {
                0.01
            } else {
                0.5
            }
        });
        let maps = StatisticMaps {
            image: "t2",
            column: "group",
            statistic_name: "t",
            statistic: &stat,
            p_fwe: &p,
            alpha: 0.05,
        };
        assert_eq!(chosen_slice(&maps), 3);
        let opts = FigureOptions::default();
        let f = statistic_slice(&maps, &opts).unwrap();
        assert_eq!(f.name, "compare_t2_group.png");
        let again = statistic_slice(&maps, &opts).unwrap();
        assert_eq!(f.image.as_bytes(), again.image.as_bytes());
        // the outline adds black pixels to those of the frame and text
        let black = |f: &Figure| {
            (0..f.image.height() as i64)
                .flat_map(|y| (0..f.image.width() as i64).map(move |x| (x, y)))
                .filter(|&(x, y)| f.image.get(x, y) == Some(INK))
                .count()
        };
        let p_none = grid(|_, _, _| 0.5);
        let plain = statistic_slice(
            &StatisticMaps {
                p_fwe: &p_none,
                ..maps
            },
            &opts,
        )
        .unwrap();
        assert!(
            black(&f) > black(&plain) + 20,
            "{} {}",
            black(&f),
            black(&plain)
        );
        let none = grid(|_, _, _| f32::NAN);
        let maps = StatisticMaps {
            statistic: &none,
            ..maps
        };
        assert_eq!(chosen_slice(&maps), 2);
    }
}
