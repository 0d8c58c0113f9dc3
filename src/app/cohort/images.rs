//! Template-space statistics of a placenta cohort (issue 19): every image
//! the subjects pulled into the template (`<name>_flat.nii.gz`) on one
//! common grid ([`super::grid`]: the subjects' shared grid, or their
//! images resampled onto the union of their boxes), gathered voxel by
//! voxel.
//!
//! A subject counts at a voxel when the voxel's centre lies in its
//! flattened mesh (`flattened.vtu`: the pull-back sets the voxels outside
//! it to 0, which is no measurement) and the value is finite. In one pass
//! over the subjects, per voxel, the count `n`, the sum `S` and the sum of
//! squares `Q` (memory: three arrays of the grid, whatever the number of
//! subjects); then
//!
//! ```text
//! mean = S / n        std = sqrt((Q - n mean^2) / (n - 1))   (n >= 2)
//! ```
//!
//! written as `OUT/cohort/<name>_{mean,std,count}.nii.gz` (NaN where
//! undefined). In a second pass every subject's leave-one-out z-score
//! against the others,
//!
//! ```text
//! m = (S - x) / (n - 1)   s^2 = (Q - x^2 - (n - 1) m^2) / (n - 2)   z = (x - m) / s
//! ```
//!
//! (NaN where the others are fewer than two or do not vary), as
//! `OUT/cohort/z/<id>_<name>.nii.gz`. Each image's grid is recorded in
//! `OUT/cohort/grid.json`. A subject whose image has another number of
//! frames than the first subject's is left out and named.

use super::grid::{CommonGrid, FLAT, choose, on_grid};
use super::subject::SubjectRow;
use crate::app::error::{AppError, at};
use crate::app::run::files::ensure_dir;
use crate::io::{NiftiImage, write_image};
use crate::mesh::Volume;
use crate::mesh::nalgebra::Matrix4;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The names of the pulled-back images in `dir` (`<name>` of
/// `<name>_flat.nii.gz`), sorted.
fn flat_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            e.file_name()
                .to_str()
                .and_then(|n| n.strip_suffix(FLAT))
                .map(str::to_string)
        })
        .collect();
    names.sort();
    names
}

/// The placenta subjects with outputs (`report.json`), by image name:
/// `name -> [(id, OUT/<id>)]`, in the subjects' order.
pub fn placenta_images(
    out: &Path,
    subjects: &[SubjectRow],
) -> BTreeMap<String, Vec<(String, PathBuf)>> {
    let mut by_name: BTreeMap<String, Vec<(String, PathBuf)>> = BTreeMap::new();
    for s in subjects.iter().filter(|s| s.organ == "placenta") {
        let d = out.join(&s.id);
        if !d.join("report.json").is_file() {
            continue;
        }
        for n in flat_names(&d) {
            by_name
                .entry(n)
                .or_default()
                .push((s.id.clone(), d.clone()));
        }
    }
    by_name
}

fn write(
    path: &Path,
    dims: [usize; 4],
    affine: Matrix4<f64>,
    data: Vec<f32>,
) -> Result<(), AppError> {
    let vol = Volume::new(dims, affine, data).map_err(|e| at(path, e))?;
    Ok(write_image(path, &NiftiImage::new(vol))?)
}

/// What [`placenta_statistics`] did: the files written, the grid of each
/// image, and the subjects left out with why.
pub struct Statistics {
    /// The images written.
    pub written: Vec<PathBuf>,
    /// `(name, grid, subjects)`: each image's common grid and how many
    /// subjects entered its statistics.
    pub grids: Vec<(String, CommonGrid, usize)>,
    /// `(id, why)` of each subject left out of an image's statistics.
    pub left_out: Vec<(String, String)>,
}

/// Writes the statistics of every pulled-back image of the placenta
/// subjects with a report, on each image's common grid
/// ([`super::grid`]), and `OUT/cohort/grid.json` (per image name: dims,
/// frames, spacing, origin, subjects, resampled).
///
/// # Errors
/// Reading a subject's image or mesh; an image whose affine is not
/// axis-aligned or a common grid too large ([`super::grid::choose`]);
/// writing the results.
pub fn placenta_statistics(out: &Path, subjects: &[SubjectRow]) -> Result<Statistics, AppError> {
    let by_name = placenta_images(out, subjects);
    let stats_dir = out.join("cohort");
    if !by_name.is_empty() {
        ensure_dir(&stats_dir.join("z"))?;
    }
    let mut written = Vec::new();
    let mut left_out = Vec::new();
    let mut grids = Vec::new();
    for (name, members) in by_name {
        let Some((grid, out_of_grid)) = choose(&name, &members)? else {
            continue;
        };
        let leaves: Vec<&String> = out_of_grid.iter().map(|(id, _)| id).collect();
        let members: Vec<&(String, PathBuf)> = members
            .iter()
            .filter(|(id, _)| !leaves.contains(&id))
            .collect();
        left_out.extend(out_of_grid.iter().cloned());
        // pass 1: n, S, Q per voxel on the common grid
        let len = grid.frame_len() * grid.dims[3];
        let (mut n, mut sum, mut sq) = (vec![0u32; len], vec![0.0f64; len], vec![0.0f64; len]);
        for (_, d) in &members {
            let (vol, mask) = on_grid(&grid, d, &name)?;
            let per_frame = mask.len();
            for (i, &x) in vol.data().iter().enumerate() {
                if mask[i % per_frame] && x.is_finite() {
                    let x = f64::from(x);
                    n[i] += 1;
                    sum[i] += x;
                    sq[i] += x * x;
                }
            }
        }
        let (dims, affine) = (grid.dims, grid.affine);
        let mean: Vec<f32> = (0..n.len())
            .map(|i| {
                if n[i] > 0 {
                    (sum[i] / f64::from(n[i])) as f32
                } else {
                    f32::NAN
                }
            })
            .collect();
        let std: Vec<f32> = (0..n.len())
            .map(|i| {
                let c = f64::from(n[i]);
                if n[i] >= 2 {
                    let m = sum[i] / c;
                    ((sq[i] - c * m * m).max(0.0) / (c - 1.0)).sqrt() as f32
                } else {
                    f32::NAN
                }
            })
            .collect();
        let count: Vec<f32> = n.iter().map(|&c| c as f32).collect();
        for (what, data) in [("mean", mean), ("std", std), ("count", count)] {
            let p = stats_dir.join(format!("{name}_{what}.nii.gz"));
            write(&p, dims, affine, data)?;
            written.push(p);
        }
        // pass 2: each subject against the others
        for (id, d) in &members {
            let (vol, mask) = on_grid(&grid, d, &name)?;
            let per_frame = mask.len();
            let z: Vec<f32> = vol
                .data()
                .iter()
                .enumerate()
                .map(|(i, &x)| {
                    if !(mask[i % per_frame] && x.is_finite()) || n[i] < 3 {
                        return f32::NAN;
                    }
                    let x = f64::from(x);
                    let others = f64::from(n[i] - 1);
                    let m = (sum[i] - x) / others;
                    let var = (sq[i] - x * x - others * m * m) / (others - 1.0);
                    let scale = 1e-12 * (m.abs() + 1.0);
                    if var > scale * scale {
                        ((x - m) / var.sqrt()) as f32
                    } else {
                        f32::NAN
                    }
                })
                .collect();
            let p = stats_dir.join("z").join(format!("{id}_{name}.nii.gz"));
            write(&p, dims, affine, z)?;
            written.push(p);
        }
        grids.push((name, grid, members.len()));
    }
    if !grids.is_empty() {
        let path = stats_dir.join("grid.json");
        let json: serde_json::Map<String, serde_json::Value> = grids
            .iter()
            .map(|(name, g, k)| (name.clone(), g.to_json(*k)))
            .collect();
        let text = serde_json::to_string_pretty(&json).map_err(|e| at(&path, e))?;
        crate::io::atomic_write(&path, text.as_bytes())?;
    }
    Ok(Statistics {
        written,
        grids,
        left_out,
    })
}
