//! A synthetic placenta: a curved, tapered, elliptical slab of tets.

use super::layered::{check_layers, prism_tets, ring_start};
use super::{Pose, check_positive, check_range, invalid};
use crate::{Field, MeshError, TetMesh};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, TAU};

/// The `side` labels of a placenta's vertices, the one vocabulary of the
/// synthetic placenta here and of the placenta pipeline
/// (`unfold_organs::placenta::side`, ALGORITHMS 2.5): the boundary splits
/// into the fetal side, the maternal side and the margin between them.
pub mod side {
    /// A vertex inside the volume (no template term).
    pub const INTERIOR: u8 = 0;
    /// A vertex on the fetal (chorionic) side; on the synthetic slab the
    /// concave `w = +1` face.
    pub const FETAL: u8 = 1;
    /// A vertex on the maternal (basal) side; on the synthetic slab the
    /// convex `w = -1` face.
    pub const MATERNAL: u8 = 2;
    /// A vertex on the margin between the two sides; on the synthetic slab
    /// the lateral wall, its edges with the two faces included.
    pub const MARGIN: u8 = 3;
    /// The names of the labels, indexed by label.
    pub const NAMES: [&str; 4] = ["interior", "fetal", "maternal", "margin"];
}

/// Parameters of [`placenta_slab`]. All lengths in millimetres.
///
/// The canonical frame (before [`Pose`]): the outline's major axis along x,
/// its minor axis along y, the thickness along z with the fetal side up
/// (+z). The mid-surface is bent onto a sphere of radius `bend_radius`
/// centred at `(0, 0, bend_radius)`, so the slab is a shallow bowl open
/// towards +z: the maternal face (which lies on the uterine wall) is on the
/// convex outside, the fetal face on the concave inside. The centre of the
/// mid-surface is at the origin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlacentaParams {
    /// Length of the elliptical outline along its major axis (x), measured
    /// along the mid-surface, mm. Default 180.
    pub length: f64,
    /// Width of the outline along its minor axis (y), mm. Default 150.
    pub width: f64,
    /// Thickness at the centre, mm. Default 25.
    pub thickness_centre: f64,
    /// Thickness at the rim (the lateral wall's height), mm; must be > 0.
    /// The thickness varies as `t(r) = t_rim + (t_centre - t_rim)(1 - r^2)`
    /// with `r` in `[0, 1]` the normalized distance from the centre.
    /// Default 9.
    pub thickness_rim: f64,
    /// Radius of the bowl the mid-surface is bent onto, mm; `0` (or
    /// infinity) gives a flat slab. Must be at least the thickness and large
    /// enough that the bowl stays within a hemisphere. Default 200.
    pub bend_radius: f64,
    /// Relative outward bulge of the outline on one side (a lobe):
    /// the outline radius is scaled by `1 + lobe * max(0, cos(phi - phi_lobe))^2`.
    /// `0` gives a pure ellipse; at most 0.5. Default 0.1.
    pub lobe: f64,
    /// Direction of the lobe in degrees, counter-clockwise from +x about +z.
    /// Default 40.
    pub lobe_angle_deg: f64,
    /// Radial resolution: cells from the centre to the rim. Every layer of
    /// vertices is a hexagonal-ring disk with `1 + 3 n (n + 1)` vertices and
    /// `6 n^2` triangles (`n` = `cells_radial`), so cells across the
    /// diameter = `2 n`. In `[2, 400]`. Default 20.
    pub cells_radial: usize,
    /// Cells (prism layers) through the thickness, each prism split into 3
    /// tets. In `[1, 100]`. Default 4.
    pub cells_through: usize,
    /// Rigid motion applied at the end. Default identity.
    pub pose: Pose,
}

impl Default for PlacentaParams {
    fn default() -> Self {
        PlacentaParams {
            length: 180.0,
            width: 150.0,
            thickness_centre: 25.0,
            thickness_rim: 9.0,
            bend_radius: 200.0,
            lobe: 0.1,
            lobe_angle_deg: 40.0,
            cells_radial: 20,
            cells_through: 4,
            pose: Pose::identity(),
        }
    }
}

impl PlacentaParams {
    /// Whether the slab is flat (`bend_radius` 0 or infinite).
    pub fn is_flat(&self) -> bool {
        self.bend_radius == 0.0 || self.bend_radius.is_infinite()
    }

    /// Centre of the bowl's sphere in world coordinates (after the pose),
    /// `None` for a flat slab. The fetal face is the one closer to it.
    pub fn bowl_centre(&self) -> Option<Point3<f64>> {
        (!self.is_flat()).then(|| self.pose.apply(&Point3::new(0.0, 0.0, self.bend_radius)))
    }

    /// The direction the fetal face looks at the centre of the slab (the
    /// canonical +z after the pose's rotation).
    pub fn fetal_direction(&self) -> Vector3<f64> {
        self.pose.apply_vector(&Vector3::z())
    }

    /// Number of vertices and tets the parameters produce (no validation).
    pub fn counts(&self) -> (usize, usize) {
        let n = self.cells_radial;
        let m = self.cells_through;
        let per_layer = 1 + 3 * n * (n + 1);
        (per_layer * (m + 1), 18 * n * n * m)
    }

    /// Checks every parameter; the error names the offending one.
    pub fn validate(&self) -> Result<(), MeshError> {
        const W: &str = "placenta_slab";
        check_positive(W, "length", self.length)?;
        check_positive(W, "width", self.width)?;
        check_positive(W, "thickness_centre", self.thickness_centre)?;
        check_positive(W, "thickness_rim", self.thickness_rim)?;
        check_range(W, "lobe", self.lobe, 0.0, 0.5)?;
        if !self.lobe_angle_deg.is_finite() {
            return Err(invalid(format!(
                "{W}: lobe_angle_deg must be finite, got {}",
                self.lobe_angle_deg
            )));
        }
        if self.bend_radius.is_nan() || self.bend_radius < 0.0 {
            return Err(invalid(format!(
                "{W}: bend_radius must be >= 0 (0 or infinity = flat), got {}",
                self.bend_radius
            )));
        }
        if !self.is_flat() {
            let t = self.thickness_centre.max(self.thickness_rim);
            if self.bend_radius < t {
                return Err(invalid(format!(
                    "{W}: bend_radius {} mm is smaller than the thickness {t} mm; \
                     the fetal side would fold (use 0 for a flat slab)",
                    self.bend_radius
                )));
            }
            let reach = 0.5 * self.length.max(self.width) * (1.0 + self.lobe);
            if reach / self.bend_radius > FRAC_PI_2 {
                return Err(invalid(format!(
                    "{W}: bend_radius {} mm is too small for a {reach} mm half-length: \
                     the bowl would close beyond a hemisphere (need >= {:.1} mm)",
                    self.bend_radius,
                    reach / FRAC_PI_2
                )));
            }
        }
        check_layers(W, self.cells_radial, self.cells_through, self.counts().0)?;
        self.pose.check(W)
    }
}

/// A synthetic placenta: the tet mesh and the ground-truth labels of its
/// boundary vertices.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacentaShape {
    /// The slab; every tet positively oriented. `mesh.point_data` holds the
    /// same labels as [`PlacentaShape::side`] as an I32 field named `side`.
    pub mesh: TetMesh,
    /// Per vertex: [`side::INTERIOR`] (0), [`side::FETAL`] (1),
    /// [`side::MATERNAL`] (2) or [`side::MARGIN`] (3). Vertices on both a face and
    /// the lateral wall are margin.
    pub side: Vec<u8>,
    /// The parameters that produced it.
    pub params: PlacentaParams,
}

/// Builds the synthetic placenta described by `p`.
///
/// Construction: every layer of vertices is the same hexagonal-ring
/// triangulation of the unit disk (`cells_radial` rings, equally spaced
/// angles per ring), mapped to the lobed ellipse
/// `(x, y) = r R(phi) (L/2 cos phi, W/2 sin phi)`; layer `l` sits at the
/// normalized thickness coordinate `w = -1 + 2 l / cells_through` and is
/// offset by `w t(r) / 2` along the mid-surface normal; the mid-surface
/// point at distance `d` from the centre in direction `u` is bent to
/// `(R sin(d/R) u, R (1 - cos(d/R)))`, normal `(-sin(d/R) u, cos(d/R))`,
/// which keeps distances from the centre along the mid-surface. Every
/// triangular prism between two layers is split into 3 tets by the rule
/// "the diagonal of each quad face joins the lower-indexed vertex at the
/// bottom to the higher-indexed vertex at the top", which makes neighbouring
/// prisms agree (a conforming mesh); the corner order of each tet is chosen
/// combinatorially so that it is positively oriented.
///
/// Labels: `w = +1` layer fetal, `w = -1` layer maternal, the outer ring
/// of every layer rim, the rest interior.
///
/// At the defaults: 6,305 vertices and 28,800 tets.
pub fn placenta_slab(p: &PlacentaParams) -> Result<PlacentaShape, MeshError> {
    p.validate()?;
    let n = p.cells_radial;
    let m = p.cells_through;
    let per_layer = ring_start(n + 1);
    let (a, b) = (0.5 * p.length, 0.5 * p.width);
    let lobe_dir = p.lobe_angle_deg.to_radians();
    let flat = p.is_flat();
    let big_r = p.bend_radius;

    // Disk vertices: (normalized radius, angle).
    let mut disk: Vec<(f64, f64)> = Vec::with_capacity(per_layer);
    disk.push((0.0, 0.0));
    for k in 1..=n {
        for j in 0..6 * k {
            disk.push((k as f64 / n as f64, TAU * j as f64 / (6 * k) as f64));
        }
    }

    let mut positions = Vec::with_capacity(per_layer * (m + 1));
    let mut side = Vec::with_capacity(per_layer * (m + 1));
    for l in 0..=m {
        let w = -1.0 + 2.0 * l as f64 / m as f64;
        for (v, &(r, phi)) in disk.iter().enumerate() {
            let bulge = (phi - lobe_dir).cos().max(0.0);
            let scale = r * (1.0 + p.lobe * bulge * bulge);
            let x = a * scale * phi.cos();
            let y = b * scale * phi.sin();
            let t = p.thickness_rim + (p.thickness_centre - p.thickness_rim) * (1.0 - r * r);
            let off = 0.5 * w * t;
            let pos = if flat {
                Point3::new(x, y, off)
            } else {
                let d = x.hypot(y);
                let (ux, uy) = if d > 0.0 { (x / d, y / d) } else { (0.0, 0.0) };
                let (s, c) = (d / big_r).sin_cos();
                Point3::new(
                    big_r * s * ux - off * s * ux,
                    big_r * s * uy - off * s * uy,
                    big_r * (1.0 - c) + off * c,
                )
            };
            positions.push(pos);
            side.push(if v >= ring_start(n) {
                side::MARGIN
            } else if l == m {
                side::FETAL
            } else if l == 0 {
                side::MATERNAL
            } else {
                side::INTERIOR
            });
        }
    }

    let tets = prism_tets(n, m);

    p.pose.apply_all(&mut positions);
    let mut mesh = TetMesh::try_new(positions, tets)?;
    mesh.add_point_field(Field::labels(
        "side",
        side.iter().map(|&s| i32::from(s)).collect(),
    ))?;
    Ok(PlacentaShape {
        mesh,
        side,
        params: p.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use super::*;
    use crate::geometry::tet_signed_volume;
    use proptest::prelude::*;

    fn small() -> PlacentaParams {
        PlacentaParams {
            cells_radial: 5,
            cells_through: 2,
            ..PlacentaParams::default()
        }
    }

    /// Everything a valid placenta must satisfy.
    fn check_placenta(shape: &PlacentaShape) {
        let mesh = &shape.mesh;
        let p = &shape.params;
        let (nv, nt) = p.counts();
        assert_eq!(mesh.num_vertices(), nv);
        assert_eq!(mesh.num_tets(), nt);
        assert_eq!(shape.side.len(), nv);

        // Positive, non-degenerate tets.
        let vols: Vec<f64> = (0..mesh.num_tets())
            .map(|t| {
                let [a, b, c, d] = mesh.tet_points(t);
                tet_signed_volume(&a, &b, &c, &d)
            })
            .collect();
        let mean = vols.iter().sum::<f64>() / vols.len() as f64;
        let min = vols.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min > 1e-3 * mean, "min tet volume {min} vs mean {mean}");

        // Conforming, closed boundary of sphere topology, outward.
        let boundary = tet_boundary(&mesh.tets);
        assert_oriented_manifold(&boundary);
        assert!(boundary_loops(&boundary).is_empty(), "boundary not closed");
        assert_eq!(euler_tri(&boundary), 2);
        let vol: f64 = vols.iter().sum();
        assert!(
            (enclosed_volume(&mesh.positions, &boundary) - vol).abs() < 1e-9 * vol,
            "boundary does not enclose the tets"
        );
        let n = p.cells_radial;
        let m = p.cells_through;
        assert_eq!(boundary.len(), 2 * 6 * n * n + 2 * 6 * n * m);

        // Labels: fetal/maternal/rim are exactly the boundary vertices.
        let mut on_boundary = vec![false; nv];
        for f in &boundary {
            for &v in f {
                on_boundary[v as usize] = true;
            }
        }
        for (v, &s) in shape.side.iter().enumerate() {
            assert_eq!(on_boundary[v], s != side::INTERIOR, "vertex {v} side {s}");
        }
        let per_layer = ring_start(n + 1);
        assert_eq!(
            shape.side.iter().filter(|&&s| s == side::FETAL).count(),
            ring_start(n)
        );
        assert_eq!(
            shape.side.iter().filter(|&&s| s == side::MARGIN).count(),
            6 * n * (m + 1)
        );
        assert_eq!(shape.side.len(), per_layer * (m + 1));
        // Every boundary triangle is on one side only (rim triangles have
        // all vertices rim; fetal/maternal faces may touch the rim).
        for f in &boundary {
            let s: Vec<u8> = f.iter().map(|&v| shape.side[v as usize]).collect();
            let non_rim: Vec<u8> = s.iter().copied().filter(|&x| x != side::MARGIN).collect();
            assert!(non_rim.windows(2).all(|w| w[0] == w[1]), "mixed face {s:?}");
        }
        // Field mirrors the labels.
        let field = mesh.point_data.get("side").expect("side field");
        for (v, &s) in shape.side.iter().enumerate() {
            assert_eq!(field.get(v, 0), Some(f64::from(s)));
        }
    }

    fn centroid_of(shape: &PlacentaShape, label: u8) -> Point3<f64> {
        let pts: Vec<_> = shape
            .side
            .iter()
            .zip(&shape.mesh.positions)
            .filter(|(s, _)| **s == label)
            .map(|(_, p)| p.coords)
            .collect();
        Point3::from(pts.iter().sum::<Vector3<f64>>() / pts.len() as f64)
    }

    #[test]
    fn shapes_placenta_default_size_and_validity() {
        let p = PlacentaParams::default();
        assert_eq!(p.counts(), (6305, 28800));
        let shape = placenta_slab(&p).unwrap();
        check_placenta(&shape);
        // Dimensions: extent along x about the length (bent: a bit less).
        let xs: Vec<f64> = shape.mesh.positions.iter().map(|q| q.x).collect();
        let span = xs.iter().copied().fold(f64::MIN, f64::max)
            - xs.iter().copied().fold(f64::MAX, f64::min);
        assert!(span > 160.0 && span < 200.0, "x span {span}");
        // Thickness at the centre: the two centre vertices.
        let top = shape.mesh.positions[4 * ring_start(21)];
        let bottom = shape.mesh.positions[0];
        assert!(((top - bottom).norm() - 25.0).abs() < 1e-9);
    }

    #[test]
    fn shapes_placenta_sides_are_on_the_right_sides_of_the_bowl() {
        let p = small();
        let shape = placenta_slab(&p).unwrap();
        let centre = p.bowl_centre().unwrap();
        let fetal = centroid_of(&shape, side::FETAL);
        let maternal = centroid_of(&shape, side::MATERNAL);
        // Fetal (concave) side closer to the bowl centre, maternal farther.
        assert!((fetal - centre).norm() < (maternal - centre).norm());
        // Every maternal vertex is farther from the bowl centre than every fetal vertex
        // of the same column.
        let per_layer = ring_start(p.cells_radial + 1);
        let top = p.cells_through * per_layer;
        for v in 0..ring_start(p.cells_radial) {
            let mat = shape.mesh.positions[v];
            let fet = shape.mesh.positions[top + v];
            assert_eq!(shape.side[v], side::MATERNAL);
            assert_eq!(shape.side[top + v], side::FETAL);
            assert!((mat - centre).norm() > (fet - centre).norm());
        }
        // The rim lies above the centre of the bowl's bottom (it is a bowl).
        let rim_z = shape.mesh.positions[ring_start(p.cells_radial)].z;
        assert!(rim_z > 10.0, "rim z {rim_z}");
        assert!((fetal - maternal).dot(&p.fetal_direction()) > 0.0);
    }

    #[test]
    fn shapes_placenta_flat_and_lobe() {
        for bend in [0.0, f64::INFINITY] {
            let p = PlacentaParams {
                bend_radius: bend,
                ..small()
            };
            assert!(p.bowl_centre().is_none());
            let shape = placenta_slab(&p).unwrap();
            check_placenta(&shape);
            for (q, &s) in shape.mesh.positions.iter().zip(&shape.side) {
                match s {
                    side::FETAL => assert!(q.z > 0.0),
                    side::MATERNAL => assert!(q.z < 0.0),
                    _ => {}
                }
            }
        }
        // The lobe bulges the outline towards its direction.
        let p = PlacentaParams {
            lobe: 0.3,
            lobe_angle_deg: 0.0,
            bend_radius: 0.0,
            ..small()
        };
        let shape = placenta_slab(&p).unwrap();
        let max_x = shape
            .mesh
            .positions
            .iter()
            .map(|q| q.x)
            .fold(f64::MIN, f64::max);
        let min_x = shape
            .mesh
            .positions
            .iter()
            .map(|q| q.x)
            .fold(f64::MAX, f64::min);
        assert!((max_x - 90.0 * 1.3).abs() < 1e-9 && (min_x + 90.0).abs() < 1e-9);
    }

    #[test]
    fn shapes_placenta_rejects_bad_parameters() {
        let bad = [
            PlacentaParams {
                length: 0.0,
                ..small()
            },
            PlacentaParams {
                width: -3.0,
                ..small()
            },
            PlacentaParams {
                thickness_rim: 0.0,
                ..small()
            },
            PlacentaParams {
                thickness_centre: f64::NAN,
                ..small()
            },
            PlacentaParams {
                bend_radius: -1.0,
                ..small()
            },
            PlacentaParams {
                bend_radius: 20.0,
                ..small()
            },
            PlacentaParams {
                bend_radius: 50.0,
                ..small()
            },
            PlacentaParams {
                lobe: 0.9,
                ..small()
            },
            PlacentaParams {
                cells_radial: 1,
                ..small()
            },
            PlacentaParams {
                cells_through: 0,
                ..small()
            },
            PlacentaParams {
                cells_radial: 400,
                cells_through: 100,
                ..small()
            },
            PlacentaParams {
                pose: Pose::new([0.0, f64::INFINITY, 0.0], [0.0; 3]),
                ..small()
            },
        ];
        for p in bad {
            match placenta_slab(&p) {
                Err(MeshError::InvalidArgument(msg)) => assert!(msg.starts_with("placenta_slab")),
                other => panic!("{p:?} gave {other:?}"),
            }
        }
    }

    #[test]
    fn shapes_placenta_is_deterministic() {
        let p = small();
        assert_eq!(placenta_slab(&p).unwrap(), placenta_slab(&p).unwrap());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        #[test]
        fn shapes_placenta_valid_for_random_parameters(
            length in 60.0..250.0f64,
            aspect in 0.5..1.0f64,
            t_centre in 10.0..40.0f64,
            t_rim_frac in 0.2..1.2f64,
            bend in prop_oneof![Just(0.0), 150.0..600.0f64],
            lobe in 0.0..0.5f64,
            lobe_angle in -180.0..180.0f64,
            n in 2usize..7,
            m in 1usize..4,
        ) {
            let p = PlacentaParams {
                length,
                width: length * aspect,
                thickness_centre: t_centre,
                thickness_rim: t_centre * t_rim_frac,
                bend_radius: bend,
                lobe,
                lobe_angle_deg: lobe_angle,
                cells_radial: n,
                cells_through: m,
                pose: Pose::identity(),
            };
            let shape = placenta_slab(&p).unwrap();
            check_placenta(&shape);
            if let Some(c) = p.bowl_centre() {
                let f = centroid_of(&shape, side::FETAL);
                let mm = centroid_of(&shape, side::MATERNAL);
                prop_assert!((f - c).norm() < (mm - c).norm());
            }
        }

        #[test]
        fn shapes_placenta_pose_invariance(
            roll in -180.0..180.0f64,
            pitch in -90.0..90.0f64,
            yaw in -180.0..180.0f64,
            tx in -500.0..500.0f64,
            ty in -500.0..500.0f64,
            tz in -500.0..500.0f64,
        ) {
            let base = small();
            let moved = PlacentaParams { pose: Pose::new([roll, pitch, yaw], [tx, ty, tz]), ..small() };
            let s0 = placenta_slab(&base).unwrap();
            let s1 = placenta_slab(&moved).unwrap();
            check_placenta(&s1);
            prop_assert_eq!(&s0.side, &s1.side);
            prop_assert_eq!(&s0.mesh.tets, &s1.mesh.tets);
            let n = s0.mesh.num_vertices();
            for i in (0..n).step_by(7) {
                let j = (i * 31 + 5) % n;
                let d0 = (s0.mesh.positions[i] - s0.mesh.positions[j]).norm();
                let d1 = (s1.mesh.positions[i] - s1.mesh.positions[j]).norm();
                prop_assert!((d0 - d1).abs() < 1e-9 * (1.0 + d0));
            }
            let c = moved.bowl_centre().unwrap();
            let f = centroid_of(&s1, side::FETAL);
            let mm = centroid_of(&s1, side::MATERNAL);
            prop_assert!((f - c).norm() < (mm - c).norm());
        }
    }
}
