//! The placenta's settings: every choice of a run other than its files,
//! with the published defaults, checked once into the pipeline's
//! [`Config`] and pieces (the same checks and messages for the command
//! line, Python and manifests).

use crate::app::error::{AppError, positive};
use crate::app::mesh::mask::MaskSettings;
use crate::app::run::frame::MeshFrame;
use crate::organs::placenta::parcellation::{DEFAULT_MARGIN_VOXELS, ParcellationConfig};
use crate::organs::placenta::{
    Config, GridBox, Held, Interpolation, Pipeline, PlacentaTemplate, TemplateKind,
};
use crate::param::energy::EnergyKind;
use crate::param::solver::SolverKind;
use serde::{Deserialize, Serialize};

/// A placenta run's settings; the names are the command line's flags
/// (`lambda_sweep` is `--lambda-sweep`, a manifest's `lambda-sweep`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// The template the mesh is flattened onto.
    pub template: TemplateKind,
    /// The optimizer.
    pub solver: SolverKind,
    /// The distortion energy `D`.
    pub energy: EnergyKind,
    /// Weight lambda of the distortion term.
    pub lambda: f64,
    /// Also flatten with each of these weights (the trade-off curve).
    pub lambda_sweep: Vec<f64>,
    /// Hold the half thickness `h` at this value, mm (planes and single
    /// plane).
    pub fix_h: Option<f64>,
    /// Half-width of the margin to start from, mm (none: five voxels of
    /// `voxel_mm`).
    pub margin_mm: Option<f64>,
    /// Sharpness `gamma` of the parcellation's affinity.
    pub gamma: f64,
    /// Ring size of the affinity's neighbourhood (1 to 6).
    pub rings: usize,
    /// Voxel size of the acquisition, mm (none: the mask's mean spacing
    /// with a segmentation, else 3).
    pub voxel_mm: Option<f64>,
    /// Stop when the gradient norm falls below this.
    pub tol: f64,
    /// Iteration limit per optimization stage (none: the solver's).
    pub max_iterations: Option<usize>,
    /// Isotropic voxel size of the template-space images, mm (none: each
    /// image's own).
    pub spacing_mm: Option<f64>,
    /// A fixed template-frame box for the images,
    /// `[xmin, xmax, ymin, ymax, zmin, zmax]`, mm.
    pub grid: Option<[f64; 6]>,
    /// How images are sampled.
    pub interp: Interpolation,
    /// Skip the check that the mesh lies in each image's foreground.
    pub no_frame_check: bool,
    /// The frame of the mesh file's coordinates.
    pub mesh_frame: MeshFrame,
    /// Do not draw the figures.
    pub no_figures: bool,
    /// With a segmentation: mesh it uniformly at the voxel size (or
    /// `size_mm`) instead of graded at a size chosen from its volume.
    pub dense: bool,
    /// With a segmentation: how it is meshed.
    #[serde(flatten)]
    pub mask: MaskSettings,
}

impl Default for Settings {
    /// The published method: planes, projected Newton, symmetric Dirichlet,
    /// lambda 1, gamma 20,
    /// 3-rings, gradient tolerance 1e-4, linear interpolation.
    fn default() -> Self {
        Settings {
            template: TemplateKind::Planes,
            solver: SolverKind::Newton,
            energy: EnergyKind::SymmetricDirichlet,
            lambda: 1.0,
            lambda_sweep: Vec::new(),
            fix_h: None,
            margin_mm: None,
            gamma: 20.0,
            rings: 3,
            voxel_mm: None,
            tol: 1e-4,
            max_iterations: None,
            spacing_mm: None,
            grid: None,
            interp: Interpolation::Linear,
            no_frame_check: false,
            mesh_frame: MeshFrame::Auto,
            no_figures: false,
            dense: false,
            mask: MaskSettings::default(),
        }
    }
}

/// `--voxel-mm` without a segmentation.
pub const DEFAULT_VOXEL_MM: f64 = 3.0;

impl Settings {
    /// Every setting checked, before any file is read: the pipeline's
    /// configuration and pieces, the sweep's weights, and with a
    /// segmentation (`seg`) the mesher's options; without one, the mask
    /// settings must be their defaults.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag.
    pub fn validate(&self, seg: bool) -> Result<(), AppError> {
        if !seg && (!self.mask.is_default() || self.dense) {
            return Err(AppError::Usage(
                "--size-mm, --smooth-voxels, --dilate, --threshold, --label, --level, --grade and \
                 --dense apply to --seg"
                    .into(),
            ));
        }
        self.config(DEFAULT_VOXEL_MM, None)?;
        self.pipeline(Config::default())?;
        for &l in &self.lambda_sweep {
            positive("--lambda-sweep", l)?;
        }
        if seg {
            self.mask.options(false)?;
        }
        Ok(())
    }

    /// The pipeline's configuration, every value checked with its flag's
    /// message; `voxel_mm` is the default of `voxel_mm` (the mask's, or
    /// [`DEFAULT_VOXEL_MM`]), `half_thickness_mm` the segmentation's, if
    /// any.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag.
    pub fn config(
        &self,
        voxel_mm: f64,
        half_thickness_mm: Option<f64>,
    ) -> Result<Config, AppError> {
        let lambda = positive("--lambda", self.lambda)?;
        let voxel_mm = positive("--voxel-mm", self.voxel_mm.unwrap_or(voxel_mm))?;
        let gamma = positive("--gamma", self.gamma)?;
        if !(1..=6).contains(&self.rings) {
            return Err(AppError::Usage(format!(
                "--rings must be 1 to 6, got {}",
                self.rings
            )));
        }
        let margin_mm = match self.margin_mm {
            Some(m) => positive("--margin-mm", m)?,
            None => DEFAULT_MARGIN_VOXELS * voxel_mm,
        };
        let grad_tol = positive("--tol", self.tol)?;
        if let Some(s) = self.spacing_mm {
            positive("--spacing-mm", s)?;
        }
        if self.max_iterations == Some(0) {
            return Err(AppError::Usage(
                "--max-iterations must be at least 1".into(),
            ));
        }
        let config = Config {
            lambda,
            grad_tol,
            max_iterations: self.max_iterations,
            max_seconds: None,
            parcellation: ParcellationConfig {
                gamma,
                rings: self.rings,
                margin_mm,
                voxel_mm,
                ..ParcellationConfig::default()
            },
            half_thickness_mm,
            spacing_mm: self.spacing_mm,
            interpolation: self.interp,
            grid: self.grid.as_ref().map(|g| GridBox {
                min: [g[0], g[2], g[4]],
                max: [g[1], g[3], g[5]],
            }),
            frame_check: !self.no_frame_check,
        };
        if let Some(g) = &config.grid {
            g.validate()
                .map_err(|e| AppError::Usage(format!("--grid: {e}")))?;
        }
        config
            .validate()
            .map_err(|e| AppError::Usage(format!("{e} (see --margin-mm and --voxel-mm)")))?;
        Ok(config)
    }

    /// The pipeline: the template (held at `fix_h`), solver and energy of
    /// the settings, the published pieces otherwise, and `config`.
    ///
    /// # Errors
    /// [`hold_half_thickness`]'s.
    pub fn pipeline(&self, config: Config) -> Result<Pipeline, AppError> {
        self.pipeline_with(self.template.build(), config)
    }

    /// [`Settings::pipeline`] with another `template` (a method
    /// developer's, or Python's), held at `fix_h` when given.
    ///
    /// # Errors
    /// [`hold_half_thickness`]'s.
    pub fn pipeline_with(
        &self,
        template: Box<dyn PlacentaTemplate>,
        config: Config,
    ) -> Result<Pipeline, AppError> {
        Ok(Pipeline::new()
            .template(hold_half_thickness(template, self.fix_h)?)
            .solver(self.solver.build())
            .energy(self.energy.build())
            .config(config))
    }
}

/// `--fix-h`: `template` with its half thickness `h` held at `h_mm`
/// ([`Held`]), or `template` itself without a value.
///
/// # Errors
/// [`AppError::Usage`] for an `h_mm` that is not finite and positive, or a
/// template whose parameters are not exactly `h` (the ellipsoid's radii).
pub fn hold_half_thickness(
    template: Box<dyn PlacentaTemplate>,
    h_mm: Option<f64>,
) -> Result<Box<dyn PlacentaTemplate>, AppError> {
    let Some(h) = h_mm else {
        return Ok(template);
    };
    let h = positive("--fix-h", h)?;
    let names = template.parameter_names();
    let name = template.name();
    Held::new(template, vec![h])
        .filter(|_| names == ["h"])
        .map(|held| Box::new(held) as Box<dyn PlacentaTemplate>)
        .ok_or_else(|| {
            AppError::Usage(format!(
                "--fix-h holds a half thickness h, but the {name} template's parameters are \
                 [{}]; use it with --template planes or single-plane",
                names.join(", ")
            ))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_the_published_method_and_pass_their_checks() {
        let s = Settings::default();
        s.validate(false).unwrap();
        let c = s.config(DEFAULT_VOXEL_MM, None).unwrap();
        assert_eq!(c.lambda, 1.0);
        assert_eq!(c.parcellation.gamma, 20.0);
        assert_eq!(c.parcellation.rings, 3);
        assert_eq!(c.parcellation.margin_mm, 15.0);
        assert_eq!(c.grad_tol, 1e-4);
    }

    #[test]
    fn names_are_the_flags() {
        let v = serde_json::to_value(Settings::default()).unwrap();
        for key in [
            "lambda-sweep",
            "fix-h",
            "no-frame-check",
            "size-mm",
            "smooth-voxels",
        ] {
            assert!(v.get(key).is_some(), "{key} missing from {v}");
        }
        let s: Settings =
            serde_json::from_value(serde_json::json!({"template": "ellipsoid", "lambda": 2.0}))
                .unwrap();
        assert_eq!(s.template, TemplateKind::Ellipsoid);
        assert_eq!(s.lambda, 2.0);
        assert_eq!(s.gamma, 20.0);
    }

    #[test]
    fn bad_values_name_their_flags() {
        let bad = |s: Settings, seg: bool| s.validate(seg).unwrap_err().to_string();
        assert_eq!(
            bad(
                Settings {
                    lambda: -1.0,
                    ..Settings::default()
                },
                false
            ),
            "--lambda must be a finite number > 0, got -1"
        );
        assert_eq!(
            bad(
                Settings {
                    rings: 7,
                    ..Settings::default()
                },
                false
            ),
            "--rings must be 1 to 6, got 7"
        );
        assert!(
            bad(
                Settings {
                    dense: true,
                    ..Settings::default()
                },
                false
            )
            .ends_with("apply to --seg")
        );
        assert!(
            bad(
                Settings {
                    template: TemplateKind::Ellipsoid,
                    fix_h: Some(10.0),
                    ..Settings::default()
                },
                false
            )
            .starts_with("--fix-h holds a half thickness h, but the ellipsoid template")
        );
        assert_eq!(
            bad(
                Settings {
                    lambda_sweep: vec![1.0, 0.0],
                    ..Settings::default()
                },
                false
            ),
            "--lambda-sweep must be a finite number > 0, got 0"
        );
    }
}
