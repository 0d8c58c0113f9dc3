//! `report.json` of one valve: the inputs' name, the library's [`Report`]
//! and the run's provenance; and the report's one-paragraph summary.

use crate::app::run::provenance::Provenance;
use crate::organs::mitral::Report;
use crate::organs::mitral::segmentation::SegmentationReport;
use serde::{Deserialize, Serialize};

/// `report.json`: `inputs`, then every key of the library's [`Report`]
/// (flattened), then `provenance`. The command line and Python write this
/// one type (Python's provenance has no command line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MitralReport {
    /// The inputs' names ([`super::inputs::ValveFiles::label`], or what the caller
    /// calls the valve).
    pub inputs: String,
    /// The library's report.
    #[serde(flatten)]
    pub report: Report,
    /// How the leaflets were cut from a label map (`--seg`; absent
    /// otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<SegmentationReport>,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: Provenance,
}

impl MitralReport {
    /// The report as indented JSON, ending in a newline.
    ///
    /// # Errors
    /// `serde_json`'s (a non-finite number where JSON has none is written as
    /// `null`, so in practice none).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self).map(|json| format!("{json}\n"))
    }
}

/// A one-paragraph summary of a report: the annulus, the leaflets, the
/// relaxation's energies, flips, coaptation and time (the line the command
/// line prints for a valve and for each step of a series).
pub fn summary(r: &Report) -> String {
    format!(
        "annulus {:.1} mm (u extent {:.1} mm), saddle horn {:.2} mm, leaflets {:.0} + {:.0} mm^2 \
         ({:.0} mm^2 above the annulus plane); relax {} from {}/{}: mean energies area {:.3} -> \
         {:.3}, angle {:.3} -> {:.3}, length {:.3} -> {:.3}; {} flipped triangles; coaptation \
         {} vertices; {:.3} s",
        r.annulus_length_mm,
        r.u_extent_mm,
        r.saddle_horn_height_mm,
        r.leaflet_area_mm2.anterior,
        r.leaflet_area_mm2.posterior,
        r.area_above_plane_mm2,
        r.relax,
        r.init[0],
        r.init[1],
        r.distortion.initial.area,
        r.distortion.r#final.area,
        r.distortion.initial.angle,
        r.distortion.r#final.angle,
        r.distortion.initial.length,
        r.distortion.r#final.length,
        r.flipped_triangles,
        r.coaptation_vertices.within,
        r.seconds
    )
}
