//! What `unfold info` reports about a file: a mesh's size, cell types,
//! bounding box, data arrays, topology (components, boundary loops, a tet
//! mesh's boundary surface), area or volume and validity problems; an
//! image's grid, affine, data type and value range. The typed reports
//! ([`MeshInfo`], [`ImageInfo`]) and their JSON (`info --json`, the demo's
//! `info.json`).
//!
//! An image is read header first ([`crate::io::read_image_header`] fields)
//! and its values are streamed once for the range
//! ([`crate::io::image_value_summary`]): memory stays about 1 MiB whatever
//! the image's size, and a `.nii.gz` is never inflated past what its header
//! declares.

use crate::app::AppError;
use crate::app::run::units::{self, OrganSize};
use crate::io::{FileKind, ImageHeader, ValueSummary, image_value_summary, read_mesh};
use crate::mesh::fold_check::{FoldCounts, planar_triangle_folds, tet_folds};
use crate::mesh::geometry::{bounding_box, total_area, total_volume};
use crate::mesh::topology::{
    boundary_loops, connected_components, euler_characteristic, tet_boundary,
};
use crate::mesh::validate::{ValidationOptions, check_tet_mesh, check_tri_mesh};
use crate::mesh::{CellMesh, Field, MeshError};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Summary of one data array.
#[derive(Debug, Serialize)]
pub struct ArrayInfo {
    /// The array's name.
    pub name: String,
    /// Components per point or cell.
    pub components: usize,
    /// The stored value type (`float64`, `int32`, ...).
    #[serde(rename = "type")]
    pub value_type: &'static str,
    /// The smallest finite value (none: no finite value).
    pub min: Option<f64>,
    /// The largest finite value (none: no finite value).
    pub max: Option<f64>,
}

/// One kind of validity problem.
#[derive(Debug, Serialize)]
pub struct ProblemInfo {
    /// The problem's kind ([`MeshError::kind`]).
    pub kind: &'static str,
    /// How many times it occurs.
    pub count: usize,
    /// The first occurrence, as a message.
    pub first: String,
}

/// The boundary surface of a tet mesh.
#[derive(Debug, Serialize)]
pub struct BoundaryInfo {
    /// Vertices of the boundary surface.
    pub vertices: usize,
    /// Its triangles.
    pub triangles: usize,
    /// Its connected components.
    pub components: usize,
    /// Its Euler characteristic `V - E + F`.
    pub euler_characteristic: i64,
}

/// What `info` reports about a mesh.
#[derive(Debug, Serialize)]
pub struct MeshInfo {
    /// The file, as given.
    pub file: String,
    /// `mesh`.
    pub kind: &'static str,
    /// `tetrahedral`, `surface`, `lines`, `points` or `mixed`.
    pub mesh_type: &'static str,
    /// Number of points.
    pub points: usize,
    /// Number of cells.
    pub cells: usize,
    /// Cells per cell type.
    pub cell_types: BTreeMap<String, usize>,
    /// `[min, max]` corners of the points' bounding box (none: no points).
    pub bounding_box: Option<[[f64; 3]; 2]>,
    /// When the mesh is smaller than any organ (coordinates read as mm):
    /// [`crate::app::run::units::note`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub units_note: Option<String>,
    /// The point data arrays.
    pub point_arrays: Vec<ArrayInfo>,
    /// The cell data arrays.
    pub cell_arrays: Vec<ArrayInfo>,
    /// Connected components (tet and surface meshes).
    pub components: Option<usize>,
    /// Vertices of each boundary loop (surface meshes).
    pub boundary_loops: Option<Vec<usize>>,
    /// The boundary surface (tet meshes).
    pub boundary_surface: Option<BoundaryInfo>,
    /// Total area, mm^2 (surface meshes).
    pub area_mm2: Option<f64>,
    /// Total volume, mm^3 (tet meshes).
    pub volume_mm3: Option<f64>,
    /// Inverted and folded elements ([`crate::mesh::fold_check`]): of a tet
    /// mesh, or of a surface whose points lie in one plane (none for a
    /// surface curved in space). Each one found is also a problem.
    pub folds: Option<FoldCounts>,
    /// Whether no validity problem was found.
    pub valid: bool,
    /// The validity problems, one per kind.
    pub problems: Vec<ProblemInfo>,
}

/// What `info` reports about an image.
#[derive(Debug, Serialize)]
pub struct ImageInfo {
    /// The file, as given.
    pub file: String,
    /// `image`.
    pub kind: &'static str,
    /// Voxels along i, j, k and frames.
    pub dims: [usize; 4],
    /// Voxel spacing, mm.
    pub spacing_mm: [f64; 3],
    /// The voxel-to-world (RAS) affine, rows.
    pub affine: [[f64; 4]; 4],
    /// Where the affine came from (`sform`, `qform`, ...).
    pub affine_source: String,
    /// The stored data type, lower case.
    pub datatype: String,
    /// `[min, max]` of the finite values (none: no finite value).
    pub value_range: Option<[f64; 2]>,
}

/// What `info` reports about a file: a mesh or an image.
#[derive(Debug)]
pub enum Info {
    /// A mesh file.
    Mesh(MeshInfo),
    /// An image file.
    Image(ImageInfo),
}

impl MeshInfo {
    /// `info --strict`: an error naming the first validity problem, if
    /// any.
    ///
    /// # Errors
    /// [`AppError::Invalid`] when the mesh has validity problems.
    pub fn strict(&self) -> Result<(), AppError> {
        match self.problems.first() {
            Some(p) => Err(AppError::Invalid {
                path: self.file.clone(),
                count: self.problems.len(),
                first: p.first.clone(),
            }),
            None => Ok(()),
        }
    }
}

/// The summary of one data array: its finite values' range.
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
        units_note: OrganSize::ANY.too_small(&mesh.positions).map(|side| {
            let file = path.display().to_string();
            let unit = OrganSize::ANY.likely_unit(side);
            units::note(&file, side, unit, &units::convert_fix(&file, unit))
        }),
        point_arrays: mesh.point_data.iter().map(array_info).collect(),
        cell_arrays: mesh.cell_data.iter().map(array_info).collect(),
        components: None,
        boundary_loops: None,
        boundary_surface: None,
        area_mm2: None,
        volume_mm3: None,
        folds: None,
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
                let mut problems = check_tet_mesh(&t, &opts);
                let (folds, folded) = tet_folds(&t);
                info.folds = Some(folds);
                problems.extend(folded);
                problems
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
                let mut problems = check_tri_mesh(&t, &opts);
                if let Some((folds, folded)) = planar_triangle_folds(&t) {
                    info.folds = Some(folds);
                    problems.extend(folded);
                }
                problems
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
///
/// # Errors
/// Reading the image.
pub fn read_image_info(path: &Path) -> Result<ImageInfo, AppError> {
    let (header, values) = image_value_summary(path)?;
    Ok(image_info(path, &header, &values))
}

/// The report of the file at `path`, a mesh or an image by its
/// extension.
///
/// # Errors
/// An unknown extension, reading the file.
pub fn info(path: &Path) -> Result<Info, AppError> {
    match FileKind::from_path(path)? {
        FileKind::Nifti { .. } | FileKind::Nrrd { .. } => Ok(Info::Image(read_image_info(path)?)),
        FileKind::Mesh(_) => Ok(Info::Mesh(mesh_info(path, &read_mesh(path)?))),
    }
}

/// `v` as indented JSON, safe on a terminal: besides the C0 controls
/// `serde_json` escapes, DEL and the C1 controls (U+007F..U+009F) inside
/// strings are written `\u00XX`.
pub fn to_json<T: Serialize>(v: &T) -> String {
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

/// The report of `path` as JSON ([`to_json`]) and whether the file is
/// valid (an image always is): `info --json`'s text and the demo's
/// `info.json` entries.
///
/// # Errors
/// [`info`]'s.
pub fn info_json(path: &Path) -> Result<(String, bool), AppError> {
    match info(path)? {
        Info::Image(i) => Ok((to_json(&i), true)),
        Info::Mesh(i) => Ok((to_json(&i), i.valid)),
    }
}
