//! Flip checks: the sign of every element's Jacobian determinant under a
//! map (ALGORITHMS 1.1).

use crate::{ParamError, ParamMesh, RestElements};
use nalgebra::{Matrix2, Matrix3, Vector3};
use rayon::prelude::*;

/// `det J` of element `e` under the map `x` (flat, `mesh.dim()` coordinates
/// per vertex): `det(Ds) det(Dm^-1)`, with `Ds` the mapped edge matrix
/// (ALGORITHMS 1.1). For a triangle this is the signed area of the mapped
/// triangle over its rest area, for a tet the signed mapped volume over the
/// rest volume. Positive when the element keeps its orientation.
///
/// # Panics
/// If `e` is out of range or `x` is too short.
pub fn jacobian_determinant(mesh: &ParamMesh, x: &[f64], e: usize) -> f64 {
    match &mesh.elements {
        RestElements::Tets { tets, dm_inv } => {
            let t = tets[e];
            let p = |k: usize| {
                let v = t[k] as usize * 3;
                Vector3::new(x[v], x[v + 1], x[v + 2])
            };
            let p0 = p(0);
            let ds = Matrix3::from_columns(&[p(1) - p0, p(2) - p0, p(3) - p0]);
            ds.determinant() * dm_inv[e].determinant()
        }
        RestElements::Tris { tris, dm_inv } => {
            let t = tris[e];
            let p = |k: usize| {
                let v = t[k] as usize * 2;
                [x[v], x[v + 1]]
            };
            let (a, b, c) = (p(0), p(1), p(2));
            let ds = Matrix2::new(b[0] - a[0], c[0] - a[0], b[1] - a[1], c[1] - a[1]);
            ds.determinant() * dm_inv[e].determinant()
        }
    }
}

/// Checks that the map `x` (flat, `mesh.dim()` coordinates per vertex)
/// inverts no element: `det J > 0` for every element (2D: positive signed
/// area of the mapped triangle; 3D: positive signed volume of the mapped
/// tet; see [`jacobian_determinant`]).
///
/// # Errors
/// `Length` when `x.len() != dim * n`; [`ParamError::InvertedStart`] for the
/// first (lowest-index) element with `det J <= 0` (or NaN).
pub fn check_no_flips(mesh: &ParamMesh, x: &[f64]) -> Result<(), ParamError> {
    let expected = mesh.dim() * mesh.num_vertices();
    if x.len() != expected {
        return Err(ParamError::Length {
            what: "mapped positions",
            expected,
            found: x.len(),
        });
    }
    let bad = (0..mesh.num_elements())
        .into_par_iter()
        .map(|e| (e, jacobian_determinant(mesh, x, e)))
        .find_first(|&(_, det)| det.is_nan() || det <= 0.0);
    match bad {
        None => Ok(()),
        Some((element, det)) => Err(ParamError::InvertedStart { element, det }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::shapes::primitives::{grid_disk, kuhn_grid};

    #[test]
    fn check_no_flips_reports_the_first_inverted_element() {
        // Triangles.
        let m = grid_disk(3, 3);
        let pm = ParamMesh::from_triangles(&m).unwrap();
        let mut x: Vec<f64> = m.positions.iter().flat_map(|p| [p.x, p.y]).collect();
        assert!(check_no_flips(&pm, &x).is_ok());
        // Push vertex 5 (interior, (1, 1)) across its neighbours.
        x[10] = 2.6;
        x[11] = 2.7;
        let first = (0..pm.num_elements())
            .find(|&e| jacobian_determinant(&pm, &x, e) <= 0.0)
            .unwrap();
        match check_no_flips(&pm, &x) {
            Err(ParamError::InvertedStart { element, det }) => {
                assert_eq!(element, first);
                assert!(det <= 0.0);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            check_no_flips(&pm, &x[1..]),
            Err(ParamError::Length { .. })
        ));
        // A flat (zero-area) triangle counts as inverted; NaN as well.
        let mut y: Vec<f64> = m.positions.iter().flat_map(|p| [p.x, p.y]).collect();
        y[1] = f64::NAN;
        assert!(matches!(
            check_no_flips(&pm, &y),
            Err(ParamError::InvertedStart { .. })
        ));
        // Tets: the identity is fine, a mirror image inverts everything.
        let t = kuhn_grid([1, 1, 1], [1.0, 1.0, 1.0]);
        let pt = ParamMesh::from_tets(&t).unwrap();
        let mut z = pt.rest_flat();
        assert!(check_no_flips(&pt, &z).is_ok());
        for c in z.chunks_mut(3) {
            c[2] = -c[2];
        }
        assert!(matches!(
            check_no_flips(&pt, &z),
            Err(ParamError::InvertedStart { element: 0, det }) if (det + 1.0).abs() < 1e-12
        ));
    }
}
