//! Streamlines of `grad f` (ALGORITHMS 3.3, 3.8): the curves
//! `dc/ds = sigma g(c) / |g(c)|` parameterized by arc length `s`, with `g`
//! the field's one continuous interpolant of `grad f` and `sigma = -1`
//! toward S, `+1` toward H.
//!
//! The integrator is Dormand–Prince 5(4) with error control: a step of
//! length `ds` is accepted when the embedded error estimate
//! `max_i |y5_i - y4_i| <= tol`, and the next step is
//! `ds * clamp(0.9 (tol / err)^(1/5), 0.2, 5)`, at most half a grid cell.
//! Arc length is the integration variable, so lengths are exact sums of
//! steps. An event (S crossed, H entered, the wanted length reached) ends
//! the trace on the event: the last step's length `sigma*` is found by
//! regula falsi (Illinois) on the Dormand–Prince step itself, so the end
//! point is a point of the numerical curve, accurate to the tolerance.

use super::error::PointFailure;
use super::field::{GradientCache, LaplaceField};
use crate::OrganError;
use std::cell::RefCell;
use std::collections::HashMap;
use unfold_mesh::TriMesh;

/// Default local error tolerance of the integrator, mm.
pub const DEFAULT_TRACE_TOLERANCE_MM: f64 = 1e-8;

/// Where a trace toward S ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// Triangle of S crossed.
    pub triangle: usize,
    /// Barycentric coordinates of the hit point in that triangle.
    pub barycentric: [f64; 3],
    /// The hit point (basal frame).
    pub point: [f64; 3],
    /// Arc length from the start, mm.
    pub length: f64,
}

/// Accepted step points of a trace with their arc lengths, mm.
pub type Record = Vec<([f64; 3], f64)>;

/// Why a trace failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TraceFailure {
    /// The curve left the region where the field is defined.
    LeftField([f64; 3]),
    /// `grad f` vanished.
    Stagnant([f64; 3]),
    /// The curve was longer than the limit without reaching its target.
    TooLong(f64),
}

impl TraceFailure {
    /// This failure as the reason a point cannot be mapped, the trace
    /// having gone toward `target`.
    pub fn toward(self, target: TraceTarget) -> PointFailure {
        PointFailure::Streamline {
            target,
            failure: self,
        }
    }
}

/// Where a trace was going (named in messages).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TraceTarget {
    /// The enclosing surface S ("S").
    Surface,
    /// The hemisphere H ("the hemisphere H").
    Hemisphere,
    /// The arc length of a point's depth along its streamline ("its
    /// depth").
    Depth,
}

impl std::fmt::Display for TraceTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TraceTarget::Surface => "S",
            TraceTarget::Hemisphere => "the hemisphere H",
            TraceTarget::Depth => "its depth",
        })
    }
}

/// The triangles of S binned by grid cell, for crossing tests.
#[derive(Debug, Clone)]
pub struct SurfaceIndex {
    points: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    cell: f64,
    origin: [f64; 3],
    bins: HashMap<[i32; 3], (u32, u32)>,
    items: Vec<u32>,
}

impl SurfaceIndex {
    /// Bins the triangles of `surface` (in the basal frame of `field`) in
    /// cubes of the grid spacing.
    pub fn new(surface: &TriMesh, field: &LaplaceField) -> SurfaceIndex {
        let frame = field.frame();
        let points: Vec<[f64; 3]> = surface.positions.iter().map(|p| frame.local(p)).collect();
        let cell = field.grid_mm();
        let mut origin = [f64::INFINITY; 3];
        for p in &points {
            for a in 0..3 {
                origin[a] = origin[a].min(p[a]);
            }
        }
        let origin = origin.map(|o| if o.is_finite() { o - cell } else { 0.0 });
        let mut pairs: Vec<([i32; 3], u32)> = Vec::new();
        for (t, tri) in surface.triangles.iter().enumerate() {
            let p = tri.map(|v| points[v as usize]);
            let mut lo = [0i32; 3];
            let mut hi = [0i32; 3];
            for a in 0..3 {
                let mn = p.iter().map(|q| q[a]).fold(f64::INFINITY, f64::min);
                let mx = p.iter().map(|q| q[a]).fold(f64::NEG_INFINITY, f64::max);
                lo[a] = ((mn - origin[a]) / cell - 1e-6).floor() as i32;
                hi[a] = ((mx - origin[a]) / cell + 1e-6).floor() as i32;
            }
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    for i in lo[0]..=hi[0] {
                        pairs.push(([i, j, k], t as u32));
                    }
                }
            }
        }
        pairs.sort_unstable();
        let mut bins = HashMap::new();
        let mut items = Vec::with_capacity(pairs.len());
        let mut s = 0;
        while s < pairs.len() {
            let mut e = s;
            while e < pairs.len() && pairs[e].0 == pairs[s].0 {
                items.push(pairs[e].1);
                e += 1;
            }
            bins.insert(pairs[s].0, (s as u32, e as u32));
            s = e;
        }
        SurfaceIndex {
            points,
            triangles: surface.triangles.clone(),
            cell,
            origin,
            bins,
            items,
        }
    }

    /// Basal-frame positions of S's vertices.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Candidate triangles near the box `[lo, hi]` (deduplicated into `out`).
    fn candidates(&self, lo: [f64; 3], hi: [f64; 3], out: &mut Vec<u32>) {
        out.clear();
        let c = |x: f64, a: usize| ((x - self.origin[a]) / self.cell).floor() as i32;
        for k in c(lo[2], 2)..=c(hi[2], 2) {
            for j in c(lo[1], 1)..=c(hi[1], 1) {
                for i in c(lo[0], 0)..=c(hi[0], 0) {
                    if let Some(&(s, e)) = self.bins.get(&[i, j, k]) {
                        out.extend_from_slice(&self.items[s as usize..e as usize]);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    /// The first crossing of segment `p -> q` with S: `(triangle, t)` with
    /// the crossing at `p + t (q - p)`, `t` in `[0, 1]`.
    fn first_crossing(&self, p: [f64; 3], q: [f64; 3], buf: &mut Vec<u32>) -> Option<(usize, f64)> {
        let lo = [0, 1, 2].map(|a| p[a].min(q[a]));
        let hi = [0, 1, 2].map(|a| p[a].max(q[a]));
        self.candidates(lo, hi, buf);
        let d = sub(q, p);
        let mut best: Option<(usize, f64)> = None;
        for &t in buf.iter() {
            let [a, b, c] = self.triangles[t as usize].map(|v| self.points[v as usize]);
            let e1 = sub(b, a);
            let e2 = sub(c, a);
            let pv = cross(d, e2);
            let det = dot(e1, pv);
            if det == 0.0 {
                continue;
            }
            let inv = 1.0 / det;
            let tv = sub(p, a);
            let u = dot(tv, pv) * inv;
            let qv = cross(tv, e1);
            let v = dot(d, qv) * inv;
            let s = dot(e2, qv) * inv;
            let eps = 1e-9;
            if u >= -eps && v >= -eps && u + v <= 1.0 + eps && (0.0..=1.0).contains(&s) {
                match best {
                    Some((_, bs)) if bs <= s => {}
                    _ => best = Some((t as usize, s)),
                }
            }
        }
        best
    }

    /// Signed distance of `x` from the plane of triangle `t` (along its
    /// unit normal) and the barycentric coordinates of `x`'s projection.
    fn plane(&self, t: usize, x: [f64; 3]) -> (f64, [f64; 3]) {
        let [a, b, c] = self.triangles[t].map(|v| self.points[v as usize]);
        let e1 = sub(b, a);
        let e2 = sub(c, a);
        let n = cross(e1, e2);
        let nn = dot(n, n);
        let w = sub(x, a);
        let dist = dot(w, n) / nn.sqrt();
        let b1 = dot(cross(w, e2), n) / nn;
        let b2 = dot(cross(e1, w), n) / nn;
        (dist, [1.0 - b1 - b2, b1, b2])
    }

    /// Whether `x` is inside the closed S (the ray toward `+z`, the apex
    /// side, crosses S an odd number of times; `z < 0` is beyond the cap).
    pub fn contains(&self, x: [f64; 3], buf: &mut Vec<u32>) -> bool {
        if x[2] < 0.0 {
            return false;
        }
        let top = self
            .points
            .iter()
            .map(|p| p[2])
            .fold(f64::NEG_INFINITY, f64::max);
        if x[2] > top {
            return false;
        }
        let mut count = 0usize;
        // jittered vertical ray through x
        let jx = x[0] + 2.7182818e-9 * self.cell;
        let jy = x[1] + 3.1415926e-9 * self.cell;
        let c = |v: f64, a: usize| ((v - self.origin[a]) / self.cell).floor() as i32;
        let (i, j) = (c(jx, 0), c(jy, 1));
        buf.clear();
        for k in c(x[2], 2)..=c(top, 2) {
            if let Some(&(s, e)) = self.bins.get(&[i, j, k]) {
                buf.extend_from_slice(&self.items[s as usize..e as usize]);
            }
        }
        buf.sort_unstable();
        buf.dedup();
        for &t in buf.iter() {
            let [a, b, cc] = self.triangles[t as usize].map(|v| self.points[v as usize]);
            let (e1u, e1v) = (b[0] - a[0], b[1] - a[1]);
            let (e2u, e2v) = (cc[0] - a[0], cc[1] - a[1]);
            let det = e1u * e2v - e1v * e2u;
            if det == 0.0 {
                continue;
            }
            let (px, py) = (jx - a[0], jy - a[1]);
            let b1 = (px * e2v - py * e2u) / det;
            let b2 = (e1u * py - e1v * px) / det;
            let b0 = 1.0 - b1 - b2;
            if b0 >= 0.0 && b1 >= 0.0 && b2 >= 0.0 {
                let z = b0 * a[2] + b1 * b[2] + b2 * cc[2];
                if z > x[2] {
                    count += 1;
                }
            }
        }
        count % 2 == 1
    }
}

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline]
fn axpy(y: [f64; 3], a: f64, x: [f64; 3]) -> [f64; 3] {
    [y[0] + a * x[0], y[1] + a * x[1], y[2] + a * x[2]]
}

/// What ends a trace.
#[derive(Debug, Clone, Copy)]
enum Target {
    Surface,
    Hemisphere,
    Length(f64),
}

/// How a trace ended.
enum End {
    Surface(SurfaceHit),
    Point([f64; 3], f64),
}

/// Dormand–Prince 5(4) tableau (nodes 0, 1/5, 3/10, 4/5, 8/9, 1, 1; the
/// field is autonomous, so only the weights are needed).
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
const B5: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
const B4: [f64; 7] = [
    5179.0 / 57600.0,
    0.0,
    7571.0 / 16695.0,
    393.0 / 640.0,
    -92097.0 / 339200.0,
    187.0 / 2100.0,
    1.0 / 40.0,
];

/// Streamline tracer on a field and S.
#[derive(Debug, Clone)]
pub struct Tracer<'a> {
    field: &'a LaplaceField,
    surface: &'a SurfaceIndex,
    tolerance: f64,
    max_length: f64,
    /// The last cell's corner gradients (one tracer per thread).
    cache: RefCell<GradientCache>,
}

impl<'a> Tracer<'a> {
    /// A tracer with local error tolerance `tolerance` (mm) giving up after
    /// `max_length` mm.
    pub fn new(
        field: &'a LaplaceField,
        surface: &'a SurfaceIndex,
        tolerance: f64,
        max_length: f64,
    ) -> Result<Tracer<'a>, OrganError> {
        OrganError::check_positive(&[
            ("trace tolerance (mm)", tolerance),
            ("largest streamline length (mm)", max_length),
        ])?;
        Ok(Tracer {
            field,
            surface,
            tolerance,
            max_length,
            cache: RefCell::new(GradientCache::default()),
        })
    }

    /// Unit direction `sigma g / |g|` at `y`.
    #[inline]
    fn dir(&self, y: [f64; 3], sigma: f64) -> Result<[f64; 3], TraceFailure> {
        let g = self
            .field
            .gradient_cached(y, &mut self.cache.borrow_mut())
            .ok_or(TraceFailure::LeftField(y))?;
        let n = dot(g, g).sqrt();
        if n.is_nan() || n <= 1e-300 {
            return Err(TraceFailure::Stagnant(y));
        }
        let s = sigma / n;
        Ok([g[0] * s, g[1] * s, g[2] * s])
    }

    /// One Dormand–Prince step of length `ds` from `y` with first stage
    /// `k0`: the 5th-order point, the error estimate and the last stage
    /// (the next step's first, FSAL).
    fn step(
        &self,
        y: [f64; 3],
        k0: [f64; 3],
        ds: f64,
        sigma: f64,
    ) -> Result<([f64; 3], f64, [f64; 3]), TraceFailure> {
        let mut k = [[0.0; 3]; 7];
        k[0] = k0;
        for s in 1..7 {
            let mut yi = y;
            for (r, kr) in k.iter().enumerate().take(s) {
                let a = A[s][r];
                if a != 0.0 {
                    yi = axpy(yi, ds * a, *kr);
                }
            }
            k[s] = self.dir(yi, sigma)?;
        }
        let mut y5 = y;
        let mut err = 0.0f64;
        for a in 0..3 {
            let mut d5 = 0.0;
            let mut d4 = 0.0;
            for s in 0..7 {
                d5 += B5[s] * k[s][a];
                d4 += B4[s] * k[s][a];
            }
            y5[a] += ds * d5;
            err = err.max((ds * (d5 - d4)).abs());
        }
        Ok((y5, err, k[6]))
    }

    /// Integrates from `start` until `target`.
    fn run(
        &self,
        start: [f64; 3],
        sigma: f64,
        target: Target,
        mut record: Option<&mut Record>,
    ) -> Result<End, TraceFailure> {
        let hmax = 0.5 * self.field.grid_mm();
        let tol = self.tolerance;
        let mut y = start;
        let mut s = 0.0;
        let mut k0 = self.dir(y, sigma)?;
        let mut ds_ctl = 0.1 * hmax;
        let mut buf = Vec::new();
        if let Target::Length(l) = target
            && l <= 0.0
        {
            return Ok(End::Point(start, 0.0));
        }
        if let Target::Hemisphere = target
            && self.field.hemisphere_level(y) <= 0.0
        {
            return Ok(End::Point(start, 0.0));
        }
        loop {
            if s > self.max_length {
                return Err(TraceFailure::TooLong(self.max_length));
            }
            // no step straddles a grid face (the interpolant's kinks)
            let face = self.field.face_distance(y, k0);
            let capped = face < ds_ctl;
            let mut ds = ds_ctl.min(face);
            if let Target::Length(l) = target {
                ds = ds.min(l - s);
            }
            let (y1, err, k1) = match self.step(y, k0, ds, sigma) {
                Ok(x) => x,
                Err(e) => {
                    // a stage left the field: retry shorter, unless tiny
                    if ds > 1e-6 * hmax {
                        ds_ctl = 0.25 * ds;
                        continue;
                    }
                    return Err(e);
                }
            };
            if err > tol && ds > 1e-12 {
                ds_ctl = ds * (0.9 * (tol / err).powf(0.2)).clamp(0.1, 0.9);
                continue;
            }
            // the step is accepted: events on it
            match target {
                Target::Surface => {
                    if let Some((t, _)) = self.surface.first_crossing(y, y1, &mut buf) {
                        return self.refine_surface(y, k0, ds, sigma, t, s);
                    }
                }
                Target::Hemisphere => {
                    if self.field.hemisphere_level(y1) <= 0.0 {
                        let f = |x: [f64; 3]| self.field.hemisphere_level(x);
                        let (p, d) = self.refine(y, k0, ds, sigma, f)?;
                        return Ok(End::Point(p, s + d));
                    }
                }
                Target::Length(l) => {
                    if s + ds >= l {
                        return Ok(End::Point(y1, l));
                    }
                }
            }
            s += ds;
            y = y1;
            if let Some(r) = record.as_deref_mut() {
                r.push((y, s));
            }
            k0 = k1;
            let grow = if err > 0.0 {
                (0.9 * (tol / err).powf(0.2)).clamp(0.2, 5.0)
            } else {
                5.0
            };
            // a step cut short at a face does not shrink the next one
            ds_ctl = if capped {
                ds_ctl.max(ds * grow)
            } else {
                ds * grow
            }
            .min(hmax);
        }
    }

    /// The step length `d` in `(0, ds]` whose Dormand–Prince step from `y`
    /// ends where `level` changes sign (Illinois regula falsi); the end
    /// point and `d`.
    fn refine(
        &self,
        y: [f64; 3],
        k0: [f64; 3],
        ds: f64,
        sigma: f64,
        level: impl Fn([f64; 3]) -> f64,
    ) -> Result<([f64; 3], f64), TraceFailure> {
        let (mut a, mut fa) = (0.0, level(y));
        let (mut pb, _, _) = self.step(y, k0, ds, sigma)?;
        let (mut b, mut fb) = (ds, level(pb));
        if fa == 0.0 {
            return Ok((y, 0.0));
        }
        if fa * fb > 0.0 {
            // the chord crossed but the curve's end did not: take the end
            return Ok((pb, ds));
        }
        let mut side = 0i32;
        for _ in 0..100 {
            if (b - a).abs() <= 1e-15 * ds.max(1e-300) || fb.abs() < 1e-14 {
                break;
            }
            let m = (a * fb - b * fa) / (fb - fa);
            let m = if m > a && m < b { m } else { 0.5 * (a + b) };
            let (pm, _, _) = self.step(y, k0, m, sigma)?;
            let fm = level(pm);
            if fm * fb < 0.0 {
                a = b;
                fa = fb;
                side = 0;
            } else {
                if side == 1 {
                    fa *= 0.5;
                }
                side = 1;
            }
            b = m;
            fb = fm;
            pb = pm;
            if fm == 0.0 {
                break;
            }
        }
        Ok((pb, b))
    }

    /// Ends a trace toward S on the triangle crossed in the last step.
    #[allow(clippy::too_many_arguments)]
    fn refine_surface(
        &self,
        y: [f64; 3],
        k0: [f64; 3],
        ds: f64,
        sigma: f64,
        mut tri: usize,
        s: f64,
    ) -> Result<End, TraceFailure> {
        let mut buf = Vec::new();
        let mut point = y;
        let mut len = 0.0;
        let mut bary = [1.0 / 3.0; 3];
        for _ in 0..4 {
            let side = self.surface.plane(tri, y).0;
            let f = |x: [f64; 3]| {
                let d = self.surface.plane(tri, x).0;
                if side >= 0.0 { d } else { -d }
            };
            let (p, d) = self.refine(y, k0, ds, sigma, f)?;
            point = p;
            len = d;
            let (_, b) = self.surface.plane(tri, p);
            bary = b;
            let worst = b[0].min(b[1]).min(b[2]);
            if worst >= -1e-9 {
                break;
            }
            // the end point lies beside this triangle: the neighbour it is in
            let e = 1e-6 * self.field.grid_mm();
            self.surface.candidates(
                [p[0] - e, p[1] - e, p[2] - e],
                [p[0] + e, p[1] + e, p[2] + e],
                &mut buf,
            );
            let mut best = (tri, worst);
            for &t in &buf {
                let (dist, bt) = self.surface.plane(t as usize, p);
                let w = bt[0].min(bt[1]).min(bt[2]);
                if w > best.1 && dist.abs() < 1e-3 * self.field.grid_mm() {
                    best = (t as usize, w);
                }
            }
            if best.0 == tri {
                break;
            }
            tri = best.0;
        }
        let clamp = bary.map(|x| x.max(0.0));
        let sum: f64 = clamp.iter().sum();
        let bary = clamp.map(|x| x / sum);
        Ok(End::Surface(SurfaceHit {
            triangle: tri,
            barycentric: bary,
            point,
            length: s + len,
        }))
    }

    /// Traces from `start` against `grad f` until the curve crosses S.
    pub fn to_surface(&self, start: [f64; 3]) -> Result<SurfaceHit, TraceFailure> {
        match self.run(start, -1.0, Target::Surface, None)? {
            End::Surface(h) => Ok(h),
            End::Point(p, _) => Err(TraceFailure::LeftField(p)),
        }
    }

    /// Traces from `start` along `grad f` until the curve enters H: the end
    /// point and the arc length.
    pub fn to_hemisphere(&self, start: [f64; 3]) -> Result<([f64; 3], f64), TraceFailure> {
        match self.run(start, 1.0, Target::Hemisphere, None)? {
            End::Point(p, l) => Ok((p, l)),
            End::Surface(h) => Err(TraceFailure::LeftField(h.point)),
        }
    }

    /// [`Tracer::to_hemisphere`], also returning the accepted step points
    /// with their arc lengths (for [`Tracer::along_recorded`]).
    pub fn to_hemisphere_recorded(
        &self,
        start: [f64; 3],
    ) -> Result<([f64; 3], f64, Record), TraceFailure> {
        let mut rec = vec![(start, 0.0)];
        match self.run(start, 1.0, Target::Hemisphere, Some(&mut rec))? {
            End::Point(p, l) => Ok((p, l, rec)),
            End::Surface(h) => Err(TraceFailure::LeftField(h.point)),
        }
    }

    /// The point at arc length `length` along a recorded trace: integrated
    /// from the last recorded point at or before `length`.
    pub fn along_recorded(
        &self,
        record: &[([f64; 3], f64)],
        length: f64,
    ) -> Result<[f64; 3], TraceFailure> {
        let k = record.partition_point(|r| r.1 <= length).max(1) - 1;
        let (y, s) = record[k];
        self.along(y, length - s)
    }

    /// The point at arc length `length` along `grad f` from `start`.
    pub fn along(&self, start: [f64; 3], length: f64) -> Result<[f64; 3], TraceFailure> {
        match self.run(start, 1.0, Target::Length(length), None)? {
            End::Point(p, _) => Ok(p),
            End::Surface(h) => Err(TraceFailure::LeftField(h.point)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ventricle::field::FieldConfig;
    use crate::ventricle::landmarks::{DEFAULT_SNAP_MM, Landmarks};
    use proptest::prelude::*;
    use std::f64::consts::TAU;
    use std::sync::OnceLock;
    use unfold_mesh::shapes::{VentricleParams, ventricle_cup};

    /// Radius of the hemispherical S, mm.
    const R: f64 = 20.0;
    /// Largest streamline length of the test tracers, mm.
    const MAX_LENGTH: f64 = 200.0;

    struct Hemi {
        field: LaplaceField,
        index: SurfaceIndex,
    }

    /// S a hemisphere of radius `R` (its apex given: every vertex is
    /// equally far from the rim's centre), its field on a 1 mm grid and its
    /// surface index, built once.
    fn hemi() -> &'static Hemi {
        static H: OnceLock<Hemi> = OnceLock::new();
        H.get_or_init(|| {
            let cup = ventricle_cup(&VentricleParams {
                radius: R,
                length: R,
                base_above_equator: 0.0,
                ..VentricleParams::default()
            })
            .unwrap();
            let l = Landmarks::resolve(
                &cup.surface,
                &cup.anterior,
                &cup.inferior,
                Some(&cup.apex),
                DEFAULT_SNAP_MM,
            )
            .unwrap();
            let config = FieldConfig {
                grid_mm: 1.0,
                ..FieldConfig::default()
            };
            let field = LaplaceField::solve(&cup.surface, &l, &config).unwrap();
            let index = SurfaceIndex::new(&cup.surface, &field);
            Hemi { field, index }
        })
    }

    fn tracer(h: &Hemi) -> Tracer<'_> {
        Tracer::new(&h.field, &h.index, DEFAULT_TRACE_TOLERANCE_MM, MAX_LENGTH).unwrap()
    }

    fn norm(q: [f64; 3]) -> f64 {
        dot(q, q).sqrt()
    }

    fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
        norm(sub(a, b))
    }

    fn scale(q: [f64; 3], s: f64) -> [f64; 3] {
        q.map(|x| x * s)
    }

    /// The basal-frame point at radius `rho`, polar angle `polar` from `e3`
    /// and azimuth `az`.
    fn spherical(rho: f64, polar: f64, az: f64) -> [f64; 3] {
        [
            rho * polar.sin() * az.cos(),
            rho * polar.sin() * az.sin(),
            rho * polar.cos(),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(8))]

        /// `contains` is the analytic test "z >= 0 and |x| < R" at points
        /// more than 0.1 mm from the sphere (S's chords lie within 0.01 mm
        /// of it); everything below the cap is outside.
        #[test]
        fn contains_agrees_with_the_hemisphere(
            points in prop::collection::vec((0.0..1.3f64, 0.0..std::f64::consts::PI, 0.0..TAU), 64),
        ) {
            let h = hemi();
            let mut buf = Vec::new();
            let mut seen = [0usize; 2];
            for (u, polar, az) in points {
                let x = spherical(u * R, polar, az);
                let rho = u * R;
                if (rho - R).abs() <= 0.1 {
                    continue;
                }
                let want = x[2] >= 0.0 && rho < R;
                seen[want as usize] += 1;
                prop_assert_eq!(h.index.contains(x, &mut buf), want, "{:?}, |x| = {}", x, rho);
            }
            prop_assert!(seen[0] > 0 && seen[1] > 0, "{seen:?}");
        }

        /// Streamlines on the hemisphere are radial: toward S from `v` they
        /// end near `R v / |v|` after `R - |v|`, toward H near `r v / |v|`
        /// after `|v| - r`; `along` walks the radial line by arc length.
        /// (Within 0.05 mm for the lengths; the end points are within
        /// 0.1 mm: the 1 mm grid's gradient next to S and H is off by up to
        /// 2-3 degrees; measured worst 0.06 mm.)
        #[test]
        fn hemisphere_streamlines_are_radial(
            u in 0.0..1.0f64,
            polar in 0.0..1.55f64,
            az in 0.0..TAU,
            fractions in prop::collection::vec(0.001..0.8f64, 3),
        ) {
            let h = hemi();
            let t = tracer(h);
            let r = h.field.hemisphere_radius();
            let rho = r + 2.0 + u * (R - r - 3.0);
            let v = spherical(rho, polar, az);
            let dir = scale(v, 1.0 / rho);

            let hit = t.to_surface(v).unwrap();
            let on_sphere = scale(dir, R);
            prop_assert!(dist(hit.point, on_sphere) < 0.1, "hit {:?} vs {on_sphere:?}", hit.point);
            prop_assert!((hit.length - (R - rho)).abs() < 0.05, "length {} vs {}", hit.length, R - rho);
            // the hit lies in its triangle, at its barycentric coordinates
            let b = hit.barycentric;
            prop_assert!(b.iter().all(|&x| x >= 0.0) && (b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let tri = h.index.triangles[hit.triangle].map(|k| h.index.points[k as usize]);
            let at = [0, 1, 2].map(|a| b[0] * tri[0][a] + b[1] * tri[1][a] + b[2] * tri[2][a]);
            prop_assert!(dist(at, hit.point) < 1e-6, "{at:?} vs {:?}", hit.point);

            let (end, length) = t.to_hemisphere(v).unwrap();
            prop_assert!((length - (rho - r)).abs() < 0.05, "length {length} vs {}", rho - r);
            prop_assert!(h.field.hemisphere_level(end).abs() < 1e-9, "end {end:?}");
            prop_assert!(dist(end, scale(dir, r)) < 0.1, "end {end:?}");
            for f in fractions {
                let l = f * length;
                let p = t.along(v, l).unwrap();
                prop_assert!((dist(p, v) - l).abs() < 1e-3, "|p - v| = {} for l = {l}", dist(p, v));
                let radial = axpy(v, -l, dir);
                prop_assert!(dist(p, radial) < 0.1, "{p:?} vs {radial:?}");
            }
        }

        /// `to_hemisphere_recorded` ends where `to_hemisphere` does and
        /// records increasing arc lengths; `along_recorded` returns the
        /// recorded points exactly at their arc lengths and agrees with
        /// `along` in between (both integrate the same curve from different
        /// step sequences; the error estimate of a step across a face of the
        /// grid, where the trilinear gradient has a kink, can be 300 times
        /// too small: measured up to 3e-5 mm apart at the 1e-8 mm tolerance).
        #[test]
        fn recorded_traces_give_the_points_along_the_streamline(
            u in 0.0..1.0f64,
            polar in 0.0..1.55f64,
            az in 0.0..TAU,
            fractions in prop::collection::vec(0.0..1.0f64, 4),
        ) {
            let h = hemi();
            let t = tracer(h);
            let r = h.field.hemisphere_radius();
            let v = spherical(r + 1.0 + u * (R - r - 2.0), polar, az);
            let (end, length) = t.to_hemisphere(v).unwrap();
            let (end2, length2, record) = t.to_hemisphere_recorded(v).unwrap();
            prop_assert_eq!(end2, end);
            prop_assert_eq!(length2, length);
            prop_assert_eq!(record[0], (v, 0.0));
            prop_assert!(record.len() >= 3, "{} points", record.len());
            prop_assert!(record.windows(2).all(|w| w[1].1 > w[0].1 && w[1].1 < length));
            for &(y, s) in &record {
                prop_assert_eq!(t.along_recorded(&record, s).unwrap(), y);
            }
            for f in fractions {
                let l = f * length;
                let p = t.along(v, l).unwrap();
                let q = t.along_recorded(&record, l).unwrap();
                prop_assert!(dist(p, q) < 1e-6, "along {p:?} vs recorded {q:?} at {l}");
            }
            let q = t.along_recorded(&record, length).unwrap();
            prop_assert!(dist(q, end) < 1e-6, "{q:?} vs the end {end:?}");
        }
    }

    /// Steps end on grid faces, so the error estimate sees a polynomial
    /// field and the global error stays near the tolerance: a trace at the
    /// default 1e-8 mm per step agrees with one at 1e-13 mm.
    #[test]
    fn traces_are_accurate_to_their_tolerance() {
        let h = hemi();
        let t = tracer(h);
        let fine = Tracer::new(&h.field, &h.index, 1e-13, MAX_LENGTH).unwrap();
        let r = h.field.hemisphere_radius();
        let mut worst: f64 = 0.0;
        for k in 0..40 {
            let v = spherical(
                r + 1.0 + 0.3 * k as f64,
                0.1 + 0.035 * k as f64,
                0.4 * k as f64,
            );
            let (_, length) = fine.to_hemisphere(v).unwrap();
            for f in [0.3, 0.9] {
                let a = t.along(v, f * length).unwrap();
                let b = fine.along(v, f * length).unwrap();
                worst = worst.max(dist(a, b));
            }
            let a = t.to_surface(v).unwrap();
            let b = fine.to_surface(v).unwrap();
            worst = worst.max(dist(a.point, b.point));
        }
        assert!(worst < 1e-6, "default vs fine tolerance: {worst:e} mm");
    }

    #[test]
    fn zero_lengths_and_starts_inside_h_end_where_they_start() {
        let h = hemi();
        let t = tracer(h);
        let v = [3.0, -4.0, 9.0];
        assert_eq!(t.along(v, 0.0).unwrap(), v);
        assert_eq!(t.along(v, -1.0).unwrap(), v);
        assert_eq!(t.along_recorded(&[(v, 0.0)], 0.0).unwrap(), v);
        // a start inside H (where the field is still defined) is on H
        let inside = [0.0, 2.0, 3.0];
        assert!(h.field.hemisphere_level(inside) < 0.0);
        assert_eq!(t.to_hemisphere(inside).unwrap(), (inside, 0.0));
    }

    #[test]
    fn bad_tracer_settings_are_refused_with_a_clear_error() {
        let h = hemi();
        for bad in [0.0, -1e-8, f64::NAN, f64::INFINITY] {
            match Tracer::new(&h.field, &h.index, bad, MAX_LENGTH) {
                Err(e @ OrganError::Config(_)) => {
                    assert!(e.to_string().contains("trace tolerance"), "{e}")
                }
                other => panic!("tolerance {bad}: {other:?}"),
            }
            match Tracer::new(&h.field, &h.index, 1e-8, bad) {
                Err(e @ OrganError::Config(_)) => {
                    assert!(e.to_string().contains("largest streamline length"), "{e}")
                }
                other => panic!("max length {bad}: {other:?}"),
            }
        }
    }

    #[test]
    fn traces_that_cannot_reach_their_target_fail() {
        let h = hemi();
        let t = tracer(h);
        // far outside the field: it is left at once
        for far in [
            [10.0 * R, 0.0, 0.0],
            [0.0, 0.0, 10.0 * R],
            [0.0, 0.0, -10.0 * R],
        ] {
            assert_eq!(t.to_surface(far), Err(TraceFailure::LeftField(far)));
            assert_eq!(t.to_hemisphere(far), Err(TraceFailure::LeftField(far)));
            assert_eq!(t.along(far, 1.0), Err(TraceFailure::LeftField(far)));
        }
        // a limit shorter than the way to H
        let short = Tracer::new(&h.field, &h.index, 1e-8, 2.0).unwrap();
        let v = [0.0, 0.0, 15.0];
        assert_eq!(short.to_hemisphere(v), Err(TraceFailure::TooLong(2.0)));
        assert_eq!(
            short.to_surface([0.0, 0.0, 6.0]),
            Err(TraceFailure::TooLong(2.0))
        );
        // the same starts reach their targets with the default limit
        assert!(t.to_hemisphere(v).is_ok() && t.to_surface([0.0, 0.0, 6.0]).is_ok());
    }

    #[test]
    fn failures_are_described_with_their_target() {
        let left = TraceFailure::LeftField([1.0, -2.5, 3.25])
            .toward(TraceTarget::Surface)
            .to_string();
        assert!(left.contains("left the field"), "{left}");
        assert!(left.contains("(1.000, -2.500, 3.250)"), "{left}");
        assert!(left.ends_with("before reaching S"), "{left}");
        let long = TraceFailure::TooLong(123.45)
            .toward(TraceTarget::Hemisphere)
            .to_string();
        assert!(long.contains("did not reach the hemisphere H"), "{long}");
        assert!(long.contains("123.5 mm"), "{long}");
        let stuck = TraceFailure::Stagnant([0.0, 1.0, 2.0])
            .toward(TraceTarget::Surface)
            .to_string();
        assert!(stuck.contains("grad f vanishes"), "{stuck}");
        assert!(stuck.contains("(0.000, 1.000, 2.000)"), "{stuck}");
        assert!(stuck.ends_with("before reaching S"), "{stuck}");
        let depth = TraceFailure::TooLong(1.0).toward(TraceTarget::Depth);
        assert_eq!(
            depth,
            PointFailure::Streamline {
                target: TraceTarget::Depth,
                failure: TraceFailure::TooLong(1.0)
            }
        );
        assert!(
            depth.to_string().contains("did not reach its depth"),
            "{depth}"
        );
    }
}
