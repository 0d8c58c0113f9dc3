//! Hole filling: boundary loops whose perimeter `Σ |v_{i+1} - v_i|` (the
//! loop's length, closing edge included) is at most a given distance are
//! closed with triangles over the loop's own vertices (no vertex is added).
//!
//! The loops are the boundary's simple cycles ([`boundary_cycles`]): the
//! boundary half-edges are walked into closed walks, and a walk that visits
//! a vertex twice (a hole touching itself, another hole or the rim at one
//! vertex: a pinch) is split there, so each part is filled on its own and
//! the pinch is closed by the filling instead of being cut apart.
//!
//! A loop is projected onto the plane through it with the Newell normal
//! `n = Σ v_i × v_{i+1}` (of the loop reversed, so the new triangles traverse
//! every boundary edge opposite to the triangle that has it: they are
//! oriented with the surface) and triangulated by ear clipping: repeatedly
//! cut off a convex corner whose triangle holds no other loop vertex. A
//! loop too twisted to have such an ear in that plane gets its most convex
//! corner cut instead, so every loop of `k` vertices gets `k - 2` triangles.
//! A corner whose new edge (its diagonal) is already an edge of the mesh is
//! never cut: that edge would get a third and a fourth triangle. A loop
//! whose every corner is such a corner cannot be closed over its own
//! vertices without a non-manifold edge and is left open (counted in
//! [`Filled::left_open`]). So the filling never makes an edge of more than
//! two triangles. Each new triangle takes the cell data of the triangle
//! along the loop's first edge.

use super::work::Work;
use nalgebra::{Point3, Vector3};
use std::collections::{HashMap, HashSet};

/// What [`fill_holes`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Filled {
    /// Boundary loops closed.
    pub holes: usize,
    /// Triangles added.
    pub triangles: usize,
    /// Loops short enough to fill that could not be closed without an edge
    /// of more than two triangles, left open.
    pub left_open: usize,
}

/// The perimeter of a closed loop of points.
pub(crate) fn perimeter(points: &[Point3<f64>]) -> f64 {
    (0..points.len())
        .map(|i| (points[(i + 1) % points.len()] - points[i]).norm())
        .sum()
}

/// The boundary's simple cycles: the boundary half-edges (directed as in
/// the one triangle that has them) walked into closed walks, each walk split
/// at every vertex it visits twice. Edges of two or more triangles are not
/// boundary; a half-edge whose walk cannot be closed (an inconsistent
/// orientation) is left out. Each cycle runs as its half-edges do.
pub fn boundary_cycles(triangles: &[[u32; 3]]) -> Vec<Vec<u32>> {
    let mut count: HashMap<(u32, u32), usize> = HashMap::new();
    for t in triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut out: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut starts: Vec<u32> = Vec::new();
    for t in triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            if a != b && count[&(a.min(b), a.max(b))] == 1 {
                out.entry(a).or_default().push(b);
                starts.push(a);
            }
        }
    }
    let mut cycles = Vec::new();
    for s in starts {
        // a walk from `s` along unused half-edges until it comes back to a
        // vertex it has visited: the part since that visit is a cycle
        let mut walk: Vec<u32> = vec![s];
        let mut at: HashMap<u32, usize> = HashMap::from([(s, 0)]);
        loop {
            let v = *walk.last().unwrap_or(&s);
            let Some(next) = out.get_mut(&v).and_then(Vec::pop) else {
                break; // an open walk: not a boundary cycle
            };
            if let Some(&i) = at.get(&next) {
                // walk[i] == next: walk[i..] is a cycle; go on from `next`
                let cycle = walk.split_off(i);
                for c in &cycle {
                    at.remove(c);
                }
                cycles.push(cycle);
            }
            at.insert(next, walk.len());
            walk.push(next);
        }
    }
    cycles.retain(|c| c.len() >= 3);
    cycles
}

/// Fills the boundary loops ([`boundary_cycles`]) of perimeter at most
/// `max_perimeter` and, when `fraction` is given, at most `fraction` times
/// the longest loop's perimeter, the longest loop itself never (see the
/// module docs). The mesh must be edge-manifold and consistently oriented.
pub(crate) fn fill_holes(w: &mut Work<3>, max_perimeter: f64, fraction: Option<f64>) -> Filled {
    let loops = boundary_cycles(&w.elements);
    let mut owner: HashMap<(u32, u32), usize> = HashMap::new();
    let mut edges: HashSet<(u32, u32)> = HashSet::new();
    let sorted = |t: [u32; 3]| {
        let mut s = t;
        s.sort_unstable();
        s
    };
    let faces: HashSet<[u32; 3]> = w.elements.iter().map(|&t| sorted(t)).collect();
    for (t, tri) in w.elements.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            owner.insert((a, b), t);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let perimeters: Vec<f64> = loops
        .iter()
        .map(|l| {
            let pts: Vec<Point3<f64>> = l.iter().map(|&v| w.positions[v as usize]).collect();
            perimeter(&pts)
        })
        .collect();
    let longest = (0..loops.len()).max_by(|&a, &b| perimeters[a].total_cmp(&perimeters[b]));
    let mut filled = Filled::default();
    for (k, l) in loops.iter().enumerate() {
        let bound = match (fraction, longest) {
            (Some(_), Some(r)) if r == k => continue,
            (Some(f), Some(r)) => max_perimeter.min(f * perimeters[r]),
            _ => max_perimeter,
        };
        if perimeters[k] > bound {
            continue;
        }
        let row = owner.get(&(l[0], l[1])).map(|&t| w.rows[t]).unwrap_or(0);
        let reversed: Vec<u32> = l.iter().rev().copied().collect();
        // (a loop of three around a lone triangle would get that triangle
        // again, reversed: a sheet's outline, not a hole)
        let Some(new) = ear_clip_avoiding(&reversed, &w.positions, &edges)
            .filter(|new| new.iter().all(|&t| !faces.contains(&sorted(t))))
        else {
            filled.left_open += 1;
            continue;
        };
        filled.holes += 1;
        filled.triangles += new.len();
        for t in new {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                edges.insert((a.min(b), a.max(b)));
            }
            w.elements.push(t);
            w.rows.push(row);
        }
    }
    filled
}

/// Triangulates the polygon `poly` (vertex ids into `positions`) by ear
/// clipping in the plane of its Newell normal; the triangles follow the
/// polygon's direction. A corner whose diagonal is in `edges` (undirected,
/// smaller id first) is never cut; `None` when only such corners are left.
pub(crate) fn ear_clip_avoiding(
    poly: &[u32],
    positions: &[Point3<f64>],
    edges: &HashSet<(u32, u32)>,
) -> Option<Vec<[u32; 3]>> {
    let p = |v: u32| positions[v as usize];
    let mut n = Vector3::zeros();
    for i in 0..poly.len() {
        n += p(poly[i])
            .coords
            .cross(&p(poly[(i + 1) % poly.len()]).coords);
    }
    let n = if n.norm() > 0.0 {
        n.normalize()
    } else {
        Vector3::z()
    };
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&helper).normalize();
    let v = n.cross(&u);
    let flat = |id: u32| [p(id).coords.dot(&u), p(id).coords.dot(&v)];
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let mut left: Vec<u32> = poly.to_vec();
    let mut out = Vec::with_capacity(poly.len().saturating_sub(2));
    while left.len() > 3 {
        let k = left.len();
        let corner = |i: usize| (left[(i + k - 1) % k], left[i], left[(i + 1) % k]);
        let is_ear = |i: usize| {
            let (a, b, c) = corner(i);
            let (fa, fb, fc) = (flat(a), flat(b), flat(c));
            cross(fa, fb, fc) > 0.0
                && left.iter().all(|&q| {
                    if q == a || q == b || q == c {
                        return true;
                    }
                    let fq = flat(q);
                    !(cross(fa, fb, fq) >= 0.0
                        && cross(fb, fc, fq) >= 0.0
                        && cross(fc, fa, fq) >= 0.0)
                })
        };
        // a corner whose diagonal is an edge already: never cut
        let free = |i: usize| {
            let (a, _, c) = corner(i);
            !edges.contains(&(a.min(c), a.max(c)))
        };
        let i = (0..k).find(|&i| free(i) && is_ear(i)).or_else(|| {
            (0..k).filter(|&i| free(i)).max_by(|&x, &y| {
                let (a, b, c) = corner(x);
                let (d, e, f) = corner(y);
                cross(flat(a), flat(b), flat(c)).total_cmp(&cross(flat(d), flat(e), flat(f)))
            })
        })?;
        let (a, b, c) = corner(i);
        out.push([a, b, c]);
        left.remove(i);
    }
    if left.len() == 3 {
        out.push([left[0], left[1], left[2]]);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle_area_vector;

    #[test]
    fn a_non_convex_polygon_is_clipped_into_k_minus_2_positive_triangles() {
        // An L shape in the plane z = 1, counter-clockwise seen from +z.
        let xy = [
            (0.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (1.0, 1.0),
            (1.0, 2.0),
            (0.0, 2.0),
        ];
        let pos: Vec<Point3<f64>> = xy.iter().map(|&(x, y)| Point3::new(x, y, 1.0)).collect();
        let poly: Vec<u32> = (0..6).collect();
        let tris = ear_clip_avoiding(&poly, &pos, &HashSet::new()).unwrap();
        assert_eq!(tris.len(), 4);
        let mut area = 0.0;
        for t in &tris {
            let a = triangle_area_vector(
                &pos[t[0] as usize],
                &pos[t[1] as usize],
                &pos[t[2] as usize],
            );
            assert!(a.z > 0.0, "{t:?}");
            area += a.z;
        }
        assert!((area - 3.0).abs() < 1e-12);
    }

    #[test]
    fn perimeter_of_a_unit_square_is_4() {
        let sq =
            [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(x, y)| Point3::new(x, y, 0.0));
        assert!((perimeter(&sq) - 4.0).abs() < 1e-15);
    }

    #[test]
    fn a_corner_whose_diagonal_is_an_edge_is_not_cut() {
        // the unit square 0-1-2-3; the mesh has the edge 0-2 already
        let pos =
            [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(x, y)| Point3::new(x, y, 0.0));
        let edges = HashSet::from([(0, 2)]);
        let tris = ear_clip_avoiding(&[0, 1, 2, 3], &pos, &edges).unwrap();
        assert_eq!(tris.len(), 2);
        assert!(
            tris.iter().all(|t| t.contains(&1) && t.contains(&3)),
            "{tris:?}"
        );
        // both diagonals taken: no way to close it without a third triangle
        let edges = HashSet::from([(0, 2), (1, 3)]);
        assert_eq!(ear_clip_avoiding(&[0, 1, 2, 3], &pos, &edges), None);
    }

    #[test]
    fn a_walk_through_a_vertex_twice_is_two_cycles() {
        // two triangles touching at vertex 0 (a bow-tie): one walk, split
        let mut cycles = boundary_cycles(&[[0, 1, 2], [0, 3, 4]]);
        for c in &mut cycles {
            let i = c.iter().position(|&v| v == 0).unwrap();
            c.rotate_left(i);
        }
        cycles.sort();
        assert_eq!(cycles, vec![vec![0, 1, 2], vec![0, 3, 4]]);
    }
}

/// Generated leaflets (height fields over a grid with triangles removed at
/// random: holes that touch each other, the rim or themselves at one
/// vertex, holes whose loop has a chord that is an edge of the mesh) keep,
/// once their holes are filled, every edge to at most two triangles, one
/// orientation, and their vertices.
#[cfg(test)]
mod properties {
    use crate::repair::{RepairOptions, repair_tri_mesh_with};
    use crate::shapes::grid_disk;
    use crate::{TriMesh, topology::connected_components};
    use petgraph::unionfind::UnionFind;
    use proptest::prelude::*;
    use std::collections::HashMap;

    /// Triangles connected through shared edges: one piece.
    fn edge_connected(tris: &[[u32; 3]]) -> bool {
        let mut uf = UnionFind::<usize>::new(tris.len());
        let mut first: HashMap<(u32, u32), usize> = HashMap::new();
        for (t, tri) in tris.iter().enumerate() {
            for i in 0..3 {
                let (a, b) = (tri[i], tri[(i + 1) % 3]);
                if let Some(&u) = first.get(&(a.min(b), a.max(b))) {
                    uf.union(t, u);
                } else {
                    first.insert((a.min(b), a.max(b)), t);
                }
            }
        }
        (0..tris.len()).all(|t| uf.equiv(t, 0))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn filling_holes_never_makes_a_non_manifold_edge(
            nx in 5usize..10, ny in 5usize..10, amp in 0.0f64..1.5, tilt in -0.2f64..0.2,
            drop in proptest::collection::vec(0usize..1000, 1..12),
        ) {
            let mut g = grid_disk(nx, ny);
            for p in &mut g.positions {
                p.z = amp * (0.7 * p.x).sin() * (0.5 * p.y).cos() + tilt * p.x * p.y;
            }
            let n = g.triangles.len();
            let tris: Vec<[u32; 3]> = g
                .triangles
                .iter()
                .enumerate()
                .filter(|(t, _)| !drop.iter().any(|d| d % n == *t))
                .map(|(_, t)| *t)
                .collect();
            prop_assume!(edge_connected(&tris));
            let leaflet = TriMesh::new(g.positions.clone(), tris);
            let options = RepairOptions {
                fill_holes: Some(f64::INFINITY),
                fill_holes_fraction: Some(0.25),
                ..Default::default()
            };
            let (out, r) = repair_tri_mesh_with(&leaflet, &options).unwrap();
            let mut count: HashMap<(u32, u32), usize> = HashMap::new();
            let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
            for t in &out.triangles {
                for i in 0..3 {
                    let (a, b) = (t[i], t[(i + 1) % 3]);
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                    *directed.entry((a, b)).or_default() += 1;
                }
            }
            prop_assert!(count.values().all(|&c| c <= 2), "{:?}", count.iter().find(|e| *e.1 > 2));
            prop_assert!(directed.values().all(|&c| c == 1), "inconsistent orientation");
            prop_assert_eq!(connected_components(out.num_vertices(), &out.triangles).count, 1);
            if r.non_manifold_vertices_split == 0 {
                // the vertices are the input's used ones, in order
                let mut used = vec![false; leaflet.num_vertices()];
                for t in &leaflet.triangles {
                    for &v in t {
                        used[v as usize] = true;
                    }
                }
                let kept: Vec<_> = (0..used.len()).filter(|&v| used[v]).map(|v| leaflet.positions[v]).collect();
                prop_assert_eq!(&out.positions, &kept);
            }
            // every loop left but the rim is too long to be a hole or was
            // left open, counted
            let cycles = super::boundary_cycles(&out.triangles);
            let per: Vec<f64> = cycles
                .iter()
                .map(|c| super::perimeter(&c.iter().map(|&v| out.positions[v as usize]).collect::<Vec<_>>()))
                .collect();
            let rim = per.iter().copied().fold(0.0, f64::max);
            let long = per.iter().filter(|&&p| p > 0.25 * rim).count();
            prop_assert_eq!(cycles.len(), long + r.holes_left_open, "{:?}", per);
            // when the input's only long loop is the rim and every shorter
            // one was closed, no pinch is left to split (a long hole that
            // touches the rim at one vertex stays open and is split there,
            // joining the rim's loop in the output)
            let input_per: Vec<f64> = super::boundary_cycles(&leaflet.triangles)
                .iter()
                .map(|c| super::perimeter(&c.iter().map(|&v| leaflet.positions[v as usize]).collect::<Vec<_>>()))
                .collect();
            let input_rim = input_per.iter().copied().fold(0.0, f64::max);
            let input_long = input_per.iter().filter(|&&p| p > 0.25 * input_rim).count();
            if input_long == 1 && r.holes_left_open == 0 {
                prop_assert_eq!(r.non_manifold_vertices_split, 0);
                prop_assert_eq!(crate::topology::euler_characteristic(&out), 1);
            }
        }
    }
}
