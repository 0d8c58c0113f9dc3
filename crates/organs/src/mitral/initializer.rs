//! The mitral pipeline's default [`Initializer`]: a leaflet's initial
//! layout below its annulus (ALGORITHMS 4.2), longitudes when the leaflet
//! has them, else a Tutte embedding (see [`layout`](super::layout)).
//!
//! The mitral pipeline hands every leaflet's initializer
//!
//! - the leaflet as a triangle [`ParamMesh`] (its 3D rest shape);
//! - the annulus as [`Pin`]s, one per annulus vertex in ring order, at its
//!   `(u, v)` target of the annulus layout ([`Pin::planar`]);
//! - as labels, the leaflet's side on every vertex ([`ANTERIOR`] = 0,
//!   [`POSTERIOR`] = 1), so that errors can name it.
//!
//! A method developer's initializer gets the same and must leave the pinned
//! annulus where it is (the pipeline checks) and flip no triangle.

use super::error::LeafletSide;
use super::layout::{longitude_layout, longitudes, tutte_layout};
use super::{ANTERIOR, InitMode, LayoutError, Leaflet, POSTERIOR};
use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_param::{Constraints, InitialMap, Initializer, ParamError, ParamMesh};

/// The leaflet layout of ALGORITHMS 4.2 as an [`Initializer`]: longitudes
/// or Tutte below the pinned annulus, by `mode`. Details:
/// `("layout", "longitudes" | "tutte")`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LeafletLayout {
    /// Which layout (default: longitudes when the leaflet has them).
    pub mode: InitMode,
}

/// An organ error as a [`ParamError::Piece`] of `piece`.
fn piece(piece: &'static str, e: impl Into<OrganError>) -> ParamError {
    ParamError::piece(piece, e.into())
}

impl Initializer for LeafletLayout {
    fn name(&self) -> &'static str {
        "leaflet-layout"
    }

    /// # Errors
    /// [`ParamError::WrongElements`] for a tet mesh; the layout's errors
    /// (a leaflet without longitudes in `Longitudes` mode, a leaflet that is
    /// not a disk, targets that do not fit, ...) as [`ParamError::Piece`]
    /// holding the [`OrganError`].
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        let tris = mesh.triangles(self.name())?;
        if constraints.pins.is_empty() {
            return Err(piece(self.name(), LayoutError::NoAnnulusPins));
        }
        let side = match constraints.labels.first() {
            Some(&l) if usize::from(l) == POSTERIOR => LeafletSide::Posterior,
            _ => LeafletSide::of(ANTERIOR),
        };
        let annulus: Vec<u32> = constraints.pins.iter().map(|p| p.vertex).collect();
        let targets: Vec<[f64; 2]> = constraints
            .pins
            .iter()
            .map(|p| [p.position[0], p.position[1]])
            .collect();
        let leaflet =
            Leaflet::from_annulus(TriMesh::new(mesh.rest.clone(), tris.to_vec()), annulus)
                .map_err(|e| piece(self.name(), e))?;
        let chains = match self.mode {
            InitMode::Tutte => None,
            InitMode::Auto | InitMode::Longitudes => longitudes(&leaflet),
        };
        let (uv, which) = match (self.mode, chains) {
            (_, Some(chains)) => (
                longitude_layout(&leaflet, &chains, &targets).map_err(|e| piece(self.name(), e))?,
                "longitudes",
            ),
            (InitMode::Longitudes, None) => {
                return Err(piece(
                    self.name(),
                    LayoutError::NoLongitudes { leaflet: side },
                ));
            }
            _ => (
                tutte_layout(&leaflet, &targets).map_err(|e| piece(self.name(), e))?,
                "tutte",
            ),
        };
        let mut start = InitialMap::new(uv.iter().flatten().copied().collect());
        start.details.push(("layout", which));
        Ok(start)
    }
}
