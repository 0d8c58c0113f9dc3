//! The errors of the placenta pipeline.
//!
//! [`PlacentaError`] holds the failures of the mesh (its shape does not fit
//! the pipeline) and of the parcellation into fetal and maternal sides;
//! [`PullbackError`] those of the template grid and the image pull-back
//! (ALGORITHMS 2.7). Both reach callers of the pipeline as
//! [`OrganError::Placenta`]; settings out of range are
//! [`ConfigError`](crate::ConfigError)s.

use super::pullback::{MAX_VOXELS, dims_for};
use crate::OrganError;
use std::fmt;
use thiserror::Error;
use unfold_mesh::MeshError;

/// Everything the placenta pipeline itself can reject (besides bad
/// settings, mesh validation and solver failures).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum PlacentaError {
    // ---- the mesh's shape ----
    /// The mesh has no tetrahedra (a surface mesh was given).
    #[error(
        "the mesh has no tetrahedra (a surface mesh?); the placenta pipeline needs a tetrahedral \
         volume mesh"
    )]
    NoTetrahedra,
    /// The mesh overlaps itself: interior faces whose two tets lie on the
    /// same side (a folded or tangled mesh). Re-orienting its tets would not
    /// make it a valid domain, so it is refused rather than mapped.
    #[error(
        "the mesh is tangled: {folded} interior face(s) are folded (both tets of the face lie on \
         the same side of it), the first between tets {} and {} at ({:.2}, {:.2}, {:.2}) mm \
         (vertices {:?}); untangle or remesh it",
        .tets[0], .tets[1], .position[0], .position[1], .position[2], .face
    )]
    Tangled {
        /// Folded interior faces.
        folded: usize,
        /// The first folded face's vertices.
        face: [u32; 3],
        /// The two tets of that face.
        tets: [usize; 2],
        /// Its centroid, mm.
        position: [f64; 3],
    },
    /// The mesh overlaps itself globally: no tet is inverted and no face
    /// folded, but its boundary surface meets itself (say a slab bent round
    /// so that one end passes through the other,
    /// [`unfold_mesh::geometry::tet_boundary_self_intersections`]). Such a
    /// mesh is no valid domain, so it is refused rather than mapped.
    #[error(
        "the mesh overlaps itself: its boundary meets itself at ({:.2}, {:.2}, {:.2}) mm, where \
         boundary face {:?} of tet {} and boundary face {:?} of tet {} intersect ({faces} \
         boundary face(s) involved); remesh it",
        .position[0], .position[1], .position[2], .vertices[0], .tets[0], .vertices[1], .tets[1]
    )]
    SelfOverlapping {
        /// Boundary faces in at least one intersecting pair.
        faces: usize,
        /// The first intersecting pair's vertices (volume vertex ids).
        vertices: [[u32; 3]; 2],
        /// The tets of those two faces.
        tets: [usize; 2],
        /// A point where they meet, mm.
        position: [f64; 3],
    },
    /// The mesh encloses no volume (flat, or empty).
    #[error("the mesh has no volume")]
    NoVolume {
        /// The sum of the tets' volumes, mm^3 (0, negative or not finite).
        volume_mm3: f64,
    },
    /// No interior point (sampled or vertex) has a finite distance to the
    /// boundary, so the thickness cannot be estimated.
    #[error("no interior point found to estimate the thickness")]
    NoInteriorPoint {
        /// Quasi-random points tried in the mesh's bounding box.
        samples: usize,
    },
    /// The boundary has no two vertices joined by a path, so its geodesic
    /// width (the radius `ry`) is 0.
    #[error("the boundary has no two connected vertices")]
    NoBoundaryWidth,
    /// A segmentation has no voxel inside.
    #[error("the segmentation has no voxel inside")]
    EmptyMask,
    /// Every voxel of a segmentation is set: no background, so no
    /// boundary and no thickness to measure.
    #[error(
        "every one of the segmentation's {voxels} voxels is set: a mask needs background around \
         the placenta (an inverted mask? a probability map needs --threshold)"
    )]
    FullMask {
        /// Voxels in the mask (all set).
        voxels: usize,
    },
    /// The optimizer ran no stage (an internal error).
    #[error("no optimization stage ran")]
    NoStage,

    // ---- the parcellation into fetal and maternal sides ----
    /// The tet mesh has no boundary triangles.
    #[error("parcellation: the mesh has no boundary")]
    NoBoundary,
    /// The largest piece of the boundary has too few vertices.
    #[error(
        "parcellation: the boundary has only {vertices} vertices; at least {needed} are needed"
    )]
    BoundaryTooSmall {
        /// Vertices of the largest boundary piece.
        vertices: usize,
        /// The fewest the parcellation accepts.
        needed: usize,
    },
    /// No edge of the boundary has a positive, finite length.
    #[error("parcellation: the boundary has no edges of positive length")]
    NoEdgeLength {
        /// The longest ring distance found, mm.
        longest_mm: f64,
    },
    /// The affinity `exp(gamma n_i . n_j d_ij / l_max)` overflowed.
    #[error("parcellation: the affinity overflows (a normal is not finite?)")]
    AffinityOverflow {
        /// The first boundary vertex (index in the boundary piece) whose
        /// degree is not finite.
        vertex: usize,
    },
    /// The eigensolver could not find the Fiedler vector.
    #[error("parcellation: Fiedler vector: {0}")]
    Fiedler(#[source] unfold_linalg::LinalgError),
    /// The Fiedler vector has one sign on the whole boundary (e.g. a
    /// sphere has no two sides).
    #[error("parcellation: the Fiedler vector does not split the boundary into two sides")]
    NoSplit {
        /// Vertices of the boundary piece.
        vertices: usize,
        /// Of those, vertices where the Fiedler vector is positive (0 or
        /// all).
        positive: usize,
    },
    /// The margin swallowed a whole side.
    #[error(
        "parcellation: the margin covers a whole side ({fetal} fetal, {maternal} maternal \
         vertices left); try a smaller margin"
    )]
    MarginCoversSide {
        /// Fetal vertices left outside the margin.
        fetal: usize,
        /// Maternal vertices left outside the margin.
        maternal: usize,
    },
    /// A side has no boundary area, so the alignment cannot tell the fetal
    /// side (up) from the maternal side.
    #[error("parcellation: a side has no boundary area; cannot tell up from down")]
    SideWithoutArea {
        /// Total boundary weight of the fetal side.
        fetal_area: f64,
        /// Total boundary weight of the maternal side.
        maternal_area: f64,
    },
    /// The rigid motion that best fits the initial map cannot be computed
    /// (no points, different counts, non-finite coordinates).
    #[error("no rigid fit of the initial map: {input} input points, {mapped} mapped points")]
    NoRigidFit {
        /// Input points.
        input: usize,
        /// Mapped points.
        mapped: usize,
    },
    /// A template's starting parameters do not match its parameter names.
    #[error("template {template}: {found} starting parameters for {expected} named ones")]
    TemplateParameters {
        /// The template.
        template: &'static str,
        /// Its number of named parameters.
        expected: usize,
        /// The number of starting parameters it gave.
        found: usize,
    },
    /// An image is named twice (the outputs would collide).
    #[error("images {first} and {index} have the same name; rename one of them")]
    ImageNameRepeated {
        /// The first image with the name (index in the input).
        first: usize,
        /// The image that repeats it.
        index: usize,
    },
    /// The mesh lies outside the foreground of image `index`, and an axis
    /// flip would put it in ([`super::frame_check`]): the mesh is probably
    /// in another frame (x and y: LPS instead of RAS).
    #[error(
        "only {:.0}% of the mesh lies in the foreground of image {index}; mirrored in {} \
         ({}) {:.0}% would: convert the mesh to the image's frame",
        100.0 * .inside,
        .flip.describe(),
        if .flip.is_lps_ras() { "LPS <-> RAS" } else { "an axis flip" },
        100.0 * .flipped_inside
    )]
    MeshFlipped {
        /// The image.
        index: usize,
        /// Fraction of the mesh volume in its foreground.
        inside: f64,
        /// The flip that would fix it.
        flip: super::frame_check::Flip,
        /// Fraction after that flip.
        flipped_inside: f64,
    },
    /// Almost none of the mesh lies in the foreground of image `index`, and
    /// no axis flip helps ([`super::frame_check`]).
    #[error(
        "only {:.0}% of the mesh lies in the foreground of image {index} (values >= {threshold:.4}) \
         and no axis flip helps: check that the image and the mesh come from the same scan"
    , 100.0 * .inside)]
    MeshOutsideForeground {
        /// The image.
        index: usize,
        /// Fraction of the mesh volume in its foreground.
        inside: f64,
        /// The foreground threshold (Otsu's).
        threshold: f64,
    },

    /// Pulling one image back failed (the table of its spacing or its
    /// resampling).
    #[error("{source}")]
    ImagePullback {
        /// The image's index in the input.
        index: usize,
        /// What failed.
        source: Box<PullbackError>,
    },

    // ---- the template grid and the image pull-back ----
    /// The template grid or the pull-back failed (boxed: its bounding boxes
    /// would make every `Result<_, OrganError>` large).
    #[error(transparent)]
    Pullback(Box<PullbackError>),
}

impl From<PullbackError> for PlacentaError {
    fn from(e: PullbackError) -> Self {
        PlacentaError::Pullback(Box::new(e))
    }
}

/// Failures of the template grid and of the image pull-back
/// ([`super::pullback`]).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum PullbackError {
    // ---- the template grid ----
    /// A fixed template grid box has a non-finite bound or a max below its
    /// min.
    #[error(
        "invalid configuration: the template grid box needs finite bounds with max >= min on \
         every axis, got min [{}] and max [{}] mm",
        Mm3(.min),
        Mm3(.max)
    )]
    GridBox {
        /// `(xmin, ymin, zmin)`, mm.
        min: [f64; 3],
        /// `(xmax, ymax, zmax)`, mm.
        max: [f64; 3],
    },
    /// A template voxel spacing is not finite and positive.
    #[error(
        "invalid configuration: the template voxel spacing must be finite and positive, got [{}] mm",
        Mm3(.spacing)
    )]
    Spacing {
        /// The spacing given, mm.
        spacing: [f64; 3],
    },
    /// A grid was asked to cover no point.
    #[error("invalid configuration: the template grid must cover at least one point, got none")]
    NoPoints,
    /// The points' bounding box has an infinite extent.
    #[error(
        "the points' bounding box [{}] - [{}] mm is too large",
        Mm3(.lo),
        Mm3(.hi)
    )]
    BoxTooLarge {
        /// Lower corner, mm.
        lo: [f64; 3],
        /// Upper corner, mm.
        hi: [f64; 3],
    },
    /// The grid covering the points at the spacing asked would have more
    /// than [`MAX_VOXELS`] voxels. The message gives the voxels needed along
    /// each axis, `ceil((hi - lo) / spacing) + 1`.
    #[error(
        "invalid configuration: a template grid of [{}] voxels at spacing [{}] mm covering [{}] - \
         [{}] mm exceeds the limit of {} voxels{}",
        Counts(.lo, .hi, .spacing),
        Mm3(.spacing),
        Mm3(.lo),
        Mm3(.hi),
        MAX_VOXELS,
        FitHint(.fitting)
    )]
    GridTooLarge {
        /// The spacing asked, mm.
        spacing: [f64; 3],
        /// Lower corner of the points' bounding box, mm.
        lo: [f64; 3],
        /// Upper corner of the points' bounding box, mm.
        hi: [f64; 3],
        /// The smallest multiple of the spacing that would fit (rounded up
        /// to 1e-3 mm), when there is one.
        fitting: Option<[f64; 3]>,
    },
    /// A hand-made grid's origin is not finite.
    #[error(
        "invalid configuration: the template grid's origin must be finite, got [{}]",
        Mm3(.origin)
    )]
    Origin {
        /// The origin given, mm.
        origin: [f64; 3],
    },
    /// A hand-made grid has no voxel or too many.
    #[error(
        "invalid configuration: the template grid must have between 1 and {limit} voxels, got \
         dims {dims:?}"
    )]
    GridSize {
        /// Voxels along x, y and z.
        dims: [usize; 3],
        /// The largest grid accepted, voxels.
        limit: usize,
    },
    /// The reference (scanner) grid of the way back has no voxel or too many.
    #[error(
        "the reference image grid must have between 1 and {limit} voxels, got dims {dims:?}; \
         resample the reference image coarser"
    )]
    ReferenceGridSize {
        /// Voxels along i, j and k.
        dims: [usize; 3],
        /// The largest grid accepted, voxels.
        limit: usize,
    },
    /// The reference (scanner) grid's affine has a non-finite entry.
    #[error("the reference image's voxel-to-world affine is not finite")]
    ReferenceAffine,
    /// A point is not finite.
    #[error("{what} {index} is not finite: ({}, {}, {})", .point[0], .point[1], .point[2])]
    NotFinite {
        /// Which points (`point`, `mapped position`, `source position`).
        what: &'static str,
        /// Its index.
        index: usize,
        /// Its coordinates, mm.
        point: [f64; 3],
    },

    // ---- the pull-back table ----
    /// Mapped and source positions differ in number.
    #[error(
        "{mapped} mapped positions but {sources} source positions; the pull-back needs one of each \
         per vertex"
    )]
    LengthMismatch {
        /// Number of mapped (flattened) positions.
        mapped: usize,
        /// Number of source (rest) positions.
        sources: usize,
    },
    /// The mesh has no vertex or no tet.
    #[error("the pull-back needs a non-empty tet mesh, got {vertices} vertices and {tets} tets")]
    EmptyMesh {
        /// Number of vertices.
        vertices: usize,
        /// Number of tets.
        tets: usize,
    },
    /// A tet refers to a vertex that does not exist.
    #[error("tet {tet} {corners:?} refers to a vertex beyond the {vertices} positions")]
    VertexOutOfRange {
        /// The tet's index.
        tet: usize,
        /// Its corners.
        corners: [u32; 4],
        /// Number of positions.
        vertices: usize,
    },
    /// Every tet of the mapped mesh is flat, so no voxel can be located.
    #[error("all {tets} tets of the mapped mesh are degenerate (flat)")]
    AllTetsFlat {
        /// Number of tets.
        tets: usize,
    },

    // ---- applying the table to an image ----
    /// The image has no voxels (or no frame).
    #[error("image: the image has no voxels")]
    EmptyImage {
        /// Voxels per frame.
        frame_voxels: usize,
        /// Frames.
        frames: usize,
    },
    /// No voxel centre of the template grid lies inside the mapped mesh.
    #[error(
        "the pull-back table is empty: no voxel centre of the template grid lies inside the \
         mapped mesh"
    )]
    EmptyTable {
        /// Voxels of the template grid.
        grid_voxels: usize,
    },
    /// No source point falls inside the image.
    #[error(
        "image: the image does not overlap the mesh: its world bounding box [{}] - [{}] mm vs the \
         mesh's [{}] - [{}] mm (no source point of the {voxels} voxels inside the mesh falls \
         inside the image)",
        Mm3(.image_lo),
        Mm3(.image_hi),
        Mm3(.mesh_lo),
        Mm3(.mesh_hi)
    )]
    NoOverlap {
        /// Lower corner of the image's world bounding box, mm.
        image_lo: [f64; 3],
        /// Upper corner of the image's world bounding box, mm.
        image_hi: [f64; 3],
        /// Lower corner of the mesh's (rest positions') bounding box, mm.
        mesh_lo: [f64; 3],
        /// Upper corner of the mesh's bounding box, mm.
        mesh_hi: [f64; 3],
        /// Template voxels inside the mesh.
        voxels: usize,
    },
    /// An image's world box does not meet the mesh's bounding box (checked
    /// before the optimization).
    #[error(
        "the image does not overlap the mesh: its world bounding box is [{}] - \
         [{}] mm, the mesh's is [{}] - [{}] mm (is it an image of this placenta, in the same \
         scanner frame?)",
        Mm3(.image_lo),
        Mm3(.image_hi),
        Mm3(.mesh_lo),
        Mm3(.mesh_hi)
    )]
    Disjoint {
        /// The image's index in the input.
        index: usize,
        /// Lower corner of the image's world bounding box, mm.
        image_lo: [f64; 3],
        /// Upper corner of the image's world bounding box, mm.
        image_hi: [f64; 3],
        /// Lower corner of the mesh's bounding box, mm.
        mesh_lo: [f64; 3],
        /// Upper corner of the mesh's bounding box, mm.
        mesh_hi: [f64; 3],
    },
    /// The pulled-back image could not be built.
    #[error("image: building the pulled-back image: {0}")]
    Output(#[source] MeshError),
}

impl From<PullbackError> for OrganError {
    fn from(e: PullbackError) -> Self {
        OrganError::Placenta(e.into())
    }
}

/// Three millimetre values as `x, y, z` with one decimal.
struct Mm3<'a>(&'a [f64; 3]);

impl fmt::Display for Mm3<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        write!(f, "{:.1}, {:.1}, {:.1}", v[0], v[1], v[2])
    }
}

/// The voxel counts `nx, ny, nz` of a grid covering `[lo, hi]` (the first
/// two) at a spacing (the third).
struct Counts<'a>(&'a [f64; 3], &'a [f64; 3], &'a [f64; 3]);

impl fmt::Display for Counts<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Counts(lo, hi, spacing) = self;
        let ext = std::array::from_fn(|a| hi[a] - lo[a]);
        let c = dims_for(ext, **spacing);
        write!(f, "{}, {}, {}", c[0], c[1], c[2])
    }
}

/// "; a spacing of at least [..] mm would fit", or nothing.
struct FitHint<'a>(&'a Option<[f64; 3]>);

impl fmt::Display for FitHint<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(s) => write!(
                f,
                "; a spacing of at least [{:.3}, {:.3}, {:.3}] mm would fit",
                s[0], s[1], s[2]
            ),
            None => Ok(()),
        }
    }
}
