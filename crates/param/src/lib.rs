//! unfold-param: the parameterization framework.
//!
//! The problem is always (DESIGN.md, ALGORITHMS 1-2)
//!
//! ```text
//! minimize  sum_m w_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! subject to every element staying positively oriented, fixed vertices fixed
//! ```
//!
//! and its pieces are traits, so a method developer adds one without
//! touching the rest: [`DistortionEnergy`] (a function of the singular values
//! of `J`), [`Template`] (the boundary penalty), [`Initializer`] (a valid
//! starting map), [`LineSearch`] (bounded by the first flip) and the solvers
//! (gradient descent, the placenta paper's baseline; projected Newton, the
//! default) reporting every iteration to [`Observer`]s.

pub mod energy;
mod error;
pub mod initializer;
pub mod linesearch;
pub mod metrics;
pub mod objective;
pub mod rest;
pub mod solver;
pub mod template;

pub use energy::DistortionEnergy;
pub use error::ParamError;
pub use initializer::Initializer;
pub use linesearch::{Backtracking, LineSearch, LineSearchResult};
pub use objective::{HessianLayout, Objective, TemplateTerm};
pub use rest::{ParamMesh, RestElements};
pub use solver::{
    GradientDescent, History, Iteration, Observer, ProjectedNewton, SolveReport, Solver,
    StopReason, Stopping,
};
pub use template::Template;
pub use unfold_linalg as linalg;
pub use unfold_mesh as mesh;
