//! Meshing analytic masks (issue 7's acceptance): a ball, an ellipsoid, a
//! torus and a placenta-like slab are voxelized (a voxel is set when its
//! centre is inside), meshed with the default options, and compared with
//! the analytic shape: enclosed volume within 3 %, boundary within one
//! voxel of the analytic surface both ways (Hausdorff), dihedral angles at
//! least 10 degrees, a valid mesh with a closed manifold boundary.

use proptest::prelude::*;
use std::f64::consts::PI;
use unfold_mesh::geometry::tet_dihedral_angles;
use unfold_mesh::mesher::{
    IsoLevel, MaskMeshOptions, MaskSelection, MeshQuality, cube_side_for_cubes, mask_from_image,
    mesh_mask, voxel_frame,
};
use unfold_mesh::nalgebra::{Matrix3, Matrix4, Point3, Rotation3, Vector3};
use unfold_mesh::spatial::ClosestPointQuery;
use unfold_mesh::stuffing::check_closed_manifold;
use unfold_mesh::topology::tet_boundary;
use unfold_mesh::{MeshError, Volume};

type Inside = Box<dyn Fn(&Point3<f64>) -> bool>;
type Distance = Box<dyn Fn(&Point3<f64>) -> f64>;

/// An analytic shape: inside test, exact distance to its surface, points
/// spread over its surface, and its volume.
struct Shape {
    name: &'static str,
    inside: Inside,
    distance: Distance,
    samples: Vec<Point3<f64>>,
    volume: f64,
}

/// A grid of `n` voxels of side `v` mm covering `[lo, lo + n v]`, rotated
/// by `rot` about the world origin (scanner grids are rarely axis-aligned).
fn grid_affine(lo: [f64; 3], v: f64, rot: &Matrix3<f64>) -> Matrix4<f64> {
    let mut a = Matrix4::identity();
    let m = rot * v;
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&m);
    let t = rot * Vector3::from(lo);
    a[(0, 3)] = t.x;
    a[(1, 3)] = t.y;
    a[(2, 3)] = t.z;
    a
}

fn voxelize(s: &Shape, half: f64, v: f64, rot: &Matrix3<f64>) -> Volume<bool> {
    let n = (2.0 * half / v).ceil() as usize;
    let a = grid_affine([-half; 3], v, rot);
    let mut bits = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = a.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                bits.push((s.inside)(&p));
            }
        }
    }
    Volume::new([n, n, n, 1], a, bits).unwrap()
}

/// Distance from `p` to the ellipsoid with semi-axes `r` (axis-aligned at
/// the origin): the closest point is `x_i = r_i^2 p_i / (t + r_i^2)` with
/// `t` the root of `sum (r_i p_i / (t + r_i^2))^2 = 1`, found by
/// bisection.
fn ellipsoid_distance(r: [f64; 3], p: &Point3<f64>) -> f64 {
    let g = |t: f64| {
        (0..3)
            .map(|i| (r[i] * p[i] / (t + r[i] * r[i])).powi(2))
            .sum::<f64>()
            - 1.0
    };
    let rmin2 = r.iter().map(|x| x * x).fold(f64::MAX, f64::min);
    let (mut lo, mut hi) = (-rmin2 + 1e-12, 1e4);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    let t = 0.5 * (lo + hi);
    let x = Vector3::from_fn(|i, _| r[i] * r[i] * p[i] / (t + r[i] * r[i]));
    (p.coords - x).norm()
}

fn rotation() -> Matrix3<f64> {
    *Rotation3::from_euler_angles(0.3, -0.2, 0.5).matrix()
}

fn ellipsoid(r: [f64; 3]) -> Shape {
    let mut samples = Vec::new();
    for a in 0..60 {
        for b in 0..120 {
            let (th, ph) = (PI * (a as f64 + 0.5) / 60.0, 2.0 * PI * b as f64 / 120.0);
            samples.push(Point3::new(
                r[0] * th.sin() * ph.cos(),
                r[1] * th.sin() * ph.sin(),
                r[2] * th.cos(),
            ));
        }
    }
    Shape {
        name: "ellipsoid",
        inside: Box::new(move |p| (0..3).map(|i| (p[i] / r[i]).powi(2)).sum::<f64>() < 1.0),
        distance: Box::new(move |p| ellipsoid_distance(r, p)),
        samples,
        volume: 4.0 / 3.0 * PI * r[0] * r[1] * r[2],
    }
}

fn torus(big: f64, small: f64) -> Shape {
    let d = move |p: &Point3<f64>| {
        let q = (p.x * p.x + p.y * p.y).sqrt() - big;
        (q * q + p.z * p.z).sqrt() - small
    };
    let mut samples = Vec::new();
    for a in 0..120 {
        for b in 0..60 {
            let (u, v) = (2.0 * PI * a as f64 / 120.0, 2.0 * PI * b as f64 / 60.0);
            let rho = big + small * v.cos();
            samples.push(Point3::new(rho * u.cos(), rho * u.sin(), small * v.sin()));
        }
    }
    Shape {
        name: "torus",
        inside: Box::new(move |p| d(p) < 0.0),
        distance: Box::new(move |p| d(p).abs()),
        samples,
        volume: 2.0 * PI * PI * big * small * small,
    }
}

/// A placenta-like slab: the points within `c` of a flat disc of radius
/// `r` (a disc `2c` thick with a rounded margin), tilted. Its volume is
/// `2 pi r^2 c + pi^2 r c^2 + 4/3 pi c^3` (Steiner).
fn slab(r: f64, c: f64) -> Shape {
    let rot = *Rotation3::from_euler_angles(0.25, 0.15, 0.0).matrix();
    let inv = rot.transpose();
    let d = move |p: &Point3<f64>| {
        let q = inv * p.coords;
        let rho = (q.x * q.x + q.y * q.y).sqrt();
        ((rho - r).max(0.0).powi(2) + q.z * q.z).sqrt() - c
    };
    let mut samples = Vec::new();
    for a in 0..180 {
        let u = 2.0 * PI * a as f64 / 180.0;
        for b in 0..30 {
            // faces
            let rho = r * ((b as f64 + 0.5) / 30.0).sqrt();
            for z in [-c, c] {
                samples.push(Point3::from(
                    rot * Vector3::new(rho * u.cos(), rho * u.sin(), z),
                ));
            }
            // margin
            let v = PI * ((b as f64 + 0.5) / 30.0 - 0.5);
            let rho = r + c * v.cos();
            samples.push(Point3::from(
                rot * Vector3::new(rho * u.cos(), rho * u.sin(), c * v.sin()),
            ));
        }
    }
    Shape {
        name: "slab",
        inside: Box::new(move |p| d(p) < 0.0),
        distance: Box::new(move |p| d(p).abs()),
        samples,
        volume: 2.0 * PI * r * r * c + PI * PI * r * c * c + 4.0 / 3.0 * PI * c.powi(3),
    }
}

/// Meshes the voxelized shape with the default options and checks every
/// acceptance figure; returns (volume error, Hausdorff / voxel).
fn check(s: &Shape, half: f64, voxel: f64) -> (f64, f64) {
    let mask = voxelize(s, half, voxel, &rotation());
    let out = mesh_mask(&mask, &MaskMeshOptions::default()).unwrap();
    let m = &out.mesh;
    assert_eq!(out.components, 1, "{}", s.name);
    assert!(m.validate().is_ok(), "{}: {:?}", s.name, m.validate());
    check_closed_manifold(m).unwrap();
    let q = MeshQuality::of(m).unwrap();
    let err = q.volume_mm3 / s.volume - 1.0;
    let b = tet_boundary(m).unwrap();
    let to_shape = b
        .surface
        .positions
        .iter()
        .map(|p| (s.distance)(p))
        .fold(0.0, f64::max);
    let query = ClosestPointQuery::new(&b.surface);
    let to_mesh = s
        .samples
        .iter()
        .map(|p| query.closest(p).unwrap().distance)
        .fold(0.0, f64::max);
    let hausdorff = to_shape.max(to_mesh) / voxel;
    println!(
        "{}: {} tets, {} boundary triangles, volume {:.4} % off, Hausdorff {:.3} voxel \
         (mesh->shape {:.3}, shape->mesh {:.3} mm), dihedral {:.2} .. {:.2} degrees, level {:.3}",
        s.name,
        q.tets,
        q.boundary_triangles,
        100.0 * err,
        hausdorff,
        to_shape,
        to_mesh,
        q.min_dihedral_deg,
        q.max_dihedral_deg,
        out.level
    );
    assert!(
        err.abs() < 0.03,
        "{}: volume {:.3} % off",
        s.name,
        100.0 * err
    );
    assert!(hausdorff <= 1.0, "{}: Hausdorff {hausdorff} voxels", s.name);
    assert!(
        q.min_dihedral_deg >= 10.0,
        "{}: {}",
        s.name,
        q.min_dihedral_deg
    );
    for t in 0..m.num_tets() {
        let a = tet_dihedral_angles(&m.tet_points(t));
        assert!(a.iter().all(|x| x.to_degrees() < 170.0));
    }
    (err, hausdorff)
}

#[test]
fn a_ball_is_meshed_within_the_tolerances() {
    let mut b = ellipsoid([20.0; 3]);
    b.name = "ball";
    check(&b, 24.0, 1.0);
}

#[test]
fn an_ellipsoid_is_meshed_within_the_tolerances() {
    check(&ellipsoid([30.0, 22.0, 16.0]), 33.0, 1.0);
}

#[test]
fn a_torus_is_meshed_within_the_tolerances() {
    check(&torus(25.0, 11.0), 39.0, 1.0);
}

#[test]
fn a_placenta_like_slab_at_3_mm_is_meshed_within_the_tolerances() {
    check(&slab(80.0, 13.0), 100.0, 3.0);
}

#[test]
fn bad_masks_are_clear_errors() {
    let a = Matrix4::identity();
    let empty = Volume::new([4, 4, 4, 1], a, vec![false; 64]).unwrap();
    let e = mesh_mask(&empty, &MaskMeshOptions::default()).unwrap_err();
    assert!(matches!(e, MeshError::Empty { .. }), "{e}");
    assert!(e.to_string().contains("no voxel set"), "{e}");

    let labels = Volume::new(
        [2, 2, 2, 1],
        a,
        vec![0.0f32, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
    .unwrap();
    let e = mask_from_image(&labels, MaskSelection::Nonzero)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("2 values besides 0 (1, 2)") && e.contains("threshold"),
        "{e}"
    );
    let m = mask_from_image(&labels, MaskSelection::Above(1.5)).unwrap();
    assert_eq!(m.data().iter().filter(|&&b| b).count(), 1);
    let m = mask_from_image(&labels, MaskSelection::Above(0.5)).unwrap();
    assert_eq!(m.data().iter().filter(|&&b| b).count(), 2);
    let m = mask_from_image(&labels, MaskSelection::Label(1.0)).unwrap();
    assert_eq!(m.data().iter().filter(|&&b| b).count(), 1);
    let e = mask_from_image(&labels, MaskSelection::Above(f64::NAN))
        .unwrap_err()
        .to_string();
    assert!(e.contains("threshold"), "{e}");

    let series = Volume::new([2, 2, 2, 2], a, vec![1.0f32; 16]).unwrap();
    let e = mask_from_image(&series, MaskSelection::Nonzero)
        .unwrap_err()
        .to_string();
    assert!(e.contains("3D") && e.contains("2 frames"), "{e}");

    // one voxel set: smoothing leaves nothing above 0.5
    let mut bits = vec![false; 125];
    bits[62] = true;
    let speck = Volume::new([5, 5, 5, 1], a, bits).unwrap();
    let e = mesh_mask(&speck, &MaskMeshOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("nothing of the mask"), "{e}");
    let fixed = MaskMeshOptions {
        level: IsoLevel::Fixed(0.5),
        ..Default::default()
    };
    let e = mesh_mask(&speck, &fixed).unwrap_err().to_string();
    assert!(e.contains("nothing of the mask"), "{e}");

    for (opts, what) in [
        (
            MaskMeshOptions {
                size_mm: Some(0.0),
                ..Default::default()
            },
            "element size",
        ),
        (
            MaskMeshOptions {
                smooth_voxels: -1.0,
                ..Default::default()
            },
            "smoothing",
        ),
        (
            MaskMeshOptions {
                dilate: 9,
                ..Default::default()
            },
            "dilations",
        ),
        (
            MaskMeshOptions {
                level: IsoLevel::Fixed(1.0),
                ..Default::default()
            },
            "level",
        ),
    ] {
        let mut bits = vec![false; 125];
        bits[62] = true;
        let m = Volume::new([5, 5, 5, 1], a, bits).unwrap();
        let e = mesh_mask(&m, &opts).unwrap_err().to_string();
        assert!(e.contains(what), "{e}");
    }
}

#[test]
fn the_reference_level_shrinks_a_curved_shape_and_the_default_does_not() {
    let ball = ellipsoid([20.0; 3]);
    let mask = voxelize(&ball, 24.0, 1.0, &rotation());
    let coarse = MaskMeshOptions {
        size_mm: Some(2.0),
        ..Default::default()
    };
    let keep = mesh_mask(&mask, &coarse).unwrap();
    let half = mesh_mask(
        &mask,
        &MaskMeshOptions {
            level: IsoLevel::Fixed(0.5),
            ..coarse
        },
    )
    .unwrap();
    assert_eq!(half.level, 0.5);
    assert!(keep.level < 0.5, "{}", keep.level);
    let v = |m: &unfold_mesh::mesher::MaskMesh| MeshQuality::of(&m.mesh).unwrap().volume_mm3;
    let (ek, eh) = (v(&keep) / ball.volume - 1.0, v(&half) / ball.volume - 1.0);
    // sigma^2 / r = 2.25 / 20 voxels inward: about 1.7 % of the volume,
    // plus the mesh's own (inscribed) loss
    assert!(eh < -0.015 && eh > -0.04, "{eh}");
    assert!(ek.abs() < 0.01, "{ek}");
    assert!(keep.mask_voxels > 0 && (keep.mask_volume_mm3 / ball.volume - 1.0).abs() < 0.01);
}

/// `--grade` keeps the boundary exactly (same triangles at the same
/// positions, so the same volume) and removes interior vertices, with every
/// angle still in [10, 165] degrees.
#[test]
fn grading_coarsens_the_inside_and_keeps_the_boundary() {
    let s = slab(80.0, 13.0);
    let mask = voxelize(&s, 100.0, 3.0, &rotation());
    let uniform = mesh_mask(&mask, &MaskMeshOptions::default()).unwrap();
    let graded = mesh_mask(
        &mask,
        &MaskMeshOptions {
            grade: true,
            ..Default::default()
        },
    )
    .unwrap();
    let (u, g) = (&uniform.mesh, &graded.mesh);
    assert!(graded.graded_collapses > 0 && uniform.graded_collapses == 0);
    assert_eq!(g.num_vertices() + graded.graded_collapses, u.num_vertices());
    let qu = MeshQuality::of(u).unwrap();
    let qg = MeshQuality::of(g).unwrap();
    println!(
        "slab at 3 mm: {} tets uniform, {} graded ({} interior vertices removed), \
         graded dihedral {:.2} .. {:.2} degrees",
        qu.tets, qg.tets, graded.graded_collapses, qg.min_dihedral_deg, qg.max_dihedral_deg
    );
    assert!(qg.tets < qu.tets * 3 / 4, "{} vs {}", qg.tets, qu.tets);
    assert!(qg.min_dihedral_deg >= 10.0 && qg.max_dihedral_deg <= 165.0);
    assert!(g.validate().is_ok());
    check_closed_manifold(g).unwrap();
    assert!((qg.volume_mm3 / qu.volume_mm3 - 1.0).abs() < 1e-9);
    let key = |m: &unfold_mesh::TetMesh| {
        let b = tet_boundary(m).unwrap();
        let mut t: Vec<[[u64; 3]; 3]> = b
            .surface
            .triangles
            .iter()
            .map(|t| {
                let mut c = t.map(|v| {
                    b.surface.positions[v as usize]
                        .coords
                        .map(f64::to_bits)
                        .into()
                });
                c.sort_unstable();
                c
            })
            .collect();
        t.sort_unstable();
        t
    };
    assert_eq!(key(u), key(g));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(6))]

    /// The lattice lies in the mask's voxel frame: the same voxels under an
    /// affine moved by a rigid motion `P` (`P A`) give the same mesh moved
    /// by `P`, vertex for vertex.
    #[test]
    fn a_rigidly_moved_mask_gives_the_same_mesh_moved(
        angles in prop::array::uniform3(-3.2..3.2f64),
        shift in prop::array::uniform3(-80.0..80.0f64),
    ) {
        let mask = voxelize(&ellipsoid([14.0, 9.0, 6.0]), 17.0, 2.0, &rotation());
        let r = Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
        let t = Vector3::from(shift);
        let mut pose = Matrix4::identity();
        pose.fixed_view_mut::<3, 3>(0, 0).copy_from(r.matrix());
        pose.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
        let moved = Volume::new(mask.dims(), pose * mask.affine(), mask.data().to_vec()).unwrap();
        let a = mesh_mask(&mask, &MaskMeshOptions::default()).unwrap().mesh;
        let b = mesh_mask(&moved, &MaskMeshOptions::default()).unwrap().mesh;
        prop_assert_eq!(a.num_vertices(), b.num_vertices());
        prop_assert_eq!(&a.tets, &b.tets);
        let worst = a
            .positions
            .iter()
            .zip(&b.positions)
            .map(|(p, q)| (r * p + t - q).norm())
            .fold(0.0, f64::max);
        prop_assert!(worst < 1e-9, "{}", worst);
    }
}

proptest! {
    /// The cube side chosen from a mask's volume: `(n v / cubes)^(1/3)`,
    /// whatever the grid's rotation and position, and independent of the
    /// image's resolution: 8 times as many voxels of half the side give
    /// the same cube side.
    #[test]
    fn the_cube_side_from_the_mask_volume_follows_the_volume(
        v in 0.3..4.0f64,
        n_in in 1usize..200,
        cubes in 1.0..1e5f64,
        angles in prop::array::uniform3(-3.2..3.2f64),
    ) {
        let rot = *Rotation3::from_euler_angles(angles[0], angles[1], angles[2]).matrix();
        let a = grid_affine([-3.0, 5.0, 11.0], v, &rot);
        let bits: Vec<bool> = (0..216).map(|i| i < n_in).collect();
        let mask = Volume::new([6, 6, 6, 1], a, bits).unwrap();
        let side = cube_side_for_cubes(&mask, cubes).unwrap();
        let expected = (n_in as f64 * v.powi(3) / cubes).cbrt();
        prop_assert!((side - expected).abs() <= 1e-12 * expected, "{} vs {}", side, expected);
        // The same volume at half the voxel size: 8 times the voxels.
        let fine = Volume::new(
            [12, 12, 12, 1],
            grid_affine([-3.0, 5.0, 11.0], v / 2.0, &rot),
            (0..1728).map(|i| i < 8 * n_in).collect(),
        )
        .unwrap();
        let fine_side = cube_side_for_cubes(&fine, cubes).unwrap();
        prop_assert!((fine_side - side).abs() <= 1e-12 * side);
    }
}

/// No cube side for an empty mask or a count that is not positive.
#[test]
fn no_cube_side_for_an_empty_mask_or_a_bad_count() {
    let a = grid_affine([0.0; 3], 2.0, &Matrix3::identity());
    let empty = Volume::new([4, 4, 4, 1], a, vec![false; 64]).unwrap();
    assert_eq!(cube_side_for_cubes(&empty, 100.0), None);
    let full = Volume::new([4, 4, 4, 1], a, vec![true; 64]).unwrap();
    assert_eq!(cube_side_for_cubes(&full, 8.0), Some(4.0));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(cube_side_for_cubes(&full, bad), None, "{bad}");
    }
}

/// The voxel frame is a rotation along the voxel axes, also for a mirroring
/// affine (its third axis then points against the k axis); parallel axes
/// have none.
#[test]
fn the_voxel_frame_is_a_rotation_along_the_voxel_axes() {
    let mut a = grid_affine([0.0; 3], 2.0, &rotation());
    for i in 0..3 {
        a[(i, 0)] = -a[(i, 0)];
    }
    let q = voxel_frame(&a).unwrap();
    assert!((q.matrix().determinant() - 1.0).abs() < 1e-12);
    for j in 0..3 {
        let axis: Vector3<f64> = a.fixed_view::<3, 1>(0, j).into_owned() / 2.0;
        let sign = if j == 2 { -1.0 } else { 1.0 };
        assert!(
            (q.matrix().column(j) - sign * axis).norm() < 1e-12,
            "axis {j}"
        );
    }
    let mut flat = a;
    for i in 0..3 {
        flat[(i, 1)] = 3.0 * a[(i, 0)];
    }
    assert!(voxel_frame(&flat).is_none());
}
