//! `unfold deform REST [--targets FILE] [--init INIT] [--fixed HANDLES]
//! [--fixed-boundary] -o OUT`: the flags of a deformation turned into its
//! settings and files ([`crate::app::deform`] runs it: the problem, the
//! files' formats and the outputs are described there), and the summary
//! line printed on stdout.

use super::choice::named;
use super::progress::Progress;
use super::stop_name;
use crate::app::AppError;
use crate::app::deform::{self, Files, Outputs, Settings};
use crate::app::run::StagedOutputs;
use crate::param::energy::EnergyKind;
use crate::param::solver::SolverKind;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `unfold deform`.
#[derive(Debug, Args)]
pub struct DeformArgs {
    /// REST: the rest shape, a tet mesh (.vtu .vtk .mesh .msh; mapped into
    /// space, every tet positively oriented) or a triangle mesh, planar or
    /// a surface (.obj .off .ply .stl .vtk .vtu ...; mapped to the plane
    /// z = 0). Without --init a tet mesh is also the start. A problem file
    /// of the Locally Injective Mappings benchmark (.input or .tlc: rest,
    /// start, cells and handles in one file) gives REST, INIT and HANDLES.
    #[arg(value_name = "REST")]
    mesh: PathBuf,
    /// Soft targets: CSV lines `vertex,x,y,z` (0-based vertex index; z = 0
    /// for a triangle mesh); blank lines, `#` comments and a `vertex,x,y,z`
    /// header line are allowed.
    #[arg(long, value_name = "FILE")]
    targets: Option<PathBuf>,
    /// The start: a mesh with REST's vertices and cells in the same order
    /// at other positions, tangled or not (a folded start is untangled
    /// first). For a triangle REST it is required and lies in z = 0.
    #[arg(long, value_name = "INIT")]
    init: Option<PathBuf>,
    /// Fixed vertices (hard constraints): 0-based vertex indices, one per
    /// line (blank lines and `#` comments allowed); they keep their start
    /// positions exactly.
    #[arg(long, value_name = "HANDLES")]
    fixed: Option<PathBuf>,
    /// Fix every boundary vertex too (the vertices of the faces used by one
    /// tet, or of the edges used by one triangle).
    #[arg(long)]
    fixed_boundary: bool,
    /// Output mesh: REST's cells at the mapped positions, with the cell
    /// arrays det_j and inverted (1 where det J <= 0) in the formats that
    /// hold arrays (.vtu .vtk .vtp .ply). Tets: .vtu .vtk .mesh; triangles
    /// also .ply .obj .off .vtp. The report is written beside it as
    /// OUT.report.json.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Weight W of the target term `W sum_b |x_b - t_b|^2` (the distortion
    /// term is weighted by rest volume or area, the weights summing to 1).
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
    /// Iteration limit [default: 1000 for newton, 100000 for gd].
    #[arg(long, value_name = "N")]
    max_iterations: Option<usize>,
}

impl DeformArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            weight: self.weight,
            energy: self.energy,
            solver: self.solver,
            tol: self.tol,
            max_iterations: self.max_iterations,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            mesh: self.mesh.clone(),
            targets: self.targets.clone(),
            init: self.init.clone(),
            fixed: self.fixed.clone(),
            fixed_boundary: self.fixed_boundary,
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold deform`: the settings and files checked, both outputs
/// staged before the inputs are read and put in place together at the end,
/// the summary line on stdout; exit 3 (outputs written) when no injective
/// map was found ([`AppError::NotInjective`]) or the solver did not
/// converge ([`AppError::NotConverged`]).
pub fn run(a: &DeformArgs) -> Result<(), AppError> {
    let settings = a.settings();
    settings.validate()?;
    let files = a.files();
    files.check()?;
    let mut staged = StagedOutputs::new(files.inputs());
    let (mesh_target, report_target) = (staged.file(&a.output)?, staged.file(files.report())?);
    let inputs = deform::read(&files)?;
    let run = deform::run(&settings, inputs, &mut Progress::new(true))?;
    deform::write(
        &run,
        &Outputs {
            mesh: &mesh_target,
            report: &report_target,
            staged: &staged,
        },
    )?;
    staged.commit()?;

    let report = &run.report.report;
    let status = if report.converged {
        "converged".to_string()
    } else {
        format!("NOT converged ({})", stop_name(report.stop_reason))
    };
    let stages = |n: usize| format!("{n} stage{}", if n == 1 { "" } else { "s" });
    let untangle = match &report.untangle {
        Some(u) if u.untangled => format!(
            ", untangled in {} ({} iterations)",
            stages(u.stages),
            u.iterations
        ),
        Some(u) => format!(
            ", NOT untangled after {} ({} iterations)",
            stages(u.stages),
            u.iterations
        ),
        None => String::new(),
    };
    let elements = run.elements;
    println!(
        "{} -> {}: {} {elements}, {} fixed, {} targets; {} -> {} inverted {elements}{untangle}; \
         {} {}: {status} in {} iterations, {:.3} s; objective {:.10e} (distortion {:.6e}){}",
        a.mesh.display(),
        a.output.display(),
        run.element_count,
        report.fixed,
        report.targets,
        report.start.inverted,
        report.end.inverted,
        report.solver,
        report.energy,
        report.iterations,
        report.seconds,
        report.objective,
        report.distortion,
        if report.injective {
            "; injective"
        } else {
            "; NOT injective"
        }
    );
    if !report.injective {
        return Err(AppError::NotInjective {
            inverted: report.end.inverted,
            folded: report.end.folded,
            min_det_j: report.end.min_det_j,
            output: a.output.display().to_string(),
        });
    }
    if !report.converged {
        return Err(AppError::NotConverged {
            what: "the deformation",
            reason: stop_name(report.stop_reason),
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

    fn settings_of(args: &[&str]) -> Settings {
        use clap::Parser;
        let base = ["deform", "m.vtu", "--init", "i.vtu", "-o", "o.vtu"];
        DeformCmd::try_parse_from(base.iter().chain(args))
            .unwrap()
            .args
            .settings()
    }

    #[test]
    fn files_of_the_flags() {
        use clap::Parser;
        let args = [
            "deform",
            "r.obj",
            "--init",
            "i.obj",
            "--fixed",
            "h.txt",
            "--fixed-boundary",
            "-o",
            "o.ply",
        ];
        let f = DeformCmd::try_parse_from(args).unwrap().args.files();
        assert_eq!(f.targets, None);
        assert_eq!(f.init, Some(PathBuf::from("i.obj")));
        assert_eq!(f.fixed, Some(PathBuf::from("h.txt")));
        assert!(f.fixed_boundary);
        assert_eq!(f.inputs().len(), 3);
        f.check().unwrap();
        let nothing = DeformCmd::try_parse_from(["deform", "r.vtu", "-o", "o.vtu"])
            .unwrap()
            .args
            .files();
        assert!(
            nothing
                .check()
                .unwrap_err()
                .to_string()
                .starts_with("nothing to do: give --targets FILE, --init INIT")
        );
    }

    #[test]
    fn settings_default_to_the_flags_defaults() {
        assert_eq!(settings_of(&[]), Settings::default());
        let s = settings_of(&["--energy", "arap", "--weight", "2"]);
        assert_eq!((s.energy, s.weight), (EnergyKind::Arap, 2.0));
        assert!(
            Settings {
                weight: 0.0,
                ..Settings::default()
            }
            .validate()
            .unwrap_err()
            .to_string()
            .contains("--weight must be a finite positive number, got 0")
        );
    }
}
