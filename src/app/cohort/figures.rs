//! The cohort figures (issue 19 point 3): `unfold cohort` (and so the end of
//! `unfold batch`) draws what it wrote into `OUT/cohort/figures/*.png` and
//! lists them in `OUT/cohort/figures/index.json`, a JSON array of `{"file":
//! "<name>.png", "title": ..., "caption": ..., "subject": "<id>" | null}`
//! (a subject's z bull's-eye carries its id).
//!
//! - `placenta_distortion.png`: per template, box plots of the placentas'
//!   mean `log2 det J` and mean `log2 x_ij/z_ij` (the placenta paper's
//!   Fig. 7; the template from each subject's `report.json`);
//! - `scatter_<measure>_vs_<covariate>.png`: a `cohort.csv` measurement
//!   against a numeric covariate with the least-squares line, the points
//!   coloured by the first categorical covariate that varies among them;
//!   `--plot MEASURE:COVARIATE` chooses them, by default every numeric
//!   covariate against the headline measurements [`HEADLINE`];
//! - `ventricle_<array>_mean_bullseye.png`, `..._std_bullseye.png` and
//!   `ventricle_<array>_z_<id>_bullseye.png` from
//!   `ventricle_segments.csv` and `ventricle_z.csv`;
//! - `placenta_<image>_slices.png`: the mid-depth slices of
//!   `<image>_mean.nii.gz` and `<image>_std.nii.gz` (the count image gives
//!   the covered voxels);
//! - `mitral_energies.png`: the valves' area, angle and length energies
//!   (`mitral_measurements.csv`) by the `phase` covariate (open, closed);
//! - `compare_<image>_<column>.png`: a group comparison's statistic
//!   (`stats/compare.json`, [`super::compare`]) at the slice of its
//!   smallest family-wise p, the significant voxels outlined.
//!
//! A figure needs [`MIN_SUBJECTS`] subjects with its values; one with fewer
//! is skipped, and a line says so. PNGs of an earlier run that this run did
//! not draw are removed, so that the index lists exactly the PNGs present.

use super::compare::file_part;
use super::reports::{SubjectReport, subject_report};
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::files::{read_image_checked, write_figures};
use crate::app::run::printable::printable;
use crate::figures::cohort::bullseyes::{
    SegmentStatistics, mean_bullseye, std_bullseye, z_bullseye,
};
use crate::figures::cohort::distortion::{SubjectDistortion, placenta_distortion};
use crate::figures::cohort::energies::{ValveEnergies, mitral_energies};
use crate::figures::cohort::scatter::{Scatter, ScatterPoint, least_squares, scatter};
use crate::figures::cohort::slices::{ImageStatistics, mean_std_slices};
use crate::figures::{Figure, FigureOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The fewest subjects (or valves, or hearts) a cohort figure is drawn for.
pub(crate) const MIN_SUBJECTS: usize = 3;

/// The headline measurements plotted against every numeric covariate by
/// default (those present in `cohort.csv`): placenta volume and Dirichlet
/// excess, the ventricle map's mean round-trip error, the mitral annulus
/// length.
pub(crate) const HEADLINE: [&str; 4] = [
    "estimates.volume_mm3",
    "dirichlet_excess_percent",
    "roundtrip_error_um.mean",
    "annulus_length_mm",
];

/// `--plot MEASURE:COVARIATE`: a `cohort.csv` column against another.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlotSpec {
    /// The measurement (y).
    pub measure: String,
    /// The covariate (x).
    pub covariate: String,
}

impl std::str::FromStr for PlotSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.rsplit_once(':') {
            Some((m, c)) if !m.is_empty() && !c.is_empty() => Ok(PlotSpec {
                measure: m.to_string(),
                covariate: c.to_string(),
            }),
            _ => Err(format!(
                "'{s}' is not MEASURE:COVARIATE (e.g. estimates.volume_mm3:age_weeks)"
            )),
        }
    }
}

/// `cohort.csv`: its columns and one map per row.
struct Table {
    header: Vec<String>,
    rows: Vec<BTreeMap<String, String>>,
}

impl Table {
    fn read(path: &Path) -> Result<Table, AppError> {
        let mut r = csv::Reader::from_path(path).map_err(|e| at(path, e))?;
        let header: Vec<String> = r
            .headers()
            .map_err(|e| at(path, e))?
            .iter()
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for rec in r.records() {
            let rec = rec.map_err(|e| at(path, e))?;
            rows.push(
                header
                    .iter()
                    .cloned()
                    .zip(rec.iter().map(str::to_string))
                    .collect(),
            );
        }
        Ok(Table { header, rows })
    }

    /// Whether `col` has a value and every value is a finite number.
    fn numeric(&self, col: &str) -> bool {
        let mut any = false;
        for r in &self.rows {
            match r.get(col).map(String::as_str) {
                None | Some("") => {}
                Some(v) => match v.parse::<f64>() {
                    Ok(x) if x.is_finite() => any = true,
                    _ => return false,
                },
            }
        }
        any
    }
}

/// A row's finite number in `col`.
fn num(row: &BTreeMap<String, String>, col: &str) -> Option<f64> {
    row.get(col)
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|x| x.is_finite())
}

/// A figure and its index entry.
struct Entry {
    figure: Figure,
    title: String,
    caption: String,
    subject: Option<String>,
}

/// What the run drew, and what it skipped with why.
#[derive(Default)]
struct Drawn {
    entries: Vec<Entry>,
    skipped: Vec<(String, String)>,
}

impl Drawn {
    fn skip(&mut self, figure: impl Into<String>, why: impl Into<String>) {
        self.skipped.push((figure.into(), why.into()));
    }
}

/// Checks `plots` against the columns of `cohort.csv`.
fn check_plots(table: &Table, plots: &[PlotSpec], path: &Path) -> Result<(), AppError> {
    for p in plots {
        for (what, col) in [("MEASURE", &p.measure), ("COVARIATE", &p.covariate)] {
            if !table.header.contains(col) {
                return Err(AppError::Usage(format!(
                    "--plot {}:{}: {what} '{}' is not a column of {}; the columns are: {}",
                    p.measure,
                    p.covariate,
                    printable(col),
                    path.display(),
                    table.header.join(", ")
                )));
            }
        }
        if !table.numeric(&p.covariate) {
            return Err(AppError::Usage(format!(
                "--plot {}:{}: the column '{}' of {} is not numeric; plot against a numeric \
                 covariate",
                p.measure,
                p.covariate,
                p.covariate,
                path.display()
            )));
        }
    }
    Ok(())
}

/// The scatter plots.
fn scatters(
    table: &Table,
    covariates: &[String],
    plots: &[PlotSpec],
    opts: &FigureOptions,
    drawn: &mut Drawn,
) -> Result<(), AppError> {
    let specs: Vec<PlotSpec> = if plots.is_empty() {
        covariates
            .iter()
            .filter(|c| table.numeric(c))
            .flat_map(|c| {
                HEADLINE
                    .iter()
                    .filter(|m| table.header.iter().any(|h| h == *m))
                    .map(|m| PlotSpec {
                        measure: (*m).to_string(),
                        covariate: c.clone(),
                    })
            })
            .collect()
    } else {
        plots.to_vec()
    };
    for p in &specs {
        let name = format!(
            "scatter_{}_vs_{}.png",
            file_part(&p.measure),
            file_part(&p.covariate)
        );
        let rows: Vec<&BTreeMap<String, String>> = table
            .rows
            .iter()
            .filter(|r| num(r, &p.measure).is_some() && num(r, &p.covariate).is_some())
            .collect();
        let distinct_x = {
            let mut xs: Vec<f64> = rows.iter().filter_map(|r| num(r, &p.covariate)).collect();
            xs.sort_by(f64::total_cmp);
            xs.dedup();
            xs.len()
        };
        if rows.len() < MIN_SUBJECTS || distinct_x < 2 {
            // Defaults that do not apply to this cohort are left out quietly
            // when no subject has the measurement.
            if !plots.is_empty() || !rows.is_empty() {
                drawn.skip(
                    &name,
                    format!(
                        "{} subjects have both {} and {} ({} distinct {} values); it needs {} \
                         and 2",
                        rows.len(),
                        p.measure,
                        p.covariate,
                        distinct_x,
                        p.covariate,
                        MIN_SUBJECTS
                    ),
                );
            }
            continue;
        }
        let colour_by = covariates.iter().find(|c| {
            **c != p.covariate && !table.numeric(c) && {
                let mut v: Vec<&str> = rows
                    .iter()
                    .filter_map(|r| r.get(*c).map(String::as_str))
                    .filter(|v| !v.is_empty())
                    .collect();
                v.sort_unstable();
                v.dedup();
                v.len() >= 2
            }
        });
        let points = rows
            .iter()
            .map(|r| ScatterPoint {
                x: num(r, &p.covariate).unwrap_or(f64::NAN),
                y: num(r, &p.measure).unwrap_or(f64::NAN),
                category: colour_by
                    .and_then(|c| r.get(c))
                    .filter(|v| !v.is_empty())
                    .cloned(),
            })
            .collect();
        let s = Scatter {
            measure: p.measure.clone(),
            covariate: p.covariate.clone(),
            colour_by: colour_by.cloned(),
            points,
        };
        let fig = scatter(&name, &s, opts).map_err(|e| at(Path::new(&name), e))?;
        let xy: Vec<(f64, f64)> = s.points.iter().map(|q| (q.x, q.y)).collect();
        let fit = least_squares(&xy);
        let mut caption = format!(
            "{} against {} for {} subjects with the least-squares line",
            p.measure,
            p.covariate,
            rows.len()
        );
        if let Some(f) = fit {
            let v = crate::figures::render::format_value;
            caption.push_str(&format!(
                " y = {} + {} x (r^2 = {}, n = {})",
                v(f.a),
                v(f.b),
                v(f.r2),
                f.n
            ));
        }
        if let Some(c) = colour_by {
            caption.push_str(&format!("; points coloured by {c}"));
        }
        caption.push('.');
        drawn.entries.push(Entry {
            figure: fig,
            title: format!("{} against {}", p.measure, p.covariate),
            caption,
            subject: None,
        });
    }
    Ok(())
}

/// The placenta distortions per template.
fn distortion(
    out: &Path,
    table: &Table,
    opts: &FigureOptions,
    drawn: &mut Drawn,
) -> Result<(), AppError> {
    let mut subjects = Vec::new();
    for r in table.rows.iter().filter(|r| {
        r.get("organ").map(String::as_str) == Some("placenta")
            && r.get("status").map(String::as_str) == Some("ok")
    }) {
        let (Some(dj), Some(er)) = (num(r, "log2_det_j.mean"), num(r, "log2_edge_ratio.mean"))
        else {
            continue;
        };
        let id = r.get("id").cloned().unwrap_or_default();
        let template = match subject_report(&out.join(&id), "placenta")? {
            Some(SubjectReport::Placenta(r)) => r.report.template.to_string(),
            _ => "unknown".to_string(),
        };
        subjects.push(SubjectDistortion {
            template,
            log2_det_j: dj,
            log2_edge_ratio: er,
        });
    }
    let name = crate::figures::cohort::distortion::DISTORTION_PNG;
    if subjects.len() < MIN_SUBJECTS {
        if !subjects.is_empty() {
            drawn.skip(
                name,
                format!(
                    "{} placentas with distortions; it needs {MIN_SUBJECTS}",
                    subjects.len()
                ),
            );
        }
        return Ok(());
    }
    let fig = placenta_distortion(&subjects, opts).map_err(|e| at(Path::new(name), e))?;
    let mut templates: Vec<&str> = subjects.iter().map(|s| s.template.as_str()).collect();
    templates.sort_unstable();
    templates.dedup();
    drawn.entries.push(Entry {
        figure: fig,
        title: "Placenta distortion per template".into(),
        caption: format!(
            "Box-and-whisker plots of (a) the local volumetric distortion (mean log2 det J) and \
             (b) the metric distortion (mean log2 x_ij/z_ij) of {} placentas per template ({}). \
             Black lines: medians; boxes: 25th to 75th percentiles; whiskers: the most extreme \
             values within 1.5 times the interquartile range; red crosses: outliers beyond.",
            subjects.len(),
            templates.join(", ")
        ),
        subject: None,
    });
    Ok(())
}

/// Reads a CSV file into maps, one per row.
fn read_rows(path: &Path) -> Result<Vec<BTreeMap<String, String>>, AppError> {
    Ok(Table::read(path)?.rows)
}

/// A segment table row's AHA segment, 1 to 17 (`None` for anything else).
fn segment(row: &BTreeMap<String, String>) -> Option<usize> {
    row.get("segment")
        .and_then(|s| s.parse::<usize>().ok())
        .filter(|k| (1..=17).contains(k))
}

/// The ventricle bull's-eyes.
fn bullseyes(out: &Path, opts: &FigureOptions, drawn: &mut Drawn) -> Result<(), AppError> {
    let seg_path = out.join("cohort").join("ventricle_segments.csv");
    if !seg_path.is_file() {
        return Ok(());
    }
    let mut stats: BTreeMap<String, SegmentStatistics> = BTreeMap::new();
    for r in read_rows(&seg_path)? {
        let (Some(array), Some(seg)) = (r.get("array"), segment(&r)) else {
            continue;
        };
        let s = stats
            .entry(array.clone())
            .or_insert_with(|| SegmentStatistics {
                array: array.clone(),
                hearts: [0; 17],
                mean: [None; 17],
                std: [None; 17],
            });
        s.hearts[seg - 1] = r.get("hearts").and_then(|h| h.parse().ok()).unwrap_or(0);
        s.mean[seg - 1] = num(&r, "mean");
        s.std[seg - 1] = num(&r, "std");
    }
    for s in stats.values() {
        let hearts = s.hearts.iter().copied().max().unwrap_or(0);
        if hearts < MIN_SUBJECTS {
            let why = format!("{hearts} hearts; it needs {MIN_SUBJECTS}");
            drawn.skip(crate::figures::cohort::bullseyes::mean_name(&s.array), &why);
            drawn.skip(crate::figures::cohort::bullseyes::std_name(&s.array), why);
            continue;
        }
        let fig = mean_bullseye(s, opts).map_err(|e| at(&seg_path, e))?;
        drawn.entries.push(Entry {
            figure: fig,
            title: format!("Cohort mean of {} per AHA segment", s.array),
            caption: format!(
                "LV bull's-eye of the mean over {hearts} hearts of each heart's mean {} in each \
                 AHA segment (anterior up, septum left).",
                s.array
            ),
            subject: None,
        });
        let fig = std_bullseye(s, opts).map_err(|e| at(&seg_path, e))?;
        drawn.entries.push(Entry {
            figure: fig,
            title: format!("Cohort standard deviation of {} per AHA segment", s.array),
            caption: format!(
                "LV bull's-eye of the sample standard deviation over {hearts} hearts of their \
                 segment means of {}.",
                s.array
            ),
            subject: None,
        });
    }
    let z_path = out.join("cohort").join("ventricle_z.csv");
    if !z_path.is_file() {
        return Ok(());
    }
    type PerSegment = ([Option<f64>; 17], [Option<f64>; 17]);
    let mut by: BTreeMap<(String, String), PerSegment> = BTreeMap::new();
    for r in read_rows(&z_path)? {
        let (Some(id), Some(array), Some(seg)) = (r.get("id"), r.get("array"), segment(&r)) else {
            continue;
        };
        let e = by
            .entry((id.clone(), array.clone()))
            .or_insert(([None; 17], [None; 17]));
        e.0[seg - 1] = num(&r, "z");
        e.1[seg - 1] = num(&r, "value");
    }
    for ((id, array), (z, values)) in &by {
        let name = crate::figures::cohort::bullseyes::z_name(id, array);
        if z.iter().all(Option::is_none) {
            drawn.skip(
                name,
                "no z-score (fewer than 2 other hearts, or they do not vary)",
            );
            continue;
        }
        let fig = z_bullseye(id, array, z, values, opts).map_err(|e| at(&z_path, e))?;
        drawn.entries.push(Entry {
            figure: fig,
            title: format!("{id}: z-scores of {array} per AHA segment"),
            caption: format!(
                "LV bull's-eye of {id}'s z-scores of {array}: per AHA segment, its segment mean \
                 minus the mean of the other hearts, over their standard deviation; blue below, \
                 red above, colours over at least [-2, 2]."
            ),
            subject: Some(id.clone()),
        });
    }
    Ok(())
}

/// The placenta mean and standard deviation slices of `images`.
fn slices(
    out: &Path,
    images: &[String],
    opts: &FigureOptions,
    drawn: &mut Drawn,
) -> Result<(), AppError> {
    let dir = out.join("cohort");
    for image in images {
        let name = crate::figures::cohort::slices::slices_name(image);
        let std_path = dir.join(format!("{image}_std.nii.gz"));
        if !std_path.is_file() {
            drawn.skip(name, format!("no {}", std_path.display()));
            continue;
        }
        let mean = read_image_checked(&dir.join(format!("{image}_mean.nii.gz")), 1.0)?;
        let std = read_image_checked(&std_path, 1.0)?;
        let count_path = dir.join(format!("{image}_count.nii.gz"));
        let count = if count_path.is_file() {
            Some(read_image_checked(&count_path, 1.0)?)
        } else {
            None
        };
        if let Some(c) = &count {
            let most = c.volume.data().iter().fold(0.0f32, |m, &v| m.max(v));
            if (most as usize) < MIN_SUBJECTS {
                drawn.skip(
                    name,
                    format!("at most {most} placentas per voxel; it needs {MIN_SUBJECTS}"),
                );
                continue;
            }
        }
        let stats = ImageStatistics {
            image,
            mean: &mean.volume,
            std: &std.volume,
            count: count.as_ref().map(|c| &c.volume),
        };
        let k = crate::figures::cohort::slices::mid_depth(&stats);
        let fig = mean_std_slices(&stats, opts).map_err(|e| at(&std_path, e))?;
        drawn.entries.push(Entry {
            figure: fig,
            title: format!("Cohort mean and standard deviation of {image}"),
            caption: format!(
                "Mid-depth slice (template grid slice {}) of the voxel-wise mean (left) and \
                 standard deviation (right) of {image} over the placentas in template space, \
                 axes in mm; grey: voxels no placenta covers.",
                k + 1
            ),
            subject: None,
        });
    }
    Ok(())
}

/// The mitral energies open against closed.
fn energies(
    out: &Path,
    table: &Table,
    opts: &FigureOptions,
    drawn: &mut Drawn,
) -> Result<(), AppError> {
    let name = crate::figures::cohort::energies::ENERGIES_PNG;
    let path = out.join("cohort").join("mitral_measurements.csv");
    if !path.is_file() {
        return Ok(());
    }
    if !table.header.iter().any(|h| h == "phase") {
        drawn.skip(name, "no `phase` covariate (open, closed) in the manifest");
        return Ok(());
    }
    let phase: BTreeMap<&str, &str> = table
        .rows
        .iter()
        .filter_map(|r| Some((r.get("id")?.as_str(), r.get("phase")?.as_str())))
        .filter(|(_, p)| !p.is_empty())
        .collect();
    let mut valves = Vec::new();
    for r in read_rows(&path)? {
        let Some(p) = r.get("id").and_then(|id| phase.get(id.as_str())) else {
            continue;
        };
        let (Some(area), Some(angle), Some(length)) = (
            num(&r, "area_energy"),
            num(&r, "angle_energy"),
            num(&r, "length_energy"),
        ) else {
            continue;
        };
        valves.push(ValveEnergies {
            phase: (*p).to_string(),
            area,
            angle,
            length,
        });
    }
    if valves.len() < MIN_SUBJECTS {
        drawn.skip(
            name,
            format!(
                "{} valves with a phase and energies; it needs {MIN_SUBJECTS}",
                valves.len()
            ),
        );
        return Ok(());
    }
    let fig = mitral_energies(&valves, opts).map_err(|e| at(&path, e))?;
    let mut groups: BTreeMap<&str, usize> = BTreeMap::new();
    for v in &valves {
        *groups.entry(v.phase.as_str()).or_default() += 1;
    }
    let counts: Vec<String> = groups.iter().map(|(p, n)| format!("{n} {p}")).collect();
    drawn.entries.push(Entry {
        figure: fig,
        title: "Mitral distortion energies by phase".into(),
        caption: format!(
            "Box plots of the flat maps' area, angle (MIPS) and length energies (2 is an \
             undistorted map) of the valves by phase ({}); red crosses: outliers beyond 1.5 \
             times the interquartile range.",
            counts.join(", ")
        ),
        subject: None,
    });
    Ok(())
}

/// The group comparison's statistic slices, one per placenta image of
/// `OUT/cohort/stats/compare.json`.
fn group_comparison(out: &Path, opts: &FigureOptions, drawn: &mut Drawn) -> Result<(), AppError> {
    use crate::figures::cohort::statistic::{StatisticMaps, statistic_slice};
    let dir = out.join("cohort").join(super::compare::STATS);
    let path = dir.join(super::compare::COMPARE_JSON);
    if !path.is_file() {
        return Ok(());
    }
    let text = std::fs::read_to_string(&path).map_err(|e| at(&path, e))?;
    let json: serde_json::Value = serde_json::from_str(&text).map_err(|e| at(&path, e))?;
    let column = json["column"].as_str().unwrap_or_default();
    let alpha = json["alpha"].as_f64().unwrap_or(super::compare::ALPHA);
    let empty = Vec::new();
    for a in json["analyses"].as_array().unwrap_or(&empty) {
        let (Some("placenta"), Some(image), Some(kind)) = (
            a["organ"].as_str(),
            a["name"].as_str(),
            a["statistic"].as_str(),
        ) else {
            continue;
        };
        let stat_name = if kind == "f" { "F" } else { "t" };
        let stem = format!("{}_{}", file_part(image), file_part(column));
        let stat = read_image_checked(&dir.join(format!("{stem}_{stat_name}.nii.gz")), 1.0)?;
        let pfwe = read_image_checked(&dir.join(format!("{stem}_pfwe.nii.gz")), 1.0)?;
        let maps = StatisticMaps {
            image: &file_part(image),
            column: &file_part(column),
            statistic_name: stat_name,
            statistic: &stat.volume,
            p_fwe: &pfwe.volume,
            alpha,
        };
        let k = crate::figures::cohort::statistic::chosen_slice(&maps);
        let fig = statistic_slice(&maps, opts).map_err(|e| at(&path, e))?;
        drawn.entries.push(Entry {
            figure: fig,
            title: format!("Group comparison: {image} by {column}"),
            caption: format!(
                "{} ({}): the {stat_name} statistic of each tested voxel at template grid slice                  {} (the slice of the smallest family-wise p, {}); outlined in black: p_fwe <                  {alpha} ({} voxels of {} tested in the whole grid); grey: untested (not                  covered by every subject).",
                a["design"].as_str().unwrap_or_default(),
                image,
                k + 1,
                a["min_p_fwe"],
                a["significant"],
                a["tested"]
            ),
            subject: None,
        });
    }
    Ok(())
}

/// Draws the cohort figures of `OUT` (see the module documentation) into
/// `OUT/cohort/figures/` with their `index.json`; `covariates` are the
/// manifest's covariate columns, `plots` the `--plot` requests (none: the
/// default scatter plots), `placenta_images` the names of the placenta
/// images whose statistics the cohort wrote (`<name>_mean.nii.gz`, ...; other
/// statistics in `OUT/cohort/`, such as the mitral maps, are not placenta
/// images). Returns the files written.
///
/// # Errors
/// A `--plot` naming a column `cohort.csv` lacks or a covariate that is not
/// numeric (the message lists the columns); reading the tables, images or a
/// placenta's report ([`AppError::Report`]);
/// drawing or writing a figure.
pub fn cohort_figures(
    out: &Path,
    covariates: &[String],
    plots: &[PlotSpec],
    placenta_images: &[String],
    observer: &mut dyn Observer,
) -> Result<Vec<PathBuf>, AppError> {
    let csv_path = out.join("cohort.csv");
    let table = Table::read(&csv_path)?;
    check_plots(&table, plots, &csv_path)?;
    let opts = FigureOptions::default();
    let mut drawn = Drawn::default();
    distortion(out, &table, &opts, &mut drawn)?;
    scatters(&table, covariates, plots, &opts, &mut drawn)?;
    bullseyes(out, &opts, &mut drawn)?;
    slices(out, placenta_images, &opts, &mut drawn)?;
    energies(out, &table, &opts, &mut drawn)?;
    group_comparison(out, &opts, &mut drawn)?;
    for (figure, why) in &drawn.skipped {
        observer.info(&format!("cohort: figure {figure} skipped: {why}"));
    }
    let cohort_dir = out.join("cohort");
    let fig_dir = cohort_dir.join("figures");
    let figures: Vec<Figure> = drawn.entries.iter().map(|e| e.figure.clone()).collect();
    if figures.is_empty() && !fig_dir.is_dir() {
        return Ok(Vec::new());
    }
    let mut written = write_figures(&cohort_dir, &figures)?;
    // PNGs an earlier run drew and this one did not.
    if let Ok(listing) = std::fs::read_dir(&fig_dir) {
        for e in listing.filter_map(Result::ok) {
            let n = e.file_name().to_string_lossy().into_owned();
            if n.ends_with(".png") && !figures.iter().any(|f| f.name == n) {
                std::fs::remove_file(e.path()).map_err(|err| at(&e.path(), err))?;
            }
        }
    }
    let index: Vec<serde_json::Value> = drawn
        .entries
        .iter()
        .map(|e| {
            serde_json::json!({
                "file": e.figure.name,
                "title": e.title,
                "caption": e.caption,
                "subject": e.subject,
            })
        })
        .collect();
    let path = fig_dir.join("index.json");
    let text = serde_json::to_string_pretty(&index).map_err(|e| at(&path, e))?;
    crate::io::atomic_write(&path, text.as_bytes())?;
    written.push(path);
    Ok(written)
}
