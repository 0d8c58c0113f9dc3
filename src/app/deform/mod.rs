//! Deforming a tet or triangle mesh with the least distortion, flip-free,
//! from its own shape or from any start (tangled or not), with soft targets
//! and hard fixed vertices (`unfold deform REST [--targets FILE] [--init
//! INIT] [--fixed HANDLES] [--fixed-boundary] -o OUT`).
//!
//! The problem is
//!
//! ```text
//! minimize  sum_k V_k D(J_k)  +  W sum_b |x_b - t_b|^2
//! subject to  x_h = x0_h for every fixed vertex h,  det J_k > 0
//! ```
//!
//! over the vertex positions `x`, with `V_k` the rest measures normalized
//! to sum 1, `D` the distortion energy (every energy of the registry,
//! `--energy`) of the Jacobian `J_k` of element `k` against its rest shape
//! (REST), `t_b` the soft targets of the vertices listed in FILE, and `x0`
//! the start. This is the problem of the Locally Injective Mappings
//! benchmark (Du et al. 2020, "Lifting Simplices to Find Injectivity"): a
//! rest mesh, a tangled initial embedding and handle vertices that must
//! stay exactly where they are.
//!
//! - REST is a tet mesh, mapped into space, or a triangle mesh (planar or a
//!   surface in 3D), mapped to the plane `z = 0`: tets when the file has
//!   any (then every cell must be a tet), else triangles
//!   ([`shape::rest_of`]).
//! - INIT (`--init`, required for triangles) has REST's vertex count and
//!   cells in the same order ([`shape::check_same_cells`]); its positions
//!   are the start (for triangles in the plane `z = 0`, its `x, y`). A
//!   start that inverts elements is untangled first (the library's
//!   [`crate::param::Untangler`]), then the distortion is lowered with
//!   every iterate flip-free. Without INIT a tet REST starts from its own
//!   shape.
//! - HANDLES (`--fixed`, format in [`fixed`]) lists vertices kept bit for
//!   bit at their start; `--fixed-boundary` fixes every boundary vertex
//!   too (the vertices of the faces, for triangles the edges, used by one
//!   element).
//! - Targets (`--targets`, format in [`inputs`]) are soft; for triangles
//!   their `z` must be 0.
//!
//! A run needs at least one of them. A run is [`Settings`] (checked once,
//! [`Settings::validate`]), its [`Files`] checked ([`Files::check`]) and
//! read into [`Inputs`] ([`read`]), [`run()`] into a [`Run`] with its typed
//! [`DeformRunReport`], and [`write()`]:
//!
//! Output: OUT is REST (its cells, point and cell arrays) with the
//! positions replaced (`z = 0` for triangles) and two cell arrays: `det_j`
//! (f64, mapped over rest volume or area) and `inverted` (u8, 1 where
//! `det_j <= 0`), so a viewer shows where the map fails
//! ([`run::flip_arrays`]; formats without arrays, .obj .off .mesh, keep the
//! positions and cells only). `OUT.report.json` beside it holds the files and
//! the library's report: `injective`, inverted and folded counts at the
//! `start` and the `end`, the `untangle` stages and iterations, `fixed` and
//! `fixed_error_max`, `objective`, `iterations`, `converged`, ... Finding no
//! injective map (`injective: false`) or not converging within the
//! iteration limit is not an error of the run: both files are written and
//! the command exits with 3.
//!
//! Vertices used by no element and without a target carry no term at all;
//! they are kept where they are.
//!
//! A tet REST without INIT is repaired first ([`crate::mesh::repair`]:
//! coincident vertices welded, duplicate, repeated-vertex and zero-volume
//! tets dropped; an inverted tet stays an error; counts under `repair` in
//! the report). The solve runs on the repaired mesh; targets, fixed
//! vertices and the output still use the input's vertex numbers (welded
//! copies move together; the first target of a welded vertex counts; a
//! vertex no tet uses goes to its target, if it has one). With INIT, whose
//! vertex numbers must correspond to REST's, nothing is repaired (`repair`
//! is `null`): a degenerate rest element is an error naming REST.

pub mod fixed;
pub mod inputs;
pub mod report;
pub mod run;
pub mod settings;
pub mod shape;
pub mod write;

pub use fixed::{boundary_vertices, fixed_vertices, parse_handles};
pub use inputs::{Files, Inputs, check_output_holds, parse_targets, read, report_path};
pub use report::DeformRunReport;
pub use run::{Deformed, Run, deform_mesh, flip_arrays, run};
pub use settings::Settings;
pub use shape::{Rest, check_same_cells, rest_of, start_of};
pub use write::{Outputs, write};
