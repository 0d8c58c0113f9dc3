//! A mitral run's files: the two leaflets and the annulus ring of one
//! valve (or a directory of time steps, [`series_steps`]) and the output
//! directory; checked before anything is read (no output over an input),
//! then read into [`Inputs`].
//!
//! A leaflet is any surface mesh file (its triangles; lines and points
//! are dropped). The annulus ring is a closed polyline in a mesh file (one
//! polyline cell, or 2-point line segments that chain into one ring;
//! `.vtu`, `.vtp`, `.vtk`, `.obj`, ...), a file of points only (in ring
//! order), or a text file (`.csv`, `.txt`, `.xyz`) with one `x,y,z` (or
//! `x y z`) per line. Without a ring file, the ring is found from the
//! places where the leaflets' boundaries meet
//! ([`annulus_from_leaflets`]).

use super::seg::{SegFiles, check_no_labels, refuse_closed, refuse_image};
use super::series::steps::series_steps;
use super::settings::Settings;
use crate::app::error::{AppError, at, organ};
use crate::app::run::StagedOutputs;
use crate::app::run::columns::Column;
use crate::app::run::files::canonical;
use crate::io::read_mesh;
use crate::mesh::nalgebra::Point3;
use crate::mesh::{CellMesh, CellType, TriMesh};
use crate::organs::mitral::{Pipeline, annulus_from_leaflets};
use std::path::{Path, PathBuf};

/// Both leaflets in 3D with every map, anterior first.
pub const VALVE3D: &str = "valve3d.vtu";
/// The same laid out at `(u, v, 0)`.
pub const VALVE2D: &str = "valve2d.vtu";
/// The report.
pub const REPORT: &str = "report.json";
/// The files of one valve's output directory, in the order they are
/// written (the figures aside).
pub const OUTPUTS: [&str; 3] = [VALVE3D, VALVE2D, REPORT];

/// The files of a run, as given: one valve's, or a series directory's.
#[derive(Debug, Clone, Default)]
pub struct Files {
    /// The anterior leaflet.
    pub anterior: Option<PathBuf>,
    /// The posterior leaflet.
    pub posterior: Option<PathBuf>,
    /// The annulus ring (none: found from the leaflets).
    pub annulus: Option<PathBuf>,
    /// Or a directory of time steps.
    pub series: Option<PathBuf>,
    /// Or a label map (`--seg`).
    pub seg: Option<PathBuf>,
    /// The output directory.
    pub output: PathBuf,
}

/// The files a mitral run takes by name (beside its [`super::Settings`]);
/// it takes no positional input.
pub const FILE_COLUMNS: &[Column] = &[
    Column::path("anterior"),
    Column::path("posterior"),
    Column::path("annulus"),
    Column::path("series"),
    Column::path("seg"),
];

/// What [`Files::check`] found to run.
#[derive(Debug, Clone)]
pub enum Job {
    /// One valve.
    Valve(ValveFiles),
    /// The steps of a series directory, in order.
    Series(Vec<Step>),
    /// One valve from a label map.
    Seg(SegFiles),
}

/// One step of a series: its output directory's name and its files.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// `step_000`, `step_001`, ... in the series' order: the step's
    /// directory in the output directory.
    pub name: String,
    /// The step's files.
    pub files: ValveFiles,
}

impl Files {
    /// Checks the files before any is read: the output is a directory (or
    /// absent); then a series' steps are found in its directory
    /// ([`series_steps`]), or one valve's leaflets must be given and no output of
    /// its directory may be one of its inputs.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the file, or the series directory's
    /// problems.
    pub fn check(&self) -> Result<Job, AppError> {
        let out = self.output.as_path();
        if out.exists() && !out.is_dir() {
            return Err(at(
                out,
                "exists and is not a directory; -o needs a directory",
            ));
        }
        if let Some(seg) = &self.seg {
            if self.anterior.is_some() || self.posterior.is_some() || self.series.is_some() {
                return Err(AppError::Usage(
                    "--seg LABELS takes the leaflets from the label map: leave out --anterior, \
                     --posterior and --series"
                        .into(),
                ));
            }
            check_not_inputs(out, &[seg])?;
            return Ok(Job::Seg(SegFiles { seg: seg.clone() }));
        }
        if let Some(series) = &self.series {
            let steps = series_steps(series)?
                .into_iter()
                .enumerate()
                .map(|(i, s)| Step {
                    name: format!("step_{i:03}"),
                    files: ValveFiles {
                        anterior: s.anterior,
                        posterior: s.posterior,
                        annulus: s.annulus,
                    },
                })
                .collect();
            return Ok(Job::Series(steps));
        }
        let (Some(anterior), Some(posterior)) = (&self.anterior, &self.posterior) else {
            return Err(AppError::Usage(
                "give --anterior and --posterior (and --annulus, or it is found from the \
                 leaflets), --series DIR, or a label map: --seg LABELS --anterior-label A \
                 --posterior-label P"
                    .into(),
            ));
        };
        let files = ValveFiles {
            anterior: anterior.clone(),
            posterior: posterior.clone(),
            annulus: self.annulus.clone(),
        };
        check_not_inputs(out, &files.paths())?;
        Ok(Job::Valve(files))
    }
}

/// One valve's input files.
#[derive(Debug, Clone, PartialEq)]
pub struct ValveFiles {
    /// The anterior leaflet.
    pub anterior: PathBuf,
    /// The posterior leaflet.
    pub posterior: PathBuf,
    /// The annulus ring (none: found from the leaflets).
    pub annulus: Option<PathBuf>,
}

impl ValveFiles {
    /// `anterior + posterior + annulus` (or `anterior + posterior (annulus
    /// from the leaflets)`), naming the inputs in errors and reports.
    pub fn label(&self) -> String {
        let ring = match &self.annulus {
            Some(r) => format!(" + {}", r.display()),
            None => " (annulus from the leaflets)".into(),
        };
        format!(
            "{} + {}{ring}",
            self.anterior.display(),
            self.posterior.display(),
        )
    }

    /// The input files (the annulus when given).
    pub fn paths(&self) -> Vec<&PathBuf> {
        let mut v = vec![&self.anterior, &self.posterior];
        v.extend(&self.annulus);
        v
    }

    /// The files as `out` will show them after its commit.
    pub fn shown(&self, out: &StagedOutputs) -> ValveFiles {
        ValveFiles {
            anterior: out.shown(&self.anterior),
            posterior: out.shown(&self.posterior),
            annulus: self.annulus.as_ref().map(|r| out.shown(r)),
        }
    }
}

/// Refuses an output directory `dir` whose files ([`OUTPUTS`]) would
/// overwrite one of `inputs`.
///
/// # Errors
/// [`AppError::Usage`] naming the input.
pub fn check_not_inputs(dir: &Path, inputs: &[&PathBuf]) -> Result<(), AppError> {
    let d = canonical(dir);
    for input in inputs {
        let c = canonical(input);
        for f in OUTPUTS {
            if d.join(f) == c {
                return Err(at(
                    input,
                    format!("is an input and would be overwritten by the output {f}"),
                ));
            }
        }
    }
    Ok(())
}

/// One valve, read and checked.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// The inputs' name in messages and the report ([`ValveFiles::label`],
    /// or what Python calls the valve).
    pub label: String,
    /// The anterior leaflet.
    pub anterior: TriMesh,
    /// The posterior leaflet.
    pub posterior: TriMesh,
    /// The annulus ring's points in ring order.
    pub ring: Vec<Point3<f64>>,
}

/// Reads one valve's leaflets, then its ring (from its file, or found from
/// the leaflets' shared boundary with `pipeline`'s tolerance); `label`
/// names the inputs in messages and the report.
///
/// # Errors
/// Reading a file, a leaflet that is not a triangle surface, a ring that
/// is not one ring, or no ring found from the leaflets (about `label`).
pub fn read(files: &ValveFiles, label: String, pipeline: &Pipeline) -> Result<Inputs, AppError> {
    let anterior = read_leaflet(&files.anterior)?;
    let posterior = read_leaflet(&files.posterior)?;
    let ring = match &files.annulus {
        Some(path) => read_ring(path)?,
        None => annulus_from_leaflets(&anterior, &posterior, pipeline.settings().tolerance_mm)
            .map(|f| f.ring)
            .map_err(|e| organ(&label, e))?,
    };
    Ok(Inputs {
        label,
        anterior,
        posterior,
        ring,
    })
}

/// A leaflet file as a triangle mesh (surface cells only; lines and points
/// are dropped, volume cells are an error).
///
/// # Errors
/// Reading the file, or [`leaflet_of`]'s.
pub fn read_leaflet(path: &Path) -> Result<TriMesh, AppError> {
    refuse_image(path)?;
    let cells = read_mesh(path)?;
    crate::app::run::units::refuse_mesh_larger_than_an_organ(path, &cells.positions)?;
    let mesh = leaflet_of(&cells, path)?;
    refuse_closed(&mesh, &path.display().to_string())?;
    Ok(mesh)
}

/// Checks `settings` against the job: the label flags only with `--seg`.
///
/// # Errors
/// [`AppError::Usage`] naming the flag.
pub fn check_settings(job: &Job, settings: &Settings) -> Result<(), AppError> {
    match job {
        Job::Seg(_) => super::seg::labels_of(settings).map(|_| ()),
        _ => check_no_labels(settings),
    }
}

/// The leaflet in `cells` (named `path` in messages) as a triangle mesh:
/// its surface cells and point arrays (lines and points are dropped).
///
/// # Errors
/// Volume cells, no triangles, or cells that do not make a triangle mesh,
/// at `path`.
pub fn leaflet_of(cells: &CellMesh, path: &Path) -> Result<TriMesh, AppError> {
    let mut surface = CellMesh::from_points(cells.positions.clone());
    let mut volume = 0;
    for (t, vs) in cells.cells() {
        match t.dimension() {
            2 => surface.push_cell(t, vs),
            3 => volume += 1,
            _ => {}
        }
    }
    if volume > 0 {
        return Err(at(
            path,
            format!(
                "has {volume} volume cell(s); a leaflet is a triangle surface; {}",
                super::seg::SEG_ROUTE
            ),
        ));
    }
    if surface.num_cells() == 0 {
        return Err(at(
            path,
            "has no triangles; a leaflet is a triangle surface",
        ));
    }
    surface.point_data = cells.point_data.clone();
    surface.to_tri_mesh().map_err(|e| at(path, e))
}

/// Parses `x,y,z` (or whitespace-separated) lines; blank lines, `#`
/// comments and one non-numeric header line are skipped.
fn parse_points(text: &str, path: &Path) -> Result<Vec<Point3<f64>>, AppError> {
    let mut points = Vec::new();
    let mut header_allowed = true;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        let nums: Result<Vec<f64>, _> = fields.iter().map(|f| f.parse::<f64>()).collect();
        match nums {
            Ok(v) if v.len() == 3 => {
                if !v.iter().all(|x| x.is_finite()) {
                    return Err(at(
                        path,
                        format!("line {}: a coordinate is not finite", i + 1),
                    ));
                }
                points.push(Point3::new(v[0], v[1], v[2]));
            }
            Ok(v) => {
                return Err(at(
                    path,
                    format!("line {}: expected 3 coordinates, found {}", i + 1, v.len()),
                ));
            }
            Err(_) if header_allowed => {}
            Err(_) => {
                return Err(at(
                    path,
                    format!("line {}: not three numbers: {line:?}", i + 1),
                ));
            }
        }
        header_allowed = false;
    }
    Ok(points)
}

/// The annulus ring's points in ring order, from a text file of points
/// (`.csv`, `.txt`, `.xyz`) or a mesh file (one closed polyline, 2-point
/// segments that chain into one ring, or points only).
///
/// # Errors
/// Reading the file; a bad line; no polyline, several, or segments that
/// are not one ring.
pub fn read_ring(path: &Path) -> Result<Vec<Point3<f64>>, AppError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if matches!(ext.as_str(), "csv" | "txt" | "xyz") {
        let text = std::fs::read_to_string(path).map_err(|source| AppError::Fs {
            path: path.display().to_string(),
            source,
        })?;
        return parse_points(&text, path);
    }
    let cells = read_mesh(path)?;
    crate::app::run::units::refuse_mesh_larger_than_an_organ(path, &cells.positions)?;
    let lines = cells.polylines();
    match lines.len() {
        1 => Ok(lines[0]
            .iter()
            .map(|&v| cells.positions[v as usize])
            .collect()),
        0 => {
            let only_points = cells
                .cells()
                .all(|(t, _)| t == CellType::Vertex || t == CellType::PolyVertex);
            if only_points {
                Ok(cells.positions.clone())
            } else {
                Err(at(
                    path,
                    "has no polyline; the annulus ring is one closed polyline (or its points in order)",
                ))
            }
        }
        // Separate 2-point segments (as meshio and many tools write a
        // curve) are chained into the ring.
        n if lines.iter().all(|l| l.len() == 2) => {
            let segments: Vec<[u32; 2]> = lines.iter().map(|l| [l[0], l[1]]).collect();
            let order = crate::mesh::chain::chain_segments(&segments)
                .map_err(|e| at(path, format!("its {n} line segments are not one ring: {e}")))?;
            Ok(order.iter().map(|&v| cells.positions[v as usize]).collect())
        }
        n => Err(at(
            path,
            format!("has {n} polylines; the annulus ring is one closed polyline"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_text_accepts_commas_spaces_comments_and_a_header() {
        let p = Path::new("ring.csv");
        let pts = parse_points("# ring\nx,y,z\n1,2,3\n4 5 6\n\n7;8;9\n", p).unwrap();
        assert_eq!(pts.len(), 3);
        assert_eq!(pts[1], Point3::new(4.0, 5.0, 6.0));
        let e = parse_points("1,2,3\n4,5\n", p).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("3 coordinates"), "{e}");
        let e = parse_points("1,2,3\nx,y,z\n", p).unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        let e = parse_points("1,2,nan\n", p).unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
    }
}
