//! Measures of simplices and meshes: signed tet volumes and dihedral angles,
//! triangle areas and normals, mesh totals, enclosed volume, vertex normals,
//! barycentric vertex areas and volumes, centroids.

use crate::{TetMesh, TriMesh};
use nalgebra::{Point3, Unit, Vector3};

/// Signed volume of the tet `(a, b, c, d)`: `(b-a)·((c-a)×(d-a)) / 6`;
/// positive when `d` lies on the side of `abc` its counter-clockwise normal
/// points to.
#[inline]
pub fn tet_signed_volume(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
    d: &Point3<f64>,
) -> f64 {
    (b - a).dot(&(c - a).cross(&(d - a))) / 6.0
}

/// The six interior dihedral angles (radians) of the tet `p`, at the edges
/// `01, 02, 03, 12, 13, 23`: the angle at edge `ij` is `pi` minus the angle
/// between the outward normals of the two faces sharing it,
/// `acos(-n_a · n_b)`. A degenerate tet gives angles of 0 or pi (or NaN for
/// coincident corners).
pub fn tet_dihedral_angles(p: &[Point3<f64>; 4]) -> [f64; 6] {
    // face k is opposite corner k; its outward normal points away from p[k]
    let normal = |k: usize| {
        let f: Vec<usize> = (0..4).filter(|&i| i != k).collect();
        let n = (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]]));
        let n = if n.dot(&(p[k] - p[f[0]])) > 0.0 {
            -n
        } else {
            n
        };
        n / n.norm()
    };
    let n = [normal(0), normal(1), normal(2), normal(3)];
    // edge ij is shared by the faces opposite the two other corners
    let edges = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    edges.map(|(i, j)| {
        let o: Vec<usize> = (0..4).filter(|&x| x != i && x != j).collect();
        (-n[o[0]].dot(&n[o[1]])).clamp(-1.0, 1.0).acos()
    })
}

/// Area vector of the triangle `(a, b, c)`: `(b-a)×(c-a) / 2`, its length the
/// area and its direction the counter-clockwise normal.
#[inline]
pub fn triangle_area_vector(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> Vector3<f64> {
    (b - a).cross(&(c - a)) * 0.5
}

/// Area of the triangle `(a, b, c)`: `|(b-a)×(c-a)| / 2`.
#[inline]
pub fn triangle_area(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    triangle_area_vector(a, b, c).norm()
}

/// Unit normal of the triangle `(a, b, c)`, `None` when it is degenerate.
#[inline]
pub fn triangle_normal(
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Option<Unit<Vector3<f64>>> {
    Unit::try_new(triangle_area_vector(a, b, c), f64::MIN_POSITIVE)
}

/// Signed area of the planar triangle `(a, b, c)` (x, y only):
/// `((b-a) × (c-a))_z / 2`, positive when counter-clockwise.
#[inline]
pub fn triangle_signed_area_2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

/// Signed volume of every tet, `V_t = (b-a)·((c-a)×(d-a)) / 6` (see
/// [`tet_signed_volume`]); negative for inverted tets.
///
/// Panics if a tet refers to a vertex out of range (see [`check_indices`](super::check_indices)).
pub fn tet_volumes(mesh: &TetMesh) -> Vec<f64> {
    (0..mesh.tets.len())
        .map(|t| {
            let [a, b, c, d] = mesh.tet_points(t);
            tet_signed_volume(&a, &b, &c, &d)
        })
        .collect()
}

/// Sum of the signed tet volumes, `sum_t V_t`; the mesh volume when every tet
/// is positively oriented (inverted tets subtract).
///
/// Panics if a tet refers to a vertex out of range.
pub fn total_volume(mesh: &TetMesh) -> f64 {
    tet_volumes(mesh).iter().sum()
}

/// Area of every triangle, `A_t = |(b-a)×(c-a)| / 2` (see [`triangle_area`]).
///
/// Panics if a triangle refers to a vertex out of range.
pub fn triangle_areas(mesh: &TriMesh) -> Vec<f64> {
    (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.triangle_points(t);
            triangle_area(&a, &b, &c)
        })
        .collect()
}

/// Surface area, `sum_t A_t`.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn total_area(mesh: &TriMesh) -> f64 {
    triangle_areas(mesh).iter().sum()
}

/// Volume enclosed by a closed triangle surface, by the divergence theorem:
/// `V = sum_t a_t·(b_t×c_t) / 6` (each triangle forms a signed tet with the
/// origin). Positive for a closed mesh whose counter-clockwise normals point
/// outward, negative when they point inward. For a closed mesh the result does
/// not depend on the origin; for an open mesh it does (it is then the signed
/// volume of the cone from the origin over the surface).
///
/// Panics if a triangle refers to a vertex out of range.
pub fn enclosed_volume(mesh: &TriMesh) -> f64 {
    (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.triangle_points(t);
            a.coords.dot(&b.coords.cross(&c.coords))
        })
        .sum::<f64>()
        / 6.0
}

/// Area-weighted vertex normals: `n_v = N_v / |N_v|` with
/// `N_v = sum_{t ∋ v} (b_t-a_t)×(c_t-a_t) / 2`, the sum of the (unnormalised)
/// area vectors of the triangles around `v`, so larger triangles weigh more.
/// Vertices used by no triangle, or whose area vectors cancel, get the zero
/// vector.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn vertex_normals(mesh: &TriMesh) -> Vec<Vector3<f64>> {
    let mut acc = vec![Vector3::zeros(); mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = mesh.triangle_points(t);
        let n = triangle_area_vector(&a, &b, &c);
        for &v in tri {
            acc[v as usize] += n;
        }
    }
    for n in &mut acc {
        let len = n.norm();
        *n = if len > 0.0 && len.is_finite() {
            *n / len
        } else {
            Vector3::zeros()
        };
    }
    acc
}

/// Barycentric vertex areas: `A_v = sum_{t ∋ v} A_t / 3` (each triangle gives
/// a third of its area to each corner), so `sum_v A_v = sum_t A_t`. The lumped
/// mass matrix of linear finite elements. Isolated vertices get 0.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn vertex_areas(mesh: &TriMesh) -> Vec<f64> {
    let mut acc = vec![0.0; mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = mesh.triangle_points(t);
        let third = triangle_area(&a, &b, &c) / 3.0;
        for &v in tri {
            acc[v as usize] += third;
        }
    }
    acc
}

/// Barycentric vertex volumes: `V_v = sum_{t ∋ v} |V_t| / 4` (each tet gives a
/// quarter of its unsigned volume to each corner), so `sum_v V_v = sum_t |V_t|`
/// (equal to [`total_volume`] when no tet is inverted). Isolated vertices get 0.
///
/// Panics if a tet refers to a vertex out of range.
pub fn tet_vertex_volumes(mesh: &TetMesh) -> Vec<f64> {
    let mut acc = vec![0.0; mesh.positions.len()];
    for (t, tet) in mesh.tets.iter().enumerate() {
        let [a, b, c, d] = mesh.tet_points(t);
        let quarter = tet_signed_volume(&a, &b, &c, &d).abs() / 4.0;
        for &v in tet {
            acc[v as usize] += quarter;
        }
    }
    acc
}

/// Vertex mean `c = (1/n) sum_i p_i`; `None` for an empty slice.
pub fn centroid(points: &[Point3<f64>]) -> Option<Point3<f64>> {
    if points.is_empty() {
        return None;
    }
    let sum = points
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.coords);
    Some(Point3::from(sum / points.len() as f64))
}

/// Centroid of the surface (a thin shell of uniform density):
/// `c = sum_t A_t (a_t + b_t + c_t)/3 / sum_t A_t`. Unlike [`centroid`] it does
/// not depend on how densely each region is sampled. `None` when the total
/// area is zero (no triangles, or all degenerate) or not finite.
///
/// Panics if a triangle refers to a vertex out of range.
pub fn area_weighted_centroid(mesh: &TriMesh) -> Option<Point3<f64>> {
    let mut total = 0.0;
    let mut acc = Vector3::zeros();
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.triangle_points(t);
        let area = triangle_area(&a, &b, &c);
        total += area;
        acc += (a.coords + b.coords + c.coords) * (area / 3.0);
    }
    (total > 0.0 && total.is_finite()).then(|| Point3::from(acc / total))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::strategies::point;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use std::collections::HashMap;

    /// Flips triangles of a convex, origin-containing surface to face outward.
    fn orient_outward(positions: &[Point3<f64>], tris: &mut [[u32; 3]], center: Point3<f64>) {
        for t in tris.iter_mut() {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let mid = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            if triangle_area_vector(&a, &b, &c).dot(&(mid - center)) < 0.0 {
                t.swap(1, 2);
            }
        }
    }

    fn unit_cube_surface() -> TriMesh {
        let positions: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let quads = [
            [0, 1, 3, 2],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 3, 7, 5],
        ];
        let mut tris: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        orient_outward(&positions, &mut tris, Point3::new(0.5, 0.5, 0.5));
        TriMesh::new(positions, tris)
    }

    /// Subdivided icosahedron on the unit sphere, outward oriented.
    fn icosphere(levels: usize) -> TriMesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut positions: Vec<Point3<f64>> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|p| Point3::from(Vector3::new(p[0], p[1], p[2]).normalize()))
        .collect();
        let mut tris: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
            let mut next = Vec::with_capacity(tris.len() * 4);
            for &[a, b, c] in &tris {
                let mut m = |i: u32, j: u32| {
                    *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                        let p = (positions[i as usize].coords + positions[j as usize].coords)
                            .normalize();
                        positions.push(Point3::from(p));
                        positions.len() as u32 - 1
                    })
                };
                let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            tris = next;
        }
        orient_outward(&positions, &mut tris, Point3::origin());
        TriMesh::new(positions, tris)
    }

    /// The unit cube as 6 positively oriented Kuhn tets.
    fn kuhn_cube() -> TetMesh {
        let positions: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let mut tets = Vec::new();
        for perm in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            let a = 0u32;
            let b = 1u32 << perm[0];
            let c = b | (1 << perm[1]);
            let mut tet = [a, b, c, 7];
            let [p, q, r, s] = tet.map(|i| positions[i as usize]);
            if tet_signed_volume(&p, &q, &r, &s) < 0.0 {
                tet.swap(2, 3);
            }
            tets.push(tet);
        }
        TetMesh::new(positions, tets)
    }

    proptest! {
        /// Mirroring the positions (x -> -x) negates every signed tet volume and
        /// the enclosed volume of a surface, and keeps areas.
        #[test]
        fn signed_volumes_flip_under_reflection(pts in prop::collection::vec(point(), 8)) {
            let tets = vec![[0, 1, 2, 3], [4, 5, 6, 7], [0, 2, 4, 6]];
            let mesh = TetMesh::new(pts.clone(), tets);
            let mirrored = TetMesh::new(
                pts.iter().map(|p| Point3::new(-p.x, p.y, p.z)).collect(),
                mesh.tets.clone(),
            );
            for (v, w) in tet_volumes(&mesh).iter().zip(tet_volumes(&mirrored)) {
                prop_assert!((v + w).abs() <= 1e-9 * (1.0 + v.abs()));
            }
            let cube = unit_cube_surface();
            let mut m = cube.clone();
            for p in &mut m.positions { p.x = -p.x; }
            prop_assert!((enclosed_volume(&m) + 1.0).abs() < 1e-12);
            prop_assert!((total_area(&m) - 6.0).abs() < 1e-12);
        }

        /// The divergence-theorem volume of a closed surface does not depend on
        /// where it sits.
        #[test]
        fn enclosed_volume_is_translation_invariant(t in point()) {
            let mut cube = unit_cube_surface();
            for p in &mut cube.positions { *p += t.coords; }
            prop_assert!((enclosed_volume(&cube) - 1.0).abs() < 1e-12);
            let c = area_weighted_centroid(&cube).unwrap();
            prop_assert!((c - (Point3::new(0.5, 0.5, 0.5) + t.coords)).norm() < 1e-12);
        }
    }

    #[test]
    fn cube_measures() {
        let cube = unit_cube_surface();
        assert_relative_eq!(enclosed_volume(&cube), 1.0, epsilon = 1e-14);
        assert_relative_eq!(total_area(&cube), 6.0, epsilon = 1e-14);
        assert_eq!(triangle_areas(&cube), vec![0.5; 12]);
        let tets = kuhn_cube();
        assert_eq!(tets.tets.len(), 6);
        for v in tet_volumes(&tets) {
            assert_relative_eq!(v, 1.0 / 6.0, epsilon = 1e-15);
        }
        assert_relative_eq!(total_volume(&tets), 1.0, epsilon = 1e-14);
        let vv = tet_vertex_volumes(&tets);
        assert_relative_eq!(vv.iter().sum::<f64>(), 1.0, epsilon = 1e-14);
        // Vertices 0 and 7 are in all six tets.
        assert_relative_eq!(vv[0], 0.25, epsilon = 1e-15);
        assert_relative_eq!(vv[7], 0.25, epsilon = 1e-15);
        // Inverted tets still contribute their unsigned volume.
        let mut inv = tets.clone();
        inv.tets[0].swap(0, 1);
        assert_relative_eq!(total_volume(&inv), 4.0 / 6.0, epsilon = 1e-14);
        assert_relative_eq!(
            tet_vertex_volumes(&inv).iter().sum::<f64>(),
            1.0,
            epsilon = 1e-14
        );
        let c = centroid(&cube.positions).unwrap();
        assert_relative_eq!(c, Point3::new(0.5, 0.5, 0.5), epsilon = 1e-15);
        assert_eq!(centroid(&[]), None);
        assert_eq!(area_weighted_centroid(&TriMesh::default()), None);
    }

    #[test]
    fn sphere_normals_areas_and_volume() {
        let s = icosphere(4);
        let normals = vertex_normals(&s);
        for (p, n) in s.positions.iter().zip(&normals) {
            assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-12);
            assert!(n.dot(&p.coords) > 0.999, "normal {n:?} at {p:?}");
        }
        let areas = vertex_areas(&s);
        assert_relative_eq!(
            areas.iter().sum::<f64>(),
            total_area(&s),
            max_relative = 1e-12
        );
        let pi = std::f64::consts::PI;
        assert_relative_eq!(total_area(&s), 4.0 * pi, max_relative = 1e-2);
        assert_relative_eq!(enclosed_volume(&s), 4.0 / 3.0 * pi, max_relative = 2e-2);
        assert!(enclosed_volume(&s) < 4.0 / 3.0 * pi);
        // Inward orientation gives a negative volume.
        let mut inward = s.clone();
        inward.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert_relative_eq!(
            enclosed_volume(&inward),
            -enclosed_volume(&s),
            epsilon = 1e-12
        );
        let c = area_weighted_centroid(&s).unwrap();
        assert!(c.coords.norm() < 1e-12);
    }

    #[test]
    fn isolated_vertices_get_zero() {
        let mut cube = unit_cube_surface();
        cube.positions.push(Point3::new(5.0, 5.0, 5.0));
        let n = vertex_normals(&cube);
        assert_eq!(n[8], Vector3::zeros());
        assert_relative_eq!(n[0], -Vector3::repeat(1.0).normalize(), epsilon = 1e-12);
        assert_eq!(vertex_areas(&cube)[8], 0.0);
        assert!(vertex_normals(&TriMesh::default()).is_empty());
    }
}
