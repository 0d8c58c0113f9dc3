//! The shipped general-purpose initializers by name ([`Named`](crate::named::Named)), for
//! command lines, Python and manifests. (An organ's own initializers, such
//! as the mitral leaflet layout, are named in its crate.)

use super::{DiskBoundary, Identity, Initializer, PcaIdentity, TutteDisk, TutteWeights};
use serde::{Deserialize, Serialize};

/// The shipped initializers; [`InitializerKind::build`] makes one. The
/// names are the initializers' own [`Initializer::name`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitializerKind {
    /// [`Identity`]: the rest positions (the default).
    #[default]
    Identity,
    /// [`PcaIdentity`]: the rest positions in their principal axes.
    PcaIdentity,
    /// [`TutteDisk`] with mean-value weights, the boundary on the circle.
    TutteMeanValue,
    /// [`TutteDisk`] with cotangent weights, the boundary on the circle.
    TutteCotangent,
}

crate::named!(InitializerKind {
    Identity => "identity",
    PcaIdentity => "pca-identity",
    TutteMeanValue => "tutte-mean-value",
    TutteCotangent => "tutte-cotangent",
});

impl InitializerKind {
    /// The initializer.
    pub fn build(self) -> Box<dyn Initializer> {
        let tutte = |weights| {
            Box::new(TutteDisk {
                weights,
                boundary: DiskBoundary::Circle,
            })
        };
        match self {
            InitializerKind::Identity => Box::new(Identity),
            InitializerKind::PcaIdentity => Box::new(PcaIdentity),
            InitializerKind::TutteMeanValue => tutte(TutteWeights::MeanValue),
            InitializerKind::TutteCotangent => tutte(TutteWeights::Cotangent),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::named::Named;

    #[test]
    fn every_initializer_is_built_under_its_name() {
        crate::named::check_named::<InitializerKind>();
        for kind in InitializerKind::all() {
            assert_eq!(kind.build().name(), kind.name());
            assert_eq!(serde_json::to_value(kind).unwrap(), kind.name());
        }
    }
}
