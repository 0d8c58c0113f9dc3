//! `unfold placenta MESH -o DIR [--image FILE ...]`: the flags of a
//! placenta run turned into its settings and files ([`crate::app::placenta`]
//! runs it), and the summary printed on stdout.

mod summary;

use super::choice::named;
use super::mesh::MaskArgs;
use super::progress::Progress;
use crate::app::AppError;
use crate::app::names::stop_name;
use crate::app::placenta::{self, Files, Outputs, Settings};
use crate::app::run::StagedOutputs;
use crate::app::run::frame::MeshFrame;
use crate::organs::placenta::{Interpolation, TemplateKind};
use crate::param::energy::EnergyKind;
use crate::param::solver::SolverKind;
use clap::Args;
use std::path::PathBuf;
pub(crate) use summary::Summary;

/// `--grid XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX`: six finite numbers, mm.
fn parse_grid(text: &str) -> Result<[f64; 6], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{text}' is not six numbers XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX"))?;
    <[f64; 6]>::try_from(values).map_err(|v| {
        format!(
            "'{text}' has {} numbers, expected XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX",
            v.len()
        )
    })
}

/// Arguments of `unfold placenta`.
#[derive(Debug, Args)]
#[command(
    after_help = "Writes DIR/original.vtu and DIR/flattened.vtu (point array `side`: 0 \
interior, 1 fetal, 2 maternal, 3 margin), DIR/<name>_flat.nii.gz per image and DIR/report.json."
)]
pub struct PlacentaArgs {
    /// Placenta tet mesh (.vtu .vtk .mesh .msh), millimetres, scanner frame.
    /// Boundary triangles and other lower-dimensional cells are ignored.
    mesh: Option<PathBuf>,
    /// Start from a segmentation instead of a mesh: a 3D mask of the
    /// placenta (.nii .nii.gz .nrrd .seg.nrrd .nhdr), meshed as `unfold mesh`
    /// does (written as DIR/mesh.vtu); its distance transform gives the
    /// initial half thickness.
    #[arg(long, value_name = "MASK", conflicts_with = "mesh")]
    seg: Option<PathBuf>,
    #[command(flatten)]
    mask: MaskArgs,
    /// With --seg: mesh the mask uniformly at the smallest voxel spacing (or
    /// --size-mm). The default grades the interior (as `unfold mesh
    /// --grade`: the boundary kept, coarser tets inside) at a cube side
    /// chosen from the mask's volume (about 5,000 lattice cubes, never finer
    /// than the voxels): near the published meshes' size and many times
    /// faster to flatten.
    #[arg(long, conflicts_with = "grade")]
    dense: bool,
    /// Do not write the PNG figures into DIR/figures/.
    #[arg(long)]
    no_figures: bool,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Template the mesh is flattened onto.
    #[arg(long, value_parser = named::<TemplateKind>(), default_value = "planes")]
    template: TemplateKind,
    /// Also flatten with each of these distortion weights (comma-separated,
    /// each > 0) and write DIR/lambda_sweep.csv and the trade-off curve
    /// DIR/figures/lambda_sweep.png (template error against Dirichlet
    /// excess, the paper's Fig. 3); the other outputs are those of --lambda.
    #[arg(
        long,
        value_name = "L,L,...",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    lambda_sweep: Vec<f64>,
    /// Hold the template's half thickness `h` at this value, mm, instead of
    /// optimizing it (planes and single-plane templates).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    fix_h: Option<f64>,
    /// Weight lambda of the distortion term (the paper finds 0.1..5 alike).
    #[arg(
        long,
        value_name = "LAMBDA",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    lambda: f64,
    /// Half-width of the margin between the fetal and maternal sides to
    /// start from, mm (adapted in quarter-voxel steps, below 10 voxels)
    /// [default: five voxels of --voxel-mm, 15 mm at 3 mm as published].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    margin_mm: Option<f64>,
    /// Sharpness `gamma` of the parcellation's affinity
    /// `exp(gamma <n_i, n_j> l_ij)` between boundary vertices (ALGORITHMS
    /// 2.5; the published 20): larger splits the sides at sharper bends.
    #[arg(
        long,
        value_name = "GAMMA",
        default_value_t = 20.0,
        allow_negative_numbers = true
    )]
    gamma: f64,
    /// Ring size of the affinity's neighbourhood (1 to 6; the published 3).
    #[arg(long, value_name = "N", default_value_t = 3)]
    rings: usize,
    /// Voxel size of the acquisition, mm: the unit of the margin's steps and
    /// of the template error in voxels [default: the mean voxel spacing of
    /// the --seg mask, else 3].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    voxel_mm: Option<f64>,
    /// Optimizer.
    #[arg(long, value_parser = named::<SolverKind>(), default_value = "newton")]
    solver: SolverKind,
    /// Distortion energy D (ALGORITHMS 1.2): symmetric-dirichlet (the
    /// published method, a barrier against flips), mips, arap or area-ratio.
    #[arg(long, value_parser = named::<EnergyKind>(), default_value = "symmetric-dirichlet")]
    energy: EnergyKind,
    /// A 3D or 4D image (.nii .nii.gz .nrrd .seg.nrrd .nhdr) in the mesh's
    /// scanner frame to pull into the template; written as
    /// DIR/<name>_flat.nii.gz. Repeatable.
    #[arg(long = "image", value_name = "FILE")]
    images: Vec<PathBuf>,
    /// Isotropic voxel size of the template-space images, mm [default: each
    /// input image's own voxel spacing].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    spacing_mm: Option<f64>,
    /// A fixed template-frame box for the pulled-back images,
    /// XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX in mm (needs --spacing-mm): voxel
    /// centres from the minima in steps of the spacing, so every run with the
    /// same box and spacing writes images of one grid. Mesh vertices outside
    /// the box are counted in report.json and warned about.
    #[arg(
        long,
        value_name = "BOX",
        value_parser = parse_grid,
        allow_hyphen_values = true,
        requires = "spacing_mm"
    )]
    grid: Option<[f64; 6]>,
    /// The frame of the mesh's coordinates: ras (NIfTI's world), lps (ITK,
    /// DICOM, 3D Slicer's default) or auto (3D Slicer's SPACE= marker in
    /// the file, else ras). LPS meshes are converted to RAS on reading; every
    /// output is in RAS.
    #[arg(long, value_parser = named::<MeshFrame>(), default_value = "auto", conflicts_with = "seg")]
    mesh_frame: MeshFrame,
    /// Skip the check that the mesh lies in each image's foreground (for
    /// images without a placenta foreground).
    #[arg(long)]
    no_frame_check: bool,
    /// How the images are sampled: linear (intensities) or nearest (label
    /// maps).
    #[arg(long, value_parser = named::<Interpolation>(), default_value = "linear")]
    interp: Interpolation,
    /// Also write the map as a displacement field (.nii or .nii.gz) that
    /// ITK, ANTs and SimpleITK read: on the template grid (--grid if given;
    /// the spacing of --spacing-mm, else of the first --image, else
    /// --voxel-mm), vectors
    /// d(p) = z(p) - p in LPS (ITK's frame) so that a template voxel p comes
    /// from the scanner point p + d(p); 0 outside the placenta.
    #[arg(long, value_name = "FILE")]
    displacement: Option<PathBuf>,
    /// Stop when the gradient norm |grad phi|_F falls below this.
    #[arg(
        long,
        value_name = "TOL",
        default_value_t = 1e-4,
        allow_negative_numbers = true
    )]
    tol: f64,
    /// Iteration limit per optimization stage [default: 200 for newton,
    /// 100000 for gd]. Not converging within it is not an error.
    #[arg(long, value_name = "N")]
    max_iterations: Option<usize>,
}

impl PlacentaArgs {
    /// The settings of the flags.
    pub(crate) fn settings(&self) -> Settings {
        Settings {
            template: self.template,
            solver: self.solver,
            energy: self.energy,
            lambda: self.lambda,
            lambda_sweep: self.lambda_sweep.clone(),
            fix_h: self.fix_h,
            margin_mm: self.margin_mm,
            gamma: self.gamma,
            rings: self.rings,
            voxel_mm: self.voxel_mm,
            tol: self.tol,
            max_iterations: self.max_iterations,
            spacing_mm: self.spacing_mm,
            grid: self.grid,
            interp: self.interp,
            no_frame_check: self.no_frame_check,
            mesh_frame: self.mesh_frame,
            no_figures: self.no_figures,
            dense: self.dense,
            mask: self.mask.settings(),
        }
    }

    /// The files of the flags.
    pub(crate) fn files(&self) -> Files {
        Files {
            mesh: self.mesh.clone(),
            seg: self.seg.clone(),
            images: self.images.clone(),
            displacement: self.displacement.clone(),
            output: self.output.clone(),
        }
    }

    /// The mesh file read (none with `--seg`), for the units hint.
    pub(crate) fn input_meshes(&self) -> Vec<PathBuf> {
        crate::app::run::units::mesh_inputs(&[&self.mesh])
    }
}

/// Runs `unfold placenta`: every flag checked before any file is read,
/// every output checked (and staged) before any input is read, the run,
/// its outputs put in place, the summary on stdout; exit 3 (outputs
/// written) when the solver did not converge.
pub fn run(a: &PlacentaArgs) -> Result<(), AppError> {
    let settings = a.settings();
    let files = a.files();
    settings.validate(files.seg.is_some())?;
    let names = files.check()?;
    let input = files.input()?;
    let mut staged =
        StagedOutputs::new(std::iter::once(input).chain(files.images.iter().map(PathBuf::as_path)));
    let staging = staged.dir(&files.output)?;
    let displacement = files
        .displacement
        .as_ref()
        .map(|d| staged.file(d))
        .transpose()?;
    let mut progress = Progress::new(true);
    let inputs = placenta::read(&settings, &files, names, &staging, &staged, &mut progress)?;
    let written = placenta::run(&settings, &inputs, &mut progress)
        .and_then(|run| {
            let written = placenta::write(
                &run,
                &settings,
                &inputs,
                &Outputs {
                    dir: &staging,
                    displacement: displacement.as_deref(),
                    staged: &staged,
                },
                &mut progress,
            )?;
            Ok((run, written))
        })
        .map_err(|e| crate::app::error::shown(&staged, e))?;
    drop(progress);
    let (run, written) = written;
    staged.commit()?;
    let summary = Summary {
        label: inputs.label.clone(),
        report: run.report.report,
        written,
    };
    println!("{summary}");
    if !summary.report.converged {
        return Err(AppError::NotConverged {
            what: "the placenta's flattening",
            reason: stop_name(summary.report.stop_reason),
            iterations: summary.report.iterations,
            output: a.output.display().to_string(),
        });
    }
    Ok(())
}
