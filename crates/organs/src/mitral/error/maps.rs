//! Errors of the distortion and clinical maps ([`maps`](crate::mitral::maps)).

use super::LeafletSide;
use thiserror::Error;

/// A layout, the annulus plane or precomputed distances do not fit the
/// maps.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MapsError {
    /// Not one coaptation distance per vertex of a leaflet.
    #[error(
        "{distances} coaptation distances for leaflet {} of {vertices} vertices",
        .leaflet.index()
    )]
    CoaptationDistanceCount {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Distances given.
        distances: usize,
        /// The leaflet's vertices.
        vertices: usize,
    },
    /// The annulus plane has a non-finite point or a zero or non-finite
    /// normal.
    #[error(
        "the annulus plane must have a finite point and a non-zero finite normal, got point ({}, \
         {}, {}) and normal ({}, {}, {})",
        .point[0], .point[1], .point[2], .normal[0], .normal[1], .normal[2]
    )]
    PlaneNotUsable {
        /// The plane's point, mm.
        point: [f64; 3],
        /// Its normal.
        normal: [f64; 3],
    },
    /// Not one `(u, v)` per leaflet vertex.
    #[error("the {leaflet} leaflet has {vertices} vertices but {uv_positions} uv positions")]
    UvCount {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Its vertices.
        vertices: usize,
        /// Positions given.
        uv_positions: usize,
    },
    /// A `(u, v)` is not finite.
    #[error(
        "the {leaflet} leaflet's uv position {vertex} is not finite: ({}, {})",
        .uv[0], .uv[1]
    )]
    UvNotFinite {
        /// The leaflet.
        leaflet: LeafletSide,
        /// The vertex.
        vertex: usize,
        /// Its `(u, v)`.
        uv: [f64; 2],
    },
    /// A leaflet has fewer than two annulus vertices.
    #[error("the {leaflet} leaflet has {annulus_vertices} annulus vertices; expected at least 2")]
    TooFewAnnulusVertices {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Its annulus vertices.
        annulus_vertices: usize,
    },
    /// An annulus vertex the layout does not have.
    #[error(
        "the {leaflet} leaflet's annulus vertex {vertex} is out of range ({vertices} vertices)"
    )]
    AnnulusVertexOutOfRange {
        /// The leaflet.
        leaflet: LeafletSide,
        /// The vertex index.
        vertex: u32,
        /// Vertices of the layout.
        vertices: usize,
    },
    /// A leaflet's annulus does not run towards increasing `u`.
    #[error(
        "the {leaflet} leaflet's annulus must increase in u from its first to its last vertex, \
         got u = {u_first} and {u_last}"
    )]
    AnnulusNotIncreasing {
        /// The leaflet.
        leaflet: LeafletSide,
        /// `u` of its first annulus vertex.
        u_first: f64,
        /// `u` of its last annulus vertex.
        u_last: f64,
    },
    /// The whole annulus has no positive extent in `u`.
    #[error(
        "the annulus has no extent in u (anterolateral commissure at u = {u_start}, cut at u = \
         {u_end}); expected the posterior leaflet's last annulus vertex right of the anterior \
         leaflet's first"
    )]
    NoUExtent {
        /// `u` of the anterior leaflet's first annulus vertex.
        u_start: f64,
        /// `u` of the posterior leaflet's last annulus vertex.
        u_end: f64,
    },
    /// The leaflet's rest mesh is not a triangle mesh (no angle energy).
    #[error("the leaflet is not a triangle mesh")]
    NotATriangleMesh {
        /// The leaflet.
        leaflet: LeafletSide,
    },
}
