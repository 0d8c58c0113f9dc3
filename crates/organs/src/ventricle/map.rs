//! The map `psi: M -> cylinder` and its inverse (ALGORITHMS 3.3, 3.4) for
//! one heart: a [`Chart`] holds S, its landmarks, its disk map `phi`, the
//! Laplace field and the streamline tracer.
//!
//! `psi(v) = (phi(v_S), d(v))` with `v_S` where the streamline through `v`
//! meets S (traced against `grad f`) and `d(v) = len(v_S -> v) /
//! len(v_S -> v_H)`. The inverse locates `(xi, zeta)` in the flattened S
//! (barycentric coordinates of a disk triangle give `v_S` on S), traces
//! from `v_S` to H (length `L`) and returns the point at arc length `d L`.
//! Both directions follow the same interpolant of `grad f` with the same
//! error-controlled integrator, so `psi^-1(psi(v)) = v` up to the
//! integrator's tolerance. Transfer to another heart is `other.inverse(
//! self.forward(v))`.

use super::base::{ExtendedSurface, close_base};
use super::disk::{DiskMap, lv_disk, rv_half_disk};
use super::error::{PointFailure, VentricleError};
use super::field::{FieldConfig, LaplaceField};
use super::harmonic_disk::HarmonicDisk;
use super::landmarks::Landmarks;
use super::openings::{Capped, Openings, cap_openings};
use super::pipeline::LandmarkPoints;
use super::trace::{DEFAULT_TRACE_TOLERANCE_MM, SurfaceIndex, TraceTarget, Tracer};
use crate::OrganError;
use crate::gate::Gates;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::closest_point_on_segment_2d;
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::repair::{RepairOptions, RepairReport, Weld, repair_tri_mesh_with};
use unfold_mesh::spatial::{ClosestPointQuery, PlanarTriLocator};
use unfold_param::Initializer;

/// Which chamber S encloses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Chamber {
    /// Left ventricle: the unit disk.
    #[default]
    Lv,
    /// Right ventricle: the half disk `x >= 1.25` of the unit circle
    /// centred at `(1.25, 0)`.
    Rv,
}

unfold_param::named!(Chamber { Lv => "lv", Rv => "rv" });

/// Default distance, mm, within which an anatomy point counts as lying on S
/// (depth 0, mapped through its closest point of S).
pub const DEFAULT_ON_SURFACE_MM: f64 = 1e-4;

/// Settings of a [`Chart`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChartConfig {
    /// The chamber (disk or half disk).
    pub chamber: Chamber,
    /// The Laplace field's grid and hemisphere.
    pub field: FieldConfig,
    /// Local error tolerance of the streamline integrator, mm.
    pub trace_tolerance_mm: f64,
    /// Largest distance, mm, from a given rim landmark to the rim.
    pub snap_mm: f64,
    /// Anatomy points closer than this to S (mm) are on S.
    pub on_surface_mm: f64,
}

impl Default for ChartConfig {
    fn default() -> Self {
        ChartConfig {
            chamber: Chamber::Lv,
            field: FieldConfig::default(),
            trace_tolerance_mm: DEFAULT_TRACE_TOLERANCE_MM,
            snap_mm: super::landmarks::DEFAULT_SNAP_MM,
            on_surface_mm: DEFAULT_ON_SURFACE_MM,
        }
    }
}

/// A point of the cylinder: disk position `(xi, zeta)` and depth `d` in
/// `[0, 1]` (0 on S, 1 on H).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CylinderPoint {
    /// Disk x.
    pub xi: f64,
    /// Disk y.
    pub zeta: f64,
    /// Normalized arc length from S along the streamline.
    pub depth: f64,
}

/// The forward map of one point, with its streamline's pieces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardPoint {
    /// `psi(v)`.
    pub coords: CylinderPoint,
    /// Triangle of S where the streamline starts.
    pub triangle: usize,
    /// Barycentric coordinates of `v_S` in it.
    pub barycentric: [f64; 3],
    /// Arc length `v_S -> v`, mm.
    pub to_surface_mm: f64,
    /// Arc length `v -> v_H`, mm.
    pub to_hemisphere_mm: f64,
}

/// Seconds spent building a chart.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ChartTimings {
    /// Mesh repair, landmarks and the disk map.
    pub disk: f64,
    /// The Laplace field (computed while the disk map is: the two overlap
    /// in time, so their sum can exceed the chart's wall time).
    pub laplace: f64,
}

/// One heart prepared for mapping.
#[derive(Debug, Clone)]
pub struct Chart {
    surface: TriMesh,
    repair: RepairReport,
    landmarks: Landmarks,
    disk: DiskMap,
    field: LaplaceField,
    index: SurfaceIndex,
    locator: PlanarTriLocator,
    closest: ClosestPointQuery,
    /// Boundary edges of the disk: `(a, b, triangle)`.
    rim_edges: Vec<(u32, u32, usize)>,
    config: ChartConfig,
    max_length: f64,
    strip_height_mm: f64,
    original_vertices: usize,
    /// S's own basal rim (before the strip), vertices of `surface`.
    rim_of_s: Vec<u32>,
    openings: Openings,
    gates: Gates,
    timings: ChartTimings,
}

impl Chart {
    /// Repairs S ([`repair_tri_mesh_with`], coincident vertices welded),
    /// resolves the landmarks
    /// (given points snapped to the rim; the apex given or found), flattens
    /// S to the disk (LV) or half disk (RV) and solves the Laplace field.
    ///
    /// # Errors
    /// `Mesh` when S cannot be repaired; `Ventricle` when S is not a disk,
    /// a landmark is off the rim, the disk map folds
    /// ([`VentricleError::DiskFlips`]) or H does not fit; `Config` for bad
    /// settings.
    pub fn new(
        surface: &TriMesh,
        anterior: &Point3<f64>,
        inferior: &Point3<f64>,
        apex: Option<&Point3<f64>>,
        config: &ChartConfig,
    ) -> Result<Chart, OrganError> {
        Self::build(surface, anterior, inferior, apex, config, &HarmonicDisk)
    }

    /// [`Chart::new`] with the disk map `disk` in place of [`HarmonicDisk`]
    /// (see [`super::harmonic_disk`] for what a disk initializer is
    /// handed).
    ///
    /// # Errors
    /// As [`Chart::new`], and the initializer's own errors.
    pub fn build(
        surface: &TriMesh,
        anterior: &Point3<f64>,
        inferior: &Point3<f64>,
        apex: Option<&Point3<f64>>,
        config: &ChartConfig,
        disk: &dyn Initializer,
    ) -> Result<Chart, OrganError> {
        let landmarks = LandmarkPoints {
            anterior: *anterior,
            inferior: *inferior,
            apex: apex.copied(),
            rim_near: None,
        };
        Self::from_landmarks(surface, &landmarks, config, disk)
    }

    /// [`Chart::build`] with the landmarks as one value, `rim_near` included:
    /// S may have several boundary loops; the basal rim is the one nearest
    /// `rim_near` (when given) or the rim landmarks (which must agree with
    /// the anatomy, the largest opening facing away from the apex, when the
    /// apex is given), and every other loop is capped ([`cap_openings`])
    /// before the landmarks are snapped.
    ///
    /// # Errors
    /// As [`Chart::build`], and [`cap_openings`]'s errors
    /// ([`VentricleError::AmbiguousRim`], [`VentricleError::RimNearFar`],
    /// [`VentricleError::RimDisagrees`], [`VentricleError::OpeningsTie`],
    /// [`VentricleError::OpeningNotCappable`]).
    pub fn from_landmarks(
        surface: &TriMesh,
        points: &LandmarkPoints,
        config: &ChartConfig,
        disk: &dyn Initializer,
    ) -> Result<Chart, OrganError> {
        let (anterior, inferior, apex) = (&points.anterior, &points.inferior, points.apex.as_ref());
        OrganError::check_positive(&[
            ("trace tolerance (mm)", config.trace_tolerance_mm),
            ("on-surface distance (mm)", config.on_surface_mm),
        ])?;
        let t0 = Instant::now();
        let weld = RepairOptions {
            weld: Weld::Relative,
            ..Default::default()
        };
        let (surface, repair) = repair_tri_mesh_with(surface, &weld)?;
        let Capped {
            surface,
            openings,
            gates,
        } = cap_openings(
            &surface,
            anterior,
            inferior,
            points.rim_near.as_ref(),
            apex,
            config.snap_mm,
        )?;
        let landmarks = Landmarks::resolve(&surface, anterior, inferior, apex, config.snap_mm)?;
        let rim_of_s = landmarks.rim.clone();
        let ExtendedSurface {
            surface,
            landmarks,
            strip_height_mm,
            original_vertices,
        } = close_base(&surface, &landmarks)?;
        // The disk map and the Laplace field need only S and its landmarks:
        // they run side by side (the field's grid loops are parallel, the
        // disk map's factorization mostly serial), each timed on its own.
        let t1 = Instant::now();
        let ((disk, disk_s), (field, laplace_s)) = rayon::join(
            || {
                let d = match config.chamber {
                    Chamber::Lv => lv_disk(&surface, &landmarks, disk),
                    Chamber::Rv => rv_half_disk(&surface, &landmarks, disk),
                };
                (d, t1.elapsed().as_secs_f64())
            },
            || {
                let t = Instant::now();
                let f = LaplaceField::solve(&surface, &landmarks, &config.field)
                    .map(|f| (SurfaceIndex::new(&surface, &f), f));
                (f, t.elapsed().as_secs_f64())
            },
        );
        // the disk map's errors first, as when it ran before the field
        let disk = disk?;
        if disk.flipped_triangles > 0 {
            return Err(VentricleError::DiskFlips {
                triangles: disk.flipped_triangles,
            }
            .into());
        }
        let (index, field) = field?;
        let locator = PlanarTriLocator::new(&disk.uv, &surface.triangles);
        let closest = ClosestPointQuery::new(&surface);
        let rim = &landmarks.rim;
        let mut rim_edges = Vec::with_capacity(rim.len());
        {
            let mut edge_tri = std::collections::HashMap::new();
            for (t, tri) in surface.triangles.iter().enumerate() {
                for k in 0..3 {
                    edge_tri.insert((tri[k], tri[(k + 1) % 3]), t);
                    edge_tri.insert((tri[(k + 1) % 3], tri[k]), t);
                }
            }
            for k in 0..rim.len() {
                let (a, b) = (rim[k], rim[(k + 1) % rim.len()]);
                if let Some(&t) = edge_tri.get(&(a, b)) {
                    rim_edges.push((a, b, t));
                }
            }
        }
        let diag = {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for p in index.points() {
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
            ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
        };
        Ok(Chart {
            surface,
            repair,
            landmarks,
            disk,
            field,
            index,
            locator,
            closest,
            rim_edges,
            config: *config,
            max_length: 4.0 * diag,
            strip_height_mm,
            original_vertices,
            rim_of_s,
            openings,
            gates,
            timings: ChartTimings {
                disk: (t1 - t0).as_secs_f64() + disk_s,
                laplace: laplace_s,
            },
        })
    }

    /// S after the repair, closed down to its basal plane (`S'` of
    /// [`close_base`]; S's vertices come first).
    pub fn surface(&self) -> &TriMesh {
        &self.surface
    }

    /// Number of vertices of S (repaired, its openings but the rim capped)
    /// at the start of [`Chart::surface`].
    pub fn original_vertices(&self) -> usize {
        self.original_vertices
    }

    /// S's own basal rim, vertices of [`Chart::surface`] in the order of
    /// [`Chart::landmarks`]' rim (the same positions `anterior` and
    /// `inferior`): the rim of S itself, not the strip's lowest layer.
    pub fn rim_of_s(&self) -> &[u32] {
        &self.rim_of_s
    }

    /// Height of the strip closing S down to its basal plane, mm (0 for a
    /// planar rim).
    pub fn strip_height_mm(&self) -> f64 {
        self.strip_height_mm
    }

    /// S's boundary loops: which is the rim, and the caps of the others.
    pub fn openings(&self) -> &Openings {
        &self.openings
    }

    /// The quality gates of the chart (`base.rim_agrees`, see
    /// [`super::openings`]).
    pub fn gates(&self) -> &Gates {
        &self.gates
    }

    /// What the repair of S changed.
    pub fn repair(&self) -> &RepairReport {
        &self.repair
    }

    /// The landmarks as vertices of [`Chart::surface`] (its rim is the
    /// strip's lowest layer when S was extended).
    pub fn landmarks(&self) -> &Landmarks {
        &self.landmarks
    }

    /// The disk map `phi`.
    pub fn disk(&self) -> &DiskMap {
        &self.disk
    }

    /// The Laplace field.
    pub fn field(&self) -> &LaplaceField {
        &self.field
    }

    /// The settings.
    pub fn config(&self) -> &ChartConfig {
        &self.config
    }

    /// Seconds spent building the chart.
    pub fn timings(&self) -> ChartTimings {
        self.timings
    }

    fn tracer(&self) -> Tracer<'_> {
        Tracer::new(
            &self.field,
            &self.index,
            self.config.trace_tolerance_mm,
            self.max_length,
        )
        .expect("the tolerance was checked in Chart::new")
    }

    /// Disk position of barycentric coordinates `b` in triangle `t` of S.
    fn disk_point(&self, t: usize, b: [f64; 3]) -> [f64; 2] {
        let tri = self.surface.triangles[t];
        let mut x = [0.0; 2];
        for (k, &v) in tri.iter().enumerate() {
            let uv = self.disk.uv[v as usize];
            x[0] += b[k] * uv[0];
            x[1] += b[k] * uv[1];
        }
        x
    }

    /// Basal-frame point of barycentric coordinates `b` in triangle `t`.
    fn surface_point(&self, t: usize, b: [f64; 3]) -> [f64; 3] {
        let tri = self.surface.triangles[t];
        let pts = self.index.points();
        let mut x = [0.0; 3];
        for (k, &v) in tri.iter().enumerate() {
            for a in 0..3 {
                x[a] += b[k] * pts[v as usize][a];
            }
        }
        x
    }

    /// `psi(v)` of one point.
    ///
    /// # Errors
    /// Why the point cannot be mapped: [`PointFailure::NotFinite`],
    /// [`PointFailure::OutsideSurface`], [`PointFailure::InsideHemisphere`],
    /// or [`PointFailure::Streamline`] when its streamline fails.
    pub fn forward(&self, v: &Point3<f64>) -> Result<ForwardPoint, PointFailure> {
        let point = [v.x, v.y, v.z];
        if !point.iter().all(|x| x.is_finite()) {
            return Err(PointFailure::NotFinite { point });
        }
        let tracer = self.tracer();
        let frame = self.field.frame();
        let near = self.closest.closest(v).ok_or(PointFailure::NoTriangle)?;
        let (triangle, barycentric, to_surface, start) =
            if near.distance <= self.config.on_surface_mm {
                let s = self.surface_point(near.triangle, near.barycentric);
                (near.triangle, near.barycentric, 0.0, s)
            } else {
                let mut q = frame.local(v);
                if q[2] < 0.0 && q[2] > -self.config.on_surface_mm {
                    q[2] = 0.0;
                }
                let mut buf = Vec::new();
                if !self.index.contains(q, &mut buf) {
                    return Err(PointFailure::OutsideSurface {
                        point,
                        distance_mm: near.distance,
                    });
                }
                if self.field.hemisphere_level(q) < -self.config.on_surface_mm {
                    return Err(PointFailure::InsideHemisphere {
                        point,
                        radius_mm: self.field.hemisphere_radius(),
                    });
                }
                let hit = tracer
                    .to_surface(q)
                    .map_err(|e| e.toward(TraceTarget::Surface))?;
                (hit.triangle, hit.barycentric, hit.length, q)
            };
        let (_, to_h) = tracer
            .to_hemisphere(start)
            .map_err(|e| e.toward(TraceTarget::Hemisphere))?;
        let [xi, zeta] = self.disk_point(triangle, barycentric);
        let total = to_surface + to_h;
        let depth = if total > 0.0 { to_surface / total } else { 1.0 };
        Ok(ForwardPoint {
            coords: CylinderPoint { xi, zeta, depth },
            triangle,
            barycentric,
            to_surface_mm: to_surface,
            to_hemisphere_mm: to_h,
        })
    }

    /// `psi` of every point, in parallel.
    ///
    /// # Errors
    /// [`VentricleError::Unmapped`]: how many points failed and why the
    /// first did.
    pub fn forward_all(&self, points: &[Point3<f64>]) -> Result<Vec<ForwardPoint>, VentricleError> {
        let out: Vec<Result<ForwardPoint, PointFailure>> =
            points.par_iter().map(|p| self.forward(p)).collect();
        collect("anatomy points", out)
    }

    /// The triangle of S and barycentric coordinates at disk position
    /// `(xi, zeta)`; a position just outside the disk polygon (between a rim
    /// edge and the circle, within `1e-3`) goes to the nearest rim point.
    fn locate(&self, xi: f64, zeta: f64) -> Option<(usize, [f64; 3])> {
        if let Some(x) = self.locator.locate([xi, zeta]) {
            return Some(x);
        }
        let p = [xi, zeta];
        let mut best: Option<(f64, usize, [f64; 3])> = None;
        for &(a, b, t) in &self.rim_edges {
            let pa = self.disk.uv[a as usize];
            let pb = self.disk.uv[b as usize];
            let (q, s) = closest_point_on_segment_2d(p, pa, pb);
            let dist = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
            if best.is_none_or(|x| dist < x.0) {
                let tri = self.surface.triangles[t];
                let mut bary = [0.0; 3];
                for k in 0..3 {
                    if tri[k] == a {
                        bary[k] = 1.0 - s;
                    } else if tri[k] == b {
                        bary[k] = s;
                    }
                }
                best = Some((dist, t, bary));
            }
        }
        best.filter(|x| x.0 <= 1e-3).map(|x| (x.1, x.2))
    }

    /// `psi^-1` of one cylinder point.
    ///
    /// # Errors
    /// Why the point cannot be mapped: [`PointFailure::NotOnCylinder`] for a
    /// non-finite point or a depth outside `[0, 1]`,
    /// [`PointFailure::OffDisk`] for a disk position outside the (half)
    /// disk, [`PointFailure::Streamline`] when the streamline fails.
    pub fn inverse(&self, c: &CylinderPoint) -> Result<Point3<f64>, PointFailure> {
        if !(c.xi.is_finite() && c.zeta.is_finite() && (0.0..=1.0).contains(&c.depth)) {
            return Err(PointFailure::NotOnCylinder {
                xi: c.xi,
                zeta: c.zeta,
                depth: c.depth,
            });
        }
        let (t, b) = self.locate(c.xi, c.zeta).ok_or(PointFailure::OffDisk {
            xi: c.xi,
            zeta: c.zeta,
        })?;
        let start = self.surface_point(t, b);
        let frame = self.field.frame();
        if c.depth == 0.0 {
            return Ok(frame.world(start));
        }
        let tracer = self.tracer();
        let (end, total, record) = tracer
            .to_hemisphere_recorded(start)
            .map_err(|e| e.toward(TraceTarget::Hemisphere))?;
        if c.depth == 1.0 {
            return Ok(frame.world(end));
        }
        let q = tracer
            .along_recorded(&record, c.depth * total)
            .map_err(|e| e.toward(TraceTarget::Depth))?;
        Ok(frame.world(q))
    }

    /// `psi^-1` of every cylinder point, in parallel.
    ///
    /// # Errors
    /// [`VentricleError::Unmapped`]: how many points failed and why the
    /// first did.
    pub fn inverse_all(
        &self,
        coords: &[CylinderPoint],
    ) -> Result<Vec<Point3<f64>>, VentricleError> {
        let out: Vec<Result<Point3<f64>, PointFailure>> =
            coords.par_iter().map(|c| self.inverse(c)).collect();
        collect("cylinder points", out)
    }
}

/// All results, or [`VentricleError::Unmapped`] naming how many of the
/// `points` failed and why the first did.
fn collect<T>(
    points: &'static str,
    out: Vec<Result<T, PointFailure>>,
) -> Result<Vec<T>, VentricleError> {
    let total = out.len();
    let mut failures = out
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.as_ref().err().map(|e| (i, *e)));
    if let Some((first, reason)) = failures.next() {
        return Err(VentricleError::Unmapped {
            points,
            failed: 1 + failures.count(),
            total,
            first,
            reason,
        });
    }
    // No failure: every result is a value.
    Ok(out.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::TAU;
    use std::sync::OnceLock;
    use unfold_mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};

    struct Cup {
        shape: VentricleShape,
        chart: Chart,
    }

    fn config(chamber: Chamber, grid_mm: f64) -> ChartConfig {
        ChartConfig {
            chamber,
            field: FieldConfig {
                grid_mm,
                ..FieldConfig::default()
            },
            ..ChartConfig::default()
        }
    }

    /// The default cup's LV chart on a 1.5 mm grid, built once.
    fn cup() -> &'static Cup {
        static C: OnceLock<Cup> = OnceLock::new();
        C.get_or_init(|| {
            let shape = ventricle_cup(&VentricleParams::default()).unwrap();
            let chart = Chart::new(
                &shape.surface,
                &shape.anterior,
                &shape.inferior,
                None,
                &config(Chamber::Lv, 1.5),
            )
            .unwrap();
            Cup { shape, chart }
        })
    }

    /// The point of the ray from the rim centre (the origin) at polar angle
    /// `polar` from the apex direction `-z` and azimuth `az`, a fraction
    /// `u` of the way from 0.5 mm outside H to 1 mm inside S (the default
    /// cup's ellipsoid: semi-axes `a`, `a`, `c` centred at `(0, 0, z0)`).
    fn on_ray(polar: f64, az: f64, u: f64, r_h: f64) -> Point3<f64> {
        let p = VentricleParams::default();
        let (a, c) = (p.radius, p.long_semi_axis());
        let z0 = c - p.length;
        let d = [polar.sin() * az.cos(), polar.sin() * az.sin(), -polar.cos()];
        // |t d - (0, 0, z0)| on the ellipsoid: qa t^2 + qb t + qc = 0
        let qa = (d[0] * d[0] + d[1] * d[1]) / (a * a) + d[2] * d[2] / (c * c);
        let qb = -2.0 * d[2] * z0 / (c * c);
        let qc = z0 * z0 / (c * c) - 1.0;
        let hit = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
        assert!(hit > r_h + 2.0, "{hit}");
        let t = r_h + 0.5 + u * (hit - 1.0 - r_h - 0.5);
        Point3::new(t * d[0], t * d[1], t * d[2])
    }

    fn failure<T: std::fmt::Debug>(r: Result<T, PointFailure>) -> PointFailure {
        match r {
            Err(e) => e,
            Ok(x) => panic!("expected an error, got {x:?}"),
        }
    }

    fn message<T: std::fmt::Debug>(r: Result<T, PointFailure>) -> String {
        failure(r).to_string()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(8))]

        /// `psi^-1(psi(v)) = v` for points between H and S: an anatomy point
        /// of the cup and points on rays from the rim centre.
        #[test]
        fn forward_then_inverse_is_the_identity(
            k in 0usize..648,
            polar in 0.0..1.45f64,
            az in 0.0..TAU,
            u in 0.0..1.0f64,
        ) {
            let c = cup();
            let r_h = c.chart.field().hemisphere_radius();
            prop_assert_eq!(c.shape.anatomy_points.len(), 648);
            for v in [c.shape.anatomy_points[k], on_ray(polar, az, u, r_h)] {
                let f = c.chart.forward(&v).unwrap();
                let cp = f.coords;
                prop_assert!(cp.depth > 0.0 && cp.depth < 1.0, "{cp:?}");
                prop_assert!(cp.xi.hypot(cp.zeta) <= 1.0 + 1e-9, "{cp:?}");
                prop_assert!(f.to_surface_mm > 0.0 && f.to_hemisphere_mm > 0.0);
                let d = f.to_surface_mm / (f.to_surface_mm + f.to_hemisphere_mm);
                prop_assert!((cp.depth - d).abs() < 1e-15);
                prop_assert!((f.barycentric.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                let back = c.chart.inverse(&cp).unwrap();
                prop_assert!((back - v).norm() < 1e-4, "{v:?} -> {cp:?} -> {back:?}: {}", (back - v).norm());
            }
        }
    }

    #[test]
    fn points_on_s_have_depth_0_and_points_on_h_depth_1() {
        let c = cup();
        let s = &c.shape.surface;
        // vertices of S: the apex, one inside, one on the rim
        for v in [0, s.positions.len() / 2, c.shape.rim[7] as usize] {
            let p = s.positions[v];
            let f = c.chart.forward(&p).unwrap();
            assert_eq!(f.coords.depth, 0.0, "vertex {v}");
            assert_eq!(f.to_surface_mm, 0.0);
            let back = c.chart.inverse(&f.coords).unwrap();
            assert!(
                (back - p).norm() < 1e-9,
                "vertex {v}: {}",
                (back - p).norm()
            );
        }
        // the apex is the centre of the disk
        let f = c.chart.forward(&c.shape.apex).unwrap();
        assert!(f.coords.xi.hypot(f.coords.zeta) < 1e-9, "{:?}", f.coords);
        // points on H
        let frame = *c.chart.field().frame();
        let r_h = c.chart.field().hemisphere_radius();
        for (polar, az) in [(0.0, 0.0), (0.7, 1.0), (1.3, 4.0)] {
            let q = [
                r_h * f64::sin(polar) * f64::cos(az),
                r_h * f64::sin(polar) * f64::sin(az),
                r_h * f64::cos(polar),
            ];
            let f = c.chart.forward(&frame.world(q)).unwrap();
            assert!((f.coords.depth - 1.0).abs() < 1e-9, "{:?}", f.coords);
            // and depth 1 maps back onto H
            let end = frame.local(&c.chart.inverse(&f.coords).unwrap());
            let rho = (end[0] * end[0] + end[1] * end[1] + end[2] * end[2]).sqrt();
            assert!((rho - r_h).abs() < 1e-9, "{rho}");
        }
    }

    #[test]
    fn bad_points_are_refused_with_a_clear_error() {
        let c = cup();
        let ch = &c.chart;
        let e = failure(ch.forward(&Point3::new(f64::NAN, 0.0, -10.0)));
        assert!(matches!(e, PointFailure::NotFinite { .. }), "{e:?}");
        assert!(e.to_string().contains("not finite"), "{e}");
        let m = message(ch.forward(&Point3::new(0.0, f64::INFINITY, -10.0)));
        assert!(m.contains("not finite"), "{m}");
        // beyond the apex, beside the cup, above the base
        for p in [
            Point3::new(0.0, 0.0, -65.0),
            Point3::new(40.0, 0.0, -20.0),
            Point3::new(0.0, 0.0, 3.0),
        ] {
            let e = failure(ch.forward(&p));
            match e {
                PointFailure::OutsideSurface { point, distance_mm } => {
                    assert_eq!(point, [p.x, p.y, p.z]);
                    assert!(distance_mm > 0.0, "{distance_mm}");
                }
                e => panic!("expected outside S, got {e:?}"),
            }
            let m = e.to_string();
            assert!(m.contains("outside S"), "{m}");
        }
        let e = failure(ch.forward(&Point3::new(1.0, -1.0, -2.0)));
        assert_eq!(
            e,
            PointFailure::InsideHemisphere {
                point: [1.0, -1.0, -2.0],
                radius_mm: ch.field().hemisphere_radius()
            }
        );
        let m = e.to_string();
        assert!(m.contains("inside the hemisphere"), "{m}");
        let ok = ch.forward(&c.shape.anatomy_points[0]).unwrap().coords;
        for depth in [1.5, -0.1, f64::NAN, f64::INFINITY] {
            let e = failure(ch.inverse(&CylinderPoint { depth, ..ok }));
            assert!(matches!(e, PointFailure::NotOnCylinder { .. }), "{e:?}");
            let m = e.to_string();
            assert!(m.contains("depth"), "{m}");
        }
        let m = message(ch.inverse(&CylinderPoint { xi: f64::NAN, ..ok }));
        assert!(m.contains("not a point of the cylinder"), "{m}");
        for (xi, zeta) in [(3.0, 0.0), (0.0, -1.01), (0.8, 0.8)] {
            let e = failure(ch.inverse(&CylinderPoint {
                xi,
                zeta,
                depth: 0.5,
            }));
            assert_eq!(e, PointFailure::OffDisk { xi, zeta });
            let m = e.to_string();
            assert!(m.contains("outside the flattened S"), "{m}");
        }
    }

    #[test]
    fn many_points_fail_together_naming_the_first() {
        let c = cup();
        let good = &c.shape.anatomy_points[..4];
        let mut points = good.to_vec();
        points.insert(3, Point3::new(0.0, 0.0, -65.0));
        match c.chart.forward_all(&points) {
            Err(
                e @ VentricleError::Unmapped {
                    points: "anatomy points",
                    failed: 1,
                    total: 5,
                    first: 3,
                    reason: PointFailure::OutsideSurface { .. },
                    ..
                },
            ) => {
                let m = e.to_string();
                assert!(m.contains("1 of 5 anatomy points"), "{m}");
                assert!(m.contains("point 3"), "{m}");
                assert!(m.contains("outside S"), "{m}");
            }
            other => panic!("{other:?}"),
        }
        points[1] = Point3::new(f64::NAN, 0.0, 0.0);
        match c.chart.forward_all(&points) {
            Err(
                e @ VentricleError::Unmapped {
                    failed: 2,
                    total: 5,
                    first: 1,
                    reason: PointFailure::NotFinite { .. },
                    ..
                },
            ) => {
                let m = e.to_string();
                assert!(m.contains("2 of 5"), "{m}");
                assert!(m.contains("point 1") && m.contains("not finite"), "{m}");
            }
            other => panic!("{other:?}"),
        }
        let fw = c.chart.forward_all(good).unwrap();
        assert_eq!(fw.len(), 4);
        let mut coords: Vec<CylinderPoint> = fw.iter().map(|f| f.coords).collect();
        let back = c.chart.inverse_all(&coords).unwrap();
        for (p, q) in good.iter().zip(&back) {
            assert!((p - q).norm() < 1e-4);
        }
        coords[2].depth = 2.0;
        match c.chart.inverse_all(&coords) {
            Err(
                e @ VentricleError::Unmapped {
                    points: "cylinder points",
                    failed: 1,
                    total: 4,
                    first: 2,
                    reason: PointFailure::NotOnCylinder { depth: 2.0, .. },
                    ..
                },
            ) => {
                let m = e.to_string();
                assert!(m.contains("1 of 4 cylinder points"), "{m}");
                assert!(m.contains("point 2") && m.contains("depth"), "{m}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_chart_settings_are_refused() {
        let s = ventricle_cup(&VentricleParams::default()).unwrap();
        let new = |c: ChartConfig| Chart::new(&s.surface, &s.anterior, &s.inferior, None, &c);
        for bad in [0.0, -1.0, f64::NAN] {
            match new(ChartConfig {
                trace_tolerance_mm: bad,
                ..config(Chamber::Lv, 2.0)
            }) {
                Err(e @ OrganError::Config(_)) => {
                    assert!(e.to_string().contains("trace tolerance"), "{e}")
                }
                other => panic!("{other:?}"),
            }
            match new(ChartConfig {
                on_surface_mm: bad,
                ..config(Chamber::Lv, 2.0)
            }) {
                Err(e @ OrganError::Config(_)) => {
                    assert!(e.to_string().contains("on-surface distance"), "{e}")
                }
                other => panic!("{other:?}"),
            }
        }
        let mut big = config(Chamber::Lv, 2.0);
        big.field.hemisphere_mm = 30.0;
        match new(big) {
            Err(OrganError::Ventricle(e @ VentricleError::HemisphereDoesNotFit { .. })) => {
                assert!(e.to_string().contains("does not fit"), "{e}")
            }
            other => panic!("{other:?}"),
        }
    }

    /// The cup as an RV: every point maps into the half disk `xi >= 1.25`
    /// and back.
    #[test]
    fn an_rv_chart_maps_into_the_half_disk() {
        let shape = ventricle_cup(&VentricleParams::default()).unwrap();
        let chart = Chart::new(
            &shape.surface,
            &shape.anterior,
            &shape.inferior,
            None,
            &config(Chamber::Rv, 2.0),
        )
        .unwrap();
        assert_eq!(chart.config().chamber, Chamber::Rv);
        let points: Vec<Point3<f64>> = shape.anatomy_points.iter().step_by(9).copied().collect();
        let fw = chart.forward_all(&points).unwrap();
        for f in &fw {
            let c = f.coords;
            assert!(c.xi >= 1.25 - 1e-9, "{c:?}");
            assert!((c.xi - 1.25).hypot(c.zeta) <= 1.0 + 1e-9, "{c:?}");
            assert!(c.depth > 0.0 && c.depth < 1.0, "{c:?}");
        }
        let coords: Vec<CylinderPoint> = fw.iter().map(|f| f.coords).collect();
        let back = chart.inverse_all(&coords).unwrap();
        for (p, q) in points.iter().zip(&back) {
            assert!((p - q).norm() < 1e-4, "{}", (p - q).norm());
        }
        // the LV disk's centre is outside the half disk
        let e = failure(chart.inverse(&CylinderPoint {
            xi: 0.0,
            zeta: 0.0,
            depth: 0.5,
        }));
        assert_eq!(e, PointFailure::OffDisk { xi: 0.0, zeta: 0.0 });
        assert!(e.to_string().contains("outside the flattened S"), "{e}");
    }
}
