//! A bowl-shaped shell: a spherical cap of tets with a given thickness, the
//! benchmark problem of `unfold deform` (flatten the bowl into a slab).

use super::layered::{check_layers, prism_tets, ring_start};
use super::{Pose, check_positive, check_range};
use crate::{Field, MeshError, TetMesh};
use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Parameters of [`bowl_shell`]. All lengths in millimetres.
///
/// The canonical frame (before [`Pose`]): the bowl opens towards +z; the
/// centre of its spheres is at `(0, 0, radius + thickness / 2)`, so the
/// bottom of the bowl's mid-surface is at the origin, the top (inner) pole
/// at `z = +thickness / 2` and the bottom (outer) pole at
/// `z = -thickness / 2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ShellParams {
    /// Radius of the inner (top, concave) sphere, mm. Default 60.
    pub radius: f64,
    /// Thickness of the shell (the outer sphere's radius is
    /// `radius + thickness`), mm. Default 8.
    pub thickness: f64,
    /// Opening half angle in degrees: the polar angle of the rim, seen from
    /// the spheres' centre, from the bowl's axis. In `[1, 150]`. Default 60.
    pub half_angle_deg: f64,
    /// Cells from the pole to the rim. Every layer of vertices is a
    /// hexagonal-ring disk with `1 + 3 n (n + 1)` vertices and `6 n^2`
    /// triangles (`n` = `cells_radial`), rings at equally spaced polar
    /// angles. In `[2, 400]`. Default 14.
    pub cells_radial: usize,
    /// Cells (prism layers) through the thickness, each prism split into 3
    /// tets. In `[1, 100]`. Default 2.
    pub cells_through: usize,
    /// Rigid motion applied at the end. Default identity.
    pub pose: Pose,
}

impl Default for ShellParams {
    /// 1,893 vertices and 7,056 tets (cells about 4.7 x 4.7 x 4 mm).
    fn default() -> Self {
        ShellParams {
            radius: 60.0,
            thickness: 8.0,
            half_angle_deg: 60.0,
            cells_radial: 14,
            cells_through: 2,
            pose: Pose::identity(),
        }
    }
}

impl ShellParams {
    /// Number of vertices and tets the parameters produce (no validation).
    pub fn counts(&self) -> (usize, usize) {
        let n = self.cells_radial;
        let m = self.cells_through;
        (ring_start(n + 1) * (m + 1), 18 * n * n * m)
    }

    /// The same shape with the resolution chosen for about `tets` tets and
    /// roughly isotropic cells: `cells_through` from the ratio of the
    /// thickness to the in-plane cell size, then `cells_radial` for the
    /// count. With the default geometry, 7,000 gives the default (14, 2:
    /// 7,056 tets) and 60,000 gives (29, 4: 60,552 tets). Out-of-range
    /// results are clamped to the valid ranges; non-finite geometry leaves
    /// the resolution alone (validation reports it).
    pub fn with_about_tets(mut self, tets: usize) -> Self {
        let arc = (self.radius + 0.5 * self.thickness) * self.half_angle_deg.to_radians();
        if !(arc.is_finite() && arc > 0.0 && self.thickness.is_finite() && self.thickness > 0.0) {
            return self;
        }
        let target = tets.max(1) as f64;
        // 18 n^2 m tets with m = t n / arc  =>  n^3 = target arc / (18 t).
        let n0 = (target * arc / (18.0 * self.thickness)).cbrt();
        let m = (self.thickness * n0 / arc).round().clamp(1.0, 100.0);
        let n = (target / (18.0 * m)).sqrt().round().clamp(2.0, 400.0);
        self.cells_through = m as usize;
        self.cells_radial = n as usize;
        self
    }

    /// Centre of the shell's spheres in world coordinates (after the pose).
    pub fn centre(&self) -> Point3<f64> {
        self.pose
            .apply(&Point3::new(0.0, 0.0, self.radius + 0.5 * self.thickness))
    }

    /// Checks every parameter; the error names the offending one.
    pub fn validate(&self) -> Result<(), MeshError> {
        const W: &str = "bowl_shell";
        check_positive(W, "radius", self.radius)?;
        check_positive(W, "thickness", self.thickness)?;
        check_range(W, "half_angle_deg", self.half_angle_deg, 1.0, 150.0)?;
        check_layers(W, self.cells_radial, self.cells_through, self.counts().0)?;
        self.pose.check(W)
    }
}

/// A bowl-shaped shell and the vertex sets of its two faces.
#[derive(Debug, Clone, PartialEq)]
pub struct ShellShape {
    /// The shell; every tet positively oriented. `mesh.point_data` holds an
    /// I32 field `side`: [`ShellShape::INTERIOR`] (0),
    /// [`ShellShape::TOP`] (1), [`ShellShape::BOTTOM`] (2) or
    /// [`ShellShape::RIM`] (3).
    pub mesh: TetMesh,
    /// Vertices of the top (inner, concave) surface, rim excluded,
    /// ascending.
    pub top: Vec<u32>,
    /// Vertices of the bottom (outer, convex) surface, rim excluded,
    /// ascending.
    pub bottom: Vec<u32>,
    /// The parameters that produced it.
    pub params: ShellParams,
}

impl ShellShape {
    /// `side` label of a vertex inside the shell.
    pub const INTERIOR: u8 = 0;
    /// `side` label of a vertex on the top (inner, concave) surface.
    pub const TOP: u8 = 1;
    /// `side` label of a vertex on the bottom (outer, convex) surface.
    pub const BOTTOM: u8 = 2;
    /// `side` label of a vertex on the rim (including the rim's edges with
    /// the top and bottom surfaces).
    pub const RIM: u8 = 3;
}

/// Builds the bowl-shaped shell described by `p`.
///
/// Construction: every layer of vertices is the same hexagonal-ring
/// triangulation of the unit disk (`cells_radial` rings, equally spaced
/// angles per ring); ring `k`, angle `phi` is placed at polar angle
/// `theta = half_angle k / n` and azimuth `phi` on the sphere of radius
/// `rho` about the centre `c = (0, 0, R + t/2)`:
/// `c + rho (sin theta cos phi, sin theta sin phi, -cos theta)`. Layer `l`
/// (of `m = cells_through`) has `rho = R + t (1 - l / m)`, so layer 0 is the
/// bottom (outer) surface and layer `m` the top (inner) one. Every
/// triangular prism between two layers is split into 3 tets, the diagonal of
/// each quad face joining the lower-indexed vertex at the bottom to the
/// higher-indexed vertex at the top, so neighbouring prisms agree (a
/// conforming mesh); corner orders make every tet positively oriented.
///
/// At the defaults: 1,893 vertices and 7,056 tets; with
/// [`ShellParams::with_about_tets`]`(60_000)`: 13,055 vertices and 60,552
/// tets.
pub fn bowl_shell(p: &ShellParams) -> Result<ShellShape, MeshError> {
    p.validate()?;
    let n = p.cells_radial;
    let m = p.cells_through;
    let per_layer = ring_start(n + 1);
    let alpha = p.half_angle_deg.to_radians();
    let cz = p.radius + 0.5 * p.thickness;

    let mut positions = Vec::with_capacity(per_layer * (m + 1));
    let mut side = Vec::with_capacity(per_layer * (m + 1));
    let (mut top, mut bottom) = (Vec::new(), Vec::new());
    for l in 0..=m {
        let rho = p.radius + p.thickness * (1.0 - l as f64 / m as f64);
        for k in 0..=n {
            let (st, ct) = (alpha * k as f64 / n as f64).sin_cos();
            let count = if k == 0 { 1 } else { 6 * k };
            for j in 0..count {
                let (sp, cp) = if k == 0 {
                    (0.0, 1.0)
                } else {
                    (TAU * j as f64 / count as f64).sin_cos()
                };
                let v = positions.len() as u32;
                positions.push(Point3::new(rho * st * cp, rho * st * sp, cz - rho * ct));
                side.push(if k == n {
                    ShellShape::RIM
                } else if l == m {
                    top.push(v);
                    ShellShape::TOP
                } else if l == 0 {
                    bottom.push(v);
                    ShellShape::BOTTOM
                } else {
                    ShellShape::INTERIOR
                });
            }
        }
    }

    let tets = prism_tets(n, m);

    p.pose.apply_all(&mut positions);
    let mut mesh = TetMesh::try_new(positions, tets)?;
    mesh.add_point_field(Field::labels(
        "side",
        side.iter().map(|&s| i32::from(s)).collect(),
    ))?;
    Ok(ShellShape {
        mesh,
        top,
        bottom,
        params: p.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use super::*;
    use crate::geometry::tet_signed_volume;
    use std::f64::consts::PI;

    fn small() -> ShellParams {
        ShellParams {
            cells_radial: 5,
            cells_through: 2,
            ..ShellParams::default()
        }
    }

    /// Everything a valid shell must satisfy.
    fn check_shell(shape: &ShellShape) {
        let mesh = &shape.mesh;
        let p = &shape.params;
        let (nv, nt) = p.counts();
        assert_eq!(mesh.num_vertices(), nv);
        assert_eq!(mesh.num_tets(), nt);

        // Positive, non-degenerate tets.
        let vols: Vec<f64> = (0..mesh.num_tets())
            .map(|t| {
                let [a, b, c, d] = mesh.tet_points(t);
                tet_signed_volume(&a, &b, &c, &d)
            })
            .collect();
        let mean = vols.iter().sum::<f64>() / vols.len() as f64;
        let min = vols.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min > 1e-2 * mean, "min tet volume {min} vs mean {mean}");

        // Conforming, closed boundary of sphere topology, outward, enclosing
        // the tets; its volume is the spherical shell sector's.
        let boundary = tet_boundary(&mesh.tets);
        assert_oriented_manifold(&boundary);
        assert!(boundary_loops(&boundary).is_empty(), "boundary not closed");
        assert_eq!(euler_tri(&boundary), 2);
        let vol: f64 = vols.iter().sum();
        assert!(
            (enclosed_volume(&mesh.positions, &boundary) - vol).abs() < 1e-9 * vol,
            "boundary does not enclose the tets"
        );
        let (n, m) = (p.cells_radial, p.cells_through);
        assert_eq!(boundary.len(), 2 * 6 * n * n + 2 * 6 * n * m);
        let (r0, r1) = (p.radius, p.radius + p.thickness);
        let exact = 2.0 * PI / 3.0
            * (r1.powi(3) - r0.powi(3))
            * (1.0 - p.half_angle_deg.to_radians().cos());
        assert!(vol < exact && vol > 0.9 * exact, "{vol} vs {exact}");

        // top / bottom / rim are exactly the boundary vertices; the field
        // mirrors them.
        let mut on_boundary = vec![false; nv];
        for f in &boundary {
            for &v in f {
                on_boundary[v as usize] = true;
            }
        }
        let field = mesh.point_data.get("side").expect("side field");
        let mut side = vec![ShellShape::INTERIOR; nv];
        for &v in &shape.top {
            side[v as usize] = ShellShape::TOP;
        }
        for &v in &shape.bottom {
            assert_eq!(
                side[v as usize],
                ShellShape::INTERIOR,
                "vertex {v} top and bottom"
            );
            side[v as usize] = ShellShape::BOTTOM;
        }
        for (v, &b) in on_boundary.iter().enumerate() {
            let s = field.get(v, 0).unwrap() as u8;
            if s != ShellShape::RIM {
                assert_eq!(s, side[v], "vertex {v}");
            }
            assert_eq!(b, s != ShellShape::INTERIOR, "vertex {v} side {s}");
        }
        assert_eq!(shape.top.len(), ring_start(n));
        assert_eq!(shape.bottom.len(), ring_start(n));
        assert!(shape.top.windows(2).all(|w| w[0] < w[1]));
        assert!(shape.bottom.windows(2).all(|w| w[0] < w[1]));
        let rim = (0..nv)
            .filter(|&v| field.get(v, 0) == Some(f64::from(ShellShape::RIM)))
            .count();
        assert_eq!(rim, 6 * n * (m + 1));
    }

    #[test]
    fn shapes_shell_default_is_about_7k_tets_and_valid() {
        let p = ShellParams::default();
        assert_eq!(p.counts(), (1893, 7056));
        assert_eq!(p.clone().with_about_tets(7000), p);
        let shape = bowl_shell(&p).unwrap();
        check_shell(&shape);
        // Poles: top at z = +4, bottom at z = -4; distances from the centre.
        let c = p.centre();
        let pos = &shape.mesh.positions;
        assert!((pos[shape.top[0] as usize] - Point3::new(0.0, 0.0, 4.0)).norm() < 1e-12);
        assert!((pos[shape.bottom[0] as usize] - Point3::new(0.0, 0.0, -4.0)).norm() < 1e-12);
        for &v in &shape.top {
            assert!(((pos[v as usize] - c).norm() - 60.0).abs() < 1e-9);
        }
        for &v in &shape.bottom {
            assert!(((pos[v as usize] - c).norm() - 68.0).abs() < 1e-9);
        }
        // A bowl: the rim is high above the bottom.
        let zmax = pos.iter().map(|q| q.z).fold(f64::MIN, f64::max);
        assert!((zmax - (64.0 - 60.0 * 0.5)).abs() < 1e-9, "{zmax}");
    }

    #[test]
    fn shapes_shell_about_60k_tets() {
        let p = ShellParams::default().with_about_tets(60_000);
        assert_eq!((p.cells_radial, p.cells_through), (29, 4));
        assert_eq!(p.counts(), (13_055, 60_552));
        check_shell(&bowl_shell(&p).unwrap());
    }

    #[test]
    fn shapes_shell_valid_for_other_parameters() {
        for (radius, thickness, angle, n, m) in [
            (60.0, 8.0, 60.0, 5, 1),
            (10.0, 30.0, 90.0, 4, 3),
            (100.0, 2.0, 10.0, 3, 1),
            (40.0, 5.0, 150.0, 8, 2),
        ] {
            let p = ShellParams {
                radius,
                thickness,
                half_angle_deg: angle,
                cells_radial: n,
                cells_through: m,
                pose: Pose::identity(),
            };
            check_shell(&bowl_shell(&p).unwrap());
        }
        // The pose moves everything rigidly, labels and tets unchanged.
        let moved = ShellParams {
            pose: Pose::new([30.0, -20.0, 75.0], [5.0, 6.0, -7.0]),
            ..small()
        };
        let (s0, s1) = (bowl_shell(&small()).unwrap(), bowl_shell(&moved).unwrap());
        check_shell(&s1);
        assert_eq!((&s0.top, &s0.bottom), (&s1.top, &s1.bottom));
        assert_eq!(s0.mesh.tets, s1.mesh.tets);
        for (a, b) in s0.mesh.positions.iter().zip(&s1.mesh.positions) {
            assert!((moved.pose.apply(a) - b).norm() < 1e-9);
        }
    }

    #[test]
    fn shapes_shell_rejects_bad_parameters() {
        let bad = [
            ShellParams {
                radius: 0.0,
                ..small()
            },
            ShellParams {
                thickness: f64::NAN,
                ..small()
            },
            ShellParams {
                half_angle_deg: 170.0,
                ..small()
            },
            ShellParams {
                half_angle_deg: 0.0,
                ..small()
            },
            ShellParams {
                cells_radial: 1,
                ..small()
            },
            ShellParams {
                cells_through: 0,
                ..small()
            },
            ShellParams {
                cells_radial: 400,
                cells_through: 100,
                ..small()
            },
            ShellParams {
                pose: Pose::new([f64::NAN, 0.0, 0.0], [0.0; 3]),
                ..small()
            },
        ];
        for p in bad {
            match bowl_shell(&p) {
                Err(MeshError::InvalidArgument(msg)) => assert!(msg.starts_with("bowl_shell")),
                other => panic!("{p:?} gave {other:?}"),
            }
        }
    }

    #[test]
    fn shapes_shell_is_deterministic() {
        assert_eq!(bowl_shell(&small()).unwrap(), bowl_shell(&small()).unwrap());
    }
}
