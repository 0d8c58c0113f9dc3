//! The optimization stages of the placenta pipeline (ALGORITHMS 2.1):
//! minimize
//!
//! ```text
//! phi(X, theta) = sum_{m in boundary} A_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! ```
//!
//! with the pipeline's template `T`, energy `D`, solver and line search,
//! one stage per template: the template's warm start first, if it has one
//! (the single plane starts from the parallel planes' optimum). The stages
//! share the Hessian layout ([`unfold_param::LayoutCache`]): the mesh's
//! pattern is ordered and analysed once per optimization.

use super::estimate::Estimates;
use super::templates::PlacentaTemplate;
use crate::{OrganError, PipelineObserver};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::collections::BTreeMap;
use unfold_param::{
    DistortionEnergy, Executor, Iteration, LayoutCache, LineSearch, Objective, ParamMesh,
    SolveReport, Solver, Stopping, Template, TemplateTerm,
};

/// The fixed data of an optimization: the rest mesh, the boundary labels
/// and the template weights `A_m` (per vertex).
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// Rest data of the tet mesh.
    pub mesh: &'a ParamMesh,
    /// Per vertex side labels (`side::INTERIOR`, fetal, maternal, margin).
    pub labels: &'a [u8],
    /// Per vertex template weights (normalized boundary areas).
    pub weights: &'a [f64],
}

/// The pieces and settings a stage runs with.
#[derive(Debug, Clone, Copy)]
pub struct Method<'a> {
    /// The distortion energy `D`.
    pub energy: &'a dyn DistortionEnergy,
    /// Its weight `lambda`.
    pub lambda: f64,
    /// The solver.
    pub solver: &'a dyn Solver,
    /// The line search.
    pub line_search: &'a dyn LineSearch,
    /// The stopping rules of each stage.
    pub stopping: Stopping,
}

/// One optimization stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageReport {
    /// The template of the stage.
    pub template: Cow<'static, str>,
    /// Template parameters at the start (named).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub theta_initial: BTreeMap<Cow<'static, str>, f64>,
    /// Template parameters at the end (named).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub theta: BTreeMap<Cow<'static, str>, f64>,
    /// The solver's report.
    pub solve: SolveReport,
}

/// The result of [`optimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Optimized {
    /// Mapped positions, flat (`3 n`), template frame.
    pub x: Vec<f64>,
    /// Final template parameters.
    pub theta: Vec<f64>,
    /// The final template's starting parameters from the estimates.
    pub theta_initial: Vec<f64>,
    /// One entry per stage.
    pub stages: Vec<StageReport>,
}

/// `name -> value` of template parameters.
pub(crate) fn named(names: &[&'static str], theta: &[f64]) -> BTreeMap<Cow<'static, str>, f64> {
    names
        .iter()
        .map(|&n| Cow::Borrowed(n))
        .zip(theta.iter().copied())
        .collect()
}

/// The template's starting parameters, checked against its names.
fn initial_theta(
    template: &dyn PlacentaTemplate,
    estimates: &Estimates,
) -> Result<Vec<f64>, OrganError> {
    let theta = template.initial_theta(estimates);
    let expected = template.parameter_names().len();
    if theta.len() != expected {
        return Err(super::PlacentaError::TemplateParameters {
            template: template.name(),
            expected,
            found: theta.len(),
        }
        .into());
    }
    Ok(theta)
}

/// Runs one stage: minimizes `phi` for `template` from `x`, `theta`, with
/// the Hessian layout of an earlier stage on the same mesh when `layouts`
/// has one (and keeping its own otherwise).
fn stage(
    problem: &Problem<'_>,
    method: &Method<'_>,
    template: &dyn Template,
    x: &mut [f64],
    theta: &mut [f64],
    layouts: &LayoutCache,
    observer: &mut dyn PipelineObserver,
) -> Result<StageReport, OrganError> {
    observer.stage(&format!("optimization ({})", template.name()));
    let term = TemplateTerm {
        template,
        labels: problem.labels,
        weights: problem.weights,
    };
    let mut objective = layouts.reuse(Objective::new(
        problem.mesh,
        method.energy,
        method.lambda,
        Some(term),
        &[],
    )?)?;
    let theta_initial = named(&template.parameter_names(), theta);
    let mut forward = |it: &Iteration| observer.iteration(it);
    let solve = Executor::new(method.solver)
        .line_search(method.line_search)
        .stopping(method.stopping)
        .observer(&mut forward)
        .run(&mut objective, x, theta)?;
    layouts.keep(&objective);
    Ok(StageReport {
        template: template.name().into(),
        theta_initial,
        theta: named(&template.parameter_names(), theta),
        solve,
    })
}

/// Minimizes `phi` from `x0` (the initial map, flat) for `template`: first
/// the chain of its warm starts ([`PlacentaTemplate::warm_start`], each
/// from its own starting parameters or the previous stage's when the
/// counts agree), then the template itself, its parameters handed over
/// from the previous stage when the counts agree.
///
/// # Errors
/// [`super::PlacentaError::TemplateParameters`] for a template whose
/// starting parameters do not match its names; `Param` when an objective
/// cannot be set up or a solver fails.
pub fn optimize(
    problem: &Problem<'_>,
    method: &Method<'_>,
    template: &dyn PlacentaTemplate,
    estimates: &Estimates,
    x0: Vec<f64>,
    observer: &mut dyn PipelineObserver,
) -> Result<Optimized, OrganError> {
    let mut chain: Vec<Box<dyn PlacentaTemplate>> = Vec::new();
    let mut next = template.warm_start();
    while let Some(t) = next {
        next = t.warm_start();
        chain.push(t);
        if chain.len() > 8 {
            break;
        }
    }
    chain.reverse();
    let theta_initial = initial_theta(template, estimates)?;
    let mut x = x0;
    let mut theta: Vec<f64> = Vec::new();
    let mut stages = Vec::new();
    // The stages share one mesh: its pattern is ordered and analysed once.
    let layouts = LayoutCache::default();
    let stage_templates = chain
        .iter()
        .map(|t| t.as_ref() as &dyn PlacentaTemplate)
        .chain(std::iter::once(template));
    for (k, t) in stage_templates.enumerate() {
        let own = initial_theta(t, estimates)?;
        if k == 0 || theta.len() != own.len() {
            theta = own;
        }
        stages.push(stage(
            problem, method, t, &mut x, &mut theta, &layouts, observer,
        )?);
    }
    Ok(Optimized {
        x,
        theta,
        theta_initial,
        stages,
    })
}
