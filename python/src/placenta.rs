//! `unfold.placenta`: the placenta run of the application layer
//! ([`unfold::app::placenta`]) on numpy arrays: the command line's settings,
//! defaults, messages and `report.json` layout ([`PlacentaReport`]).

use crate::arrays::mesh_tuple;
use crate::inputs::{choice, volume, volume_arrays};
use crate::progress::Callback;
use crate::template::PyTemplate;
use numpy::{PyReadonlyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::PathBuf;
use unfold::app::placenta::settings::DEFAULT_VOXEL_MM;
use unfold::app::placenta::{ImageInput, Inputs, PlacentaReport, Settings, run_with};
use unfold::app::run::memory::MemoryReport;
use unfold::app::run::provenance::Provenance;
use unfold::io::{Frame, NiftiImage};
use unfold::mesh::{CellMesh, TetMesh};
use unfold::organs::placenta::{PlacentaTemplate, TemplateKind, prepare_mesh};
use unfold::param::Named;

/// The template argument: a shipped template's name (None: planes), or a
/// Python object implementing the template protocol ([`PyTemplate`]).
enum TemplateChoice {
    Shipped(TemplateKind),
    Python(PyTemplate),
}

impl TemplateChoice {
    fn new(template: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        match template {
            None => Ok(TemplateChoice::Shipped(TemplateKind::Planes)),
            Some(t) => match t.extract::<String>() {
                Ok(name) => {
                    choice::<TemplateKind>("--template", &name).map(TemplateChoice::Shipped)
                }
                Err(_) => PyTemplate::new(t).map(TemplateChoice::Python),
            },
        }
    }

    /// The name the report and the provenance use.
    fn name(&self) -> &'static str {
        match self {
            TemplateChoice::Shipped(kind) => kind.name(),
            TemplateChoice::Python(t) => unfold::param::Template::name(t),
        }
    }
}

/// An image to pull back: its name, its values (3D or 4D float32) and its
/// 4x4 affine (voxel indices to RAS mm).
type ImageArrays<'py> = (
    String,
    PyReadonlyArrayDyn<'py, f32>,
    PyReadonlyArray2<'py, f64>,
);

/// Flattens a placenta tet mesh and pulls `images` into the template;
/// returns `(flattened, original, report_json, flat_images)` with each mesh
/// as `(points, cells, point_data, cell_data)` and `flat_images` a dict
/// name -> `(data, affine)`.
#[pyfunction]
#[pyo3(signature = (
    points, tets, *, template=None, lam=1.0, margin_mm=None, gamma=20.0, rings=3, voxel_mm=3.0, fix_h=None,
    solver="newton", energy="symmetric-dirichlet", tol=1e-4, max_iterations=None, name="mesh", progress=None,
    images=Vec::new(), interp="linear", spacing_mm=None, frame_check=true
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn placenta<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    tets: PyReadonlyArray2<'py, i64>,
    template: Option<&Bound<'py, PyAny>>,
    lam: f64,
    margin_mm: Option<f64>,
    gamma: f64,
    rings: i64,
    voxel_mm: f64,
    fix_h: Option<f64>,
    solver: &str,
    energy: &str,
    tol: f64,
    max_iterations: Option<i64>,
    name: &str,
    progress: Option<Py<PyAny>>,
    images: Vec<ImageArrays<'py>>,
    interp: &str,
    spacing_mm: Option<f64>,
    frame_check: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = unfold::app::run::provenance::now();
    let settings = Settings {
        solver: choice("--solver", solver)?,
        energy: choice("--energy", energy)?,
        lambda: lam,
        fix_h,
        margin_mm,
        gamma,
        rings: usize::try_from(rings)
            .map_err(|_| crate::error(format!("--rings must be 1 to 6, got {rings}")))?,
        voxel_mm: Some(voxel_mm),
        tol,
        max_iterations: crate::inputs::max_iterations(max_iterations, "--max-iterations")?,
        spacing_mm,
        interp: choice("--interp", interp)?,
        no_frame_check: !frame_check,
        no_figures: true,
        ..Settings::default()
    };
    let config = settings
        .config(DEFAULT_VOXEL_MM, None)
        .map_err(crate::error)?;
    let template = TemplateChoice::new(template)?;
    let template_name = template.name();
    let template_error = match &template {
        TemplateChoice::Python(t) => Some(t.error_slot()),
        TemplateChoice::Shipped(_) => None,
    };
    let template: Box<dyn PlacentaTemplate> = match template {
        TemplateChoice::Shipped(kind) => kind.build(),
        TemplateChoice::Python(t) => Box::new(t),
    };
    let pipeline = settings
        .pipeline_with(template, config)
        .map_err(crate::error)?;
    let mesh = tet_mesh(&points, &tets)?;
    let parameters = format!(
        "template={template_name:?}, lam={lam}, margin_mm={margin_mm:?}, gamma={gamma}, rings={rings}, \
         voxel_mm={voxel_mm}, fix_h={fix_h:?}, \
         solver={solver:?}, energy={energy:?}, tol={tol}, max_iterations={max_iterations:?}, interp={interp:?}, \
         spacing_mm={spacing_mm:?}, frame_check={frame_check}"
    );
    let images = images
        .iter()
        .map(|(n, data, affine)| {
            Ok(ImageInput {
                path: PathBuf::from(n),
                name: n.clone(),
                image: NiftiImage::new(volume(data, affine, n)?),
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let label = name.to_string();
    let mut callback = Callback::new(progress);
    let run = py.detach(|| {
        let prepared = prepare_mesh(&mesh).map_err(|e| unfold::app::placenta::organ(&label, e))?;
        let predicted = unfold::organs::placenta::memory::estimate_memory(&prepared.mesh, 0.0, 0)
            .map(|e| MemoryReport::predicted_from(&e))
            .unwrap_or_else(|_| MemoryReport::predicted(0.0));
        let inputs = Inputs {
            label: label.clone(),
            mesh: prepared,
            images,
            frame: Frame::Ras,
            voxel_mm: DEFAULT_VOXEL_MM,
            segmentation: None,
        };
        let run = run_with(&pipeline, &settings, &inputs, &mut callback)?;
        Ok::<_, unfold::app::AppError>((run, predicted))
    });
    if let Some(e) = template_error.and_then(|slot| slot.lock().ok()?.take()) {
        return Err(e);
    }
    if let Some(e) = callback.error.take() {
        return Err(e);
    }
    let (run, predicted) = run.map_err(|e| {
        crate::input_error(
            e,
            &[(name, &mesh.positions)],
            unfold::app::run::units::OrganSize::PLACENTA,
        )
    })?;
    let outcome = run.outcome;
    let mut report: PlacentaReport = run.report;
    for entry in &mut report.report.images {
        entry.input = Some(entry.name.clone());
    }
    report.memory = predicted;
    report.provenance = Provenance::python(parameters, started);
    let json = report.to_json().map_err(crate::error)?;
    let flattened = mesh_tuple(py, &CellMesh::from(&outcome.flattened))?;
    let original = mesh_tuple(py, &CellMesh::from(&outcome.original))?;
    let flat_images = PyDict::new(py);
    for image in &outcome.images {
        flat_images.set_item(&image.name, volume_arrays(py, &image.volume)?)?;
    }
    PyTuple::new(
        py,
        [
            flattened.into_any(),
            original.into_any(),
            json.into_pyobject(py)?.into_any(),
            flat_images.into_any(),
        ],
    )
}

/// A tet mesh from `(n, 3)` points and `(m, 4)` tets, every index checked.
fn tet_mesh(
    points: &PyReadonlyArray2<'_, f64>,
    tets: &PyReadonlyArray2<'_, i64>,
) -> PyResult<TetMesh> {
    let positions = crate::inputs::points(points, "points")?;
    let tets = crate::inputs::cells::<4>(tets, positions.len(), "tets")?;
    Ok(TetMesh::new(positions, tets))
}
