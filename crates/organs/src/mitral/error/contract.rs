//! Errors of the input contract ([`prepare`](crate::mitral::contract::prepare)):
//! the annulus ring, each leaflet's topology and attachment to the ring,
//! the commissures and the atrial side.

use super::{Counts, LeafletSide, Mm};
use thiserror::Error;
use unfold_mesh::MeshError;

/// The leaflets or the annulus ring do not fit the input contract (see the
/// steps in [`contract`](crate::mitral::contract)).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ContractError {
    /// A ring point has a NaN or infinite coordinate.
    #[error(
        "annulus ring: point {index} has a non-finite coordinate ({}, {}, {}); expected finite \
         coordinates in mm",
        .point[0], .point[1], .point[2]
    )]
    RingPointNotFinite {
        /// Index of the point in the ring as given.
        index: usize,
        /// The point, mm.
        point: [f64; 3],
    },
    /// The ring has fewer points than the contract needs.
    #[error(
        "the annulus ring has {count} point(s){}; expected at least {min}",
        if *.closing_point_dropped { " (after dropping the repeated closing point)" } else { "" }
    )]
    TooFewRingPoints {
        /// Its distinct points.
        count: usize,
        /// The minimum.
        min: usize,
        /// Whether a repeated closing point was dropped before counting.
        closing_point_dropped: bool,
    },
    /// Two consecutive ring points (the last and the first included) are
    /// equal.
    #[error(
        "annulus ring: points {first} and {second} are equal ({}, {}, {}); consecutive ring \
         points must differ",
        .point[0], .point[1], .point[2]
    )]
    EqualConsecutiveRingPoints {
        /// Index of the first of the two.
        first: usize,
        /// Index of the second (0 after the last point).
        second: usize,
        /// The repeated point, mm.
        point: [f64; 3],
    },
    /// The ring's total length is zero or not finite.
    #[error("the annulus ring's length is {length_mm} mm; expected a finite positive length")]
    RingLength {
        /// The length, mm.
        length_mm: f64,
    },
    /// The ring's principal axes (its least-squares plane) cannot be
    /// computed.
    #[error("the annulus ring's least-squares plane cannot be computed")]
    RingPlaneUndefined,
    /// The ring's points lie on a line.
    #[error(
        "the annulus ring is degenerate: its points lie on a line (spreads {} mm and {} mm along \
         its principal axes); expected a closed curve",
        Mm(.spreads_mm[0]), Mm(.spreads_mm[1])
    )]
    RingOnALine {
        /// Standard deviations of the points along the two main principal
        /// axes, mm.
        spreads_mm: [f64; 2],
    },
    /// A leaflet fails mesh validation (default options: unused vertices,
    /// degenerate triangles, several components, inconsistent orientation
    /// are all rejected).
    #[error("{leaflet} leaflet: {source}")]
    LeafletMesh {
        /// The leaflet.
        leaflet: LeafletSide,
        /// What validation found.
        source: MeshError,
    },
    /// A leaflet's boundary loops cannot be traced (a non-manifold rim).
    #[error("the {leaflet} leaflet is not a disk: {source}")]
    LeafletBoundary {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Why the loops cannot be traced.
        source: MeshError,
    },
    /// A leaflet has no boundary loop or more than one (a closed surface, a
    /// hole).
    #[error(
        "the {leaflet} leaflet is not a disk: {} boundary loops{}; expected exactly one (its rim): \
         close its holes first (`unfold repair --fill-holes-mm P`) or export the leaflet without them",
        .loop_sizes.len(),
        LoopSizes(.loop_sizes)
    )]
    BoundaryLoops {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Number of vertices of each boundary loop.
        loop_sizes: Vec<usize>,
    },
    /// A leaflet with one boundary loop is not a disk (a handle).
    #[error(
        "the {leaflet} leaflet is not a disk: Euler characteristic {euler_characteristic} \
         (V - E + F); a disk has 1"
    )]
    EulerCharacteristic {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Its `V - E + F`.
        euler_characteristic: i64,
    },
    /// No boundary vertex of a leaflet is within the tolerance of the ring.
    #[error(
        "the {leaflet} leaflet does not touch the annulus ring: its closest boundary vertex is \
         {} mm away (tolerance {tolerance_mm} mm)",
        Mm(*.closest_mm)
    )]
    LeafletOffRing {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Distance of its closest boundary vertex to the ring, mm.
        closest_mm: f64,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// A leaflet's whole boundary lies on the ring: it has no free edge.
    #[error(
        "the {leaflet} leaflet's whole boundary ({boundary_vertices} vertices) lies on the \
         annulus ring (within {tolerance_mm} mm); a leaflet needs a free edge off the ring"
    )]
    NoFreeEdge {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Vertices of its boundary loop.
        boundary_vertices: usize,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// A leaflet's boundary touches the ring in several separate stretches.
    #[error(
        "the {leaflet} leaflet touches the annulus ring in {} separate places (stretches of {} \
         boundary vertices within {tolerance_mm} mm); expected one contiguous stretch",
        .stretches.len(),
        Counts(.stretches)
    )]
    SeveralStretches {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Number of boundary vertices of each stretch on the ring.
        stretches: Vec<usize>,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// Only one boundary vertex of a leaflet is on the ring.
    #[error(
        "the {leaflet} leaflet touches the annulus ring at a single boundary vertex ({vertex}); \
         expected at least 2 consecutive boundary vertices within {tolerance_mm} mm"
    )]
    SingleVertexOnRing {
        /// The leaflet.
        leaflet: LeafletSide,
        /// The vertex on the ring.
        vertex: u32,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// Consecutive annulus vertices of a leaflet step back along the ring by
    /// more than the tolerance.
    #[error(
        "the {leaflet} leaflet's annulus vertices do not progress monotonically around the \
         annulus ring: from boundary vertex {from} to {to} they step back {} mm along the ring \
         (tolerance {tolerance_mm} mm)",
        Mm(*.back_mm)
    )]
    AnnulusStepsBack {
        /// The leaflet.
        leaflet: LeafletSide,
        /// The vertex stepped from.
        from: u32,
        /// The vertex stepped to.
        to: u32,
        /// How far it lies behind `from` along the ring, mm (`> 0`).
        back_mm: f64,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// A leaflet's annulus vertices cover no more ring than the tolerance.
    #[error(
        "the {leaflet} leaflet's {annulus_vertices} annulus vertices cover only {} mm of the \
         annulus ring; expected an arc longer than the tolerance ({tolerance_mm} mm)",
        Mm(*.extent_mm)
    )]
    ArcTooShort {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Its annulus vertices.
        annulus_vertices: usize,
        /// The arc length they cover, mm.
        extent_mm: f64,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// A leaflet's annulus vertices go (at least) once around the ring.
    #[error(
        "the {leaflet} leaflet's annulus vertices go {} mm around the annulus ring, which is \
         only {} mm long; expected one arc of it",
        Mm(*.extent_mm), Mm(*.ring_length_mm)
    )]
    ArcTooLong {
        /// The leaflet.
        leaflet: LeafletSide,
        /// The arc length they cover, mm.
        extent_mm: f64,
        /// The ring's length, mm.
        ring_length_mm: f64,
    },
    /// The two leaflets' arcs claim the same stretch of ring.
    #[error(
        "the anterior and posterior leaflets' annulus arcs overlap: both claim the same {} mm of \
         the annulus ring (at most {} mm allowed)",
        Mm(*.overlap_mm), Mm(*.allowed_mm)
    )]
    ArcsOverlap {
        /// Length of ring both arcs cover, mm.
        overlap_mm: f64,
        /// The junction's tolerance, mm.
        allowed_mm: f64,
    },
    /// The arcs do not meet at exactly two junctions (commissures).
    #[error(
        "the leaflets' annulus arcs meet at {matched} point(s) on the annulus ring (gaps of {} mm \
         from anterior to posterior and {} mm from posterior to anterior along the ring; at most \
         {} and {} mm allowed); a mitral annulus has 2 commissures",
        Mm(.gaps_mm[0]), Mm(.gaps_mm[1]), Mm(.allowed_mm[0]), Mm(.allowed_mm[1])
    )]
    CommissureCount {
        /// Junctions within their tolerance.
        matched: usize,
        /// Signed gaps along the ring from the end of the anterior arc to
        /// the start of the posterior one, and from the end of the posterior
        /// arc to the start of the anterior one, mm (negative: overlap).
        gaps_mm: [f64; 2],
        /// The two junctions' tolerances, mm.
        allowed_mm: [f64; 2],
    },
    /// The free edges lie on the ring's plane: the atrial side is
    /// undecidable.
    #[error(
        "cannot tell the atrial side: the leaflets' free edges lie on the annulus ring's \
         least-squares plane ({} mm from it on average); expected the leaflets to hang to one \
         side",
        Mm(*.mean_offset_mm)
    )]
    AtrialSideUndecided {
        /// Signed mean distance of the free-edge vertices from the plane,
        /// mm.
        mean_offset_mm: f64,
    },
    /// The ring encloses no area seen from the atrium (its direction is
    /// undecidable).
    #[error(
        "the annulus ring encloses no area seen from the atrium (signed area {} mm^2); expected \
         a simple closed curve around the valve",
        Mm(*.signed_area_mm2)
    )]
    RingEnclosesNoArea {
        /// The ring's signed area about the atrial direction, mm^2.
        signed_area_mm2: f64,
    },
    /// Internal invariant broken: a commissure found no place on the ring
    /// (please report).
    #[error("the commissures could not be placed on the annulus ring")]
    CommissuresNotPlaced,
    /// Finding the annulus from the leaflets: their boundaries do not
    /// touch.
    #[error(
        "the leaflets share no boundary: their boundaries come no closer than {} mm (tolerance \
         {tolerance_mm} mm); without an annulus ring the leaflets must meet at the commissures",
        Mm(*.closest_mm)
    )]
    NoSharedBoundary {
        /// Distance from the anterior leaflet's boundary vertices to the
        /// posterior leaflet's boundary, the smallest, mm.
        closest_mm: f64,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// Finding the annulus from the leaflets: their boundaries meet in
    /// fewer than two places (the two commissures), or along a leaflet's
    /// whole boundary.
    #[error(
        "the leaflets' boundaries meet in {places} place(s) along the {leaflet} leaflet's \
         boundary ({shared_vertices} of its {boundary_vertices} boundary vertices within \
         {tolerance_mm} mm of the other leaflet's); finding the annulus needs two places with \
         free boundary between them (the commissures)"
    )]
    SharedBoundaryPlaces {
        /// The leaflet along whose boundary the places were counted.
        leaflet: LeafletSide,
        /// Runs of shared vertices with unshared ones between them.
        places: usize,
        /// Its boundary vertices within the tolerance of the other leaflet.
        shared_vertices: usize,
        /// Its boundary vertices.
        boundary_vertices: usize,
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// Finding the annulus from the leaflets: no arc of the anterior and
    /// one of the posterior leaflet's boundary close into a ring.
    #[error(
        "the leaflets' boundaries meet in {} and {} places, but no arc of the anterior and one of \
         the posterior boundary between them close into a ring (tolerance {tolerance_mm} mm)",
        .places[0], .places[1]
    )]
    NoClosingArcs {
        /// Places where the boundaries meet, per leaflet.
        places: [usize; 2],
        /// The tolerance, mm.
        tolerance_mm: f64,
    },
    /// Both commissures fall on the same ring point.
    #[error(
        "both commissures fall on annulus ring point {ring_point}; expected two distinct \
         commissures"
    )]
    CommissuresCoincide {
        /// The ring point (after inserting the commissures).
        ring_point: usize,
    },
}

/// The loop sizes of [`ContractError::BoundaryLoops`]: ` (of 12, 4
/// vertices)`, nothing when there is no loop.
struct LoopSizes<'a>(&'a [usize]);

impl std::fmt::Display for LoopSizes<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_empty() {
            Ok(())
        } else {
            write!(f, " (of {} vertices)", Counts(self.0))
        }
    }
}
