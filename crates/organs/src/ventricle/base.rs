//! Closing S by a planar base (ALGORITHMS 3.3: "U is the region inside S,
//! closed by the basal plane").
//!
//! A real rim is not planar (Cobiveco geo2's varies by 9.7 mm about its
//! least-squares plane). A zero-flux wall standing on a tilted rim would not
//! lie on grid planes, and streamlines would leak through it. Instead, S is
//! extended by a strip straight down (along the long axis `e3`) from its rim
//! to the plane `delta` below the most basal rim vertex: the extended
//! surface `S'` has a planar rim, its cap lies on a grid plane (where the
//! zero-flux condition is exact), and every streamline ends on `S'`. The
//! strip has `n_L = ceil(max height / mean rim edge)` layers (at most 64);
//! rim vertex `i` at height `z_i` above the plane gets the copies at heights
//! `z_i (1 - l / n_L)`. `delta` is half the mean rim edge, so no strip
//! triangle is flat. A planar rim (height range below `1e-9` of S's size)
//! gets no strip.

use super::field::BasalFrame;
use super::landmarks::Landmarks;
use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_mesh::nalgebra::Point3;

/// S closed down to its basal plane.
#[derive(Debug, Clone)]
pub struct ExtendedSurface {
    /// `S'`: S's vertices and triangles first, then the strip's.
    pub surface: TriMesh,
    /// The landmarks on `S'` (its rim is the strip's lowest layer; the rim
    /// landmarks keep their positions in the loop).
    pub landmarks: Landmarks,
    /// Tallest strip column, mm (0 without a strip).
    pub strip_height_mm: f64,
    /// Vertices of S (the first ones of `S'`).
    pub original_vertices: usize,
}

/// Extends `surface` (with `landmarks`) down to its basal plane.
///
/// # Errors
/// `Input` when the rim is degenerate (see [`BasalFrame::new`]).
pub fn close_base(surface: &TriMesh, landmarks: &Landmarks) -> Result<ExtendedSurface, OrganError> {
    let frame = BasalFrame::new(surface, landmarks)?;
    let pos = &surface.positions;
    let rim = &landmarks.rim;
    let m = rim.len();
    let heights: Vec<f64> = rim
        .iter()
        .map(|&v| frame.local(&pos[v as usize])[2])
        .collect();
    let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let size = {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in pos {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max)
    };
    let original_vertices = pos.len();
    if top.is_nan() || top <= 1e-9 * size {
        return Ok(ExtendedSurface {
            surface: surface.clone(),
            landmarks: landmarks.clone(),
            strip_height_mm: 0.0,
            original_vertices,
        });
    }
    let mean_edge = (0..m)
        .map(|k| (pos[rim[k] as usize] - pos[rim[(k + 1) % m] as usize]).norm())
        .sum::<f64>()
        / m as f64;
    let delta = 0.5 * mean_edge;
    let layers = ((top + delta) / mean_edge).ceil().clamp(1.0, 64.0) as usize;
    let mut positions = pos.clone();
    let mut triangles = surface.triangles.clone();
    let e3 = frame.rotation.row(2).transpose();
    // layer l (1..=layers) of rim vertex k: index n0 + (l - 1) m + k
    let n0 = positions.len() as u32;
    for l in 1..=layers {
        for (&v, &h) in rim.iter().zip(&heights) {
            let z = h + delta;
            let drop = z * l as f64 / layers as f64;
            let p: Point3<f64> = pos[v as usize] - e3 * drop;
            positions.push(p);
        }
    }
    let id = |l: usize, k: usize| -> u32 {
        if l == 0 {
            rim[k]
        } else {
            n0 + ((l - 1) * m + k) as u32
        }
    };
    for l in 0..layers {
        for k in 0..m {
            let k1 = (k + 1) % m;
            // S has the half-edge rim[k] -> rim[k1]; the strip uses the reverse
            let (a0, b0, a1, b1) = (id(l, k), id(l, k1), id(l + 1, k), id(l + 1, k1));
            triangles.push([b0, a0, a1]);
            triangles.push([b0, a1, b1]);
        }
    }
    let bottom: Vec<u32> = (0..m).map(|k| id(layers, k)).collect();
    let extended = TriMesh::new(positions, triangles);
    let landmarks = Landmarks {
        rim: bottom,
        anterior: landmarks.anterior,
        inferior: landmarks.inferior,
        apex: landmarks.apex,
        snap_distances_mm: landmarks.snap_distances_mm,
    };
    landmarks.check(&extended)?;
    Ok(ExtendedSurface {
        surface: extended,
        landmarks,
        strip_height_mm: top + delta,
        original_vertices,
    })
}
