//! `unfold ventricle ANATOMY` without `--surface`: the enclosing surface S
//! built from the anatomy ([`crate::organs::ventricle::enclosing`], ALGORITHMS
//! 3.9): voxelized at `--surface-voxel-mm`, dilated by
//! `--surface-margin-mm`, holes filled, its boundary extracted and smoothed
//! (`--surface-smoothing` Taubin iterations), cut at the basal plane. The
//! rest of the command then runs as with `--surface`; S is written as
//! `DIR/surface.vtu` and `report.json` says how it was built
//! (`enclosing_surface`).

use super::{AppError, organ, positive};
use crate::mesh::TriMesh;
use crate::mesh::nalgebra::Point3;
use crate::organs::ventricle::LandmarkPoints;
use crate::organs::ventricle::enclosing::{
    DEFAULT_MARGIN_MM, DEFAULT_SMOOTHING_ITERATIONS, DEFAULT_VOXEL_MM, Enclosing, EnclosingConfig,
    EnclosingReport, enclosing_surface,
};
use clap::Args;
use std::path::Path;

/// The file S is written to when it is built.
pub(crate) const SURFACE: &str = "surface.vtu";

/// The flags of the built S (refused next to `--surface`).
#[derive(Debug, Args)]
pub struct EnclosingArgs {
    /// Without --surface: the voxel size of the grid on which S is built
    /// from the anatomy, mm (the source paper's 0.5; coarser is faster and
    /// gives a coarser S).
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_VOXEL_MM,
          allow_negative_numbers = true, conflicts_with = "surface")]
    pub surface_voxel_mm: f64,
    /// Without --surface: how far S stays from the anatomy (the dilation),
    /// mm; more than sqrt(3) voxels.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_MARGIN_MM,
          allow_negative_numbers = true, conflicts_with = "surface")]
    pub surface_margin_mm: f64,
    /// Without --surface: Taubin smoothing iterations of the built S.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_SMOOTHING_ITERATIONS,
          conflicts_with = "surface")]
    pub surface_smoothing: usize,
}

/// S built from the anatomy.
#[derive(Debug, Clone)]
pub(crate) struct Built {
    /// S.
    pub surface: TriMesh,
    /// The rim landmarks carried onto S's rim (anterior, inferior).
    pub rim_landmarks: [Point3<f64>; 2],
    /// How it was built.
    pub report: EnclosingReport,
}

/// S built from `anatomy` (called `label` in messages) with the rim
/// landmarks (or RV insertion points) and apex of `given`, with
/// `voxel_mm` voxels, a `margin_mm` dilation and `smoothing` Taubin
/// iterations (the command line's and Python's one path; errors as the
/// command line words them).
///
/// # Errors
/// A usage error for a size that is not finite and positive; the
/// pipeline's error about `label` when S cannot be built.
pub fn build_from(
    anatomy: &crate::mesh::CellMesh,
    label: &str,
    given: &LandmarkPoints,
    voxel_mm: f64,
    margin_mm: f64,
    smoothing: usize,
) -> Result<Enclosing, AppError> {
    let config = EnclosingConfig {
        voxel_mm: positive("--surface-voxel-mm", voxel_mm)?,
        margin_mm: positive("--surface-margin-mm", margin_mm)?,
        smoothing_iterations: smoothing,
    };
    enclosing_surface(
        anatomy,
        [given.anterior, given.inferior],
        given.apex,
        &config,
    )
    .map_err(|e| organ(label, e))
}

/// Builds S from `anatomy` (named `anatomy_path`) with the rim landmarks
/// (or the RV insertion points) of `given` (an input inside DIR, which
/// `surface.vtu` could overwrite, is refused by the staging of the outputs
/// before).
pub(crate) fn build(
    args: &EnclosingArgs,
    anatomy: &crate::mesh::CellMesh,
    anatomy_path: &Path,
    given: &LandmarkPoints,
) -> Result<Built, AppError> {
    let label = anatomy_path.display().to_string();
    let e = build_from(
        anatomy,
        &label,
        given,
        args.surface_voxel_mm,
        args.surface_margin_mm,
        args.surface_smoothing,
    )?;
    let r = &e.report;
    println!(
        "{label}: built S from the anatomy ({}, {} mm voxels, {} mm dilation, {} smoothing \
         iterations, cut {:.2} mm above its highest point): {} vertices, {} triangles, \
         closest anatomy point {:.3} mm inside, {:.2} s",
        match r.anatomy {
            crate::organs::ventricle::enclosing::AnatomyKind::Tets => "tets",
            crate::organs::ventricle::enclosing::AnatomyKind::ClosedSurface => "closed surface",
            crate::organs::ventricle::enclosing::AnatomyKind::OpenSurface => "open surface",
        },
        r.voxel_mm,
        r.margin_mm,
        r.smoothing_iterations,
        r.cut_above_highest_mm,
        r.vertices,
        r.triangles,
        r.min_clearance_mm,
        r.seconds
    );
    Ok(Built {
        surface: e.surface,
        rim_landmarks: e.rim_landmarks,
        report: e.report,
    })
}
