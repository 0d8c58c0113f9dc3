//! The figures of a placenta map (ALGORITHMS 2.6).

use super::parcellation::Parcellation;
use unfold_mesh::nalgebra::Point3;
use unfold_param::metrics::{
    dirichlet_excess_percent, folded_count, inverted_count, log2_area_ratio, log2_det_j,
    log2_edge_ratio, min_det_j, symmetric_dirichlet, template_matching_error,
};
use unfold_param::{ParamMesh, Template};

/// The figures of ALGORITHMS 2.6 for a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// `sqrt(sum_m A_m T(x_m, theta))`, mm.
    pub template_error_mm: f64,
    /// Dirichlet excess, percent.
    pub dirichlet_excess_percent: f64,
    /// Smallest `det J`.
    pub min_det_j: f64,
    /// Tets with `det J <= 0`.
    pub inverted_tets: usize,
    /// Interior faces whose two tets lie on the same side of the face in
    /// the map (an overlap that orientation alone does not show).
    pub folded_faces: usize,
    /// Boundary faces that meet another boundary face in the map (a global
    /// overlap, [`unfold_mesh::geometry::triangle_self_intersections`]).
    pub overlapping_boundary_faces: usize,
    /// Per tet `log2 det J`.
    pub log2_det_j: Vec<f64>,
    /// Per tet `D(J)` (symmetric Dirichlet).
    pub sym_dirichlet: Vec<f64>,
    /// Per edge `log2(|x_ij| / |z_ij|)`.
    pub log2_edge_ratio: Vec<f64>,
    /// Per boundary triangle `log2(area ratio)`.
    pub log2_area_ratio: Vec<f64>,
}

/// Evaluates a map (ALGORITHMS 2.6).
pub fn evaluate(
    mesh: &ParamMesh,
    parcellation: &Parcellation,
    template: &dyn Template,
    weights: &[f64],
    x: &[f64],
    theta: &[f64],
) -> Evaluation {
    let mapped: Vec<Point3<f64>> = x
        .chunks_exact(3)
        .map(|c| Point3::new(c[0], c[1], c[2]))
        .collect();
    let boundary = &parcellation.boundary;
    let tris: Vec<[u32; 3]> = boundary
        .surface
        .triangles
        .iter()
        .map(|t| t.map(|v| boundary.to_volume[v as usize]))
        .collect();
    Evaluation {
        template_error_mm: template_matching_error(
            template,
            &parcellation.labels,
            x,
            3,
            weights,
            theta,
        ),
        dirichlet_excess_percent: dirichlet_excess_percent(mesh, x),
        min_det_j: min_det_j(mesh, x),
        inverted_tets: inverted_count(mesh, x),
        folded_faces: folded_count(mesh, x),
        overlapping_boundary_faces: unfold_mesh::geometry::triangle_self_intersections(
            &mapped, &tris,
        )
        .triangles_involved,
        log2_det_j: log2_det_j(mesh, x),
        sym_dirichlet: symmetric_dirichlet(mesh, x),
        log2_edge_ratio: log2_edge_ratio(mesh, x),
        log2_area_ratio: log2_area_ratio(&mesh.rest, &mapped, &tris),
    }
}
