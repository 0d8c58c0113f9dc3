//! `report.json` of the placenta pipeline.

use super::align::TransformReport;
use super::canonical::TemplateSymmetry;
use super::estimate::Estimates;
use super::optimize::StageReport;
use super::parcellation::ParcellationSummary;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::collections::BTreeMap;
use unfold_param::StopReason;
use unfold_param::metrics::Summary;

/// Boundary vertex counts by side.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryReport {
    /// Fetal vertices.
    pub fetal: usize,
    /// Maternal vertices.
    pub maternal: usize,
    /// Margin vertices.
    pub margin: usize,
    /// The parcellation's details.
    pub parcellation: ParcellationSummary,
}

/// The input, as the pipeline saw it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputReport {
    /// Vertices.
    pub vertices: usize,
    /// Tets.
    pub tets: usize,
    /// Tets whose orientation was repaired.
    pub reoriented_tets: usize,
    /// Volume, mm^3.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub volume_mm3: f64,
}

/// Seconds per step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Timings {
    /// Validation and orientation.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub prepare: f64,
    /// Parcellation.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub parcellation: f64,
    /// Alignment and initial estimates.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub initialization: f64,
    /// Optimization (all stages).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub optimization: f64,
    /// Evaluation.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub evaluation: f64,
    /// Pulling the images back (tables and resampling).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub images: f64,
}

/// `report.json` (ALGORITHMS 2.6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Report {
    /// The template's name ("planes", "ellipsoid", "single-plane", or a
    /// method developer's).
    pub template: Cow<'static, str>,
    /// `lambda`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub lambda: f64,
    /// The solver's name ("newton", "gd", ...).
    pub solver: Cow<'static, str>,
    /// Every piece the pipeline was built from.
    pub pieces: Pieces,
    /// Iterations, all stages.
    pub iterations: usize,
    /// Wall-clock seconds of the whole pipeline.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub seconds: f64,
    /// Whether the last stage converged.
    pub converged: bool,
    /// Why the last stage stopped.
    pub stop_reason: StopReason,
    /// Final `phi`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub objective: f64,
    /// Final `|grad phi|_F`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub grad_norm: f64,
    /// `sqrt(sum_m A_m T(x_m, theta))`, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub template_error_mm: f64,
    /// The same in voxels of `voxel_mm`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub template_error_voxels: f64,
    /// The voxel size, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub voxel_mm: f64,
    /// `(sum V_k D(J_k) - 6) / 6 * 100`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub dirichlet_excess_percent: f64,
    /// Smallest `det J`.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub min_det_j: f64,
    /// Tets with `det J <= 0` (0 by construction).
    pub inverted_tets: usize,
    /// Interior faces folded in the map (the two tets on the same side of
    /// the face; 0 for an injective map).
    pub folded_faces: usize,
    /// Boundary faces of the map that meet another boundary face (the
    /// boundary surface overlapping itself; 0 for an injective map).
    pub overlapping_boundary_faces: usize,
    /// Final template parameters, mm (`h`, or `rx`, `ry`, `rz`).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub theta: BTreeMap<Cow<'static, str>, f64>,
    /// Initial template parameters (ALGORITHMS 2.4), mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub theta_initial: BTreeMap<Cow<'static, str>, f64>,
    /// The mesh-only estimates behind `theta_initial`.
    pub estimates: Estimates,
    /// Per tet `log2 det J`.
    pub log2_det_j: Option<Summary>,
    /// Per edge `log2(|x_ij| / |z_ij|)`.
    pub log2_edge_ratio: Option<Summary>,
    /// Per boundary triangle `log2(area ratio)`.
    pub log2_area_ratio: Option<Summary>,
    /// Boundary vertex counts.
    pub boundary: BoundaryReport,
    /// Input to template frame: the rigid motion that best fits the start
    /// of the optimization, followed by `canonical_frame.motion`.
    pub transform: TransformReport,
    /// The motion applied to the optimized map to put it into the
    /// canonical template frame (ALGORITHMS 2.10).
    pub canonical_frame: CanonicalReport,
    /// What the repair of the input mesh changed (see
    /// [`super::prepare::prepare_mesh`]); the outputs use the repaired
    /// mesh's vertices.
    pub repair: unfold_mesh::repair::RepairReport,
    /// The input.
    pub input: InputReport,
    /// One entry per optimization stage.
    pub stages: Vec<StageReport>,
    /// One entry per pulled-back image.
    pub images: Vec<ImageReport>,
    /// Seconds per step.
    pub timings: Timings,
    /// The quality gates, in the order checked: the side split's
    /// (`sides.*`, [`super::parcellation`]) and the solve's (`solve.*`,
    /// [`super::solve_gates`]), each with its measured value.
    pub gates: crate::gate::Gates,
}

/// The pieces a run was built from, by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pieces {
    /// The template.
    pub template: Cow<'static, str>,
    /// The distortion energy.
    pub energy: Cow<'static, str>,
    /// The initializer.
    pub initializer: Cow<'static, str>,
    /// The choices the initializer reported (`what -> which`).
    pub initializer_details: BTreeMap<Cow<'static, str>, Cow<'static, str>>,
    /// The line search.
    pub line_search: Cow<'static, str>,
    /// The solver.
    pub solver: Cow<'static, str>,
}

/// `canonical_frame` in the report (ALGORITHMS 2.10).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CanonicalReport {
    /// The template's symmetry the motion is drawn from.
    pub symmetry: TemplateSymmetry,
    /// The motion, optimized map -> canonical frame (`x' = rotation x +
    /// translation`; `centroid` is the mid-surface centre `c` moved to the
    /// origin).
    pub motion: TransformReport,
}

/// One entry of `images` in `report.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageReport {
    /// The image's name (as given in the input).
    pub name: String,
    /// Where the image was read from, when a caller that reads files says
    /// so (the command line: the path).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input: Option<String>,
    /// Where its template-space image was written, when a caller that
    /// writes files says so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    /// How the image was sampled: "linear" or "nearest".
    pub interpolation: Cow<'static, str>,
    /// Voxel size of the template grid, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub spacing_mm: [f64; 3],
    /// Voxels along x, y, z of the template grid.
    pub dims: [usize; 3],
    /// Frames (1 for a 3D image).
    pub frames: usize,
    /// Voxel-to-world affine of the template grid (template frame, mm),
    /// row-major.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub affine: [[f64; 4]; 4],
    /// Template voxels whose centre lies inside the flattened mesh.
    pub inside_mesh: usize,
    /// Of those, voxels whose source point lies inside the image.
    pub sampled: usize,
    /// Of those, voxels whose source point lies outside the image (0).
    pub outside_image: usize,
    /// Vertices of the flattened mesh outside the template grid (always 0
    /// for the grid covering the mesh; with a fixed `grid` box, the part of
    /// the placenta it cuts off).
    pub vertices_outside_grid: usize,
}
