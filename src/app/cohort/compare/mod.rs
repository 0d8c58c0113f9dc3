//! Group comparisons in template space: `unfold cohort OUT --compare COLUMN
//! [--covariates C1,C2] [--permutations N] [--seed S]`.
//!
//! The regressors are columns of `OUT/subjects.csv` (the manifest's
//! covariates). `COLUMN` is *categorical* when one of its non-empty values
//! does not parse as a finite number (groups: two give a t of the second
//! sorted level minus the first, three or more an F), else *continuous*
//! (a t of its slope); every covariate must be numeric (a nuisance slope).
//! The model, its Freedman-Lane permutations and the max-statistic
//! family-wise correction are [`crate::linalg::glm`] (ALGORITHMS 5). A
//! subject with an empty cell in `COLUMN` or a covariate is left out and
//! named.
//!
//! Analyses, each one test (one family for the correction):
//!
//! - placenta, per image name: the subjects' `<name>_flat.nii.gz` on the
//!   image's common grid ([`super::grid`]); the voxels (of every frame)
//!   covered by every included subject are tested. Written into
//!   `OUT/cohort/stats/`: `<name>_<column>_t.nii.gz` (or `_F`; NaN where
//!   untested), `<name>_<column>_pfwe.nii.gz` (1 where untested) and
//!   `<name>_<column>_p.nii.gz` (uncorrected, 1 where untested). A placenta
//!   subject without the image is left out of that image's test and named;
//! - ventricle, per scalar array of the anatomies: the hearts' AHA segment
//!   means ([`super::segments`]) over the segments every included heart
//!   has, in `ventricle_<column>.csv`;
//! - mitral: the single valves' measurements ([`super::mitral`]: annulus,
//!   areas, saddle, coaptation, energies; not the seconds or the flipped
//!   triangles, which describe the run) in `mitral_<column>.csv`; a series
//!   (a value per step) is left out and named;
//! - mitral, per scalar array of the flat maps: the valves' Carpentier
//!   segment means (A1-A3, P1-P3; [`super::valve_segments`]) over the
//!   segments every included valve has, in `mitral_segments_<column>.csv`.
//!
//! The tables have one row per tested column (`array` and `segment`, or
//! `measurement`), its `statistic`, `p`, `p_fwe`, then `n_<level>` and
//! `mean_<level>` per group (continuous: `n`, `mean`). `compare.json`
//! records the column, its kind, the covariates, the permutations and
//! seed, the subjects left out, and per analysis the design's one-line
//! description, the groups and their counts, the relabelings run (and
//! whether they were all the distinct ones), the tested columns, the
//! smallest `p_fwe` and how many columns have `p_fwe <` [`ALPHA`]. The
//! folder is replaced by each comparison. The same `--seed` gives the same
//! files.

mod placenta;
mod study;
mod tables;

use placenta::placenta;
use study::Study;
use tables::{mitral, mitral_segments, ventricle};

use super::grid::{choose, on_grid};
use super::images::placenta_images;
use super::reports::{SubjectReport, subject_report};
use super::subject::SubjectRow;
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::files::ensure_dir;
use crate::app::run::printable::printable;
use crate::io::{NiftiImage, write_image};
use crate::linalg::glm::{
    Design, PermutationSettings, Regressor, RegressorValues, StatisticKind, TestResult,
    permutation_test,
};
use crate::mesh::Volume;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The family-wise level whose significant columns are counted and
/// outlined.
pub const ALPHA: f64 = 0.05;

/// The comparison's folder in `OUT/cohort/`.
pub const STATS: &str = "stats";

/// The summary file in `OUT/cohort/stats/`.
pub const COMPARE_JSON: &str = "compare.json";

/// The mitral measurements tested (of [`super::mitral::COLUMNS`]).
const MITRAL_TESTED: [&str; 10] = [
    "annulus_length_mm",
    "u_extent_mm",
    "anterior_area_mm2",
    "posterior_area_mm2",
    "saddle_horn_height_mm",
    "area_above_plane_mm2",
    "coaptation_vertices",
    "angle_energy",
    "area_energy",
    "length_energy",
];

/// What `--compare` asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CompareSettings {
    /// The column of interest.
    pub column: String,
    /// Nuisance columns (numeric).
    pub covariates: Vec<String>,
    /// Relabelings, the identity included.
    pub permutations: usize,
    /// Seed of the random relabelings.
    pub seed: u64,
}

impl CompareSettings {
    /// `column` with the defaults: no covariates, 1000 permutations, seed 0.
    pub fn new(column: &str) -> Self {
        CompareSettings {
            column: column.to_string(),
            covariates: Vec::new(),
            permutations: 1000,
            seed: 0,
        }
    }
}

/// How the column of interest is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ColumnKind {
    /// Groups (a value that is not a number).
    Categorical,
    /// A number per subject.
    Continuous,
}

/// A subject left out of an analysis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LeftOut {
    /// The subject.
    pub id: String,
    /// Why.
    pub why: String,
}

/// One test and what it found.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Analysis {
    /// `placenta`, `ventricle` or `mitral`.
    pub organ: String,
    /// The image name, the ventricle array, or `measurements`.
    pub name: String,
    /// The design in one line ([`Design::describe`]).
    pub design: String,
    /// t or F.
    pub statistic: StatisticKind,
    /// The groups and their subjects (none for a continuous column).
    pub groups: BTreeMap<String, usize>,
    /// The subjects included, in the cohort's order.
    pub subjects: Vec<String>,
    /// Relabelings run, the identity included.
    pub permutations: usize,
    /// Whether every distinct relabeling was run.
    pub exhaustive: bool,
    /// `(k, n - p)`.
    pub degrees_of_freedom: (f64, f64),
    /// Columns tested (voxels, segments, measurements).
    pub tested: usize,
    /// The smallest family-wise p.
    pub min_p_fwe: f64,
    /// Columns with `p_fwe <` [`ALPHA`].
    pub significant: usize,
    /// The files written, relative to `OUT/cohort/stats/`.
    pub files: Vec<String>,
}

/// `compare.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// The column of interest.
    pub column: String,
    /// How it was read.
    pub kind: ColumnKind,
    /// The nuisance columns.
    pub covariates: Vec<String>,
    /// Relabelings asked for.
    pub permutations: usize,
    /// Their seed.
    pub seed: u64,
    /// The family-wise level counted.
    pub alpha: f64,
    /// Subjects left out, with why.
    pub left_out: Vec<LeftOut>,
    /// Every test.
    pub analyses: Vec<Analysis>,
}

/// `name` for a file name: every character but ASCII letters, digits,
/// `.`, `-` and `_` replaced by `_`.
pub fn file_part(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A cell as a finite number.
fn number(cell: &str) -> Option<f64> {
    cell.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

/// The statistic's file suffix: `t` or `F`.
pub fn statistic_suffix(kind: StatisticKind) -> &'static str {
    match kind {
        StatisticKind::T => "t",
        StatisticKind::F => "F",
    }
}

/// Checks the settings against the columns of `OUT/subjects.csv` and reads
/// the column's kind (run before the cohort's work, so that a bad flag
/// fails at once).
///
/// # Errors
/// An unknown column (the columns listed), a covariate given twice or
/// equal to the column, a non-numeric covariate (a subject's value named),
/// zero permutations.
pub fn check(
    out: &Path,
    subjects: &[SubjectRow],
    columns: &[String],
    settings: &CompareSettings,
) -> Result<ColumnKind, AppError> {
    let table = out.join("subjects.csv");
    let listed = if columns.is_empty() {
        "it has no covariate columns (add them to the manifest)".to_string()
    } else {
        format!("the columns are: {}", columns.join(", "))
    };
    let unknown = |flag: &str, c: &str| {
        AppError::Usage(format!(
            "{flag} {}: not a column of {}; {listed}",
            printable(c),
            table.display()
        ))
    };
    if !columns.contains(&settings.column) {
        return Err(unknown("--compare", &settings.column));
    }
    let mut seen = BTreeSet::new();
    for c in &settings.covariates {
        if !columns.contains(c) {
            return Err(unknown("--covariates", c));
        }
        if *c == settings.column || !seen.insert(c) {
            return Err(AppError::Usage(format!(
                "--covariates: '{}' is given twice or is the --compare column; give each column \
                 once",
                printable(c)
            )));
        }
        if let Some(r) = subjects.iter().find(|r| {
            r.covariates
                .get(c)
                .is_some_and(|v| !v.trim().is_empty() && number(v).is_none())
        }) {
            return Err(AppError::Usage(format!(
                "--covariates: '{}' is not numeric (subject {} has '{}'); a covariate must be a \
                 number (compare groups with --compare)",
                printable(c),
                r.id,
                printable(&r.covariates[c])
            )));
        }
    }
    if settings.permutations == 0 {
        return Err(AppError::Usage(
            "--permutations must be at least 1 (1000 is usual)".into(),
        ));
    }
    let categorical = subjects.iter().any(|r| {
        r.covariates
            .get(&settings.column)
            .is_some_and(|v| !v.trim().is_empty() && number(v).is_none())
    });
    Ok(if categorical {
        ColumnKind::Categorical
    } else {
        ColumnKind::Continuous
    })
}

/// Runs the comparison of the cohort in `out` (module documentation):
/// `subjects` and `columns` are `OUT/subjects.csv`'s rows and covariate
/// columns. Writes `OUT/cohort/stats/` and returns what `compare.json`
/// says.
///
/// # Errors
/// An unknown column, a non-numeric covariate, zero permutations; the
/// model's refusals ([`AppError::Compare`]: one group, too few subjects,
/// a collinear covariate, ...); an image with no voxel every subject
/// covers; nothing to compare; reading or writing a file.
pub fn compare(
    out: &Path,
    subjects: &[SubjectRow],
    columns: &[String],
    settings: &CompareSettings,
    observer: &mut dyn Observer,
) -> Result<Comparison, AppError> {
    let kind = check(out, subjects, columns, settings)?;
    let dir = out.join("cohort").join(STATS);
    if dir.is_dir() {
        std::fs::remove_dir_all(&dir).map_err(|e| at(&dir, e))?;
    }
    ensure_dir(&dir)?;
    let mut study = Study {
        settings,
        kind,
        left_out: Vec::new(),
        dir,
    };
    let mut analyses = placenta(&mut study, out, subjects, observer)?;
    analyses.extend(ventricle(&mut study, out, subjects, observer)?);
    analyses.extend(mitral(&mut study, out, subjects, observer)?);
    analyses.extend(mitral_segments(&mut study, out, subjects, observer)?);
    if analyses.is_empty() {
        return Err(AppError::Usage(format!(
            "--compare {}: nothing to compare in {} (no placenta image, ventricle anatomy or \
             single mitral valve with outputs)",
            settings.column,
            out.display()
        )));
    }
    for l in &study.left_out {
        observer.info(&format!("compare: {} left out: {}", l.id, l.why));
    }
    let comparison = Comparison {
        column: settings.column.clone(),
        kind,
        covariates: settings.covariates.clone(),
        permutations: settings.permutations,
        seed: settings.seed,
        alpha: ALPHA,
        left_out: study.left_out,
        analyses,
    };
    let path = study.dir.join(COMPARE_JSON);
    let text = serde_json::to_string_pretty(&comparison).map_err(|e| at(&path, e))?;
    crate::io::atomic_write(&path, text.as_bytes())?;
    observer.info(&format!("compare: wrote {}", study.dir.display()));
    Ok(comparison)
}

/// One line about a finished test.
fn tell(observer: &mut dyn Observer, what: &str, a: &Analysis) {
    observer.info(&format!(
        "compare: {what}: {}; {} tested, {} relabelings{}: min p_fwe {}, {} with p_fwe < {ALPHA}",
        a.design,
        a.tested,
        a.permutations,
        if a.exhaustive { " (all)" } else { "" },
        a.min_p_fwe,
        a.significant
    ));
}

#[cfg(test)]
mod tests {
    use super::tables::{TableRows, test_table};
    use super::*;

    fn row(id: &str, cells: &[(&str, &str)]) -> SubjectRow {
        SubjectRow {
            id: id.into(),
            organ: "placenta".into(),
            covariates: cells
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        }
    }

    #[test]
    fn a_column_is_categorical_when_a_value_is_not_a_number() {
        let d = tempfile::tempdir().unwrap();
        let cols = vec!["group".to_string(), "age".to_string()];
        let rows = vec![
            row("a", &[("group", "1"), ("age", "30")]),
            row("b", &[("group", "x"), ("age", "")]),
        ];
        let kind = |c: &str| check(d.path(), &rows, &cols, &CompareSettings::new(c));
        assert_eq!(kind("group").unwrap(), ColumnKind::Categorical);
        assert_eq!(kind("age").unwrap(), ColumnKind::Continuous);
        let e = kind("site").unwrap_err().to_string();
        assert!(
            e.contains("not a column") && e.contains("group, age"),
            "{e}"
        );
        let mut s = CompareSettings::new("age");
        s.covariates = vec!["group".into()];
        let e = check(d.path(), &rows, &cols, &s).unwrap_err().to_string();
        assert!(e.contains("not numeric") && e.contains("subject b"), "{e}");
        s.covariates = vec!["age".into()];
        let e = check(d.path(), &rows, &cols, &s).unwrap_err().to_string();
        assert!(e.contains("twice"), "{e}");
        let mut s = CompareSettings::new("age");
        s.permutations = 0;
        let e = check(d.path(), &rows, &cols, &s).unwrap_err().to_string();
        assert!(e.contains("--permutations"), "{e}");
    }

    /// Six subjects in two groups: column 0 differs by group, column 1 is
    /// noise, column 2 misses a value (untested); the table has a row per
    /// column with the group counts and means.
    #[test]
    fn a_table_tests_the_columns_every_subject_has() {
        let settings = CompareSettings::new("group");
        let study = Study {
            settings: &settings,
            kind: ColumnKind::Categorical,
            left_out: Vec::new(),
            dir: PathBuf::new(),
        };
        let subjects: Vec<SubjectRow> = (0..8)
            .map(|k| {
                row(
                    &format!("s{k}"),
                    &[("group", if k < 4 { "A" } else { "B" })],
                )
            })
            .collect();
        let rows: Vec<&SubjectRow> = subjects.iter().collect();
        let noise = [0.3, -0.1, 0.2, -0.4, 0.1, -0.2, 0.4, -0.3];
        let values: Vec<Vec<Option<f64>>> = (0..8)
            .map(|k| {
                let shift = if k < 4 { 0.0 } else { 10.0 };
                vec![
                    Some(shift + noise[k]),
                    Some(noise[(k + 3) % 8]),
                    (k != 5).then_some(1.0),
                ]
            })
            .collect();
        let keys: Vec<Vec<String>> = ["a", "b", "c"]
            .iter()
            .map(|k| vec![k.to_string()])
            .collect();
        let mut table = TableRows::new(&study, &["measurement"], &["A".into(), "B".into()]);
        let a = test_table(
            &study,
            "mitral",
            "measurements",
            &keys,
            &rows,
            &values,
            &mut table,
            "m.csv",
        )
        .unwrap();
        assert_eq!((a.tested, a.significant, a.exhaustive), (2, 1, true));
        assert_eq!(a.groups, BTreeMap::from([("A".into(), 4), ("B".into(), 4)]));
        assert_eq!(
            table.header,
            [
                "measurement",
                "statistic",
                "p",
                "p_fwe",
                "n_A",
                "mean_A",
                "n_B",
                "mean_B"
            ]
        );
        let p_fwe = |r: usize| table.rows[r][3].parse::<f64>().unwrap();
        assert!(p_fwe(0) < ALPHA && p_fwe(1) > ALPHA, "{:?}", table.rows);
        assert!(table.rows[0][1].parse::<f64>().unwrap() > 0.0, "B - A > 0");
        assert_eq!(table.rows[2][1..4], ["", "", ""], "untested");
        assert_eq!(
            table.rows[2][4..],
            ["4", "1", "3", "1"],
            "means over who has it"
        );
    }

    #[test]
    fn file_parts_keep_safe_characters() {
        assert_eq!(file_part("age (weeks)/2"), "age__weeks__2");
        assert_eq!(file_part("t2.x-y_z"), "t2.x-y_z");
    }
}
