//! `unfold info FILE [--json]`: what a mesh or image contains, and whether
//! it is valid ([`crate::app::mesh::info`] builds the report), printed as
//! text or JSON.

use crate::app::AppError;
use crate::app::mesh::info::{ImageInfo, Info, MeshInfo, info, to_json};
use crate::app::run::printable::printable;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `unfold info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// A mesh (.vtk .vtu .vtp .ply .obj .stl .off .mesh .msh) or image (.nii .nii.gz
    /// .nrrd .seg.nrrd .nhdr).
    file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Exit with an error when the mesh has validity problems.
    #[arg(long)]
    strict: bool,
}

/// Prints a mesh's report as text.
fn print_mesh(i: &MeshInfo) {
    println!("{}: {} mesh", printable(&i.file), i.mesh_type);
    println!("  points: {}", i.points);
    let types: Vec<String> = i
        .cell_types
        .iter()
        .map(|(t, n)| format!("{n} {t}"))
        .collect();
    println!("  cells: {} ({})", i.cells, types.join(", "));
    if let Some([lo, hi]) = i.bounding_box {
        println!(
            "  bounding box: [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}] (size {:.4} x {:.4} x {:.4})",
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2],
            hi[0] - lo[0],
            hi[1] - lo[1],
            hi[2] - lo[2]
        );
    }
    if let Some(n) = &i.units_note {
        println!("  {}", printable(n));
    }
    for (what, arrays) in [("point", &i.point_arrays), ("cell", &i.cell_arrays)] {
        for a in arrays {
            let range = match (a.min, a.max) {
                (Some(lo), Some(hi)) => format!(", range [{lo}, {hi}]"),
                _ => String::new(),
            };
            println!(
                "  {what} array '{}': {} x {}{range}",
                printable(&a.name),
                a.components,
                a.value_type
            );
        }
    }
    if let Some(c) = i.components {
        println!("  connected components: {c}");
    }
    if let Some(ls) = &i.boundary_loops {
        println!("  boundary loops: {} {:?}", ls.len(), ls);
    }
    if let Some(b) = &i.boundary_surface {
        println!(
            "  boundary surface: {} vertices, {} triangles, {} component(s), Euler characteristic {}",
            b.vertices, b.triangles, b.components, b.euler_characteristic
        );
    }
    if let Some(a) = i.area_mm2 {
        println!("  area: {a:.6} mm^2");
    }
    if let Some(v) = i.volume_mm3 {
        println!("  volume: {v:.6} mm^3");
    }
    if let Some(f) = &i.folds {
        println!(
            "  inverted elements: {}, folded {}: {}",
            f.inverted,
            if i.mesh_type == "tetrahedral" {
                "faces"
            } else {
                "edges"
            },
            f.folded
        );
    }
    if i.valid {
        println!("  valid: yes");
    } else {
        println!("  valid: no");
        for p in &i.problems {
            println!(
                "  problem {} (x{}): {}",
                p.kind,
                p.count,
                printable(&p.first)
            );
        }
    }
}

/// Prints an image's report as text.
fn print_image(i: &ImageInfo) {
    println!("{}: image", printable(&i.file));
    println!("  dims: {:?}", i.dims);
    println!(
        "  spacing: {:.6} x {:.6} x {:.6} mm",
        i.spacing_mm[0], i.spacing_mm[1], i.spacing_mm[2]
    );
    println!("  affine ({}):", i.affine_source);
    for r in &i.affine {
        println!(
            "    [{:12.6} {:12.6} {:12.6} {:12.6}]",
            r[0], r[1], r[2], r[3]
        );
    }
    println!("  data type: {}", i.datatype);
    if let Some([lo, hi]) = i.value_range {
        println!("  value range: [{lo}, {hi}]");
    }
}

/// Runs `unfold info`.
pub fn run(a: &InfoArgs) -> Result<(), AppError> {
    match info(&a.file)? {
        Info::Image(i) => {
            if a.json {
                println!("{}", to_json(&i));
            } else {
                print_image(&i);
            }
            Ok(())
        }
        Info::Mesh(i) => {
            if a.json {
                println!("{}", to_json(&i));
            } else {
                print_mesh(&i);
            }
            if a.strict { i.strict() } else { Ok(()) }
        }
    }
}
