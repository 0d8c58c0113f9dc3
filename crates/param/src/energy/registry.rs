//! The energies by name, for command lines and configuration files.

use super::{Arap, AreaRatio, DistortionEnergy, Mips, SymmetricDirichlet};

/// The names [`energy_by_name`] accepts, in a stable order.
pub const ENERGY_NAMES: [&str; 4] = ["symmetric-dirichlet", "mips", "arap", "area-ratio"];

/// The energy called `name`: `"symmetric-dirichlet"` ([`SymmetricDirichlet`]),
/// `"mips"` ([`Mips`]), `"arap"` ([`Arap`]) or `"area-ratio"` ([`AreaRatio`]);
/// `None` for anything else (see [`ENERGY_NAMES`]).
pub fn energy_by_name(name: &str) -> Option<Box<dyn DistortionEnergy>> {
    match name {
        "symmetric-dirichlet" => Some(Box::new(SymmetricDirichlet)),
        "mips" => Some(Box::new(Mips)),
        "arap" => Some(Box::new(Arap)),
        "area-ratio" => Some(Box::new(AreaRatio)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn energy_by_name_finds_every_energy() {
        for name in ENERGY_NAMES {
            let e = energy_by_name(name).expect(name);
            assert_eq!(e.name(), name);
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
