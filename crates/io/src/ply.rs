//! Stanford PLY `.ply`: `ascii`, `binary_little_endian` and
//! `binary_big_endian`.
//!
//! The parser and writer are written here rather than taken from `ply-rs-bw`
//! (the maintained ply-rs fork): that crate reports binary errors by element
//! number rather than byte offset, stores every vertex as a hash map of
//! properties, and aborts the process (out of memory) on a 70-byte header
//! declaring a property-less element with a huge count.
//!
//! Reading:
//! - `vertex`: the scalar properties `x`, `y`, `z` (any numeric type) are the
//!   positions; every other scalar vertex property becomes a point-data field
//!   (list properties are skipped).
//! - `face`: the list `vertex_indices` (or `vertex_index`), any count and
//!   index types; 3 vertices make a triangle, 4 a quad, more a polygon (fewer
//!   than 3 is an error). Other scalar face properties become cell-data
//!   fields; other lists are skipped.
//! - Every other element (`edge`, `material`, ...) is skipped, in binary
//!   files too. A file without a `face` element is a point set: points and no
//!   cells.
//! - Field types: `uchar` → U8; `char`, `short`, `ushort`, `int` → I32;
//!   `uint` → I64; `float` → F32; `double` → F64. Consecutive properties
//!   `name_0`, `name_1`, ..., `name_{k-1}` (k ≥ 2) of one type are read as one
//!   field `name` with k components (unless another property is called
//!   `name`).
//! - Errors give the 1-based line (header, ASCII data) or the byte offset
//!   (binary data).
//!
//! Writing (ASCII with [`WriteOptions::ascii`], otherwise binary,
//! little-endian unless [`WriteOptions::big_endian`]):
//! - positions as `double`; ASCII numbers in shortest round-trip form, so
//!   every encoding reads back exactly;
//! - point data as vertex properties, cell data as face properties; a field
//!   with k ≥ 2 components becomes the properties `name_0` ... `name_{k-1}`;
//!   F64 → `double`, F32 → `float`, I32 → `int`, U8 → `uchar`; I64 → `int`
//!   when every value fits in 32 bits, else `double` when every value is
//!   exact in a double (|v| ≤ 2^53), else unsupported;
//! - field names must be non-empty printable ASCII without spaces and must
//!   not clash with `x`, `y`, `z`, `vertex_indices` or each other;
//! - only surface cells (triangles, quads, polygons) are stored, as the
//!   `face` element; point cells (vertex, poly-vertex) are not written (every
//!   point is stored anyway), and then the mesh may not have cell data; line
//!   and volume cells are unsupported.

use crate::off::{Tokens, cap, polygon_type, show};
use crate::{IoError, Location, WriteOptions};
use nalgebra::Point3;
use std::collections::HashSet;
use std::fmt::Write as _;
use unfold_mesh::{CellMesh, Field, FieldValues};

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(s: &str) -> Option<Scalar> {
        use Scalar::*;
        Some(match s {
            "char" | "int8" => I8,
            "uchar" | "uint8" => U8,
            "short" | "int16" => I16,
            "ushort" | "uint16" => U16,
            "int" | "int32" => I32,
            "uint" | "uint32" => U32,
            "float" | "float32" => F32,
            "double" | "float64" => F64,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        use Scalar::*;
        match self {
            I8 => "char",
            U8 => "uchar",
            I16 => "short",
            U16 => "ushort",
            I32 => "int",
            U32 => "uint",
            F32 => "float",
            F64 => "double",
        }
    }

    fn size(self) -> usize {
        use Scalar::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            F64 => 8,
        }
    }

    /// The value range of an integer type.
    fn int_range(self) -> Option<(i64, i64)> {
        use Scalar::*;
        Some(match self {
            I8 => (i8::MIN.into(), i8::MAX.into()),
            U8 => (0, u8::MAX.into()),
            I16 => (i16::MIN.into(), i16::MAX.into()),
            U16 => (0, u16::MAX.into()),
            I32 => (i32::MIN.into(), i32::MAX.into()),
            U32 => (0, u32::MAX.into()),
            F32 | F64 => return None,
        })
    }
}

/// A value read from a file.
#[derive(Debug, Clone, Copy)]
enum Num {
    Int(i64),
    F32(f32),
    F64(f64),
}

impl Num {
    fn f64(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::F32(x) => x.into(),
            Num::F64(x) => x,
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Scalar(Scalar),
    /// A list: count type, item type.
    List(Scalar, Scalar),
}

#[derive(Debug)]
struct Prop {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
    /// Header line of the `element` statement.
    line: usize,
}

impl Element {
    /// The smallest number of bytes one row can take.
    fn min_row_bytes(&self, binary: bool) -> usize {
        if !binary {
            return 2 * self.props.len();
        }
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(t) | Kind::List(t, _) => t.size(),
            })
            .sum()
    }

    /// The row size if every property is a scalar.
    fn fixed_row_bytes(&self) -> Option<usize> {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(t) => Some(t.size()),
                Kind::List(..) => None,
            })
            .sum()
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Le,
    Be,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    data_start: usize,
    end_line: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, IoError> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(IoError::malformed(
                Location::Line(line_no.max(1)),
                "unexpected end of file in the header; expected 'end_header'",
            ));
        }
        let rest = bytes.get(pos..).unwrap_or_default();
        let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
            Some(n) => (rest.get(..n).unwrap_or_default(), pos + n + 1),
            None => (rest, bytes.len()),
        };
        pos = next;
        line_no += 1;
        let err = |msg: String| IoError::malformed(Location::Line(line_no), msg);
        let Ok(text) = std::str::from_utf8(raw) else {
            return Err(if line_no == 1 {
                err("not a PLY file: the first line must be 'ply'".into())
            } else {
                err("the header line is not text".into())
            });
        };
        let text = text.trim();
        if line_no == 1 {
            if text != "ply" {
                return Err(err(format!(
                    "not a PLY file: the first line must be 'ply', found '{}'",
                    show(text.as_bytes())
                )));
            }
            continue;
        }
        let mut words = text.split_whitespace();
        match words.next() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                encoding = Some(match words.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Le,
                    Some("binary_big_endian") => Encoding::Be,
                    other => {
                        return Err(err(format!(
                            "unknown format '{}'; expected ascii, binary_little_endian or binary_big_endian",
                            other.unwrap_or("")
                        )));
                    }
                });
                if words.next().is_none() {
                    return Err(err("the format line has no version (e.g. '1.0')".into()));
                }
            }
            Some("element") => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(err("expected 'element <name> <count>'".into()));
                };
                let Ok(count) = count.parse::<usize>() else {
                    return Err(err(format!(
                        "element '{name}': expected a count, found '{}'",
                        show(count.as_bytes())
                    )));
                };
                if elements.iter().any(|e| e.name == name) {
                    return Err(err(format!("element '{name}' is declared twice")));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(err("a property comes before any element".into()));
                };
                let scalar = |w: Option<&str>| {
                    let w = w.unwrap_or("");
                    Scalar::from_name(w).ok_or_else(|| {
                        err(format!(
                            "unknown property type '{}'; expected char, uchar, short, ushort, int, uint, float, double (or int8 ... float64)",
                            show(w.as_bytes())
                        ))
                    })
                };
                let first = words.next();
                let kind = if first == Some("list") {
                    let count_type = scalar(words.next())?;
                    if count_type.int_range().is_none() {
                        return Err(err(format!(
                            "list count type '{}' must be an integer type",
                            count_type.name()
                        )));
                    }
                    Kind::List(count_type, scalar(words.next())?)
                } else {
                    Kind::Scalar(scalar(first)?)
                };
                let Some(name) = words.next() else {
                    return Err(err("the property has no name".into()));
                };
                if element.props.iter().any(|p| p.name == name) {
                    return Err(err(format!(
                        "property '{name}' of element '{}' is declared twice",
                        element.name
                    )));
                }
                element.props.push(Prop {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => {
                let Some(encoding) = encoding else {
                    return Err(err("'end_header' before any 'format' line".into()));
                };
                return Ok(Header {
                    encoding,
                    elements,
                    data_start: pos,
                    end_line: line_no,
                });
            }
            Some(other) => {
                return Err(err(format!(
                    "unknown header keyword '{}'; expected format, element, property, comment or end_header",
                    show(other.as_bytes())
                )));
            }
        }
    }
}

/// Where the values of the data section come from.
trait Source {
    /// Reads one value of type `t`; the error says what went wrong.
    fn num(&mut self, t: Scalar) -> Result<Num, String>;
    /// The location of the last value read (or attempted).
    fn loc(&self) -> Location;
    /// Bytes left.
    fn remaining(&self) -> usize;
    /// Skips `n` bytes of a binary file (Err if there are not so many).
    fn skip_bytes(&mut self, n: usize) -> Result<(), String>;
}

struct Ascii<'a> {
    t: Tokens<'a>,
}

impl Source for Ascii<'_> {
    fn num(&mut self, t: Scalar) -> Result<Num, String> {
        let Some(tok) = self.t.next() else {
            return Err(format!("unexpected end of file; expected a {}", t.name()));
        };
        let bad = || format!("expected a {}, found '{}'", t.name(), show(tok));
        match t.int_range() {
            Some((lo, hi)) => {
                let v: i64 = crate::off::parse(tok).ok_or_else(bad)?;
                if v < lo || v > hi {
                    return Err(format!("{v} is out of range for a {}", t.name()));
                }
                Ok(Num::Int(v))
            }
            None if t == Scalar::F32 => crate::off::parse(tok).map(Num::F32).ok_or_else(bad),
            None => crate::off::parse(tok).map(Num::F64).ok_or_else(bad),
        }
    }

    fn loc(&self) -> Location {
        self.t.location()
    }

    fn remaining(&self) -> usize {
        self.t.remaining()
    }

    fn skip_bytes(&mut self, _n: usize) -> Result<(), String> {
        Err("internal error: byte skipping in an ASCII file".into())
    }
}

struct Binary<'a> {
    bytes: &'a [u8],
    pos: usize,
    last: usize,
    big: bool,
}

impl Binary<'_> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let end = self.pos.checked_add(N)?;
        let a: [u8; N] = self.bytes.get(self.pos..end)?.try_into().ok()?;
        self.pos = end;
        Some(if self.big {
            let mut a = a;
            a.reverse();
            a
        } else {
            a
        })
    }
}

impl Source for Binary<'_> {
    fn num(&mut self, t: Scalar) -> Result<Num, String> {
        use Scalar::*;
        self.last = self.pos;
        let eof = || {
            format!(
                "unexpected end of file; expected a {} ({} bytes)",
                t.name(),
                t.size()
            )
        };
        // `take` returns little-endian byte order.
        Ok(match t {
            I8 => Num::Int(i8::from_le_bytes(self.take().ok_or_else(eof)?).into()),
            U8 => Num::Int(u8::from_le_bytes(self.take().ok_or_else(eof)?).into()),
            I16 => Num::Int(i16::from_le_bytes(self.take().ok_or_else(eof)?).into()),
            U16 => Num::Int(u16::from_le_bytes(self.take().ok_or_else(eof)?).into()),
            I32 => Num::Int(i32::from_le_bytes(self.take().ok_or_else(eof)?).into()),
            U32 => Num::Int(u32::from_le_bytes(self.take().ok_or_else(eof)?).into()),
            F32 => Num::F32(f32::from_le_bytes(self.take().ok_or_else(eof)?)),
            F64 => Num::F64(f64::from_le_bytes(self.take().ok_or_else(eof)?)),
        })
    }

    fn loc(&self) -> Location {
        Location::Byte(self.last as u64)
    }

    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    fn skip_bytes(&mut self, n: usize) -> Result<(), String> {
        self.last = self.pos;
        if n > self.remaining() {
            return Err(format!(
                "unexpected end of file; expected {n} more bytes, found {}",
                self.remaining()
            ));
        }
        self.pos += n;
        Ok(())
    }
}

/// A column of one scalar property, in the field type it will become.
enum Column {
    U8(Vec<u8>),
    I32(Vec<i32>),
    I64(Vec<i64>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

impl Column {
    fn new(t: Scalar, capacity: usize) -> Column {
        use Scalar::*;
        match t {
            U8 => Column::U8(Vec::with_capacity(capacity)),
            I8 | I16 | U16 | I32 => Column::I32(Vec::with_capacity(capacity)),
            U32 => Column::I64(Vec::with_capacity(capacity)),
            F32 => Column::F32(Vec::with_capacity(capacity)),
            F64 => Column::F64(Vec::with_capacity(capacity)),
        }
    }

    /// Appends a value (read with this column's scalar type, so in range).
    fn push(&mut self, v: Num) {
        match self {
            Column::U8(c) => c.push(v.f64() as u8),
            Column::I32(c) => c.push(v.f64() as i32),
            Column::I64(c) => c.push(v.f64() as i64),
            Column::F32(c) => c.push(match v {
                Num::F32(x) => x,
                other => other.f64() as f32,
            }),
            Column::F64(c) => c.push(v.f64()),
        }
    }

    fn into_values(self) -> FieldValues {
        match self {
            Column::U8(v) => FieldValues::U8(v),
            Column::I32(v) => FieldValues::I32(v),
            Column::I64(v) => FieldValues::I64(v),
            Column::F32(v) => FieldValues::F32(v),
            Column::F64(v) => FieldValues::F64(v),
        }
    }
}

fn interleave<T: Copy>(cols: &[&Vec<T>]) -> Vec<T> {
    let rows = cols.first().map_or(0, |c| c.len());
    let mut out = Vec::with_capacity(rows * cols.len());
    for r in 0..rows {
        for c in cols {
            if let Some(&v) = c.get(r) {
                out.push(v);
            }
        }
    }
    out
}

/// Joins same-typed columns into one multi-component array (None if the
/// types differ).
fn join(cols: Vec<FieldValues>) -> Option<FieldValues> {
    macro_rules! join_as {
        ($variant:ident) => {{
            let parts: Option<Vec<_>> = cols
                .iter()
                .map(|c| match c {
                    FieldValues::$variant(v) => Some(v),
                    _ => None,
                })
                .collect();
            Some(FieldValues::$variant(interleave(&parts?)))
        }};
    }
    match cols.first()? {
        FieldValues::F64(_) => join_as!(F64),
        FieldValues::F32(_) => join_as!(F32),
        FieldValues::I64(_) => join_as!(I64),
        FieldValues::I32(_) => join_as!(I32),
        FieldValues::U8(_) => join_as!(U8),
    }
}

/// Turns named columns into fields, joining `name_0`, `name_1`, ... runs.
fn make_fields(cols: Vec<(String, Scalar, Column)>) -> Vec<Field> {
    let names: HashSet<String> = cols.iter().map(|c| c.0.clone()).collect();
    let mut out = Vec::new();
    let mut cols = cols.into_iter().peekable();
    while let Some((name, t, col)) = cols.next() {
        let base = name.strip_suffix("_0").filter(|b| !b.is_empty());
        let Some(base) = base.filter(|b| !names.contains(*b)) else {
            if let Ok(f) = Field::new(name, 1, col.into_values()) {
                out.push(f);
            }
            continue;
        };
        let base = base.to_string();
        let mut group = vec![col.into_values()];
        while let Some((n, t2, _)) = cols.peek() {
            if *t2 != t || *n != format!("{base}_{}", group.len()) {
                break;
            }
            if let Some((_, _, c)) = cols.next() {
                group.push(c.into_values());
            }
        }
        let k = group.len();
        if k == 1 {
            if let Some(v) = group.pop()
                && let Ok(f) = Field::new(name, 1, v)
            {
                out.push(f);
            }
        } else if let Some(v) = join(group)
            && let Ok(f) = Field::new(base, k, v)
        {
            out.push(f);
        }
    }
    out
}

fn read_value<S: Source>(
    src: &mut S,
    t: Scalar,
    e: &Element,
    row: usize,
    prop: &str,
) -> Result<Num, IoError> {
    src.num(t).map_err(|m| {
        IoError::malformed(
            src.loc(),
            format!("element '{}' {row}, property '{prop}': {m}", e.name),
        )
    })
}

/// Reads a list count (must be >= 0).
fn read_count<S: Source>(
    src: &mut S,
    t: Scalar,
    e: &Element,
    row: usize,
    prop: &str,
) -> Result<usize, IoError> {
    match read_value(src, t, e, row, prop)? {
        Num::Int(n) if n >= 0 => Ok(n as usize),
        n => Err(IoError::malformed(
            src.loc(),
            format!(
                "element '{}' {row}, property '{prop}': invalid list length {}",
                e.name,
                n.f64()
            ),
        )),
    }
}

fn skip_element<S: Source>(src: &mut S, e: &Element, binary: bool) -> Result<(), IoError> {
    if e.props.is_empty() || e.count == 0 {
        return Ok(());
    }
    if binary && let Some(row) = e.fixed_row_bytes() {
        let total = row.saturating_mul(e.count);
        return src.skip_bytes(total).map_err(|m| {
            IoError::malformed(
                src.loc(),
                format!("element '{}' ({} rows): {m}", e.name, e.count),
            )
        });
    }
    for row in 0..e.count {
        for p in &e.props {
            match p.kind {
                Kind::Scalar(t) => {
                    read_value(src, t, e, row, &p.name)?;
                }
                Kind::List(ct, it) => {
                    let n = read_count(src, ct, e, row, &p.name)?;
                    for _ in 0..n {
                        read_value(src, it, e, row, &p.name)?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Columns for the scalar properties of `e` other than `skip`.
fn columns<S: Source>(
    src: &S,
    e: &Element,
    binary: bool,
    skip: &[usize],
) -> Vec<Option<(String, Scalar, Column)>> {
    let rows = cap(e.count, src.remaining(), e.min_row_bytes(binary));
    e.props
        .iter()
        .enumerate()
        .map(|(j, p)| match p.kind {
            Kind::Scalar(t) if !skip.contains(&j) => {
                Some((p.name.clone(), t, Column::new(t, rows)))
            }
            _ => None,
        })
        .collect()
}

fn read_vertices<S: Source>(
    src: &mut S,
    e: &Element,
    binary: bool,
) -> Result<(Vec<Point3<f64>>, Vec<Field>), IoError> {
    let find = |name: &str| {
        e.props
            .iter()
            .position(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
            .ok_or_else(|| {
                IoError::malformed(
                    Location::Line(e.line),
                    format!("the vertex element has no scalar property '{name}'"),
                )
            })
    };
    let xyz = [find("x")?, find("y")?, find("z")?];
    let mut cols = columns(src, e, binary, &xyz);
    let mut positions = Vec::with_capacity(cap(e.count, src.remaining(), e.min_row_bytes(binary)));
    for row in 0..e.count {
        let mut p = [0.0f64; 3];
        let mut row_loc = None;
        for (j, prop) in e.props.iter().enumerate() {
            match prop.kind {
                Kind::Scalar(t) => {
                    let v = read_value(src, t, e, row, &prop.name)?;
                    row_loc.get_or_insert(src.loc());
                    if let Some(k) = xyz.iter().position(|&x| x == j) {
                        p[k] = v.f64();
                    } else if let Some(Some((_, _, c))) = cols.get_mut(j) {
                        c.push(v);
                    }
                }
                Kind::List(ct, it) => {
                    let n = read_count(src, ct, e, row, &prop.name)?;
                    row_loc.get_or_insert(src.loc());
                    for _ in 0..n {
                        read_value(src, it, e, row, &prop.name)?;
                    }
                }
            }
        }
        if !p.iter().all(|c| c.is_finite()) {
            return Err(IoError::malformed(
                row_loc.unwrap_or(Location::Unknown),
                format!(
                    "vertex {row} has a non-finite coordinate ({}, {}, {})",
                    p[0], p[1], p[2]
                ),
            ));
        }
        positions.push(Point3::new(p[0], p[1], p[2]));
    }
    Ok((positions, make_fields(cols.into_iter().flatten().collect())))
}

fn read_faces<S: Source>(
    src: &mut S,
    e: &Element,
    binary: bool,
    num_vertices: usize,
    mesh: &mut CellMesh,
) -> Result<Vec<Field>, IoError> {
    let idx = e
        .props
        .iter()
        .position(|p| {
            (p.name == "vertex_indices" || p.name == "vertex_index")
                && matches!(p.kind, Kind::List(..))
        })
        .ok_or_else(|| {
            IoError::malformed(
                Location::Line(e.line),
                "the face element has no list property 'vertex_indices' (or 'vertex_index')",
            )
        })?;
    if let Some(Prop {
        kind: Kind::List(_, it),
        name,
    }) = e.props.get(idx)
        && it.int_range().is_none()
    {
        return Err(IoError::malformed(
            Location::Line(e.line),
            format!(
                "face property '{name}' holds {} values; vertex indices must be integers",
                it.name()
            ),
        ));
    }
    let mut cols = columns(src, e, binary, &[]);
    let rows = cap(e.count, src.remaining(), e.min_row_bytes(binary));
    mesh.cell_types.reserve(rows);
    mesh.offsets.reserve(rows);
    for row in 0..e.count {
        for (j, prop) in e.props.iter().enumerate() {
            match prop.kind {
                Kind::Scalar(t) => {
                    let v = read_value(src, t, e, row, &prop.name)?;
                    if let Some(Some((_, _, c))) = cols.get_mut(j) {
                        c.push(v);
                    }
                }
                Kind::List(ct, it) if j == idx => {
                    let n = read_count(src, ct, e, row, &prop.name)?;
                    if n < 3 {
                        return Err(IoError::malformed(
                            src.loc(),
                            format!("face {row} has {n} vertices; a face needs at least 3"),
                        ));
                    }
                    for _ in 0..n {
                        let v = read_value(src, it, e, row, &prop.name)?.f64();
                        if v < 0.0 || v >= num_vertices as f64 || v > u32::MAX as f64 {
                            return Err(IoError::malformed(
                                src.loc(),
                                format!(
                                    "face {row} refers to vertex {v}, but the file has {num_vertices} vertices"
                                ),
                            ));
                        }
                        mesh.connectivity.push(v as u32);
                    }
                    mesh.cell_types.push(polygon_type(n));
                    mesh.offsets.push(mesh.connectivity.len());
                }
                Kind::List(ct, it) => {
                    let n = read_count(src, ct, e, row, &prop.name)?;
                    for _ in 0..n {
                        read_value(src, it, e, row, &prop.name)?;
                    }
                }
            }
        }
    }
    Ok(make_fields(cols.into_iter().flatten().collect()))
}

fn read_data<S: Source>(src: &mut S, h: &Header) -> Result<CellMesh, IoError> {
    let binary = h.encoding != Encoding::Ascii;
    if !h.elements.iter().any(|e| e.name == "vertex") {
        return Err(IoError::malformed(
            Location::Line(h.end_line),
            "the header declares no 'vertex' element",
        ));
    }
    let num_vertices = h
        .elements
        .iter()
        .find(|e| e.name == "vertex")
        .map_or(0, |e| e.count);
    let mut mesh = CellMesh::default();
    let mut point_fields = Vec::new();
    let mut cell_fields = Vec::new();
    for e in &h.elements {
        match e.name.as_str() {
            "vertex" => {
                let (p, f) = read_vertices(src, e, binary)?;
                mesh.positions = p;
                point_fields = f;
            }
            "face" => cell_fields = read_faces(src, e, binary, num_vertices, &mut mesh)?,
            _ => skip_element(src, e, binary)?,
        }
    }
    for f in point_fields {
        mesh.add_point_field(f)?;
    }
    for f in cell_fields {
        mesh.add_cell_field(f)?;
    }
    Ok(mesh)
}

/// Parses a PLY file's bytes (see the module documentation).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let h = parse_header(bytes)?;
    match h.encoding {
        Encoding::Ascii => {
            let mut t = Tokens::new(bytes, None);
            t.seek(h.data_start);
            read_data(&mut Ascii { t }, &h)
        }
        Encoding::Le | Encoding::Be => read_data(
            &mut Binary {
                bytes,
                pos: h.data_start,
                last: h.data_start,
                big: h.encoding == Encoding::Be,
            },
            &h,
        ),
    }
}

/// How a field is written: its property type and property names.
struct Plan<'a> {
    field: &'a Field,
    ty: Scalar,
    names: Vec<String>,
}

fn plan<'a>(
    fields: impl Iterator<Item = &'a Field>,
    what: &str,
    reserved: &[&str],
) -> Result<Vec<Plan<'a>>, IoError> {
    let mut used: HashSet<String> = reserved.iter().map(|s| s.to_string()).collect();
    let mut out = Vec::new();
    for f in fields {
        let name = f.name();
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_graphic()) {
            return Err(IoError::unsupported(format!(
                "PLY property names must be printable ASCII without spaces; {what} field '{name}' cannot be written"
            )));
        }
        let ty = match f.values() {
            FieldValues::F64(_) => Scalar::F64,
            FieldValues::F32(_) => Scalar::F32,
            FieldValues::I32(_) => Scalar::I32,
            FieldValues::U8(_) => Scalar::U8,
            FieldValues::I64(v) => {
                if v.iter().all(|&x| i32::try_from(x).is_ok()) {
                    Scalar::I32
                } else if v.iter().all(|&x| x.unsigned_abs() <= 1u64 << 53) {
                    Scalar::F64
                } else {
                    return Err(IoError::unsupported(format!(
                        "{what} field '{name}' holds 64-bit integers beyond ±2^53, which PLY (int or double) cannot store exactly"
                    )));
                }
            }
        };
        let names: Vec<String> = if f.components() == 1 {
            vec![name.to_string()]
        } else {
            (0..f.components()).map(|k| format!("{name}_{k}")).collect()
        };
        for n in &names {
            if !used.insert(n.clone()) {
                return Err(IoError::unsupported(format!(
                    "{what} field '{name}' would be written as PLY property '{n}', which is already taken"
                )));
            }
        }
        out.push(Plan {
            field: f,
            ty,
            names,
        });
    }
    Ok(out)
}

/// Where written values go.
enum Sink {
    Text(String, bool),
    Bin(Vec<u8>, bool),
}

impl Sink {
    fn put(&mut self, ty: Scalar, v: Num) {
        match self {
            Sink::Text(s, first) => {
                if !*first {
                    s.push(' ');
                }
                *first = false;
                let _ = match v {
                    Num::Int(i) => write!(s, "{i}"),
                    Num::F32(x) => write!(s, "{x:?}"),
                    Num::F64(x) => write!(s, "{x:?}"),
                };
            }
            Sink::Bin(b, big) => {
                macro_rules! bytes {
                    ($x:expr) => {
                        if *big {
                            b.extend_from_slice(&$x.to_be_bytes())
                        } else {
                            b.extend_from_slice(&$x.to_le_bytes())
                        }
                    };
                }
                let i = match v {
                    Num::Int(i) => i,
                    _ => 0,
                };
                match ty {
                    Scalar::I8 => bytes!(i as i8),
                    Scalar::U8 => bytes!(i as u8),
                    Scalar::I16 => bytes!(i as i16),
                    Scalar::U16 => bytes!(i as u16),
                    Scalar::I32 => bytes!(i as i32),
                    Scalar::U32 => bytes!(i as u32),
                    Scalar::F32 => bytes!(match v {
                        Num::F32(x) => x,
                        other => other.f64() as f32,
                    }),
                    Scalar::F64 => bytes!(v.f64()),
                }
            }
        }
    }

    fn end_row(&mut self) {
        if let Sink::Text(s, first) = self {
            s.push('\n');
            *first = true;
        }
    }
}

fn field_value(v: &FieldValues, k: usize) -> Num {
    match v {
        FieldValues::F64(a) => Num::F64(a.get(k).copied().unwrap_or(0.0)),
        FieldValues::F32(a) => Num::F32(a.get(k).copied().unwrap_or(0.0)),
        FieldValues::I64(a) => Num::Int(a.get(k).copied().unwrap_or(0)),
        FieldValues::I32(a) => Num::Int(a.get(k).copied().unwrap_or(0).into()),
        FieldValues::U8(a) => Num::Int(a.get(k).copied().unwrap_or(0).into()),
    }
}

fn put_fields(sink: &mut Sink, plans: &[Plan], row: usize) {
    for p in plans {
        let c = p.field.components();
        for k in 0..c {
            let v = field_value(p.field.values(), row * c + k);
            // I64 planned as double is converted here (exact by the plan).
            let v = match (p.ty, v) {
                (Scalar::F64, Num::Int(i)) => Num::F64(i as f64),
                (_, v) => v,
            };
            sink.put(p.ty, v);
        }
    }
}

fn header_props(h: &mut String, plans: &[Plan]) {
    for p in plans {
        for n in &p.names {
            let _ = writeln!(h, "property {} {n}", p.ty.name());
        }
    }
}

/// Serializes a mesh as PLY (see the module documentation).
pub fn write(mesh: &CellMesh, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    let mut faces = Vec::new();
    let mut point_cells = false;
    for (i, (t, _)) in mesh.cells().enumerate() {
        match t.dimension() {
            0 => point_cells = true,
            2 => faces.push(i),
            _ => {
                return Err(IoError::unsupported(format!(
                    "PLY stores points and polygons only; cell {i} is a {t:?}"
                )));
            }
        }
    }
    if point_cells && !mesh.cell_data.is_empty() {
        return Err(IoError::unsupported(
            "PLY does not store point cells, so their cell data cannot be written",
        ));
    }
    let point_plans = plan(mesh.point_data.iter(), "point", &["x", "y", "z"])?;
    let cell_plans = plan(mesh.cell_data.iter(), "cell", &["vertex_indices"])?;
    let max_len = faces
        .iter()
        .map(|&i| mesh.offsets[i + 1] - mesh.offsets[i])
        .max()
        .unwrap_or(0);
    let count_type = if max_len <= 255 {
        Scalar::U8
    } else {
        Scalar::U32
    };
    let index_type = if mesh.num_points() <= i32::MAX as usize {
        Scalar::I32
    } else {
        Scalar::U32
    };

    let mut h = String::from("ply\n");
    let _ = writeln!(
        h,
        "format {} 1.0",
        if opts.ascii {
            "ascii"
        } else if opts.big_endian {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        }
    );
    h.push_str("comment written by unfold\n");
    let _ = writeln!(h, "element vertex {}", mesh.num_points());
    h.push_str("property double x\nproperty double y\nproperty double z\n");
    header_props(&mut h, &point_plans);
    let with_faces = !faces.is_empty() || !cell_plans.is_empty();
    if with_faces {
        let _ = writeln!(h, "element face {}", faces.len());
        let _ = writeln!(
            h,
            "property list {} {} vertex_indices",
            count_type.name(),
            index_type.name()
        );
        header_props(&mut h, &cell_plans);
    }
    h.push_str("end_header\n");

    let mut sink = if opts.ascii {
        Sink::Text(h, true)
    } else {
        let mut b = h.into_bytes();
        b.reserve(mesh.num_points() * 24 + mesh.connectivity.len() * 4 + faces.len());
        Sink::Bin(b, opts.big_endian)
    };
    for (i, p) in mesh.positions.iter().enumerate() {
        for c in [p.x, p.y, p.z] {
            sink.put(Scalar::F64, Num::F64(c));
        }
        put_fields(&mut sink, &point_plans, i);
        sink.end_row();
    }
    if with_faces {
        for (row, &i) in faces.iter().enumerate() {
            let (_, vs) = mesh.cell(i);
            sink.put(count_type, Num::Int(vs.len() as i64));
            for &v in vs {
                sink.put(index_type, Num::Int(v.into()));
            }
            put_fields(&mut sink, &cell_plans, row);
            sink.end_row();
        }
    }
    Ok(match sink {
        Sink::Text(s, _) => s.into_bytes(),
        Sink::Bin(b, _) => b,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::off::test_support::*;
    use proptest::prelude::*;
    use unfold_mesh::CellType;

    const DATA: &str = "../../tests/data/cobiveco-geo2";

    #[test]
    fn ply_reads_cobiveco_files() {
        for (name, nv, nf) in [
            ("heart_endo_lv.ply", 6309, 12479),
            ("heart_endo_rv.ply", 5859, 11533),
            ("heart_epi.ply", 11321, 22388),
            ("heart_base.ply", 1349, 2125),
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(DATA)
                .join(name);
            let bytes = std::fs::read(&path).unwrap();
            let m = read(&bytes).unwrap();
            assert_eq!(m.num_points(), nv, "{name}");
            assert_eq!(m.num_cells(), nf, "{name}");
            assert!(
                m.cell_types.iter().all(|&t| t == CellType::Triangle),
                "{name}"
            );
            m.check().unwrap();
            // Binary round trip of a real file (positions widen from float).
            let again = read(&write(&m, &WriteOptions::default()).unwrap()).unwrap();
            assert_eq!(again, m);
        }
    }

    const ASCII: &str = "ply
format ascii 1.0
comment hand-written
element vertex 4
property float x
property float y
property double z
property uchar red
property uchar green
property uchar blue
property float quality
element face 2
property list uint8 uint32 vertex_index
property int label
element edge 1
property int vertex1
property int vertex2
end_header
0 0 0 255 0 0 0.5
1 0 0 0 255 0 1.5
1 1 0 0 0 255 2.5
0 1 0.25 9 9 9 3.5
3 0 1 2 7
4 0 1 2 3 -8
0 1
";

    #[test]
    fn ply_reads_ascii_with_properties() {
        let m = read(ASCII.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 4);
        assert_eq!(m.positions[3], Point3::new(0.0, 1.0, 0.25));
        assert_eq!(m.cell_types, vec![CellType::Triangle, CellType::Quad]);
        assert_eq!(m.connectivity, vec![0, 1, 2, 0, 1, 2, 3]);
        assert_eq!(
            m.point_data.get("red").unwrap().values(),
            &FieldValues::U8(vec![255, 0, 0, 9])
        );
        assert_eq!(
            m.point_data.get("quality").unwrap().values(),
            &FieldValues::F32(vec![0.5, 1.5, 2.5, 3.5])
        );
        assert_eq!(
            m.cell_data.get("label").unwrap().values(),
            &FieldValues::I32(vec![7, -8])
        );
        m.check().unwrap();
    }

    /// Big-endian file with an unknown element holding lists before the faces.
    fn big_endian_file() -> Vec<u8> {
        let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty short x\nproperty float y\nproperty double z\nelement material 2\nproperty list ushort float weights\nproperty char k\nelement face 1\nproperty uchar flags\nproperty list int ushort vertex_indices\nend_header\n".to_vec();
        for (x, y, z) in [(1i16, 2.5f32, -3.0f64), (4, 5.0, 6.0), (-7, 8.0, 9.5)] {
            b.extend_from_slice(&x.to_be_bytes());
            b.extend_from_slice(&y.to_be_bytes());
            b.extend_from_slice(&z.to_be_bytes());
        }
        for n in [2u16, 0] {
            b.extend_from_slice(&n.to_be_bytes());
            for _ in 0..n {
                b.extend_from_slice(&1.0f32.to_be_bytes());
            }
            b.push(0xff);
        }
        b.push(3);
        b.extend_from_slice(&3i32.to_be_bytes());
        for v in [2u16, 1, 0] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b
    }

    #[test]
    fn ply_reads_big_endian_and_skips_unknown_elements() {
        let m = read(&big_endian_file()).unwrap();
        assert_eq!(m.positions[0], Point3::new(1.0, 2.5, -3.0));
        assert_eq!(m.positions[2], Point3::new(-7.0, 8.0, 9.5));
        assert_eq!(m.cell(0), (CellType::Triangle, &[2, 1, 0][..]));
        assert_eq!(
            m.cell_data.get("flags").unwrap().values(),
            &FieldValues::U8(vec![3])
        );
    }

    #[test]
    fn ply_point_set_and_multi_component_names() {
        let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float n_0\nproperty float n_1\nproperty float n_2\nproperty int a_0\nend_header\n0 0 0 1 2 3 4\n1 1 1 5 6 7 8\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_cells(), 0);
        let n = m.point_data.get("n").unwrap();
        assert_eq!(n.components(), 3);
        assert_eq!(n.values(), &FieldValues::F32(vec![1., 2., 3., 5., 6., 7.]));
        assert_eq!(m.point_data.get("a_0").unwrap().components(), 1);
    }

    #[test]
    fn ply_errors_give_lines_and_byte_offsets() {
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"plx\n".to_vec(), "line 1: not a PLY file"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty foo x\n".to_vec(), "line 4: unknown property type"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n".to_vec(), "expected 'end_header'"),
            (b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 oops 1\n".to_vec(), "line 9: element 'vertex' 1, property 'y': expected a float, found 'oops'"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 0 1\n".to_vec(), "line 11: face 0 refers to vertex 1"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n".to_vec(), "line 3: the vertex element has no scalar property 'z'"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty uchar x\nproperty float y\nproperty float z\nend_header\n256 0 0\n".to_vec(), "out of range"),
            // Binary: the data starts at byte 115 (x), y at 119 is cut short.
            (b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0\0\0".to_vec(), "byte 119: element 'vertex' 0, property 'y'"),
            // ply-rs-bw aborts (out of memory) on this one.
            (b"ply\nformat binary_little_endian 1.0\nelement foo 9999999999999\nend_header\n".to_vec(), "no 'vertex' element"),
            (b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n\0\0\0\0\0\0\xf8\x7f\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0".to_vec(), "byte 118: vertex 0 has a non-finite coordinate"),
        ];
        for (bytes, want) in cases {
            let e = read(&bytes).unwrap_err().to_string();
            assert!(e.contains(want), "{}: {e}", String::from_utf8_lossy(&bytes));
        }
    }

    #[test]
    fn ply_write_rules() {
        let mut m = CellMesh::from_points(vec![Point3::origin(); 4]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        let mut m = CellMesh::from_points(vec![Point3::origin(); 3]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        m.add_point_field(Field::scalars("x", vec![0.0; 3]))
            .unwrap();
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        m.point_data = Default::default();
        m.add_point_field(Field::scalars("a b", vec![0.0; 3]))
            .unwrap();
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        m.point_data = Default::default();
        m.add_point_field(Field::new("big", 1, FieldValues::I64(vec![1 << 60, 0, 0])).unwrap())
            .unwrap();
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        // i64 in 32-bit range is written as int, beyond as double.
        m.point_data = Default::default();
        m.add_point_field(Field::new("small", 1, FieldValues::I64(vec![-5, 0, 7])).unwrap())
            .unwrap();
        m.add_point_field(Field::new("wide", 1, FieldValues::I64(vec![1 << 40, 0, 7])).unwrap())
            .unwrap();
        let bytes = write(&m, &WriteOptions::ascii()).unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        assert!(
            text.contains("property int small\nproperty double wide\n"),
            "{text}"
        );
        let back = read(&bytes).unwrap();
        assert_eq!(
            back.point_data.get("small").unwrap().values(),
            &FieldValues::I32(vec![-5, 0, 7])
        );
        // Point cells are not written; the points are.
        let mut p = CellMesh::from_points(vec![Point3::new(1.0, 2.0, 3.0)]);
        p.push_cell(CellType::Vertex, &[0]);
        let back = read(&write(&p, &WriteOptions::ascii()).unwrap()).unwrap();
        assert_eq!(back, CellMesh::from_points(p.positions.clone()));
    }

    #[test]
    fn ply_truncations_never_panic() {
        check_truncations(ASCII.as_bytes(), read);
        check_truncations(&big_endian_file(), read);
        let mut m = read(ASCII.as_bytes()).unwrap();
        m.add_cell_field(Field::vectors("v", &[[1.0, 2.0, 3.0]; 2]))
            .unwrap();
        check_truncations(&write(&m, &WriteOptions::default()).unwrap(), read);
    }

    fn surface_mesh() -> impl Strategy<Value = CellMesh> {
        let cs = cells(
            vec![
                (CellType::Triangle, 3..=3),
                (CellType::Quad, 4..=4),
                (CellType::Polygon, 5..=8),
            ],
            0..12,
        );
        (points(coord(), 0..12), cs, 0usize..3, 0usize..3).prop_flat_map(|(p, c, np, nc)| {
            let m = mesh_with(p, &c);
            let (n, k) = (m.num_points(), m.num_cells());
            let pf: Vec<_> = (0..np).map(|i| field(format!("pf{i}"), n)).collect();
            let cf: Vec<_> = (0..nc).map(|i| field(format!("cf{i}"), k)).collect();
            (Just(m), pf, cf).prop_map(|(mut m, pf, cf)| {
                for f in pf {
                    m.add_point_field(f).unwrap();
                }
                for f in cf {
                    m.add_cell_field(f).unwrap();
                }
                m
            })
        })
    }

    fn same_mesh(a: &CellMesh, b: &CellMesh) -> Result<(), TestCaseError> {
        prop_assert_eq!(&a.positions, &b.positions);
        prop_assert_eq!(&a.cell_types, &b.cell_types);
        prop_assert_eq!(&a.offsets, &b.offsets);
        prop_assert_eq!(&a.connectivity, &b.connectivity);
        for (x, y) in [(&a.point_data, &b.point_data), (&a.cell_data, &b.cell_data)] {
            prop_assert_eq!(x.len(), y.len());
            for (f, g) in x.iter().zip(y.iter()) {
                prop_assert!(same_values(f, g), "{:?} vs {:?}", f, g);
            }
        }
        Ok(())
    }

    proptest! {
        #[test]
        fn ply_round_trip_all_encodings(m in surface_mesh()) {
            for opts in [
                WriteOptions::ascii(),
                WriteOptions::default(),
                WriteOptions { big_endian: true, ..WriteOptions::default() },
            ] {
                let bytes = write(&m, &opts).unwrap();
                let back = read(&bytes).unwrap();
                same_mesh(&m, &back)?;
            }
        }

        #[test]
        fn ply_random_bytes_are_errors(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn ply_random_data_after_header_never_panics(
            head in prop::sample::select(vec![ASCII.split("end_header\n").next().unwrap().to_string() + "end_header\n",
                "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n".to_string(),
                "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty uchar x\nproperty int y\nproperty short z\nelement face 1\nproperty list uint uint vertex_indices\nend_header\n".to_string()]),
            tail in prop::collection::vec(any::<u8>(), 0..200),
        ) {
            let mut bytes = head.into_bytes();
            bytes.extend(tail);
            if let Ok(m) = read(&bytes) {
                prop_assert!(m.check().is_ok());
            }
        }

        #[test]
        fn ply_corruptions_never_panic(
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
            which in 0usize..2,
        ) {
            let mut bytes = if which == 0 { ASCII.as_bytes().to_vec() } else { big_endian_file() };
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
