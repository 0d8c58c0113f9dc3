//! The settings of `ventricle-inverse`: where the coordinates come from,
//! the target heart's chart (as `unfold ventricle`'s) and the layers;
//! checked once into the chart's [`Config`].

use super::coordinates::Coordinates;
use crate::app::AppError;
use crate::app::run::frame::MeshFrame;
use crate::app::ventricle::layers::check_layers;
use crate::app::ventricle::settings::ChartSettings;
use crate::organs::ventricle::Config;
use serde::{Deserialize, Serialize};

/// A `ventricle-inverse` run's settings; the names are the command line's
/// flags.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// Where the cylinder coordinates of the mesh's points come from.
    pub coordinates: Coordinates,
    /// The frame of S's coordinates (the mesh in cylinder coordinates is
    /// not converted).
    pub mesh_frame: MeshFrame,
    /// The target heart's chart: chamber, grid, hemisphere, display
    /// exponent (inverted for coordinates read from the points), snap
    /// distance.
    #[serde(flatten)]
    pub chart: ChartSettings,
    /// Label this many transmural layers (0 for a point not mapped).
    pub layers: Option<u32>,
}

impl Settings {
    /// Every setting checked before any file is read (the chart's, then
    /// `--layers`); returns the chart's configuration.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag.
    pub fn validate(&self) -> Result<Config, AppError> {
        let config = self.chart.config()?;
        check_layers(self.layers.map(i64::from))?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_flags_and_the_defaults_pass() {
        let s = Settings::default();
        assert_eq!(s.validate().unwrap(), Config::default());
        let v = serde_json::to_value(&s).unwrap();
        for key in ["coordinates", "mesh-frame", "grid-mm", "snap-mm", "layers"] {
            assert!(v.get(key).is_some(), "{key} missing from {v}");
        }
        let s: Settings =
            serde_json::from_value(serde_json::json!({"coordinates": "points"})).unwrap();
        assert_eq!(s.coordinates, Coordinates::Points);
    }
}
