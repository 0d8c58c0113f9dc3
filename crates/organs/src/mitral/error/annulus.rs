//! Errors of the annulus layout ([`annulus`](crate::mitral::annulus)): an
//! unusable prepared valve, or no reference plane for its heights.

use crate::mitral::AnnulusMode;
use thiserror::Error;

/// The annulus cannot be laid out in 2D.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum AnnulusError {
    /// The ring has fewer than 3 points.
    #[error("the annulus ring has {count} points, at least 3 are needed")]
    TooFewPoints {
        /// Its points.
        count: usize,
    },
    /// A ring point has a NaN or infinite coordinate.
    #[error("annulus ring point {index} is not finite")]
    PointNotFinite {
        /// Index of the point in the ring.
        index: usize,
        /// The point, mm.
        point: [f64; 3],
    },
    /// The posteromedial commissure's index is not strictly inside the ring.
    #[error(
        "the posteromedial commissure index {index} must be in 1..{ring_points} (the ring has \
         {ring_points} points)"
    )]
    PosteromedialOutOfRange {
        /// The index given.
        index: usize,
        /// The ring's points.
        ring_points: usize,
    },
    /// The atrial direction is zero or not finite.
    #[error("the atrial direction {atrium:?} is not a finite non-zero vector")]
    AtriumNotUsable {
        /// The direction given.
        atrium: [f64; 3],
    },
    /// A reference plane's normal is (nearly) perpendicular to the atrial
    /// direction, so its atrial side is unknown.
    #[error(
        "the {} plane's normal is perpendicular to the atrial direction; cannot tell its atrial \
         side",
        plane_name(*.mode)
    )]
    NormalPerpendicularToAtrium {
        /// The mode whose plane it is (least squares or landmark).
        mode: AnnulusMode,
        /// The plane's unit normal.
        normal: [f64; 3],
    },
    /// The ring points lie on a line: they have no least-squares plane.
    #[error("the annulus ring points lie on a line: no least-squares plane")]
    PointsOnALine {
        /// The two largest eigenvalues of the points' covariance (middle,
        /// largest), mm^2.
        spreads_mm2: [f64; 2],
    },
    /// Internal invariant broken: the least-squares mode gave no plane
    /// (please report).
    #[error("the annulus has no least-squares plane")]
    NoLeastSquaresPlane,
    /// The posterior arc has no ring point strictly between the
    /// commissures, so the landmark plane has no third point.
    #[error("the posterior annulus has no points between the commissures: no landmark plane")]
    NoPosteriorPoints,
    /// Both commissures and the posterior barycentre are collinear.
    #[error(
        "the landmark points (both commissures and the posterior annulus barycentre) are \
         collinear: no landmark plane; use the least-squares or straight mode"
    )]
    LandmarksCollinear {
        /// The anterolateral commissure, the posteromedial commissure and
        /// the posterior barycentre, mm.
        landmarks: [[f64; 3]; 3],
    },
    /// The ring's length is zero or not finite.
    #[error("the annulus ring has length {length_mm} mm")]
    Length {
        /// The length, mm.
        length_mm: f64,
    },
    /// A `(u, v)` of the laid-out ring is not finite.
    #[error("the annulus layout is not finite")]
    LayoutNotFinite {
        /// The first ring point (index; the ring's length for the closing
        /// point) whose `(u, v)` is not finite.
        index: usize,
    },
}

/// The plane's name in messages: `least-squares`, `landmark`.
fn plane_name(mode: AnnulusMode) -> &'static str {
    match mode {
        AnnulusMode::Straight => "straight",
        AnnulusMode::LeastSquares => "least-squares",
        AnnulusMode::Landmark => "landmark",
    }
}
