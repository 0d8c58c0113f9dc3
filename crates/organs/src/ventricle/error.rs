//! The errors of the ventricle pipeline.
//!
//! [`VentricleError`] holds the failures of the landmarks, the disk map, the
//! Laplace field and the mapping of point sets; it reaches callers of the
//! pipeline as [`OrganError::Ventricle`](crate::OrganError::Ventricle).
//! [`PointFailure`] is why one point cannot be mapped by
//! [`Chart::forward`](super::Chart::forward) or
//! [`Chart::inverse`](super::Chart::inverse). Settings out of range are
//! [`ConfigError`](crate::ConfigError)s.

use super::openings::RimChoice;
use super::trace::{TraceFailure, TraceTarget};
use std::fmt;
use thiserror::Error;
use unfold_mesh::MeshError;

/// Everything the ventricle pipeline itself can reject (besides bad
/// settings, mesh repair and solver failures).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum VentricleError {
    // ---- the landmarks (ALGORITHMS 3.1) ----
    /// S is not a disk (one connected piece, one boundary loop, no handles).
    #[error("the enclosing surface S is not a disk: {0}")]
    NotADisk(#[source] MeshError),
    /// S's boundary loop has no vertex.
    #[error("S has an empty boundary loop")]
    EmptyRim,
    /// S has no vertex in a triangle.
    #[error("S has no vertex")]
    NoVertex,
    /// A landmark point is not finite.
    #[error("the {landmark} landmark is not finite: {point:?}")]
    LandmarkNotFinite {
        /// Which landmark (`anterior`, `inferior` or `apex`).
        landmark: &'static str,
        /// The point given.
        point: [f64; 3],
    },
    /// A rim landmark is farther than the snap distance from every vertex of
    /// the rim.
    #[error(
        "the {landmark} landmark {point:?} is {distance_mm:.3} mm from the nearest vertex of S's \
         boundary loop (more than {snap_mm} mm): it must lie on the basal rim"
    )]
    LandmarkOffRim {
        /// Which landmark (`anterior` or `inferior`).
        landmark: &'static str,
        /// The point given.
        point: [f64; 3],
        /// Its distance to the nearest rim vertex, mm.
        distance_mm: f64,
        /// The largest distance accepted, mm.
        snap_mm: f64,
    },
    /// `--rv-landmarks`: the ray from the basal rim's centroid through an
    /// RV insertion point meets no triangle of S.
    #[error(
        "the ray from the basal rim's centroid {centroid:?} through the {landmark} RV insertion \
         point {point:?} meets no triangle of S: give points outside the LV at the base, \
         where the RV wall attaches"
    )]
    RvRayMisses {
        /// Which point (`anterior` or `inferior`).
        landmark: &'static str,
        /// The point given.
        point: [f64; 3],
        /// The rim's centroid, mm.
        centroid: [f64; 3],
    },
    /// Both rim landmarks snap to one rim vertex.
    #[error("the anterior and inferior landmarks snap to the same rim vertex {vertex}")]
    SameRimVertex {
        /// The vertex of S.
        vertex: u32,
    },
    /// The apex snaps to a vertex of the rim.
    #[error("the apex is the rim vertex {apex}: it must be inside S, away from the basal rim")]
    ApexOnRim {
        /// The vertex of S.
        apex: u32,
    },
    /// Hand-made landmarks: the rim has fewer than 3 vertices.
    #[error("landmarks: a rim of {rim} vertices")]
    RimTooShort {
        /// Vertices of the rim.
        rim: usize,
    },
    /// Hand-made landmarks: a rim vertex does not exist.
    #[error("landmarks: rim vertex {vertex} out of range ({vertices} vertices)")]
    RimVertexOutOfRange {
        /// The rim vertex.
        vertex: u32,
        /// Vertices of S.
        vertices: usize,
    },
    /// Hand-made landmarks: the two rim positions are out of range or equal.
    #[error(
        "landmarks: rim positions {anterior} and {inferior} for a rim of {rim} vertices (two \
         distinct ones needed)"
    )]
    RimPositions {
        /// Position of the first rim landmark in the rim.
        anterior: usize,
        /// Position of the second rim landmark in the rim.
        inferior: usize,
        /// Vertices of the rim.
        rim: usize,
    },
    /// Hand-made landmarks: the apex does not exist or lies on the rim.
    #[error("landmarks: apex {apex} out of range or on the rim")]
    ApexInvalid {
        /// The apex vertex.
        apex: u32,
        /// Vertices of S.
        vertices: usize,
    },

    // ---- several openings (ALGORITHMS 3.1) ----
    /// Two boundary loops of S are about equally near the points that name
    /// the rim.
    #[error(
        "the basal rim is ambiguous: {} and {} are about equally near the {} (distances \
         {}; the rim must be at least twice as near and {snap_mm} mm nearer than any other \
         opening); name the rim with a point on it or at its centre (--rim-near X,Y,Z)",
        .openings[0],
        .openings[1],
        choice_name(*.by),
        distance_list(.distances_mm)
    )]
    AmbiguousRim {
        /// What named the rim (the landmarks or the `rim_near` point).
        by: RimChoice,
        /// The two nearest openings.
        nearest: [usize; 2],
        /// Their sizes and centres (boxed: the variant stays small).
        openings: Box<[OpeningSize; 2]>,
        /// Distance of every opening, mm (longest opening first).
        distances_mm: Vec<f64>,
        /// The snap distance, mm.
        snap_mm: f64,
    },
    /// The `rim_near` point is far from every boundary loop of S.
    #[error(
        "the rim-near point is more than {snap_mm} mm from every opening of S (distances to each \
         opening's ring or the disk it spans: {}); give a point on the basal rim or at the centre \
         of its opening",
        distance_list(.distances_mm)
    )]
    RimNearFar {
        /// Distance of every opening's disk, mm (longest opening first).
        distances_mm: Vec<f64>,
        /// The largest distance accepted, mm.
        snap_mm: f64,
    },
    /// The anatomy cannot tell the basal rim from another opening (two
    /// openings of about the same size, both facing away from the apex) and
    /// nothing else names it.
    #[error(
        "the basal rim is ambiguous: {} and {} are within 15% of each other in size{}; name \
         the rim with --rim-near X,Y,Z (a point on it or at its centre)",
        .openings[0],
        .openings[1],
        if *.apex { " and both face away from the apex" } else { " (no --apex given)" }
    )]
    OpeningsTie {
        /// The two largest openings (boxed: the variant stays small).
        openings: Box<[OpeningSize; 2]>,
        /// Whether the apex was known (both face away from it).
        apex: bool,
    },
    /// The rim landmarks lie on another opening than the anatomy's basal rim
    /// (the largest opening facing away from the apex).
    #[error(
        "the rim landmarks lie on {}, but the basal rim by the anatomy (the largest opening \
         facing away from the apex) is {}; name the rim with --rim-near X,Y,Z (a point on it or \
         at its centre), or move the landmarks onto it",
        .landmarks,
        .anatomy
    )]
    RimDisagrees {
        /// The opening the landmarks name (boxed: the variant stays small).
        landmarks: Box<OpeningSize>,
        /// The anatomy's choice.
        anatomy: Box<OpeningSize>,
    },
    /// An opening other than the rim cannot be capped by a fan from its
    /// centroid.
    #[error(
        "opening {opening} of S ({vertices} vertices) is not star-shaped about its centroid \
         ({folded} fan triangles fold); cap or trim it before unfolding"
    )]
    OpeningNotCappable {
        /// Which opening (longest first).
        opening: usize,
        /// Its vertices.
        vertices: usize,
        /// Fan triangles turning against the loop.
        folded: usize,
    },
    /// The cap of an opening would cross S.
    #[error(
        "the cap of opening {opening} of S (a fan from its centroid) would cross triangle \
         {triangle} of S; cap or trim that opening before unfolding"
    )]
    CapCrossesSurface {
        /// Which opening (longest first).
        opening: usize,
        /// A triangle of S it crosses.
        triangle: usize,
    },

    // ---- the disk map (ALGORITHMS 3.2) ----
    /// An arc of the RV rim between its two corners has no length.
    #[error("the RV rim has an arc of zero length between its two corners")]
    ZeroRimArc {
        /// Length of the septal arc, mm.
        septal_mm: f64,
        /// Length of the free-wall arc, mm.
        free_mm: f64,
    },
    /// The disk map folds.
    #[error("the disk map of S flips {triangles} triangles")]
    DiskFlips {
        /// Triangles flipped or of zero area.
        triangles: usize,
    },

    // ---- the basal frame and the Laplace field (ALGORITHMS 3.3) ----
    /// The rim's vertices are collinear, so it has no plane.
    #[error("the rim of S is degenerate (its vertices are collinear)")]
    CollinearRim {
        /// Eigenvalues of the rim's covariance, ascending, mm^2.
        variances: [f64; 3],
    },
    /// The apex lies in the rim's plane.
    #[error("the apex lies in the plane of the rim: S is not a cup")]
    FlatCup {
        /// The apex's height over the rim's plane, mm.
        height_mm: f64,
    },
    /// The hemisphere H reaches S.
    #[error(
        "the hemisphere H (radius {radius_mm} mm at the centre of the base) does not fit inside \
         S: vertex {vertex} of S is {distance_mm:.3} mm from its centre"
    )]
    HemisphereDoesNotFit {
        /// The hemisphere's radius, mm.
        radius_mm: f64,
        /// The vertex of S nearest the centre.
        vertex: usize,
        /// Its distance from the centre, mm.
        distance_mm: f64,
    },
    /// The field's grid over S would have too many nodes.
    #[error(
        "invalid configuration: a {grid_mm} mm grid over S needs {}x{}x{} nodes (more than \
         {limit}); use a coarser grid",
        .dims[0],
        .dims[1],
        .dims[2]
    )]
    GridTooLarge {
        /// The grid spacing, mm.
        grid_mm: f64,
        /// Nodes along x, y and z.
        dims: [usize; 3],
        /// The largest grid accepted, nodes.
        limit: usize,
    },
    /// The field would take more memory than the run may use.
    #[error(
        "the Laplace field at a {grid_mm} mm grid ({nodes:.3e} nodes) would need about \
         {:.2} GiB, more than the {:.2} GiB the run may use (--max-memory, else what is \
         available); raise --grid-mm (the grid grows as 1/h^3)",
        estimate / 1073741824.0,
        limit / 1073741824.0
    )]
    FieldMemory {
        /// The grid spacing, mm.
        grid_mm: f64,
        /// Nodes of the grid (a real: it may not fit an integer).
        nodes: f64,
        /// The estimate, bytes.
        estimate: f64,
        /// The limit, bytes.
        limit: f64,
    },
    /// No grid node lies between S and H.
    #[error(
        "no grid node lies between S and the hemisphere H at a {grid_mm} mm grid; use a finer grid"
    )]
    NoUnknowns {
        /// The grid spacing, mm.
        grid_mm: f64,
    },
    /// The multigrid hierarchy has no finest level (an internal error).
    #[error("the multigrid hierarchy lost its finest level")]
    NoFinestLevel,

    // ---- mapping point sets (ALGORITHMS 3.3, 3.4) ----
    /// The anatomy has no points.
    #[error("the anatomy has no points")]
    NoAnatomyPoints,
    /// Some points of a set cannot be mapped.
    #[error(
        "{failed} of {total} {points} cannot be mapped; the first, point {first}: {reason}{}",
        unmapped_fix(.reason)
    )]
    Unmapped {
        /// Which points (`anatomy points` or `cylinder points`).
        points: &'static str,
        /// How many failed.
        failed: usize,
        /// How many there are.
        total: usize,
        /// Index of the first that failed.
        first: usize,
        /// Why it failed.
        reason: PointFailure,
    },

    // ---- building S from the anatomy (ALGORITHMS 3.9) ----
    /// S cannot be built from the anatomy (boxed: the variant is large).
    #[error(transparent)]
    Enclosing(#[from] Box<super::enclosing::EnclosingError>),
}

/// Why one point cannot be mapped by `psi` or `psi^-1`.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[non_exhaustive]
pub enum PointFailure {
    /// The point is not finite.
    #[error("it is not finite: {point:?}")]
    NotFinite {
        /// The point.
        point: [f64; 3],
    },
    /// S has no triangle to find a closest point on.
    #[error("S has no triangle")]
    NoTriangle,
    /// The point lies outside S (closed by its basal plane).
    #[error(
        "({:.3}, {:.3}, {:.3}) lies outside S (closed by its basal plane), {distance_mm:.3} mm \
         from it",
        .point[0],
        .point[1],
        .point[2]
    )]
    OutsideSurface {
        /// The point.
        point: [f64; 3],
        /// Its distance to S, mm.
        distance_mm: f64,
    },
    /// The point lies inside the hemisphere H.
    #[error(
        "({:.3}, {:.3}, {:.3}) lies inside the hemisphere H (radius {radius_mm} mm at the centre \
         of the base)",
        .point[0],
        .point[1],
        .point[2]
    )]
    InsideHemisphere {
        /// The point.
        point: [f64; 3],
        /// The hemisphere's radius, mm.
        radius_mm: f64,
    },
    /// The cylinder point is not finite or its depth is outside `[0, 1]`.
    #[error("({xi}, {zeta}, {depth}) is not a point of the cylinder (depth must be in [0, 1])")]
    NotOnCylinder {
        /// Disk x.
        xi: f64,
        /// Disk y.
        zeta: f64,
        /// Depth.
        depth: f64,
    },
    /// The disk position lies outside the flattened S.
    #[error("the disk position ({xi:.6}, {zeta:.6}) lies outside the flattened S")]
    OffDisk {
        /// Disk x.
        xi: f64,
        /// Disk y.
        zeta: f64,
    },
    /// The point's streamline failed.
    #[error("{}", Streamline(.failure, *.target))]
    Streamline {
        /// Where the streamline was going.
        target: TraceTarget,
        /// How it failed.
        failure: TraceFailure,
    },
}

/// A failed trace toward its target, as one line.
struct Streamline<'a>(&'a TraceFailure, TraceTarget);

impl fmt::Display for Streamline<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Streamline(failure, target) = self;
        match failure {
            TraceFailure::LeftField(q) => write!(
                f,
                "its streamline left the field at basal-frame point ({:.3}, {:.3}, {:.3}) before \
                 reaching {target}",
                q[0], q[1], q[2]
            ),
            TraceFailure::Stagnant(q) => write!(
                f,
                "its streamline stopped where grad f vanishes, at basal-frame point \
                 ({:.3}, {:.3}, {:.3}), before reaching {target}",
                q[0], q[1], q[2]
            ),
            TraceFailure::TooLong(l) => {
                write!(f, "its streamline did not reach {target} within {l:.1} mm")
            }
        }
    }
}

/// One opening of S in a message: its index (longest first), vertices,
/// perimeter and centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpeningSize {
    /// Index among S's openings, longest first.
    pub index: usize,
    /// Vertices of its loop.
    pub vertices: usize,
    /// Perimeter, mm.
    pub perimeter_mm: f64,
    /// Length-weighted centroid, mm.
    pub centroid_mm: [f64; 3],
}

impl fmt::Display for OpeningSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.centroid_mm;
        write!(
            f,
            "opening {} ({} vertices, {:.1} mm around, centre {:.1},{:.1},{:.1})",
            self.index,
            self.vertices,
            self.perimeter_mm,
            // + 0.0: no "-0.0"
            c[0] + 0.0,
            c[1] + 0.0,
            c[2] + 0.0
        )
    }
}

/// What helps when points fail for `reason`: for a streamline, the flags
/// that change the field it follows.
fn unmapped_fix(reason: &PointFailure) -> &'static str {
    match reason {
        PointFailure::Streamline { .. } => {
            "; streamlines leave the field or stall where S is thin or near its base: a finer \
             --grid-mm resolves thin parts of S, a smaller --hemisphere-mm lets streamlines near \
             the base reach H, or leave such points out of the anatomy"
        }
        _ => "",
    }
}

/// What named the rim, in words.
fn choice_name(c: RimChoice) -> &'static str {
    match c {
        RimChoice::RimNear => "rim-near point",
        _ => "rim landmarks (mean distance of anterior and inferior)",
    }
}

/// `opening 0: 1.234 mm, opening 1: ...`.
fn distance_list(d: &[f64]) -> String {
    d.iter()
        .enumerate()
        .map(|(k, x)| format!("opening {k}: {x:.3} mm"))
        .collect::<Vec<_>>()
        .join(", ")
}
