//! The mitral valve's settings: every choice of a run other than its
//! files, with the command line's defaults, checked once into the
//! pipeline (the same checks and messages for the command line, Python and
//! manifests).

use crate::app::error::{AppError, positive};
use crate::organs::mitral::{AnnulusMode, Config, InitMode, LeafletLayout, Pipeline, RelaxMode};
use crate::param::energy::EnergyKind;
use serde::{Deserialize, Serialize};

/// A mitral run's settings; the names are the command line's flags
/// (`coaptation_mm` is `--coaptation-mm`, a manifest's `coaptation-mm`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// How the annulus is laid out.
    pub annulus_mode: AnnulusMode,
    /// The initial leaflet layout.
    pub init: InitMode,
    /// The relaxation.
    pub relax: RelaxMode,
    /// The distortion energy `D` of the flip-free relaxation (`sd`).
    pub energy: EnergyKind,
    /// Spring relaxation: the number of explicit steps.
    pub iterations: usize,
    /// Spring relaxation: the step scale (none: the library's).
    pub step_scale: Option<f64>,
    /// Coaptation threshold, mm (the zone: closer than this to the other
    /// leaflet).
    pub coaptation_mm: f64,
    /// Distance within which a leaflet boundary vertex lies on the ring, mm
    /// (none: the library's).
    pub tolerance_mm: Option<f64>,
    /// A second cut at the posteromedial commissure.
    pub cut_posteromedial: bool,
    /// Do not draw the figures.
    pub no_figures: bool,
    /// With `--seg`: the anterior leaflet's label in the label map.
    pub anterior_label: Option<i64>,
    /// With `--seg`: the posterior leaflet's label.
    pub posterior_label: Option<i64>,
    /// With `--seg`: the annulus' label, if the map has one.
    pub annulus_label: Option<i64>,
}

impl Default for Settings {
    /// The command line's defaults: landmark annulus, auto init, sd
    /// relaxation, 5 spring steps, coaptation 2 mm, figures drawn.
    fn default() -> Self {
        Settings {
            annulus_mode: AnnulusMode::Landmark,
            init: InitMode::Auto,
            relax: RelaxMode::Sd,
            energy: EnergyKind::SymmetricDirichlet,
            iterations: 5,
            step_scale: None,
            coaptation_mm: 2.0,
            tolerance_mm: None,
            cut_posteromedial: false,
            no_figures: false,
            anterior_label: None,
            posterior_label: None,
            annulus_label: None,
        }
    }
}

impl Settings {
    /// The pipeline of the settings, every setting checked: the layout
    /// mode as the initializer, the energy of the settings, the published
    /// pieces otherwise.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag out of range.
    pub fn pipeline(&self) -> Result<Pipeline, AppError> {
        let init = LeafletLayout { mode: self.init };
        Ok(Pipeline::new()
            .initializer(init)
            .energy(self.energy.build())
            .config(self.config()?))
    }

    /// The pipeline's configuration, every value checked with its flag's
    /// message.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag out of range, or the library's
    /// own check of the configuration.
    pub fn config(&self) -> Result<Config, AppError> {
        let mut c = Config {
            annulus_mode: self.annulus_mode,
            relax: self.relax,
            cut_posteromedial: self.cut_posteromedial,
            ..Config::default()
        };
        c.spring.iterations = self.iterations;
        if let Some(s) = self.step_scale {
            c.spring.step_scale = positive("--step-scale", s)?;
        }
        c.maps.coaptation_mm = positive("--coaptation-mm", self.coaptation_mm)?;
        if let Some(t) = self.tolerance_mm {
            c.tolerance_mm = positive("--tolerance-mm", t)?;
        }
        c.validate().map_err(|e| AppError::Usage(e.to_string()))?;
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_pass_their_checks() {
        let c = Settings::default().config().unwrap();
        assert_eq!(c.maps.coaptation_mm, 2.0);
        assert_eq!(c.spring.iterations, 5);
        assert_eq!(c.relax, RelaxMode::Sd);
    }

    #[test]
    fn names_are_the_flags() {
        let v = serde_json::to_value(Settings::default()).unwrap();
        for key in [
            "annulus-mode",
            "init",
            "relax",
            "step-scale",
            "coaptation-mm",
            "tolerance-mm",
            "cut-posteromedial",
            "no-figures",
            "anterior-label",
            "posterior-label",
            "annulus-label",
        ] {
            assert!(v.get(key).is_some(), "{key} missing from {v}");
        }
        let s: Settings = serde_json::from_value(
            serde_json::json!({"relax": "spring", "annulus-mode": "least-squares"}),
        )
        .unwrap();
        assert_eq!(s.relax, RelaxMode::Spring);
        assert_eq!(s.annulus_mode, AnnulusMode::LeastSquares);
        assert_eq!(s.coaptation_mm, 2.0);
    }

    #[test]
    fn bad_values_name_their_flags() {
        let bad = |s: Settings| s.pipeline().map(|_| ()).unwrap_err().to_string();
        assert_eq!(
            bad(Settings {
                coaptation_mm: 0.0,
                ..Settings::default()
            }),
            "--coaptation-mm must be a finite number > 0, got 0"
        );
        assert_eq!(
            bad(Settings {
                step_scale: Some(f64::NAN),
                ..Settings::default()
            }),
            "--step-scale must be a finite number > 0, got NaN"
        );
        assert_eq!(
            bad(Settings {
                tolerance_mm: Some(-1.0),
                ..Settings::default()
            }),
            "--tolerance-mm must be a finite number > 0, got -1"
        );
    }
}
