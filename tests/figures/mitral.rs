//! Figures of the mitral pipeline (issue 8): one `map_<array>.png` per map
//! of ALGORITHMS 4.4 / 4.5, the 2D map beside the 3D view. Content checks
//! on the synthetic closed and open valves (coaptation, Carpentier
//! segments, the annulus, orientation, crisp labels), exact sizes,
//! determinism and errors.
//!
//! `UNFOLD_FIGURES_DIR=/some/dir cargo test --test figures_mitral` also
//! writes the figures there (`closed/` and `open/`).

use std::sync::OnceLock;

use unfold::figures::mitral::{
    ANNULUS_COLOR, CARPENTIER_COLORS, COAPTATION_COLORS, LEAFLET_COLORS, OUTLINE_COLOR, figures,
};
use unfold::figures::render::{Colormap, Image, Rgb, Rgba};
use unfold::figures::{Figure, FigureError, FigureOptions};
use unfold::mesh::shapes::{ValveParams, mitral_valve};
use unfold::organs::mitral::{ANTERIOR, Config, Outcome, POSTERIOR, Pipeline, ValveInput};

/// The published pipeline with `config`.
fn run_valve(
    input: &ValveInput<'_>,
    config: &Config,
) -> Result<Outcome, unfold::organs::OrganError> {
    Pipeline::new().config(*config).run(input)
}

/// Every figure, in order.
const NAMES: [&str; 11] = [
    "map_area_energy.png",
    "map_angle_energy.png",
    "map_length_energy.png",
    "map_leaflet.png",
    "map_u_gradient.png",
    "map_u_interval.png",
    "map_checker.png",
    "map_carpentier.png",
    "map_coaptation.png",
    "map_coaptation_distance_mm.png",
    "map_tenting_mm.png",
];

/// The pipeline on the built-in valve, as `unfold demo` runs it.
fn outcome_of(p: &ValveParams) -> Outcome {
    let shape = mitral_valve(p).expect("valve");
    run_valve(
        &ValveInput {
            anterior: &shape.anterior,
            posterior: &shape.posterior,
            annulus: &shape.annulus,
        },
        &Config::default(),
    )
    .expect("mitral pipeline")
}

/// The demo's closed valve.
fn closed() -> &'static Outcome {
    static OUT: OnceLock<Outcome> = OnceLock::new();
    OUT.get_or_init(|| outcome_of(&ValveParams::default()))
}

/// A widely open valve: the free edges 12 mm apart in the middle.
fn open() -> &'static Outcome {
    static OUT: OnceLock<Outcome> = OnceLock::new();
    OUT.get_or_init(|| {
        outcome_of(&ValveParams {
            coaptation_gap: 12.0,
            commissure_gap: 15.0,
            ..ValveParams::default()
        })
    })
}

/// The figures at the default size (written to `UNFOLD_FIGURES_DIR/dir`
/// when that is set).
fn default_figures(out: &Outcome, dir: &str) -> Vec<Figure> {
    let figs = figures(out, &FigureOptions::default()).expect("figures");
    write(&figs, dir);
    figs
}

/// Writes `figs` to `UNFOLD_FIGURES_DIR/dir` when that is set.
fn write(figs: &[Figure], dir: &str) {
    if let Ok(root) = std::env::var("UNFOLD_FIGURES_DIR") {
        let d = std::path::Path::new(&root).join(dir);
        std::fs::create_dir_all(&d).unwrap();
        for f in figs {
            std::fs::write(d.join(&f.name), f.image.to_png().unwrap()).unwrap();
        }
    }
}

fn closed_figures() -> &'static [Figure] {
    static FIGS: OnceLock<Vec<Figure>> = OnceLock::new();
    FIGS.get_or_init(|| default_figures(closed(), "closed"))
}

fn open_figures() -> &'static [Figure] {
    static FIGS: OnceLock<Vec<Figure>> = OnceLock::new();
    FIGS.get_or_init(|| default_figures(open(), "open"))
}

fn find<'a>(figs: &'a [Figure], name: &str) -> &'a Image {
    &figs
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("no figure {name}"))
        .image
}

/// A pixel's column and row.
type Pixel = (u32, u32);

const PAPER: Rgba = Rgba::WHITE;
const INK: Rgba = Rgba::BLACK;

fn panel_width() -> u32 {
    FigureOptions::default().panel_width
}

/// Pixels of colour `c` in columns `x0..x1` of `img`, as `(x, y)`.
fn pixels_of(img: &Image, x0: u32, x1: u32, c: Rgba) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for y in 0..img.height() {
        for x in x0..x1 {
            if img.get(i64::from(x), i64::from(y)) == Some(c) {
                out.push((x, y));
            }
        }
    }
    out
}

/// Where the 2D map lies in the left panel, read from its pixels: the
/// annulus (its colour is used nowhere else there) gives the columns of
/// `u = 0` and `u = L` and the top, the grey outline of the free edges the
/// bottom.
struct MapPixels {
    /// Columns of the annulus' ends (u = 0 and u = L).
    x0: f64,
    x1: f64,
    /// Topmost annulus row and lowest outline row.
    top: u32,
    bottom: u32,
    /// `u` at the two ends.
    u0: f64,
    ul: f64,
}

impl MapPixels {
    fn new(img: &Image, out: &Outcome) -> MapPixels {
        let ring = pixels_of(img, 0, panel_width(), ANNULUS_COLOR);
        let outline = pixels_of(img, 0, panel_width(), OUTLINE_COLOR);
        assert!(ring.len() > 300, "annulus pixels: {}", ring.len());
        assert!(outline.len() > 300, "outline pixels: {}", outline.len());
        // The annulus line is 3 pixels thick, centred on the ring.
        let x0 = ring.iter().map(|p| p.0).min().unwrap() as f64 + 1.0;
        let x1 = ring.iter().map(|p| p.0).max().unwrap() as f64 - 1.0;
        let top = ring.iter().map(|p| p.1).min().unwrap();
        let bottom = outline.iter().map(|p| p.1).max().unwrap();
        let uv = |k: usize, i: u32| {
            let off = if k == ANTERIOR {
                0
            } else {
                out.valve.leaflets[ANTERIOR].mesh.positions.len() as u32
            };
            out.valve2d.positions[(i + off) as usize]
        };
        let u0 = uv(ANTERIOR, out.valve.leaflets[ANTERIOR].annulus[0]).x;
        let ul = uv(
            POSTERIOR,
            *out.valve.leaflets[POSTERIOR].annulus.last().unwrap(),
        )
        .x;
        MapPixels {
            x0,
            x1,
            top,
            bottom,
            u0,
            ul,
        }
    }

    /// The column of `u`.
    fn x(&self, u: f64) -> f64 {
        self.x0 + (u - self.u0) / (self.ul - self.u0) * (self.x1 - self.x0)
    }

    /// Pixels per mm.
    fn scale(&self) -> f64 {
        (self.x1 - self.x0) / (self.ul - self.u0)
    }

    /// The middle row of the map.
    fn middle(&self) -> f64 {
        0.5 * (self.top + self.bottom) as f64
    }

    /// Whether column `x` is farther than `mm` (in u) from every commissure.
    fn away_from_commissures(&self, out: &Outcome, x: u32, mm: f64) -> bool {
        let off = out.valve.leaflets[ANTERIOR].mesh.positions.len();
        let pm =
            out.valve2d.positions[*out.valve.leaflets[ANTERIOR].annulus.last().unwrap() as usize].x;
        let pm_p = out.valve2d.positions[out.valve.leaflets[POSTERIOR].annulus[0] as usize + off].x;
        [self.u0, pm, pm_p, self.ul]
            .iter()
            .all(|&u| (f64::from(x) - self.x(u)).abs() > mm * self.scale())
    }
}

#[test]
fn one_figure_per_map_at_the_requested_size() {
    let figs = closed_figures();
    let names: Vec<&str> = figs.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, NAMES);
    for f in figs {
        assert_eq!(
            (f.image.width(), f.image.height()),
            (960, 400),
            "{}",
            f.name
        );
    }
    let opts = FigureOptions {
        panel_width: 360,
        panel_height: 260,
    };
    let small = figures(closed(), &opts).unwrap();
    write(&small, "small");
    assert_eq!(small.len(), NAMES.len());
    for f in &small {
        assert_eq!(
            (f.image.width(), f.image.height()),
            (720, 260),
            "{}",
            f.name
        );
        // Still a map with its annulus and a 3D view.
        assert!(
            pixels_of(&f.image, 0, 360, ANNULUS_COLOR).len() > 200,
            "{}",
            f.name
        );
        assert!(
            pixels_of(&f.image, 360, 720, ANNULUS_COLOR).len() > 100,
            "{}",
            f.name
        );
    }
    let big = figures(
        closed(),
        &FigureOptions {
            panel_width: 700,
            panel_height: 520,
        },
    )
    .unwrap();
    write(&big, "big");
    assert!(
        big.iter()
            .all(|f| (f.image.width(), f.image.height()) == (1400, 520))
    );
}

#[test]
fn figures_are_deterministic() {
    let a = closed_figures();
    let b = figures(closed(), &FigureOptions::default()).unwrap();
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.name, y.name);
        assert!(
            x.image.to_png().unwrap() == y.image.to_png().unwrap(),
            "{} differs between two renderings",
            x.name
        );
    }
}

#[test]
fn bad_sizes_and_missing_arrays_are_errors() {
    for (w, h) in [(100, 400), (480, 100), (0, 0)] {
        let opts = FigureOptions {
            panel_width: w,
            panel_height: h,
        };
        assert!(
            matches!(figures(closed(), &opts), Err(FigureError::Input { .. })),
            "{w} x {h}"
        );
    }
    let too_big = FigureOptions {
        panel_width: 20_000,
        panel_height: 400,
    };
    assert!(figures(closed(), &too_big).is_err());

    let mut out = closed().clone();
    out.valve2d.point_data.remove("carpentier");
    match figures(&out, &FigureOptions::default()) {
        Err(FigureError::Input { what, .. }) => assert!(what.contains("carpentier"), "{what}"),
        other => panic!("expected an input error, got {:?}", other.map(|f| f.len())),
    }
    let mut out = closed().clone();
    out.valve2d.positions.pop();
    assert!(matches!(
        figures(&out, &FigureOptions::default()),
        Err(FigureError::Input { .. })
    ));
}

#[test]
fn coaptation_lies_low_on_a_closed_valve_and_only_at_the_commissures_of_an_open_one() {
    let green = COAPTATION_COLORS[2].opaque();
    for (out, figs, is_closed) in [
        (closed(), closed_figures(), true),
        (open(), open_figures(), false),
    ] {
        let img = find(figs, "map_coaptation.png");
        let map = MapPixels::new(img, out);
        let zone = pixels_of(img, 0, panel_width(), green);
        let (away, near): (Vec<Pixel>, Vec<Pixel>) = zone
            .iter()
            .partition(|p| map.away_from_commissures(out, p.0, 6.0));
        let low = away
            .iter()
            .filter(|p| f64::from(p.1) > map.middle())
            .count();
        println!(
            "{}: map rows {}..{}, zone pixels {} ({} away from the commissures, {} of them low)",
            if is_closed { "closed" } else { "open" },
            map.top,
            map.bottom,
            zone.len(),
            away.len(),
            low
        );
        if is_closed {
            // Along the free edges: many pixels, all in the lower half.
            assert!(away.len() > 2000, "{}", away.len());
            assert_eq!(low, away.len());
        } else {
            // Only at the commissures, at the top of the map.
            assert_eq!(away.len(), 0);
            assert!(
                near.iter().all(|p| f64::from(p.1) < map.middle()),
                "zone pixels below the middle on the open valve"
            );
        }
    }
}

#[test]
fn carpentier_has_six_segment_colours_in_their_places() {
    let img = find(closed_figures(), "map_carpentier.png");
    let mut centres = Vec::new();
    for (k, c) in CARPENTIER_COLORS.iter().enumerate() {
        let px = pixels_of(img, 0, panel_width(), c.opaque());
        assert!(px.len() > 500, "segment {k}: {} pixels", px.len());
        centres.push(px.iter().map(|p| f64::from(p.0)).sum::<f64>() / px.len() as f64);
        // Every segment is seen in the 3D view too (head-on pixels keep
        // their colour exactly; shaded ones are darker).
        let in_3d = count_where(img, panel_width(), 2 * panel_width(), |q| {
            near_shade_of(q, *c)
        });
        assert!(in_3d > 200, "segment {k} in 3D: {in_3d} pixels");
    }
    // Along u: A1, A2, A3 on the anterior leaflet, then the posterior from
    // the posteromedial commissure: P3, P2, P1.
    let order = [0, 1, 2, 5, 4, 3];
    for w in order.windows(2) {
        assert!(
            centres[w[0]] < centres[w[1]],
            "segment {} not left of {}: {centres:?}",
            w[0],
            w[1]
        );
    }
}

/// Whether `q` is `c` scaled by a shading factor in [0.3, 1] (within 3 per
/// channel).
fn near_shade_of(q: Rgba, c: Rgb) -> bool {
    let (cr, cg, cb) = (f64::from(c.r), f64::from(c.g), f64::from(c.b));
    let k = f64::from(q.r) / cr.max(1.0);
    if !(0.3..=1.0).contains(&k) {
        return false;
    }
    let close = |v: u8, base: f64| (f64::from(v) - k * base).abs() <= 3.0;
    close(q.r, cr) && close(q.g, cg) && close(q.b, cb)
}

/// Whether `c` is anti-aliased text over one of `bases`: black text (or a
/// white halo around text) blended over the base, `c = (1 - a) base + a
/// ink` for one `a` in `[0, 1]` and `ink` black or white, to within a
/// few rounding steps per channel; or, for a near grey, black text over a
/// partly white halo over the base. A mix of two label colours is none of
/// these, but for mixes within the rounding of one of them.
fn is_text_over(c: Rgba, bases: &[Rgba]) -> bool {
    let blend_of = |base: Rgba, ink: f64| {
        let b = [base.r, base.g, base.b].map(f64::from);
        let q = [c.r, c.g, c.b].map(f64::from);
        let d = b.map(|v| ink - v);
        let dd: f64 = d.iter().map(|v| v * v).sum();
        if dd < 1.0 {
            return (0..3).all(|i| (q[i] - ink).abs() <= 2.5);
        }
        // Least-squares a; the glyph and its halo are blended in several
        // passes, each rounded, so allow a few levels of rounding.
        let a = (0..3).map(|i| (q[i] - b[i]) * d[i]).sum::<f64>() / dd;
        (-0.02..=1.02).contains(&a) && (0..3).all(|i| (b[i] + a * d[i] - q[i]).abs() <= 2.5)
    };
    // One layer (text or halo); or, for a near grey only (a mix of two
    // label colours is far from grey), black text over a halo's partial
    // white.
    let near_grey = c.r.max(c.g).max(c.b) - c.r.min(c.g).min(c.b) <= 10;
    bases.iter().any(|&base| {
        blend_of(base, 0.0)
            || blend_of(base, 255.0)
            || near_grey
                && (1..100).any(|k| {
                    let h = f64::from(k) / 100.0;
                    let lift = |v: u8| (f64::from(v) + h * (255.0 - f64::from(v))).round() as u8;
                    blend_of(
                        Rgba::new(lift(base.r), lift(base.g), lift(base.b), 255),
                        0.0,
                    )
                })
    })
}

fn count_where(img: &Image, x0: u32, x1: u32, f: impl Fn(Rgba) -> bool) -> usize {
    let mut n = 0;
    for y in 0..img.height() {
        for x in x0..x1 {
            if f(img.get(i64::from(x), i64::from(y)).unwrap()) {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn the_annulus_runs_along_the_top_of_the_map() {
    for name in NAMES {
        let img = find(closed_figures(), name);
        let map = MapPixels::new(img, closed());
        let (x0, x1) = (map.x0.ceil() as u32 + 3, map.x1.floor() as u32 - 3);
        assert!(x1 > x0 + 300, "{name}: annulus from {x0} to {x1}");
        // In every column along the annulus the first drawn pixel below
        // the labels (text, grey at its anti-aliased edges, and the u = 0
        // line are black) is the annulus.
        let mut first_is_ring = 0;
        for x in x0..x1 {
            let first = (60..img.height())
                .map(|y| img.get(i64::from(x), i64::from(y)).unwrap())
                .find(|&c| c != PAPER && !is_text_over(c, &[PAPER]));
            if first == Some(ANNULUS_COLOR) {
                first_is_ring += 1;
            }
        }
        let n = x1 - x0;
        assert!(
            first_is_ring as f64 >= 0.97 * f64::from(n),
            "{name}: the annulus tops {first_is_ring} of {n} columns"
        );
        assert!(f64::from(map.top) < map.middle() - 40.0, "{name}");
        // And it is highlighted in the 3D view.
        let ring_3d = pixels_of(img, panel_width(), 2 * panel_width(), ANNULUS_COLOR);
        assert!(ring_3d.len() > 500, "{name}: {} pixels", ring_3d.len());
    }
}

#[test]
fn u_zero_is_marked_at_the_left_end_of_the_annulus() {
    let img = find(closed_figures(), "map_leaflet.png");
    let map = MapPixels::new(img, closed());
    // A dashed black line in the column of u = 0 (or next to it) from the
    // labels down past the annulus.
    let x = map.x(map.u0).round() as i64;
    let dashes = (0..3)
        .map(|d| {
            (map.top + 10..map.bottom)
                .filter(|&y| img.get(x - 1 + d, i64::from(y)) == Some(INK))
                .count()
        })
        .max()
        .unwrap();
    let span = (map.bottom - map.top - 10) as usize;
    assert!(
        dashes > span / 3 && dashes < span,
        "{dashes} dash pixels over {span} rows"
    );
}

#[test]
fn label_maps_are_crisp() {
    // The 2D panels of the maps whose labels change inside a leaflet hold
    // only their label colours, lines and text: no colour between two
    // labels (each triangle is split among its corners' labels).
    let lines = [PAPER, INK, OUTLINE_COLOR, ANNULUS_COLOR];
    let intervals: Vec<Rgba> = (0..8)
        .map(|k| Colormap::Tableau10.label(k).opaque())
        .collect();
    let carpentier: Vec<Rgba> = CARPENTIER_COLORS.iter().map(|c| c.opaque()).collect();
    let coaptation: Vec<Rgba> = COAPTATION_COLORS.iter().map(|c| c.opaque()).collect();
    for (name, labels) in [
        ("map_u_interval.png", intervals),
        ("map_carpentier.png", carpentier),
        ("map_coaptation.png", coaptation),
    ] {
        let img = find(closed_figures(), name);
        // Label text is anti-aliased black over the paper or a fill.
        let bases: Vec<Rgba> = lines.iter().chain(&labels).copied().collect();
        let stray = count_where(img, 0, panel_width(), |c| {
            !lines.contains(&c) && !labels.contains(&c) && !is_text_over(c, &bases)
        });
        assert_eq!(stray, 0, "{name}");
        for c in &labels {
            assert!(
                !pixels_of(img, 0, panel_width(), *c).is_empty(),
                "{name}: label colour {c:?} missing"
            );
        }
    }
}

#[test]
fn the_3d_view_has_the_anterior_leaflet_up() {
    let img = find(closed_figures(), "map_leaflet.png");
    let pw = panel_width();
    let blue = pixels_of(img, 0, pw, LEAFLET_COLORS[0].opaque());
    let red = pixels_of(img, 0, pw, LEAFLET_COLORS[1].opaque());
    assert!(blue.len() > 5000 && red.len() > 5000);
    // The anterior leaflet lies left of the posterior in 2D ...
    let mean = |p: &[(u32, u32)], f: fn(&(u32, u32)) -> u32| {
        p.iter().map(|q| f64::from(f(q))).sum::<f64>() / p.len() as f64
    };
    assert!(mean(&blue, |p| p.0) < mean(&red, |p| p.0));
    // ... and above it in the 3D view (shaded, so by hue).
    let mut b3 = Vec::new();
    let mut r3 = Vec::new();
    for y in 0..img.height() {
        for x in pw..2 * pw {
            let c = img.get(i64::from(x), i64::from(y)).unwrap();
            if near_shade_of(c, LEAFLET_COLORS[0]) {
                b3.push((x, y));
            } else if near_shade_of(c, LEAFLET_COLORS[1]) {
                r3.push((x, y));
            }
        }
    }
    assert!(
        b3.len() > 3000 && r3.len() > 3000,
        "{} {}",
        b3.len(),
        r3.len()
    );
    assert!(mean(&b3, |p| p.1) < mean(&r3, |p| p.1));
}

#[test]
fn the_3d_view_has_the_anterolateral_commissure_on_the_left() {
    // u_gradient: red at u = 0 (the anterolateral end of the anterior
    // leaflet), green at the posteromedial commissure.
    let img = find(closed_figures(), "map_u_gradient.png");
    let pw = panel_width();
    let (mut red, mut green) = (Vec::new(), Vec::new());
    for y in 0..img.height() {
        for x in pw..2 * pw {
            let c = img.get(i64::from(x), i64::from(y)).unwrap();
            let (r, g, b) = (i32::from(c.r), i32::from(c.g), i32::from(c.b));
            if r > g + 80 && r > b + 80 {
                red.push(f64::from(x));
            } else if g > r + 80 && g > b + 80 {
                green.push(f64::from(x));
            }
        }
    }
    assert!(red.len() > 500 && green.len() > 500);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(mean(&red) < mean(&green) - 40.0);
}

#[test]
fn other_layouts_render_too() {
    // A coarse valve, straight annulus, spring relaxation (which may flip
    // triangles: infinite energies) and a second cut at the posteromedial
    // commissure (the posterior leaflet shifted right).
    use unfold::organs::mitral::{AnnulusMode, RelaxMode};
    let shape = mitral_valve(&ValveParams {
        annulus_segments: 32,
        depth_segments: 6,
        ..ValveParams::default()
    })
    .unwrap();
    let config = Config {
        annulus_mode: AnnulusMode::Straight,
        relax: RelaxMode::Spring,
        cut_posteromedial: true,
        ..Config::default()
    };
    let out = run_valve(
        &ValveInput {
            anterior: &shape.anterior,
            posterior: &shape.posterior,
            annulus: &shape.annulus,
        },
        &config,
    )
    .unwrap();
    let figs = figures(&out, &FigureOptions::default()).unwrap();
    write(&figs, "coarse_straight_spring_cut");
    assert_eq!(figs.len(), NAMES.len());
    for f in &figs {
        assert_eq!((f.image.width(), f.image.height()), (960, 400));
    }
    let img = find(&figs, "map_carpentier.png");
    let map = MapPixels::new(img, &out);
    // Straight annulus: v = 0 all along, so the annulus is one row band.
    let ring = pixels_of(img, 0, panel_width(), ANNULUS_COLOR);
    let rows: Vec<u32> = ring.iter().map(|p| p.1).collect();
    assert!(rows.iter().max().unwrap() - rows.iter().min().unwrap() <= 2);
    assert!(f64::from(map.top) < map.middle());
    for c in CARPENTIER_COLORS {
        assert!(!pixels_of(img, 0, panel_width(), c.opaque()).is_empty());
    }
}
