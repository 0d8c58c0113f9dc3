//! A ventricle run's files: the anatomy, the enclosing surface S (or none:
//! S built from the anatomy), the landmarks, the second heart of a
//! transfer and the output directory; checked before anything is read
//! (no output over an input), then read into [`Inputs`].

use super::landmarks::HeartLandmarks;
use super::settings::Settings;
use crate::app::error::{AppError, about, at, positive};
use crate::app::observer::Observer;
use crate::app::run::columns::Column;
use crate::app::run::files::canonical;
use crate::app::run::frame::{MeshFrame, mesh_frame, to_ras};
use crate::io::{read_mesh, read_tri_mesh};
use crate::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
use crate::mesh::{CellMesh, Field, TriMesh};
use crate::organs::ventricle::LandmarkPoints;
use crate::organs::ventricle::enclosing::EnclosingReport;
use crate::organs::ventricle::rv_landmarks::FromRv;
use std::path::{Path, PathBuf};

/// The anatomy in the cylinder.
pub const NORMALIZED: &str = "normalized.vtu";
/// The input anatomy with the cylinder's arrays.
pub const ANATOMY: &str = "anatomy.vtu";
/// S flattened.
pub const DISK: &str = "disk.vtu";
/// The anatomy carried into the second heart.
pub const TRANSFERRED: &str = "transferred.vtu";
/// The LV's AHA-segment table (not written for the RV).
pub const AHA_SEGMENTS: &str = "aha_segments.csv";
/// The report.
pub const REPORT: &str = "report.json";

/// The files of a run, as given.
#[derive(Debug, Clone, Default)]
pub struct Files {
    /// The anatomy inside S (any mesh file), mm.
    pub anatomy: PathBuf,
    /// The enclosing surface S (none: built from the anatomy).
    pub surface: Option<PathBuf>,
    /// The landmarks of S.
    pub heart: HeartLandmarks,
    /// The enclosing surface of a second heart to transfer the anatomy
    /// into.
    pub to_surface: Option<PathBuf>,
    /// The second heart's landmarks (no RV insertion points).
    pub to: HeartLandmarks,
    /// The output directory.
    pub output: PathBuf,
}

/// The files and landmarks a ventricle run takes by name (beside its
/// [`super::Settings`]): the anatomy is the positional `input`.
pub const FILE_COLUMNS: &[Column] = &[
    Column::path("surface"),
    Column::value("anterior"),
    Column::value("inferior"),
    Column::value("rv-landmarks").repeated(),
    Column::value("apex"),
    Column::path("landmarks"),
    Column::value("rim-near"),
    Column::path("to-surface"),
    Column::value("to-anterior"),
    Column::value("to-inferior"),
    Column::value("to-apex"),
    Column::path("to-landmarks"),
    Column::value("to-rim-near"),
];

impl Files {
    /// The input files, in the order the outputs are checked against
    /// them: the anatomy, S, S2, the landmarks files.
    pub fn inputs(&self) -> Vec<&Path> {
        let mut inputs = vec![self.anatomy.as_path()];
        inputs.extend(self.surface.as_deref());
        inputs.extend(self.to_surface.as_deref());
        inputs.extend(self.heart.landmarks.as_deref());
        inputs.extend(self.to.landmarks.as_deref());
        inputs
    }

    /// Checks the files before anything is read: the output is a
    /// directory (or absent), a second surface has its rim landmarks, and
    /// no output is an input.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the file or the flags.
    pub fn check(&self) -> Result<(), AppError> {
        let out = self.output.as_path();
        if out.exists() && !out.is_dir() {
            return Err(at(
                out,
                "exists and is not a directory; -o needs a directory (created if missing)",
            ));
        }
        if self.to_surface.is_some()
            && self.to.landmarks.is_none()
            && (self.to.anterior.is_none() || self.to.inferior.is_none())
        {
            return Err(AppError::Usage(
                "--to-surface needs --to-anterior and --to-inferior (the second heart's rim \
                 landmarks) or --to-landmarks FILE"
                    .into(),
            ));
        }
        check_not_inputs(out, &self.inputs())
    }
}

/// Refuses an output directory whose files would overwrite an input.
fn check_not_inputs(dir: &Path, inputs: &[&Path]) -> Result<(), AppError> {
    let d = canonical(dir);
    for input in inputs {
        let c = canonical(input);
        for f in [NORMALIZED, ANATOMY, DISK, TRANSFERRED, AHA_SEGMENTS, REPORT] {
            if d.join(f) == c {
                return Err(at(
                    input,
                    format!(
                        "is an input and would be overwritten by the output {f}; choose another -o"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The second heart of a transfer.
#[derive(Debug, Clone)]
pub struct Transfer {
    /// Its name in messages and the report (its path, usually).
    pub label: String,
    /// Its enclosing surface.
    pub surface: TriMesh,
    /// Its landmarks.
    pub landmarks: LandmarkPoints,
}

impl Transfer {
    /// A hemisphere of radius `r` mm as the second heart ([`hemisphere`]),
    /// called `the hemisphere of radius R mm`.
    ///
    /// # Errors
    /// A usage error of `--to-hemisphere` for a radius that is not finite
    /// and > 0, or a shape that cannot be built.
    pub fn hemisphere(r: f64) -> Result<Transfer, AppError> {
        let h = hemisphere(positive("--to-hemisphere", r)?)?;
        Ok(Transfer {
            label: format!("the hemisphere of radius {r} mm"),
            surface: h.surface,
            landmarks: LandmarkPoints {
                anterior: h.anterior,
                inferior: h.inferior,
                apex: Some(h.apex),
                rim_near: None,
            },
        })
    }
}

/// The hemisphere of radius `r` (mm) as an enclosing surface: the built-in
/// cup with equal radius and length, cut at the equator (its base centre at
/// the origin, apex on +z).
///
/// # Errors
/// The shape's, as a usage error of `--to-hemisphere`.
pub fn hemisphere(r: f64) -> Result<VentricleShape, AppError> {
    ventricle_cup(&VentricleParams {
        radius: r,
        length: r,
        base_above_equator: 0.0,
        anatomy_point_depth: 0.05 * r,
        anatomy_surface_depth: 0.1 * r,
        rings: 40,
        ..VentricleParams::default()
    })
    .map_err(|e| AppError::Usage(format!("--to-hemisphere {r}: {e}")))
}

/// What a run works on, read and checked.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// The anatomy's name in messages and the report (its path, usually).
    pub anatomy_label: String,
    /// The anatomy (points mapped, cells kept), RAS mm.
    pub anatomy: CellMesh,
    /// S's name in messages and the report.
    pub surface_label: String,
    /// The enclosing surface S, RAS mm.
    pub surface: TriMesh,
    /// The landmarks of S.
    pub landmarks: LandmarkPoints,
    /// How `--rv-landmarks` gave the rim landmarks, for the report.
    pub from_rv: Option<FromRv>,
    /// How S was built from the anatomy (then written as `surface.vtu`).
    pub enclosing: Option<EnclosingReport>,
    /// A transfer into a second heart, when asked for.
    pub transfer: Option<Transfer>,
}

/// Reads an enclosing surface S and turns it into RAS (`frame`).
///
/// # Errors
/// Reading the file; a frame marker that contradicts `frame`.
pub fn read_surface(path: &Path, frame: MeshFrame) -> Result<TriMesh, AppError> {
    let mut m = read_tri_mesh(path)?;
    crate::app::run::units::refuse_mesh_larger_than_an_organ(path, &m.positions)?;
    to_ras(mesh_frame(frame, path)?, &mut m.positions);
    Ok(m)
}

/// The point array `name` of `anatomy` (called `label` in messages) for
/// the bull's-eye: one value per point.
///
/// # Errors
/// [`AppError::Usage`] when the anatomy has no such array, or it has more
/// than one component.
pub fn bullseye_field<'a>(
    anatomy: &'a CellMesh,
    name: &str,
    label: &str,
) -> Result<&'a Field, AppError> {
    match anatomy.point_data.get(name) {
        None => Err(about(
            label,
            format!("has no point array {name:?} for the bull's-eye"),
        )),
        Some(f) if f.components() != 1 => Err(about(
            label,
            format!(
                "point array {name:?} has {} components; the bull's-eye needs 1",
                f.components()
            ),
        )),
        Some(f) => Ok(f),
    }
}

/// Reads and checks a run's inputs: the anatomy (into RAS; it must have
/// points, and the bull's-eye's array is checked before any work), S (read,
/// or built from the anatomy, [`super::surface::build`]), the second heart
/// (a surface file or the hemisphere of `to_hemisphere`), and the
/// landmarks on S ([`HeartLandmarks::on_surface`]; those S was built with
/// are carried onto its rim). Tells `observer` what was read.
///
/// # Errors
/// Reading a file, building S, the landmarks, `--to-hemisphere`.
pub fn read(
    settings: &Settings,
    files: &Files,
    observer: &mut dyn Observer,
) -> Result<Inputs, AppError> {
    let path = files.anatomy.as_path();
    let mut anatomy = read_mesh(path)?;
    crate::app::run::units::refuse_mesh_larger_than_an_organ(path, &anatomy.positions)?;
    to_ras(
        mesh_frame(settings.mesh_frame, path)?,
        &mut anatomy.positions,
    );
    if anatomy.positions.is_empty() {
        return Err(at(
            path,
            "has no points; the anatomy to map is a mesh or points inside S",
        ));
    }
    let anatomy_label = path.display().to_string();
    // The bull's-eye's array is checked before any work, not after it.
    if let Some(name) = &settings.bullseye_array {
        bullseye_field(&anatomy, name, &anatomy_label)?;
    }
    let (surface, built) = match &files.surface {
        Some(p) => (read_surface(p, settings.mesh_frame)?, None),
        None => {
            let given = files.heart.for_building()?;
            let b = super::surface::build(
                &settings.enclosing,
                &anatomy,
                &anatomy_label,
                &given,
                observer,
            )?;
            (b.surface, Some((b.rim_landmarks, b.report)))
        }
    };
    let to_surface = match &files.to_surface {
        Some(p) => Some(read_surface(p, settings.mesh_frame)?),
        None => None,
    };
    let hemisphere = match settings.to_hemisphere {
        Some(r) => Some(Transfer::hemisphere(r)?),
        None => None,
    };
    let surface_label = match &files.surface {
        Some(p) => p.display().to_string(),
        None => format!("S built from {}", path.display()),
    };
    let (mut landmarks, from_rv) = files.heart.on_surface(
        &surface,
        &surface_label,
        settings.chart.chamber,
        settings.chart.snap_mm,
    )?;
    if let (Some((rim, _)), None) = (&built, &from_rv) {
        // the given rim landmarks lie on the anatomy's rim: carried to S's
        [landmarks.anterior, landmarks.inferior] = *rim;
    }
    let transfer = match (to_surface, hemisphere, &files.to_surface) {
        (Some(surface), _, Some(p)) => Some(Transfer {
            label: p.display().to_string(),
            surface,
            landmarks: files
                .to
                .points("--to-anterior and --to-inferior or --to-landmarks FILE")?,
        }),
        (None, Some(h), _) => Some(h),
        _ => None,
    };
    observer.progress(&format!(
        "ventricle: read {} ({} points, {} cells) and {}",
        anatomy_label,
        anatomy.positions.len(),
        anatomy.num_cells(),
        surface_label
    ));
    Ok(Inputs {
        anatomy_label,
        anatomy,
        surface_label,
        surface,
        landmarks,
        from_rv,
        enclosing: built.map(|(_, report)| report),
        transfer,
    })
}
