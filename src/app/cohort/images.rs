//! Template-space statistics of a placenta cohort (issue 19): every image
//! the subjects pulled into the template (`<name>_flat.nii.gz`) on one
//! grid, gathered voxel by voxel.
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
//! `OUT/cohort/z/<id>_<name>.nii.gz`. A subject whose image is on another
//! grid (a run without the common `--grid`) is left out and named.

use super::subject::SubjectRow;
use crate::app::error::{AppError, at};
use crate::app::run::files::{ensure_dir, read_image_checked};
use crate::io::{NiftiImage, read_tet_mesh, write_image};
use crate::mesh::Volume;
use crate::mesh::nalgebra::{Matrix4, Point3};
use crate::mesh::spatial::TetLocator;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The suffix of a pulled-back image.
const FLAT: &str = "_flat.nii.gz";

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

/// Whether two grids are the same (dims and affine to 1e-6 mm).
fn same_grid(a: &Volume<f32>, b: &Volume<f32>) -> bool {
    a.dims() == b.dims() && (a.affine() - b.affine()).iter().all(|d| d.abs() <= 1e-6)
}

/// Which voxels of `grid` have their centre in the subject's flattened
/// mesh.
fn inside(dir: &Path, grid: &Volume<f32>) -> Result<Vec<bool>, AppError> {
    let mesh = read_tet_mesh(dir.join("flattened.vtu"))?;
    let locator = TetLocator::new(&mesh);
    let [nx, ny, nz, _] = grid.dims();
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = grid.voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
                out.push(locator.locate(&p).is_some());
            }
        }
    }
    Ok(out)
}

/// One subject's image and mask on the common grid.
fn load(dir: &Path, name: &str) -> Result<(Volume<f32>, Vec<bool>), AppError> {
    let img = read_image_checked(&dir.join(format!("{name}{FLAT}")), 1.0)?;
    let mask = inside(dir, &img.volume)?;
    Ok((img.volume, mask))
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

/// What [`placenta_statistics`] did: the files written, and the subjects
/// left out with why.
pub struct Statistics {
    /// The images written.
    pub written: Vec<PathBuf>,
    /// `(id, why)` of each subject left out of an image's statistics.
    pub left_out: Vec<(String, String)>,
}

/// Writes the statistics of every pulled-back image of the placenta
/// subjects with a report.
///
/// # Errors
/// Reading a subject's image or mesh, writing the results.
pub fn placenta_statistics(out: &Path, subjects: &[SubjectRow]) -> Result<Statistics, AppError> {
    let dirs: Vec<(&SubjectRow, PathBuf)> = subjects
        .iter()
        .filter(|s| s.organ == "placenta")
        .map(|s| (s, out.join(&s.id)))
        .filter(|(_, d)| d.join("report.json").is_file())
        .collect();
    let mut by_name: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (k, (_, d)) in dirs.iter().enumerate() {
        for n in flat_names(d) {
            by_name.entry(n).or_default().push(k);
        }
    }
    let stats_dir = out.join("cohort");
    if !by_name.is_empty() {
        ensure_dir(&stats_dir.join("z"))?;
    }
    let mut written = Vec::new();
    let mut left_out = Vec::new();
    for (name, members) in by_name {
        // pass 1: n, S, Q per voxel on the first subject's grid
        // the common grid: the first subject's
        let mut grid: Option<Volume<f32>> = None;
        let mut included = Vec::new();
        let (mut n, mut sum, mut sq) = (Vec::new(), Vec::new(), Vec::new());
        for &k in &members {
            let (s, d) = &dirs[k];
            let (vol, mask) = load(d, &name)?;
            match &grid {
                Some(g) if !same_grid(g, &vol) => {
                    left_out.push((
                        s.id.clone(),
                        format!("{name}{FLAT} is on another grid (give every subject one --grid)"),
                    ));
                    continue;
                }
                Some(_) => {}
                None => {
                    let len = vol.data().len();
                    (n, sum, sq) = (vec![0u32; len], vec![0.0f64; len], vec![0.0f64; len]);
                    grid = Some(vol.clone());
                }
            }
            let per_frame = mask.len();
            for (i, &x) in vol.data().iter().enumerate() {
                if mask[i % per_frame] && x.is_finite() {
                    let x = f64::from(x);
                    n[i] += 1;
                    sum[i] += x;
                    sq[i] += x * x;
                }
            }
            included.push(k);
        }
        let Some(g) = grid else {
            continue;
        };
        let (dims, affine) = (g.dims(), *g.affine());
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
        for &k in &included {
            let (s, d) = &dirs[k];
            let (vol, mask) = load(d, &name)?;
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
            let p = stats_dir.join("z").join(format!("{}_{name}.nii.gz", s.id));
            write(&p, dims, affine, z)?;
            written.push(p);
        }
    }
    Ok(Statistics { written, left_out })
}
