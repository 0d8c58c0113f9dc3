//! The ventricle pipeline's default disk [`Initializer`] (ALGORITHMS 3.2):
//! the harmonic map of S with its rim pinned, then a thin-plate spline that
//! keeps the rim and moves the interior pins (the apex) to their targets,
//! with a Mobius warp where the spline folds.
//!
//! The ventricle pipeline hands a disk initializer
//!
//! - S (closed down to its basal plane) as a triangle [`ParamMesh`];
//! - pins: every rim vertex at its place on the disk's boundary (the unit
//!   circle by arc length for the LV, the half disk for the RV, already
//!   mirrored and rotated so the landmarks are in place), then the apex at
//!   the disk's centre;
//! - labels: [`ANTERIOR`], [`INFERIOR`] and [`APEX`] on the landmark
//!   vertices, 0 elsewhere.
//!
//! A method developer's disk map gets the same and must return a map of S
//! into the plane whose triangles all have one orientation (the pipeline
//! counts the others and refuses the map when there are any).

use crate::OrganError;
use unfold_linalg::tps::ThinPlateSpline2;
use unfold_mesh::TriMesh;
use unfold_mesh::geometry::flipped_triangles;
use unfold_mesh::topology::disk_boundary_loop;
use unfold_param::initializer::{DiskBoundary, TutteDisk, TutteWeights};
use unfold_param::{Constraints, InitialMap, Initializer, ParamError, ParamMesh, Pin, Untangler};

/// The label of the first rim landmark (the anterior RV insertion point of
/// an LV, the first septal corner of an RV).
pub const ANTERIOR: u8 = 1;
/// The label of the second rim landmark (the inferior insertion point, the
/// second septal corner).
pub const INFERIOR: u8 = 2;
/// The label of the apex.
pub const APEX: u8 = 3;

/// The harmonic disk map with its apex warp, as an [`Initializer`]:
///
/// 1. the harmonic (cotangent) embedding of S with the pins on the
///    boundary loop fixed (mean-value weights instead when the harmonic map
///    flips a triangle: they are positive, so that embedding is bijective
///    for a convex boundary);
/// 2. the thin-plate spline that keeps every boundary pin and moves every
///    interior pin to its target (the apex to the centre);
/// 3. when the spline folds triangles, one interior pin targets the origin
///    and the boundary pins lie on the unit circle (the LV), the Mobius
///    automorphism `z -> (z - a) / (1 - conj(a) z)` of the disk taking the
///    apex `a` to the centre instead: conformal and bijective, but the rim
///    slides along the circle; the map is then turned so that the bisector
///    of the [`ANTERIOR`] and [`INFERIOR`] landmarks is back on +x.
///
/// 4. when folds remain, the untangler (ALGORITHMS 1.7) with every pin
///    fixed, so the rim and the apex stay exactly where they are pinned.
///
/// Details: `("weights", "cotangent" | "mean-value")`,
/// `("apex warp", "thin-plate spline" | "mobius" | "none")`,
/// `("untangled", "yes" | "no" | "failed")`. The result's flips are not an
/// error here (the pipeline decides).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HarmonicDisk;

fn piece(e: impl Into<OrganError>) -> ParamError {
    ParamError::piece("harmonic-disk", e.into())
}

impl Initializer for HarmonicDisk {
    fn name(&self) -> &'static str {
        "harmonic-disk"
    }

    /// # Errors
    /// [`ParamError::WrongElements`] for a tet mesh; [`ParamError::NoPins`]
    /// without a pin on the boundary; the embedding's errors (S not a
    /// disk, bad pins); a spline that cannot be fitted (as
    /// [`ParamError::Piece`]).
    fn initialize(
        &self,
        mesh: &ParamMesh,
        constraints: &Constraints<'_>,
    ) -> Result<InitialMap, ParamError> {
        let tris = mesh.triangles(self.name())?;
        let surface = TriMesh::new(mesh.rest.clone(), tris.to_vec());
        let mut on_boundary = vec![false; surface.num_vertices()];
        for v in disk_boundary_loop(&surface)? {
            on_boundary[v as usize] = true;
        }
        let on_rim = |p: &&Pin| on_boundary.get(p.vertex as usize).copied().unwrap_or(false);
        let rim: Vec<Pin> = constraints.pins.iter().filter(on_rim).copied().collect();
        let interior: Vec<Pin> = constraints
            .pins
            .iter()
            .filter(|p| !on_rim(p))
            .copied()
            .collect();
        if rim.is_empty() {
            return Err(ParamError::NoPins {
                piece: "harmonic-disk (rim)",
            });
        }
        let given: Vec<(u32, [f64; 2])> = rim
            .iter()
            .map(|p| (p.vertex, [p.position[0], p.position[1]]))
            .collect();
        let layout = |weights| {
            TutteDisk {
                weights,
                boundary: DiskBoundary::Given(given.clone()),
            }
            .layout(&surface)
        };
        let harmonic = layout(TutteWeights::Cotangent)?;
        let (uv, weights) = if flipped_triangles(&harmonic, &surface.triangles) == 0 {
            (harmonic, "cotangent")
        } else {
            (layout(TutteWeights::MeanValue)?, "mean-value")
        };
        let (mut warped, mut warp) = (uv.clone(), "none");
        if !interior.is_empty() {
            warped = spline_warp(&uv, &rim, &interior).map_err(piece)?;
            warp = "thin-plate spline";
            let flips = flipped_triangles(&warped, &surface.triangles);
            if flips > 0
                && let Some(m) = mobius_warp(&uv, &rim, &interior, constraints.labels)
                && flipped_triangles(&m, &surface.triangles) < flips
            {
                (warped, warp) = (m, "mobius");
            }
        }
        let mut x: Vec<f64> = warped.iter().flatten().copied().collect();
        let untangled = if flipped_triangles(&warped, &surface.triangles) > 0 {
            untangle_with_pins(mesh, &mut x, constraints.pins)?
        } else {
            "no"
        };
        let mut start = InitialMap::new(x);
        start.details.push(("weights", weights));
        start.details.push(("apex warp", warp));
        start.details.push(("untangled", untangled));
        Ok(start)
    }
}

/// Untangles the disk map `x` (flat uv) with every pin fixed (ALGORITHMS
/// 1.7), in the orientation the map mostly has (a clockwise map is
/// mirrored `v -> -v` for the untangler and back, exactly). `"yes"` when it
/// ends flip-free (`x` replaced), `"failed"` otherwise (`x` kept).
fn untangle_with_pins(
    mesh: &ParamMesh,
    x: &mut [f64],
    pins: &[Pin],
) -> Result<&'static str, ParamError> {
    let dets = unfold_param::metrics::det_j(mesh, x);
    let signed: f64 = dets.iter().zip(&mesh.measure).map(|(d, m)| d * m).sum();
    let mut y = x.to_vec();
    let mirror = |y: &mut [f64]| {
        if signed < 0.0 {
            y.iter_mut().skip(1).step_by(2).for_each(|v| *v = -*v);
        }
    };
    mirror(&mut y);
    let mut fixed = vec![false; mesh.num_vertices()];
    for p in pins {
        if let Some(f) = fixed.get_mut(p.vertex as usize) {
            *f = true;
        }
    }
    if !Untangler::default().run(mesh, &mut y, &fixed)?.untangled {
        return Ok("failed");
    }
    mirror(&mut y);
    x.copy_from_slice(&y);
    Ok("yes")
}

/// `uv` warped by the thin-plate spline through the rim pins (kept) and the
/// interior pins (moved to their targets); the pins are then set exactly.
fn spline_warp(
    uv: &[[f64; 2]],
    rim: &[Pin],
    interior: &[Pin],
) -> Result<Vec<[f64; 2]>, OrganError> {
    let xy = |p: &Pin| [p.position[0], p.position[1]];
    let centres: Vec<[f64; 2]> = rim
        .iter()
        .chain(interior)
        .map(|p| uv[p.vertex as usize])
        .collect();
    let targets: Vec<[f64; 2]> = rim.iter().chain(interior).map(xy).collect();
    let tps = ThinPlateSpline2::fit(&centres, &targets)?;
    let mut warped = tps.eval_many(uv);
    for p in rim.iter().chain(interior) {
        warped[p.vertex as usize] = xy(p);
    }
    Ok(warped)
}

/// The Mobius fallback (see [`HarmonicDisk`]), when it applies: one
/// interior pin with target 0 and every rim pin on the unit circle.
fn mobius_warp(
    uv: &[[f64; 2]],
    rim: &[Pin],
    interior: &[Pin],
    labels: &[u8],
) -> Option<Vec<[f64; 2]>> {
    let [apex] = interior else { return None };
    let on_circle = |p: &Pin| (p.position[0].hypot(p.position[1]) - 1.0).abs() < 1e-9;
    if apex.position[0] != 0.0 || apex.position[1] != 0.0 || !rim.iter().all(on_circle) {
        return None;
    }
    let a = uv[apex.vertex as usize];
    let mut m: Vec<[f64; 2]> = uv.iter().map(|&q| mobius(q, a)).collect();
    m[apex.vertex as usize] = [0.0, 0.0];
    let find = |label: u8| labels.iter().position(|&l| l == label);
    if let (Some(va), Some(vi)) = (find(ANTERIOR), find(INFERIOR)) {
        let angle = |q: [f64; 2]| q[1].atan2(q[0]);
        let (ta, ti) = (angle(m[va]), angle(m[vi]));
        rotate(&mut m, -(ti + 0.5 * wrap(ta - ti)));
    }
    Some(m)
}

/// An angle in `(-pi, pi]`.
pub(crate) fn wrap(a: f64) -> f64 {
    let t = a.rem_euclid(std::f64::consts::TAU);
    if t > std::f64::consts::PI {
        t - std::f64::consts::TAU
    } else {
        t
    }
}

/// Rotates every point by `angle` (radians, counter-clockwise).
pub(crate) fn rotate(uv: &mut [[f64; 2]], angle: f64) {
    let (c, s) = (angle.cos(), angle.sin());
    for q in uv {
        *q = [c * q[0] - s * q[1], s * q[0] + c * q[1]];
    }
}

/// The Mobius automorphism of the unit disk taking `a` to 0:
/// `(z - a) / (1 - conj(a) z)` in complex numbers.
pub(crate) fn mobius(z: [f64; 2], a: [f64; 2]) -> [f64; 2] {
    let num = [z[0] - a[0], z[1] - a[1]];
    // 1 - conj(a) z = 1 - (a0 - i a1)(z0 + i z1)
    let den = [
        1.0 - (a[0] * z[0] + a[1] * z[1]),
        -(a[0] * z[1] - a[1] * z[0]),
    ];
    let d2 = den[0] * den[0] + den[1] * den[1];
    [
        (num[0] * den[0] + num[1] * den[1]) / d2,
        (num[1] * den[0] - num[0] * den[1]) / d2,
    ]
}
