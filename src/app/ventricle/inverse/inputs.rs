//! The files of `ventricle-inverse`: the mesh in cylinder coordinates, the
//! target heart's S and landmarks, the output directory; checked before
//! anything is read (no output over an input), then read into [`Inputs`].

use super::settings::Settings;
use crate::app::AppError;
use crate::app::error::at;
use crate::app::run::files::canonical;
use crate::app::ventricle::inputs::read_surface;
use crate::app::ventricle::landmarks::HeartLandmarks;
use crate::io::read_mesh;
use crate::mesh::{CellMesh, TriMesh};
use crate::organs::ventricle::LandmarkPoints;
use crate::organs::ventricle::rv_landmarks::FromRv;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The mesh carried onto the heart.
pub const MAPPED: &str = "mapped.vtu";
/// The report.
pub const REPORT: &str = "report.json";

/// The files of a run, as given.
#[derive(Debug, Clone, Default)]
pub struct Files {
    /// The mesh in normalized coordinates (any mesh file).
    pub normalized: PathBuf,
    /// The enclosing surface S of the target heart.
    pub surface: PathBuf,
    /// S's landmarks.
    pub heart: HeartLandmarks,
    /// The output directory.
    pub output: PathBuf,
}

impl Files {
    /// The input files: the mesh, S, the landmarks file.
    pub fn inputs(&self) -> Vec<&Path> {
        let mut inputs = vec![self.normalized.as_path(), self.surface.as_path()];
        inputs.extend(self.heart.landmarks.as_deref());
        inputs
    }

    /// Checks the files before anything is read: the output is a
    /// directory (or absent) and no output is an input.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the file.
    pub fn check(&self) -> Result<(), AppError> {
        let out = self.output.as_path();
        if out.exists() && !out.is_dir() {
            return Err(at(
                out,
                "exists and is not a directory; -o needs a directory (created if missing)",
            ));
        }
        let d = canonical(out);
        for input in self.inputs() {
            for f in [MAPPED, REPORT] {
                if d.join(f) == canonical(input) {
                    return Err(at(
                        input,
                        format!(
                            "is an input and would be overwritten by the output {f}; choose \
                             another -o"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// What a run works on, read.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// The mesh in cylinder coordinates.
    pub normalized: CellMesh,
    /// What messages and the report call it.
    pub normalized_label: String,
    /// The target heart's S, RAS mm.
    pub surface: TriMesh,
    /// What messages and the report call S.
    pub surface_label: String,
    /// S's landmarks.
    pub landmarks: LandmarkPoints,
    /// The RV insertion points they came from, if so.
    pub from_rv: Option<FromRv>,
    /// When the run started (for `seconds.total`).
    pub started: Instant,
}

/// Reads the mesh in cylinder coordinates (not converted), S (into RAS)
/// and S's landmarks ([`HeartLandmarks::on_surface`]); `started` is when
/// the run started.
///
/// # Errors
/// Reading a file; the landmarks'.
pub fn read(settings: &Settings, files: &Files, started: Instant) -> Result<Inputs, AppError> {
    let normalized = read_mesh(&files.normalized)?;
    let normalized_label = files.normalized.display().to_string();
    let surface = read_surface(&files.surface, settings.mesh_frame)?;
    let surface_label = files.surface.display().to_string();
    let (landmarks, from_rv) = files.heart.on_surface(
        &surface,
        &surface_label,
        settings.chart.chamber,
        settings.chart.snap_mm,
    )?;
    Ok(Inputs {
        normalized,
        normalized_label,
        surface,
        surface_label,
        landmarks,
        from_rv,
        started,
    })
}
