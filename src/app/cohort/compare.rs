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
//!   (a value per step) is left out and named.
//!
//! The tables have one row per tested column (`array`, `segment` or
//! `measurement`), its `statistic`, `p`, `p_fwe`, then `n_<level>` and
//! `mean_<level>` per group (continuous: `n`, `mean`). `compare.json`
//! records the column, its kind, the covariates, the permutations and
//! seed, the subjects left out, and per analysis the design's one-line
//! description, the groups and their counts, the relabelings run (and
//! whether they were all the distinct ones), the tested columns, the
//! smallest `p_fwe` and how many columns have `p_fwe <` [`ALPHA`]. The
//! folder is replaced by each comparison. The same `--seed` gives the same
//! files.

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

/// The comparison being run: settings, the column's kind, what was left
/// out.
struct Study<'a> {
    settings: &'a CompareSettings,
    kind: ColumnKind,
    left_out: Vec<LeftOut>,
    dir: PathBuf,
}

impl Study<'_> {
    /// Notes `id` left out for `why` (once).
    fn leave_out(&mut self, id: &str, why: String) {
        let l = LeftOut {
            id: id.to_string(),
            why,
        };
        if !self.left_out.contains(&l) {
            self.left_out.push(l);
        }
    }

    /// The rows with a value in the column and every covariate; the others
    /// left out and named.
    fn eligible<'r>(&mut self, rows: Vec<&'r SubjectRow>) -> Vec<&'r SubjectRow> {
        let mut keep = Vec::with_capacity(rows.len());
        for r in rows {
            let empty = std::iter::once(&self.settings.column)
                .chain(&self.settings.covariates)
                .find(|c| r.covariates.get(*c).is_none_or(|v| v.trim().is_empty()));
            match empty {
                Some(c) => self.leave_out(&r.id, format!("its '{c}' cell is empty")),
                None => keep.push(r),
            }
        }
        keep
    }

    /// The regressors of `rows` (all eligible).
    fn regressors(&self, rows: &[&SubjectRow]) -> (Regressor, Vec<Regressor>) {
        let cell = |r: &SubjectRow, c: &str| r.covariates.get(c).cloned().unwrap_or_default();
        let column = &self.settings.column;
        let interest = Regressor {
            name: column.clone(),
            values: match self.kind {
                ColumnKind::Categorical => RegressorValues::Categorical(
                    rows.iter()
                        .map(|r| cell(r, column).trim().to_string())
                        .collect(),
                ),
                ColumnKind::Continuous => RegressorValues::Continuous(
                    rows.iter()
                        .map(|r| number(&cell(r, column)).unwrap_or(f64::NAN))
                        .collect(),
                ),
            },
        };
        let covariates = self
            .settings
            .covariates
            .iter()
            .map(|c| Regressor {
                name: c.clone(),
                values: RegressorValues::Continuous(
                    rows.iter()
                        .map(|r| number(&cell(r, c)).unwrap_or(f64::NAN))
                        .collect(),
                ),
            })
            .collect();
        (interest, covariates)
    }

    /// The groups of `rows` and their sizes (none for a continuous column).
    fn groups(&self, rows: &[&SubjectRow]) -> BTreeMap<String, usize> {
        let mut g = BTreeMap::new();
        if self.kind == ColumnKind::Categorical {
            for r in rows {
                let v = r.covariates.get(&self.settings.column);
                *g.entry(v.map_or("", |v| v.trim()).to_string()).or_insert(0) += 1;
            }
        }
        g
    }

    /// Fits and tests `y` (`rows.len()` x columns, column-major) for the
    /// analysis `what`.
    fn test(
        &self,
        what: &str,
        rows: &[&SubjectRow],
        y: &[f64],
    ) -> Result<(Design, TestResult), AppError> {
        let analysis = format!(
            "--compare {}: {what} over {} subjects",
            self.settings.column,
            rows.len()
        );
        let wrap = |source| AppError::Compare {
            analysis: analysis.clone(),
            source,
        };
        let (interest, covariates) = self.regressors(rows);
        let design = Design::new(interest, covariates).map_err(wrap)?;
        let settings = PermutationSettings {
            permutations: self.settings.permutations,
            seed: self.settings.seed,
        };
        let result = permutation_test(&design, y, &settings).map_err(wrap)?;
        Ok((design, result))
    }

    /// The summary of a test.
    #[allow(clippy::too_many_arguments)]
    fn analysis(
        &self,
        organ: &str,
        name: &str,
        rows: &[&SubjectRow],
        design: &Design,
        result: &TestResult,
        files: Vec<String>,
    ) -> Analysis {
        Analysis {
            organ: organ.to_string(),
            name: name.to_string(),
            design: design.describe(),
            statistic: result.kind,
            groups: self.groups(rows),
            subjects: rows.iter().map(|r| r.id.clone()).collect(),
            permutations: result.permutations,
            exhaustive: result.exhaustive,
            degrees_of_freedom: result.degrees_of_freedom,
            tested: result.statistic.len(),
            min_p_fwe: result.p_fwe.iter().copied().fold(1.0, f64::min),
            significant: result.p_fwe.iter().filter(|&&p| p < ALPHA).count(),
            files,
        }
    }
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

/// The placenta images' tests.
fn placenta(
    study: &mut Study<'_>,
    out: &Path,
    subjects: &[SubjectRow],
    observer: &mut dyn Observer,
) -> Result<Vec<Analysis>, AppError> {
    let with_outputs: Vec<&SubjectRow> = subjects
        .iter()
        .filter(|s| s.organ == "placenta" && out.join(&s.id).join("report.json").is_file())
        .collect();
    let mut analyses = Vec::new();
    for (name, members) in placenta_images(out, subjects) {
        let what = format!("placenta image {name}");
        observer.progress(&format!("compare: {what}"));
        let Some((grid, off_grid)) = choose(&name, &members)? else {
            continue;
        };
        for (id, why) in off_grid.iter().cloned() {
            study.leave_out(&id, why);
        }
        for s in &with_outputs {
            if !members.iter().any(|(id, _)| *id == s.id) {
                study.leave_out(&s.id, format!("no {name}_flat.nii.gz"));
            }
        }
        let candidates: Vec<&SubjectRow> = with_outputs
            .iter()
            .copied()
            .filter(|s| members.iter().any(|(id, _)| *id == s.id))
            .filter(|s| !off_grid.iter().any(|(id, _)| *id == s.id))
            .collect();
        let rows = study.eligible(candidates);
        let dir_of = |s: &SubjectRow| out.join(&s.id);
        // pass 1: the values every subject has
        let len = grid.frame_len() * grid.dims[3];
        let mut covered = vec![true; len];
        for s in &rows {
            let (vol, mask) = on_grid(&grid, &dir_of(s), &name)?;
            let per_frame = mask.len();
            for (i, (c, &x)) in covered.iter_mut().zip(vol.data()).enumerate() {
                *c &= mask[i % per_frame] && x.is_finite();
            }
        }
        let tested: Vec<usize> = (0..len)
            .filter(|&i| covered[i] && !rows.is_empty())
            .collect();
        if tested.is_empty() {
            return Err(AppError::Usage(format!(
                "--compare {}: {what}: no voxel is covered by all {} subjects; check their \
                 flattened meshes (cohort/{name}_count.nii.gz)",
                study.settings.column,
                rows.len()
            )));
        }
        // pass 2: y, subjects x tested voxels, column-major
        let n = rows.len();
        let mut y = vec![0.0f64; n * tested.len()];
        for (k, s) in rows.iter().enumerate() {
            let (vol, _) = on_grid(&grid, &dir_of(s), &name)?;
            for (j, &i) in tested.iter().enumerate() {
                y[j * n + k] = f64::from(vol.data()[i]);
            }
        }
        let (design, result) = study.test(&what, &rows, &y)?;
        let stem = format!("{}_{}", file_part(&name), file_part(&study.settings.column));
        let images = [
            (statistic_suffix(result.kind), &result.statistic, f32::NAN),
            ("pfwe", &result.p_fwe, 1.0),
            ("p", &result.p_uncorrected, 1.0),
        ];
        let mut files = Vec::new();
        for (suffix, values, untested) in images {
            let mut data = vec![untested; len];
            for (j, &i) in tested.iter().enumerate() {
                data[i] = values[j] as f32;
            }
            let file = format!("{stem}_{suffix}.nii.gz");
            let path = study.dir.join(&file);
            let vol = Volume::new(grid.dims, grid.affine, data).map_err(|e| at(&path, e))?;
            write_image(&path, &NiftiImage::new(vol))?;
            files.push(file);
        }
        let a = study.analysis("placenta", &name, &rows, &design, &result, files);
        tell(observer, &what, &a);
        analyses.push(a);
    }
    Ok(analyses)
}

/// A table's rows: a tested column's key cells, then its statistic, p,
/// p_fwe, and the count and mean of each group.
struct TableRows {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl TableRows {
    fn new(study: &Study<'_>, keys: &[&str], groups: &[String]) -> Self {
        let mut header: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
        header.extend(["statistic", "p", "p_fwe"].map(String::from));
        if study.kind == ColumnKind::Categorical {
            for g in groups {
                header.push(format!("n_{g}"));
                header.push(format!("mean_{g}"));
            }
        } else {
            header.extend(["n", "mean"].map(String::from));
        }
        TableRows {
            header,
            rows: Vec::new(),
        }
    }

    /// One row: `keys`, the test's column `j` (none: untested), and per
    /// group (or overall) the count and mean of `values` (one per row of
    /// `rows`, `None` where missing).
    fn push(
        &mut self,
        study: &Study<'_>,
        keys: Vec<String>,
        test: Option<(&TestResult, usize)>,
        rows: &[&SubjectRow],
        values: &[Option<f64>],
        groups: &[String],
    ) {
        let mut row = keys;
        match test {
            Some((r, j)) => row.extend([
                r.statistic[j].to_string(),
                r.p_uncorrected[j].to_string(),
                r.p_fwe[j].to_string(),
            ]),
            None => row.extend([String::new(), String::new(), String::new()]),
        }
        let summary = |pick: &dyn Fn(&SubjectRow) -> bool| {
            let v: Vec<f64> = rows
                .iter()
                .zip(values)
                .filter(|(r, _)| pick(r))
                .filter_map(|(_, v)| *v)
                .collect();
            let mean = if v.is_empty() {
                String::new()
            } else {
                (v.iter().sum::<f64>() / v.len() as f64).to_string()
            };
            [v.len().to_string(), mean]
        };
        if study.kind == ColumnKind::Categorical {
            for g in groups {
                row.extend(summary(&|r: &SubjectRow| {
                    r.covariates
                        .get(&study.settings.column)
                        .is_some_and(|v| v.trim() == g)
                }));
            }
        } else {
            row.extend(summary(&|_| true));
        }
        self.rows.push(row);
    }

    fn write(&self, path: &Path) -> Result<(), AppError> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.header).map_err(|e| at(path, e))?;
        for r in &self.rows {
            w.write_record(r).map_err(|e| at(path, e))?;
        }
        let bytes = w.into_inner().map_err(|e| at(path, e))?;
        Ok(crate::io::atomic_write(path, &bytes)?)
    }
}

/// Tests `values` (per row of `rows`, per column of `keys`: `None` where
/// missing) over the columns every row has; the rows of the table and the
/// analysis.
#[allow(clippy::too_many_arguments)]
fn test_table(
    study: &Study<'_>,
    organ: &str,
    name: &str,
    keys: &[Vec<String>],
    rows: &[&SubjectRow],
    values: &[Vec<Option<f64>>],
    table: &mut TableRows,
    file: &str,
) -> Result<Analysis, AppError> {
    let groups: Vec<String> = study.groups(rows).into_keys().collect();
    let n = rows.len();
    let tested: Vec<usize> = (0..keys.len())
        .filter(|&c| values.iter().all(|v| v[c].is_some()))
        .collect();
    let what = format!("{organ} {name}");
    if tested.is_empty() {
        return Err(AppError::Usage(format!(
            "--compare {}: {what}: no value every one of the {n} subjects has",
            study.settings.column
        )));
    }
    let mut y = Vec::with_capacity(n * tested.len());
    for &c in &tested {
        y.extend(values.iter().map(|v| v[c].unwrap_or(f64::NAN)));
    }
    let (design, result) = study.test(&what, rows, &y)?;
    for (c, key) in keys.iter().enumerate() {
        let j = tested.iter().position(|&t| t == c);
        let column: Vec<Option<f64>> = values.iter().map(|v| v[c]).collect();
        table.push(
            study,
            key.clone(),
            j.map(|j| (&result, j)),
            rows,
            &column,
            &groups,
        );
    }
    Ok(study.analysis(organ, name, rows, &design, &result, vec![file.to_string()]))
}

/// The ventricles' AHA segment tests, one per array.
fn ventricle(
    study: &mut Study<'_>,
    out: &Path,
    subjects: &[SubjectRow],
    observer: &mut dyn Observer,
) -> Result<Vec<Analysis>, AppError> {
    let hearts: Vec<&SubjectRow> = subjects
        .iter()
        .filter(|s| s.organ == "ventricle" && out.join(&s.id).join("report.json").is_file())
        .collect();
    if hearts.is_empty() {
        return Ok(Vec::new());
    }
    let rows = study.eligible(hearts);
    let mut means = Vec::with_capacity(rows.len());
    for s in &rows {
        means.push(super::segments::heart_means(&out.join(&s.id))?);
    }
    let arrays: BTreeSet<String> = means
        .iter()
        .flat_map(|m| m.keys().map(|(a, _)| a.clone()))
        .collect();
    let file = format!("ventricle_{}.csv", file_part(&study.settings.column));
    let groups: Vec<String> = study.groups(&rows).into_keys().collect();
    let mut table = TableRows::new(study, &["array", "segment"], &groups);
    let mut analyses = Vec::new();
    for array in &arrays {
        let keys: Vec<Vec<String>> = (1..=17)
            .map(|k| vec![array.clone(), k.to_string()])
            .collect();
        let values: Vec<Vec<Option<f64>>> = means
            .iter()
            .map(|m| {
                (1..=17)
                    .map(|k| {
                        m.get(&(array.clone(), k))
                            .copied()
                            .filter(|v| v.is_finite())
                    })
                    .collect()
            })
            .collect();
        let a = test_table(
            study,
            "ventricle",
            array,
            &keys,
            &rows,
            &values,
            &mut table,
            &file,
        )?;
        tell(observer, &format!("ventricle {array}"), &a);
        analyses.push(a);
    }
    table.write(&study.dir.join(&file))?;
    Ok(analyses)
}

/// The single mitral valves' measurements, one test.
fn mitral(
    study: &mut Study<'_>,
    out: &Path,
    subjects: &[SubjectRow],
    observer: &mut dyn Observer,
) -> Result<Vec<Analysis>, AppError> {
    let mut valves = Vec::new();
    let mut reports = Vec::new();
    for s in subjects.iter().filter(|s| s.organ == "mitral") {
        let dir = out.join(&s.id);
        if dir.join("series.csv").is_file() {
            study.leave_out(
                &s.id,
                "a mitral series (a value per step) is not compared".into(),
            );
        } else if let Some(SubjectReport::Mitral(r)) = subject_report(&dir, &s.organ)? {
            valves.push(s);
            reports.push((s.id.clone(), r));
        }
    }
    if valves.is_empty() {
        return Ok(Vec::new());
    }
    let rows = study.eligible(valves);
    let columns = super::mitral::COLUMNS;
    let values: Vec<Vec<Option<f64>>> = rows
        .iter()
        .map(|s| {
            let row = reports
                .iter()
                .find(|(id, _)| *id == s.id)
                .map(|(_, r)| super::mitral::report_row(r))
                .unwrap_or_default();
            MITRAL_TESTED
                .iter()
                .map(|m| {
                    columns
                        .iter()
                        .position(|c| c == m)
                        .and_then(|i| row.get(i))
                        .and_then(|v| number(v))
                })
                .collect()
        })
        .collect();
    let keys: Vec<Vec<String>> = MITRAL_TESTED.iter().map(|m| vec![m.to_string()]).collect();
    let file = format!("mitral_{}.csv", file_part(&study.settings.column));
    let groups: Vec<String> = study.groups(&rows).into_keys().collect();
    let mut table = TableRows::new(study, &["measurement"], &groups);
    let a = test_table(
        study,
        "mitral",
        "measurements",
        &keys,
        &rows,
        &values,
        &mut table,
        &file,
    )?;
    table.write(&study.dir.join(&file))?;
    tell(observer, "mitral measurements", &a);
    Ok(vec![a])
}

#[cfg(test)]
mod tests {
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
