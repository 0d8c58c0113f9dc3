//! The template's fetal and maternal levels (`z`, mm), from the report's
//! parameters or the flattened mesh.

use unfold_render::format_value;

use super::meshes::Meshes;
use super::numbers::signed;
use crate::organs::placenta::Outcome;

/// The template's fetal and maternal `z` (top, bottom), mm.
pub(super) struct Depths {
    pub(super) top: f64,
    pub(super) bottom: f64,
    /// How they were found, for captions (`h = 12.5 mm`).
    pub(super) label: String,
    /// Short names of the two levels (`+h`, `-h`).
    pub(super) names: [&'static str; 2],
}

impl Depths {
    pub(super) fn z(&self, fraction: f64) -> f64 {
        0.5 * (self.top + self.bottom) + fraction * 0.5 * (self.top - self.bottom)
    }

    /// `fetal side: z = +9.67 mm (+h)`-style descriptions of the two
    /// levels.
    pub(super) fn describe(&self) -> [String; 2] {
        [
            format!(
                "fetal side: z = {} mm ({})",
                signed(self.top),
                self.names[0]
            ),
            format!(
                "maternal side: z = {} mm ({})",
                signed(self.bottom),
                self.names[1]
            ),
        ]
    }
}

/// `z = +-h` for the planes, `+-rz` for the ellipsoid, `-h` and the mean
/// fetal `z` for the single plane; the flattened mesh's `z` range when the
/// report's parameters are missing or unusable.
pub(super) fn depth_range(outcome: &Outcome, m: &Meshes<'_>) -> Depths {
    let theta = &outcome.report.theta;
    let good = |v: Option<&f64>| v.copied().filter(|x| x.is_finite() && *x > 0.0);
    let fetal_mean = || {
        let labels = m.labels.as_ref()?;
        let z: Vec<f64> = labels
            .iter()
            .zip(m.flattened)
            .filter(|(l, _)| **l == 1)
            .map(|(_, p)| p.z)
            .collect();
        (!z.is_empty()).then(|| z.iter().sum::<f64>() / z.len() as f64)
    };
    match outcome.report.template.as_ref() {
        "ellipsoid" => {
            if let Some(rz) = good(theta.get("rz")) {
                return Depths {
                    top: rz,
                    bottom: -rz,
                    label: format!("rz = {} mm", format_value(rz)),
                    names: ["+rz", "-rz"],
                };
            }
        }
        "single-plane" => {
            if let Some(h) = good(theta.get("h")) {
                let top = fetal_mean().filter(|t| *t > -h).unwrap_or(h);
                return Depths {
                    top,
                    bottom: -h,
                    label: format!("h = {} mm", format_value(h)),
                    names: ["fetal", "-h"],
                };
            }
        }
        _ => {
            if let Some(h) = good(theta.get("h")) {
                return Depths {
                    top: h,
                    bottom: -h,
                    label: format!("h = {} mm", format_value(h)),
                    names: ["+h", "-h"],
                };
            }
        }
    }
    let (lo, hi) = m
        .flattened
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.z), hi.max(p.z))
        });
    Depths {
        top: hi,
        bottom: lo,
        label: "the mesh's z range".into(),
        names: ["top", "bottom"],
    }
}
