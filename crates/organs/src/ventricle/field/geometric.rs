//! The field's solver: conjugate gradients preconditioned by a matrix-free
//! geometric multigrid V-cycle.
//!
//! **Levels.** Level 0 is the field's grid (spacing `h`); level `l + 1` is
//! the grid of spacing `2^(l+1) h` over the same origin, classified and
//! discretized as the field's (its own crossings with S and H, the same
//! Gibou links, so every level is a symmetric M-matrix). No level stores a
//! matrix: row `i` of `A` is `d_i u_i - sum_m w_m u_m` over the unknown
//! grid neighbours `m` (`w = 1/2` for the lateral links of cap nodes, else
//! 1), with the diagonal `d_i` (which carries the boundary links) stored.
//! The first level with at most [`ALGEBRAIC_MAX`] unknowns is assembled and
//! handed to the algebraic [`Multigrid`] (Galerkin levels, dense coarsest
//! solve).
//!
//! **Smoother.** Red-black Gauss-Seidel: the unknowns are numbered red
//! (`i + j + k` even) first ([`colour_numbering`]), and every neighbour of a
//! red node is black, so each colour is updated in parallel from the other
//! one. The V-cycle smooths red then black before the coarse correction
//! and black then red after it, so it is symmetric.
//!
//! **Transfers.** `P` is trilinear interpolation from the coarse nodes
//! that are unknowns (a fine node's parents are the coarse nodes of its
//! cell's corners: weights `1` or `1/2` per axis), the restriction is
//! `P^T / 2`: for trilinear `P` in 3D, `P^T A_h P` is about twice the
//! operator rediscretized at `2h` (`8` fine nodes per coarse one, each row
//! scaled by `h^2` against `(2h)^2`), so `(P^T A_h P)^-1 P^T r` is
//! approximated by `A_{2h}^-1 (P^T r / 2)`.
//!
//! **Memory.** Per unknown of the field's grid: its box node (4 B), the
//! diagonal only where it is not the regular 6 (3 on the cap), and four
//! vectors and a half during the iteration (`x`, `r`, `p`, `z` and the
//! red residual: 36 B); the box-to-unknown numbers are the field's own
//! (shared with the gradients). The assembled matrix and Galerkin
//! hierarchy this replaces took about 330 B per unknown (geo2 at 0.5 mm:
//! `unfold ventricle` peaked at 1,950 MiB before, 471 to 527 MiB now;
//! docs/DESIGN-NOTES.md, "The field's solver is matrix-free").

use super::{Ctx, Grid, Link, UNKNOWN, all_crossings, classify, connected_unknowns};
use crate::OrganError;
use rayon::prelude::*;
use std::borrow::Cow;
use unfold_linalg::LinalgError;
use unfold_linalg::multigrid::{Multigrid, dot};

/// Rows per parallel task.
const CHUNK: usize = 8192;
/// A level with at most this many unknowns is solved by the algebraic multigrid.
const ALGEBRAIC_MAX: usize = 120_000;

/// Vectors over the unknowns of one level, split by colour.
pub(super) type Split = [Vec<f64>; 2];

/// One matrix-free level.
pub(super) struct Level<'a> {
    grid: Grid,
    /// Box node -> unknown number, the red unknowns first (`u32::MAX`: not
    /// an unknown); see [`colour_numbering`].
    number: Cow<'a, [u32]>,
    /// Number of red unknowns.
    n_red: usize,
    /// Colour -> its unknowns' box nodes, in unknown order.
    ids: [Vec<u32>; 2],
    diag: [Diagonal; 2],
    /// No unknown on a box face but the cap `k = 0`: neighbours need no
    /// bounds checks.
    padded: bool,
}

/// The diagonal of one colour's rows: `6` (all six links to unknowns), `3`
/// on the cap (`k = 0`: four half lateral links and one up), except at the
/// rows listed (those with a boundary link or a missing neighbour), whose
/// values are stored: a tenth of the memory and traffic of a full array.
struct Diagonal {
    /// Nodes with `k = 0` are the box ids below this.
    plane: usize,
    /// Positions (in the colour) of the listed rows, ascending.
    pos: Vec<u32>,
    val: Vec<f64>,
}

impl Diagonal {
    /// The diagonal `d` of the colour's rows at box nodes `ids`.
    fn new(plane: usize, ids: &[u32], d: &[f64]) -> Diagonal {
        let mut pos = Vec::new();
        let mut val = Vec::new();
        for (p, (&id, &v)) in ids.iter().zip(d).enumerate() {
            if v != Self::regular(plane, id as usize) {
                pos.push(p as u32);
                val.push(v);
            }
        }
        Diagonal { plane, pos, val }
    }

    #[inline]
    fn regular(plane: usize, id: usize) -> f64 {
        if id < plane { 3.0 } else { 6.0 }
    }

    /// The first listed row at or after position `start`.
    #[inline]
    fn cursor(&self, start: usize) -> usize {
        self.pos.partition_point(|&q| (q as usize) < start)
    }

    /// The diagonal of position `p` (box node `id`); `cur` from
    /// [`Diagonal::cursor`] and positions visited in ascending order.
    #[inline]
    fn at(&self, p: usize, id: usize, cur: &mut usize) -> f64 {
        match self.pos.get(*cur) {
            Some(&q) if q as usize == p => {
                *cur += 1;
                self.val[*cur - 1]
            }
            _ => Self::regular(self.plane, id),
        }
    }
}

/// The last level: the algebraic multigrid on its assembled matrix.
struct Bottom {
    /// Colour position -> row of the matrix.
    row: [Vec<u32>; 2],
    mg: Multigrid,
}

/// The hierarchy.
pub(super) struct Hierarchy<'a> {
    levels: Vec<Level<'a>>,
    bottom: Bottom,
}

#[inline]
fn colour(ijk: [usize; 3]) -> usize {
    (ijk[0] + ijk[1] + ijk[2]) & 1
}

/// Renumbers the unknowns of `index` (box node -> unknown, `u32::MAX`
/// elsewhere) red first (`i + j + k` even), each colour in box order;
/// returns the number of red unknowns.
pub(super) fn colour_numbering(grid: &Grid, index: &mut [u32]) -> usize {
    let mut next = [0u32; 2];
    for (id, q) in index.iter_mut().enumerate() {
        if *q != u32::MAX {
            let c = colour(grid.ijk(id));
            *q = next[c];
            next[c] += 1;
        }
    }
    let n_red = next[0];
    for (id, q) in index.iter_mut().enumerate() {
        if *q != u32::MAX && colour(grid.ijk(id)) == 1 {
            *q += n_red;
        }
    }
    n_red as usize
}

/// Unknown numbers in box order (the numbering `Ctx::assemble` and the
/// algebraic multigrid work in).
fn ascending_numbering(state: &[u8]) -> Vec<u32> {
    let mut next = 0u32;
    state
        .iter()
        .map(|&s| {
            if s == UNKNOWN {
                next += 1;
                next - 1
            } else {
                u32::MAX
            }
        })
        .collect()
}

impl<'a> Level<'a> {
    /// The level of a classified grid whose `ctx.index` is a
    /// [`colour_numbering`] with `n_red` red unknowns; `number` is that same
    /// numbering, kept by the level. With `with_rhs`, also the right-hand
    /// side (the boundary values' terms), from the same pass over the rows.
    fn new(
        ctx: &Ctx,
        number: Cow<'a, [u32]>,
        n_red: usize,
        with_rhs: bool,
    ) -> (Level<'a>, Option<Split>) {
        let g = *ctx.grid;
        let n = ctx.index.iter().filter(|&&q| q != u32::MAX).count();
        let mut ids: [Vec<u32>; 2] = [vec![0; n_red], vec![0; n - n_red]];
        let mut padded = true;
        for (id, &q) in ctx.index.iter().enumerate() {
            if q != u32::MAX {
                let ijk = g.ijk(id);
                padded &= ijk[0] > 0
                    && ijk[1] > 0
                    && ijk[0] + 1 < g.dims[0]
                    && ijk[1] + 1 < g.dims[1]
                    && ijk[2] + 1 < g.dims[2];
                let q = q as usize;
                if q < n_red {
                    ids[0][q] = id as u32;
                } else {
                    ids[1][q - n_red] = id as u32;
                }
            }
        }
        let plane = g.dims[0] * g.dims[1];
        let mut rhs: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        let diag = [0, 1].map(|c| {
            let rows = ids[c]
                .par_iter()
                .map(|&id| diagonal_and_rhs(ctx, id as usize));
            let d: Vec<f64> = if with_rhs {
                let d;
                (d, rhs[c]) = rows.unzip();
                d
            } else {
                rows.map(|(d, _)| d).collect()
            };
            Diagonal::new(plane, &ids[c], &d)
        });
        let level = Level {
            grid: g,
            number,
            n_red,
            ids,
            diag,
            padded,
        };
        (level, with_rhs.then_some(rhs))
    }

    /// The colour and the position in it of box node `id`'s unknown.
    #[inline]
    fn slot(&self, id: usize) -> Option<(usize, usize)> {
        let q = self.number[id] as usize;
        if q == u32::MAX as usize {
            None
        } else if q < self.n_red {
            Some((0, q))
        } else {
            Some((1, q - self.n_red))
        }
    }

    /// Offset of colour `c`'s unknown numbers.
    #[inline]
    fn offset(&self, c: usize) -> usize {
        if c == 0 { 0 } else { self.n_red }
    }

    pub(super) fn len(&self) -> usize {
        self.ids[0].len() + self.ids[1].len()
    }

    pub(super) fn zeros(&self) -> Split {
        [vec![0.0; self.ids[0].len()], vec![0.0; self.ids[1].len()]]
    }

    /// `sum_m w_m x[m]` over the unknown neighbours of box node `id` (all of
    /// the other colour).
    #[inline]
    fn gather(&self, id: usize, other: &[f64], off: usize) -> f64 {
        if self.padded {
            let g = &self.grid;
            let (sy, sz) = (g.dims[0], g.dims[0] * g.dims[1]);
            let v = |m: usize| self.val(m, other, off);
            let lateral = v(id - 1) + v(id + 1) + v(id - sy) + v(id + sy);
            return if id < sz {
                0.5 * lateral + v(id + sz)
            } else {
                lateral + v(id + sz) + v(id - sz)
            };
        }
        self.gather_checked(id, other, off)
    }

    #[inline]
    fn gather_checked(&self, id: usize, other: &[f64], off: usize) -> f64 {
        let g = &self.grid;
        let [i, j, k] = g.ijk(id);
        let lateral = if k == 0 { 0.5 } else { 1.0 };
        let mut s = 0.0;
        let (sx, sy, sz) = (1, g.dims[0], g.dims[0] * g.dims[1]);
        if i > 0 {
            s += lateral * self.val(id - sx, other, off);
        }
        if i + 1 < g.dims[0] {
            s += lateral * self.val(id + sx, other, off);
        }
        if j > 0 {
            s += lateral * self.val(id - sy, other, off);
        }
        if j + 1 < g.dims[1] {
            s += lateral * self.val(id + sy, other, off);
        }
        if k > 0 {
            s += self.val(id - sz, other, off);
        }
        if k + 1 < g.dims[2] {
            s += self.val(id + sz, other, off);
        }
        s
    }

    #[inline]
    fn val(&self, m: usize, other: &[f64], off: usize) -> f64 {
        let q = self.number[m];
        if q == u32::MAX {
            0.0
        } else {
            other[q as usize - off]
        }
    }

    /// `y = A x`.
    pub(super) fn apply(&self, x: &Split, y: &mut Split) {
        for c in 0..2 {
            let (own, other) = (&x[c], &x[1 - c]);
            y[c].par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(ch, out)| {
                    let start = ch * CHUNK;
                    let mut cur = self.diag[c].cursor(start);
                    for (t, o) in out.iter_mut().enumerate() {
                        let p = start + t;
                        let id = self.ids[c][p] as usize;
                        *o = self.diag[c].at(p, id, &mut cur) * own[p]
                            - self.gather(id, other, self.offset(1 - c));
                    }
                });
        }
    }

    /// `r = b - A x` after a smoothing sweep that ended with the black
    /// unknowns: their rows are solved exactly, so the black part is zero
    /// and only the red part is computed and returned.
    fn residual_after_black(&self, b: &Split, x: &Split) -> Vec<f64> {
        let (own, other) = (&x[0], &x[1]);
        let off = self.offset(1);
        let mut red = vec![0.0; self.n_red];
        red.par_chunks_mut(CHUNK).enumerate().for_each(|(ch, out)| {
            let start = ch * CHUNK;
            let mut cur = self.diag[0].cursor(start);
            for (t, o) in out.iter_mut().enumerate() {
                let p = start + t;
                let id = self.ids[0][p] as usize;
                *o = b[0][p] - self.diag[0].at(p, id, &mut cur) * own[p]
                    + self.gather(id, other, off);
            }
        });
        red
    }

    /// Red-black Gauss-Seidel: the colours in `order`.
    fn smooth(&self, b: &Split, x: &mut Split, order: [usize; 2]) {
        for c in order {
            let (lo, hi) = x.split_at_mut(1);
            let (own, other) = if c == 0 {
                (&mut lo[0], &hi[0])
            } else {
                (&mut hi[0], &lo[0])
            };
            own.par_chunks_mut(CHUNK).enumerate().for_each(|(ch, out)| {
                let start = ch * CHUNK;
                let mut cur = self.diag[c].cursor(start);
                for (t, o) in out.iter_mut().enumerate() {
                    let p = start + t;
                    let id = self.ids[c][p] as usize;
                    *o = (b[c][p] + self.gather(id, other, self.offset(1 - c)))
                        / self.diag[c].at(p, id, &mut cur);
                }
            });
        }
    }
}

/// The finite-volume row's diagonal and right-hand side at box node `id`
/// (as `Ctx::assemble`).
fn diagonal_and_rhs(ctx: &Ctx, id: usize) -> (f64, f64) {
    let g = ctx.grid;
    let cap = g.ijk(id)[2] == 0;
    let mut diag = 0.0;
    let mut b = 0.0;
    for a in [2usize, 1, 0] {
        for dir in [-1, 1] {
            let w = if cap && a != 2 { 0.5 } else { 1.0 };
            match ctx.link(id, a, dir) {
                Link::Node(_) => diag += w,
                Link::Boundary { theta, value } => {
                    diag += w / theta;
                    b += w / theta * value;
                }
                Link::Wall | Link::Mirror => {}
            }
        }
    }
    (diag, b)
}

/// Fine node `i` of a level and its coarse parents: `(I, weight)`.
#[inline]
fn parents(i: usize) -> ([usize; 2], [f64; 2], usize) {
    if i.is_multiple_of(2) {
        ([i / 2, 0], [1.0, 0.0], 1)
    } else {
        ([i / 2, i / 2 + 1], [0.5, 0.5], 2)
    }
}

impl<'a> Hierarchy<'a> {
    /// The levels of the classified grid `ctx` (its index a
    /// [`colour_numbering`] with `n_red` red unknowns) and of the grids at
    /// twice, four times, ... its spacing, until one has at most
    /// [`ALGEBRAIC_MAX`] unknowns: that one gets the algebraic multigrid.
    pub(super) fn new(
        ctx: &Ctx<'a>,
        n_red: usize,
        local: &[[f64; 3]],
        tris: &[[u32; 3]],
        rim2: &[[f64; 2]],
    ) -> Result<(Hierarchy<'a>, Split), OrganError> {
        Self::with_bottom(ctx, n_red, local, tris, rim2, ALGEBRAIC_MAX)
    }

    /// [`Hierarchy::new`] with the algebraic multigrid taking over at
    /// `algebraic_max` unknowns.
    fn with_bottom(
        ctx: &Ctx<'a>,
        n_red: usize,
        local: &[[f64; 3]],
        tris: &[[u32; 3]],
        rim2: &[[f64; 2]],
        algebraic_max: usize,
    ) -> Result<(Hierarchy<'a>, Split), OrganError> {
        let radius = ctx.radius;
        let (finest, rhs) = Level::new(ctx, Cow::Borrowed(ctx.index), n_red, true);
        let rhs = rhs.expect("asked for");
        let mut levels = vec![finest];
        let mut bottom_state: Option<Vec<u8>> = None;
        loop {
            let last = levels.last().expect("the finest level");
            if last.len() <= algebraic_max {
                let grid = last.grid;
                let state = bottom_state.as_deref().unwrap_or(ctx.state);
                let ascending = ascending_numbering(state);
                let crossings;
                let crossings_ref = if levels.len() == 1 {
                    ctx.crossings
                } else {
                    crossings = all_crossings(&grid, local, tris);
                    &crossings
                };
                let actx = Ctx {
                    grid: &grid,
                    state,
                    index: &ascending,
                    crossings: crossings_ref,
                    radius,
                };
                let (a, _) = actx.assemble()?;
                let row = [0, 1].map(|c| {
                    last.ids[c]
                        .iter()
                        .map(|&id| ascending[id as usize])
                        .collect::<Vec<u32>>()
                });
                let mg = Multigrid::for_grid(a, grid.dims, &ascending)?;
                return Ok((
                    Hierarchy {
                        levels,
                        bottom: Bottom { row, mg },
                    },
                    rhs,
                ));
            }
            let grid = Grid {
                h: 2.0 * last.grid.h,
                origin: last.grid.origin,
                dims: last.grid.dims.map(|d| d / 2 + 1),
            };
            let crossings = all_crossings(&grid, local, tris);
            let mut state = classify(&grid, &crossings[2], rim2, radius);
            let mut index = connected_unknowns(&grid, &mut state);
            let n_red = colour_numbering(&grid, &mut index);
            let cctx = Ctx {
                grid: &grid,
                state: &state,
                index: &index,
                crossings: &crossings,
                radius,
            };
            let (mut level, _) = Level::new(&cctx, Cow::Borrowed(&[]), n_red, false);
            level.number = Cow::Owned(index);
            levels.push(level);
            bottom_state = Some(state);
        }
    }

    /// The finest level.
    pub(super) fn finest(&self) -> &Level<'a> {
        &self.levels[0]
    }

    /// The finest level's box nodes per colour (unknown order); the rest is
    /// freed.
    pub(super) fn into_finest_ids(mut self) -> [Vec<u32>; 2] {
        std::mem::take(&mut self.levels[0].ids)
    }

    /// Levels: the geometric ones and those of the algebraic multigrid below
    /// the last.
    pub(super) fn depth(&self) -> usize {
        self.levels.len() - 1 + self.bottom.mg.levels()
    }

    /// `z = M^{-1} r`: one V-cycle.
    pub(super) fn apply(&self, r: &Split, z: &mut Split) {
        self.cycle(0, r, z);
    }

    fn cycle(&self, l: usize, b: &Split, x: &mut Split) {
        if l + 1 == self.levels.len() {
            let bot = &self.bottom;
            let n = self.levels[l].len();
            let mut bb = vec![0.0; n];
            for (rows, bc) in bot.row.iter().zip(b) {
                for (&row, &v) in rows.iter().zip(bc) {
                    bb[row as usize] = v;
                }
            }
            let mut xx = vec![0.0; n];
            bot.mg.apply(&bb, &mut xx);
            for (rows, xc) in bot.row.iter().zip(x.iter_mut()) {
                for (&row, v) in rows.iter().zip(xc.iter_mut()) {
                    *v = xx[row as usize];
                }
            }
            return;
        }
        let lev = &self.levels[l];
        let coarse = &self.levels[l + 1];
        x.iter_mut().for_each(|v| v.fill(0.0));
        lev.smooth(b, x, [0, 1]);
        let res = lev.residual_after_black(b, x);
        let bc = restrict(lev, coarse, &res);
        drop(res);
        let mut xc = coarse.zeros();
        self.cycle(l + 1, &bc, &mut xc);
        drop(bc);
        prolong_add(lev, coarse, &xc, x);
        lev.smooth(b, x, [1, 0]);
    }
}

/// `0.5 P^T r` (the Galerkin operator of trilinear `P` is about twice the
/// coarse grid's own) for `r` zero on the black fine unknowns, as
/// [`Level::residual_after_black`] leaves it (`red`: its red part): only
/// the red fine nodes are visited (`2 I + o` is red where `o` has an even number of nonzero
/// components).
fn restrict(fine: &Level<'_>, coarse: &Level<'_>, red: &[f64]) -> Split {
    let gf = &fine.grid;
    let gc = &coarse.grid;
    [0, 1].map(|c| {
        coarse.ids[c]
            .par_iter()
            .map(|&idc| {
                let [ci, cj, ck] = gc.ijk(idc as usize);
                let mut acc = 0.0;
                for ok in -1i64..=1 {
                    let k = 2 * ck as i64 + ok;
                    if k < 0 || k >= gf.dims[2] as i64 {
                        continue;
                    }
                    let wk = if ok == 0 { 1.0 } else { 0.5 };
                    for oj in -1i64..=1 {
                        let j = 2 * cj as i64 + oj;
                        if j < 0 || j >= gf.dims[1] as i64 {
                            continue;
                        }
                        let wj = if oj == 0 { wk } else { 0.5 * wk };
                        for oi in -1i64..=1 {
                            let i = 2 * ci as i64 + oi;
                            if i < 0 || i >= gf.dims[0] as i64 {
                                continue;
                            }
                            if (oi + oj + ok).rem_euclid(2) == 1 {
                                // a black fine node: its residual is zero
                                continue;
                            }
                            let w = if oi == 0 { wj } else { 0.5 * wj };
                            let ijk = [i as usize, j as usize, k as usize];
                            if let Some((_, q)) = fine.slot(gf.id(ijk[0], ijk[1], ijk[2])) {
                                acc += w * red[q];
                            }
                        }
                    }
                }
                0.5 * acc
            })
            .collect()
    })
}

/// `x += P xc`.
fn prolong_add(fine: &Level<'_>, coarse: &Level<'_>, xc: &Split, x: &mut Split) {
    let gf = &fine.grid;
    let gc = &coarse.grid;
    for (xs, ids) in x.iter_mut().zip(&fine.ids) {
        xs.par_chunks_mut(CHUNK).enumerate().for_each(|(ch, out)| {
            let start = ch * CHUNK;
            for (t, o) in out.iter_mut().enumerate() {
                let id = ids[start + t] as usize;
                let [i, j, k] = gf.ijk(id);
                let (pi, wi, ni) = parents(i);
                let (pj, wj, nj) = parents(j);
                let (pk, wk, nk) = parents(k);
                let mut s = 0.0;
                for a in 0..nk {
                    for b in 0..nj {
                        for e in 0..ni {
                            let ijk = [pi[e], pj[b], pk[a]];
                            if ijk[0] >= gc.dims[0] || ijk[1] >= gc.dims[1] || ijk[2] >= gc.dims[2]
                            {
                                continue;
                            }
                            if let Some((c, q)) = coarse.slot(gc.id(ijk[0], ijk[1], ijk[2])) {
                                s += wi[e] * wj[b] * wk[a] * xc[c][q];
                            }
                        }
                    }
                }
                *o += s;
            }
        });
    }
}

/// Preconditioned conjugate gradients on the finest level from `x = 0`
/// (`r` holds `b` on entry, the last residual on return), preconditioned by
/// one V-cycle; stops at `|r| <= tol |b|`. Returns `x` (one vector in the
/// unknown numbering, red first, with room for `extra` more entries), the
/// iterations and `|r| / |b|`. Four vectors of the finest level are alive
/// at once, `x`, `r`, `p` and `z` (which also holds `A p`), and the
/// V-cycle's red residual.
///
/// # Errors
/// [`LinalgError::NoConvergence`] after `max_iter` iterations,
/// [`LinalgError::Breakdown`] when `p^T A p` or `r^T M^-1 r` is not positive.
pub(super) fn pcg(
    h: &Hierarchy,
    r: &mut Split,
    tol: f64,
    max_iter: usize,
    extra: usize,
) -> Result<(Vec<f64>, usize, f64), LinalgError> {
    let lev = h.finest();
    let dot = |a: &Split, b: &Split| -> f64 { dot(&a[0], &b[0]) + dot(&a[1], &b[1]) };
    let axpy = |y: &mut Split, a: f64, x: &Split| {
        for c in 0..2 {
            y[c].par_iter_mut()
                .zip(&x[c])
                .for_each(|(y, x)| *y += a * x);
        }
    };
    let breakdown = |iteration: usize, quantity: &'static str, value: f64| {
        if value > 0.0 && value.is_finite() {
            Ok(value)
        } else {
            Err(LinalgError::Breakdown {
                iteration,
                quantity,
                value,
            })
        }
    };
    // x in the unknown numbering (red first), with room for `extra` more
    // entries: it becomes the field's values without a copy
    let mut x = Vec::with_capacity(lev.len() + extra);
    x.resize(lev.len(), 0.0);
    let bn = dot(r, r).sqrt();
    if bn == 0.0 {
        return Ok((x, 0, 0.0));
    }
    let mut z = lev.zeros();
    h.apply(r, &mut z);
    let mut p = z.clone();
    let mut rz = breakdown(0, "r^T M^-1 r", dot(r, &z))?;
    for it in 1..=max_iter {
        lev.apply(&p, &mut z);
        let alpha = rz / breakdown(it, "p^T A p", dot(&p, &z))?;
        let (xr, xb) = x.split_at_mut(lev.n_red);
        for (xs, ps) in [xr, xb].into_iter().zip(&p) {
            xs.par_iter_mut().zip(ps).for_each(|(y, v)| *y += alpha * v);
        }
        axpy(r, -alpha, &z);
        let rel = dot(r, r).sqrt() / bn;
        if rel <= tol {
            return Ok((x, it, rel));
        }
        if !rel.is_finite() {
            return Err(LinalgError::Breakdown {
                iteration: it,
                quantity: "|r|",
                value: rel,
            });
        }
        h.apply(r, &mut z);
        let rz2 = breakdown(it, "r^T M^-1 r", dot(r, &z))?;
        let beta = rz2 / rz;
        rz = rz2;
        for c in 0..2 {
            p[c].par_iter_mut()
                .zip(&z[c])
                .for_each(|(p, z)| *p = z + beta * *p);
        }
    }
    Err(LinalgError::NoConvergence {
        iterations: max_iter,
        residual: dot(r, r).sqrt() / bn,
    })
}

#[cfg(test)]
mod tests {
    use super::super::{
        AxisCrossings, BasalFrame, FieldConfig, axis_crossings, grid_box, used_vertices,
    };
    use super::*;
    use crate::ventricle::landmarks::{DEFAULT_SNAP_MM, Landmarks};
    use proptest::prelude::*;
    use unfold_mesh::shapes::{VentricleParams, ventricle_cup};

    /// A cup's field problem classified as `LaplaceField::solve` does it.
    struct Problem {
        grid: Grid,
        state: Vec<u8>,
        index: Vec<u32>,
        n_red: usize,
        crossings: [AxisCrossings; 3],
        local: Vec<[f64; 3]>,
        tris: Vec<[u32; 3]>,
        rim2: Vec<[f64; 2]>,
        radius: f64,
    }

    impl Problem {
        fn new(radius_mm: f64, length_mm: f64, h: f64) -> Problem {
            let cup = ventricle_cup(&VentricleParams {
                radius: radius_mm,
                length: length_mm,
                ..VentricleParams::default()
            })
            .unwrap();
            let s = &cup.surface;
            let l =
                Landmarks::resolve(s, &cup.anterior, &cup.inferior, None, DEFAULT_SNAP_MM).unwrap();
            let frame = BasalFrame::new(s, &l).unwrap();
            let local: Vec<[f64; 3]> = s.positions.iter().map(|p| frame.local(p)).collect();
            let (dims, origin) = grid_box(&local, &used_vertices(s), h);
            let grid = Grid {
                h,
                origin,
                dims: dims.map(|d| d as usize),
            };
            let crossings = [0, 1, 2].map(|a| axis_crossings(&grid, &local, &s.triangles, a));
            let rim2: Vec<[f64; 2]> = l
                .rim
                .iter()
                .map(|&v| [local[v as usize][0], local[v as usize][1]])
                .collect();
            let radius = FieldConfig::default().hemisphere_mm;
            let mut state = classify(&grid, &crossings[2], &rim2, radius);
            let mut index = connected_unknowns(&grid, &mut state);
            let n_red = colour_numbering(&grid, &mut index);
            Problem {
                grid,
                state,
                index,
                n_red,
                crossings,
                local,
                tris: s.triangles.clone(),
                rim2,
                radius,
            }
        }

        fn ctx(&self) -> Ctx<'_> {
            Ctx {
                grid: &self.grid,
                state: &self.state,
                index: &self.index,
                crossings: &self.crossings,
                radius: self.radius,
            }
        }

        /// The hierarchy with the algebraic multigrid from `bottom`
        /// unknowns on.
        fn hierarchy(&self, bottom: usize) -> (Hierarchy<'_>, Split) {
            Hierarchy::with_bottom(
                &self.ctx(),
                self.n_red,
                &self.local,
                &self.tris,
                &self.rim2,
                bottom,
            )
            .unwrap()
        }
    }

    /// Deterministic values in `[-1, 1]`.
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut x = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (0..n)
            .map(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
            })
            .collect()
    }

    fn split(level: &Level<'_>, v: &[f64]) -> Split {
        let (r, b) = v.split_at(level.n_red);
        [r.to_vec(), b.to_vec()]
    }

    fn dot(a: &Split, b: &Split) -> f64 {
        (0..2)
            .map(|c| a[c].iter().zip(&b[c]).map(|(x, y)| x * y).sum::<f64>())
            .sum()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(6))]

        /// The matrix-free operator and right-hand side are the assembled
        /// finite-volume system's, row by row (in the assembly's numbering).
        #[test]
        fn the_matrix_free_operator_is_the_assembled_system(
            radius in 14.0f64..22.0,
            length in 20.0f64..34.0,
            h in 0.9f64..1.6,
            seed in 0u64..1000,
        ) {
            let p = Problem::new(radius, length, h);
            let ctx = p.ctx();
            let (level, rhs) = Level::new(&ctx, Cow::Borrowed(&p.index), p.n_red, true);
            let rhs = rhs.unwrap();
            let ascending = ascending_numbering(&p.state);
            let (a, b) = Ctx { index: &ascending, ..p.ctx() }.assemble().unwrap();
            let x = noise(level.len(), seed);
            let xs = split(&level, &x);
            let mut y = level.zeros();
            level.apply(&xs, &mut y);
            // x in the assembly's numbering
            let mut xa = vec![0.0; x.len()];
            for (id, &q) in p.index.iter().enumerate() {
                if q != u32::MAX {
                    xa[ascending[id] as usize] = x[q as usize];
                }
            }
            let mut ya = vec![0.0; x.len()];
            a.mul_vec(&xa, &mut ya);
            for (id, &q) in p.index.iter().enumerate() {
                if q == u32::MAX {
                    continue;
                }
                let (c, k) = level.slot(id).unwrap();
                let row = ascending[id] as usize;
                let scale = a.row(row).1.iter().map(|v| v.abs()).sum::<f64>();
                prop_assert!((y[c][k] - ya[row]).abs() <= 1e-12 * scale, "row {row}");
                prop_assert!((rhs[c][k] - b[row]).abs() <= 1e-12 * scale.max(1.0), "rhs {row}");
            }
        }
    }

    #[test]
    fn the_v_cycle_is_symmetric_positive_definite_and_restriction_is_half_the_transpose() {
        let p = Problem::new(20.0, 30.0, 1.0);
        // three geometric levels above the algebraic one
        let (hierarchy, _) = p.hierarchy(1500);
        assert!(hierarchy.levels.len() >= 3, "{}", hierarchy.levels.len());
        let fine = hierarchy.finest();
        let (r1, r2) = (
            split(fine, &noise(fine.len(), 1)),
            split(fine, &noise(fine.len(), 2)),
        );
        let (mut z1, mut z2) = (fine.zeros(), fine.zeros());
        hierarchy.apply(&r1, &mut z1);
        hierarchy.apply(&r2, &mut z2);
        let (a, b) = (dot(&z1, &r2), dot(&r1, &z2));
        assert!((a - b).abs() <= 1e-10 * a.abs().max(b.abs()), "{a} {b}");
        assert!(dot(&z1, &r1) > 0.0 && dot(&z2, &r2) > 0.0);
        for l in 0..hierarchy.levels.len() - 1 {
            let (f, c) = (&hierarchy.levels[l], &hierarchy.levels[l + 1]);
            // the residual after a sweep that ended with the black unknowns
            let mut r = split(f, &noise(f.len(), 3 + l as u64));
            r[1].fill(0.0);
            let red = r[0].clone();
            let xc = split(c, &noise(c.len(), 7 + l as u64));
            let mut px = f.zeros();
            prolong_add(f, c, &xc, &mut px);
            let left = dot(&restrict(f, c, &red), &xc);
            let right = 0.5 * dot(&r, &px);
            assert!(
                (left - right).abs() <= 1e-12 * left.abs().max(1.0),
                "{left} {right}"
            );
        }
    }

    #[test]
    fn the_geometric_solve_is_the_algebraic_one_and_a_cut_off_solve_is_an_error() {
        let p = Problem::new(20.0, 30.0, 1.0);
        let (hierarchy, rhs) = p.hierarchy(1500);
        let mut r = rhs.clone();
        let (x, iterations, rel) = pcg(&hierarchy, &mut r, 1e-11, 100, 0).unwrap();
        assert!(rel <= 1e-11 && iterations <= 30, "{iterations} {rel}");
        // the same system assembled and solved by the algebraic multigrid
        let ascending = ascending_numbering(&p.state);
        let (a, b) = Ctx {
            index: &ascending,
            ..p.ctx()
        }
        .assemble()
        .unwrap();
        let mg = Multigrid::for_grid(a.clone(), p.grid.dims, &ascending).unwrap();
        let mut xa = vec![0.0; b.len()];
        unfold_linalg::multigrid::pcg(&a, &b, &mut xa, &mg, 1e-11, 100).unwrap();
        let mut worst = 0.0f64;
        for (id, &q) in p.index.iter().enumerate() {
            if q != u32::MAX {
                worst = worst.max((x[q as usize] - xa[ascending[id] as usize]).abs());
            }
        }
        assert!(worst < 1e-8, "{worst}");
        let mut r = rhs;
        match pcg(&hierarchy, &mut r, 1e-14, 2, 0) {
            Err(LinalgError::NoConvergence {
                iterations,
                residual,
            }) => {
                assert_eq!(iterations, 2);
                assert!(residual > 1e-14);
            }
            other => panic!("expected NoConvergence, got {:?}", other.map(|o| o.1)),
        }
    }
}
