//! The shipped line searches by name ([`Named`](crate::named::Named)), for command lines, Python
//! and manifests.

use super::{Backtracking, LineSearch};
use serde::{Deserialize, Serialize};

/// The shipped line searches; [`LineSearchKind::build`] makes one. The
/// names are the line searches' own [`LineSearch::name`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LineSearchKind {
    /// [`Backtracking::default`]: halving below the flip bound until the
    /// Armijo condition holds (projected Newton's).
    #[default]
    ArmijoBacktracking,
    /// [`Backtracking::paper`]: halving until the objective decreases (the
    /// placenta paper's, gradient descent's).
    Backtracking,
}

crate::named!(LineSearchKind {
    ArmijoBacktracking => "armijo-backtracking",
    Backtracking => "backtracking",
});

impl LineSearchKind {
    /// The line search.
    pub fn build(self) -> Box<dyn LineSearch> {
        match self {
            LineSearchKind::ArmijoBacktracking => Box::new(Backtracking::default()),
            LineSearchKind::Backtracking => Box::new(Backtracking::paper()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::named::Named;

    #[test]
    fn every_line_search_is_built_under_its_name() {
        crate::named::check_named::<LineSearchKind>();
        for kind in LineSearchKind::all() {
            assert_eq!(kind.build().name(), kind.name());
            assert_eq!(serde_json::to_value(kind).unwrap(), kind.name());
        }
    }
}
