//! The ventricle map `psi` and its inverse (ALGORITHMS 3.3-3.7, issue 6):
//! analytic checks on a hemisphere and on the half-ellipsoid cup, the round
//! trip and AHA labels on a real heart (`tests/data/cobiveco-geo2`,
//! Apache-2.0) and on a synthetic ellipsoid written by meshio
//! (`tests/data/ellipsoid-heart`), and the transfer geo2 -> ellipsoid ->
//! geo2.
//!
//! The data sets do not mark the RV insertion points: two rim points a third
//! of the loop apart stand in for them.

use std::sync::OnceLock;
use unfold::io::{read_mesh, read_tri_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{VentricleParams, ventricle_cup};
use unfold::mesh::{CellMesh, TriMesh};
use unfold::organs::OrganError;
use unfold::organs::ventricle::rings_meridians::rings_and_meridians;
use unfold::organs::ventricle::{
    Chart, ChartConfig, Config, CylinderPoint, LandmarkPoints, Outcome, Pipeline,
};
use unfold::param::initializer::disk_boundary_loop;

/// The published pipeline with `config`.
fn run(
    anatomy: &CellMesh,
    surface: &TriMesh,
    landmarks: &LandmarkPoints,
    config: &Config,
) -> Result<Outcome, OrganError> {
    Pipeline::new()
        .config(*config)
        .run(anatomy, surface, landmarks)
}

/// Two rim points a third of the loop apart (after the repair of S).
fn rim_landmarks(s: &TriMesh) -> LandmarkPoints {
    let (r, _) = unfold::mesh::repair::repair_tri_mesh(s).unwrap();
    let rim = disk_boundary_loop(&r).unwrap();
    LandmarkPoints {
        anterior: r.positions[rim[0] as usize],
        inferior: r.positions[rim[rim.len() / 3] as usize],
        apex: None,
        rim_near: None,
    }
}

fn config(grid_mm: f64) -> Config {
    let mut c = Config::default();
    c.chart.field.grid_mm = grid_mm;
    c
}

/// The real heart: S, the anatomy and the pipeline's outcome at 1 mm.
struct Heart {
    landmarks: LandmarkPoints,
    outcome: Outcome,
}

fn heart(surface: &str, anatomy: &str) -> Heart {
    let s = read_tri_mesh(surface).unwrap();
    let a: CellMesh = read_mesh(anatomy).unwrap();
    let landmarks = rim_landmarks(&s);
    let outcome = run(&a, &s, &landmarks, &config(1.0)).unwrap();
    Heart { landmarks, outcome }
}

fn geo2() -> &'static Heart {
    static H: OnceLock<Heart> = OnceLock::new();
    H.get_or_init(|| {
        heart(
            "tests/data/cobiveco-geo2/heart_epi.ply",
            "tests/data/cobiveco-geo2/heart_endo_lv.ply",
        )
    })
}

fn ellipsoid() -> &'static Heart {
    static H: OnceLock<Heart> = OnceLock::new();
    H.get_or_init(|| {
        heart(
            "tests/data/ellipsoid-heart/epi.obj",
            "tests/data/ellipsoid-heart/heart.vtu",
        )
    })
}

fn check_real(name: &str, h: &Heart) {
    let r = &h.outcome.report;
    let e = r.roundtrip_error_um;
    println!(
        "{name}: {} points, round trip um mean {:.2e} median {:.2e} std {:.2e} max {:.2e}; \
         flipped {}; field {:?}; seconds {:?}; aha {:?}; strip {:.2} mm; repair {:?}",
        r.anatomy_points,
        e.mean,
        e.median,
        e.std,
        e.max,
        r.flipped_disk_triangles,
        r.field,
        r.seconds,
        r.aha_points,
        h.outcome.chart.strip_height_mm(),
        r.surface_repair,
    );
    assert!(e.mean < 0.1, "{name}: mean {} um", e.mean);
    assert!(e.max < 5.0, "{name}: max {} um", e.max);
    assert_eq!(r.flipped_disk_triangles, 0, "{name}");
    let aha = r.aha_points.expect("LV");
    assert!(
        aha.iter().all(|&c| c > 0),
        "{name}: empty AHA segment {aha:?}"
    );
    assert_eq!(aha.iter().sum::<usize>(), r.anatomy_points, "{name}");
    for c in &h.outcome.coords {
        assert!((0.0..=1.0).contains(&c.depth), "{name}: depth {}", c.depth);
        assert!(
            c.xi.hypot(c.zeta) <= 1.0 + 1e-9,
            "{name}: off the disk {c:?}"
        );
    }
}

#[test]
fn cobiveco_geo2_round_trip_and_aha() {
    let h = geo2();
    check_real("cobiveco geo2", h);
    // the rim of geo2 is not planar: S is closed by a strip down to its base
    assert!(h.outcome.chart.strip_height_mm() > 1.0);
}

#[test]
fn ellipsoid_round_trip_and_aha() {
    let h = ellipsoid();
    check_real("ellipsoid", h);
    // its rim is planar (no strip), and half of S's triangles were reversed
    assert_eq!(h.outcome.chart.strip_height_mm(), 0.0);
    assert!(h.outcome.report.surface_repair.flipped > 0);
    // the tet vertices on the epicardium have depth 0
    let on_s = h.outcome.coords.iter().filter(|c| c.depth == 0.0).count();
    assert!(on_s > 100, "{on_s} points on S");
}

/// geo2 -> ellipsoid -> geo2 returns every anatomy point.
#[test]
fn transfer_geo2_to_the_ellipsoid_and_back() {
    let (g, l) = (geo2(), ellipsoid());
    let there = l.outcome.chart.inverse_all(&g.outcome.coords).unwrap();
    let coords: Vec<CylinderPoint> = l
        .outcome
        .chart
        .forward_all(&there)
        .unwrap()
        .iter()
        .map(|f| f.coords)
        .collect();
    let back = g.outcome.chart.inverse_all(&coords).unwrap();
    let a = read_mesh("tests/data/cobiveco-geo2/heart_endo_lv.ply").unwrap();
    let worst = a
        .positions
        .iter()
        .zip(&back)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    println!("transfer geo2 -> ellipsoid -> geo2: max {worst:.3e} mm");
    assert!(worst < 1e-3, "max {worst} mm");
    // the transferred points are inside the other heart (depths kept)
    for (c, d) in g.outcome.coords.iter().zip(&coords) {
        assert!((c.depth - d.depth).abs() < 1e-6, "{c:?} vs {d:?}");
    }
    let _ = &g.landmarks;
}

/// On a hemispherical S of radius R with H of radius r at its centre, the
/// Laplace field is the concentric-spheres one (the cap is a plane of
/// symmetry): streamlines are radial, `v_S = R v / |v|` and
/// `d = (R - |v|) / (R - r)`.
#[test]
fn hemisphere_streamlines_are_radial() {
    let radius = 20.0;
    let p = VentricleParams {
        radius,
        length: radius,
        base_above_equator: 0.0,
        rings: 40,
        ..VentricleParams::default()
    };
    let cup = ventricle_cup(&p).unwrap();
    let mut cfg = ChartConfig::default();
    cfg.field.grid_mm = 0.5;
    // every vertex of a hemisphere is equally far from the rim's centre:
    // the apex is given
    let chart = Chart::new(
        &cup.surface,
        &cup.anterior,
        &cup.inferior,
        Some(&cup.apex),
        &cfg,
    )
    .unwrap();
    let frame = *chart.field().frame();
    let r_h = chart.field().hemisphere_radius();
    let mut worst_dir: f64 = 0.0;
    let mut worst_depth: f64 = 0.0;
    let mut pts = Vec::new();
    for k in 0..60 {
        // directions spread over the hemisphere, radii between H and S
        let t = k as f64 / 60.0;
        let polar = 0.1 + 1.35 * ((k * 7 % 60) as f64 / 60.0);
        let az = 2.0 * std::f64::consts::PI * t * 5.0;
        let rad = r_h + 1.0 + (radius - r_h - 2.0) * ((k * 13 % 60) as f64 / 60.0);
        let q = [
            rad * polar.sin() * az.cos(),
            rad * polar.sin() * az.sin(),
            rad * polar.cos(),
        ];
        pts.push((frame.world(q), rad, q));
    }
    let fw = chart
        .forward_all(&pts.iter().map(|x| x.0).collect::<Vec<_>>())
        .unwrap();
    let s = chart.surface();
    for ((_, rad, q), f) in pts.iter().zip(&fw) {
        let tri = s.triangles[f.triangle];
        let hit = tri
            .iter()
            .zip(f.barycentric)
            .fold(Point3::origin(), |acc, (&v, b)| {
                acc + s.positions[v as usize].coords * b
            });
        let h = frame.local(&hit);
        let hn = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let cos = (h[0] * q[0] + h[1] * q[1] + h[2] * q[2]) / (hn * rad);
        worst_dir = worst_dir.max(cos.clamp(-1.0, 1.0).acos().to_degrees());
        let expect = (radius - rad) / (radius - r_h);
        worst_depth = worst_depth.max((f.coords.depth - expect).abs());
    }
    println!("hemisphere: direction error {worst_dir:.3} deg, depth error {worst_depth:.2e}");
    assert!(worst_dir < 0.5, "{worst_dir} deg");
    assert!(worst_depth < 0.01, "{worst_depth}");
}

/// ALGORITHMS 3.7 on the half-ellipsoid cup: anatomy rings of constant
/// height map to circles (radius spread < 2 %), meridians to rays (angle
/// spread < 1 degree), and depth increases along every streamline.
#[test]
fn cup_rings_to_circles_meridians_to_rays() {
    let cup = ventricle_cup(&VentricleParams::default()).unwrap();
    let mut cfg = ChartConfig::default();
    cfg.field.grid_mm = 0.5;
    let chart = Chart::new(&cup.surface, &cup.anterior, &cup.inferior, None, &cfg).unwrap();
    let fw = chart.forward_all(&cup.anatomy_points).unwrap();
    let coords: Vec<CylinderPoint> = fw.iter().map(|f| f.coords).collect();
    let spread = rings_and_meridians(&coords, &cup.anatomy_rings, &cup.anatomy_meridians);
    let (worst_ring, worst_ray) = (spread.worst_radius_spread, spread.worst_angle_deg);
    println!(
        "cup: {} rings, worst radius spread {:.3} %; {} meridians, worst angle spread {:.3} deg",
        cup.anatomy_rings.len(),
        100.0 * worst_ring,
        cup.anatomy_meridians.len(),
        worst_ray
    );
    assert!(!cup.anatomy_rings.is_empty() && !cup.anatomy_meridians.is_empty());
    assert!(worst_ring < 0.02, "{worst_ring}");
    assert!(worst_ray < 1.0, "{worst_ray}");
    // depth along streamlines: points at depths 0, 0.1, .., 1 on the
    // streamline of every anatomy point map back to increasing depths with
    // the same disk position
    for f in &fw {
        let line: Vec<CylinderPoint> = (0..=10)
            .map(|k| CylinderPoint {
                depth: k as f64 / 10.0,
                ..f.coords
            })
            .collect();
        let pts = chart.inverse_all(&line).unwrap();
        let again = chart.forward_all(&pts).unwrap();
        for (k, w) in again.windows(2).enumerate() {
            assert!(
                w[1].coords.depth > w[0].coords.depth,
                "depth not increasing at step {k}: {:?}",
                again.iter().map(|x| x.coords.depth).collect::<Vec<_>>()
            );
        }
        for (g, want) in again.iter().zip(&line) {
            assert!((g.coords.depth - want.depth).abs() < 1e-6);
            assert!((g.coords.xi - want.xi).abs() < 1e-6);
            assert!((g.coords.zeta - want.zeta).abs() < 1e-6);
        }
    }
}

/// Inputs as they come (issue 6, point 0): S with duplicated and reversed
/// triangles is repaired, the repair is reported, and the result is the
/// clean surface's; the anatomy may be bare points.
#[test]
fn a_messy_surface_is_repaired_and_reported() {
    let cup = ventricle_cup(&VentricleParams::default()).unwrap();
    let mut messy = cup.surface.clone();
    let n = messy.triangles.len();
    // every 10th triangle duplicated, every 7th reversed
    for t in (0..n).step_by(10) {
        let tri = messy.triangles[t];
        messy.triangles.push(tri);
    }
    for t in (0..n).step_by(7) {
        messy.triangles[t].swap(0, 1);
    }
    let points = CellMesh::from_points(cup.anatomy_points.clone());
    let landmarks = LandmarkPoints {
        anterior: cup.anterior,
        inferior: cup.inferior,
        apex: None,
        rim_near: None,
    };
    let clean = run(&points, &cup.surface, &landmarks, &config(2.0)).unwrap();
    let fixed = run(&points, &messy, &landmarks, &config(2.0)).unwrap();
    let r = fixed.report.surface_repair;
    println!("repair of the messy cup: {r:?}");
    assert_eq!(r.duplicate_elements, n.div_ceil(10));
    assert!(r.flipped > 0);
    assert!(clean.report.surface_repair.is_clean());
    assert_eq!(fixed.report.flipped_disk_triangles, 0);
    assert!(fixed.report.roundtrip_error_um.max < 5.0);
    // the repaired surface gives the same map as the clean one
    let worst = largest_difference(&clean, &fixed);
    assert!(worst < 1e-6, "{worst}");
}

/// The largest difference of `xi`, `zeta` or `depth` between two maps of
/// the same points.
fn largest_difference(a: &Outcome, b: &Outcome) -> f64 {
    assert_eq!(a.coords.len(), b.coords.len());
    a.coords
        .iter()
        .zip(&b.coords)
        .map(|(a, b)| {
            (a.xi - b.xi)
                .abs()
                .max((a.zeta - b.zeta).abs())
                .max((a.depth - b.depth).abs())
        })
        .fold(0.0, f64::max)
}

/// A file whose triangles all wind the other way (a consistent surface, so
/// the repair keeps its orientation) gives geo2 the same map: its rim is
/// walked the other way round, and the strip that closes the non-planar
/// rim is split the same way (before, each strip quad was split along the
/// diagonal the walk met first, and the map moved by up to 1.9e-3).
#[test]
fn geo2_reversed_triangles_give_the_same_map() {
    let h = geo2();
    let mut s = read_tri_mesh("tests/data/cobiveco-geo2/heart_epi.ply").unwrap();
    for t in &mut s.triangles {
        t.swap(1, 2);
    }
    let a: CellMesh = read_mesh("tests/data/cobiveco-geo2/heart_endo_lv.ply").unwrap();
    let reversed = run(&a, &s, &h.landmarks, &config(1.0)).unwrap();
    assert!(reversed.report.surface_repair.is_clean());
    assert!(h.outcome.chart.strip_height_mm() > 1.0, "a strip to close");
    let worst = largest_difference(&h.outcome, &reversed);
    println!("geo2 with reversed triangles: largest difference {worst:.2e}");
    assert!(worst < 1e-9, "{worst}");
}
