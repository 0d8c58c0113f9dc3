//! unfold-io: reading and writing the files unfold works with.
//!
//! Meshes: VTK legacy `.vtk` (ASCII / binary, versions up to 4.2 and 5.1),
//! VTK XML `.vtu` / `.vtp` (ASCII, inline base64, appended raw or base64,
//! zlib), PLY, OBJ, STL, OFF, Medit `.mesh`, Gmsh `.msh` (read). Images:
//! NIfTI-1 `.nii` / `.nii.gz`, NRRD `.nrrd` / `.nhdr` / `.seg.nrrd`.
//! Landmarks: 3D Slicer markups `.mrk.json` and `.fcsv` ([`markups`]).
//! The format is chosen by file extension. Injectivity problems, the TLC
//! benchmark's rest / init / simplices / handles text file, have no
//! extension of their own and are read by [`read_injectivity_problem`]
//! ([`tlc`]). An image's header can be read alone
//! ([`read_image_header`]) and its values streamed in bounded memory
//! ([`scan_image_values`], [`image_value_summary`]).
//!
//! Every format module parses bytes and serializes to bytes; the functions
//! here add the file path to errors and write atomically (temporary file in
//! the same directory, then rename), so a crash never leaves half a file and
//! an input is never modified in place. (Whole-run output sets, staged beside
//! their targets, are the application's: `unfold::app::run::staged`.)

mod decode_limit;
mod error;
mod format;
pub mod frame;
pub mod gmsh;
mod image_header;
mod image_values;
pub mod markups;
pub mod medit;
pub mod nifti;
pub mod nrrd;
pub mod obj;
pub mod off;
mod options;
pub mod ply;
pub mod stl;
pub mod tlc;
pub mod vtk_legacy;
pub mod vtk_xml;

pub use decode_limit::set_decode_limit;
pub use error::{FilePath, IoError, Location};
pub use format::{
    FileKind, MeshFormat, atomic_write, read_image, read_mesh, read_tet_mesh, read_tri_mesh,
    write_image, write_mesh,
};
pub use frame::{Frame, mesh_frame_hint};
pub use image_header::{ImageHeader, read_image_header};
pub use image_values::{ValueSummary, image_value_summary, scan_image_values};
pub use markups::{Markups, MarkupsError, read_markups};
pub use nifti::{Datatype, NiftiImage};
pub use options::{LegacyVersion, WriteOptions, XmlEncoding};
pub use tlc::{
    Cells, InjectivityProblem, TlcError, format_injectivity_problem, parse_injectivity_problem,
    read_injectivity_problem, write_injectivity_problem,
};
