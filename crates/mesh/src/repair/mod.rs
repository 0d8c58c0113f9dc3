//! Repair of triangle and tet meshes as other tools export them, one step
//! per file, run in this order:
//!
//! 1. **weld** ([`crate::weld`]) coincident vertices, when asked
//!    ([`Weld`]): a triangle soup becomes a connected surface;
//! 2. **degenerate** ([`degenerate`]): drop elements that use a vertex
//!    twice; collapse zero-area triangles (slivers, so no hole is left where
//!    a needle sat between two good triangles) / drop zero-volume tets;
//! 3. **duplicates** ([`duplicates`]): drop elements with the vertex set of
//!    an earlier one, in either orientation;
//! 4. **non-manifold edges** ([`non_manifold`], triangles): drop fins, the
//!    extra triangles or patches glued along an edge that the largest sheet
//!    already uses twice;
//! 5. **orient** ([`orient`]): triangle patches consistent and closed ones
//!    outward (a non-orientable surface is the one refusal:
//!    [`MeshError::NonOrientable`], with vertex ids and coordinates); tets
//!    positive unless [`RepairOptions::keep_tet_orientation`];
//! 6. **holes** ([`holes`], triangles, when asked): close boundary loops of
//!    small perimeter, before the fans are split, so a hole that touches
//!    another or the rim at one vertex is closed there instead of cut
//!    apart; the filling never makes an edge of more than two triangles;
//! 7. **non-manifold vertices** ([`non_manifold`], triangles): one copy of a
//!    vertex per fan of triangles around it;
//! 8. **unreferenced vertices**: drop the vertices no element uses
//!    ([`compact_vertices`]).
//!
//! Every step only renumbers, merges, drops or copies vertices, so each
//! output vertex has the position and point data of one input vertex, and
//! each output element the cell data of one input element (a hole-filling
//! triangle: that of the triangle along the hole's first edge). Vertex
//! numbering changes when anything is merged, split or dropped.
//!
//! Also here: [`TetMesh::orient`] and `largest_component` of both mesh
//! types ([`component`]).

/// Kept here for the `repair::compact_vertices` path; the code lives in
/// [`crate::reindex`].
pub use crate::reindex::{Compacted, compact_vertices};
pub use degenerate::{DEGENERATE_RELATIVE, SINGLE_PRECISION};
pub use report::RepairReport;

pub mod component;
pub mod degenerate;
pub mod duplicates;
pub mod holes;
pub mod non_manifold;
pub mod orient;
pub mod report;
mod work;

use crate::{
    Fields, MeshError, TetMesh, TriMesh,
    geometry::{check_finite, check_indices},
    topology::connected_components,
};
use nalgebra::Point3;
use work::Work;

/// How a repair welds coincident vertices ([`crate::weld`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Weld {
    /// No welding ([`repair_tri_mesh`] and [`repair_tet_mesh`]).
    #[default]
    Off,
    /// Within [`crate::weld::default_tolerance`]: a millionth of the mean
    /// edge length, and at most a quarter of the shortest edge. Should a
    /// chain of close vertices still reach from one corner of an element to
    /// another at a different position, only exact copies are welded.
    Relative,
    /// Within this distance, mm (0: exactly equal positions only).
    Within(f64),
}

/// Settings of [`repair_tri_mesh_with`] and [`repair_tet_mesh_with`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RepairOptions {
    /// Welding of coincident vertices, before anything else.
    pub weld: Weld,
    /// Close the boundary loops whose perimeter is at most this, mm
    /// (triangle meshes; `None`: no hole is filled).
    pub fill_holes: Option<f64>,
    /// With [`RepairOptions::fill_holes`]: close only the loops whose
    /// perimeter is also at most this fraction of the longest loop's, and
    /// never the longest (a sheet's rim).
    pub fill_holes_fraction: Option<f64>,
    /// Leave the tets' orientation alone (a pipeline that orients and
    /// reports it itself).
    pub keep_tet_orientation: bool,
}

/// Checks indices, coordinates and field lengths before a repair.
fn check_input<const K: usize>(
    positions: &[Point3<f64>],
    elements: &[[u32; K]],
    point_data: &Fields,
    cell_data: &Fields,
) -> Result<(), MeshError> {
    check_indices(positions.len(), elements)?;
    check_finite(positions)?;
    point_data.check_tuples(positions.len())?;
    cell_data.check_tuples(elements.len())
}

/// Step 1: welds `w` as `weld` says; returns the vertices merged away.
fn weld_step<const K: usize>(w: &mut Work<K>, weld: Weld) -> Result<usize, MeshError> {
    let tolerance = match weld {
        Weld::Off => return Ok(0),
        Weld::Relative => crate::weld::default_tolerance(&w.positions, &w.elements),
        Weld::Within(t) => t,
    };
    let mut welded = crate::weld::weld(&w.positions, tolerance)?;
    if weld == Weld::Relative && merges_an_edge(w, &welded.new_of) {
        // A chain of close vertices reached across an element: weld exact
        // copies only.
        welded = crate::weld::weld(&w.positions, 0.0)?;
    }
    let root: Vec<usize> = welded
        .new_of
        .iter()
        .map(|&k| welded.kept[k as usize])
        .collect();
    Ok(w.merge(&root))
}

/// True when welding as `new_of` says would merge two corners of one
/// element that are at different positions.
fn merges_an_edge<const K: usize>(w: &Work<K>, new_of: &[u32]) -> bool {
    w.elements.iter().any(|el| {
        (0..K).any(|i| {
            (i + 1..K).any(|j| {
                let (a, b) = (el[i] as usize, el[j] as usize);
                new_of[a] == new_of[b] && w.positions[a] != w.positions[b]
            })
        })
    })
}

/// Repairs a triangle mesh without welding: [`repair_tri_mesh_with`] with
/// the default [`RepairOptions`].
///
/// # Errors
/// As [`repair_tri_mesh_with`].
pub fn repair_tri_mesh(mesh: &TriMesh) -> Result<(TriMesh, RepairReport), MeshError> {
    repair_tri_mesh_with(mesh, &RepairOptions::default())
}

/// Repairs a triangle mesh: the steps of the [module docs](self), in that
/// order. `flipped` counts the triangles whose orientation the orient step
/// reversed; `components` is the number of vertex-connected components of
/// the result. A clean mesh (manifold, consistently oriented and, where
/// closed, outward, every vertex used, nothing to weld) comes back
/// unchanged.
///
/// # Errors
/// [`MeshError::IndexOutOfRange`], [`MeshError::NonFiniteCoordinate`],
/// [`MeshError::FieldLength`] when a field does not match its mesh,
/// [`MeshError::WeldTolerance`] for a bad distance, and
/// [`MeshError::NonOrientable`] for a surface no flipping makes consistent.
pub fn repair_tri_mesh_with(
    mesh: &TriMesh,
    options: &RepairOptions,
) -> Result<(TriMesh, RepairReport), MeshError> {
    repair_tri_mesh_traced(mesh, options).map(|t| (t.mesh, t.report))
}

/// A repaired mesh, what changed, and where each input vertex went.
#[derive(Debug, Clone, PartialEq)]
pub struct Traced<M> {
    /// The repaired mesh.
    pub mesh: M,
    /// What changed.
    pub report: RepairReport,
    /// `vertex_of_input[i]`: the repaired vertex input vertex `i` became
    /// (welded copies all point to the same one; `None` when it was dropped
    /// as unused; the first copy when it was split).
    pub vertex_of_input: Vec<Option<u32>>,
}

/// [`repair_tri_mesh_with`], also telling where each input vertex went
/// (for data indexed by the input's vertices, e.g. targets).
///
/// # Errors
/// As [`repair_tri_mesh_with`].
pub fn repair_tri_mesh_traced(
    mesh: &TriMesh,
    options: &RepairOptions,
) -> Result<Traced<TriMesh>, MeshError> {
    check_input(
        &mesh.positions,
        &mesh.triangles,
        &mesh.point_data,
        &mesh.cell_data,
    )?;
    let mut w = Work::new(&mesh.positions, &mesh.triangles);
    let mut r = RepairReport {
        welded_vertices: weld_step(&mut w, options.weld)?,
        repeated_vertex_elements: degenerate::drop_repeated(&mut w),
        ..Default::default()
    };
    let c = degenerate::collapse_slivers(&mut w);
    r.degenerate_elements = c.triangles;
    r.collapsed_vertices = c.vertices;
    r.duplicate_elements = duplicates::drop_duplicates(&mut w);
    r.fin_triangles = non_manifold::drop_fins(&mut w);
    r.flipped = orient::orient_triangles(&mut w).map_err(|t| {
        let v = t.edge.map(|v| w.origin[v as usize]);
        MeshError::NonOrientable {
            triangles: [w.rows[t.t], w.rows[t.u]],
            vertices: v,
            at: v.map(|v| {
                let p = mesh.positions[v];
                [p.x, p.y, p.z]
            }),
        }
    })?;
    if let Some(d) = options.fill_holes {
        let f = holes::fill_holes(&mut w, d, options.fill_holes_fraction);
        r.holes_filled = f.holes;
        r.hole_triangles = f.triangles;
        r.holes_left_open = f.left_open;
    }
    r.non_manifold_vertices_split = non_manifold::split_fans(&mut w);
    r.unused_vertices = w.drop_unreferenced();
    r.components = connected_components(w.positions.len(), &w.elements).count;
    let (point_data, cell_data) = w.fields(&mesh.point_data, &mesh.cell_data);
    Ok(Traced {
        vertex_of_input: w.vertex_of_input(),
        mesh: TriMesh {
            positions: w.positions,
            triangles: w.elements,
            point_data,
            cell_data,
        },
        report: r,
    })
}

/// Repairs a tet mesh without welding: [`repair_tet_mesh_with`] with the
/// default [`RepairOptions`].
///
/// # Errors
/// As [`repair_tet_mesh_with`].
pub fn repair_tet_mesh(mesh: &TetMesh) -> Result<(TetMesh, RepairReport), MeshError> {
    repair_tet_mesh_with(mesh, &RepairOptions::default())
}

/// Repairs a tet mesh: weld (as `options.weld` says), drop tets that use a
/// vertex twice and zero-volume tets ([`degenerate`]), drop duplicate tets
/// (same vertex set; the first is kept), drop unused vertices (point data
/// and the kept tets' cell data are carried over), then make every tet
/// positive ([`TetMesh::orient`]) unless
/// [`RepairOptions::keep_tet_orientation`]. Folded tets are not otherwise
/// changed.
///
/// # Errors
/// [`MeshError::IndexOutOfRange`], [`MeshError::NonFiniteCoordinate`],
/// [`MeshError::FieldLength`] when a field does not match its mesh and
/// [`MeshError::WeldTolerance`] for a bad distance.
pub fn repair_tet_mesh_with(
    mesh: &TetMesh,
    options: &RepairOptions,
) -> Result<(TetMesh, RepairReport), MeshError> {
    repair_tet_mesh_traced(mesh, options).map(|t| (t.mesh, t.report))
}

/// [`repair_tet_mesh_with`], also telling where each input vertex went.
///
/// # Errors
/// As [`repair_tet_mesh_with`].
pub fn repair_tet_mesh_traced(
    mesh: &TetMesh,
    options: &RepairOptions,
) -> Result<Traced<TetMesh>, MeshError> {
    check_input(
        &mesh.positions,
        &mesh.tets,
        &mesh.point_data,
        &mesh.cell_data,
    )?;
    let mut w = Work::new(&mesh.positions, &mesh.tets);
    let mut r = RepairReport {
        welded_vertices: weld_step(&mut w, options.weld)?,
        repeated_vertex_elements: degenerate::drop_repeated(&mut w),
        ..Default::default()
    };
    r.degenerate_elements = degenerate::drop_flat_tets(&mut w);
    r.duplicate_elements = duplicates::drop_duplicates(&mut w);
    r.unused_vertices = w.drop_unreferenced();
    let (point_data, cell_data) = w.fields(&mesh.point_data, &mesh.cell_data);
    let vertex_of_input = w.vertex_of_input();
    let mut out = TetMesh {
        positions: w.positions,
        tets: w.elements,
        point_data,
        cell_data,
    };
    if !options.keep_tet_orientation {
        r.flipped = out.orient()?;
    }
    r.components = connected_components(out.positions.len(), &out.tets).count;
    Ok(Traced {
        mesh: out,
        report: r,
        vertex_of_input,
    })
}

#[cfg(test)]
mod tests;
