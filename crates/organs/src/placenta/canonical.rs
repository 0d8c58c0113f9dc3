//! The canonical template frame (ALGORITHMS 2.10): after the optimization,
//! the flattened mesh is moved by a rigid motion that leaves the objective
//! unchanged, so that the same placenta in any input pose gets the same
//! template coordinates and two subjects' flattened images share an origin.
//!
//! The distortion term is invariant under every rigid motion of `X`, so a
//! motion leaves `phi` unchanged exactly when it is a symmetry of the
//! template term; each template says which through
//! [`PlacentaTemplate::symmetry`](super::PlacentaTemplate::symmetry):
//!
//! - [`TemplateSymmetry::InPlane`] (parallel planes, single plane): any
//!   translation in x and y and any rotation about z. The frame is fixed
//!   completely: origin at the centre `c` of the mid-surface, x along the
//!   major in-plane principal axis, `y = z x x`, the sign of x chosen by
//!   the third moment;
//! - [`TemplateSymmetry::HalfTurnAboutZ`] (ellipsoid with three different
//!   radii: its rotational symmetries are the half turns about x, y and z;
//!   the half turns about x and y would put the fetal side down): only the
//!   sign of x (together with y) is chosen, by the third moment;
//! - [`TemplateSymmetry::None`] (a template that says nothing): no motion.
//!
//! With `V_k` the (flattened) volume of tet `k` and `g_k` its centroid:
//!
//! ```text
//! c   = sum_k V_k g_k / sum_k V_k,  with c_z replaced by 0 (the mid-plane z = 0)
//! C   = sum_k V_k (g_k - c)(g_k - c)^T, its x-y block [[a, b], [b, d]]
//! th  = atan2(2 b, a - d) / 2          (the major axis: (cos th, sin th, 0))
//! m3  = sum_k V_k u_k^3,  u_k = (cos th, sin th) . (g_k - c)_xy
//! th += pi  if m3 < 0                  (x points to the heavier tail)
//! x'  = Rz(-th) (x - c)
//! ```
//!
//! For the half-turn symmetry `c` and `th` are 0 and only the `m3` rule
//! applies (about the origin, the ellipsoid's centre).
//!
//! Ties: a shape symmetric under the half turn about z has `m3 = 0`; then
//! (`|m3| <= 1e-9 sum V_k |u_k|^3`) the sign from `atan2` is kept, which
//! depends on the input pose, and two poses may differ by that half turn.
//! An in-plane isotropic shape (`a = d`, `b = 0`: a disc) has no major
//! axis, and `th` is as undetermined. Neither happens for a real placenta.

use super::align::Alignment;
use unfold_mesh::nalgebra::{Point3, Rotation3, Vector3};

/// The rigid motions that leave a template's energy unchanged, as far as
/// the canonical frame uses them (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TemplateSymmetry {
    /// No motion is known to be a symmetry: the frame is left as is.
    #[default]
    None,
    /// The half turn about z (with the identity).
    HalfTurnAboutZ,
    /// Translations in x and y and rotations about z.
    InPlane,
}

/// Relative size below which the third moment counts as zero.
const TIE: f64 = 1e-9;

/// The canonical motion of flattened `positions` with tets `tets` under
/// `symmetry`, as an [`Alignment`] `x' = Rz(-th) (x - c)` (rotation, the
/// centre `c` as its `centroid`, offset 0). The identity for
/// [`TemplateSymmetry::None`], for no tets, or for a mesh without volume.
pub fn canonical_motion(
    positions: &[Point3<f64>],
    tets: &[[u32; 4]],
    symmetry: TemplateSymmetry,
) -> Alignment {
    let identity = Alignment {
        rotation: Rotation3::identity(),
        centroid: Point3::origin(),
        offset: Vector3::zeros(),
    };
    if symmetry == TemplateSymmetry::None {
        return identity;
    }
    let mut weighted: Vec<(f64, Point3<f64>)> = Vec::with_capacity(tets.len());
    for t in tets {
        let Some(p) = t
            .iter()
            .map(|&i| positions.get(i as usize))
            .collect::<Option<Vec<_>>>()
        else {
            return identity;
        };
        let v = (p[1] - p[0])
            .cross(&(p[2] - p[0]))
            .dot(&(p[3] - p[0]))
            .abs()
            / 6.0;
        let g = Point3::from((p[0].coords + p[1].coords + p[2].coords + p[3].coords) / 4.0);
        weighted.push((v, g));
    }
    let total: f64 = weighted.iter().map(|(v, _)| v).sum();
    if !(total.is_finite() && total > 0.0) {
        return identity;
    }
    let (centre, theta) = match symmetry {
        TemplateSymmetry::InPlane => {
            let c = weighted
                .iter()
                .fold(Vector3::zeros(), |a, (v, g)| a + *v * g.coords)
                / total;
            let c = Point3::new(c.x, c.y, 0.0);
            let (mut a, mut b, mut d) = (0.0, 0.0, 0.0);
            for (v, g) in &weighted {
                let r = g - c;
                a += v * r.x * r.x;
                b += v * r.x * r.y;
                d += v * r.y * r.y;
            }
            (c, 0.5 * (2.0 * b).atan2(a - d))
        }
        _ => (Point3::origin(), 0.0),
    };
    let axis = Vector3::new(theta.cos(), theta.sin(), 0.0);
    let (mut m3, mut scale) = (0.0, 0.0);
    for (v, g) in &weighted {
        let u = axis.dot(&(g - centre));
        m3 += v * u * u * u;
        scale += v * (u * u * u).abs();
    }
    let theta = if m3 < -TIE * scale {
        theta + std::f64::consts::PI
    } else {
        theta
    };
    Alignment {
        rotation: Rotation3::from_axis_angle(&Vector3::z_axis(), -theta),
        centroid: centre,
        offset: Vector3::zeros(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::placenta::side;
    use crate::placenta::templates::{Ellipsoid, ParallelPlanes, PlacentaTemplate, SinglePlane};
    use proptest::prelude::*;
    use unfold_mesh::shapes::{PlacentaParams, placenta_slab};
    use unfold_param::ParamMesh;
    use unfold_param::Template;
    use unfold_param::metrics::symmetric_dirichlet;
    use unfold_param::template::weighted_value;

    /// A small asymmetric (lobed) slab, flattened-looking: fetal side up
    /// about z = 0, and its side labels.
    fn slab() -> (Vec<Point3<f64>>, Vec<[u32; 4]>, Vec<u8>) {
        let s = placenta_slab(&PlacentaParams {
            cells_radial: 4,
            cells_through: 2,
            bend_radius: 0.0,
            ..PlacentaParams::default()
        })
        .expect("slab");
        (s.mesh.positions, s.mesh.tets, s.side)
    }

    fn moved(ps: &[Point3<f64>], a: &Alignment) -> Vec<Point3<f64>> {
        ps.iter().map(|p| a.apply(p)).collect()
    }

    /// `phi` of the placenta objective with `template` at `theta` (uniform
    /// boundary weights, rest shape `rest`).
    fn phi(
        template: &dyn Template,
        rest: &[Point3<f64>],
        tets: &[[u32; 4]],
        labels: &[u8],
        x: &[Point3<f64>],
        theta: &[f64],
    ) -> f64 {
        let pm = ParamMesh::from_tets(&unfold_mesh::TetMesh::new(rest.to_vec(), tets.to_vec()))
            .expect("param mesh");
        let xs: Vec<f64> = x.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let weights: Vec<f64> = labels
            .iter()
            .map(|&l| if l == side::INTERIOR { 0.0 } else { 1.0 })
            .collect();
        weighted_value(template, labels, &xs, 3, &weights, theta)
            + symmetric_dirichlet(&pm, &xs).iter().sum::<f64>()
    }

    fn templates() -> Vec<(Box<dyn PlacentaTemplate>, Vec<f64>)> {
        vec![
            (Box::new(ParallelPlanes::default()), vec![8.0]),
            (Box::new(SinglePlane::default()), vec![8.0]),
            (Box::new(Ellipsoid::default()), vec![90.0, 70.0, 10.0]),
        ]
    }

    /// A pose that keeps z (a symmetry of every template frame up to the
    /// ones the template has): rotation about z by `angle` and a shift in
    /// x and y.
    fn in_plane(angle: f64, dx: f64, dy: f64) -> Alignment {
        Alignment {
            rotation: Rotation3::from_axis_angle(&Vector3::z_axis(), angle),
            centroid: Point3::origin(),
            offset: Vector3::new(dx, dy, 0.0),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        #[test]
        fn the_motion_keeps_the_energy_and_is_idempotent(
            angle in -3.2..3.2f64, dx in -50.0..50.0f64, dy in -50.0..50.0f64,
        ) {
            let (rest, tets, labels) = slab();
            let x = moved(&rest, &in_plane(angle, dx, dy));
            for (template, theta) in templates() {
                let m = canonical_motion(&x, &tets, template.symmetry());
                let y = moved(&x, &m);
                let before = phi(template.as_ref(), &rest, &tets, &labels, &x, &theta);
                let after = phi(template.as_ref(), &rest, &tets, &labels, &y, &theta);
                prop_assert!(
                    (before - after).abs() <= 1e-9 * before.abs().max(1.0),
                    "{}: {before} -> {after}", template.name()
                );
                // A second application changes nothing.
                let again = canonical_motion(&y, &tets, template.symmetry());
                for (p, q) in y.iter().zip(moved(&y, &again)) {
                    prop_assert!((p - q).norm() < 1e-8, "{}: {p} -> {q}", template.name());
                }
            }
        }

        #[test]
        fn the_frame_does_not_depend_on_the_pose(
            angle in -3.2..3.2f64, dx in -50.0..50.0f64, dy in -50.0..50.0f64,
        ) {
            let (rest, tets, _) = slab();
            let x = moved(&rest, &in_plane(angle, dx, dy));
            let sym = TemplateSymmetry::InPlane;
            let a = moved(&rest, &canonical_motion(&rest, &tets, sym));
            let b = moved(&x, &canonical_motion(&x, &tets, sym));
            for (p, q) in a.iter().zip(&b) {
                prop_assert!((p - q).norm() < 1e-8, "{p} vs {q}");
            }
            // Under the half turn only, a pose differing by it is undone.
            let half = moved(&a, &in_plane(std::f64::consts::PI, 0.0, 0.0));
            let sym = TemplateSymmetry::HalfTurnAboutZ;
            let back = moved(&half, &canonical_motion(&half, &tets, sym));
            let same = moved(&a, &canonical_motion(&a, &tets, sym));
            for (p, q) in back.iter().zip(&same) {
                prop_assert!((p - q).norm() < 1e-8, "{p} vs {q}");
            }
        }
    }

    #[test]
    fn the_frame_is_centred_on_its_major_axis_with_a_positive_third_moment() {
        let (rest, tets, _) = slab();
        let x = moved(&rest, &in_plane(0.7, 30.0, -12.0));
        let m = canonical_motion(&x, &tets, TemplateSymmetry::InPlane);
        let y = moved(&x, &m);
        let mut c = Vector3::zeros();
        let (mut total, mut sxx, mut syy, mut sxy, mut m3) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for t in &tets {
            let p: Vec<_> = t.iter().map(|&i| y[i as usize]).collect();
            let v = (p[1] - p[0])
                .cross(&(p[2] - p[0]))
                .dot(&(p[3] - p[0]))
                .abs()
                / 6.0;
            let g = (p[0].coords + p[1].coords + p[2].coords + p[3].coords) / 4.0;
            c += v * g;
            total += v;
            sxx += v * g.x * g.x;
            syy += v * g.y * g.y;
            sxy += v * g.x * g.y;
            m3 += v * g.x.powi(3);
        }
        c /= total;
        assert!(c.x.abs() < 1e-9 && c.y.abs() < 1e-9, "{c}");
        assert!(sxy.abs() < 1e-6 * sxx, "{sxy} {sxx}");
        assert!(sxx > syy, "{sxx} {syy}");
        assert!(m3 > 0.0, "{m3}");
        // z untouched.
        for (p, q) in x.iter().zip(&y) {
            assert!((p.z - q.z).abs() < 1e-12);
        }
        // No symmetry: no motion; no tets: no motion.
        let none = canonical_motion(&x, &tets, TemplateSymmetry::None);
        assert_eq!(none.rotation, Rotation3::identity());
        let empty = canonical_motion(&x, &[], TemplateSymmetry::InPlane);
        assert_eq!(empty.centroid, Point3::origin());
    }
}
