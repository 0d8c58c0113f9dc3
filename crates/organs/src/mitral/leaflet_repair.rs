//! The leaflets as they come, repaired before the contract checks them:
//! coincident vertices welded, duplicate and degenerate triangles dropped,
//! one orientation, and holes closed. A leaflet exported from a
//! segmentation often has a hole where it was thin; the rim is its longest
//! boundary loop, and any other loop up to [`LEAFLET_HOLE_FRACTION`] of the
//! rim's perimeter is closed by the repair's hole filling (ear clipping over
//! the loop's own vertices, [`unfold_mesh::repair::holes`]). Holes that
//! touch each other or the rim at one vertex are split there and each
//! closed; the filling never makes an edge of more than two triangles (a
//! hole that cannot be closed so is left open and counted,
//! `holes_left_open`). A longer second loop is not taken for a hole: the
//! contract refuses the leaflet as not a disk. `report.json`'s
//! `repair` counts what was done (`holes_filled`, `hole_triangles`).

use super::{ANTERIOR, LeafletRepairs, LeafletSide, POSTERIOR};
use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_mesh::repair::{RepairOptions, Weld, repair_tri_mesh_with};

/// A leaflet's boundary loops other than its rim (the longest) are closed
/// when each loop's perimeter is at most this fraction of the rim's.
pub const LEAFLET_HOLE_FRACTION: f64 = 0.25;

/// Both leaflets repaired ([`repair_tri_mesh_with`], coincident vertices
/// welded, holes closed: [`LEAFLET_HOLE_FRACTION`]), with what changed.
///
/// # Errors
/// [`super::ContractError::LeafletMesh`] naming the leaflet when it cannot
/// be repaired (out-of-range indices, non-finite coordinates, a
/// non-orientable surface).
pub fn repair_leaflets(
    anterior: &TriMesh,
    posterior: &TriMesh,
) -> Result<([TriMesh; 2], LeafletRepairs), OrganError> {
    let options = RepairOptions {
        weld: Weld::Relative,
        fill_holes: Some(f64::INFINITY),
        fill_holes_fraction: Some(LEAFLET_HOLE_FRACTION),
        ..Default::default()
    };
    let one = |k: usize, mesh: &TriMesh| {
        repair_tri_mesh_with(mesh, &options).map_err(|source| {
            OrganError::from(super::ContractError::LeafletMesh {
                leaflet: LeafletSide::of(k),
                source,
            })
        })
    };
    // the two leaflets are independent: repaired in parallel
    let (a, p) = rayon::join(|| one(ANTERIOR, anterior), || one(POSTERIOR, posterior));
    let ((a, ra), (p, rp)) = (a?, p?);
    Ok((
        [a, p],
        LeafletRepairs {
            anterior: ra,
            posterior: rp,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use unfold_mesh::shapes::{ValveParams, mitral_valve};

    /// The default valve's anterior leaflet without the triangles around
    /// each of `centres` (column, row; interior vertices whose neighbours
    /// are interior too: columns from 2, rows 2 to 14), compacted: one hole
    /// each.
    fn holed(centres: &[(usize, usize)]) -> (TriMesh, TriMesh) {
        let v = mitral_valve(&ValveParams::default()).unwrap();
        let drop: Vec<u32> = centres
            .iter()
            .map(|&(c, r)| v.anterior_longitudes[c][r])
            .collect();
        let mut m = v.anterior.clone();
        m.triangles.retain(|t| !t.iter().any(|x| drop.contains(x)));
        let c = unfold_mesh::reindex::compact_vertices(&m.positions, &m.point_data, &m.triangles)
            .unwrap();
        (v.anterior, TriMesh::new(c.positions, c.elements))
    }

    #[test]
    fn a_clean_leaflet_is_left_as_it_is() {
        let v = mitral_valve(&ValveParams::default()).unwrap();
        let ([a, p], r) = repair_leaflets(&v.anterior, &v.posterior).unwrap();
        assert_eq!(a.triangles, v.anterior.triangles);
        assert_eq!(p.triangles, v.posterior.triangles);
        assert!(r.anterior.is_clean() && r.posterior.is_clean());
    }

    #[test]
    fn a_frame_around_a_large_opening_is_not_closed() {
        // every interior vertex's star removed: a frame two rows wide, its
        // inner loop far longer than a quarter of the rim
        let v = mitral_valve(&ValveParams::default()).unwrap();
        let (cols, rows) = (v.anterior_longitudes.len(), v.anterior_longitudes[0].len());
        let centres: Vec<(usize, usize)> = (2..cols - 2)
            .flat_map(|c| (2..rows - 2).map(move |r| (c, r)))
            .collect();
        let (clean, frame) = holed(&centres);
        assert_eq!(
            unfold_mesh::topology::boundary_loops(&frame).unwrap().len(),
            2
        );
        let ([a, _], r) = repair_leaflets(&frame, &clean).unwrap();
        assert_eq!(r.anterior.holes_filled, 0);
        assert_eq!(a.triangles.len(), frame.triangles.len());
    }

    /// Two holes that touch at a vertex (the stars of two vertices one
    /// apart on a row) and a third next to them: closed, the leaflet a
    /// disk again over the same vertices, no edge of more than two
    /// triangles (the hole filling once made edges of four).
    #[test]
    fn holes_touching_at_a_vertex_are_closed_into_a_disk() {
        for centres in [
            &[(4, 3), (6, 3)][..],
            &[(4, 3), (6, 3), (5, 5)],
            &[(3, 2), (4, 4)],
        ] {
            let (clean, leaflet) = holed(centres);
            let ([a, _], r) = repair_leaflets(&leaflet, &clean).unwrap();
            assert_eq!(r.anterior.holes_left_open, 0, "{centres:?}");
            assert_eq!(r.anterior.non_manifold_vertices_split, 0, "{centres:?}");
            assert_eq!(a.positions, leaflet.positions, "{centres:?}");
            unfold_mesh::topology::disk_boundary_loop(&a).unwrap();
            let mut count = std::collections::HashMap::<(u32, u32), usize>::new();
            for t in &a.triangles {
                for i in 0..3 {
                    let (x, y) = (t[i], t[(i + 1) % 3]);
                    *count.entry((x.min(y), x.max(y))).or_default() += 1;
                }
            }
            assert!(count.values().all(|&c| c <= 2), "{centres:?}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// One or two holes around interior vertices are closed: one loop
        /// left, the vertices kept, the counts reported (a hole of `n`
        /// vertices takes `n - 2` triangles).
        #[test]
        fn holes_are_closed_and_counted(
            c0 in 2usize..8, r0 in 2usize..5, c1 in 10usize..18, r1 in 2usize..5, two: bool,
        ) {
            let centres: Vec<(usize, usize)> =
                if two { vec![(c0, r0), (c1, r1)] } else { vec![(c0, r0)] };
            let (clean, leaflet) = holed(&centres);
            let mut loops: Vec<usize> = unfold_mesh::topology::boundary_loops(&leaflet)
                .unwrap()
                .iter()
                .map(Vec::len)
                .collect();
            prop_assert_eq!(loops.len(), 1 + centres.len());
            loops.sort_unstable();
            let rim = loops.pop().unwrap();
            prop_assert!(loops.iter().all(|&n| (3..rim).contains(&n)), "{:?}", loops);
            let ([a, _], r) = repair_leaflets(&leaflet, &clean).unwrap();
            prop_assert_eq!(r.anterior.holes_filled, centres.len());
            prop_assert_eq!(
                r.anterior.hole_triangles,
                loops.iter().map(|n| n - 2).sum::<usize>()
            );
            prop_assert_eq!(unfold_mesh::topology::boundary_loops(&a).unwrap().len(), 1);
            prop_assert_eq!(a.positions.len(), leaflet.positions.len());
        }
    }
}
