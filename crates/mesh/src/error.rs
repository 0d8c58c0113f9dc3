//! The error type of unfold-mesh.

use thiserror::Error;

/// Everything that can be wrong with a mesh, a field or an image handed to
/// unfold-mesh. Variants carry the element / vertex indices a user needs to
/// find the problem in their file.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The mesh has no vertices or no elements where some are required.
    #[error("the mesh is empty: {what}")]
    Empty {
        /// What was missing ("vertices", "triangles", ...).
        what: &'static str,
    },
    /// An element refers to a vertex index `>=` the number of vertices.
    #[error("element {element} refers to vertex {index}, but the mesh has {vertex_count} vertices")]
    IndexOutOfRange {
        /// Element (triangle, tet or cell) index.
        element: usize,
        /// The offending vertex index.
        index: u32,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// An element uses the same vertex twice.
    #[error("element {element} uses vertex {index} more than once")]
    RepeatedVertex {
        /// Element index.
        element: usize,
        /// The repeated vertex index.
        index: u32,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({x}, {y}, {z})")]
    NonFiniteCoordinate {
        /// Vertex index.
        vertex: usize,
        /// x coordinate.
        x: f64,
        /// y coordinate.
        y: f64,
        /// z coordinate.
        z: f64,
    },
    /// An element's area (triangles) or volume (tets) is below the relative
    /// threshold `threshold = rel * mean |measure|`.
    #[error("element {element} is degenerate: |measure| {measure:e} is below {threshold:e}")]
    DegenerateElement {
        /// Element index.
        element: usize,
        /// Its signed area or volume.
        measure: f64,
        /// The absolute threshold it fell below.
        threshold: f64,
    },
    /// A tet has negative signed volume `(b-a)·((c-a)×(d-a))/6 < 0`.
    #[error(
        "tet {element} is inverted (signed volume {volume:e}): when every tet is, the mesh is \
         mirrored and `unfold repair` re-orients it; when only some are, it is folded"
    )]
    InvertedElement {
        /// Tet index.
        element: usize,
        /// Its signed volume.
        volume: f64,
    },
    /// A triangle of a planar mesh turns against the others: its signed
    /// area in the mesh's plane has the sign fewer triangles have (the mesh
    /// is folded).
    #[error(
        "triangle {element} of the planar mesh is inverted (signed area {area:e} against the \
         others'): the map is folded"
    )]
    InvertedTriangle {
        /// Triangle index.
        element: usize,
        /// Its signed area in the plane (the majority's sign is positive).
        area: f64,
    },
    /// An interior face of a tet mesh is folded: the two tets sharing it
    /// lie on the same side of it, so the mesh overlaps itself there
    /// ([`crate::geometry::folded_faces`]).
    #[error(
        "face ({}, {}, {}) is folded: tets {} and {} lie on the same side of it (the mesh \
         overlaps itself; re-orienting cannot fix that: re-mesh or untangle it)",
        face[0], face[1], face[2], tets[0], tets[1]
    )]
    FoldedFace {
        /// The face's vertices, ascending.
        face: [u32; 3],
        /// The two tets sharing it.
        tets: [usize; 2],
    },
    /// An interior edge of a planar triangle mesh is folded: its two
    /// triangles lie on the same side of it ([`crate::geometry::folded_edges`]).
    #[error(
        "edge ({}, {}) is folded: triangles {} and {} lie on the same side of it (the map \
         overlaps itself; re-orienting cannot fix that: re-mesh or untangle it)",
        edge[0], edge[1], triangles[0], triangles[1]
    )]
    FoldedEdge {
        /// The edge's vertices, ascending.
        edge: [u32; 2],
        /// The two triangles sharing it.
        triangles: [usize; 2],
    },
    /// Some vertices are used by no element.
    #[error("{count} vertices are used by no element (first: vertex {first})")]
    UnusedVertices {
        /// How many.
        count: usize,
        /// The smallest such index.
        first: usize,
    },
    /// An edge of a triangle mesh is shared by more than two triangles.
    #[error("edge ({a}, {b}) is shared by {faces} triangles (non-manifold)")]
    NonManifoldEdge {
        /// First vertex of the edge.
        a: u32,
        /// Second vertex of the edge.
        b: u32,
        /// Number of triangles sharing it.
        faces: usize,
    },
    /// A face of a tet mesh is shared by more than two tets.
    #[error("face ({}, {}, {}) is shared by {tets} tets (non-manifold)", face[0], face[1], face[2])]
    NonManifoldFace {
        /// The face's vertices (sorted).
        face: [u32; 3],
        /// Number of tets sharing it.
        tets: usize,
    },
    /// Two triangles sharing an edge traverse it in the same direction.
    #[error(
        "triangles {triangle1} and {triangle2} are inconsistently oriented across edge ({}, {})",
        edge[0], edge[1]
    )]
    InconsistentOrientation {
        /// First triangle.
        triangle1: usize,
        /// Second triangle.
        triangle2: usize,
        /// The shared edge.
        edge: [u32; 2],
    },
    /// A surface that no choice of triangle orientations makes consistent
    /// (a Möbius strip, a Klein bottle): repair cannot fix it. Vertex and
    /// triangle ids are those of the input.
    #[error(
        "the surface is not orientable (a Moebius strip or similar): triangles {} and {} cannot \
         agree across the edge from vertex {} ({}, {}, {}) to vertex {} ({}, {}, {}); cut the \
         surface along that edge or remove the twisted part",
        triangles[0], triangles[1],
        vertices[0], at[0][0], at[0][1], at[0][2],
        vertices[1], at[1][0], at[1][1], at[1][2]
    )]
    NonOrientable {
        /// The two triangles (input numbering).
        triangles: [usize; 2],
        /// The shared edge's vertices (input numbering).
        vertices: [usize; 2],
        /// Their coordinates, mm.
        at: [[f64; 3]; 2],
    },
    /// The mesh falls apart into several connected components.
    #[error(
        "the mesh has {count} connected components; expected one (largest_component() keeps the largest)"
    )]
    MultipleComponents {
        /// Number of components.
        count: usize,
    },
    /// A triangle mesh that should be a disk is closed (no boundary loop).
    #[error("the surface is closed (no boundary loop); cut it open first")]
    ClosedSurface,
    /// A triangle mesh that should be a disk has several boundary loops.
    #[error(
        "the surface has {} boundary loops (lengths {lengths:?}), expected exactly 1 (disk \
         topology); fill the holes first",
        lengths.len()
    )]
    BoundaryLoops {
        /// The vertex count of every loop.
        lengths: Vec<usize>,
    },
    /// A triangle mesh with one boundary loop that is not a disk (it has
    /// handles).
    #[error("Euler characteristic {euler}, expected 1 for a disk (the surface has handles)")]
    NotADisk {
        /// `V - E + F`.
        euler: i64,
    },
    /// A named field has the wrong number of values for what it is attached to.
    #[error("field '{name}' has {found} tuples, expected {expected}")]
    FieldLength {
        /// Field name.
        name: String,
        /// Expected number of tuples (vertices or cells).
        expected: usize,
        /// Number found.
        found: usize,
    },
    /// A field's value count is not a multiple of its component count.
    #[error("field '{name}' has {len} values, not a multiple of {components} components")]
    FieldComponents {
        /// Field name.
        name: String,
        /// Number of values.
        len: usize,
        /// Number of components per tuple.
        components: usize,
    },
    /// A mixed cell mesh holds cells that the requested mesh type cannot hold.
    #[error("cell {cell} is a {found:?}, but a {expected} mesh was required")]
    WrongCellType {
        /// Cell index.
        cell: usize,
        /// The cell's type.
        found: crate::CellType,
        /// What was expected ("triangle", "tetrahedral", ...).
        expected: &'static str,
    },
    /// A cell has the wrong number of vertices for its type.
    #[error("cell {cell} of type {cell_type:?} has {found} vertices")]
    CellSize {
        /// Cell index.
        cell: usize,
        /// Its type.
        cell_type: crate::CellType,
        /// The number of vertices found.
        found: usize,
    },
    /// A weld tolerance that is negative, NaN or infinite.
    #[error("the weld tolerance must be a finite distance >= 0, got {tolerance}")]
    WeldTolerance {
        /// The tolerance given, mm.
        tolerance: f64,
    },
    /// A working grid (the cropped, smoothed mask of the mesher) would have
    /// more voxels than can be held.
    #[error(
        "{what} would need a {} x {} x {} voxel working grid ({voxels:.3e} voxels, about {gib:.1} \
         GiB), more than the {limit} voxels allowed; {hint}",
        dims[0], dims[1], dims[2]
    )]
    WorkingGridTooLarge {
        /// What needs the grid.
        what: &'static str,
        /// Voxels along each axis (as reals: they may not fit an integer).
        dims: [f64; 3],
        /// Their product.
        voxels: f64,
        /// Estimated memory, GiB.
        gib: f64,
        /// The largest grid allowed, voxels.
        limit: usize,
        /// What to change.
        hint: &'static str,
    },
    /// An element's area (triangles) or volume (tets) is not finite although
    /// its corners' coordinates are: they are too large for the products of
    /// the measure (e.g. `1e308`) in `f64`.
    #[error(
        "the {what} of element {element} is {value} although its coordinates are finite: \
         they are too large; scale the mesh down (e.g. to millimetres)"
    )]
    NonFiniteMeasure {
        /// "area" or "volume".
        what: &'static str,
        /// Element index.
        element: usize,
        /// The measure computed (infinite or NaN).
        value: f64,
    },
    /// The total area or volume, `Σ |measure|` over the elements, overflows
    /// although every element's is finite.
    #[error(
        "the total {what} of the mesh is {value}: its coordinates are too large; scale the \
         mesh down (e.g. to millimetres)"
    )]
    NonFiniteTotalMeasure {
        /// "area" or "volume".
        what: &'static str,
        /// The sum (infinite).
        value: f64,
    },
    /// A raster grid ([`crate::raster::Grid2`]) without cells, or with a
    /// spacing that is not a finite number > 0, or a non-finite origin.
    #[error(
        "a raster grid needs at least one cell along each axis, finite spacings > 0 and a finite \
         origin; got {} x {} cells of {} x {} from ({}, {})",
        dims[0], dims[1], spacing[0], spacing[1], origin[0], origin[1]
    )]
    RasterGrid {
        /// The origin given.
        origin: [f64; 2],
        /// The spacing given.
        spacing: [f64; 2],
        /// The cell counts given.
        dims: [usize; 2],
    },
    /// A volume's data length or dimensions are inconsistent.
    #[error("image: {0}")]
    Image(String),
    /// A mask image holds several values besides 0 (a label map), and no
    /// label or threshold says which voxels are inside.
    #[error(
        "the mask holds {}{} values besides 0 ({}{}): a label or a threshold must say which \
         voxels are inside",
        if *all_counted { "" } else { "at least " },
        values.len() + more,
        list_values(values),
        match (*more, *all_counted) {
            (0, _) => String::new(),
            (m, true) => format!(" and {m} more"),
            (m, false) => format!(" and over {m} more"),
        }
    )]
    MaskValues {
        /// The first few distinct nonzero values, ascending.
        values: Vec<f64>,
        /// How many more distinct nonzero values there are (counted up to
        /// a bound, see `all_counted`).
        more: usize,
        /// Whether every distinct value was counted (false: there are
        /// more than `values.len() + more`, an intensity image).
        all_counted: bool,
    },
    /// No voxel of a mask image holds the label asked for.
    #[error(
        "no voxel of the mask holds the label {label}; it holds {}{}",
        if values.is_empty() { "only 0".to_string() } else { list_values(values) },
        match (*more, *all_counted) {
            (0, _) => String::new(),
            (m, true) => format!(" and {m} more values"),
            (m, false) => format!(" and over {m} more values"),
        }
    )]
    MaskLabelAbsent {
        /// The label asked for.
        label: f64,
        /// The first few distinct nonzero values the mask holds, ascending.
        values: Vec<f64>,
        /// How many more distinct nonzero values there are (counted up to
        /// a bound, see `all_counted`).
        more: usize,
        /// Whether every distinct value was counted.
        all_counted: bool,
    },
    /// The boundary of a tet mesh cut from a lattice still touches itself
    /// after [`crate::pinch::resolve_pinches`]'s rounds.
    #[error(
        "the mesh's boundary stays pinched near ({:.2}, {:.2}, {:.2}) ({edges} edges, {vertices} \
         vertices touching themselves after {rounds} rounds of splitting and opening); {hint}",
        at[0], at[1], at[2]
    )]
    Pinched {
        /// A pinched vertex's position.
        at: [f64; 3],
        /// Pinched edges left.
        edges: usize,
        /// Pinched vertices left.
        vertices: usize,
        /// Rounds run.
        rounds: usize,
        /// What to change.
        hint: &'static str,
    },
    /// Any other invalid argument, with a message.
    #[error("{0}")]
    InvalidArgument(String),
}

impl MeshError {
    /// A stable snake_case name of the problem kind, for reports and JSON.
    pub fn kind(&self) -> &'static str {
        match self {
            MeshError::Empty { .. } => "empty",
            MeshError::IndexOutOfRange { .. } => "index_out_of_range",
            MeshError::RepeatedVertex { .. } => "repeated_vertex",
            MeshError::NonFiniteCoordinate { .. } => "non_finite_coordinate",
            MeshError::DegenerateElement { .. } => "degenerate_element",
            MeshError::InvertedElement { .. } => "inverted_element",
            MeshError::InvertedTriangle { .. } => "inverted_triangle",
            MeshError::FoldedFace { .. } => "folded_face",
            MeshError::FoldedEdge { .. } => "folded_edge",
            MeshError::UnusedVertices { .. } => "unused_vertices",
            MeshError::NonManifoldEdge { .. } => "non_manifold_edge",
            MeshError::NonManifoldFace { .. } => "non_manifold_face",
            MeshError::InconsistentOrientation { .. } => "inconsistent_orientation",
            MeshError::NonOrientable { .. } => "non_orientable",
            MeshError::MultipleComponents { .. } => "multiple_components",
            MeshError::ClosedSurface => "closed_surface",
            MeshError::BoundaryLoops { .. } => "boundary_loops",
            MeshError::NotADisk { .. } => "not_a_disk",
            MeshError::FieldLength { .. } => "field_length",
            MeshError::FieldComponents { .. } => "field_components",
            MeshError::WrongCellType { .. } => "wrong_cell_type",
            MeshError::CellSize { .. } => "cell_size",
            MeshError::WeldTolerance { .. } => "weld_tolerance",
            MeshError::WorkingGridTooLarge { .. } => "working_grid_too_large",
            MeshError::NonFiniteMeasure { .. } => "non_finite_measure",
            MeshError::NonFiniteTotalMeasure { .. } => "non_finite_total_measure",
            MeshError::RasterGrid { .. } => "raster_grid",
            MeshError::Image(_) => "image",
            MeshError::MaskValues { .. } => "mask_values",
            MeshError::MaskLabelAbsent { .. } => "mask_label_absent",
            MeshError::Pinched { .. } => "pinched",
            MeshError::InvalidArgument(_) => "invalid_argument",
        }
    }
}

/// `values` as `1, 2, 3`.
fn list_values(values: &[f64]) -> String {
    values
        .iter()
        .map(f64::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}
