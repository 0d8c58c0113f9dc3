//! A synthetic mitral valve: a saddle-shaped D annulus with two
//! longitude-structured leaflets that coapt without intersecting.

use super::{ArcTable, Pose, check_count, check_positive, check_range, invalid};
use crate::{MeshError, TriMesh};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Largest number of leaflet vertices [`mitral_valve`] agrees to build.
const MAX_VERTICES: usize = 2_000_000;

/// Samples of each Bezier part of a leaflet column before resampling.
const COLUMN_SAMPLES: usize = 64;

/// Parameters of [`mitral_valve`]. All lengths in millimetres.
///
/// The canonical frame (before [`Pose`]): the atrium is on the +z side, the
/// ventricle (where the leaflets hang) on the -z side; the commissures lie
/// on the x axis at `(-d/2, 0, -h/2)` (anterolateral) and `(d/2, 0, -h/2)`
/// (posteromedial), `d = commissural_diameter`, `h = saddle_height`; the
/// anterior annulus is on the +y side. The annulus is
/// `(d/2 cos t, b(t) sin t, -h/2 cos 2t)` with `b = b_a` (anterior,
/// `sin t >= 0`) or `b_p` (posterior), `b_a + b_p = anteroposterior_diameter`:
/// a D shape (flatter anterior arc) whose saddle horns (highest points) are
/// the anterior and posterior midpoints and whose lowest points are the
/// commissures.
///
/// The closed leaflets meet along a coaptation curve that sags posteriorly,
/// `y = -coaptation_offset (1 - (x / (d/2))^2)`: the anterior leaflet hangs
/// from the anterior arc down to just anterior of that curve, the posterior
/// one from the posterior arc down to just posterior of it; near the free
/// edge both run
/// straight down for `coaptation_length`, `coaptation_gap` apart at the
/// middle and wider towards the commissures (`commissure_gap`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ValveParams {
    /// Distance between the two commissures (x), mm. Default 30.
    pub commissural_diameter: f64,
    /// Anteroposterior diameter of the annulus (y), mm. Default 25.
    pub anteroposterior_diameter: f64,
    /// Fraction of the anteroposterior diameter on the anterior side of the
    /// commissural line, in `[0.2, 0.5]`. Default 0.36 (9 mm anterior,
    /// 16 mm posterior).
    pub anterior_fraction: f64,
    /// Saddle height: highest minus lowest annulus point, mm, in
    /// `[0, commissural_diameter / 2]`. Default 6.
    pub saddle_height: f64,
    /// How far the middle of the coaptation curve lies posterior of the
    /// commissural line, mm; less than 0.8 times the posterior semi-axis.
    /// Default 8.
    pub coaptation_offset: f64,
    /// Depth of the top of the coaptation zone at the middle below the
    /// annulus' mean plane `z = 0`, mm; more than `saddle_height / 2`.
    /// Default 6.
    pub coaptation_depth: f64,
    /// Height of the zone where the leaflets run parallel at the middle, mm
    /// (half of it at the commissures). Default 5.
    pub coaptation_length: f64,
    /// Distance between the two leaflets' free edges at the middle, mm
    /// (> 0). Default 1.
    pub coaptation_gap: f64,
    /// Distance between the free edges at the commissural ends, mm
    /// (`>= coaptation_gap`); the gap grows as `gap_mid + (gap_end -
    /// gap_mid) xi^6` along the normalized position `xi` in `[-1, 1]`.
    /// Default 8.
    pub commissure_gap: f64,
    /// How far inside the commissures (along x) the free edges end, mm, in
    /// `(0, commissural_diameter / 4]`. Default 3.
    pub commissure_inset: f64,
    /// Billow of the leaflet bodies towards the atrium, in `[0, 1]`: the
    /// relative length of the handles of the Bezier curve each column follows
    /// from the annulus (leaving horizontally) to the coaptation zone
    /// (arriving vertically); 0 gives straight columns. Default 0.4.
    pub billow: f64,
    /// Annulus resolution: segments of the closed annulus ring, split between
    /// the arcs in proportion to their lengths (at least 2 each). In
    /// `[6, 20000]`. Default 96.
    pub annulus_segments: usize,
    /// Segments of every column from the annulus to the free edge. In
    /// `[2, 2000]`. Default 16.
    pub depth_segments: usize,
    /// Rigid motion applied at the end. Default identity.
    pub pose: Pose,
}

impl Default for ValveParams {
    fn default() -> Self {
        ValveParams {
            commissural_diameter: 30.0,
            anteroposterior_diameter: 25.0,
            anterior_fraction: 0.36,
            saddle_height: 6.0,
            coaptation_offset: 8.0,
            coaptation_depth: 6.0,
            coaptation_length: 5.0,
            coaptation_gap: 1.0,
            commissure_gap: 8.0,
            commissure_inset: 3.0,
            billow: 0.4,
            annulus_segments: 96,
            depth_segments: 16,
            pose: Pose::identity(),
        }
    }
}

impl ValveParams {
    /// Anterior and posterior semi-axes `(b_a, b_p)` of the annulus along y.
    pub fn semi_axes(&self) -> (f64, f64) {
        let ap = self.anteroposterior_diameter;
        (
            ap * self.anterior_fraction,
            ap * (1.0 - self.anterior_fraction),
        )
    }

    /// Checks every parameter; the error names the offending one.
    pub fn validate(&self) -> Result<(), MeshError> {
        const W: &str = "mitral_valve";
        check_positive(W, "commissural_diameter", self.commissural_diameter)?;
        check_positive(W, "anteroposterior_diameter", self.anteroposterior_diameter)?;
        check_range(W, "anterior_fraction", self.anterior_fraction, 0.2, 0.5)?;
        let half = 0.5 * self.commissural_diameter;
        check_range(W, "saddle_height", self.saddle_height, 0.0, half)?;
        let (_, bp) = self.semi_axes();
        check_positive(W, "coaptation_offset", self.coaptation_offset)?;
        if self.coaptation_offset >= 0.8 * bp {
            return Err(invalid(format!(
                "{W}: coaptation_offset = {} mm must be less than 0.8 times the posterior \
                 semi-axis ({} mm)",
                self.coaptation_offset,
                0.8 * bp
            )));
        }
        check_positive(W, "coaptation_depth", self.coaptation_depth)?;
        if self.coaptation_depth <= 0.5 * self.saddle_height {
            return Err(invalid(format!(
                "{W}: coaptation_depth = {} mm must exceed half the saddle height ({} mm)",
                self.coaptation_depth,
                0.5 * self.saddle_height
            )));
        }
        check_range(
            W,
            "coaptation_length",
            self.coaptation_length,
            0.0,
            self.anteroposterior_diameter,
        )?;
        check_positive(W, "coaptation_gap", self.coaptation_gap)?;
        check_positive(W, "commissure_gap", self.commissure_gap)?;
        if self.commissure_gap < self.coaptation_gap {
            return Err(invalid(format!(
                "{W}: commissure_gap = {} mm must be at least coaptation_gap = {} mm",
                self.commissure_gap, self.coaptation_gap
            )));
        }
        if self.coaptation_offset + 0.5 * self.commissure_gap >= bp {
            return Err(invalid(format!(
                "{W}: coaptation_offset + commissure_gap / 2 = {} mm must stay inside the \
                 posterior semi-axis ({bp} mm)",
                self.coaptation_offset + 0.5 * self.commissure_gap
            )));
        }
        check_positive(W, "commissure_inset", self.commissure_inset)?;
        check_range(
            W,
            "commissure_inset",
            self.commissure_inset,
            0.0,
            0.5 * half,
        )?;
        check_range(W, "billow", self.billow, 0.0, 1.0)?;
        check_count(W, "annulus_segments", self.annulus_segments, 6, 20_000)?;
        check_count(W, "depth_segments", self.depth_segments, 2, 2_000)?;
        let nv = (self.annulus_segments + 2) * (self.depth_segments + 1);
        if nv > MAX_VERTICES {
            return Err(invalid(format!(
                "{W}: annulus_segments = {} and depth_segments = {} would give {nv} vertices \
                 (more than {MAX_VERTICES}); lower the resolution",
                self.annulus_segments, self.depth_segments
            )));
        }
        self.pose.check(W)
    }
}

/// A synthetic mitral valve. Everything is in world coordinates (after the
/// pose).
#[derive(Debug, Clone, PartialEq)]
pub struct ValveShape {
    /// The closed annulus ring, clockwise seen from the atrium, starting at
    /// the anterolateral commissure (index 0), then the anterior arc, the
    /// posteromedial commissure (`commissures[1]`) and the posterior arc.
    pub annulus: Vec<Point3<f64>>,
    /// Indices into `annulus` of the anterolateral (`0`) and posteromedial
    /// commissures.
    pub commissures: [usize; 2],
    /// The anterior leaflet: disk topology, a grid of
    /// `anterior_longitudes.len()` columns by `depth_segments + 1` rows,
    /// normals towards the atrium side.
    pub anterior: TriMesh,
    /// The posterior leaflet, like `anterior`.
    pub posterior: TriMesh,
    /// Per column of the anterior leaflet, in annulus order: its vertex
    /// indices from the annulus to the free edge.
    pub anterior_longitudes: Vec<Vec<u32>>,
    /// Per column of the posterior leaflet, in annulus order.
    pub posterior_longitudes: Vec<Vec<u32>>,
    /// The anterior leaflet's annulus vertices in annulus order (from the
    /// anterolateral to the posteromedial commissure).
    pub anterior_annulus: Vec<u32>,
    /// For each of `anterior_annulus`, its index into `annulus` (the vertex
    /// positions are identical).
    pub anterior_annulus_ring: Vec<usize>,
    /// The posterior leaflet's annulus vertices in annulus order (from the
    /// posteromedial to the anterolateral commissure).
    pub posterior_annulus: Vec<u32>,
    /// For each of `posterior_annulus`, its index into `annulus` (the last
    /// one is 0, the anterolateral commissure).
    pub posterior_annulus_ring: Vec<usize>,
    /// Unit vector towards the atrium (the canonical +z after the pose).
    pub atrium_direction: Vector3<f64>,
    /// The parameters that produced it.
    pub params: ValveParams,
}

/// Point of the annulus at ellipse parameter `t`.
fn ring_point(p: &ValveParams, t: f64) -> Point3<f64> {
    let (ba, bp) = p.semi_axes();
    let b = if t.sin() >= 0.0 { ba } else { bp };
    Point3::new(
        0.5 * p.commissural_diameter * t.cos(),
        b * t.sin(),
        -0.5 * p.saddle_height * (2.0 * t).cos(),
    )
}

/// Cubic Bezier.
fn bezier(p: [Point3<f64>; 4], t: f64) -> Point3<f64> {
    let s = 1.0 - t;
    Point3::from(
        p[0].coords * (s * s * s)
            + p[1].coords * (3.0 * s * s * t)
            + p[2].coords * (3.0 * s * t * t)
            + p[3].coords * (t * t * t),
    )
}

/// `n + 1` points equally spaced in arc length along a polyline (the first
/// is exactly `poly[0]`).
fn resample(poly: &[Point3<f64>], n: usize) -> Vec<Point3<f64>> {
    let mut cum = vec![0.0];
    for w in poly.windows(2) {
        let last = cum[cum.len() - 1];
        cum.push(last + (w[1] - w[0]).norm());
    }
    let total = cum[cum.len() - 1];
    let mut out = vec![poly[0]];
    let mut seg = 0;
    for k in 1..=n {
        let s = total * k as f64 / n as f64;
        while seg + 2 < cum.len() && cum[seg + 1] < s {
            seg += 1;
        }
        let (s0, s1) = (cum[seg], cum[seg + 1]);
        let w = if s1 > s0 {
            ((s - s0) / (s1 - s0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        out.push(poly[seg] + (poly[seg + 1] - poly[seg]) * w);
    }
    out
}

/// One leaflet as a column-major grid; `anterior` selects the side of the
/// coaptation curve. `arc` are the annulus points of the leaflet in annulus
/// order; column `i` uses the arc-length fraction `u_i = i / (len - 1)`.
fn leaflet(p: &ValveParams, arc: &[Point3<f64>], anterior: bool) -> (TriMesh, Vec<Vec<u32>>) {
    let half = 0.5 * p.commissural_diameter;
    let xf = half - p.commissure_inset;
    let h2 = 0.5 * p.saddle_height;
    let z_mid = -p.coaptation_depth;
    let z_end = -h2 - 0.6 * (p.coaptation_depth - h2);
    let sign = if anterior { 1.0 } else { -1.0 };
    let rows = p.depth_segments;
    let cols = arc.len();
    let mut positions = Vec::with_capacity(cols * (rows + 1));
    let mut longitudes = Vec::with_capacity(cols);
    for (i, &a) in arc.iter().enumerate() {
        let u = i as f64 / (cols - 1) as f64;
        // Free-edge target in plan: along the coaptation curve.
        let x_t = -sign * xf * (PI * u).cos();
        let xi = x_t / xf;
        let gap = p.coaptation_gap + (p.commissure_gap - p.coaptation_gap) * xi.powi(6);
        let y_sep = -p.coaptation_offset * (1.0 - (x_t / half).powi(2));
        let y_t = y_sep + sign * 0.5 * gap;
        // Columns near the commissures reach only part of the way (curtain).
        let reach = 1.0 - 0.5 * (1.0 - (PI * u).sin()).powi(2);
        let cx = a.x + reach * (x_t - a.x);
        let cy = a.y + reach * (y_t - a.y);
        let cz = z_end + (z_mid - z_end) * (1.0 - xi * xi);
        let c = Point3::new(cx, cy, cz);
        let f = Point3::new(
            cx,
            cy,
            cz - p.coaptation_length * (0.5 + 0.5 * (1.0 - xi * xi)),
        );
        let horiz = Vector3::new(cx - a.x, cy - a.y, 0.0);
        let k1 = p.billow * horiz.norm();
        let dir = if horiz.norm() > 0.0 {
            horiz.normalize()
        } else {
            Vector3::zeros()
        };
        let k2 = p.billow * (a.z - cz);
        let ctrl = [a, a + dir * k1, c + Vector3::new(0.0, 0.0, k2), c];
        let mut poly: Vec<Point3<f64>> = (0..=COLUMN_SAMPLES)
            .map(|s| bezier(ctrl, s as f64 / COLUMN_SAMPLES as f64))
            .collect();
        poly[0] = a;
        if f != c {
            poly.push(f);
        }
        let column = resample(&poly, rows);
        let start = positions.len() as u32;
        longitudes.push((start..start + rows as u32 + 1).collect());
        positions.extend(column);
    }
    let v = |i: usize, k: usize| (i * (rows + 1) + k) as u32;
    let mut triangles = Vec::with_capacity(2 * (cols - 1) * rows);
    for i in 0..cols - 1 {
        for k in 0..rows {
            let (p00, p01, p10, p11) = (v(i, k), v(i, k + 1), v(i + 1, k), v(i + 1, k + 1));
            let d1 = (positions[p01 as usize] - positions[p10 as usize]).norm_squared();
            let d2 = (positions[p00 as usize] - positions[p11 as usize]).norm_squared();
            // Cyclic order p00 -> p01 -> p11 -> p10 (normal towards the atrium).
            if d1 <= d2 {
                triangles.push([p00, p01, p10]);
                triangles.push([p10, p01, p11]);
            } else {
                triangles.push([p00, p01, p11]);
                triangles.push([p00, p11, p10]);
            }
        }
    }
    (TriMesh::new(positions, triangles), longitudes)
}

/// Builds the synthetic mitral valve described by `p`.
///
/// The annulus is sampled at equal arc lengths on each arc (the two
/// commissures exactly at `(-+d/2, 0, -h/2)`; the anterior arc gets an even
/// number of segments, so its saddle horn `(0, b_a, h/2)` is a vertex and
/// the sampled ring has exactly the saddle height). Each leaflet is a grid of
/// columns (one per annulus point of its arc, in annulus order) by
/// `depth_segments + 1` rows; every column starts exactly at its annulus
/// point, follows a cubic Bezier curve that leaves the annulus horizontally
/// towards its target on the coaptation curve (offset by half the local
/// gap to its leaflet's side) and arrives there vertically, then runs
/// straight down through the coaptation zone to the free edge; its vertices
/// are equally spaced in arc length. Columns near the commissures reach only
/// half-way to their target (`reach = 1 - (1 - sin(pi u))^2 / 2` along
/// the leaflet), so the leaflets there hang like curtains and the two
/// commissural columns that share a commissure diverge. Each grid quad is
/// split along its shorter diagonal.
///
/// The anterior leaflet is the longer one when
/// `b_a + coaptation_offset > b_p - coaptation_offset` (as with the defaults:
/// about 25 mm against 17 mm at the middle).
///
/// At the defaults: 96 annulus points (42 segments on the anterior arc,
/// 54 on the posterior), anterior 731 vertices and 1,344 triangles,
/// posterior 935 vertices and 1,728 triangles; smallest angle about 16
/// degrees (at the short commissural columns), the free edges within 2 mm
/// of each other along about 45 % of their length, and the closest
/// non-shared vertices of the two leaflets about 0.5 mm apart.
pub fn mitral_valve(p: &ValveParams) -> Result<ValveShape, MeshError> {
    p.validate()?;
    let half = 0.5 * p.commissural_diameter;
    let h2 = 0.5 * p.saddle_height;
    // Anterior arc: t from pi down to 0; posterior arc: t from 0 down to -pi.
    let ant = |tau: f64| ring_point(p, PI - tau);
    let post = |tau: f64| ring_point(p, -tau);
    let ant_table = ArcTable::new(ant, 0.0, PI, 4096);
    let post_table = ArcTable::new(post, 0.0, PI, 4096);
    let (la, lp) = (ant_table.length(), post_table.length());
    let n = p.annulus_segments;
    // An even anterior count puts a vertex exactly on the anterior saddle
    // horn (and on the posterior one too when `n` is even).
    let na = (2 * (0.5 * n as f64 * la / (la + lp)).round() as usize).clamp(2, n - 2);
    let np = n - na;

    let k_al = Point3::new(-half, 0.0, -h2);
    let k_pm = Point3::new(half, 0.0, -h2);
    let mut annulus = Vec::with_capacity(n);
    annulus.push(k_al);
    for i in 1..na {
        annulus.push(if 2 * i == na {
            ring_point(p, 0.5 * PI)
        } else {
            ant(ant_table.param_at_fraction(i as f64 / na as f64))
        });
    }
    annulus.push(k_pm);
    for j in 1..np {
        annulus.push(if 2 * j == np {
            ring_point(p, -0.5 * PI)
        } else {
            post(post_table.param_at_fraction(j as f64 / np as f64))
        });
    }

    let ant_ring: Vec<usize> = (0..=na).collect();
    let post_ring: Vec<usize> = (na..=n).map(|r| r % n).collect();
    let ant_arc: Vec<Point3<f64>> = ant_ring.iter().map(|&r| annulus[r]).collect();
    let post_arc: Vec<Point3<f64>> = post_ring.iter().map(|&r| annulus[r]).collect();
    let (mut anterior, anterior_longitudes) = leaflet(p, &ant_arc, true);
    let (mut posterior, posterior_longitudes) = leaflet(p, &post_arc, false);
    let anterior_annulus: Vec<u32> = anterior_longitudes.iter().map(|c| c[0]).collect();
    let posterior_annulus: Vec<u32> = posterior_longitudes.iter().map(|c| c[0]).collect();

    let pose = p.pose;
    pose.apply_all(&mut annulus);
    pose.apply_all(&mut anterior.positions);
    pose.apply_all(&mut posterior.positions);
    // Bit-identical shared positions after the pose too.
    for (&v, &r) in anterior_annulus.iter().zip(&ant_ring) {
        anterior.positions[v as usize] = annulus[r];
    }
    for (&v, &r) in posterior_annulus.iter().zip(&post_ring) {
        posterior.positions[v as usize] = annulus[r];
    }
    crate::geometry::check_finite(&anterior.positions)?;
    crate::geometry::check_finite(&posterior.positions)?;
    Ok(ValveShape {
        annulus,
        commissures: [0, na],
        anterior,
        posterior,
        anterior_longitudes,
        posterior_longitudes,
        anterior_annulus,
        anterior_annulus_ring: ant_ring,
        posterior_annulus,
        posterior_annulus_ring: post_ring,
        atrium_direction: pose.apply_vector(&Vector3::z()),
        params: p.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use super::*;
    use crate::geometry::point_segment_distance;
    use proptest::prelude::*;

    fn column_length(mesh: &TriMesh, col: &[u32]) -> f64 {
        col.windows(2)
            .map(|w| (mesh.positions[w[1] as usize] - mesh.positions[w[0] as usize]).norm())
            .sum()
    }

    /// Signed area of the annulus projected on the plane normal to `up`
    /// (positive = counter-clockwise seen from `up`).
    fn projected_signed_area(pts: &[Point3<f64>], up: &Vector3<f64>) -> f64 {
        let n = pts.len();
        (0..n)
            .map(|i| pts[i].coords.cross(&pts[(i + 1) % n].coords).dot(up))
            .sum::<f64>()
            * 0.5
    }

    fn check_leaflet(
        shape: &ValveShape,
        mesh: &TriMesh,
        longitudes: &[Vec<u32>],
        annulus: &[u32],
        ring: &[usize],
    ) {
        let p = &shape.params;
        assert_oriented_manifold(&mesh.triangles);
        assert_eq!(euler_tri(&mesh.triangles), 1);
        let loops = boundary_loops(&mesh.triangles);
        assert_eq!(loops.len(), 1);
        assert_eq!(
            loops[0].len(),
            2 * (longitudes.len() - 1) + 2 * p.depth_segments
        );
        let (ratio, angle) = (
            min_area_ratio(&mesh.positions, &mesh.triangles),
            min_angle_deg(&mesh.positions, &mesh.triangles),
        );
        assert!(
            ratio > 0.02 && angle > 5.0,
            "min area ratio {ratio}, min angle {angle}"
        );
        // Longitudes cover every vertex once and start at the annulus.
        let mut all: Vec<u32> = longitudes.iter().flatten().copied().collect();
        all.sort_unstable();
        assert_eq!(all, (0..mesh.num_vertices() as u32).collect::<Vec<_>>());
        for (col, (&a, &r)) in longitudes.iter().zip(annulus.iter().zip(ring)) {
            assert_eq!(col.len(), p.depth_segments + 1);
            assert_eq!(col[0], a);
            assert_eq!(mesh.positions[a as usize], shape.annulus[r]);
        }
        // Consecutive ring indices.
        let n = shape.annulus.len();
        for w in ring.windows(2) {
            assert_eq!((w[0] + 1) % n, w[1]);
        }
        // Normals towards the atrium: on the whole and at the annulus row.
        let up = shape.atrium_direction;
        assert!(area_vector_sum(&mesh.positions, &mesh.triangles).dot(&up) > 0.0);
        let top: std::collections::HashSet<u32> = annulus.iter().copied().collect();
        let mut up_tris = 0;
        let mut top_tris = 0;
        for t in &mesh.triangles {
            if t.iter().filter(|v| top.contains(v)).count() == 2 {
                top_tris += 1;
                let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                if (b - a).cross(&(c - a)).dot(&up) > 0.0 {
                    up_tris += 1;
                }
            }
        }
        assert!(
            up_tris * 10 >= top_tris * 9,
            "{up_tris} of {top_tris} annulus triangles face the atrium"
        );
    }

    fn check_valve(shape: &ValveShape) {
        let p = &shape.params;
        let n = shape.annulus.len();
        assert_eq!(n, p.annulus_segments);
        assert_eq!(shape.commissures[0], 0);
        let up = shape.atrium_direction;
        // Clockwise seen from the atrium.
        assert!(projected_signed_area(&shape.annulus, &up) < 0.0);
        // Saddle height.
        let heights: Vec<f64> = shape.annulus.iter().map(|q| q.coords.dot(&up)).collect();
        let range = heights.iter().copied().fold(f64::MIN, f64::max)
            - heights.iter().copied().fold(f64::MAX, f64::min);
        assert!(
            (range - p.saddle_height).abs() <= 1e-9 * (1.0 + p.saddle_height),
            "saddle {range}"
        );
        // Commissures are the lowest points.
        let low = heights.iter().copied().fold(f64::MAX, f64::min);
        for &c in &shape.commissures {
            assert!((heights[c] - low).abs() < 1e-9);
        }
        check_leaflet(
            shape,
            &shape.anterior,
            &shape.anterior_longitudes,
            &shape.anterior_annulus,
            &shape.anterior_annulus_ring,
        );
        check_leaflet(
            shape,
            &shape.posterior,
            &shape.posterior_longitudes,
            &shape.posterior_annulus,
            &shape.posterior_annulus_ring,
        );
        // Commissures shared; the arcs together cover the ring.
        let [al, pm] = shape.commissures;
        assert_eq!(shape.anterior_annulus_ring[0], al);
        assert_eq!(*shape.anterior_annulus_ring.last().unwrap(), pm);
        assert_eq!(shape.posterior_annulus_ring[0], pm);
        assert_eq!(*shape.posterior_annulus_ring.last().unwrap(), al);
        assert_eq!(
            shape.anterior_annulus_ring.len() + shape.posterior_annulus_ring.len(),
            n + 2
        );
        // Every leaflet vertex hangs below the annulus' highest point.
        let top = heights.iter().copied().fold(f64::MIN, f64::max);
        for q in shape
            .anterior
            .positions
            .iter()
            .chain(&shape.posterior.positions)
        {
            assert!(q.coords.dot(&up) <= top + 1e-9);
        }
        // Anterior leaflet longer than the posterior at the middle.
        let mid_a = &shape.anterior_longitudes[shape.anterior_longitudes.len() / 2];
        let mid_p = &shape.posterior_longitudes[shape.posterior_longitudes.len() / 2];
        let (la, lp) = (
            column_length(&shape.anterior, mid_a),
            column_length(&shape.posterior, mid_p),
        );
        let (ba, bp) = p.semi_axes();
        if ba + p.coaptation_offset > bp - p.coaptation_offset + 4.0 {
            assert!(la > lp + 1.0, "anterior {la} vs posterior {lp}");
        }
        // No intersection between the leaflets (away from the shared
        // commissure vertices) and clear separation of their vertices.
        let comm: Vec<Point3<f64>> = shape
            .commissures
            .iter()
            .map(|&c| shape.annulus[c])
            .collect();
        let is_comm = |q: &Point3<f64>| comm.iter().any(|c| c == q);
        let mut min_d = f64::INFINITY;
        for qa in shape.anterior.positions.iter().filter(|q| !is_comm(q)) {
            for qp in shape.posterior.positions.iter().filter(|q| !is_comm(q)) {
                min_d = min_d.min((qa - qp).norm());
            }
        }
        let spacing = 0.5 * p.commissure_gap.min(8.0) / p.depth_segments as f64;
        assert!(min_d > 0.3f64.min(spacing), "leaflets {min_d} mm apart");
        for ta in &shape.anterior.triangles {
            let a = ta.map(|v| shape.anterior.positions[v as usize]);
            if a.iter().any(&is_comm) {
                continue;
            }
            for tp in &shape.posterior.triangles {
                let b = tp.map(|v| shape.posterior.positions[v as usize]);
                if b.iter().any(&is_comm) {
                    continue;
                }
                assert!(
                    !triangles_intersect(a, b),
                    "leaflets intersect: {a:?} {b:?}"
                );
            }
        }
        // Coaptation: free edges within 2 mm over part of their length
        // (distance of each anterior free-edge vertex to the posterior free
        // edge as a polyline, so the check does not depend on resolution).
        let free_p: Vec<Point3<f64>> = shape
            .posterior_longitudes
            .iter()
            .map(|c| shape.posterior.positions[*c.last().unwrap() as usize])
            .collect();
        let close = shape
            .anterior_longitudes
            .iter()
            .filter(|c| {
                let q = shape.anterior.positions[*c.last().unwrap() as usize];
                free_p
                    .windows(2)
                    .any(|w| point_segment_distance(&q, &w[0], &w[1]) < 2.0)
            })
            .count();
        assert!(
            close * 4 >= shape.anterior_longitudes.len(),
            "only {close} of {} anterior free-edge vertices coapt",
            shape.anterior_longitudes.len()
        );
    }

    fn small() -> ValveParams {
        ValveParams {
            annulus_segments: 40,
            depth_segments: 8,
            ..ValveParams::default()
        }
    }

    #[test]
    fn shapes_valve_default_is_valid() {
        let p = ValveParams::default();
        let shape = mitral_valve(&p).unwrap();
        check_valve(&shape);
        assert_eq!(shape.commissures, [0, 42]);
        assert_eq!(shape.anterior.num_vertices(), 43 * 17);
        assert_eq!(shape.anterior.num_triangles(), 2 * 42 * 16);
        assert_eq!(shape.posterior.num_vertices(), 55 * 17);
        assert_eq!(shape.posterior.num_triangles(), 2 * 54 * 16);
        for m in [&shape.anterior, &shape.posterior] {
            assert!(min_angle_deg(&m.positions, &m.triangles) > 15.0);
        }
        // The anterior leaflet is clearly the longer one (about 25 vs 17 mm).
        let mid = |cols: &[Vec<u32>], m: &TriMesh| column_length(m, &cols[cols.len() / 2]);
        let la = mid(&shape.anterior_longitudes, &shape.anterior);
        let lp = mid(&shape.posterior_longitudes, &shape.posterior);
        assert!(
            la > 20.0 && la < 30.0 && lp > 12.0 && lp < 20.0 && la > lp + 5.0,
            "{la} {lp}"
        );
        // Coaptation over a good part of the free edge.
        let free = |cols: &[Vec<u32>], m: &TriMesh| -> Vec<Point3<f64>> {
            cols.iter()
                .map(|c| m.positions[*c.last().unwrap() as usize])
                .collect()
        };
        let fa = free(&shape.anterior_longitudes, &shape.anterior);
        let fp = free(&shape.posterior_longitudes, &shape.posterior);
        let close = fa
            .iter()
            .filter(|q| fp.iter().any(|r| (*q - r).norm() < 2.0))
            .count();
        assert!(close * 5 >= fa.len() * 2, "{close} of {}", fa.len());
        // Anatomical sizes: annulus about 30 x 25 mm.
        let xs: Vec<f64> = shape.annulus.iter().map(|q| q.x).collect();
        let ys: Vec<f64> = shape.annulus.iter().map(|q| q.y).collect();
        let span = |v: &[f64]| {
            v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
        };
        assert!((span(&xs) - 30.0).abs() < 1e-9);
        assert!((span(&ys) - 25.0).abs() < 0.05);
    }

    #[test]
    fn shapes_valve_rejects_bad_parameters() {
        let bad = [
            ValveParams {
                commissural_diameter: 0.0,
                ..small()
            },
            ValveParams {
                anteroposterior_diameter: -1.0,
                ..small()
            },
            ValveParams {
                anterior_fraction: 0.7,
                ..small()
            },
            ValveParams {
                saddle_height: -1.0,
                ..small()
            },
            ValveParams {
                coaptation_offset: 15.0,
                ..small()
            },
            ValveParams {
                coaptation_depth: 2.0,
                ..small()
            },
            ValveParams {
                coaptation_gap: 0.0,
                ..small()
            },
            ValveParams {
                commissure_gap: 0.5,
                ..small()
            },
            ValveParams {
                commissure_inset: 0.0,
                ..small()
            },
            ValveParams {
                billow: 2.0,
                ..small()
            },
            ValveParams {
                annulus_segments: 5,
                ..small()
            },
            ValveParams {
                depth_segments: 1,
                ..small()
            },
            ValveParams {
                annulus_segments: 20_000,
                depth_segments: 2_000,
                ..small()
            },
            ValveParams {
                pose: Pose::new([f64::NAN, 0.0, 0.0], [0.0; 3]),
                ..small()
            },
        ];
        for p in bad {
            match mitral_valve(&p) {
                Err(MeshError::InvalidArgument(msg)) => {
                    assert!(msg.starts_with("mitral_valve"), "{msg}")
                }
                other => panic!("{p:?} gave {other:?}"),
            }
        }
    }

    #[test]
    fn shapes_valve_is_deterministic() {
        let p = small();
        assert_eq!(mitral_valve(&p).unwrap(), mitral_valve(&p).unwrap());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn shapes_valve_valid_for_random_parameters(
            cd in 24.0..40.0f64,
            ap in 20.0..34.0f64,
            frac in 0.3..0.45f64,
            saddle in 0.0..9.0f64,
            offset_frac in 0.3..0.6f64,
            depth_extra in 2.0..8.0f64,
            billow in 0.0..1.0f64,
            rows in 3usize..10,
            extra in 0usize..12,
            roll in -180.0..180.0f64,
            pitch in -90.0..90.0f64,
            yaw in -180.0..180.0f64,
            t in prop::array::uniform3(-300.0..300.0f64),
        ) {
            let bp = ap * (1.0 - frac);
            let p = ValveParams {
                commissural_diameter: cd,
                anteroposterior_diameter: ap,
                anterior_fraction: frac,
                saddle_height: saddle,
                coaptation_offset: offset_frac * bp,
                coaptation_depth: 0.5 * saddle + depth_extra,
                commissure_gap: (0.3 * bp).min(8.0),
                billow,
                // Balanced resolutions (as the defaults, 96 x 16): a very
                // coarse annulus with many rows gives needle triangles at
                // the short commissural columns.
                annulus_segments: 6 * rows + extra,
                depth_segments: rows,
                pose: Pose::new([roll, pitch, yaw], t),
                ..ValveParams::default()
            };
            let shape = mitral_valve(&p).unwrap();
            check_valve(&shape);
            let base = mitral_valve(&ValveParams { pose: Pose::identity(), ..p.clone() }).unwrap();
            prop_assert_eq!(&base.anterior.triangles, &shape.anterior.triangles);
            prop_assert_eq!(&base.posterior.triangles, &shape.posterior.triangles);
            for (a, b) in base.annulus.iter().zip(&shape.annulus) {
                prop_assert!(((a - base.annulus[0]).norm() - (b - shape.annulus[0]).norm()).abs() < 1e-9);
            }
        }
    }
}
