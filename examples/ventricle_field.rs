//! The ventricle Laplace field's accuracy, time and peak memory at one grid
//! spacing (issue 21, point 3), one measurement per process so that the
//! printed peak (`VmHWM`) is that measurement's:
//!
//! ```sh
//! cargo run --release --example ventricle_field -- hemisphere 0.5
//! cargo run --release --example ventricle_field -- geo2 0.5 /tmp/geo2_0.5.txt
//! cargo run --release --example ventricle_field -- compare /tmp/geo2_1.txt /tmp/geo2_0.5.txt
//! cargo run --release --example ventricle_field -- transfer 1
//! cargo run --release --example ventricle_field -- targets
//! ```
//!
//! - `hemisphere H`: the test `hemisphere_streamlines_are_radial`
//!   (`tests/ventricle_map.rs`) at grid `H` mm: S a hemisphere of radius 20
//!   mm, 60 points between H and S; the worst angle between the streamline's
//!   end on S and the radial direction, and the worst depth error against
//!   `(R - |v|) / (R - r)`.
//! - `geo2 H [FILE|-] [TOL]`: the pipeline on Cobiveco geo2 (as
//!   `benches/ventricle.rs`) at grid `H`: seconds per step, unknowns, round
//!   trip; with `FILE`, each anatomy point's `xi zeta depth` written there;
//!   with `TOL`, the field's relative residual tolerance instead of the
//!   default.
//! - `compare A B`: the largest and mean differences of two such files
//!   (the map's change between two grids; with B from a finer grid, A's
//!   error), and how much of it the outer tenth of the points by disk
//!   radius (the base) carries.
//! - `transfer H`: geo2 -> ellipsoid -> geo2 at grid `H` (the test
//!   `transfer_geo2_to_the_ellipsoid_and_back`): the largest distance.
//! - `targets`: `geo2 0.5` and `geo2 0.3`, each in a process of its own,
//!   their whole pipeline's seconds and peak against the targets (0.5 mm
//!   under 2 s and 400 MB, 0.3 mm under 5 s and 1 GB), with the load.
//!
//! Every mode ends with `peak_mib` (the process's `VmHWM`, Linux) and the
//! wall time.

use std::time::Instant;
use unfold::io::{read_mesh, read_tri_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{VentricleParams, ventricle_cup};
use unfold::mesh::{CellMesh, TriMesh};
use unfold::organs::ventricle::{
    Chart, ChartConfig, Config, CylinderPoint, LandmarkPoints, Outcome, Pipeline,
};
use unfold::param::initializer::disk_boundary_loop;

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let t0 = Instant::now();
    let num = |k: usize| -> Res<f64> {
        Ok(args
            .get(k)
            .ok_or("missing the grid spacing (mm)")?
            .parse::<f64>()?)
    };
    match args.first().map(String::as_str) {
        Some("hemisphere") => hemisphere(num(1)?)?,
        Some("geo2") => geo2(
            num(1)?,
            args.get(2).map(String::as_str).filter(|f| *f != "-"),
            args.get(3).map(|t| t.parse::<f64>()).transpose()?,
        )?,
        Some("compare") => compare(
            args.get(1).ok_or("missing file A")?,
            args.get(2).ok_or("missing file B")?,
        )?,
        Some("transfer") => transfer(num(1)?)?,
        Some("targets") => return targets(),
        _ => {
            return Err(
                "usage: ventricle_field hemisphere|geo2|compare|transfer|targets ...".into(),
            );
        }
    }
    println!(
        "peak_mib {:.1} wall_s {:.2}",
        vm_hwm().unwrap_or(0) as f64 / 1_048_576.0,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The process's peak resident size, bytes (`VmHWM`).
fn vm_hwm() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn hemisphere(grid_mm: f64) -> Res<()> {
    let radius = 20.0;
    let cup = ventricle_cup(&VentricleParams {
        radius,
        length: radius,
        base_above_equator: 0.0,
        rings: 40,
        ..VentricleParams::default()
    })?;
    let mut cfg = ChartConfig::default();
    cfg.field.grid_mm = grid_mm;
    let t = Instant::now();
    let chart = Chart::new(
        &cup.surface,
        &cup.anterior,
        &cup.inferior,
        Some(&cup.apex),
        &cfg,
    )?;
    let chart_s = t.elapsed().as_secs_f64();
    let frame = *chart.field().frame();
    let r_h = chart.field().hemisphere_radius();
    let mut pts = Vec::new();
    for k in 0..60 {
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
    let t = Instant::now();
    let fw = chart.forward_all(&pts.iter().map(|x| x.0).collect::<Vec<_>>())?;
    let trace_s = t.elapsed().as_secs_f64();
    let s = chart.surface();
    let (mut worst_dir, mut worst_depth) = (0.0f64, 0.0f64);
    for ((_, rad, q), f) in pts.iter().zip(&fw) {
        let hit = s.triangles[f.triangle]
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
    println!(
        "hemisphere grid {grid_mm} mm: unknowns {} chart_s {chart_s:.2} trace_s {trace_s:.2} \
         direction_deg {worst_dir:.4} depth {worst_depth:.3e}",
        chart.field().stats().unknowns
    );
    Ok(())
}

/// Two rim points a third of the loop apart (after the repair of S), as the
/// tests and the bench take them.
fn rim_landmarks(s: &TriMesh) -> Res<LandmarkPoints> {
    let (r, _) = unfold::mesh::repair::repair_tri_mesh(s)?;
    let rim = disk_boundary_loop(&r)?;
    Ok(LandmarkPoints {
        anterior: r.positions[rim[0] as usize],
        inferior: r.positions[rim[rim.len() / 3] as usize],
        apex: None,
        rim_near: None,
    })
}

fn run(surface: &str, anatomy: &str, grid_mm: f64) -> Res<Outcome> {
    run_with(surface, anatomy, grid_mm, None)
}

fn run_with(surface: &str, anatomy: &str, grid_mm: f64, tolerance: Option<f64>) -> Res<Outcome> {
    let s = read_tri_mesh(surface)?;
    let a: CellMesh = read_mesh(anatomy)?;
    let landmarks = rim_landmarks(&s)?;
    let mut c = Config::default();
    c.chart.field.grid_mm = grid_mm;
    if let Some(t) = tolerance {
        c.chart.field.tolerance = t;
    }
    Ok(Pipeline::new().config(c).run(&a, &s, &landmarks)?)
}

const GEO2: [&str; 2] = [
    "tests/data/cobiveco-geo2/heart_epi.ply",
    "tests/data/cobiveco-geo2/heart_endo_lv.ply",
];

fn geo2(grid_mm: f64, out: Option<&str>, tolerance: Option<f64>) -> Res<()> {
    let t = Instant::now();
    let o = run_with(GEO2[0], GEO2[1], grid_mm, tolerance)?;
    let total = t.elapsed().as_secs_f64();
    let r = &o.report;
    println!(
        "geo2 grid {grid_mm} mm: unknowns {} cg {} seconds {:?} total_s {total:.2} \
         round trip um mean {:.2e} max {:.2e} residual {:.1e}",
        r.field.unknowns,
        r.field.cg_iterations,
        r.seconds,
        r.roundtrip_error_um.mean,
        r.roundtrip_error_um.max,
        r.field.relative_residual
    );
    if let Some(path) = out {
        let text: String = o
            .coords
            .iter()
            .map(|c| format!("{:.12e} {:.12e} {:.12e}\n", c.xi, c.zeta, c.depth))
            .collect();
        std::fs::write(path, text)?;
    }
    Ok(())
}

fn read_coords(path: &str) -> Res<Vec<[f64; 3]>> {
    std::fs::read_to_string(path)?
        .lines()
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()?;
            Ok([v[0], v[1], v[2]])
        })
        .collect()
}

fn compare(a: &str, b: &str) -> Res<()> {
    let (a, b) = (read_coords(a)?, read_coords(b)?);
    if a.len() != b.len() {
        return Err(format!("{} points against {}", a.len(), b.len()).into());
    }
    let (mut disk, mut depth, mut sum) = (0.0f64, 0.0f64, 0.0f64);
    for (p, q) in a.iter().zip(&b) {
        let d = (p[0] - q[0]).hypot(p[1] - q[1]);
        disk = disk.max(d);
        sum += d;
        depth = depth.max((p[2] - q[2]).abs());
    }
    println!(
        "compare: {} points, disk position max {disk:.3e} mean {:.3e} (unit disk), depth max {depth:.3e}",
        a.len(),
        sum / a.len() as f64
    );
    // the outer tenth of the points by B's disk radius (the base)
    let mut by_radius: Vec<(f64, f64)> = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (q[0].hypot(q[1]), (p[0] - q[0]).hypot(p[1] - q[1])))
        .collect();
    by_radius.sort_by(|x, y| x.0.total_cmp(&y.0));
    let cut = by_radius.len() * 9 / 10;
    let (inner, outer) = by_radius.split_at(cut);
    let mean = |v: &[(f64, f64)]| v.iter().map(|x| x.1).sum::<f64>() / v.len().max(1) as f64;
    let outer_sum: f64 = outer.iter().map(|x| x.1).sum();
    println!(
        "compare: outer tenth (disk radius above {:.2}) mean {:.3e}, {:.0} % of the summed shift; \
         the rest mean {:.3e}",
        outer.first().map_or(f64::NAN, |x| x.0),
        mean(outer),
        100.0 * outer_sum / sum.max(f64::MIN_POSITIVE),
        mean(inner)
    );
    Ok(())
}

fn transfer(grid_mm: f64) -> Res<()> {
    let g = run(GEO2[0], GEO2[1], grid_mm)?;
    let l = run(
        "tests/data/ellipsoid-heart/epi.obj",
        "tests/data/ellipsoid-heart/heart.vtu",
        grid_mm,
    )?;
    let there = l.chart.inverse_all(&g.coords)?;
    let coords: Vec<CylinderPoint> = l
        .chart
        .forward_all(&there)?
        .iter()
        .map(|f| f.coords)
        .collect();
    let back = g.chart.inverse_all(&coords)?;
    let a = read_mesh(GEO2[1])?;
    let worst = a
        .positions
        .iter()
        .zip(&back)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    println!("transfer grid {grid_mm} mm: geo2 -> ellipsoid -> geo2 max {worst:.3e} mm");
    Ok(())
}

/// `geo2 0.5` and `geo2 0.3` in child processes: each one's pipeline
/// seconds (`total_s`) and peak (`peak_mib`) against the targets.
fn targets() -> Res<()> {
    let exe = std::env::current_exe()?;
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "load {}",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    for (grid, max_s, max_mib) in [("0.5", 2.0, 400.0), ("0.3", 5.0, 1000.0)] {
        let out = std::process::Command::new(&exe)
            .args(["geo2", grid])
            .output()?;
        let text = String::from_utf8_lossy(&out.stdout);
        let field = |key: &str| -> Option<f64> {
            let rest = &text[text.find(&format!("{key} "))? + key.len() + 1..];
            rest.split_whitespace().next()?.parse().ok()
        };
        let (secs, peak) = (field("total_s"), field("peak_mib"));
        let laplace = text
            .find("laplace: ")
            .and_then(|i| text[i + 9..].split(',').next()?.trim().parse::<f64>().ok());
        println!(
            "geo2 {grid} mm: pipeline {:.2} s (target {max_s} s; Laplace {:.2} s), peak {:.1} MiB \
             (target {max_mib} MB = {:.1} MiB){}",
            secs.unwrap_or(f64::NAN),
            laplace.unwrap_or(f64::NAN),
            peak.unwrap_or(f64::NAN),
            max_mib * 1e6 / 1_048_576.0,
            if out.status.success() { "" } else { "; FAILED" }
        );
    }
    Ok(())
}
