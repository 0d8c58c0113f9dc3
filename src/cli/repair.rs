//! `unfold repair IN -o OUT`: the mesh repaired (coincident vertices
//! welded, degenerate and duplicate elements dropped, slivers collapsed,
//! fins dropped, non-manifold vertices split, orientation made consistent,
//! small holes filled when asked, unused vertices dropped; with
//! `--largest-component` only the largest connected component kept), with
//! counts per kind; the steps are those of [`crate::mesh::repair`].

use super::{AppError, at};
use crate::app::run::StagedOutputs;
use crate::io::{WriteOptions, read_mesh, write_mesh};
use crate::mesh::CellMesh;
use crate::mesh::repair::{
    RepairOptions, RepairReport, Weld, repair_tet_mesh_with, repair_tri_mesh_with,
};
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `unfold repair`.
#[derive(Debug, Args)]
#[command(
    after_help = "Triangle meshes (polygons are fan-triangulated) and tet meshes (lower-dimensional \
cells are left out). Prints what was repaired, one count per kind. Refuses only what cannot be \
repaired (a non-orientable surface), naming the vertices."
)]
pub struct RepairArgs {
    /// The mesh to repair (never modified).
    input: PathBuf,
    /// The repaired mesh (format by extension).
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Weld vertices closer than this, mm [default: a millionth of the mean
    /// edge length].
    #[arg(
        long,
        value_name = "MM",
        conflicts_with = "no_weld",
        allow_negative_numbers = true
    )]
    weld_mm: Option<f64>,
    /// Do not weld coincident vertices.
    #[arg(long)]
    no_weld: bool,
    /// Close the boundary loops whose perimeter is at most this, mm
    /// (triangle meshes; ear clipping over the loop's own vertices).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    fill_holes_mm: Option<f64>,
    /// After the repair, keep only the largest connected component (most
    /// elements; the first on ties) and drop the others, e.g. specks of a
    /// segmentation or a second organ in the same file.
    #[arg(long)]
    largest_component: bool,
    /// Print the counts as JSON instead of a sentence.
    #[arg(long)]
    json: bool,
}

/// What `--largest-component` dropped.
#[derive(Debug, Clone, Copy, Serialize)]
struct Dropped {
    /// Components the repaired mesh had.
    components: usize,
    /// Elements of the components dropped.
    elements: usize,
    /// Vertices of the components dropped.
    vertices: usize,
}

/// What `--json` prints.
#[derive(Debug, Serialize)]
struct Summary<'a> {
    input: String,
    output: String,
    /// "triangles" or "tets".
    elements: &'static str,
    vertices: usize,
    cells: usize,
    repair: &'a RepairReport,
    /// With `--largest-component`: what was dropped.
    #[serde(skip_serializing_if = "Option::is_none")]
    largest_component: Option<Dropped>,
}

/// Runs `unfold repair`.
pub fn run(a: &RepairArgs) -> Result<(), AppError> {
    let weld = match (a.no_weld, a.weld_mm) {
        (true, _) => Weld::Off,
        (false, None) => Weld::Relative,
        (false, Some(t)) if t.is_finite() && t >= 0.0 => Weld::Within(t),
        (false, Some(t)) => {
            return Err(AppError::Usage(format!(
                "--weld-mm must be a finite distance >= 0, got {t}"
            )));
        }
    };
    if let Some(d) = a.fill_holes_mm
        && !(d.is_finite() && d > 0.0)
    {
        return Err(AppError::Usage(format!(
            "--fill-holes-mm must be a finite perimeter > 0 mm, got {d}"
        )));
    }
    if super::canonical(&a.input) == super::canonical(&a.output) {
        return Err(AppError::Usage(format!(
            "{}: refusing to overwrite the input; choose another output path",
            a.output.display()
        )));
    }
    // The output checked (and staged) before the input is read.
    let mut staged = StagedOutputs::new([&a.input]);
    let target = staged.file(&a.output)?;
    let cells = read_mesh(&a.input)?;
    let options = RepairOptions {
        weld,
        fill_holes: a.fill_holes_mm,
        ..Default::default()
    };
    let volume = cells.cells().any(|(t, _)| t.dimension() == 3);
    let dropped = |r: &RepairReport, before: (usize, usize), after: (usize, usize)| Dropped {
        components: r.components,
        elements: before.0 - after.0,
        vertices: before.1 - after.1,
    };
    let mut kept = None;
    let (out, report, elements): (CellMesh, RepairReport, &'static str) = if volume {
        let tets = cells.volume_tets().map_err(|e| at(&a.input, e))?;
        let (mut m, r) = repair_tet_mesh_with(&tets, &options).map_err(|e| at(&a.input, e))?;
        if a.largest_component {
            let before = (m.tets.len(), m.positions.len());
            m = m.largest_component().map_err(|e| at(&a.input, e))?.0;
            kept = Some(dropped(&r, before, (m.tets.len(), m.positions.len())));
        }
        (CellMesh::from(&m), r, "tets")
    } else {
        let tris = cells.to_tri_mesh().map_err(|e| at(&a.input, e))?;
        let (mut m, r) = repair_tri_mesh_with(&tris, &options).map_err(|e| at(&a.input, e))?;
        if a.largest_component {
            let before = (m.triangles.len(), m.positions.len());
            m = m.largest_component().map_err(|e| at(&a.input, e))?.0;
            kept = Some(dropped(&r, before, (m.triangles.len(), m.positions.len())));
        }
        (CellMesh::from(&m), r, "triangles")
    };
    write_mesh(&target, &out, &WriteOptions::default()).map_err(|e| staged.shown_error(e))?;
    staged.commit()?;
    if a.json {
        let s = Summary {
            input: a.input.display().to_string(),
            output: a.output.display().to_string(),
            elements,
            vertices: out.num_points(),
            cells: out.num_cells(),
            repair: &report,
            largest_component: kept,
        };
        println!(
            "{}",
            serde_json::to_string_pretty(&s).map_err(|e| at(&a.output, e))?
        );
    } else {
        let largest = match kept {
            Some(d) if d.components > 1 => format!(
                "; kept the largest of {} components ({} {elements} and {} vertices dropped)",
                d.components, d.elements, d.vertices
            ),
            _ => String::new(),
        };
        println!(
            "{} -> {}: {report}{largest}; {} vertices, {} {elements}",
            a.input.display(),
            a.output.display(),
            out.num_points(),
            out.num_cells()
        );
    }
    Ok(())
}
