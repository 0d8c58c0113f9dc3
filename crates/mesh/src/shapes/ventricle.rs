//! A synthetic left ventricle: a truncated prolate ellipsoid cup with
//! anatomy inside and landmarks on its basal rim.

use super::{ArcTable, Pose, check_count, check_positive, check_range, invalid};
use crate::geometry::winding_number;
use crate::{MeshError, TriMesh};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Largest number of anatomy points [`ventricle_cup`] agrees to build.
const MAX_POINTS: usize = 1_000_000;

/// Parameters of [`ventricle_cup`]. All lengths in millimetres.
///
/// The canonical frame (before [`Pose`]): the long axis is the z axis, the
/// apex at `(0, 0, -length)` at the bottom, the basal plane `z = 0` at the
/// top (the rim is planar and centred on the origin). The enclosing surface
/// S is the part below `z = 0` of the ellipsoid
/// `(x^2 + y^2) / a^2 + (z - z0)^2 / c^2 = 1` with `a = radius`,
/// `c = length / (1 + base_above_equator)` and `z0 = c - length`. The septum
/// (where the right ventricle attaches) faces +x: the anterior landmark is at
/// azimuth `+landmark_separation_deg / 2` (the +y side), the inferior one at
/// `-landmark_separation_deg / 2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct VentricleParams {
    /// Equatorial (short-axis) radius `a` of S, mm. Default 25.
    pub radius: f64,
    /// Apex-to-base distance along the long axis, mm. Default 60.
    pub length: f64,
    /// Height of the basal plane above the ellipsoid's equator as a fraction
    /// of its long semi-axis `c`, in `[-0.6, 0.6]` (negative: cut below the
    /// equator, the cup widens up to its rim). Default 0.15.
    pub base_above_equator: f64,
    /// Angle about the long axis between the anterior and inferior
    /// landmarks (the RV insertion points), degrees, in `[10, 180]`.
    /// Default 110.
    pub landmark_separation_deg: f64,
    /// Depth of the anatomy points inside S, mm: they lie on the ellipsoid
    /// with semi-axes `a - depth`, `c - depth` (same centre) and at least
    /// `depth` below the basal plane. Default 1.5.
    pub anatomy_point_depth: f64,
    /// Depth of the anatomy surface (an inner cup) inside S, mm, defined
    /// like `anatomy_point_depth`. Default 4.
    pub anatomy_surface_depth: f64,
    /// Number of circumferential rings of anatomy points, at equally spaced
    /// heights between the inner apex and the top (paper section 4.1).
    /// In `[0, 100]`. Default 5.
    pub ring_count: usize,
    /// Points per ring (equally spaced in azimuth), in `[3, 100000]`.
    /// Default 72 (every 5 degrees).
    pub points_per_ring: usize,
    /// Number of longitudinal meridians of anatomy points, equally spaced in
    /// azimuth starting at +x, in `[0, 360]`. Default 12 (every 30 degrees).
    pub meridian_count: usize,
    /// Points per meridian (from just above the apex to the top, equally
    /// spaced in the ellipse parameter), in `[2, 100000]`. Default 24.
    pub points_per_meridian: usize,
    /// Resolution of S: vertex rings from the apex to the rim (the meridian
    /// is split into `rings` equal arc lengths; each ring gets as many
    /// equally spaced vertices as keep the triangles near equilateral). In
    /// `[8, 600]` (the default anatomy depths work from 8 on; thinner
    /// anatomy depths need more rings, see [`ventricle_cup`]). Default 30.
    pub rings: usize,
    /// Rigid motion applied at the end. Default identity.
    pub pose: Pose,
}

impl Default for VentricleParams {
    fn default() -> Self {
        VentricleParams {
            radius: 25.0,
            length: 60.0,
            base_above_equator: 0.15,
            landmark_separation_deg: 110.0,
            anatomy_point_depth: 1.5,
            anatomy_surface_depth: 4.0,
            ring_count: 5,
            points_per_ring: 72,
            meridian_count: 12,
            points_per_meridian: 24,
            rings: 30,
            pose: Pose::identity(),
        }
    }
}

impl VentricleParams {
    /// The ellipsoid's long semi-axis `c = length / (1 + base_above_equator)`.
    pub fn long_semi_axis(&self) -> f64 {
        self.length / (1.0 + self.base_above_equator)
    }

    /// Checks every parameter; the error names the offending one.
    pub fn validate(&self) -> Result<(), MeshError> {
        const W: &str = "ventricle_cup";
        check_positive(W, "radius", self.radius)?;
        check_positive(W, "length", self.length)?;
        check_range(W, "base_above_equator", self.base_above_equator, -0.6, 0.6)?;
        check_range(
            W,
            "landmark_separation_deg",
            self.landmark_separation_deg,
            10.0,
            180.0,
        )?;
        check_positive(W, "anatomy_point_depth", self.anatomy_point_depth)?;
        check_positive(W, "anatomy_surface_depth", self.anatomy_surface_depth)?;
        let c = self.long_semi_axis();
        let limit = 0.5 * self.radius.min(c);
        for (name, d) in [
            ("anatomy_point_depth", self.anatomy_point_depth),
            ("anatomy_surface_depth", self.anatomy_surface_depth),
        ] {
            if d >= limit {
                return Err(invalid(format!(
                    "{W}: {name} = {d} mm must be less than half the smaller semi-axis ({limit} mm)"
                )));
            }
        }
        check_count(W, "ring_count", self.ring_count, 0, 100)?;
        check_count(W, "points_per_ring", self.points_per_ring, 3, 100_000)?;
        check_count(W, "meridian_count", self.meridian_count, 0, 360)?;
        check_count(
            W,
            "points_per_meridian",
            self.points_per_meridian,
            2,
            100_000,
        )?;
        let total =
            self.ring_count * self.points_per_ring + self.meridian_count * self.points_per_meridian;
        if total > MAX_POINTS {
            return Err(invalid(format!(
                "{W}: {total} anatomy points requested, more than {MAX_POINTS}"
            )));
        }
        check_count(W, "rings", self.rings, 8, 600)?;
        self.pose.check(W)
    }
}

/// A synthetic ventricle: the enclosing surface S, anatomy inside it and
/// landmarks. Everything is in world coordinates (after the pose).
#[derive(Debug, Clone, PartialEq)]
pub struct VentricleShape {
    /// S: disk topology (its one boundary loop is the planar basal rim),
    /// consistently oriented with outward normals.
    pub surface: TriMesh,
    /// A smaller concentric cup strictly inside S (closed by its basal
    /// plane): the ellipsoid `anatomy_surface_depth` inside S, cut
    /// `anatomy_surface_depth` below the basal plane; outward normals.
    pub anatomy: TriMesh,
    /// Points strictly inside S: rings at equally spaced heights followed by
    /// meridians (see [`VentricleShape::anatomy_rings`] and
    /// [`VentricleShape::anatomy_meridians`]).
    pub anatomy_points: Vec<Point3<f64>>,
    /// Indices into `anatomy_points` of each ring, bottom to top, each ring
    /// by increasing azimuth.
    pub anatomy_rings: Vec<Vec<usize>>,
    /// Indices into `anatomy_points` of each meridian (azimuths
    /// `360 k / meridian_count` degrees from the septal +x direction), apex
    /// to base.
    pub anatomy_meridians: Vec<Vec<usize>>,
    /// Vertex indices of S's boundary loop (the basal rim) by increasing
    /// azimuth, i.e. counter-clockwise seen from the base looking towards
    /// the apex (+z before the pose); this is the reverse of the direction
    /// of S's boundary half-edges.
    pub rim: Vec<u32>,
    /// Anterior RV insertion point (a rim vertex of S).
    pub anterior: Point3<f64>,
    /// Inferior RV insertion point (a rim vertex of S).
    pub inferior: Point3<f64>,
    /// The apex (a vertex of S, the farthest from the rim's centroid for the
    /// default proportions).
    pub apex: Point3<f64>,
    /// Index of `anterior` in `surface`.
    pub anterior_index: usize,
    /// Index of `inferior` in `surface`.
    pub inferior_index: usize,
    /// Index of `apex` in `surface`.
    pub apex_index: usize,
    /// Centre of the basal rim.
    pub base_centre: Point3<f64>,
    /// Unit long-axis direction from the apex to the base.
    pub long_axis: Vector3<f64>,
    /// The parameters that produced it.
    pub params: VentricleParams,
}

/// A cup-shaped triangulation of the ellipsoid
/// `(x^2+y^2)/a^2 + (z-z0)^2/c^2 = 1` from its bottom (the apex, parameter
/// `t = 0`) to the parameter `t_end`, in rings of equal meridian arc length.
struct Cup {
    positions: Vec<Point3<f64>>,
    triangles: Vec<[u32; 3]>,
    /// (first vertex, vertex count, angular offset in steps) per ring.
    rings: Vec<(usize, usize, f64)>,
}

/// Builds a [`Cup`]. Ring `k` (`k = 1..=rings`) at arc length
/// `k S / rings` gets `max(5, round(2 pi r_k / ds))` vertices at azimuths
/// `2 pi (i + o_k) / m_k` (`o_k = 1/2` on odd rings, 0 on even ones); ring 0
/// is the apex. Consecutive rings are zipped together by azimuth (always
/// advancing on the ring whose next vertex comes first), the apex by a fan.
/// Triangles are oriented so that their normals point out of the ellipsoid.
/// `top_z`, if given, overrides the last ring's height (to make it exactly
/// planar).
fn ellipsoid_cup(a: f64, c: f64, z0: f64, t_end: f64, rings: usize, top_z: Option<f64>) -> Cup {
    let meridian = |t: f64| Point3::new(a * t.sin(), 0.0, z0 - c * t.cos());
    let table = ArcTable::new(meridian, 0.0, t_end, 4096);
    let ds = table.length() / rings as f64;
    let mut positions = vec![Point3::new(0.0, 0.0, z0 - c)];
    let mut ring_info = vec![(0usize, 1usize, 0.0f64)];
    for k in 1..=rings {
        let t = if k == rings {
            t_end
        } else {
            table.param_at(k as f64 * ds)
        };
        let r = a * t.sin();
        let z = match top_z {
            Some(z) if k == rings => z,
            _ => z0 - c * t.cos(),
        };
        let count = ((TAU * r / ds).round() as usize).max(5);
        let off = if k % 2 == 1 { 0.5 } else { 0.0 };
        ring_info.push((positions.len(), count, off));
        for i in 0..count {
            let phi = TAU * (i as f64 + off) / count as f64;
            positions.push(Point3::new(r * phi.cos(), r * phi.sin(), z));
        }
    }

    let mut triangles = Vec::new();
    for k in 1..=rings {
        let (sa, p, oa) = ring_info[k - 1];
        let (sb, q, ob) = ring_info[k];
        let av = |i: usize| (sa + i % p) as u32;
        let bv = |j: usize| (sb + j % q) as u32;
        if p == 1 {
            for j in 0..q {
                triangles.push([av(0), bv(j), bv(j + 1)]);
            }
            continue;
        }
        let (mut i, mut j) = (0usize, 0usize);
        while i < p || j < q {
            let next_a = (i as f64 + 1.0 + oa) / p as f64;
            let next_b = (j as f64 + 1.0 + ob) / q as f64;
            if j == q || (i < p && next_a <= next_b) {
                triangles.push([av(i), av(i + 1), bv(j)]);
                i += 1;
            } else {
                triangles.push([av(i), bv(j + 1), bv(j)]);
                j += 1;
            }
        }
    }
    // Outward orientation: against the ellipsoid's gradient at the centroid.
    for tri in &mut triangles {
        let [p0, p1, p2] = tri.map(|v| positions[v as usize]);
        let n = (p1 - p0).cross(&(p2 - p0));
        let g = (p0.coords + p1.coords + p2.coords) / 3.0;
        let grad = Vector3::new(g.x / (a * a), g.y / (a * a), (g.z - z0) / (c * c));
        if n.dot(&grad) < 0.0 {
            tri.swap(1, 2);
        }
    }
    Cup {
        positions,
        triangles,
        rings: ring_info,
    }
}

/// Point of the ellipsoid with semi-axes `(a, a, c)` centred at `(0, 0, z0)`
/// at parameter `t` (0 at the bottom) and azimuth `phi`.
#[inline]
fn ellipsoid_point(a: f64, c: f64, z0: f64, t: f64, phi: f64) -> Point3<f64> {
    let r = a * t.sin();
    Point3::new(r * phi.cos(), r * phi.sin(), z0 - c * t.cos())
}

/// Index of the vertex of a ring (`start`, `count`, offset) nearest in
/// azimuth to `phi`.
fn nearest_on_ring(ring: (usize, usize, f64), phi: f64) -> usize {
    let (start, count, off) = ring;
    let mut best = (f64::INFINITY, start);
    for i in 0..count {
        let a = TAU * (i as f64 + off) / count as f64;
        let d = (a - phi).rem_euclid(TAU);
        let d = d.min(TAU - d);
        if d < best.0 {
            best = (d, start + i);
        }
    }
    best.1
}

/// The point of the triangle `(a, b, c)` closest to the origin (Ericson,
/// Real-Time Collision Detection, 5.1.5, with the query point at 0).
fn closest_to_origin(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> Vector3<f64> {
    let ab = b - a;
    let ac = c - a;
    let ap = -a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = -b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = -c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// S closed by a fan over its rim (the last ring, by increasing azimuth)
/// around the rim's centre (its vertices' mean): the positions with the
/// centre appended and the triangles with the fan `(centre, u, v)` (normal
/// +z) appended, for [`winding_number`].
fn closed_by_cap(
    pos: &[Point3<f64>],
    tris: &[[u32; 3]],
    rings: usize,
    ring_info: &[(usize, usize, f64)],
) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let (start, count, _) = ring_info[rings];
    let centre = Point3::from(
        (start..start + count)
            .map(|v| pos[v].coords)
            .sum::<Vector3<f64>>()
            / count as f64,
    );
    let mut closed_pos = pos.to_vec();
    closed_pos.push(centre);
    let hub = pos.len() as u32;
    let mut closed = tris.to_vec();
    for i in 0..count {
        let (u, v) = (start + i, start + (i + 1) % count);
        closed.push([hub, u as u32, v as u32]);
    }
    (closed_pos, closed)
}

/// Builds the synthetic ventricle described by `p`.
///
/// S is the truncated ellipsoid of [`VentricleParams`], triangulated in
/// rings of equal meridian arc length with near-equilateral triangles (see
/// `rings`); the apex is vertex 0, the rim is the last ring (planar, at
/// `z = 0` before the pose). The anatomy (an inner cup surface and the
/// validation points of ALGORITHMS.md 3.7: rings at equally spaced heights
/// and meridians every `360 / meridian_count` degrees, just inside the wall)
/// lies on smaller concentric ellipsoids, strictly inside the ellipsoid and
/// below the basal plane. The generator checks that the anatomy is also
/// strictly inside the *triangulated* S closed by its cap: a coarse S cuts
/// into the ellipsoid by the sagitta of its triangles, and if that reaches
/// (conservatively: the ellipsoid's level set through the deepest point of
/// S's triangles) the anatomy, an [`MeshError::InvalidArgument`] asks for
/// more `rings` or a larger depth.
///
/// At the defaults: S has 1,523 vertices and 2,978 triangles (smallest
/// angle about 41 degrees), the anatomy cup 1,116 vertices and 2,173
/// triangles, and there are 648 anatomy points.
pub fn ventricle_cup(p: &VentricleParams) -> Result<VentricleShape, MeshError> {
    const W: &str = "ventricle_cup";
    p.validate()?;
    let a = p.radius;
    let c = p.long_semi_axis();
    let z0 = c - p.length;
    let t_base = (-p.base_above_equator).acos();
    let s = ellipsoid_cup(a, c, z0, t_base, p.rings, Some(0.0));

    // Anatomy surface: the ellipsoid `d` inside, cut `d` below the base.
    let inner = |d: f64| {
        let (ai, ci) = (a - d, c - d);
        let t_cut = ((z0 + d) / ci).clamp(-1.0, 1.0).acos();
        (ai, ci, t_cut)
    };
    let (ai, ci, ti) = inner(p.anatomy_surface_depth);
    let outer_len =
        ArcTable::new(|t| ellipsoid_point(a, c, z0, t, 0.0), 0.0, t_base, 1024).length();
    let inner_len = ArcTable::new(|t| ellipsoid_point(ai, ci, z0, t, 0.0), 0.0, ti, 1024).length();
    let inner_rings = ((p.rings as f64 * inner_len / outer_len).round() as usize).max(4);
    let anat = ellipsoid_cup(ai, ci, z0, ti, inner_rings, None);

    // Anatomy points.
    let (ap, cp, tp) = inner(p.anatomy_point_depth);
    let mut points = Vec::new();
    let mut rings = Vec::with_capacity(p.ring_count);
    let (z_lo, z_hi) = (z0 - cp, -p.anatomy_point_depth);
    for i in 0..p.ring_count {
        let z = z_lo + (z_hi - z_lo) * (i + 1) as f64 / (p.ring_count + 1) as f64;
        let t = ((z0 - z) / cp).clamp(-1.0, 1.0).acos();
        let mut ring = Vec::with_capacity(p.points_per_ring);
        for j in 0..p.points_per_ring {
            let phi = TAU * j as f64 / p.points_per_ring as f64;
            let mut q = ellipsoid_point(ap, cp, z0, t, phi);
            q.z = z;
            ring.push(points.len());
            points.push(q);
        }
        rings.push(ring);
    }
    let mut meridians = Vec::with_capacity(p.meridian_count);
    for k in 0..p.meridian_count {
        let phi = TAU * k as f64 / p.meridian_count as f64;
        let mut mer = Vec::with_capacity(p.points_per_meridian);
        for j in 1..=p.points_per_meridian {
            let t = tp * j as f64 / p.points_per_meridian as f64;
            mer.push(points.len());
            points.push(ellipsoid_point(ap, cp, z0, t, phi));
        }
        meridians.push(mer);
    }

    // Strictly inside the triangulated S closed by its cap. With
    // F(x) = (x^2 + y^2)/a^2 + (z - z0)^2/c^2, S's triangles all have
    // F >= f_min (the squared distance from the origin to the triangles
    // mapped to the unit sphere's coordinates), so the convex set
    // {F < f_min, z < 0} meets neither S nor its cap: it lies wholly inside
    // or wholly outside, and one winding number tells which. Anatomy
    // vertices in it put the whole anatomy (triangles too) in it.
    let scaled = |q: &Point3<f64>| Vector3::new(q.x / a, q.y / a, (q.z - z0) / c);
    let f_min = s
        .triangles
        .iter()
        .map(|t| {
            let [p0, p1, p2] = t.map(|v| scaled(&s.positions[v as usize]));
            closest_to_origin(p0, p1, p2).norm_squared()
        })
        .fold(f64::INFINITY, f64::min);
    let margin = 1e-9 * p.length.max(p.radius);
    let level_margin = 1e-9;
    let inside = |q: &Point3<f64>| q.z < -margin && scaled(q).norm_squared() < f_min - level_margin;
    if let Some(q) = points.iter().chain(&anat.positions).find(|q| !inside(q)) {
        return Err(invalid(format!(
            "{W}: the anatomy point ({:.3}, {:.3}, {:.3}) is not safely inside the \
             triangulated surface: rings = {} is too coarse for anatomy depths of {} / {} mm; \
             increase rings or the depths",
            q.x, q.y, q.z, p.rings, p.anatomy_point_depth, p.anatomy_surface_depth
        )));
    }
    let probe = anat.positions[0];
    let (closed_pos, closed) = closed_by_cap(&s.positions, &s.triangles, p.rings, &s.rings);
    let w = winding_number(&probe, &closed_pos, &closed);
    if (w - 1.0).abs() > 0.5 {
        return Err(invalid(format!(
            "{W}: internal check failed: the anatomy lies outside S (winding number {w})"
        )));
    }

    // Landmarks on the rim.
    let rim_ring = s.rings[p.rings];
    let half = 0.5 * p.landmark_separation_deg.to_radians();
    let anterior_index = nearest_on_ring(rim_ring, half);
    let inferior_index = nearest_on_ring(rim_ring, -half);
    if anterior_index == inferior_index {
        return Err(invalid(format!(
            "{W}: the landmarks snap to the same rim vertex: rings = {} is too coarse for a \
             separation of {} degrees",
            p.rings, p.landmark_separation_deg
        )));
    }
    let rim: Vec<u32> = (rim_ring.0..rim_ring.0 + rim_ring.1)
        .map(|v| v as u32)
        .collect();

    // Pose.
    let pose = p.pose;
    let mut s_pos = s.positions;
    let mut a_pos = anat.positions;
    pose.apply_all(&mut s_pos);
    pose.apply_all(&mut a_pos);
    pose.apply_all(&mut points);
    let surface = TriMesh::try_new(s_pos, s.triangles)?;
    let anatomy = TriMesh::try_new(a_pos, anat.triangles)?;
    Ok(VentricleShape {
        anterior: surface.positions[anterior_index],
        inferior: surface.positions[inferior_index],
        apex: surface.positions[0],
        anterior_index,
        inferior_index,
        apex_index: 0,
        base_centre: pose.apply(&Point3::origin()),
        long_axis: pose.apply_vector(&Vector3::z()),
        rim,
        surface,
        anatomy,
        anatomy_points: points,
        anatomy_rings: rings,
        anatomy_meridians: meridians,
        params: p.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use super::*;
    use proptest::prelude::*;

    /// S closed by a fan over its rim (cap normal pointing out of the cup).
    fn closed(shape: &VentricleShape) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let mut pos = shape.surface.positions.clone();
        let mut tris = shape.surface.triangles.clone();
        let centre = pos.len() as u32;
        pos.push(shape.base_centre);
        let loops = boundary_loops(&tris);
        for w in loops[0].windows(2) {
            // Boundary half-edges run a -> b; the cap uses b -> a.
            tris.push([w[1], w[0], centre]);
        }
        let (first, last) = (loops[0][0], *loops[0].last().unwrap());
        tris.push([first, last, centre]);
        (pos, tris)
    }

    fn check_ventricle(shape: &VentricleShape) {
        let s = &shape.surface;
        let p = &shape.params;
        assert_oriented_manifold(&s.triangles);
        let loops = boundary_loops(&s.triangles);
        assert_eq!(loops.len(), 1, "one boundary loop");
        assert_eq!(euler_tri(&s.triangles), 1);
        assert!(min_area_ratio(&s.positions, &s.triangles) > 0.05);
        assert!(min_angle_deg(&s.positions, &s.triangles) > 15.0);
        // The rim: the boundary loop, reversed, by increasing azimuth.
        let mut lp = loops[0].clone();
        lp.reverse();
        let k = lp.iter().position(|&v| v == shape.rim[0]).unwrap();
        lp.rotate_left(k);
        assert_eq!(lp, shape.rim);
        // Planar rim through the base centre, perpendicular to the axis.
        for &v in &shape.rim {
            let d = (s.positions[v as usize] - shape.base_centre).dot(&shape.long_axis);
            assert!(d.abs() < 1e-9, "rim off the basal plane by {d}");
        }
        // Outward: the closed surface has positive volume; the winding number
        // of every anatomy point is 1 and of far points 0.
        let (pos, tris) = closed(shape);
        assert_oriented_manifold(&tris);
        assert_eq!(euler_tri(&tris), 2);
        let vol = enclosed_volume(&pos, &tris);
        let c = p.long_semi_axis();
        let ellipsoid_cap_vol = {
            // Volume of the ellipsoid below the basal plane.
            let h = p.length / c; // cap height in units of c
            std::f64::consts::PI * p.radius * p.radius * c * (h * h - h * h * h / 3.0)
        };
        assert!(
            vol > 0.9 * ellipsoid_cap_vol && vol < ellipsoid_cap_vol,
            "volume {vol} vs {ellipsoid_cap_vol}"
        );
        for q in shape.anatomy_points.iter().chain(&shape.anatomy.positions) {
            let w = winding_number(q, &pos, &tris);
            assert!(
                (w - 1.0).abs() < 1e-6,
                "anatomy point {q} has winding number {w}"
            );
        }
        let far = shape.base_centre + shape.long_axis * 10.0;
        assert!(winding_number(&far, &pos, &tris).abs() < 1e-6);
        // The anatomy cup is a valid cup with outward normals.
        let an = &shape.anatomy;
        assert_oriented_manifold(&an.triangles);
        assert_eq!(boundary_loops(&an.triangles).len(), 1);
        assert_eq!(euler_tri(&an.triangles), 1);
        assert!(area_vector_sum(&an.positions, &an.triangles).dot(&shape.long_axis) < 0.0);
        // Landmarks: rim vertices, apex the far end of the axis.
        assert!(shape.rim.contains(&(shape.anterior_index as u32)));
        assert!(shape.rim.contains(&(shape.inferior_index as u32)));
        assert_eq!(s.positions[shape.anterior_index], shape.anterior);
        assert_eq!(s.positions[shape.inferior_index], shape.inferior);
        assert_eq!(s.positions[shape.apex_index], shape.apex);
        let apex_expected = shape.base_centre - shape.long_axis * p.length;
        assert!((shape.apex - apex_expected).norm() < 1e-9);
        // Anatomy bookkeeping.
        assert_eq!(shape.anatomy_rings.len(), p.ring_count);
        assert_eq!(shape.anatomy_meridians.len(), p.meridian_count);
        let total: usize = shape
            .anatomy_rings
            .iter()
            .chain(&shape.anatomy_meridians)
            .map(Vec::len)
            .sum();
        assert_eq!(total, shape.anatomy_points.len());
        for ring in &shape.anatomy_rings {
            let h0 = (shape.anatomy_points[ring[0]] - shape.base_centre).dot(&shape.long_axis);
            for &i in ring {
                let h = (shape.anatomy_points[i] - shape.base_centre).dot(&shape.long_axis);
                assert!((h - h0).abs() < 1e-9, "ring not at constant height");
            }
        }
    }

    fn small() -> VentricleParams {
        VentricleParams {
            rings: 12,
            points_per_ring: 12,
            points_per_meridian: 6,
            anatomy_point_depth: 2.0,
            ..VentricleParams::default()
        }
    }

    #[test]
    fn shapes_ventricle_default_is_valid() {
        let shape = ventricle_cup(&VentricleParams::default()).unwrap();
        check_ventricle(&shape);
        assert_eq!(shape.surface.num_vertices(), 1523);
        assert_eq!(shape.surface.num_triangles(), 2978);
        assert_eq!(shape.anatomy.num_vertices(), 1116);
        assert!(min_angle_deg(&shape.surface.positions, &shape.surface.triangles) > 35.0);
        assert_eq!(shape.anatomy_points.len(), 5 * 72 + 12 * 24);
        // Landmarks about 110 degrees apart, on either side of +x.
        let (a, i) = (shape.anterior, shape.inferior);
        let angle = (a.y.atan2(a.x) - i.y.atan2(i.x)).to_degrees();
        assert!((angle - 110.0).abs() < 6.0, "landmark angle {angle}");
        assert!(a.y > 0.0 && i.y < 0.0 && a.x > 0.0 && i.x > 0.0);
        // The apex is the vertex of S farthest from the rim centroid.
        let far = shape
            .surface
            .positions
            .iter()
            .enumerate()
            .max_by(|x, y| {
                (x.1 - shape.base_centre)
                    .norm()
                    .total_cmp(&(y.1 - shape.base_centre).norm())
            })
            .unwrap()
            .0;
        assert_eq!(far, shape.apex_index);
    }

    #[test]
    fn shapes_ventricle_rejects_bad_parameters() {
        let bad = [
            VentricleParams {
                radius: 0.0,
                ..small()
            },
            VentricleParams {
                length: -5.0,
                ..small()
            },
            VentricleParams {
                base_above_equator: 0.9,
                ..small()
            },
            VentricleParams {
                landmark_separation_deg: 0.0,
                ..small()
            },
            VentricleParams {
                anatomy_point_depth: 0.0,
                ..small()
            },
            VentricleParams {
                anatomy_surface_depth: 20.0,
                ..small()
            },
            VentricleParams {
                rings: 7,
                ..small()
            },
            VentricleParams {
                rings: 100_000,
                ..small()
            },
            VentricleParams {
                points_per_ring: 2,
                ..small()
            },
            VentricleParams {
                ring_count: 100,
                points_per_ring: 100_000,
                ..small()
            },
            VentricleParams {
                anatomy_point_depth: 0.3,
                rings: 8,
                ..small()
            },
            VentricleParams {
                pose: Pose::new([0.0; 3], [f64::NAN, 0.0, 0.0]),
                ..small()
            },
        ];
        for p in bad {
            match ventricle_cup(&p) {
                Err(MeshError::InvalidArgument(msg)) => {
                    assert!(msg.starts_with("ventricle_cup"), "{msg}")
                }
                other => panic!("{p:?} gave {other:?}"),
            }
        }
    }

    #[test]
    fn shapes_ventricle_closest_point_to_origin() {
        let v = |x: f64, y: f64, z: f64| Vector3::new(x, y, z);
        // Face interior, edge, and vertex regions.
        let c = closest_to_origin(v(-1.0, -1.0, 2.0), v(3.0, -1.0, 2.0), v(-1.0, 3.0, 2.0));
        assert!((c - v(0.0, 0.0, 2.0)).norm() < 1e-12);
        let c = closest_to_origin(v(1.0, -1.0, 0.0), v(1.0, 1.0, 0.0), v(3.0, 0.0, 1.0));
        assert!((c - v(1.0, 0.0, 0.0)).norm() < 1e-12);
        let c = closest_to_origin(v(1.0, 1.0, 1.0), v(2.0, 1.0, 1.0), v(1.0, 2.0, 1.0));
        assert!((c - v(1.0, 1.0, 1.0)).norm() < 1e-12);
        // Defaults at every small resolution work.
        for rings in 8..14 {
            assert!(
                ventricle_cup(&VentricleParams {
                    rings,
                    ..VentricleParams::default()
                })
                .is_ok()
            );
        }
    }

    #[test]
    fn shapes_ventricle_is_deterministic() {
        let p = small();
        assert_eq!(ventricle_cup(&p).unwrap(), ventricle_cup(&p).unwrap());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn shapes_ventricle_valid_for_random_parameters(
            radius in 15.0..35.0f64,
            length in 45.0..90.0f64,
            cut in -0.5..0.5f64,
            sep in 60.0..180.0f64,
            rings in 14usize..24,
            roll in -180.0..180.0f64,
            pitch in -90.0..90.0f64,
            yaw in -180.0..180.0f64,
            t in prop::array::uniform3(-300.0..300.0f64),
        ) {
            let p = VentricleParams {
                radius,
                length,
                base_above_equator: cut,
                landmark_separation_deg: sep,
                rings,
                pose: Pose::new([roll, pitch, yaw], t),
                ..small()
            };
            // Too coarse a surface for the anatomy depths is refused with a
            // clear error (documented); three times the rings must work.
            let p = match ventricle_cup(&p) {
                Ok(_) => p,
                Err(MeshError::InvalidArgument(m)) if m.contains("too coarse") => {
                    VentricleParams { rings: 3 * rings, ..p }
                }
                Err(e) => return Err(TestCaseError::fail(e.to_string())),
            };
            let shape = ventricle_cup(&p).unwrap();
            check_ventricle(&shape);
            // Pose invariance against the identity pose.
            let base = ventricle_cup(&VentricleParams { pose: Pose::identity(), ..p.clone() }).unwrap();
            prop_assert_eq!(&base.surface.triangles, &shape.surface.triangles);
            prop_assert_eq!(base.anterior_index, shape.anterior_index);
            prop_assert_eq!(base.inferior_index, shape.inferior_index);
            let n = base.surface.num_vertices();
            for i in (0..n).step_by(5) {
                let j = (i * 17 + 3) % n;
                let d0 = (base.surface.positions[i] - base.surface.positions[j]).norm();
                let d1 = (shape.surface.positions[i] - shape.surface.positions[j]).norm();
                prop_assert!((d0 - d1).abs() < 1e-9 * (1.0 + d0));
            }
        }
    }
}
