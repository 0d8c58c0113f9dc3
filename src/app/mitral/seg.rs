//! One valve from a label map (`unfold mitral --seg LABELS --anterior-label
//! A --posterior-label P [--annulus-label N]`, Python's `unfold.mitral(seg=
//! ...)`): the map read (NIfTI or NRRD, any voxel size and affine, mm in
//! its world frame) within the memory budget, both leaflets' atrial
//! surfaces and the annulus ring cut from it
//! ([`crate::organs::mitral::segmentation::valve_from_labels`]), then the
//! usual pipeline. `report.json` gets `segmentation`: the labels, their
//! voxels, the grid, the atrial side, the surfaces' sizes and the cut's
//! gates.

use super::inputs::Inputs;
use super::settings::Settings;
use crate::app::error::{AppError, about, at, organ};
use crate::app::run::files::read_image_checked;
use crate::mesh::Volume;
use crate::organs::mitral::segmentation::{
    LeafletLabels, SegmentationReport, SegmentedValve, valve_from_labels,
};
use std::path::{Path, PathBuf};

/// A valve's label map.
#[derive(Debug, Clone, PartialEq)]
pub struct SegFiles {
    /// The label map.
    pub seg: PathBuf,
}

impl SegFiles {
    /// The label map, naming the inputs in errors and reports.
    pub fn label(&self) -> String {
        format!("{} (label map)", self.seg.display())
    }
}

/// The labels of `settings`: `--anterior-label` and `--posterior-label`
/// must be given (`--annulus-label` may be).
///
/// # Errors
/// [`AppError::Usage`] naming the missing flag.
pub fn labels_of(settings: &Settings) -> Result<LeafletLabels, AppError> {
    match (settings.anterior_label, settings.posterior_label) {
        (Some(anterior), Some(posterior)) => Ok(LeafletLabels {
            anterior,
            posterior,
            annulus: settings.annulus_label,
        }),
        _ => Err(AppError::Usage(
            "--seg needs the leaflets' labels: give --anterior-label A --posterior-label P (and \
             --annulus-label N if the map labels the annulus)"
                .into(),
        )),
    }
}

/// Refuses the label flags without `--seg` (they would be ignored).
///
/// # Errors
/// [`AppError::Usage`] naming the flag.
pub fn check_no_labels(settings: &Settings) -> Result<(), AppError> {
    for (flag, v) in [
        ("--anterior-label", settings.anterior_label),
        ("--posterior-label", settings.posterior_label),
        ("--annulus-label", settings.annulus_label),
    ] {
        if v.is_some() {
            return Err(AppError::Usage(format!(
                "{flag} is for a label map: give --seg LABELS with it, or leave it out"
            )));
        }
    }
    Ok(())
}

/// Cuts the valve from the label map `labels` (named `label` in messages)
/// with the labels of `settings` into the pipeline's [`Inputs`] and the
/// report's `segmentation`.
///
/// # Errors
/// Missing label flags, and the cut's errors about `label`.
pub fn inputs_from_labels(
    labels: &Volume<f32>,
    label: String,
    settings: &Settings,
) -> Result<(Inputs, SegmentationReport), AppError> {
    let which = labels_of(settings)?;
    let SegmentedValve {
        anterior,
        posterior,
        ring,
        report,
    } = valve_from_labels(labels, which, None).map_err(|e| organ(&label, e))?;
    Ok((
        Inputs {
            label,
            anterior,
            posterior,
            ring,
        },
        report,
    ))
}

/// Reads the label map of `files` (within the memory budget: its values and
/// a byte per voxel) and cuts the valve from it ([`inputs_from_labels`]);
/// `label` names it in messages and the report.
///
/// # Errors
/// Reading the image, and [`inputs_from_labels`]'s.
pub fn read_seg(
    files: &SegFiles,
    label: String,
    settings: &Settings,
) -> Result<(Inputs, SegmentationReport), AppError> {
    labels_of(settings)?;
    let image = read_image_checked(&files.seg, 1.0)?;
    inputs_from_labels(&image.volume, label, settings)
}

/// The image file extensions: a leaflet given as one is refused with the
/// `--seg` route.
pub fn is_image_path(path: &Path) -> bool {
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    [".nii", ".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd"]
        .iter()
        .any(|e| name.ends_with(e))
}

/// The route from a label map, for refusals of inputs that are not leaflet
/// surfaces.
pub const SEG_ROUTE: &str = "from a label map, give --seg LABELS --anterior-label A \
                             --posterior-label P (and --annulus-label N)";

/// Refuses a leaflet file that is an image, naming the `--seg` route.
///
/// # Errors
/// [`AppError::Usage`] at `path`.
pub fn refuse_image(path: &Path) -> Result<(), AppError> {
    if is_image_path(path) {
        return Err(at(
            path,
            format!("is an image, not a leaflet surface; {SEG_ROUTE}"),
        ));
    }
    Ok(())
}

/// A leaflet surface with no boundary (a closed surface, such as a
/// leaflet's label meshed whole) refused with the `--seg` route, named
/// `label`.
///
/// # Errors
/// [`AppError::Usage`] about `label`.
pub fn refuse_closed(mesh: &crate::mesh::TriMesh, label: &str) -> Result<(), AppError> {
    let loops = crate::mesh::topology::boundary_loops(mesh)
        .map(|l| l.len())
        .unwrap_or(1);
    if loops == 0 && mesh.num_triangles() > 0 {
        return Err(about(
            label,
            format!(
                "is a closed surface; a leaflet is an open surface (its atrial side, with the \
                 annulus and the free edge as its boundary); {SEG_ROUTE}"
            ),
        ));
    }
    Ok(())
}

/// One valve from its label map to its outputs: read and cut
/// ([`read_seg`]), run ([`super::run_with`]), `segmentation` put into the
/// report, written into `out.dir` ([`super::write()`], the figures with
/// `figures`).
///
/// # Errors
/// Reading, cutting, running or writing.
pub fn run_seg(
    files: &SegFiles,
    settings: &Settings,
    pipeline: &crate::organs::mitral::Pipeline,
    out: &super::Outputs<'_>,
    figures: bool,
    observer: &mut dyn crate::app::observer::Observer,
) -> Result<super::Run, AppError> {
    let shown = SegFiles {
        seg: out.staged.shown(&files.seg),
    };
    observer.stage("mitral: the leaflets cut from the label map");
    let (inputs, segmentation) = read_seg(files, shown.label(), settings)?;
    let mut run = super::run_with(pipeline, &inputs, observer)?;
    run.report.segmentation = Some(segmentation);
    super::write(&run, out, figures)?;
    Ok(run)
}
