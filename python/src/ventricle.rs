//! `unfold.ventricle`: the ventricle run of the application layer
//! ([`unfold::app::ventricle`]) on numpy arrays: the command line's
//! settings checks, pipeline, transfer, messages and `report.json` layout
//! ([`VentricleReport`]).

use crate::arrays::{cell_mesh, mesh_tuple};
use crate::inputs::{choice, opt_point, point, tri_mesh};
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::io::IsTerminal;
use unfold::app::error::positive;
use unfold::app::run::memory::MemoryReport;
use unfold::app::run::provenance::Provenance;
use unfold::app::ventricle::surface::build_from;
use unfold::app::ventricle::{
    ChartSettings, EnclosingSettings, Inputs, Settings, Transfer, VentricleReport, run,
    with_vertex_cells,
};
use unfold::mesh::CellMesh;
use unfold::organs::PipelineObserver;
use unfold::organs::ventricle::{Chamber, LandmarkPoints};
use unfold::param::Named;

/// The anatomy given as `(points, cells, point_data, cell_data)`.
type Anatomy<'py> = (
    PyReadonlyArray2<'py, f64>,
    Bound<'py, PyDict>,
    Option<Bound<'py, PyDict>>,
    Option<Bound<'py, PyDict>>,
);

/// The chamber of a name ("lv", "rv", any case).
pub(crate) fn chamber(name: &str) -> PyResult<Chamber> {
    match Chamber::by_name(&name.to_ascii_lowercase()) {
        Some(c) => Ok(c),
        None => choice("--chamber", name),
    }
}

/// The run's progress lines on stderr when it is a terminal, and its
/// warnings, as the command line shows them.
struct Terminal;

impl PipelineObserver for Terminal {}

impl unfold::app::observer::Observer for Terminal {
    fn progress(&mut self, line: &str) {
        if std::io::stderr().is_terminal() {
            eprintln!("{line}");
        }
    }

    fn warning(&mut self, text: &str) {
        eprintln!("warning: {text}");
    }
}

/// Maps an anatomy into the canonical cylinder; returns `(normalized,
/// anatomy, disk, transferred or None, report_json, built S or None)`,
/// each mesh as `(points, cells, point_data, cell_data)`. Without
/// `points` and `triangles`, S is built from the anatomy
/// ([`unfold::app::ventricle::surface::build_from`], `surface_voxel_mm`,
/// `surface_margin_mm`, `surface_smoothing`), as the command line does
/// without `--surface`.
#[pyfunction]
#[pyo3(signature = (
    points, triangles, anatomy, *, anterior, inferior, apex=None, rim_near=None,
    surface_voxel_mm=None, surface_margin_mm=None, surface_smoothing=None,
    chamber="lv", grid_mm=None, hemisphere_mm=None, display_exponent=None, snap_mm=None,
    to_points=None, to_triangles=None, to_anterior=None, to_inferior=None, to_apex=None,
    to_rim_near=None, to_hemisphere=None, anatomy_name="anatomy", surface_name="surface",
    to_name="second surface"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn ventricle<'py>(
    py: Python<'py>,
    points: Option<PyReadonlyArray2<'py, f64>>,
    triangles: Option<PyReadonlyArray2<'py, i64>>,
    anatomy: Anatomy<'py>,
    anterior: [f64; 3],
    inferior: [f64; 3],
    apex: Option<[f64; 3]>,
    rim_near: Option<[f64; 3]>,
    surface_voxel_mm: Option<f64>,
    surface_margin_mm: Option<f64>,
    surface_smoothing: Option<usize>,
    chamber: &str,
    grid_mm: Option<f64>,
    hemisphere_mm: Option<f64>,
    display_exponent: Option<f64>,
    snap_mm: Option<f64>,
    to_points: Option<PyReadonlyArray2<'py, f64>>,
    to_triangles: Option<PyReadonlyArray2<'py, i64>>,
    to_anterior: Option<[f64; 3]>,
    to_inferior: Option<[f64; 3]>,
    to_apex: Option<[f64; 3]>,
    to_rim_near: Option<[f64; 3]>,
    to_hemisphere: Option<f64>,
    anatomy_name: &str,
    surface_name: &str,
    to_name: &str,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = unfold::app::run::provenance::now();
    let defaults = ChartSettings::default();
    let mut settings = Settings {
        chart: ChartSettings {
            chamber: self::chamber(chamber)?,
            grid_mm: grid_mm.unwrap_or(defaults.grid_mm),
            hemisphere_mm: hemisphere_mm.unwrap_or(defaults.hemisphere_mm),
            display_exponent,
            snap_mm: snap_mm.unwrap_or(defaults.snap_mm),
        },
        no_figures: true,
        ..Settings::default()
    };
    let config = settings.validate().map_err(crate::error)?;
    let parameters = format!("{config:?}");
    let given = match (&points, &triangles) {
        (Some(p), Some(t)) => {
            if surface_voxel_mm.is_some()
                || surface_margin_mm.is_some()
                || surface_smoothing.is_some()
            {
                return Err(crate::error(
                    "surface_voxel_mm, surface_margin_mm and surface_smoothing are for S built \
                     from the anatomy; give them without points and triangles",
                ));
            }
            Some(tri_mesh(p, t, surface_name)?)
        }
        (None, None) => None,
        _ => {
            return Err(crate::error(
                "give both points and triangles of S, or neither (S built from the anatomy)",
            ));
        }
    };
    let (ap, ac, apd, acd) = anatomy;
    let anatomy = cell_mesh(ap, &ac, apd.as_ref(), acd.as_ref())?;
    if anatomy.positions.is_empty() {
        return Err(crate::error(format!(
            "{anatomy_name}: has no points; the anatomy to map is a mesh or points inside S"
        )));
    }
    let mut landmarks = LandmarkPoints {
        anterior: point(anterior, "anterior")?,
        inferior: point(inferior, "inferior")?,
        apex: opt_point(apex, "apex")?,
        rim_near: opt_point(rim_near, "rim_near")?,
    };
    let built_label = format!("S built from {anatomy_name}");
    let (surface, built, surface_name) = match given {
        Some(s) => (s, None, surface_name),
        None => {
            let defaults = EnclosingSettings::default();
            settings.enclosing = EnclosingSettings {
                surface_voxel_mm: surface_voxel_mm.unwrap_or(defaults.surface_voxel_mm),
                surface_margin_mm: surface_margin_mm.unwrap_or(defaults.surface_margin_mm),
                surface_smoothing: surface_smoothing.unwrap_or(defaults.surface_smoothing),
            };
            let built = py
                .detach(|| build_from(&anatomy, anatomy_name, &landmarks, &settings.enclosing))
                .map_err(|e| {
                    crate::input_error(
                        e,
                        &[(anatomy_name, &anatomy.positions)],
                        unfold::app::run::units::OrganSize::VENTRICLE,
                    )
                })?;
            // the given rim landmarks lie on the anatomy's rim: carried to S's
            [landmarks.anterior, landmarks.inferior] = built.rim_landmarks;
            (built.surface.clone(), Some(built), built_label.as_str())
        }
    };
    if let Some(r) = to_hemisphere {
        positive("--to-hemisphere", r).map_err(crate::error)?;
    }
    let transfer = match (to_points, to_triangles, to_hemisphere) {
        (Some(_), _, Some(_)) => {
            return Err(crate::error("give to_surface or to_hemisphere, not both"));
        }
        (Some(p), Some(t), None) => {
            let (Some(a), Some(i)) = (to_anterior, to_inferior) else {
                return Err(crate::error(
                    "--to-surface needs --to-anterior and --to-inferior (the second heart's \
                     rim landmarks)",
                ));
            };
            Some(Transfer {
                surface: tri_mesh(&p, &t, to_name)?,
                landmarks: LandmarkPoints {
                    anterior: point(a, "to_anterior")?,
                    inferior: point(i, "to_inferior")?,
                    apex: opt_point(to_apex, "to_apex")?,
                    rim_near: opt_point(to_rim_near, "to_rim_near")?,
                },
                label: to_name.to_string(),
            })
        }
        (None, _, Some(r)) => Some(Transfer::hemisphere(r).map_err(crate::error)?),
        _ => None,
    };
    settings.to_hemisphere = to_hemisphere;
    let inputs = Inputs {
        anatomy_label: anatomy_name.to_string(),
        anatomy,
        surface_label: surface_name.to_string(),
        surface,
        landmarks,
        from_rv: None,
        enclosing: built.as_ref().map(|b| b.report.clone()),
        transfer,
    };
    let run = py
        .detach(|| run(&settings, &inputs, &mut Terminal))
        .map_err(|e| {
            crate::input_error(
                e,
                &[
                    (anatomy_name, &inputs.anatomy.positions),
                    (surface_name, &inputs.surface.positions),
                ],
                unfold::app::run::units::OrganSize::VENTRICLE,
            )
        })?;
    let outcome = &run.outcome;
    let mut report: VentricleReport = run.report.clone();
    report.memory = MemoryReport::predicted(outcome.report.field.estimated_bytes);
    report.provenance = Provenance::python(parameters, started);
    let json = serde_json::to_string_pretty(&report).map_err(crate::error)?;
    let normalized = mesh_tuple(py, &with_vertex_cells(&outcome.normalized))?;
    let anatomy = mesh_tuple(py, &with_vertex_cells(&outcome.anatomy))?;
    let disk = mesh_tuple(py, &CellMesh::from(&outcome.disk))?;
    let transferred = match &run.transferred {
        Some(mesh) => mesh_tuple(py, &with_vertex_cells(mesh))?.into_any(),
        None => py.None().into_bound(py),
    };
    let built = match &built {
        Some(b) => mesh_tuple(py, &CellMesh::from(&b.surface))?.into_any(),
        None => py.None().into_bound(py),
    };
    PyTuple::new(
        py,
        [
            normalized.into_any(),
            anatomy.into_any(),
            disk.into_any(),
            transferred,
            json.into_pyobject(py)?.into_any(),
            built,
        ],
    )
}
