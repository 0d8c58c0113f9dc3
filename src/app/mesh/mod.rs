//! Meshes from segmentations and from other tools, and the files around
//! them: masks meshed into tets ([`mask`], the run of `unfold mesh`
//! [`segmentation`]), meshes repaired ([`repair`]), files converted
//! ([`convert`]) and described ([`info`]).

pub mod convert;
pub mod info;
pub mod mask;
pub mod repair;
pub mod segmentation;
