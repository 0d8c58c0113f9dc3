//! A deformation on its inputs: a tet REST without INIT repaired (welded,
//! degenerate tets dropped) and solved from its own shape, any other REST
//! solved as it is from INIT's positions (their vertex numbers must
//! correspond), the fixed vertices gathered (HANDLES and, with
//! `--fixed-boundary`, the boundary), the library's [`Deform`] run (the
//! memory budget checked before a Newton factor), the solution put back on
//! REST's cells with `det_j` and `inverted` cell arrays, and the typed
//! report. Nothing is written here ([`super::write()`] does).

use super::fixed::fixed_vertices;
use super::inputs::Inputs;
use super::report::DeformRunReport;
use super::settings::Settings;
use super::shape::Rest;
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::provenance;
use crate::mesh::nalgebra::Point3;
use crate::mesh::repair::{RepairOptions, RepairReport, Weld, repair_tet_mesh_traced};
use crate::mesh::{CellMesh, Field, FieldValues, MeshError};
use crate::param::solver::SolverKind;
use crate::param::{Deform, DeformOutcome, DeformReport, Named, ParamError, ParamMesh};
use std::path::{Path, PathBuf};

/// A deformed mesh and what the run found.
#[derive(Debug, Clone)]
pub struct Deformed {
    /// REST's cells and arrays with the positions replaced, and the cell
    /// arrays `det_j` and `inverted` ([`flip_arrays`]).
    pub mesh: CellMesh,
    /// `"tets"` or `"triangles"`.
    pub elements: &'static str,
    /// Number of elements of REST.
    pub element_count: usize,
    /// What the repair of REST changed (`None`: not repaired).
    pub repair: Option<RepairReport>,
    /// The library's report.
    pub report: DeformReport,
}

/// What a run produced.
#[derive(Debug, Clone)]
pub struct Run {
    /// REST's cells and arrays with the positions replaced, and the cell
    /// arrays `det_j` and `inverted`.
    pub mesh: CellMesh,
    /// `"tets"` or `"triangles"`.
    pub elements: &'static str,
    /// Number of elements of REST.
    pub element_count: usize,
    /// `OUT.report.json` (the output's name is filled in when it is
    /// written).
    pub report: DeformRunReport,
}

/// Deforms `inputs` with `settings` ([`deform_mesh`]) into a [`Run`] whose
/// report names the inputs, with this process's provenance; the solver's
/// iterations go to `observer`.
///
/// # Errors
/// [`deform_mesh`]'s.
pub fn run(
    settings: &Settings,
    inputs: Inputs,
    observer: &mut dyn Observer,
) -> Result<Run, AppError> {
    let name = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
    let (mesh, targets, init, fixed_file) = (
        inputs.mesh.display().to_string(),
        name(&inputs.targets),
        name(&inputs.init),
        name(&inputs.fixed_file),
    );
    let deformed = deform_mesh(inputs, settings, observer)?;
    Ok(Run {
        mesh: deformed.mesh,
        elements: deformed.elements,
        element_count: deformed.element_count,
        report: DeformRunReport {
            mesh,
            targets_file: targets,
            init,
            fixed_file,
            output: String::new(),
            repair: deformed.repair,
            report: deformed.report,
            provenance: provenance::this_run(),
        },
    })
}

/// A pipeline error, worded for this command and attributed to the input
/// it is about (REST `mesh`, `targets` or INIT `init`).
fn deform_problem(
    mesh: &Path,
    targets: &Path,
    init: &Path,
    solver: SolverKind,
    e: ParamError,
) -> AppError {
    match e {
        ParamError::Mesh(MeshError::InvertedElement { element, volume }) => at(
            mesh,
            format!(
                "tet {element} is inverted (signed volume {volume:e}); REST is the rest shape, \
                 so every tet must be positively oriented (a tangled start goes in --init)"
            ),
        ),
        ParamError::Mesh(MeshError::DegenerateElement {
            element, measure, ..
        }) => at(
            mesh,
            format!(
                "element {element} is degenerate (rest area or volume {measure:e}); REST is the \
                 rest shape, so every element must have a positive size: remove it (from REST \
                 and INIT alike) or give REST without it"
            ),
        ),
        e @ (ParamError::TargetNotFinite { .. } | ParamError::TargetRepeated { .. }) => {
            at(targets, e)
        }
        e @ (ParamError::Length { .. } | ParamError::PinNotFinite { .. }) => at(init, e),
        e @ (ParamError::Mesh(_) | ParamError::Setting { .. }) => at(mesh, e),
        e => at(mesh, format!("the {} solver failed: {e}", solver.name())),
    }
}

/// Checks the memory of a Newton factor on `pmesh` (REST called `mesh`).
fn check_memory(settings: &Settings, pmesh: &ParamMesh, mesh: &Path) -> Result<(), AppError> {
    if settings.solver == SolverKind::Newton {
        let estimate = crate::param::memory::mesh_newton_memory(pmesh).map_err(|e| at(mesh, e))?;
        crate::app::run::memory::check(
            "deforming the mesh",
            &estimate,
            "coarsen the mesh, or use --solver gd (no factor)",
        )?;
    }
    Ok(())
}

/// Deforms REST (`inputs.rest`, its cells `inputs.cells`) minimizing
///
/// ```text
/// sum_k V_k D(J_k)  +  W sum_b |x_b - t_b|^2,   x_h = x0_h for the fixed h
/// ```
///
/// flip-free from the start: INIT's positions (`inputs.start`), untangled
/// first when they invert elements, else REST's own shape (tets only). The
/// fixed vertices are HANDLES' and, with `fixed_boundary`, the vertices of
/// the facets used by one element ([`super::fixed::fixed_vertices`]).
///
/// A tet REST without INIT is repaired first and solved on the repaired
/// mesh; the solution is put back on REST's vertex numbers (welded copies
/// move together; the first target of a welded vertex counts; a vertex no
/// tet uses goes to its target, if it has one). With INIT the meshes are
/// used as they are, so that their vertex numbers correspond. The stage
/// `deformation` and every iteration go to `observer`.
///
/// # Errors
/// The settings' ([`Settings::validate`]), a target out of range (or off
/// the plane for triangles), a mesh that cannot be repaired, an inverted or
/// degenerate rest element, the solver's failures; each at the input it is
/// about. Finding no injective map is not an error: the report says
/// `injective: false`.
pub fn deform_mesh(
    inputs: Inputs,
    settings: &Settings,
    observer: &mut dyn Observer,
) -> Result<Deformed, AppError> {
    settings.validate()?;
    let Inputs {
        mesh,
        targets,
        init,
        cells,
        rest,
        pairs,
        start,
        handles,
        fixed_boundary,
        ..
    } = inputs;
    let targets = targets.unwrap_or_else(|| PathBuf::from("targets"));
    let init = init.unwrap_or_else(|| PathBuf::from("init"));
    let n = rest.num_vertices();
    if let Some(&(v, _)) = pairs.iter().find(|(v, _)| *v >= n) {
        return Err(at(
            &targets,
            format!("vertex {v} is out of range (the mesh has {n} vertices, numbered from 0)"),
        ));
    }
    if let (Rest::Triangles(_), Some(&(v, t))) = (&rest, pairs.iter().find(|(_, t)| t[2] != 0.0)) {
        return Err(at(
            &targets,
            format!(
                "vertex {v}: target z = {:e}; a triangle mesh is mapped to the plane, so its \
                 targets must have z = 0",
                t[2]
            ),
        ));
    }
    let fixed = fixed_vertices(&handles, fixed_boundary, &rest.element_vertices(), n);
    let solver: Box<dyn crate::param::Solver> = match settings.solver {
        SolverKind::Newton => Box::new(crate::param::deform_newton()),
        other => other.build(),
    };
    let mut stopping = solver.default_stopping();
    stopping.grad_tol = settings.tol;
    stopping.max_iterations = settings.iteration_limit();
    let pipeline = Deform::new()
        .weight(settings.weight)
        .stopping(stopping)
        .energy(settings.energy.build())
        .solver(solver);
    let problem = |e| deform_problem(&mesh, &targets, &init, settings.solver, e);
    let elements = rest.elements();
    let element_count = rest.len();
    let (positions, repair, report) = match (&rest, start) {
        (Rest::Tets(tet_mesh), None) => {
            let repaired = repair_tet_mesh_traced(
                tet_mesh,
                &RepairOptions {
                    weld: Weld::Relative,
                    keep_tet_orientation: true,
                    ..Default::default()
                },
            )
            .map_err(|e| at(&mesh, e))?;
            let of_input = &repaired.vertex_of_input;
            let mut targeted = vec![false; repaired.mesh.num_vertices()];
            let solve_pairs: Vec<(usize, [f64; 3])> = pairs
                .iter()
                .filter_map(|&(v, t)| {
                    let r = of_input[v]? as usize;
                    (!std::mem::replace(&mut targeted[r], true)).then_some((r, t))
                })
                .collect();
            let mut solve_fixed: Vec<usize> = fixed
                .iter()
                .filter_map(|&v| of_input[v].map(|r| r as usize))
                .collect();
            solve_fixed.sort_unstable();
            solve_fixed.dedup();
            let pmesh = ParamMesh::from_tets(&repaired.mesh).map_err(problem)?;
            check_memory(settings, &pmesh, &mesh)?;
            drop(pmesh);
            observer.stage("deformation");
            let mut iterations = |it: &crate::param::Iteration| observer.iteration(it);
            let outcome = pipeline
                .fixed(solve_fixed)
                .run_with(&repaired.mesh, &solve_pairs, &mut iterations)
                .map_err(problem)?;
            let mut positions = cells.positions.clone();
            for (i, p) in positions.iter_mut().enumerate() {
                if let Some(r) = of_input[i] {
                    *p = outcome.positions[r as usize];
                }
            }
            for &(v, t) in &pairs {
                if of_input[v].is_none() {
                    positions[v] = t.into();
                }
            }
            (positions, Some(repaired.report), outcome.report)
        }
        (rest, start) => {
            let pmesh = match rest {
                Rest::Tets(m) => ParamMesh::from_tets(m),
                Rest::Triangles(m) => ParamMesh::from_triangles(m),
            }
            .map_err(problem)?;
            check_memory(settings, &pmesh, &mesh)?;
            drop(pmesh);
            observer.stage("deformation");
            let mut iterations = |it: &crate::param::Iteration| observer.iteration(it);
            let pipeline = match start {
                Some(start) => pipeline.start(start),
                None => pipeline,
            };
            let DeformOutcome { positions, report } = pipeline
                .fixed(fixed)
                .run_shape(rest.shape(), &pairs, &mut iterations)
                .map_err(problem)?;
            (positions, None, report)
        }
    };
    let mut deformed = cells;
    let (det_j, inverted) = flip_arrays(&deformed, &positions, &rest, report.mirrored);
    deformed.positions = positions;
    deformed
        .add_cell_field(Field::scalars("det_j", det_j))
        .and_then(|()| {
            deformed.add_cell_field(Field::new("inverted", 1, FieldValues::U8(inverted))?)
        })
        .map_err(|e| at(&mesh, e))?;
    Ok(Deformed {
        mesh: deformed,
        elements,
        element_count,
        repair,
        report,
    })
}

/// The cell arrays of the map from REST (`rest_cells`' positions) to
/// `positions`: `det_j`, the ratio of mapped to rest volume (tets) or of
/// mapped signed area in the plane to rest area (triangles; times -1 when
/// the solve `mirrored` the start, so that it is positive where the map
/// agrees with the library's orientation), and `inverted`, 1 where
/// `det_j <= 0`, else 0.
pub fn flip_arrays(
    rest_cells: &CellMesh,
    positions: &[Point3<f64>],
    rest: &Rest,
    mirrored: bool,
) -> (Vec<f64>, Vec<u8>) {
    let p0 = &rest_cells.positions;
    let det_j: Vec<f64> = rest
        .element_vertices()
        .iter()
        .map(|e| {
            let at = |p: &[Point3<f64>], k: usize| p[e[k] as usize];
            if e.len() == 4 {
                let vol = |p: &[Point3<f64>]| {
                    let a = at(p, 0);
                    (at(p, 1) - a).cross(&(at(p, 2) - a)).dot(&(at(p, 3) - a))
                };
                vol(positions) / vol(p0)
            } else {
                let cross = |p: &[Point3<f64>]| {
                    let a = at(p, 0);
                    (at(p, 1) - a).cross(&(at(p, 2) - a))
                };
                let sign = if mirrored { -1.0 } else { 1.0 };
                sign * cross(positions).z / cross(p0).norm()
            }
        })
        .collect();
    let inverted = det_j.iter().map(|&d| u8::from(d <= 0.0)).collect();
    (det_j, inverted)
}
