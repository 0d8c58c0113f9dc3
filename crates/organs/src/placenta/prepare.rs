//! The input checks of the placenta pipeline, and the boundary weights.

use super::error::PlacentaError;
use super::parcellation::Parcellation;
use super::side;
use crate::OrganError;
use unfold_mesh::TetMesh;

/// The input mesh after [`prepare_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedMesh {
    /// The mesh, every tet positively oriented.
    pub mesh: TetMesh,
    /// Tets whose vertex order was swapped to orient them positively.
    pub reoriented_tets: usize,
}

/// Checks that `mesh` is a usable placenta mesh and orients its tets
/// positively (a repair that is reported, not an error): it must have tets,
/// finite coordinates, no folded interior face
/// ([`unfold_mesh::geometry::folded_faces`]: a tangled mesh is refused, a
/// mirrored one is not), no degenerate tets, one connected component, a
/// manifold boundary and no unused vertices.
///
/// # Errors
/// [`PlacentaError::NoTetrahedra`] for a mesh without tets (a surface
/// mesh); [`PlacentaError::Tangled`] for folded faces; `Mesh` with the
/// first validation problem otherwise.
pub fn prepare_mesh(mesh: &TetMesh) -> Result<PreparedMesh, OrganError> {
    if mesh.tets.is_empty() {
        return Err(PlacentaError::NoTetrahedra.into());
    }
    unfold_mesh::geometry::check_finite(&mesh.positions)?;
    // Folds do not depend on orientation: a mirrored file has none, a
    // tangled one has some whatever its tets' vertex order.
    let folds = unfold_mesh::geometry::folded_faces(mesh);
    if let Some(first) = folds.first() {
        return Err(PlacentaError::Tangled {
            folded: folds.len(),
            face: first.face,
            tets: first.tets,
            position: first.position.coords.into(),
        }
        .into());
    }
    let mut m = mesh.clone();
    let reoriented_tets = m.orient()?;
    m.validate()?;
    Ok(PreparedMesh {
        mesh: m,
        reoriented_tets,
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
