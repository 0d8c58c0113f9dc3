//! AHA-segment statistics of a ventricle cohort (issue 19): every scalar
//! point array of the subjects' `anatomy.vtu` (the cylinder coordinates
//! `xi`, `zeta`, `depth`, and any array the anatomy carried in, e.g. a scar
//! or thickness map) averaged over each of the 17 segments per heart, then
//! across hearts.
//!
//! For an array `a` and segment `k`, heart `h`'s value is the mean of `a`
//! over its points labelled `k` (`aha`); across the `n` hearts with points
//! in `k`, `OUT/cohort/ventricle_segments.csv` gives `n`, the mean and the
//! sample standard deviation of those values, and
//! `OUT/cohort/ventricle_z.csv` each heart's value and its leave-one-out
//! z-score `(v_h - m) / s` against the other hearts' mean `m` and standard
//! deviation `s` (empty where the others are fewer than two or do not
//! vary).

use super::subject::SubjectRow;
use crate::app::error::{AppError, at};
use crate::app::run::files::ensure_dir;
use crate::app::ventricle::aha_segments::heart_segments;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `(array, segment) -> [(subject id, the heart's segment mean)]`.
type SegmentMeans = BTreeMap<(String, i32), Vec<(String, f64)>>;

/// One heart's segment means of every scalar point array of `anatomy.vtu`.
pub(super) fn heart_means(dir: &Path) -> Result<BTreeMap<(String, i32), f64>, AppError> {
    let path = dir.join("anatomy.vtu");
    let mesh = crate::io::read_mesh(&path)?;
    heart_segments(&mesh)
        .map(|s| s.means)
        .ok_or_else(|| at(&path, "has no 'aha' point array"))
}

/// Mean and sample standard deviation (`None` below two values).
fn mean_std(values: impl Iterator<Item = f64> + Clone) -> (f64, Option<f64>) {
    let n = values.clone().count() as f64;
    let mean = values.clone().sum::<f64>() / n;
    let std =
        (n >= 2.0).then(|| (values.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
    (mean, std)
}

/// Writes the segment statistics of the ventricle subjects with a report;
/// the files written (none without a ventricle subject).
///
/// # Errors
/// Reading a subject's `anatomy.vtu`, writing the tables.
pub fn ventricle_segments(out: &Path, subjects: &[SubjectRow]) -> Result<Vec<PathBuf>, AppError> {
    let mut by: SegmentMeans = BTreeMap::new();
    for s in subjects.iter().filter(|s| s.organ == "ventricle") {
        let dir = out.join(&s.id);
        if !dir.join("report.json").is_file() {
            continue;
        }
        for (key, v) in heart_means(&dir)? {
            by.entry(key).or_default().push((s.id.clone(), v));
        }
    }
    if by.is_empty() {
        return Ok(Vec::new());
    }
    let stats_dir = out.join("cohort");
    ensure_dir(&stats_dir)?;
    let seg_path = stats_dir.join("ventricle_segments.csv");
    let z_path = stats_dir.join("ventricle_z.csv");
    let mut seg = csv::Writer::from_writer(Vec::new());
    let mut zw = csv::Writer::from_writer(Vec::new());
    let e1 = |e: csv::Error| at(&seg_path, e);
    seg.write_record(["array", "segment", "hearts", "mean", "std"])
        .map_err(e1)?;
    zw.write_record(["id", "array", "segment", "value", "z"])
        .map_err(|e| at(&z_path, e))?;
    for ((array, segment), hearts) in &by {
        let (mean, std) = mean_std(hearts.iter().map(|h| h.1));
        seg.write_record([
            array.clone(),
            segment.to_string(),
            hearts.len().to_string(),
            mean.to_string(),
            std.map(|s| s.to_string()).unwrap_or_default(),
        ])
        .map_err(e1)?;
        for (k, (id, v)) in hearts.iter().enumerate() {
            let others = hearts
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != k)
                .map(|(_, h)| h.1);
            let z = match mean_std(others) {
                (m, Some(s)) if s > 1e-12 * (m.abs() + 1.0) => ((v - m) / s).to_string(),
                _ => String::new(),
            };
            zw.write_record([
                id.clone(),
                array.clone(),
                segment.to_string(),
                v.to_string(),
                z,
            ])
            .map_err(|e| at(&z_path, e))?;
        }
    }
    let bytes = seg.into_inner().map_err(|e| at(&seg_path, e))?;
    crate::io::atomic_write(&seg_path, &bytes)?;
    let bytes = zw.into_inner().map_err(|e| at(&z_path, e))?;
    crate::io::atomic_write(&z_path, &bytes)?;
    Ok(vec![seg_path, z_path])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_std() {
        let (m, s) = mean_std([1.0, 2.0, 3.0, 4.0].into_iter());
        assert_eq!(m, 2.5);
        assert!((s.unwrap() - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(mean_std([7.0].into_iter()).1, None);
    }
}
