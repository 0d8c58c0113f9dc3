//! The tables' tests: the ventricles' AHA segment means and the single
//! mitral valves' measurements.

use super::study::Study;
use super::*;

/// A table's rows: a tested column's key cells, then its statistic, p,
/// p_fwe, and the count and mean of each group.
pub(super) struct TableRows {
    pub(super) header: Vec<String>,
    pub(super) rows: Vec<Vec<String>>,
}

impl TableRows {
    pub(super) fn new(study: &Study<'_>, keys: &[&str], groups: &[String]) -> Self {
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
    pub(super) fn push(
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

    pub(super) fn write(&self, path: &Path) -> Result<(), AppError> {
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
pub(super) fn test_table(
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

/// Per-segment means of one subject: `(array, segment) -> mean`.
type SegmentMeans = BTreeMap<(String, i32), f64>;

/// One test per array over the segments `segments` (`(label, name)`) of
/// the subjects `rows` with their segment means `means`, written as one
/// table `file` (keys `array`, `segment`); `what` names the analysis in
/// the progress lines.
#[allow(clippy::too_many_arguments)]
fn segment_tests(
    study: &mut Study<'_>,
    organ: &str,
    what: &str,
    rows: &[&SubjectRow],
    means: &[SegmentMeans],
    segments: &[(i32, String)],
    file: &str,
    observer: &mut dyn Observer,
) -> Result<Vec<Analysis>, AppError> {
    let arrays: BTreeSet<String> = means
        .iter()
        .flat_map(|m| m.keys().map(|(a, _)| a.clone()))
        .collect();
    let groups: Vec<String> = study.groups(rows).into_keys().collect();
    let mut table = TableRows::new(study, &["array", "segment"], &groups);
    let mut analyses = Vec::new();
    for array in &arrays {
        let keys: Vec<Vec<String>> = segments
            .iter()
            .map(|(_, name)| vec![array.clone(), name.clone()])
            .collect();
        let values: Vec<Vec<Option<f64>>> = means
            .iter()
            .map(|m| {
                segments
                    .iter()
                    .map(|(k, _)| {
                        m.get(&(array.clone(), *k))
                            .copied()
                            .filter(|v| v.is_finite())
                    })
                    .collect()
            })
            .collect();
        let a = test_table(study, organ, array, &keys, rows, &values, &mut table, file)?;
        tell(observer, &format!("{organ} {array}{what}"), &a);
        analyses.push(a);
    }
    table.write(&study.dir.join(file))?;
    Ok(analyses)
}

/// The ventricles' AHA segment tests, one per array.
pub(super) fn ventricle(
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
        means.push(crate::app::cohort::segments::heart_means(&out.join(&s.id))?);
    }
    let segments: Vec<(i32, String)> = (1..=17).map(|k| (k, k.to_string())).collect();
    let file = format!("ventricle_{}.csv", file_part(&study.settings.column));
    segment_tests(
        study,
        "ventricle",
        "",
        &rows,
        &means,
        &segments,
        &file,
        observer,
    )
}

/// The single mitral valves' measurements, one test.
pub(super) fn mitral(
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
    let columns = crate::app::cohort::mitral::COLUMNS;
    let values: Vec<Vec<Option<f64>>> = rows
        .iter()
        .map(|s| {
            let row = reports
                .iter()
                .find(|(id, _)| *id == s.id)
                .map(|(_, r)| crate::app::cohort::mitral::report_row(r))
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

/// The single mitral valves' Carpentier-segment means
/// ([`crate::app::cohort::valve_segments`]), one test per map array over
/// the six segments.
pub(super) fn mitral_segments(
    study: &mut Study<'_>,
    out: &Path,
    subjects: &[SubjectRow],
    observer: &mut dyn Observer,
) -> Result<Vec<Analysis>, AppError> {
    use crate::app::cohort::valve_segments::{SEGMENTS, segment_name, valve_means};
    let valves: Vec<&SubjectRow> = subjects
        .iter()
        .filter(|s| {
            let dir = out.join(&s.id);
            s.organ == "mitral"
                && !dir.join("series.csv").is_file()
                && dir.join("valve2d.vtu").is_file()
        })
        .collect();
    if valves.is_empty() {
        return Ok(Vec::new());
    }
    let rows = study.eligible(valves);
    let mut means = Vec::with_capacity(rows.len());
    for s in &rows {
        means.push(valve_means(&out.join(&s.id))?);
    }
    let segments: Vec<(i32, String)> = SEGMENTS
        .iter()
        .map(|&k| (k, segment_name(k).to_string()))
        .collect();
    let file = format!("mitral_segments_{}.csv", file_part(&study.settings.column));
    segment_tests(
        study,
        "mitral",
        " by Carpentier segment",
        &rows,
        &means,
        &segments,
        &file,
        observer,
    )
}
