//! unfold-mesh: the data every unfold pipeline works on.
//!
//! - [`TriMesh`], [`TetMesh`]: f64 positions (mm), u32 indices, named fields
//!   ([`Fields`]) that ride along to the writers; [`CellMesh`]: the mixed-cell
//!   mesh that files hold.
//! - [`validate`] and [`repair`]: typed problems ([`MeshError`]), orientation,
//!   duplicate removal, largest component; [`reindex`]: dropping unused
//!   vertices and renumbering the elements.
//! - [`fold_check`]: inverted and folded elements (tets, planar
//!   triangles), counted and as validation problems.
//! - [`topology`]: adjacency, edges, k-rings, boundaries, loops, components.
//! - [`geometry`]: volumes, areas, normals, vertex areas, PCA frame, hull.
//! - [`geodesic`]: Dijkstra along edges.
//! - [`spatial`]: point location and closest points (BVH).
//! - [`stats`]: [`stats::Summary`] (mean, sample std, percentiles);
//!   [`nan_as_null`]: reading back a report's numbers written as `null`.
//! - [`Volume`]: 3D / 4D images with their voxel-to-world affine; [`mask`]
//!   operations and [`mesher`]: tet meshes of segmentations by isosurface
//!   [`stuffing`], whose self-touching boundaries [`pinch`] resolves.
//! - [`marching_tets`]: the zero level set of a sampled field as a closed
//!   surface; [`taubin`]: non-shrinking smoothing; [`clip`]: a surface cut
//!   by a plane.
//! - [`shapes`]: deterministic synthetic placenta, ventricle and valve.

pub mod bcc;
pub mod cells;
pub mod chain;
pub mod clip;
pub mod coarsen;
mod error;
pub mod field;
pub mod fold_check;
pub mod geodesic;
pub mod geometry;
pub mod marching_tets;
pub mod mask;
pub mod mask_selection;
pub mod memory;
pub mod mesher;
pub mod nan_as_null;
pub mod pinch;
pub mod raster;
pub mod reindex;
pub mod repair;
pub mod shapes;
pub mod spatial;
pub mod stats;
pub mod stuffing;
pub mod taubin;
#[cfg(test)]
mod test_meshes;
pub mod tetmesh;
pub mod topology;
pub mod trimesh;
pub mod validate;
pub mod volume;
pub mod weld;

pub use cells::{CellMesh, CellType};
pub use error::MeshError;
pub use field::{Field, FieldValues, Fields};
pub use nalgebra;
pub use tetmesh::TetMesh;
pub use trimesh::TriMesh;
pub use volume::Volume;
