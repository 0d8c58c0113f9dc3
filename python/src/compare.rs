//! `unfold cohort OUT --compare COLUMN ...` for `unfold.cohort.compare`:
//! the application's comparison ([`unfold::app::cohort::compare`]) run on a
//! batch's output directory, its results read back: `compare.json`'s text,
//! the placenta maps as numpy arrays and the tables as text.

use crate::inputs::volume_arrays;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use unfold::app::cohort::compare::{COMPARE_JSON, STATS};
use unfold::app::cohort::{self as batch, CompareSettings};
use unfold::app::observer::Plain;

/// Runs the cohort step with the comparison of `column` on `out_dir`;
/// returns `(compare_json, maps, tables)`: `maps` every NIfTI file of
/// `OUT/cohort/stats/` by file name as `(data, affine)`, `tables` every CSV
/// file by name as text.
#[pyfunction]
#[pyo3(signature = (out_dir, column, covariates=Vec::new(), permutations=1000, seed=0))]
pub(crate) fn compare<'py>(
    py: Python<'py>,
    out_dir: PathBuf,
    column: String,
    covariates: Vec<String>,
    permutations: usize,
    seed: u64,
) -> PyResult<(String, Bound<'py, PyDict>, Bound<'py, PyDict>)> {
    let mut settings = CompareSettings::new(&column);
    settings.covariates = covariates;
    settings.permutations = permutations;
    settings.seed = seed;
    py.detach(|| batch::gather_compare(&out_dir, &[], Some(&settings), &mut Plain))
        .map_err(crate::error)?;
    let dir = out_dir.join("cohort").join(STATS);
    let text = std::fs::read_to_string(dir.join(COMPARE_JSON))
        .map_err(|e| crate::error(format!("{}: {e}", dir.join(COMPARE_JSON).display())))?;
    let maps = PyDict::new(py);
    let tables = PyDict::new(py);
    let mut names: Vec<(String, PathBuf)> = std::fs::read_dir(&dir)
        .map_err(|e| crate::error(format!("{}: {e}", dir.display())))?
        .filter_map(Result::ok)
        .filter_map(|e| Some((e.file_name().into_string().ok()?, e.path())))
        .collect();
    names.sort();
    for (name, path) in names {
        if name.ends_with(".nii.gz") {
            let img = py
                .detach(|| unfold::io::read_image(&path))
                .map_err(crate::error)?;
            maps.set_item(&name, volume_arrays(py, &img.volume)?)?;
        } else if name.ends_with(".csv") {
            let t = std::fs::read_to_string(&path)
                .map_err(|e| crate::error(format!("{}: {e}", path.display())))?;
            tables.set_item(&name, t)?;
        }
    }
    Ok((text, maps, tables))
}
