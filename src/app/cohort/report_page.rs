//! `OUT/index.html`: the cohort's visual report (issue 19), written at the
//! end of [`super::cohort::write_cohort`].
//!
//! One static, self-contained page (inline CSS, no JavaScript but the
//! linked viewer's, [`super::linked_viewer`], no network):
//! a header (the unfold version, the time, how many subjects are ok, not
//! converged, failed or missing, the covariates), a navigation list, a
//! cohort section (the key columns of `cohort.csv`, the cohort figures
//! listed in `cohort/figures/index.json` with their titles and captions,
//! links to the tables and statistics files), the group comparison of
//! `unfold cohort --compare` when there is one (`cohort/stats/compare.json`:
//! what was compared, each test's summary, its figures and tables) and one
//! section per subject
//! (organ, covariates, status, convergence, quality flags, figures, and for
//! a failed subject its one-line error and log). Every image and link is a
//! path relative to `OUT`, so the folder can be moved or zipped and opened
//! anywhere; every text read from a file is HTML-escaped. The page is the
//! same for the same outputs apart from its timestamp.

use super::linked_viewer::{page_assets, subject_viewer};
use super::reports::{REPORT, SubjectReport, subject_report};
use super::scalars::flatten;
use super::subject::SubjectRow;
use crate::app::AppError;
use crate::app::error::at;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The report keys (the last part of a dotted key, at any depth) that count
/// problems: zero is ok, anything else is highlighted.
const QUALITY_COUNTS: [&str; 9] = [
    "inverted_tets",
    "folded_faces",
    "overlapping_boundary_faces",
    "flipped_triangles",
    "folded_edges",
    "overlapping_boundary_edges",
    "flipped_disk_triangles",
    "folded_disk_edges",
    "overlapping_disk_boundary_edges",
];

/// A round-trip error (`roundtrip_error_um.*`, micrometres) above this is
/// highlighted: the inverse map should return a point to well under a
/// micrometre.
const ROUNDTRIP_TOLERANCE_UM: f64 = 1.0;

/// `text` for HTML text and attribute values: `&`, `<`, `>`, `"` and `'`
/// as character references.
pub(crate) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A relative path (segments joined by `/`) as a URL: every byte outside
/// RFC 3986's unreserved set (`A-Z a-z 0-9 - . _ ~`) of each segment
/// percent-encoded, then HTML-escaped for an attribute.
fn url(segments: &[&str]) -> String {
    let mut out = String::new();
    for (i, s) in segments.iter().enumerate() {
        if i > 0 {
            out.push('/');
        }
        for b in s.bytes() {
            if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~') {
                out.push(b as char);
            } else {
                let _ = write!(out, "%{b:02X}");
            }
        }
    }
    escape(&out)
}

/// A CSV file's header and rows (none when it cannot be read).
fn read_csv(path: &Path) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let mut r = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .ok()?;
    let header = r.headers().ok()?.iter().map(str::to_string).collect();
    let rows = r
        .records()
        .filter_map(Result::ok)
        .map(|rec| rec.iter().map(str::to_string).collect())
        .collect();
    Some((header, rows))
}

/// The PNG files directly in `dir`, sorted by name.
fn pngs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(Result::ok)
        .filter(|e| e.path().is_file())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| n.to_ascii_lowercase().ends_with(".png"))
        .collect();
    names.sort();
    names
}

/// The files under `dir` (recursively, `skip` left out), as paths relative
/// to `dir` split into segments, sorted.
fn files_under(dir: &Path, skip: &str) -> Vec<Vec<String>> {
    fn walk(dir: &Path, prefix: &[String], skip: &str, out: &mut Vec<Vec<String>>) {
        for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let Ok(name) = e.file_name().into_string() else {
                continue;
            };
            let mut path = prefix.to_vec();
            path.push(name.clone());
            let p = e.path();
            if p.is_dir() {
                if !(prefix.is_empty() && name == skip) {
                    walk(&p, &path, skip, out);
                }
            } else if p.is_file() && !name.starts_with('.') {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, &[], skip, &mut out);
    out.sort();
    out
}

/// A figure of the cohort (`cohort/figures/index.json`).
#[derive(Debug, Clone, serde::Deserialize)]
struct CohortFigure {
    /// Its file in `cohort/figures/`.
    file: String,
    /// Its title.
    #[serde(default)]
    title: String,
    /// What it shows.
    #[serde(default)]
    caption: String,
    /// The subject it belongs to, if one.
    #[serde(default)]
    subject: Option<String>,
}

/// The cohort figures whose files exist, and the problems with the index
/// (an unreadable index, a figure that is not a plain file name of that
/// folder or whose file is missing), shown on the page instead of a broken
/// image.
fn cohort_figures(out: &Path) -> (Vec<CohortFigure>, Vec<String>) {
    let dir = out.join("cohort").join("figures");
    let index = dir.join("index.json");
    if !index.is_file() {
        return (Vec::new(), Vec::new());
    }
    let parsed = std::fs::read_to_string(&index)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str::<Vec<CohortFigure>>(&t).map_err(|e| e.to_string()));
    let figures = match parsed {
        Ok(f) => f,
        Err(e) => return (Vec::new(), vec![format!("cohort/figures/index.json: {e}")]),
    };
    let mut problems = Vec::new();
    let ok = figures
        .into_iter()
        .filter(|f| {
            let plain =
                !f.file.is_empty() && !f.file.starts_with('.') && !f.file.contains(['/', '\\']);
            if !plain {
                problems.push(format!(
                    "cohort/figures/index.json: '{}' is not a file name in cohort/figures",
                    f.file
                ));
                false
            } else if !dir.join(&f.file).is_file() {
                problems.push(format!("cohort/figures/index.json: {} is missing", f.file));
                false
            } else {
                true
            }
        })
        .collect();
    (ok, problems)
}

/// How a subject ended, as the page shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Status {
    /// Outputs and a converged (or solver-free) report.
    Ok,
    /// A mitral series: a report per step.
    Series,
    /// Outputs written, the solver stopped early (exit code 3).
    NotConverged,
    /// In `failures.csv`.
    Failed,
    /// Neither outputs nor a failure (not run yet).
    Missing,
}

impl Status {
    fn label(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Series => "ok (series)",
            Status::NotConverged => "not converged",
            Status::Failed => "failed",
            Status::Missing => "missing",
        }
    }
    fn class(self) -> &'static str {
        match self {
            Status::Ok | Status::Series => "ok",
            Status::NotConverged => "warn",
            Status::Failed | Status::Missing => "bad",
        }
    }
}

/// The quality flags of a report: each [`QUALITY_COUNTS`] key and each
/// `roundtrip_error_um` statistic, by dotted key (`provenance` left out),
/// with whether it is a problem.
fn quality_flags(report: &serde_json::Value) -> Vec<(String, String, bool)> {
    let mut scalars = std::collections::BTreeMap::new();
    flatten("", report, &mut scalars);
    scalars
        .into_iter()
        .filter_map(|(key, value)| {
            let (parent, last) = key.rsplit_once('.').unwrap_or(("", key.as_str()));
            let x = value.parse::<f64>().ok();
            let bad = if QUALITY_COUNTS.contains(&last) {
                x != Some(0.0)
            } else if parent.ends_with("roundtrip_error_um") {
                x.is_none_or(|x| x > ROUNDTRIP_TOLERANCE_UM)
            } else {
                return None;
            };
            Some((key, value, bad))
        })
        .collect()
}

/// The page's inline style sheet.
const STYLE: &str = "body{font-family:sans-serif;margin:0 2em 2em 2em;color:#222}\
h1{margin-top:0.6em}h2{border-bottom:2px solid #888;padding-top:0.5em}\
section{margin-bottom:2em}table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}\
td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}th{background:#eee}\
.ok{color:#176b1f}.warn{color:#9a5b00;font-weight:bold}.bad{color:#b00020;font-weight:bold}\
td.bad,td.warn{background:#fde8e8}figure{display:inline-block;margin:0.5em;vertical-align:top;\
max-width:420px}figure img{max-width:400px;border:1px solid #ddd}\
figcaption{font-size:0.8em}nav ul{columns:4;font-size:0.9em}.error{background:#fde8e8;\
padding:0.5em;font-family:monospace;white-space:pre-wrap}";

/// One `<figure>`: the image at `src` (relative segments) and its caption.
fn figure(html: &mut String, src: &[&str], title: &str, caption: &str) {
    let _ = write!(
        html,
        "<figure><img src=\"{}\" alt=\"{}\" loading=\"eager\"><figcaption><b>{}</b>",
        url(src),
        escape(title),
        escape(title)
    );
    if !caption.is_empty() {
        let _ = write!(html, "<br>{}", escape(caption));
    }
    html.push_str("</figcaption></figure>\n");
}

/// A `<table>` of `header` and `rows`, every cell escaped; a cell for which
/// `class` gives a name gets that class.
fn table(
    html: &mut String,
    header: &[&str],
    rows: &[Vec<String>],
    class: impl Fn(usize, &str) -> Option<&'static str>,
) {
    html.push_str("<table><tr>");
    for h in header {
        let _ = write!(html, "<th>{}</th>", escape(h));
    }
    html.push_str("</tr>\n");
    for row in rows {
        html.push_str("<tr>");
        for (i, cell) in row.iter().enumerate() {
            match class(i, cell) {
                Some(c) => {
                    let _ = write!(html, "<td class=\"{c}\">{}</td>", escape(cell));
                }
                None => {
                    let _ = write!(html, "<td>{}</td>", escape(cell));
                }
            }
        }
        html.push_str("</tr>\n");
    }
    html.push_str("</table>\n");
}

/// A link to `OUT/<segments>` if that file exists.
fn link_if_file(html: &mut String, out: &Path, segments: &[&str], label: &str) {
    let p = segments.iter().fold(out.to_path_buf(), |p, s| p.join(s));
    if p.is_file() {
        let _ = write!(html, "<a href=\"{}\">{}</a> ", url(segments), escape(label));
    }
}

/// The "Group comparison" section from `OUT/cohort/stats/compare.json`
/// (nothing without it): the column, its kind, the covariates, the
/// relabelings and seed, the subjects left out, one row per analysis, the
/// comparison figures and the ventricle and mitral tables.
fn group_comparison(h: &mut String, out: &Path, figures: &[CohortFigure]) {
    let stats = ["cohort", super::compare::STATS];
    let dir = out.join(stats[0]).join(stats[1]);
    let Some(json) = std::fs::read_to_string(dir.join(super::compare::COMPARE_JSON))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
    else {
        return;
    };
    let text = |v: &serde_json::Value| match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Null => String::new(),
        v => v.to_string(),
    };
    let empty = Vec::new();
    let list = |v: &serde_json::Value| {
        v.as_array()
            .unwrap_or(&empty)
            .iter()
            .map(text)
            .collect::<Vec<_>>()
    };
    h.push_str("<section id=\"compare\"><h2>Group comparison</h2>\n");
    let covariates = list(&json["covariates"]);
    let _ = writeln!(
        h,
        "<p>Column <b>{}</b> ({}); covariates: {}; {} relabelings (seed {}), family-wise \
         level {}. ",
        escape(&text(&json["column"])),
        escape(&text(&json["kind"])),
        if covariates.is_empty() {
            "none".to_string()
        } else {
            escape(&covariates.join(", "))
        },
        escape(&text(&json["permutations"])),
        escape(&text(&json["seed"])),
        escape(&text(&json["alpha"]))
    );
    link_if_file(
        h,
        out,
        &[stats[0], stats[1], super::compare::COMPARE_JSON],
        "compare.json",
    );
    h.push_str("</p>\n");
    let left: Vec<Vec<String>> = json["left_out"]
        .as_array()
        .unwrap_or(&empty)
        .iter()
        .map(|l| vec![text(&l["id"]), text(&l["why"])])
        .collect();
    if !left.is_empty() {
        h.push_str("<p>Left out:</p>\n");
        table(h, &["subject", "why"], &left, |_, _| None);
    }
    let header = [
        "organ",
        "name",
        "design",
        "tested",
        "relabelings",
        "exhaustive",
        "min p_fwe",
        "p_fwe < level",
    ];
    let mut files = Vec::new();
    let rows: Vec<Vec<String>> = json["analyses"]
        .as_array()
        .unwrap_or(&empty)
        .iter()
        .map(|a| {
            for f in list(&a["files"]) {
                if !files.contains(&f) {
                    files.push(f);
                }
            }
            [
                "organ",
                "name",
                "design",
                "tested",
                "permutations",
                "exhaustive",
                "min_p_fwe",
                "significant",
            ]
            .iter()
            .map(|k| text(&a[*k]))
            .collect()
        })
        .collect();
    table(h, &header, &rows, |i, cell| {
        (i == 7 && cell != "0").then_some("warn")
    });
    h.push_str("<p>Files: ");
    for f in &files {
        link_if_file(h, out, &[stats[0], stats[1], f], f);
    }
    h.push_str("</p>\n");
    for f in figures.iter().filter(|f| f.file.starts_with("compare_")) {
        figure(h, &["cohort", "figures", &f.file], &f.title, &f.caption);
    }
    for f in files.iter().filter(|f| f.ends_with(".csv")) {
        if let Some((header, rows)) = read_csv(&dir.join(f)) {
            let _ = writeln!(h, "<h3>{}</h3>", escape(f));
            let names: Vec<&str> = header.iter().map(String::as_str).collect();
            let p_fwe = names.iter().position(|n| *n == "p_fwe");
            table(h, &names, &rows, |i, cell| {
                (Some(i) == p_fwe && cell.parse::<f64>().is_ok_and(|p| p < 0.05)).then_some("warn")
            });
        }
    }
    h.push_str("</section>\n");
}

/// Writes `OUT/index.html` for `subjects` (see the module documentation);
/// returns its path.
///
/// # Errors
/// Writing the page; a subject's report that exists but does not read as
/// its organ's ([`AppError::Report`]).
pub fn write_report(
    out: &Path,
    subjects: &[SubjectRow],
    covariates: &[String],
) -> Result<PathBuf, AppError> {
    let failures: BTreeMap<String, (String, String)> = read_csv(&out.join("failures.csv"))
        .map(|(_, rows)| {
            rows.into_iter()
                .filter(|r| r.len() >= 4)
                .map(|r| (r[0].clone(), (r[2].clone(), r[3].clone())))
                .collect()
        })
        .unwrap_or_default();
    let reports: Vec<Option<SubjectReport>> = subjects
        .iter()
        .map(|s| subject_report(&out.join(&s.id), &s.organ))
        .collect::<Result<_, _>>()?;
    let statuses: Vec<Status> = subjects
        .iter()
        .zip(&reports)
        .map(|(s, r)| {
            if failures.contains_key(&s.id) {
                Status::Failed
            } else if let Some(r) = r {
                if r.convergence().is_some_and(|c| !c.converged) {
                    Status::NotConverged
                } else {
                    Status::Ok
                }
            } else if out.join(&s.id).join("series.csv").is_file() {
                Status::Series
            } else {
                Status::Missing
            }
        })
        .collect();
    let count = |f: &dyn Fn(Status) -> bool| statuses.iter().filter(|&&s| f(s)).count();
    let (figures, figure_problems) = cohort_figures(out);

    let mut h = String::new();
    h.push_str(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>unfold cohort report</title><style>",
    );
    h.push_str(STYLE);
    h.push_str("</style></head><body>\n<header><h1>unfold cohort report</h1>\n");
    let when = humantime::format_rfc3339_seconds(std::time::SystemTime::now());
    let _ = writeln!(
        h,
        "<p>unfold {} &middot; written {when} &middot; {} subjects: \
         <span class=\"ok\">{} ok</span>, <span class=\"warn\">{} not converged</span>, \
         <span class=\"bad\">{} failed</span>, <span class=\"bad\">{} missing</span></p>",
        env!("CARGO_PKG_VERSION"),
        subjects.len(),
        count(&|s| matches!(s, Status::Ok | Status::Series)),
        count(&|s| s == Status::NotConverged),
        count(&|s| s == Status::Failed),
        count(&|s| s == Status::Missing),
    );
    let _ = writeln!(
        h,
        "<p>Covariates: {}</p></header>",
        if covariates.is_empty() {
            "none".to_string()
        } else {
            covariates
                .iter()
                .map(|c| escape(c))
                .collect::<Vec<_>>()
                .join(", ")
        }
    );

    // navigation
    h.push_str("<nav><h2>Contents</h2><ul>\n<li><a href=\"#cohort\">Cohort</a></li>\n");
    for (s, st) in subjects.iter().zip(&statuses) {
        let _ = writeln!(
            h,
            "<li><a href=\"#s-{}\">{}</a> <span class=\"{}\">{}</span></li>",
            url(&[&s.id]),
            escape(&s.id),
            st.class(),
            st.label()
        );
    }
    h.push_str("</ul></nav>\n");

    // the cohort
    h.push_str("<section id=\"cohort\"><h2>Cohort</h2>\n<p>Tables: ");
    for name in ["cohort.csv", "subjects.csv", "failures.csv"] {
        link_if_file(&mut h, out, &[name], name);
    }
    h.push_str("</p>\n");
    if let Some((header, rows)) = read_csv(&out.join("cohort.csv")) {
        // the key columns: who, the covariates, convergence, the quality counts
        let keep: Vec<usize> = header
            .iter()
            .enumerate()
            .filter(|(_, c)| {
                matches!(
                    c.as_str(),
                    "id" | "organ" | "status" | "converged" | "iterations" | "stop_reason"
                ) || covariates.contains(c)
                    || QUALITY_COUNTS.contains(&c.as_str())
                    || c.as_str() == "roundtrip_error_um.max"
            })
            .map(|(i, _)| i)
            .collect();
        let names: Vec<&str> = keep.iter().map(|&i| header[i].as_str()).collect();
        let cells: Vec<Vec<String>> = rows
            .iter()
            .map(|r| {
                keep.iter()
                    .map(|&i| r.get(i).cloned().unwrap_or_default())
                    .collect()
            })
            .collect();
        let _ = writeln!(
            h,
            "<p>The key columns of cohort.csv ({} of {}; the file has them all):</p>",
            names.len(),
            header.len()
        );
        table(&mut h, &names, &cells, |i, cell| {
            let name = names[i];
            if QUALITY_COUNTS.contains(&name) {
                (!cell.is_empty() && cell != "0").then_some("bad")
            } else if name == "converged" {
                (cell == "0").then_some("warn")
            } else if name == "status" {
                (cell == "missing").then_some("bad")
            } else if name == "roundtrip_error_um.max" {
                cell.parse::<f64>()
                    .is_ok_and(|x| x > ROUNDTRIP_TOLERANCE_UM)
                    .then_some("bad")
            } else {
                None
            }
        });
    }
    let stats = files_under(&out.join("cohort"), "figures");
    if !stats.is_empty() {
        h.push_str("<h3>Statistics</h3><ul>\n");
        for f in &stats {
            let mut segs = vec!["cohort"];
            segs.extend(f.iter().map(String::as_str));
            let _ = writeln!(
                h,
                "<li><a href=\"{}\">{}</a></li>",
                url(&segs),
                escape(&segs.join("/"))
            );
        }
        h.push_str("</ul>\n");
    }
    if !figures.is_empty() || !figure_problems.is_empty() {
        h.push_str("<h3>Figures</h3>\n");
        for p in &figure_problems {
            let _ = writeln!(h, "<p class=\"bad\">{}</p>", escape(p));
        }
        for f in &figures {
            figure(
                &mut h,
                &["cohort", "figures", &f.file],
                &f.title,
                &f.caption,
            );
        }
    }
    h.push_str("</section>\n");
    group_comparison(&mut h, out, &figures);

    // the subjects
    for ((s, st), report) in subjects.iter().zip(&statuses).zip(&reports) {
        let _ = writeln!(
            h,
            "<section id=\"s-{}\" class=\"subject\"><h2>{} <small>({})</small> \
             <span class=\"{}\">{}</span></h2>",
            url(&[&s.id]),
            escape(&s.id),
            escape(&s.organ),
            st.class(),
            st.label()
        );
        if !covariates.is_empty() {
            let row: Vec<String> = covariates
                .iter()
                .map(|c| s.covariates.get(c).cloned().unwrap_or_default())
                .collect();
            let names: Vec<&str> = covariates.iter().map(String::as_str).collect();
            table(&mut h, &names, &[row], |_, _| None);
        }
        if let Some((code, message)) = failures.get(&s.id) {
            let _ = writeln!(
                h,
                "<p>Failed (exit code {}):</p><p class=\"error\">{}</p>",
                escape(if code.is_empty() { "none" } else { code }),
                escape(message)
            );
        }
        if *st == Status::Missing {
            h.push_str("<p class=\"bad\">No outputs and no failure: not run yet.</p>\n");
        }
        h.push_str("<p>");
        link_if_file(&mut h, out, &[&s.id, "report.json"], "report.json");
        link_if_file(&mut h, out, &[&s.id, "series.csv"], "series.csv");
        let log = format!("{}.log", s.id);
        link_if_file(&mut h, out, &["logs", &log], &format!("logs/{log}"));
        h.push_str("</p>\n");
        if let Some(r) = report {
            if let Some(c) = r.convergence() {
                let ok = c.converged;
                let _ = writeln!(
                    h,
                    "<p>Convergence: <span class=\"{}\">{}</span>, {} iterations, stop \
                     reason {}</p>",
                    if ok { "ok" } else { "warn" },
                    if ok { "converged" } else { "not converged" },
                    escape(&c.iterations.to_string()),
                    escape(&c.stop_reason)
                );
            }
            let value = r
                .to_value()
                .map_err(|e| at(&out.join(&s.id).join(REPORT), e))?;
            let flags = quality_flags(&value);
            if !flags.is_empty() {
                h.push_str("<h3>Quality</h3>\n");
                let rows: Vec<Vec<String>> = flags
                    .iter()
                    .map(|(k, v, bad)| {
                        vec![
                            k.clone(),
                            v.clone(),
                            if *bad { "check" } else { "ok" }.to_string(),
                        ]
                    })
                    .collect();
                table(&mut h, &["flag", "value", ""], &rows, |i, cell| {
                    (i == 2).then_some(if cell == "ok" { "ok" } else { "bad" })
                });
            }
        }
        // the subject's figures: its own, each series step's, the cohort's about it
        let mut figs: Vec<(Vec<String>, String)> = pngs(&out.join(&s.id).join("figures"))
            .into_iter()
            .map(|f| {
                (
                    vec![s.id.clone(), "figures".into(), f.clone()],
                    f.trim_end_matches(".png").to_string(),
                )
            })
            .collect();
        let mut steps: Vec<String> = std::fs::read_dir(out.join(&s.id))
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| e.path().is_dir())
            .filter_map(|e| e.file_name().into_string().ok())
            .filter(|n| n.starts_with("step_"))
            .collect();
        steps.sort();
        for step in &steps {
            for f in pngs(&out.join(&s.id).join(step).join("figures")) {
                let title = format!("{step}: {}", f.trim_end_matches(".png"));
                figs.push((vec![s.id.clone(), step.clone(), "figures".into(), f], title));
            }
        }
        let own: Vec<&CohortFigure> = figures
            .iter()
            .filter(|f| f.subject.as_deref() == Some(s.id.as_str()))
            .collect();
        if !figs.is_empty() || !own.is_empty() {
            h.push_str("<h3>Figures</h3>\n");
            for (segs, title) in &figs {
                let segs: Vec<&str> = segs.iter().map(String::as_str).collect();
                figure(&mut h, &segs, title, "");
            }
            for f in own {
                figure(
                    &mut h,
                    &["cohort", "figures", &f.file],
                    &f.title,
                    &f.caption,
                );
            }
        }
        subject_viewer(&mut h, out, &s.id, report.as_ref());
        h.push_str("</section>\n");
    }
    page_assets(&mut h);
    h.push_str("</body></html>\n");
    let path = out.join("index.html");
    crate::io::atomic_write(&path, h.as_bytes())?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_entries_missing_or_outside_the_folder_are_reported_not_shown() {
        let dir = tempfile::tempdir().unwrap();
        let figs = dir.path().join("cohort").join("figures");
        std::fs::create_dir_all(&figs).unwrap();
        for f in ["spread.png", "s1 outlier.png"] {
            std::fs::write(figs.join(f), b"\x89PNG\r\n\x1a\n").unwrap();
        }
        std::fs::write(dir.path().join("s1.vtu"), "x").unwrap();
        std::fs::write(
            figs.join("index.json"),
            r#"[{"file": "spread.png", "title": "Spread <b>", "caption": "over the cohort", "subject": null},
                {"file": "s1 outlier.png", "title": "Outlier", "caption": "s1 against the rest", "subject": "s1"},
                {"file": "gone.png", "title": "Gone", "caption": "", "subject": null},
                {"file": "../s1.vtu", "title": "Escape", "caption": "", "subject": null}]"#,
        )
        .unwrap();
        let (found, problems) = cohort_figures(dir.path());
        let files: Vec<&str> = found.iter().map(|f| f.file.as_str()).collect();
        assert_eq!(files, ["spread.png", "s1 outlier.png"]);
        assert_eq!(found[1].subject.as_deref(), Some("s1"));
        assert_eq!(found[0].title, "Spread <b>");
        assert_eq!(
            problems,
            [
                "cohort/figures/index.json: gone.png is missing",
                "cohort/figures/index.json: '../s1.vtu' is not a file name in cohort/figures",
            ]
        );
        // An unreadable index: no figures, one problem naming the file.
        std::fs::write(figs.join("index.json"), "{not json").unwrap();
        let (found, problems) = cohort_figures(dir.path());
        assert!(found.is_empty());
        assert_eq!(problems.len(), 1);
        assert!(
            problems[0].starts_with("cohort/figures/index.json: "),
            "{problems:?}"
        );
    }

    #[test]
    fn text_from_files_is_escaped() {
        assert_eq!(
            escape("<script>alert('x')</script> & \"y\""),
            "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;y&quot;"
        );
        assert_eq!(escape("plain-id_01"), "plain-id_01");
    }

    /// `escape`'s inverse, for the round trip.
    fn unescape(text: &str) -> String {
        text.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&#39;", "'")
            .replace("&amp;", "&")
    }

    proptest::proptest! {
        #[test]
        fn escaping_leaves_no_markup_and_round_trips(text in "\\PC*") {
            let e = escape(&text);
            proptest::prop_assert!(!e.contains(['<', '>', '"', '\'']));
            proptest::prop_assert_eq!(unescape(&e), text);
        }
    }

    #[test]
    fn urls_are_relative_and_percent_encoded() {
        assert_eq!(url(&["s1", "figures", "a b.png"]), "s1/figures/a%20b.png");
        assert_eq!(url(&["x\"<y>.png"]), "x%22%3Cy%3E.png");
        assert_eq!(url(&["é.png"]), "%C3%A9.png");
    }

    #[test]
    fn quality_counts_flag_non_zero_and_skip_provenance() {
        let r = serde_json::json!({
            "inverted_tets": 0,
            "folded_faces": 2,
            "roundtrip_error_um": {"mean": 0.001, "max": 3.5},
            "repair": {"flipped": 4},
            "nested": {"flipped_triangles": 0},
            "provenance": {"inverted_tets": 9}
        });
        let flags = quality_flags(&r);
        let get = |k: &str| flags.iter().find(|f| f.0 == k).map(|f| f.2);
        assert_eq!(get("inverted_tets"), Some(false));
        assert_eq!(get("folded_faces"), Some(true));
        assert_eq!(get("roundtrip_error_um.mean"), Some(false));
        assert_eq!(get("roundtrip_error_um.max"), Some(true));
        assert_eq!(get("nested.flipped_triangles"), Some(false));
        assert_eq!(get("repair.flipped"), None);
        assert_eq!(flags.len(), 5, "{flags:?}");
    }
}
