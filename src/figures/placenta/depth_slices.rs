//! The depth figure of a pulled-back image (`<name>_depths.png`): five
//! slices of constant template `z` from the fetal to the maternal side and
//! a panel of notes and the colour bar.

use unfold_render::{Anchor, ColorScale, Colormap, Image, Rect, format_value};

use super::depths::Depths;
use super::drawing::{PANEL_EDGE, panel, scale_bar};
use super::meshes::Meshes;
use super::numbers::{nice_length, percentile, signed};
use super::sampling::sample_masked;
use super::{DEPTH_FRACTIONS, FlatImage, TITLE_BAND};
use crate::figures::layout::compose;
use crate::figures::{FigureError, FigureOptions, INK};
use crate::mesh::nalgebra::{Point3, Vector3};

/// Five slices of constant template `z` of one image and a colour bar panel.
pub(super) fn depth_slices(
    img: &FlatImage<'_>,
    m: &Meshes<'_>,
    depths: &Depths,
    opts: &FigureOptions,
    name: &str,
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let (pw, ph) = (opts.panel_width, opts.panel_height);
    let bottom = 34;
    let (ax, ay) = (8u32, TITLE_BAND);
    let (aw, ah) = (pw - 2 * ax, ph - TITLE_BAND - bottom);
    // The flattened mesh's x-y extent, with a small margin, fills the area.
    let (lo, hi) = m.flattened.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let (cx, cy) = (0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
    let (ex, ey) = (
        (hi.x - lo.x).max(1e-6) * 1.04,
        (hi.y - lo.y).max(1e-6) * 1.04,
    );
    let s = (f64::from(aw) / ex).min(f64::from(ah) / ey);
    let (w2, h2) = (0.5 * f64::from(aw), 0.5 * f64::from(ah));
    let mut slices: Vec<Vec<Option<f64>>> = Vec::with_capacity(DEPTH_FRACTIONS.len());
    let mut all = Vec::new();
    for &f in &DEPTH_FRACTIONS {
        let z = depths.z(f);
        let mut vals = Vec::with_capacity((aw * ah) as usize);
        for j in 0..ah {
            let y = cy - (f64::from(j) + 0.5 - h2) / s;
            for i in 0..aw {
                let x = cx + (f64::from(i) + 0.5 - w2) / s;
                let v = sample_masked(img.volume, &Point3::new(x, y, z), 0);
                if let Some(v) = v {
                    all.push(v);
                }
                vals.push(v);
            }
        }
        slices.push(vals);
    }
    if all.is_empty() {
        let d = img.volume.dims();
        return Err(FigureError::input(
            name,
            format!(
                "the image {:?} ({}x{}x{} voxels) has no non-zero voxel in the flattened \
                 mesh's slab (template x in [{}, {}], y in [{}, {}], z in [{}, {}] mm); \
                 is it a pulled-back image (<name>_flat.nii.gz, template frame)?",
                img.name,
                d[0],
                d[1],
                d[2],
                format_value(lo.x),
                format_value(hi.x),
                format_value(lo.y),
                format_value(hi.y),
                format_value(depths.bottom),
                format_value(depths.top),
            ),
        ));
    }
    all.sort_by(f64::total_cmp);
    let (vlo, vhi) = (
        percentile(&all, 0.01).unwrap_or(0.0),
        percentile(&all, 0.99).unwrap_or(1.0),
    );
    let scale = ColorScale::new(Colormap::Viridis, vlo, vhi);
    let bar = nice_length(0.3 * f64::from(aw) / s);

    let mut panels = Vec::with_capacity(6);
    for (k, (&f, vals)) in DEPTH_FRACTIONS.iter().zip(&slices).enumerate() {
        let z = depths.z(f);
        let title = format!("z = {} mm", signed(z));
        let subtitle = format!(
            "depth {}% from the fetal side",
            format_value(50.0 * (1.0 - f))
        );
        let mut p = panel(opts, &title, &subtitle, 2).map_err(err(name))?;
        for j in 0..ah {
            for i in 0..aw {
                if let Some(v) = vals[(j * aw + i) as usize] {
                    p.put(
                        i64::from(ax + i),
                        i64::from(ay + j),
                        scale.color(v).opaque(),
                    );
                }
            }
        }
        p.stroke_rect(
            Rect::new(ax as i32 - 1, ay as i32 - 1, aw + 2, ah + 2),
            PANEL_EDGE,
        );
        scale_bar(&mut p, f64::from(ax) + 4.0, f64::from(ph) - 10.0, bar, s).map_err(err(name))?;
        if k == 0 {
            // Orientation: template x to the right, y up.
            let (ox, oy) = (f64::from(pw) - 40.0, f64::from(ph) - 6.0);
            let l = 20.0;
            p.line([ox, oy], [ox + l, oy], INK);
            p.line([ox + l, oy], [ox + l - 4.0, oy - 3.0], INK);
            p.line([ox + l, oy], [ox + l - 4.0, oy + 3.0], INK);
            p.line([ox, oy], [ox, oy - l], INK);
            p.line([ox, oy - l], [ox - 3.0, oy - l + 4.0], INK);
            p.line([ox, oy - l], [ox + 3.0, oy - l + 4.0], INK);
            p.draw_text(
                (ox + l + 4.0) as i32,
                (oy - 6.0) as i32,
                "x",
                1,
                INK,
                Anchor::Left,
            )
            .map_err(err(name))?;
            p.draw_text(
                (ox + 6.0) as i32,
                (oy - l) as i32,
                "y",
                1,
                INK,
                Anchor::Left,
            )
            .map_err(err(name))?;
        }
        panels.push(p);
    }

    // The colour bar panel.
    let mut p = panel(opts, img.name, "pulled back into the template", 2).map_err(err(name))?;
    let frames = img.volume.frames();
    let [fetal, maternal] = depths.describe();
    let mut notes = vec![
        "slices of constant template z".to_string(),
        fetal,
        maternal,
        depths.label.clone(),
        "white: outside the mesh".into(),
        "colours: 1-99th percentile".into(),
    ];
    if frames > 1 {
        notes.push(format!("frame 1 of {frames}"));
    }
    super::drawing::notes(&mut p, &notes, 4, Some((&scale, 10, 40))).map_err(err(name))?;
    panels.push(p);
    compose(&panels, 6, opts).map_err(err(name))
}
