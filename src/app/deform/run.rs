//! A deformation on its inputs: the mesh repaired, the library's
//! [`Deform`] solved on it (the memory budget checked before a Newton
//! factor), the solution put back on the input's vertex numbers, and the
//! typed report. Nothing is written here ([`super::write()`] does).

use super::inputs::Inputs;
use super::report::DeformRunReport;
use super::settings::Settings;
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::provenance;
use crate::mesh::repair::{RepairOptions, RepairReport, Weld, repair_tet_mesh_traced};
use crate::mesh::{CellMesh, MeshError, TetMesh};
use crate::param::solver::SolverKind;
use crate::param::{Deform, DeformReport, Named, ParamError};
use std::path::Path;

/// A deformed mesh and what the run found.
#[derive(Debug, Clone)]
pub struct Deformed {
    /// The input mesh (cells and arrays) with the positions replaced.
    pub mesh: CellMesh,
    /// Tets of the input mesh.
    pub tets: usize,
    /// What the repair of the input mesh changed.
    pub repair: RepairReport,
    /// The library's report.
    pub report: DeformReport,
}

/// What a run produced.
#[derive(Debug, Clone)]
pub struct Run {
    /// The input mesh (cells and arrays) with the positions replaced.
    pub mesh: CellMesh,
    /// Tets of the input mesh.
    pub tets: usize,
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
    let Inputs {
        mesh,
        targets,
        cells,
        tets,
        pairs,
    } = inputs;
    let deformed = deform_mesh(cells, &tets, &pairs, settings, &mesh, &targets, observer)?;
    Ok(Run {
        mesh: deformed.mesh,
        tets: deformed.tets,
        report: DeformRunReport {
            mesh: mesh.display().to_string(),
            targets_file: targets.display().to_string(),
            output: String::new(),
            repair: deformed.repair,
            report: deformed.report,
            provenance: provenance::this_run(),
        },
    })
}

/// A pipeline error, worded for this command and attributed to the input
/// it is about (`mesh` or `targets`).
fn deform_problem(mesh: &Path, targets: &Path, solver: SolverKind, e: ParamError) -> AppError {
    match e {
        ParamError::Mesh(MeshError::InvertedElement { element, volume }) => at(
            mesh,
            format!(
                "tet {element} is inverted (signed volume {volume:e}); the input shape is the \
                 rest state and the starting point, so every tet must be positively oriented"
            ),
        ),
        e @ (ParamError::TargetNotFinite { .. }
        | ParamError::TargetRepeated { .. }
        | ParamError::Length { .. }) => at(targets, e),
        e @ (ParamError::Mesh(_) | ParamError::Setting { .. }) => at(mesh, e),
        e => at(mesh, format!("the {} solver failed: {e}", solver.name())),
    }
}

/// Deforms the tet mesh `cells` (its tets `tet_mesh`, by
/// [`super::inputs::tet_mesh_of`]; named `mesh` in messages) towards the
/// targets `pairs` (`(vertex, target)`, vertices of `cells`, each at most
/// once; named `targets`), minimizing
///
/// ```text
/// sum_k V_k D(J_k)  +  W sum_b |x_b - t_b|^2
/// ```
///
/// flip-free from the input positions: repairs the mesh, solves on the
/// repaired mesh (the memory budget checked before a Newton factor) and
/// puts the solution back on the input's vertex numbers (welded copies move
/// together; the first target of a welded vertex counts; a vertex no tet
/// uses goes to its target, if it has one). The stage `deformation` and
/// every iteration go to `observer`.
///
/// # Errors
/// The settings' ([`Settings::validate`]), a mesh that cannot be repaired,
/// an inverted tet, a target vertex out of range, the solver's failures;
/// each at the input it is about.
pub fn deform_mesh(
    cells: CellMesh,
    tet_mesh: &TetMesh,
    pairs: &[(usize, [f64; 3])],
    settings: &Settings,
    mesh: &Path,
    targets: &Path,
    observer: &mut dyn Observer,
) -> Result<Deformed, AppError> {
    settings.validate()?;
    let n = tet_mesh.num_vertices();
    if let Some(&(v, _)) = pairs.iter().find(|(v, _)| *v >= n) {
        return Err(at(
            targets,
            format!("vertex {v} is out of range (the mesh has {n} vertices, numbered from 0)"),
        ));
    }
    let repaired = repair_tet_mesh_traced(
        tet_mesh,
        &RepairOptions {
            weld: Weld::Relative,
            keep_tet_orientation: true,
            ..Default::default()
        },
    )
    .map_err(|e| at(mesh, e))?;
    let of_input = &repaired.vertex_of_input;
    let mut targeted = vec![false; repaired.mesh.num_vertices()];
    let solve_pairs: Vec<(usize, [f64; 3])> = pairs
        .iter()
        .filter_map(|&(v, t)| {
            let r = of_input[v]? as usize;
            (!std::mem::replace(&mut targeted[r], true)).then_some((r, t))
        })
        .collect();
    let solver = settings.solver.build();
    let mut stopping = solver.default_stopping();
    stopping.grad_tol = settings.tol;
    if let Some(n) = settings.max_iterations {
        stopping.max_iterations = n;
    }
    let pipeline = Deform::new()
        .weight(settings.weight)
        .stopping(stopping)
        .energy(settings.energy.build())
        .solver(solver);
    if settings.solver == SolverKind::Newton {
        let pmesh = crate::param::ParamMesh::from_tets(&repaired.mesh).map_err(|e| at(mesh, e))?;
        let estimate = crate::param::memory::mesh_newton_memory(&pmesh).map_err(|e| at(mesh, e))?;
        drop(pmesh);
        crate::app::run::memory::check(
            "deforming the mesh",
            &estimate,
            "coarsen the mesh, or use --solver gd (no factor)",
        )?;
    }
    observer.stage("deformation");
    let mut iterations = |it: &crate::param::Iteration| observer.iteration(it);
    let outcome = pipeline
        .run_with(&repaired.mesh, &solve_pairs, &mut iterations)
        .map_err(|e| deform_problem(mesh, targets, settings.solver, e))?;
    let mut deformed = cells;
    for (i, p) in deformed.positions.iter_mut().enumerate() {
        if let Some(r) = of_input[i] {
            *p = outcome.positions[r as usize];
        }
    }
    for &(v, t) in pairs {
        if of_input[v].is_none() {
            deformed.positions[v] = t.into();
        }
    }
    Ok(Deformed {
        mesh: deformed,
        tets: tet_mesh.num_tets(),
        repair: repaired.report,
        report: outcome.report,
    })
}
