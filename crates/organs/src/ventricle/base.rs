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
//! triangle is flat. Each quad of the strip is split along its shorter
//! diagonal (ties by vertex index), so the strip does not depend on the
//! direction S's triangles wind in. A planar rim (height range below `1e-9` of S's size)
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
/// `Ventricle` when the rim is degenerate (see [`BasalFrame::new`]).
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
    // Summed shortest first: the same bits whichever way and from wherever
    // the loop is walked.
    let mut edges: Vec<f64> = (0..m)
        .map(|k| (pos[rim[k] as usize] - pos[rim[(k + 1) % m] as usize]).norm())
        .collect();
    edges.sort_by(f64::total_cmp);
    let mean_edge = edges.iter().sum::<f64>() / m as f64;
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
            if diagonal_b0_a1(&positions, [a0, b0, a1, b1], rim[k] > rim[k1]) {
                triangles.push([b0, a0, a1]);
                triangles.push([b0, a1, b1]);
            } else {
                triangles.push([b0, a0, b1]);
                triangles.push([a0, a1, b1]);
            }
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

/// Whether the strip quad `a0 b0` (layer `l`) over `a1 b1` (layer `l + 1`)
/// is split along `b0 a1` rather than `a0 b1`: along the shorter diagonal
/// (the Delaunay split of a planar quad whose opposite angles are equal),
/// and on a tie (within `1e-9` relative) along the one from the upper copy
/// of the rim vertex with the smaller index (`b0` when `a0_larger`). The
/// rule sees neither the loop's direction nor its start, so S and S with
/// every triangle reversed get the same strip, and the same map.
fn diagonal_b0_a1(positions: &[Point3<f64>], [a0, b0, a1, b1]: [u32; 4], a0_larger: bool) -> bool {
    let at = |v: u32| positions[v as usize];
    let main = (at(b0) - at(a1)).norm();
    let other = (at(a0) - at(b1)).norm();
    if (main - other).abs() > 1e-9 * (main + other) {
        main < other
    } else {
        a0_larger
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ventricle::error::VentricleError;
    use crate::ventricle::landmarks::DEFAULT_SNAP_MM;
    use proptest::prelude::*;
    use std::f64::consts::TAU;
    use unfold_mesh::nalgebra::Vector3;
    use unfold_mesh::repair::repair_tri_mesh;
    use unfold_mesh::shapes::{VentricleParams, ventricle_cup};
    use unfold_param::initializer::disk_boundary_loop;

    /// Below the rim, heights fade out over this many mm.
    const FADE_MM: f64 = 15.0;

    /// The default cup (long axis +z, rim at `z = 0`) with its top moved
    /// along the long axis by `amplitude * sin(2 azimuth + phase)`, faded
    /// out linearly over `FADE_MM` below the rim: a saddle-shaped rim
    /// whose least-squares plane is still `z = 0`.
    fn saddle(amplitude: f64, phase: f64) -> (TriMesh, Landmarks) {
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let mut s = cup.surface;
        for p in &mut s.positions {
            if p.z > -FADE_MM {
                let az = p.y.atan2(p.x);
                p.z += amplitude * (2.0 * az + phase).sin() * (1.0 + p.z / FADE_MM);
            }
        }
        let l = Landmarks::resolve(
            &s,
            &s.positions[cup.anterior_index],
            &s.positions[cup.inferior_index],
            None,
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        (s, l)
    }

    /// Every invariant of a strip closing a non-planar rim; returns the
    /// strip's layer count.
    fn check_strip(s: &TriMesh, l: &Landmarks, e: &ExtendedSurface) -> usize {
        let n = s.positions.len();
        let m = l.rim.len();
        let pos = &e.surface.positions;
        // S is kept, first
        assert_eq!(e.original_vertices, n);
        assert_eq!(&pos[..n], &s.positions[..]);
        assert_eq!(&e.surface.triangles[..s.triangles.len()], &s.triangles[..]);
        // layers of the rim's copies, two triangles per rim edge and layer
        let added = pos.len() - n;
        assert_eq!(added % m, 0);
        let layers = added / m;
        assert!((1..=64).contains(&layers), "{layers} layers");
        assert_eq!(
            e.surface.triangles.len(),
            s.triangles.len() + 2 * m * layers
        );
        // the landmarks are the same rim positions, on the new rim; the apex kept
        assert_eq!(e.landmarks.rim.len(), m);
        assert_eq!(
            (e.landmarks.anterior, e.landmarks.inferior, e.landmarks.apex),
            (l.anterior, l.inferior, l.apex)
        );
        assert_eq!(e.landmarks.snap_distances_mm, l.snap_distances_mm);
        // still a disk, whose one boundary loop is the new rim
        let mut loop_ = disk_boundary_loop(&e.surface).unwrap();
        let k = loop_
            .iter()
            .position(|&v| v == e.landmarks.rim[0])
            .expect("the new rim is the boundary");
        loop_.rotate_left(k);
        assert_eq!(loop_, e.landmarks.rim);
        // consistently oriented with S
        let (_, report) = repair_tri_mesh(&e.surface).unwrap();
        assert_eq!(report.flipped, 0, "{report:?}");
        assert_eq!(report.components, 1);
        // in the frame of S: columns straight down along e3 from the rim
        // vertices to the plane delta below the lowest one
        let frame = BasalFrame::new(s, l).unwrap();
        let heights: Vec<f64> = l
            .rim
            .iter()
            .map(|&v| frame.local(&s.positions[v as usize])[2])
            .collect();
        let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let low = heights.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(low.abs() < 1e-9, "lowest rim height {low}");
        let edges: Vec<f64> = (0..m)
            .map(|k| {
                (s.positions[l.rim[k] as usize] - s.positions[l.rim[(k + 1) % m] as usize]).norm()
            })
            .collect();
        let delta = 0.5 * edges.iter().sum::<f64>() / m as f64;
        assert!((e.strip_height_mm - (top + delta)).abs() < 1e-9);
        assert_eq!(layers, ((top + delta) / (2.0 * delta)).ceil() as usize);
        for (k, &v) in l.rim.iter().enumerate() {
            let q0 = frame.local(&s.positions[v as usize]);
            for layer in 1..=layers {
                let w = n + (layer - 1) * m + k;
                let q = frame.local(&pos[w]);
                assert!((q[0] - q0[0]).abs() < 1e-9 && (q[1] - q0[1]).abs() < 1e-9);
                let want = heights[k] - (heights[k] + delta) * layer as f64 / layers as f64;
                assert!((q[2] - want).abs() < 1e-9, "{} vs {want}", q[2]);
            }
            // the new rim vertex k is the bottom of column k, at -delta
            assert_eq!(e.landmarks.rim[k] as usize, n + (layers - 1) * m + k);
        }
        // the new rim is planar: every vertex at the same height along e3,
        // and its own frame sees no strip to add
        let again = BasalFrame::new(&e.surface, &e.landmarks).unwrap();
        for &v in &e.landmarks.rim {
            let z = again.local(&pos[v as usize])[2];
            assert!(z.abs() < 1e-9, "new rim height {z}");
        }
        let twice = close_base(&e.surface, &e.landmarks).unwrap();
        assert_eq!(twice.strip_height_mm, 0.0);
        assert_eq!(twice.surface.positions, e.surface.positions);
        // strip triangles: outward (away from the long axis, like S's
        // normals) and no smaller than half a layer times the shortest
        // horizontal rim edge
        let e3: Vector3<f64> = frame.rotation.row(2).transpose();
        let horizontal = |d: Vector3<f64>| d - e3 * d.dot(&e3);
        let shortest = (0..m)
            .map(|k| {
                horizontal(
                    s.positions[l.rim[(k + 1) % m] as usize] - s.positions[l.rim[k] as usize],
                )
                .norm()
            })
            .fold(f64::INFINITY, f64::min);
        for t in &e.surface.triangles[s.triangles.len()..] {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            let normal = (b - a).cross(&(c - a));
            let area = 0.5 * normal.norm();
            assert!(
                area >= 0.5 * (delta / layers as f64) * shortest * (1.0 - 1e-9),
                "area {area}"
            );
            let out = horizontal((a.coords + b.coords + c.coords) / 3.0 - frame.origin.coords);
            assert!(normal.dot(&out) > 0.0, "{t:?} faces the axis");
        }
        layers
    }

    #[test]
    fn a_planar_rim_is_left_as_it_is() {
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let l = Landmarks::resolve(
            &cup.surface,
            &cup.anterior,
            &cup.inferior,
            None,
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        let e = close_base(&cup.surface, &l).unwrap();
        assert_eq!(e.strip_height_mm, 0.0);
        assert_eq!(e.original_vertices, cup.surface.positions.len());
        assert_eq!(e.surface.positions, cup.surface.positions);
        assert_eq!(e.surface.triangles, cup.surface.triangles);
        assert_eq!(e.landmarks, l);
    }

    #[test]
    fn a_saddle_rim_is_closed_by_a_strip_to_a_planar_rim() {
        let (s, l) = saddle(3.0, 0.4);
        let e = close_base(&s, &l).unwrap();
        let layers = check_strip(&s, &l, &e);
        // heights 0..6 mm above the lowest rim vertex, plus delta
        assert!(
            e.strip_height_mm > 6.0 && e.strip_height_mm < 8.0,
            "{}",
            e.strip_height_mm
        );
        assert!(layers >= 3, "{layers}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn every_saddle_rim_is_closed_by_a_consistent_strip(
            amplitude in 0.5..5.0f64,
            phase in 0.0..TAU,
        ) {
            let (s, l) = saddle(amplitude, phase);
            let e = close_base(&s, &l).unwrap();
            check_strip(&s, &l, &e);
            prop_assert!(e.strip_height_mm > 1.9 * amplitude, "{} for {amplitude}", e.strip_height_mm);
        }
    }

    /// The strip's triangles as sorted triples of `(vertex of S, layer)`:
    /// what the strip is, whatever order its vertices were made in.
    fn strip_cells(s: &TriMesh, rim: &[u32], e: &ExtendedSurface) -> Vec<[(u32, usize); 3]> {
        let n = s.positions.len();
        let m = rim.len();
        let key = |w: u32| -> (u32, usize) {
            let w = w as usize;
            if w < n {
                (w as u32, 0)
            } else {
                (rim[(w - n) % m], (w - n) / m + 1)
            }
        };
        let mut cells: Vec<[(u32, usize); 3]> = e.surface.triangles[s.triangles.len()..]
            .iter()
            .map(|t| {
                let mut c = t.map(key);
                c.sort();
                c
            })
            .collect();
        cells.sort();
        cells
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(8))]

        /// S with every triangle reversed (its rim walked the other way,
        /// from another start) is closed by the same strip: the same
        /// triangles over the same columns at the same heights.
        #[test]
        fn the_strip_does_not_depend_on_the_winding(
            amplitude in 0.5..5.0f64,
            phase in 0.0..TAU,
        ) {
            let (s, l) = saddle(amplitude, phase);
            let mut r = s.clone();
            for t in &mut r.triangles {
                t.swap(1, 2);
            }
            let lr = Landmarks::resolve(
                &r,
                &s.positions[l.rim[l.anterior] as usize],
                &s.positions[l.rim[l.inferior] as usize],
                None,
                DEFAULT_SNAP_MM,
            )
            .unwrap();
            prop_assert_ne!(&lr.rim, &l.rim);
            let (e, er) = (close_base(&s, &l).unwrap(), close_base(&r, &lr).unwrap());
            prop_assert_eq!(e.surface.positions.len(), er.surface.positions.len());
            prop_assert!((e.strip_height_mm - er.strip_height_mm).abs() < 1e-12);
            // column k stands under the k-th vertex of the rim handed over
            prop_assert_eq!(strip_cells(&s, &l.rim, &e), strip_cells(&r, &lr.rim, &er));
            // the columns' vertices at the same places
            let (rim, rim_r) = (&l.rim, &lr.rim);
            let n = s.positions.len();
            let m = rim.len();
            for (k, v) in rim.iter().enumerate() {
                let kr = rim_r.iter().position(|w| w == v).unwrap();
                for layer in 0..e.surface.positions.len().saturating_sub(n) / m {
                    let p = e.surface.positions[n + layer * m + k];
                    let q = er.surface.positions[n + layer * m + kr];
                    prop_assert!((p - q).norm() < 1e-12, "{} mm", (p - q).norm());
                }
            }
        }
    }

    #[test]
    fn a_degenerate_rim_is_refused() {
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let s = TriMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(2.0, 0.0, 0.0),
                p(1.0, 1.0, -3.0),
            ],
            vec![[0, 1, 3], [1, 2, 3]],
        );
        let l = Landmarks {
            rim: vec![0, 1, 2],
            anterior: 0,
            inferior: 1,
            apex: 3,
            snap_distances_mm: [0.0; 3],
        };
        match close_base(&s, &l) {
            Err(OrganError::Ventricle(e @ VentricleError::CollinearRim { .. })) => {
                assert!(e.to_string().contains("collinear"), "{e}")
            }
            other => panic!("{other:?}"),
        }
    }
}
