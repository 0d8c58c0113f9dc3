//! The whole ventricle pipeline on in-memory inputs (ALGORITHMS 3): a chart
//! of S, every anatomy point mapped to the cylinder and back (round-trip
//! error), AHA-17 labels and depth on the anatomy, the flattened S.

use super::aha::aha_segment;
use super::disk::display_warp;
use super::error::VentricleError;
use super::harmonic_disk::HarmonicDisk;
use super::map::{Chamber, Chart, ChartConfig, ChartTimings, CylinderPoint};
use super::openings::Openings;
use crate::gate::Gates;
use crate::{OrganError, Requirement};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::time::Instant;
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::repair::RepairReport;
use unfold_mesh::stats::Summary;
use unfold_mesh::{CellMesh, Field, TriMesh};
use unfold_param::Initializer;

/// Default display exponent `n` of `r' = r^n` (ALGORITHMS 3.2).
pub const DEFAULT_DISPLAY_EXPONENT: f64 = 1.0 / 3.0;

/// Settings of [`run`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// The chart of S (chamber, grid, hemisphere, tolerances).
    pub chart: ChartConfig,
    /// Display exponent of the LV disk; the AHA labels follow the displayed
    /// disk, so that labels and bull's-eye agree (1 labels the harmonic
    /// disk).
    pub display_exponent: f64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            chart: ChartConfig::default(),
            display_exponent: DEFAULT_DISPLAY_EXPONENT,
        }
    }
}

/// The landmarks as given (points, snapped by the pipeline).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkPoints {
    /// Anterior RV insertion point (LV) or first septal corner (RV).
    pub anterior: Point3<f64>,
    /// Inferior RV insertion point (LV) or second septal corner (RV).
    pub inferior: Point3<f64>,
    /// The apex, or `None` to take the vertex of S farthest from the rim
    /// centroid.
    pub apex: Option<Point3<f64>>,
    /// A point on or near the basal rim, naming it among several openings
    /// of S; `None`: the opening nearest the two rim landmarks (see
    /// [`super::openings`]).
    pub rim_near: Option<Point3<f64>>,
}

/// Mean, median, standard deviation and maximum of a set of values (the
/// round-trip errors of [`Report::roundtrip_error_um`], the sensitivity
/// study's shifts): four numbers of [`unfold_mesh::stats::Summary`], the one
/// summary of every report (`median` its `p50`; `std` its **sample**
/// standard deviation, `sqrt(sum (v - mean)^2 / (n - 1))`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorSummary {
    /// Mean.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub mean: f64,
    /// Median.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub median: f64,
    /// Standard deviation (sample, `n - 1`).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub std: f64,
    /// Maximum.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub max: f64,
}

impl ErrorSummary {
    /// The summary of `values`: all zero when there is none, all NaN when
    /// one is NaN.
    pub fn of(values: &[f64]) -> ErrorSummary {
        match Summary::of(values) {
            Some(s) => ErrorSummary {
                mean: s.mean,
                median: s.p50,
                std: s.std,
                max: s.max,
            },
            None if values.is_empty() => ErrorSummary::default(),
            None => ErrorSummary {
                mean: f64::NAN,
                median: f64::NAN,
                std: f64::NAN,
                max: f64::NAN,
            },
        }
    }
}

/// Seconds per step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Seconds {
    /// Repair, landmarks, disk map.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub disk: f64,
    /// The Laplace field (computed at the same time as the disk map: the
    /// two overlap).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub laplace: f64,
    /// The forward map of the anatomy.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub streamlines: f64,
    /// The inverse map (round trip).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub inverse: f64,
}

/// The Laplace field's figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldReport {
    /// Grid nodes in the bounding box.
    pub grid_nodes: usize,
    /// Unknowns.
    pub unknowns: usize,
    /// Multigrid levels.
    pub multigrid_levels: usize,
    /// Conjugate-gradient iterations.
    pub cg_iterations: usize,
    /// Relative residual reached.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub relative_residual: f64,
    /// The field's memory predicted before it was allocated, bytes.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub estimated_bytes: f64,
}

/// `report.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Report {
    /// `lv` or `rv`.
    pub chamber: Chamber,
    /// Anatomy points mapped.
    pub anatomy_points: usize,
    /// Round-trip error `|v - psi^-1(psi(v))|`, micrometres.
    pub roundtrip_error_um: ErrorSummary,
    /// Disk triangles with the wrong orientation (0: `phi` is injective).
    pub flipped_disk_triangles: usize,
    /// Interior edges of S folded in the disk map (the two triangles of an
    /// edge on the same side of it, [`unfold_mesh::geometry::folded_edges`]).
    pub folded_disk_edges: usize,
    /// Boundary edges of S that cross another boundary edge in the disk map
    /// (the outline overlapping itself,
    /// [`unfold_mesh::geometry::boundary_edge_crossings`]; 0 for an
    /// injective map).
    pub overlapping_disk_boundary_edges: usize,
    /// Grid spacing of the Laplace field, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub grid_mm: f64,
    /// Radius of H, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub hemisphere_mm: f64,
    /// The display exponent.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub display_exponent: f64,
    /// The disk initializer (`harmonic-disk`, or a method developer's).
    pub disk_map: Cow<'static, str>,
    /// The disk embedding's weights (`cotangent` or `mean-value`).
    pub disk_weights: Cow<'static, str>,
    /// The apex warp (`thin-plate spline` or `mobius`).
    pub apex_warp: Cow<'static, str>,
    /// Whether folds left by the apex warp were untangled with every pin
    /// fixed (`yes`, `no`: nothing folded, `failed`; ALGORITHMS 1.7).
    #[serde(default = "untangled_no")]
    pub disk_untangled: Cow<'static, str>,
    /// What the repair of S changed.
    pub surface_repair: RepairReport,
    /// Distances from the given landmarks to the vertices they snapped to,
    /// mm (anterior, inferior, apex; 0 for a computed apex).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub landmark_snap_mm: [f64; 3],
    /// The apex used, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub apex_mm: [f64; 3],
    /// S's boundary loops (openings): each one's size, which is the basal
    /// rim and why, and the caps closing the others.
    pub openings: Openings,
    /// Anatomy points per AHA segment 1..17 (LV only).
    pub aha_points: Option<[usize; 17]>,
    /// The quality gates: `base.rim_agrees` (see [`super::openings`]) and,
    /// for the LV, `aha.balance` (see [`aha_balance`]).
    pub gates: Gates,
    /// The Laplace field.
    pub field: FieldReport,
    /// Seconds per step.
    pub seconds: Seconds,
}

/// What [`run`] returns.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The chart of S (reusable for transfers).
    pub chart: Chart,
    /// `psi` of every anatomy point.
    pub coords: Vec<CylinderPoint>,
    /// The round trip `psi^-1(psi(v))` of every anatomy point.
    pub roundtrip: Vec<Point3<f64>>,
    /// AHA segment (1..17) of every anatomy point (LV; empty for the RV).
    pub aha: Vec<u8>,
    /// The anatomy in cylinder coordinates: points `(X, Y, d)` with
    /// `(X, Y)` the displayed disk position; arrays `xi`, `zeta` (the
    /// disk position `phi(v_S)`), `depth`, `aha` (LV).
    pub normalized: CellMesh,
    /// The input anatomy with arrays `aha` (LV), `depth`, `xi`, `zeta`.
    pub anatomy: CellMesh,
    /// S flattened: points `(X, Y, 0)` (displayed disk), arrays `xi`, `zeta`.
    pub disk: TriMesh,
    /// The report.
    pub report: Report,
}

/// Smallest [`aha_balance`] of a right LV map. Measured (1.5 mm grid):
/// 0.97 on the two-opening LV of `tests/ventricle_two_openings.rs` with its
/// mitral ring as the base, against 0.081 with its aortic ring as the base
/// (the mitral opening capped: the mid ring's areas spread from 198 to
/// 2451 mm^2). The segments of one ring have equal angles, so a
/// right map gives them areas of one order whatever the chamber's length
/// (a hemisphere's rings differ tenfold from each other, which is why the
/// rings are not compared); a quarter leaves a factor of three on the wrong
/// side and of four on the right. A value below is recorded in the
/// report's gates with its fallback (the map kept), not refused: a
/// hemispherical S built from the anatomy measures 0.11 and is right.
pub const AHA_BALANCE_MIN: f64 = 0.25;

/// The AHA balance of an LV map: the area of S (its own triangles, caps
/// included, not the strip closing it to its base) in each of the segments
/// 1..16, a triangle counted in the segment of its centroid's displayed disk
/// position (`shown`, per vertex of `surface`); in each of the basal (1..6)
/// and mid (7..12) rings the smallest segment's area over the largest's;
/// the smaller of the two (NaN when a ring has no area). The apical ring
/// is left out: on a round S it is a few triangles wide, too coarse for
/// areas by centroid (0.11 on the hemisphere of `tests/ventricle_surface.rs`).
pub fn aha_balance(surface: &TriMesh, original_vertices: usize, shown: &[[f64; 2]]) -> f64 {
    let mut area = [0.0f64; 16];
    for t in &surface.triangles {
        if t.iter().any(|&v| v as usize >= original_vertices) {
            continue;
        }
        let [a, b, c] = t.map(|v| surface.positions[v as usize]);
        let p = t.map(|v| shown[v as usize]);
        let centre = [
            (p[0][0] + p[1][0] + p[2][0]) / 3.0,
            (p[0][1] + p[1][1] + p[2][1]) / 3.0,
        ];
        let s = aha_segment(centre) as usize;
        if (1..=16).contains(&s) {
            area[s - 1] += 0.5 * (b - a).cross(&(c - a)).norm();
        }
    }
    [&area[0..6], &area[6..12]]
        .iter()
        .map(|ring| {
            let lo = ring.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ring.iter().copied().fold(0.0, f64::max);
            if hi > 0.0 { lo / hi } else { f64::NAN }
        })
        .fold(f64::INFINITY, |m, x| {
            if x.is_nan() || m.is_nan() {
                f64::NAN
            } else {
                m.min(x)
            }
        })
}

/// Displayed disk positions: the LV disk warped by `r' = r^n`; the RV half
/// disk as it is.
pub fn displayed(
    chamber: Chamber,
    uv: &[[f64; 2]],
    exponent: f64,
) -> Result<Vec<[f64; 2]>, OrganError> {
    match chamber {
        Chamber::Lv => display_warp(uv, exponent),
        Chamber::Rv => Ok(uv.to_vec()),
    }
}

/// The ventricle pipeline: its disk map and settings. [`Pipeline::new`] is
/// the published method (ALGORITHMS 3): the harmonic disk map with the apex
/// warp ([`HarmonicDisk`]); [`Pipeline::disk`] plugs in another disk
/// [`Initializer`] (see [`super::harmonic_disk`] for what it is handed).
///
/// ```text
/// Pipeline::new()
///     .disk(MyDiskMap)
///     .config(Config { display_exponent: 1.0, ..Config::default() })
///     .run(&anatomy, &surface, &landmarks)?
/// ```
#[derive(Debug)]
pub struct Pipeline {
    disk: Box<dyn Initializer>,
    config: Config,
}

impl Default for Pipeline {
    fn default() -> Self {
        Pipeline {
            disk: Box::new(HarmonicDisk),
            config: Config::default(),
        }
    }
}

impl Pipeline {
    /// The published pipeline.
    pub fn new() -> Self {
        Self::default()
    }

    /// The disk map of S.
    pub fn disk(mut self, disk: impl Initializer + 'static) -> Self {
        self.disk = Box::new(disk);
        self
    }

    /// The settings.
    pub fn config(mut self, config: Config) -> Self {
        self.config = config;
        self
    }

    /// The settings in use.
    pub fn settings(&self) -> &Config {
        &self.config
    }

    /// The chart of one heart with this pipeline's disk map and settings
    /// ([`Chart::build`]), for transfers.
    ///
    /// # Errors
    /// As [`Chart::build`].
    pub fn chart(
        &self,
        surface: &TriMesh,
        landmarks: &LandmarkPoints,
    ) -> Result<Chart, OrganError> {
        Chart::from_landmarks(surface, landmarks, &self.config.chart, self.disk.as_ref())
    }

    /// Runs the pipeline: the chart of `surface`, `psi` of every point of
    /// `anatomy` (its connectivity kept), the round trip, AHA labels and
    /// depth.
    ///
    /// # Errors
    /// `Ventricle` for a surface that is not a disk, landmarks off the rim,
    /// anatomy points outside S or inside H (how many, and the first);
    /// `Config` for bad settings; the disk initializer's own errors.
    pub fn run(
        &self,
        anatomy: &CellMesh,
        surface: &TriMesh,
        landmarks: &LandmarkPoints,
    ) -> Result<Outcome, OrganError> {
        let chart = self.chart(surface, landmarks)?;
        outcome(anatomy, chart, &self.config, self.disk.name())
    }
}

/// The pipeline's outputs for `anatomy` through `chart`.
fn outcome(
    anatomy: &CellMesh,
    chart: Chart,
    config: &Config,
    disk_map: &'static str,
) -> Result<Outcome, OrganError> {
    OrganError::check_positive(&[("display exponent", config.display_exponent)])?;
    if anatomy.positions.is_empty() {
        return Err(VentricleError::NoAnatomyPoints.into());
    }
    let t0 = Instant::now();
    let forward = chart.forward_all(&anatomy.positions)?;
    let coords: Vec<CylinderPoint> = forward.iter().map(|f| f.coords).collect();
    let t1 = Instant::now();
    let roundtrip = chart.inverse_all(&coords)?;
    let t2 = Instant::now();
    let errors_um: Vec<f64> = anatomy
        .positions
        .iter()
        .zip(&roundtrip)
        .map(|(a, b)| (a - b).norm() * 1e3)
        .collect();
    let chamber = config.chart.chamber;
    let uv: Vec<[f64; 2]> = coords.iter().map(|c| [c.xi, c.zeta]).collect();
    let shown = displayed(chamber, &uv, config.display_exponent)?;
    let aha: Vec<u8> = match chamber {
        Chamber::Lv => shown.iter().map(|&p| aha_segment(p)).collect(),
        Chamber::Rv => Vec::new(),
    };
    let depth: Vec<f64> = coords.iter().map(|c| c.depth).collect();
    let xi: Vec<f64> = coords.iter().map(|c| c.xi).collect();
    let zeta: Vec<f64> = coords.iter().map(|c| c.zeta).collect();
    let add_arrays = |mesh: &mut CellMesh| {
        mesh.point_data.insert(Field::scalars("xi", xi.clone()));
        mesh.point_data.insert(Field::scalars("zeta", zeta.clone()));
        mesh.point_data
            .insert(Field::scalars("depth", depth.clone()));
        if !aha.is_empty() {
            mesh.point_data.insert(Field::labels(
                "aha",
                aha.iter().map(|&a| a as i32).collect(),
            ));
        }
    };
    let mut normalized = anatomy.clone();
    normalized.point_data = Default::default();
    normalized.cell_data = Default::default();
    normalized.positions = shown
        .iter()
        .zip(&depth)
        .map(|(p, &d)| Point3::new(p[0], p[1], d))
        .collect();
    add_arrays(&mut normalized);
    // Each point's round trip `|psi^-1(psi(v)) - v|` (um), the figure the
    // report summarizes (the source paper's Fig. 13 per point).
    normalized
        .point_data
        .insert(Field::scalars("roundtrip_error_um", errors_um.clone()));
    let mut anatomy_out = anatomy.clone();
    add_arrays(&mut anatomy_out);
    let disk_uv = &chart.disk().uv;
    let disk_shown = displayed(chamber, disk_uv, config.display_exponent)?;
    let mut disk = TriMesh::new(
        disk_shown
            .iter()
            .map(|p| Point3::new(p[0], p[1], 0.0))
            .collect(),
        chart.surface().triangles.clone(),
    );
    disk.add_point_field(Field::scalars("xi", disk_uv.iter().map(|p| p[0]).collect()))?;
    disk.add_point_field(Field::scalars(
        "zeta",
        disk_uv.iter().map(|p| p[1]).collect(),
    ))?;
    let aha_points = (chamber == Chamber::Lv).then(|| {
        let mut c = [0usize; 17];
        for &a in &aha {
            if (1..=17).contains(&a) {
                c[a as usize - 1] += 1;
            }
        }
        c
    });
    let mut gates = chart.gates().clone();
    if chamber == Chamber::Lv {
        let balance = aha_balance(chart.surface(), chart.original_vertices(), &disk_shown);
        // Recorded, not refused: a round S built from the anatomy (the
        // hemisphere of tests/ventricle_surface.rs) measures 0.11 and is
        // right; the wrong base this catches is refused earlier, by the
        // choice of the rim (super::openings), unless --rim-near forces it.
        gates.fallback(
            "aha.balance",
            balance,
            Requirement::AtLeast(AHA_BALANCE_MIN),
            "kept the map: some AHA segments of S are nearly empty, the mark of a wrong basal \
             rim or misplaced landmarks; check openings and landmarks in this report, or name \
             the basal (mitral) opening with --rim-near X,Y,Z",
        );
    }
    let stats = chart.field().stats();
    let ChartTimings {
        disk: t_disk,
        laplace,
    } = chart.timings();
    let apex = chart.surface().positions[chart.landmarks().apex as usize];
    let report = Report {
        chamber,
        anatomy_points: anatomy.positions.len(),
        roundtrip_error_um: ErrorSummary::of(&errors_um),
        flipped_disk_triangles: chart.disk().flipped_triangles,
        folded_disk_edges: unfold_mesh::geometry::folded_edges(
            &chart.disk().uv,
            &chart.surface().triangles,
        )
        .len(),
        overlapping_disk_boundary_edges: unfold_mesh::geometry::boundary_edge_crossings(
            &chart.disk().uv,
            &chart.surface().triangles,
        )
        .edges_involved,
        grid_mm: chart.field().grid_mm(),
        hemisphere_mm: chart.field().hemisphere_radius(),
        display_exponent: config.display_exponent,
        disk_map: disk_map.into(),
        disk_weights: chart.disk().weights.into(),
        apex_warp: chart.disk().apex_warp.into(),
        disk_untangled: chart.disk().untangled.into(),
        surface_repair: *chart.repair(),
        landmark_snap_mm: chart.landmarks().snap_distances_mm,
        apex_mm: [apex.x, apex.y, apex.z],
        openings: chart.openings().clone(),
        aha_points,
        gates,
        field: FieldReport {
            grid_nodes: stats.grid_nodes,
            unknowns: stats.unknowns,
            multigrid_levels: stats.levels,
            cg_iterations: stats.iterations,
            relative_residual: stats.relative_residual,
            estimated_bytes: stats.estimated_bytes,
        },
        seconds: Seconds {
            disk: t_disk,
            laplace,
            streamlines: (t1 - t0).as_secs_f64(),
            inverse: (t2 - t1).as_secs_f64(),
        },
    };
    Ok(Outcome {
        chart,
        coords,
        roundtrip,
        aha,
        normalized,
        anatomy: anatomy_out,
        disk,
        report,
    })
}

/// `"no"`: the default of `disk_untangled` in reports written before it
/// existed.
fn untangled_no() -> Cow<'static, str> {
    "no".into()
}
