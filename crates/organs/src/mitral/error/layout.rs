//! Errors of the initial leaflet layouts ([`layout`](crate::mitral::layout)):
//! the longitude layout and the Tutte layout.

use super::LeafletSide;
use std::fmt;
use thiserror::Error;

/// Which initial layout failed; displays as the prefix of its messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LayoutKind {
    /// [`longitude_layout`](crate::mitral::layout::longitude_layout).
    Longitudes,
    /// [`tutte_layout`](crate::mitral::layout::tutte_layout).
    Tutte,
}

impl fmt::Display for LayoutKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LayoutKind::Longitudes => "longitude layout",
            LayoutKind::Tutte => "Tutte layout",
        })
    }
}

/// A leaflet's initial layout cannot be made.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// Longitudes were asked for (`--init longitudes`) but the leaflet has
    /// none.
    #[error(
        "the {leaflet} leaflet has no longitudes (one vertex chain per annulus vertex down to \
         the free edge); use --init tutte or auto"
    )]
    NoLongitudes {
        /// The leaflet.
        leaflet: LeafletSide,
    },
    /// An initializer did not place an annulus vertex at its `(u, v)`
    /// target.
    #[error(
        "the {leaflet} leaflet's initializer moved annulus vertex {vertex} {distance} from its \
         (u, v) target"
    )]
    PinMoved {
        /// The leaflet.
        leaflet: LeafletSide,
        /// The annulus vertex.
        vertex: u32,
        /// How far it is from its target, mm.
        distance: f64,
    },
    /// The layout initializer was not given the leaflet's annulus as pins.
    #[error("the leaflet layout needs the annulus as pins (one per annulus vertex, in order)")]
    NoAnnulusPins,
    /// Not one annulus `(u, v)` target per annulus vertex.
    #[error("{layout}: {targets} annulus (u, v) for {annulus_vertices} annulus vertices")]
    TargetCount {
        /// The layout.
        layout: LayoutKind,
        /// Targets given.
        targets: usize,
        /// The leaflet's annulus vertices.
        annulus_vertices: usize,
    },
    /// An annulus `(u, v)` target is not finite.
    #[error("{layout}: the (u, v) of annulus vertex {annulus_index} is not finite")]
    TargetNotFinite {
        /// The layout.
        layout: LayoutKind,
        /// Position of the vertex along the leaflet's annulus.
        annulus_index: usize,
        /// The target given.
        uv: [f64; 2],
    },
    /// Not one longitude per annulus vertex.
    #[error("longitude layout: {longitudes} longitudes for {annulus_vertices} annulus vertices")]
    LongitudeCount {
        /// Longitudes given.
        longitudes: usize,
        /// The leaflet's annulus vertices.
        annulus_vertices: usize,
    },
    /// A longitude does not start at its annulus vertex.
    #[error("longitude layout: longitude {longitude} does not start at annulus vertex {vertex}")]
    LongitudeStart {
        /// Index of the longitude (and of its annulus vertex).
        longitude: usize,
        /// The annulus vertex it should start at.
        vertex: u32,
    },
    /// A longitude names a vertex the leaflet does not have.
    #[error("longitude layout: vertex {vertex} out of range ({vertices} vertices)")]
    LongitudeVertexOutOfRange {
        /// The vertex index.
        vertex: u32,
        /// The leaflet's vertices.
        vertices: usize,
    },
    /// A vertex is on two longitudes.
    #[error("longitude layout: vertex {vertex} is on two longitudes")]
    VertexOnTwoLongitudes {
        /// The vertex.
        vertex: u32,
    },
    /// A vertex is on no longitude.
    #[error("longitude layout: vertex {vertex} is on no longitude")]
    VertexOnNoLongitude {
        /// The vertex.
        vertex: usize,
    },
    /// A longitude edge has no finite 3D length.
    #[error("longitude layout: the edge {from}-{to} has no finite length")]
    LongitudeEdgeNotFinite {
        /// The edge's upper vertex (towards the annulus).
        from: u32,
        /// The edge's lower vertex.
        to: u32,
    },
    /// The Tutte layout needs at least two annulus vertices.
    #[error(
        "Tutte layout: the leaflet has {annulus_vertices} annulus vertices, at least 2 are needed"
    )]
    TooFewAnnulusVertices {
        /// The leaflet's annulus vertices.
        annulus_vertices: usize,
    },
    /// The annulus targets' `u` does not increase strictly.
    #[error(
        "Tutte layout: u must increase strictly along the annulus, but annulus vertex \
         {annulus_index} has u = {u} after u = {previous_u}"
    )]
    UNotIncreasing {
        /// Position of the vertex along the leaflet's annulus.
        annulus_index: usize,
        /// Its `u`.
        u: f64,
        /// The `u` of the annulus vertex before it.
        previous_u: f64,
    },
    /// A leaflet triangle repeats a vertex.
    #[error("Tutte layout: triangle {triangle} repeats a vertex ({corners:?})")]
    TriangleRepeatsVertex {
        /// The triangle.
        triangle: usize,
        /// Its corners.
        corners: [u32; 3],
    },
    /// A leaflet vertex is in no triangle.
    #[error("Tutte layout: leaflet vertex {vertex} is used by no triangle")]
    UnusedVertex {
        /// The vertex.
        vertex: usize,
    },
    /// An annulus vertex the leaflet does not have.
    #[error("Tutte layout: annulus vertex {vertex} out of range ({vertices} vertices)")]
    AnnulusVertexOutOfRange {
        /// The vertex index.
        vertex: u32,
        /// The leaflet's vertices.
        vertices: usize,
    },
    /// Two triangles traverse an edge in the same direction.
    #[error(
        "Tutte layout: the leaflet's triangles are not consistently oriented (edge {}-{} is \
         traversed twice in the same direction)",
        .edge[0], .edge[1]
    )]
    InconsistentOrientation {
        /// The directed edge `[from, to]`.
        edge: [u32; 2],
    },
    /// The first annulus vertex is not on the leaflet's boundary loop.
    #[error("Tutte layout: annulus vertex {vertex} is not on the leaflet's boundary")]
    AnnulusOffBoundary {
        /// The vertex.
        vertex: u32,
    },
    /// The annulus vertices are not consecutive on the boundary loop.
    #[error(
        "Tutte layout: the annulus vertices are not a contiguous run of the leaflet's boundary \
         in annulus order"
    )]
    AnnulusNotABoundaryRun,
    /// Internal invariant broken: the Tutte setup got a leaflet facing the
    /// ventricle, which [`tutte_layout`](crate::mitral::layout::tutte_layout)
    /// mirrors first (please report).
    #[error("Tutte layout: internal: the leaflet must face the atrium here")]
    NotFacingAtrium,
    /// The leaflet's 3D area (hence the free-edge curve's depth) is not
    /// finite.
    #[error("Tutte layout: the leaflet's area is not finite")]
    AreaNotFinite {
        /// The leaflet's 3D area, mm^2.
        area_mm2: f64,
    },
    /// The embedding with the convexified annulus already flips triangles
    /// (degenerate 3D triangles give zero mean-value weights).
    #[error(
        "Tutte layout: the embedding with a convex boundary flips triangles (degenerate leaflet \
         triangles?); remove them first (`unfold repair`) or remesh the leaflet"
    )]
    ConvexEmbeddingFlips {
        /// The smallest signed triangle area of that embedding (twice the
        /// area; `<= 0` or NaN).
        min_double_area: f64,
    },
    /// The homotopy to a non-convex annulus profile did not arrive within
    /// its step budget (or its steps became vanishingly small). The fix it
    /// names: `--annulus-mode straight` puts every annulus vertex at `v = 0`,
    /// a convex boundary, where the Tutte embedding is flip-free without a
    /// homotopy (Tutte's theorem).
    #[error(
        "Tutte layout: could not move the annulus to its non-convex profile without flipping \
         triangles ({max_steps} steps); lay the annulus out straight (`--annulus-mode straight`: \
         a convex boundary) or smooth the leaflet's rim where it dips"
    )]
    HomotopyStalled {
        /// The steps allowed.
        max_steps: usize,
    },
}
