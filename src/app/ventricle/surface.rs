//! A ventricle run without a surface file: the enclosing surface S built
//! from the anatomy ([`crate::organs::ventricle::enclosing`], ALGORITHMS
//! 3.9): voxelized at `surface_voxel_mm`, dilated by `surface_margin_mm`,
//! holes filled, its boundary extracted and smoothed (`surface_smoothing`
//! Taubin iterations), cut at the basal plane. The rest of the run is as
//! with a surface file; S is written as `DIR/surface.vtu` and
//! `report.json` says how it was built (`enclosing_surface`).

use crate::app::error::{AppError, organ, positive};
use crate::app::observer::Observer;
use crate::mesh::CellMesh;
use crate::organs::ventricle::LandmarkPoints;
use crate::organs::ventricle::enclosing::{
    AnatomyKind, DEFAULT_MARGIN_MM, DEFAULT_SMOOTHING_ITERATIONS, DEFAULT_VOXEL_MM, Enclosing,
    EnclosingConfig, enclosing_surface,
};
use serde::{Deserialize, Serialize};

/// The file S is written to when it is built.
pub const SURFACE: &str = "surface.vtu";

/// How S is built from the anatomy; the names are the flags'.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct EnclosingSettings {
    /// Voxel size of the grid on which S is built, mm.
    pub surface_voxel_mm: f64,
    /// How far S stays from the anatomy (the dilation), mm.
    pub surface_margin_mm: f64,
    /// Taubin smoothing iterations of the built S.
    pub surface_smoothing: usize,
}

impl Default for EnclosingSettings {
    /// The source paper's 0.5 mm voxels and the library's margin and
    /// smoothing.
    fn default() -> Self {
        EnclosingSettings {
            surface_voxel_mm: DEFAULT_VOXEL_MM,
            surface_margin_mm: DEFAULT_MARGIN_MM,
            surface_smoothing: DEFAULT_SMOOTHING_ITERATIONS,
        }
    }
}

/// S built from `anatomy` (called `label` in messages) with the rim
/// landmarks (or RV insertion points) and apex of `given` (the command
/// line's and Python's one path; errors as the command line words them).
///
/// # Errors
/// A usage error for a size that is not finite and positive; the
/// pipeline's error about `label` when S cannot be built.
pub fn build_from(
    anatomy: &CellMesh,
    label: &str,
    given: &LandmarkPoints,
    settings: &EnclosingSettings,
) -> Result<Enclosing, AppError> {
    let config = EnclosingConfig {
        voxel_mm: positive("--surface-voxel-mm", settings.surface_voxel_mm)?,
        margin_mm: positive("--surface-margin-mm", settings.surface_margin_mm)?,
        smoothing_iterations: settings.surface_smoothing,
    };
    enclosing_surface(
        anatomy,
        [given.anterior, given.inferior],
        given.apex,
        &config,
    )
    .map_err(|e| organ(label, e))
}

/// [`build_from`], and a line on S (its size, how it was built) to
/// `observer` as a result (the command line prints it on stdout).
///
/// # Errors
/// [`build_from`]'s.
pub fn build(
    settings: &EnclosingSettings,
    anatomy: &CellMesh,
    label: &str,
    given: &LandmarkPoints,
    observer: &mut dyn Observer,
) -> Result<Enclosing, AppError> {
    let e = build_from(anatomy, label, given, settings)?;
    let r = &e.report;
    observer.info(&format!(
        "{label}: built S from the anatomy ({}, {} mm voxels, {} mm dilation, {} smoothing \
         iterations, cut {:.2} mm above its highest point): {} vertices, {} triangles, \
         closest anatomy point {:.3} mm inside, {:.2} s",
        match r.anatomy {
            AnatomyKind::Tets => "tets",
            AnatomyKind::ClosedSurface => "closed surface",
            AnatomyKind::OpenSurface => "open surface",
        },
        r.voxel_mm,
        r.margin_mm,
        r.smoothing_iterations,
        r.cut_above_highest_mm,
        r.vertices,
        r.triangles,
        r.min_clearance_mm,
        r.seconds
    ));
    Ok(e)
}
