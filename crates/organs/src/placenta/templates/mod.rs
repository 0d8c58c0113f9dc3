//! The placenta's templates (ALGORITHMS 2.3): the canonical shapes its
//! boundary is pulled onto, as [`PlacentaTemplate`]s: a [`Template`] (the
//! penalty per boundary vertex, by side label) that also knows its starting
//! parameters from the mesh's estimates and, optionally, the template whose
//! optimum it starts from.
//!
//! Shipped: [`ParallelPlanes`] (the default), [`Ellipsoid`] and
//! [`SinglePlane`] (started from the planes). A method developer's own
//! template (a cylinder, a curved shell) implements both traits and plugs
//! into [`Pipeline::template`](super::Pipeline::template); [`TemplateKind`]
//! names the shipped ones for the command line.

mod ellipsoid;
mod held;
mod planes;
mod single_plane;
#[cfg(test)]
mod tests;

pub use ellipsoid::Ellipsoid;
pub use held::Held;
pub use planes::ParallelPlanes;
pub use single_plane::SinglePlane;

pub use super::canonical::TemplateSymmetry;
use super::estimate::Estimates;
use serde::{Deserialize, Serialize};
use unfold_param::Template;

/// A template of the placenta pipeline. The pipeline calls it with the side
/// labels of [`side`](super::side) (interior, fetal, maternal, margin) and weights the
/// boundary vertices by their normalized areas.
pub trait PlacentaTemplate: Template {
    /// The starting parameters `theta` (one per
    /// [`Template::parameter_names`]) from the mesh-only estimates
    /// (ALGORITHMS 2.4: half thickness, half widths, volume).
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64>;

    /// A template whose optimum this one starts from (the single plane
    /// starts from the parallel planes), or `None` (the default) to start
    /// from the initial map. Its final parameters are handed over when the
    /// counts agree.
    fn warm_start(&self) -> Option<Box<dyn PlacentaTemplate>> {
        None
    }

    /// The rigid motions of the flattened mesh that leave this template's
    /// term unchanged (the distortion term is invariant under all of them),
    /// which the canonical frame (ALGORITHMS 2.10) uses to fix the origin
    /// and in-plane orientation. Default [`TemplateSymmetry::None`]: the
    /// frame is left as the optimization ends.
    fn symmetry(&self) -> TemplateSymmetry {
        TemplateSymmetry::None
    }
}

/// A boxed placenta template is a placenta template.
impl<T: PlacentaTemplate + ?Sized> PlacentaTemplate for Box<T> {
    fn initial_theta(&self, estimates: &Estimates) -> Vec<f64> {
        (**self).initial_theta(estimates)
    }
    fn warm_start(&self) -> Option<Box<dyn PlacentaTemplate>> {
        (**self).warm_start()
    }
    fn symmetry(&self) -> TemplateSymmetry {
        (**self).symmetry()
    }
}

/// The shipped templates by name ([`unfold_param::Named`]: the command line's
/// `--template`, Python's `template=`, a manifest's `template` column).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TemplateKind {
    /// Two parallel planes `z = +-h` (fetal up); the paper's recommendation.
    #[default]
    Planes,
    /// An axis-aligned ellipsoid with radii `(rx, ry, rz)`.
    Ellipsoid,
    /// The maternal side on `z = -h`, the fetal side free (started from the
    /// converged planes).
    SinglePlane,
}

unfold_param::named!(TemplateKind {
    Planes => "planes",
    Ellipsoid => "ellipsoid",
    SinglePlane => "single-plane",
});

impl TemplateKind {
    /// The template.
    pub fn build(self) -> Box<dyn PlacentaTemplate> {
        match self {
            TemplateKind::Planes => Box::new(ParallelPlanes::default()),
            TemplateKind::Ellipsoid => Box::new(Ellipsoid::default()),
            TemplateKind::SinglePlane => Box::new(SinglePlane::default()),
        }
    }
}
