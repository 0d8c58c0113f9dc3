//! [`SENSITIVITY_PNG`]: the landmark sensitivity of `unfold ventricle
//! --sensitivity MM` on the disk (the source paper's Fig. 15-17 seen from
//! the top): each anatomy point a dot at its displayed disk position,
//! coloured by its value (the largest reconstruction error over the
//! perturbations, mm) on [`SENSITIVITY_COLORMAP`] from 0 to the largest
//! value; points without a value (NaN) in grey. LV disk in the clinical
//! orientation of the bull's-eye (septum left, anterior up), RV half disk
//! in its own axes.

use std::f64::consts::{PI, TAU};

use unfold_organs::ventricle::Chamber;
use unfold_organs::ventricle::disk::RV_CENTRE;
use unfold_render::{ColorScale, Colormap, FillRule, Image, NAN_COLOR, Rgb, arc};

use super::disk_layout::{DiskLayout, disk_area};
use super::drawing::{colorbar_column, dot, orientation_words, title_band};
use super::{COLORBAR_COLUMN, TITLE_BAND, disk_layout, figure_size};
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// File name of the figure.
pub const SENSITIVITY_PNG: &str = "sensitivity.png";

/// Colour map of the values: 0 at `t = 0`, the largest at `t = 1`.
pub const SENSITIVITY_COLORMAP: Colormap = Colormap::Viridis;

/// Fill of the disk under the dots.
const DISK_FILL: Rgb = Rgb::new(236, 236, 236);

/// Where the disk sits: the RV's [`disk_layout`]; the LV's unit disk
/// mirrored (septum left) in the same area (the panel less the colour bar
/// column), room left for the orientation words.
fn layout(chamber: Chamber, opts: &FigureOptions) -> Result<DiskLayout, FigureError> {
    match chamber {
        Chamber::Rv => disk_layout(Chamber::Rv, opts),
        Chamber::Lv => {
            let (w, h) = disk_area(Chamber::Rv, opts)?;
            let (w, h) = (f64::from(w), f64::from(h));
            Ok(DiskLayout {
                centre: [0.5 * w, TITLE_BAND as f64 + 0.5 * h],
                scale: (0.5 * w - 8.0 * 9.0).min(0.5 * h - 22.0).floor().max(10.0),
                origin: [0.0, 0.0],
                mirrored: true,
            })
        }
    }
}

/// [`SENSITIVITY_PNG`] (1 x 1 panel): `values[k]` at the displayed disk
/// position `shown[k]`, titled with the displacement `mm`.
///
/// # Errors
/// [`FigureError::Input`] when the lengths differ, there is no point or the
/// panel is too small; the renderer's.
pub fn sensitivity_figure(
    chamber: Chamber,
    shown: &[[f64; 2]],
    values: &[f64],
    mm: f64,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = SENSITIVITY_PNG;
    if shown.len() != values.len() || shown.is_empty() {
        return Err(FigureError::input(
            F,
            format!(
                "{} disk positions for {} values (one each, at least one)",
                shown.len(),
                values.len()
            ),
        ));
    }
    let (w, h) = figure_size(opts, 1, 1)?;
    let layout = layout(chamber, opts)?;
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    let top = values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let scale = ColorScale::new(SENSITIVITY_COLORMAP, 0.0, if top > 0.0 { top } else { 1.0 });
    // The disk (LV) or half disk (RV) under the dots, and its outline.
    let outline = match chamber {
        Chamber::Lv => arc(layout.pixel([0.0, 0.0]), layout.scale, 0.0, TAU),
        Chamber::Rv => arc(layout.pixel(RV_CENTRE), layout.scale, -0.5 * PI, 0.5 * PI),
    };
    img.fill_polygon(&outline, FillRule::NonZero, DISK_FILL.opaque());
    img.polyline(&outline, true, INK);
    // Smallest first, so that the largest values stay on top; NaN first.
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| {
        let key = |v: f64| if v.is_finite() { v } else { f64::NEG_INFINITY };
        key(values[a]).total_cmp(&key(values[b]))
    });
    for k in order {
        let c = if values[k].is_finite() {
            scale.color(values[k])
        } else {
            NAN_COLOR
        };
        dot(&mut img, layout.pixel(shown[k]), 2.5, c.opaque());
    }
    if chamber == Chamber::Lv {
        orientation_words(&mut img, F, &layout)?;
    }
    let missing = values.iter().filter(|v| !v.is_finite()).count();
    let mut subtitle = format!(
        "{} anatomy points; landmarks moved {mm} mm (10 ways): the largest |v - psi_k^-1(psi(v))|",
        values.len()
    );
    if missing > 0 {
        subtitle.push_str(&format!(
            "; {missing} not mapped by some perturbation (grey)"
        ));
    }
    title_band(&mut img, F, "landmark sensitivity", &subtitle)?;
    colorbar_column(
        &mut img,
        F,
        i64::from(w) - COLORBAR_COLUMN,
        &scale,
        &["largest error", "(mm)"],
    )?;
    Ok(Figure::new(F, img))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(img: &Image, c: Rgb) -> usize {
        let c = c.opaque();
        (0..img.height() as i64)
            .flat_map(|y| (0..img.width() as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get(x, y) == Some(c))
            .count()
    }

    #[test]
    fn the_dots_take_the_colours_of_their_values() {
        let opts = FigureOptions::default();
        let shown = [[0.5, 0.0], [0.0, 0.5], [-0.5, -0.5]];
        let values = [0.0, 2.0, f64::NAN];
        let f = sensitivity_figure(Chamber::Lv, &shown, &values, 3.0, &opts).unwrap();
        assert_eq!(f.name, SENSITIVITY_PNG);
        assert_eq!(
            (f.image.width(), f.image.height()),
            (opts.panel_width, opts.panel_height)
        );
        let scale = ColorScale::new(SENSITIVITY_COLORMAP, 0.0, 2.0);
        let l = layout(Chamber::Lv, &opts).unwrap();
        // each dot's centre pixel has its value's colour
        for (p, v) in shown.iter().zip(values) {
            let c = l.pixel(*p);
            let want = if v.is_finite() {
                scale.color(v)
            } else {
                NAN_COLOR
            };
            assert_eq!(
                f.image.get(c[0] as i64, c[1] as i64),
                Some(want.opaque()),
                "{p:?}"
            );
        }
        // the septum (+xi) is drawn left of the centre
        assert!(l.pixel([0.5, 0.0])[0] < l.centre[0]);
        assert!(count(&f.image, DISK_FILL) > 1000);
        let e = sensitivity_figure(Chamber::Lv, &shown, &values[..2], 3.0, &opts).unwrap_err();
        assert!(
            e.to_string().contains("3 disk positions for 2 values"),
            "{e}"
        );
        let rv = sensitivity_figure(Chamber::Rv, &[[1.75, 0.0]], &[1.0], 1.0, &opts).unwrap();
        assert_eq!(rv.image.width(), opts.panel_width);
    }
}
