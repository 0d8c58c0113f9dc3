//! The error type of the mitral valve pipeline.
//!
//! [`MitralError`] has one nested enum per step of the pipeline (the input
//! contract, the annulus, the initial layout, the relaxation, the maps), so
//! a caller can `match` on exactly the failure it cares about, e.g.
//! `MitralError::Layout(LayoutError::VertexOnNoLongitude { vertex })`.
//! Every variant holds the indices and numbers that explain it (vertex ids,
//! the [`LeafletSide`], counts, millimetres) and its message is one line a
//! user can act on. Settings out of range are not here: they are
//! [`ConfigError`](crate::ConfigError)s. Inside [`OrganError`] a
//! `MitralError` is [`OrganError::Mitral`]; each step's error converts into
//! both directly.

mod annulus;
mod contract;
mod layout;
mod maps;
mod relax;
mod segmentation;

pub use annulus::AnnulusError;
pub use contract::ContractError;
pub use layout::{LayoutError, LayoutKind};
pub use maps::MapsError;
pub use relax::RelaxError;
pub use segmentation::SegmentationError;

use super::{ANTERIOR, POSTERIOR};
use crate::OrganError;
use std::fmt;
use thiserror::Error;

/// Everything that can go wrong in the mitral valve pipeline (besides bad
/// settings, mesh validation and solver failures, which have their own
/// [`OrganError`] variants).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MitralError {
    /// The input contract ([`prepare`](super::contract::prepare)) rejected
    /// the leaflets or the annulus ring.
    #[error(transparent)]
    Contract(#[from] ContractError),
    /// The annulus could not be laid out
    /// ([`annulus::parameterize`](super::annulus::parameterize)).
    #[error(transparent)]
    Annulus(#[from] AnnulusError),
    /// A leaflet's initial layout failed ([`layout`](super::layout)).
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// A leaflet's relaxation rejected its input or broke its promise
    /// ([`relax`](super::relax)).
    #[error(transparent)]
    Relax(#[from] RelaxError),
    /// The maps rejected a layout, a plane or distances
    /// ([`maps`](super::maps)).
    #[error(transparent)]
    Maps(#[from] MapsError),
    /// The leaflets could not be cut from a label map
    /// ([`segmentation`](super::segmentation)).
    #[error(transparent)]
    Segmentation(#[from] SegmentationError),
    /// Internal invariant broken: a per-vertex or per-triangle map has
    /// different value types on the two leaflets, so the merged valve mesh
    /// cannot hold it (both come from the same code; please report).
    #[error("field {field} has different types per leaflet")]
    MergedFieldTypes {
        /// The map's name in the output meshes (e.g. `coaptation`).
        field: &'static str,
    },
}

/// One of the two leaflets, for errors and reports (the per-leaflet arrays
/// are indexed by [`ANTERIOR`] and [`POSTERIOR`]). Displays as `anterior` /
/// `posterior`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LeafletSide {
    /// The anterior leaflet (index [`ANTERIOR`]).
    Anterior,
    /// The posterior leaflet (index [`POSTERIOR`]).
    Posterior,
}

impl LeafletSide {
    /// The leaflet at `index` in per-leaflet arrays ([`ANTERIOR`] is the
    /// anterior leaflet, anything else the posterior one).
    pub fn of(index: usize) -> Self {
        if index == ANTERIOR {
            LeafletSide::Anterior
        } else {
            LeafletSide::Posterior
        }
    }

    /// Its index in per-leaflet arrays ([`ANTERIOR`] or [`POSTERIOR`]).
    pub fn index(self) -> usize {
        match self {
            LeafletSide::Anterior => ANTERIOR,
            LeafletSide::Posterior => POSTERIOR,
        }
    }
}

impl fmt::Display for LeafletSide {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LeafletSide::Anterior => "anterior",
            LeafletSide::Posterior => "posterior",
        })
    }
}

/// Each step's error is also an [`OrganError`] directly (`?` in functions
/// returning `OrganError`).
macro_rules! into_organ_error {
    ($($step:ty),*) => {$(
        impl From<$step> for OrganError {
            fn from(e: $step) -> Self {
                OrganError::Mitral(e.into())
            }
        }
    )*};
}

into_organ_error!(
    ContractError,
    AnnulusError,
    LayoutError,
    RelaxError,
    MapsError,
    SegmentationError
);

/// A length in mm in messages: at most two decimals, trailing zeros
/// dropped (`4.2`, `5`, `0.35`; `-0` as `0`).
pub(crate) struct Mm(pub(crate) f64);

impl fmt::Display for Mm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = format!("{:.2}", self.0);
        let s = s.trim_end_matches('0').trim_end_matches('.');
        f.write_str(if s == "-0" { "0" } else { s })
    }
}

/// A list of counts in messages: `3, 4, 12`.
pub(crate) struct Counts<'a>(pub(crate) &'a [usize]);

impl fmt::Display for Counts<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, c) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{c}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mm_keeps_at_most_two_decimals() {
        for (x, s) in [
            (4.2, "4.2"),
            (5.0, "5"),
            (0.349, "0.35"),
            (-0.001, "0"),
            (100.0, "100"),
            (-1.5, "-1.5"),
        ] {
            assert_eq!(Mm(x).to_string(), s, "{x}");
        }
        assert_eq!(Counts(&[3, 4, 12]).to_string(), "3, 4, 12");
        assert_eq!(Counts(&[]).to_string(), "");
    }

    #[test]
    fn leaflet_sides_map_to_their_indices() {
        for k in [ANTERIOR, POSTERIOR] {
            assert_eq!(LeafletSide::of(k).index(), k);
        }
        assert_eq!(LeafletSide::Anterior.to_string(), "anterior");
        assert_eq!(LeafletSide::Posterior.to_string(), "posterior");
    }

    #[test]
    fn step_errors_convert_into_organ_errors() {
        let e: OrganError = LayoutError::VertexOnNoLongitude { vertex: 7 }.into();
        assert_eq!(
            e,
            OrganError::Mitral(MitralError::Layout(LayoutError::VertexOnNoLongitude {
                vertex: 7
            }))
        );
        assert_eq!(
            e.to_string(),
            "longitude layout: vertex 7 is on no longitude"
        );
    }
}
