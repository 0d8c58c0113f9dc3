//! How each organ takes a manifest's columns: its settings by their serde
//! names (the flags' names; [`columns_of`]) and its files and landmarks
//! ([`crate::app::placenta::inputs::FILE_COLUMNS`] and the others'), so a
//! manifest maps its columns onto the settings' fields by name.

use super::manifest::OrganColumns;
use crate::app::run::columns::{Column, ColumnKind, columns_of};
use crate::app::{mitral, placenta, ventricle};

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
