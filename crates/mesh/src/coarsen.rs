//! Graded interior coarsening of a tet mesh by edge collapses.
//!
//! Isosurface stuffing ([`crate::stuffing`]) makes tets of one size
//! everywhere; [`coarsen_interior`] keeps the boundary surface exactly as it
//! is and removes interior vertices where a desired edge length (a function
//! of position, e.g. growing with the distance from the boundary) asks for
//! longer edges than the mesh has. Every step is a half-edge collapse
//! `u -> v`: the interior vertex `u` disappears, its tets are given to its
//! neighbour `v` (which keeps its position), and the tets around the edge
//! `uv` disappear. A collapse is made only when it keeps the mesh a valid,
//! positively oriented triangulation of the same domain (link condition,
//! orientation) with dihedral angles within bounds.

use crate::geometry::{check_finite, tet_signed_volume};
use crate::{Fields, MeshError, TetMesh};
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

/// A tet changed by a collapse must have a signed volume above
/// `MIN_VOLUME_REL * l^3`, `l` its longest edge (a regular tet has
/// `l^3 / (6 sqrt 2) ~ 0.118 l^3`).
const MIN_VOLUME_REL: f64 = 1e-9;

/// Options of [`coarsen_interior`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoarsenOptions {
    /// Smallest dihedral angle any tet changed by a collapse may have,
    /// degrees (default 10). Finite, `>= 0` and `< max_dihedral_deg`.
    pub min_dihedral_deg: f64,
    /// Largest dihedral angle any tet changed by a collapse may have,
    /// degrees (default 165). Finite and `<= 180`.
    pub max_dihedral_deg: f64,
    /// Passes over the edges (default 8), at least 1. Each pass collapses
    /// the edges that were candidates when it began; the edges that
    /// collapses create are looked at in the next pass.
    pub max_passes: usize,
}

impl Default for CoarsenOptions {
    /// Dihedral angles within `[10, 165]` degrees, at most 8 passes.
    fn default() -> Self {
        CoarsenOptions {
            min_dihedral_deg: 10.0,
            max_dihedral_deg: 165.0,
            max_passes: 8,
        }
    }
}

impl CoarsenOptions {
    /// `InvalidArgument` naming the bad option, see the field docs.
    fn check(&self) -> Result<(), MeshError> {
        let (lo, hi) = (self.min_dihedral_deg, self.max_dihedral_deg);
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(MeshError::InvalidArgument(format!(
                "coarsening needs finite dihedral angle bounds, got min_dihedral_deg = {lo}, \
                 max_dihedral_deg = {hi}"
            )));
        }
        if !(0.0 <= lo && lo < hi && hi <= 180.0) {
            return Err(MeshError::InvalidArgument(format!(
                "coarsening needs 0 <= min_dihedral_deg < max_dihedral_deg <= 180, got \
                 min_dihedral_deg = {lo}, max_dihedral_deg = {hi}"
            )));
        }
        if self.max_passes == 0 {
            return Err(MeshError::InvalidArgument(
                "coarsening needs max_passes >= 1, got 0".to_string(),
            ));
        }
        Ok(())
    }
}

/// What coarsening did.
#[derive(Debug, Clone, PartialEq)]
pub struct Coarsened {
    /// The coarsened mesh: the used input vertices only (in their input
    /// order, positions copied exactly), tets in the order of the input tets
    /// they come from, no point or cell data.
    pub mesh: TetMesh,
    /// Number of edge collapses made, i.e. of interior vertices removed (the
    /// result has the input's used vertices minus this many).
    pub collapses: usize,
    /// Number of passes over the edges run; the last one collapsed nothing
    /// unless `max_passes` was reached.
    pub passes: usize,
}

/// Collapses interior edges shorter than `target(midpoint)` (a desired edge
/// length in mm, e.g. growing with the distance from the boundary), keeping
/// the boundary surface exactly.
///
/// Rules:
/// - The input is first given positive orientation ([`TetMesh::orient`]).
///   Boundary vertices (those of faces used by exactly one tet, as in
///   [`tet_boundary`](crate::topology::tet_boundary)) never move and are
///   never removed, and the boundary triangles (vertices, orientation,
///   positions) are exactly those of the input.
/// - Only an interior vertex `u` is collapsed onto a neighbour `v` (`u`
///   removed, `v` keeps its position, interior or boundary); an edge with
///   both ends on the boundary is never collapsed. When both ends are
///   interior, the direction whose changed tets have the larger smallest
///   `sin` of a dihedral angle is taken.
/// - An edge is a candidate when `|uv| < target((u + v) / 2)`; a target
///   that is not finite or not positive means "do not collapse here".
///   Within a pass, candidates are tried shortest relative to their target
///   first (`|uv| / target`, ties by vertex ids); edges that collapses
///   create wait for the next pass. Passes repeat until one collapses
///   nothing or `max_passes` have run.
/// - `u -> v` is made only when the link condition holds (the vertices,
///   edges and triangles common to the links of `u` and `v` are exactly the
///   link of the edge `uv`, so the collapse keeps the mesh a manifold of the
///   same topology), and every tet containing `u` but not `v` stays
///   positively oriented after `u` is replaced by `v` (signed volume
///   `> 1e-9 l^3`, `l` its longest edge) with all its dihedral angles within
///   `[min_dihedral_deg, max_dihedral_deg]`. Tets containing both `u` and
///   `v` disappear. Tets that no collapse changes are kept as they are
///   (their angles are not checked).
///
/// `target` bounds the edges that are collapsed, not the edges a collapse
/// creates (`v` inherits the edges of `u`): on BCC lattices the edges of the
/// result range up to about twice the target (95th percentile), their
/// median at the target where it grades away from the boundary.
///
/// The result is deterministic for a given input (candidates are ordered
/// totally; `target` is evaluated in parallel but only once per edge and
/// pass; the collapse qualities of a few thousand candidates at a time are
/// computed in parallel and computed again, in order, for a candidate that
/// a collapse before it touched, so the result is that of trying the
/// candidates one by one). Vertices that no tet uses are dropped, the point data and cell
/// data of the input are dropped (a collapse has no meaningful value for a
/// merged vertex or a removed tet; resample them on the result).
///
/// # Errors
/// [`MeshError::InvalidArgument`] for bad options (see [`CoarsenOptions`]),
/// [`MeshError::NonFiniteCoordinate`], [`MeshError::IndexOutOfRange`],
/// [`MeshError::RepeatedVertex`] (a tet using a vertex twice) and
/// [`MeshError::NonManifoldFace`] (the smallest face shared by more than two
/// tets, as [`tet_boundary`](crate::topology::tet_boundary) reports it) for
/// an input that is not a tet mesh this can work on.
pub fn coarsen_interior(
    mesh: &TetMesh,
    target: &(dyn Fn(&Point3<f64>) -> f64 + Sync),
    opts: &CoarsenOptions,
) -> Result<Coarsened, MeshError> {
    coarsen_in_chunks(mesh, target, opts, QUALITY_CHUNK)
}

/// Candidates whose collapse qualities are computed together, in parallel,
/// before they are tried one by one (see [`coarsen_in_chunks`]).
const QUALITY_CHUNK: usize = 2048;

/// [`coarsen_interior`] with the collapse qualities of `chunk` candidates
/// at a time computed in parallel from the state before the chunk, then
/// the candidates tried in order: a quality is computed again, in order,
/// for a candidate with an end that a collapse of the chunk touched (a
/// corner of a tet of the collapsed vertex), since only then can it have
/// changed. The result is that of trying the candidates one by one
/// (`chunk = 1`), bit for bit.
fn coarsen_in_chunks(
    mesh: &TetMesh,
    target: &(dyn Fn(&Point3<f64>) -> f64 + Sync),
    opts: &CoarsenOptions,
    chunk: usize,
) -> Result<Coarsened, MeshError> {
    opts.check()?;
    check_finite(&mesh.positions)?;
    let mut oriented = TetMesh::new(mesh.positions.clone(), mesh.tets.clone());
    oriented.orient()?;
    for (t, tet) in oriented.tets.iter().enumerate() {
        for i in 0..4 {
            if tet[i + 1..].contains(&tet[i]) {
                return Err(MeshError::RepeatedVertex {
                    element: t,
                    index: tet[i],
                });
            }
        }
    }
    let TetMesh {
        positions, tets, ..
    } = oriented;

    let mut work = Work::new(&positions, tets, opts)?;
    let mut collapses = 0;
    let mut passes = 0;
    while passes < opts.max_passes {
        passes += 1;
        let candidates = work.candidates(target);
        let mut made = 0;
        for part in candidates.chunks(chunk.max(1)) {
            let qualities = work.qualities(part);
            work.new_chunk();
            for (&(_, a, b), &q) in part.iter().zip(&qualities) {
                if work.try_collapse(a, b, q) {
                    made += 1;
                }
            }
        }
        collapses += made;
        if made == 0 {
            break;
        }
    }

    let kept: Vec<[u32; 4]> = work
        .tets
        .iter()
        .zip(&work.alive)
        .filter(|(_, alive)| **alive)
        .map(|(t, _)| *t)
        .collect();
    let compact = crate::reindex::compact_vertices(&positions, &Fields::new(), &kept)?;
    Ok(Coarsened {
        mesh: TetMesh::new(compact.positions, compact.elements),
        collapses,
        passes,
    })
}

/// The mesh being coarsened: positions never change; tets are killed
/// (`alive`) or have a corner replaced in place; `vt` lists the live tets
/// of every vertex.
struct Work<'a> {
    pos: &'a [Point3<f64>],
    tets: Vec<[u32; 4]>,
    alive: Vec<bool>,
    vt: Vec<Vec<u32>>,
    boundary: Vec<bool>,
    removed: Vec<bool>,
    /// Per vertex: `chunk` when a collapse of the current chunk touched it
    /// (its precomputed collapse qualities may be stale).
    touched: Vec<u32>,
    chunk: u32,
    /// `cos(max_dihedral)`: a dihedral cosine must be `>=` this.
    cos_lo: f64,
    /// `cos(min_dihedral)`: a dihedral cosine must be `<=` this.
    cos_hi: f64,
    // scratch for the link condition: per-vertex stamps (ring, in Lk(u),
    // counted) compared with `epoch`, edge and triangle lists
    stamp: [Vec<u32>; 3],
    epoch: u32,
    se: [Vec<[u32; 2]>; 3],
    st: [Vec<[u32; 3]>; 2],
}

impl<'a> Work<'a> {
    /// The incidence lists and the boundary vertices of `tets` (in range,
    /// no repeated vertex).
    ///
    /// # Errors
    /// [`MeshError::NonManifoldFace`] (the smallest such face).
    fn new(
        pos: &'a [Point3<f64>],
        tets: Vec<[u32; 4]>,
        opts: &CoarsenOptions,
    ) -> Result<Self, MeshError> {
        let n = pos.len();
        let mut count = vec![0u32; n];
        for t in &tets {
            for &v in t {
                count[v as usize] += 1;
            }
        }
        let mut vt: Vec<Vec<u32>> = count
            .iter()
            .map(|&c| Vec::with_capacity(c as usize))
            .collect();
        for (i, t) in tets.iter().enumerate() {
            for &v in t {
                vt[v as usize].push(i as u32);
            }
        }
        let boundary = boundary_vertices(&tets, &vt)?;
        Ok(Work {
            pos,
            alive: vec![true; tets.len()],
            tets,
            vt,
            boundary,
            removed: vec![false; n],
            touched: vec![0; n],
            chunk: 0,
            cos_lo: opts.max_dihedral_deg.to_radians().cos(),
            cos_hi: opts.min_dihedral_deg.to_radians().cos(),
            stamp: [vec![0; n], vec![0; n], vec![0; n]],
            epoch: 0,
            se: Default::default(),
            st: Default::default(),
        })
    }

    /// The edges with at least one interior end and `|ab| < target(mid)`,
    /// as `(|ab| / target, a, b)` with `a < b`, sorted.
    fn candidates(&self, target: &(dyn Fn(&Point3<f64>) -> f64 + Sync)) -> Vec<(f64, u32, u32)> {
        let mut out: Vec<(f64, u32, u32)> = (0..self.pos.len())
            .into_par_iter()
            .flat_map_iter(|a| {
                let mut nb: Vec<u32> = Vec::new();
                if !self.removed[a] {
                    for &t in &self.vt[a] {
                        nb.extend(self.tets[t as usize].iter().filter(|&&w| {
                            w as usize > a && !(self.boundary[a] && self.boundary[w as usize])
                        }));
                    }
                    nb.sort_unstable();
                    nb.dedup();
                }
                let pa = self.pos[a];
                nb.into_iter().filter_map(move |b| {
                    let pb = self.pos[b as usize];
                    let len = (pb - pa).norm();
                    let t = target(&nalgebra::center(&pa, &pb));
                    (t.is_finite() && t > 0.0 && len < t).then_some((len / t, a as u32, b))
                })
            })
            .collect();
        out.par_sort_unstable_by(|x, y| {
            x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2))
        });
        out
    }

    /// The qualities `(a -> b, b -> a)` of each candidate edge `ab`
    /// ([`Work::quality`]), in parallel.
    fn qualities(&self, part: &[(f64, u32, u32)]) -> Vec<(Option<f64>, Option<f64>)> {
        part.par_iter()
            .with_min_len(64)
            .map(|&(_, a, b)| {
                if self.removed[a as usize] || self.removed[b as usize] {
                    (None, None)
                } else {
                    (self.quality(a, b), self.quality(b, a))
                }
            })
            .collect()
    }

    /// Starts a chunk: no vertex is touched yet.
    fn new_chunk(&mut self) {
        if self.chunk == u32::MAX {
            self.touched.fill(0);
            self.chunk = 0;
        }
        self.chunk += 1;
    }

    /// [`Work::collapse_quality`] of `u -> v`, `None` for a boundary `u`.
    fn quality(&self, u: u32, v: u32) -> Option<f64> {
        if self.boundary[u as usize] {
            None
        } else {
            self.collapse_quality(u, v)
        }
    }

    /// Collapses the edge `ab` in the better admissible direction, if any;
    /// `pre` are its qualities from the start of the chunk, used when no
    /// collapse of the chunk has touched `a` or `b`.
    fn try_collapse(&mut self, a: u32, b: u32, pre: (Option<f64>, Option<f64>)) -> bool {
        if self.removed[a as usize] || self.removed[b as usize] {
            return false;
        }
        if !self.vt[a as usize]
            .iter()
            .any(|&t| self.tets[t as usize].contains(&b))
        {
            return false;
        }
        let fresh =
            self.touched[a as usize] != self.chunk && self.touched[b as usize] != self.chunk;
        let (qa, qb) = if fresh {
            pre
        } else {
            (self.quality(a, b), self.quality(b, a))
        };
        let (u, v) = match (qa, qb) {
            (Some(x), Some(y)) if y > x => (b, a),
            (Some(_), _) => (a, b),
            (None, Some(_)) => (b, a),
            (None, None) => return false,
        };
        if !self.link_condition(u, v) {
            return false;
        }
        self.collapse(u, v);
        true
    }

    /// The smallest `sin^2` of a dihedral angle of the tets containing `u`
    /// but not `v` after replacing `u` by `v`, or `None` when one of them
    /// is not positive (relative volume) or has an angle out of bounds.
    fn collapse_quality(&self, u: u32, v: u32) -> Option<f64> {
        let pv = self.pos[v as usize];
        let mut q = f64::INFINITY;
        for &t in &self.vt[u as usize] {
            let tet = self.tets[t as usize];
            if tet.contains(&v) {
                continue;
            }
            let mut p = [pv; 4];
            for k in 0..4 {
                if tet[k] != u {
                    p[k] = self.pos[tet[k] as usize];
                }
            }
            let vol = tet_signed_volume(&p[0], &p[1], &p[2], &p[3]);
            if vol.is_nan() || vol <= 0.0 {
                return None;
            }
            let mut l2: f64 = 0.0;
            for i in 0..4 {
                for j in i + 1..4 {
                    l2 = l2.max((p[j] - p[i]).norm_squared());
                }
            }
            if vol <= MIN_VOLUME_REL * l2 * l2.sqrt() {
                return None;
            }
            for c in dihedral_cosines(&p) {
                if !(c >= self.cos_lo && c <= self.cos_hi) {
                    return None;
                }
                q = q.min(1.0 - c * c);
            }
        }
        Some(q)
    }

    /// The link condition of the edge `uv`: `Lk(u) ∩ Lk(v) = Lk(uv)`, as
    /// sets of vertices, edges and triangles (`Lk(x)`: the faces opposite
    /// `x` in its tets with their edges and vertices; `Lk(uv)`: the edges
    /// opposite `uv` in its tets with their vertices). Because `u` is
    /// interior, this is the condition for a manifold with boundary too.
    ///
    /// `Lk(uv)` always lies in both links, so the vertex sets are equal when
    /// the common vertices are as many as the ring `Lk(uv)`'s; then every
    /// common edge or triangle has its vertices on the ring, and only those
    /// are collected and compared (`Lk(uv)` has no triangles).
    fn link_condition(&mut self, u: u32, v: u32) -> bool {
        if self.epoch == u32::MAX {
            for s in &mut self.stamp {
                s.fill(0);
            }
            self.epoch = 0;
        }
        self.epoch += 1;
        let e = self.epoch;
        let [ring, in_u, seen] = &mut self.stamp;
        let [eu, ev, euv] = &mut self.se;
        let [tu, tv] = &mut self.st;
        euv.clear();
        let mut ring_len = 0;
        for &t in &self.vt[u as usize] {
            let tet = self.tets[t as usize];
            for &w in &tet {
                if w != u && w != v {
                    in_u[w as usize] = e;
                }
            }
            if tet.contains(&v) {
                let mut o = tet.into_iter().filter(|&w| w != u && w != v);
                let (p, q) = (o.next().unwrap_or(u), o.next().unwrap_or(u));
                for w in [p, q] {
                    if ring[w as usize] != e {
                        ring[w as usize] = e;
                        ring_len += 1;
                    }
                }
                euv.push([p.min(q), p.max(q)]);
            }
        }
        let mut common_len = 0;
        for &t in &self.vt[v as usize] {
            for &w in &self.tets[t as usize] {
                if w != u && w != v && in_u[w as usize] == e && seen[w as usize] != e {
                    seen[w as usize] = e;
                    common_len += 1;
                }
            }
        }
        if common_len != ring_len {
            return false;
        }
        for (x, edges, tris) in [(u, &mut *eu, &mut *tu), (v, &mut *ev, &mut *tv)] {
            edges.clear();
            tris.clear();
            for &t in &self.vt[x as usize] {
                let mut f = [0u32; 3];
                let mut k = 0;
                for &w in &self.tets[t as usize] {
                    if w != x {
                        f[k] = w;
                        k += 1;
                    }
                }
                let on = [
                    ring[f[0] as usize] == e,
                    ring[f[1] as usize] == e,
                    ring[f[2] as usize] == e,
                ];
                for (i, j) in [(0, 1), (0, 2), (1, 2)] {
                    if on[i] && on[j] {
                        edges.push([f[i].min(f[j]), f[i].max(f[j])]);
                    }
                }
                if on == [true; 3] {
                    f.sort_unstable();
                    tris.push(f);
                }
            }
        }
        for x in [&mut *eu, &mut *ev, &mut *euv] {
            x.sort_unstable();
            x.dedup();
        }
        for x in [&mut *tu, &mut *tv] {
            x.sort_unstable();
            x.dedup();
        }
        common(eu, ev) == euv.len() && common(tu, tv) == 0
    }

    /// Replaces `u` by `v` in the tets of `u`; the tets containing both die.
    /// Every corner of the tets of `u` is marked touched: their incidence
    /// lists or tets change, nothing else does.
    fn collapse(&mut self, u: u32, v: u32) {
        let tets_u = std::mem::take(&mut self.vt[u as usize]);
        for &t in &tets_u {
            for &w in &self.tets[t as usize] {
                self.touched[w as usize] = self.chunk;
            }
        }
        for &t in &tets_u {
            let tet = &mut self.tets[t as usize];
            if tet.contains(&v) {
                self.alive[t as usize] = false;
                for &w in tet.iter() {
                    if w != u {
                        let list = &mut self.vt[w as usize];
                        if let Some(i) = list.iter().position(|&s| s == t) {
                            list.swap_remove(i);
                        }
                    }
                }
            } else {
                for w in tet.iter_mut() {
                    if *w == u {
                        *w = v;
                    }
                }
                self.vt[v as usize].push(t);
            }
        }
        self.removed[u as usize] = true;
    }
}

/// The vertices of the faces used by exactly one tet: the boundary of
/// [`tet_boundary`](crate::topology::tet_boundary) (`to_volume`), found
/// without a global sort. Every face
/// is listed by its smallest vertex `a` from `a`'s tets (`vt`), in parallel
/// over `a`.
///
/// # Errors
/// [`MeshError::NonManifoldFace`] for the smallest face shared by more than
/// two tets, as [`tet_boundary`](crate::topology::tet_boundary) reports it.
fn boundary_vertices(tets: &[[u32; 4]], vt: &[Vec<u32>]) -> Result<Vec<bool>, MeshError> {
    let per_vertex: Vec<Result<Vec<[u32; 2]>, MeshError>> = (0..vt.len())
        .into_par_iter()
        .map(|a| {
            let a = a as u32;
            let mut faces: Vec<[u32; 2]> = Vec::new();
            for &t in &vt[a as usize] {
                let tet = tets[t as usize];
                for k in 0..4 {
                    let mut f = [0u32; 3];
                    let mut i = 0;
                    for (j, &w) in tet.iter().enumerate() {
                        if j != k {
                            f[i] = w;
                            i += 1;
                        }
                    }
                    f.sort_unstable();
                    if f[0] == a {
                        faces.push([f[1], f[2]]);
                    }
                }
            }
            faces.sort_unstable();
            let mut once = Vec::new();
            let mut i = 0;
            while i < faces.len() {
                let mut j = i + 1;
                while j < faces.len() && faces[j] == faces[i] {
                    j += 1;
                }
                match j - i {
                    1 => once.push(faces[i]),
                    2 => {}
                    n => {
                        return Err(MeshError::NonManifoldFace {
                            face: [a, faces[i][0], faces[i][1]],
                            tets: n,
                        });
                    }
                }
                i = j;
            }
            Ok(once)
        })
        .collect();
    let mut boundary = vec![false; vt.len()];
    for (a, faces) in per_vertex.into_iter().enumerate() {
        for [b, c] in faces? {
            boundary[a] = true;
            boundary[b as usize] = true;
            boundary[c as usize] = true;
        }
    }
    Ok(boundary)
}

/// Number of elements common to two sorted, deduplicated slices.
fn common<T: Ord>(a: &[T], b: &[T]) -> usize {
    let (mut i, mut j, mut n) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                n += 1;
                i += 1;
                j += 1;
            }
        }
    }
    n
}

/// Cosines of the six interior dihedral angles of the positively oriented
/// tet `p`, at the edges `01, 02, 03, 12, 13, 23`: the formula of
/// [`crate::geometry::tet_dihedral_angles`] (`-n_a · n_b` for the outward
/// unit normals of the two faces at the edge) without its allocations and
/// `acos`, the outward normals taken from the corner order.
fn dihedral_cosines(p: &[Point3<f64>; 4]) -> [f64; 6] {
    let [a, b, c, d] = *p;
    // outward (for a positive tet) normals of the faces opposite a, b, c, d
    let n: [Vector3<f64>; 4] = [
        (c - b).cross(&(d - b)),
        (d - a).cross(&(c - a)),
        (b - a).cross(&(d - a)),
        (c - a).cross(&(b - a)),
    ];
    let len = [n[0].norm(), n[1].norm(), n[2].norm(), n[3].norm()];
    // edge ij lies on the faces opposite the two other corners
    let cos = |k: usize, l: usize| -n[k].dot(&n[l]) / (len[k] * len[l]);
    [
        cos(2, 3),
        cos(1, 3),
        cos(1, 2),
        cos(0, 3),
        cos(0, 2),
        cos(0, 1),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bcc::BccLattice;
    use crate::geometry::{tet_dihedral_angles, total_volume};
    use crate::test_meshes::{SplitMix, tet_grid};
    use crate::topology::tet_boundary;
    use proptest::prelude::*;
    use std::collections::HashMap;

    /// A compacted BCC block of `n` cubes of side `h`.
    fn bcc_block(n: [usize; 3], h: f64, o: [f64; 3]) -> TetMesh {
        let m = BccLattice::new(Point3::new(o[0], o[1], o[2]), h, n)
            .unwrap()
            .to_tet_mesh();
        let c = crate::reindex::compact_vertices(&m.positions, &m.point_data, &m.tets).unwrap();
        TetMesh::new(c.positions, c.elements)
    }

    /// The boundary triangles as position triples (bit patterns), each
    /// rotated to start at its smallest corner (keeping the orientation),
    /// sorted.
    fn boundary_key(m: &TetMesh) -> Vec<[[u64; 3]; 3]> {
        let b = tet_boundary(m).unwrap();
        let mut out: Vec<[[u64; 3]; 3]> = b
            .surface
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|v| {
                    let q = b.surface.positions[v as usize];
                    [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()]
                });
                let k = (0..3).min_by_key(|&k| p[k]).unwrap();
                [p[k], p[(k + 1) % 3], p[(k + 2) % 3]]
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Smallest and largest dihedral angle of the mesh, degrees.
    fn angle_range(m: &TetMesh) -> (f64, f64) {
        let mut r = (f64::INFINITY, f64::NEG_INFINITY);
        for t in 0..m.tets.len() {
            for a in tet_dihedral_angles(&m.tet_points(t)) {
                r = (r.0.min(a.to_degrees()), r.1.max(a.to_degrees()));
            }
        }
        r
    }

    /// Every interior vertex's link is a triangulated sphere and every
    /// boundary vertex's a disk: each link edge in two link triangles
    /// (interior) or one or two (boundary), Euler characteristic 2 or 1.
    fn check_vertex_links(m: &TetMesh) -> Result<(), String> {
        let b = tet_boundary(m).map_err(|e| e.to_string())?;
        let mut on_boundary = vec![false; m.positions.len()];
        for &v in &b.to_volume {
            on_boundary[v as usize] = true;
        }
        let mut faces: Vec<Vec<[u32; 3]>> = vec![Vec::new(); m.positions.len()];
        for t in &m.tets {
            for k in 0..4 {
                let mut f = [0u32; 3];
                let mut i = 0;
                for (j, &w) in t.iter().enumerate() {
                    if j != k {
                        f[i] = w;
                        i += 1;
                    }
                }
                f.sort_unstable();
                faces[t[k] as usize].push(f);
            }
        }
        for (v, f) in faces.iter().enumerate() {
            let mut edges: HashMap<[u32; 2], usize> = HashMap::new();
            let mut verts: Vec<u32> = Vec::new();
            for t in f {
                for (i, j) in [(0, 1), (0, 2), (1, 2)] {
                    *edges.entry([t[i], t[j]]).or_default() += 1;
                }
                verts.extend_from_slice(t);
            }
            verts.sort_unstable();
            verts.dedup();
            let chi = verts.len() as i64 - edges.len() as i64 + f.len() as i64;
            let (want_chi, ok_edges) = if on_boundary[v] {
                (1, edges.values().all(|&c| c == 1 || c == 2))
            } else {
                (2, edges.values().all(|&c| c == 2))
            };
            if chi != want_chi || !ok_edges {
                return Err(format!(
                    "vertex {v} (boundary {}) has a link with chi {chi}",
                    on_boundary[v]
                ));
            }
        }
        Ok(())
    }

    /// All the invariants of a coarsening of `input` (positive, in-bounds
    /// angles assumed for the input).
    fn check_invariants(
        input: &TetMesh,
        out: &Coarsened,
        opts: &CoarsenOptions,
    ) -> Result<(), String> {
        let m = &out.mesh;
        let (v0, v1) = (total_volume(input), total_volume(m));
        if (v1 - v0).abs() > 1e-9 * v0.abs() {
            return Err(format!("volume {v0} -> {v1}"));
        }
        if boundary_key(input) != boundary_key(m) {
            return Err("the boundary changed".into());
        }
        if m.positions.len() + out.collapses != input.positions.len() {
            return Err(format!(
                "{} vertices after {} collapses of {}",
                m.positions.len(),
                out.collapses,
                input.positions.len()
            ));
        }
        for t in 0..m.tets.len() {
            let p = m.tet_points(t);
            if tet_signed_volume(&p[0], &p[1], &p[2], &p[3]) <= 0.0 {
                return Err(format!("tet {t} is not positive"));
            }
        }
        let (lo, hi) = angle_range(m);
        if lo < opts.min_dihedral_deg - 1e-7 || hi > opts.max_dihedral_deg + 1e-7 {
            return Err(format!("dihedral angles {lo}..{hi}"));
        }
        m.validate().map_err(|e| e.to_string())?;
        crate::stuffing::check_closed_manifold(m).map_err(|e| e.to_string())?;
        check_vertex_links(m)
    }

    #[test]
    fn a_bcc_block_with_a_constant_target_loses_most_interior_tets() {
        let h = 1.0;
        let input = bcc_block([10, 10, 10], h, [0.0; 3]);
        let opts = CoarsenOptions::default();
        let start = std::time::Instant::now();
        let out = coarsen_interior(&input, &|_: &Point3<f64>| 2.5 * h, &opts).unwrap();
        let (lo, hi) = angle_range(&out.mesh);
        eprintln!(
            "bcc 10^3: {} -> {} tets, {} -> {} vertices, {} collapses in {} passes, angles {lo:.2}..{hi:.2} deg, {:?}",
            input.tets.len(),
            out.mesh.tets.len(),
            input.positions.len(),
            out.mesh.positions.len(),
            out.collapses,
            out.passes,
            start.elapsed()
        );
        assert!(
            (out.mesh.tets.len() as f64) < 0.6 * input.tets.len() as f64,
            "{} of {} tets left",
            out.mesh.tets.len(),
            input.tets.len()
        );
        check_invariants(&input, &out, &opts).unwrap();
        // deterministic
        let again = coarsen_interior(&input, &|_: &Point3<f64>| 2.5 * h, &opts).unwrap();
        assert_eq!(out, again);
    }

    #[test]
    fn a_target_of_zero_or_invalid_changes_nothing() {
        let input = bcc_block([4, 3, 5], 0.7, [1.0, -2.0, 3.0]);
        let opts = CoarsenOptions::default();
        for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let out = coarsen_interior(&input, &|_: &Point3<f64>| t, &opts).unwrap();
            assert_eq!(out.mesh, input, "target {t}");
            assert_eq!((out.collapses, out.passes), (0, 1));
        }
    }

    #[test]
    fn mixed_orientation_grids_are_oriented_and_coarsened() {
        for five in [false, true] {
            let mut input = tet_grid([5, 4, 6], five, [0.5, 0.0, -1.0]);
            let out = coarsen_interior(&input, &|_: &Point3<f64>| 3.0, &CoarsenOptions::default())
                .unwrap();
            input.orient().unwrap();
            assert!(out.collapses > 0 && out.mesh.tets.len() < input.tets.len());
            check_invariants(&input, &out, &CoarsenOptions::default()).unwrap();
        }
    }

    #[test]
    fn tighter_angle_bounds_are_respected() {
        let input = bcc_block([6, 6, 6], 1.0, [0.0; 3]);
        let opts = CoarsenOptions {
            min_dihedral_deg: 30.0,
            max_dihedral_deg: 130.0,
            max_passes: 3,
        };
        let out = coarsen_interior(&input, &|_: &Point3<f64>| 4.0, &opts).unwrap();
        assert!(out.passes <= 3);
        check_invariants(&input, &out, &opts).unwrap();
        let loose =
            coarsen_interior(&input, &|_: &Point3<f64>| 4.0, &CoarsenOptions::default()).unwrap();
        assert!(loose.collapses >= out.collapses);
    }

    #[test]
    fn bad_options_are_rejected() {
        let m = bcc_block([2, 2, 2], 1.0, [0.0; 3]);
        let d = CoarsenOptions::default();
        let cases = [
            (
                CoarsenOptions {
                    min_dihedral_deg: f64::NAN,
                    ..d
                },
                "finite",
            ),
            (
                CoarsenOptions {
                    max_dihedral_deg: f64::INFINITY,
                    ..d
                },
                "finite",
            ),
            (
                CoarsenOptions {
                    min_dihedral_deg: 100.0,
                    max_dihedral_deg: 90.0,
                    ..d
                },
                "min_dihedral_deg < max_dihedral_deg",
            ),
            (
                CoarsenOptions {
                    min_dihedral_deg: -1.0,
                    ..d
                },
                "0 <= min_dihedral_deg",
            ),
            (
                CoarsenOptions {
                    max_dihedral_deg: 181.0,
                    ..d
                },
                "<= 180",
            ),
            (CoarsenOptions { max_passes: 0, ..d }, "max_passes >= 1"),
        ];
        for (opts, msg) in cases {
            match coarsen_interior(&m, &|_: &Point3<f64>| 1.0, &opts) {
                Err(MeshError::InvalidArgument(s)) => assert!(s.contains(msg), "{s}"),
                other => panic!("{opts:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn bad_meshes_are_rejected() {
        let p = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(0.0, 0.0, -1.0),
            Point3::new(1.0, 1.0, 1.0),
        ];
        let f = |_: &Point3<f64>| 1.0;
        let o = CoarsenOptions::default();
        // three tets on the face (0, 1, 2)
        let m = TetMesh::new(p.clone(), vec![[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]]);
        assert!(matches!(
            coarsen_interior(&m, &f, &o),
            Err(MeshError::NonManifoldFace {
                face: [0, 1, 2],
                tets: 3
            })
        ));
        let m = TetMesh::new(p.clone(), vec![[0, 1, 2, 1]]);
        assert!(matches!(
            coarsen_interior(&m, &f, &o),
            Err(MeshError::RepeatedVertex {
                element: 0,
                index: 1
            })
        ));
        let m = TetMesh::new(p.clone(), vec![[0, 1, 2, 9]]);
        assert!(matches!(
            coarsen_interior(&m, &f, &o),
            Err(MeshError::IndexOutOfRange { .. })
        ));
        let mut q = p.clone();
        q[3].x = f64::NAN;
        let m = TetMesh::new(q, vec![[0, 1, 2, 3]]);
        assert!(matches!(
            coarsen_interior(&m, &f, &o),
            Err(MeshError::NonFiniteCoordinate { .. })
        ));
        // no tets: nothing to do, no vertices kept
        let out = coarsen_interior(&TetMesh::new(p, vec![]), &f, &o).unwrap();
        assert!(out.mesh.positions.is_empty() && out.mesh.tets.is_empty());
    }

    #[test]
    fn the_boundary_vertices_are_those_of_tet_boundary() {
        let mut meshes = vec![
            bcc_block([3, 4, 2], 1.0, [0.0; 3]),
            tet_grid([3, 2, 4], true, [0.0; 3]),
            tet_grid([2, 3, 3], false, [0.0; 3]),
        ];
        let out = coarsen_interior(
            &meshes[0],
            &|_: &Point3<f64>| 3.0,
            &CoarsenOptions::default(),
        );
        meshes.push(out.unwrap().mesh);
        for m in meshes {
            let w = Work::new(&m.positions, m.tets.clone(), &CoarsenOptions::default()).unwrap();
            let mine: Vec<u32> = (0..m.positions.len() as u32)
                .filter(|&v| w.boundary[v as usize])
                .collect();
            assert_eq!(mine, tet_boundary(&m).unwrap().to_volume);
        }
    }

    #[test]
    fn point_and_cell_data_are_dropped() {
        let mut m = bcc_block([3, 3, 3], 1.0, [0.0; 3]);
        let n = m.positions.len();
        m.add_point_field(crate::Field::scalars("s", vec![1.0; n]))
            .unwrap();
        let out = coarsen_interior(&m, &|_: &Point3<f64>| 2.0, &CoarsenOptions::default()).unwrap();
        assert!(out.mesh.point_data.is_empty() && out.mesh.cell_data.is_empty());
    }

    #[test]
    fn the_link_condition_compares_vertices_edges_and_triangles() {
        let pos = vec![Point3::origin(); 8];
        let [u, v, a, b, c, d, x, y] = [0u32, 1, 2, 3, 4, 5, 6, 7];
        let opts = CoarsenOptions::default();
        let holds = |tets: Vec<[u32; 4]>| {
            let mut w = Work::new(&pos, tets, &opts).unwrap();
            let l = w.link_condition(u, v);
            assert_eq!(l, w.link_condition(v, u));
            l
        };
        // the edge uv with the ring a b c d around it, a tet on either side
        let ring = vec![[u, v, a, b], [u, v, b, c], [u, v, c, d], [u, v, d, a]];
        let mut fine = ring.clone();
        fine.extend([[u, a, b, x], [v, c, d, y]]);
        assert!(holds(fine));
        // x is a neighbour of both u and v, but not in the link of uv
        let mut vertex = ring.clone();
        vertex.extend([[u, a, b, x], [v, c, d, x]]);
        assert!(!holds(vertex));
        // the edge ac is in both links (u a c x, v a c y), not in Lk(uv)
        let mut edge = ring;
        edge.extend([[u, a, c, x], [v, a, c, y]]);
        assert!(!holds(edge));
        // the triangle abc is opposite both u and v; its edges are all in
        // Lk(uv) = the ring a b c
        let tri = vec![
            [u, v, a, b],
            [u, v, b, c],
            [u, v, c, a],
            [u, a, b, c],
            [v, a, b, c],
        ];
        assert!(!holds(tri));
    }

    #[test]
    fn dihedral_cosines_match_tet_dihedral_angles() {
        let mut rng = SplitMix(7);
        let mut n = 0;
        while n < 500 {
            let mut p = [Point3::origin(); 4];
            for q in &mut p {
                *q = Point3::new(rng.sym(2.0), rng.sym(2.0), rng.sym(2.0));
            }
            if tet_signed_volume(&p[0], &p[1], &p[2], &p[3]) < 1e-3 {
                continue;
            }
            n += 1;
            let c = dihedral_cosines(&p);
            let a = tet_dihedral_angles(&p);
            for k in 0..6 {
                assert!((c[k].clamp(-1.0, 1.0).acos() - a[k]).abs() < 1e-9, "{p:?}");
            }
        }
    }

    /// Distance from `p` to the boundary of the box `[lo, hi]` (inside).
    fn box_depth(p: &Point3<f64>, lo: &Point3<f64>, hi: &Point3<f64>) -> f64 {
        (0..3)
            .map(|i| (p[i] - lo[i]).min(hi[i] - p[i]))
            .fold(f64::INFINITY, f64::min)
            .max(0.0)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Constant or graded targets keep the boundary, the volume, the
        /// orientation, the angle bounds and the manifold structure.
        #[test]
        fn coarsening_keeps_the_invariants(
            n in prop::array::uniform3(2usize..7),
            h in 0.2f64..3.0,
            o in prop::array::uniform3(-5.0f64..5.0),
            scale in 0.5f64..4.0,
            grade in 0.0f64..2.0,
            graded in any::<bool>(),
            min_deg in 0.0f64..20.0,
            max_deg in 150.0f64..180.0,
            passes in 1usize..10,
        ) {
            let input = bcc_block(n, h, o);
            let lo = Point3::new(o[0], o[1], o[2]);
            let hi = lo + Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64) * h;
            let target = move |p: &Point3<f64>| {
                if graded {
                    h * (1.0 + grade * box_depth(p, &lo, &hi) / h)
                } else {
                    scale * h
                }
            };
            let opts = CoarsenOptions {
                min_dihedral_deg: min_deg,
                max_dihedral_deg: max_deg,
                max_passes: passes,
            };
            let out = coarsen_interior(&input, &target, &opts).unwrap();
            prop_assert!(out.passes <= passes);
            if let Err(e) = check_invariants(&input, &out, &opts) {
                prop_assert!(false, "{}", e);
            }
        }

        /// Qualities computed a chunk at a time in parallel give the mesh
        /// of trying the candidates one by one, bit for bit, whatever the
        /// chunk size.
        #[test]
        fn chunked_qualities_give_the_sequential_result(
            n in prop::array::uniform3(2usize..7),
            h in 0.2f64..3.0,
            grade in 0.0f64..2.0,
            chunk in 2usize..300,
        ) {
            let input = bcc_block(n, h, [0.0; 3]);
            let hi = Point3::new(n[0] as f64, n[1] as f64, n[2] as f64) * h;
            let target = move |p: &Point3<f64>| {
                h * (1.0 + grade * box_depth(p, &Point3::origin(), &hi) / h)
            };
            let opts = CoarsenOptions::default();
            let one = coarsen_in_chunks(&input, &target, &opts, 1).unwrap();
            let many = coarsen_in_chunks(&input, &target, &opts, chunk).unwrap();
            prop_assert_eq!(one.collapses, many.collapses);
            prop_assert_eq!(one.passes, many.passes);
            prop_assert_eq!(&one.mesh.tets, &many.mesh.tets);
            prop_assert_eq!(&one.mesh.positions, &many.mesh.positions);
        }
    }
}
