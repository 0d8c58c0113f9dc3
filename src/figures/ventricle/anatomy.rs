//! The anatomy drawn in 3D: [`ANATOMY_AHA_PNG`] (the LV anatomy coloured by
//! AHA segment, seen from the septum and from the lateral wall) and
//! [`TRANSFER_PNG`] (the anatomy beside its transfer into a second heart
//! or onto a hemisphere, in the same colours).
//!
//! The view of a heart is taken from its own points and labels, so that
//! two hearts (or a heart and a hemisphere) are shown alike whatever their
//! scanner frames:
//!
//! ```text
//! LV (AHA labels):  a = unit(c_apical - c_basal)     c_basal: mean of the points in 1-6,
//!                                                    c_apical: in 13-17
//!                   s = unit((c_septal - c) - ((c_septal - c) . a) a)
//!                                                    c_septal: mean of 2, 3, 8, 9, 14
//! RV (no labels):   a, s = the first two principal axes of the points
//! ```
//!
//! and the camera looks at the centroid `c` along `-s` (from the septum) or
//! `+s` (from the lateral wall), orthographic, with `-a` up (base up, apex
//! down).

use unfold_mesh::CellMesh;
use unfold_organs::ventricle::{Chamber, Outcome};
use unfold_render::nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};
use unfold_render::{Anchor, Camera, ColorScale, Coloring, Image, Rect, Renderer, Rgb, Shading};

use super::cylinder::{Drawable, drawable};
use super::drawing::{aha_rows, colorbar_column, text, title_band};
use super::{AHA_COLORS, COLORBAR_COLUMN, DEPTH_COLORMAP, SOFT_INK, TITLE_BAND};
use super::{figure_size, segments_present};
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};
use unfold_render::NAN_COLOR;

/// File name of the LV anatomy coloured by AHA segment.
pub const ANATOMY_AHA_PNG: &str = "anatomy_aha.png";

/// File name of the transfer figure.
pub const TRANSFER_PNG: &str = "transfer.png";

/// How a heart is viewed: its centroid, the unit long axis `a` (base to
/// apex) and the unit septal direction `s` (perpendicular to `a`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeartView {
    /// The centroid of the points.
    pub centre: Point3<f64>,
    /// Base to apex.
    pub axis: Vector3<f64>,
    /// Towards the septum (LV) or the second principal axis (RV).
    pub septal: Vector3<f64>,
}

/// The mean of the points whose label is in `segments`.
fn mean_of(points: &[Point3<f64>], aha: &[u8], segments: &[u8]) -> Option<Point3<f64>> {
    let (sum, n) = points
        .iter()
        .zip(aha)
        .filter(|(_, l)| segments.contains(l))
        .fold((Vector3::zeros(), 0usize), |(s, n), (p, _)| {
            (s + p.coords, n + 1)
        });
    (n > 0).then(|| Point3::from(sum / n as f64))
}

/// The view of a heart from its points and (LV) AHA labels (see the
/// module's formulas). `None` when the points do not define one: no points,
/// a label group without points, or coincident centroids.
pub fn heart_view(points: &[Point3<f64>], aha: Option<&[u8]>) -> Option<HeartView> {
    if points.is_empty() {
        return None;
    }
    let centre = Point3::from(
        points
            .iter()
            .fold(Vector3::zeros(), |acc, p| acc + p.coords)
            / points.len() as f64,
    );
    let (axis, septal) = match aha {
        Some(aha) => {
            let basal = mean_of(points, aha, &[1, 2, 3, 4, 5, 6])?;
            let apical = mean_of(points, aha, &[13, 14, 15, 16, 17])?;
            let sept = mean_of(points, aha, &[2, 3, 8, 9, 14])?;
            let a = (apical - basal).try_normalize(1e-12)?;
            let d = sept - centre;
            ((a), (d - d.dot(&a) * a).try_normalize(1e-12)?)
        }
        None => {
            let mut cov = Matrix3::zeros();
            for p in points {
                let d = p - centre;
                cov += d * d.transpose();
            }
            let eig = SymmetricEigen::new(cov);
            let mut order = [0usize, 1, 2];
            order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
            let a: Vector3<f64> = eig.eigenvectors.column(order[0]).into();
            let s: Vector3<f64> = eig.eigenvectors.column(order[1]).into();
            (a.try_normalize(1e-12)?, s.try_normalize(1e-12)?)
        }
    };
    Some(HeartView {
        centre,
        axis,
        septal,
    })
}

/// The anatomy `mesh` rendered into `aw x ah` pixels, coloured per point,
/// seen from `side` (`+1` the septum, `-1` the lateral wall) of `view`,
/// framed on the points; `d` is what of `mesh` is drawn ([`drawable`]).
fn render_heart(
    mesh: &CellMesh,
    d: &Drawable,
    colors: &[Rgb],
    view: &HeartView,
    side: f64,
    (aw, ah): (u32, u32),
    figure: &str,
) -> Result<Image, FigureError> {
    let forward = -side * view.septal;
    let up = -view.axis;
    let right = forward.cross(&up);
    // Half extents across (right) and along (up), from the points.
    let (mut hx, mut hy) = (1e-6f64, 1e-6f64);
    for p in &mesh.positions {
        let q = p - view.centre;
        hx = hx.max(q.dot(&right).abs());
        hy = hy.max(q.dot(&up).abs());
    }
    let half_height = (hy * 1.08).max(hx * 1.08 * f64::from(ah) / f64::from(aw));
    let reach = 4.0 * hx.max(hy).max(1.0);
    let cam = Camera::orthographic(view.centre - reach * forward, view.centre, up, half_height)
        .map_err(FigureError::render(figure))?;
    let mut r = Renderer::new(aw, ah, PAPER, cam).map_err(FigureError::render(figure))?;
    if !d.triangles.is_empty() {
        r.draw_mesh(
            &mesh.positions,
            &d.triangles,
            Coloring::PerVertex(colors),
            Shading::Smooth,
        )
        .map_err(FigureError::render(figure))?;
    }
    for s in &d.segments {
        let c = colors[s[0] as usize].opaque();
        r.draw_polyline_3d(
            &[mesh.positions[s[0] as usize], mesh.positions[s[1] as usize]],
            false,
            c,
        )
        .map_err(FigureError::render(figure))?;
    }
    for &v in &d.points {
        if let Some(q) = r.project(&mesh.positions[v as usize]) {
            let rect = Rect::new(q.x as i32 - 2, q.y as i32 - 2, 5, 5);
            r.image_mut().fill_rect(rect, colors[v as usize].opaque());
        }
    }
    Ok(r.image().clone())
}

/// The AHA colour of each point (grey for a label outside 1-17).
fn aha_colors(aha: &[u8]) -> Vec<Rgb> {
    aha.iter()
        .map(|&l| {
            if (1..=17).contains(&l) {
                AHA_COLORS[l as usize - 1]
            } else {
                NAN_COLOR
            }
        })
        .collect()
}

/// The legend panel of the AHA colours at `x0` (with each segment's point
/// count).
fn aha_legend(img: &mut Image, figure: &str, x0: i64, aha: &[u8]) -> Result<(), FigureError> {
    let h = i64::from(img.height());
    let mut y = TITLE_BAND + 4;
    let row_h = ((h - y - 30) / 19).clamp(9, 16);
    let mut counts = [0usize; 18];
    for &l in aha {
        counts[(l as usize).min(17)] += 1;
    }
    text(
        img,
        figure,
        x0,
        y,
        "AHA segment (anatomy points)",
        INK,
        Anchor::Left,
    )?;
    y += row_h + 2;
    let y = aha_rows(img, figure, x0, y, row_h, &counts)?;
    text(
        img,
        figure,
        x0,
        y + 6,
        "base up, apex down",
        SOFT_INK,
        Anchor::Left,
    )?;
    Ok(())
}

/// [`ANATOMY_AHA_PNG`]: 3 x 1 panels, the LV anatomy from the septum, from
/// the lateral wall, and the legend.
pub(super) fn anatomy_aha(outcome: &Outcome, opts: &FigureOptions) -> Result<Figure, FigureError> {
    const F: &str = ANATOMY_AHA_PNG;
    let (w, h) = figure_size(opts, 3, 1)?;
    let mesh = &outcome.anatomy;
    let aha = &outcome.aha;
    let view = heart_view(&mesh.positions, Some(aha)).ok_or_else(|| {
        FigureError::input(
            F,
            format!(
                "the anatomy's AHA labels do not give a view (basal, apical and septal \
                 segments needed; present: {:?})",
                segments_present(aha)
            ),
        )
    })?;
    let colors = aha_colors(aha);
    let d = drawable(mesh).map_err(|e| FigureError::input(F, format!("the anatomy: {e}")))?;
    let (pw, ah) = (opts.panel_width, (i64::from(h) - TITLE_BAND) as u32);
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    for (k, (side, words)) in [(1.0, "from the septum"), (-1.0, "from the lateral wall")]
        .into_iter()
        .enumerate()
    {
        let panel = render_heart(mesh, &d, &colors, &view, side, (pw, ah), F)?;
        let x = i64::from(pw) * k as i64;
        img.blit(&panel, x, TITLE_BAND);
        text(
            &mut img,
            F,
            x + i64::from(pw) / 2,
            TITLE_BAND + 2,
            words,
            INK,
            Anchor::Center,
        )?;
    }
    title_band(
        &mut img,
        F,
        "LV anatomy by AHA segment",
        "in the scanner frame, orthographic; long axis from the basal to the apical segments",
    )?;
    aha_legend(&mut img, F, 2 * i64::from(pw) + 8, aha)?;
    Ok(Figure::new(F, img))
}

/// [`TRANSFER_PNG`]: 3 x 1 panels, the anatomy of `outcome` in its heart
/// and the same points `transferred` into a second heart (or onto a
/// hemisphere) named `target` (the anatomy with its points moved: its
/// cells are drawn as the anatomy's), each from its own lateral wall
/// ([`heart_view`]); LV points coloured by AHA segment (legend), RV points
/// by depth (colour bar).
///
/// # Errors
/// [`FigureError::Input`] when `transferred` has another number of points
/// than the anatomy, or a view cannot be found; [`FigureError::Render`] as
/// the renderer.
pub fn transfer_figure(
    outcome: &Outcome,
    transferred: &CellMesh,
    target: &str,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = TRANSFER_PNG;
    let (w, h) = figure_size(opts, 3, 1)?;
    let n = outcome.anatomy.positions.len();
    if transferred.positions.len() != n {
        return Err(FigureError::input(
            F,
            format!(
                "the transferred anatomy has {} points, the anatomy {n}",
                transferred.positions.len()
            ),
        ));
    }
    let chamber = outcome.report.chamber;
    let (aha, colors, scale) = match chamber {
        Chamber::Lv => (Some(&outcome.aha[..]), aha_colors(&outcome.aha), None),
        Chamber::Rv => {
            let depth: Vec<f64> = outcome.coords.iter().map(|c| c.depth).collect();
            let scale = ColorScale::from_values(DEPTH_COLORMAP, &depth);
            (None, scale.colors(&depth), Some(scale))
        }
    };
    // The transferred anatomy keeps the anatomy's cells: one drawable.
    let d = drawable(&outcome.anatomy)
        .map_err(|e| FigureError::input(F, format!("the anatomy: {e}")))?;
    let (pw, ah) = (opts.panel_width, (i64::from(h) - TITLE_BAND) as u32);
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    for (k, (mesh, words)) in [
        (&outcome.anatomy, "the anatomy".to_string()),
        (transferred, format!("in {target}")),
    ]
    .into_iter()
    .enumerate()
    {
        let view = heart_view(&mesh.positions, aha).ok_or_else(|| {
            FigureError::input(F, format!("{words}: the points do not give a view"))
        })?;
        let panel = render_heart(mesh, &d, &colors, &view, -1.0, (pw, ah), F)?;
        let x = i64::from(pw) * k as i64;
        img.blit(&panel, x, TITLE_BAND);
        text(
            &mut img,
            F,
            x + i64::from(pw) / 2,
            TITLE_BAND + 2,
            &words,
            INK,
            Anchor::Center,
        )?;
    }
    title_band(
        &mut img,
        F,
        "Transfer: psi_2^-1(psi(v))",
        "each heart from its lateral wall, base up; the same points in the same colours",
    )?;
    let x0 = 2 * i64::from(pw);
    match (aha, scale) {
        (Some(aha), _) => aha_legend(&mut img, F, x0 + 8, aha)?,
        (None, Some(scale)) => {
            let x = x0 + (i64::from(pw) - COLORBAR_COLUMN) / 2;
            colorbar_column(&mut img, F, x, &scale, &["depth", "(0 = S, 1 = H)"])?;
        }
        (None, None) => {}
    }
    Ok(Figure::new(F, img))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_render::nalgebra::Rotation3;

    /// A labelled point cloud: basal points at z = 0, apical at z = -10,
    /// septal ones at +x.
    fn cloud() -> (Vec<Point3<f64>>, Vec<u8>) {
        let mut p = Vec::new();
        let mut l = Vec::new();
        for (seg, q) in [
            (1u8, [0.0, 5.0, 0.0]),
            (2, [5.0, 2.0, 0.0]),
            (3, [5.0, -2.0, 0.0]),
            (4, [0.0, -5.0, 0.0]),
            (5, [-5.0, -2.0, 0.0]),
            (6, [-5.0, 2.0, 0.0]),
            (8, [4.0, 1.0, -4.0]),
            (9, [4.0, -1.0, -4.0]),
            (11, [-4.0, -1.0, -4.0]),
            (14, [2.0, 0.0, -8.0]),
            (16, [-2.0, 0.0, -8.0]),
            (17, [0.0, 0.0, -10.0]),
        ] {
            p.push(Point3::from(q));
            l.push(seg);
        }
        (p, l)
    }

    proptest! {
        /// The view turns with the heart: rotating and moving the points
        /// rotates the axis and the septal direction alike.
        #[test]
        fn the_view_follows_the_heart(
            ax in -3.0..3.0f64, ay in -3.0..3.0f64, az in -3.0..3.0f64,
            t in prop::collection::vec(-100.0..100.0f64, 3),
        ) {
            let (p, l) = cloud();
            let v0 = heart_view(&p, Some(&l)).unwrap();
            prop_assert!((v0.axis - Vector3::new(0.0, 0.0, -1.0)).norm() < 0.2);
            prop_assert!(v0.septal.x > 0.9);
            prop_assert!(v0.axis.dot(&v0.septal).abs() < 1e-12);
            let r = Rotation3::from_euler_angles(ax, ay, az);
            let shift = Vector3::new(t[0], t[1], t[2]);
            let q: Vec<Point3<f64>> = p.iter().map(|x| r * x + shift).collect();
            let v1 = heart_view(&q, Some(&l)).unwrap();
            prop_assert!((v1.axis - r * v0.axis).norm() < 1e-9);
            prop_assert!((v1.septal - r * v0.septal).norm() < 1e-9);
            prop_assert!((v1.centre - (r * v0.centre + shift)).norm() < 1e-9);
        }
    }

    #[test]
    fn no_view_without_the_segments_it_needs() {
        let (p, l) = cloud();
        let no_apex: Vec<u8> = l.iter().map(|&x| if x >= 13 { 7 } else { x }).collect();
        assert_eq!(heart_view(&p, Some(&no_apex)), None);
        assert_eq!(heart_view(&[], None), None);
        // Without labels: principal axes, still orthonormal.
        let v = heart_view(&p, None).unwrap();
        assert!((v.axis.norm() - 1.0).abs() < 1e-12);
        assert!(v.axis.dot(&v.septal).abs() < 1e-9);
    }
}
