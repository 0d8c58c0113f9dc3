//! The sections figure of an image (`<name>_sections.png`, the source
//! paper's Fig. 5-6): the original image's three orthogonal sections through
//! the placenta's centre beside the pulled-back image's three sections
//! through the flattened mesh's centre, on one intensity scale and one
//! millimetre scale.
//!
//! | column | top row: original (scanner voxels) | bottom row: flattened (template mm) |
//! |---|---|---|
//! | 1 | voxel plane `k = k_c` (i right, j up) | `z = z_m` (x right, y up), mid-depth |
//! | 2 | voxel plane `j = j_c` (i right, k up) | `y = y_c` (x right, z up) |
//! | 3 | voxel plane `i = i_c` (j right, k up) | `x = x_c` (y right, z up) |
//! | 4 | name, notes and the colour bar | where the sections are |
//!
//! `(i_c, j_c, k_c)` is the voxel nearest the centroid of the original
//! mesh's vertices; each original section shows the mesh's voxel bounding
//! box widened by 15 % on every side (within the image), each voxel axis at
//! its own spacing, so lengths are true. `(x_c, y_c)` is the centre of the
//! flattened mesh's bounding box and `z_m` the middle between the template's
//! fetal and maternal levels.

use unfold_render::{ColorScale, Colormap, Image, format_value};

use super::FlatImage;
use super::depths::Depths;
use super::drawing::panel;
use super::meshes::Meshes;
use super::numbers::{nice_length, percentile, signed};
use super::raster::Area;
use super::sampling::{sample_masked, sample_original};
use crate::figures::layout::compose;
use crate::figures::{FigureError, FigureOptions};
use crate::mesh::Volume;
use crate::mesh::nalgebra::{Point3, Vector3};

/// Share of the original mesh's voxel extent added on each side of the
/// original sections.
const MARGIN: f64 = 0.15;

/// One section to draw: its title, subtitle, size in mm and its values.
struct Section {
    title: String,
    subtitle: String,
    /// Width and height, mm.
    size: (f64, f64),
}

/// The sections figure of `img` (whose `original` is given) and its
/// flattened counterpart.
pub(super) fn sections(
    img: &FlatImage<'_>,
    original: &Volume<f32>,
    m: &Meshes<'_>,
    depths: &Depths,
    opts: &FigureOptions,
    name: &str,
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let area = Area::of(opts);

    // The original: the mesh's voxel box, its centre voxel.
    let dims = original.dims();
    let spacing = original.spacing();
    let voxels: Vec<Point3<f64>> = m
        .original
        .iter()
        .map(|p| original.world_to_voxel(p))
        .collect();
    let (vlo, vhi) = extent(&voxels);
    let centroid = m
        .original
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.coords)
        / m.original.len().max(1) as f64;
    let cv = original.world_to_voxel(&Point3::from(centroid));
    let mut centre = [0usize; 3];
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for a in 0..3 {
        let n = dims[a] as f64;
        let x = cv[a];
        if !x.is_finite() || x < -0.5 || x > n - 0.5 {
            return Err(FigureError::input(
                name,
                format!(
                    "the placenta's centre is outside the image {:?} (voxel axis {a}: {} of \
                     {} voxels); is it the image the mesh was made from?",
                    img.name,
                    format_value(x),
                    dims[a]
                ),
            ));
        }
        centre[a] = (x.round().max(0.0) as usize).min(dims[a] - 1);
        let pad = (MARGIN * (vhi[a] - vlo[a])).max(2.0);
        lo[a] = (vlo[a] - pad).max(-0.5);
        hi[a] = (vhi[a] + pad).min(n - 0.5);
    }
    // Voxel axes (u, v) of each original section and the fixed axis.
    let planes = [(0usize, 1usize, 2usize), (0, 2, 1), (1, 2, 0)];
    let axis = ['i', 'j', 'k'];
    let mut wanted: Vec<Section> = planes
        .iter()
        .map(|&(u, v, w)| Section {
            title: format!("original: {} = {}", axis[w], centre[w]),
            subtitle: format!("scanner voxels, {} right, {} up", axis[u], axis[v]),
            size: ((hi[u] - lo[u]) * spacing[u], (hi[v] - lo[v]) * spacing[v]),
        })
        .collect();

    // The flattened mesh's box and the middle depth.
    let (flo, fhi) = extent(m.flattened);
    let pad = |a: usize| 0.02 * (fhi[a] - flo[a]).max(1e-6);
    let fc = [
        0.5 * (flo[0] + fhi[0]),
        0.5 * (flo[1] + fhi[1]),
        0.5 * (flo[2] + fhi[2]),
    ];
    let zm = depths.z(0.0);
    let fsize = |a: usize| fhi[a] - flo[a] + 2.0 * pad(a);
    wanted.push(Section {
        title: format!("flattened: z = {} mm", signed(zm)),
        subtitle: "template, mid-depth, x right, y up".into(),
        size: (fsize(0), fsize(1)),
    });
    wanted.push(Section {
        title: format!("flattened: y = {} mm", signed(fc[1])),
        subtitle: "template, x right, z up".into(),
        size: (fsize(0), fsize(2)),
    });
    wanted.push(Section {
        title: format!("flattened: x = {} mm", signed(fc[0])),
        subtitle: "template, y right, z up".into(),
        size: (fsize(1), fsize(2)),
    });

    // One millimetre scale for all six.
    let s = wanted
        .iter()
        .map(|w| area.fit(w.size.0, w.size.1))
        .fold(f64::INFINITY, f64::min);

    let flat = img.volume;
    let flat_values = [
        area.sample((fc[0], fc[1]), s, |x, y| {
            sample_masked(flat, &Point3::new(x, y, zm), 0)
        }),
        area.sample((fc[0], fc[2]), s, |x, z| {
            sample_masked(flat, &Point3::new(x, fc[1], z), 0)
        }),
        area.sample((fc[1], fc[2]), s, |y, z| {
            sample_masked(flat, &Point3::new(fc[0], y, z), 0)
        }),
    ];
    let mut all: Vec<f64> = flat_values.iter().flatten().flatten().copied().collect();
    if all.is_empty() {
        return Err(FigureError::input(
            name,
            format!(
                "the pulled-back image {:?} has no non-zero voxel on the flattened mesh's \
                 sections (x = {}, y = {}, z = {} mm)",
                img.name,
                format_value(fc[0]),
                format_value(fc[1]),
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

    let original_values: Vec<Vec<Option<f64>>> = planes
        .iter()
        .map(|&(u, v, w)| {
            let mid = (
                0.5 * (lo[u] + hi[u]) * spacing[u],
                0.5 * (lo[v] + hi[v]) * spacing[v],
            );
            area.sample(mid, s, |a, b| {
                let (iu, iv) = (a / spacing[u], b / spacing[v]);
                if iu < lo[u] || iu > hi[u] || iv < lo[v] || iv > hi[v] {
                    return None;
                }
                let mut q = [0.0; 3];
                q[u] = iu;
                q[v] = iv;
                q[w] = centre[w] as f64;
                sample_original(original, &Point3::new(q[0], q[1], q[2]))
            })
        })
        .collect();

    let bar = nice_length(0.3 * f64::from(area.aw) / s);
    let mut panels = Vec::with_capacity(8);
    let values = original_values.iter().chain(flat_values.iter());
    for (k, (section, vals)) in wanted.iter().zip(values).enumerate() {
        let mut p = panel(opts, &section.title, &section.subtitle, 2).map_err(err(name))?;
        area.paint(&mut p, vals, &scale, bar, s)
            .map_err(err(name))?;
        panels.push(p);
        if k == 2 {
            panels.push(legend(img, &scale, opts, name)?);
        }
    }
    panels.push(whereabouts(
        opts,
        name,
        &original.voxel_to_world(&Point3::new(
            centre[0] as f64,
            centre[1] as f64,
            centre[2] as f64,
        )),
        centre,
        [fc[0], fc[1], zm],
    )?);
    compose(&panels, 4, opts).map_err(err(name))
}

/// The smallest and largest coordinate of `points` per axis.
fn extent(points: &[Point3<f64>]) -> ([f64; 3], [f64; 3]) {
    points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(mut lo, mut hi), p| {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
            (lo, hi)
        },
    )
}

/// The top-right panel: the image's name, notes and the colour bar.
fn legend(
    img: &FlatImage<'_>,
    scale: &ColorScale,
    opts: &FigureOptions,
    name: &str,
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let mut p = panel(opts, img.name, "original and flattened", 2).map_err(err(name))?;
    let mut notes = vec![
        "one intensity scale for both rows".to_string(),
        "(1-99th percentile of the flattened)".into(),
        "one mm scale for all six sections".into(),
        "white: outside the image or the mesh".into(),
    ];
    let frames = img.volume.frames();
    if frames > 1 {
        notes.push(format!("frame 1 of {frames}"));
    }
    super::drawing::notes(&mut p, &notes, 4, Some((scale, 10, 40))).map_err(err(name))?;
    Ok(p)
}

/// The bottom-right panel: where the sections are.
fn whereabouts(
    opts: &FigureOptions,
    name: &str,
    world: &Point3<f64>,
    voxel: [usize; 3],
    flat: [f64; 3],
) -> Result<Image, FigureError> {
    let err = FigureError::render;
    let mut p = panel(opts, "sections", "through the centres", 2).map_err(err(name))?;
    let mm = |v: [f64; 3]| {
        format!(
            "({}, {}, {}) mm",
            format_value(v[0]),
            format_value(v[1]),
            format_value(v[2])
        )
    };
    let lines = [
        "original: the voxel nearest the".to_string(),
        "centroid of the mesh's vertices".into(),
        format!("(i, j, k) = ({}, {}, {})", voxel[0], voxel[1], voxel[2]),
        format!("scanner {}", mm([world.x, world.y, world.z])),
        String::new(),
        "flattened: the centre of the".into(),
        "flattened mesh's box, mid-depth".into(),
        format!("template {}", mm(flat)),
    ];
    super::drawing::notes(&mut p, &lines, 4, None).map_err(err(name))?;
    Ok(p)
}
