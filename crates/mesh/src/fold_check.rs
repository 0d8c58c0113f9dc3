//! A mesh's inverted and folded elements, counted and as validation
//! problems: what `unfold info` and `unfold repair` show so that a tangled
//! mesh never passes as valid.
//!
//! - **Tet meshes.** Inverted: signed volume `(b-a)·((c-a)×(d-a))/6 < 0`.
//!   Folded: interior faces whose two tets lie on the same side of them
//!   ([`crate::geometry::folded_faces`]). The fold test does not depend on
//!   the tets' vertex order: a mirrored mesh (every tet negative) has no
//!   fold, and a folded one keeps its folds after every tet is turned
//!   positive, which is why re-orienting cannot repair it.
//! - **Planar triangle meshes** (every point in one plane,
//!   [`crate::geometry::plane_coordinates`]), in the plane's coordinates:
//!   inverted triangles are those of the minority orientation,
//!   `min(P, N)` of [`crate::geometry::Orientations`] (degenerate ones are
//!   validation's), folded edges as for [`crate::geometry::folded_edges`].
//!   A surface curved in space has no orientation to judge against and is
//!   not checked (`None`).

use crate::geometry::{
    Orientations, PLANAR_REL_TOL, folded_edges, folded_faces, majority_sign, plane_coordinates,
    tet_signed_volume, twice_signed_areas_2d,
};
use crate::validate::Problem;
use crate::{MeshError, TetMesh, TriMesh};
use serde::{Deserialize, Serialize};

/// Inverted and folded elements of a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FoldCounts {
    /// Inverted elements: negative tets; triangles of a planar mesh turned
    /// against the majority.
    pub inverted: usize,
    /// Folded interior faces (tets) or edges (planar triangles).
    pub folded: usize,
}

impl FoldCounts {
    /// Whether the mesh is neither inverted anywhere nor folded.
    pub fn is_clean(&self) -> bool {
        self.inverted == 0 && self.folded == 0
    }
}

/// The folds of a tet mesh and, when it has any, a
/// [`MeshError::FoldedFace`] problem (the first folded face, in ascending
/// face order, and how many). Inverted tets are counted but not returned as
/// a problem: [`crate::validate::check_tet_mesh`] reports them. Tets with
/// an out-of-range index are left to validation.
pub fn tet_folds(mesh: &TetMesh) -> (FoldCounts, Vec<Problem>) {
    let n = mesh.positions.len();
    let inverted = mesh
        .tets
        .iter()
        .filter(|t| t.iter().all(|&v| (v as usize) < n))
        .filter(|t| {
            let [a, b, c, d] = t.map(|v| mesh.positions[v as usize]);
            tet_signed_volume(&a, &b, &c, &d) < 0.0
        })
        .count();
    let folded = folded_faces(mesh);
    let problems = folded
        .first()
        .map(|f| Problem {
            error: MeshError::FoldedFace {
                face: f.face,
                tets: f.tets,
            },
            count: folded.len(),
        })
        .into_iter()
        .collect();
    (
        FoldCounts {
            inverted,
            folded: folded.len(),
        },
        problems,
    )
}

/// The folds of a planar triangle mesh (module doc) and its problems,
/// [`MeshError::InvertedTriangle`] (the first minority triangle) and
/// [`MeshError::FoldedEdge`] (the first folded edge), each with its count;
/// `None` when the mesh's points do not lie in one plane. Triangles with an
/// out-of-range index are left to validation.
pub fn planar_triangle_folds(mesh: &TriMesh) -> Option<(FoldCounts, Vec<Problem>)> {
    let uv = plane_coordinates(&mesh.positions, PLANAR_REL_TOL)?;
    let n = uv.len();
    let (index, triangles): (Vec<usize>, Vec<[u32; 3]>) = mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.iter().all(|&v| (v as usize) < n))
        .map(|(i, t)| (i, *t))
        .unzip();
    let areas = twice_signed_areas_2d(&uv, &triangles);
    let sign = majority_sign(&areas);
    let counts = Orientations::count(&areas);
    let minority: Vec<usize> = areas
        .iter()
        .enumerate()
        .filter(|&(_, &s)| sign * s < 0.0)
        .map(|(t, _)| t)
        .collect();
    debug_assert_eq!(minority.len(), counts.positive.min(counts.negative));
    let folded = folded_edges(&uv, &triangles);
    let mut problems = Vec::new();
    if let Some(&t) = minority.first() {
        problems.push(Problem {
            error: MeshError::InvertedTriangle {
                element: index[t],
                area: 0.5 * areas[t] * sign,
            },
            count: minority.len(),
        });
    }
    if let Some(f) = folded.first() {
        problems.push(Problem {
            error: MeshError::FoldedEdge {
                edge: f.edge,
                triangles: f.triangles.map(|t| index[t]),
            },
            count: folded.len(),
        });
    }
    Some((
        FoldCounts {
            inverted: minority.len(),
            folded: folded.len(),
        },
        problems,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::kuhn_grid;
    use nalgebra::{Point3, Rotation3, Vector3};
    use proptest::prelude::*;

    /// A `w x h` grid of unit squares in the plane z = 0, two
    /// counter-clockwise triangles each.
    fn grid(w: u32, h: u32) -> TriMesh {
        let mut p = Vec::new();
        for j in 0..=h {
            for i in 0..=w {
                p.push(Point3::new(i as f64, j as f64, 0.0));
            }
        }
        let mut t = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let a = i + (w + 1) * j;
                t.push([a, a + 1, a + w + 2]);
                t.push([a, a + w + 2, a + w + 1]);
            }
        }
        TriMesh::new(p, t)
    }

    #[test]
    fn a_clean_planar_grid_has_no_fold_and_a_curved_surface_is_not_judged() {
        let (c, problems) = planar_triangle_folds(&grid(4, 3)).unwrap();
        assert!(c.is_clean() && problems.is_empty());
        let mut bent = grid(4, 3);
        bent.positions[6].z = 0.5;
        assert!(planar_triangle_folds(&bent).is_none());
    }

    #[test]
    fn a_vertex_dragged_across_its_neighbour_folds_the_planar_grid() {
        let mut m = grid(4, 4);
        // interior vertex (2, 2) = 12 past (3, 2) = 13
        m.positions[12].x = 3.6;
        let (c, problems) = planar_triangle_folds(&m).unwrap();
        assert!(c.inverted > 0 && c.folded > 0, "{c:?}");
        let kinds: Vec<_> = problems.iter().map(|p| p.error.kind()).collect();
        assert_eq!(kinds, ["inverted_triangle", "folded_edge"]);
        assert!(
            problems[1]
                .error
                .to_string()
                .contains("re-mesh or untangle")
        );
    }

    #[test]
    fn a_folded_tet_mesh_keeps_its_folds_after_orient() {
        let mut m = kuhn_grid([3, 3, 3], [1.0; 3]);
        let id = |i: usize, j: usize, k: usize| i + 4 * (j + 4 * k);
        m.positions[id(1, 1, 1)].x = 2.6;
        let (before, problems) = tet_folds(&m);
        assert!(before.inverted > 0 && before.folded > 0, "{before:?}");
        assert_eq!(problems[0].error.kind(), "folded_face");
        let flipped = m.orient().unwrap();
        assert_eq!(flipped, before.inverted);
        let (after, _) = tet_folds(&m);
        assert_eq!(after.inverted, 0);
        assert!(after.folded > 0, "orient hides no fold: {after:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// Moved rigidly or mirrored, a valid mesh has no fold and counts
        /// its inverted elements honestly (all of a mirrored tet mesh; none
        /// of a mirrored planar map, whose orientation is judged against
        /// its own majority).
        #[test]
        fn rigid_motions_and_mirrors_fold_nothing(
            mirror in any::<bool>(),
            axis in prop::array::uniform3(-1.0f64..1.0),
            angle in 0.0f64..3.0,
            shift in prop::array::uniform3(-50.0f64..50.0),
        ) {
            let r = Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(Vector3::from(axis) + Vector3::new(1e-3, 0.0, 0.0)),
                angle,
            );
            let place = |p: &Point3<f64>| {
                let x = if mirror { -p.x } else { p.x };
                Point3::from(r * Vector3::new(x, p.y, p.z) + Vector3::from(shift))
            };
            let mut tets = kuhn_grid([2, 2, 2], [1.0; 3]);
            tets.positions = tets.positions.iter().map(place).collect();
            let (c, problems) = tet_folds(&tets);
            prop_assert_eq!(c.folded, 0);
            prop_assert!(problems.is_empty());
            prop_assert_eq!(c.inverted, if mirror { tets.tets.len() } else { 0 });
            let mut tris = grid(3, 2);
            tris.positions = tris.positions.iter().map(place).collect();
            let (c, problems) = planar_triangle_folds(&tris).expect("still planar");
            prop_assert!(c.is_clean() && problems.is_empty());
        }
    }
}
