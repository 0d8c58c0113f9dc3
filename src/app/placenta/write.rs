//! A placenta run's output set: the meshes, the flat images, the
//! displacement field, the figures, `report.json` (last of the main set)
//! and the lambda sweep's table and curve, written into a staging area of
//! a [`StagedOutputs`] (each file atomically).

use super::inputs::{FLATTENED, ORIGINAL, REPORT, flat_name};
use super::inputs::{ImageInput, Inputs};
use super::lambda_sweep::{COLUMNS, LAMBDA_SWEEP_CSV, Sweep};
use super::report::DisplacementReport;
use super::run::Run;
use super::settings::Settings;
use crate::app::AppError;
use crate::app::error::at;
use crate::app::observer::Observer;
use crate::app::run::files::{ensure_dir, write_figures};
use crate::app::run::{StagedOutputs, memory};
use crate::figures::FigureOptions;
use crate::figures::placenta::{FlatImage, figures as placenta_figures};
use crate::io::nifti::INTENT_VECTOR;
use crate::io::{Datatype, NiftiImage, WriteOptions, atomic_write, write_image, write_mesh};
use crate::mesh::CellMesh;
use crate::organs::placenta::displacement::{VectorFrame, displacement_field};
use crate::organs::placenta::images::template_grid;
use crate::organs::placenta::pullback::PullbackTable;
use crate::organs::placenta::{Interpolation, PullbackError};
use crate::param::Named;
use std::path::{Path, PathBuf};

/// Where a run's outputs go.
#[derive(Debug, Clone, Copy)]
pub struct Outputs<'a> {
    /// The output directory (created if missing): in a staging area of
    /// `staged`.
    pub dir: &'a Path,
    /// Where to write the displacement field (staged too), if asked for.
    pub displacement: Option<&'a Path>,
    /// The run's staged outputs: where the paths written will be after the
    /// commit, for the report and messages.
    pub staged: &'a StagedOutputs,
}

/// The data type of an image pulled back by nearest neighbour: the input's
/// own when it is an unscaled integer type (every output value is one of
/// its values), FLOAT32 otherwise.
pub fn nearest_datatype(input: &NiftiImage) -> Datatype {
    let integer = !matches!(input.datatype, Datatype::Float32 | Datatype::Float64);
    // scl_slope 0 means no scaling (NIfTI-1).
    let unscaled = (input.scl_slope == 0.0 || input.scl_slope == 1.0) && input.scl_inter == 0.0;
    if integer && unscaled {
        input.datatype
    } else {
        Datatype::Float32
    }
}

/// Writes `run`'s outputs into `out.dir`: `original.vtu`, `flattened.vtu`,
/// `<name>_flat.nii.gz` per image, the displacement field, the figures
/// (unless `no_figures`) and `report.json` (with the files' paths and the
/// run's memory now), then the lambda sweep's table and curve. Returns the
/// files of the main set as they will be named after the commit, in
/// order.
///
/// # Errors
/// Writing a file, building the displacement field or the figures.
pub fn write(
    run: &Run,
    settings: &Settings,
    inputs: &Inputs,
    out: &Outputs<'_>,
    observer: &mut dyn Observer,
) -> Result<Vec<PathBuf>, AppError> {
    let dir = out.dir;
    ensure_dir(dir)?;
    let outcome = &run.outcome;
    let mut report = run.report.clone();
    let mut written = Vec::new();
    observer.stage("writing meshes");
    let opts = WriteOptions::default();
    for (name, mesh) in [
        (ORIGINAL, &outcome.original),
        (FLATTENED, &outcome.flattened),
    ] {
        let p = dir.join(name);
        write_mesh(&p, &CellMesh::from(mesh), &opts)?;
        written.push(p);
    }
    for ((flat, entry), img) in outcome
        .images
        .iter()
        .zip(&mut report.report.images)
        .zip(&inputs.images)
    {
        let mut image = NiftiImage::new(flat.volume.clone());
        image.time_step = img.image.time_step;
        image.xyzt_units = img.image.xyzt_units;
        image.description = "unfold placenta: pulled back into the template".into();
        if entry.interpolation == Interpolation::Nearest.name() {
            image = image.with_datatype(nearest_datatype(&img.image));
        }
        let out_path = dir.join(flat_name(&img.name));
        write_image(&out_path, &image)?;
        entry.input = Some(out.staged.shown(&img.path).display().to_string());
        entry.output = Some(out.staged.shown(&out_path).display().to_string());
        written.push(out_path);
    }
    if let Some(path) = out.displacement {
        observer.stage("displacement field");
        report.displacement = Some(write_displacement(run, inputs, path, out)?);
        written.push(path.to_path_buf());
    }
    if !settings.no_figures {
        observer.stage("figures");
        written.extend(write_run_figures(run, &inputs.images, dir)?);
    }
    let report_path = dir.join(REPORT);
    report.memory = memory::report();
    let json = report
        .to_json()
        .map_err(|e| at(&report_path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_path, json.as_bytes())?;
    written.push(report_path);
    if let Some(sweep) = &run.sweep {
        write_sweep(sweep, dir, !settings.no_figures)?;
    }
    Ok(written.iter().map(|p| out.staged.shown(p)).collect())
}

/// The map as an ITK displacement field on the template grid (the spacing
/// of `spacing_mm`, else of the first image, else `voxel_mm`; `--grid` if
/// given), written to `path`.
fn write_displacement(
    run: &Run,
    inputs: &Inputs,
    path: &Path,
    out: &Outputs<'_>,
) -> Result<DisplacementReport, AppError> {
    let outcome = &run.outcome;
    let config = &run.config;
    let spacing = match (config.spacing_mm, inputs.images.first()) {
        (Some(s), _) => [s; 3],
        (None, Some(img)) => img.image.volume.spacing(),
        (None, None) => [config.parcellation.voxel_mm; 3],
    };
    let failed = |e: PullbackError| at(path, format!("cannot build the displacement field: {e}"));
    let grid = template_grid(&outcome.flattened, spacing, config.grid.as_ref()).map_err(failed)?;
    let table = PullbackTable::new(
        grid,
        &outcome.flattened.positions,
        &outcome.flattened.tets,
        &outcome.original.positions,
    )
    .map_err(failed)?;
    let field = displacement_field(&table, VectorFrame::Lps)
        .map_err(|e| at(path, format!("cannot build the displacement field: {e}")))?;
    let mut img = NiftiImage::new(field);
    img.intent_code = INTENT_VECTOR;
    img.intent_name = "ITK displacement".into();
    img.description = "unfold placenta: template -> scanner, d = z - p (LPS)".into();
    write_image(path, &img)?;
    Ok(DisplacementReport {
        path: out.staged.shown(path).display().to_string(),
        convention: "ITK/ANTs displacement field on the template grid: the template \
                     voxel at p (RAS affine) comes from the scanner point p + d(p); \
                     components in LPS"
            .into(),
        spacing_mm: table.grid().spacing,
        dims: table.grid().dims,
        inside_mesh: table.len(),
    })
}

/// Draws the placenta figures of `run` (each image beside the scanner
/// image it came from) and writes them into `dir/figures/`.
fn write_run_figures(
    run: &Run,
    images: &[ImageInput],
    dir: &Path,
) -> Result<Vec<PathBuf>, AppError> {
    let outcome = &run.outcome;
    let flat: Vec<FlatImage<'_>> = outcome
        .images
        .iter()
        .map(|i| FlatImage {
            name: &i.name,
            volume: &i.volume,
            original: images
                .iter()
                .find(|o| o.name == i.name)
                .map(|o| &o.image.volume),
        })
        .collect();
    let figs =
        placenta_figures(outcome, &flat, &FigureOptions::default()).map_err(|e| at(dir, e))?;
    write_figures(dir, &figs)
}

/// Writes `lambda_sweep.csv` (a row per weight, [`COLUMNS`]) and, with
/// `figure`, `figures/lambda_sweep.png` into `dir`.
fn write_sweep(sweep: &Sweep, dir: &Path, figure: bool) -> Result<(), AppError> {
    use crate::figures::placenta::lambda_sweep::{SweepPoint, lambda_sweep_plot};
    let path = dir.join(LAMBDA_SWEEP_CSV);
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(COLUMNS).map_err(|e| at(&path, e))?;
    for row in &sweep.rows {
        w.write_record(row.cells()).map_err(|e| at(&path, e))?;
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    atomic_write(&path, &bytes)?;
    if figure {
        let points: Vec<SweepPoint> = sweep
            .rows
            .iter()
            .map(|r| SweepPoint {
                lambda: r.lambda,
                dirichlet_excess_percent: r.dirichlet_excess_percent,
                template_error_mm: r.template_error_mm,
            })
            .collect();
        let figure =
            lambda_sweep_plot(&points, &FigureOptions::default()).map_err(|e| at(&path, e))?;
        write_figures(dir, &[figure])?;
    }
    Ok(())
}
