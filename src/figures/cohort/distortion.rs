//! The placenta paper's Fig. 7: box-and-whisker plots of (a) the local
//! volumetric distortion (mean `log2 det J`) and (b) the metric distortion
//! (mean `log2 x_ij / z_ij`, the edge-length ratio) of the subjects, one
//! box per template.

use super::axes::check_panel;
use super::box_plot::{BoxGroup, BoxPanel, box_panel};
use crate::figures::layout::compose;
use crate::figures::{Figure, FigureError, FigureOptions};

/// File name of the figure.
pub const DISTORTION_PNG: &str = "placenta_distortion.png";

/// One placenta subject's distortions.
#[derive(Debug, Clone, PartialEq)]
pub struct SubjectDistortion {
    /// The template it was mapped to (`planes`, ...).
    pub template: String,
    /// Mean over its tets of `log2 det J` (report `log2_det_j.mean`).
    pub log2_det_j: f64,
    /// Mean over its edges of `log2 x_ij / z_ij` (report
    /// `log2_edge_ratio.mean`).
    pub log2_edge_ratio: f64,
}

/// [`DISTORTION_PNG`] (2 x 1 panels): per template, in sorted order, the
/// box plots of the subjects' mean `log2 det J` (left) and mean `log2
/// x_ij/z_ij` (right).
///
/// # Errors
/// [`FigureError::Input`] for no subject or a panel too small; the
/// renderer's.
pub fn placenta_distortion(
    subjects: &[SubjectDistortion],
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = DISTORTION_PNG;
    check_panel(F, opts)?;
    if subjects.is_empty() {
        return Err(FigureError::input(F, "no placenta subject"));
    }
    let mut templates: Vec<&str> = subjects.iter().map(|s| s.template.as_str()).collect();
    templates.sort_unstable();
    templates.dedup();
    let groups = |get: fn(&SubjectDistortion) -> f64| -> Vec<BoxGroup> {
        templates
            .iter()
            .map(|t| BoxGroup {
                label: (*t).to_string(),
                values: subjects
                    .iter()
                    .filter(|s| s.template == *t)
                    .map(get)
                    .collect(),
            })
            .collect()
    };
    let n = subjects.len();
    let panels = [
        BoxPanel {
            title: "(a) volumetric distortion".into(),
            subtitle: format!(
                "per template, the mean of log2 det J of each of {n} placentas; red crosses: \
                 beyond 1.5 IQR"
            ),
            y_label: "mean log2 det J".into(),
            groups: groups(|s| s.log2_det_j),
        },
        BoxPanel {
            title: "(b) metric distortion".into(),
            subtitle: format!(
                "per template, the mean of log2 x_ij/z_ij (edge lengths) of each of {n} \
                 placentas"
            ),
            y_label: "mean log2 x_ij/z_ij".into(),
            groups: groups(|s| s.log2_edge_ratio),
        },
    ];
    let imgs = panels
        .iter()
        .map(|p| box_panel(p, opts))
        .collect::<Result<Vec<_>, _>>()
        .map_err(FigureError::render(F))?;
    let img = compose(&imgs, 2, opts).map_err(FigureError::render(F))?;
    Ok(Figure::new(F, img))
}
