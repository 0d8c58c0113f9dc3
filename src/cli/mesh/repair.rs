//! `unfold repair IN -o OUT`: the flags turned into the repair's settings
//! and files ([`crate::app::mesh::repair`] repairs), the counts printed as
//! a sentence or as JSON.

use crate::app::AppError;
use crate::app::error::at;
use crate::app::mesh::repair::{self, Files, Settings};
use crate::app::run::StagedOutputs;
use clap::Args;
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

impl RepairArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            weld_mm: self.weld_mm,
            no_weld: self.no_weld,
            fill_holes_mm: self.fill_holes_mm,
            largest_component: self.largest_component,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            input: self.input.clone(),
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold repair`.
pub fn run(a: &RepairArgs) -> Result<(), AppError> {
    let settings = a.settings();
    let files = a.files();
    let options = settings.options()?;
    files.check()?;
    // The output checked (and staged) before the input is read.
    let mut staged = StagedOutputs::new([&files.input]);
    let target = staged.file(&files.output)?;
    let cells = files.read()?;
    let repaired = repair::run(&cells, &options, settings.largest_component, &files.input)?;
    repair::write(&repaired, &target, &staged)?;
    staged.commit()?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&repaired.summary(&files))
                .map_err(|e| at(&a.output, e))?
        );
    } else {
        let elements = repaired.elements;
        let largest = match repaired.largest_component {
            Some(d) if d.components > 1 => format!(
                "; kept the largest of {} components ({} {elements} and {} vertices dropped)",
                d.components, d.elements, d.vertices
            ),
            _ => String::new(),
        };
        println!(
            "{} -> {}: {}{largest}; {} vertices, {} {elements}",
            a.input.display(),
            a.output.display(),
            repaired.report,
            repaired.mesh.num_points(),
            repaired.mesh.num_cells()
        );
    }
    Ok(())
}
