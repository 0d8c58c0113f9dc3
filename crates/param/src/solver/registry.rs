//! The shipped solvers by name ([`Named`](crate::named::Named)), for command lines, Python and
//! manifests.

use super::{GradientDescent, ProjectedNewton, Solver};
use serde::{Deserialize, Serialize};

/// The shipped solvers; [`SolverKind::build`] makes one. The names are the
/// solvers' own [`Solver::name`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Projected Newton with a sparse Cholesky factorization (default).
    #[default]
    Newton,
    /// Gradient descent with the injective line search (the placenta
    /// paper's Algorithm 1; a baseline, thousands of iterations).
    Gd,
}

crate::named!(SolverKind { Newton => "newton", Gd => "gd" });

impl SolverKind {
    /// The solver.
    pub fn build(self) -> Box<dyn Solver> {
        match self {
            SolverKind::Newton => Box::new(ProjectedNewton::default()),
            SolverKind::Gd => Box::new(GradientDescent),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::named::Named;

    #[test]
    fn every_solver_is_built_under_its_name() {
        crate::named::check_named::<SolverKind>();
        for kind in SolverKind::all() {
            assert_eq!(kind.build().name(), kind.name());
            assert_eq!(serde_json::to_value(kind).unwrap(), kind.name());
        }
    }
}
