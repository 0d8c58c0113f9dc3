//! unfold-param: the parameterization framework.
//!
//! The problem is always (ALGORITHMS 1-2)
//!
//! ```text
//! minimize  sum_m w_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! subject to every element staying positively oriented, fixed vertices fixed
//! ```
//!
//! and its pieces are traits, so a method developer adds one without
//! touching the rest: [`DistortionEnergy`] (a function of the singular values
//! of `J`), [`Template`] (the boundary penalty), [`Initializer`] (a valid
//! starting map under the pipeline's [`Constraints`]), [`LineSearch`]
//! (bounded by the first flip) and [`Solver`] (gradient descent, the
//! placenta paper's baseline; projected Newton, the default). An
//! [`Executor`] runs a solver with a line search, applies the [`Stopping`]
//! rules and reports every iteration to [`Observer`]s (argmin's split of
//! problem, solver and observer).
//!
//! "ALGORITHMS x.y" in the documentation is section x.y of
//! `docs/ALGORITHMS.md` in the repository.

pub mod deform;
pub mod energy;
mod error;
pub mod flips;
pub mod initializer;
pub mod layout_cache;
pub mod linesearch;
pub mod memory;
pub mod metrics;
pub mod named;
pub mod objective;
pub mod rest;
pub mod solver;
pub mod template;
pub mod untangle;

pub use deform::{Deform, DeformOutcome, DeformReport, FlipCounts, RestShape, deform_newton};
pub use energy::DistortionEnergy;
pub use error::{Elements, ParamError, PieceError};
pub use initializer::{Constraints, InitialMap, Initializer, Pin};
pub use layout_cache::LayoutCache;
pub use linesearch::{Backtracking, LineSearch, LineSearchResult};
pub use named::Named;
pub use objective::{HessianLayout, Objective, TemplateTerm};
pub use rest::{ParamMesh, RestElements};
pub use solver::{
    Executor, GradientDescent, History, Iteration, NoObserver, Observer, ProjectedNewton,
    SolveReport, Solver, State, Step, StopReason, Stopping,
};
pub use template::Template;
pub use unfold_linalg as linalg;
pub use unfold_mesh as mesh;
pub use untangle::{Untangle, UntangleReport, Untangler};
