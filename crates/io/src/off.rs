//! Object File Format `.off` (Geomview / Princeton shape benchmark), ASCII.
//!
//! Reading:
//! - the header keyword `OFF` with any of the optional prefixes `ST`, `C`,
//!   `N` (`COFF`, `NOFF`, `CNOFF`, `STOFF`, ...) or no keyword at all (the
//!   file starts with the counts); `4OFF` / `nOFF` (other dimensions) and
//!   `OFF BINARY` are rejected as unsupported;
//! - the counts `vertices faces [edges]` (the edge count is optional and
//!   ignored), on the keyword line or the next one;
//! - one vertex per line: `x y z`, anything after the three coordinates
//!   (normals, colours, texture coordinates) is ignored;
//! - one face per line: `n i1 ... in`, any size `n >= 3` (3 becomes a
//!   triangle, 4 a quad, more a polygon), 0-based indices; a trailing colour
//!   is ignored;
//! - `#` comments anywhere.
//!
//! Writing: `OFF`, the counts, the vertices (shortest round-trip decimal, so
//! ASCII is exact) and the faces. Only surface cells (triangles, quads,
//! polygons) can be stored; point cells (vertex / poly-vertex) are not
//! written (every point is stored anyway); lines and volume cells are
//! unsupported. OFF holds no data arrays: point and cell data are not written.
//!
//! This module also holds the small text tokenizer shared by the text
//! readers of this crate (OFF, Medit, STL, PLY, Gmsh).

use crate::{IoError, Location, WriteOptions};
use nalgebra::Point3;
use std::fmt::Write as _;
use std::str::FromStr;
use unfold_mesh::{CellMesh, CellType};

/// A whitespace-separated token reader over bytes that knows the line (and
/// byte offset) of every token, for error messages. `comment` starts a
/// comment that runs to the end of the line.
pub(crate) struct Tokens<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
    comment: Option<u8>,
    tok_line: usize,
    tok_start: usize,
    byte_locations: bool,
}

fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\n' | 0x0b | 0x0c)
}

impl<'a> Tokens<'a> {
    /// A reader at the start of `bytes`.
    pub(crate) fn new(bytes: &'a [u8], comment: Option<u8>) -> Self {
        Tokens {
            bytes,
            pos: 0,
            line: 1,
            comment,
            tok_line: 1,
            tok_start: 0,
            byte_locations: false,
        }
    }

    /// Report errors at byte offsets instead of lines (binary files with
    /// text parts).
    pub(crate) fn use_byte_locations(&mut self) {
        self.byte_locations = true;
    }

    /// Skips blanks and comments (and newlines when `cross_lines`); returns
    /// whether a token starts at the current position.
    fn skip_blank(&mut self, cross_lines: bool) -> bool {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'\n' {
                if !cross_lines {
                    return false;
                }
                self.line += 1;
                self.pos += 1;
            } else if is_space(b) {
                self.pos += 1;
            } else if Some(b) == self.comment {
                while let Some(&c) = self.bytes.get(self.pos) {
                    if c == b'\n' {
                        break;
                    }
                    self.pos += 1;
                }
            } else {
                return true;
            }
        }
        false
    }

    fn take_token(&mut self) -> &'a [u8] {
        let start = self.pos;
        while let Some(&b) = self.bytes.get(self.pos) {
            if is_space(b) || Some(b) == self.comment {
                break;
            }
            self.pos += 1;
        }
        self.tok_start = start;
        self.tok_line = self.line;
        self.bytes.get(start..self.pos).unwrap_or_default()
    }

    fn mark_here(&mut self) {
        self.tok_line = self.line;
        self.tok_start = self.pos;
    }

    /// The next token, on any line.
    pub(crate) fn next(&mut self) -> Option<&'a [u8]> {
        if self.skip_blank(true) {
            Some(self.take_token())
        } else {
            self.mark_here();
            None
        }
    }

    /// The next token if it is on the current line.
    pub(crate) fn next_in_line(&mut self) -> Option<&'a [u8]> {
        if self.skip_blank(false) {
            Some(self.take_token())
        } else {
            self.mark_here();
            None
        }
    }

    /// Moves to the start of the next line.
    pub(crate) fn skip_line(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            self.pos += 1;
            if b == b'\n' {
                self.line += 1;
                return;
            }
        }
    }

    /// Moves forward to byte `pos` (counting lines on the way).
    pub(crate) fn seek(&mut self, pos: usize) {
        let pos = pos.min(self.bytes.len());
        if pos > self.pos {
            let skipped = self.bytes.get(self.pos..pos).unwrap_or_default();
            self.line += skipped.iter().filter(|&&b| b == b'\n').count();
            self.pos = pos;
        }
    }

    /// The current byte offset.
    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes left after the current position.
    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    /// Where the last token (or the failed attempt to read one) is.
    pub(crate) fn location(&self) -> Location {
        if self.byte_locations {
            Location::Byte(self.tok_start as u64)
        } else {
            Location::Line(self.tok_line)
        }
    }

    /// A parse error at the last token.
    pub(crate) fn error(&self, msg: impl Into<String>) -> IoError {
        IoError::malformed(self.location(), msg)
    }

    /// The next token parsed as `T`; `what` names it for the error message.
    pub(crate) fn expect<T: FromStr>(&mut self, what: &str) -> Result<T, IoError> {
        self.expect_by(|| what.to_string())
    }

    /// [`Tokens::expect`] with the description made only on error.
    pub(crate) fn expect_by<T: FromStr>(
        &mut self,
        what: impl FnOnce() -> String,
    ) -> Result<T, IoError> {
        match self.next() {
            None => Err(self.error(format!("unexpected end of file; expected {}", what()))),
            Some(tok) => parse(tok)
                .ok_or_else(|| self.error(format!("expected {}, found '{}'", what(), show(tok)))),
        }
    }

    /// The next token as a finite coordinate.
    pub(crate) fn expect_coord(&mut self, what: &str) -> Result<f64, IoError> {
        self.expect_coord_by(|| what.to_string())
    }

    /// [`Tokens::expect_coord`] with the description made only on error.
    pub(crate) fn expect_coord_by(&mut self, what: impl Fn() -> String) -> Result<f64, IoError> {
        let v = self.expect_f64_by(&what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error(format!("{} is not finite ({v})", what())))
        }
    }

    /// The next token as f64; Fortran exponents (`1.5D+02`) are accepted.
    pub(crate) fn expect_f64(&mut self, what: &str) -> Result<f64, IoError> {
        self.expect_f64_by(|| what.to_string())
    }

    /// [`Tokens::expect_f64`] with the description made only on error.
    pub(crate) fn expect_f64_by(&mut self, what: impl Fn() -> String) -> Result<f64, IoError> {
        match self.next() {
            None => Err(self.error(format!("unexpected end of file; expected {}", what()))),
            Some(tok) => parse_f64(tok)
                .ok_or_else(|| self.error(format!("expected {}, found '{}'", what(), show(tok)))),
        }
    }

    /// The next token, which must be `keyword` (ASCII case-insensitive).
    pub(crate) fn expect_keyword(&mut self, keyword: &str) -> Result<(), IoError> {
        match self.next() {
            Some(tok) if tok.eq_ignore_ascii_case(keyword.as_bytes()) => Ok(()),
            Some(tok) => Err(self.error(format!("expected '{keyword}', found '{}'", show(tok)))),
            None => Err(self.error(format!("unexpected end of file; expected '{keyword}'"))),
        }
    }
}

/// Parses a token as `T` (None if it is not UTF-8 or does not parse).
pub(crate) fn parse<T: FromStr>(tok: &[u8]) -> Option<T> {
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Parses a float, also accepting a Fortran `D` exponent.
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    parse(tok).or_else(|| {
        if tok.iter().any(|&b| b == b'd' || b == b'D') {
            let s: Vec<u8> = tok
                .iter()
                .map(|&b| if b == b'd' || b == b'D' { b'e' } else { b })
                .collect();
            parse(&s)
        } else {
            None
        }
    })
}

/// A token for an error message (lossy UTF-8, shortened).
pub(crate) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}

/// A pre-allocation size for `count` items read from a file, capped by what
/// the remaining input could hold (`min_bytes` per item at least).
pub(crate) fn cap(count: usize, remaining: usize, min_bytes: usize) -> usize {
    count.min(remaining / min_bytes.max(1))
}

/// The surface cell type of a polygon with `n >= 3` vertices.
pub(crate) fn polygon_type(n: usize) -> CellType {
    match n {
        3 => CellType::Triangle,
        4 => CellType::Quad,
        _ => CellType::Polygon,
    }
}

/// Parses the header keyword; returns Ok(true) if a keyword was consumed,
/// Ok(false) if the file starts directly with the counts.
fn read_keyword(t: &mut Tokens) -> Result<bool, IoError> {
    let Some(tok) = t.next() else {
        return Err(t.error("empty file; expected 'OFF'"));
    };
    if parse::<u64>(tok).is_some() {
        // No keyword: the counts come first. Re-read this token as a count.
        t.pos = t.tok_start;
        t.line = t.tok_line;
        return Ok(false);
    }
    let mut rest = tok;
    for prefix in [&b"ST"[..], b"C", b"N"] {
        if let Some(r) = rest.strip_prefix(prefix) {
            rest = r;
        }
    }
    if rest == b"OFF" {
        if let Some(next) = t.next_in_line() {
            if next.eq_ignore_ascii_case(b"BINARY") {
                return Err(IoError::unsupported(format!(
                    "line {}: binary OFF is not supported; save the file as ASCII OFF",
                    t.tok_line
                )));
            }
            // Counts on the keyword line: re-read them.
            t.pos = t.tok_start;
        }
        return Ok(true);
    }
    if rest.ends_with(b"OFF") && (rest.starts_with(b"4") || rest.starts_with(b"n")) {
        return Err(IoError::unsupported(format!(
            "line {}: '{}' (4D or n-dimensional OFF) is not supported; only 3D OFF is read",
            t.tok_line,
            show(tok)
        )));
    }
    Err(t.error(format!(
        "not an OFF file: expected 'OFF' (or COFF, NOFF, ...), found '{}'",
        show(tok)
    )))
}

/// Parses an OFF file's bytes (see the module documentation).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let mut t = Tokens::new(bytes, Some(b'#'));
    read_keyword(&mut t)?;
    let nv: usize = t.expect("the vertex count")?;
    let nf: usize = t.expect("the face count")?;
    // The optional edge count must be on the same line as the face count.
    if let Some(tok) = t.next_in_line()
        && parse::<u64>(tok).is_none()
    {
        return Err(t.error(format!("expected the edge count, found '{}'", show(tok))));
    }
    let mut positions = Vec::with_capacity(cap(nv, t.remaining(), 6));
    for i in 0..nv {
        let what = || format!("a coordinate of vertex {i}");
        let x = t.expect_coord_by(what)?;
        let y = t.expect_coord_by(what)?;
        let z = t.expect_coord_by(what)?;
        positions.push(Point3::new(x, y, z));
        t.skip_line();
    }
    let mut mesh = CellMesh::from_points(positions);
    mesh.cell_types.reserve(cap(nf, t.remaining(), 8));
    mesh.offsets.reserve(cap(nf, t.remaining(), 8));
    let mut face = Vec::new();
    for i in 0..nf {
        let n: usize = t.expect_by(|| format!("the vertex count of face {i}"))?;
        if n < 3 {
            return Err(t.error(format!(
                "face {i} has {n} vertices; a face needs at least 3"
            )));
        }
        face.clear();
        for _ in 0..n {
            let v: u64 = t.expect_by(|| format!("a vertex index of face {i}"))?;
            if v >= nv as u64 {
                return Err(t.error(format!(
                    "face {i} refers to vertex {v}, but the file has {nv} vertices (indices are 0-based)"
                )));
            }
            face.push(v as u32);
        }
        mesh.push_cell(polygon_type(n), &face);
        t.skip_line();
    }
    Ok(mesh)
}

/// Serializes the surface cells of a mesh as ASCII OFF (see the module
/// documentation for what is stored).
pub fn write(mesh: &CellMesh, _opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    let mut faces = 0usize;
    for (i, (t, _)) in mesh.cells().enumerate() {
        match t.dimension() {
            0 => {}
            2 => faces += 1,
            _ => {
                return Err(IoError::unsupported(format!(
                    "OFF stores polygons only; cell {i} is a {t:?}"
                )));
            }
        }
    }
    let mut s = String::with_capacity(mesh.num_points() * 40 + faces * 20 + 32);
    let _ = writeln!(s, "OFF\n{} {} 0", mesh.num_points(), faces);
    for p in &mesh.positions {
        let _ = writeln!(s, "{:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for (t, vs) in mesh.cells() {
        if t.dimension() != 2 {
            continue;
        }
        let _ = write!(s, "{}", vs.len());
        for v in vs {
            let _ = write!(s, " {v}");
        }
        s.push('\n');
    }
    Ok(s.into_bytes())
}

/// Helpers shared by the tests of the format modules.
#[cfg(test)]
pub(crate) mod test_support {
    use nalgebra::Point3;
    use proptest::prelude::*;
    use unfold_mesh::{CellMesh, CellType, Field, FieldValues};

    /// Finite f64 of every magnitude (zero, subnormal, normal; both signs).
    pub(crate) fn coord() -> impl Strategy<Value = f64> + Clone {
        prop_oneof![
            prop::num::f64::POSITIVE
                | prop::num::f64::NEGATIVE
                | prop::num::f64::NORMAL
                | prop::num::f64::SUBNORMAL
                | prop::num::f64::ZERO,
            -1000.0..1000.0f64,
            (-1000i32..1000).prop_map(f64::from),
        ]
    }

    /// Finite f64 that are exactly representable as f32.
    pub(crate) fn coord_f32() -> impl Strategy<Value = f64> + Clone {
        prop_oneof![
            (prop::num::f32::POSITIVE
                | prop::num::f32::NEGATIVE
                | prop::num::f32::NORMAL
                | prop::num::f32::SUBNORMAL
                | prop::num::f32::ZERO)
                .prop_map(f64::from),
            (-1000.0..1000.0f32).prop_map(f64::from),
        ]
    }

    /// `n` points (n in the range) with coordinates from `c`.
    pub(crate) fn points<S: Strategy<Value = f64> + Clone>(
        c: S,
        n: std::ops::Range<usize>,
    ) -> impl Strategy<Value = Vec<Point3<f64>>> {
        prop::collection::vec((c.clone(), c.clone(), c), n).prop_map(|v| {
            v.into_iter()
                .map(|(x, y, z)| Point3::new(x, y, z))
                .collect()
        })
    }

    /// A mesh with `points` and cells given as (type, vertex indices), indices
    /// taken modulo the point count.
    pub(crate) fn mesh_with(points: Vec<Point3<f64>>, cells: &[(CellType, Vec<u32>)]) -> CellMesh {
        let n = points.len() as u32;
        let mut m = CellMesh::from_points(points);
        if n > 0 {
            for (t, vs) in cells {
                let vs: Vec<u32> = vs.iter().map(|v| v % n).collect();
                m.push_cell(*t, &vs);
            }
        }
        m
    }

    /// Random cells: `(type, vertex count)` chosen from `kinds`; indices are
    /// reduced modulo the point count by [`mesh_with`].
    pub(crate) fn cells(
        kinds: Vec<(CellType, std::ops::RangeInclusive<usize>)>,
        n: std::ops::Range<usize>,
    ) -> impl Strategy<Value = Vec<(CellType, Vec<u32>)>> {
        let one = prop::sample::select(kinds).prop_flat_map(|(t, sizes)| {
            sizes.prop_flat_map(move |k| {
                prop::collection::vec(any::<u32>(), k).prop_map(move |vs| (t, vs))
            })
        });
        prop::collection::vec(one, n)
    }

    /// Field values of a random type: `len` values.
    pub(crate) fn values(len: usize) -> impl Strategy<Value = FieldValues> {
        prop_oneof![
            prop::collection::vec(super::test_support::coord(), len).prop_map(FieldValues::F64),
            prop::collection::vec(
                prop::num::f32::NORMAL | prop::num::f32::ZERO | prop::num::f32::SUBNORMAL,
                len
            )
            .prop_map(FieldValues::F32),
            prop::collection::vec(
                prop_oneof![
                    any::<i32>().prop_map(i64::from),
                    -(1i64 << 53)..=(1i64 << 53)
                ],
                len
            )
            .prop_map(FieldValues::I64),
            prop::collection::vec(any::<i32>(), len).prop_map(FieldValues::I32),
            prop::collection::vec(any::<u8>(), len).prop_map(FieldValues::U8),
        ]
    }

    /// A field of `tuples` tuples with 1..=3 components and a random type.
    pub(crate) fn field(name: String, tuples: usize) -> impl Strategy<Value = Field> {
        (1usize..=3).prop_flat_map(move |c| {
            let name = name.clone();
            values(tuples * c).prop_map(move |v| Field::new(name.clone(), c, v).unwrap())
        })
    }

    /// Whether two fields hold the same values (types may differ).
    pub(crate) fn same_values(a: &Field, b: &Field) -> bool {
        a.name() == b.name()
            && a.components() == b.components()
            && a.values().len() == b.values().len()
            && (0..a.values().len()).all(|i| {
                let (x, y) = (a.values().get_f64(i), b.values().get_f64(i));
                x == y || x.is_some_and(f64::is_nan) && y.is_some_and(f64::is_nan)
            })
    }

    /// Every prefix of `bytes` parses without panicking, to a valid mesh if Ok.
    pub(crate) fn check_truncations(
        bytes: &[u8],
        read: fn(&[u8]) -> Result<CellMesh, crate::IoError>,
    ) {
        for n in 0..bytes.len() {
            if let Ok(m) = read(&bytes[..n]) {
                assert!(m.check().is_ok(), "prefix {n} gave an invalid mesh");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;
    use proptest::prelude::*;

    const CUBE: &str = "OFF
# a cube
8 6 12
0 0 0
1 0 0
1 1 0
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
4 0 3 2 1
4 4 5 6 7
4 0 1 5 4
4 1 2 6 5
4 2 3 7 6
3 3 0 4 255 0 0
";

    #[test]
    fn off_reads_cube_with_comments_and_colours() {
        let m = read(CUBE.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 8);
        assert_eq!(m.num_cells(), 6);
        assert_eq!(m.cell(0), (CellType::Quad, &[0, 3, 2, 1][..]));
        assert_eq!(m.cell(5), (CellType::Triangle, &[3, 0, 4][..]));
        assert_eq!(m.positions[6], Point3::new(1.0, 1.0, 1.0));
        m.check().unwrap();
    }

    #[test]
    fn off_variants_and_counts_on_keyword_line() {
        let coff = "COFF 3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n";
        let m = read(coff.as_bytes()).unwrap();
        assert_eq!(m.num_cells(), 1);
        let noff = "NOFF\n3 1\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n";
        assert_eq!(read(noff.as_bytes()).unwrap().positions[1].x, 1.0);
        let bare = "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(read(bare.as_bytes()).unwrap().num_cells(), 1);
        let hexagon = "OFF\n6 1 0\n0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 2 0\n-1 1 0\n6 0 1 2 3 4 5\n";
        assert_eq!(
            read(hexagon.as_bytes()).unwrap().cell_types,
            vec![CellType::Polygon]
        );
    }

    #[test]
    fn off_errors_name_lines() {
        let cases: &[(&str, &str)] = &[
            ("", "empty file"),
            ("PLY\n", "not an OFF file"),
            ("OFF\n3 1 0\n0 0 0\n1 0 x\n", "line 4"),
            ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "line 6"),
            ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "at least 3"),
            (
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n",
                "unexpected end of file",
            ),
            ("OFF\n1 0 0\nnan 0 0\n", "not finite"),
        ];
        for (text, want) in cases {
            let e = read(text.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        let e = read(b"4OFF\n").unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        let e = read(b"OFF BINARY\n").unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
    }

    #[test]
    fn off_write_rejects_volume_cells_and_skips_points() {
        let mut m = CellMesh::from_points(vec![Point3::origin(); 4]);
        m.push_cell(CellType::Vertex, &[0]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        let back = read(&write(&m, &WriteOptions::default()).unwrap()).unwrap();
        assert_eq!(back.cell_types, vec![CellType::Triangle]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
    }

    #[test]
    fn off_truncations_never_panic() {
        check_truncations(CUBE.as_bytes(), read);
    }

    fn surface_cells() -> impl Strategy<Value = Vec<(CellType, Vec<u32>)>> {
        cells(
            vec![
                (CellType::Triangle, 3..=3),
                (CellType::Quad, 4..=4),
                (CellType::Polygon, 5..=9),
            ],
            0..20,
        )
    }

    proptest! {
        #[test]
        fn off_round_trip(pts in points(coord(), 0..30), cs in surface_cells()) {
            let m = mesh_with(pts, &cs);
            let back = read(&write(&m, &WriteOptions::ascii()).unwrap()).unwrap();
            prop_assert_eq!(back, m);
        }

        #[test]
        fn off_random_bytes_are_errors(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn off_random_text_never_panics(s in "(OFF\n)?[0-9 .\n#e-]{0,200}") {
            if let Ok(m) = read(s.as_bytes()) {
                prop_assert!(m.check().is_ok());
            }
        }

        #[test]
        fn off_corruptions_never_panic(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8)) {
            let mut bytes = CUBE.as_bytes().to_vec();
            for (i, b) in edits {
                let i = i.index(bytes.len());
                bytes[i] = b;
            }
            if let Ok(m) = read(&bytes) {
                prop_assert!(m.check().is_ok());
            }
        }
    }
}
