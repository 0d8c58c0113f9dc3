//! The numeric settings of the placenta pipeline, and the shipped solvers
//! by name.

use super::error::PullbackError;
use super::parcellation::ParcellationConfig;
use super::pullback::Interpolation;
use crate::{ConfigError, OrganError, Requirement};
use serde::{Deserialize, Serialize};
use unfold_param::{Solver, Stopping};

/// Settings of the placenta pipeline; every default from ALGORITHMS 2. The
/// pieces (template, energy, initializer, line search, solver) are set on
/// the [`Pipeline`](super::Pipeline) itself.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Weight `lambda` of the distortion term (default 1; the paper finds
    /// 0.1..5 alike).
    pub lambda: f64,
    /// Stop when `|grad phi|_F < grad_tol` (default 1e-4).
    pub grad_tol: f64,
    /// Iteration limit per stage (default: the solver's, 200 for Newton,
    /// 100,000 for gradient descent).
    pub max_iterations: Option<usize>,
    /// Time limit per stage, seconds (default none).
    pub max_seconds: Option<f64>,
    /// Boundary parcellation settings (margin, voxel size, ...). Its
    /// `voxel_mm` is also the voxel of `template_error_voxels`.
    pub parcellation: ParcellationConfig,
    /// Half the placenta thickness (`h`, `rz`) when known from the
    /// segmentation (the 95th percentile of its distance transform,
    /// ALGORITHMS 2.4, see `unfold_mesh::mask::inside_distance_quantile`);
    /// `None` (the default): estimated from the mesh.
    pub half_thickness_mm: Option<f64>,
    /// Isotropic voxel size of the template-space images, mm (default
    /// `None`: each image's own voxel spacing).
    pub spacing_mm: Option<f64>,
    /// How the images are sampled (default trilinear; nearest for label
    /// maps).
    pub interpolation: Interpolation,
    /// A fixed box of the template frame for every pulled-back image
    /// (default `None`: a grid covering the flattened mesh), so that images
    /// of different placentas share one grid ([`TemplateGrid::fixed`](super::pullback::TemplateGrid::fixed)).
    pub grid: Option<GridBox>,
    /// Check that the mesh lies in each image's foreground before any work
    /// ([`frame_check`](super::frame_check); default true). Off for images
    /// without a placenta foreground.
    pub frame_check: bool,
}

/// A box of the template frame, mm: the first voxel centre at `min`, the
/// last at or below `max` ([`TemplateGrid::fixed`](super::pullback::TemplateGrid::fixed)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridBox {
    /// `(xmin, ymin, zmin)`, mm.
    pub min: [f64; 3],
    /// `(xmax, ymax, zmax)`, mm; each at least its `min`.
    pub max: [f64; 3],
}

impl GridBox {
    /// Checks that every bound is finite and `max >= min` on every axis.
    ///
    /// # Errors
    /// [`PullbackError::GridBox`] naming the box.
    pub fn validate(&self) -> Result<(), PullbackError> {
        let ok = (0..3).all(|a| {
            self.min[a].is_finite() && self.max[a].is_finite() && self.max[a] >= self.min[a]
        });
        if ok {
            Ok(())
        } else {
            Err(PullbackError::GridBox {
                min: self.min,
                max: self.max,
            })
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Config {
            lambda: 1.0,
            grad_tol: 1e-4,
            max_iterations: None,
            max_seconds: None,
            parcellation: ParcellationConfig::default(),
            half_thickness_mm: None,
            spacing_mm: None,
            interpolation: Interpolation::Linear,
            grid: None,
            frame_check: true,
        }
    }
}

impl Config {
    /// Checks every value; the error names the offending one.
    ///
    /// # Errors
    /// [`OrganError::Config`] for the first value out of range.
    pub fn validate(&self) -> Result<(), OrganError> {
        OrganError::check_positive(&[("lambda", self.lambda), ("grad_tol", self.grad_tol)])?;
        if let Some(n) = self.max_iterations {
            ConfigError::check("max_iterations", n as f64, Requirement::CountAtLeast(1))?;
        }
        if let Some(s) = self.max_seconds
            && (s.is_nan() || s <= 0.0)
        {
            return Err(ConfigError {
                name: "max_seconds",
                value: s,
                requirement: Requirement::Positive,
            }
            .into());
        }
        if let Some(h) = self.half_thickness_mm {
            ConfigError::check("half_thickness_mm", h, Requirement::Positive)?;
        }
        if let Some(s) = self.spacing_mm {
            ConfigError::check("spacing_mm", s, Requirement::Positive)?;
        }
        if let Some(g) = &self.grid {
            g.validate()?;
        }
        Ok(self.parcellation.validate()?)
    }

    /// The stopping rules of every stage: `grad_tol`, the time limit, and
    /// the iteration limit given or the solver's.
    pub fn stopping(&self, solver: &dyn Solver) -> Stopping {
        let default = solver.default_stopping();
        Stopping {
            grad_tol: self.grad_tol,
            max_iterations: self.max_iterations.unwrap_or(default.max_iterations),
            max_seconds: self.max_seconds.unwrap_or(f64::INFINITY),
            ..default
        }
    }
}
