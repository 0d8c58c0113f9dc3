//! The cohort table: every subject's `report.json` in one table (`unfold
//! cohort OUT`; also run at the end of `unfold batch`).
//!
//! `OUT/subjects.csv` (written by the batch: `id`, `organ`, then the
//! covariates) names the subjects; `OUT/cohort.csv` gets one row per
//! subject: `id`, `organ`, `status` (`ok`; `series` for a mitral series,
//! whose measurements per step are in `cohort/mitral_measurements.csv`;
//! `missing` without outputs),
//! the covariates, then every scalar of its report, flattened with dotted
//! keys (`field.unknowns`, `roundtrip_error_um.mean`; booleans as 0 and 1;
//! arrays and text left out, and the `provenance` section, which describes
//! the run rather than the organ). Columns are the union over subjects,
//! sorted; a subject without a value has an empty cell. Then the
//! template-space statistics of the placenta subjects
//! ([`super::images`]) and the AHA-segment statistics of the
//! ventricle subjects ([`super::segments`]), the mitral
//! measurements over valves and series steps ([`super::mitral`]) and
//! their mean maps on one normalised `(u, v)` grid
//! ([`super::mitral_maps`]), and the cohort figures
//! ([`super::figures`]; `--plot MEASURE:COVARIATE` chooses the
//! scatter plots); with `--compare`, the group comparison
//! ([`super::compare`]) before the figures. Last, the visual report `OUT/index.html`
//! ([`super::report_page`]).

use super::compare::CompareSettings;
use super::figures::PlotSpec;
use super::reports::{REPORT, subject_report};
use super::scalars::flatten;
use super::subject::SubjectRow;
use super::subject::valid_id;
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::printable::printable;
use std::collections::BTreeMap;
use std::path::Path;

/// Writes `OUT/subjects.csv` and `OUT/cohort.csv` for `subjects`, the
/// statistics and the default cohort figures.
///
/// # Errors
/// Writing either file; a subject's report that exists but does not read
/// as its organ's ([`AppError::Report`]).
pub fn write_cohort(
    out: &Path,
    subjects: &[SubjectRow],
    covariates: &[String],
    observer: &mut dyn Observer,
) -> Result<(), AppError> {
    write_cohort_plots(out, subjects, covariates, &[], None, observer)
}

/// [`write_cohort`] with the scatter plots `plots` (none: the defaults)
/// and the group comparison `compare` ([`super::compare`], before the
/// figures and the page, which show it).
///
/// # Errors
/// Writing a file; a `plots` entry naming an unknown column; a subject's
/// report that does not read as its organ's; the comparison's.
fn write_cohort_plots(
    out: &Path,
    subjects: &[SubjectRow],
    covariates: &[String],
    plots: &[PlotSpec],
    compare: Option<&CompareSettings>,
    observer: &mut dyn Observer,
) -> Result<(), AppError> {
    let path = out.join("subjects.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["id".to_string(), "organ".to_string()];
    header.extend(covariates.iter().cloned());
    w.write_record(&header).map_err(|e| at(&path, e))?;
    for s in subjects {
        let mut row = vec![s.id.clone(), s.organ.clone()];
        row.extend(
            covariates
                .iter()
                .map(|c| s.covariates.get(c).cloned().unwrap_or_default()),
        );
        w.write_record(&row).map_err(|e| at(&path, e))?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    crate::io::atomic_write(&path, &bytes)?;

    let mut rows = Vec::with_capacity(subjects.len());
    let mut keys = std::collections::BTreeSet::new();
    for s in subjects {
        let dir = out.join(&s.id);
        let report = subject_report(&dir, &s.organ)?;
        let mut scalars = BTreeMap::new();
        if let Some(r) = &report {
            let value = r.to_value().map_err(|e| at(&dir.join(REPORT), e))?;
            flatten("", &value, &mut scalars);
        }
        keys.extend(scalars.keys().cloned());
        let status = match (&report, out.join(&s.id).join("series.csv").is_file()) {
            (Some(_), _) => "ok",
            (None, true) => "series",
            (None, false) => "missing",
        };
        rows.push((s, status, scalars));
    }
    let path = out.join("cohort.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["id".to_string(), "organ".to_string(), "status".to_string()];
    header.extend(covariates.iter().cloned());
    header.extend(keys.iter().cloned());
    w.write_record(&header).map_err(|e| at(&path, e))?;
    for (s, status, scalars) in rows {
        let mut row = vec![s.id.clone(), s.organ.clone(), status.to_string()];
        row.extend(
            covariates
                .iter()
                .map(|c| s.covariates.get(c).cloned().unwrap_or_default()),
        );
        row.extend(
            keys.iter()
                .map(|k| scalars.get(k).cloned().unwrap_or_default()),
        );
        w.write_record(&row).map_err(|e| at(&path, e))?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    crate::io::atomic_write(&path, &bytes)?;
    let super::images::Statistics {
        written,
        grids,
        left_out,
    } = super::images::placenta_statistics(out, subjects)?;
    if !written.is_empty() {
        observer.info(&format!(
            "cohort: {} template-space statistics images in {}",
            written.len(),
            out.join("cohort").display()
        ));
    }
    for (name, grid, k) in &grids {
        observer.info(&format!(
            "cohort: {name} of {k} subjects {} grid of {} (cohort/grid.json)",
            if grid.resampled {
                "resampled onto a common"
            } else {
                "on their shared"
            },
            grid.describe()
        ));
    }
    for (id, why) in left_out {
        observer.info(&format!("cohort: {id} left out of the statistics: {why}"));
    }
    for p in super::segments::ventricle_segments(out, subjects)? {
        observer.info(&format!("cohort: wrote {}", p.display()));
    }
    if let Some(p) = super::mitral::mitral_measurements(out, subjects)? {
        observer.info(&format!("cohort: wrote {}", p.display()));
    }
    super::mitral_maps::mitral_maps(out, subjects)?.tell(&out.join("cohort"), observer);
    if let Some(c) = compare {
        super::compare::compare(out, subjects, covariates, c, observer)?;
    }
    // The placenta images with statistics, by name (`<name>_mean.nii.gz`).
    let mut placenta_images: Vec<String> = written
        .iter()
        .filter_map(|p| p.file_name()?.to_str()?.strip_suffix("_mean.nii.gz"))
        .map(str::to_string)
        .collect();
    placenta_images.sort();
    let figures =
        super::figures::cohort_figures(out, covariates, plots, &placenta_images, observer)?;
    if !figures.is_empty() {
        observer.info(&format!(
            "cohort: {} figures in {}",
            figures.len() - 1,
            out.join("cohort").join("figures").display()
        ));
    }
    let page = super::report_page::write_report(out, subjects, covariates)?;
    observer.info(&format!("cohort: wrote {}", page.display()));
    Ok(())
}

/// `unfold cohort OUT --plot ...`: reads `OUT/subjects.csv` (written by a
/// batch) and writes `OUT/cohort.csv`, the statistics, the figures (the
/// scatter plots `plots`; none: the defaults) and `OUT/index.html`.
///
/// # Errors
/// `OUT/subjects.csv` missing or malformed; writing a file; a `plots`
/// entry naming an unknown column; a subject's report that exists but does
/// not read as its organ's ([`AppError::Report`]: the cohort stops).
pub fn gather(
    output: &Path,
    plots: &[PlotSpec],
    observer: &mut dyn Observer,
) -> Result<(), AppError> {
    gather_compare(output, plots, None, observer)
}

/// [`gather`], then the group comparison `compare` (`unfold cohort OUT
/// --compare COLUMN ...`, [`super::compare`]) before the figures and the
/// page.
///
/// # Errors
/// Those of [`gather`]; the comparison's ([`super::compare::compare`]).
pub fn gather_compare(
    output: &Path,
    plots: &[PlotSpec],
    compare: Option<&CompareSettings>,
    observer: &mut dyn Observer,
) -> Result<(), AppError> {
    let path = output.join("subjects.csv");
    let mut reader = csv::Reader::from_path(&path).map_err(|e| {
        at(
            &path,
            format!("{e}; `unfold cohort` reads the subjects an `unfold batch` run wrote"),
        )
    })?;
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| at(&path, e))?
        .iter()
        .map(str::to_string)
        .collect();
    if header.first().map(String::as_str) != Some("id")
        || header.get(1).map(String::as_str) != Some("organ")
    {
        return Err(at(&path, "the header must start with id,organ"));
    }
    let covariates: Vec<String> = header[2..].to_vec();
    let mut subjects = Vec::new();
    for r in reader.records() {
        let r = r.map_err(|e| at(&path, e))?;
        let id = r.get(0).unwrap_or("");
        if !valid_id(id) {
            return Err(at(
                &path,
                format!("'{}' is not a subject id", printable(id)),
            ));
        }
        subjects.push(SubjectRow {
            id: id.to_string(),
            organ: r.get(1).unwrap_or("").to_string(),
            covariates: covariates
                .iter()
                .enumerate()
                .map(|(i, c)| (c.clone(), r.get(i + 2).unwrap_or("").to_string()))
                .collect(),
        });
    }
    if let Some(c) = compare {
        super::compare::check(output, &subjects, &covariates, c)?;
    }
    write_cohort_plots(output, &subjects, &covariates, plots, compare, observer)?;
    observer.info(&format!(
        "{}: {} subjects",
        output.join("cohort.csv").display(),
        subjects.len()
    ));
    Ok(())
}
