//! Errors of cutting the leaflets from a label map
//! ([`valve_from_labels`](crate::mitral::segmentation::valve_from_labels)):
//! the map's values, the labels asked for, and the leaflet surfaces seen
//! from the atrium.

use super::LeafletSide;
use thiserror::Error;

/// The label map or its leaflets do not give two leaflet surfaces and an
/// annulus ring (see [`segmentation`](crate::mitral::segmentation)).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SegmentationError {
    /// The image has several frames.
    #[error(
        "the label map has {frames} frames; give one 3D label map (one time step of a 4D series)"
    )]
    Frames {
        /// Its frames.
        frames: usize,
    },
    /// A value is not an integer: the image is not a label map.
    #[error(
        "the image is not a label map: voxel {voxel} holds {value}, not an integer; give the \
         segmentation's label map (integer labels), not the grey-scale image"
    )]
    NotLabels {
        /// The voxel's index in the image's data.
        voxel: usize,
        /// Its value.
        value: f64,
    },
    /// Two roles were given the same label.
    #[error(
        "the {first} and the {second} were both given label {label}; each part needs its own label"
    )]
    SameLabel {
        /// The label.
        label: i64,
        /// The first role (`anterior leaflet`, `posterior leaflet`, `annulus`).
        first: &'static str,
        /// The second role.
        second: &'static str,
    },
    /// A label asked for has no voxel.
    #[error(
        "the {role}'s label {label} has no voxel; the map holds labels {present}: give the {role}'s \
         label among them"
    )]
    MissingLabel {
        /// The role (`anterior leaflet`, `posterior leaflet`, `annulus`).
        role: &'static str,
        /// The label asked for.
        label: i64,
        /// The labels the map holds (at most 12, comma-separated).
        present: String,
    },
    /// The valve's voxels do not span a plane (too few, or on a line).
    #[error(
        "the {what} voxels ({count}) do not span a plane, so the annulus plane is undefined; check \
         the labels (a leaflet or annulus label of a few voxels?)"
    )]
    NoPlane {
        /// `annulus` or `leaflet`.
        what: &'static str,
        /// Their voxels.
        count: usize,
    },
    /// The grid over the annulus plane would be too large.
    #[error(
        "the leaflets span {points} grid points of {spacing_mm} mm over the annulus plane (more \
         than {max}); crop the label map to the valve or resample it to coarser voxels"
    )]
    GridTooLarge {
        /// Grid points needed.
        points: usize,
        /// The grid spacing, mm.
        spacing_mm: f64,
        /// The limit.
        max: usize,
    },
    /// Seen from the atrium, a leaflet covers too little to make a surface.
    #[error(
        "seen from the atrium, the {leaflet} leaflet covers {points} grid point(s) of {spacing_mm} \
         mm (fewer than {min}); check its label, or resample the label map to finer voxels"
    )]
    LeafletTooSmall {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Its grid points.
        points: usize,
        /// The grid spacing, mm.
        spacing_mm: f64,
        /// The minimum.
        min: usize,
    },
    /// The two leaflets' atrial surfaces share no point.
    #[error(
        "the anterior and posterior leaflets do not touch seen from the atrium (their nearest \
         points are {gap_mm:.1} mm apart); label the leaflets so they meet at the commissures (and \
         the coaptation line), e.g. close the gap in the label map"
    )]
    LeafletsApart {
        /// Distance between the leaflets' nearest grid points over the
        /// annulus plane, mm.
        gap_mm: f64,
    },
    /// A leaflet's atrial surface is not a disk.
    #[error(
        "the {leaflet} leaflet's atrial surface has {loops} boundary loop(s) and Euler \
         characteristic {euler}, not a disk (a perforation or a gap in its label?); fill the hole \
         in the label map"
    )]
    LeafletNotDisk {
        /// The leaflet.
        leaflet: LeafletSide,
        /// Its boundary loops.
        loops: usize,
        /// `V - E + F`.
        euler: i64,
    },
    /// The annulus label is not a ring around the valve.
    #[error(
        "the annulus label is not a ring around the valve: {empty} of {bins} directions from its \
         centre hold no annulus voxel; label the whole annulus, or leave the annulus label out \
         (the ring is then the leaflets' outer edge)"
    )]
    AnnulusNotRing {
        /// Directions (angular bins) without an annulus voxel.
        empty: usize,
        /// Directions looked at.
        bins: usize,
    },
}
