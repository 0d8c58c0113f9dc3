//! The mitral valves' distortion energies, open (diastolic) against closed
//! (systolic) valves, as in the mitral thesis: box plots of the area,
//! angle and length energies of the flat maps, one box per phase.

use super::axes::check_panel;
use super::box_plot::{BoxGroup, BoxPanel, box_panel};
use crate::figures::layout::compose;
use crate::figures::{Figure, FigureError, FigureOptions};

/// File name of the figure.
pub const ENERGIES_PNG: &str = "mitral_energies.png";

/// One valve's energies (the report's `distortion.final`).
#[derive(Debug, Clone, PartialEq)]
pub struct ValveEnergies {
    /// Its phase (`open`, `closed`, ...): the `phase` covariate.
    pub phase: String,
    /// Area energy.
    pub area: f64,
    /// Angle energy (MIPS).
    pub angle: f64,
    /// Length energy.
    pub length: f64,
}

/// [`ENERGIES_PNG`] (3 x 1 panels: area, angle, length): one box per phase,
/// `open` first, `closed` second, any other phase after them in sorted
/// order.
///
/// # Errors
/// [`FigureError::Input`] for no valve or a panel too small; the
/// renderer's.
pub fn mitral_energies(
    valves: &[ValveEnergies],
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = ENERGIES_PNG;
    check_panel(F, opts)?;
    if valves.is_empty() {
        return Err(FigureError::input(F, "no valve with a phase"));
    }
    let mut phases: Vec<&str> = valves.iter().map(|v| v.phase.as_str()).collect();
    let rank = |p: &str| match p {
        "open" => 0,
        "closed" => 1,
        _ => 2,
    };
    phases.sort_unstable_by(|a, b| rank(a).cmp(&rank(b)).then(a.cmp(b)));
    phases.dedup();
    let groups = |get: fn(&ValveEnergies) -> f64| -> Vec<BoxGroup> {
        phases
            .iter()
            .map(|p| BoxGroup {
                label: (*p).to_string(),
                values: valves.iter().filter(|v| v.phase == *p).map(get).collect(),
            })
            .collect()
    };
    let n = valves.len();
    let panel = |title: &str, label: &str, get: fn(&ValveEnergies) -> f64| BoxPanel {
        title: title.to_string(),
        subtitle: format!("{n} valves by phase; 2 is an undistorted map"),
        y_label: label.to_string(),
        groups: groups(get),
    };
    let panels = [
        panel("area energy", "area_energy", |v| v.area),
        panel("angle energy", "angle_energy (MIPS)", |v| v.angle),
        panel("length energy", "length_energy", |v| v.length),
    ];
    let imgs = panels
        .iter()
        .map(|p| box_panel(p, opts))
        .collect::<Result<Vec<_>, _>>()
        .map_err(FigureError::render(F))?;
    let img = compose(&imgs, 3, opts).map_err(FigureError::render(F))?;
    Ok(Figure::new(F, img))
}
