//! The names a run takes its settings and files by: the flags' names
//! without the dashes, which are also the serde names of the settings and a
//! manifest's column names. [`columns_of`] reads a settings struct's names
//! and kinds from its serde form; an organ adds its files and landmarks,
//! which are not settings, as a list of [`Column`]s.

use serde::Serialize;

/// How a run takes a named value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnKind {
    /// A value (`--name=value`).
    Value,
    /// A file path (relative paths of a manifest are its directory's).
    Path,
    /// A switch (`--name` when true).
    Switch,
}

/// One named value a run takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// The name (`grid-mm`, `image`).
    pub name: &'static str,
    /// What it holds.
    pub kind: ColumnKind,
    /// Whether it may be given several times (a manifest's cell holds the
    /// values `;`-separated).
    pub repeated: bool,
}

impl Column {
    /// A file path.
    pub const fn path(name: &'static str) -> Self {
        Column {
            name,
            kind: ColumnKind::Path,
            repeated: false,
        }
    }

    /// A value.
    pub const fn value(name: &'static str) -> Self {
        Column {
            name,
            kind: ColumnKind::Value,
            repeated: false,
        }
    }

    /// The same, given several times.
    pub const fn repeated(self) -> Self {
        Column {
            repeated: true,
            ..self
        }
    }
}

/// The columns of a settings struct from its serde form (its `Default`
/// serialized): a boolean is a switch, a list is a repeated value, anything
/// else (a number, a name, an absent option) a value.
///
/// # Panics
/// Never for the settings structs of this crate (plain data); a type whose
/// serde form is not an object yields no columns.
pub fn columns_of<S: Serialize + Default>() -> Vec<(String, ColumnKind, bool)> {
    let Ok(serde_json::Value::Object(map)) = serde_json::to_value(S::default()) else {
        return Vec::new();
    };
    map.into_iter()
        .map(|(name, v)| match v {
            serde_json::Value::Bool(_) => (name, ColumnKind::Switch, false),
            serde_json::Value::Array(_) => (name, ColumnKind::Value, true),
            _ => (name, ColumnKind::Value, false),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Serialize;

    #[derive(Serialize, Default)]
    #[serde(rename_all = "kebab-case")]
    struct S {
        grid_mm: f64,
        no_figures: bool,
        sweep: Vec<f64>,
        fix_h: Option<f64>,
    }

    #[test]
    fn kinds_come_from_the_serde_form() {
        let mut c = columns_of::<S>();
        c.sort_by(|a, b| a.0.cmp(&b.0));
        assert_eq!(
            c,
            [
                ("fix-h".to_string(), ColumnKind::Value, false),
                ("grid-mm".to_string(), ColumnKind::Value, false),
                ("no-figures".to_string(), ColumnKind::Switch, false),
                ("sweep".to_string(), ColumnKind::Value, true),
            ]
        );
    }
}
