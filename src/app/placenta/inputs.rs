//! A placenta run's files: the mesh (or the mask to mesh), the images to
//! pull into the template, the displacement field and the output
//! directory; checked before anything is read (no output over an input,
//! distinct image names), then read into [`Inputs`].

use super::errors::organ;
use super::seg::{SegReport, mesh_segmentation};
use super::settings::{DEFAULT_VOXEL_MM, Settings};
use crate::app::error::{AppError, at};
use crate::app::observer::Observer;
use crate::app::run::StagedOutputs;
use crate::app::run::columns::Column;
use crate::app::run::files::{canonical, read_image_checked};
use crate::app::run::frame::mesh_frame;
use crate::io::{Frame, NiftiImage, WriteOptions, read_mesh, write_mesh};
use crate::mesh::CellMesh;
use crate::organs::placenta::{PreparedMesh, prepare_mesh};
use std::path::{Path, PathBuf};

/// The fixed outputs in the output directory.
pub const ORIGINAL: &str = "original.vtu";
/// The flattened mesh.
pub const FLATTENED: &str = "flattened.vtu";
/// The report.
pub const REPORT: &str = "report.json";
/// The mesh of a `--seg` segmentation.
pub const SEG_MESH: &str = "mesh.vtu";

/// The files of a run, as given.
#[derive(Debug, Clone, Default)]
pub struct Files {
    /// The tet mesh (mm, scanner frame).
    pub mesh: Option<PathBuf>,
    /// Or a mask to mesh.
    pub seg: Option<PathBuf>,
    /// Images to pull into the template.
    pub images: Vec<PathBuf>,
    /// Where to write the map as an ITK displacement field.
    pub displacement: Option<PathBuf>,
    /// The output directory.
    pub output: PathBuf,
}

/// The files a placenta run takes by name (beside its [`super::Settings`]):
/// the mesh is the positional `input`.
pub const FILE_COLUMNS: &[Column] = &[
    Column::path("seg"),
    Column::path("image").repeated(),
    Column::path("displacement"),
];

/// An image to pull into the template.
#[derive(Debug, Clone)]
pub struct ImageInput {
    /// Where it came from (messages and the report).
    pub path: PathBuf,
    /// Its name: the output is `DIR/<name>_flat.nii.gz`.
    pub name: String,
    /// The image.
    pub image: NiftiImage,
}

/// What a run works on, read and checked.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// The mesh's name in messages and the report (its path, usually).
    pub label: String,
    /// The placenta tet mesh (mm, RAS), repaired and oriented.
    pub mesh: PreparedMesh,
    /// Images to pull into the template.
    pub images: Vec<ImageInput>,
    /// The frame the mesh file was in (it is in RAS now), for messages.
    pub frame: Frame,
    /// The default of `voxel_mm`: the mask's mean spacing, else 3 mm.
    pub voxel_mm: f64,
    /// How the mesh was made from a segmentation (then written as
    /// [`SEG_MESH`]).
    pub segmentation: Option<SegReport>,
}

/// `<name>` of an image file `<name>.nii`, `<name>.nii.gz`, `<name>.nrrd`,
/// `<name>.seg.nrrd` or `<name>.nhdr` (any case).
pub fn image_name(path: &Path) -> Option<String> {
    let name = path.file_name()?.to_str()?;
    let lower = name.to_ascii_lowercase();
    let ext = [".nii.gz", ".nii", ".seg.nrrd", ".nrrd", ".nhdr"]
        .iter()
        .find(|ext| lower.ends_with(*ext))?;
    (name.len() > ext.len()).then(|| name[..name.len() - ext.len()].to_string())
}

/// The output file of an image called `name`.
pub fn flat_name(name: &str) -> String {
    format!("{name}_flat.nii.gz")
}

/// Checks that no two images have the same name (so the same output).
///
/// # Errors
/// [`AppError::Usage`] naming both.
pub fn check_names<'a>(
    images: impl IntoIterator<Item = (&'a Path, &'a str)>,
) -> Result<(), AppError> {
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

impl Files {
    /// The mesh or the mask, whichever was given.
    ///
    /// # Errors
    /// [`AppError::Usage`] when neither or both are.
    pub fn input(&self) -> Result<&Path, AppError> {
        match (&self.mesh, &self.seg) {
            (Some(p), None) | (None, Some(p)) => Ok(p),
            _ => Err(AppError::Usage(
                "give a placenta tet mesh or --seg MASK (a segmentation to mesh)".into(),
            )),
        }
    }

    /// Checks the files before anything is read and returns the images'
    /// names: the output is a directory (or absent), every image has an
    /// image name and a distinct one, the displacement field is a NIfTI
    /// path, and no output (the displacement field included) is an input.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the file.
    pub fn check(&self) -> Result<Vec<String>, AppError> {
        let dir = self.output.as_path();
        if dir.exists() && !dir.is_dir() {
            return Err(at(
                dir,
                "exists and is not a directory; -o needs a directory (created if missing)",
            ));
        }
        let mut names = Vec::with_capacity(self.images.len());
        for p in &self.images {
            let name = image_name(p).ok_or_else(|| {
                at(
                    p,
                    "not a NIfTI or NRRD image name (expected .nii, .nii.gz, .nrrd, .seg.nrrd or .nhdr)",
                )
            })?;
            names.push(name);
        }
        check_names(
            self.images
                .iter()
                .zip(&names)
                .map(|(p, n)| (p.as_path(), n.as_str())),
        )?;
        let input = self.input()?;
        if let Some(d) = &self.displacement {
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
        let out_dir = canonical(dir);
        let mut outputs: Vec<String> = [ORIGINAL, FLATTENED, REPORT, SEG_MESH]
            .iter()
            .map(|s| s.to_string())
            .collect();
        outputs.extend(names.iter().map(|n| flat_name(n)));
        if let Some(d) = &self.displacement {
            let c = canonical(d);
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
        for input in std::iter::once(input).chain(self.images.iter().map(PathBuf::as_path)) {
            let c = canonical(input);
            if let Some(d) = &self.displacement
                && canonical(d) == c
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
        Ok(names)
    }
}

/// Reads and checks a run's inputs: the mesh turned into RAS (or the mask
/// meshed and written as `staging/mesh.vtu`), repaired and oriented
/// ([`prepare_mesh`]), then every image (within the memory budget), then
/// the flattening's memory predicted ([`super::memory::check_memory`]).
/// `names` are the images' names ([`Files::check`]).
///
/// # Errors
/// Reading or meshing a file, the mesh's problems, the memory checks.
pub fn read(
    settings: &Settings,
    files: &Files,
    names: Vec<String>,
    staging: &Path,
    staged: &StagedOutputs,
    observer: &mut dyn Observer,
) -> Result<Inputs, AppError> {
    let input = files.input()?;
    let label = input.display().to_string();
    let (mesh, frame, voxel_mm, segmentation) = match &files.seg {
        None => {
            let frame = mesh_frame(settings.mesh_frame, input)?;
            let cells = read_mesh(input)?;
            crate::app::run::units::refuse_mesh_larger_than_an_organ(input, &cells.positions)?;
            let mut mesh = cells.volume_tets().map_err(|e| at(input, e))?;
            // Into RAS: negate x and y of an LPS mesh (a half turn about z,
            // so no tet changes orientation).
            let signs = frame.to_ras_signs();
            for p in &mut mesh.positions {
                for a in 0..3 {
                    p[a] *= signs[a];
                }
            }
            (mesh, frame, DEFAULT_VOXEL_MM, None)
        }
        Some(seg) => {
            // A mask's mesh is made in the mask's world frame, RAS.
            let mesh_path = staging.join(SEG_MESH);
            let s = mesh_segmentation(settings, seg, &staged.shown(&mesh_path), observer)?;
            write_mesh(
                &mesh_path,
                &CellMesh::from(&s.mesh),
                &WriteOptions::default(),
            )
            .map_err(|e| staged.shown_error(e))?;
            (s.mesh, Frame::Ras, s.voxel_mm, Some(s.report))
        }
    };
    // Every setting checked against what the inputs imply.
    settings.config(
        voxel_mm,
        segmentation
            .as_ref()
            .map(|s: &SegReport| s.half_thickness_mm),
    )?;
    // Mesh problems first: an image cannot be judged against a broken mesh.
    let prepared = prepare_mesh(&mesh).map_err(|e| organ(&label, e))?;
    drop(mesh);
    let mut images = Vec::with_capacity(files.images.len());
    for (p, name) in files.images.iter().zip(names) {
        images.push(ImageInput {
            path: p.clone(),
            name,
            image: read_image_checked(p, 0.0)?,
        });
    }
    let spacings: Vec<[f64; 3]> = images.iter().map(|i| i.image.volume.spacing()).collect();
    super::memory::check_memory(
        &prepared.mesh,
        &spacings,
        settings.grid.as_ref(),
        files.displacement.is_some(),
    )?;
    Ok(Inputs {
        label,
        mesh: prepared,
        images,
        frame,
        voxel_mm,
        segmentation,
    })
}
