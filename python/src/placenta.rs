//! `unfold.placenta`: the library pipeline `unfold placenta` runs
//! ([`Pipeline`]), on numpy arrays, with the command line's defaults and
//! messages ([`unfold::placenta::pipeline_error`]) and its `report.json`
//! layout ([`unfold::placenta::FullReport`]).

use crate::arrays::mesh_tuple;
use crate::inputs::{choice, volume, volume_arrays};
use crate::progress::Callback;
use crate::report::{Memory, Provenance};
use crate::template::PyTemplate;
use numpy::{PyReadonlyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use unfold::cli::placenta::{
    InterpArg, PlacentaSettings, SolverArg, TemplateArg, hold_half_thickness,
};
use unfold::io::Frame;
use unfold::mesh::{CellMesh, TetMesh};
use unfold::organs::placenta::{
    Image, Pipeline, PlacentaTemplate, SolverKind, TemplateKind, prepare_mesh,
};

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
                Ok(name) => choice::<TemplateArg>("--template", &name)
                    .map(|t| TemplateChoice::Shipped(t.into())),
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
    solver="newton", tol=1e-4, max_iterations=None, name="mesh", progress=None,
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
    tol: f64,
    max_iterations: Option<i64>,
    name: &str,
    progress: Option<Py<PyAny>>,
    images: Vec<ImageArrays<'py>>,
    interp: &str,
    spacing_mm: Option<f64>,
    frame_check: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let started = crate::report::started();
    let config = PlacentaSettings {
        lambda: lam,
        margin_mm,
        gamma,
        rings: usize::try_from(rings)
            .map_err(|_| crate::error(format!("--rings must be 1 to 6, got {rings}")))?,
        voxel_mm,
        tol,
        spacing_mm,
        max_iterations: crate::inputs::max_iterations(max_iterations, "--max-iterations")?,
        interp: choice::<InterpArg>("--interp", interp)?,
        grid: None,
        frame_check,
    }
    .config(None)
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
    let template = hold_half_thickness(template, fix_h).map_err(crate::error)?;
    let solver_kind = SolverKind::from(choice::<SolverArg>("--solver", solver)?);
    let mesh = tet_mesh(&points, &tets)?;
    let parameters = format!(
        "template={template_name:?}, lam={lam}, margin_mm={margin_mm:?}, gamma={gamma}, rings={rings}, \
         voxel_mm={voxel_mm}, fix_h={fix_h:?}, \
         solver={solver:?}, tol={tol}, max_iterations={max_iterations:?}, interp={interp:?}, \
         spacing_mm={spacing_mm:?}, frame_check={frame_check}"
    );
    let volumes = images
        .iter()
        .map(|(n, data, affine)| Ok((n.clone(), volume(data, affine, n)?)))
        .collect::<PyResult<Vec<_>>>()?;
    let names: Vec<String> = volumes.iter().map(|(n, _)| n.clone()).collect();
    let label = name.to_string();
    let mut callback = Callback::new(progress);
    let run = py.detach(|| {
        let failed = |e| unfold::placenta::pipeline_error(&label, Frame::Ras, &names, e);
        let images: Vec<Image<'_>> = volumes
            .iter()
            .map(|(name, volume)| Image { name, volume })
            .collect();
        let prepared = prepare_mesh(&mesh).map_err(|e| unfold::placenta::organ(&label, e))?;
        let predicted = unfold::organs::placenta::memory::estimate_memory(&prepared.mesh, 0.0, 0)
            .map(|e| e.total())
            .unwrap_or(0.0);
        let pipeline = Pipeline::new()
            .template(template)
            .solver(solver_kind.build())
            .config(config);
        let outcome = pipeline
            .run_prepared(prepared, &images, &mut callback)
            .map_err(failed)?;
        Ok::<_, unfold::placenta::InputError>((outcome, predicted))
    });
    if let Some(e) = template_error.and_then(|slot| slot.lock().ok()?.take()) {
        return Err(e);
    }
    if let Some(e) = callback.error.take() {
        return Err(e);
    }
    let (mut outcome, predicted) =
        run.map_err(|e| crate::input_error(e, &[(name, &mesh.positions)]))?;
    for entry in &mut outcome.report.images {
        entry.input = Some(entry.name.clone());
    }
    let full = unfold::placenta::FullReport::<(), (), _, _> {
        mesh: name,
        segmentation: None,
        displacement: None,
        report: &outcome.report,
        memory: Memory::predicted(predicted),
        provenance: Provenance::new(parameters, started),
    };
    let json = full.to_json().map_err(crate::error)?;
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
