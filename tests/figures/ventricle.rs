//! The ventricle figures (issue 8): the bull's-eye, the disk by AHA label
//! and the anatomy in the cylinder, from the pipeline run on the built-in
//! cup (as `unfold demo` does, on a coarser grid). The tests check what the
//! pictures show (segment colours where the segments are, label colours,
//! the depth scale), their sizes, and that they are deterministic.
//!
//! With `UNFOLD_FIGURES_DIR` set, the figures are also written there.

use std::sync::OnceLock;
use unfold::figures::render::{Colormap, Image, NAN_COLOR, Rgb};
use unfold::figures::ventricle::{
    AHA_COLORS, ANATOMY_AHA_PNG, ANGLE_COLORMAP, BULLSEYE_COLORMAP, BULLSEYE_PNG, CYLINDER_PNG,
    DEPTH_COLORMAP, DISK_AHA_PNG, DISK_ANGLE_PNG, DiskLayout, bullseye_layout, disk_layout,
    figures, segment_shape,
};
use unfold::figures::{Figure, FigureError, FigureOptions};
use unfold::mesh::CellMesh;
use unfold::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
use unfold::organs::OrganError;
use unfold::organs::ventricle::aha::aha_segment;
use unfold::organs::ventricle::{Chamber, Config, LandmarkPoints, Outcome, Pipeline};

fn cup() -> &'static VentricleShape {
    static C: OnceLock<VentricleShape> = OnceLock::new();
    C.get_or_init(|| ventricle_cup(&VentricleParams::default()).unwrap())
}

fn run_cup(chamber: Chamber, anatomy: &CellMesh) -> Outcome {
    let v = cup();
    let mut config = Config::default();
    config.chart.field.grid_mm = 1.5;
    config.chart.chamber = chamber;
    run(
        anatomy,
        &v.surface,
        &LandmarkPoints {
            anterior: v.anterior,
            inferior: v.inferior,
            apex: Some(v.apex),
            rim_near: None,
        },
        &config,
    )
    .unwrap()
}

/// The published pipeline with `config`.
fn run(
    anatomy: &CellMesh,
    surface: &unfold::mesh::TriMesh,
    landmarks: &LandmarkPoints,
    config: &Config,
) -> Result<Outcome, OrganError> {
    Pipeline::new()
        .config(*config)
        .run(anatomy, surface, landmarks)
}

/// The LV pipeline on the cup, its inner cup (a triangle surface) the
/// anatomy, as in `unfold demo`.
fn lv() -> &'static Outcome {
    static O: OnceLock<Outcome> = OnceLock::new();
    O.get_or_init(|| run_cup(Chamber::Lv, &CellMesh::from(&cup().anatomy)))
}

/// The RV pipeline on the cup, the anatomy bare points (rings and
/// meridians).
fn rv() -> &'static Outcome {
    static O: OnceLock<Outcome> = OnceLock::new();
    O.get_or_init(|| {
        run_cup(
            Chamber::Rv,
            &CellMesh::from_points(cup().anatomy_points.clone()),
        )
    })
}

fn save(figs: &[Figure], sub: &str) {
    if let Ok(dir) = std::env::var("UNFOLD_FIGURES_DIR") {
        let dir = std::path::Path::new(&dir).join(sub);
        std::fs::create_dir_all(&dir).unwrap();
        for f in figs {
            std::fs::write(dir.join(&f.name), f.image.to_png().unwrap()).unwrap();
        }
    }
}

fn find<'a>(figs: &'a [Figure], name: &str) -> &'a Image {
    &figs
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("no {name} among {:?}", names(figs)))
        .image
}

fn names(figs: &[Figure]) -> Vec<&str> {
    figs.iter().map(|f| f.name.as_str()).collect()
}

fn rgb(img: &Image, p: [f64; 2]) -> Rgb {
    img.get(p[0].floor() as i64, p[1].floor() as i64)
        .unwrap_or_else(|| panic!("pixel {p:?} outside the image"))
        .rgb()
}

/// Points well inside AHA segment `seg` on the displayed disk (away from
/// its borders and from the number written at its centre).
fn inside(seg: u8) -> Vec<[f64; 2]> {
    let s = segment_shape(seg).unwrap();
    if seg == 17 {
        return vec![[0.0, 0.16], [0.0, -0.16], [0.16, -0.1], [-0.16, -0.1]];
    }
    let r = s.r0 + 0.2 * (s.r1 - s.r0);
    [0.18, 0.82]
        .iter()
        .map(|t| {
            let a = (s.a0 + t * (s.a1 - s.a0)).to_radians();
            [r * a.cos(), r * a.sin()]
        })
        .collect()
}

#[test]
fn the_lv_gives_the_bullseye_the_disk_the_cylinder_and_the_anatomy_at_the_asked_sizes() {
    let o = lv();
    for opts in [
        FigureOptions::default(),
        FigureOptions {
            panel_width: 360,
            panel_height: 300,
        },
    ] {
        let figs = figures(o, Chamber::Lv, None, &opts).unwrap();
        assert_eq!(
            names(&figs),
            [BULLSEYE_PNG, DISK_AHA_PNG, CYLINDER_PNG, ANATOMY_AHA_PNG]
        );
        let (pw, ph) = (opts.panel_width, opts.panel_height);
        for (f, cols) in figs.iter().zip([2, 2, 1, 3]) {
            assert_eq!(
                (f.image.width(), f.image.height()),
                (cols * pw, ph),
                "{}",
                f.name
            );
        }
        if opts == FigureOptions::default() {
            save(&figs, "lv");
        } else {
            save(&figs, "lv_small");
        }
    }
}

/// With a value equal to each point's AHA segment, segment k's mean is k:
/// 17 distinct colours, k at `(k - 1) / 16` of the colour map, each where
/// segment k lies in the clinical orientation.
#[test]
fn the_bullseye_shows_each_segment_mean_in_its_place() {
    let o = lv();
    let counts = o.report.aha_points.unwrap();
    assert!(counts.iter().all(|&c| c > 0), "empty segment: {counts:?}");
    let value: Vec<f64> = o.aha.iter().map(|&a| f64::from(a)).collect();
    let opts = FigureOptions::default();
    let figs = figures(o, Chamber::Lv, Some(("segment number", &value)), &opts).unwrap();
    save(&figs[..1], "lv_segment_number");
    let img = find(&figs, BULLSEYE_PNG);
    let layout = bullseye_layout(&opts).unwrap();
    let mut seen = Vec::new();
    for seg in 1..=17u8 {
        let want = BULLSEYE_COLORMAP.eval(f64::from(seg - 1) / 16.0);
        for uv in inside(seg) {
            assert_eq!(aha_segment(uv), seg);
            let got = rgb(img, layout.pixel(uv));
            assert_eq!(got, want, "segment {seg} at disk {uv:?}");
        }
        seen.push(want);
    }
    seen.sort_by_key(|c| (c.r, c.g, c.b));
    seen.dedup();
    assert_eq!(seen.len(), 17);
    // The clinical orientation: anterior (1) at the top, septal (2, 3) on
    // the left, inferior (4) at the bottom, lateral (5, 6) on the right.
    let c = layout.centre;
    let r = layout.scale;
    let at = |dx: f64, dy: f64| rgb(img, [c[0] + dx * r, c[1] + dy * r]);
    let seg_color = |k: u8| BULLSEYE_COLORMAP.eval(f64::from(k - 1) / 16.0);
    assert_eq!(at(0.0, -0.8), seg_color(1));
    assert_eq!(at(-0.8, -0.25), seg_color(2));
    assert_eq!(at(-0.8, 0.25), seg_color(3));
    assert_eq!(at(0.0, 0.8), seg_color(4));
    assert_eq!(at(0.8, 0.25), seg_color(5));
    assert_eq!(at(0.8, -0.25), seg_color(6));
    assert_eq!(at(-0.4, 0.12), seg_color(14));
    assert_eq!(at(0.4, 0.12), seg_color(16));
    // Outside the disk, paper.
    assert_eq!(at(0.75, -0.75), Rgb::WHITE);
}

#[test]
fn segments_without_a_value_are_grey() {
    let o = lv();
    // No finite value in segments 4 and 13.
    let value: Vec<f64> = o
        .aha
        .iter()
        .map(|&a| {
            if a == 4 || a == 13 {
                f64::NAN
            } else {
                f64::from(a)
            }
        })
        .collect();
    let opts = FigureOptions::default();
    let figs = figures(o, Chamber::Lv, Some(("with gaps", &value)), &opts).unwrap();
    save(&figs[..1], "lv_gaps");
    let img = find(&figs, BULLSEYE_PNG);
    let layout = bullseye_layout(&opts).unwrap();
    for seg in [4u8, 13] {
        for uv in inside(seg) {
            assert_eq!(rgb(img, layout.pixel(uv)), NAN_COLOR, "segment {seg}");
        }
    }
    // The others keep the colour map, now from 1 to 17 without 4 and 13.
    for seg in [1u8, 17] {
        let want = BULLSEYE_COLORMAP.eval(if seg == 1 { 0.0 } else { 1.0 });
        assert_eq!(rgb(img, layout.pixel(inside(seg)[0])), want);
    }
    // The default (depth) shows a finite colour everywhere.
    let figs = figures(o, Chamber::Lv, None, &opts).unwrap();
    let img = find(&figs, BULLSEYE_PNG);
    for seg in 1..=17u8 {
        assert_ne!(rgb(img, layout.pixel(inside(seg)[0])), NAN_COLOR);
    }
}

/// The most common colour in the 7 x 7 pixels about `p` among those
/// `keep` accepts (a wireframe line may cross `p`).
fn mode_among(img: &Image, p: [f64; 2], keep: impl Fn(Rgb) -> bool) -> Rgb {
    let mut counts: Vec<(Rgb, usize)> = Vec::new();
    for dy in -3..=3 {
        for dx in -3..=3 {
            let c = rgb(img, [p[0] + f64::from(dx), p[1] + f64::from(dy)]);
            if !keep(c) {
                continue;
            }
            match counts.iter_mut().find(|(k, _)| *k == c) {
                Some((_, n)) => *n += 1,
                None => counts.push((c, 1)),
            }
        }
    }
    counts.sort_by_key(|c| std::cmp::Reverse(c.1));
    counts.first().map_or(Rgb::WHITE, |c| c.0)
}

/// The most common colour in the 7 x 7 pixels about `p`.
fn mode_near(img: &Image, p: [f64; 2]) -> Rgb {
    mode_among(img, p, |_| true)
}

#[test]
fn the_disk_shows_17_label_colours_in_their_segments() {
    let o = lv();
    let opts = FigureOptions::default();
    let figs = figures(o, Chamber::Lv, None, &opts).unwrap();
    let img = find(&figs, DISK_AHA_PNG);
    let layout: DiskLayout = disk_layout(Chamber::Lv, &opts).unwrap();
    // Count the label colours inside the unit circle (the legend, in the
    // right panel, is not counted).
    let mut counts = [0usize; 17];
    let (c, r) = (layout.centre, layout.scale);
    for y in 0..img.height() as i64 {
        for x in 0..opts.panel_width as i64 {
            let (dx, dy) = (x as f64 + 0.5 - c[0], y as f64 + 0.5 - c[1]);
            if dx.hypot(dy) >= r {
                continue;
            }
            let px = img.get(x, y).unwrap().rgb();
            if let Some(k) = AHA_COLORS.iter().position(|&a| a == px) {
                counts[k] += 1;
            }
        }
    }
    // The smallest segments, the apical ones, cover 3/64 of the disk; ask
    // for a third of that.
    let area = std::f64::consts::PI * r * r;
    for (k, &n) in counts.iter().enumerate() {
        assert!(
            n as f64 > area * 3.0 / 64.0 / 3.0,
            "segment {}: {n} pixels of {area:.0}",
            k + 1
        );
    }
    for seg in 1..=17u8 {
        for uv in inside(seg) {
            // Among the label colours (not the paler wireframe).
            assert_eq!(
                mode_among(img, layout.pixel(uv), |c| AHA_COLORS.contains(&c)),
                AHA_COLORS[seg as usize - 1],
                "segment {seg} at disk {uv:?}"
            );
        }
    }
    // Anterior up, septum left, in pixels: segment 1 above the centre, 2
    // and 3 on the left, 4 below, 5 and 6 on the right.
    let label = |dx: f64, dy: f64| {
        mode_among(img, [c[0] + dx * r, c[1] + dy * r], |c| {
            AHA_COLORS.contains(&c)
        })
    };
    for (dx, dy, seg) in [
        (0.0, -0.85, 1),
        (-0.85, -0.3, 2),
        (-0.85, 0.3, 3),
        (0.0, 0.85, 4),
        (0.85, 0.3, 5),
        (0.85, -0.3, 6),
    ] {
        assert_eq!(label(dx, dy), AHA_COLORS[seg - 1], "segment {seg}");
    }
}

/// Closest `(t, k)` with `c ~ k map(t)` (shading scales the colour).
fn on_map(map: Colormap, c: Rgb) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for i in 0..=256 {
        let t = f64::from(i) / 256.0;
        let m = map.eval(t);
        let (mr, mg, mb) = (f64::from(m.r), f64::from(m.g), f64::from(m.b));
        let (cr, cg, cb) = (f64::from(c.r), f64::from(c.g), f64::from(c.b));
        let k = ((cr * mr + cg * mg + cb * mb) / (mr * mr + mg * mg + mb * mb)).clamp(0.0, 1.0);
        let e = (cr - k * mr).powi(2) + (cg - k * mg).powi(2) + (cb - k * mb).powi(2);
        if e < best.0 {
            best = (e, t, k);
        }
    }
    if best.0 < 3.0 * 4.0 * 4.0 {
        (best.1, best.2)
    } else {
        (f64::NAN, 0.0)
    }
}

/// The depth positions `t` of the colour map found among the pixels of the
/// drawing area (left of the colour bar column, below the title).
fn depth_positions(img: &Image, opts: &FigureOptions) -> Vec<f64> {
    let mut ts = Vec::new();
    for y in 52..img.height() as i64 {
        for x in 0..(opts.panel_width as i64 - 112) {
            let c = img.get(x, y).unwrap().rgb();
            let grey = c.r == c.g && c.g == c.b;
            if grey {
                continue;
            }
            let (t, k) = on_map(DEPTH_COLORMAP, c);
            if t.is_finite() && k > 0.25 {
                ts.push(t);
            }
        }
    }
    ts
}

#[test]
fn the_cylinder_spans_the_depth_scale() {
    let o = lv();
    let opts = FigureOptions::default();
    let figs = figures(o, Chamber::Lv, None, &opts).unwrap();
    let img = find(&figs, CYLINDER_PNG);
    let ts = depth_positions(img, &opts);
    assert!(ts.len() > 2000, "{} coloured pixels", ts.len());
    let lo = ts.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ts.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert!(lo < 0.06 && hi > 0.94, "depth colours span [{lo}, {hi}]");
}

#[test]
fn the_rv_gives_the_half_disk_and_the_points_in_the_half_cylinder() {
    let o = rv();
    let opts = FigureOptions::default();
    let figs = figures(o, Chamber::Rv, None, &opts).unwrap();
    save(&figs, "rv");
    assert_eq!(names(&figs), [DISK_ANGLE_PNG, CYLINDER_PNG]);
    for f in &figs {
        assert_eq!(
            (f.image.width(), f.image.height()),
            (480, 400),
            "{}",
            f.name
        );
    }
    // The half disk: coloured right of the septal edge, paper left of it.
    let img = find(&figs, DISK_ANGLE_PNG);
    let l = disk_layout(Chamber::Rv, &opts).unwrap();
    let coloured = |p: [f64; 2]| {
        let c = mode_near(img, p);
        !(c.r == c.g && c.g == c.b)
    };
    assert!(coloured(l.pixel([1.75, 0.4])));
    assert!(coloured(l.pixel([2.1, -0.3])));
    assert!(!coloured(l.pixel([1.1, 0.0])));
    assert!(l.pixel([1.25, 0.0])[0] < l.pixel([2.25, 0.0])[0]);
    // Near the first corner (angle +90) the top of the angle map, near the
    // second (-90) its bottom.
    let dist = |a: Rgb, b: Rgb| {
        (f64::from(a.r) - f64::from(b.r)).abs()
            + (f64::from(a.g) - f64::from(b.g)).abs()
            + (f64::from(a.b) - f64::from(b.b)).abs()
    };
    let (hi, lo) = (ANGLE_COLORMAP.eval(0.9), ANGLE_COLORMAP.eval(0.1));
    let up = mode_near(img, l.pixel([1.4, 0.8]));
    let down = mode_near(img, l.pixel([1.4, -0.8]));
    assert!(dist(up, hi) < dist(up, lo), "{up:?}");
    assert!(dist(down, lo) < dist(down, hi), "{down:?}");
    // The bare points are drawn as squares spanning the depth scale.
    let ts = depth_positions(find(&figs, CYLINDER_PNG), &opts);
    assert!(ts.len() > 500, "{} coloured pixels", ts.len());
    let lo = ts.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ts.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert!(lo < 0.02 && hi > 0.98, "depth colours span [{lo}, {hi}]");
}

#[test]
fn figures_are_deterministic() {
    let opts = FigureOptions::default();
    for (o, chamber) in [(lv(), Chamber::Lv), (rv(), Chamber::Rv)] {
        let a = figures(o, chamber, None, &opts).unwrap();
        let b = figures(o, chamber, None, &opts).unwrap();
        assert_eq!(names(&a), names(&b));
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(
                x.image.to_png().unwrap(),
                y.image.to_png().unwrap(),
                "{}",
                x.name
            );
        }
    }
}

#[test]
fn wrong_inputs_are_errors_that_say_why() {
    let o = lv();
    let opts = FigureOptions::default();
    let n = o.normalized.positions.len();
    let short = vec![1.0; n - 1];
    let e = figures(o, Chamber::Lv, Some(("thickness", &short)), &opts).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, FigureError::Input { .. }), "{msg}");
    assert!(
        msg.contains("thickness")
            && msg.contains(&(n - 1).to_string())
            && msg.contains(&n.to_string()),
        "{msg}"
    );
    // The wrong chamber, a value for the RV, a tiny panel.
    assert!(figures(o, Chamber::Rv, None, &opts).is_err());
    let values = vec![0.0; rv().normalized.positions.len()];
    let e = figures(rv(), Chamber::Rv, Some(("x", &values)), &opts).unwrap_err();
    assert!(e.to_string().contains("RV"), "{e}");
    let tiny = FigureOptions {
        panel_width: 40,
        panel_height: 30,
    };
    let e = figures(o, Chamber::Lv, None, &tiny).unwrap_err();
    assert!(e.to_string().contains("40x30"), "{e}");
    let huge = FigureOptions {
        panel_width: u32::MAX,
        panel_height: 400,
    };
    assert!(figures(o, Chamber::Lv, None, &huge).is_err());
}
