//! Landmark sensitivity (`--sensitivity MM`): how much the map moves when
//! the landmarks are placed MM off (the source paper's §5.4, Fig. 14-17).
//!
//! The paper displaces the landmarks by 1, 3 and 5 mm in three schemes;
//! here each run of `--sensitivity MM` builds one chart per perturbation,
//! ten in all, in this fixed order:
//!
//! 1. one rim landmark at a time, MM along S's basal rim (arc length) in
//!    either direction: `anterior +`, `anterior -`, `inferior +`,
//!    `inferior -` (`+`: the direction of the rim loop's boundary
//!    half-edges);
//! 2. both rim landmarks at once, MM each along the rim, `towards` each
//!    other and `away` from each other (along the shorter arc between them);
//! 3. the apex, MM along the tangent plane of S at the apex vertex (its
//!    normal the area-weighted mean of its triangles' normals) in four
//!    orthogonal directions: `apex +t1`, `apex -t1`, `apex +t2`,
//!    `apex -t2`, `t1` towards the anterior landmark, `t2 = n x t1`.
//!
//! The moved points snap to S's vertices as any landmark does, so the
//! displacement is whole rim edges (or the vertex nearest the moved apex);
//! the report gives the distance each landmark actually moved.
//!
//! Per anatomy point `v`, with `psi` the map of the unperturbed chart and
//! `psi_k` that of perturbation `k`:
//!
//! ```text
//! sensitivity_mm    = max_k |psi_k^-1(psi(v)) - v|            (mm; the paper's
//!                                                             reconstruction error)
//! sensitivity_disk  = max_k |D(psi_k(v)) - D(psi(v))|         (displayed disk, radius 1)
//! sensitivity_depth = max_k |d_k(v) - d(v)|
//! ```
//!
//! (`D` the displayed disk position, `d` the depth); NaN for a point that
//! some perturbation cannot map.

use crate::app::error::{AppError, at, organ, positive};
use crate::app::observer::Observer;
use crate::figures::ventricle::sensitivity_figure;
use crate::figures::{Figure, FigureOptions};
use crate::mesh::nalgebra::{Point3, Vector3};
use crate::mesh::{CellMesh, Field, TriMesh};
use crate::organs::ventricle::pipeline::{ErrorSummary, displayed};
use crate::organs::ventricle::{Chart, Config, CylinderPoint, LandmarkPoints, Outcome, Pipeline};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// One perturbation of the landmarks.
#[derive(Debug, Clone, PartialEq)]
pub struct Perturbation {
    /// Its name (`anterior +`, `both towards`, `apex +t1`, ...).
    pub name: &'static str,
    /// The landmarks given to its chart.
    pub landmarks: LandmarkPoints,
}

/// The point at arc length `mm` from rim position `k` along the closed
/// polyline `rim` (positions), forward (`dir = 1`) or backward (`-1`).
fn along_rim(rim: &[Point3<f64>], k: usize, dir: isize, mm: f64) -> Point3<f64> {
    let m = rim.len() as isize;
    let mut left = mm;
    let mut at = k as isize;
    // at most one lap: a longer walk wraps around
    for _ in 0..rim.len() {
        let next = (at + dir).rem_euclid(m);
        let (a, b) = (rim[at as usize], rim[next as usize]);
        let len = (b - a).norm();
        if len >= left {
            return if len > 0.0 {
                a + (b - a) * (left / len)
            } else {
                a
            };
        }
        left -= len;
        at = next;
    }
    rim[at as usize]
}

/// Arc length from rim position `a` forward to `b`.
fn forward_arc(rim: &[Point3<f64>], a: usize, b: usize) -> f64 {
    let m = rim.len();
    let mut s = 0.0;
    let mut k = a;
    while k != b {
        let n = (k + 1) % m;
        s += (rim[n] - rim[k]).norm();
        k = n;
    }
    s
}

/// Area-weighted mean normal of `surface` at vertex `v`.
fn vertex_normal(surface: &TriMesh, v: u32) -> Vector3<f64> {
    let p = &surface.positions;
    let mut n = Vector3::zeros();
    for t in surface.triangles.iter().filter(|t| t.contains(&v)) {
        let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
        n += (b - a).cross(&(c - a));
    }
    n.try_normalize(0.0).unwrap_or_else(Vector3::z)
}

/// The ten perturbations of `given` by `mm` on `chart`'s S (module doc).
pub fn perturbations(chart: &Chart, given: &LandmarkPoints, mm: f64) -> Vec<Perturbation> {
    let s = chart.surface();
    let rim: Vec<Point3<f64>> = chart
        .rim_of_s()
        .iter()
        .map(|&v| s.positions[v as usize])
        .collect();
    let l = chart.landmarks();
    let (a, i) = (l.anterior, l.inferior);
    let apex = s.positions[l.apex as usize];
    let perimeter = forward_arc(&rim, 0, rim.len() - 1) + (rim[0] - rim[rim.len() - 1]).norm();
    // towards each other along the shorter arc: a forward when a -> i
    // forward is the shorter way round
    let a_dir: isize = if forward_arc(&rim, a, i) <= 0.5 * perimeter {
        1
    } else {
        -1
    };
    let moved = |anterior: Option<Point3<f64>>,
                 inferior: Option<Point3<f64>>,
                 apex_at: Option<Point3<f64>>| LandmarkPoints {
        anterior: anterior.unwrap_or(given.anterior),
        inferior: inferior.unwrap_or(given.inferior),
        apex: apex_at.or(given.apex),
        rim_near: given.rim_near,
    };
    let n = vertex_normal(s, l.apex);
    let toward = rim[a] - apex;
    let t1 = (toward - n * n.dot(&toward))
        .try_normalize(1e-12)
        .unwrap_or_else(|| n.cross(&Vector3::x()).normalize());
    let t2 = n.cross(&t1);
    vec![
        Perturbation {
            name: "anterior +",
            landmarks: moved(Some(along_rim(&rim, a, 1, mm)), None, None),
        },
        Perturbation {
            name: "anterior -",
            landmarks: moved(Some(along_rim(&rim, a, -1, mm)), None, None),
        },
        Perturbation {
            name: "inferior +",
            landmarks: moved(None, Some(along_rim(&rim, i, 1, mm)), None),
        },
        Perturbation {
            name: "inferior -",
            landmarks: moved(None, Some(along_rim(&rim, i, -1, mm)), None),
        },
        Perturbation {
            name: "both towards",
            landmarks: moved(
                Some(along_rim(&rim, a, a_dir, mm)),
                Some(along_rim(&rim, i, -a_dir, mm)),
                None,
            ),
        },
        Perturbation {
            name: "both away",
            landmarks: moved(
                Some(along_rim(&rim, a, -a_dir, mm)),
                Some(along_rim(&rim, i, a_dir, mm)),
                None,
            ),
        },
        Perturbation {
            name: "apex +t1",
            landmarks: moved(None, None, Some(apex + t1 * mm)),
        },
        Perturbation {
            name: "apex -t1",
            landmarks: moved(None, None, Some(apex - t1 * mm)),
        },
        Perturbation {
            name: "apex +t2",
            landmarks: moved(None, None, Some(apex + t2 * mm)),
        },
        Perturbation {
            name: "apex -t2",
            landmarks: moved(None, None, Some(apex - t2 * mm)),
        },
    ]
}

/// The snapped landmarks of a chart: anterior, inferior (on S's own rim)
/// and apex.
fn snapped(chart: &Chart) -> [Point3<f64>; 3] {
    let s = &chart.surface().positions;
    let l = chart.landmarks();
    let rim = chart.rim_of_s();
    [
        s[rim[l.anterior] as usize],
        s[rim[l.inferior] as usize],
        s[l.apex as usize],
    ]
}

/// One perturbation in `report.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerturbationReport {
    /// Its name (module doc).
    pub name: String,
    /// How far the snapped anterior, inferior and apex landmarks moved, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub moved_mm: [f64; 3],
    /// `|psi_k^-1(psi(v)) - v|` over the anatomy points, mm.
    pub error_mm: ErrorSummary,
    /// `|D(psi_k(v)) - D(psi(v))|`, displayed disk units.
    pub disk_shift: ErrorSummary,
    /// `|d_k(v) - d(v)|`.
    pub depth_shift: ErrorSummary,
    /// Anatomy points this perturbation cannot map (left out above).
    pub points_not_mapped: usize,
    /// Why its chart could not be built (then no figures above).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// `sensitivity` in `report.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensitivityReport {
    /// The displacement asked for, mm.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub displacement_mm: f64,
    /// Each perturbation.
    pub perturbations: Vec<PerturbationReport>,
    /// Per anatomy point the largest reconstruction error over the
    /// perturbations (`sensitivity_mm`), mm.
    pub error_mm: ErrorSummary,
    /// Per point the largest disk shift (`sensitivity_disk`).
    pub disk_shift: ErrorSummary,
    /// Per point the largest depth shift (`sensitivity_depth`).
    pub depth_shift: ErrorSummary,
    /// Points some perturbation cannot map (NaN in the arrays).
    pub points_not_mapped: usize,
    /// Seconds for the perturbed charts and maps.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub seconds: f64,
}

/// The per-point arrays and the report.
#[derive(Debug, Clone)]
pub struct Sensitivity {
    /// `sensitivity_mm` per anatomy point.
    pub error_mm: Vec<f64>,
    /// `sensitivity_disk` per anatomy point.
    pub disk_shift: Vec<f64>,
    /// `sensitivity_depth` per anatomy point.
    pub depth_shift: Vec<f64>,
    /// The summary.
    pub report: SensitivityReport,
}

impl Sensitivity {
    /// Adds the point arrays `sensitivity_mm`, `sensitivity_disk` and
    /// `sensitivity_depth` to `mesh` (the anatomy or its normalized copy).
    pub fn add_arrays(&self, mesh: &mut CellMesh) {
        let data = &mut mesh.point_data;
        data.insert(Field::scalars("sensitivity_mm", self.error_mm.clone()));
        data.insert(Field::scalars("sensitivity_disk", self.disk_shift.clone()));
        data.insert(Field::scalars(
            "sensitivity_depth",
            self.depth_shift.clone(),
        ));
    }

    /// `figures/sensitivity.png`: `sensitivity_mm` at each anatomy point's
    /// position in `outcome`'s displayed disk (the points of
    /// `normalized.vtu`).
    ///
    /// # Errors
    /// The figure's, as a usage error naming `dir`.
    pub fn figure(&self, outcome: &Outcome, dir: &Path) -> Result<Figure, AppError> {
        let shown: Vec<[f64; 2]> = outcome
            .normalized
            .positions
            .iter()
            .map(|p| [p.x, p.y])
            .collect();
        sensitivity_figure(
            outcome.report.chamber,
            &shown,
            &self.error_mm,
            self.report.displacement_mm,
            &FigureOptions::default(),
        )
        .map_err(|e| at(dir, e))
    }
}

/// The summary of the finite values.
fn finite_summary(v: &[f64]) -> ErrorSummary {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    ErrorSummary::of(&f)
}

/// Runs the ten perturbations of `given` by `mm` (module doc) for the
/// anatomy `anatomy` of `outcome` in `surface`, with `config`; warns
/// `observer` when perturbations moved no landmark.
///
/// # Errors
/// A usage error for `mm` not finite and > 0; an organ error (named
/// `label`) when no perturbed chart can be built.
#[allow(clippy::too_many_arguments)]
pub fn sensitivity(
    outcome: &Outcome,
    anatomy: &CellMesh,
    surface: &TriMesh,
    given: &LandmarkPoints,
    config: Config,
    mm: f64,
    label: &str,
    observer: &mut dyn Observer,
) -> Result<Sensitivity, AppError> {
    let mm = positive("--sensitivity", mm)?;
    let t0 = Instant::now();
    let chamber = config.chart.chamber;
    let shown = |c: &[CylinderPoint]| -> Result<Vec<[f64; 2]>, AppError> {
        let uv: Vec<[f64; 2]> = c.iter().map(|c| [c.xi, c.zeta]).collect();
        displayed(chamber, &uv, config.display_exponent).map_err(|e| organ(label, e))
    };
    let base = shown(&outcome.coords)?;
    let base_landmarks = snapped(&outcome.chart);
    let n = anatomy.positions.len();
    let mut error_mm = vec![0.0f64; n];
    let mut disk_shift = vec![0.0f64; n];
    let mut depth_shift = vec![0.0f64; n];
    let mut failed = vec![false; n];
    let mut reports = Vec::new();
    let mut first_error = None;
    for p in perturbations(&outcome.chart, given, mm) {
        let mut c = config;
        c.chart.field.max_memory_bytes = crate::app::run::memory::room();
        let chart = match Pipeline::new().config(c).chart(surface, &p.landmarks) {
            Ok(chart) => chart,
            Err(e) => {
                let msg = e.to_string();
                first_error.get_or_insert((p.name, e));
                reports.push(PerturbationReport {
                    name: p.name.to_string(),
                    moved_mm: [f64::NAN; 3],
                    error_mm: ErrorSummary::default(),
                    disk_shift: ErrorSummary::default(),
                    depth_shift: ErrorSummary::default(),
                    points_not_mapped: n,
                    error: Some(msg),
                });
                continue;
            }
        };
        let moved = snapped(&chart);
        let moved_mm = std::array::from_fn(|k| (moved[k] - base_landmarks[k]).norm());
        let back: Vec<Option<Point3<f64>>> = outcome
            .coords
            .par_iter()
            .map(|c| chart.inverse(c).ok())
            .collect();
        let forward: Vec<Option<CylinderPoint>> = anatomy
            .positions
            .par_iter()
            .map(|v| chart.forward(v).ok().map(|f| f.coords))
            .collect();
        let mapped: Vec<CylinderPoint> = forward
            .iter()
            .map(|c| {
                c.unwrap_or(CylinderPoint {
                    xi: 0.0,
                    zeta: 0.0,
                    depth: 0.0,
                })
            })
            .collect();
        let shown_k = shown(&mapped)?;
        let (mut e_k, mut s_k, mut d_k) = (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]);
        let mut not_mapped = 0;
        for j in 0..n {
            match (back[j], forward[j]) {
                (Some(b), Some(f)) => {
                    e_k[j] = (b - anatomy.positions[j]).norm();
                    s_k[j] = (shown_k[j][0] - base[j][0]).hypot(shown_k[j][1] - base[j][1]);
                    d_k[j] = (f.depth - outcome.coords[j].depth).abs();
                    error_mm[j] = error_mm[j].max(e_k[j]);
                    disk_shift[j] = disk_shift[j].max(s_k[j]);
                    depth_shift[j] = depth_shift[j].max(d_k[j]);
                }
                _ => {
                    failed[j] = true;
                    not_mapped += 1;
                }
            }
        }
        reports.push(PerturbationReport {
            name: p.name.to_string(),
            moved_mm,
            error_mm: finite_summary(&e_k),
            disk_shift: finite_summary(&s_k),
            depth_shift: finite_summary(&d_k),
            points_not_mapped: not_mapped,
            error: None,
        });
    }
    if reports.iter().all(|r| r.error.is_some())
        && let Some((name, e)) = first_error
    {
        return Err(organ(&format!("{label} (--sensitivity {mm}, {name})"), e));
    }
    // Landmarks snap to S's vertices: a displacement shorter than half an
    // edge moves nothing, which the numbers alone would not say.
    let unmoved = reports
        .iter()
        .filter(|r| r.error.is_none() && r.moved_mm.iter().all(|&m| m == 0.0))
        .count();
    if unmoved > 0 {
        observer.warning(&format!(
            "{label}: --sensitivity {mm}: {unmoved} of {} perturbations left every \
             landmark on its vertex (the landmarks snap to S's vertices; a displacement under \
             half an edge of S moves nothing); see report.json's sensitivity.perturbations",
            reports.len()
        ));
    }
    for j in 0..n {
        if failed[j] {
            error_mm[j] = f64::NAN;
            disk_shift[j] = f64::NAN;
            depth_shift[j] = f64::NAN;
        }
    }
    let report = SensitivityReport {
        displacement_mm: mm,
        perturbations: reports,
        error_mm: finite_summary(&error_mm),
        disk_shift: finite_summary(&disk_shift),
        depth_shift: finite_summary(&depth_shift),
        points_not_mapped: failed.iter().filter(|&&f| f).count(),
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok(Sensitivity {
        error_mm,
        disk_shift,
        depth_shift,
        report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn circle(m: usize, r: f64) -> Vec<Point3<f64>> {
        (0..m)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / m as f64;
                Point3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect()
    }

    proptest! {
        /// Walking `s` along a polygon and back returns to the start, and
        /// the point walked to lies `s` of arc length away (the chord of
        /// each edge, the rim being the polygon).
        #[test]
        fn walking_along_the_rim_covers_the_arc_length(
            m in 8usize..64,
            k in 0usize..8,
            s in 0.0..10.0f64,
        ) {
            let rim = circle(m, 20.0);
            let edge = (rim[1] - rim[0]).norm();
            let p = along_rim(&rim, k, 1, s);
            let q = along_rim(&rim, k, -1, s);
            // the walk's arc length: whole edges plus the part of the last
            let whole = (s / edge).floor();
            let end = (k + whole as usize) % m;
            let frac = s - whole * edge;
            prop_assert!(((p - rim[end]).norm() - frac).abs() < 1e-9);
            let end_back = (k + m - (whole as usize % m)) % m;
            prop_assert!(((q - rim[end_back]).norm() - frac).abs() < 1e-9);
            prop_assert!((forward_arc(&rim, 0, m - 1) + edge - m as f64 * edge).abs() < 1e-9);
        }
    }
}
