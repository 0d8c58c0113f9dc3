//! The shipped energies by name ([`Named`]), for command lines, Python and
//! manifests.

use super::{Arap, AreaRatio, DistortionEnergy, Mips, SymmetricDirichlet};
use crate::named::Named;
use serde::{Deserialize, Serialize};

/// The shipped distortion energies; [`EnergyKind::build`] makes one. The
/// names are the energies' own [`DistortionEnergy::name`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EnergyKind {
    /// [`SymmetricDirichlet`] (the default).
    #[default]
    SymmetricDirichlet,
    /// [`Mips`].
    Mips,
    /// [`Arap`].
    Arap,
    /// [`AreaRatio`].
    AreaRatio,
}

crate::named!(EnergyKind {
    SymmetricDirichlet => "symmetric-dirichlet",
    Mips => "mips",
    Arap => "arap",
    AreaRatio => "area-ratio",
});

impl EnergyKind {
    /// The energy.
    pub fn build(self) -> Box<dyn DistortionEnergy> {
        match self {
            EnergyKind::SymmetricDirichlet => Box::new(SymmetricDirichlet),
            EnergyKind::Mips => Box::new(Mips),
            EnergyKind::Arap => Box::new(Arap),
            EnergyKind::AreaRatio => Box::new(AreaRatio),
        }
    }
}

/// The energy called `name` (one of [`EnergyKind`]'s names), built.
pub fn energy_by_name(name: &str) -> Option<Box<dyn DistortionEnergy>> {
    EnergyKind::by_name(name).map(EnergyKind::build)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn energy_by_name_finds_every_energy() {
        crate::named::check_named::<EnergyKind>();
        for &name in EnergyKind::NAMES {
            let e = energy_by_name(name).expect(name);
            assert_eq!(e.name(), name);
            assert_eq!(
                serde_json::to_value(EnergyKind::by_name(name).unwrap()).unwrap(),
                name
            );
        }
        assert!(energy_by_name("dirichlet").is_none());
        let expected = [
            ("symmetric-dirichlet", 4.0, 6.0, true),
            ("mips", 2.0, 3.0, true),
            ("arap", 0.0, 0.0, false),
            ("area-ratio", 2.0, 2.0, true),
        ];
        for (name, m2, m3, barrier) in expected {
            let e = energy_by_name(name).unwrap();
            assert_eq!(
                (e.minimum(2), e.minimum(3), e.is_barrier()),
                (m2, m3, barrier)
            );
        }
    }
}
