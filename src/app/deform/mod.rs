//! Deforming a tet mesh towards soft positional targets with the least
//! distortion, flip-free (`unfold deform MESH --targets FILE -o OUT`).
//!
//! The problem is
//!
//! ```text
//! minimize  sum_k V_k D(J_k)  +  W sum_b |x_b - t_b|^2
//! ```
//!
//! over the vertex positions `x`, with `V_k` the rest volumes normalized to
//! sum 1, `D` the distortion energy (symmetric Dirichlet or ARAP) of the
//! Jacobian `J_k` of tet `k` against its rest shape (the input), and `t_b`
//! the targets of the vertices listed in FILE. It starts from the identity
//! (the input positions) and every iterate keeps every tet positively
//! oriented. This is the general tool for method developers, and how unfold
//! is compared with other injective solvers on the same problem.
//!
//! A run is [`Settings`] (checked once, [`Settings::validate`]), its
//! [`Files`] checked ([`Files::check`]) and read into [`Inputs`] ([`read`];
//! the targets file's format is in [`inputs`]), [`run()`] into a [`Run`] with
//! its typed [`DeformRunReport`], and [`write()`]:
//!
//! Output: OUT is the input mesh (its cells, point and cell arrays) with the
//! positions replaced; `OUT.report.json` beside it holds the result
//! (`objective`, `distortion`, `iterations`, `seconds`, `converged`,
//! `inverted_tets`, ...). Not converging within the iteration limit is not
//! an error: both files are written, `converged` is false and the summary
//! line says why it stopped.
//!
//! Vertices used by no tet and without a target carry no term at all; they
//! are kept where they are.
//!
//! The mesh is repaired first ([`crate::mesh::repair`]: coincident vertices
//! welded, duplicate, repeated-vertex and zero-volume tets dropped; an
//! inverted tet stays an error; counts under `repair` in the report). The solve runs on the
//! repaired mesh; targets and the output still use the input's vertex
//! numbers (welded copies move together; the first target of a welded
//! vertex counts; a vertex no tet uses goes to its target, if it has one).

pub mod inputs;
pub mod report;
pub mod run;
pub mod settings;
pub mod write;

pub use inputs::{Files, Inputs, parse_targets, read, report_path, tet_mesh_of};
pub use report::DeformRunReport;
pub use run::{Deformed, Run, deform_mesh, run};
pub use settings::Settings;
pub use write::{Outputs, write};
