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

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::nalgebra::Point3;
    use unfold_mesh::shapes::kuhn_grid;

    /// A slab of `n` x 2 x 3 cells of 1.5 mm wound round the z axis
    /// through `turns` turns at radius 30 mm, climbing and moving in
    /// 0.5 mm per turn.
    fn wound_slab(n: usize, turns: f64) -> TetMesh {
        let mut m = kuhn_grid([n, 2, 3], [1.5; 3]);
        let len = 1.5 * n as f64;
        for p in &mut m.positions {
            let f = turns * p.x / len;
            let th = 2.0 * std::f64::consts::PI * f;
            let r = 30.0 - p.y - 0.5 * f;
            *p = Point3::new(r * th.cos(), r * th.sin(), p.z + 0.5 * f);
        }
        m
    }

    /// An open ring is prepared; a ring whose ends pass through each other
    /// (no tet inverted, no face folded) is refused, naming two boundary
    /// faces of the tets it names, near the point it names.
    #[test]
    fn a_boundary_meeting_itself_is_refused() {
        let open = wound_slab(120, 0.8);
        let prepared = prepare_mesh(&open).expect("an open ring is a valid domain");
        assert_eq!(prepared.reoriented_tets, 0);
        let wound = wound_slab(150, 1.25);
        match prepare_mesh(&wound) {
            Err(OrganError::Placenta(PlacentaError::SelfOverlapping {
                faces,
                vertices,
                tets,
                position,
            })) => {
                assert!(faces >= 2, "{faces}");
                assert_ne!(tets[0], tets[1]);
                let p = Point3::from(position);
                for k in 0..2 {
                    let tet = wound.tets[tets[k]];
                    for &v in &vertices[k] {
                        assert!(tet.contains(&v), "face {:?} of tet {tet:?}", vertices[k]);
                        assert!((wound.positions[v as usize] - p).norm() < 5.0);
                    }
                }
                // the two faces lie about a full turn (150 / 1.25 = 120
                // cells) apart along the slab: vertex i + 151 (j + 3 k) is
                // in column i
                let column = |k: usize| vertices[k][0] % 151;
                let gap = column(0).abs_diff(column(1));
                assert!((115..=125).contains(&gap), "{vertices:?}");
            }
            other => panic!("expected SelfOverlapping, got {other:?}"),
        }
    }
}
