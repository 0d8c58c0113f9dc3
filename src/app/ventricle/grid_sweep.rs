//! The grid sweep (`--grid-sweep 2,1,0.5`): the pipeline rerun on each
//! grid spacing of the Laplace field (the source paper's Fig. 11: error
//! and time against the voxel size).
//!
//! For each spacing `h` (in the order given) the whole pipeline runs on
//! the anatomy with the run's other settings: the chart (disk map, Laplace
//! field on the `h` grid), `psi` of every anatomy point and the round trip
//! `psi^-1(psi(v))`. `grid_sweep.csv` gets a row per grid:
//!
//! - `grid_mm`, `unknowns` (the field's), `cg_iterations`;
//! - `roundtrip_mean_um`, `roundtrip_max_um`: `|v - psi^-1(psi(v))|` as
//!   `report.json` summarizes it;
//! - `disk_shift_max`, `depth_shift_max`: the largest change of a point's
//!   displayed disk position (disk radius 1) and depth from the finest grid
//!   of the sweep (0 on that grid): how far the map itself has converged;
//! - `seconds` (wall clock of the grid's run), `disk_seconds`,
//!   `laplace_seconds`, `streamlines_seconds`, `inverse_seconds`;
//! - `estimated_field_bytes`: the field's memory predicted before it is
//!   allocated; `peak_bytes`: the process's peak resident size during the
//!   grid's run (`VmHWM` reset before it; it includes what the process
//!   already held, the main run's outputs among them), empty where the
//!   system cannot reset or tell it.
//!
//! and, unless `--no-figures`, `figures/grid_sweep.png`
//! ([`crate::figures::ventricle::grid_sweep_plot`]). The main outputs are
//! those of `--grid-mm`.

use crate::app::error::{AppError, at, organ, positive};
use crate::app::observer::Observer;
use crate::app::run::StagedOutputs;
use crate::app::run::files::write_figures;
use crate::figures::FigureOptions;
use crate::figures::ventricle::{GridPoint, grid_sweep_plot};
use crate::io::atomic_write;
use crate::mesh::{CellMesh, TriMesh};
use crate::organs::ventricle::pipeline::displayed;
use crate::organs::ventricle::{Config, LandmarkPoints, Pipeline};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The table's file name.
pub const GRID_SWEEP_CSV: &str = "grid_sweep.csv";

/// The table's columns.
pub const COLUMNS: [&str; 14] = [
    "grid_mm",
    "unknowns",
    "cg_iterations",
    "roundtrip_mean_um",
    "roundtrip_max_um",
    "disk_shift_max",
    "depth_shift_max",
    "seconds",
    "disk_seconds",
    "laplace_seconds",
    "streamlines_seconds",
    "inverse_seconds",
    "estimated_field_bytes",
    "peak_bytes",
];

/// Checks the spacings: each finite and > 0, no repeat.
///
/// # Errors
/// A usage error naming the spacing.
pub fn check_grids(grids: &[f64]) -> Result<(), AppError> {
    for (k, &g) in grids.iter().enumerate() {
        positive("--grid-sweep", g)?;
        if grids[..k].contains(&g) {
            return Err(AppError::Usage(format!(
                "--grid-sweep lists {g} twice; give each spacing once"
            )));
        }
    }
    Ok(())
}

/// One grid's run.
#[derive(Debug, Clone)]
struct Row {
    grid_mm: f64,
    unknowns: usize,
    cg_iterations: usize,
    mean_um: f64,
    max_um: f64,
    shown: Vec<[f64; 2]>,
    depth: Vec<f64>,
    seconds: f64,
    disk_seconds: f64,
    laplace_seconds: f64,
    streamlines_seconds: f64,
    inverse_seconds: f64,
    estimated_bytes: f64,
    peak_bytes: Option<f64>,
}

/// The sweep's runs, one per grid in the order given.
#[derive(Debug, Clone)]
pub struct GridSweep {
    rows: Vec<Row>,
}

/// Runs the pipeline on `anatomy` inside `surface` (called `label` in
/// messages) once per grid spacing in `grids`, with `config` otherwise
/// (module doc); tells `observer` a line per grid as a result (the
/// command line prints it on stdout). Nothing is written ([`write`]).
///
/// # Errors
/// A spacing that is not finite and > 0 or repeated; a grid whose run
/// fails (named with its spacing).
pub fn sweep(
    grids: &[f64],
    anatomy: &CellMesh,
    surface: &TriMesh,
    landmarks: &LandmarkPoints,
    config: Config,
    label: &str,
    observer: &mut dyn Observer,
) -> Result<GridSweep, AppError> {
    check_grids(grids)?;
    let mut rows = Vec::with_capacity(grids.len());
    for &g in grids {
        let mut c = config;
        c.chart.field.grid_mm = g;
        c.chart.field.max_memory_bytes = crate::app::run::memory::room();
        let reset = crate::app::run::memory::reset_peak();
        let t0 = Instant::now();
        let outcome = Pipeline::new()
            .config(c)
            .run(anatomy, surface, landmarks)
            .map_err(|e| organ(&format!("{label} (--grid-sweep {g})"), e))?;
        let seconds = t0.elapsed().as_secs_f64();
        let peak_bytes = if reset {
            crate::app::run::memory::peak_since_reset()
        } else {
            None
        };
        let r = &outcome.report;
        let uv: Vec<[f64; 2]> = outcome.coords.iter().map(|c| [c.xi, c.zeta]).collect();
        let shown =
            displayed(c.chart.chamber, &uv, c.display_exponent).map_err(|e| organ(label, e))?;
        let row = Row {
            grid_mm: g,
            unknowns: r.field.unknowns,
            cg_iterations: r.field.cg_iterations,
            mean_um: r.roundtrip_error_um.mean,
            max_um: r.roundtrip_error_um.max,
            shown,
            depth: outcome.coords.iter().map(|c| c.depth).collect(),
            seconds,
            disk_seconds: r.seconds.disk,
            laplace_seconds: r.seconds.laplace,
            streamlines_seconds: r.seconds.streamlines,
            inverse_seconds: r.seconds.inverse,
            estimated_bytes: r.field.estimated_bytes,
            peak_bytes,
        };
        observer.info(&format!(
            "grid sweep {g} mm: {} unknowns, round trip mean {:.3e} um, max {:.3e} um, {:.2} s \
             (Laplace {:.2} s), field estimate {:.1} MiB{}",
            row.unknowns,
            row.mean_um,
            row.max_um,
            row.seconds,
            row.laplace_seconds,
            row.estimated_bytes / 1048576.0,
            match row.peak_bytes {
                Some(p) => format!(", peak {:.1} MiB", p / 1048576.0),
                None => String::new(),
            }
        ));
        rows.push(row);
    }
    Ok(GridSweep { rows })
}

/// Writes the sweep's table [`GRID_SWEEP_CSV`] (a row per grid,
/// [`COLUMNS`]) and, with `figures`, `figures/grid_sweep.png` into `dir`
/// (a staging area of `staged`). Returns the files written as they will be
/// named after the commit.
///
/// # Errors
/// Writing the table or the figure.
pub fn write(
    sweep: &GridSweep,
    dir: &Path,
    figures: bool,
    staged: &StagedOutputs,
) -> Result<Vec<PathBuf>, AppError> {
    let rows = &sweep.rows;
    // the finest grid is the reference of the shifts
    let finest = rows
        .iter()
        .min_by(|a, b| a.grid_mm.total_cmp(&b.grid_mm))
        .map(|r| (r.shown.clone(), r.depth.clone()))
        .unwrap_or_default();
    let path = dir.join(GRID_SWEEP_CSV);
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(COLUMNS).map_err(|e| at(&path, e))?;
    for r in rows {
        let disk_shift = r
            .shown
            .iter()
            .zip(&finest.0)
            .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
            .fold(0.0, f64::max);
        let depth_shift = r
            .depth
            .iter()
            .zip(&finest.1)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        w.write_record([
            r.grid_mm.to_string(),
            r.unknowns.to_string(),
            r.cg_iterations.to_string(),
            r.mean_um.to_string(),
            r.max_um.to_string(),
            disk_shift.to_string(),
            depth_shift.to_string(),
            r.seconds.to_string(),
            r.disk_seconds.to_string(),
            r.laplace_seconds.to_string(),
            r.streamlines_seconds.to_string(),
            r.inverse_seconds.to_string(),
            format!("{:.0}", r.estimated_bytes),
            r.peak_bytes.map(|p| format!("{p:.0}")).unwrap_or_default(),
        ])
        .map_err(|e| at(&path, e))?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    atomic_write(&path, &bytes)?;
    let mut written = vec![path.clone()];
    if figures {
        let points: Vec<GridPoint> = rows
            .iter()
            .map(|r| GridPoint {
                grid_mm: r.grid_mm,
                mean_um: r.mean_um,
                max_um: r.max_um,
                seconds: r.seconds,
                laplace_seconds: r.laplace_seconds,
            })
            .collect();
        let figure =
            grid_sweep_plot(&points, &FigureOptions::default()).map_err(|e| at(&path, e))?;
        written.extend(write_figures(dir, &[figure])?);
    }
    Ok(written.iter().map(|p| staged.shown(p)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spacings_must_be_positive_and_distinct() {
        assert!(check_grids(&[2.0, 1.0, 0.5]).is_ok());
        let e = check_grids(&[1.0, 0.0]).unwrap_err();
        assert!(
            e.to_string()
                .contains("--grid-sweep must be a finite number > 0, got 0"),
            "{e}"
        );
        let e = check_grids(&[1.0, 2.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("lists 1 twice"), "{e}");
        assert!(check_grids(&[f64::NAN]).is_err());
    }
}
