//! Progress of an organ pipeline, for progress bars and logs.

use unfold_param::Iteration;

/// Receives a pipeline's progress: the steps as they start and every
/// optimizer iteration. Every method has an empty default.
pub trait PipelineObserver {
    /// A step starts ("parcellation", "optimization (planes)", ...).
    fn stage(&mut self, _name: &str) {}
    /// An optimizer iteration of the current step.
    fn iteration(&mut self, _it: &Iteration) {}
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct Quiet;

impl PipelineObserver for Quiet {}
