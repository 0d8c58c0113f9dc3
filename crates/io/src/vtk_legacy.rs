//! VTK legacy `.vtk` files (`# vtk DataFile Version ...`).
//!
//! Reading:
//! - `ASCII` and `BINARY` files (binary data is big-endian, as the VTK file
//!   format specifies), file versions up to 4.2 (`CELLS n size` with a count
//!   before each cell) and 5.x (`CELLS n_offsets n_connectivity` followed by
//!   `OFFSETS` / `CONNECTIVITY` arrays of any integer type, e.g.
//!   `vtktypeint64` or `vtktypeint32`).
//! - `DATASET UNSTRUCTURED_GRID` (`POINTS`, `CELLS`, `CELL_TYPES`) and
//!   `DATASET POLYDATA` (`POINTS`, `VERTICES`, `LINES`, `POLYGONS`,
//!   `TRIANGLE_STRIPS`). Polydata cells are numbered as VTK numbers them
//!   (vertices, then lines, then polygons, then strips, whatever the order of
//!   the sections in the file); each cell gets the type VTK gives it from its
//!   size (1 point: vertex, more: poly-vertex; 2: line, more: polyline; 3:
//!   triangle, 4: quad, more: polygon). Triangle strips are split into
//!   triangles (alternating orientation, as VTK does), their cell data
//!   repeated for every triangle; a strip of fewer than 3 points yields none.
//! - `POINT_DATA` / `CELL_DATA` with `SCALARS` (optional component count and
//!   `LOOKUP_TABLE`), `COLOR_SCALARS`, `VECTORS`, `NORMALS`,
//!   `TEXTURE_COORDINATES`, `TENSORS`, `TENSORS6`, `GLOBAL_IDS`,
//!   `PEDIGREE_IDS` and `FIELD` arrays. Stand-alone `LOOKUP_TABLE` sections,
//!   `METADATA` blocks and dataset-level `FIELD` data are skipped. Array
//!   names are `%XX`-decoded as VTK does.
//! - Element types map into [`FieldValues`]: `double` -> `F64`, `float` ->
//!   `F32`; `long`, `vtktypeint64`, `vtkIdType`, `unsigned_int`,
//!   `unsigned_long`, `vtktypeuint64` -> `I64` (an unsigned 64-bit value above
//!   `i64::MAX` is an error); `int`, `short`, `unsigned_short`, `char`,
//!   `signed_char` -> `I32`; `unsigned_char` -> `U8`. `long` and
//!   `unsigned_long` are 8 bytes in binary files (as written on 64-bit Linux
//!   and macOS); `vtkIdType` is 4 bytes, as VTK writes it. `bit` and string
//!   arrays are unsupported.
//! - Cell types: those of [`CellType`]; any other id is an
//!   [`IoError::Unsupported`] naming it. Other dataset types (structured
//!   points / grids, rectilinear grids) are unsupported.
//!
//! Writing:
//! - `BINARY` unless [`WriteOptions::ascii`]; version 4.2 or 5.1 by
//!   [`WriteOptions::legacy_version`] (5.1 cells use `vtktypeint64` offsets
//!   and connectivity). Points are written as `double`, so they survive a
//!   round trip exactly; ASCII numbers use Rust's shortest round-trip
//!   representation (non-finite field values are written `NaN`, `inf`,
//!   `-inf`, which unfold reads back but VTK's own ASCII reader does not).
//! - `DATASET POLYDATA` when every cell is a vertex, line or surface cell of
//!   the type VTK would give it from its size (see above), and the cells are
//!   already in VTK's polydata order (vertices, then lines, then polygons);
//!   otherwise `DATASET UNSTRUCTURED_GRID`. Either way the cells, their
//!   order and their types survive a round trip.
//! - Point and cell data are written as `FIELD FieldData` arrays of their
//!   own type (`double`, `float`, `vtktypeint64`, `int`, `unsigned_char`).
//!   Legacy VTK cannot hold names with white space: every white-space or
//!   control character of a name is replaced by `_` (an empty name becomes
//!   `unnamed`), and a name made equal to an earlier one gets a `_2`, `_3`,
//!   ... suffix. `%` is written `%25`, which VTK and this reader decode.

use crate::{IoError, LegacyVersion, Location, WriteOptions};
use nalgebra::Point3;
use std::io::Write as _;
use unfold_mesh::{CellMesh, CellType, Field, FieldValues, Fields};

// ---------------------------------------------------------------------------
// Helpers shared with `vtk_xml`.
// ---------------------------------------------------------------------------

/// The element type of a VTK data array, as stored in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    /// Bytes per value.
    pub(crate) fn size(self) -> usize {
        use Scalar::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            I64 | U64 | F64 => 8,
        }
    }

    /// The VTK XML type name.
    pub(crate) fn xml_name(self) -> &'static str {
        use Scalar::*;
        match self {
            I8 => "Int8",
            U8 => "UInt8",
            I16 => "Int16",
            U16 => "UInt16",
            I32 => "Int32",
            U32 => "UInt32",
            I64 => "Int64",
            U64 => "UInt64",
            F32 => "Float32",
            F64 => "Float64",
        }
    }

    /// Parses a VTK XML type name.
    pub(crate) fn from_xml(name: &str) -> Option<Scalar> {
        use Scalar::*;
        Some(match name {
            "Int8" => I8,
            "UInt8" => U8,
            "Int16" => I16,
            "UInt16" => U16,
            "Int32" => I32,
            "UInt32" => U32,
            "Int64" => I64,
            "UInt64" => U64,
            "Float32" => F32,
            "Float64" => F64,
            _ => return None,
        })
    }

    /// Parses a legacy type name (case-insensitive). `vtkIdType` is 4 bytes
    /// in binary files and read as 64-bit integers in ASCII files.
    fn from_legacy(name: &[u8], binary: bool) -> Option<Scalar> {
        use Scalar::*;
        let name = std::str::from_utf8(name).ok()?.to_ascii_lowercase();
        Some(match name.as_str() {
            "unsigned_char" | "vtktypeuint8" => U8,
            "char" | "signed_char" | "vtktypeint8" => I8,
            "unsigned_short" | "vtktypeuint16" => U16,
            "short" | "vtktypeint16" => I16,
            "unsigned_int" | "vtktypeuint32" => U32,
            "int" | "vtktypeint32" => I32,
            "unsigned_long" | "vtktypeuint64" => U64,
            "long" | "vtktypeint64" => I64,
            "vtkidtype" if binary => I32,
            "vtkidtype" => I64,
            "float" | "vtktypefloat32" => F32,
            "double" | "vtktypefloat64" => F64,
            _ => return None,
        })
    }

    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// An empty value vector of the [`FieldValues`] variant `ty` maps to.
pub(crate) fn empty_values(ty: Scalar, capacity: usize) -> FieldValues {
    use Scalar::*;
    match ty {
        F64 => FieldValues::F64(Vec::with_capacity(capacity)),
        F32 => FieldValues::F32(Vec::with_capacity(capacity)),
        I64 | U32 | U64 => FieldValues::I64(Vec::with_capacity(capacity)),
        I8 | I16 | U16 | I32 => FieldValues::I32(Vec::with_capacity(capacity)),
        U8 => FieldValues::U8(Vec::with_capacity(capacity)),
    }
}

/// Parses one ASCII value of type `ty` onto `out` (made by
/// [`empty_values`] for `ty`). False if the token is not a valid value.
pub(crate) fn push_ascii(ty: Scalar, token: &[u8], out: &mut FieldValues) -> bool {
    let Ok(s) = std::str::from_utf8(token) else {
        return false;
    };
    fn put<T>(v: &mut Vec<T>, x: Option<T>) -> bool {
        match x {
            Some(x) => {
                v.push(x);
                true
            }
            None => false,
        }
    }
    match out {
        FieldValues::F64(v) => put(v, s.parse().ok()),
        FieldValues::F32(v) => put(v, s.parse().ok()),
        FieldValues::I64(v) => {
            let x = match ty {
                Scalar::U32 => s.parse::<u32>().ok().map(i64::from),
                Scalar::U64 => s.parse::<u64>().ok().and_then(|x| i64::try_from(x).ok()),
                _ => s.parse::<i64>().ok(),
            };
            put(v, x)
        }
        FieldValues::I32(v) => {
            let x = match ty {
                Scalar::I8 => s.parse::<i8>().ok().map(i32::from),
                Scalar::I16 => s.parse::<i16>().ok().map(i32::from),
                Scalar::U16 => s.parse::<u16>().ok().map(i32::from),
                _ => s.parse::<i32>().ok(),
            };
            put(v, x)
        }
        FieldValues::U8(v) => put(v, s.parse().ok()),
    }
}

/// Decodes packed binary values. The length must be a multiple of the value
/// size; unsigned 64-bit values above `i64::MAX` are an error.
pub(crate) fn decode_binary(
    ty: Scalar,
    bytes: &[u8],
    big_endian: bool,
) -> Result<FieldValues, String> {
    if !bytes.len().is_multiple_of(ty.size()) {
        return Err(format!(
            "{} bytes of data is not a whole number of {}-byte values",
            bytes.len(),
            ty.size()
        ));
    }
    macro_rules! conv {
        ($t:ty, $n:literal, $map:expr) => {{
            let arr = |c: &[u8]| {
                let mut a = [0u8; $n];
                a.copy_from_slice(c);
                a
            };
            if big_endian {
                bytes
                    .chunks_exact($n)
                    .map(|c| $map(<$t>::from_be_bytes(arr(c))))
                    .collect()
            } else {
                bytes
                    .chunks_exact($n)
                    .map(|c| $map(<$t>::from_le_bytes(arr(c))))
                    .collect()
            }
        }};
    }
    use Scalar::*;
    Ok(match ty {
        F64 => FieldValues::F64(conv!(f64, 8, |x| x)),
        F32 => FieldValues::F32(conv!(f32, 4, |x| x)),
        I64 => FieldValues::I64(conv!(i64, 8, |x| x)),
        U32 => FieldValues::I64(conv!(u32, 4, i64::from)),
        I32 => FieldValues::I32(conv!(i32, 4, |x| x)),
        I16 => FieldValues::I32(conv!(i16, 2, i32::from)),
        U16 => FieldValues::I32(conv!(u16, 2, i32::from)),
        I8 => FieldValues::I32(bytes.iter().map(|&b| i32::from(b as i8)).collect()),
        U8 => FieldValues::U8(bytes.to_vec()),
        U64 => {
            let v: Vec<u64> = conv!(u64, 8, |x| x);
            let mut out = Vec::with_capacity(v.len());
            for (i, x) in v.into_iter().enumerate() {
                out.push(i64::try_from(x).map_err(|_| {
                    format!("value {i} ({x}) does not fit a signed 64-bit integer")
                })?);
            }
            FieldValues::I64(out)
        }
    })
}

/// The values as f64 (moved when they already are).
pub(crate) fn into_f64(values: FieldValues) -> Vec<f64> {
    match values {
        FieldValues::F64(v) => v,
        other => other.to_f64(),
    }
}

/// The values as i64, or `None` for floating-point values.
pub(crate) fn into_i64(values: FieldValues) -> Option<Vec<i64>> {
    match values {
        FieldValues::I64(v) => Some(v),
        FieldValues::I32(v) => Some(v.into_iter().map(i64::from).collect()),
        FieldValues::U8(v) => Some(v.into_iter().map(i64::from).collect()),
        FieldValues::F64(_) | FieldValues::F32(_) => None,
    }
}

/// Point indices: integers in `0..=u32::MAX`.
pub(crate) fn into_indices(values: FieldValues) -> Result<Vec<u32>, String> {
    match values {
        FieldValues::I64(v) => v
            .into_iter()
            .map(|x| u32::try_from(x).map_err(|_| format!("{x} is not a valid point index")))
            .collect(),
        FieldValues::I32(v) => v
            .into_iter()
            .map(|x| u32::try_from(x).map_err(|_| format!("{x} is not a valid point index")))
            .collect(),
        FieldValues::U8(v) => Ok(v.into_iter().map(u32::from).collect()),
        FieldValues::F64(_) | FieldValues::F32(_) => {
            Err("point indices must be integers, not floating-point values".into())
        }
    }
}

/// CSR offsets (with the leading 0) from a sequence of offsets that should
/// start at 0, never decrease, and end at `nconn`.
pub(crate) fn checked_offsets(
    offsets: impl IntoIterator<Item = i64>,
    nconn: usize,
) -> Result<Vec<usize>, String> {
    let it = offsets.into_iter();
    let mut out = Vec::with_capacity(it.size_hint().0.min(nconn.saturating_add(1)));
    let mut prev = 0usize;
    for (i, o) in it.enumerate() {
        let o = usize::try_from(o).map_err(|_| format!("offset {i} is negative ({o})"))?;
        if i == 0 && o != 0 {
            return Err(format!("the first offset must be 0, found {o}"));
        }
        if o < prev {
            return Err(format!(
                "offset {i} ({o}) is smaller than the one before ({prev})"
            ));
        }
        if o > nconn {
            return Err(format!(
                "offset {i} ({o}) is beyond the {nconn} connectivity entries"
            ));
        }
        prev = o;
        out.push(o);
    }
    if out.is_empty() {
        out.push(0);
    }
    if prev != nconn {
        return Err(format!(
            "the last offset is {prev}, but there are {nconn} connectivity entries"
        ));
    }
    Ok(out)
}

/// The cell type for a VTK id, or an unsupported error naming it.
pub(crate) fn cell_type(id: i64) -> Result<CellType, IoError> {
    u8::try_from(id)
        .ok()
        .and_then(CellType::from_vtk_id)
        .ok_or_else(|| {
            IoError::unsupported(format!(
                "VTK cell type {id} is not supported (supported: 1 vertex, 2 poly-vertex, \
                 3 line, 4 polyline, 5 triangle, 7 polygon, 9 quad, 10 tetra, \
                 12 hexahedron, 13 wedge, 14 pyramid)"
            ))
        })
}

/// Checks every cell's size for its type and every point index.
pub(crate) fn check_cells(
    types: &[CellType],
    offsets: &[usize],
    conn: &[u32],
    npoints: usize,
) -> Result<(), String> {
    if offsets.len() != types.len() + 1 {
        return Err(format!(
            "{} cell types for {} cells",
            types.len(),
            offsets.len().saturating_sub(1)
        ));
    }
    for (i, (t, w)) in types.iter().zip(offsets.windows(2)).enumerate() {
        let k = w[1].saturating_sub(w[0]);
        let ok = match t.fixed_size() {
            Some(n) => k == n,
            None => k >= t.min_size(),
        };
        if !ok {
            return Err(format!("cell {i} is a {t:?} with {k} points"));
        }
    }
    if let Some(&v) = conn.iter().find(|&&v| v as usize >= npoints) {
        return Err(format!(
            "a cell refers to point {v}, but there are only {npoints} points"
        ));
    }
    Ok(())
}

/// Which polydata cell array a cell type belongs to: 0 vertices, 1 lines,
/// 2 polygons; `None` for volume cells.
pub(crate) fn poly_class(t: CellType) -> Option<usize> {
    match t.dimension() {
        d @ 0..=2 => Some(d as usize),
        _ => None,
    }
}

/// The type VTK gives a polydata cell of `size` points in cell array
/// `class` (0 verts, 1 lines, 2 polys).
pub(crate) fn poly_type(class: usize, size: usize) -> Option<CellType> {
    Some(match (class, size) {
        (0, 0) | (1, 0..=1) | (2, 0..=2) => return None,
        (0, 1) => CellType::Vertex,
        (0, _) => CellType::PolyVertex,
        (1, 2) => CellType::Line,
        (1, _) => CellType::PolyLine,
        (2, 3) => CellType::Triangle,
        (2, 4) => CellType::Quad,
        (2, _) => CellType::Polygon,
        _ => return None,
    })
}

/// One polydata cell array in CSR form.
pub(crate) struct PolyGroup {
    pub(crate) offsets: Vec<usize>,
    pub(crate) conn: Vec<u32>,
}

impl PolyGroup {
    fn cells(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

/// Polydata cells as cell-mesh cells.
pub(crate) struct JoinedPoly {
    pub(crate) types: Vec<CellType>,
    pub(crate) offsets: Vec<usize>,
    pub(crate) conn: Vec<u32>,
    /// Number of cells in the file (strips counted once).
    pub(crate) file_cells: usize,
    /// When strips changed the cell count: the file cell of each cell.
    pub(crate) rows: Option<Vec<usize>>,
}

/// Polydata cells (verts, lines, polys, strips) joined into cell-mesh cells
/// in VTK's order, strips split into triangles. The error names the group
/// (0..4) and the problem.
pub(crate) fn join_poly(groups: [Option<PolyGroup>; 4]) -> Result<JoinedPoly, (usize, String)> {
    const NAMES: [&str; 4] = ["vertex", "line", "polygon", "strip"];
    let total: usize = groups.iter().flatten().map(PolyGroup::cells).sum();
    let conn_total: usize = groups.iter().flatten().map(|g| g.conn.len()).sum();
    let has_strips = groups[3].as_ref().is_some_and(|g| g.cells() > 0);
    let mut types = Vec::with_capacity(total);
    let mut offsets = Vec::with_capacity(total + 1);
    offsets.push(0);
    let mut conn = Vec::with_capacity(conn_total);
    let mut rows = Vec::new();
    let mut file_cell = 0usize;
    for (class, g) in groups.iter().enumerate() {
        let Some(g) = g else { continue };
        for (i, w) in g.offsets.windows(2).enumerate() {
            let vs = g
                .conn
                .get(w[0]..w[1])
                .ok_or((class, "bad offsets".to_string()))?;
            if class == 3 {
                for k in 0..vs.len().saturating_sub(2) {
                    let (a, b) = if k % 2 == 0 { (k, k + 1) } else { (k + 1, k) };
                    conn.extend_from_slice(&[vs[a], vs[b], vs[k + 2]]);
                    types.push(CellType::Triangle);
                    offsets.push(conn.len());
                    rows.push(file_cell);
                }
            } else {
                let t = poly_type(class, vs.len()).ok_or_else(|| {
                    (
                        class,
                        format!("{} cell {i} has {} points", NAMES[class], vs.len()),
                    )
                })?;
                types.push(t);
                conn.extend_from_slice(vs);
                offsets.push(conn.len());
                if has_strips {
                    rows.push(file_cell);
                }
            }
            file_cell += 1;
        }
    }
    Ok(JoinedPoly {
        types,
        offsets,
        conn,
        file_cells: file_cell,
        rows: has_strips.then_some(rows),
    })
}

/// Writes `x` in the shortest form that parses back to the same f64.
pub(crate) fn put_f64(out: &mut Vec<u8>, x: f64) {
    let _ = write!(out, "{x:?}");
}

/// Writes values as ASCII text, one tuple of `ncomp` values per line.
pub(crate) fn put_ascii_values(out: &mut Vec<u8>, values: &FieldValues, ncomp: usize) {
    fn lines<T>(out: &mut Vec<u8>, v: &[T], ncomp: usize, f: impl Fn(&mut Vec<u8>, &T)) {
        for tuple in v.chunks(ncomp.max(1)) {
            for (j, x) in tuple.iter().enumerate() {
                if j > 0 {
                    out.push(b' ');
                }
                f(out, x);
            }
            out.push(b'\n');
        }
    }
    match values {
        FieldValues::F64(v) => lines(out, v, ncomp, |o, &x| put_f64(o, x)),
        FieldValues::F32(v) => lines(out, v, ncomp, |o, x| {
            let _ = write!(o, "{x:?}");
        }),
        FieldValues::I64(v) => lines(out, v, ncomp, |o, x| {
            let _ = write!(o, "{x}");
        }),
        FieldValues::I32(v) => lines(out, v, ncomp, |o, x| {
            let _ = write!(o, "{x}");
        }),
        FieldValues::U8(v) => lines(out, v, ncomp, |o, x| {
            let _ = write!(o, "{x}");
        }),
    }
}

/// `text` cut to at most 40 characters, for messages.
pub(crate) fn shown(text: &[u8]) -> String {
    let s = String::from_utf8_lossy(text);
    if s.chars().count() > 40 {
        let cut: String = s.chars().take(40).collect();
        format!("{cut}...")
    } else {
        s.into_owned()
    }
}

// ---------------------------------------------------------------------------
// Reading.
// ---------------------------------------------------------------------------

fn is_ws(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\r' | b'\n' | 0x0b | 0x0c)
}

/// A position in the file, reading text tokens or binary blocks.
#[derive(Clone, Copy)]
struct Lex<'a> {
    b: &'a [u8],
    pos: usize,
    binary: bool,
}

impl<'a> Lex<'a> {
    fn line_at(&self, pos: usize) -> usize {
        let upto = self.b.get(..pos).unwrap_or(self.b);
        1 + upto.iter().filter(|&&c| c == b'\n').count()
    }

    /// An error in the text at `pos`, located by line.
    fn err(&self, pos: usize, msg: impl Into<String>) -> IoError {
        IoError::malformed(Location::Line(self.line_at(pos)), msg)
    }

    /// Where data at `pos` is: a byte offset in binary files, else a line.
    fn data_loc(&self, pos: usize) -> Location {
        if self.binary {
            Location::Byte(pos as u64)
        } else {
            Location::Line(self.line_at(pos))
        }
    }

    fn token(&mut self) -> Option<(usize, &'a [u8])> {
        while self.b.get(self.pos).is_some_and(|&c| is_ws(c)) {
            self.pos += 1;
        }
        let start = self.pos;
        while self.b.get(self.pos).is_some_and(|&c| !is_ws(c)) {
            self.pos += 1;
        }
        (self.pos > start).then(|| (start, &self.b[start..self.pos]))
    }

    /// The next token if it is on the current line.
    fn line_token(&mut self) -> Option<(usize, &'a [u8])> {
        while self
            .b
            .get(self.pos)
            .is_some_and(|&c| c != b'\n' && is_ws(c))
        {
            self.pos += 1;
        }
        match self.b.get(self.pos) {
            None | Some(b'\n') => None,
            Some(_) => self.token(),
        }
    }

    fn expect(&mut self, what: &str) -> Result<(usize, &'a [u8]), IoError> {
        self.token().ok_or_else(|| {
            self.err(
                self.b.len(),
                format!("the file ends where {what} was expected"),
            )
        })
    }

    fn count(&mut self, what: &str) -> Result<usize, IoError> {
        let (p, t) = self.expect(what)?;
        std::str::from_utf8(t)
            .ok()
            .and_then(|s| s.parse::<u64>().ok())
            .and_then(|n| usize::try_from(n).ok())
            .ok_or_else(|| {
                self.err(
                    p,
                    format!(
                        "expected {what} (a non-negative integer), found '{}'",
                        shown(t)
                    ),
                )
            })
    }

    fn scalar(&mut self, what: &str) -> Result<Scalar, IoError> {
        let (p, t) = self.expect(what)?;
        Scalar::from_legacy(t, self.binary).ok_or_else(|| {
            let lower = String::from_utf8_lossy(t).to_ascii_lowercase();
            if matches!(lower.as_str(), "bit" | "string" | "utf8_string" | "variant") {
                IoError::unsupported(format!(
                    "line {}: arrays of type '{lower}' are not supported",
                    self.line_at(p)
                ))
            } else {
                self.err(
                    p,
                    format!(
                        "unknown data type '{}' (expected float, double, int, \
                         unsigned_char, vtktypeint64, ...)",
                        shown(t)
                    ),
                )
            }
        })
    }

    fn skip_line(&mut self) {
        while let Some(&c) = self.b.get(self.pos) {
            self.pos += 1;
            if c == b'\n' {
                break;
            }
        }
    }

    /// The rest of the current line (without the newline), moving past it.
    fn rest_of_line(&mut self) -> &'a [u8] {
        let start = self.pos;
        self.skip_line();
        let line = &self.b[start..self.pos];
        line.strip_suffix(b"\n").unwrap_or(line)
    }

    fn peek_is(&self, keyword: &str) -> bool {
        let mut c = *self;
        c.token()
            .is_some_and(|(_, t)| t.eq_ignore_ascii_case(keyword.as_bytes()))
    }

    /// Skips a `METADATA` block (its keyword already read): lines up to an
    /// empty line or the end of the file.
    fn skip_metadata(&mut self) {
        self.skip_line();
        while self.pos < self.b.len() {
            if self.rest_of_line().iter().all(|&c| is_ws(c)) {
                break;
            }
        }
    }

    /// Reads `count` values of type `ty` (text tokens, or a big-endian
    /// binary block starting on the next line).
    fn values(&mut self, ty: Scalar, count: usize, what: &str) -> Result<FieldValues, IoError> {
        if self.binary {
            self.skip_line();
            let start = self.pos;
            let left = self.b.len() - start;
            let nbytes = count
                .checked_mul(ty.size())
                .filter(|&n| n <= left)
                .ok_or_else(|| {
                    IoError::malformed(
                        Location::Byte(start as u64),
                        format!(
                            "{what}: expected {count} binary values of {} bytes, but only \
                             {left} bytes are left",
                            ty.size()
                        ),
                    )
                })?;
            let bytes = &self.b[start..start + nbytes];
            self.pos = start + nbytes;
            decode_binary(ty, bytes, true).map_err(|m| {
                IoError::malformed(Location::Byte(start as u64), format!("{what}: {m}"))
            })
        } else {
            let left = self.b.len() - self.pos;
            let mut out = empty_values(ty, count.min(left / 2 + 1));
            for i in 0..count {
                let Some((p, t)) = self.token() else {
                    return Err(self.err(
                        self.b.len(),
                        format!("{what}: expected {count} values, the file ends after {i}"),
                    ));
                };
                if !push_ascii(ty, t, &mut out) {
                    return Err(self.err(
                        p,
                        format!(
                            "{what}: '{}' is not a valid {} value (value {i} of {count})",
                            shown(t),
                            ty.xml_name()
                        ),
                    ));
                }
            }
            Ok(out)
        }
    }

    fn ints(&mut self, count: usize, what: &str) -> Result<Vec<i64>, IoError> {
        let ty = if self.binary {
            Scalar::I32
        } else {
            Scalar::I64
        };
        let v = self.values(ty, count, what)?;
        Ok(into_i64(v).unwrap_or_default())
    }

    /// `CELLS`, `VERTICES`, `LINES`, ... after the keyword: CSR offsets and
    /// connectivity, in the 4.2 or 5.x layout.
    fn cell_array(&mut self, keyword: &str, v5: bool) -> Result<PolyGroup, IoError> {
        let a = self.count(&format!("the {keyword} cell count"))?;
        let b = self.count(&format!("the {keyword} size"))?;
        if v5 {
            let mut int_array = |name: &str, n: usize| -> Result<(usize, FieldValues), IoError> {
                let (p, t) = self.expect(name)?;
                if !t.eq_ignore_ascii_case(name.as_bytes()) {
                    return Err(self.err(
                        p,
                        format!(
                            "expected {name} after {keyword} (file version 5), found '{}'",
                            shown(t)
                        ),
                    ));
                }
                let ty = self.scalar(&format!("the {name} data type"))?;
                if ty.is_float() {
                    return Err(self.err(p, format!("{name} must have an integer type")));
                }
                let start = self.pos;
                Ok((start, self.values(ty, n, name)?))
            };
            let (op, offs) = int_array("OFFSETS", a)?;
            let (cp, conn) = int_array("CONNECTIVITY", b)?;
            let offs = into_i64(offs).unwrap_or_default();
            let offsets = checked_offsets(offs, b).map_err(|m| {
                IoError::malformed(self.data_loc(op), format!("{keyword} OFFSETS: {m}"))
            })?;
            let conn = into_indices(conn).map_err(|m| {
                IoError::malformed(self.data_loc(cp), format!("{keyword} CONNECTIVITY: {m}"))
            })?;
            Ok(PolyGroup { offsets, conn })
        } else {
            let start = self.pos;
            if a > b {
                return Err(self.err(
                    start,
                    format!("{keyword} declares {a} cells but only {b} values (each cell needs at least its point count)"),
                ));
            }
            let data = self.ints(b, keyword)?;
            let mut offsets = Vec::with_capacity(a + 1);
            offsets.push(0);
            let mut conn = Vec::with_capacity(b - a);
            let mut i = 0usize;
            for c in 0..a {
                let bad = |m: String| {
                    IoError::malformed(self.data_loc(start), format!("{keyword}: cell {c}: {m}"))
                };
                let k = *data
                    .get(i)
                    .ok_or_else(|| bad("the data ends before this cell".into()))?;
                let k = usize::try_from(k).map_err(|_| bad(format!("negative point count {k}")))?;
                let vs = data.get(i + 1..).and_then(|r| r.get(..k)).ok_or_else(|| {
                    bad(format!("{k} points do not fit in the declared size {b}"))
                })?;
                for &v in vs {
                    conn.push(
                        u32::try_from(v)
                            .map_err(|_| bad(format!("{v} is not a valid point index")))?,
                    );
                }
                i += 1 + k;
                offsets.push(conn.len());
            }
            if i != b {
                return Err(IoError::malformed(
                    self.data_loc(start),
                    format!("{keyword}: the {a} cells use {i} values, but the size is {b}"),
                ));
            }
            Ok(PolyGroup { offsets, conn })
        }
    }
}

/// Decodes VTK's `%XX` escapes in array names.
fn decode_name(raw: &[u8]) -> String {
    let mut out = Vec::with_capacity(raw.len());
    let mut i = 0;
    while let Some(&c) = raw.get(i) {
        if c == b'%'
            && let Some(h) = raw.get(i + 1..i + 3)
            && let Ok(s) = std::str::from_utf8(h)
            && let Ok(v) = u8::from_str_radix(s, 16)
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(c);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[derive(Clone, Copy, PartialEq)]
enum Target {
    None,
    Point,
    Cell,
}

/// Parses a legacy VTK file's bytes.
///
/// Errors carry the line of the problem, or the byte offset for binary data.
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let mut lx = Lex {
        b: bytes,
        pos: 0,
        binary: false,
    };
    // Header: version line, title line, ASCII | BINARY, DATASET type.
    let first = lx.rest_of_line();
    const MAGIC: &[u8] = b"# vtk datafile version";
    let trimmed = first.trim_ascii();
    let version = trimmed
        .get(..MAGIC.len())
        .filter(|h| h.eq_ignore_ascii_case(MAGIC))
        .map(|_| trimmed.get(MAGIC.len()..).unwrap_or_default().trim_ascii())
        .ok_or_else(|| {
            IoError::malformed(
                Location::Line(1),
                "not a VTK legacy file: expected '# vtk DataFile Version x.y'",
            )
        })?;
    let major: u32 = std::str::from_utf8(version)
        .ok()
        .and_then(|v| v.split('.').next())
        .and_then(|m| m.trim().parse().ok())
        .ok_or_else(|| {
            IoError::malformed(
                Location::Line(1),
                format!("unreadable file version '{}'", shown(version)),
            )
        })?;
    let v5 = major >= 5;
    if lx.pos >= bytes.len() {
        return Err(lx.err(
            bytes.len(),
            "the file ends after its first line (expected a title line)",
        ));
    }
    lx.rest_of_line(); // title
    let (p, enc) = lx.expect("ASCII or BINARY")?;
    lx.binary = if enc.eq_ignore_ascii_case(b"binary") {
        true
    } else if enc.eq_ignore_ascii_case(b"ascii") {
        false
    } else {
        return Err(lx.err(
            p,
            format!("expected ASCII or BINARY, found '{}'", shown(enc)),
        ));
    };
    let (p, kw) = lx.expect("DATASET")?;
    if !kw.eq_ignore_ascii_case(b"dataset") {
        return Err(lx.err(p, format!("expected DATASET, found '{}'", shown(kw))));
    }
    let (p, ds) = lx.expect("the dataset type")?;
    let poly = if ds.eq_ignore_ascii_case(b"polydata") {
        true
    } else if ds.eq_ignore_ascii_case(b"unstructured_grid") {
        false
    } else {
        let name = String::from_utf8_lossy(ds).to_ascii_uppercase();
        if matches!(
            name.as_str(),
            "STRUCTURED_POINTS" | "STRUCTURED_GRID" | "RECTILINEAR_GRID" | "FIELD"
        ) {
            return Err(IoError::unsupported(format!(
                "VTK legacy dataset type {name} is not supported (only POLYDATA and UNSTRUCTURED_GRID)"
            )));
        }
        return Err(lx.err(
            p,
            format!(
                "expected POLYDATA or UNSTRUCTURED_GRID after DATASET, found '{}'",
                shown(ds)
            ),
        ));
    };

    let mut positions: Option<Vec<Point3<f64>>> = None;
    let mut cells: Option<(usize, PolyGroup)> = None;
    let mut types: Option<(usize, Vec<CellType>)> = None;
    let mut groups: [Option<PolyGroup>; 4] = [None, None, None, None];
    let mut group_pos = [0usize; 4];
    let mut point_data = Fields::new();
    let mut cell_data = Fields::new();
    let mut point_n: Option<(usize, usize)> = None;
    let mut cell_n: Option<(usize, usize)> = None;
    let mut target = Target::None;

    while let Some((kp, tok)) = lx.token() {
        let kw = String::from_utf8_lossy(tok).to_ascii_lowercase();
        let group = ["vertices", "lines", "polygons", "triangle_strips"]
            .iter()
            .position(|&g| g == kw);
        match kw.as_str() {
            "points" => {
                if positions.is_some() {
                    return Err(lx.err(kp, "a second POINTS section"));
                }
                let n = lx.count("the number of points")?;
                let ty = lx.scalar("the POINTS data type")?;
                let len = n
                    .checked_mul(3)
                    .ok_or_else(|| lx.err(kp, format!("impossible point count {n}")))?;
                let v = into_f64(lx.values(ty, len, "POINTS")?);
                positions = Some(
                    v.chunks_exact(3)
                        .map(|c| Point3::new(c[0], c[1], c[2]))
                        .collect(),
                );
            }
            "cells" if !poly => {
                if cells.is_some() {
                    return Err(lx.err(kp, "a second CELLS section"));
                }
                cells = Some((kp, lx.cell_array("CELLS", v5)?));
            }
            "cell_types" if !poly => {
                if types.is_some() {
                    return Err(lx.err(kp, "a second CELL_TYPES section"));
                }
                let n = lx.count("the number of cell types")?;
                let ids = lx.ints(n, "CELL_TYPES")?;
                let t = ids
                    .into_iter()
                    .map(cell_type)
                    .collect::<Result<Vec<_>, _>>()?;
                types = Some((kp, t));
            }
            _ if poly && group.is_some() => {
                let g = group.unwrap_or_default();
                if groups[g].is_some() {
                    return Err(lx.err(kp, format!("a second {} section", kw.to_ascii_uppercase())));
                }
                groups[g] = Some(lx.cell_array(&kw.to_ascii_uppercase(), v5)?);
                group_pos[g] = kp;
            }
            "point_data" => {
                if point_n.is_some() {
                    return Err(lx.err(kp, "a second POINT_DATA section"));
                }
                point_n = Some((kp, lx.count("the POINT_DATA count")?));
                target = Target::Point;
            }
            "cell_data" => {
                if cell_n.is_some() {
                    return Err(lx.err(kp, "a second CELL_DATA section"));
                }
                cell_n = Some((kp, lx.count("the CELL_DATA count")?));
                target = Target::Cell;
            }
            "metadata" => lx.skip_metadata(),
            _ => {
                let (fields, n) = match target {
                    Target::Point => (&mut point_data, point_n.map(|x| x.1).unwrap_or(0)),
                    Target::Cell => (&mut cell_data, cell_n.map(|x| x.1).unwrap_or(0)),
                    Target::None => (&mut Fields::new(), 0),
                };
                if kw == "field" {
                    read_field(&mut lx, fields, n, target == Target::None)?;
                } else if target != Target::None {
                    read_attribute(&mut lx, kp, &kw, fields, n)?;
                } else {
                    return Err(lx.err(
                        kp,
                        format!(
                            "unknown keyword '{}' (expected POINTS, {}, POINT_DATA, CELL_DATA, FIELD or METADATA)",
                            shown(tok),
                            if poly { "VERTICES, LINES, POLYGONS, TRIANGLE_STRIPS" } else { "CELLS, CELL_TYPES" }
                        ),
                    ));
                }
            }
        }
    }

    let positions = positions.unwrap_or_default();
    let npoints = positions.len();
    let (cell_types, offsets, connectivity, file_cells, rows) = if poly {
        let j = join_poly(groups).map_err(|(g, m)| lx.err(group_pos[g], m))?;
        let (t, o, c, n, rows) = (j.types, j.offsets, j.conn, j.file_cells, j.rows);
        if let Some(&v) = c.iter().find(|&&v| v as usize >= npoints) {
            return Err(IoError::malformed(
                Location::Unknown,
                format!("a cell refers to point {v}, but the file has {npoints} points"),
            ));
        }
        (t, o, c, n, rows)
    } else {
        let (cp, g) = match cells {
            Some((p, g)) => (p, g),
            None => (
                0,
                PolyGroup {
                    offsets: vec![0],
                    conn: Vec::new(),
                },
            ),
        };
        let (tp, t) = types.unwrap_or((cp, Vec::new()));
        if t.len() != g.cells() {
            return Err(lx.err(
                tp,
                format!("CELL_TYPES lists {} types for {} cells", t.len(), g.cells()),
            ));
        }
        check_cells(&t, &g.offsets, &g.conn, npoints)
            .map_err(|m| lx.err(cp, format!("CELLS: {m}")))?;
        let n = t.len();
        (t, g.offsets, g.conn, n, None)
    };
    if let Some((p, n)) = point_n
        && n != npoints
    {
        return Err(lx.err(
            p,
            format!("POINT_DATA declares {n} values, but the file has {npoints} points"),
        ));
    }
    if let Some((p, n)) = cell_n
        && n != file_cells
    {
        return Err(lx.err(
            p,
            format!("CELL_DATA declares {n} values, but the file has {file_cells} cells"),
        ));
    }
    let cell_data = match rows {
        Some(rows) => cell_data.select(&rows),
        None => cell_data,
    };
    Ok(CellMesh {
        positions,
        cell_types,
        offsets,
        connectivity,
        point_data,
        cell_data,
    })
}

/// A `FIELD name n` block (keyword read): its arrays go into `fields`, each
/// with `n` tuples (unless `discard`, for dataset-level field data).
fn read_field(
    lx: &mut Lex<'_>,
    fields: &mut Fields,
    n: usize,
    discard: bool,
) -> Result<(), IoError> {
    lx.expect("the FIELD name")?;
    let arrays = lx.count("the number of FIELD arrays")?;
    for _ in 0..arrays {
        while lx.peek_is("METADATA") {
            lx.token();
            lx.skip_metadata();
        }
        let (p, raw) = lx.expect("a FIELD array name")?;
        if raw.eq_ignore_ascii_case(b"NULL_ARRAY") {
            continue;
        }
        let name = decode_name(raw);
        let ncomp = lx.count(&format!("the component count of array '{name}'"))?;
        let ntuples = lx.count(&format!("the tuple count of array '{name}'"))?;
        let ty = lx.scalar(&format!("the data type of array '{name}'"))?;
        if ncomp == 0 {
            return Err(lx.err(p, format!("array '{name}' has 0 components")));
        }
        if !discard && ntuples != n {
            return Err(lx.err(
                p,
                format!("array '{name}' has {ntuples} tuples, but its section declares {n}"),
            ));
        }
        let len = ncomp
            .checked_mul(ntuples)
            .ok_or_else(|| lx.err(p, format!("array '{name}': impossible size")))?;
        let values = lx.values(ty, len, &format!("array '{name}'"))?;
        if !discard {
            let f = Field::new(name, ncomp, values).map_err(|e| lx.err(p, e.to_string()))?;
            fields.insert(f);
        }
    }
    Ok(())
}

/// An attribute (`SCALARS`, `VECTORS`, ...; keyword `kw` read at `kp`) of
/// `n` tuples.
fn read_attribute(
    lx: &mut Lex<'_>,
    kp: usize,
    kw: &str,
    fields: &mut Fields,
    n: usize,
) -> Result<(), IoError> {
    let name_of = |lx: &mut Lex<'_>| -> Result<String, IoError> {
        Ok(decode_name(
            lx.expect(&format!("the {} name", kw.to_ascii_uppercase()))?
                .1,
        ))
    };
    let size = |lx: &Lex<'_>, ncomp: usize| {
        ncomp
            .checked_mul(n)
            .ok_or_else(|| lx.err(kp, "impossible array size"))
    };
    let (name, ncomp, values) = match kw {
        "scalars" => {
            let name = name_of(lx)?;
            let ty = lx.scalar("the SCALARS data type")?;
            let ncomp = match lx.line_token() {
                Some((p, t)) => std::str::from_utf8(t)
                    .ok()
                    .and_then(|s| s.parse::<usize>().ok())
                    .filter(|&c| c >= 1)
                    .ok_or_else(|| {
                        lx.err(
                            p,
                            format!("expected a component count, found '{}'", shown(t)),
                        )
                    })?,
                None => 1,
            };
            if lx.peek_is("LOOKUP_TABLE") {
                lx.token();
                lx.line_token();
            }
            let len = size(lx, ncomp)?;
            let v = lx.values(ty, len, &format!("SCALARS '{name}'"))?;
            (name, ncomp, v)
        }
        "color_scalars" => {
            let name = name_of(lx)?;
            let ncomp = lx.count("the COLOR_SCALARS component count")?;
            if ncomp == 0 {
                return Err(lx.err(kp, "COLOR_SCALARS with 0 components"));
            }
            let len = size(lx, ncomp)?;
            let what = format!("COLOR_SCALARS '{name}'");
            let values = if lx.binary {
                lx.values(Scalar::U8, len, &what)?
            } else {
                let v = into_f64(lx.values(Scalar::F32, len, &what)?);
                FieldValues::U8(
                    v.into_iter()
                        .map(|x| (x * 255.0).round().clamp(0.0, 255.0) as u8)
                        .collect(),
                )
            };
            (name, ncomp, values)
        }
        "lookup_table" => {
            lx.expect("the LOOKUP_TABLE name")?;
            let entries = lx.count("the LOOKUP_TABLE size")?;
            let len = entries
                .checked_mul(4)
                .ok_or_else(|| lx.err(kp, "impossible LOOKUP_TABLE size"))?;
            let ty = if lx.binary { Scalar::U8 } else { Scalar::F32 };
            lx.values(ty, len, "LOOKUP_TABLE")?;
            return Ok(());
        }
        "vectors" | "normals" | "tensors" | "tensors6" | "global_ids" | "pedigree_ids" => {
            let ncomp = match kw {
                "vectors" | "normals" => 3,
                "tensors" => 9,
                "tensors6" => 6,
                _ => 1,
            };
            let name = name_of(lx)?;
            let ty = lx.scalar(&format!("the {} data type", kw.to_ascii_uppercase()))?;
            let len = size(lx, ncomp)?;
            let v = lx.values(ty, len, &format!("{} '{name}'", kw.to_ascii_uppercase()))?;
            (name, ncomp, v)
        }
        "texture_coordinates" => {
            let name = name_of(lx)?;
            let ncomp = lx.count("the TEXTURE_COORDINATES dimension")?;
            if ncomp == 0 {
                return Err(lx.err(kp, "TEXTURE_COORDINATES with dimension 0"));
            }
            let ty = lx.scalar("the TEXTURE_COORDINATES data type")?;
            let len = size(lx, ncomp)?;
            let v = lx.values(ty, len, &format!("TEXTURE_COORDINATES '{name}'"))?;
            (name, ncomp, v)
        }
        _ => {
            return Err(lx.err(
                kp,
                format!(
                    "unknown keyword '{}' in point or cell data (expected SCALARS, VECTORS, \
                     NORMALS, TEXTURE_COORDINATES, TENSORS, COLOR_SCALARS, LOOKUP_TABLE, FIELD, ...)",
                    kw.to_ascii_uppercase()
                ),
            ));
        }
    };
    let f = Field::new(name, ncomp, values).map_err(|e| lx.err(kp, e.to_string()))?;
    fields.insert(f);
    Ok(())
}

// ---------------------------------------------------------------------------
// Writing.
// ---------------------------------------------------------------------------

/// Array names legacy VTK can hold: white space and control characters
/// become `_`, an empty name `unnamed`, and names made equal get suffixes.
fn legacy_names(fields: &Fields) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(fields.len());
    for f in fields {
        let mut base = String::with_capacity(f.name().len());
        for c in f.name().chars() {
            match c {
                '%' => base.push_str("%25"),
                c if c.is_whitespace() || c.is_control() => base.push('_'),
                c => base.push(c),
            }
        }
        if base.is_empty() {
            base = "unnamed".into();
        }
        let mut name = base.clone();
        let mut k = 2;
        while out.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        out.push(name);
    }
    out
}

/// Whether the mesh can be written as POLYDATA and read back identically.
fn is_polydata(mesh: &CellMesh) -> bool {
    let mut last = 0;
    mesh.cells().all(|(t, vs)| {
        let Some(c) = poly_class(t) else { return false };
        let ok = c >= last && poly_type(c, vs.len()) == Some(t);
        last = c;
        ok
    })
}

struct Out {
    buf: Vec<u8>,
    binary: bool,
    v5: bool,
}

impl Out {
    fn text(&mut self, args: std::fmt::Arguments<'_>) {
        let _ = self.buf.write_fmt(args);
    }

    fn i32s(&mut self, v: impl Iterator<Item = i64>, per_line: usize) -> Result<(), IoError> {
        let mut k = 0;
        for x in v {
            let x = i32::try_from(x).map_err(|_| {
                IoError::unsupported(format!(
                    "value {x} does not fit the 32-bit integers of VTK legacy 4.2; write version 5.1"
                ))
            })?;
            if self.binary {
                self.buf.extend_from_slice(&x.to_be_bytes());
            } else {
                self.text(format_args!("{x}"));
                k += 1;
                self.buf.push(if k % per_line == 0 { b'\n' } else { b' ' });
            }
        }
        self.end_data();
        Ok(())
    }

    fn i64s(&mut self, v: impl Iterator<Item = i64>) {
        for x in v {
            if self.binary {
                self.buf.extend_from_slice(&x.to_be_bytes());
            } else {
                self.text(format_args!("{x}\n"));
            }
        }
        self.end_data();
    }

    fn end_data(&mut self) {
        if self.binary || self.buf.last() != Some(&b'\n') {
            self.buf.push(b'\n');
        }
    }

    /// Cells `range` of the mesh under `keyword` (`CELLS`, `LINES`, ...).
    fn cells(
        &mut self,
        keyword: &str,
        mesh: &CellMesh,
        range: std::ops::Range<usize>,
    ) -> Result<(), IoError> {
        let offs = &mesh.offsets[range.start..=range.end];
        let base = offs[0];
        let conn = &mesh.connectivity[base..offs[offs.len() - 1]];
        let n = range.len();
        if self.v5 {
            self.text(format_args!(
                "{keyword} {} {}\nOFFSETS vtktypeint64\n",
                n + 1,
                conn.len()
            ));
            self.i64s(offs.iter().map(|&o| (o - base) as i64));
            self.text(format_args!("CONNECTIVITY vtktypeint64\n"));
            self.i64s(conn.iter().map(|&v| i64::from(v)));
        } else {
            self.text(format_args!("{keyword} {n} {}\n", n + conn.len()));
            if self.binary {
                let vals = offs.windows(2).flat_map(|w| {
                    std::iter::once((w[1] - w[0]) as i64)
                        .chain(mesh.connectivity[w[0]..w[1]].iter().map(|&v| i64::from(v)))
                });
                self.i32s(vals, 1)?;
            } else {
                for w in offs.windows(2) {
                    let vs = &mesh.connectivity[w[0]..w[1]];
                    self.text(format_args!("{}", vs.len()));
                    for v in vs {
                        self.text(format_args!(" {v}"));
                    }
                    self.buf.push(b'\n');
                }
            }
        }
        Ok(())
    }

    fn fields(&mut self, section: &str, fields: &Fields, n: usize) {
        if fields.is_empty() {
            return;
        }
        self.text(format_args!(
            "{section} {n}\nFIELD FieldData {}\n",
            fields.len()
        ));
        for (f, name) in fields.iter().zip(legacy_names(fields)) {
            let ty = match f.values() {
                FieldValues::F64(_) => "double",
                FieldValues::F32(_) => "float",
                FieldValues::I64(_) => "vtktypeint64",
                FieldValues::I32(_) => "int",
                FieldValues::U8(_) => "unsigned_char",
            };
            self.text(format_args!(
                "{name} {} {} {ty}\n",
                f.components(),
                f.tuples()
            ));
            if self.binary {
                let b = &mut self.buf;
                match f.values() {
                    FieldValues::F64(v) => {
                        v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()))
                    }
                    FieldValues::F32(v) => {
                        v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()))
                    }
                    FieldValues::I64(v) => {
                        v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()))
                    }
                    FieldValues::I32(v) => {
                        v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()))
                    }
                    FieldValues::U8(v) => b.extend_from_slice(v),
                }
            } else {
                put_ascii_values(&mut self.buf, f.values(), f.components());
            }
            self.end_data();
        }
    }
}

/// Serializes a mesh as a legacy VTK file: `BINARY` (big-endian) unless
/// `opts.ascii`, version 4.2 or 5.1 by `opts.legacy_version`, `POLYDATA`
/// when the cells allow it without changing them or their order, else
/// `UNSTRUCTURED_GRID` (see the module documentation).
pub fn write(mesh: &CellMesh, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    let v5 = opts.legacy_version == LegacyVersion::V5_1;
    let binary = !opts.ascii;
    let poly = is_polydata(mesh);
    let estimate = if binary {
        mesh.num_points() * 24 + mesh.connectivity.len() * 8 + mesh.num_cells() * 16 + 256
    } else {
        mesh.num_points() * 60 + mesh.connectivity.len() * 8 + mesh.num_cells() * 8 + 256
    };
    let mut o = Out {
        buf: Vec::with_capacity(estimate),
        binary,
        v5,
    };
    o.text(format_args!(
        "# vtk DataFile Version {}\nunfold\n{}\nDATASET {}\n",
        if v5 { "5.1" } else { "4.2" },
        if binary { "BINARY" } else { "ASCII" },
        if poly {
            "POLYDATA"
        } else {
            "UNSTRUCTURED_GRID"
        }
    ));
    o.text(format_args!("POINTS {} double\n", mesh.num_points()));
    for p in &mesh.positions {
        if binary {
            for c in [p.x, p.y, p.z] {
                o.buf.extend_from_slice(&c.to_be_bytes());
            }
        } else {
            put_f64(&mut o.buf, p.x);
            o.buf.push(b' ');
            put_f64(&mut o.buf, p.y);
            o.buf.push(b' ');
            put_f64(&mut o.buf, p.z);
            o.buf.push(b'\n');
        }
    }
    o.end_data();
    if poly {
        let mut start = 0;
        for (class, keyword) in ["VERTICES", "LINES", "POLYGONS"].into_iter().enumerate() {
            let end = start
                + mesh.cell_types[start..]
                    .iter()
                    .take_while(|&&t| poly_class(t) == Some(class))
                    .count();
            if end > start {
                o.cells(keyword, mesh, start..end)?;
            }
            start = end;
        }
    } else {
        o.cells("CELLS", mesh, 0..mesh.num_cells())?;
        o.text(format_args!("CELL_TYPES {}\n", mesh.num_cells()));
        o.i32s(mesh.cell_types.iter().map(|&t| i64::from(t.vtk_id())), 1)?;
    }
    o.fields("POINT_DATA", &mesh.point_data, mesh.num_points());
    o.fields("CELL_DATA", &mesh.cell_data, mesh.num_cells());
    Ok(o.buf)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Finite coordinates of every magnitude (normal, subnormal, zero).
    fn coord() -> impl Strategy<Value = f64> {
        use proptest::num::f64::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
        prop_oneof![
            (POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO),
            -1e3..1e3f64,
        ]
    }

    fn values(variant: usize, n: usize) -> BoxedStrategy<FieldValues> {
        use prop::collection::vec;
        match variant {
            0 => vec(any::<f64>(), n).prop_map(FieldValues::F64).boxed(),
            1 => vec(any::<f32>(), n).prop_map(FieldValues::F32).boxed(),
            2 => vec(any::<i64>(), n).prop_map(FieldValues::I64).boxed(),
            3 => vec(any::<i32>(), n).prop_map(FieldValues::I32).boxed(),
            _ => vec(any::<u8>(), n).prop_map(FieldValues::U8).boxed(),
        }
    }

    /// Up to 5 fields of `tuples` tuples, of every variant and 1..=4
    /// components, with unique names matching `name_re`.
    fn fields(tuples: usize, name_re: &'static str) -> BoxedStrategy<Fields> {
        prop::collection::vec((0..5usize, 1..=4usize, name_re), 0..=5)
            .prop_flat_map(move |specs| {
                let parts: Vec<_> = specs
                    .into_iter()
                    .enumerate()
                    .map(|(k, (variant, ncomp, name))| {
                        let name = format!("{name}{k}");
                        values(variant, tuples * ncomp).prop_map(move |v| {
                            Field::new(name.clone(), ncomp, v).expect("valid field")
                        })
                    })
                    .collect();
                parts.prop_map(|fs| fs.into_iter().collect::<Fields>())
            })
            .boxed()
    }

    /// Which cells a generated mesh holds.
    #[derive(Debug, Clone, Copy)]
    pub(crate) enum Cells {
        /// Any cell type, any order.
        Any,
        /// 0..2-dimensional cells of the type VTK infers from their size, in
        /// any order.
        Poly,
        /// Like `Poly`, sorted as verts, lines, polys.
        PolySorted,
    }

    /// A random mesh: points of all magnitudes, cells as `kind` says, point
    /// and cell data of every type; names matching `name_re`.
    pub(crate) fn arb_mesh(kind: Cells, name_re: &'static str) -> BoxedStrategy<CellMesh> {
        let types: Vec<CellType> = match kind {
            Cells::Any => CellType::ALL.to_vec(),
            _ => CellType::ALL
                .into_iter()
                .filter(|t| t.dimension() < 3)
                .collect(),
        };
        (1..10usize)
            .prop_flat_map(move |np| {
                let cell = (
                    prop::sample::select(types.clone()),
                    0..4usize,
                    prop::collection::vec(0..np as u32, 12),
                );
                (
                    prop::collection::vec([coord(), coord(), coord()], np),
                    prop::collection::vec(cell, 0..12),
                )
            })
            .prop_flat_map(move |(pts, cells)| {
                let mut m = CellMesh::from_points(
                    pts.iter().map(|c| Point3::new(c[0], c[1], c[2])).collect(),
                );
                let mut cells = cells;
                if matches!(kind, Cells::PolySorted) {
                    cells.sort_by_key(|c| c.0.dimension());
                }
                for (t, extra, vs) in cells {
                    let size = match (kind, t) {
                        (_, t) if t.fixed_size().is_some() => t.min_size(),
                        (Cells::Any, t) => t.min_size() + extra,
                        (_, CellType::PolyVertex) => 2 + extra,
                        (_, CellType::PolyLine) => 3 + extra,
                        _ => 5 + extra,
                    };
                    m.push_cell(t, &vs[..size]);
                }
                let (np, nc) = (m.num_points(), m.num_cells());
                (Just(m), fields(np, name_re), fields(nc, name_re))
            })
            .prop_map(|(mut m, pd, cd)| {
                m.point_data = pd;
                m.cell_data = cd;
                m
            })
            .boxed()
    }

    fn same_values(a: &FieldValues, b: &FieldValues) -> bool {
        use FieldValues::*;
        let f = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        match (a, b) {
            (F64(x), F64(y)) => x.len() == y.len() && x.iter().zip(y).all(|(&x, &y)| f(x, y)),
            (F32(x), F32(y)) => {
                x.len() == y.len()
                    && x.iter()
                        .zip(y)
                        .all(|(&x, &y)| f(f64::from(x), f64::from(y)))
            }
            (I64(x), I64(y)) => x == y,
            (I32(x), I32(y)) => x == y,
            (U8(x), U8(y)) => x == y,
            _ => false,
        }
    }

    fn same_fields(a: &Fields, b: &Fields, what: &str) -> Result<(), TestCaseError> {
        prop_assert_eq!(a.len(), b.len(), "{} count", what);
        for (x, y) in a.iter().zip(b) {
            prop_assert_eq!(x.name(), y.name());
            prop_assert_eq!(x.components(), y.components(), "{}", x.name());
            prop_assert!(
                same_values(x.values(), y.values()),
                "{} '{}': {:?} != {:?}",
                what,
                x.name(),
                x.values(),
                y.values()
            );
        }
        Ok(())
    }

    /// Bit-exact positions, identical cells and arrays.
    pub(crate) fn assert_same(a: &CellMesh, b: &CellMesh) -> Result<(), TestCaseError> {
        let bits = |m: &CellMesh| {
            m.positions
                .iter()
                .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .collect::<Vec<_>>()
        };
        prop_assert_eq!(bits(a), bits(b));
        prop_assert_eq!(&a.cell_types, &b.cell_types);
        prop_assert_eq!(&a.offsets, &b.offsets);
        prop_assert_eq!(&a.connectivity, &b.connectivity);
        same_fields(&a.point_data, &b.point_data, "point data")?;
        same_fields(&a.cell_data, &b.cell_data, "cell data")
    }

    fn all_opts() -> Vec<WriteOptions> {
        let mut v = Vec::new();
        for ascii in [false, true] {
            for legacy_version in [LegacyVersion::V4_2, LegacyVersion::V5_1] {
                v.push(WriteOptions {
                    ascii,
                    legacy_version,
                    ..WriteOptions::default()
                });
            }
        }
        v
    }

    fn location(e: IoError) -> (Location, String) {
        match e {
            IoError::Malformed {
                location, message, ..
            } => (location, message),
            e => panic!("expected a malformed-file error, got {e}"),
        }
    }

    /// A small mesh of every feature, for truncation and corruption tests.
    fn sample(kind: Cells) -> CellMesh {
        let mut m = CellMesh::from_points(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.5, -2.25, 1e-300),
            Point3::new(0.1, 1e300, 3.0),
            Point3::new(-7.0, 2.0, 0.5),
        ]);
        match kind {
            Cells::Any => {
                m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
                m.push_cell(CellType::Line, &[0, 3]);
                m.push_cell(CellType::Triangle, &[0, 1, 2]);
            }
            _ => {
                m.push_cell(CellType::Vertex, &[2]);
                m.push_cell(CellType::Line, &[0, 3]);
                m.push_cell(CellType::Triangle, &[0, 1, 2]);
                m.push_cell(CellType::Quad, &[0, 1, 2, 3]);
            }
        }
        let nc = m.num_cells();
        m.add_point_field(Field::vectors(
            "v",
            &[
                [1.0, 2.0, 3.0],
                [4.0, 5.0, 6.0],
                [7.0, 8.0, 9.0],
                [0.5, 0.25, 0.125],
            ],
        ))
        .unwrap();
        m.add_point_field(Field::new("u8", 1, FieldValues::U8(vec![1, 2, 3, 255])).unwrap())
            .unwrap();
        m.add_cell_field(Field::labels("label", (0..nc as i32).collect()))
            .unwrap();
        m.add_cell_field(
            Field::new(
                "big",
                1,
                FieldValues::I64((0..nc as i64).map(|i| i << 40).collect()),
            )
            .unwrap(),
        )
        .unwrap();
        m.add_cell_field(
            Field::new(
                "f32",
                2,
                FieldValues::F32((0..2 * nc).map(|i| i as f32 / 3.0).collect()),
            )
            .unwrap(),
        )
        .unwrap();
        m
    }

    #[test]
    fn ascii_42_polydata_by_hand() {
        let text = "# vtk DataFile Version 4.2
a hand-written polydata
ASCII

DATASET POLYDATA
FIELD FieldData 1
TIME 1 1 double
0.5
POINTS 5 float
0 0 0  1 0 0  1 1 0
0 1 0  0.5 0.5 1
METADATA
INFORMATION 0

POLYGONS 2 9
4 0 1 2 3
3 0 1 4
LINES 1 4
3 0 2 4
TRIANGLE_STRIPS 1 5
4 0 1 3 2
POINT_DATA 5
SCALARS temperature double 1
LOOKUP_TABLE default
1 2 3 4 5
NORMALS n float
0 0 1 0 0 1 0 0 1 0 0 1 0 0 1
COLOR_SCALARS rgb 3
1 0 0  0 1 0  0 0 1  0.5 0.5 0.5  1 1 1
TEXTURE_COORDINATES uv 2 float
0 0 1 0 1 1 0 1 0.5 0.5
CELL_DATA 4
SCALARS id%20x int
LOOKUP_TABLE my_table
10 20 30 40
LOOKUP_TABLE my_table 2
0 0 0 1  1 1 1 1
FIELD FieldData 2
w 2 4 unsigned_char
1 2 3 4 5 6 7 8
NULL_ARRAY
";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 5);
        assert_eq!(m.positions[4], Point3::new(0.5, 0.5, 1.0));
        // Cells in VTK order: lines, polygons, strip triangles.
        assert_eq!(
            m.cell_types,
            vec![
                CellType::PolyLine,
                CellType::Quad,
                CellType::Triangle,
                CellType::Triangle,
                CellType::Triangle
            ]
        );
        assert_eq!(m.offsets, vec![0, 3, 7, 10, 13, 16]);
        assert_eq!(
            m.connectivity,
            vec![0, 2, 4, 0, 1, 2, 3, 0, 1, 4, 0, 1, 3, 3, 1, 2]
        );
        let t = m.point_data.get("temperature").unwrap();
        assert_eq!(t.values(), &FieldValues::F64(vec![1.0, 2.0, 3.0, 4.0, 5.0]));
        let n = m.point_data.get("n").unwrap();
        assert_eq!((n.components(), n.values().type_name()), (3, "f32"));
        let rgb = m.point_data.get("rgb").unwrap();
        assert_eq!(
            rgb.values(),
            &FieldValues::U8(vec![
                255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128, 255, 255, 255
            ])
        );
        let uv = m.point_data.get("uv").unwrap();
        assert_eq!((uv.components(), uv.get(4, 1)), (2, Some(0.5)));
        // Cell data is in VTK's cell order (verts, lines, polys, strips,
        // whatever the order of the sections); the strip's value repeated.
        let id = m.cell_data.get("id x").unwrap();
        assert_eq!(id.values(), &FieldValues::I32(vec![10, 20, 30, 40, 40]));
        let w = m.cell_data.get("w").unwrap();
        assert_eq!(
            w.values(),
            &FieldValues::U8(vec![1, 2, 3, 4, 5, 6, 7, 8, 7, 8])
        );
        assert!(m.check().is_ok());
    }

    /// A binary 5.1 unstructured grid, assembled byte by byte.
    fn binary_51() -> Vec<u8> {
        let mut b =
            b"# vtk DataFile Version 5.1\nvtk output\nBINARY\nDATASET UNSTRUCTURED_GRID\n".to_vec();
        b.extend_from_slice(b"POINTS 5 double\n");
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.1, 0.2, 1e-310],
        ];
        for c in pts.iter().flatten() {
            b.extend_from_slice(&f64::to_be_bytes(*c));
        }
        b.extend_from_slice(
            b"\nMETADATA\nINFORMATION 2\nNAME L2_NORM_RANGE LOCATION vtkDataArray\n\
              DATA 2 0 1.73205 \nNAME L2_NORM_FINITE_RANGE LOCATION vtkDataArray\n\
              DATA 2 0 1.73205 \n\n",
        );
        b.extend_from_slice(b"CELLS 3 6\nOFFSETS vtktypeint64\n");
        for o in [0i64, 4, 6] {
            b.extend_from_slice(&o.to_be_bytes());
        }
        b.extend_from_slice(b"\nCONNECTIVITY vtktypeint64\n");
        for v in [0i64, 1, 2, 3, 3, 4] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.extend_from_slice(b"\nCELL_TYPES 2\n");
        for t in [10i32, 3] {
            b.extend_from_slice(&t.to_be_bytes());
        }
        b.extend_from_slice(b"\nCELL_DATA 2\nSCALARS mat int 1\nLOOKUP_TABLE default\n");
        for v in [7i32, -8] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.extend_from_slice(b"\nPOINT_DATA 5\nVECTORS disp float\n");
        for i in 0..15 {
            b.extend_from_slice(&(i as f32 * 0.5).to_be_bytes());
        }
        b.extend_from_slice(b"\nCOLOR_SCALARS c 4\n");
        b.extend((0..20u8).map(|i| i * 10));
        b.extend_from_slice(b"\nFIELD FieldData 1\nids 1 5 vtktypeint32\n");
        for i in 0..5i32 {
            b.extend_from_slice(&(100 + i).to_be_bytes());
        }
        b.push(b'\n');
        b
    }

    #[test]
    fn binary_51_unstructured_grid_by_hand() {
        let m = read(&binary_51()).unwrap();
        assert_eq!(m.num_points(), 5);
        assert_eq!(m.positions[4].z, 1e-310);
        assert_eq!(m.cell_types, vec![CellType::Tetra, CellType::Line]);
        assert_eq!(m.offsets, vec![0, 4, 6]);
        assert_eq!(m.connectivity, vec![0, 1, 2, 3, 3, 4]);
        assert_eq!(
            m.cell_data.get("mat").unwrap().values(),
            &FieldValues::I32(vec![7, -8])
        );
        let d = m.point_data.get("disp").unwrap();
        assert_eq!(d.components(), 3);
        assert_eq!(d.get(4, 2), Some(7.0));
        let c = m.point_data.get("c").unwrap();
        assert_eq!((c.components(), c.get(4, 3)), (4, Some(190.0)));
        assert_eq!(
            m.point_data.get("ids").unwrap().values(),
            &FieldValues::I32(vec![100, 101, 102, 103, 104])
        );
        // The same with 32-bit offsets and connectivity.
        let mut b = b"# vtk DataFile Version 5.1\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\n\
                      POINTS 4 float\n"
            .to_vec();
        for i in 0..12 {
            b.extend_from_slice(&(i as f32).to_be_bytes());
        }
        b.extend_from_slice(b"\nCELLS 2 3\nOFFSETS vtktypeint32\n");
        for o in [0i32, 3] {
            b.extend_from_slice(&o.to_be_bytes());
        }
        b.extend_from_slice(b"\nCONNECTIVITY vtktypeint32\n");
        for v in [1i32, 2, 3] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.extend_from_slice(b"\nCELL_TYPES 1\n");
        b.extend_from_slice(&5i32.to_be_bytes());
        let m = read(&b).unwrap();
        assert_eq!(m.cell_types, vec![CellType::Triangle]);
        assert_eq!(m.connectivity, vec![1, 2, 3]);
        assert_eq!(m.positions[3], Point3::new(9.0, 10.0, 11.0));
    }

    #[test]
    fn polydata_or_grid_is_chosen_to_keep_the_cells() {
        let header = |b: &[u8]| String::from_utf8_lossy(&b[..80]).into_owned();
        let opts = WriteOptions::ascii();
        let poly = sample(Cells::PolySorted);
        let b = write(&poly, &opts).unwrap();
        assert!(header(&b).contains("DATASET POLYDATA"), "{}", header(&b));
        let mut unsorted = CellMesh::from_points(poly.positions.clone());
        unsorted.push_cell(CellType::Triangle, &[0, 1, 2]);
        unsorted.push_cell(CellType::Line, &[0, 1]);
        let b = write(&unsorted, &opts).unwrap();
        assert!(header(&b).contains("UNSTRUCTURED_GRID"));
        assert_eq!(read(&b).unwrap(), unsorted);
        // A 4-point polygon would come back as a quad from POLYDATA.
        let mut polygon = CellMesh::from_points(poly.positions.clone());
        polygon.push_cell(CellType::Polygon, &[0, 1, 2, 3]);
        let b = write(&polygon, &opts).unwrap();
        assert!(header(&b).contains("UNSTRUCTURED_GRID"));
        assert_eq!(read(&b).unwrap(), polygon);
    }

    #[test]
    fn names_with_spaces_are_written_with_underscores() {
        let mut m = sample(Cells::Any);
        m.point_data = [
            Field::scalars("a b", vec![0.0; 4]),
            Field::scalars("a_b", vec![1.0; 4]),
            Field::scalars("", vec![2.0; 4]),
            Field::scalars("50%\tdone", vec![3.0; 4]),
        ]
        .into_iter()
        .collect();
        for opts in all_opts() {
            let back = read(&write(&m, &opts).unwrap()).unwrap();
            let names: Vec<_> = back
                .point_data
                .iter()
                .map(|f| f.name().to_string())
                .collect();
            assert_eq!(names, ["a_b", "a_b_2", "unnamed", "50%_done"]);
        }
    }

    #[test]
    fn error_locations_and_messages() {
        let head = "# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";
        let (loc, msg) = location(
            read(format!("{head}POINTS 2 double\n0 0 0\n1 x 0\n").as_bytes()).unwrap_err(),
        );
        assert_eq!(loc, Location::Line(7));
        assert!(msg.contains("'x' is not a valid Float64 value"), "{msg}");

        let (loc, msg) = location(
            read(format!("{head}POINTS 1 double\n0 0 0\nCELLS 1 3\n3 0 0 0\n").as_bytes())
                .unwrap_err(),
        );
        assert_eq!(loc, Location::Line(7));
        assert!(msg.contains("do not fit in the declared size 3"), "{msg}");

        let (loc, msg) = location(
            read(format!("{head}POINTS 1 double\n0 0 0\nBOGUS 3\n").as_bytes()).unwrap_err(),
        );
        assert_eq!(loc, Location::Line(7));
        assert!(msg.contains("unknown keyword 'BOGUS'"), "{msg}");

        let (loc, msg) = location(read(b"hello\n").unwrap_err());
        assert_eq!(loc, Location::Line(1));
        assert!(msg.contains("not a VTK legacy file"), "{msg}");

        // Binary data cut short: the byte offset where it starts.
        let b = binary_51();
        let points_at = b
            .windows(16)
            .position(|w| w == b"POINTS 5 double\n")
            .unwrap()
            + 16;
        let (loc, msg) = location(read(&b[..points_at + 20]).unwrap_err());
        assert_eq!(loc, Location::Byte(points_at as u64));
        assert!(msg.contains("only 20 bytes are left"), "{msg}");

        let e = read(
            format!(
                "{head}POINTS 3 double\n0 0 0 1 0 0 0 1 0\nCELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n22\n"
            )
            .as_bytes(),
        )
        .unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        assert!(e.to_string().contains("cell type 22"), "{e}");

        let e =
            read(b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\n").unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");

        let (loc, msg) = location(
            read(
                format!(
                    "{head}POINTS 2 double\n0 0 0 1 1 1\nPOINT_DATA 3\nSCALARS s float\n1 2 3\n"
                )
                .as_bytes(),
            )
            .unwrap_err(),
        );
        assert_eq!(loc, Location::Line(7));
        assert!(msg.contains("POINT_DATA declares 3"), "{msg}");
    }

    #[test]
    fn empty_mesh_round_trips() {
        for opts in all_opts() {
            let m = CellMesh::default();
            assert_eq!(read(&write(&m, &opts).unwrap()).unwrap(), m);
        }
    }

    proptest! {
        #[test]
        fn round_trip_every_version_and_encoding(
            m in prop_oneof![
                arb_mesh(Cells::Any, "[a-zA-Z][a-zA-Z0-9_.]{0,6}"),
                arb_mesh(Cells::PolySorted, "[a-zA-Z][a-zA-Z0-9_.]{0,6}"),
            ]
        ) {
            for opts in all_opts() {
                let bytes = write(&m, &opts).unwrap();
                let back = read(&bytes).unwrap();
                assert_same(&m, &back)?;
            }
        }

        #[test]
        fn random_bytes_are_an_error(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn random_tokens_after_a_header_never_panic(
            binary in any::<bool>(),
            v5 in any::<bool>(),
            poly in any::<bool>(),
            tokens in prop::collection::vec(prop::sample::select(vec![
                "POINTS", "CELLS", "CELL_TYPES", "VERTICES", "LINES", "POLYGONS",
                "TRIANGLE_STRIPS", "POINT_DATA", "CELL_DATA", "SCALARS", "LOOKUP_TABLE",
                "VECTORS", "FIELD", "METADATA", "OFFSETS", "CONNECTIVITY", "COLOR_SCALARS",
                "TEXTURE_COORDINATES", "double", "float", "int", "vtktypeint64", "char",
                "unsigned_long", "0", "1", "2", "3", "4", "-1", "10", "99999999999999999999",
                "18446744073709551615", "1e400", "nan", "\n", "\n\n", "%41", "x",
            ]), 0..60),
        ) {
            let mut text = format!(
                "# vtk DataFile Version {}\nt\n{}\nDATASET {}\n",
                if v5 { "5.1" } else { "4.2" },
                if binary { "BINARY" } else { "ASCII" },
                if poly { "POLYDATA" } else { "UNSTRUCTURED_GRID" }
            );
            text.push_str(&tokens.join(" "));
            let _ = read(text.as_bytes());
        }

        #[test]
        fn corrupted_bytes_never_panic(
            kind in 0..3usize,
            opts in prop::sample::select(all_opts()),
            pokes in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
        ) {
            let m = sample([Cells::Any, Cells::Poly, Cells::PolySorted][kind]);
            let mut b = write(&m, &opts).unwrap();
            for (i, v) in pokes {
                let i = i.index(b.len());
                b[i] = v;
            }
            let _ = read(&b);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        #[test]
        fn truncations_of_random_files_never_panic(
            m in arb_mesh(Cells::Any, "[a-z]{1,4}"),
        ) {
            for opts in all_opts() {
                let b = write(&m, &opts).unwrap();
                for n in 0..b.len() {
                    let _ = read(&b[..n]);
                }
            }
        }
    }

    #[test]
    fn every_truncation_never_panics() {
        for kind in [Cells::Any, Cells::PolySorted] {
            for opts in all_opts() {
                let b = write(&sample(kind), &opts).unwrap();
                assert!(read(&b).is_ok());
                for n in 0..b.len() {
                    let _ = read(&b[..n]);
                }
            }
        }
    }
}
