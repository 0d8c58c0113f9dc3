//! The input checks of the placenta pipeline, and the boundary weights.

use super::error::PlacentaError;
use super::parcellation::Parcellation;
use super::side;
use crate::OrganError;
use unfold_mesh::TetMesh;
use unfold_mesh::repair::{RepairOptions, RepairReport, Weld, repair_tet_mesh_with};

/// The input mesh after [`prepare_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedMesh {
    /// The mesh, every tet positively oriented.
    pub mesh: TetMesh,
    /// Tets whose vertex order was swapped to orient them positively.
    pub reoriented_tets: usize,
    /// What the repair before the checks changed (welded vertices,
    /// duplicate, repeated-vertex and zero-volume tets, unused vertices).
    pub repair: RepairReport,
}

/// Repairs `mesh` ([`repair_tet_mesh_with`]: coincident vertices welded
/// within a millionth of the mean edge, duplicate, repeated-vertex and
/// zero-volume tets and unused vertices dropped; the orientation is left to
/// the next step), refuses it if it is tangled (a folded interior face,
/// [`unfold_mesh::geometry::folded_faces`]: a mirrored mesh has none),
/// orients its tets positively (a repair that is reported, not an error)
/// and checks that it is a usable placenta mesh: it must have tets, finite
/// coordinates, no degenerate tets, one connected component, a manifold
/// boundary, and a boundary that does not meet itself (with every tet
/// positive, the test of a global overlap,
/// [`unfold_mesh::geometry::tet_boundary_self_intersections`]). The
/// vertices are then those of the repaired mesh.
///
/// # Errors
/// [`PlacentaError::NoTetrahedra`] for a mesh without tets (a surface
/// mesh); [`PlacentaError::Tangled`] for folded faces;
/// [`PlacentaError::SelfOverlapping`] for a boundary meeting itself; `Mesh`
/// with the first validation problem otherwise.
pub fn prepare_mesh(mesh: &TetMesh) -> Result<PreparedMesh, OrganError> {
    if mesh.tets.is_empty() {
        return Err(PlacentaError::NoTetrahedra.into());
    }
    unfold_mesh::geometry::check_finite(&mesh.positions)?;
    let options = RepairOptions {
        weld: Weld::Relative,
        keep_tet_orientation: true,
        ..Default::default()
    };
    let (mut m, repair) = repair_tet_mesh_with(mesh, &options)?;
    if m.tets.is_empty() {
        return Err(PlacentaError::NoTetrahedra.into());
    }
    // Folds do not depend on orientation: a mirrored file has none, a
    // tangled one has some whatever its tets' vertex order. Checked after
    // the repair, so a duplicated tet is dropped rather than seen as a fold.
    let folds = unfold_mesh::geometry::folded_faces(&m);
    if let Some(first) = folds.first() {
        return Err(PlacentaError::Tangled {
            folded: folds.len(),
            face: first.face,
            tets: first.tets,
            position: first.position.coords.into(),
        }
        .into());
    }
    let reoriented_tets = m.orient()?;
    m.validate()?;
    // Every tet positive now and no face folded, so the mesh overlaps
    // itself exactly when its boundary meets itself.
    let overlaps = unfold_mesh::geometry::tet_boundary_self_intersections(&m)?;
    if let Some(first) = overlaps.intersections.pairs.first() {
        let tet = |f: usize| overlaps.face_tet[f] as usize;
        return Err(PlacentaError::SelfOverlapping {
            faces: overlaps.intersections.triangles_involved,
            vertices: first.vertices,
            tets: [tet(first.triangles[0]), tet(first.triangles[1])],
            position: first.position.coords.into(),
        }
        .into());
    }
    Ok(PreparedMesh {
        mesh: m,
        reoriented_tets,
        repair,
    })
}

/// Normalized barycentric boundary vertex areas `A_m` (sum 1) over the
/// parcellated boundary (every vertex with a label other than interior),
/// per volume vertex (0 elsewhere).
pub fn boundary_weights(parcellation: &Parcellation) -> Vec<f64> {
    let areas = unfold_mesh::geometry::vertex_areas(&parcellation.boundary.surface);
    let mut w = vec![0.0; parcellation.labels.len()];
    for (&v, a) in parcellation.boundary.to_volume.iter().zip(areas) {
        if parcellation.labels[v as usize] != side::INTERIOR {
            w[v as usize] = a;
        }
    }
    let total: f64 = w.iter().sum();
    if total > 0.0 {
        w.iter_mut().for_each(|x| *x /= total);
    }
    w
}
