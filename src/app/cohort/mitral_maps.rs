//! Mean maps of a mitral cohort on one common `(u, v)` grid (issue 19;
//! ALGORITHMS 4.8 "Mitral cohort maps").
//!
//! Every flat map of the mitral subjects (`OUT/<id>/valve2d.vtu`, and each
//! `OUT/<id>/step_NNN/valve2d.vtu` of a series, every step a map of its
//! own) is normalised by its annulus: with `U` the annulus' `u` extent
//! (`u_extent_mm` of the map's `report.json`; the anterolateral commissure
//! at `u = 0` and again, after the cut, at `u = U`) and `v_top` the highest
//! `v` of the map (the saddle horn: the leaflets hang below their annulus),
//!
//! ```text
//! u' = u / U        v' = (v - v_top) / U
//! ```
//!
//! one scale for both axes, so shapes are not distorted, both commissures
//! land on `u' = 0` and `1`, the horn on `v' = 0`, and a valve scaled by
//! any factor has the same normalised map. The grid covers
//! `[0, 1] x [-1/2, 0]` with [`NU`] x [`NV`] square cells (of `U / 256`:
//! 0.35 mm on a 90 mm annulus); a map's part outside it (deeper leaflets,
//! the gap of `--cut-posteromedial` beyond `u' = 1`) is left out, and a
//! map with more than 1% of its area outside is named.
//!
//! Each map's floating-point scalar arrays (point arrays: `length_energy`,
//! `coaptation_distance_mm`, `tenting_mm`; cell arrays: `area_energy`,
//! `angle_energy`) are rasterised at the cell centres
//! ([`crate::mesh::raster`]: point arrays linear in each flat triangle,
//! cell arrays constant); the label arrays (`leaflet`, `carpentier`,
//! `u_interval`, `checker`, `coaptation`) are categories, not quantities to
//! average, and the vectors (`u_gradient`, `uv`) are left out. Per array
//! and cell, Welford's one-pass update over the maps holding a finite
//! value there (`n`, the mean `m`, `M2`; three grids per array, whatever
//! the number of maps):
//!
//! ```text
//! n <- n + 1    d = x - m    m <- m + d / n    M2 <- M2 + d (x - m)
//! std = sqrt(M2 / (n - 1))   (n >= 2, else NaN)
//! ```
//!
//! written as `OUT/cohort/mitral_<array>_{mean,std,count}.nii.gz`: 2D NIfTI
//! images of one slice whose affine takes voxel `(i, j, 0)` to the cell
//! centre `(u', v', 0)` (NaN where undefined). NIfTI, as the placenta
//! statistics: nibabel, ITK, 3D Slicer and ParaView read it, it holds
//! NaN, and an image is the natural form of a regular grid.

use super::reports::{SubjectReport, subject_report};
use super::subject::SubjectRow;
use crate::app::error::{AppError, at};
use crate::app::mitral::MitralReport;
use crate::app::observer::Observer;
use crate::app::run::files::ensure_dir;
use crate::io::{NiftiImage, read_mesh, write_image};
use crate::mesh::nalgebra::Matrix4;
use crate::mesh::raster::{Coverage, Grid2};
use crate::mesh::{FieldValues, Fields, Volume};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Grid cells along `u'` (`[0, 1]`).
pub(crate) const NU: usize = 256;
/// Grid cells along `v'` (`[-1/2, 0]`).
pub(crate) const NV: usize = 128;
/// The lowest `v'` of the grid.
const V_LOW: f64 = -0.5;

/// The common grid over the normalised box.
fn grid() -> Grid2 {
    Grid2 {
        origin: [0.0, V_LOW],
        spacing: [1.0 / NU as f64, -V_LOW / NV as f64],
        dims: [NU, NV],
    }
}

/// One array's running statistics per cell (Welford).
struct Accumulator {
    n: Vec<u32>,
    mean: Vec<f64>,
    m2: Vec<f64>,
}

impl Accumulator {
    fn new(len: usize) -> Self {
        Accumulator {
            n: vec![0; len],
            mean: vec![0.0; len],
            m2: vec![0.0; len],
        }
    }

    fn add(&mut self, sample: &[Option<f64>]) {
        for (k, x) in sample.iter().enumerate() {
            let Some(x) = x.filter(|x| x.is_finite()) else {
                continue;
            };
            self.n[k] += 1;
            let d = x - self.mean[k];
            self.mean[k] += d / f64::from(self.n[k]);
            self.m2[k] += d * (x - self.mean[k]);
        }
    }
}

/// The flat maps of the mitral subjects: `(label, directory)`, a series'
/// steps in order.
fn maps(out: &Path, subjects: &[SubjectRow]) -> Vec<(String, PathBuf)> {
    let mut found = Vec::new();
    for s in subjects.iter().filter(|s| s.organ == "mitral") {
        let dir = out.join(&s.id);
        if dir.join("series.csv").is_file() {
            let mut steps: Vec<(String, PathBuf)> = std::fs::read_dir(&dir)
                .into_iter()
                .flatten()
                .flatten()
                .filter_map(|e| {
                    let name = e.file_name().to_str()?.to_string();
                    (name.starts_with("step_") && e.path().join("valve2d.vtu").is_file())
                        .then(|| (format!("{}/{name}", s.id), e.path()))
                })
                .collect();
            steps.sort();
            found.extend(steps);
        } else if dir.join("valve2d.vtu").is_file() {
            found.push((s.id.clone(), dir));
        }
    }
    found
}

/// The floating-point scalar arrays of `fields` with `tuples` values.
fn scalar_arrays(fields: &Fields, tuples: usize) -> Vec<(String, Vec<f64>)> {
    fields
        .iter()
        .filter(|f| f.components() == 1 && f.tuples() == tuples)
        .filter(|f| matches!(f.values(), FieldValues::F64(_) | FieldValues::F32(_)))
        .map(|f| (f.name().to_string(), f.values().to_f64()))
        .collect()
}

/// One map: its coverage of the grid, its arrays sampled, and the share of
/// its area outside the grid.
type Sampled = (Vec<(String, Vec<Option<f64>>)>, f64);

/// Reads, normalises and rasterises one map (module doc) with its
/// `report` (none: the map has no report); the reason when it cannot be
/// used.
fn sample(dir: &Path, report: Option<&MitralReport>) -> Result<Sampled, String> {
    let report = report.ok_or("no readable report.json next to valve2d.vtu")?;
    let extent = report.report.u_extent_mm;
    if !(extent.is_finite() && extent > 0.0) {
        return Err(format!(
            "its report's u_extent_mm is {extent}, not a length > 0 to normalise by"
        ));
    }
    let mesh = read_mesh(dir.join("valve2d.vtu"))
        .map_err(|e| e.to_string())?
        .to_tri_mesh()
        .map_err(|e| format!("valve2d.vtu: {e}"))?;
    let top = mesh
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f64::NEG_INFINITY, f64::max);
    let uv: Vec<[f64; 2]> = mesh
        .positions
        .iter()
        .map(|p| [p.x / extent, (p.y - top) / extent])
        .collect();
    let g = grid();
    let cov = Coverage::new(&uv, &mesh.triangles, &g).map_err(|e| format!("valve2d.vtu: {e}"))?;
    let mut arrays = Vec::new();
    for (name, values) in scalar_arrays(&mesh.point_data, uv.len()) {
        let r = cov
            .point_field(&values)
            .map_err(|e| format!("{name}: {e}"))?;
        arrays.push((name, r));
    }
    for (name, values) in scalar_arrays(&mesh.cell_data, mesh.triangles.len()) {
        let r = cov
            .cell_field(&values)
            .map_err(|e| format!("{name}: {e}"))?;
        arrays.push((name, r));
    }
    let area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| uv[v as usize]);
            ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs() / 2.0
        })
        .sum();
    let cell_area = g.spacing[0] * g.spacing[1];
    let covered = (0..g.len()).filter(|&k| cov.count(k) > 0).count() as f64 * cell_area;
    let outside = if area > 0.0 {
        (1.0 - covered / area).max(0.0)
    } else {
        0.0
    };
    Ok((arrays, outside))
}

/// What [`mitral_maps`] did: the images written, the maps used, and the
/// maps left out (or partly outside the grid) with why.
pub struct MitralMaps {
    /// The images written.
    pub written: Vec<PathBuf>,
    /// The number of flat maps averaged.
    pub maps: usize,
    /// `(map, why)`: a map left out, or more than 1% of it outside the grid.
    pub notes: Vec<(String, String)>,
}

impl MitralMaps {
    /// Tells `observer` what was written into `dir` and every note, one
    /// line each.
    pub fn tell(&self, dir: &Path, observer: &mut dyn Observer) {
        if !self.written.is_empty() {
            observer.info(&format!(
                "cohort: {} mitral map images over {} flat maps in {}",
                self.written.len(),
                self.maps,
                dir.display()
            ));
        }
        for (map, why) in &self.notes {
            observer.info(&format!("cohort: {map}: {why}"));
        }
    }
}

/// Writes the mean, std and count images of every scalar array of the
/// mitral subjects' flat maps (module doc).
///
/// # Errors
/// Writing an image; a map's report that exists but does not read as a
/// valve's ([`AppError::Report`]).
pub fn mitral_maps(out: &Path, subjects: &[SubjectRow]) -> Result<MitralMaps, AppError> {
    let g = grid();
    let mut stats: BTreeMap<String, Accumulator> = BTreeMap::new();
    let mut notes = Vec::new();
    let mut used = 0;
    for (label, dir) in maps(out, subjects) {
        let report = match subject_report(&dir, "mitral")? {
            Some(SubjectReport::Mitral(r)) => Some(r),
            _ => None,
        };
        match sample(&dir, report.as_deref()) {
            Ok((arrays, outside)) => {
                used += 1;
                for (name, r) in arrays {
                    stats
                        .entry(name)
                        .or_insert_with(|| Accumulator::new(g.len()))
                        .add(&r);
                }
                if outside > 0.01 {
                    notes.push((
                        label,
                        format!(
                            "{:.1}% of its flat map is outside the common grid (u' in [0, 1], \
                             v' in [{V_LOW}, 0]) and left out",
                            100.0 * outside
                        ),
                    ));
                }
            }
            Err(why) => notes.push((label, format!("left out of the mitral maps: {why}"))),
        }
    }
    let mut written = Vec::new();
    if stats.is_empty() {
        return Ok(MitralMaps {
            written,
            maps: used,
            notes,
        });
    }
    let dir = out.join("cohort");
    ensure_dir(&dir)?;
    // voxel (i, j, 0) -> the centre of cell (i, j) in (u', v', 0)
    let mut affine = Matrix4::identity();
    affine[(0, 0)] = g.spacing[0];
    affine[(1, 1)] = g.spacing[1];
    affine[(0, 3)] = g.origin[0] + 0.5 * g.spacing[0];
    affine[(1, 3)] = g.origin[1] + 0.5 * g.spacing[1];
    for (name, acc) in &stats {
        let mean: Vec<f32> = (0..g.len())
            .map(|k| {
                if acc.n[k] > 0 {
                    acc.mean[k] as f32
                } else {
                    f32::NAN
                }
            })
            .collect();
        let std: Vec<f32> = (0..g.len())
            .map(|k| {
                if acc.n[k] >= 2 {
                    (acc.m2[k].max(0.0) / f64::from(acc.n[k] - 1)).sqrt() as f32
                } else {
                    f32::NAN
                }
            })
            .collect();
        let count: Vec<f32> = acc.n.iter().map(|&n| n as f32).collect();
        for (what, data) in [("mean", mean), ("std", std), ("count", count)] {
            let path = dir.join(format!("mitral_{name}_{what}.nii.gz"));
            let vol = Volume::new([NU, NV, 1, 1], affine, data).map_err(|e| at(&path, e))?;
            write_image(&path, &NiftiImage::new(vol))?;
            written.push(path);
        }
    }
    Ok(MitralMaps {
        written,
        maps: used,
        notes,
    })
}
