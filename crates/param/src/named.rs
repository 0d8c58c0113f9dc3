//! Choices made by name: the shipped pieces (energies, templates,
//! initializers, line searches, solvers) and the settings that pick one of a
//! few ways (an interpolation, a chamber). The command line, the Python
//! package and cohort manifests all take these names, so each list is
//! written once, beside what it names, in the crate that owns it.

/// A value chosen by one of a fixed list of names.
///
/// `by_name(name(x)) == Some(x)` for every value, and `NAMES` lists
/// `name(x)` of every value in a stable order (the order help texts show).
/// Names are lower case, words joined by `-` (`symmetric-dirichlet`),
/// exactly as serde writes the value when the type is serializable.
pub trait Named: Sized + Copy + 'static {
    /// Every name, in a stable order.
    const NAMES: &'static [&'static str];

    /// The value called `name` (exact, case-sensitive), if any.
    fn by_name(name: &str) -> Option<Self>;

    /// This value's name, one of [`Named::NAMES`].
    fn name(self) -> &'static str;

    /// Every value, in the order of [`Named::NAMES`].
    fn all() -> Vec<Self> {
        Self::NAMES
            .iter()
            .filter_map(|n| Self::by_name(n))
            .collect()
    }
}

/// Implements [`Named`] for a fieldless enum from `Variant => "name"` pairs
/// (the order of the pairs is the order of `NAMES`).
#[macro_export]
macro_rules! named {
    ($ty:ty { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $crate::named::Named for $ty {
            const NAMES: &'static [&'static str] = &[$($name),+];

            fn by_name(name: &str) -> Option<Self> {
                match name {
                    $($name => Some(<$ty>::$variant),)+
                    _ => None,
                }
            }

            fn name(self) -> &'static str {
                match self {
                    $(<$ty>::$variant => $name,)+
                }
            }
        }
    };
}

/// Checks the [`Named`] contract of `T`: every name found, round trips,
/// distinct, in `NAMES` order, and lower-case kebab case. For the tests of
/// every implementation (panics with the first violation).
pub fn check_named<T: Named + PartialEq + std::fmt::Debug>() {
    let mut seen = std::collections::HashSet::new();
    for &name in T::NAMES {
        assert!(seen.insert(name), "{name} appears twice");
        assert!(
            !name.is_empty()
                && name
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'),
            "{name} is not lower-case kebab case"
        );
        let value = T::by_name(name).unwrap_or_else(|| panic!("{name} not found"));
        assert_eq!(value.name(), name);
    }
    assert_eq!(T::all().len(), T::NAMES.len());
    assert!(T::by_name("").is_none());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Colour {
        Red,
        DarkBlue,
    }

    crate::named!(Colour { Red => "red", DarkBlue => "dark-blue" });

    #[test]
    fn names_round_trip() {
        check_named::<Colour>();
        assert_eq!(Colour::by_name("dark-blue"), Some(Colour::DarkBlue));
        assert_eq!(Colour::by_name("Red"), None);
        assert_eq!(Colour::all(), [Colour::Red, Colour::DarkBlue]);
    }
}
