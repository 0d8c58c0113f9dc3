//! `unfold placenta MESH -o DIR [--image FILE ...]`: flattens a placenta tet
//! mesh onto a canonical template (ALGORITHMS 2) and pulls images into the
//! template frame.
//!
//! The pipeline is [`crate::organs::placenta::flatten_with`]: it minimizes
//!
//! ```text
//! phi(X, theta) = sum_{m in boundary} A_m T(x_m, theta)  +  lambda sum_k V_k D(J_k)
//! ```
//!
//! (`T` the template term of the fetal, maternal and margin boundary
//! vertices, `D` the symmetric Dirichlet energy), flip-free, and evaluates the
//! map. Every image given with `--image` is then resampled on an
//! axis-aligned grid covering the flattened mesh (ALGORITHMS 2.7), one
//! pull-back table per distinct grid spacing, shared by all frames of a 4D
//! series and by all images with that spacing.
//!
//! Outputs in DIR (created if missing), each written atomically:
//!
//! - `original.vtu`: the input (tets oriented positively) with the point
//!   array `side` (0 interior, 1 fetal, 2 maternal, 3 margin);
//! - `flattened.vtu`: the mapped mesh in the template frame, point array
//!   `side`, cell arrays `log2_det_j` and `sym_dirichlet`;
//! - `<name>_flat.nii.gz` for every image `<name>.nii[.gz]` (or `.nrrd`,
//!   `.seg.nrrd`, `.nhdr`);
//! - `report.json`: the library's report plus `mesh` (the input) and
//!   `images` (one entry per image: input, output, spacing, dims, frames
//!   and the voxel counts of the pull-back).
//!
//! Every input is read and checked before the optimization starts: the mesh
//! (tets, finite coordinates, no degenerate tets, one component, manifold
//! boundary), every image (readable, overlapping the mesh), distinct image
//! names, and no output path equal to an input. Tets with a negative
//! orientation are reoriented (a repair that is reported, not an error).

use super::mesh::{MaskArgs, describe, warn_dropped};
use super::{AppError, at, positive};
use crate::app::run::StagedOutputs;
use crate::figures::FigureOptions;
use crate::figures::placenta::{FlatImage, figures as placenta_figures};
use crate::io::Frame;
use crate::io::nifti::INTENT_VECTOR;
use crate::io::{
    Datatype, NiftiImage, WriteOptions, atomic_write, read_mesh, write_image, write_mesh,
};
use crate::mesh::mask::inside_distance_quantile;
use crate::mesh::mesher::{MaskMeshOptions, MeshQuality, cube_side_for_cubes};
use crate::mesh::{CellMesh, MeshError, Volume};
use crate::organs::placenta::displacement::{VectorFrame, displacement_field};
use crate::organs::placenta::images::{check_images, template_grid};
use crate::organs::placenta::parcellation::{DEFAULT_MARGIN_VOXELS, ParcellationConfig};
use crate::organs::placenta::pullback::PullbackTable;
use crate::organs::placenta::segmentation::{THICKNESS_QUANTILE, from_segmentation};
use crate::organs::placenta::{
    Config, GridBox, Held, Image, Interpolation, Pipeline, PlacentaTemplate, PreparedMesh,
    PullbackError, Report, SolverKind, TemplateKind, prepare_mesh,
};
use crate::organs::{OrganError, PipelineObserver};
use crate::param::Iteration;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::fmt;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Image interpolation on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InterpArg {
    /// Trilinear (intensities); the default.
    Linear,
    /// The nearest voxel's value (label maps: no blended labels; an integer
    /// image is written with its own integer type).
    Nearest,
}

impl From<InterpArg> for Interpolation {
    fn from(i: InterpArg) -> Self {
        match i {
            InterpArg::Linear => Interpolation::Linear,
            InterpArg::Nearest => Interpolation::Nearest,
        }
    }
}

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

/// Templates on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TemplateArg {
    /// Two parallel planes z = +-h (fetal side up); the default.
    Planes,
    /// An axis-aligned ellipsoid with radii rx, ry, rz.
    Ellipsoid,
    /// The maternal side on z = -h, the fetal side free (starts from planes).
    SinglePlane,
}

impl From<TemplateArg> for TemplateKind {
    fn from(t: TemplateArg) -> Self {
        match t {
            TemplateArg::Planes => TemplateKind::Planes,
            TemplateArg::Ellipsoid => TemplateKind::Ellipsoid,
            TemplateArg::SinglePlane => TemplateKind::SinglePlane,
        }
    }
}

/// Solvers on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SolverArg {
    /// Projected Newton (sparse Cholesky of the PSD-projected Hessian).
    Newton,
    /// Gradient descent (the paper's Algorithm 1; thousands of iterations).
    Gd,
}

impl From<SolverArg> for SolverKind {
    fn from(s: SolverArg) -> Self {
        match s {
            SolverArg::Newton => SolverKind::Newton,
            SolverArg::Gd => SolverKind::Gd,
        }
    }
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
    #[arg(long, value_enum, default_value = "planes")]
    template: TemplateArg,
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
    #[arg(long, value_enum, default_value = "newton")]
    solver: SolverArg,
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
    #[arg(long, value_parser = super::choice::named::<super::MeshFrame>(), default_value = "auto", conflicts_with = "seg")]
    mesh_frame: super::MeshFrame,
    /// Skip the check that the mesh lies in each image's foreground (for
    /// images without a placenta foreground).
    #[arg(long)]
    no_frame_check: bool,
    /// How the images are sampled: linear (intensities) or nearest (label
    /// maps).
    #[arg(long, value_enum, default_value = "linear")]
    interp: InterpArg,
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

/// A pipeline error about the input `path` (the mesh, or an image), as
/// [`crate::placenta::organ`] words it.
fn organ(path: &str, source: impl Into<OrganError>) -> AppError {
    crate::placenta::organ(path, source).into()
}

impl PlacentaArgs {
    /// The pipeline settings, every flag checked; `voxel_mm` is the
    /// default of `--voxel-mm`, `half_thickness_mm` the segmentation's.
    fn config(&self, voxel_mm: f64, half_thickness_mm: Option<f64>) -> Result<Config, AppError> {
        PlacentaSettings {
            lambda: self.lambda,
            margin_mm: self.margin_mm,
            gamma: self.gamma,
            rings: self.rings,
            voxel_mm: self.voxel_mm.unwrap_or(voxel_mm),
            tol: self.tol,
            spacing_mm: self.spacing_mm,
            max_iterations: self.max_iterations,
            interp: self.interp,
            grid: self.grid,
            frame_check: !self.no_frame_check,
        }
        .config(half_thickness_mm)
    }
}

/// The placenta's numeric settings as the flags give them, checked into the
/// pipeline's [`Config`] by one function for the command line and the
/// Python package (so both refuse a value with the same message).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacentaSettings {
    /// `--lambda`.
    pub lambda: f64,
    /// `--margin-mm` (`None`: [`DEFAULT_MARGIN_VOXELS`] voxels of
    /// `voxel_mm`).
    pub margin_mm: Option<f64>,
    /// `--gamma`.
    pub gamma: f64,
    /// `--rings`.
    pub rings: usize,
    /// `--voxel-mm`.
    pub voxel_mm: f64,
    /// `--tol`.
    pub tol: f64,
    /// `--spacing-mm`.
    pub spacing_mm: Option<f64>,
    /// `--max-iterations`.
    pub max_iterations: Option<usize>,
    /// `--interp`.
    pub interp: InterpArg,
    /// `--grid`.
    pub grid: Option<[f64; 6]>,
    /// Not `--no-frame-check`.
    pub frame_check: bool,
}

impl Default for PlacentaSettings {
    /// The flags' defaults (`--voxel-mm` 3, as without `--seg`).
    fn default() -> Self {
        PlacentaSettings {
            lambda: 1.0,
            margin_mm: None,
            gamma: 20.0,
            rings: 3,
            voxel_mm: 3.0,
            tol: 1e-4,
            spacing_mm: None,
            max_iterations: None,
            interp: InterpArg::Linear,
            grid: None,
            frame_check: true,
        }
    }
}

impl PlacentaSettings {
    /// The pipeline's configuration, every value checked with its flag's
    /// message; `half_thickness_mm` is the segmentation's, if any.
    pub fn config(&self, half_thickness_mm: Option<f64>) -> Result<Config, AppError> {
        let lambda = positive("--lambda", self.lambda)?;
        let voxel_mm = positive("--voxel-mm", self.voxel_mm)?;
        let gamma = positive("--gamma", self.gamma)?;
        if !(1..=6).contains(&self.rings) {
            return Err(AppError::Usage(format!(
                "--rings must be 1 to 6, got {}",
                self.rings
            )));
        }
        let margin_mm = match self.margin_mm {
            Some(m) => positive("--margin-mm", m)?,
            None => DEFAULT_MARGIN_VOXELS * voxel_mm,
        };
        let grad_tol = positive("--tol", self.tol)?;
        if let Some(s) = self.spacing_mm {
            positive("--spacing-mm", s)?;
        }
        if self.max_iterations == Some(0) {
            return Err(AppError::Usage(
                "--max-iterations must be at least 1".into(),
            ));
        }
        let config = Config {
            lambda,
            grad_tol,
            max_iterations: self.max_iterations,
            max_seconds: None,
            parcellation: ParcellationConfig {
                gamma,
                rings: self.rings,
                margin_mm,
                voxel_mm,
                ..ParcellationConfig::default()
            },
            half_thickness_mm,
            spacing_mm: self.spacing_mm,
            interpolation: self.interp.into(),
            grid: self.grid.as_ref().map(|g| GridBox {
                min: [g[0], g[2], g[4]],
                max: [g[1], g[3], g[5]],
            }),
            frame_check: self.frame_check,
        };
        if let Some(g) = &config.grid {
            g.validate()
                .map_err(|e| AppError::Usage(format!("--grid: {e}")))?;
        }
        config
            .validate()
            .map_err(|e| AppError::Usage(format!("{e} (see --margin-mm and --voxel-mm)")))?;
        Ok(config)
    }
}

impl PlacentaArgs {
    /// The pipeline: the template and solver of the flags, the published
    /// pieces otherwise, and `config`.
    fn pipeline(&self, config: Config) -> Result<Pipeline, AppError> {
        Ok(Pipeline::new()
            .template(hold_half_thickness(
                TemplateKind::from(self.template).build(),
                self.fix_h,
            )?)
            .solver(SolverKind::from(self.solver).build())
            .config(config))
    }
}

/// `--fix-h`: `template` with its half thickness `h` held at `h_mm`
/// ([`Held`]), or `template` itself without a value.
///
/// # Errors
/// [`AppError::Usage`] for an `h_mm` that is not finite and positive, or a
/// template whose parameters are not exactly `h` (the ellipsoid's radii).
pub fn hold_half_thickness(
    template: Box<dyn PlacentaTemplate>,
    h_mm: Option<f64>,
) -> Result<Box<dyn PlacentaTemplate>, AppError> {
    let Some(h) = h_mm else {
        return Ok(template);
    };
    let h = positive("--fix-h", h)?;
    let names = template.parameter_names();
    let name = template.name();
    Held::new(template, vec![h])
        .filter(|_| names == ["h"])
        .map(|held| Box::new(held) as Box<dyn PlacentaTemplate>)
        .ok_or_else(|| {
            AppError::Usage(format!(
                "--fix-h holds a half thickness h, but the {name} template's parameters are \
                 [{}]; use it with --template planes or single-plane",
                names.join(", ")
            ))
        })
}

/// The data type of an image pulled back by nearest neighbour: the input's
/// own when it is an unscaled integer type (every output value is one of
/// its values), FLOAT32 otherwise.
pub(crate) fn nearest_datatype(input: &NiftiImage) -> Datatype {
    let integer = !matches!(input.datatype, Datatype::Float32 | Datatype::Float64);
    // scl_slope 0 means no scaling (NIfTI-1).
    let unscaled = (input.scl_slope == 0.0 || input.scl_slope == 1.0) && input.scl_inter == 0.0;
    if integer && unscaled {
        input.datatype
    } else {
        Datatype::Float32
    }
}

/// `<name>` of an image file `<name>.nii`, `<name>.nii.gz`, `<name>.nrrd`,
/// `<name>.seg.nrrd` or `<name>.nhdr` (any case).
fn image_name(path: &Path) -> Option<String> {
    let name = path.file_name()?.to_str()?;
    let lower = name.to_ascii_lowercase();
    let ext = [".nii.gz", ".nii", ".seg.nrrd", ".nrrd", ".nhdr"]
        .iter()
        .find(|ext| lower.ends_with(*ext))?;
    (name.len() > ext.len()).then(|| name[..name.len() - ext.len()].to_string())
}

/// The output file of an image called `name`.
fn flat_name(name: &str) -> String {
    format!("{name}_flat.nii.gz")
}

/// The fixed outputs in DIR.
const ORIGINAL: &str = "original.vtu";
const FLATTENED: &str = "flattened.vtu";
const REPORT: &str = "report.json";
/// The mesh of a `--seg` segmentation.
const SEG_MESH: &str = "mesh.vtu";

/// An image to pull into the template.
#[derive(Debug, Clone)]
pub(crate) struct ImageInput {
    /// Where it came from (messages and the report).
    pub path: PathBuf,
    /// Its name: the output is `DIR/<name>_flat.nii.gz`.
    pub name: String,
    /// The image.
    pub image: NiftiImage,
}

/// What [`run_pipeline`] works on.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PipelineInput<'a> {
    /// The mesh's name in messages and the report (its path, usually).
    pub label: &'a str,
    /// The placenta tet mesh (mm, scanner frame), checked and oriented.
    pub mesh: &'a PreparedMesh,
    /// Images to pull into the template.
    pub images: &'a [ImageInput],
    /// The pipeline (settings already validated).
    pub pipeline: &'a Pipeline,
    /// Output directory (created if missing): in a staging area of `out`.
    pub dir: &'a Path,
    /// The run's staged outputs: where the paths written will be after the
    /// commit, for the report and messages.
    pub out: &'a StagedOutputs,
    /// Show a progress spinner on stderr (only if stderr is a terminal).
    pub progress: bool,
    /// How the mesh was made from a segmentation (`--seg`), for the report.
    pub segmentation: Option<&'a SegReport>,
    /// Write the figures into `dir/figures/`.
    pub figures: bool,
    /// Write the map as an ITK displacement field here.
    pub displacement: Option<&'a Path>,
    /// The frame the mesh file was in (it is in RAS now), for messages.
    pub frame: Frame,
}

/// `displacement` in `report.json`: the map as an ITK displacement field.
#[derive(Debug, Clone, Serialize)]
struct DisplacementReport {
    /// The file written.
    path: String,
    /// How to read it.
    convention: &'static str,
    /// Voxel size of the template grid, mm.
    spacing_mm: [f64; 3],
    /// Voxels of the template grid.
    dims: [usize; 3],
    /// Voxels inside the flattened mesh (the others are 0).
    inside_mesh: usize,
}

/// Lattice cubes the mask holds at `placenta --seg`'s default cube side.
/// A typical placenta (about 500 cm^3) then gets a cube side near 4.6 mm
/// and, graded, 15,000 to 20,000 tets, within a few times the published
/// meshes' ~6,700 (ALGORITHMS: the placenta paper), whatever the image's
/// resolution: at 3 mm voxels that is 2.4 times fewer tets than the voxel
/// size gives, and flattening costs grow faster than the tet count.
pub const SEG_CUBES: usize = 5_000;

/// Where `placenta --seg`'s lattice cube side came from (`size_from` in
/// the report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SizeFrom {
    /// `--size-mm`.
    Given,
    /// The smallest voxel spacing (`--dense`, or a mask so small or thin
    /// that the other rules would be finer than its voxels).
    Voxel,
    /// [`SEG_CUBES`] cubes in the mask's volume.
    MaskVolume,
    /// Half the mask's half thickness: a thin mask keeps at least four
    /// cubes through its thickness.
    Thickness,
}

/// The cube side `placenta --seg` meshes at: `--size-mm` when given; the
/// smallest voxel spacing `v` with `--dense`; otherwise
/// `max(v, min(s_V, h / 2))` with `s_V` the side at which the mask holds
/// [`SEG_CUBES`] cubes ([`cube_side_for_cubes`]) and `h` the mask's half
/// thickness (the 0.95 quantile of its distance transform, as the
/// pipeline's initial `h`), so that at least four cubes span the
/// thickness. Returns the side and the rule that set it.
///
/// # Errors
/// The distance transform's [`MeshError`].
pub(crate) fn seg_cube_side(
    mask: &Volume<bool>,
    given: Option<f64>,
    dense: bool,
) -> Result<(f64, SizeFrom), MeshError> {
    if let Some(s) = given {
        return Ok((s, SizeFrom::Given));
    }
    let voxel = mask.spacing().iter().copied().fold(f64::INFINITY, f64::min);
    if dense {
        return Ok((voxel, SizeFrom::Voxel));
    }
    let Some(by_volume) = cube_side_for_cubes(mask, SEG_CUBES as f64) else {
        return Ok((voxel, SizeFrom::Voxel));
    };
    let half_thickness =
        inside_distance_quantile(mask, THICKNESS_QUANTILE)?.unwrap_or(f64::INFINITY);
    let (side, from) = if half_thickness / 2.0 < by_volume {
        (half_thickness / 2.0, SizeFrom::Thickness)
    } else {
        (by_volume, SizeFrom::MaskVolume)
    };
    Ok(if side > voxel {
        (side, from)
    } else {
        (voxel, SizeFrom::Voxel)
    })
}

/// `segmentation` in `report.json`: how the mesh was made from a mask.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct SegReport {
    /// The mask.
    pub mask: String,
    /// The mesh written.
    pub mesh: String,
    /// Voxels set, and their volume in mm^3.
    pub mask_voxels: usize,
    /// Volume of the voxels set, mm^3.
    pub mask_volume_mm3: f64,
    /// Lattice cube side, mm.
    pub size_mm: f64,
    /// Where the cube side came from.
    pub size_from: SizeFrom,
    /// Gaussian smoothing, voxels.
    pub smooth_voxels: f64,
    /// Box dilations.
    pub dilate: u8,
    /// Level of the smoothed mask meshed.
    pub level: f64,
    /// Whether the interior was graded (the default; not with `--dense`).
    pub graded: bool,
    /// Interior vertices removed by the grading.
    pub graded_collapses: usize,
    /// Tet counts of the components left out.
    pub dropped_components: Vec<usize>,
    /// Half thickness: the 95th percentile of the mask's distance
    /// transform, mm.
    pub half_thickness_mm: f64,
    /// Size and quality of the mesh.
    pub quality: MeshQuality,
}

/// What a run produced, for the summary on stdout.
#[derive(Debug, Clone)]
pub(crate) struct Summary {
    /// The mesh's name.
    pub label: String,
    /// The library's report.
    pub report: Report,
    /// Every file written, in order.
    pub written: Vec<PathBuf>,
}

/// `name value` pairs of template parameters, mm.
fn params(theta: &std::collections::BTreeMap<&'static str, f64>) -> String {
    theta
        .iter()
        .map(|(k, v)| format!("{k} {v:.2}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn plural(n: usize, one: &str) -> String {
    if n == 1 {
        format!("{n} {one}")
    } else {
        format!("{n} {one}s")
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.report;
        let status = if r.converged {
            "converged".to_string()
        } else {
            format!("NOT converged ({})", super::stop_name(r.stop_reason))
        };
        writeln!(
            f,
            "{}: {} tets, {} vertices -> {} template ({}): {status} in {}, {:.2} s",
            self.label,
            r.input.tets,
            r.input.vertices,
            r.template,
            r.solver,
            plural(r.iterations, "iteration"),
            r.seconds
        )?;
        if r.input.reoriented_tets > 0 {
            writeln!(
                f,
                "  reoriented {} (negatively oriented in the input)",
                plural(r.input.reoriented_tets, "tet")
            )?;
        }
        writeln!(
            f,
            "  template error {:.3} mm ({:.3} voxels of {} mm), Dirichlet excess {:.2} %",
            r.template_error_mm, r.template_error_voxels, r.voxel_mm, r.dirichlet_excess_percent
        )?;
        writeln!(
            f,
            "  min det J {:.4}, {}",
            r.min_det_j,
            plural(r.inverted_tets, "inverted tet")
        )?;
        writeln!(
            f,
            "  {} mm (initial {} mm)",
            params(&r.theta),
            params(&r.theta_initial)
        )?;
        writeln!(
            f,
            "  boundary vertices: {} fetal, {} maternal, {} margin",
            r.boundary.fetal, r.boundary.maternal, r.boundary.margin
        )?;
        for i in &r.images {
            writeln!(
                f,
                "  {} -> {}: {} voxels inside the mesh, {} sampled, {} outside the image",
                i.input.as_deref().unwrap_or(&i.name),
                i.output.as_deref().unwrap_or("-"),
                i.inside_mesh,
                i.sampled,
                i.outside_image
            )?;
        }
        for (k, p) in self.written.iter().enumerate() {
            if k + 1 == self.written.len() {
                write!(f, "wrote {}", p.display())?;
            } else {
                writeln!(f, "wrote {}", p.display())?;
            }
        }
        Ok(())
    }
}

/// The progress spinner on stderr: the current stage and, while optimizing,
/// the iteration, objective and gradient norm. Nothing at all is drawn when
/// stderr is not a terminal.
struct Progress {
    bar: Option<ProgressBar>,
    stage: String,
}

impl Progress {
    fn new(show: bool) -> Self {
        let bar = (show && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::new_spinner();
            if let Ok(style) = ProgressStyle::with_template("{spinner} [{elapsed}] {wide_msg}") {
                bar.set_style(style);
            }
            bar.enable_steady_tick(Duration::from_millis(120));
            bar
        });
        Progress {
            bar,
            stage: String::new(),
        }
    }

    fn set(&mut self, stage: &str) {
        self.stage = stage.to_string();
        if let Some(b) = &self.bar {
            b.set_message(stage.to_string());
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl PipelineObserver for Progress {
    fn stage(&mut self, name: &str) {
        self.set(name);
    }

    fn iteration(&mut self, it: &Iteration) {
        if let Some(b) = &self.bar {
            b.set_message(format!(
                "{}, it {}: phi {:.5e}, |grad| {:.2e}",
                self.stage, it.iteration, it.value, it.grad_norm
            ));
        }
    }
}

/// Checks that no two images have the same name (so the same output).
fn check_names<'a>(images: impl IntoIterator<Item = (&'a Path, &'a str)>) -> Result<(), AppError> {
    let mut seen: Vec<(&Path, &str)> = Vec::new();
    for (path, name) in images {
        if let Some((first, _)) = seen.iter().find(|(_, n)| *n == name) {
            return Err(at(
                path,
                format!(
                    "has the same name as {} (both would be written to {}); rename one of them",
                    first.display(),
                    flat_name(name)
                ),
            ));
        }
        seen.push((path, name));
    }
    Ok(())
}

/// Runs the placenta pipeline and writes its outputs into `input.dir`:
/// checks the image names (their outputs must differ), runs the library's
/// [`Pipeline`] (which checks the images against the mesh before any work,
/// flattens and pulls every image back) and writes `original.vtu`,
/// `flattened.vtu`, `<name>_flat.nii.gz` per image, the figures and
/// `report.json` (last).
pub(crate) fn run_pipeline(input: &PipelineInput<'_>) -> Result<Summary, AppError> {
    let label = input.label;
    check_names(
        input
            .images
            .iter()
            .map(|i| (i.path.as_path(), i.name.as_str())),
    )?;
    let images: Vec<Image<'_>> = input
        .images
        .iter()
        .map(|i| Image {
            name: &i.name,
            volume: &i.image.volume,
        })
        .collect();
    // The library checks the images again; checking them here first means
    // nothing is created for a run that cannot start.
    let frame_check = input.pipeline.settings().frame_check;
    check_images(&input.mesh.mesh, &images, frame_check)
        .map_err(|e| pipeline_error(label, input.frame, input.images, e))?;
    super::ensure_dir(input.dir)?;
    let mut progress = Progress::new(input.progress);
    let mut outcome = input
        .pipeline
        .run_prepared(input.mesh.clone(), &images, &mut progress)
        .map_err(|e| pipeline_error(label, input.frame, input.images, e))?;
    for i in &outcome.report.images {
        if i.vertices_outside_grid > 0 {
            eprintln!(
                "warning: {}: {} of the flattened mesh's {} vertices lie outside the --grid box \
                 (counted in report.json)",
                i.name,
                i.vertices_outside_grid,
                outcome.flattened.num_vertices()
            );
        }
    }

    let dir = input.dir;
    let mut written = Vec::new();
    progress.set("writing meshes");
    let opts = WriteOptions::default();
    for (name, mesh) in [
        (ORIGINAL, &outcome.original),
        (FLATTENED, &outcome.flattened),
    ] {
        let p = dir.join(name);
        write_mesh(&p, &CellMesh::from(mesh), &opts)?;
        written.push(p);
    }
    for ((flat, entry), img) in outcome
        .images
        .iter()
        .zip(&mut outcome.report.images)
        .zip(input.images)
    {
        let mut out = NiftiImage::new(flat.volume.clone());
        out.time_step = img.image.time_step;
        out.xyzt_units = img.image.xyzt_units;
        out.description = "unfold placenta: pulled back into the template".into();
        if entry.interpolation == Interpolation::Nearest.name() {
            out = out.with_datatype(nearest_datatype(&img.image));
        }
        let out_path = dir.join(flat_name(&img.name));
        write_image(&out_path, &out)?;
        entry.input = Some(input.out.shown(&img.path).display().to_string());
        entry.output = Some(input.out.shown(&out_path).display().to_string());
        written.push(out_path);
    }

    let displacement = match input.displacement {
        Some(path) => {
            progress.set("displacement field");
            let settings = input.pipeline.settings();
            let spacing = match (settings.spacing_mm, input.images.first()) {
                (Some(s), _) => [s; 3],
                (None, Some(img)) => img.image.volume.spacing(),
                (None, None) => [settings.parcellation.voxel_mm; 3],
            };
            let failed =
                |e: PullbackError| at(path, format!("cannot build the displacement field: {e}"));
            let grid = template_grid(&outcome.flattened, spacing, settings.grid.as_ref())
                .map_err(failed)?;
            let table = PullbackTable::new(
                grid,
                &outcome.flattened.positions,
                &outcome.flattened.tets,
                &outcome.original.positions,
            )
            .map_err(failed)?;
            let field = displacement_field(&table, VectorFrame::Lps)
                .map_err(|e| at(path, format!("cannot build the displacement field: {e}")))?;
            let mut img = NiftiImage::new(field);
            img.intent_code = INTENT_VECTOR;
            img.intent_name = "ITK displacement".into();
            img.description = "unfold placenta: template -> scanner, d = z - p (LPS)".into();
            write_image(path, &img)?;
            written.push(path.to_path_buf());
            Some(DisplacementReport {
                path: input.out.shown(path).display().to_string(),
                convention: "ITK/ANTs displacement field on the template grid: the template \
                             voxel at p (RAS affine) comes from the scanner point p + d(p); \
                             components in LPS",
                spacing_mm: table.grid().spacing,
                dims: table.grid().dims,
                inside_mesh: table.len(),
            })
        }
        None => None,
    };

    if input.figures {
        progress.set("figures");
        let images: Vec<FlatImage<'_>> = outcome
            .images
            .iter()
            .map(|i| FlatImage {
                name: &i.name,
                volume: &i.volume,
                original: input
                    .images
                    .iter()
                    .find(|o| o.name == i.name)
                    .map(|o| &o.image.volume),
            })
            .collect();
        let figs = placenta_figures(&outcome, &images, &FigureOptions::default())
            .map_err(|e| at(dir, e))?;
        written.extend(super::write_figures(dir, &figs)?);
    }

    let report_path = dir.join(REPORT);
    let full = crate::placenta::FullReport {
        mesh: label,
        segmentation: input.segmentation,
        displacement,
        report: &outcome.report,
        memory: crate::app::run::memory::report(),
        provenance: crate::app::run::provenance::this_run(),
    };
    let json = full
        .to_json()
        .map_err(|e| at(&report_path, format!("cannot serialize the report: {e}")))?;
    atomic_write(&report_path, json.as_bytes())?;
    written.push(report_path);
    drop(progress);

    Ok(Summary {
        label: label.to_string(),
        report: outcome.report,
        written: written.iter().map(|p| input.out.shown(p)).collect(),
    })
}

/// A pipeline error, attributed to the file it is about
/// ([`crate::placenta::pipeline_error`]).
fn pipeline_error(label: &str, frame: Frame, images: &[ImageInput], e: OrganError) -> AppError {
    let paths: Vec<String> = images
        .iter()
        .map(|i| i.path.display().to_string())
        .collect();
    crate::placenta::pipeline_error(label, frame, &paths, e).into()
}

impl PlacentaArgs {
    /// The mesh file read (none with `--seg`), for the units hint.
    pub(crate) fn input_meshes(&self) -> Vec<PathBuf> {
        crate::app::run::units::mesh_inputs(&[&self.mesh])
    }
}

/// Runs `unfold placenta`.
pub fn run(a: &PlacentaArgs) -> Result<(), AppError> {
    let m = &a.mask;
    if a.seg.is_none()
        && (m.size_mm.is_some()
            || m.threshold.is_some()
            || m.label.is_some()
            || m.level.is_some()
            || m.dilate != 0
            || m.grade
            || a.dense
            || m.smooth_voxels != 1.5)
    {
        return Err(AppError::Usage(
            "--size-mm, --smooth-voxels, --dilate, --threshold, --label, --level, --grade and \
             --dense apply to --seg"
                .into(),
        ));
    }
    // every flag checked before any file is read
    a.config(3.0, None)?;
    a.pipeline(Config::default())?;
    for &l in &a.lambda_sweep {
        positive("--lambda-sweep", l)?;
    }
    if a.seg.is_some() {
        m.options(false)?;
    }
    let dir = a.output.as_path();
    if dir.exists() && !dir.is_dir() {
        return Err(at(
            dir,
            "exists and is not a directory; -o needs a directory (created if missing)",
        ));
    }
    let mut names = Vec::with_capacity(a.images.len());
    for p in &a.images {
        let name = image_name(p).ok_or_else(|| {
            at(
                p,
                "not a NIfTI or NRRD image name (expected .nii, .nii.gz, .nrrd, .seg.nrrd or .nhdr)",
            )
        })?;
        names.push(name);
    }
    check_names(
        a.images
            .iter()
            .zip(&names)
            .map(|(p, n)| (p.as_path(), n.as_str())),
    )?;
    let input = match (&a.mesh, &a.seg) {
        (Some(p), None) | (None, Some(p)) => p,
        _ => {
            return Err(AppError::Usage(
                "give a placenta tet mesh or --seg MASK (a segmentation to mesh)".into(),
            ));
        }
    };
    if let Some(d) = &a.displacement {
        let lower = d
            .file_name()
            .map(|n| n.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if !(lower.ends_with(".nii") || lower.ends_with(".nii.gz")) {
            return Err(at(
                d,
                "--displacement writes a NIfTI image: give a .nii or .nii.gz path",
            ));
        }
    }
    // Never overwrite an input.
    let out_dir = super::canonical(dir);
    let mut outputs: Vec<String> = [ORIGINAL, FLATTENED, REPORT, SEG_MESH]
        .iter()
        .map(|s| s.to_string())
        .collect();
    outputs.extend(names.iter().map(|n| flat_name(n)));
    if let Some(d) = &a.displacement {
        let c = super::canonical(d);
        if let Some(o) = outputs.iter().find(|o| out_dir.join(o) == c) {
            return Err(at(
                d,
                format!(
                    "--displacement would overwrite the output {}",
                    dir.join(o).display()
                ),
            ));
        }
    }
    for input in std::iter::once(input).chain(&a.images) {
        let c = super::canonical(input);
        if let Some(d) = &a.displacement
            && super::canonical(d) == c
        {
            return Err(at(
                input,
                "is an input and would be overwritten by --displacement; choose another path",
            ));
        }
        if let Some(o) = outputs.iter().find(|o| out_dir.join(o) == c) {
            return Err(at(
                input,
                format!(
                    "is an input and would be overwritten by the output {}; choose another -o",
                    dir.join(o).display()
                ),
            ));
        }
    }

    // Every output checked (and staged) before any input is read.
    let mut staged = StagedOutputs::new(std::iter::once(input).chain(&a.images));
    let staging = staged.dir(dir)?;
    let displacement = a
        .displacement
        .as_ref()
        .map(|d| staged.file(d))
        .transpose()?;

    let label = input.display().to_string();
    // A mask's mesh is made in the mask's world frame, RAS.
    let frame = match &a.seg {
        None => super::mesh_frame(a.mesh_frame, input)?,
        Some(_) => Frame::Ras,
    };
    let (mesh, config, seg) = match &a.seg {
        None => {
            let cells = read_mesh(input)?;
            let mut mesh = cells.volume_tets().map_err(|e| at(input, e))?;
            // Into RAS: negate x and y of an LPS mesh (a half turn about z,
            // so no tet changes orientation).
            let signs = frame.to_ras_signs();
            for p in &mut mesh.positions {
                for a in 0..3 {
                    p[a] *= signs[a];
                }
            }
            (mesh, a.config(3.0, None)?, None)
        }
        Some(seg) => {
            let mask = m.read_mask(seg)?;
            let spacing = mask.spacing();
            let (size_mm, size_from) =
                seg_cube_side(&mask, m.size_mm, a.dense).map_err(|e| at(seg, e))?;
            let options = MaskMeshOptions {
                grade: !a.dense,
                size_mm: Some(size_mm),
                ..m.options(false)?
            };
            m.check_memory_of(seg, &mask, &options)?;
            let segmented = from_segmentation(&mask, &options).map_err(|e| organ(&label, e))?;
            drop(mask);
            let (out, h) = (segmented.meshed, segmented.half_thickness_mm);
            warn_dropped(seg, &out, false);
            let quality = MeshQuality::of(&out.mesh)?;
            println!(
                "{}: {}{}",
                seg.display(),
                describe(&out, &quality),
                match size_from {
                    SizeFrom::MaskVolume => format!(
                        "; cube side from the mask's volume (about {SEG_CUBES} lattice cubes; \
                         --size-mm or --dense for finer)"
                    ),
                    SizeFrom::Thickness => "; cube side from the mask's thickness (four cubes \
                                            through it; --size-mm or --dense for finer)"
                        .to_string(),
                    _ => String::new(),
                }
            );
            let mesh_path = staging.join(SEG_MESH);
            write_mesh(
                &mesh_path,
                &CellMesh::from(&out.mesh),
                &WriteOptions::default(),
            )
            .map_err(|e| staged.shown_error(e))?;
            let report = SegReport {
                mask: label.clone(),
                mesh: staged.shown(&mesh_path).display().to_string(),
                mask_voxels: out.mask_voxels,
                mask_volume_mm3: out.mask_volume_mm3,
                size_mm: out.size_mm,
                size_from,
                smooth_voxels: m.smooth_voxels,
                dilate: m.dilate,
                level: out.level,
                graded: !a.dense,
                graded_collapses: out.graded_collapses,
                dropped_components: out.dropped_components.clone(),
                half_thickness_mm: h,
                quality,
            };
            let voxel = (spacing[0] + spacing[1] + spacing[2]) / 3.0;
            (out.mesh, a.config(voxel, Some(h))?, Some(report))
        }
    };
    // Mesh problems first: an image cannot be judged against a broken mesh.
    let prepared = prepare_mesh(&mesh).map_err(|e| organ(&label, e))?;
    drop(mesh);
    let mut images = Vec::with_capacity(a.images.len());
    for (p, name) in a.images.iter().zip(names) {
        images.push(ImageInput {
            path: p.clone(),
            name,
            image: super::read_image_checked(p, 0.0)?,
        });
    }
    check_memory(
        &prepared.mesh,
        &images,
        a.grid.as_ref(),
        a.displacement.is_some(),
    )?;

    let sweep_config = config;
    let summary = run_pipeline(&PipelineInput {
        label: &label,
        mesh: &prepared,
        images: &images,
        pipeline: &a.pipeline(config)?,
        dir: &staging,
        out: &staged,
        progress: true,
        segmentation: seg.as_ref(),
        figures: !a.no_figures,
        displacement: displacement.as_deref(),
        frame,
    })
    .map_err(|e| super::shown(&staged, e))?;
    if !a.lambda_sweep.is_empty() {
        lambda_sweep(a, sweep_config, &prepared, &label, &staging)
            .map_err(|e| super::shown(&staged, e))?;
    }
    staged.commit()?;
    println!("{summary}");
    if !summary.report.converged {
        return Err(AppError::NotConverged {
            what: "the placenta's flattening",
            reason: super::stop_name(summary.report.stop_reason),
            iterations: summary.report.iterations,
            output: a.output.display().to_string(),
        });
    }
    Ok(())
}

/// `--lambda-sweep`: flattens `prepared` once per weight (no images; the
/// settings of the main run otherwise) and writes `lambda_sweep.csv` (a row
/// per weight: `lambda`, `converged`, `iterations`, `template_error_mm`,
/// `dirichlet_excess_percent`, `min_det_j`, `seconds`) and, unless
/// `--no-figures`, `figures/lambda_sweep.png` into `dir`.
///
/// # Errors
/// A run that fails (named with its weight), writing the outputs.
fn lambda_sweep(
    a: &PlacentaArgs,
    config: Config,
    prepared: &PreparedMesh,
    label: &str,
    dir: &Path,
) -> Result<(), AppError> {
    use crate::figures::placenta::lambda_sweep::{SweepPoint, lambda_sweep_plot};
    let path = dir.join(LAMBDA_SWEEP_CSV);
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "lambda",
        "converged",
        "iterations",
        "template_error_mm",
        "dirichlet_excess_percent",
        "min_det_j",
        "seconds",
    ])
    .map_err(|e| at(&path, e))?;
    let mut points = Vec::new();
    for &lambda in &a.lambda_sweep {
        eprintln!("{label}: lambda sweep, lambda = {lambda}");
        let outcome = a
            .pipeline(Config { lambda, ..config })?
            .run_prepared(prepared.clone(), &[], &mut crate::organs::Quiet)
            .map_err(|e| super::organ(&format!("{label} (--lambda-sweep {lambda})"), e))?;
        let r = &outcome.report;
        w.write_record([
            lambda.to_string(),
            r.converged.to_string(),
            r.iterations.to_string(),
            r.template_error_mm.to_string(),
            r.dirichlet_excess_percent.to_string(),
            r.min_det_j.to_string(),
            r.seconds.to_string(),
        ])
        .map_err(|e| at(&path, e))?;
        points.push(SweepPoint {
            lambda,
            dirichlet_excess_percent: r.dirichlet_excess_percent,
            template_error_mm: r.template_error_mm,
        });
    }
    let bytes = w.into_inner().map_err(|e| at(&path, e))?;
    atomic_write(&path, &bytes)?;
    if !a.no_figures {
        let figure =
            lambda_sweep_plot(&points, &FigureOptions::default()).map_err(|e| at(&path, e))?;
        super::write_figures(dir, &[figure])?;
    }
    Ok(())
}

/// The table of `--lambda-sweep`.
const LAMBDA_SWEEP_CSV: &str = "lambda_sweep.csv";

/// Refuses the optimization when the predicted peak passes the budget:
/// the factor and per-tet buffers of the mesh
/// ([`crate::organs::placenta::memory::estimate_memory`]) and one
/// pull-back table per image (and displacement field) on the template grid,
/// `--grid` at the images' finest spacing, else about four times the
/// mesh's volume in voxels (the box of the flattened mesh).
fn check_memory(
    mesh: &crate::mesh::TetMesh,
    images: &[ImageInput],
    grid: Option<&[f64; 6]>,
    displacement: bool,
) -> Result<(), AppError> {
    let voxel = images
        .iter()
        .map(|i| i.image.volume.spacing())
        .fold([f64::INFINITY; 3], |m, s| {
            std::array::from_fn(|a| m[a].min(s[a]))
        });
    let voxel = if voxel.iter().all(|x| x.is_finite() && *x > 0.0) {
        voxel
    } else {
        [3.0; 3]
    };
    let template_voxels = match grid {
        Some(g) => (0..3)
            .map(|a| ((g[2 * a + 1] - g[2 * a]) / voxel[a]).ceil() + 1.0)
            .product(),
        None => 4.0 * crate::mesh::geometry::total_volume(mesh) / (voxel[0] * voxel[1] * voxel[2]),
    };
    let tables = images.len() + usize::from(displacement);
    let estimate = crate::organs::placenta::memory::estimate_memory(mesh, template_voxels, tables)
        .map_err(|e| AppError::Usage(e.to_string()))?;
    let hint = match estimate.largest() {
        Some(p) if p.what == "pull-back tables" => {
            "shrink the --grid box or raise --spacing-mm (the tables grow as the template grid's \
             voxels)"
        }
        _ => "coarsen the mesh (unfold mesh or --seg with a larger --size-mm, or --grade)",
    };
    crate::app::run::memory::check("flattening the placenta", &estimate, hint)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--size-mm` wins, `--dense` takes the voxel size, and otherwise the
    /// cube side from the mask's volume, capped at half its half
    /// thickness, unless that is finer than the voxels.
    #[test]
    fn the_seg_cube_side_follows_the_flags_and_the_mask() {
        let mut affine = nalgebra::Matrix4::identity();
        affine[(0, 0)] = 2.0;
        affine[(1, 1)] = 2.0;
        affine[(2, 2)] = 3.0;
        // A 40 x 40 x 12 block of 12 mm^3 voxels (80 x 80 x 36 mm) inside a
        // margin: (230,400 / 5,000)^(1/3) = 3.58 mm; half thickness about
        // 18 mm, so the volume rule holds.
        let (nx, nz) = (44, 16);
        let block = |x: usize, y: usize, z: usize| {
            (2..42).contains(&x) && (2..42).contains(&y) && (2..14).contains(&z)
        };
        let mut bits = Vec::new();
        for z in 0..nz {
            for y in 0..nx {
                for x in 0..nx {
                    bits.push(block(x, y, z));
                }
            }
        }
        let big = Volume::new([nx, nx, nz, 1], affine, bits).unwrap();
        let (side, from) = seg_cube_side(&big, None, false).unwrap();
        assert_eq!(from, SizeFrom::MaskVolume);
        let expected = (12.0 * (40 * 40 * 12) as f64 / SEG_CUBES as f64).cbrt();
        assert!((side - expected).abs() < 1e-12, "{side} vs {expected}");
        assert_eq!(
            seg_cube_side(&big, None, true).unwrap(),
            (2.0, SizeFrom::Voxel)
        );
        assert_eq!(
            seg_cube_side(&big, Some(7.5), true).unwrap(),
            (7.5, SizeFrom::Given)
        );
        // A sheet 3 voxels (9 mm) thick and 400 mm wide: the volume rule
        // gives 6.6 mm; the distance transform's 0.95 quantile is the middle
        // layer's 6 mm (two 3 mm voxels to the outside), so h / 2 = 3 mm.
        let (n, nz) = (200, 7);
        let mut bits = Vec::new();
        for z in 0..nz {
            for _ in 0..n * n {
                bits.push((2..5).contains(&z));
            }
        }
        let sheet = Volume::new([n, n, nz, 1], affine, bits).unwrap();
        assert_eq!(
            seg_cube_side(&sheet, None, false).unwrap(),
            (3.0, SizeFrom::Thickness)
        );
        // A few voxels: the voxel size.
        let mut bits = vec![false; nx * nx * nz];
        bits[..30].fill(true);
        let small = Volume::new([nx, nx, nz, 1], affine, bits).unwrap();
        assert_eq!(
            seg_cube_side(&small, None, false).unwrap(),
            (2.0, SizeFrom::Voxel)
        );
    }

    #[test]
    fn image_names_drop_the_nifti_extension() {
        assert_eq!(
            image_name(Path::new("a/bold.nii.gz")).as_deref(),
            Some("bold")
        );
        assert_eq!(image_name(Path::new("T2.NII")).as_deref(), Some("T2"));
        assert_eq!(image_name(Path::new("x.y.nii")).as_deref(), Some("x.y"));
        assert_eq!(image_name(Path::new(".nii")), None);
        assert_eq!(
            image_name(Path::new("a/brain.seg.nrrd")).as_deref(),
            Some("brain")
        );
        assert_eq!(image_name(Path::new("T1.NRRD")).as_deref(), Some("T1"));
        assert_eq!(image_name(Path::new("x.nhdr")).as_deref(), Some("x"));
        assert_eq!(image_name(Path::new(".seg.nrrd")), None);
        assert_eq!(image_name(Path::new("img.vtu")), None);
    }
}
