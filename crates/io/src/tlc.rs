//! The injectivity benchmark's problem file (Du et al. 2020, "Lifting
//! Simplices to Find Injectivity", the TLC-QN and TLC-PN programs): one text
//! file holding a rest mesh, an initial embedding, the simplices and the
//! handle vertices.
//!
//! The file is four blocks, each a header line of counts followed by that
//! many rows of whitespace-separated values:
//!
//! ```text
//! num_rest_vertices rest_dim        rest_dim 2 or 3
//! ... one row of rest_dim numbers per vertex ...
//! num_init_vertices init_dim        num_init_vertices = num_rest_vertices
//! ... one row of init_dim numbers per vertex ...
//! num_simplices simplex_size        3 (triangles) or 4 (tets)
//! ... one row of simplex_size 0-based vertex indices per simplex ...
//! num_handles
//! ... one 0-based vertex index per row ...
//! ```
//!
//! TLC-QN's inputs may end with two more lines, the name of the initializer
//! that made the embedding (`harmonic` or `tutte-uniform`) and the energy's
//! `alpha`; they are accepted and ignored. Triangles map into the plane
//! (`init_dim = 2`, the rest is planar or a surface in 3D); tets map 3D to
//! 3D (`rest_dim = init_dim = 3`). Blank lines are skipped. Every problem is
//! a typed [`TlcError`] carrying its 1-based line, inside
//! [`IoError::Tlc`] naming the file.
//!
//! [`write_injectivity_problem`] writes the same layout (tab-separated, the
//! shortest decimal that reads back to the same `f64`), so a problem
//! round-trips bit for bit.

use crate::error::{FilePath, IoError};
use crate::format::atomic_write;
use std::fmt::Write as _;
use std::path::Path;
use thiserror::Error;

/// The simplices of a problem: all triangles or all tets.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Cells {
    /// Triangles (simplex size 3), mapped into the plane.
    Triangles(Vec<[u32; 3]>),
    /// Tetrahedra (simplex size 4), mapped 3D to 3D.
    Tets(Vec<[u32; 4]>),
}

impl Cells {
    /// The number of simplices.
    pub fn len(&self) -> usize {
        match self {
            Cells::Triangles(t) => t.len(),
            Cells::Tets(t) => t.len(),
        }
    }

    /// Whether there are no simplices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The number of vertices per simplex: 3 or 4.
    pub fn simplex_size(&self) -> usize {
        match self {
            Cells::Triangles(_) => 3,
            Cells::Tets(_) => 4,
        }
    }
}

/// One problem of the injectivity benchmark: find positions for every
/// vertex such that every simplex is positively oriented, starting from
/// `init`, with the `handles` kept exactly at their `init` positions.
#[derive(Debug, Clone, PartialEq)]
pub struct InjectivityProblem {
    /// Rest positions; `z = 0` when the rest is 2D.
    pub rest: Vec<[f64; 3]>,
    /// The rest's dimension in the file: 2 or 3.
    pub rest_dim: usize,
    /// Initial positions, one per rest vertex; `z = 0` when 2D.
    pub init: Vec<[f64; 3]>,
    /// The initial embedding's dimension: 2 for triangles, 3 for tets.
    pub init_dim: usize,
    /// The simplices (0-based vertex indices).
    pub cells: Cells,
    /// The handle vertices, in file order, without repeats.
    pub handles: Vec<u32>,
}

impl InjectivityProblem {
    /// The signed content of simplex `c` in `init`: for a triangle the
    /// signed area `((b - a) x (c - a))_z / 2` in the plane, for a tet the
    /// signed volume `(b - a) . ((c - a) x (d - a)) / 6`. Positive is
    /// correctly oriented.
    pub fn init_signed_content(&self, c: usize) -> f64 {
        let p = |i: u32| self.init[i as usize];
        match &self.cells {
            Cells::Triangles(t) => {
                let [a, b, c] = t[c].map(p);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            }
            Cells::Tets(t) => {
                let [a, b, c, d] = t[c].map(p);
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
                (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
                    + u[2] * (v[0] * w[1] - v[1] * w[0]))
                    / 6.0
            }
        }
    }

    /// How many simplices are not positively oriented in `init` (signed
    /// content `<= 0`, [`Self::init_signed_content`]).
    pub fn inverted_in_init(&self) -> usize {
        (0..self.cells.len())
            .filter(|&c| {
                self.init_signed_content(c).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            })
            .count()
    }
}

impl From<&unfold_mesh::shapes::TangledCase> for InjectivityProblem {
    /// A generated case as a benchmark problem: its rest mesh, its `init`,
    /// its elements and its handles (`fixed`). Tets are 3D to 3D;
    /// triangles map into the plane (`init_dim = 2`), from a 2D rest when
    /// every rest `z` is 0 and a 3D one otherwise.
    fn from(c: &unfold_mesh::shapes::TangledCase) -> Self {
        let rest: Vec<[f64; 3]> = c.rest_positions.iter().map(|q| [q.x, q.y, q.z]).collect();
        let (cells, rest_dim, init_dim) = if c.is_tets() {
            (Cells::Tets(c.tets.clone()), 3, 3)
        } else {
            let flat = rest.iter().all(|x| x[2] == 0.0);
            (
                Cells::Triangles(c.triangles.clone()),
                if flat { 2 } else { 3 },
                2,
            )
        };
        InjectivityProblem {
            rest,
            rest_dim,
            init: c.init.clone(),
            init_dim,
            cells,
            handles: c.fixed.clone(),
        }
    }
}

/// What is wrong with an injectivity problem file. `line` is 1-based.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum TlcError {
    /// The file ends before a block is complete.
    #[error(
        "line {line}: the file ends inside the {block} block ({found} of {expected} rows); \
         the block's header line gives its row count"
    )]
    UnexpectedEnd {
        /// The line after the last one.
        line: usize,
        /// The block: "rest vertices", "init vertices", "simplices" or "handles".
        block: &'static str,
        /// Rows the header announced.
        expected: usize,
        /// Rows found.
        found: usize,
    },
    /// A header or row has the wrong number of values.
    #[error("line {line}: {found} values where the {what} needs {expected}")]
    FieldCount {
        /// The line.
        line: usize,
        /// What the line is ("rest vertices header", "simplex", ...).
        what: &'static str,
        /// Values needed.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// A count or an index is not a non-negative integer that fits 32 bits.
    #[error("line {line}: {token:?} is not a vertex index or count (a non-negative integer)")]
    BadInteger {
        /// The line.
        line: usize,
        /// The text.
        token: String,
    },
    /// A coordinate is not a finite number.
    #[error("line {line}: {token:?} is not a finite number")]
    BadNumber {
        /// The line.
        line: usize,
        /// The text.
        token: String,
    },
    /// A vertex block's dimension is not 2 or 3.
    #[error("line {line}: the {block} have dimension {dim}; 2 or 3 is needed")]
    Dimension {
        /// The header's line.
        line: usize,
        /// "rest vertices" or "init vertices".
        block: &'static str,
        /// The dimension given.
        dim: usize,
    },
    /// The init block does not have one row per rest vertex.
    #[error("line {line}: {init} init vertices for {rest} rest vertices; they must be equal")]
    InitCount {
        /// The init header's line.
        line: usize,
        /// Rest vertices.
        rest: usize,
        /// Init vertices.
        init: usize,
    },
    /// The simplex size is neither 3 (triangles) nor 4 (tets).
    #[error("line {line}: simplex size {size}; 3 (triangles) or 4 (tets) is needed")]
    SimplexSize {
        /// The header's line.
        line: usize,
        /// The size given.
        size: usize,
    },
    /// The dimensions do not fit the simplices: triangles need a 2D init,
    /// tets a 3D rest and a 3D init.
    #[error(
        "line {line}: {simplex_size}-vertex simplices with a {rest_dim}D rest and a {init_dim}D \
         init; triangles need a 2D init, tets a 3D rest and a 3D init"
    )]
    DimensionMismatch {
        /// The simplices header's line.
        line: usize,
        /// 3 or 4.
        simplex_size: usize,
        /// The rest's dimension.
        rest_dim: usize,
        /// The init's dimension.
        init_dim: usize,
    },
    /// The file has no vertices or no simplices.
    #[error("line {line}: the {block} block is empty; a problem needs at least one")]
    Empty {
        /// The header's line.
        line: usize,
        /// The empty block.
        block: &'static str,
    },
    /// A simplex names a vertex that does not exist.
    #[error(
        "line {line}: simplex {simplex} names vertex {index}, but there are {vertices} vertices \
         (indices are 0-based)"
    )]
    IndexOutOfRange {
        /// The line.
        line: usize,
        /// 0-based simplex index.
        simplex: usize,
        /// The index.
        index: u64,
        /// Number of vertices.
        vertices: usize,
    },
    /// A simplex names a vertex twice.
    #[error("line {line}: simplex {simplex} names vertex {index} twice")]
    RepeatedVertex {
        /// The line.
        line: usize,
        /// 0-based simplex index.
        simplex: usize,
        /// The repeated vertex.
        index: u32,
    },
    /// A handle names a vertex that does not exist.
    #[error(
        "line {line}: handle {index} is not a vertex; there are {vertices} (indices are 0-based)"
    )]
    HandleOutOfRange {
        /// The line.
        line: usize,
        /// The index.
        index: u64,
        /// Number of vertices.
        vertices: usize,
    },
    /// A handle is listed twice.
    #[error("line {line}: handle {index} is listed again (first on line {first_line})")]
    RepeatedHandle {
        /// The line of the repeat.
        line: usize,
        /// The vertex.
        index: u32,
        /// The line that listed it first.
        first_line: usize,
    },
    /// Text after the handles other than TLC-QN's optional initializer name
    /// and `alpha` lines.
    #[error(
        "line {line}: unexpected {token:?} after the handles (only an initializer name and an \
         alpha value may follow them)"
    )]
    TrailingData {
        /// The line.
        line: usize,
        /// The first value on it.
        token: String,
    },
}

/// Reads an injectivity problem file (the layout in the [module
/// docs](self)).
pub fn read_injectivity_problem(path: &Path) -> Result<InjectivityProblem, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Io {
        path: FilePath(path.to_path_buf()),
        source,
    })?;
    let text = String::from_utf8_lossy(&bytes);
    parse_injectivity_problem(&text).map_err(|source| IoError::Tlc {
        path: FilePath(path.to_path_buf()),
        source,
    })
}

/// Writes `problem` in the benchmark's layout (tab-separated; every number
/// the shortest decimal that reads back to the same `f64`), atomically.
/// Fails with [`IoError::Unsupported`] when the problem could not be read
/// back: a non-finite coordinate, an index out of range, or init and rest
/// counts that differ.
pub fn write_injectivity_problem(path: &Path, problem: &InjectivityProblem) -> Result<(), IoError> {
    let text = format_injectivity_problem(problem).map_err(|e| e.with_path(path))?;
    atomic_write(path, text.as_bytes())
}

/// The text [`write_injectivity_problem`] writes.
pub fn format_injectivity_problem(p: &InjectivityProblem) -> Result<String, IoError> {
    let n = p.rest.len();
    if p.init.len() != n {
        return Err(IoError::unsupported(format!(
            "{} init positions for {n} rest vertices",
            p.init.len()
        )));
    }
    for (block, dim) in [("rest", p.rest_dim), ("init", p.init_dim)] {
        if !(2..=3).contains(&dim) {
            return Err(IoError::unsupported(format!(
                "{block} dimension {dim} (2 or 3)"
            )));
        }
    }
    if let Some(v) = p
        .rest
        .iter()
        .chain(&p.init)
        .position(|x| x.iter().any(|c| !c.is_finite()))
    {
        return Err(IoError::unsupported(format!(
            "vertex {} has a non-finite coordinate",
            v % n.max(1)
        )));
    }
    let out_of_range = |i: &u32| *i as usize >= n;
    let bad_cell = match &p.cells {
        Cells::Triangles(t) => t.iter().flatten().any(out_of_range),
        Cells::Tets(t) => t.iter().flatten().any(out_of_range),
    };
    if bad_cell || p.handles.iter().any(out_of_range) {
        return Err(IoError::unsupported(format!(
            "a simplex or handle names a vertex past the {n} vertices"
        )));
    }
    let mut s = String::new();
    let block = |s: &mut String, points: &[[f64; 3]], dim: usize| {
        let _ = writeln!(s, "{}\t{dim}", points.len());
        for x in points {
            let row: Vec<String> = x[..dim].iter().map(|c| format!("{c:?}")).collect();
            let _ = writeln!(s, "{}", row.join("\t"));
        }
    };
    block(&mut s, &p.rest, p.rest_dim);
    block(&mut s, &p.init, p.init_dim);
    let _ = writeln!(s, "{}\t{}", p.cells.len(), p.cells.simplex_size());
    match &p.cells {
        Cells::Triangles(t) => t.iter().for_each(|[a, b, c]| {
            let _ = writeln!(s, "{a}\t{b}\t{c}");
        }),
        Cells::Tets(t) => t.iter().for_each(|[a, b, c, d]| {
            let _ = writeln!(s, "{a}\t{b}\t{c}\t{d}");
        }),
    }
    let _ = writeln!(s, "{}", p.handles.len());
    for h in &p.handles {
        let _ = writeln!(s, "{h}");
    }
    Ok(s)
}

/// The non-blank lines of a text with their 1-based numbers.
struct Lines<'a> {
    inner: std::iter::Enumerate<std::str::Lines<'a>>,
    /// The number of the last line read (0 before the first).
    last: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            inner: text.lines().enumerate(),
            last: 0,
        }
    }

    /// The next non-blank line: its number and its whitespace-separated values.
    fn next_row(&mut self) -> Option<(usize, Vec<&'a str>)> {
        for (i, l) in self.inner.by_ref() {
            self.last = i + 1;
            let fields: Vec<&str> = l.split_whitespace().collect();
            if !fields.is_empty() {
                return Some((i + 1, fields));
            }
        }
        None
    }

    /// The next row of a block that announced `expected` rows, `found`
    /// of them read so far.
    fn block_row(
        &mut self,
        block: &'static str,
        expected: usize,
        found: usize,
    ) -> Result<(usize, Vec<&'a str>), TlcError> {
        self.next_row().ok_or(TlcError::UnexpectedEnd {
            line: self.last + 1,
            block,
            expected,
            found,
        })
    }
}

fn integer(line: usize, token: &str) -> Result<u64, TlcError> {
    token
        .parse::<u32>()
        .map(u64::from)
        .map_err(|_| TlcError::BadInteger {
            line,
            token: token.to_string(),
        })
}

fn number(line: usize, token: &str) -> Result<f64, TlcError> {
    match token.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(TlcError::BadNumber {
            line,
            token: token.to_string(),
        }),
    }
}

fn expect_fields(
    line: usize,
    fields: &[&str],
    what: &'static str,
    expected: usize,
) -> Result<(), TlcError> {
    if fields.len() == expected {
        Ok(())
    } else {
        Err(TlcError::FieldCount {
            line,
            what,
            expected,
            found: fields.len(),
        })
    }
}

/// A `count dim` header of a vertex block; returns (line, count, dim).
fn vertex_header(
    lines: &mut Lines<'_>,
    block: &'static str,
) -> Result<(usize, usize, usize), TlcError> {
    let (line, f) = lines.block_row(block, 1, 0)?;
    expect_fields(line, &f, "vertex block header (count, dimension)", 2)?;
    let count = integer(line, f[0])? as usize;
    let dim = integer(line, f[1])? as usize;
    if !(2..=3).contains(&dim) {
        return Err(TlcError::Dimension { line, block, dim });
    }
    if count == 0 {
        return Err(TlcError::Empty { line, block });
    }
    Ok((line, count, dim))
}

fn vertex_rows(
    lines: &mut Lines<'_>,
    block: &'static str,
    count: usize,
    dim: usize,
) -> Result<Vec<[f64; 3]>, TlcError> {
    let mut out = Vec::with_capacity(count.min(1 << 20));
    for k in 0..count {
        let (line, f) = lines.block_row(block, count, k)?;
        expect_fields(line, &f, "vertex row", dim)?;
        let mut x = [0.0; 3];
        for (xi, t) in x.iter_mut().zip(&f) {
            *xi = number(line, t)?;
        }
        out.push(x);
    }
    Ok(out)
}

fn simplex_rows<const K: usize>(
    lines: &mut Lines<'_>,
    count: usize,
    vertices: usize,
) -> Result<Vec<[u32; K]>, TlcError> {
    let block = "simplices";
    let mut out = Vec::with_capacity(count.min(1 << 20));
    for k in 0..count {
        let (line, f) = lines.block_row(block, count, k)?;
        expect_fields(line, &f, "simplex", K)?;
        let mut s = [0u32; K];
        for (j, t) in f.iter().enumerate() {
            let index = integer(line, t)?;
            if index as usize >= vertices {
                return Err(TlcError::IndexOutOfRange {
                    line,
                    simplex: k,
                    index,
                    vertices,
                });
            }
            let index = index as u32;
            if s[..j].contains(&index) {
                return Err(TlcError::RepeatedVertex {
                    line,
                    simplex: k,
                    index,
                });
            }
            s[j] = index;
        }
        out.push(s);
    }
    Ok(out)
}

/// Parses the text of an injectivity problem file (the layout in the
/// [module docs](self)).
pub fn parse_injectivity_problem(text: &str) -> Result<InjectivityProblem, TlcError> {
    let mut lines = Lines::new(text);
    let (_, n, rest_dim) = vertex_header(&mut lines, "rest vertices")?;
    let rest = vertex_rows(&mut lines, "rest vertices", n, rest_dim)?;
    let (init_line, m, init_dim) = vertex_header(&mut lines, "init vertices")?;
    if m != n {
        return Err(TlcError::InitCount {
            line: init_line,
            rest: n,
            init: m,
        });
    }
    let init = vertex_rows(&mut lines, "init vertices", m, init_dim)?;

    let (line, f) = lines.block_row("simplices", 1, 0)?;
    expect_fields(line, &f, "simplices header (count, simplex size)", 2)?;
    let count = integer(line, f[0])? as usize;
    let size = integer(line, f[1])? as usize;
    let fits = match size {
        3 => init_dim == 2,
        4 => rest_dim == 3 && init_dim == 3,
        _ => return Err(TlcError::SimplexSize { line, size }),
    };
    if !fits {
        return Err(TlcError::DimensionMismatch {
            line,
            simplex_size: size,
            rest_dim,
            init_dim,
        });
    }
    if count == 0 {
        return Err(TlcError::Empty {
            line,
            block: "simplices",
        });
    }
    let cells = if size == 3 {
        Cells::Triangles(simplex_rows::<3>(&mut lines, count, n)?)
    } else {
        Cells::Tets(simplex_rows::<4>(&mut lines, count, n)?)
    };

    let (line, f) = lines.block_row("handles", 1, 0)?;
    expect_fields(line, &f, "handles header (count)", 1)?;
    let count = integer(line, f[0])? as usize;
    let mut handles = Vec::with_capacity(count.min(n));
    let mut first_line = std::collections::HashMap::new();
    for k in 0..count {
        let (line, f) = lines.block_row("handles", count, k)?;
        expect_fields(line, &f, "handle row", 1)?;
        let index = integer(line, f[0])?;
        if index as usize >= n {
            return Err(TlcError::HandleOutOfRange {
                line,
                index,
                vertices: n,
            });
        }
        let index = index as u32;
        if let Some(&first_line) = first_line.get(&index) {
            return Err(TlcError::RepeatedHandle {
                line,
                index,
                first_line,
            });
        }
        first_line.insert(index, line);
        handles.push(index);
    }

    // TLC-QN's optional trailer: an initializer name, then alpha.
    if let Some((line, f)) = lines.next_row() {
        let is_name = f.len() == 1 && f[0].parse::<f64>().is_err();
        if !is_name {
            return Err(TlcError::TrailingData {
                line,
                token: f[0].to_string(),
            });
        }
        if let Some((line, f)) = lines.next_row()
            && (f.len() != 1 || number(line, f[0]).is_err())
        {
            return Err(TlcError::TrailingData {
                line,
                token: f[0].to_string(),
            });
        }
        if let Some((line, f)) = lines.next_row() {
            return Err(TlcError::TrailingData {
                line,
                token: f[0].to_string(),
            });
        }
    }

    Ok(InjectivityProblem {
        rest,
        rest_dim,
        init,
        init_dim,
        cells,
        handles,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EXAMPLE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/tlc/tlc-pn-example.input"
    );

    /// A small valid planar problem: the unit square split in two, one
    /// triangle flipped in init, handles 0 and 2.
    fn square() -> String {
        "4 2\n0 0\n1 0\n1 1\n0 1\n4 2\n0 0\n1 0\n1 1\n0.2 -0.5\n2 3\n0 1 2\n0 2 3\n2\n0\n2\n"
            .to_string()
    }

    fn err(text: &str) -> TlcError {
        parse_injectivity_problem(text).unwrap_err()
    }

    #[test]
    fn reads_the_vendored_tlc_pn_example() {
        let p = read_injectivity_problem(Path::new(EXAMPLE)).unwrap();
        assert_eq!((p.rest.len(), p.rest_dim), (1024, 3));
        assert_eq!((p.init.len(), p.init_dim), (1024, 2));
        assert!(matches!(&p.cells, Cells::Triangles(t) if t.len() == 2000));
        assert_eq!(p.handles.len(), 46);
        assert!(p.handles.iter().all(|&h| (h as usize) < 1024));
        assert!(p.init.iter().all(|x| x[2] == 0.0));
        // First and last values of each block, as in the file.
        assert_eq!(p.rest[0], [-0.27308, 2.776429, 0.322655]);
        assert_eq!(p.init[3], [0.5, 0.07499999999999998, 0.0]);
        assert_eq!(p.handles[..3], [4, 6, 491]);
        assert_eq!(p.handles[45], 3);
        let inverted = p.inverted_in_init();
        let positive = (0..p.cells.len())
            .filter(|&c| p.init_signed_content(c) > 0.0)
            .count();
        println!(
            "tlc-pn example: {} vertices, {} triangles, rest {}D, init {}D, {} handles; \
             init: {inverted} not positive (signed area <= 0), {positive} positive",
            p.rest.len(),
            p.cells.len(),
            p.rest_dim,
            p.init_dim,
            p.handles.len()
        );
        // A tangled start: some triangles are inverted, most are not.
        assert!(inverted > 0 && inverted < p.cells.len() / 2, "{inverted}");
        // It round-trips bit for bit.
        let text = format_injectivity_problem(&p).unwrap();
        assert_eq!(parse_injectivity_problem(&text).unwrap(), p);
    }

    #[test]
    fn the_vendored_example_is_a_disk_with_its_handles_on_the_boundary() {
        use unfold_mesh::topology::{boundary_loops, euler_characteristic};
        let p = read_injectivity_problem(Path::new(EXAMPLE)).unwrap();
        let Cells::Triangles(t) = &p.cells else {
            panic!("triangles expected")
        };
        let pts = p.rest.iter().map(|&x| x.into()).collect();
        let mesh = unfold_mesh::TriMesh::new(pts, t.clone());
        assert!(mesh.validate().is_ok());
        assert_eq!(euler_characteristic(&mesh), 1);
        let loops = boundary_loops(&mesh).unwrap();
        assert_eq!(loops.len(), 1);
        let on_boundary = |h: &u32| loops[0].contains(h);
        let n_on = p.handles.iter().filter(|h| on_boundary(h)).count();
        let zero = (0..p.cells.len())
            .filter(|&c| p.init_signed_content(c) == 0.0)
            .count();
        println!(
            "tlc-pn example: a disk, boundary loop of {} vertices, {n_on} of {} handles on it; \
             {zero} init triangles of zero area",
            loops[0].len(),
            p.handles.len()
        );
        assert_eq!(n_on, p.handles.len());
    }

    #[test]
    fn generated_cases_write_and_read_back() {
        use unfold_mesh::shapes::{Handles, TangledKind, TangledParams, tangled_case};
        let dir = tempfile::tempdir().unwrap();
        for (kind, dims) in [
            (TangledKind::Planar, (2, 2)),
            (TangledKind::SurfaceToPlane, (3, 2)),
            (TangledKind::Tets, (3, 3)),
        ] {
            let case = tangled_case(&TangledParams {
                kind,
                elements: 200,
                handles: Handles::Sparse { fraction: 0.1 },
                scramble: 0.5,
                seed: 4,
            })
            .unwrap();
            let p = InjectivityProblem::from(&case);
            assert_eq!((p.rest_dim, p.init_dim), dims);
            assert_eq!(p.inverted_in_init(), case.inverted_in_init());
            let path = dir.path().join("case.input");
            write_injectivity_problem(&path, &p).unwrap();
            assert_eq!(read_injectivity_problem(&path).unwrap(), p);
        }
    }

    /// The construction of TLC-QN's example problem (a 3 x 3 x 3 grid of
    /// the unit cube, 6 tets per box; the 8 interior vertices reflected
    /// through the centre, `p -> 1 - p`, in init; the 56 boundary vertices
    /// are the handles), rebuilt from our own Kuhn grid: that repository
    /// has no licence, so its file is not copied. Its layout (values
    /// aligned with runs of spaces) is read by the same parser.
    #[test]
    fn the_tlc_qn_example_rebuilt_reads_back_tangled() {
        let grid = unfold_mesh::shapes::kuhn_grid([3, 3, 3], [1.0 / 3.0; 3]);
        let rest: Vec<[f64; 3]> = grid.positions.iter().map(|q| [q.x, q.y, q.z]).collect();
        let interior = |x: &[f64; 3]| x.iter().all(|&c| c > 0.1 && c < 0.9);
        let init: Vec<[f64; 3]> = rest
            .iter()
            .map(|x| if interior(x) { x.map(|c| 1.0 - c) } else { *x })
            .collect();
        let handles: Vec<u32> = (0..64).filter(|&v| !interior(&rest[v as usize])).collect();
        let p = InjectivityProblem {
            rest,
            rest_dim: 3,
            init,
            init_dim: 3,
            cells: Cells::Tets(grid.tets.clone()),
            handles,
        };
        let text = format_injectivity_problem(&p).unwrap().replace('\t', "   ");
        let q = parse_injectivity_problem(&text).unwrap();
        assert_eq!(q, p);
        assert_eq!((q.cells.len(), q.handles.len()), (162, 56));
        let inverted = q.inverted_in_init();
        println!(
            "the TLC-QN example rebuilt: 64 vertices, 162 tets, 56 handles, {inverted} tets inverted in init"
        );
        assert!(inverted > 0);
    }

    #[test]
    fn parses_a_small_problem_and_counts_its_inverted_triangle() {
        let p = parse_injectivity_problem(&square()).unwrap();
        assert_eq!(p.cells, Cells::Triangles(vec![[0, 1, 2], [0, 2, 3]]));
        assert_eq!(p.handles, vec![0, 2]);
        assert_eq!(p.rest[3], [0.0, 1.0, 0.0]);
        assert_eq!(p.inverted_in_init(), 1);
        assert!(p.init_signed_content(0) > 0.0);
    }

    #[test]
    fn accepts_blank_lines_c_style_numbers_and_the_tlc_qn_trailer() {
        let text = square().replace("0 0\n1 0\n1 1\n0 1\n4 2", "0. 0\n\n1.0 0e0\n1 1\n0 1\n4\t2");
        assert!(parse_injectivity_problem(&text).is_ok());
        let trailer = format!("{}harmonic\n1e-4\n", square());
        assert!(parse_injectivity_problem(&trailer).is_ok());
        assert!(matches!(
            err(&format!("{}harmonic\n1e-4\n7\n", square())),
            TlcError::TrailingData { line: 19, .. }
        ));
        assert!(matches!(
            err(&format!("{}5\n", square())),
            TlcError::TrailingData { line: 17, .. }
        ));
    }

    #[test]
    fn reads_a_tet_problem() {
        let text = "4 3\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n4 3\n0 0 0\n1 0 0\n0 1 0\n0 0 -1\n\
                    1 4\n0 1 2 3\n0\n";
        let p = parse_injectivity_problem(text).unwrap();
        assert_eq!(p.cells, Cells::Tets(vec![[0, 1, 2, 3]]));
        assert!((p.init_signed_content(0) + 1.0 / 6.0).abs() < 1e-15);
        assert_eq!(p.inverted_in_init(), 1);
        assert!(p.handles.is_empty());
    }

    #[test]
    fn every_bad_file_gets_its_error_and_line() {
        let sq = square();
        // Counts and headers.
        assert!(matches!(
            err(""),
            TlcError::UnexpectedEnd {
                line: 1,
                block: "rest vertices",
                ..
            }
        ));
        assert!(matches!(
            err("4\n"),
            TlcError::FieldCount {
                line: 1,
                expected: 2,
                found: 1,
                ..
            }
        ));
        assert!(matches!(
            err("-4 2\n"),
            TlcError::BadInteger { line: 1, .. }
        ));
        assert!(matches!(
            err("4 5\n"),
            TlcError::Dimension {
                line: 1,
                dim: 5,
                ..
            }
        ));
        assert!(matches!(err("0 2\n"), TlcError::Empty { line: 1, .. }));
        assert!(matches!(
            err(&sq[..sq.find("1 1").unwrap()]),
            TlcError::UnexpectedEnd {
                line: 4,
                expected: 4,
                found: 2,
                ..
            }
        ));
        assert!(matches!(
            err(&sq.replacen("\n4 2\n", "\n3 2\n", 1)),
            TlcError::InitCount {
                line: 6,
                rest: 4,
                init: 3
            }
        ));
        // Numbers.
        assert!(matches!(
            err(&sq.replacen("1 0", "1 x", 1)),
            TlcError::BadNumber { line: 3, .. }
        ));
        assert!(matches!(
            err(&sq.replacen("1 0", "1 nan", 1)),
            TlcError::BadNumber { line: 3, .. }
        ));
        assert!(matches!(
            err(&sq.replacen("1 0", "1 inf", 1)),
            TlcError::BadNumber { line: 3, .. }
        ));
        assert!(matches!(
            err(&sq.replacen("1 0", "1 0 0", 1)),
            TlcError::FieldCount {
                line: 3,
                expected: 2,
                found: 3,
                ..
            }
        ));
        // Simplices.
        assert!(matches!(
            err(&sq.replace("2 3\n", "2 5\n")),
            TlcError::SimplexSize { line: 11, size: 5 }
        ));
        assert!(matches!(
            err(&sq.replace("2 3\n", "2 4\n")),
            TlcError::DimensionMismatch {
                line: 11,
                simplex_size: 4,
                ..
            }
        ));
        assert!(matches!(
            err(&sq.replace("2 3\n", "0 3\n")),
            TlcError::Empty { line: 11, .. }
        ));
        assert!(matches!(
            err(&sq.replace("0 2 3\n", "0 2 4\n")),
            TlcError::IndexOutOfRange {
                line: 13,
                simplex: 1,
                index: 4,
                vertices: 4
            }
        ));
        assert!(matches!(
            err(&sq.replace("0 2 3\n", "0 2 99999999999\n")),
            TlcError::BadInteger { line: 13, .. }
        ));
        assert!(matches!(
            err(&sq.replace("0 2 3\n", "0 2 0\n")),
            TlcError::RepeatedVertex {
                line: 13,
                simplex: 1,
                index: 0
            }
        ));
        assert!(matches!(
            err(&sq.replace("0 2 3\n", "0 2\n")),
            TlcError::FieldCount {
                line: 13,
                expected: 3,
                found: 2,
                ..
            }
        ));
        // Handles.
        assert!(matches!(
            err(&sq.replace("2\n0\n2\n", "2\n0\n4\n")),
            TlcError::HandleOutOfRange {
                line: 16,
                index: 4,
                vertices: 4
            }
        ));
        assert!(matches!(
            err(&sq.replace("2\n0\n2\n", "2\n0\n0\n")),
            TlcError::RepeatedHandle {
                line: 16,
                index: 0,
                first_line: 15
            }
        ));
        assert!(matches!(
            err(&sq.replace("2\n0\n2\n", "3\n0\n2\n")),
            TlcError::UnexpectedEnd {
                line: 17,
                block: "handles",
                expected: 3,
                found: 2
            }
        ));
        assert!(matches!(
            err(&sq.replace("2\n0\n2\n", "")),
            TlcError::UnexpectedEnd {
                line: 14,
                block: "handles",
                ..
            }
        ));
        // A 3D rest with triangles and a 3D init is refused.
        let t3 = "3 3\n0 0 0\n1 0 0\n0 1 0\n3 3\n0 0 0\n1 0 0\n0 1 0\n1 3\n0 1 2\n0\n";
        assert!(matches!(
            err(t3),
            TlcError::DimensionMismatch {
                line: 9,
                simplex_size: 3,
                ..
            }
        ));
    }

    #[test]
    fn file_errors_name_the_file_and_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.input");
        std::fs::write(&path, square().replace("0 2 3\n", "0 2 7\n")).unwrap();
        let e = read_injectivity_problem(&path).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(
            e,
            IoError::Tlc {
                source: TlcError::IndexOutOfRange { .. },
                ..
            }
        ));
        assert!(
            msg.contains("bad.input") && msg.contains("line 13") && msg.contains("vertex 7"),
            "{msg}"
        );
        let missing = read_injectivity_problem(&dir.path().join("none")).unwrap_err();
        assert!(matches!(missing, IoError::Io { .. }));
    }

    #[test]
    fn the_writer_refuses_what_it_could_not_read_back() {
        let mut p = parse_injectivity_problem(&square()).unwrap();
        p.init[1][0] = f64::NAN;
        assert!(matches!(
            format_injectivity_problem(&p),
            Err(IoError::Unsupported { .. })
        ));
        let mut p = parse_injectivity_problem(&square()).unwrap();
        p.handles.push(9);
        assert!(matches!(
            format_injectivity_problem(&p),
            Err(IoError::Unsupported { .. })
        ));
        let mut p = parse_injectivity_problem(&square()).unwrap();
        p.init.pop();
        assert!(matches!(
            format_injectivity_problem(&p),
            Err(IoError::Unsupported { .. })
        ));
    }

    /// A random problem: `n` vertices, triangles or tets, finite
    /// coordinates of any magnitude, distinct handles.
    fn problem() -> impl Strategy<Value = InjectivityProblem> {
        (4usize..12, any::<bool>(), any::<bool>()).prop_flat_map(|(n, tets, rest2)| {
            let coord = prop_oneof![-1e3..1e3f64, -1e-30..1e-30f64, (-1e300..1e300f64)];
            let rest_dim = if tets || !rest2 { 3 } else { 2 };
            let init_dim = if tets { 3 } else { 2 };
            let point = |dim: usize| {
                proptest::array::uniform3(coord.clone()).prop_map(move |mut x| {
                    x[dim..].iter_mut().for_each(|c| *c = 0.0);
                    x
                })
            };
            (
                proptest::collection::vec(point(rest_dim), n),
                proptest::collection::vec(point(init_dim), n),
                proptest::collection::vec(
                    Just((0..n as u32).collect::<Vec<u32>>()).prop_shuffle(),
                    1..6,
                ),
                proptest::sample::subsequence((0..n as u32).collect::<Vec<u32>>(), 0..n),
            )
                .prop_map(move |(rest, init, perms, handles)| InjectivityProblem {
                    rest,
                    rest_dim,
                    init,
                    init_dim,
                    cells: if tets {
                        Cells::Tets(perms.iter().map(|p| [p[0], p[1], p[2], p[3]]).collect())
                    } else {
                        Cells::Triangles(perms.iter().map(|p| [p[0], p[1], p[2]]).collect())
                    },
                    handles,
                })
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn write_then_read_is_the_identity(p in problem()) {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("p.input");
            write_injectivity_problem(&path, &p).unwrap();
            prop_assert_eq!(read_injectivity_problem(&path).unwrap(), p);
        }

        #[test]
        fn no_input_panics(cut in 0usize..200, junk in "[ -~\n\t]{0,12}") {
            // A valid file cut anywhere, with junk spliced in: an error or a
            // problem, never a panic.
            let sq = square();
            let at = cut.min(sq.len());
            let text = format!("{}{}{}", &sq[..at], junk, &sq[at..]);
            let _ = parse_injectivity_problem(&text);
        }
    }
}
