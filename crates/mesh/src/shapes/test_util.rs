//! Mesh checks for the shape tests: the crate's own topology and geometry
//! where it has them, plus checks it does not offer (vertex-fan
//! manifoldness, winding numbers, triangle intersections, quality).

use crate::geometry::segment_crosses_triangle;
use nalgebra::{Point3, Vector3};
use std::collections::{BTreeMap, HashMap};

/// Undirected edge -> number of triangles using it.
pub fn edge_counts(tris: &[[u32; 3]]) -> BTreeMap<(u32, u32), usize> {
    let mut m = BTreeMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *m.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    m
}

/// Checks the triangle mesh is an oriented 2-manifold with boundary: every
/// edge is used by one or two triangles, every directed edge at most once
/// (consistent orientation), and no triangle repeats a vertex.
pub fn assert_oriented_manifold(tris: &[[u32; 3]]) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "triangle {i} repeats a vertex: {t:?}"
        );
        for k in 0..3 {
            let e = (t[k], t[(k + 1) % 3]);
            if let Some(j) = directed.insert(e, i) {
                panic!(
                    "directed edge {e:?} used by triangles {j} and {i}: inconsistent orientation or non-manifold"
                );
            }
        }
    }
    for (e, c) in edge_counts(tris) {
        assert!(c == 1 || c == 2, "edge {e:?} used by {c} triangles");
    }
    // Vertex manifoldness: the triangles around each vertex form one fan.
    let mut around: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            around
                .entry(t[k])
                .or_default()
                .push((t[(k + 1) % 3], t[(k + 2) % 3]));
        }
    }
    for (v, fan) in around {
        // Count fan components by following next -> prev links.
        let next: HashMap<u32, u32> = fan.iter().copied().collect();
        let prevs: std::collections::HashSet<u32> = fan.iter().map(|&(_, b)| b).collect();
        // Start at a vertex without predecessor (boundary fan) or anywhere.
        let start = fan
            .iter()
            .map(|&(a, _)| a)
            .find(|a| !prevs.contains(a))
            .unwrap_or(fan[0].0);
        let mut seen = 0;
        let mut cur = start;
        while let Some(&n) = next.get(&cur) {
            seen += 1;
            cur = n;
            if cur == start || seen > fan.len() {
                break;
            }
        }
        assert_eq!(seen, fan.len(), "vertex {v} is not manifold (several fans)");
    }
}

/// Boundary loops (vertex sequences following the boundary half-edges),
/// via [`crate::topology::boundary_loops`]; panics on a non-manifold rim.
pub fn boundary_loops(tris: &[[u32; 3]]) -> Vec<Vec<u32>> {
    crate::topology::boundary_loops(&index_only(tris)).expect("manifold boundary")
}

/// Euler characteristic V - E + F of a triangle mesh (V = used vertices).
pub fn euler_tri(tris: &[[u32; 3]]) -> i64 {
    crate::topology::euler_characteristic(&index_only(tris))
}

/// A mesh with the given triangles and placeholder positions, for the
/// purely combinatorial queries.
fn index_only(tris: &[[u32; 3]]) -> crate::TriMesh {
    let n = tris
        .iter()
        .flatten()
        .map(|&v| v as usize + 1)
        .max()
        .unwrap_or(0);
    crate::TriMesh::new(vec![Point3::origin(); n], tris.to_vec())
}

/// Outward boundary faces of a positively oriented tet mesh (faces used by
/// exactly one tet, oriented with the normal pointing out of that tet);
/// asserts that every face is used by one or two tets.
pub fn tet_boundary(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut faces: HashMap<[u32; 3], (usize, [u32; 3])> = HashMap::new();
    for t in tets {
        // Outward faces of a positive tet [a, b, c, d].
        for f in [
            [t[1], t[2], t[3]],
            [t[0], t[3], t[2]],
            [t[0], t[1], t[3]],
            [t[0], t[2], t[1]],
        ] {
            let mut key = f;
            key.sort_unstable();
            let e = faces.entry(key).or_insert((0, f));
            e.0 += 1;
        }
    }
    let mut out = Vec::new();
    for (k, (c, f)) in faces {
        assert!(c == 1 || c == 2, "face {k:?} used by {c} tets");
        if c == 1 {
            out.push(f);
        }
    }
    out.sort_unstable();
    out
}

/// Sum of the triangles' area vectors `(b-a)x(c-a)/2`.
pub fn area_vector_sum(pos: &[Point3<f64>], tris: &[[u32; 3]]) -> Vector3<f64> {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            (b - a).cross(&(c - a)) * 0.5
        })
        .sum()
}

/// Signed volume enclosed by a closed oriented triangle surface.
pub fn enclosed_volume(pos: &[Point3<f64>], tris: &[[u32; 3]]) -> f64 {
    crate::geometry::enclosed_volume(&crate::TriMesh::new(pos.to_vec(), tris.to_vec()))
}

/// Smallest triangle area divided by the mean area.
pub fn min_area_ratio(pos: &[Point3<f64>], tris: &[[u32; 3]]) -> f64 {
    let areas: Vec<f64> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            (b - a).cross(&(c - a)).norm() * 0.5
        })
        .collect();
    let mean = areas.iter().sum::<f64>() / areas.len() as f64;
    areas.iter().copied().fold(f64::INFINITY, f64::min) / mean
}

/// Smallest interior angle (degrees) over all triangles.
pub fn min_angle_deg(pos: &[Point3<f64>], tris: &[[u32; 3]]) -> f64 {
    let mut m = 180.0f64;
    for t in tris {
        let p = t.map(|i| pos[i as usize]);
        for k in 0..3 {
            let u = p[(k + 1) % 3] - p[k];
            let v = p[(k + 2) % 3] - p[k];
            m = m.min(u.angle(&v).to_degrees());
        }
    }
    m
}

/// Whether two triangles intersect (one's edge crosses the other).
pub fn triangles_intersect(t1: [Point3<f64>; 3], t2: [Point3<f64>; 3]) -> bool {
    for k in 0..3 {
        if segment_crosses_triangle(&t1[k], &t1[(k + 1) % 3], &t2[0], &t2[1], &t2[2])
            || segment_crosses_triangle(&t2[k], &t2[(k + 1) % 3], &t1[0], &t1[1], &t1[2])
        {
            return true;
        }
    }
    false
}
