//! Convex hull membership: which points are corners of the hull (exact
//! Quickhull, with planar and collinear fallbacks).

use super::predicates::{collinear_exact, orient2d_exact, orient3d_exact, project};
use nalgebra::Point3;
use std::cmp::Ordering;

fn lex_cmp(a: &Point3<f64>, b: &Point3<f64>) -> Ordering {
    a.x.total_cmp(&b.x)
        .then(a.y.total_cmp(&b.y))
        .then(a.z.total_cmp(&b.z))
}

/// Which points are vertices (extreme points) of the convex hull of the set.
///
/// A point is marked `true` iff it is a corner of the hull polytope: it is not
/// in the convex hull of the other (distinct) points. Points lying exactly on
/// a hull face or edge without being a corner are **not** marked, nor are
/// interior points. All copies of a duplicated corner are marked. Points with
/// a NaN or infinite coordinate are ignored (marked `false`).
///
/// Degenerate sets are handled by dimension: a single distinct point is its
/// own hull; for collinear sets the two end points are marked; for coplanar
/// sets the corners of the planar convex polygon are marked.
///
/// Coordinates are first scaled by a power of two (exact) so that the largest
/// magnitude is about 1; the result is then exact unless coordinate
/// differences are below ~`1e-100` times that magnitude (where the predicates'
/// products underflow).
///
/// Algorithm: Quickhull (furthest point from a face first, conflict lists,
/// expected `O(n log n)`) on the distinct points, with every visibility
/// decision taken by exact orientation predicates ([`orient3d_exact`]): a
/// point is inserted only when it is strictly outside a face, so the hull
/// stays a consistent convex triangulated sphere whatever the input. As
/// coplanar insertions can leave non-corner points as vertices of that
/// triangulation, a final exact pass keeps only the vertices whose incident
/// triangles span at least three distinct planes (a point in the relative
/// interior of a facet touches one plane, on an edge two).
pub fn convex_hull_vertices(points: &[Point3<f64>]) -> Vec<bool> {
    let n = points.len();
    let mut out = vec![false; n];
    // `+ 0.0` turns -0.0 into +0.0 so that equal points compare equal.
    let canon = |p: &Point3<f64>| Point3::new(p.x + 0.0, p.y + 0.0, p.z + 0.0);
    let mut idx: Vec<usize> = (0..n)
        .filter(|&i| points[i].coords.iter().all(|x| x.is_finite()))
        .collect();
    idx.sort_unstable_by(|&i, &j| lex_cmp(&canon(&points[i]), &canon(&points[j])));
    let mut uniq: Vec<Point3<f64>> = Vec::with_capacity(idx.len());
    let mut group = vec![0usize; n];
    for &i in &idx {
        let p = canon(&points[i]);
        if uniq.last() != Some(&p) {
            uniq.push(p);
        }
        group[i] = uniq.len() - 1;
    }
    // Scale by a power of two (exact) so that the largest magnitude is about
    // 1: the predicates are exact only while their products neither overflow
    // nor underflow.
    let max = uniq
        .iter()
        .flat_map(|p| p.coords.iter().map(|x| x.abs()))
        .fold(0.0f64, f64::max);
    if max > 0.0 {
        let k = max.log2().ceil() as i32;
        let (s1, s2) = (2f64.powi(-(k / 2)), 2f64.powi(-(k - k / 2)));
        for p in &mut uniq {
            *p = Point3::from(p.coords * s1 * s2);
        }
    }
    let extreme = extreme_points_unique(&uniq);
    for &i in &idx {
        out[i] = extreme[group[i]];
    }
    out
}

/// Extreme points of distinct finite points sorted lexicographically.
fn extreme_points_unique(u: &[Point3<f64>]) -> Vec<bool> {
    let m = u.len();
    let mut ext = vec![false; m];
    if m <= 2 {
        ext.iter_mut().for_each(|e| *e = true);
        return ext;
    }
    let a = 0;
    // b: farthest from a (any other point would do: all are distinct).
    let b = (1..m)
        .max_by(|&i, &j| {
            (u[i] - u[a])
                .norm_squared()
                .total_cmp(&(u[j] - u[a]).norm_squared())
        })
        .unwrap_or(1);
    // c: farthest from the line ab (by float score, checked exactly).
    let ab = u[b] - u[a];
    let score_c = |i: usize| ab.cross(&(u[i] - u[a])).norm_squared();
    let mut c = (0..m)
        .max_by(|&i, &j| score_c(i).total_cmp(&score_c(j)))
        .unwrap_or(0);
    if collinear_exact(&u[a], &u[b], &u[c]) {
        match (0..m).find(|&i| !collinear_exact(&u[a], &u[b], &u[i])) {
            Some(i) => c = i,
            None => {
                // Collinear: lexicographic order is monotone along the line.
                ext[0] = true;
                ext[m - 1] = true;
                return ext;
            }
        }
    }
    // d: farthest from the plane abc; the exact predicate is 0 iff coplanar.
    let d = (0..m)
        .map(|i| (i, orient3d_exact(&u[a], &u[b], &u[c], &u[i]).abs()))
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .filter(|x| x.1 > 0.0)
        .map(|x| x.0);
    match d {
        None => planar_hull(u, [a, b, c], &mut ext),
        Some(d) => quickhull(u, [a, b, c, d], &mut ext),
    }
    ext
}

/// Corners of the convex polygon of coplanar points (`tri` non-collinear):
/// projects onto the coordinate plane in which `tri` stays non-degenerate
/// (an affine bijection of the common plane) and runs Andrew's monotone chain
/// with exact 2D orientations, dropping collinear points.
fn planar_hull(u: &[Point3<f64>], tri: [usize; 3], ext: &mut [bool]) {
    let [a, b, c] = tri;
    let drop = (0..3)
        .find(|&k| orient2d_exact(project(&u[a], k), project(&u[b], k), project(&u[c], k)) != 0.0)
        .unwrap_or(2);
    let q: Vec<[f64; 2]> = u.iter().map(|p| project(p, drop)).collect();
    let mut order: Vec<usize> = (0..u.len()).collect();
    order.sort_unstable_by(|&i, &j| {
        q[i][0]
            .total_cmp(&q[j][0])
            .then(q[i][1].total_cmp(&q[j][1]))
    });
    let mut chain: Vec<usize> = Vec::with_capacity(2 * u.len());
    for pass in 0..2 {
        let start = chain.len();
        let iter: Box<dyn Iterator<Item = &usize>> = if pass == 0 {
            Box::new(order.iter())
        } else {
            Box::new(order.iter().rev())
        };
        for &i in iter {
            while chain.len() >= start + 2
                && orient2d_exact(q[chain[chain.len() - 2]], q[chain[chain.len() - 1]], q[i]) <= 0.0
            {
                chain.pop();
            }
            chain.push(i);
        }
    }
    for i in chain {
        ext[i] = true;
    }
}

const NONE: u32 = u32::MAX;

/// A hull triangle; `nbr[i]` lies across the edge `(v[i], v[i+1 mod 3])`.
struct HullFace {
    v: [u32; 3],
    nbr: [u32; 3],
    alive: bool,
    /// Stamp of the last insertion that tested this face, and its result.
    visit: u32,
    visible: bool,
    /// Points strictly outside this face (conflict list) and the farthest.
    pts: Vec<u32>,
    far: u32,
    far_dist: f64,
}

impl HullFace {
    fn new(v: [u32; 3]) -> Self {
        HullFace {
            v,
            nbr: [NONE; 3],
            alive: true,
            visit: 0,
            visible: false,
            pts: Vec::new(),
            far: NONE,
            far_dist: 0.0,
        }
    }

    fn add_point(&mut self, p: u32, dist: f64) {
        self.pts.push(p);
        if self.far == NONE || dist > self.far_dist {
            self.far = p;
            self.far_dist = dist;
        }
    }
}

/// Exact "strictly outside" test of `p` against face `f` (outward = counter-
/// clockwise normal); returns the (approximate) positive height, or `None`.
#[inline]
fn outside(u: &[Point3<f64>], f: &HullFace, p: u32) -> Option<f64> {
    let [a, b, c] = f.v.map(|i| &u[i as usize]);
    let s = orient3d_exact(a, b, c, &u[p as usize]);
    (s > 0.0).then_some(s)
}

fn quickhull(u: &[Point3<f64>], simplex: [usize; 4], ext: &mut [bool]) {
    let [a, mut b, mut c, d] = simplex.map(|i| i as u32);
    if orient3d_exact(
        &u[a as usize],
        &u[b as usize],
        &u[c as usize],
        &u[d as usize],
    ) < 0.0
    {
        std::mem::swap(&mut b, &mut c);
    }
    // Positive tet (a, b, c, d): outward faces.
    let mut faces: Vec<HullFace> = [[a, c, b], [a, b, d], [a, d, c], [b, c, d]]
        .into_iter()
        .map(HullFace::new)
        .collect();
    for f in 0..4 {
        for i in 0..3 {
            let (p, q) = (faces[f].v[i], faces[f].v[(i + 1) % 3]);
            let g = (0..4).find(|&g| {
                g != f && (0..3).any(|j| faces[g].v[j] == q && faces[g].v[(j + 1) % 3] == p)
            });
            faces[f].nbr[i] = g.map_or(NONE, |g| g as u32);
        }
    }
    for p in 0..u.len() as u32 {
        if [a, b, c, d].contains(&p) {
            continue;
        }
        for f in faces.iter_mut() {
            if let Some(s) = outside(u, f, p) {
                f.add_point(p, s);
                break;
            }
        }
    }

    let mut stack: Vec<u32> = (0..4).collect();
    let mut stamp = 0u32;
    let mut visible: Vec<u32> = Vec::new();
    let mut horizon: Vec<(u32, u32, u32)> = Vec::new();
    let mut new_faces: Vec<u32> = Vec::new();
    let mut start_face = vec![NONE; u.len()];
    let mut orphans: Vec<u32> = Vec::new();
    while let Some(f) = stack.pop() {
        let f = f as usize;
        if !faces[f].alive || faces[f].pts.is_empty() {
            continue;
        }
        let p = faces[f].far;
        stamp += 1;
        // Visible region: connected, found by BFS from f with exact tests.
        visible.clear();
        visible.push(f as u32);
        faces[f].visit = stamp;
        faces[f].visible = true;
        let mut k = 0;
        while k < visible.len() {
            let g = visible[k] as usize;
            k += 1;
            for i in 0..3 {
                let h = faces[g].nbr[i] as usize;
                if faces[h].visit != stamp {
                    faces[h].visit = stamp;
                    faces[h].visible = outside(u, &faces[h], p).is_some();
                    if faces[h].visible {
                        visible.push(h as u32);
                    }
                }
            }
        }
        // Horizon edges (u, w) of visible faces with an invisible neighbour h.
        horizon.clear();
        for &g in &visible {
            let g = g as usize;
            for i in 0..3 {
                let h = faces[g].nbr[i] as usize;
                if !faces[h].visible {
                    horizon.push((faces[g].v[i], faces[g].v[(i + 1) % 3], h as u32));
                }
            }
        }
        // Cone from p over the horizon.
        new_faces.clear();
        for &(s, w, h) in &horizon {
            let nf = faces.len() as u32;
            let mut face = HullFace::new([s, w, p]);
            face.nbr[0] = h;
            faces.push(face);
            let hf = &mut faces[h as usize];
            for j in 0..3 {
                if hf.v[j] == w && hf.v[(j + 1) % 3] == s {
                    hf.nbr[j] = nf;
                }
            }
            start_face[s as usize] = nf;
            new_faces.push(nf);
        }
        for &nf in &new_faces {
            let w = faces[nf as usize].v[1];
            let g = start_face[w as usize];
            faces[nf as usize].nbr[1] = g;
            faces[g as usize].nbr[2] = nf;
        }
        // Retire the visible faces and hand their outside points to the cone.
        orphans.clear();
        for &g in &visible {
            let g = g as usize;
            faces[g].alive = false;
            orphans.append(&mut faces[g].pts);
            faces[g].pts.shrink_to_fit();
        }
        for &q in &orphans {
            if q == p {
                continue;
            }
            for &nf in &new_faces {
                if let Some(s) = outside(u, &faces[nf as usize], q) {
                    faces[nf as usize].add_point(q, s);
                    break;
                }
            }
        }
        for &nf in &new_faces {
            if !faces[nf as usize].pts.is_empty() {
                stack.push(nf);
            }
        }
    }

    // Keep the vertices whose incident faces span >= 3 distinct planes.
    let mut count = vec![0u32; u.len() + 1];
    for f in faces.iter().filter(|f| f.alive) {
        for &v in &f.v {
            count[v as usize + 1] += 1;
        }
    }
    for i in 0..u.len() {
        count[i + 1] += count[i];
    }
    let mut fill = count.clone();
    let mut incident = vec![0u32; count[u.len()] as usize];
    for (fi, f) in faces.iter().enumerate().filter(|(_, f)| f.alive) {
        for &v in &f.v {
            incident[fill[v as usize] as usize] = fi as u32;
            fill[v as usize] += 1;
        }
    }
    let coplanar = |f: &HullFace, g: &HullFace| {
        g.v.iter().all(|&w| {
            f.v.contains(&w)
                || orient3d_exact(
                    &u[f.v[0] as usize],
                    &u[f.v[1] as usize],
                    &u[f.v[2] as usize],
                    &u[w as usize],
                ) == 0.0
        })
    };
    for v in 0..u.len() {
        let around = &incident[count[v] as usize..count[v + 1] as usize];
        let mut planes: [usize; 3] = [0; 3];
        let mut np = 0;
        for &g in around {
            let g = g as usize;
            if !planes[..np].iter().any(|&r| coplanar(&faces[r], &faces[g])) {
                planes[np] = g;
                np += 1;
                if np == 3 {
                    ext[v] = true;
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::strategies::point;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    use crate::test_meshes::SplitMix as Rng;

    fn in_segment(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> bool {
        collinear_exact(a, b, p) && (p - a).dot(&(b - a)) >= 0.0 && (p - b).dot(&(a - b)) >= 0.0
    }

    fn in_triangle(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> bool {
        if collinear_exact(a, b, c) || orient3d_exact(a, b, c, p) != 0.0 {
            return false;
        }
        let k = (0..3)
            .find(|&k| orient2d_exact(project(a, k), project(b, k), project(c, k)) != 0.0)
            .unwrap();
        let [a, b, c, p] = [a, b, c, p].map(|q| project(q, k));
        let o = orient2d_exact(a, b, c);
        [
            orient2d_exact(a, b, p),
            orient2d_exact(b, c, p),
            orient2d_exact(c, a, p),
        ]
        .iter()
        .all(|s| s * o >= 0.0)
    }

    fn in_tet(p: &Point3<f64>, t: [&Point3<f64>; 4]) -> bool {
        let o = orient3d_exact(t[0], t[1], t[2], t[3]);
        o != 0.0
            && (0..4).all(|i| {
                let mut q = t;
                q[i] = p;
                orient3d_exact(q[0], q[1], q[2], q[3]) * o >= 0.0
            })
    }

    /// Extreme points by Carathéodory: `p` is not a corner iff it lies in a
    /// closed non-degenerate segment, triangle or tet of the other points.
    fn brute_extreme(points: &[Point3<f64>]) -> Vec<bool> {
        let mut uniq: Vec<Point3<f64>> = Vec::new();
        for p in points {
            if !uniq.contains(p) {
                uniq.push(*p);
            }
        }
        let ext: Vec<bool> = (0..uniq.len())
            .map(|i| {
                let p = &uniq[i];
                let s: Vec<&Point3<f64>> = uniq
                    .iter()
                    .enumerate()
                    .filter(|e| e.0 != i)
                    .map(|e| e.1)
                    .collect();
                let m = s.len();
                for a in 0..m {
                    for b in a + 1..m {
                        if in_segment(p, s[a], s[b]) {
                            return false;
                        }
                        for c in b + 1..m {
                            if in_triangle(p, s[a], s[b], s[c]) {
                                return false;
                            }
                            for d in c + 1..m {
                                if in_tet(p, [s[a], s[b], s[c], s[d]]) {
                                    return false;
                                }
                            }
                        }
                    }
                }
                true
            })
            .collect();
        points
            .iter()
            .map(|p| ext[uniq.iter().position(|q| q == p).unwrap()])
            .collect()
    }

    fn fibonacci_sphere(n: usize, r: f64, c: Vector3<f64>) -> Vec<Point3<f64>> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let rho = (1.0 - z * z).sqrt();
                let th = golden * i as f64;
                Point3::from(Vector3::new(rho * th.cos(), rho * th.sin(), z) * r + c)
            })
            .collect()
    }

    #[test]
    fn hull_sphere_points_are_all_on_hull() {
        let mut pts = fibonacci_sphere(2000, 3.0, Vector3::new(1.0, -2.0, 0.5));
        let n = pts.len();
        // Interior points are not.
        let mut rng = Rng(7);
        for _ in 0..500 {
            let d = Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()).normalize();
            pts.push(Point3::from(
                d * 2.9 * rng.f64() + Vector3::new(1.0, -2.0, 0.5),
            ));
        }
        let on = convex_hull_vertices(&pts);
        assert!(on[..n].iter().all(|&b| b));
        assert!(on[n..].iter().all(|&b| !b));
    }

    #[test]
    fn hull_cube_interior_faces_and_corners() {
        let mut pts: Vec<Point3<f64>> = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                for k in 0..5 {
                    pts.push(Point3::new(i as f64, j as f64, k as f64) * 0.25);
                }
            }
        }
        let on = convex_hull_vertices(&pts);
        for (p, &b) in pts.iter().zip(&on) {
            let corner = p.coords.iter().all(|&x| x == 0.0 || x == 1.0);
            assert_eq!(b, corner, "{p:?}");
        }
        // Duplicated corners are all marked; shuffled order does not matter.
        let mut dup = pts.clone();
        dup.extend_from_slice(&pts);
        dup.reverse();
        let on2 = convex_hull_vertices(&dup);
        assert_eq!(on2.iter().filter(|&&b| b).count(), 16);
    }

    #[test]
    fn hull_degenerate_inputs() {
        assert!(convex_hull_vertices(&[]).is_empty());
        let p = Point3::new(1.0, 2.0, 3.0);
        assert_eq!(convex_hull_vertices(&[p]), vec![true]);
        assert_eq!(convex_hull_vertices(&[p, p, p]), vec![true; 3]);
        let q = Point3::new(-1.0, 0.0, 3.0);
        assert_eq!(convex_hull_vertices(&[p, q]), vec![true, true]);
        // -0.0 and 0.0 are the same point.
        let z = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(-0.0, 0.0, -0.0),
            Point3::new(1.0, 0.0, 0.0),
        ];
        assert_eq!(convex_hull_vertices(&z), vec![true, true, true]);
        // Collinear: only the end points.
        let line: Vec<_> = (0..7)
            .map(|i| Point3::new(3.0 - i as f64, 2.0 * i as f64, 1.0))
            .collect();
        let on = convex_hull_vertices(&line);
        assert_eq!(on, vec![true, false, false, false, false, false, true]);
        // Coplanar (tilted plane): corners of the polygon only.
        let mut plane = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let (u, v) = (i as f64, j as f64);
                plane.push(Point3::new(u, v, 0.5 * u - 2.0 * v));
            }
        }
        let on = convex_hull_vertices(&plane);
        assert_eq!(on, brute_extreme(&plane));
        assert_eq!(on.iter().filter(|&&b| b).count(), 4);
        // Triangle plus collinear points on its edge.
        let tri = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(4.0, 0.0, 0.0),
            Point3::new(0.0, 4.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(2.0, 2.0, 0.0),
        ];
        assert_eq!(
            convex_hull_vertices(&tri),
            vec![true, true, true, false, false]
        );
        // NaN and infinite points are ignored.
        let mut bad = fibonacci_sphere(50, 1.0, Vector3::zeros());
        bad.push(Point3::new(f64::NAN, 0.0, 0.0));
        bad.push(Point3::new(f64::INFINITY, 0.0, 0.0));
        let on = convex_hull_vertices(&bad);
        assert!(on[..50].iter().all(|&b| b));
        assert!(!on[50] && !on[51]);
        // Tiny and huge coordinates.
        let tiny: Vec<_> = fibonacci_sphere(100, 1e-300, Vector3::zeros());
        assert!(convex_hull_vertices(&tiny).iter().all(|&b| b));
        let huge: Vec<_> = fibonacci_sphere(100, 1e300, Vector3::zeros());
        assert!(convex_hull_vertices(&huge).iter().all(|&b| b));
    }

    #[test]
    fn hull_of_10k_sphere_points_and_10k_inside_is_exact() {
        let mut rng = Rng(3);
        let mut pts = fibonacci_sphere(10_000, 1.0, Vector3::zeros());
        while pts.len() < 20_000 {
            let d = Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()) * 0.4;
            if d.norm() < 0.99 {
                pts.push(Point3::from(d));
            }
        }
        let on = convex_hull_vertices(&pts);
        assert!(on[..10_000].iter().all(|&b| b));
        assert!(on[10_000..].iter().all(|&b| !b));
        // Lattice with heavy degeneracy.
        let mut grid = Vec::new();
        for i in 0..22 {
            for j in 0..22 {
                for k in 0..22 {
                    grid.push(Point3::new(i as f64, j as f64, k as f64));
                }
            }
        }
        let on = convex_hull_vertices(&grid);
        assert_eq!(on.iter().filter(|&&b| b).count(), 8);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Small-integer sets (many coplanar / collinear / repeated points)
        /// against the brute-force corner test.
        #[test]
        fn hull_matches_brute_force_on_lattice(
            pts in prop::collection::vec((0..4i32, 0..4i32, 0..3i32), 0..11)
        ) {
            let pts: Vec<_> = pts.iter().map(|&(x, y, z)| Point3::new(x as f64, y as f64, z as f64)).collect();
            prop_assert_eq!(convex_hull_vertices(&pts), brute_extreme(&pts));
        }

        /// Coplanar and collinear lattice subsets in a tilted plane.
        #[test]
        fn hull_matches_brute_force_in_a_plane(
            pts in prop::collection::vec((0..5i32, 0..5i32), 0..12), flat in any::<bool>()
        ) {
            let pts: Vec<_> = pts.iter().map(|&(u, v)| {
                let (u, v) = (u as f64, v as f64);
                if flat { Point3::new(u + v, 2.0 * u + 2.0 * v, 1.0 - u - v + v) } else { Point3::new(u, v, 3.0 * u - v) }
            }).collect();
            prop_assert_eq!(convex_hull_vertices(&pts), brute_extreme(&pts));
        }

        /// Random real coordinates (general position).
        #[test]
        fn hull_matches_brute_force_random(pts in prop::collection::vec(point(), 0..12)) {
            prop_assert_eq!(convex_hull_vertices(&pts), brute_extreme(&pts));
        }
    }
}
