//! Initializers: valid (non-inverted) starting maps.
//!
//! Every pipeline that minimizes from an embedding asks an [`Initializer`]
//! for it: the placenta (PCA alignment, fetal side up), the mitral leaflets
//! (their layout below the annulus), the ventricle's disk map and `deform`
//! (the identity). The pipeline hands over what it knows in
//! [`Constraints`]: vertices it will hold fixed ([`Pin`]s, e.g. a leaflet's
//! annulus or a ventricle's rim), per-vertex labels and weights (e.g. the
//! placenta's sides and boundary areas). A method developer's own
//! initializer plugs into any of them.
//!
//! Shipped here: [`Identity`] and [`PcaIdentity`] (tet meshes) and
//! [`TutteDisk`] (disk-topology triangle meshes into the plane).

mod identity;
mod registry;
mod tutte;

pub use identity::{Identity, PcaIdentity, PcaTransform, pca_transform};
pub use registry::InitializerKind;
pub use tutte::{DiskBoundary, TutteDisk, TutteWeights, circle_boundary};
pub use unfold_mesh::topology::disk_boundary_loop;

use crate::{ParamError, ParamMesh};

/// A vertex whose mapped position is prescribed: the pipeline holds it
/// there during the solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pin {
    /// The vertex.
    pub vertex: u32,
    /// Its mapped position; the first `mesh.dim()` coordinates are used
    /// (the rest is ignored, 0 by convention).
    pub position: [f64; 3],
}

impl Pin {
    /// A pin in the plane.
    pub fn planar(vertex: u32, q: [f64; 2]) -> Self {
        Pin {
            vertex,
            position: [q[0], q[1], 0.0],
        }
    }
}

/// What a pipeline knows when it asks for a starting map. Every slice may
/// be empty (nothing known).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Constraints<'a> {
    /// Prescribed positions: an initializer must put these vertices there
    /// (or refuse with an error), in the order given (a loop's order where
    /// the pipeline pins a loop, such as a leaflet's annulus or a
    /// ventricle's rim).
    pub pins: &'a [Pin],
    /// Per-vertex labels whose meaning the pipeline documents (the
    /// placenta's sides, the ventricle's landmarks).
    pub labels: &'a [u8],
    /// Per-vertex weights (the placenta's normalized boundary areas).
    pub weights: &'a [f64],
}

/// A starting map: flat positions (`mesh.dim()` per vertex) in which no
/// element is inverted, and which variant of its method the initializer
/// used (for reports, e.g. `("weights", "mean-value")`).
#[derive(Debug, Clone, PartialEq)]
pub struct InitialMap {
    /// Positions, flat.
    pub x: Vec<f64>,
    /// `(what, which)` choices the initializer made, in order.
    pub details: Vec<(&'static str, &'static str)>,
}

impl InitialMap {
    /// A map without details.
    pub fn new(x: Vec<f64>) -> Self {
        InitialMap {
            x,
            details: Vec::new(),
        }
    }

    /// The choice recorded under `what`, if any.
    pub fn detail(&self, what: &str) -> Option<&'static str> {
        self.details
            .iter()
            .find(|(w, _)| *w == what)
            .map(|(_, which)| *which)
    }
}

/// Produces a starting map for a [`ParamMesh`] under the pipeline's
/// [`Constraints`]: flat positions, `mesh.dim()` coordinates per vertex,
/// in which no element is inverted and every pin is at its position.
pub trait Initializer: Send + Sync + std::fmt::Debug {
    /// A short name ("identity", "tutte-mean-value", ...).
    fn name(&self) -> &'static str;
    /// The starting map.
    ///
    /// # Errors
    /// When the mesh or the constraints do not suit the method (a triangle
    /// mesh for a volume initializer, pins it cannot honour, ...), or the
    /// map it finds inverts an element.
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError>;
}

/// A boxed initializer is an initializer (so pipelines can hold and take
/// `Box<dyn Initializer>`).
impl<I: Initializer + ?Sized> Initializer for Box<I> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        (**self).initialize(mesh, constraints)
    }
}
