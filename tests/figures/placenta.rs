//! Placenta figures (issue 8): content, sizes and determinism of
//! `unfold::figures::placenta::figures` on a real outcome of the pipeline
//! (a small synthetic slab) and a synthetic image pulled into the template.
//!
//! Set `UNFOLD_FIGURES_DIR` to also write the figures there as PNG files.

use std::sync::OnceLock;

use unfold::figures::placenta::{
    DISTORTION_FIGURE, FlatImage, HISTOGRAM_COLOR, LOG2_DET_J_FIGURE, PROFILE_COLOR,
    PROFILE_FIGURE, SIDE_COLORS, SIDE_FIGURE, TITLE_BAND, depths_figure_name, figures,
    frames_figure_name, sections_figure_name,
};
use unfold::figures::render::{Image, Rgb, Rgba};
use unfold::figures::{Figure, FigureError, FigureOptions};
use unfold::mesh::geometry::bounding_box;
use unfold::mesh::nalgebra::{Matrix4, Point3};
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::mesh::{Field, Volume};
use unfold::organs::Quiet;
use unfold::organs::placenta::{Outcome, Pipeline};

struct Fixture {
    outcome: Outcome,
    /// The synthetic scanner image.
    scan: Volume<f32>,
    /// The synthetic image pulled into the template.
    flat: Volume<f32>,
}

/// Intensity of the synthetic scanner image: 100 plus the signed distance
/// from the slab's bent mid-surface, positive towards the fetal side (the
/// fetal face is the one nearer the bowl's centre), so it grows with the
/// template's z.
fn intensity(params: &PlacentaParams, p: &Point3<f64>) -> f64 {
    let c = params.bowl_centre().expect("a bent slab");
    100.0 + params.bend_radius - (p - c).norm()
}

/// An axis-aligned 2 mm image covering `points` with a 6 mm margin.
fn scanner_image(params: &PlacentaParams, points: &[Point3<f64>]) -> Volume<f32> {
    let bb = bounding_box(points).expect("points");
    let (s, margin) = (2.0, 6.0);
    let origin = bb.min.coords.add_scalar(-margin);
    let dims: [usize; 3] =
        std::array::from_fn(|a| ((bb.max[a] - bb.min[a] + 2.0 * margin) / s).ceil() as usize + 1);
    let mut affine = Matrix4::identity();
    for a in 0..3 {
        affine[(a, a)] = s;
        affine[(a, 3)] = origin[a];
    }
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                data.push(intensity(params, &p) as f32);
            }
        }
    }
    Volume::new([dims[0], dims[1], dims[2], 1], affine, data).expect("volume")
}

/// The pipeline on a 1296-tet slab, and the image pulled back at 3 mm.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let params = PlacentaParams {
            cells_radial: 6,
            cells_through: 2,
            ..PlacentaParams::default()
        };
        let shape = placenta_slab(&params).expect("slab");
        let outcome = Pipeline::new()
            .run(&shape.mesh, &[], &mut Quiet)
            .expect("pipeline");
        let image = scanner_image(&params, &shape.mesh.positions);
        let table = outcome.pullback_table([3.0; 3]).expect("table");
        let (flat, _) = table.apply(&image).expect("pull-back");
        Fixture {
            outcome,
            scan: image,
            flat,
        }
    })
}

fn default_figures() -> &'static Vec<Figure> {
    static F: OnceLock<Vec<Figure>> = OnceLock::new();
    F.get_or_init(|| {
        let f = fixture();
        let images = [FlatImage {
            name: "mri",
            volume: &f.flat,
            original: Some(&f.scan),
        }];
        let figs = figures(&f.outcome, &images, &FigureOptions::default()).expect("figures");
        if let Ok(dir) = std::env::var("UNFOLD_FIGURES_DIR") {
            std::fs::create_dir_all(&dir).expect("figure directory");
            for fig in &figs {
                let png = fig.image.to_png().expect("png");
                std::fs::write(format!("{dir}/{}", fig.name), png).expect("written");
            }
        }
        figs
    })
}

fn get<'a>(figs: &'a [Figure], name: &str) -> &'a Image {
    &figs
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("figure {name} missing"))
        .image
}

/// Pixels of the rectangle `[x0, x1) x [y0, y1)` satisfying `pred`, as
/// coordinates.
fn pixels(
    img: &Image,
    (x0, y0, x1, y1): (u32, u32, u32, u32),
    pred: impl Fn(Rgba) -> bool,
) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let c = img.get(i64::from(x), i64::from(y)).expect("inside");
            if pred(c) {
                out.push((x, y));
            }
        }
    }
    out
}

/// Whether `c` is `base` lit by a factor in [0.4, 1] (flat shading,
/// rounded per channel).
fn shade_of(c: Rgba, base: Rgb) -> bool {
    let b = [base.r, base.g, base.b].map(f64::from);
    let x = [c.r, c.g, c.b].map(f64::from);
    let k = (0..3).map(|i| x[i] * b[i]).sum::<f64>() / (0..3).map(|i| b[i] * b[i]).sum::<f64>();
    (0.4..=1.01).contains(&k) && (0..3).all(|i| (x[i] - k * b[i]).abs() <= 2.0)
}

const FETAL: usize = 1;
const MATERNAL: usize = 2;
const MARGIN: usize = 3;

#[test]
fn names_and_sizes_are_as_asked() {
    let figs = default_figures();
    let names: Vec<&str> = figs.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            SIDE_FIGURE,
            LOG2_DET_J_FIGURE,
            PROFILE_FIGURE,
            DISTORTION_FIGURE,
            "mri_depths.png",
            "mri_sections.png"
        ]
    );
    assert_eq!(depths_figure_name("mri"), "mri_depths.png");
    assert_eq!(sections_figure_name("mri"), "mri_sections.png");
    assert_eq!(frames_figure_name("mri"), "mri_frames.png");
    let (w, h) = (480, 400);
    for (name, cols, rows) in [
        (SIDE_FIGURE, 2, 2),
        (LOG2_DET_J_FIGURE, 2, 2),
        (PROFILE_FIGURE, 2, 1),
        (DISTORTION_FIGURE, 3, 1),
        ("mri_depths.png", 6, 1),
        ("mri_sections.png", 4, 2),
    ] {
        let img = get(figs, name);
        assert_eq!((img.width(), img.height()), (cols * w, rows * h), "{name}");
    }

    // Another size: every figure a multiple of the panel.
    let f = fixture();
    let opts = FigureOptions {
        panel_width: 300,
        panel_height: 220,
    };
    let images = [FlatImage {
        name: "mri",
        volume: &f.flat,
        original: None,
    }];
    let small = figures(&f.outcome, &images, &opts).expect("figures");
    for (fig, (cols, rows)) in small.iter().zip([(2, 2), (2, 2), (2, 1), (3, 1), (6, 1)]) {
        assert_eq!(
            (fig.image.width(), fig.image.height()),
            (cols * 300, rows * 220),
            "{}",
            fig.name
        );
    }
}

#[test]
fn figures_are_deterministic() {
    let f = fixture();
    let images = [FlatImage {
        name: "mri",
        volume: &f.flat,
        original: Some(&f.scan),
    }];
    let again = figures(&f.outcome, &images, &FigureOptions::default()).expect("figures");
    let first = default_figures();
    assert_eq!(first.len(), again.len());
    for (a, b) in first.iter().zip(&again) {
        assert_eq!(a.name, b.name);
        assert_eq!(
            a.image.to_png().expect("png"),
            b.image.to_png().expect("png"),
            "{} differs between two runs",
            a.name
        );
    }
}

/// The silhouette of the profile panel `col`: the bounding box (width,
/// height) of its mesh pixels, and their count.
fn silhouette(img: &Image, col: u32) -> (u32, u32, usize) {
    let (w, h) = (480, 400);
    let px = pixels(img, (col * w, TITLE_BAND, (col + 1) * w, h), |c| {
        c == PROFILE_COLOR.opaque()
    });
    assert!(!px.is_empty(), "no silhouette in panel {col}");
    let (xmin, xmax) = px
        .iter()
        .fold((u32::MAX, 0), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (ymin, ymax) = px
        .iter()
        .fold((u32::MAX, 0), |(a, b), p| (a.min(p.1), b.max(p.1)));
    (xmax - xmin + 1, ymax - ymin + 1, px.len())
}

#[test]
fn flattened_profile_is_flat() {
    let img = get(default_figures(), PROFILE_FIGURE);
    let (fw, fh, _) = silhouette(img, 1);
    assert!(
        3 * fh < fw,
        "flattened silhouette {fw} x {fh} px is not below a third of its width"
    );
    assert!(
        fw > 200,
        "the flattened slab spans most of the panel: {fw} px"
    );
    // The aligned original (a bowl) stands taller than the flattened slab
    // at the same scale.
    let (_, oh, _) = silhouette(img, 0);
    assert!(oh > fh + 10, "original {oh} px vs flattened {fh} px high");
}

#[test]
fn sides_are_where_they_belong() {
    let img = get(default_figures(), SIDE_FIGURE);
    let (w, h) = (480u32, 400u32);
    let strip = 120;
    // Mesh areas of the four panels: (col, row).
    let count = |col: u32, row: u32, label: usize| {
        let right = if col == 1 { w - strip } else { w };
        pixels(
            img,
            (
                col * w + 1,
                row * h + TITLE_BAND,
                col * w + right - 1,
                (row + 1) * h - 4,
            ),
            |c| shade_of(c, SIDE_COLORS[label]),
        )
        .len()
    };
    for col in 0..2 {
        let (fetal_top, maternal_top, margin_top) = (
            count(col, 0, FETAL),
            count(col, 0, MATERNAL),
            count(col, 0, MARGIN),
        );
        let (fetal_bottom, maternal_bottom, margin_bottom) = (
            count(col, 1, FETAL),
            count(col, 1, MATERNAL),
            count(col, 1, MARGIN),
        );
        // Seen from the fetal side: the fetal face fills the view, the
        // maternal face is hidden; from the maternal side the reverse.
        assert!(
            fetal_top > 5000 && fetal_top > 20 * maternal_top,
            "panel ({col}, 0): fetal {fetal_top}, maternal {maternal_top}"
        );
        assert!(
            maternal_bottom > 5000 && maternal_bottom > 20 * fetal_bottom,
            "panel ({col}, 1): fetal {fetal_bottom}, maternal {maternal_bottom}"
        );
        assert!(margin_top > 300 && margin_bottom > 300, "margin visible");
    }
    // The legend: unlit swatches of the three boundary colours in the strip.
    for label in [FETAL, MATERNAL, MARGIN] {
        let swatch = pixels(img, (2 * w - strip, TITLE_BAND, 2 * w, h), |c| {
            c == SIDE_COLORS[label].opaque()
        });
        assert!(swatch.len() >= 100, "legend swatch of label {label}");
    }
}

#[test]
fn log2_det_j_colours_follow_the_tets() {
    // Replace the cell array by -0.5 for tets left of x = 0 in the template
    // and +0.5 right of it: blue left, red right in the flattened views.
    let f = fixture();
    let mut outcome = f.outcome.clone();
    let flat = &outcome.flattened;
    let values: Vec<f64> = flat
        .tets
        .iter()
        .map(|t| {
            let x: f64 = t.iter().map(|&v| flat.positions[v as usize].x).sum::<f64>() / 4.0;
            if x < 0.0 { -0.5 } else { 0.5 }
        })
        .collect();
    outcome
        .flattened
        .add_cell_field(Field::scalars("log2_det_j", values))
        .expect("field");
    let figs = figures(&outcome, &[], &FigureOptions::default()).expect("figures");
    let img = get(&figs, LOG2_DET_J_FIGURE);
    let (w, strip) = (480u32, 120u32);
    let is_red = |c: Rgba| c != Rgba::WHITE && i32::from(c.r) > i32::from(c.b) + 30;
    let is_blue = |c: Rgba| c != Rgba::WHITE && i32::from(c.b) > i32::from(c.r) + 30;
    for row in 0..2u32 {
        let (y0, y1) = (row * 400 + TITLE_BAND, row * 400 + 396);
        let reds = pixels(img, (w + 1, y0, 2 * w - strip, y1), is_red);
        let blues = pixels(img, (w + 1, y0, 2 * w - strip, y1), is_blue);
        assert!(reds.len() > 3000 && blues.len() > 3000, "row {row}");
        let mean_x =
            |p: &[(u32, u32)]| p.iter().map(|q| f64::from(q.0)).sum::<f64>() / p.len() as f64;
        assert!(
            mean_x(&reds) > mean_x(&blues) + 60.0,
            "row {row}: +x (red) is right of -x (blue)"
        );
    }
    // The colour bar: both ends of the diverging map in the strip.
    let bar = pixels(img, (2 * w - strip, TITLE_BAND, 2 * w, 400), |c| {
        c.r < 40 && c.b > 80
    });
    assert!(!bar.is_empty(), "colour bar's blue end");
}

#[test]
fn distortion_histograms_have_bars() {
    let img = get(default_figures(), DISTORTION_FIGURE);
    for k in 0..3u32 {
        let bars = pixels(img, (k * 480, TITLE_BAND, (k + 1) * 480, 400), |c| {
            c == HISTOGRAM_COLOR.opaque()
        });
        assert!(bars.len() > 300, "panel {k}: {} bar pixels", bars.len());
        // The tallest bar reaches the top of the plot, well above the axis.
        let (top, bottom) = bars
            .iter()
            .fold((u32::MAX, 0), |(a, b), p| (a.min(p.1), b.max(p.1)));
        assert!(bottom - top > 150, "panel {k}: bars {top}..{bottom}");
    }
}

/// Mean luminance and count of the coloured (data) pixels of slice `k`.
fn slice_luminance(img: &Image, k: u32) -> (f64, usize) {
    let (w, h) = (480u32, 400u32);
    let data = pixels(img, (k * w + 8, TITLE_BAND, (k + 1) * w - 8, h - 30), |c| {
        let (r, g, b) = (c.r, c.g, c.b);
        // Not paper, ink or the grey outline: a viridis colour.
        !(r == g && g == b)
    });
    let lum: f64 = data
        .iter()
        .map(|&(x, y)| {
            let c = img.get(i64::from(x), i64::from(y)).expect("inside").rgb();
            c.luminance()
        })
        .sum();
    (lum / data.len().max(1) as f64, data.len())
}

#[test]
fn depth_slices_go_from_fetal_to_maternal() {
    let img = get(default_figures(), "mri_depths.png");
    let stats: Vec<(f64, usize)> = (0..5).map(|k| slice_luminance(img, k)).collect();
    for (k, (_, n)) in stats.iter().enumerate() {
        assert!(*n > 20_000, "slice {k} shows the placenta: {n} pixels");
    }
    // The image grows towards the fetal side, viridis is lighter for larger
    // values: each slice is darker than the one above it.
    for k in 0..4 {
        assert!(
            stats[k].0 > stats[k + 1].0 + 0.02,
            "slice {k} ({}) vs {} ({})",
            stats[k].0,
            k + 1,
            stats[k + 1].0
        );
    }
    // The sixth panel holds the colour bar (viridis' yellow end).
    let yellow = pixels(img, (5 * 480, TITLE_BAND, 6 * 480, 400), |c| {
        c.r > 200 && c.g > 200 && c.b < 80
    });
    assert!(!yellow.is_empty(), "colour bar");
}

#[test]
fn four_d_images_show_frame_zero() {
    let f = fixture();
    let [nx, ny, nz, _] = f.flat.dims();
    let mut data = f.flat.data().to_vec();
    // Frame 1: something else entirely.
    data.extend(
        f.flat
            .data()
            .iter()
            .map(|&x| if x != 0.0 { 1000.0 - x } else { 0.0 }),
    );
    let series = Volume::new([nx, ny, nz, 2], *f.flat.affine(), data).expect("4D");
    let figs = figures(
        &f.outcome,
        &[FlatImage {
            name: "mri",
            volume: &series,
            original: None,
        }],
        &FigureOptions::default(),
    )
    .expect("figures");
    let a = get(default_figures(), "mri_depths.png");
    let b = get(&figs, "mri_depths.png");
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    // The five slices are the same pixels (the notes panel says "frame 1 of 2").
    for y in 0..400 {
        for x in 0..5 * 480 {
            assert_eq!(a.get(x, y), b.get(x, y), "pixel ({x}, {y})");
        }
    }
}

#[test]
fn bad_images_are_errors_not_panics() {
    let f = fixture();
    let opts = FigureOptions::default();
    let is_input = |r: Result<Vec<Figure>, FigureError>, figure: &str| match r {
        Err(FigureError::Input { figure: got, .. }) => assert_eq!(got, figure),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("{figure}: accepted"),
    };
    // An original image that does not contain the placenta (another
    // subject's scan, a wrong frame).
    let mut affine = *f.scan.affine();
    affine[(2, 3)] += 5000.0;
    let elsewhere = Volume::new(f.scan.dims(), affine, f.scan.data().to_vec()).expect("volume");
    is_input(
        figures(
            &f.outcome,
            &[FlatImage {
                name: "mri",
                volume: &f.flat,
                original: Some(&elsewhere),
            }],
            &opts,
        ),
        "mri_sections.png",
    );
    // An image that does not cover the template (e.g. a scanner-frame image
    // far from it).
    let mut affine = *f.flat.affine();
    affine[(0, 3)] += 5000.0;
    let far = Volume::new(f.flat.dims(), affine, f.flat.data().to_vec()).expect("volume");
    is_input(
        figures(
            &f.outcome,
            &[FlatImage {
                name: "far",
                volume: &far,
                original: None,
            }],
            &opts,
        ),
        "far_depths.png",
    );
    // All zeros: nothing inside the mesh.
    let zero = f.flat.map(|_| 0.0f32);
    is_input(
        figures(
            &f.outcome,
            &[FlatImage {
                name: "zero",
                volume: &zero,
                original: None,
            }],
            &opts,
        ),
        "zero_depths.png",
    );
    // A single voxel at the template's origin: only the middle slice
    // crosses it, and that is enough.
    let one = Volume::new([1, 1, 1, 1], Matrix4::identity(), vec![1.0f32]).expect("volume");
    let figs = figures(
        &f.outcome,
        &[FlatImage {
            name: "one",
            volume: &one,
            original: None,
        }],
        &opts,
    )
    .expect("one voxel");
    assert_eq!(figs.len(), 5);
    // Names that are not file names, or repeated.
    is_input(
        figures(
            &f.outcome,
            &[FlatImage {
                name: "a/b",
                volume: &f.flat,
                original: None,
            }],
            &opts,
        ),
        "a/b_depths.png",
    );
    is_input(
        figures(
            &f.outcome,
            &[FlatImage {
                name: "",
                volume: &f.flat,
                original: None,
            }],
            &opts,
        ),
        "_depths.png",
    );
    let twice = [
        FlatImage {
            name: "mri",
            volume: &f.flat,
            original: None,
        },
        FlatImage {
            name: "mri",
            volume: &f.flat,
            original: None,
        },
    ];
    is_input(figures(&f.outcome, &twice, &opts), "mri_depths.png");
}

#[test]
fn missing_side_labels_and_no_images_still_work() {
    let f = fixture();
    let mut outcome = f.outcome.clone();
    outcome.original.point_data.remove("side");
    outcome.flattened.point_data.remove("side");
    outcome.flattened.cell_data.remove("log2_det_j");
    outcome.labels.clear();
    let figs = figures(&outcome, &[], &FigureOptions::default()).expect("figures");
    let names: Vec<&str> = figs.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [LOG2_DET_J_FIGURE, PROFILE_FIGURE, DISTORTION_FIGURE],
        "no side figure, no depth figure"
    );
    // log2 det J recomputed from the tet volumes: still a coloured map.
    let img = get(&figs, LOG2_DET_J_FIGURE);
    let coloured = pixels(img, (481, TITLE_BAND, 480 + 360, 396), |c| c != Rgba::WHITE);
    assert!(coloured.len() > 10_000);
    let (fw, fh, _) = silhouette(get(&figs, PROFILE_FIGURE), 1);
    assert!(3 * fh < fw);
}

#[test]
fn inconsistent_outcomes_and_tiny_panels_are_errors() {
    let f = fixture();
    let mut outcome = f.outcome.clone();
    outcome.flattened.positions.pop();
    assert!(matches!(
        figures(&outcome, &[], &FigureOptions::default()),
        Err(FigureError::Input { .. })
    ));
    let mut outcome = f.outcome.clone();
    outcome.flattened.positions[0].x = f64::NAN;
    assert!(matches!(
        figures(&outcome, &[], &FigureOptions::default()),
        Err(FigureError::Input { .. })
    ));
    let mut outcome = f.outcome.clone();
    outcome.flattened.tets[0][0] = u32::MAX;
    assert!(matches!(
        figures(&outcome, &[], &FigureOptions::default()),
        Err(FigureError::Input { .. })
    ));
    let tiny = FigureOptions {
        panel_width: 100,
        panel_height: 80,
    };
    assert!(matches!(
        figures(&f.outcome, &[], &tiny),
        Err(FigureError::Input { .. })
    ));
    // Too large for the renderer (6 panels of 3000 pixels with an image):
    // an error, not a panic.
    let huge = FigureOptions {
        panel_width: 3000,
        panel_height: 300,
    };
    let images = [FlatImage {
        name: "mri",
        volume: &f.flat,
        original: None,
    }];
    assert!(matches!(
        figures(&f.outcome, &images, &huge),
        Err(FigureError::Input { .. })
    ));
}

/// The data (viridis) pixels of the rectangle `[x0, x1) x [y0, y1)`: their
/// coordinates and luminance.
fn data_pixels(img: &Image, rect: (u32, u32, u32, u32)) -> Vec<(u32, u32, f64)> {
    pixels(img, rect, |c| !(c.r == c.g && c.g == c.b))
        .into_iter()
        .map(|(x, y)| {
            let c = img.get(i64::from(x), i64::from(y)).expect("inside").rgb();
            (x, y, c.luminance())
        })
        .collect()
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    s / n.max(1) as f64
}

#[test]
fn sections_show_the_original_beside_the_flattened() {
    let img = get(default_figures(), "mri_sections.png");
    let (w, h) = (480u32, 400u32);
    let area = |col: u32, row: u32| {
        (
            col * w + 8,
            row * h + TITLE_BAND,
            (col + 1) * w - 8,
            (row + 1) * h - 34,
        )
    };
    for row in 0..2 {
        for col in 0..3 {
            let n = data_pixels(img, area(col, row)).len();
            assert!(n > 2_000, "section ({col}, {row}) shows data: {n} pixels");
        }
    }
    // The image grows towards the fetal side (template +z): in the
    // flattened x-z section the upper half of the data is lighter.
    let xz = data_pixels(img, area(1, 1));
    let mut ys: Vec<u32> = xz.iter().map(|p| p.1).collect();
    ys.sort_unstable();
    let mid = ys[ys.len() / 2];
    let upper = mean(xz.iter().filter(|p| p.1 < mid).map(|p| p.2));
    let lower = mean(xz.iter().filter(|p| p.1 > mid).map(|p| p.2));
    assert!(upper > lower + 0.1, "upper {upper} vs lower {lower}");
    // The mid-depth slice cuts one depth: its colours spread far less than
    // the x-z section's from top to bottom.
    let flat = data_pixels(img, area(0, 1));
    let m = mean(flat.iter().map(|p| p.2));
    let sd = mean(flat.iter().map(|p| (p.2 - m) * (p.2 - m))).sqrt();
    assert!(
        sd < 0.25 * (upper - lower),
        "mid-depth spread {sd} vs {upper} - {lower}"
    );
}

#[test]
fn every_frame_of_a_series_is_a_thumbnail_on_one_scale() {
    let f = fixture();
    let [nx, ny, nz, _] = f.flat.dims();
    // Frame t: the image plus 10 t inside the mesh, 0 outside.
    let mut data = Vec::new();
    for t in 0..3 {
        data.extend(
            f.flat
                .data()
                .iter()
                .map(|&x| if x != 0.0 { x + 10.0 * t as f32 } else { 0.0 }),
        );
    }
    let series = Volume::new([nx, ny, nz, 3], *f.flat.affine(), data).expect("4D");
    let figs = figures(
        &f.outcome,
        &[FlatImage {
            name: "mri",
            volume: &series,
            original: None,
        }],
        &FigureOptions::default(),
    )
    .expect("figures");
    let img = get(&figs, "mri_frames.png");
    // Three thumbnails and the colour bar, each half a panel.
    let (w, h) = (240u32, 200u32);
    assert_eq!((img.width(), img.height()), (4 * w, h));
    let lum: Vec<f64> = (0..3)
        .map(|k| {
            let d = data_pixels(img, (k * w + 8, TITLE_BAND, (k + 1) * w - 8, h - 34));
            assert!(d.len() > 2_000, "frame {k}: {} pixels", d.len());
            mean(d.iter().map(|p| p.2))
        })
        .collect();
    // One scale: later frames are brighter.
    assert!(lum[0] + 0.05 < lum[1] && lum[1] + 0.05 < lum[2], "{lum:?}");
    // A single frame makes no frames figure.
    assert!(default_figures().iter().all(|f| f.name != "mri_frames.png"));
}
