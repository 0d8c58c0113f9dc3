//! The flags of S built from the anatomy (`unfold ventricle` without
//! `--surface`; [`crate::app::ventricle::surface`] builds it).

use crate::app::ventricle::EnclosingSettings;
use crate::organs::ventricle::enclosing::{
    DEFAULT_MARGIN_MM, DEFAULT_SMOOTHING_ITERATIONS, DEFAULT_VOXEL_MM,
};
use clap::Args;

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

impl EnclosingArgs {
    /// The settings of the flags.
    pub(crate) fn settings(&self) -> EnclosingSettings {
        EnclosingSettings {
            surface_voxel_mm: self.surface_voxel_mm,
            surface_margin_mm: self.surface_margin_mm,
            surface_smoothing: self.surface_smoothing,
        }
    }
}
