//! The frames figure of a 4D pulled-back image (`<name>_frames.png`): the
//! mid-depth slice (template `z = z_m`, the middle between the fetal and
//! maternal levels) of every frame, as a strip of thumbnails on one
//! intensity scale, [`FRAME_COLUMNS`] per row, then a panel with the colour
//! bar.
//!
//! Thumbnails are half a panel on each side (at least
//! [`MIN_PANEL`](super::MIN_PANEL)). A series with more frames than the
//! renderer's largest image holds ([`unfold_render::MAX_SIDE`] pixels of
//! rows) shows every `k`-th frame, `k` the smallest stride that fits, and
//! says so.

use unfold_render::{ColorScale, Colormap, Image, MAX_SIDE, format_value};

use super::depths::Depths;
use super::drawing::panel;
use super::meshes::Meshes;
use super::numbers::{nice_length, percentile, signed};
use super::raster::Area;
use super::sampling::sample_masked;
use super::{FlatImage, MIN_PANEL};
use crate::figures::layout::compose;
use crate::figures::{FigureError, FigureOptions};
use crate::mesh::nalgebra::Point3;

/// Thumbnails per row.
pub const FRAME_COLUMNS: u32 = 8;

/// The size of a thumbnail: half of `opts`' panel, at least [`MIN_PANEL`].
pub fn thumbnail_options(opts: &FigureOptions) -> FigureOptions {
    FigureOptions {
        panel_width: (opts.panel_width / 2).max(MIN_PANEL.0),
        panel_height: (opts.panel_height / 2).max(MIN_PANEL.1),
    }
}

/// The frames shown of a series of `frames`: `0, k, 2k, ...` with the
/// smallest stride `k >= 1` for which they and the colour-bar panel fit in
/// rows of [`FRAME_COLUMNS`] thumbnails of height `thumb_height` within
/// [`MAX_SIDE`] pixels.
pub fn shown_frames(frames: usize, thumb_height: u32) -> Vec<usize> {
    let rows = (MAX_SIDE / thumb_height.max(1)).max(1) as usize;
    let capacity = (rows * FRAME_COLUMNS as usize).saturating_sub(1).max(1);
    let stride = frames.div_ceil(capacity).max(1);
    (0..frames).step_by(stride).collect()
}

/// The frames figure of `img` (a series of at least two frames).
pub(super) fn frames(
    img: &FlatImage<'_>,
    m: &Meshes<'_>,
    depths: &Depths,
    opts: &FigureOptions,
    name: &str,
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let thumb = thumbnail_options(opts);
    let area = Area::of(&thumb);
    let total = img.volume.frames();
    let shown = shown_frames(total, thumb.panel_height);

    let (lo, hi) = m.flattened.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(mut lo, mut hi), p| {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
            (lo, hi)
        },
    );
    let centre = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
    let s = area.fit(
        (hi[0] - lo[0]).max(1e-6) * 1.04,
        (hi[1] - lo[1]).max(1e-6) * 1.04,
    );
    let zm = depths.z(0.0);
    let slices: Vec<Vec<Option<f64>>> = shown
        .iter()
        .map(|&t| {
            area.sample(centre, s, |x, y| {
                sample_masked(img.volume, &Point3::new(x, y, zm), t)
            })
        })
        .collect();
    let mut all: Vec<f64> = slices.iter().flatten().flatten().copied().collect();
    if all.is_empty() {
        return Err(FigureError::input(
            name,
            format!(
                "the series {:?} has no non-zero voxel in any frame on the mid-depth slice \
                 z = {} mm",
                img.name,
                format_value(zm)
            ),
        ));
    }
    all.sort_by(f64::total_cmp);
    let scale = ColorScale::new(
        Colormap::Viridis,
        percentile(&all, 0.01).unwrap_or(0.0),
        percentile(&all, 0.99).unwrap_or(1.0),
    );
    let bar = nice_length(0.3 * f64::from(area.aw) / s);
    let mut panels = Vec::with_capacity(shown.len() + 1);
    for (&t, vals) in shown.iter().zip(&slices) {
        let title = format!("frame {}", t + 1);
        let mut p = panel(&thumb, &title, &format!("of {total}"), 1).map_err(err(name))?;
        area.paint(&mut p, vals, &scale, bar, s)
            .map_err(err(name))?;
        panels.push(p);
    }

    let mut p = panel(&thumb, img.name, "every frame", 1).map_err(err(name))?;
    let stride = shown.get(1).map_or(1, |&k| k);
    let mut notes = vec![
        format!("{} frames, mid-depth", total),
        format!("z = {} mm", signed(zm)),
        "one scale (1-99th pct.)".to_string(),
    ];
    if stride > 1 {
        notes.push(format!("every {stride}th frame shown"));
    }
    super::drawing::notes(&mut p, &notes, 2, Some((&scale, 6, 30))).map_err(err(name))?;
    panels.push(p);
    let columns = FRAME_COLUMNS.min(panels.len() as u32);
    compose(&panels, columns, &thumb).map_err(err(name))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The shown frames start at 0, keep one stride, and fit with the
        /// colour-bar panel in MAX_SIDE pixels of rows; the stride is 1
        /// whenever every frame fits.
        #[test]
        fn shown_frames_fit_and_keep_one_stride(frames in 2usize..20_000, h in 200u32..2000) {
            let shown = shown_frames(frames, h);
            prop_assert_eq!(shown[0], 0);
            let stride = shown.get(1).copied().unwrap_or(1);
            prop_assert!(shown.windows(2).all(|w| w[1] - w[0] == stride));
            let rows = (shown.len() as u32 + 1).div_ceil(FRAME_COLUMNS);
            prop_assert!(u64::from(rows) * u64::from(h) <= u64::from(MAX_SIDE));
            let capacity = ((MAX_SIDE / h) * FRAME_COLUMNS) as usize - 1;
            if frames <= capacity {
                prop_assert_eq!(shown.len(), frames);
            }
            prop_assert!(*shown.last().unwrap() < frames);
        }
    }
}
