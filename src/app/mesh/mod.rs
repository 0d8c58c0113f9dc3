//! Meshes from segmentations and from other tools: masks meshed into tets
//! ([`mask`]).

pub mod mask;
