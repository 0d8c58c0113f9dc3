//! How each organ takes a manifest's columns: its settings by their serde
//! names (the flags' names; [`columns_of`]) and its files and landmarks
//! ([`crate::app::placenta::inputs::FILE_COLUMNS`] and the others'), so a
//! manifest maps its columns onto the settings' fields by name.

use crate::app::run::columns::{Column, ColumnKind, columns_of};
use crate::app::{mitral, placenta, ventricle};
use std::collections::{BTreeMap, HashSet};

/// How an organ's run takes the columns of a manifest: each column is one
/// of its settings or files, by name (the flag's name without the dashes).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct OrganColumns {
    /// Columns taking a value (true: a file path).
    pub valued: BTreeMap<String, bool>,
    /// Columns that are switches.
    pub switches: HashSet<String>,
    /// Columns that may hold several values, `;`-separated.
    pub repeated: HashSet<String>,
    /// Whether the positional input (`input`) is a path; `None`: the organ
    /// takes none.
    pub input: Option<bool>,
}

/// How `organ` (`placenta`, `ventricle` or `mitral`) takes a manifest's
/// columns; `None` for another name.
pub fn organ_columns(organ: &str) -> Option<OrganColumns> {
    let (settings, files, input) = match organ {
        "placenta" => (
            columns_of::<placenta::Settings>(),
            placenta::inputs::FILE_COLUMNS,
            Some(true),
        ),
        "ventricle" => (
            columns_of::<ventricle::Settings>(),
            ventricle::inputs::FILE_COLUMNS,
            Some(true),
        ),
        "mitral" => (
            columns_of::<mitral::Settings>(),
            mitral::inputs::FILE_COLUMNS,
            None,
        ),
        _ => return None,
    };
    let mut c = OrganColumns {
        input,
        ..OrganColumns::default()
    };
    let files = files.iter().map(
        |&Column {
             name,
             kind,
             repeated,
         }| (name.to_string(), kind, repeated),
    );
    for (name, kind, repeated) in settings.into_iter().chain(files) {
        if repeated {
            c.repeated.insert(name.clone());
        }
        match kind {
            ColumnKind::Switch => {
                c.switches.insert(name);
            }
            ColumnKind::Value => {
                c.valued.insert(name, false);
            }
            ColumnKind::Path => {
                c.valued.insert(name, true);
            }
        }
    }
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_organ_takes_its_settings_and_files_by_name() {
        let p = organ_columns("placenta").unwrap();
        assert_eq!(p.input, Some(true));
        assert_eq!(p.valued.get("seg"), Some(&true));
        assert_eq!(p.valued.get("template"), Some(&false));
        assert_eq!(p.valued.get("size-mm"), Some(&false));
        assert!(p.repeated.contains("image"));
        assert!(p.repeated.contains("lambda-sweep"));
        assert!(p.switches.contains("no-figures"));
        assert!(p.switches.contains("grade"));
        assert!(!p.valued.contains_key("output"));
        let m = organ_columns("mitral").unwrap();
        assert_eq!(m.input, None);
        assert_eq!(m.valued.get("annulus"), Some(&true));
        assert!(m.switches.contains("cut-posteromedial"));
        let v = organ_columns("ventricle").unwrap();
        assert_eq!(v.valued.get("surface"), Some(&true));
        assert_eq!(v.valued.get("anterior"), Some(&false));
        assert!(v.repeated.contains("grid-sweep"));
        assert!(organ_columns("heart").is_none());
    }
}
