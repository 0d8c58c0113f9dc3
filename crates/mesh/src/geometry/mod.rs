//! Geometry: signed volumes and areas, normals, vertex areas, centroid, PCA
//! frame, convex hull membership, bounding boxes.
//!
//! One idea per file, everything re-exported here so that
//! `unfold_mesh::geometry::X` is the path to use:
//! - `measures`: simplex formulas (signed tet volume, dihedral angles,
//!   triangle area vector, area and normal) and mesh measures (volumes,
//!   areas, enclosed volume, vertex normals, vertex areas and volumes,
//!   centroids);
//! - `validation`: [`check_finite`], [`check_indices`];
//! - `predicates`: exact orientation tests [`orient3d_exact`],
//!   [`orient2d_exact`];
//! - `hull`: [`convex_hull_vertices`] (exact Quickhull, 3D);
//! - `hull_2d`: [`convex_hull_2d`] (monotone chain, counter-clockwise);
//! - `winding`: [`winding_number`] (solid angles over `4 pi`);
//! - `intersect`: [`segment_crosses_triangle`];
//! - `segment`: [`point_segment_distance`], [`closest_point_on_segment`],
//!   [`closest_point_on_segment_2d`] (clamped projection);
//! - `pca`: [`PcaFrame`], [`pca_frame`];
//! - `planar`: [`plane_coordinates`] (points in one plane, in its
//!   coordinates);
//! - `aabb`: [`Aabb`], [`bounding_box`];
//! - `orientation`: [`flipped_triangles`] (one tie rule: the minority
//!   orientation and the degenerate triangles of a planar map),
//!   [`majority_sign`], [`flipped_indices`], [`Orientations`],
//!   [`twice_signed_areas_2d`];
//! - `folds`: [`folded_faces`], [`folded_edges`] (local overlaps that
//!   orientation does not show);
//! - `broad_phase`: [`overlapping_box_pairs`] (meeting boxes on a grid);
//! - `self_intersections`: [`triangle_self_intersections`],
//!   [`tet_boundary_self_intersections`] (a surface, or a tet mesh's
//!   boundary, meeting itself: the global overlaps);
//! - `boundary_crossings`: [`boundary_edge_crossings`] (the boundary of a
//!   planar triangle map crossing itself).

mod aabb;
mod boundary_crossings;
mod broad_phase;
mod folds;
mod hull;
mod hull_2d;
mod intersect;
mod measures;
mod orientation;
mod pca;
mod planar;
mod predicates;
mod segment;
mod self_intersections;
#[cfg(test)]
mod strategies;
mod validation;
mod winding;

pub use aabb::{Aabb, bounding_box};
pub use boundary_crossings::{BoundaryCrossings, EdgeCrossing, boundary_edge_crossings};
pub use broad_phase::overlapping_box_pairs;
pub use folds::{FoldedEdge, FoldedFace, folded_edges, folded_faces};
pub use hull::convex_hull_vertices;
pub use hull_2d::convex_hull_2d;
pub use intersect::segment_crosses_triangle;
pub use measures::{
    area_weighted_centroid, centroid, enclosed_volume, tet_dihedral_angles, tet_signed_volume,
    tet_vertex_volumes, tet_volumes, total_area, total_volume, triangle_area, triangle_area_vector,
    triangle_areas, triangle_normal, triangle_signed_area_2d, vertex_areas, vertex_normals,
};
pub use orientation::{
    Orientations, flipped_indices, flipped_triangles, majority_sign, twice_signed_areas_2d,
};
pub use pca::{PcaFrame, pca_frame};
pub use planar::{PLANAR_REL_TOL, plane_coordinates};
pub use predicates::{orient2d_exact, orient3d_exact};
pub use segment::{closest_point_on_segment, closest_point_on_segment_2d, point_segment_distance};
pub use self_intersections::{
    BoundaryOverlaps, SelfIntersections, TriangleOverlap, tet_boundary_self_intersections,
    triangle_self_intersections,
};
pub use validation::{check_finite, check_indices};
pub use winding::winding_number;
