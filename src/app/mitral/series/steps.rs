//! The files of a series directory (`unfold mitral --series DIR`): which
//! file is which leaflet (or annulus) of which time step.
//!
//! A file's role comes from its name (any case): the anterior leaflet is
//! named `*anterior*` or has the word `AL` (a run of letters `al`, as in
//! `AL_01.vtp`, `mv-al3.stl`), the posterior `*posterior*` or `PL`, the
//! annulus `*annulus*`; other files are ignored. A directory uses one
//! naming for its leaflets, not both. The step of a file is its name
//! without the role's word and without its extension (`.gz` and the one
//! before it), reduced to its runs of letters and digits joined by `_`
//! (`AL_01.vtp`, `PL-01.vtp` and `annulus_01.csv` are all step `01`). The
//! steps are ordered by that key, numbers by value (`2` before `10`).
//!
//! Every step needs an anterior and a posterior leaflet; annulus files are
//! given for every step or for none (then each step's annulus is found
//! from its leaflets, [`unfold_organs::mitral::annulus_from_leaflets`]).

use crate::app::error::{AppError, at};
use std::cmp::Ordering;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One step's files.
#[derive(Debug, Clone, PartialEq)]
pub struct StepFiles {
    /// The step's key (the name without the role and extension).
    pub key: String,
    /// The anterior leaflet.
    pub anterior: PathBuf,
    /// The posterior leaflet.
    pub posterior: PathBuf,
    /// The annulus ring, when the series has annulus files.
    pub annulus: Option<PathBuf>,
}

/// What a file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Anterior,
    Posterior,
    Annulus,
}

/// How a leaflet file is named.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Naming {
    /// `*anterior*`, `*posterior*`.
    Words,
    /// `AL*`, `PL*`.
    Short,
}

/// The name without its extension (and a `.gz` before it), lower case.
fn stem(name: &str) -> String {
    let lower = name.to_ascii_lowercase();
    let cut = |s: &str| s.rfind('.').filter(|&i| i > 0).map(|i| s[..i].to_string());
    let s = cut(&lower).unwrap_or(lower.clone());
    if lower.ends_with(".gz") {
        cut(&s).unwrap_or(s)
    } else {
        s
    }
}

/// The runs of ASCII letters of `s` with their byte ranges.
fn letter_runs(s: &str) -> Vec<(usize, usize)> {
    let b = s.as_bytes();
    let mut runs = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphabetic() {
            let j = (i..b.len())
                .find(|&j| !b[j].is_ascii_alphabetic())
                .unwrap_or(b.len());
            runs.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    runs
}

/// `s` reduced to its runs of letters and digits joined by `_`.
fn normalized(s: &str) -> String {
    s.split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

/// The roles a file name claims, each with its naming (none for the
/// annulus) and the step key.
fn roles(name: &str) -> Vec<(Role, Option<Naming>, String)> {
    let s = stem(name);
    let mut found = Vec::new();
    for (word, role) in [
        ("anterior", Role::Anterior),
        ("posterior", Role::Posterior),
        ("annulus", Role::Annulus),
    ] {
        if let Some(i) = s.find(word) {
            let key = format!("{}_{}", &s[..i], &s[i + word.len()..]);
            let naming = (role != Role::Annulus).then_some(Naming::Words);
            found.push((role, naming, normalized(&key)));
        }
    }
    for (i, j) in letter_runs(&s) {
        let role = match &s[i..j] {
            "al" => Role::Anterior,
            "pl" => Role::Posterior,
            _ => continue,
        };
        let key = format!("{}_{}", &s[..i], &s[j..]);
        found.push((role, Some(Naming::Short), normalized(&key)));
    }
    found
}

/// Natural order of step keys: runs of digits compare by value, the rest
/// as text.
fn natural(a: &str, b: &str) -> Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for i in 1..=bytes.len() {
            if i == bytes.len() || bytes[i].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..i]));
                start = i;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (x, y) in ca.iter().zip(&cb) {
        let o = match (x, y) {
            ((true, x), (true, y)) => {
                let (x, y) = (x.trim_start_matches('0'), y.trim_start_matches('0'));
                x.len().cmp(&y.len()).then(x.cmp(y))
            }
            ((_, x), (_, y)) => x.cmp(y),
        };
        if o != Ordering::Equal {
            return o;
        }
    }
    ca.len().cmp(&cb.len()).then(a.cmp(b))
}

/// The steps of a series directory (see the module docs), in order.
///
/// # Errors
/// The directory unreadable; a file naming two roles; both namings in one
/// directory; two files of one role and step; a leaflet without its
/// partner; an annulus without leaflets; annulus files for some steps but
/// not all; no leaflet file at all. Each one line naming the file(s).
pub fn series_steps(dir: &Path) -> Result<Vec<StepFiles>, AppError> {
    let fs = |source| AppError::Fs {
        path: dir.display().to_string(),
        source,
    };
    let mut files: Vec<(PathBuf, String)> = Vec::new();
    for e in std::fs::read_dir(dir).map_err(fs)? {
        let e = e.map_err(fs)?;
        let p = e.path();
        if p.is_file() {
            files.push((p, e.file_name().to_string_lossy().into_owned()));
        }
    }
    files.sort();
    let mut by_role: [BTreeMap<String, PathBuf>; 3] = Default::default();
    let mut first_of: [Option<PathBuf>; 2] = [None, None];
    for (path, name) in &files {
        let found = roles(name);
        let (role, naming, key) = match found.as_slice() {
            [] => continue,
            [one] => one.clone(),
            _ => {
                return Err(at(
                    path,
                    "names more than one of anterior / posterior / annulus (AL / PL); name \
                     each file for one",
                ));
            }
        };
        if let Some(n) = naming {
            let k = n as usize;
            if let Some(other) = &first_of[1 - k] {
                return Err(AppError::Usage(format!(
                    "{} and {}: a series names its leaflets either AL* / PL* or *anterior* / \
                     *posterior*, not both",
                    other.display(),
                    path.display()
                )));
            }
            first_of[k].get_or_insert_with(|| path.clone());
        }
        if let Some(other) = by_role[role as usize].insert(key.clone(), path.clone()) {
            return Err(AppError::Usage(format!(
                "{} and {}: two {} files for step '{key}'",
                other.display(),
                path.display(),
                ["anterior", "posterior", "annulus"][role as usize]
            )));
        }
    }
    let [ant, post, ring] = by_role;
    if ant.is_empty() && post.is_empty() {
        return Err(at(
            dir,
            "no leaflet files in this series directory (named AL* / PL* or *anterior* / \
             *posterior*)",
        ));
    }
    let partner = |naming_short: bool, role: Role, key: &str| -> String {
        let word = match (naming_short, role) {
            (true, Role::Anterior) => "AL",
            (true, _) => "PL",
            (false, Role::Anterior) => "anterior",
            (false, _) => "posterior",
        };
        format!("a {word} file for step '{key}'")
    };
    let short = first_of[1].is_some();
    for (have, want, role) in [
        (&ant, &post, Role::Posterior),
        (&post, &ant, Role::Anterior),
    ] {
        if let Some((key, path)) = have.iter().find(|(k, _)| !want.contains_key(*k)) {
            return Err(at(
                path,
                format!(
                    "has no {} partner in the series: expected {}",
                    if role == Role::Posterior {
                        "posterior"
                    } else {
                        "anterior"
                    },
                    partner(short, role, key)
                ),
            ));
        }
    }
    if let Some((key, path)) = ring.iter().find(|(k, _)| !ant.contains_key(*k)) {
        return Err(at(
            path,
            format!("is the annulus of step '{key}', which has no leaflet files"),
        ));
    }
    if !ring.is_empty() && ring.len() != ant.len() {
        let (key, path) = ant
            .iter()
            .find(|(k, _)| !ring.contains_key(*k))
            .map(|(k, p)| (k.clone(), p.clone()))
            .unwrap_or_default();
        return Err(at(
            &path,
            format!(
                "step '{key}' has no annulus file, but {} of the {} steps have one: give one per \
                 step, or none (each annulus is then found from its leaflets)",
                ring.len(),
                ant.len()
            ),
        ));
    }
    let mut steps: Vec<StepFiles> = ant
        .into_iter()
        .map(|(key, anterior)| StepFiles {
            posterior: post[&key].clone(),
            annulus: ring.get(&key).cloned(),
            anterior,
            key,
        })
        .collect();
    steps.sort_by(|a, b| natural(&a.key, &b.key));
    Ok(steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_give_roles_and_step_keys() {
        let one = |n: &str| {
            let r = roles(n);
            assert_eq!(r.len(), 1, "{n}: {r:?}");
            (r[0].0, r[0].2.clone())
        };
        assert_eq!(one("AL_01.vtp"), (Role::Anterior, "01".into()));
        assert_eq!(one("PL-01.vtk.gz"), (Role::Posterior, "01".into()));
        assert_eq!(one("mv_al3.stl"), (Role::Anterior, "mv_3".into()));
        assert_eq!(one("mv_pl3.stl"), (Role::Posterior, "mv_3".into()));
        assert_eq!(one("t00_anterior.vtp"), (Role::Anterior, "t00".into()));
        assert_eq!(one("annulus_01.csv"), (Role::Annulus, "01".into()));
        // `al` inside a word is no tag.
        assert!(roles("final_mesh.vtp").is_empty());
        assert!(roles("aligned.vtp").is_empty());
        assert_eq!(roles("AL_posterior.vtp").len(), 2);
    }

    #[test]
    fn keys_sort_numbers_by_value() {
        let mut k = vec!["t10", "t2", "t1", "a", "t02b"];
        k.sort_by(|a, b| natural(a, b));
        assert_eq!(k, vec!["a", "t1", "t2", "t02b", "t10"]);
        assert_eq!(stem("x.vtk.gz"), "x");
        assert_eq!(stem("AL.vtp"), "al");
        assert_eq!(stem(".hidden"), ".hidden");
    }
}
