//! The mitral valve pipeline (ALGORITHMS 4): the annulus laid out first
//! (arc length and height), the leaflets below it, relaxed into a flat
//! map; clinical maps and measurements.
//!
//! Steps (each public, so a pipeline can be composed from code):
//!
//! Without an annulus ring, [`shared_boundary::annulus_from_leaflets`]
//! finds it from the places where the leaflets' boundaries meet.
//!
//! 0. Both leaflets are repaired ([`unfold_mesh::repair`], coincident
//!    vertices welded; [`Report::repair`]); the outputs use the repaired
//!    leaflets' vertices.
//! 1. [`contract::prepare`]: the input contract. Leaflet annulus vertices,
//!    commissures, atrial side, ring order (clockwise seen from the atrium,
//!    from the anterolateral commissure).
//! 2. [`annulus::parameterize`]: the annulus in 2D (straight, least-squares
//!    plane or landmark plane).
//! 3. [`layout`]: the initial leaflet layout (longitudes or Tutte).
//! 4. [`relax`]: the spring baseline or flip-free symmetric Dirichlet.
//! 5. [`maps`]: distortion and clinical maps, measurements.
//! 6. [`gates`]: the quality gates (leaflet areas against the annulus,
//!    flips), listed in [`Report::gates`]; a failed gate stops the run with
//!    one line naming the fix.
//!
//! Failures specific to the valve are [`MitralError`]s (one nested enum
//! per step, see [`error`]), inside [`OrganError::Mitral`].

pub mod annulus;
pub mod contract;
pub mod error;
pub mod gates;
pub mod initializer;
pub mod layout;
pub mod leaflet_repair;
pub mod maps;
mod pipeline;
pub mod relax;
pub mod segmentation;
pub mod shared_boundary;

pub use initializer::LeafletLayout;
pub use pipeline::Pipeline;
pub use shared_boundary::{FoundAnnulus, annulus_from_leaflets};

pub use error::{
    AnnulusError, ContractError, LayoutError, LayoutKind, LeafletSide, MapsError, MitralError,
    RelaxError, SegmentationError,
};

use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use unfold_mesh::TriMesh;
use unfold_mesh::nalgebra::{Point3, Vector3};

/// Index of the anterior leaflet in per-leaflet arrays.
pub const ANTERIOR: usize = 0;
/// Index of the posterior leaflet in per-leaflet arrays.
pub const POSTERIOR: usize = 1;

/// The valve as it comes from a segmentation: two leaflet surfaces (disk
/// topology each) and the annulus ring (a closed polyline, any start, any
/// direction; a repeated closing point is allowed).
#[derive(Debug, Clone, Copy)]
pub struct ValveInput<'a> {
    /// The anterior leaflet.
    pub anterior: &'a TriMesh,
    /// The posterior leaflet.
    pub posterior: &'a TriMesh,
    /// The annulus ring's points in order along the ring.
    pub annulus: &'a [Point3<f64>],
}

/// One leaflet after the input contract.
#[derive(Debug, Clone, PartialEq)]
pub struct Leaflet {
    /// The leaflet surface as given.
    pub mesh: TriMesh,
    /// Its annulus vertices (boundary vertices on the ring), in ring order:
    /// anterior from the anterolateral to the posteromedial commissure,
    /// posterior from the posteromedial to the anterolateral commissure.
    pub annulus: Vec<u32>,
    /// Per annulus vertex: its position along the (reordered) ring as arc
    /// length from the anterolateral commissure, in `[0, L]` (`L` the ring
    /// length); non-decreasing along `annulus`. The posterior leaflet's
    /// last vertex (at the anterolateral commissure) has `L`, not 0.
    pub annulus_s: Vec<f64>,
    /// The rest of its boundary loop (the free edge), from the vertex after
    /// the last annulus vertex to the vertex before the first.
    pub free_edge: Vec<u32>,
}

impl Leaflet {
    /// A leaflet from its mesh and its annulus vertices in ring order: the
    /// annulus arc lengths are the 3D distances along them from the first,
    /// the free edge the rest of the mesh's boundary loop, from the vertex
    /// after the last annulus vertex to the vertex before the first.
    ///
    /// # Errors
    /// [`LayoutError::AnnulusVertexOutOfRange`] for an annulus vertex out of
    /// range; `Mesh` when the mesh is not a disk;
    /// [`LayoutError::AnnulusNotABoundaryRun`] when the annulus is not a run
    /// of the boundary loop.
    pub fn from_annulus(mesh: TriMesh, annulus: Vec<u32>) -> Result<Leaflet, OrganError> {
        let n = mesh.positions.len();
        if let Some(&vertex) = annulus.iter().find(|&&v| v as usize >= n) {
            return Err(LayoutError::AnnulusVertexOutOfRange {
                vertex,
                vertices: n,
            }
            .into());
        }
        let mut annulus_s = Vec::with_capacity(annulus.len());
        let mut s = 0.0;
        for (k, &v) in annulus.iter().enumerate() {
            if k > 0 {
                s += (mesh.positions[v as usize] - mesh.positions[annulus[k - 1] as usize]).norm();
            }
            annulus_s.push(s);
        }
        let boundary = unfold_mesh::topology::disk_boundary_loop(&mesh)?;
        let m = boundary.len();
        let at = |v: u32| boundary.iter().position(|&b| b == v);
        let (Some(first), Some(last)) = (
            annulus.first().copied().and_then(at),
            annulus.last().copied().and_then(at),
        ) else {
            return Err(LayoutError::AnnulusNotABoundaryRun.into());
        };
        // The direction in which the loop runs along the annulus.
        let step = if annulus.len() < 2 || boundary[(first + 1) % m] == annulus[1] {
            1
        } else {
            m - 1
        };
        let mut free_edge = Vec::new();
        let mut k = (last + step) % m;
        while k != first && free_edge.len() < m {
            free_edge.push(boundary[k]);
            k = (k + step) % m;
        }
        Ok(Leaflet {
            mesh,
            annulus,
            annulus_s,
            free_edge,
        })
    }
}

/// The valve after [`contract::prepare`].
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedValve {
    /// The annulus ring, clockwise seen from the atrium, starting at the
    /// anterolateral commissure (`ring[0]`); closed implicitly (the last
    /// point is not repeated). Commissure points not on a ring vertex were
    /// inserted into their segments.
    pub ring: Vec<Point3<f64>>,
    /// Index into `ring` of the posteromedial commissure: the anterior arc
    /// is `ring[0..=posteromedial]`, the posterior arc
    /// `ring[posteromedial..]` followed by `ring[0]`.
    pub posteromedial: usize,
    /// Unit normal towards the atrium: the normal of the ring's
    /// least-squares plane, on the side away from the leaflets.
    pub atrium: Vector3<f64>,
    /// The leaflets, indexed by [`ANTERIOR`] and [`POSTERIOR`].
    pub leaflets: [Leaflet; 2],
    /// The tolerance used to find annulus vertices, mm.
    pub tolerance_mm: f64,
}

/// A plane `{p : n . (p - point) = 0}` with unit normal `n` towards the
/// atrium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point on the plane.
    pub point: Point3<f64>,
    /// Unit normal, towards the atrium.
    pub normal: Vector3<f64>,
}

impl Plane {
    /// Signed distance `n . (p - point)` (positive on the atrial side).
    pub fn signed_distance(&self, p: &Point3<f64>) -> f64 {
        self.normal.dot(&(p - self.point))
    }
}

/// How the annulus is laid out (ALGORITHMS 4.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AnnulusMode {
    /// `v = 0`, `u` the 3D arc length.
    Straight,
    /// Heights above the least-squares plane of the annulus points.
    LeastSquares,
    /// Heights above the plane through the two commissures and the
    /// barycentre of the posterior annulus points (default).
    #[default]
    Landmark,
}

/// The initial leaflet layout (ALGORITHMS 4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitMode {
    /// Longitudes when the leaflet has them, else Tutte (default).
    #[default]
    Auto,
    /// Longitudes (an error when a leaflet has none).
    Longitudes,
    /// Tutte embedding below the fixed annulus.
    Tutte,
}

/// The relaxation (ALGORITHMS 4.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RelaxMode {
    /// The source's mass-spring method (baseline; may flip triangles).
    Spring,
    /// 2D symmetric Dirichlet, annulus pinned, projected Newton with the
    /// injective line search (default; never flips).
    #[default]
    Sd,
}

unfold_param::named!(AnnulusMode {
    Straight => "straight",
    LeastSquares => "least-squares",
    Landmark => "landmark",
});
unfold_param::named!(InitMode { Auto => "auto", Longitudes => "longitudes", Tutte => "tutte" });
unfold_param::named!(RelaxMode { Spring => "spring", Sd => "sd" });

use crate::OrganError;
use unfold_mesh::Field;

/// Settings of the mitral pipeline; every default from ALGORITHMS 4.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// How the annulus is laid out (default: landmark plane).
    pub annulus_mode: AnnulusMode,
    /// The relaxation (default: flip-free symmetric Dirichlet).
    pub relax: RelaxMode,
    /// Settings of the spring relaxation (`relax = spring`).
    pub spring: relax::SpringConfig,
    /// Settings of the symmetric Dirichlet relaxation (`relax = sd`).
    pub sd: relax::SdConfig,
    /// Distance within which a leaflet boundary vertex is on the ring, mm.
    pub tolerance_mm: f64,
    /// Coaptation threshold and checkerboard size.
    pub maps: maps::MapsConfig,
    /// Second cut at the posteromedial commissure: the posterior leaflet is
    /// drawn `cut_gap_mm` to the right of the anterior one instead of
    /// touching it there (default false).
    pub cut_posteromedial: bool,
    /// Gap between the leaflets at a second cut, mm (default 4).
    pub cut_gap_mm: f64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            annulus_mode: AnnulusMode::default(),
            relax: RelaxMode::default(),
            spring: relax::SpringConfig::default(),
            sd: relax::SdConfig::default(),
            tolerance_mm: contract::DEFAULT_TOLERANCE_MM,
            maps: maps::MapsConfig::default(),
            cut_posteromedial: false,
            cut_gap_mm: 4.0,
        }
    }
}

impl Config {
    /// Checks the values the steps do not check themselves.
    pub fn validate(&self) -> Result<(), OrganError> {
        crate::ConfigError::check(
            "cut_gap_mm",
            self.cut_gap_mm,
            crate::Requirement::NonNegative,
        )?;
        OrganError::check_positive(&[("tolerance_mm", self.tolerance_mm)])
    }
}

/// Mean distortion energies before and after the relaxation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DistortionReport {
    /// Of the initial layout.
    pub initial: maps::DistortionSummary,
    /// Of the relaxed layout.
    pub r#final: maps::DistortionSummary,
}

/// `report.json` of one valve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Report {
    /// Length of the annulus ring, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub annulus_length_mm: f64,
    /// Extent of the annulus in u, mm (the length in straight mode; shorter
    /// in the plane modes, where part of each segment goes into v).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub u_extent_mm: f64,
    /// Leaflet areas (3D), mm^2.
    pub leaflet_area_mm2: maps::PerLeaflet,
    /// Highest annulus point above the annulus plane, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub saddle_horn_height_mm: f64,
    /// Leaflet area on the atrial side of the annulus plane, mm^2.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub area_above_plane_mm2: f64,
    /// Leaflet area on the ventricular side of the annulus plane, mm^2.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub area_below_plane_mm2: f64,
    /// Mean area, angle and length energies, before and after relaxing.
    pub distortion: DistortionReport,
    /// Triangles with non-positive area in the final 2D map (both leaflets),
    /// against each leaflet's majority orientation
    /// ([`unfold_mesh::geometry::flipped_triangles`]).
    pub flipped_triangles: usize,
    /// Interior edges folded in the final 2D map, both leaflets (the two
    /// triangles of an edge on the same side of it,
    /// [`unfold_mesh::geometry::folded_edges`]; 0 for a locally injective
    /// map).
    pub folded_edges: usize,
    /// Boundary edges of the final 2D map that cross another boundary edge
    /// of the same leaflet's map (the leaflet's outline overlapping itself,
    /// [`unfold_mesh::geometry::boundary_edge_crossings`]), both leaflets;
    /// 0 for an injective map.
    pub overlapping_boundary_edges: usize,
    /// The relaxation ("sd" or "spring").
    pub relax: Cow<'static, str>,
    /// The initial layout used per leaflet ("longitudes" or "tutte" for
    /// the default initializer, else the initializer's name).
    pub init: [Cow<'static, str>; 2],
    /// The pieces the pipeline was built from.
    pub pieces: Pieces,
    /// The annulus mode.
    pub annulus_mode: AnnulusMode,
    /// Per leaflet relaxation reports.
    pub relax_reports: [relax::RelaxReport; 2],
    /// Vertices in the coaptation zone (within the threshold) and near it
    /// (within twice the threshold), both leaflets.
    pub coaptation_vertices: CoaptationCounts,
    /// Vertices per Carpentier segment A1, A2, A3, P1, P2, P3.
    pub carpentier_vertices: [usize; 6],
    /// The commissures (anterolateral, posteromedial), mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub commissures_mm: [[f64; 3]; 2],
    /// The plane the annulus heights `v` of the 2D map are measured from
    /// (point and normal towards the atrium); absent in straight mode.
    pub layout_plane: Option<PlaneReport>,
    /// The annulus' least-squares plane, from which tenting, the
    /// saddle-horn height and the areas above / below are measured.
    pub annulus_plane: PlaneReport,
    /// Whether the posteromedial commissure was cut.
    pub cut_posteromedial: bool,
    /// What the repair of each leaflet changed, before the input contract
    /// (coincident vertices welded, see [`unfold_mesh::repair`]); the
    /// outputs use the repaired leaflets' vertices.
    pub repair: LeafletRepairs,
    /// Wall-clock seconds of the pipeline (no file I/O).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
    /// Seconds per step.
    pub timings: Timings,
    /// The quality gates checked ([`gates`]), each with its measured value.
    pub gates: crate::gate::Gates,
}

/// The repair of each leaflet ([`Report::repair`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeafletRepairs {
    /// The anterior leaflet's.
    pub anterior: unfold_mesh::repair::RepairReport,
    /// The posterior leaflet's.
    pub posterior: unfold_mesh::repair::RepairReport,
}

/// The pieces a run was built from, by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pieces {
    /// The relaxation's distortion energy.
    pub energy: Cow<'static, str>,
    /// The initial layout.
    pub initializer: Cow<'static, str>,
    /// The line search.
    pub line_search: Cow<'static, str>,
    /// The solver.
    pub solver: Cow<'static, str>,
}

/// Seconds per step of a run.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timings {
    /// The input contract.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub contract: f64,
    /// Annulus and initial layouts.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub layout: f64,
    /// Relaxation of both leaflets (with their initial layouts' energies
    /// and, after each leaflet's relaxation, its coaptation distances).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub relax: f64,
    /// The other maps, measurements and output meshes.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub maps: f64,
}

/// Coaptation counts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoaptationCounts {
    /// Within the threshold.
    pub within: usize,
    /// Within twice the threshold (but not the threshold).
    pub near: usize,
    /// The threshold, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub threshold_mm: f64,
}

/// A plane in the report.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneReport {
    /// A point on the plane, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub point: [f64; 3],
    /// Unit normal towards the atrium.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub normal: [f64; 3],
}

/// Everything [`run`] produces.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The prepared valve (ordered ring, annulus vertices, ...).
    pub valve: PreparedValve,
    /// The annulus layout.
    pub annulus: annulus::AnnulusMap,
    /// Final 2D positions per leaflet.
    pub uv: [Vec<[f64; 2]>; 2],
    /// Both leaflets in 3D (anterior vertices first) with every map as a
    /// point or cell array.
    pub valve3d: TriMesh,
    /// The same connectivity and arrays at `(u, v, 0)`.
    pub valve2d: TriMesh,
    /// Per leaflet maps.
    pub maps: [maps::LeafletMaps; 2],
    /// The report.
    pub report: Report,
}

/// A per-leaflet map with its name (static, for
/// [`MitralError::MergedFieldTypes`]).
type NamedField = (&'static str, Field);

fn leaflet_fields(m: &maps::LeafletMaps, n: usize) -> (Vec<NamedField>, Vec<NamedField>) {
    let labels = |name: &'static str, v: Vec<i32>| (name, Field::labels(name, v));
    let scalars = |name: &'static str, v: Vec<f64>| (name, Field::scalars(name, v));
    let point = vec![
        labels("leaflet", vec![m.leaflet; n]),
        ("u_gradient", Field::vectors("u_gradient", &m.u_gradient)),
        labels("u_interval", m.u_interval.clone()),
        labels("checker", m.checker.clone()),
        labels("carpentier", m.carpentier.clone()),
        scalars("length_energy", m.length_energy.clone()),
        labels("coaptation", m.coaptation.clone()),
        scalars("coaptation_distance_mm", m.coaptation_distance_mm.clone()),
        scalars("tenting_mm", m.tenting_mm.clone()),
    ];
    let cell = vec![
        scalars("area_energy", m.area_energy.clone()),
        scalars("angle_energy", m.angle_energy.clone()),
    ];
    (point, cell)
}

/// Concatenates two fields of the same name and layout.
fn concat((name, a): &NamedField, (_, b): &NamedField) -> Result<Field, OrganError> {
    use unfold_mesh::FieldValues;
    let values = match (a.values(), b.values()) {
        (FieldValues::F64(x), FieldValues::F64(y)) => {
            FieldValues::F64(x.iter().chain(y).copied().collect())
        }
        (FieldValues::I32(x), FieldValues::I32(y)) => {
            FieldValues::I32(x.iter().chain(y).copied().collect())
        }
        _ => return Err(MitralError::MergedFieldTypes { field: name }.into()),
    };
    Ok(Field::new(a.name(), a.components(), values)?)
}

/// Both leaflets as one mesh (anterior first) with their maps and `uv`.
fn merged(
    valve: &PreparedValve,
    uv: &[Vec<[f64; 2]>; 2],
    maps: &[maps::LeafletMaps; 2],
    flat: bool,
) -> Result<TriMesh, OrganError> {
    let [a, p] = [
        &valve.leaflets[ANTERIOR].mesh,
        &valve.leaflets[POSTERIOR].mesh,
    ];
    let offset = a.positions.len() as u32;
    let position = |k: usize, i: usize, q: &Point3<f64>| {
        if flat {
            Point3::new(uv[k][i][0], uv[k][i][1], 0.0)
        } else {
            *q
        }
    };
    let positions = a
        .positions
        .iter()
        .enumerate()
        .map(|(i, q)| position(ANTERIOR, i, q))
        .chain(
            p.positions
                .iter()
                .enumerate()
                .map(|(i, q)| position(POSTERIOR, i, q)),
        )
        .collect();
    let triangles = a
        .triangles
        .iter()
        .copied()
        .chain(p.triangles.iter().map(|t| t.map(|v| v + offset)))
        .collect();
    let mut mesh = TriMesh::new(positions, triangles);
    let (pa, ca) = leaflet_fields(&maps[ANTERIOR], a.positions.len());
    let (pp, cp) = leaflet_fields(&maps[POSTERIOR], p.positions.len());
    for (x, y) in pa.iter().zip(&pp) {
        mesh.add_point_field(concat(x, y)?)?;
    }
    for (x, y) in ca.iter().zip(&cp) {
        mesh.add_cell_field(concat(x, y)?)?;
    }
    let uv_all: Vec<f64> = uv[ANTERIOR]
        .iter()
        .chain(&uv[POSTERIOR])
        .flat_map(|q| [q[0], q[1]])
        .collect();
    mesh.add_point_field(Field::new("uv", 2, unfold_mesh::FieldValues::F64(uv_all))?)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merging_maps_of_different_types_is_an_internal_error() {
        let a = ("checker", Field::labels("checker", vec![1, 2]));
        let b = ("checker", Field::scalars("checker", vec![1.0]));
        let e = concat(&a, &b).unwrap_err();
        assert_eq!(
            e,
            OrganError::Mitral(MitralError::MergedFieldTypes { field: "checker" })
        );
        assert_eq!(
            e.to_string(),
            "field checker has different types per leaflet"
        );
        let c = ("checker", Field::labels("checker", vec![3]));
        assert_eq!(concat(&a, &c).unwrap().tuples(), 3);
    }
}
