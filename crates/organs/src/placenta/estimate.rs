//! Initial template parameters from the mesh alone (ALGORITHMS 2.4).
//!
//! - `h` and `rz`: half the placenta thickness, taken as the 95th percentile
//!   of the distances from interior points to the boundary surface (the
//!   reference computes a distance transform of the segmentation; here the
//!   points are a quasi-random (R3 sequence) sample of the mesh's interior,
//!   about [`THICKNESS_SAMPLES`] of them, plus the interior vertices).
//! - `ry`: half the 95th percentile of the geodesic (shortest edge path)
//!   distances between boundary vertices. All pairs would cost
//!   `O(n^2 log n)`; the pairs from up to [`WIDTH_SOURCES`] sources spread
//!   evenly over the vertex order to every vertex are a uniform sample of
//!   all pairs, and their 95th percentile estimates it faithfully (exactly
//!   all pairs when the boundary has at most that many vertices).
//! - `rx`: so that the ellipsoid keeps the mesh volume,
//!   `4/3 pi rx ry rz = V`.

use super::error::PlacentaError;
use crate::{ConfigError, OrganError, Requirement};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use unfold_mesh::geodesic::EdgeGraph;
use unfold_mesh::geometry::{bounding_box, total_volume};
use unfold_mesh::nalgebra::Point3;
use unfold_mesh::spatial::{ClosestPointQuery, TetLocator};
use unfold_mesh::{TetMesh, TriMesh};
use unfold_param::metrics::percentile_sorted;

/// Target number of sample points inside the mesh for the thickness.
pub const THICKNESS_SAMPLES: usize = 20_000;
/// Largest number of sources for the geodesic width.
pub const WIDTH_SOURCES: usize = 256;

/// The estimates of ALGORITHMS 2.4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Estimates {
    /// Half thickness: `h` and `rz`, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub half_thickness_mm: f64,
    /// `ry`, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub ry_mm: f64,
    /// `rx = 3 V / (4 pi ry rz)`, mm.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub rx_mm: f64,
    /// Mesh volume `V`, mm^3.
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub volume_mm3: f64,
    /// Interior points whose distances were used (0 when the half
    /// thickness came from the segmentation).
    pub thickness_points: usize,
    /// Where the half thickness came from: `"mesh"` (interior distances)
    /// or `"segmentation"` (the mask's distance transform).
    pub thickness_from: Cow<'static, str>,
}

/// The 95th percentile of the distances from interior points (a
/// quasi-random sample and the vertices not on `boundary`) to the boundary surface.
///
/// # Errors
/// [`PlacentaError::NoVolume`] for a mesh without volume,
/// [`PlacentaError::NoInteriorPoint`] without interior points.
pub fn half_thickness(
    mesh: &TetMesh,
    boundary: &TriMesh,
    is_boundary: &[bool],
) -> Result<(f64, usize), OrganError> {
    let volume = total_volume(mesh);
    let bb = match bounding_box(&mesh.positions) {
        Some(bb) if volume.is_finite() && volume > 0.0 => bb,
        _ => return Err(PlacentaError::NoVolume { volume_mm3: volume }.into()),
    };
    // Quasi-random points in the bounding box (the R3 sequence:
    // u_k = frac(1/2 + k alpha), alpha_i = phi^-i with phi the real root of
    // phi^4 = phi + 1), about THICKNESS_SAMPLES of them inside the mesh;
    // unlike a lattice, they do not quantize the distances of a thin slab.
    let extent = bb.max - bb.min;
    let box_volume = extent.x * extent.y * extent.z;
    let candidates = ((THICKNESS_SAMPLES as f64 * box_volume / volume).ceil() as usize)
        .clamp(THICKNESS_SAMPLES, 50 * THICKNESS_SAMPLES);
    const PHI3: f64 = 1.220_744_084_605_759_5; // phi^4 = phi + 1
    let alpha = [1.0 / PHI3, 1.0 / (PHI3 * PHI3), 1.0 / (PHI3 * PHI3 * PHI3)];
    let locator = TetLocator::new(mesh);
    let query = ClosestPointQuery::new(boundary);
    let distance = |p: &Point3<f64>| query.closest(p).map(|c| c.distance);
    let mut d: Vec<f64> = (0..candidates)
        .into_par_iter()
        .with_min_len(1024)
        .filter_map(|k| {
            let u = alpha.map(|a| (0.5 + k as f64 * a).fract());
            let p = Point3::new(
                bb.min.x + u[0] * extent.x,
                bb.min.y + u[1] * extent.y,
                bb.min.z + u[2] * extent.z,
            );
            locator.locate(&p).and_then(|_| distance(&p))
        })
        .collect();
    d.extend(
        mesh.positions
            .iter()
            .zip(is_boundary)
            .filter(|&(_, &b)| !b)
            .filter_map(|(p, _)| distance(p)),
    );
    d.retain(|x| x.is_finite());
    if d.is_empty() {
        return Err(PlacentaError::NoInteriorPoint {
            samples: candidates,
        }
        .into());
    }
    d.sort_by(f64::total_cmp);
    Ok((percentile_sorted(&d, 95.0), d.len()))
}

/// Half the 95th percentile of the geodesic distances between the
/// vertices of `surface` (finite distances only; see the module docs).
pub fn half_geodesic_width(surface: &TriMesh) -> Option<f64> {
    let n = surface.positions.len();
    if n < 2 {
        return None;
    }
    let graph = EdgeGraph::from_tri_mesh(surface);
    let sources = n.min(WIDTH_SOURCES);
    let mut d: Vec<f64> = (0..sources)
        .into_par_iter()
        .flat_map_iter(|s| {
            let src = (s * n / sources) as u32;
            graph
                .distances(&[src])
                .into_iter()
                .enumerate()
                .filter(move |&(v, x)| v as u32 != src && x.is_finite())
                .map(|(_, x)| x)
        })
        .collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(0.5 * percentile_sorted(&d, 95.0))
}

/// All estimates of ALGORITHMS 2.4 for a valid tet mesh with boundary
/// `boundary` (`is_boundary[v]` for the volume vertices on it).
///
/// # Errors
/// As [`half_thickness`]; [`PlacentaError::NoBoundaryWidth`] when the
/// boundary has no two connected vertices.
pub fn estimate(
    mesh: &TetMesh,
    boundary: &TriMesh,
    is_boundary: &[bool],
) -> Result<Estimates, OrganError> {
    let (h, thickness_points) = half_thickness(mesh, boundary, is_boundary)?;
    with_thickness(mesh, boundary, h, thickness_points, "mesh")
}

/// The estimates with a half thickness `h` known from elsewhere (the
/// segmentation's distance transform); `ry` and `rx` as in [`estimate`].
///
/// # Errors
/// `Config` (`half_thickness_mm`) for an `h` that is not finite and `> 0`;
/// [`PlacentaError::NoVolume`] for a mesh without volume,
/// [`PlacentaError::NoBoundaryWidth`] for a boundary without two connected
/// vertices.
pub fn estimate_with_thickness(
    mesh: &TetMesh,
    boundary: &TriMesh,
    h: f64,
) -> Result<Estimates, OrganError> {
    ConfigError::check("half_thickness_mm", h, Requirement::Positive)?;
    with_thickness(mesh, boundary, h, 0, "segmentation")
}

fn with_thickness(
    mesh: &TetMesh,
    boundary: &TriMesh,
    h: f64,
    thickness_points: usize,
    thickness_from: &'static str,
) -> Result<Estimates, OrganError> {
    let ry = half_geodesic_width(boundary)
        .filter(|r| *r > 0.0)
        .ok_or(PlacentaError::NoBoundaryWidth)?;
    let volume = total_volume(mesh);
    if !(volume.is_finite() && volume > 0.0) {
        return Err(PlacentaError::NoVolume { volume_mm3: volume }.into());
    }
    Ok(Estimates {
        half_thickness_mm: h,
        ry_mm: ry,
        rx_mm: 3.0 * volume / (4.0 * std::f64::consts::PI * ry * h),
        volume_mm3: volume,
        thickness_points,
        thickness_from: thickness_from.into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::shapes::kuhn_grid;
    use unfold_mesh::topology::tet_boundary;

    fn boundary_flags(mesh: &TetMesh, to_volume: &[u32]) -> Vec<bool> {
        let mut b = vec![false; mesh.num_vertices()];
        for &v in to_volume {
            b[v as usize] = true;
        }
        b
    }

    #[test]
    fn half_thickness_of_a_wide_box_is_just_under_half_its_height() {
        // 120 x 100 x 12 mm: interior distances are at most 6 mm, and most
        // of the volume is far from the sides, so the 95th percentile is
        // close to 6.
        let mesh = kuhn_grid([20, 16, 4], [6.0, 6.25, 3.0]);
        let b = tet_boundary(&mesh).unwrap();
        let flags = boundary_flags(&mesh, &b.to_volume);
        let (h, n) = half_thickness(&mesh, &b.surface, &flags).unwrap();
        assert!(n > THICKNESS_SAMPLES / 2, "{n} samples");
        assert!((5.4..=6.0).contains(&h), "h = {h}");
    }

    #[test]
    fn geodesic_width_uses_every_pair_on_small_surfaces() {
        let mesh = kuhn_grid([3, 2, 2], [1.0, 1.0, 1.0]);
        let b = tet_boundary(&mesh).unwrap();
        assert!(b.surface.positions.len() <= WIDTH_SOURCES);
        let all = EdgeGraph::from_tri_mesh(&b.surface).all_pairs();
        let n = b.surface.positions.len();
        let mut d: Vec<f64> = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| all[i * n + j])
            .collect();
        d.sort_by(f64::total_cmp);
        let want = 0.5 * percentile_sorted(&d, 95.0);
        let got = half_geodesic_width(&b.surface).unwrap();
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
    }

    #[test]
    fn rx_keeps_the_volume() {
        let mesh = kuhn_grid([8, 6, 2], [5.0, 5.0, 4.0]);
        let b = tet_boundary(&mesh).unwrap();
        let flags = boundary_flags(&mesh, &b.to_volume);
        let e = estimate(&mesh, &b.surface, &flags).unwrap();
        let v = 4.0 / 3.0 * std::f64::consts::PI * e.rx_mm * e.ry_mm * e.half_thickness_mm;
        assert!((v - e.volume_mm3).abs() < 1e-9 * e.volume_mm3);
        assert!((e.volume_mm3 - 40.0 * 30.0 * 8.0).abs() < 1e-6);
        assert_eq!(e.thickness_from, "mesh");
        // a half thickness from the segmentation: the same ry, rx again
        // keeping the volume
        let s = estimate_with_thickness(&mesh, &b.surface, 3.0).unwrap();
        assert_eq!((s.half_thickness_mm, s.ry_mm), (3.0, e.ry_mm));
        assert_eq!(
            (s.thickness_from.as_ref(), s.thickness_points),
            ("segmentation", 0)
        );
        let v = 4.0 / 3.0 * std::f64::consts::PI * s.rx_mm * s.ry_mm * 3.0;
        assert!((v - s.volume_mm3).abs() < 1e-9 * s.volume_mm3);
        for h in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                estimate_with_thickness(&mesh, &b.surface, h),
                Err(OrganError::Config(ConfigError {
                    name: "half_thickness_mm",
                    ..
                }))
            ));
        }
    }

    #[test]
    fn a_flat_mesh_has_no_volume_error() {
        let mut mesh = kuhn_grid([2, 2, 1], [1.0, 1.0, 1.0]);
        for p in &mut mesh.positions {
            p.z = 0.0;
        }
        let b = tet_boundary(&kuhn_grid([2, 2, 1], [1.0, 1.0, 1.0])).unwrap();
        let flags = vec![true; mesh.num_vertices()];
        assert!(matches!(
            half_thickness(&mesh, &b.surface, &flags),
            Err(OrganError::Placenta(PlacentaError::NoVolume { volume_mm3 })) if volume_mm3 == 0.0
        ));
    }
}
