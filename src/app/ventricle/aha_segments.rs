//! The AHA-segment table of one heart (`DIR/aha_segments.csv`, issue 22):
//! for each of the 17 segments, the anatomy points labelled with it and the
//! mean of every scalar point array of `anatomy.vtu` over them (the
//! cylinder coordinates `xi`, `zeta`, `depth`, and any array the anatomy
//! carried in). The cohort statistics (`cohort_segments`) average the same
//! per-heart means across hearts.

use crate::app::error::{AppError, at};
use crate::mesh::CellMesh;
use std::collections::BTreeMap;
use std::path::Path;

/// One heart's segment figures: points per segment (index `k - 1` for
/// segment `k`) and `(array, segment) -> mean` over the finite values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HeartSegments {
    /// Points labelled `k`, at `k - 1`.
    pub points: [usize; 17],
    /// Mean of each scalar array (not the labels `aha` and `layer`) over the finite values of the
    /// points of each segment that has any.
    pub means: BTreeMap<(String, i32), f64>,
}

/// The segment figures of an anatomy with the point array `aha`
/// (1..=17; other labels are skipped); `None` without it (RV, or not
/// mapped).
pub fn heart_segments(mesh: &CellMesh) -> Option<HeartSegments> {
    let labels = mesh.point_data.get("aha")?;
    let mut out = HeartSegments::default();
    for i in 0..labels.tuples() {
        if let Some(l) = labels.get(i, 0).filter(|l| (1.0..=17.0).contains(l)) {
            out.points[l as usize - 1] += 1;
        }
    }
    let mut sums: BTreeMap<(String, i32), (f64, usize)> = BTreeMap::new();
    for f in mesh.point_data.iter() {
        // Labels, not measurements.
        if f.name() == "aha" || f.name() == "layer" || f.components() != 1 {
            continue;
        }
        for i in 0..f.tuples() {
            let (Some(label), Some(v)) = (labels.get(i, 0), f.get(i, 0)) else {
                continue;
            };
            if !(1.0..=17.0).contains(&label) || !v.is_finite() {
                continue;
            }
            let e = sums
                .entry((f.name().to_string(), label as i32))
                .or_default();
            e.0 += v;
            e.1 += 1;
        }
    }
    out.means = sums
        .into_iter()
        .map(|(k, (s, n))| (k, s / n as f64))
        .collect();
    Some(out)
}

/// `aha_segments.csv`: a row per segment (`segment`, `points`, then one
/// column per array, empty where the segment has no finite value).
///
/// # Errors
/// Only the CSV writer's (named at `path`).
pub fn segment_table(s: &HeartSegments, path: &Path) -> Result<Vec<u8>, AppError> {
    let arrays: Vec<&String> = {
        let mut a: Vec<&String> = s.means.keys().map(|(n, _)| n).collect();
        a.dedup();
        a
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["segment".to_string(), "points".to_string()];
    header.extend(arrays.iter().map(|a| a.to_string()));
    w.write_record(&header).map_err(|e| at(path, e))?;
    for k in 1..=17i32 {
        let mut row = vec![k.to_string(), s.points[k as usize - 1].to_string()];
        for a in &arrays {
            row.push(
                s.means
                    .get(&((*a).clone(), k))
                    .map(|v| v.to_string())
                    .unwrap_or_default(),
            );
        }
        w.write_record(&row).map_err(|e| at(path, e))?;
    }
    w.into_inner().map_err(|e| at(path, e))
}
