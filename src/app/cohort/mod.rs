//! Cohorts: many subjects run from a manifest, each as its own process
//! ([`batch`], [`manifest`], [`subject`], [`finish`]), then gathered into
//! the cohort table ([`table`]), the template-space statistics of the
//! placentas on a common grid ([`images`], [`grid`]), the AHA-segment statistics of the ventricles
//! ([`segments`]), the mitral measurements and mean maps ([`mitral`],
//! [`mitral_maps`]), the cohort figures ([`figures`]) and the report page
//! ([`report_page`]); every subject's report read typed ([`reports`]);
//! `--layout bids` as a BIDS derivative dataset ([`bids`]).

pub mod batch;
pub mod bids;
pub mod columns;
pub mod compare;
pub mod figures;
pub mod finish;
pub mod grid;
pub mod images;
pub mod linked_viewer;
pub mod manifest;
pub mod mitral;
pub mod mitral_maps;
pub mod report_page;
pub mod reports;
pub mod scalars;
pub mod segments;
pub mod subject;
pub mod table;
pub mod valve_segments;

pub use batch::{BatchObserver, run_manifest, run_plan};
pub use bids::{Layout, run_manifest_bids};
pub use columns::{OrganColumns, organ_columns};
pub use compare::{CompareSettings, Comparison, compare};
pub use figures::PlotSpec;
pub use finish::{Counts, finish, prepare_output};
pub use manifest::{Plan, plan};
pub use reports::{SubjectReport, read_report};
pub use subject::{
    Ended, Program, STATUSES, Subject, SubjectRow, place_subject, recorded_hash, run_subject,
};
pub use table::{gather, gather_compare};
