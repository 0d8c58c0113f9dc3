//! A deformation's files: the tet mesh, the targets file and the output
//! mesh (its report `OUT.report.json` beside it); checked before anything
//! is read (no output over an input, an output format that holds tets),
//! then read into [`Inputs`].
//!
//! Targets file: CSV, one `vertex,x,y,z` per line (0-based vertex index,
//! coordinates in the mesh's units). Blank lines and lines starting with `#`
//! are ignored; the first remaining line may be the header `vertex,x,y,z`
//! (exactly those names, any case; any other non-numeric line is an error,
//! so a typo in the first data line is never mistaken for a header). Fields
//! may be surrounded by spaces. Every problem is reported with the file and
//! line: a wrong field count, a bad vertex index or coordinate (coordinates
//! must be finite), a vertex out of range, a vertex listed twice, no targets.

use crate::app::error::{AppError, at};
use crate::app::run::files::canonical;
use crate::io::{FileKind, read_mesh};
use crate::mesh::{CellMesh, MeshError, TetMesh};
use std::path::{Path, PathBuf};

/// The files of a deformation, as given.
#[derive(Debug, Clone, Default)]
pub struct Files {
    /// The tet mesh: the rest state and the starting point.
    pub mesh: PathBuf,
    /// The targets file.
    pub targets: PathBuf,
    /// The output mesh.
    pub output: PathBuf,
}

impl Files {
    /// The report beside the output: `OUT.report.json`.
    pub fn report(&self) -> PathBuf {
        report_path(&self.output)
    }

    /// Checks the files before anything is read: neither output (the mesh
    /// or its report) is an input, and the output's format holds a tet
    /// mesh.
    ///
    /// # Errors
    /// [`AppError::Usage`] naming the output, or an output whose kind is
    /// unknown.
    pub fn check(&self) -> Result<(), AppError> {
        let report_file = self.report();
        let (out, rep) = (canonical(&self.output), canonical(&report_file));
        for input in [&self.mesh, &self.targets] {
            let c = canonical(input);
            if c == out || c == rep {
                return Err(at(
                    if c == out { &self.output } else { &report_file },
                    "refusing to overwrite an input; choose another output path",
                ));
            }
        }
        match FileKind::from_path(&self.output)? {
            FileKind::Mesh(f) if f.writable() && f.holds_volume_cells() => Ok(()),
            _ => Err(at(
                &self.output,
                "cannot hold a tet mesh; write .vtu, .vtk or .mesh",
            )),
        }
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
    /// The mesh's name in messages and the report (its path, or what
    /// Python calls it).
    pub mesh: PathBuf,
    /// The targets' name in messages and the report.
    pub targets: PathBuf,
    /// The mesh as read (its cells and arrays are the output's).
    pub cells: CellMesh,
    /// Its tets ([`tet_mesh_of`]).
    pub tets: TetMesh,
    /// `(vertex, target)` pairs, vertices of `cells`, each at most once.
    pub pairs: Vec<(usize, [f64; 3])>,
}

/// Reads the mesh (its tets, [`tet_mesh_of`]), then the targets file
/// ([`parse_targets`]).
///
/// # Errors
/// Reading either file, a mesh that is not a tet mesh, a bad targets file.
pub fn read(files: &Files) -> Result<Inputs, AppError> {
    let cells = read_mesh(&files.mesh)?;
    let tets = tet_mesh_of(&cells, &files.mesh)?;
    let n = tets.num_vertices();
    let text = std::fs::read_to_string(&files.targets).map_err(|source| AppError::Fs {
        path: files.targets.display().to_string(),
        source,
    })?;
    let pairs = parse_targets(&text, &files.targets, n)?;
    Ok(Inputs {
        mesh: files.mesh.clone(),
        targets: files.targets.clone(),
        cells,
        tets,
        pairs,
    })
}

/// The tets of `cells` (named `mesh` in messages).
///
/// # Errors
/// A mesh with other cells than tets ("not a tetrahedral mesh"), or bad
/// indices, at `mesh`.
pub fn tet_mesh_of(cells: &CellMesh, mesh: &Path) -> Result<TetMesh, AppError> {
    cells.to_tet_mesh().map_err(|e| match e {
        MeshError::WrongCellType { cell, found, .. } => at(
            mesh,
            format!(
                "not a tetrahedral mesh (cell {cell} is a {found:?}); unfold deform needs a tet mesh"
            ),
        ),
        e => at(mesh, e),
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
