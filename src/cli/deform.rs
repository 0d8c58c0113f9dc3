//! `unfold deform MESH --targets FILE -o OUT`: the flags of a deformation
//! turned into its settings and files ([`crate::app::deform`] runs it:
//! the problem, the targets file's format and the outputs are described
//! there), and the summary line printed on stdout.

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
            output: self.output.clone(),
        }
    }
}

/// Runs `unfold deform`: the settings and files checked, both outputs
/// staged before the inputs are read and put in place together at the end,
/// the summary line on stdout; exit 3 (outputs written) when the solver did
/// not converge.
pub fn run(a: &DeformArgs) -> Result<(), AppError> {
    let settings = a.settings();
    settings.validate()?;
    let files = a.files();
    files.check()?;
    let mut staged = StagedOutputs::new([&a.mesh, &a.targets]);
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
    println!(
        "{} -> {}: {} tets, {} targets, {} {}: {status} in {} iterations, {:.3} s; \
         objective {:.10e} (distortion {:.6e}), {} inverted tets",
        a.mesh.display(),
        a.output.display(),
        run.tets,
        report.targets,
        report.solver,
        report.energy,
        report.iterations,
        report.seconds,
        report.objective,
        report.distortion,
        report.end.inverted
    );
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
        let base = ["deform", "m.vtu", "--targets", "t.csv", "-o", "o.vtu"];
        DeformCmd::try_parse_from(base.iter().chain(args))
            .unwrap()
            .args
            .settings()
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
