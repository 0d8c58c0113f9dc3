//! A deformation's files: REST (a tet or triangle mesh), the targets file,
//! INIT, HANDLES and the output mesh (its report `OUT.report.json` beside
//! it); checked before anything is read (something to do, no output over
//! an input, a full-precision output format), then read into [`Inputs`]
//! (an output format that holds REST's cells). HANDLES' format is in
//! [`super::fixed`].
//!
//! Targets file: CSV, one `vertex,x,y,z` per line (0-based vertex index,
//! coordinates in the mesh's units). Blank lines and lines starting with `#`
//! are ignored; the first remaining line may be the header `vertex,x,y,z`
//! (exactly those names, any case; any other non-numeric line is an error,
//! so a typo in the first data line is never mistaken for a header). Fields
//! may be surrounded by spaces. Every problem is reported with the file and
//! line: a wrong field count, a bad vertex index or coordinate (coordinates
//! must be finite), a vertex out of range, a vertex listed twice, no targets.

use super::fixed::parse_handles;
use super::shape::{Rest, check_same_cells, rest_of, start_of};
use crate::app::error::{AppError, at};
use crate::app::run::files::canonical;
use crate::io::{FileKind, read_mesh};
use crate::mesh::CellMesh;
use std::path::{Path, PathBuf};

/// The files of a deformation, as given.
#[derive(Debug, Clone, Default)]
pub struct Files {
    /// REST: the tet or triangle mesh of the rest shape.
    pub mesh: PathBuf,
    /// The targets file (soft targets), if any.
    pub targets: Option<PathBuf>,
    /// INIT: the start (REST's cells at other positions), if any.
    pub init: Option<PathBuf>,
    /// HANDLES: the fixed vertices, one index per line, if any.
    pub fixed: Option<PathBuf>,
    /// Whether every boundary vertex is fixed too.
    pub fixed_boundary: bool,
    /// The output mesh.
    pub output: PathBuf,
}

impl Files {
    /// The report beside the output: `OUT.report.json`.
    pub fn report(&self) -> PathBuf {
        report_path(&self.output)
    }

    /// The input files given: REST, then the targets, INIT and HANDLES.
    pub fn inputs(&self) -> Vec<&Path> {
        let mut v = vec![self.mesh.as_path()];
        v.extend(
            [&self.targets, &self.init, &self.fixed]
                .into_iter()
                .flatten()
                .map(PathBuf::as_path),
        );
        v
    }

    /// Checks the files before anything is read: there is something to do
    /// (targets, a start, or fixed vertices), neither output (the mesh or
    /// its report) is an input, and the output's format can be written
    /// with its positions in full precision (which cells it must hold is
    /// checked once REST is read, [`check_output_holds`]).
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the flags or the output, or an output
    /// whose kind is unknown.
    pub fn check(&self) -> Result<(), AppError> {
        if self.targets.is_none()
            && self.init.is_none()
            && self.fixed.is_none()
            && !self.fixed_boundary
            && !is_problem_file(&self.mesh)
        {
            return Err(AppError::Usage(
                "nothing to do: give --targets FILE, --init INIT, --fixed HANDLES or \
                 --fixed-boundary (see unfold deform --help)"
                    .into(),
            ));
        }
        let report_file = self.report();
        let (out, rep) = (canonical(&self.output), canonical(&report_file));
        for input in self.inputs() {
            let c = canonical(input);
            if c == out || c == rep {
                return Err(at(
                    if c == out { &self.output } else { &report_file },
                    "refusing to overwrite an input; choose another output path",
                ));
            }
        }
        match FileKind::from_path(&self.output)? {
            FileKind::Mesh(f) if f.writable() && !f.single_precision() => Ok(()),
            FileKind::Mesh(f) if f.writable() => Err(at(
                &self.output,
                "stores single-precision positions, so the fixed vertices would move; write \
                 .vtu, .vtk, .mesh, .ply, .obj or .off",
            )),
            _ => Err(at(
                &self.output,
                "is not a mesh format unfold writes; write .vtu, .vtk or .mesh",
            )),
        }
    }
}

/// Checks that the output `out` can hold the cells of `rest`: tets need a
/// volume format (.vtu .vtk .mesh); triangles any mesh format.
///
/// # Errors
/// [`AppError::Usage`] naming the output.
pub fn check_output_holds(out: &Path, rest: &Rest) -> Result<(), AppError> {
    match (FileKind::from_path(out)?, rest) {
        (FileKind::Mesh(f), Rest::Tets(_)) if !f.holds_volume_cells() => {
            Err(at(out, "cannot hold a tet mesh; write .vtu, .vtk or .mesh"))
        }
        _ => Ok(()),
    }
}

/// `path` with `.report.json` appended to its file name.
pub fn report_path(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".report.json");
    PathBuf::from(s)
}

/// What a deformation works on, read and checked.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// REST's name in messages and the report (its path, or what Python
    /// calls it).
    pub mesh: PathBuf,
    /// The targets' name in messages and the report, if any.
    pub targets: Option<PathBuf>,
    /// INIT's name in messages and the report, if any.
    pub init: Option<PathBuf>,
    /// HANDLES' name in messages and the report, if any.
    pub fixed_file: Option<PathBuf>,
    /// REST as read (its cells and arrays are the output's).
    pub cells: CellMesh,
    /// Its elements ([`rest_of`]).
    pub rest: Rest,
    /// `(vertex, target)` pairs, vertices of `cells`, each at most once.
    pub pairs: Vec<(usize, [f64; 3])>,
    /// The start from INIT ([`start_of`]), if any.
    pub start: Option<Vec<f64>>,
    /// The vertices of HANDLES, each once.
    pub handles: Vec<usize>,
    /// Whether every boundary vertex is fixed too.
    pub fixed_boundary: bool,
}

/// Reads REST (its tets or triangles, [`rest_of`]), then INIT (checked to
/// have REST's cells, [`check_same_cells`]; its positions the start,
/// [`start_of`]), HANDLES ([`parse_handles`]) and the targets file
/// ([`parse_targets`]), each if given.
///
/// # Errors
/// Reading any file, a REST that is neither tets nor triangles, a triangle
/// REST without INIT, an INIT with other cells or off the plane, a bad
/// HANDLES or targets file, an output that cannot hold REST's cells.
pub fn read(files: &Files) -> Result<Inputs, AppError> {
    if is_problem_file(&files.mesh) {
        return read_problem(files);
    }
    let cells = read_mesh(&files.mesh)?;
    let name = files.mesh.display().to_string();
    let rest = rest_of(&cells, &name)?;
    check_output_holds(&files.output, &rest)?;
    if matches!(rest, Rest::Triangles(_)) && files.init.is_none() {
        return Err(at(
            &files.mesh,
            "a triangle mesh is mapped to the plane: give its start with --init (REST's cells \
             at positions in z = 0)",
        ));
    }
    let n = rest.num_vertices();
    let start = match &files.init {
        Some(init) => {
            let init_cells = read_mesh(init)?;
            let init_name = init.display().to_string();
            check_same_cells(&cells, &init_cells, &init_name)?;
            Some(start_of(&rest, &init_cells.positions, &init_name)?)
        }
        None => None,
    };
    let (handles, pairs) = handles_and_targets(files, n)?;
    Ok(Inputs {
        mesh: files.mesh.clone(),
        targets: files.targets.clone(),
        init: files.init.clone(),
        fixed_file: files.fixed.clone(),
        cells,
        rest,
        pairs,
        start,
        handles,
        fixed_boundary: files.fixed_boundary,
    })
}

/// HANDLES' vertices and the targets file's pairs (each empty when the
/// file is not given), for a REST of `n` vertices.
fn handles_and_targets(files: &Files, n: usize) -> Result<HandlesAndTargets, AppError> {
    let handles = match &files.fixed {
        Some(f) => parse_handles(&read_text(f)?, f, n)?,
        None => Vec::new(),
    };
    let pairs = match &files.targets {
        Some(t) => parse_targets(&read_text(t)?, t, n)?,
        None => Vec::new(),
    };
    Ok((handles, pairs))
}

/// Fixed vertices and `(vertex, target)` pairs.
type HandlesAndTargets = (Vec<usize>, Vec<(usize, [f64; 3])>);

/// The text of the file `path`.
fn read_text(path: &Path) -> Result<String, AppError> {
    std::fs::read_to_string(path).map_err(|source| AppError::Fs {
        path: path.display().to_string(),
        source,
    })
}

/// Whether `path` names a problem file of the Locally Injective Mappings
/// benchmark (Du et al. 2020, "Lifting Simplices to Find Injectivity"):
/// extension `.input` or `.tlc` ([`crate::io::tlc`]).
pub fn is_problem_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("input") || e.eq_ignore_ascii_case("tlc"))
}

/// Reads a benchmark problem file as REST: its rest positions and cells,
/// its init positions as the start and its handles as fixed vertices
/// (with those of `--fixed`, if given). `--init` is refused beside it.
///
/// # Errors
/// Reading or parsing the file (its line named), `--init` given too, a
/// 2D init of tets, the HANDLES and targets files' errors.
fn read_problem(files: &Files) -> Result<Inputs, AppError> {
    use crate::io::tlc::{Cells, read_injectivity_problem};
    use crate::mesh::CellType;
    use crate::mesh::nalgebra::Point3;
    if files.init.is_some() {
        return Err(at(
            &files.mesh,
            "a benchmark problem file holds its own start; drop --init",
        ));
    }
    let problem = read_injectivity_problem(&files.mesh)?;
    let mut cells = CellMesh::from_points(problem.rest.iter().map(|p| Point3::from(*p)).collect());
    match &problem.cells {
        Cells::Triangles(t) => t
            .iter()
            .for_each(|c| cells.push_cell(CellType::Triangle, c)),
        Cells::Tets(t) => t.iter().for_each(|c| cells.push_cell(CellType::Tetra, c)),
    }
    let name = files.mesh.display().to_string();
    let rest = rest_of(&cells, &name)?;
    check_output_holds(&files.output, &rest)?;
    let init: Vec<Point3<f64>> = problem.init.iter().map(|p| Point3::from(*p)).collect();
    let start = start_of(&rest, &init, &name)?;
    let n = rest.num_vertices();
    let (mut handles, pairs) = handles_and_targets(files, n)?;
    handles.extend(problem.handles.iter().map(|&h| h as usize));
    handles.sort_unstable();
    handles.dedup();
    Ok(Inputs {
        mesh: files.mesh.clone(),
        targets: files.targets.clone(),
        init: Some(files.mesh.clone()),
        fixed_file: files.fixed.clone(),
        cells,
        rest,
        pairs,
        start: Some(start),
        handles,
        fixed_boundary: files.fixed_boundary,
    })
}

/// Parses the targets CSV `text` (from `file`, for messages) for a mesh of
/// `num_vertices` vertices: `(vertex, target)` pairs in file order (module
/// doc).
///
/// # Errors
/// [`AppError::Usage`] naming the file and the line.
pub fn parse_targets(
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

#[cfg(test)]
mod tests {
    use super::*;

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
