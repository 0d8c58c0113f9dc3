//! `unfold deform MESH --targets FILE -o OUT`: deforms a tet mesh towards
//! soft positional targets with the least distortion, flip-free.
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
//! Targets file: CSV, one `vertex,x,y,z` per line (0-based vertex index,
//! coordinates in the mesh's units). Blank lines and lines starting with `#`
//! are ignored; the first remaining line may be the header `vertex,x,y,z`
//! (exactly those names, any case; any other non-numeric line is an error,
//! so a typo in the first data line is never mistaken for a header). Fields
//! may be surrounded by spaces. Every problem is reported with the file and
//! line: a wrong field count, a bad vertex index or coordinate (coordinates
//! must be finite), a vertex out of range, a vertex listed twice, no targets.
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

use super::choice::named;
use super::{AppError, at};
use crate::app::run::StagedOutputs;
use crate::io::{FileKind, WriteOptions, atomic_write, read_mesh, write_mesh};
use crate::mesh::repair::{RepairOptions, RepairReport, Weld, repair_tet_mesh_traced};
use crate::mesh::{CellMesh, MeshError, TetMesh};
use crate::param::energy::EnergyKind;
use crate::param::solver::SolverKind;
use crate::param::{Deform, DeformReport, Named, ParamError};
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `unfold deform`.
#[derive(Debug, Args)]
pub struct DeformArgs {
    /// Tet mesh (.vtu .vtk .mesh .msh); its shape is the rest state and the
    /// starting point, so every tet must be positively oriented.
    mesh: PathBuf,
    /// Targets: CSV lines `vertex,x,y,z` (0-based vertex index); blank lines,
    /// `#` comments and a `vertex,x,y,z` header line are allowed.
    #[arg(long, value_name = "FILE")]
    targets: PathBuf,
    /// Output mesh (.vtu .vtk .mesh): the input with the positions replaced.
    /// The report is written beside it as OUT.report.json.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Weight W of the target term `W sum_b |x_b - t_b|^2` (the distortion
    /// term is volume-weighted with weights summing to 1).
    #[arg(long, value_name = "W", default_value_t = 1.0)]
    weight: f64,
    /// Distortion energy D.
    #[arg(long, value_parser = named::<EnergyKind>(), default_value = "symmetric-dirichlet")]
    energy: EnergyKind,
    /// Solver.
    #[arg(long, value_parser = named::<SolverKind>(), default_value = "newton")]
    solver: SolverKind,
    /// Stop when the gradient norm |grad|_F falls below this.
    #[arg(long, value_name = "TOL", default_value_t = 1e-4)]
    tol: f64,
    /// Iteration limit [default: 200 for newton, 100000 for gd].
    #[arg(long, value_name = "N")]
    max_iterations: Option<usize>,
}

/// What `OUT.report.json` holds: the files, then the library's report,
/// then the run's provenance (the command line's, or the Python package's:
/// a type parameter, so both write one layout).
#[derive(Debug, Serialize)]
pub struct Report<'a, P> {
    /// The input mesh.
    pub mesh: String,
    /// The targets file.
    pub targets_file: String,
    /// The output mesh.
    pub output: String,
    /// What the repair of the input mesh changed.
    pub repair: RepairReport,
    /// The library's report.
    #[serde(flatten)]
    pub report: &'a DeformReport,
    /// Version, command line, parameters, input hashes, start time.
    pub provenance: P,
}

/// The settings of `unfold deform` other than its files (the flags'
/// defaults: [`DeformSettings::default`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeformSettings {
    /// `--weight`: W of the target term.
    pub weight: f64,
    /// `--energy`.
    pub energy: EnergyKind,
    /// `--solver`.
    pub solver: SolverKind,
    /// `--tol`: the gradient norm to stop at.
    pub tol: f64,
    /// `--max-iterations` (none: the solver's default).
    pub max_iterations: Option<usize>,
}

impl Default for DeformSettings {
    /// The command line's defaults: W = 1, symmetric Dirichlet, Newton,
    /// tol 1e-4, the solver's iteration limit.
    fn default() -> Self {
        DeformSettings {
            weight: 1.0,
            energy: EnergyKind::SymmetricDirichlet,
            solver: SolverKind::Newton,
            tol: 1e-4,
            max_iterations: None,
        }
    }
}

impl DeformSettings {
    /// Checks every setting.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flag: a weight or tolerance not
    /// finite and positive.
    pub fn check(&self) -> Result<(), AppError> {
        if !(self.weight.is_finite() && self.weight > 0.0) {
            return Err(AppError::Usage(format!(
                "--weight must be a finite positive number, got {}",
                self.weight
            )));
        }
        if !(self.tol.is_finite() && self.tol > 0.0) {
            return Err(AppError::Usage(format!(
                "--tol must be a finite positive number, got {}",
                self.tol
            )));
        }
        Ok(())
    }
}

/// A deformed mesh and what the run found.
#[derive(Debug, Clone)]
pub struct Deformed {
    /// The input mesh (cells and arrays) with the positions replaced.
    pub mesh: CellMesh,
    /// Tets of the input mesh.
    pub tets: usize,
    /// What the repair of the input mesh changed.
    pub repair: RepairReport,
    /// The library's report.
    pub report: DeformReport,
}

/// `path` with `.report.json` appended to its file name.
fn report_path(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".report.json");
    PathBuf::from(s)
}

/// Parses the targets CSV `text` (from `file`, for messages) for a mesh of
/// `num_vertices` vertices: `(vertex, target)` pairs in file order.
fn parse_targets(
    text: &str,
    file: &Path,
    num_vertices: usize,
) -> Result<Vec<(usize, [f64; 3])>, AppError> {
    let err = |line: usize, msg: String| at(file, format!("line {line}: {msg}"));
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // Line (1-based) of each vertex's target; 0 = none yet.
    let mut line_of = vec![0usize; num_vertices];
    let mut pairs = Vec::new();
    let mut first = true;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let header = first
            && fields.len() == 4
            && fields
                .iter()
                .zip(["vertex", "x", "y", "z"])
                .all(|(f, h)| f.eq_ignore_ascii_case(h));
        first = false;
        if header {
            continue;
        }
        if fields.len() != 4 {
            return Err(err(
                line_no,
                format!(
                    "expected 4 comma-separated fields `vertex,x,y,z`, found {}",
                    fields.len()
                ),
            ));
        }
        let v: usize = fields[0].parse().map_err(|_| {
            err(
                line_no,
                format!(
                    "bad vertex index `{}` (expected a non-negative integer)",
                    fields[0]
                ),
            )
        })?;
        if v >= num_vertices {
            return Err(err(
                line_no,
                format!(
                    "vertex {v} is out of range (the mesh has {num_vertices} vertices, numbered from 0)"
                ),
            ));
        }
        let mut t = [0.0; 3];
        for (c, name) in ["x", "y", "z"].iter().enumerate() {
            let s = fields[c + 1];
            t[c] = s
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    err(
                        line_no,
                        format!("bad {name} coordinate `{s}` (expected a finite number)"),
                    )
                })?;
        }
        if line_of[v] != 0 {
            return Err(err(
                line_no,
                format!("vertex {v} is listed twice (first on line {})", line_of[v]),
            ));
        }
        line_of[v] = line_no;
        pairs.push((v, t));
    }
    if pairs.is_empty() {
        return Err(at(file, "no targets (expected lines `vertex,x,y,z`)"));
    }
    Ok(pairs)
}

/// A pipeline error, worded for this command and attributed to the input
/// it is about (`mesh` or `targets`).
fn deform_problem(mesh: &Path, targets: &Path, solver: SolverKind, e: ParamError) -> AppError {
    match e {
        ParamError::Mesh(MeshError::InvertedElement { element, volume }) => at(
            mesh,
            format!(
                "tet {element} is inverted (signed volume {volume:e}); the input shape is the \
                 rest state and the starting point, so every tet must be positively oriented"
            ),
        ),
        e @ (ParamError::TargetNotFinite { .. }
        | ParamError::TargetRepeated { .. }
        | ParamError::Length { .. }) => at(targets, e),
        e @ (ParamError::Mesh(_) | ParamError::Setting { .. }) => at(mesh, e),
        e => at(mesh, format!("the {} solver failed: {e}", solver.name())),
    }
}

/// The tets of `cells` (named `mesh` in messages).
///
/// # Errors
/// A mesh with other cells than tets ("not a tetrahedral mesh"), or bad
/// indices, at `mesh`.
pub fn tet_mesh_of(cells: &CellMesh, mesh: &Path) -> Result<TetMesh, AppError> {
    cells.to_tet_mesh().map_err(|e| match e {
        MeshError::WrongCellType { cell, found, .. } => at(
            mesh,
            format!(
                "not a tetrahedral mesh (cell {cell} is a {found:?}); unfold deform needs a tet mesh"
            ),
        ),
        e => at(mesh, e),
    })
}

/// Deforms the tet mesh `cells` (its tets `tet_mesh`, by [`tet_mesh_of`];
/// named `mesh` in messages) towards the targets `pairs` (`(vertex,
/// target)`, vertices of `cells`, each at most once; named `targets`):
/// repairs the mesh, solves on the repaired mesh (the memory budget checked
/// before a Newton factor) and puts the solution back on the input's vertex
/// numbers (module doc).
///
/// # Errors
/// A mesh that cannot be repaired, an inverted tet, a target vertex out of
/// range, the solver's failures; each at the input it is about.
pub fn deform_mesh(
    cells: CellMesh,
    tet_mesh: &TetMesh,
    pairs: &[(usize, [f64; 3])],
    settings: &DeformSettings,
    mesh: &Path,
    targets: &Path,
) -> Result<Deformed, AppError> {
    settings.check()?;
    let n = tet_mesh.num_vertices();
    if let Some(&(v, _)) = pairs.iter().find(|(v, _)| *v >= n) {
        return Err(at(
            targets,
            format!("vertex {v} is out of range (the mesh has {n} vertices, numbered from 0)"),
        ));
    }
    let repaired = repair_tet_mesh_traced(
        tet_mesh,
        &RepairOptions {
            weld: Weld::Relative,
            keep_tet_orientation: true,
            ..Default::default()
        },
    )
    .map_err(|e| at(mesh, e))?;
    let of_input = &repaired.vertex_of_input;
    let mut targeted = vec![false; repaired.mesh.num_vertices()];
    let solve_pairs: Vec<(usize, [f64; 3])> = pairs
        .iter()
        .filter_map(|&(v, t)| {
            let r = of_input[v]? as usize;
            (!std::mem::replace(&mut targeted[r], true)).then_some((r, t))
        })
        .collect();
    let solver = settings.solver.build();
    let mut stopping = solver.default_stopping();
    stopping.grad_tol = settings.tol;
    if let Some(n) = settings.max_iterations {
        stopping.max_iterations = n;
    }
    let pipeline = Deform::new()
        .weight(settings.weight)
        .stopping(stopping)
        .energy(settings.energy.build())
        .solver(solver);
    if settings.solver == SolverKind::Newton {
        let pmesh = crate::param::ParamMesh::from_tets(&repaired.mesh).map_err(|e| at(mesh, e))?;
        let estimate = crate::param::memory::mesh_newton_memory(&pmesh).map_err(|e| at(mesh, e))?;
        drop(pmesh);
        crate::app::run::memory::check(
            "deforming the mesh",
            &estimate,
            "coarsen the mesh, or use --solver gd (no factor)",
        )?;
    }
    let outcome = pipeline
        .run(&repaired.mesh, &solve_pairs)
        .map_err(|e| deform_problem(mesh, targets, settings.solver, e))?;
    let mut deformed = cells;
    for (i, p) in deformed.positions.iter_mut().enumerate() {
        if let Some(r) = of_input[i] {
            *p = outcome.positions[r as usize];
        }
    }
    for &(v, t) in pairs {
        if of_input[v].is_none() {
            deformed.positions[v] = t.into();
        }
    }
    Ok(Deformed {
        mesh: deformed,
        tets: tet_mesh.num_tets(),
        repair: repaired.report,
        report: outcome.report,
    })
}

/// Runs `unfold deform`.
pub fn run(a: &DeformArgs) -> Result<(), AppError> {
    let settings = DeformSettings {
        weight: a.weight,
        energy: a.energy,
        solver: a.solver,
        tol: a.tol,
        max_iterations: a.max_iterations,
    };
    settings.check()?;
    let report_file = report_path(&a.output);
    let (out, rep) = (super::canonical(&a.output), super::canonical(&report_file));
    for input in [&a.mesh, &a.targets] {
        let c = super::canonical(input);
        if c == out || c == rep {
            return Err(at(
                if c == out { &a.output } else { &report_file },
                "refusing to overwrite an input; choose another output path",
            ));
        }
    }
    match FileKind::from_path(&a.output)? {
        FileKind::Mesh(f) if f.writable() && f.holds_volume_cells() => {}
        _ => {
            return Err(at(
                &a.output,
                "cannot hold a tet mesh; write .vtu, .vtk or .mesh",
            ));
        }
    }

    // Both outputs checked (and staged) before the inputs are read, and put
    // in place together at the end.
    let mut staged = StagedOutputs::new([&a.mesh, &a.targets]);
    let (mesh_target, report_target) = (staged.file(&a.output)?, staged.file(&report_file)?);
    let cells = read_mesh(&a.mesh)?;
    let tet_mesh = tet_mesh_of(&cells, &a.mesh)?;
    let n = tet_mesh.num_vertices();
    let text = std::fs::read_to_string(&a.targets).map_err(|source| AppError::Fs {
        path: a.targets.display().to_string(),
        source,
    })?;
    let pairs = parse_targets(&text, &a.targets, n)?;
    let Deformed {
        mesh: deformed,
        tets,
        repair,
        report,
    } = deform_mesh(cells, &tet_mesh, &pairs, &settings, &a.mesh, &a.targets)?;
    let report = &report;
    write_mesh(&mesh_target, &deformed, &WriteOptions::default())
        .map_err(|e| staged.shown_error(e))?;
    let full = Report {
        mesh: a.mesh.display().to_string(),
        targets_file: a.targets.display().to_string(),
        output: a.output.display().to_string(),
        repair,
        report,
        provenance: crate::app::run::provenance::this_run(),
    };
    let json = serde_json::to_string_pretty(&full)
        .map_err(|e| at(&report_file, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_target, format!("{json}\n").as_bytes())
        .map_err(|e| staged.shown_error(e))?;
    staged.commit()?;

    let status = if report.converged {
        "converged".to_string()
    } else {
        format!("NOT converged ({})", super::stop_name(report.stop_reason))
    };
    println!(
        "{} -> {}: {} tets, {} targets, {} {}: {status} in {} iterations, {:.3} s; \
         objective {:.10e} (distortion {:.6e}), {} inverted tets",
        a.mesh.display(),
        a.output.display(),
        tets,
        report.targets,
        report.solver,
        report.energy,
        report.iterations,
        report.seconds,
        report.objective,
        report.distortion,
        report.inverted_tets
    );
    if !report.converged {
        return Err(AppError::NotConverged {
            what: "the deformation",
            reason: super::stop_name(report.stop_reason),
            iterations: report.iterations,
            output: a.output.display().to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `unfold deform` alone, to parse its flags.
    #[derive(clap::Parser)]
    struct DeformCmd {
        #[command(flatten)]
        args: DeformArgs,
    }

    fn settings_of(args: &[&str]) -> DeformSettings {
        use clap::Parser;
        let base = ["deform", "m.vtu", "--targets", "t.csv", "-o", "o.vtu"];
        let a = DeformCmd::try_parse_from(base.iter().chain(args))
            .unwrap()
            .args;
        DeformSettings {
            weight: a.weight,
            energy: a.energy,
            solver: a.solver,
            tol: a.tol,
            max_iterations: a.max_iterations,
        }
    }

    #[test]
    fn settings_default_to_the_flags_defaults() {
        assert_eq!(settings_of(&[]), DeformSettings::default());
        let s = settings_of(&["--energy", "arap", "--weight", "2"]);
        assert_eq!((s.energy, s.weight), (EnergyKind::Arap, 2.0));
        assert!(
            DeformSettings {
                weight: 0.0,
                ..DeformSettings::default()
            }
            .check()
            .unwrap_err()
            .to_string()
            .contains("--weight must be a finite positive number, got 0")
        );
    }

    fn parse(text: &str, n: usize) -> Result<Vec<(usize, [f64; 3])>, String> {
        parse_targets(text, Path::new("t.csv"), n).map_err(|e| e.to_string())
    }

    #[test]
    fn targets_csv_header_comments_and_blanks() {
        let text = "\u{feff}# targets\n\n Vertex , X,y,Z \r\n0,1,2,3\n  # more\n2, -1.5 ,1e-3,4\n";
        assert_eq!(
            parse(text, 3).unwrap(),
            vec![(0, [1.0, 2.0, 3.0]), (2, [-1.5, 1e-3, 4.0])]
        );
        assert_eq!(parse("1,0,0,0", 2).unwrap(), vec![(1, [0.0; 3])]);
    }

    #[test]
    fn targets_csv_errors_name_the_line() {
        for (text, needle) in [
            ("0,1,2,3\nx,1,2,3\n", "t.csv: line 2: bad vertex index `x`"),
            ("vertex,x,y,z\nvertex,x,y,z\n", "line 2: bad vertex index"),
            ("vertex,x,y\n", "line 1: expected 4 comma-separated fields"),
            (
                "0,1,2\n",
                "line 1: expected 4 comma-separated fields `vertex,x,y,z`, found 3",
            ),
            ("0,1,2,3,4\n", "found 5"),
            ("-1,1,2,3\n", "line 1: bad vertex index `-1`"),
            ("1.5,1,2,3\n", "bad vertex index `1.5`"),
            ("0,1,abc,3\n", "line 1: bad y coordinate `abc`"),
            ("0,1,2,nan\n", "bad z coordinate `nan`"),
            ("0,1e999,2,3\n", "bad x coordinate `1e999`"),
            ("0,,2,3\n", "bad x coordinate ``"),
            (
                "#\n5,1,2,3\n",
                "line 2: vertex 5 is out of range (the mesh has 5 vertices",
            ),
            (
                "1,0,0,0\n\n1,1,1,1\n",
                "line 3: vertex 1 is listed twice (first on line 1)",
            ),
            ("", "t.csv: no targets"),
            ("# nothing\n\nvertex,x,y,z\n", "t.csv: no targets"),
        ] {
            let e = parse(text, 5).unwrap_err();
            assert!(e.contains(needle), "{text:?}: {e:?} lacks {needle:?}");
        }
    }

    #[test]
    fn report_path_appends_to_the_file_name() {
        assert_eq!(
            report_path(Path::new("a/b.vtu")),
            PathBuf::from("a/b.vtu.report.json")
        );
    }
}
