//! Each triangle split into the three regions nearest its corners, so that
//! per-vertex labels are drawn crisply (no colour between two labels).

use std::collections::HashMap;

use unfold_render::nalgebra::{Point3, Vector3};

pub(super) fn sorted(e: [u32; 2]) -> [u32; 2] {
    if e[0] <= e[1] { e } else { [e[1], e[0]] }
}

/// Each triangle split into the three regions nearest its corners (two
/// triangles each, through the edge midpoints and the centroid), for crisp
/// per-vertex labels.
pub(super) struct Subdivision {
    /// Per new vertex: the barycentric combination of old vertices (1, 2 or
    /// 3 of them, equal weights).
    pub(super) points: Vec<Vec<u32>>,
    /// The new triangles.
    pub(super) triangles: Vec<[u32; 3]>,
    /// The old vertex whose label each new triangle takes.
    pub(super) corner: Vec<u32>,
}

impl Subdivision {
    pub(super) fn new(triangles: &[[u32; 3]], n: usize) -> Self {
        let mut points: Vec<Vec<u32>> = (0..n as u32).map(|i| vec![i]).collect();
        let mut mids: HashMap<[u32; 2], u32> = HashMap::new();
        let mut out = Vec::with_capacity(6 * triangles.len());
        let mut corner = Vec::with_capacity(6 * triangles.len());
        for t in triangles {
            let mut mid = |a: u32, b: u32, points: &mut Vec<Vec<u32>>| {
                *mids.entry(sorted([a, b])).or_insert_with(|| {
                    points.push(vec![a, b]);
                    (points.len() - 1) as u32
                })
            };
            let m01 = mid(t[0], t[1], &mut points);
            let m12 = mid(t[1], t[2], &mut points);
            let m20 = mid(t[2], t[0], &mut points);
            points.push(t.to_vec());
            let g = (points.len() - 1) as u32;
            for (v, next, prev) in [(t[0], m01, m20), (t[1], m12, m01), (t[2], m20, m12)] {
                out.push([v, next, g]);
                out.push([v, g, prev]);
                corner.push(v);
                corner.push(v);
            }
        }
        Subdivision {
            points,
            triangles: out,
            corner,
        }
    }

    /// The new vertices' positions.
    pub(super) fn positions(&self, p: &[Point3<f64>]) -> Vec<Point3<f64>> {
        self.points
            .iter()
            .map(|ids| {
                let s = ids
                    .iter()
                    .fold(Vector3::zeros(), |s, &i| s + p[i as usize].coords);
                Point3::from(s / ids.len() as f64)
            })
            .collect()
    }
}
