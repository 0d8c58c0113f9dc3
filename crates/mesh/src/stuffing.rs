//! Isosurface stuffing (Labelle & Shewchuk 2007; ALGORITHMS 2.8): a tet
//! mesh of the domain `{x : f(x) < 0}` of an implicit function, cut from
//! the [`BccLattice`] ([`stuff`]).
//!
//! 1. [`cut_and_warp`] finds the cut points and warps the lattice:
//! - a lattice edge `(v, w)` with `f(v) f(w) < 0` has one cut point, the
//!   root of `f` on it (Illinois regula falsi to `1e-12` of the edge);
//! - a vertex `v` is *violated* when a cut point `c` on one of its edges `e`
//!   lies within `alpha_e |e|` of it (`alpha_long` for the black-black and
//!   red-red edges, of length `h`; `alpha_short` for the red-black edges, of
//!   length `sqrt(3)/2 h`); it moves to its nearest violating cut point and
//!   its value becomes 0 (on the surface). With `alpha < 1/2` a cut point
//!   violates at most one end of its edge, so vertices warp independently;
//!   cut points on edges of warped vertices are dropped.
//!
//! 2. [`fill`] replaces every lattice tet by the part of it inside the
//!    domain. With the signs of its corners after warping (`-` inside, `0`
//!    on the surface, `+` outside) that part is the convex hull of its `-`
//!    and `0` corners and the cut points of its `-+` edges: nothing (no `-`
//!    corner: a tet with four `0` corners is a sliver lying in the surface,
//!    left out), the whole tet (no `+` corner), a tet (one `-` corner), a
//!    pyramid (`--0+`), or a triangular prism (`--++`, `---+`). A pyramid
//!    is split into 2 tets and a prism into 3 by the *smallest-vertex rule*:
//!    every quadrilateral face is split by the diagonal through its
//!    smallest vertex (lattice vertices by id before cut points, cut points
//!    by their edge). The rule depends on the face alone, so two tets
//!    sharing a face split it alike (the mesh is conforming), and it never
//!    chooses the three diagonals of a prism cyclically (Dompierre et al.
//!    1999), so every prism splits into tets.
//! 3. [`stuff`] resolves the pinches of the boundary (where the domain is
//!    thinner than the lattice resolves, the cut can touch itself at a
//!    vertex or an edge: [`crate::pinch::resolve_pinches`] splits those
//!    vertices, or opens what splitting cannot), then keeps the largest
//!    connected component (or all of them) and reports the others.
//!
//! The paper's `alpha_long = 0.24999`, `alpha_short = 0.41189` bound its
//! dihedral angles to `[10.7, 164.8]` degrees for smooth surfaces resolved
//! by the lattice; the tests measure the angles this implementation gives.

use crate::bcc::BccLattice;
use crate::geometry::tet_signed_volume;
use crate::{Fields, MeshError, TetMesh};
use nalgebra::Point3;
use rayon::prelude::*;

/// Warp parameter of the long edges (black-black, red-red).
pub const ALPHA_LONG: f64 = 0.24999;
/// Warp parameter of the short edges (red-black).
pub const ALPHA_SHORT: f64 = 0.41189;

/// An implicit domain `{x : f(x) < 0}`.
pub trait Implicit: Sync {
    /// `f(p)`: negative inside, positive outside.
    fn value(&self, p: &Point3<f64>) -> f64;
}

impl<F: Fn(&Point3<f64>) -> f64 + Sync> Implicit for F {
    fn value(&self, p: &Point3<f64>) -> f64 {
        self(p)
    }
}

/// The lattice after cutting and warping.
#[derive(Debug, Clone)]
pub struct Warped {
    /// Vertex positions (warped vertices moved onto the surface).
    pub positions: Vec<Point3<f64>>,
    /// `f` at the vertices, exactly 0 at warped ones.
    pub values: Vec<f64>,
    /// The edges whose ends have strictly opposite signs after warping, as
    /// sorted vertex pairs, in ascending order.
    pub cut_edges: Vec<(u32, u32)>,
    /// The cut point of each of `cut_edges`.
    pub cut_points: Vec<Point3<f64>>,
    /// Number of warped vertices.
    pub warped: usize,
}

impl Warped {
    /// Index in `cut_edges` of the cut edge `{a, b}`.
    pub fn cut_index(&self, a: u32, b: u32) -> Option<usize> {
        self.cut_edges.binary_search(&(a.min(b), a.max(b))).ok()
    }
}

/// The root of `f` on the segment `a -> b` (`f(a) f(b) < 0`).
fn root(f: &dyn Implicit, a: &Point3<f64>, fa: f64, b: &Point3<f64>, fb: f64) -> Point3<f64> {
    let (mut t0, mut f0, mut t1, mut f1) = (0.0, fa, 1.0, fb);
    let mut side = 0;
    for _ in 0..100 {
        let t = (t0 * f1 - t1 * f0) / (f1 - f0);
        let t = if t > t0 && t < t1 { t } else { 0.5 * (t0 + t1) };
        let ft = f.value(&(a + (b - a) * t));
        if ft == 0.0 || t1 - t0 < 1e-12 {
            return a + (b - a) * t;
        }
        if (ft < 0.0) == (f0 < 0.0) {
            t0 = t;
            f0 = ft;
            if side == -1 {
                f1 *= 0.5;
            }
            side = -1;
        } else {
            t1 = t;
            f1 = ft;
            if side == 1 {
                f0 *= 0.5;
            }
            side = 1;
        }
    }
    a + (b - a) * (0.5 * (t0 + t1))
}

/// Calls `visit(v, w, alpha)` for every edge of the lattice with its warp
/// parameter: black-black and red-red edges (`alpha_long`), then red-black
/// (`alpha_short`).
pub fn for_each_edge(l: &BccLattice, mut visit: impl FnMut(u32, u32, f64)) {
    let [nx, ny, nz] = l.n;
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let v = l.black(i, j, k);
                if i < nx {
                    visit(v, l.black(i + 1, j, k), ALPHA_LONG);
                }
                if j < ny {
                    visit(v, l.black(i, j + 1, k), ALPHA_LONG);
                }
                if k < nz {
                    visit(v, l.black(i, j, k + 1), ALPHA_LONG);
                }
            }
        }
    }
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let r = l.red(i, j, k);
                if i + 1 < nx {
                    visit(r, l.red(i + 1, j, k), ALPHA_LONG);
                }
                if j + 1 < ny {
                    visit(r, l.red(i, j + 1, k), ALPHA_LONG);
                }
                if k + 1 < nz {
                    visit(r, l.red(i, j, k + 1), ALPHA_LONG);
                }
                for c in 0..8 {
                    let b = l.black(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                    visit(r, b, ALPHA_SHORT);
                }
            }
        }
    }
}

/// The edges of the lattice with their warp parameters `(v, w, alpha)`, in
/// the order of [`for_each_edge`].
pub fn lattice_edges(l: &BccLattice) -> Vec<(u32, u32, f64)> {
    let mut e = Vec::new();
    for_each_edge(l, |v, w, a| e.push((v, w, a)));
    e
}

/// Cuts the lattice's edges with the surface `f = 0` and warps violated
/// vertices onto it.
///
/// # Errors
/// `InvalidArgument` when `f` is not finite at a lattice vertex.
pub fn cut_and_warp(l: &BccLattice, f: &dyn Implicit) -> Result<Warped, MeshError> {
    let mut positions = l.positions();
    let mut values: Vec<f64> = positions.iter().map(|p| f.value(p)).collect();
    if let Some(v) = values.iter().position(|x| !x.is_finite()) {
        return Err(MeshError::InvalidArgument(format!(
            "the implicit function is not finite at lattice vertex {v} ({:?})",
            positions[v]
        )));
    }
    // cut points of the lattice as it is, and the violations they cause
    let mut nearest: Vec<Option<(f64, Point3<f64>)>> = vec![None; positions.len()];
    let mut cuts: Vec<(u32, u32, Point3<f64>)> = Vec::new();
    for_each_edge(l, |v, w, alpha| {
        let (fv, fw) = (values[v as usize], values[w as usize]);
        if fv * fw >= 0.0 {
            return;
        }
        let (pv, pw) = (positions[v as usize], positions[w as usize]);
        let c = root(f, &pv, fv, &pw, fw);
        let len = (pw - pv).norm();
        for (x, px) in [(v, pv), (w, pw)] {
            let d = (c - px).norm();
            if d < alpha * len && nearest[x as usize].is_none_or(|(bd, _)| d < bd) {
                nearest[x as usize] = Some((d, c));
            }
        }
        cuts.push((v.min(w), v.max(w), c));
    });
    let mut warped = 0;
    for (x, n) in nearest.iter().enumerate() {
        if let Some((_, c)) = n {
            positions[x] = *c;
            values[x] = 0.0;
            warped += 1;
        }
    }
    cuts.retain(|&(v, w, _)| values[v as usize] * values[w as usize] < 0.0);
    cuts.sort_unstable_by_key(|&(v, w, _)| (v, w));
    Ok(Warped {
        positions,
        values,
        cut_edges: cuts.iter().map(|&(v, w, _)| (v, w)).collect(),
        cut_points: cuts.iter().map(|&(_, _, c)| c).collect(),
        warped,
    })
}

/// Splits the pyramid with apex `z` over the quadrilateral `q` (in cyclic
/// order) into two tets by the diagonal through `q`'s smallest vertex.
fn split_pyramid(z: u32, q: [u32; 4], out: &mut Vec<[u32; 4]>) {
    let m = (0..4).min_by_key(|&i| q[i]).unwrap_or(0);
    let (d0, d1) = (q[m], q[(m + 2) % 4]);
    out.push([z, d0, q[(m + 1) % 4], d1]);
    out.push([z, d0, d1, q[(m + 3) % 4]]);
}

/// Splits the triangular prism with end triangles `a`, `b` (lateral edges
/// `a[i] b[i]`) into three tets by the smallest-vertex rule.
fn split_prism(a: [u32; 3], b: [u32; 3], out: &mut Vec<[u32; 4]>) {
    let (mut a, mut b) = (a, b);
    let min_a = a.iter().copied().min().unwrap_or(u32::MAX);
    let min_b = b.iter().copied().min().unwrap_or(u32::MAX);
    if min_b < min_a {
        std::mem::swap(&mut a, &mut b);
    }
    let r = (0..3).min_by_key(|&i| a[i]).unwrap_or(0);
    let a = [a[r], a[(r + 1) % 3], a[(r + 2) % 3]];
    let b = [b[r], b[(r + 1) % 3], b[(r + 2) % 3]];
    // both quads at a[0] are split through it: the tet a0 b0 b1 b2, then the
    // pyramid a0 over the third quad a1 a2 b2 b1
    out.push([a[0], b[0], b[1], b[2]]);
    split_pyramid(a[0], [a[1], a[2], b[2], b[1]], out);
}

/// The part inside the domain of a lattice tet with corners `t` and corner
/// signs `s` (`-1` inside, `0` on the surface, `1` outside), as tets on the
/// output ids (lattice vertices keep their ids, the cut point of `{a, b}`
/// is `cut(a, b)`), appended to `out` in no particular orientation.
fn stencil(t: [u32; 4], s: [i8; 4], cut: impl Fn(u32, u32) -> u32, out: &mut Vec<[u32; 4]>) {
    let idx = |sign: i8| (0..4).filter(move |&i| s[i] == sign).map(|i| t[i]);
    let neg: Vec<u32> = idx(-1).collect();
    let zero: Vec<u32> = idx(0).collect();
    let pos: Vec<u32> = idx(1).collect();
    match (neg.len(), zero.len(), pos.len()) {
        (0, _, _) => {}
        (_, _, 0) => out.push(t),
        (1, _, _) => {
            let a = neg[0];
            let mut tet = [a; 4];
            let mut k = 1;
            for &z in &zero {
                tet[k] = z;
                k += 1;
            }
            for &p in &pos {
                tet[k] = cut(a, p);
                k += 1;
            }
            out.push(tet);
        }
        (2, 1, 1) => {
            let (a, b, p) = (neg[0], neg[1], pos[0]);
            split_pyramid(zero[0], [a, b, cut(b, p), cut(a, p)], out);
        }
        (2, 0, 2) => {
            let (a, b, p, q) = (neg[0], neg[1], pos[0], pos[1]);
            split_prism([a, cut(a, p), cut(a, q)], [b, cut(b, p), cut(b, q)], out);
        }
        (3, 0, 1) => {
            let p = pos[0];
            let [a, b, c] = [neg[0], neg[1], neg[2]];
            split_prism([a, b, c], [cut(a, p), cut(b, p), cut(c, p)], out);
        }
        _ => unreachable!("four corners"),
    }
}

/// The tets of the domain from a cut and warped lattice (step 2 of the
/// module doc), positively oriented, on the vertices `w.positions`
/// followed by `w.cut_points` (cut point `i` is vertex
/// `w.positions.len() + i`); unused vertices are not removed.
///
/// # Errors
/// `InvalidArgument` when `w` does not belong to `l`, or when a cut point a
/// tet needs is missing (both mean `w` was not made by [`cut_and_warp`]).
pub fn fill(l: &BccLattice, w: &Warped) -> Result<Vec<[u32; 4]>, MeshError> {
    let n = l.num_black() + l.num_red();
    if w.positions.len() != n || w.values.len() != n || w.cut_points.len() != w.cut_edges.len() {
        return Err(MeshError::InvalidArgument(format!(
            "the warped lattice has {} vertices, the lattice {n}",
            w.positions.len()
        )));
    }
    let sign = |v: u32| -> i8 {
        let x = w.values[v as usize];
        if x < 0.0 {
            -1
        } else if x > 0.0 {
            1
        } else {
            0
        }
    };
    let missing = std::sync::atomic::AtomicBool::new(false);
    let cut = |a: u32, b: u32| -> u32 {
        match w.cut_index(a, b) {
            Some(i) => (n + i) as u32,
            None => {
                missing.store(true, std::sync::atomic::Ordering::Relaxed);
                a
            }
        }
    };
    let slabs: Vec<Vec<[u32; 4]>> = (0..l.n[2])
        .into_par_iter()
        .map(|k| {
            let mut out = Vec::new();
            l.for_each_tet_in_slab(k, |t| {
                let s = t.map(sign);
                if s.iter().all(|&x| x > 0) {
                    return;
                }
                stencil(t, s, cut, &mut out);
            });
            out
        })
        .collect();
    if missing.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(MeshError::InvalidArgument(
            "a cut point is missing from the warped lattice".into(),
        ));
    }
    let point = |v: u32| {
        let v = v as usize;
        if v < n {
            w.positions[v]
        } else {
            w.cut_points[v - n]
        }
    };
    let mut tets: Vec<[u32; 4]> = slabs.into_iter().flatten().collect();
    tets.par_iter_mut().for_each(|t| {
        let p = t.map(point);
        if tet_signed_volume(&p[0], &p[1], &p[2], &p[3]) < 0.0 {
            t.swap(2, 3);
        }
    });
    Ok(tets)
}

/// A tet mesh of an implicit domain, see [`stuff`].
#[derive(Debug, Clone)]
pub struct Stuffed {
    /// The mesh: positively oriented tets, no unused vertices.
    pub mesh: TetMesh,
    /// Connected components (through shared vertices) of the domain's mesh.
    pub components: usize,
    /// Tet counts of the components left out, largest first (empty when
    /// all were kept).
    pub dropped_components: Vec<usize>,
    /// The background lattice.
    pub lattice: BccLattice,
    /// Lattice vertices warped onto the surface.
    pub warped: usize,
    /// What resolving the boundary's pinches did (before the components
    /// were chosen).
    pub pinches: crate::pinch::PinchRepair,
}

/// Isosurface stuffing of `{x : f(x) < 0}`: a lattice of cube side `h`
/// around the box `[min, max]` that must contain the domain, cut and warped
/// ([`cut_and_warp`]), filled ([`fill`]), its boundary's pinches resolved
/// ([`crate::pinch::resolve_pinches`]); the largest connected component
/// (most tets) is kept, or all when `keep_all_components`.
///
/// # Errors
/// `InvalidArgument` for a bad box or spacing, a lattice too large, or a
/// domain reaching the box's border; `Empty` when the domain has no tets
/// (nothing inside, or thinner than the lattice resolves); `Pinched` when
/// the boundary still touches itself after resolving; `NonManifoldEdge` /
/// `InvalidArgument` when the boundary is not a closed manifold otherwise
/// (not expected: the check guards the construction).
pub fn stuff(
    f: &dyn Implicit,
    min: Point3<f64>,
    max: Point3<f64>,
    h: f64,
    keep_all_components: bool,
) -> Result<Stuffed, MeshError> {
    let finite = |p: &Point3<f64>| p.coords.iter().all(|x| x.is_finite());
    if !(finite(&min) && finite(&max) && (0..3).all(|a| max[a] >= min[a])) {
        return Err(MeshError::InvalidArgument(format!(
            "the box to mesh must be finite with max >= min, got {min:?} .. {max:?}"
        )));
    }
    if !(h.is_finite() && h > 0.0) {
        return Err(MeshError::InvalidArgument(format!(
            "the element size must be finite and > 0, got {h}"
        )));
    }
    // cubes 1 ..= n - 2 have all their neighbours, so their tets cover them
    // completely; they cover [min - h, max + h]
    let mut n = [0usize; 3];
    for a in 0..3 {
        let cubes = ((max[a] - min[a]) / h).ceil() + 4.0;
        if cubes > 1e6 {
            return Err(MeshError::InvalidArgument(format!(
                "an element size of {h} is too small for a box {} long",
                max[a] - min[a]
            )));
        }
        n[a] = cubes as usize;
    }
    let origin = min - nalgebra::Vector3::repeat(2.0 * h);
    let lattice = BccLattice::new(origin, h, n)?;
    let w = cut_and_warp(&lattice, f)?;
    check_inside_box(&lattice, &w.values)?;
    let tets = fill(&lattice, &w)?;
    if tets.is_empty() {
        return Err(MeshError::Empty { what: "tets" });
    }
    let mut positions = w.positions.clone();
    positions.extend_from_slice(&w.cut_points);
    let compact = crate::reindex::compact_vertices(&positions, &Fields::new(), &tets)?;
    let (mut mesh, pinches) =
        crate::pinch::resolve_pinches(&TetMesh::new(compact.positions, compact.elements))?;
    let comps = crate::topology::connected_components(mesh.num_vertices(), &mesh.tets);
    let mut dropped = Vec::new();
    if comps.count > 1 && !keep_all_components {
        let keep = (0..comps.count)
            .max_by_key(|&c| (comps.element_counts[c], std::cmp::Reverse(c)))
            .unwrap_or(0) as u32;
        dropped = (0..comps.count)
            .filter(|&c| c as u32 != keep)
            .map(|c| comps.element_counts[c])
            .collect();
        dropped.sort_unstable_by(|a, b| b.cmp(a));
        let kept: Vec<[u32; 4]> = mesh
            .tets
            .iter()
            .zip(&comps.element_label)
            .filter(|&(_, &c)| c == keep)
            .map(|(t, _)| *t)
            .collect();
        let compact = crate::reindex::compact_vertices(&mesh.positions, &Fields::new(), &kept)?;
        mesh = TetMesh::new(compact.positions, compact.elements);
    }
    check_closed_manifold(&mesh)?;
    Ok(Stuffed {
        mesh,
        components: comps.count,
        dropped_components: dropped,
        lattice,
        warped: w.warped,
        pinches,
    })
}

/// An error when a lattice vertex in the two outer layers is inside (the
/// domain is not inside the box given to [`stuff`]).
fn check_inside_box(l: &BccLattice, values: &[f64]) -> Result<(), MeshError> {
    let [nx, ny, nz] = l.n;
    let outer_black = |i: usize, n: usize| i <= 1 || i + 1 >= n;
    let outer_red = |i: usize, n: usize| i == 0 || i + 1 == n;
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                if (outer_black(i, nx) || outer_black(j, ny) || outer_black(k, nz))
                    && values[l.black(i, j, k) as usize] < 0.0
                {
                    return Err(MeshError::InvalidArgument(format!(
                        "the domain reaches beyond the box to mesh (inside at {:?})",
                        l.origin + nalgebra::Vector3::new(i as f64, j as f64, k as f64) * l.h
                    )));
                }
            }
        }
    }
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if (outer_red(i, nx) || outer_red(j, ny) || outer_red(k, nz))
                    && values[l.red(i, j, k) as usize] < 0.0
                {
                    return Err(MeshError::InvalidArgument(
                        "the domain reaches beyond the box to mesh".into(),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// `Ok` when the boundary of `mesh` is a closed 2-manifold: every boundary
/// edge is shared by exactly two boundary triangles, and the boundary
/// triangles around every boundary vertex form a single fan (their edges
/// opposite the vertex one cycle).
///
/// # Errors
/// `NonManifoldFace` / `NonManifoldEdge`, or `InvalidArgument` naming a
/// boundary edge with one triangle or a pinched vertex.
pub fn check_closed_manifold(mesh: &TetMesh) -> Result<(), MeshError> {
    let b = crate::topology::tet_boundary(mesh)?;
    let s = &b.surface;
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(3 * s.triangles.len());
    for t in &s.triangles {
        for e in 0..3 {
            let (u, v) = (t[e], t[(e + 1) % 3]);
            edges.push((u.min(v), u.max(v)));
        }
    }
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        let (u, v) = edges[i];
        let (u, v) = (b.to_volume[u as usize], b.to_volume[v as usize]);
        match j - i {
            2 => {}
            1 => {
                return Err(MeshError::InvalidArgument(format!(
                    "the boundary is not closed at edge ({u}, {v})"
                )));
            }
            faces => return Err(MeshError::NonManifoldEdge { a: u, b: v, faces }),
        }
        i = j;
    }
    // the fan of every vertex: edges opposite it, a -> b, must form one cycle
    let mut fan: Vec<Vec<(u32, u32)>> = vec![Vec::new(); s.positions.len()];
    for t in &s.triangles {
        for c in 0..3 {
            fan[t[c] as usize].push((t[(c + 1) % 3], t[(c + 2) % 3]));
        }
    }
    for (v, f) in fan.iter().enumerate() {
        let Some(&(start, _)) = f.first() else {
            continue;
        };
        let mut at = start;
        let mut steps = 0;
        while let Some(&(_, next)) = f.iter().find(|e| e.0 == at) {
            at = next;
            steps += 1;
            if at == start || steps > f.len() {
                break;
            }
        }
        if at != start || steps != f.len() {
            let p = mesh.positions[b.to_volume[v] as usize];
            return Err(MeshError::InvalidArgument(format!(
                "the boundary is pinched at vertex {} ({:.2}, {:.2}, {:.2}) (its triangles form \
                 no single fan: the object touches itself there)",
                b.to_volume[v], p.x, p.y, p.z
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ball(c: [f64; 3], r: f64) -> impl Fn(&Point3<f64>) -> f64 + Sync {
        move |p: &Point3<f64>| {
            ((p.x - c[0]).powi(2) + (p.y - c[1]).powi(2) + (p.z - c[2]).powi(2)).sqrt() - r
        }
    }

    #[test]
    fn edges_are_the_lattice_edges() {
        let l = BccLattice::new(Point3::origin(), 1.0, [2, 3, 4]).unwrap();
        let e = lattice_edges(&l);
        let p = l.positions();
        let long = e.iter().filter(|x| x.2 == ALPHA_LONG).count();
        let short = e.iter().filter(|x| x.2 == ALPHA_SHORT).count();
        // black: 2*4*5 + 3*3*5 + 3*4*4 = 133; red: 1*3*4 + 2*2*4 + 2*3*3 = 46
        assert_eq!(long, 133 + 46);
        assert_eq!(short, 8 * 24);
        for &(v, w, a) in &e {
            let len = (p[v as usize] - p[w as usize]).norm();
            let want = if a == ALPHA_LONG {
                1.0
            } else {
                3f64.sqrt() / 2.0
            };
            assert!((len - want).abs() < 1e-12);
        }
        // every tet edge is a lattice edge
        let set: std::collections::HashSet<(u32, u32)> =
            e.iter().map(|&(v, w, _)| (v.min(w), v.max(w))).collect();
        for t in l.tets() {
            for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                assert!(set.contains(&(t[a].min(t[b]), t[a].max(t[b]))));
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// After warping: warped vertices lie on the sphere; every kept cut
        /// point is on the sphere, on its edge, and at least `alpha |e|`
        /// from both ends, whose signs are strictly opposite; a vertex whose
        /// edges are all uncut keeps its place.
        #[test]
        fn warping_follows_the_rules(
            c in prop::array::uniform3(3.0f64..5.0),
            r in 1.0f64..2.9,
        ) {
            let l = BccLattice::new(Point3::origin(), 0.7, [12, 12, 12]).unwrap();
            let f = ball(c, r);
            let w = cut_and_warp(&l, &f).unwrap();
            let orig = l.positions();
            let alpha: std::collections::HashMap<(u32, u32), f64> = lattice_edges(&l)
                .into_iter()
                .map(|(a, b, al)| ((a.min(b), a.max(b)), al))
                .collect();
            prop_assert!(w.warped > 0 && !w.cut_edges.is_empty());
            prop_assert!(w.cut_edges.windows(2).all(|e| e[0] < e[1]));
            for (x, p) in w.positions.iter().enumerate() {
                if w.values[x] == 0.0 {
                    prop_assert!(f(p).abs() < 1e-9, "warped vertex off the surface: {}", f(p));
                } else {
                    prop_assert_eq!(*p, orig[x]);
                    prop_assert_eq!(w.values[x], f(p));
                }
            }
            for (&(a, b), cp) in w.cut_edges.iter().zip(&w.cut_points) {
                let (pa, pb) = (orig[a as usize], orig[b as usize]);
                prop_assert!(w.values[a as usize] * w.values[b as usize] < 0.0);
                prop_assert!(f(cp).abs() < 1e-9);
                let len = (pb - pa).norm();
                let (da, db) = ((cp - pa).norm(), (cp - pb).norm());
                prop_assert!((da + db - len).abs() < 1e-9, "not on its edge");
                let al = alpha[&(a, b)];
                prop_assert!(da >= al * len - 1e-12 && db >= al * len - 1e-12);
            }
        }
    }

    #[test]
    fn a_nan_function_is_an_error() {
        let l = BccLattice::new(Point3::origin(), 1.0, [1, 1, 1]).unwrap();
        let f = |_: &Point3<f64>| f64::NAN;
        let e = cut_and_warp(&l, &f).unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
    }

    use crate::geometry::{tet_dihedral_angles, tet_signed_volume, total_volume};
    use crate::topology::{euler_characteristic, tet_boundary};

    /// Extreme dihedral angles of a tet mesh, degrees.
    fn angle_range(m: &TetMesh) -> (f64, f64) {
        let mut r = (180.0f64, 0.0f64);
        for t in 0..m.num_tets() {
            for a in tet_dihedral_angles(&m.tet_points(t)) {
                r = (r.0.min(a.to_degrees()), r.1.max(a.to_degrees()));
            }
        }
        r
    }

    /// The checks every stuffed mesh of a smooth closed surface must pass:
    /// valid (positive tets, conforming, one component, no unused
    /// vertices), a closed manifold boundary of Euler characteristic
    /// `chi` whose vertices all lie on the surface, interior vertices
    /// inside, dihedral angles within [10, 165] degrees.
    fn check_stuffed(s: &Stuffed, f: &dyn Implicit, chi: i64) -> Result<(), TestCaseError> {
        let m = &s.mesh;
        prop_assert!(m.validate().is_ok(), "{:?}", m.validate());
        for t in 0..m.num_tets() {
            let p = m.tet_points(t);
            prop_assert!(tet_signed_volume(&p[0], &p[1], &p[2], &p[3]) > 0.0);
        }
        prop_assert!(check_closed_manifold(m).is_ok());
        let b = tet_boundary(m).unwrap();
        prop_assert_eq!(euler_characteristic(&b.surface), chi);
        let mut on = vec![false; m.num_vertices()];
        for &v in &b.to_volume {
            on[v as usize] = true;
            let fv = f.value(&m.positions[v as usize]);
            prop_assert!(fv.abs() < 1e-9, "boundary vertex {v} off the surface: {fv}");
        }
        for (v, p) in m.positions.iter().enumerate() {
            if !on[v] {
                prop_assert!(f.value(p) < 0.0, "interior vertex {v} outside");
            }
        }
        let (lo, hi) = angle_range(m);
        prop_assert!(lo >= 10.0 && hi <= 165.0, "dihedral angles {lo} .. {hi}");
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Ellipsoids of random centre, radii and lattice spacing: a valid
        /// mesh (see `check_stuffed`) of the right volume; inscribed in a
        /// convex surface, it loses at most `10 h / r_min` percent.
        #[test]
        fn ellipsoids_are_stuffed_well(
            c in prop::array::uniform3(-1.0f64..1.0),
            r in prop::array::uniform3(1.5f64..4.0),
            h in 0.3f64..0.6,
        ) {
            let f = move |p: &Point3<f64>| {
                ((p.x - c[0]) / r[0]).powi(2)
                    + ((p.y - c[1]) / r[1]).powi(2)
                    + ((p.z - c[2]) / r[2]).powi(2)
                    - 1.0
            };
            let s = stuff(&f, Point3::new(-5.0, -5.0, -5.0), Point3::new(5.0, 5.0, 5.0), h, false)
                .unwrap();
            check_stuffed(&s, &f, 2)?;
            prop_assert_eq!(s.components, 1);
            prop_assert!(s.dropped_components.is_empty() && s.warped > 0);
            let exact = 4.0 / 3.0 * std::f64::consts::PI * r[0] * r[1] * r[2];
            let err = (total_volume(&s.mesh) / exact - 1.0) * 100.0;
            let rmin = r.iter().cloned().fold(f64::MAX, f64::min);
            prop_assert!(err <= 0.0 && -err <= 10.0 * h / rmin, "volume error {err} %");
        }

        /// A torus (tube radius 1.2 to 2, centre radius 3.5) gives a boundary
        /// of genus one.
        #[test]
        fn a_torus_has_genus_one(rt in 1.2f64..2.0, h in 0.3f64..0.5, z in -0.5f64..0.5) {
            let f = move |p: &Point3<f64>| {
                let q = (p.x * p.x + p.y * p.y).sqrt() - 3.5;
                (q * q + (p.z - z) * (p.z - z)).sqrt() - rt
            };
            let s = stuff(&f, Point3::new(-6.0, -6.0, -3.0), Point3::new(6.0, 6.0, 3.0), h, false)
                .unwrap();
            check_stuffed(&s, &f, 0)?;
            let exact = 2.0 * std::f64::consts::PI.powi(2) * 3.5 * rt * rt;
            let err = (total_volume(&s.mesh) / exact - 1.0).abs();
            prop_assert!(err < 0.03, "volume error {err}");
        }
    }

    fn two_balls(p: &Point3<f64>) -> f64 {
        let a = ((p.x + 3.0).powi(2) + p.y * p.y + p.z * p.z).sqrt() - 2.0;
        let b = ((p.x - 3.0).powi(2) + p.y * p.y + p.z * p.z).sqrt() - 1.0;
        a.min(b)
    }

    #[test]
    fn the_largest_component_is_kept_and_the_others_reported() {
        let (lo, hi) = (Point3::new(-6.0, -3.0, -3.0), Point3::new(5.0, 3.0, 3.0));
        let all = stuff(&two_balls, lo, hi, 0.4, true).unwrap();
        assert_eq!(all.components, 2);
        assert!(all.dropped_components.is_empty());
        let comps = crate::topology::connected_components(all.mesh.num_vertices(), &all.mesh.tets);
        assert_eq!(comps.count, 2);
        let mut counts = comps.element_counts.clone();
        counts.sort_unstable();
        let one = stuff(&two_balls, lo, hi, 0.4, false).unwrap();
        assert_eq!(one.components, 2);
        assert_eq!(one.dropped_components, vec![counts[0]]);
        assert_eq!(one.mesh.num_tets(), counts[1]);
        assert!(one.mesh.validate().is_ok());
        // the big ball (radius 2) is the one kept
        let c =
            one.mesh.positions.iter().map(|p| p.x).sum::<f64>() / one.mesh.num_vertices() as f64;
        assert!((c + 3.0).abs() < 0.1, "{c}");
    }

    #[test]
    fn bad_domains_and_boxes_are_errors() {
        let ball = |p: &Point3<f64>| p.coords.norm() - 2.0;
        let (lo, hi) = (Point3::new(-3.0, -3.0, -3.0), Point3::new(3.0, 3.0, 3.0));
        // nothing inside
        let none = |_: &Point3<f64>| 1.0;
        assert!(matches!(
            stuff(&none, lo, hi, 0.5, false),
            Err(MeshError::Empty { .. })
        ));
        // the domain is larger than the box
        let e = stuff(
            &ball,
            Point3::new(-1.0, -1.0, -1.0),
            Point3::new(1.0, 1.0, 1.0),
            0.25,
            false,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("beyond the box"), "{e}");
        for h in [0.0, -1.0, f64::NAN] {
            let e = stuff(&ball, lo, hi, h, false).unwrap_err().to_string();
            assert!(e.contains("element size"), "{e}");
        }
        let e = stuff(&ball, hi, lo, 0.5, false).unwrap_err().to_string();
        assert!(e.contains("max >= min"), "{e}");
        let e = stuff(&ball, lo, hi, 1e-9, false).unwrap_err().to_string();
        assert!(e.contains("too small"), "{e}");
    }

    #[test]
    fn non_manifold_boundaries_are_found() {
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let base = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
        ];
        let one = TetMesh::new(base.clone(), vec![[0, 1, 2, 3]]);
        assert!(check_closed_manifold(&one).is_ok());
        // two tets sharing the edge (0, 1) only
        let mut pos = base.clone();
        pos.extend([p(0.0, -1.0, 0.0), p(0.0, 0.0, -1.0)]);
        let edge = TetMesh::new(pos, vec![[0, 1, 2, 3], [0, 1, 5, 4]]);
        let e = check_closed_manifold(&edge).unwrap_err();
        assert!(
            matches!(
                e,
                MeshError::NonManifoldEdge {
                    a: 0,
                    b: 1,
                    faces: 4
                }
            ),
            "{e}"
        );
        // two tets sharing the vertex 0 only
        let mut pos = base;
        pos.extend([p(-1.0, 0.0, 0.0), p(0.0, -1.0, 0.0), p(0.0, 0.0, -1.0)]);
        let vertex = TetMesh::new(pos, vec![[0, 1, 2, 3], [0, 4, 6, 5]]);
        let e = check_closed_manifold(&vertex).unwrap_err().to_string();
        assert!(e.contains("pinched at vertex 0"), "{e}");
    }

    /// Every labelling of a prism splits into three tets filling it; a
    /// quadrilateral face is split through its smallest vertex.
    #[test]
    fn prisms_split_by_the_smallest_vertex() {
        let p = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.2, 1.0, 0.0),
            // the top is the bottom translated: planar quadrilaterals, so
            // every split has the prism's volume
            Point3::new(0.1, 0.2, 1.0),
            Point3::new(1.1, 0.2, 1.0),
            Point3::new(0.3, 1.2, 1.0),
        ];
        let exact = {
            let v = |a: usize, b: usize, c: usize, d: usize| {
                tet_signed_volume(&p[a], &p[b], &p[c], &p[d]).abs()
            };
            v(0, 1, 2, 3) + v(1, 2, 3, 4) + v(2, 3, 4, 5)
        };
        let mut perm: Vec<u32> = (0..6).collect();
        let mut seen = 0;
        // all 720 labellings (Heap's algorithm)
        let mut c = [0usize; 6];
        let mut check = |ids: &[u32]| {
            let at = |id: u32| p[ids.iter().position(|&x| x == id).unwrap()];
            let mut out = Vec::new();
            split_prism([ids[0], ids[1], ids[2]], [ids[3], ids[4], ids[5]], &mut out);
            assert_eq!(out.len(), 3);
            let vol: f64 = out
                .iter()
                .map(|t| tet_signed_volume(&at(t[0]), &at(t[1]), &at(t[2]), &at(t[3])).abs())
                .sum();
            assert!((vol - exact).abs() < 1e-12, "{ids:?}: {vol} vs {exact}");
            for t in &out {
                let v = tet_signed_volume(&at(t[0]), &at(t[1]), &at(t[2]), &at(t[3])).abs();
                assert!(v > 1e-3, "{ids:?}: a flat tet");
            }
            // every quadrilateral is split through its smallest vertex
            for quad in [
                [ids[0], ids[1], ids[4], ids[3]],
                [ids[1], ids[2], ids[5], ids[4]],
                [ids[2], ids[0], ids[3], ids[5]],
            ] {
                let m = (0..4).min_by_key(|&i| quad[i]).unwrap();
                let diag = (quad[m], quad[(m + 2) % 4]);
                assert!(
                    out.iter()
                        .any(|t| t.contains(&diag.0) && t.contains(&diag.1)),
                    "{ids:?}: diagonal {diag:?} missing"
                );
            }
            seen += 1;
        };
        check(&perm);
        let mut i = 0;
        while i < 6 {
            if c[i] < i {
                if i % 2 == 0 {
                    perm.swap(0, i);
                } else {
                    perm.swap(c[i], i);
                }
                check(&perm);
                c[i] += 1;
                i = 0;
            } else {
                c[i] = 0;
                i += 1;
            }
        }
        assert_eq!(seen, 720);
    }
}
