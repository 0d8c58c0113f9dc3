//! `unfold repair`: a mesh exported by another tool repaired (coincident
//! vertices welded, degenerate and duplicate elements dropped, slivers
//! collapsed, fins dropped, non-manifold vertices split, orientation made
//! consistent, small holes filled when asked, unused vertices dropped;
//! with `largest_component` only the largest connected component kept),
//! with counts per kind; the steps are those of [`crate::mesh::repair`].
//!
//! [`Settings`] (checked by [`Settings::options`]), the [`Files`] checked
//! before anything is read, [`run`] on the mesh read into a [`Repaired`],
//! [`write`] into the staged output, and the typed [`RepairSummary`] that
//! `repair --json` prints.

use crate::app::error::{AppError, at};
use crate::app::run::StagedOutputs;
use crate::app::run::files::canonical;
use crate::io::{WriteOptions, read_mesh, write_mesh};
use crate::mesh::CellMesh;
use crate::mesh::fold_check::{FoldCounts, planar_triangle_folds, tet_folds};
use crate::mesh::repair::{
    RepairOptions, RepairReport, Weld, repair_tet_mesh_with, repair_tri_mesh_with,
};
use crate::mesh::validate::Problem;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How a mesh is repaired; the names are the command line's flags.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, rename_all = "kebab-case")]
pub struct Settings {
    /// Weld vertices closer than this, mm (none: a millionth of the mean
    /// edge length).
    pub weld_mm: Option<f64>,
    /// Do not weld coincident vertices.
    pub no_weld: bool,
    /// Close the boundary loops whose perimeter is at most this, mm
    /// (triangle meshes).
    pub fill_holes_mm: Option<f64>,
    /// After the repair, keep only the largest connected component.
    pub largest_component: bool,
}

impl Settings {
    /// The repair's options, every setting checked.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag out of range.
    pub fn options(&self) -> Result<RepairOptions, AppError> {
        let weld = match (self.no_weld, self.weld_mm) {
            (true, _) => Weld::Off,
            (false, None) => Weld::Relative,
            (false, Some(t)) if t.is_finite() && t >= 0.0 => Weld::Within(t),
            (false, Some(t)) => {
                return Err(AppError::Usage(format!(
                    "--weld-mm must be a finite distance >= 0, got {t}"
                )));
            }
        };
        if let Some(d) = self.fill_holes_mm
            && !(d.is_finite() && d > 0.0)
        {
            return Err(AppError::Usage(format!(
                "--fill-holes-mm must be a finite perimeter > 0 mm, got {d}"
            )));
        }
        Ok(RepairOptions {
            weld,
            fill_holes: self.fill_holes_mm,
            ..Default::default()
        })
    }
}

/// The files of a repair.
#[derive(Debug, Clone)]
pub struct Files {
    /// The mesh to repair (never modified).
    pub input: PathBuf,
    /// The repaired mesh (format by extension).
    pub output: PathBuf,
}

impl Files {
    /// Checks the files before anything is read: the output is not the
    /// input.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the output.
    pub fn check(&self) -> Result<(), AppError> {
        if canonical(&self.input) == canonical(&self.output) {
            return Err(at(
                &self.output,
                "refusing to overwrite the input; choose another output path",
            ));
        }
        Ok(())
    }

    /// Reads the input mesh (any format unfold reads).
    ///
    /// # Errors
    /// Reading the file.
    pub fn read(&self) -> Result<CellMesh, AppError> {
        Ok(read_mesh(&self.input)?)
    }
}

/// What `largest_component` dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Dropped {
    /// Components the repaired mesh had.
    pub components: usize,
    /// Elements of the components dropped.
    pub elements: usize,
    /// Vertices of the components dropped.
    pub vertices: usize,
}

/// A repaired mesh and what the repair did.
#[derive(Debug, Clone)]
pub struct Repaired {
    /// The repaired mesh (triangles or tets only).
    pub mesh: CellMesh,
    /// The counts per kind of repair.
    pub report: RepairReport,
    /// `triangles` or `tets`.
    pub elements: &'static str,
    /// With `largest_component`: what was dropped.
    pub largest_component: Option<Dropped>,
}

/// What `repair --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct RepairSummary {
    /// The input file, as given.
    pub input: String,
    /// The output file, as given.
    pub output: String,
    /// "triangles" or "tets".
    pub elements: &'static str,
    /// Vertices of the repaired mesh.
    pub vertices: usize,
    /// Elements of the repaired mesh.
    pub cells: usize,
    /// The counts per kind of repair.
    pub repair: RepairReport,
    /// With `--largest-component`: what was dropped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub largest_component: Option<Dropped>,
}

/// Repairs `cells` (read from `input`, which messages name) with
/// `options` ([`Settings::options`]): a tet mesh when it holds a 3D cell
/// (lower-dimensional cells left out), else a triangle mesh (polygons
/// fan-triangulated); with `largest_component`, only the largest connected
/// component (most elements, the first on ties) is kept.
///
/// A folded mesh (tets, or triangles in one plane, whose elements overlap
/// their neighbours: [`crate::mesh::fold_check`]) is refused rather than
/// re-oriented: turning its inverted elements positive would hide the fold,
/// not undo it. A mirrored mesh (every tet negative) has no fold and is
/// re-oriented.
///
/// # Errors
/// [`AppError::Usage`] at `input` for what cannot be repaired (a
/// non-orientable surface, naming the vertices; a folded mesh, naming the
/// first fold).
pub fn run(
    cells: &CellMesh,
    options: &RepairOptions,
    largest_component: bool,
    input: &Path,
) -> Result<Repaired, AppError> {
    let volume = cells.cells().any(|(t, _)| t.dimension() == 3);
    let dropped = |r: &RepairReport, before: (usize, usize), after: (usize, usize)| Dropped {
        components: r.components,
        elements: before.0 - after.0,
        vertices: before.1 - after.1,
    };
    let mut kept = None;
    let (mesh, report, elements): (CellMesh, RepairReport, &'static str) = if volume {
        let tets = cells.volume_tets().map_err(|e| at(input, e))?;
        let (mut m, r) = repair_tet_mesh_with(&tets, options).map_err(|e| at(input, e))?;
        let (folds, problems) = tet_folds(&m);
        refuse_folds(input, "faces", folds, &problems)?;
        if largest_component {
            let before = (m.tets.len(), m.positions.len());
            m = m.largest_component().map_err(|e| at(input, e))?.0;
            kept = Some(dropped(&r, before, (m.tets.len(), m.positions.len())));
        }
        (CellMesh::from(&m), r, "tets")
    } else {
        let tris = cells.to_tri_mesh().map_err(|e| at(input, e))?;
        let (mut m, r) = repair_tri_mesh_with(&tris, options).map_err(|e| at(input, e))?;
        if let Some((folds, problems)) = planar_triangle_folds(&m) {
            refuse_folds(input, "edges", folds, &problems)?;
        }
        if largest_component {
            let before = (m.triangles.len(), m.positions.len());
            m = m.largest_component().map_err(|e| at(input, e))?.0;
            kept = Some(dropped(&r, before, (m.triangles.len(), m.positions.len())));
        }
        (CellMesh::from(&m), r, "triangles")
    };
    Ok(Repaired {
        mesh,
        report,
        elements,
        largest_component: kept,
    })
}

/// Refuses a repaired mesh that still has folds or inverted elements
/// (`folds` and `problems` from [`crate::mesh::fold_check`]), naming how
/// many and the last problem (the first folded face or edge when there is
/// one).
fn refuse_folds(
    input: &Path,
    what: &str,
    folds: FoldCounts,
    problems: &[Problem],
) -> Result<(), AppError> {
    match problems.last() {
        Some(fold) if !folds.is_clean() => Err(at(
            input,
            format!(
                "the mesh is folded ({} folded {what}, {} inverted elements), which repair \
                 cannot undo: {}",
                folds.folded, folds.inverted, fold.error
            ),
        )),
        _ => Ok(()),
    }
}

impl Repaired {
    /// The summary of the repair of `files`.
    pub fn summary(&self, files: &Files) -> RepairSummary {
        RepairSummary {
            input: files.input.display().to_string(),
            output: files.output.display().to_string(),
            elements: self.elements,
            vertices: self.mesh.num_points(),
            cells: self.mesh.num_cells(),
            repair: self.report,
            largest_component: self.largest_component,
        }
    }
}

/// Writes the repaired mesh at `target`, a staging path of `staged`
/// (errors name the path it will have).
///
/// # Errors
/// Writing the file.
pub fn write(repaired: &Repaired, target: &Path, staged: &StagedOutputs) -> Result<(), AppError> {
    write_mesh(target, &repaired.mesh, &WriteOptions::default())
        .map_err(|e| staged.shown_error(e))?;
    Ok(())
}
