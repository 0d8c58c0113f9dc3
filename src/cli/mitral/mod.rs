//! `unfold mitral --anterior AL --posterior PL --annulus RING -o DIR`: the
//! flags of a mitral run turned into its settings and files
//! ([`crate::app::mitral`] runs it, one valve or a `--series DIR`), and the
//! summary printed on stdout.

mod summary;

use super::choice::named;
use super::progress::Progress;
use crate::app::AppError;
use crate::app::error::shown;
use crate::app::mitral::{self, Files, Job, Outputs, Settings, series};
use crate::app::run::StagedOutputs;
use crate::organs::mitral::{AnnulusMode, InitMode, RelaxMode};
use crate::param::energy::EnergyKind;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `unfold mitral`.
#[derive(Debug, Args)]
#[command(
    after_help = "Writes DIR/valve3d.vtu, DIR/valve2d.vtu (arrays: leaflet, u_gradient, \
                  u_interval, checker, carpentier, area_energy, angle_energy, length_energy, \
                  coaptation, coaptation_distance_mm, tenting_mm, uv) and DIR/report.json; with \
                  --series, one such set per time step, DIR/series.csv and \
                  DIR/figures/series.png. Without --annulus the ring is found from the places \
                  where the leaflets' boundaries meet (the commissures)."
)]
pub struct MitralArgs {
    /// Do not write the PNG figures into DIR/figures/.
    #[arg(long)]
    no_figures: bool,
    /// Anterior leaflet (triangle mesh, disk topology).
    #[arg(long, value_name = "AL", required_unless_present_any = ["series", "seg"])]
    anterior: Option<PathBuf>,
    /// Posterior leaflet (triangle mesh, disk topology).
    #[arg(long, value_name = "PL", required_unless_present_any = ["series", "seg"])]
    posterior: Option<PathBuf>,
    /// Annulus ring: a closed polyline (mesh file) or x,y,z lines (.csv .txt
    /// .xyz); without it, found from the leaflets' shared boundary.
    #[arg(long, value_name = "RING")]
    annulus: Option<PathBuf>,
    /// A directory of time steps: leaflets named AL* / PL* or *anterior* /
    /// *posterior*, optional *annulus* files, paired by the rest of the name.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["anterior", "posterior", "annulus"])]
    series: Option<PathBuf>,
    /// A label map (NIfTI or NRRD, any voxel size and affine): the leaflets'
    /// atrial surfaces and the annulus ring are cut from it (needs
    /// --anterior-label and --posterior-label).
    #[arg(long, value_name = "LABELS", conflicts_with_all = ["anterior", "posterior", "annulus", "series"])]
    seg: Option<PathBuf>,
    /// With --seg: the anterior leaflet's label.
    #[arg(long, value_name = "A", requires = "seg")]
    anterior_label: Option<i64>,
    /// With --seg: the posterior leaflet's label.
    #[arg(long, value_name = "P", requires = "seg")]
    posterior_label: Option<i64>,
    /// With --seg: the annulus' label (without it, the plane and the atrial
    /// side come from the leaflets).
    #[arg(long, value_name = "N", requires = "seg")]
    annulus_label: Option<i64>,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// How the annulus is laid out.
    #[arg(long, value_parser = named::<AnnulusMode>(), default_value = "landmark")]
    annulus_mode: AnnulusMode,
    /// Initial leaflet layout.
    #[arg(long, value_parser = named::<InitMode>(), default_value = "auto")]
    init: InitMode,
    /// Relaxation.
    #[arg(long, value_parser = named::<RelaxMode>(), default_value = "sd")]
    relax: RelaxMode,
    /// Distortion energy D of the flip-free relaxation (ALGORITHMS 1.2):
    /// symmetric-dirichlet (the default), mips, arap or area-ratio.
    #[arg(long, value_parser = named::<EnergyKind>(), default_value = "symmetric-dirichlet")]
    energy: EnergyKind,
    /// Spring relaxation: number of explicit steps.
    #[arg(long, value_name = "N", default_value_t = 5)]
    iterations: usize,
    /// Spring relaxation: step scale (smaller is safer).
    #[arg(long, value_name = "S")]
    step_scale: Option<f64>,
    /// Coaptation threshold, mm (the zone: closer than this to the other leaflet).
    #[arg(long, value_name = "MM", default_value_t = 2.0)]
    coaptation_mm: f64,
    /// Distance within which a leaflet boundary vertex lies on the ring, mm.
    #[arg(long, value_name = "MM")]
    tolerance_mm: Option<f64>,
    /// Second cut at the posteromedial commissure (the leaflets drawn apart there).
    #[arg(long)]
    cut_posteromedial: bool,
}

impl MitralArgs {
    /// The settings of the flags.
    fn settings(&self) -> Settings {
        Settings {
            annulus_mode: self.annulus_mode,
            init: self.init,
            relax: self.relax,
            energy: self.energy,
            iterations: self.iterations,
            step_scale: self.step_scale,
            coaptation_mm: self.coaptation_mm,
            tolerance_mm: self.tolerance_mm,
            cut_posteromedial: self.cut_posteromedial,
            no_figures: self.no_figures,
            anterior_label: self.anterior_label,
            posterior_label: self.posterior_label,
            annulus_label: self.annulus_label,
        }
    }

    /// The files of the flags.
    fn files(&self) -> Files {
        Files {
            anterior: self.anterior.clone(),
            posterior: self.posterior.clone(),
            annulus: self.annulus.clone(),
            series: self.series.clone(),
            seg: self.seg.clone(),
            output: self.output.clone(),
        }
    }

    /// The mesh files read (leaflets and ring; none for a series), for the
    /// units hint.
    pub(crate) fn input_meshes(&self) -> Vec<PathBuf> {
        crate::app::run::units::mesh_inputs(&[&self.anterior, &self.posterior, &self.annulus])
    }
}

/// Runs `unfold mitral`: the settings checked, the files checked (and the
/// outputs staged) before any is read, one valve or every step of a
/// series run and written, the outputs put in place, the summary on
/// stdout.
pub fn run(a: &MitralArgs) -> Result<(), AppError> {
    let settings = a.settings();
    let pipeline = settings.pipeline()?;
    let out = a.output.as_path();
    let figures = !settings.no_figures;
    let job = a.files().check()?;
    mitral::check_settings(&job, &settings)?;
    match job {
        Job::Seg(files) => {
            let mut staged = StagedOutputs::new([&files.seg]);
            let dir = staged.dir(out)?;
            let run = mitral::seg::run_seg(
                &files,
                &settings,
                &pipeline,
                &Outputs {
                    dir: &dir,
                    staged: &staged,
                },
                figures,
                &mut Progress::new(true),
            )
            .map_err(|e| shown(&staged, e))?;
            staged.commit()?;
            summary::valve(&run.outcome.report, out);
        }
        Job::Valve(files) => {
            let mut staged = StagedOutputs::new(files.paths());
            let dir = staged.dir(out)?;
            let run = mitral::run_valve(
                &files,
                &pipeline,
                &Outputs {
                    dir: &dir,
                    staged: &staged,
                },
                figures,
                &mut Progress::new(true),
            )
            .map_err(|e| shown(&staged, e))?;
            staged.commit()?;
            summary::valve(&run.outcome.report, out);
        }
        Job::Series(steps) => {
            // The whole series is staged: `out` holds all its steps or none.
            let mut staged = StagedOutputs::new(steps.iter().flat_map(|s| s.files.paths()));
            let staging = staged.dir(out)?;
            let inputs = series::read(&pipeline, &steps, out)?;
            let runs = series::run(&pipeline, &inputs);
            drop(inputs);
            let table = series::write(
                &steps,
                runs,
                &series::Outputs {
                    dir: out,
                    staging: &staging,
                    staged: &staged,
                },
                figures,
                &mut Progress::new(false),
            )?;
            staged.commit()?;
            summary::series(table.steps.len(), out);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `unfold mitral` alone, to parse its flags.
    #[derive(clap::Parser)]
    struct Mitral {
        #[command(flatten)]
        args: MitralArgs,
    }

    #[test]
    fn settings_default_to_the_flags_defaults() {
        use clap::Parser;
        let m = Mitral::try_parse_from(["mitral", "--series", "d", "-o", "o"]).unwrap();
        assert_eq!(m.args.settings(), Settings::default());
        let m = Mitral::try_parse_from([
            "mitral",
            "--series",
            "d",
            "-o",
            "o",
            "--relax",
            "spring",
            "--coaptation-mm",
            "3",
        ])
        .unwrap();
        assert_eq!(m.args.settings().relax, RelaxMode::Spring);
        assert_eq!(m.args.settings().coaptation_mm, 3.0);
    }
}
