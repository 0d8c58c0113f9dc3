//! The ventricle's settings: every choice of a run other than its files
//! and landmarks, with the command line's defaults, checked once into the
//! pipeline's [`Config`] (the same checks and messages for the command
//! line, Python and manifests).

use super::grid_sweep::check_grids;
use super::layers::check_layers;
use super::surface::EnclosingSettings;
use crate::app::error::{AppError, positive};
use crate::app::run::frame::MeshFrame;
use crate::organs::ventricle::field::{DEFAULT_GRID_MM, DEFAULT_HEMISPHERE_MM, FieldConfig};
use crate::organs::ventricle::landmarks::DEFAULT_SNAP_MM;
use crate::organs::ventricle::{Chamber, ChartConfig, Config};
use serde::{Deserialize, Serialize};

/// The settings of a heart's chart (`unfold ventricle` and `unfold
/// ventricle-inverse` alike); the names are the flags'.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct ChartSettings {
    /// The chamber S encloses.
    pub chamber: Chamber,
    /// Grid spacing of the Laplace field, mm.
    pub grid_mm: f64,
    /// Radius of the hemisphere H at the centre of the base, mm.
    pub hemisphere_mm: f64,
    /// Display exponent `n` of the LV disk, `r' = r^n` (none: 1/3).
    pub display_exponent: Option<f64>,
    /// Largest distance from a given rim landmark to the rim of S, mm.
    pub snap_mm: f64,
}

impl Default for ChartSettings {
    /// The LV, the library's grid, hemisphere and snap distance.
    fn default() -> Self {
        ChartSettings {
            chamber: Chamber::Lv,
            grid_mm: DEFAULT_GRID_MM,
            hemisphere_mm: DEFAULT_HEMISPHERE_MM,
            display_exponent: None,
            snap_mm: DEFAULT_SNAP_MM,
        }
    }
}

impl ChartSettings {
    /// The pipeline's configuration, every value checked: `chamber`,
    /// `--grid-mm`, `--hemisphere-mm`, `--display-exponent` (none: 1/3),
    /// `--snap-mm`.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag that is not a finite number > 0.
    pub fn config(&self) -> Result<Config, AppError> {
        let defaults = Config::default();
        let display_exponent = match self.display_exponent {
            Some(n) => positive("--display-exponent", n)?,
            None => defaults.display_exponent,
        };
        Ok(Config {
            chart: ChartConfig {
                chamber: self.chamber,
                field: FieldConfig {
                    grid_mm: positive("--grid-mm", self.grid_mm)?,
                    hemisphere_mm: positive("--hemisphere-mm", self.hemisphere_mm)?,
                    ..defaults.chart.field
                },
                snap_mm: positive("--snap-mm", self.snap_mm)?,
                ..defaults.chart
            },
            display_exponent,
        })
    }
}

/// An `unfold ventricle` run's settings; the names are the command line's
/// flags (`grid_sweep` is `--grid-sweep`, a manifest's `grid-sweep`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// The chart: chamber, grid, hemisphere, display exponent, snap
    /// distance.
    #[serde(flatten)]
    pub chart: ChartSettings,
    /// Do not draw the figures.
    pub no_figures: bool,
    /// A point array of the anatomy shown on the bull's-eye (LV), as its
    /// mean per AHA segment (none: the depth).
    pub bullseye_array: Option<String>,
    /// Label this many transmural layers of equal depth
    /// ([`super::layers::transmural_layers`]).
    pub layers: Option<u32>,
    /// Landmark sensitivity: the displacement to test, mm
    /// ([`super::sensitivity`]).
    pub sensitivity: Option<f64>,
    /// Also run the pipeline on each of these grid spacings, mm
    /// ([`super::grid_sweep`]).
    pub grid_sweep: Vec<f64>,
    /// The frame of the mesh files' coordinates.
    pub mesh_frame: MeshFrame,
    /// Transfer the anatomy onto a hemisphere of this radius, mm.
    pub to_hemisphere: Option<f64>,
    /// Building S from the anatomy (without a surface file).
    #[serde(flatten)]
    pub enclosing: EnclosingSettings,
}

impl Default for Settings {
    /// The command line's defaults: the LV at the library's grid, no
    /// layers, no sensitivity, no sweep, figures drawn.
    fn default() -> Self {
        Settings {
            chart: ChartSettings::default(),
            no_figures: false,
            bullseye_array: None,
            layers: None,
            sensitivity: None,
            grid_sweep: Vec::new(),
            mesh_frame: MeshFrame::Auto,
            to_hemisphere: None,
            enclosing: EnclosingSettings::default(),
        }
    }
}

impl Settings {
    /// Every setting checked before any file is read (the chart's, then
    /// `--sensitivity`, `--grid-sweep` and `--layers`); returns the
    /// pipeline's configuration. `--to-hemisphere` and the built S's sizes
    /// are checked where they are used, as the command line always did.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag.
    pub fn validate(&self) -> Result<Config, AppError> {
        let config = self.chart.config()?;
        if let Some(mm) = self.sensitivity {
            positive("--sensitivity", mm)?;
        }
        check_grids(&self.grid_sweep)?;
        check_layers(self.layers.map(i64::from))?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_the_library_s_and_pass_their_checks() {
        let config = Settings::default().validate().unwrap();
        assert_eq!(config, Config::default());
    }

    #[test]
    fn names_are_the_flags() {
        let v = serde_json::to_value(Settings::default()).unwrap();
        for key in [
            "chamber",
            "grid-mm",
            "hemisphere-mm",
            "display-exponent",
            "snap-mm",
            "grid-sweep",
            "bullseye-array",
            "mesh-frame",
            "surface-voxel-mm",
            "surface-margin-mm",
            "surface-smoothing",
            "to-hemisphere",
        ] {
            assert!(v.get(key).is_some(), "{key} missing from {v}");
        }
        let s: Settings =
            serde_json::from_value(serde_json::json!({"chamber": "rv", "grid-mm": 2.0})).unwrap();
        assert_eq!(s.chart.chamber, Chamber::Rv);
        assert_eq!(s.chart.grid_mm, 2.0);
        assert_eq!(s.chart.snap_mm, DEFAULT_SNAP_MM);
    }

    #[test]
    fn bad_values_name_their_flags() {
        let bad = |s: Settings| s.validate().unwrap_err().to_string();
        let mut s = Settings::default();
        s.chart.grid_mm = 0.0;
        assert_eq!(bad(s), "--grid-mm must be a finite number > 0, got 0");
        let mut s = Settings::default();
        s.chart.display_exponent = Some(-1.0);
        assert_eq!(
            bad(s),
            "--display-exponent must be a finite number > 0, got -1"
        );
        let s = Settings {
            sensitivity: Some(f64::NAN),
            ..Settings::default()
        };
        assert_eq!(bad(s), "--sensitivity must be a finite number > 0, got NaN");
        let s = Settings {
            grid_sweep: vec![1.0, 1.0],
            ..Settings::default()
        };
        assert!(bad(s).contains("lists 1 twice"));
        let s = Settings {
            layers: Some(0),
            ..Settings::default()
        };
        assert_eq!(bad(s), "--layers must be between 1 and 100, got 0");
    }
}
