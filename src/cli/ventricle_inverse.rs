//! `unfold ventricle-inverse NORMALIZED --surface S --anterior X,Y,Z
//! --inferior X,Y,Z -o OUT`: a mesh given in the normalized coordinates of
//! the cylinder carried back onto a heart, `v = psi^-1(xi, zeta, depth)`
//! (ALGORITHMS 3.4; the source paper's Algorithm 2, §3.5).
//!
//! NORMALIZED is any mesh file (points, lines, triangles, tets). Its
//! points' cylinder coordinates are read, by `--coordinates`:
//!
//! - `arrays`: the point arrays `xi`, `zeta` (the harmonic disk position
//!   `phi(v_S)`) and `depth`, as `unfold ventricle` writes them into
//!   `normalized.vtu`;
//! - `points`: the points themselves as `(X, Y, depth)`, `(X, Y)` the
//!   *displayed* disk position (the LV disk warped by `r' = r^n`,
//!   `--display-exponent n`, which is inverted: `r = r'^(1/n)`; the RV
//!   half disk as it is), as `normalized.vtu`'s points are. Regions drawn
//!   on the displayed disk or the bull's-eye are given this way;
//! - `auto` (default): the arrays when the mesh has all three, else the
//!   points (one or two of the arrays alone is an error).
//!
//! The chart of the target heart is built from S and its landmarks with
//! the settings and flags of `unfold ventricle` (grid, hemisphere,
//! chamber, display exponent, snap distance, markups file, mesh frame),
//! through the same code ([`super::ventricle`]). Every point is mapped by
//! [`Chart::inverse`] on its own: one that cannot be mapped (depth outside
//! `[0, 1]`, a disk position outside the flattened S, a failed streamline)
//! gets a status instead of failing the run, and is placed at the centre of
//! the base (the centre of H, where no mapped point lies; mesh files cannot
//! hold NaN); all points failing is an error.
//!
//! Outputs in OUT (created if missing), each written atomically:
//!
//! - `mapped.vtu`: the input's cells and every point and cell array
//!   (label fields come along), the points at `psi^-1`, in RAS mm; point
//!   arrays `inverse_status` (0 mapped, 1 not a cylinder point, 2 off the
//!   disk, 3 streamline failed), `xi`, `zeta`, `depth` (the coordinates
//!   used) and with `--layers N` `layer` (1 at S to N at H, 0 for a point
//!   not mapped); the points not mapped at the centre of the base;
//! - `report.json`: the points, how many were mapped, the failures per
//!   reason and the first ones with their messages, the chart's settings
//!   and landmarks, seconds, memory and provenance.

use super::ventricle::{
    ChamberArg, MAX_LAYERS, heart_landmarks, read_surface, settings, transmural_layers,
    with_vertex_cells,
};
use super::ventricle_landmark_args::HeartLandmarkArgs;
use super::{AppError, MeshFrame, about, at, organ};
use crate::app::run::StagedOutputs;
use crate::io::{WriteOptions, atomic_write, read_mesh, write_mesh};
use crate::mesh::nalgebra::Point3;
use crate::mesh::{CellMesh, Field, TriMesh};
use crate::organs::ventricle::disk::display_warp;
use crate::organs::ventricle::field::{DEFAULT_GRID_MM, DEFAULT_HEMISPHERE_MM};
use crate::organs::ventricle::landmarks::DEFAULT_SNAP_MM;
use crate::organs::ventricle::rv_landmarks::FromRv;
use crate::organs::ventricle::{
    Chamber, Config, CylinderPoint, LandmarkPoints, Pipeline, PointFailure,
};
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// `--coordinates`: where the cylinder coordinates of NORMALIZED's points
/// come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CoordinatesArg {
    /// The point arrays when all three are present, else the points.
    Auto,
    /// The point arrays `xi`, `zeta`, `depth` (harmonic disk and depth).
    Arrays,
    /// The points as `(X, Y, depth)`, `(X, Y)` on the displayed disk.
    Points,
}

/// Arguments of `unfold ventricle-inverse`.
#[derive(Debug, Args)]
#[command(
    after_help = "NORMALIZED's cylinder coordinates: with --coordinates auto (default) the point \
                  arrays xi, zeta, depth when it has all three (what unfold ventricle writes into \
                  normalized.vtu), else its points as (X, Y, depth) with (X, Y) on the displayed \
                  disk (the LV disk warped by r' = r^n, n the --display-exponent, inverted here). \
                  Writes OUT/mapped.vtu (NORMALIZED's cells and arrays, the points carried onto \
                  the heart; point arrays inverse_status: 0 mapped, 1 not a cylinder point, 2 \
                  off the disk, 3 streamline failed, placed at the centre of the base; xi, zeta, \
                  depth; \
                  layer with --layers) and OUT/report.json. The heart's flags are those of \
                  unfold ventricle."
)]
pub struct VentricleInverseArgs {
    /// The mesh in normalized coordinates (any mesh file: points, lines,
    /// triangles, tets), e.g. an `unfold ventricle` run's normalized.vtu, a
    /// label field drawn on the disk, an atlas in the cylinder.
    normalized: PathBuf,
    /// Where the cylinder coordinates come from (see below).
    #[arg(long, value_enum, default_value = "auto")]
    coordinates: CoordinatesArg,
    /// The enclosing surface S of the target heart (as for `unfold
    /// ventricle`).
    #[arg(long, value_name = "S")]
    surface: PathBuf,
    #[command(flatten)]
    heart: HeartLandmarkArgs,
    /// The frame of S's coordinates (auto, ras, lps); NORMALIZED is in
    /// cylinder coordinates and is not converted.
    #[arg(long, value_parser = super::choice::named::<MeshFrame>(), default_value = "auto")]
    mesh_frame: MeshFrame,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The chamber S encloses.
    #[arg(long, value_enum, default_value = "lv")]
    chamber: ChamberArg,
    /// Grid spacing of the Laplace field, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_GRID_MM, allow_negative_numbers = true)]
    grid_mm: f64,
    /// Radius of the hemisphere H at the centre of the base, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_HEMISPHERE_MM, allow_negative_numbers = true)]
    hemisphere_mm: f64,
    /// Display exponent n of the LV disk, r' = r^n, inverted for
    /// coordinates read from the points [default: 1/3].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    display_exponent: Option<f64>,
    /// Largest distance from a given rim landmark to the rim of S, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_SNAP_MM, allow_negative_numbers = true)]
    snap_mm: f64,
    /// Label N transmural layers of equal depth: the point array `layer`,
    /// 1 at S (depth 0) to N at H (depth 1), `min(floor(depth N) + 1, N)`;
    /// 0 for a point not mapped.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_LAYERS)))]
    layers: Option<u32>,
}

/// The output files.
const MAPPED: &str = "mapped.vtu";
const REPORT: &str = "report.json";

/// `inverse_status` of a point mapped.
pub(crate) const STATUS_MAPPED: i32 = 0;
/// `inverse_status`: not a cylinder point (not finite, depth outside
/// `[0, 1]`).
pub(crate) const STATUS_NOT_ON_CYLINDER: i32 = 1;
/// `inverse_status`: the disk position lies outside the flattened S.
pub(crate) const STATUS_OFF_DISK: i32 = 2;
/// `inverse_status`: the streamline failed.
pub(crate) const STATUS_STREAMLINE: i32 = 3;

/// The `inverse_status` of a failure.
fn status_of(f: &PointFailure) -> i32 {
    match f {
        PointFailure::NotOnCylinder { .. } | PointFailure::NotFinite { .. } => {
            STATUS_NOT_ON_CYLINDER
        }
        PointFailure::OffDisk { .. } => STATUS_OFF_DISK,
        _ => STATUS_STREAMLINE,
    }
}

/// How many first failures `report.json` lists with their messages.
const LISTED_FAILURES: usize = 20;

/// Where the coordinates came from, for the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// The point arrays `xi`, `zeta`, `depth`.
    Arrays,
    /// The points as `(X, Y, depth)`.
    Points,
}

/// The point arrays of the cylinder coordinates.
const ARRAYS: [&str; 3] = ["xi", "zeta", "depth"];

/// The cylinder coordinates of `mesh`'s points (module doc), and where
/// they came from.
///
/// # Errors
/// A usage error naming `path` for one or two of the arrays alone (with
/// `auto`), an array missing (with `arrays`) or not one value per point.
fn cylinder_coordinates(
    mesh: &CellMesh,
    path: &str,
    how: CoordinatesArg,
    chamber: Chamber,
    display_exponent: f64,
) -> Result<(Vec<CylinderPoint>, Source), AppError> {
    let present: Vec<&str> = ARRAYS
        .iter()
        .copied()
        .filter(|n| mesh.point_data.get(n).is_some())
        .collect();
    let source = match how {
        CoordinatesArg::Points => Source::Points,
        CoordinatesArg::Arrays => {
            if present.len() < 3 {
                let missing: Vec<&str> = ARRAYS
                    .iter()
                    .copied()
                    .filter(|n| !present.contains(n))
                    .collect();
                return Err(about(
                    path,
                    format!(
                        "has no point array {} (--coordinates arrays reads xi, zeta and depth)",
                        missing.join(", ")
                    ),
                ));
            }
            Source::Arrays
        }
        CoordinatesArg::Auto => match present.len() {
            3 => Source::Arrays,
            0 => Source::Points,
            _ => {
                return Err(about(
                    path,
                    format!(
                        "has the point array(s) {} but not all of xi, zeta, depth: give all \
                         three, or --coordinates points to read (X, Y, depth) from the points",
                        present.join(", ")
                    ),
                ));
            }
        },
    };
    let n = mesh.positions.len();
    let coords = match source {
        Source::Arrays => {
            let mut cols = Vec::with_capacity(3);
            for name in ARRAYS {
                let f = mesh
                    .point_data
                    .get(name)
                    .ok_or_else(|| about(path, format!("has no point array {name}")))?;
                if f.components() != 1 || f.tuples() != n {
                    return Err(about(
                        path,
                        format!(
                            "point array {name} has {} component(s) and {} tuple(s); one value \
                             per point ({n}) is needed",
                            f.components(),
                            f.tuples()
                        ),
                    ));
                }
                cols.push(f.values().to_f64());
            }
            (0..n)
                .map(|i| CylinderPoint {
                    xi: cols[0][i],
                    zeta: cols[1][i],
                    depth: cols[2][i],
                })
                .collect()
        }
        Source::Points => {
            let shown: Vec<[f64; 2]> = mesh.positions.iter().map(|p| [p.x, p.y]).collect();
            let uv = harmonic_positions(chamber, &shown, display_exponent)?;
            uv.iter()
                .zip(&mesh.positions)
                .map(|(q, p)| CylinderPoint {
                    xi: q[0],
                    zeta: q[1],
                    depth: p.z,
                })
                .collect()
        }
    };
    Ok((coords, source))
}

/// The harmonic disk positions of displayed ones: the LV's display warp
/// `r' = r^n` inverted, `r = r'^(1/n)` (the warp with exponent `1/n`); the
/// RV's half disk is not warped. Non-finite positions stay non-finite.
///
/// # Errors
/// A usage error for an exponent that is not finite and > 0.
pub(crate) fn harmonic_positions(
    chamber: Chamber,
    shown: &[[f64; 2]],
    exponent: f64,
) -> Result<Vec<[f64; 2]>, AppError> {
    match chamber {
        Chamber::Lv => {
            display_warp(shown, 1.0 / exponent).map_err(|e| AppError::Usage(e.to_string()))
        }
        Chamber::Rv => Ok(shown.to_vec()),
    }
}

/// Failures per reason in `report.json`.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FailureCounts {
    /// Not a cylinder point (not finite, depth outside `[0, 1]`).
    not_on_cylinder: usize,
    /// Disk position outside the flattened S.
    off_disk: usize,
    /// The streamline failed.
    streamline: usize,
}

/// One failure listed in `report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct FailureEntry {
    /// Index of the point in NORMALIZED.
    point: usize,
    /// Its `inverse_status`.
    status: i32,
    /// Why.
    reason: String,
}

/// Seconds per step.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct InverseSeconds {
    /// Repair, landmarks and disk map of S.
    disk: f64,
    /// The Laplace field.
    laplace: f64,
    /// The inverse map of every point.
    inverse: f64,
    /// The whole command.
    total: f64,
}

/// The inputs named in `report.json`.
#[derive(Serialize)]
pub struct InverseInputs<'a> {
    normalized: &'a str,
    surface: &'a str,
    /// `arrays` or `points`.
    coordinates: Source,
    #[serde(skip_serializing_if = "Option::is_none")]
    rv_landmarks: Option<&'a FromRv>,
}

/// `report.json` of `unfold ventricle-inverse`: [`InverseBody`], then
/// the memory and provenance sections (the command line's or Python's).
#[derive(Serialize)]
pub struct InverseReport<'a, M, P> {
    /// What [`invert`] found.
    #[serde(flatten)]
    pub body: &'a InverseBody<'a>,
    /// Predicted (and measured) peak memory.
    pub memory: M,
    /// Version, parameters, time.
    pub provenance: P,
}

/// The sections of `report.json` that [`invert`] fills.
#[derive(Serialize)]
pub struct InverseBody<'a> {
    inputs: InverseInputs<'a>,
    chamber: Chamber,
    /// Points of NORMALIZED.
    points: usize,
    /// Points carried onto the heart.
    mapped: usize,
    /// Points that could not be.
    failed: usize,
    /// Where mapped.vtu puts them: the centre of the base (of H), mm.
    failed_points_at_mm: [f64; 3],
    failures: FailureCounts,
    /// The first failures, with their messages.
    first_failures: Vec<FailureEntry>,
    grid_mm: f64,
    hemisphere_mm: f64,
    display_exponent: f64,
    landmark_snap_mm: [f64; 3],
    apex_mm: [f64; 3],
    seconds: InverseSeconds,
}

/// What [`invert`] is given.
pub struct InverseInput<'a> {
    /// The mesh in cylinder coordinates.
    pub normalized: &'a CellMesh,
    /// What messages and the report call it.
    pub normalized_label: &'a str,
    /// Where its coordinates come from.
    pub coordinates: CoordinatesArg,
    /// The target heart's S.
    pub surface: &'a TriMesh,
    /// What messages and the report call S.
    pub surface_label: &'a str,
    /// S's landmarks.
    pub landmarks: LandmarkPoints,
    /// The RV insertion points they came from, if so.
    pub from_rv: Option<&'a FromRv>,
    /// The chart's settings ([`settings`]).
    pub config: Config,
    /// `--layers`.
    pub layers: Option<u32>,
    /// When the run started (for `seconds.total`).
    pub started: Instant,
}

/// What [`invert`] computes before anything is written.
pub struct Inverted<'a> {
    /// The input with its points at `psi^-1` and the point arrays of the
    /// module doc (`mapped.vtu`).
    pub mapped: CellMesh,
    /// `report.json` without memory and provenance.
    pub body: InverseBody<'a>,
    /// The field's predicted memory, bytes.
    pub estimated_bytes: f64,
}

/// Runs `unfold ventricle-inverse`.
pub fn run(a: &VentricleInverseArgs) -> Result<(), AppError> {
    let start = Instant::now();
    let config = settings(
        a.chamber.into(),
        a.grid_mm,
        a.hemisphere_mm,
        a.display_exponent,
        a.snap_mm,
    )?;
    let out = a.output.as_path();
    if out.exists() && !out.is_dir() {
        return Err(at(
            out,
            "exists and is not a directory; -o needs a directory (created if missing)",
        ));
    }
    let mut inputs = vec![&a.normalized, &a.surface];
    inputs.extend(&a.heart.landmarks);
    let d = super::canonical(out);
    for input in &inputs {
        for f in [MAPPED, REPORT] {
            if d.join(f) == super::canonical(input) {
                return Err(at(
                    input,
                    format!(
                        "is an input and would be overwritten by the output {f}; choose another -o"
                    ),
                ));
            }
        }
    }
    let mut staged = StagedOutputs::new(&inputs);
    let staging = staged.dir(out)?;

    let normalized = read_mesh(&a.normalized)?;
    let normalized_label = a.normalized.display().to_string();
    let surface = read_surface(&a.surface, a.mesh_frame)?;
    let surface_label = a.surface.display().to_string();
    let (landmarks, from_rv) = heart_landmarks(&surface, &surface_label, a.chamber, &a.heart)?;
    let Inverted {
        mapped,
        body,
        estimated_bytes: _,
    } = invert(&InverseInput {
        normalized: &normalized,
        normalized_label: &normalized_label,
        coordinates: a.coordinates,
        surface: &surface,
        surface_label: &surface_label,
        landmarks,
        from_rv: from_rv.as_ref(),
        config,
        layers: a.layers,
        started: start,
    })?;
    let (n, failed, counts) = (body.points, body.failed, body.failures);

    super::ensure_dir(&staging)?;
    let mapped_path = staging.join(MAPPED);
    write_mesh(
        &mapped_path,
        &with_vertex_cells(&mapped),
        &WriteOptions::default(),
    )
    .map_err(|e| super::shown(&staged, e.into()))?;
    let report_path = staging.join(REPORT);
    let json = serde_json::to_string_pretty(&InverseReport {
        body: &body,
        memory: crate::app::run::memory::report(),
        provenance: crate::app::run::provenance::this_run(),
    })
    .map_err(|e| at(&report_path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_path, format!("{json}\n").as_bytes())
        .map_err(|e| super::shown(&staged, e.into()))?;
    staged.commit()?;
    println!(
        "{}: {} of {} points mapped onto {}{} in {:.2} s (chart {:.2} s, inverse {:.2} s)",
        normalized_label,
        n - failed,
        n,
        surface_label,
        if failed > 0 {
            format!(
                "; {failed} not (not a cylinder point: {}, off the disk: {}, streamline: {}; \
                 see inverse_status)",
                counts.not_on_cylinder, counts.off_disk, counts.streamline
            )
        } else {
            String::new()
        },
        start.elapsed().as_secs_f64(),
        body.seconds.disk + body.seconds.laplace,
        body.seconds.inverse
    );
    for f in [MAPPED, REPORT] {
        println!("wrote {}", out.join(f).display());
    }
    Ok(())
}

/// `psi^-1` of every point of a mesh in cylinder coordinates onto one
/// heart (the module doc): the command line's and Python's one path.
///
/// # Errors
/// A usage error for an input without points, coordinates that cannot be
/// read, or no point mapped; the pipeline's error about S.
pub fn invert<'a>(input: &InverseInput<'a>) -> Result<Inverted<'a>, AppError> {
    let normalized = input.normalized;
    let config = input.config;
    if normalized.positions.is_empty() {
        return Err(about(
            input.normalized_label,
            "has no points; give a mesh in normalized coordinates (xi, zeta, depth)",
        ));
    }
    let chamber = config.chart.chamber;
    let (coords, source) = cylinder_coordinates(
        normalized,
        input.normalized_label,
        input.coordinates,
        chamber,
        config.display_exponent,
    )?;
    // The field checks its estimate against the room left (issue 18).
    let mut chart_config = config;
    chart_config.chart.field.max_memory_bytes = crate::app::run::memory::room();
    let resident = crate::app::run::memory::resident_bytes().unwrap_or(0.0);
    let chart = Pipeline::new()
        .config(chart_config)
        .chart(input.surface, &input.landmarks)
        .map_err(|e| organ(input.surface_label, e))?;
    let estimated_bytes = chart.field().stats().estimated_bytes;
    crate::app::run::memory::record(resident + estimated_bytes);

    let t0 = Instant::now();
    let results: Vec<Result<Point3<f64>, PointFailure>> =
        coords.par_iter().map(|c| chart.inverse(c)).collect();
    let inverse_seconds = t0.elapsed().as_secs_f64();

    let n = coords.len();
    let nowhere = chart.field().frame().world([0.0; 3]);
    let mut status = Vec::with_capacity(n);
    let mut positions = Vec::with_capacity(n);
    let mut counts = FailureCounts::default();
    let mut first_failures = Vec::new();
    for (i, r) in results.iter().enumerate() {
        match r {
            Ok(p) => {
                status.push(STATUS_MAPPED);
                positions.push(*p);
            }
            Err(f) => {
                let s = status_of(f);
                match s {
                    STATUS_NOT_ON_CYLINDER => counts.not_on_cylinder += 1,
                    STATUS_OFF_DISK => counts.off_disk += 1,
                    _ => counts.streamline += 1,
                }
                if first_failures.len() < LISTED_FAILURES {
                    first_failures.push(FailureEntry {
                        point: i,
                        status: s,
                        reason: f.to_string(),
                    });
                }
                status.push(s);
                positions.push(nowhere);
            }
        }
    }
    let failed = n - status.iter().filter(|&&s| s == STATUS_MAPPED).count();
    if failed == n {
        let first = &first_failures[0];
        return Err(about(
            input.normalized_label,
            format!(
                "none of its {n} points maps onto the heart (not a cylinder point: {}, off the \
                 disk: {}, streamline: {}); point {}: {} (read from the {})",
                counts.not_on_cylinder,
                counts.off_disk,
                counts.streamline,
                first.point,
                first.reason,
                match source {
                    Source::Arrays => "point arrays xi, zeta, depth",
                    Source::Points => "points as (X, Y, depth)",
                }
            ),
        ));
    }

    let mut mapped = normalized.clone();
    mapped.positions = positions;
    mapped
        .point_data
        .insert(Field::labels("inverse_status", status.clone()));
    if source == Source::Points {
        mapped
            .point_data
            .insert(Field::scalars("xi", coords.iter().map(|c| c.xi).collect()));
        mapped.point_data.insert(Field::scalars(
            "zeta",
            coords.iter().map(|c| c.zeta).collect(),
        ));
        mapped.point_data.insert(Field::scalars(
            "depth",
            coords.iter().map(|c| c.depth).collect(),
        ));
    }
    if let Some(k) = input.layers {
        let layer: Vec<i32> = transmural_layers(&coords, k)
            .into_iter()
            .zip(&status)
            .map(|(l, &s)| if s == STATUS_MAPPED { l } else { 0 })
            .collect();
        mapped.point_data.insert(Field::labels("layer", layer));
    }
    let timings = chart.timings();
    let apex = chart.surface().positions[chart.landmarks().apex as usize];
    let body = InverseBody {
        inputs: InverseInputs {
            normalized: input.normalized_label,
            surface: input.surface_label,
            coordinates: source,
            rv_landmarks: input.from_rv,
        },
        chamber,
        points: n,
        mapped: n - failed,
        failed,
        failed_points_at_mm: [nowhere.x, nowhere.y, nowhere.z],
        failures: counts,
        first_failures,
        grid_mm: chart.field().grid_mm(),
        hemisphere_mm: chart.field().hemisphere_radius(),
        display_exponent: config.display_exponent,
        landmark_snap_mm: chart.landmarks().snap_distances_mm,
        apex_mm: [apex.x, apex.y, apex.z],
        seconds: InverseSeconds {
            disk: timings.disk,
            laplace: timings.laplace,
            inverse: inverse_seconds,
            total: input.started.elapsed().as_secs_f64(),
        },
    };
    Ok(Inverted {
        mapped,
        body,
        estimated_bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::organs::ventricle::pipeline::displayed;
    use proptest::prelude::*;

    proptest! {
        /// The display warp inverted: `harmonic_positions(displayed(uv))
        /// = uv` on the LV disk for any exponent, and the RV untouched.
        #[test]
        fn the_display_warp_is_inverted(
            r in 0.0..1.0f64,
            a in 0.0..std::f64::consts::TAU,
            n in 0.1..3.0f64,
        ) {
            let uv = [[r * a.cos(), r * a.sin()]];
            let shown = displayed(Chamber::Lv, &uv, n).unwrap();
            let back = harmonic_positions(Chamber::Lv, &shown, n).unwrap();
            prop_assert!((back[0][0] - uv[0][0]).abs() < 1e-12);
            prop_assert!((back[0][1] - uv[0][1]).abs() < 1e-12);
            let rv = harmonic_positions(Chamber::Rv, &uv, n).unwrap();
            prop_assert_eq!(rv, uv.to_vec());
        }
    }

    #[test]
    fn partial_arrays_are_refused_and_points_are_read_as_displayed() {
        let mut m = CellMesh::from_points(vec![Point3::new(0.5, 0.0, 0.25)]);
        let p = "n.vtu";
        let (c, s) = cylinder_coordinates(&m, p, CoordinatesArg::Auto, Chamber::Lv, 0.5).unwrap();
        assert_eq!(s, Source::Points);
        assert!((c[0].xi - 0.25).abs() < 1e-15 && c[0].zeta == 0.0 && c[0].depth == 0.25);
        m.point_data.insert(Field::scalars("xi", vec![0.1]));
        let e = cylinder_coordinates(&m, p, CoordinatesArg::Auto, Chamber::Lv, 0.5).unwrap_err();
        assert!(e.to_string().contains("not all of xi, zeta, depth"), "{e}");
        let e = cylinder_coordinates(&m, p, CoordinatesArg::Arrays, Chamber::Lv, 0.5).unwrap_err();
        assert!(e.to_string().contains("no point array zeta, depth"), "{e}");
        let (c, s) = cylinder_coordinates(&m, p, CoordinatesArg::Points, Chamber::Rv, 0.5).unwrap();
        assert_eq!(s, Source::Points);
        assert_eq!((c[0].xi, c[0].depth), (0.5, 0.25));
    }
}
