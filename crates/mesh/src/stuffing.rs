//! Isosurface stuffing (Labelle & Shewchuk 2007; ALGORITHMS 2.8), in
//! progress for issue 7: the domain is `{x : f(x) < 0}` of an implicit
//! function, the background mesh the [`BccLattice`].
//!
//! This step finds the cut points and warps the lattice:
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
//! The paper's `alpha_long = 0.24999`, `alpha_short = 0.41189` give
//! dihedral angles in `[10.7, 164.8]` degrees once the stencils (next step)
//! fill the tets.

use crate::MeshError;
use crate::bcc::BccLattice;
use nalgebra::Point3;
use std::collections::HashMap;

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
    /// Cut points of the edges whose ends have strictly opposite signs
    /// after warping, keyed by the sorted vertex pair.
    pub cuts: HashMap<(u32, u32), Point3<f64>>,
    /// Number of warped vertices.
    pub warped: usize,
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

/// The edges of the lattice with their warp parameters `(v, w, alpha)`.
pub fn lattice_edges(l: &BccLattice) -> Vec<(u32, u32, f64)> {
    let [nx, ny, nz] = l.n;
    let mut e = Vec::new();
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let v = l.black(i, j, k);
                if i < nx {
                    e.push((v, l.black(i + 1, j, k), ALPHA_LONG));
                }
                if j < ny {
                    e.push((v, l.black(i, j + 1, k), ALPHA_LONG));
                }
                if k < nz {
                    e.push((v, l.black(i, j, k + 1), ALPHA_LONG));
                }
            }
        }
    }
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let r = l.red(i, j, k);
                if i + 1 < nx {
                    e.push((r, l.red(i + 1, j, k), ALPHA_LONG));
                }
                if j + 1 < ny {
                    e.push((r, l.red(i, j + 1, k), ALPHA_LONG));
                }
                if k + 1 < nz {
                    e.push((r, l.red(i, j, k + 1), ALPHA_LONG));
                }
                for c in 0..8 {
                    let b = l.black(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                    e.push((r, b, ALPHA_SHORT));
                }
            }
        }
    }
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
    let edges = lattice_edges(l);
    // cut points of the lattice as it is, and the violations they cause
    let mut nearest: Vec<Option<(f64, Point3<f64>)>> = vec![None; positions.len()];
    let mut cuts: Vec<(u32, u32, Point3<f64>)> = Vec::new();
    for &(v, w, alpha) in &edges {
        let (fv, fw) = (values[v as usize], values[w as usize]);
        if fv * fw >= 0.0 {
            continue;
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
        cuts.push((v, w, c));
    }
    let mut warped = 0;
    for (x, n) in nearest.iter().enumerate() {
        if let Some((_, c)) = n {
            positions[x] = *c;
            values[x] = 0.0;
            warped += 1;
        }
    }
    let cuts = cuts
        .into_iter()
        .filter(|&(v, w, _)| values[v as usize] * values[w as usize] < 0.0)
        .map(|(v, w, c)| ((v.min(w), v.max(w)), c))
        .collect();
    Ok(Warped {
        positions,
        values,
        cuts,
        warped,
    })
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
            let alpha: HashMap<(u32, u32), f64> = lattice_edges(&l)
                .into_iter()
                .map(|(a, b, al)| ((a.min(b), a.max(b)), al))
                .collect();
            prop_assert!(w.warped > 0 && !w.cuts.is_empty());
            for (x, p) in w.positions.iter().enumerate() {
                if w.values[x] == 0.0 {
                    prop_assert!(f(p).abs() < 1e-9, "warped vertex off the surface: {}", f(p));
                } else {
                    prop_assert_eq!(*p, orig[x]);
                    prop_assert_eq!(w.values[x], f(p));
                }
            }
            for (&(a, b), cp) in &w.cuts {
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
}
