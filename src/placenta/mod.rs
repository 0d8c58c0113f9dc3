//! What `unfold placenta` and the Python package's `unfold.placenta` share
//! beyond the library pipeline ([`crate::organs::placenta::Pipeline`]): the
//! one-line messages of its errors ([`errors`]) and the shape of
//! `report.json` ([`report`]).

pub mod errors;
pub mod report;

pub use errors::{InputError, organ, pipeline_error};
pub use report::FullReport;
