//! `unfold batch MANIFEST -o OUT --layout bids`: the batch's outputs as a
//! BIDS derivative dataset (the BIDS specification 1.9.0, "Derivatives":
//! `dataset_description.json` with `DatasetType: derivative` and
//! `GeneratedBy`; file names `sub-<label>(_<key>-<value>)*_<suffix>.<ext>`
//! with `space-` entities for the template frames and `xfm` transforms
//! named `from-<space>_to-<space>_mode-image`).
//!
//! The batch runs as in the default layout into `OUT/work/` (the subjects'
//! folders, logs, tables and cohort statistics, exactly what the default
//! layout has at `OUT`), every placenta subject also writing its map as a
//! displacement field (`--displacement`). At the end the BIDS tree is made
//! from it: `OUT/dataset_description.json`, `OUT/sub-<label>/` per subject
//! and `OUT/group/` for the cohort maps, each file a hard link to its
//! working copy (a copy where linking fails), each folder written through
//! a staging area and put in place whole ([`crate::app::run::staged`]).
//!
//! The names ([`subject_file`], [`group_file`]):
//!
//! | working file | BIDS name |
//! |---|---|
//! | any organ `report.json` | `sub-L_desc-unfold_report.json` |
//! | placenta `original.vtu` | `sub-L_desc-original_mesh.vtu` |
//! | placenta `flattened.vtu` | `sub-L_space-placentaTemplate_desc-flattened_mesh.vtu` |
//! | placenta `<name>_flat.nii.gz` | `sub-L_space-placentaTemplate_<Suffix>.nii.gz` for a BIDS suffix name (`T2w`, `t1w`, `flair`, ...), else `sub-L_space-placentaTemplate_desc-<name>_image.nii.gz` |
//! | placenta displacement field | `sub-L_from-native_to-placentaTemplate_mode-image_xfm.nii.gz` |
//! | ventricle `anatomy.vtu` | `sub-L_desc-anatomy_mesh.vtu` |
//! | ventricle `normalized.vtu` | `sub-L_space-ventricleCylinder_desc-normalized_mesh.vtu` |
//! | ventricle `disk.vtu` | `sub-L_space-ventricleDisk_desc-disk_mesh.vtu` |
//! | mitral `valve3d.vtu` | `sub-L_desc-valve_mesh.vtu` |
//! | mitral `valve2d.vtu` | `sub-L_space-mitralMap_desc-valve_mesh.vtu` |
//! | `cohort/<name>_mean.nii.gz` (`_std`, `_count`) | `group/space-placentaTemplate_desc-<name>Mean_stat.nii.gz` (`Std`, `Count`) |
//! | `cohort/mitral_<array>_mean.nii.gz` (`_std`, `_count`) | `group/space-mitralMap_desc-<array>Mean_stat.nii.gz` (...) |
//! | `cohort/z/<id>_<name>.nii.gz` | `sub-L_space-placentaTemplate_desc-<name>Z_stat.nii.gz` |
//!
//! `L` is the subject's id with every character outside `[a-zA-Z0-9]`
//! removed ([`label`]); two ids with one label, or an id without a letter
//! or digit, are refused before anything runs ([`labels`]). A name's
//! `<name>` goes into a `desc-` value in camel case ([`camel`]:
//! `area_energy` -> `areaEnergy`). Files without a BIDS name (figures,
//! CSV tables, a mitral series' steps, logs) stay in `OUT/work/` only.

use super::manifest::{Plan, plan};
use super::{BatchObserver, run_plan};
use crate::app::error::{AppError, at};
use crate::app::run::StagedOutputs;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The BIDS version the derivative dataset follows.
pub const BIDS_VERSION: &str = "1.9.0";
/// The working area of a BIDS batch: `OUT/work/` holds what the default
/// layout writes at `OUT`.
pub const WORK: &str = "work";
/// The folder of the group maps: `OUT/group/`.
pub const GROUP: &str = "group";
/// The displacement field a placenta subject writes into its working
/// folder (`OUT/work/<id>/`) when its row does not name one.
pub const DISPLACEMENT: &str = "displacement.nii.gz";

/// How `unfold batch` lays out its outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Layout {
    /// `OUT/<id>/`, `OUT/cohort/`, ... (the module documentation of
    /// [`super::batch`]).
    #[default]
    Default,
    /// A BIDS derivative dataset (this module).
    Bids,
}

crate::param::named!(Layout { Default => "default", Bids => "bids" });

/// Why a manifest's ids cannot name BIDS subjects.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum BidsError {
    /// An id with no letter or digit.
    #[error(
        "subject id '{id}' has no letter or digit, so no BIDS label (sub-<label> keeps only \
         a-z, A-Z and 0-9): give it one in the manifest"
    )]
    NoLabel {
        /// The id.
        id: String,
    },
    /// Two ids with the same label.
    #[error(
        "subject ids '{first}' and '{second}' both become sub-{label} (BIDS labels keep only \
         a-z, A-Z and 0-9): rename one in the manifest"
    )]
    Collision {
        /// The first id.
        first: String,
        /// The second id.
        second: String,
        /// Their label.
        label: String,
    },
}

/// The BIDS label of a subject id: its ASCII letters and digits, in order
/// (`p-01_a` -> `p01a`).
pub fn label(id: &str) -> String {
    id.chars().filter(char::is_ascii_alphanumeric).collect()
}

/// The labels of `ids`, in order.
///
/// # Errors
/// [`BidsError::NoLabel`] for an empty label, [`BidsError::Collision`]
/// for two ids with one label.
pub fn labels<'a>(ids: impl IntoIterator<Item = &'a str>) -> Result<Vec<String>, BidsError> {
    let mut seen: BTreeMap<String, &str> = BTreeMap::new();
    let mut out = Vec::new();
    for id in ids {
        let l = label(id);
        if l.is_empty() {
            return Err(BidsError::NoLabel { id: id.into() });
        }
        if let Some(first) = seen.insert(l.clone(), id) {
            return Err(BidsError::Collision {
                first: first.into(),
                second: id.into(),
                label: l,
            });
        }
        out.push(l);
    }
    Ok(out)
}

/// `name` as a BIDS entity value in camel case: its runs of ASCII letters
/// and digits joined, each run after the first with its first letter in
/// upper case (`area_energy` -> `areaEnergy`, `T2w` -> `T2w`).
pub fn camel(name: &str) -> String {
    let mut out = String::new();
    for (k, word) in name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .enumerate()
    {
        let mut chars = word.chars();
        if let Some(c) = chars.next() {
            out.push(if k == 0 { c } else { c.to_ascii_uppercase() });
            out.extend(chars);
        }
    }
    out
}

/// The BIDS suffixes of anatomical and functional images an image name
/// may be (compared without case).
const IMAGE_SUFFIXES: [&str; 14] = [
    "T1w",
    "T2w",
    "PDw",
    "T2starw",
    "FLAIR",
    "inplaneT1",
    "inplaneT2",
    "PDT2",
    "T1map",
    "T2map",
    "T2starmap",
    "R2starmap",
    "bold",
    "dwi",
];

/// The BIDS suffix `name` is (case aside), if any: `t2w` -> `T2w`.
pub fn image_suffix(name: &str) -> Option<&'static str> {
    IMAGE_SUFFIXES
        .iter()
        .find(|s| s.eq_ignore_ascii_case(name))
        .copied()
}

/// The template space of an organ's maps (`placentaTemplate`,
/// `ventricleCylinder`, `mitralMap`).
pub fn space(organ: &str) -> Option<&'static str> {
    match organ {
        "placenta" => Some("placentaTemplate"),
        "ventricle" => Some("ventricleCylinder"),
        "mitral" => Some("mitralMap"),
        _ => None,
    }
}

/// The BIDS name of the file `file` (a name in the subject's working
/// folder) of a subject labelled `label` with organ `organ`, if it has one
/// (the table of the module documentation).
pub fn subject_file(label: &str, organ: &str, file: &str) -> Option<String> {
    let sub = format!("sub-{label}");
    if file == "report.json" {
        return Some(format!("{sub}_desc-unfold_report.json"));
    }
    let named = match (organ, file) {
        ("placenta", "original.vtu") => "desc-original_mesh.vtu".to_string(),
        ("placenta", "flattened.vtu") => {
            "space-placentaTemplate_desc-flattened_mesh.vtu".to_string()
        }
        ("placenta", DISPLACEMENT) => {
            "from-native_to-placentaTemplate_mode-image_xfm.nii.gz".into()
        }
        ("placenta", f) => {
            let name = f.strip_suffix("_flat.nii.gz")?;
            image_name("placentaTemplate", name)?
        }
        ("ventricle", "anatomy.vtu") => "desc-anatomy_mesh.vtu".into(),
        ("ventricle", "normalized.vtu") => {
            "space-ventricleCylinder_desc-normalized_mesh.vtu".into()
        }
        ("ventricle", "disk.vtu") => "space-ventricleDisk_desc-disk_mesh.vtu".into(),
        ("mitral", "valve3d.vtu") => "desc-valve_mesh.vtu".into(),
        ("mitral", "valve2d.vtu") => "space-mitralMap_desc-valve_mesh.vtu".into(),
        _ => return None,
    };
    Some(format!("{sub}_{named}"))
}

/// `space-<space>_<Suffix>.nii.gz` for an image called `name` that is a
/// BIDS suffix, else `space-<space>_desc-<name>_image.nii.gz`; `None` for
/// a name without a letter or digit.
fn image_name(space: &str, name: &str) -> Option<String> {
    Some(match image_suffix(name) {
        Some(s) => format!("space-{space}_{s}.nii.gz"),
        None => {
            let desc = camel(name);
            if desc.is_empty() {
                return None;
            }
            format!("space-{space}_desc-{desc}_image.nii.gz")
        }
    })
}

/// The BIDS name (in `OUT/group/`) of the cohort map `file` (a name in
/// `OUT/work/cohort/`), if it has one: `<name>_<stat>.nii.gz` of the
/// placentas or `mitral_<array>_<stat>.nii.gz` of the valves, `stat` one
/// of `mean`, `std`, `count`.
pub fn group_file(file: &str) -> Option<String> {
    let stem = file.strip_suffix(".nii.gz")?;
    let (name, stat) = stem.rsplit_once('_')?;
    let stat = match stat {
        "mean" => "Mean",
        "std" => "Std",
        "count" => "Count",
        _ => return None,
    };
    let (space, name) = match name.strip_prefix("mitral_") {
        Some(array) => ("mitralMap", array),
        None => ("placentaTemplate", name),
    };
    let desc = camel(name);
    (!desc.is_empty()).then(|| format!("space-{space}_desc-{desc}{stat}_stat.nii.gz"))
}

/// The BIDS name of a placenta's leave-one-out z map `file` (a name in
/// `OUT/work/cohort/z/`, `<id>_<name>.nii.gz`) among `ids` (the longest
/// id that prefixes it): its id and the name.
pub fn z_file<'a>(file: &str, ids: &[&'a str]) -> Option<(&'a str, String)> {
    let stem = file.strip_suffix(".nii.gz")?;
    let id = ids
        .iter()
        .filter(|id| stem.len() > id.len() + 1 && stem.starts_with(&format!("{id}_")))
        .max_by_key(|id| id.len())?;
    let desc = camel(&stem[id.len() + 1..]);
    (!desc.is_empty()).then(|| {
        (
            *id,
            format!(
                "sub-{}_space-placentaTemplate_desc-{desc}Z_stat.nii.gz",
                label(id)
            ),
        )
    })
}

/// The text of `OUT/dataset_description.json`: `Name`, `BIDSVersion`,
/// `DatasetType: derivative` and `GeneratedBy` (unfold, its version and
/// the command line as its description).
pub fn dataset_description(command_line: &[String]) -> String {
    let v = serde_json::json!({
        "Name": "unfold derivatives",
        "BIDSVersion": BIDS_VERSION,
        "DatasetType": "derivative",
        "GeneratedBy": [{
            "Name": "unfold",
            "Version": env!("CARGO_PKG_VERSION"),
            "Description": command_line.join(" "),
        }],
    });
    let mut text = serde_json::to_string_pretty(&v).unwrap_or_default();
    text.push('\n');
    text
}

/// Runs the subjects of `manifest` into `out` as a BIDS derivative dataset
/// (the module documentation): the labels checked first, the batch into
/// `OUT/work/`, then the BIDS tree from it, also when subjects failed (the
/// batch's error is returned after). `command_line` goes into
/// `dataset_description.json`.
///
/// # Errors
/// A bad manifest or colliding labels (before anything runs); the batch's;
/// writing the tree.
pub fn run_manifest_bids(
    manifest: &Path,
    out: &Path,
    jobs: Option<usize>,
    command_line: &[String],
    observer: &mut dyn BatchObserver,
) -> Result<(), AppError> {
    let mut plan = plan(manifest)?;
    labels(plan.subjects.iter().map(|s| s.id.as_str())).map_err(|e| at(manifest, e.to_string()))?;
    if out.is_file() {
        return Err(at(out, "is a file; -o names a directory"));
    }
    let work = out.join(WORK);
    let work_abs = std::path::absolute(&work).map_err(|e| at(&work, e))?;
    let displacements = ask_displacements(&mut plan, &work_abs);
    let ran = run_plan(&plan, &work, jobs, observer);
    if !work.join("logs").is_dir() {
        // nothing ran (the batch refused its options)
        return ran;
    }
    let written = write_tree(out, &work, &plan, &displacements, command_line)?;
    observer.info(&format!(
        "batch: BIDS derivatives of {written} subjects in {}",
        out.display()
    ));
    ran
}

/// Adds `--displacement=WORK/<id>/displacement.nii.gz` to every placenta
/// subject whose row does not name one; returns where each placenta's
/// field is.
fn ask_displacements(plan: &mut Plan, work: &Path) -> BTreeMap<String, PathBuf> {
    let mut out = BTreeMap::new();
    for s in plan.subjects.iter_mut().filter(|s| s.organ == "placenta") {
        let given = s.args.iter().enumerate().find_map(|(k, a)| {
            if a == "--displacement" {
                s.args.get(k + 1).map(PathBuf::from)
            } else {
                a.strip_prefix("--displacement=").map(PathBuf::from)
            }
        });
        let path = given.unwrap_or_else(|| {
            let p = work.join(&s.id).join(DISPLACEMENT);
            s.args.push(format!("--displacement={}", p.display()));
            p
        });
        out.insert(s.id.clone(), path);
    }
    out
}

/// A file of the tree: where it comes from, its name in its folder.
type Entries = Vec<(PathBuf, String)>;

/// Writes the BIDS tree of the batch in `work` into `out`; returns how many
/// subjects have a folder.
fn write_tree(
    out: &Path,
    work: &Path,
    plan: &Plan,
    displacements: &BTreeMap<String, PathBuf>,
    command_line: &[String],
) -> Result<usize, AppError> {
    let ids: Vec<&str> = plan.subjects.iter().map(|s| s.id.as_str()).collect();
    let mut subjects: BTreeMap<&str, Entries> = BTreeMap::new();
    for s in &plan.subjects {
        let dir = work.join(&s.id);
        let l = label(&s.id);
        let mut files = Entries::new();
        for name in file_names(&dir) {
            if let Some(b) = subject_file(&l, &s.organ, &name) {
                files.push((dir.join(&name), b));
            }
        }
        // a field the row named elsewhere (the batch's own is in `dir`)
        if !files.is_empty()
            && let Some(d) = displacements.get(&s.id).filter(|d| d.is_file())
            && let Some(b) = subject_file(&l, "placenta", DISPLACEMENT)
            && !files.iter().any(|(_, n)| *n == b)
        {
            files.push((d.clone(), b));
        }
        subjects.insert(&s.id, files);
    }
    let cohort = work.join("cohort");
    for name in file_names(&cohort.join("z")) {
        if let Some((id, b)) = z_file(&name, &ids)
            && let Some(files) = subjects.get_mut(id).filter(|f| !f.is_empty())
        {
            files.push((cohort.join("z").join(&name), b));
        }
    }
    let group: Entries = file_names(&cohort)
        .into_iter()
        .filter_map(|n| group_file(&n).map(|b| (cohort.join(&n), b)))
        .collect();
    let mut staged = StagedOutputs::new(std::iter::empty::<&Path>());
    let mut written = 0;
    for (id, files) in subjects.iter().filter(|(_, f)| !f.is_empty()) {
        let dir = staged.dir(out.join(format!("sub-{}", label(id))))?;
        link_all(files, &dir)?;
        written += 1;
    }
    if !group.is_empty() {
        let dir = staged.dir(out.join(GROUP))?;
        link_all(&group, &dir)?;
    }
    let description = staged.file(out.join("dataset_description.json"))?;
    crate::io::atomic_write(&description, dataset_description(command_line).as_bytes())?;
    staged.commit()?;
    Ok(written)
}

/// The names of the regular files directly in `dir`, sorted (none when it
/// cannot be read).
fn file_names(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    names.sort();
    names
}

/// Hard-links (copies where linking fails) every file of `files` into
/// `dir` under its name; two files with one name (images called `t2w` and
/// `T2w`) are refused.
fn link_all(files: &Entries, dir: &Path) -> Result<(), AppError> {
    for (from, name) in files {
        let to = dir.join(name);
        if std::fs::symlink_metadata(&to).is_ok() {
            return Err(at(
                from,
                format!("has the BIDS name {name} of another file: rename one of the images"),
            ));
        }
        if std::fs::hard_link(from, &to).is_err() {
            std::fs::copy(from, &to).map_err(|e| at(&to, e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The BIDS file-name pattern: `sub-<label>(_<key>-<value>)*_<suffix>`
    /// then an extension, labels and values alphanumeric.
    fn is_bids_name(name: &str) -> bool {
        let Some((stem, ext)) = name.split_once('.') else {
            return false;
        };
        let alnum = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric());
        let parts: Vec<&str> = stem.split('_').collect();
        let Some((suffix, entities)) = parts.split_last() else {
            return false;
        };
        alnum(suffix)
            && alnum(&ext.replace('.', ""))
            && entities.first().is_some_and(|e| e.starts_with("sub-"))
            && entities
                .iter()
                .all(|e| e.split_once('-').is_some_and(|(k, v)| alnum(k) && alnum(v)))
    }

    #[test]
    fn labels_keep_letters_and_digits_and_must_differ() {
        assert_eq!(label("p-01_a.b"), "p01ab");
        assert_eq!(labels(["s1", "s-2"]).unwrap(), ["s1", "s2"]);
        assert_eq!(
            labels(["p_1", "ok", "p1"]).unwrap_err(),
            BidsError::Collision {
                first: "p_1".into(),
                second: "p1".into(),
                label: "p1".into()
            }
        );
        let e = labels(["a", "_-."]).unwrap_err();
        assert_eq!(e, BidsError::NoLabel { id: "_-.".into() });
        assert!(e.to_string().contains("no letter or digit"), "{e}");
    }

    #[test]
    fn names_are_camel_case_and_suffixes_are_recognised() {
        assert_eq!(camel("area_energy"), "areaEnergy");
        assert_eq!(camel("coaptation_distance_mm"), "coaptationDistanceMm");
        assert_eq!(camel("T2w"), "T2w");
        assert_eq!(camel("__"), "");
        assert_eq!(image_suffix("t2w"), Some("T2w"));
        assert_eq!(image_suffix("flair"), Some("FLAIR"));
        assert_eq!(image_suffix("mri"), None);
    }

    #[test]
    fn subject_files_get_bids_names() {
        let cases = [
            ("placenta", "report.json", "sub-p1_desc-unfold_report.json"),
            ("placenta", "original.vtu", "sub-p1_desc-original_mesh.vtu"),
            (
                "placenta",
                "flattened.vtu",
                "sub-p1_space-placentaTemplate_desc-flattened_mesh.vtu",
            ),
            (
                "placenta",
                "t2w_flat.nii.gz",
                "sub-p1_space-placentaTemplate_T2w.nii.gz",
            ),
            (
                "placenta",
                "mri_flat.nii.gz",
                "sub-p1_space-placentaTemplate_desc-mri_image.nii.gz",
            ),
            (
                "placenta",
                DISPLACEMENT,
                "sub-p1_from-native_to-placentaTemplate_mode-image_xfm.nii.gz",
            ),
            (
                "ventricle",
                "normalized.vtu",
                "sub-p1_space-ventricleCylinder_desc-normalized_mesh.vtu",
            ),
            (
                "mitral",
                "valve2d.vtu",
                "sub-p1_space-mitralMap_desc-valve_mesh.vtu",
            ),
        ];
        for (organ, file, want) in cases {
            let got = subject_file("p1", organ, file).unwrap();
            assert_eq!(got, want);
            assert!(is_bids_name(&got), "{got}");
        }
        for (organ, file) in [
            ("placenta", "figures"),
            ("placenta", "lambda_sweep.csv"),
            ("ventricle", "original.vtu"),
            ("mitral", "flattened.vtu"),
        ] {
            assert_eq!(subject_file("p1", organ, file), None, "{organ} {file}");
        }
        assert_eq!(space("ventricle"), Some("ventricleCylinder"));
        assert_eq!(space("liver"), None);
    }

    #[test]
    fn group_and_z_files_get_bids_names() {
        assert_eq!(
            group_file("mri_mean.nii.gz").unwrap(),
            "space-placentaTemplate_desc-mriMean_stat.nii.gz"
        );
        assert_eq!(
            group_file("mitral_area_energy_std.nii.gz").unwrap(),
            "space-mitralMap_desc-areaEnergyStd_stat.nii.gz"
        );
        assert_eq!(group_file("mri_median.nii.gz"), None);
        assert_eq!(group_file("ventricle_segments.csv"), None);
        let ids = ["p1", "p1_b"];
        assert_eq!(
            z_file("p1_b_mri.nii.gz", &ids).unwrap(),
            (
                "p1_b",
                "sub-p1b_space-placentaTemplate_desc-mriZ_stat.nii.gz".into()
            )
        );
        assert_eq!(z_file("p1_t2.nii.gz", &ids).unwrap().0, "p1");
        assert_eq!(z_file("q_mri.nii.gz", &ids), None);
    }

    #[test]
    fn the_pattern_check_refuses_non_bids_names() {
        assert!(is_bids_name("sub-a_desc-unfold_report.json"));
        assert!(!is_bids_name("report.json"));
        assert!(!is_bids_name("sub-a_desc-un_fold_report.json"));
        assert!(!is_bids_name("sub-a_report"));
    }

    #[test]
    fn the_dataset_description_has_the_required_keys() {
        let v: serde_json::Value =
            serde_json::from_str(&dataset_description(&["unfold".into(), "batch".into()])).unwrap();
        assert_eq!(v["BIDSVersion"], BIDS_VERSION);
        assert_eq!(v["DatasetType"], "derivative");
        assert_eq!(v["GeneratedBy"][0]["Name"], "unfold");
        assert_eq!(v["GeneratedBy"][0]["Description"], "unfold batch");
        assert!(v["Name"].is_string());
    }

    #[test]
    fn layouts_have_names() {
        crate::param::named::check_named::<Layout>();
        assert_eq!(
            <Layout as crate::param::Named>::by_name("bids"),
            Some(Layout::Bids)
        );
    }
}
