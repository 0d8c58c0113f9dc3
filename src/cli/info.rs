//! `unfold info FILE [--json]`: what a mesh or image contains, and whether
//! it is valid.
//!
//! An image is read header first ([`crate::io::read_image_header`] fields)
//! and its values are streamed once for the range
//! ([`crate::io::image_value_summary`]): memory stays about 1 MiB whatever
//! the image's size, and a `.nii.gz` is never inflated past what its header
//! declares.

use super::{AppError, printable};
use crate::io::{FileKind, ImageHeader, ValueSummary, image_value_summary, read_mesh};
use crate::mesh::geometry::{bounding_box, total_area, total_volume};
use crate::mesh::topology::{
    boundary_loops, connected_components, euler_characteristic, tet_boundary,
};
use crate::mesh::validate::{ValidationOptions, check_tet_mesh, check_tri_mesh};
use crate::mesh::{CellMesh, Field, MeshError};
use clap::Args;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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

/// Summary of one data array.
#[derive(Debug, Serialize)]
pub struct ArrayInfo {
    name: String,
    components: usize,
    #[serde(rename = "type")]
    value_type: &'static str,
    min: Option<f64>,
    max: Option<f64>,
}

/// One kind of validity problem.
#[derive(Debug, Serialize)]
pub struct ProblemInfo {
    kind: &'static str,
    count: usize,
    first: String,
}

/// The boundary surface of a tet mesh.
#[derive(Debug, Serialize)]
pub struct BoundaryInfo {
    vertices: usize,
    triangles: usize,
    components: usize,
    euler_characteristic: i64,
}

/// What `info` reports about a mesh.
#[derive(Debug, Serialize)]
pub struct MeshInfo {
    file: String,
    kind: &'static str,
    mesh_type: &'static str,
    points: usize,
    cells: usize,
    cell_types: BTreeMap<String, usize>,
    bounding_box: Option<[[f64; 3]; 2]>,
    /// When the mesh is smaller than any organ (coordinates read as mm):
    /// [`crate::app::run::units::note`].
    #[serde(skip_serializing_if = "Option::is_none")]
    units_note: Option<String>,
    point_arrays: Vec<ArrayInfo>,
    cell_arrays: Vec<ArrayInfo>,
    components: Option<usize>,
    boundary_loops: Option<Vec<usize>>,
    boundary_surface: Option<BoundaryInfo>,
    area_mm2: Option<f64>,
    volume_mm3: Option<f64>,
    valid: bool,
    problems: Vec<ProblemInfo>,
}

/// What `info` reports about an image.
#[derive(Debug, Serialize)]
pub struct ImageInfo {
    file: String,
    kind: &'static str,
    dims: [usize; 4],
    spacing_mm: [f64; 3],
    affine: [[f64; 4]; 4],
    affine_source: String,
    datatype: String,
    value_range: Option<[f64; 2]>,
}

fn array_info(f: &Field) -> ArrayInfo {
    let v = f.values().to_f64();
    let finite = v.iter().copied().filter(|x| x.is_finite());
    let (min, max) = finite.fold((None, None), |(lo, hi): (Option<f64>, Option<f64>), x| {
        (
            Some(lo.map_or(x, |l| l.min(x))),
            Some(hi.map_or(x, |h| h.max(x))),
        )
    });
    ArrayInfo {
        name: f.name().to_string(),
        components: f.components(),
        value_type: f.values().type_name(),
        min,
        max,
    }
}

/// Builds the report of a mesh already read.
pub fn mesh_info(path: &Path, mesh: &CellMesh) -> MeshInfo {
    let counts = mesh.cell_type_counts();
    let dims: Vec<u8> = counts.iter().map(|(t, _)| t.dimension()).collect();
    let only = |d: u8| !dims.is_empty() && dims.iter().all(|&x| x == d);
    let mesh_type = if mesh.num_cells() == 0 {
        "points"
    } else if counts.len() == 1 && counts[0].0 == crate::mesh::CellType::Tetra {
        "tetrahedral"
    } else if only(2) {
        "surface"
    } else if only(1) {
        "lines"
    } else if only(0) {
        "points"
    } else {
        "mixed"
    };
    let mut info = MeshInfo {
        file: path.display().to_string(),
        kind: "mesh",
        mesh_type,
        points: mesh.num_points(),
        cells: mesh.num_cells(),
        cell_types: counts.iter().map(|(t, n)| (format!("{t:?}"), *n)).collect(),
        bounding_box: bounding_box(&mesh.positions)
            .map(|b| [[b.min.x, b.min.y, b.min.z], [b.max.x, b.max.y, b.max.z]]),
        units_note: crate::app::run::units::smaller_than_an_organ(&mesh.positions).map(|side| {
            let file = path.display();
            crate::app::run::units::note(
                &file.to_string(),
                side,
                &format!("if it is in metres, `unfold convert {file} OUT --scale 1000`"),
            )
        }),
        point_arrays: mesh.point_data.iter().map(array_info).collect(),
        cell_arrays: mesh.cell_data.iter().map(array_info).collect(),
        components: None,
        boundary_loops: None,
        boundary_surface: None,
        area_mm2: None,
        volume_mm3: None,
        valid: true,
        problems: Vec::new(),
    };
    // Several components are information (`components`), not a defect: a
    // valve's two leaflets or a heart's chambers are one valid file.
    let opts = ValidationOptions {
        require_single_component: false,
        ..ValidationOptions::default()
    };
    let problems = match mesh_type {
        "tetrahedral" => match mesh.to_tet_mesh() {
            Ok(t) => {
                info.components = Some(connected_components(t.num_vertices(), &t.tets).count);
                info.volume_mm3 = Some(total_volume(&t));
                if let Ok(b) = tet_boundary(&t) {
                    let s = &b.surface;
                    info.boundary_surface = Some(BoundaryInfo {
                        vertices: s.num_vertices(),
                        triangles: s.num_triangles(),
                        components: connected_components(s.num_vertices(), &s.triangles).count,
                        euler_characteristic: euler_characteristic(s),
                    });
                }
                check_tet_mesh(&t, &opts)
            }
            Err(e) => vec![crate::mesh::validate::Problem { error: e, count: 1 }],
        },
        "surface" => match mesh.to_tri_mesh() {
            Ok(t) => {
                info.components = Some(connected_components(t.num_vertices(), &t.triangles).count);
                info.area_mm2 = Some(total_area(&t));
                info.boundary_loops = boundary_loops(&t)
                    .ok()
                    .map(|ls| ls.iter().map(Vec::len).collect());
                check_tri_mesh(&t, &opts)
            }
            Err(e) => vec![crate::mesh::validate::Problem { error: e, count: 1 }],
        },
        // A file of bare points is valid, a file of nothing is not.
        _ if mesh.num_points() == 0 => vec![crate::mesh::validate::Problem {
            error: MeshError::Empty { what: "vertices" },
            count: 1,
        }],
        _ => Vec::new(),
    };
    info.valid = problems.is_empty();
    info.problems = problems
        .into_iter()
        .map(|p| ProblemInfo {
            kind: p.error.kind(),
            count: p.count,
            first: p.error.to_string(),
        })
        .collect();
    info
}

/// Builds the report of an image from its header and a pass over its values.
pub fn image_info(path: &Path, header: &ImageHeader, values: &ValueSummary) -> ImageInfo {
    let a = &header.affine;
    ImageInfo {
        file: path.display().to_string(),
        kind: "image",
        dims: header.dims,
        spacing_mm: header.spacing(),
        affine: std::array::from_fn(|i| std::array::from_fn(|j| a[(i, j)])),
        affine_source: format!("{:?}", header.affine_source).to_lowercase(),
        datatype: format!("{:?}", header.datatype).to_lowercase(),
        value_range: values.range.map(|(lo, hi)| [lo, hi]),
    }
}

/// Reads an image's header and streams its values once (bounded memory).
fn read_image_info(path: &Path) -> Result<ImageInfo, AppError> {
    let (header, values) = image_value_summary(path)?;
    Ok(image_info(path, &header, &values))
}

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

fn to_json<T: Serialize>(v: &T) -> String {
    // Serializing plain structs of numbers and strings cannot fail.
    let text =
        serde_json::to_string_pretty(v).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
    // serde_json escapes C0 controls; DEL and C1 (U+007F..U+009F, e.g. the
    // 8-bit CSI) can only occur inside strings, where `\u00XX` is the same
    // character: escape them too, so the output is safe on a terminal.
    if !text.chars().any(|c| ('\u{7f}'..='\u{9f}').contains(&c)) {
        return text;
    }
    text.chars()
        .map(|c| {
            if ('\u{7f}'..='\u{9f}').contains(&c) {
                format!("\\u{:04x}", c as u32)
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// The report of `path` as JSON (used by `demo` as well).
pub fn info_json(path: &Path) -> Result<(String, bool), AppError> {
    match FileKind::from_path(path)? {
        FileKind::Nifti { .. } | FileKind::Nrrd { .. } => {
            Ok((to_json(&read_image_info(path)?), true))
        }
        FileKind::Mesh(_) => {
            let i = mesh_info(path, &read_mesh(path)?);
            Ok((to_json(&i), i.valid))
        }
    }
}

/// Runs `unfold info`.
pub fn run(a: &InfoArgs) -> Result<(), AppError> {
    let path = a.file.as_path();
    match FileKind::from_path(path)? {
        FileKind::Nifti { .. } | FileKind::Nrrd { .. } => {
            let i = read_image_info(path)?;
            if a.json {
                println!("{}", to_json(&i));
            } else {
                print_image(&i);
            }
            Ok(())
        }
        FileKind::Mesh(_) => {
            let i = mesh_info(path, &read_mesh(path)?);
            if a.json {
                println!("{}", to_json(&i));
            } else {
                print_mesh(&i);
            }
            match (a.strict, i.problems.first()) {
                (true, Some(p)) => Err(AppError::Invalid {
                    path: i.file.clone(),
                    count: i.problems.len(),
                    first: p.first.clone(),
                }),
                _ => Ok(()),
            }
        }
    }
}
