//! VTK XML files: unstructured grids (`.vtu`) and polydata (`.vtp`).
//!
//! Reading ([`read`], which tells the two apart by `<VTKFile type=...>`):
//! - Array formats `ascii`, `binary` (base64 inside the `<DataArray>`) and
//!   `appended` (`<AppendedData encoding="raw">` or `encoding="base64"`);
//!   `header_type` `UInt32` (the default) or `UInt64`; `byte_order`
//!   `LittleEndian` or `BigEndian`; no compression or
//!   `compressor="vtkZLibDataCompressor"` (other compressors, LZ4 and LZMA,
//!   are reported as unsupported). Base64 data is accepted with the header
//!   encoded separately (as VTK writes compressed data) or together with
//!   the data.
//! - Array types `Int8` ... `Int64`, `UInt8` ... `UInt64`, `Float32`,
//!   `Float64`, mapped into [`FieldValues`]: `Float64` -> `F64`, `Float32`
//!   -> `F32`, `Int64`, `UInt32`, `UInt64` -> `I64` (a value above
//!   `i64::MAX` is an error), `Int8`, `Int16`, `UInt16`, `Int32` -> `I32`,
//!   `UInt8` -> `U8`. Other array types (strings, bits) are unsupported.
//! - `UnstructuredGrid`: `Points`, `Cells` (`connectivity`, `offsets`,
//!   `types`), `PointData`, `CellData`. `PolyData`: `Points`, `Verts`,
//!   `Lines`, `Strips`, `Polys`, numbered in VTK's cell order (verts, lines,
//!   polys, strips) with the type VTK gives a polydata cell from its size
//!   (1 point vertex, more poly-vertex; 2 line, more polyline; 3 triangle,
//!   4 quad, more polygon); strips are split into triangles, their cell
//!   data repeated. `FieldData` is ignored by [`read`] ([`field_data_text`]
//!   reads one string array of it). One `<Piece>` only. Cell types
//!   are those of [`CellType`]; others are
//!   unsupported.
//!
//! Writing ([`write_vtu`], [`write_vtp`]):
//! - `<VTKFile type=... version="1.0" byte_order="LittleEndian"
//!   header_type="UInt64">`, one `<Piece>`; arrays stored per
//!   [`WriteOptions::xml_encoding`] (appended raw by default, appended
//!   base64, inline base64, or ASCII, which [`WriteOptions::ascii`] also
//!   selects), zlib-compressed in 32 KiB blocks (`vtkZLibDataCompressor`)
//!   when [`WriteOptions::compress`] is set and the encoding is binary.
//! - Points as `Float64` (exact round trip); `connectivity` and `offsets`
//!   as `Int64`, `types` as `UInt8`; point and cell data as their own type
//!   (`Float64`, `Float32`, `Int64`, `Int32`, `UInt8`) with
//!   `NumberOfComponents`. ASCII numbers use the shortest representation
//!   that reads back exactly. Names are XML-escaped (control characters
//!   other than tab, newline and carriage return, which XML cannot hold,
//!   become `_`).
//! - `.vtp` holds vertices, lines and surface cells only (volume cells are
//!   an unsupported error). PolyData stores cells grouped as verts, lines,
//!   polys, so cells are reordered stably into that order when needed,
//!   with their cell data permuted alongside; reading the file back gives
//!   every cell the type VTK infers from its size (so e.g. a 4-point
//!   `Polygon` comes back as a `Quad`).

use crate::vtk_legacy::{
    PolyGroup, Scalar, cell_type, check_cells, checked_offsets, decode_binary, empty_values,
    into_f64, into_i64, into_indices, join_poly, poly_class, push_ascii, put_ascii_values, put_f64,
    shown,
};
use crate::{IoError, Location, WriteOptions, XmlEncoding};
use base64::Engine as _;
use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
use flate2::{Compress, Compression, Decompress, FlushCompress, FlushDecompress, Status};
use nalgebra::Point3;
use quick_xml::Reader;
use quick_xml::events::{BytesStart, Event};
use std::borrow::Cow;
use std::io::Write as _;
use unfold_mesh::{CellMesh, CellType, Field, FieldValues, Fields};

/// Standard base64; decoding accepts missing padding and trailing bits.
const B64: GeneralPurpose = GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    GeneralPurposeConfig::new()
        .with_encode_padding(true)
        .with_decode_padding_mode(DecodePaddingMode::Indifferent)
        .with_decode_allow_trailing_bits(true),
);

/// Uncompressed size of the zlib blocks the writer makes (VTK's default).
const BLOCK: usize = 1 << 15;

/// zlib level of the writer: fast, most of the size gain of higher levels.
const LEVEL: u32 = 1;

// ---------------------------------------------------------------------------
// Reading.
// ---------------------------------------------------------------------------

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    PointData,
    CellData,
    Points,
    Cells,
    Verts,
    Lines,
    Strips,
    Polys,
    /// `<FieldData>` of the dataset (only read by [`field_data_text`]).
    FieldData,
}

impl Section {
    fn from_name(n: &str) -> Option<Section> {
        Some(match n {
            "PointData" => Section::PointData,
            "CellData" => Section::CellData,
            "Points" => Section::Points,
            "Cells" => Section::Cells,
            "Verts" => Section::Verts,
            "Lines" => Section::Lines,
            "Strips" => Section::Strips,
            "Polys" => Section::Polys,
            _ => return None,
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    Binary,
    Appended(usize),
}

struct ArrayDesc<'a> {
    section: Section,
    name: Option<String>,
    ty: String,
    ncomp: usize,
    format: Format,
    text: Cow<'a, [u8]>,
    text_pos: usize,
    pos: usize,
}

impl ArrayDesc<'_> {
    fn label(&self) -> String {
        match &self.name {
            Some(n) => format!("array '{n}'"),
            None => "an unnamed array".into(),
        }
    }
}

enum Elem {
    VtkFile,
    Dataset,
    Piece,
    Section(Section),
    Array(usize),
    Other,
}

#[derive(Default)]
struct Piece {
    pos: usize,
    points: usize,
    cells: usize,
    verts: usize,
    lines: usize,
    strips: usize,
    polys: usize,
}

struct Doc<'a> {
    head: &'a [u8],
    poly: bool,
    big_endian: bool,
    header64: bool,
    /// `Ok(true)` zlib, `Ok(false)` none, `Err(name)` unsupported.
    compressor: Result<bool, String>,
    piece: Option<Piece>,
    arrays: Vec<ArrayDesc<'a>>,
    /// Appended data after the `_`, whether it is raw, and its file offset.
    appended: Option<(&'a [u8], bool, usize)>,
}

fn line_of(text: &[u8], pos: usize) -> usize {
    1 + text
        .get(..pos)
        .unwrap_or(text)
        .iter()
        .filter(|&&c| c == b'\n')
        .count()
}

fn find(hay: &[u8], needle: &[u8], from: usize) -> Option<usize> {
    let first = *needle.first()?;
    let mut i = from;
    while let Some(rest) = hay.get(i..) {
        let k = rest.iter().position(|&c| c == first)?;
        i += k;
        if hay.get(i..i + needle.len()) == Some(needle) {
            return Some(i);
        }
        i += 1;
    }
    None
}

/// Parses a `.vtu` or `.vtp` file's bytes.
///
/// Errors in the XML text carry a line; errors in binary data a byte offset
/// (of the array in the file).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let doc = parse_head(bytes)?;
    if doc.poly {
        build_poly(&doc)
    } else {
        build_grid(&doc)
    }
}

/// The text of the field-data string array `name` of a VTK XML file (its
/// first string: the bytes up to the first NUL), e.g. `"LPS"` for the
/// `SPACE` array 3D Slicer writes into every `.vtu` / `.vtp` model
/// (`<FieldData><Array type="String" Name="SPACE" ...>`). Any encoding
/// the reader supports (ASCII byte values, inline base64, appended, zlib).
/// `Ok(None)` when the file has no such array.
///
/// # Errors
/// As [`read`] for a file that is not VTK XML or whose array data is
/// malformed.
pub fn field_data_text(bytes: &[u8], name: &str) -> Result<Option<String>, IoError> {
    let doc = parse_head(bytes)?;
    let Some(a) = doc.array(Section::FieldData, Some(name)) else {
        return Ok(None);
    };
    // A VTK string array is stored as its bytes, each string ended by a NUL.
    let ty = if a.ty == "String" { "UInt8" } else { &a.ty };
    let bytes_of = ArrayDesc {
        section: a.section,
        name: a.name.clone(),
        ty: ty.to_string(),
        ncomp: 1,
        format: a.format,
        text: a.text.clone(),
        text_pos: a.text_pos,
        pos: a.pos,
    };
    // A frame tag is a few bytes; 1 MiB bounds what a hostile file can make
    // the reader inflate for it.
    let raw: Vec<u8> = match doc.values(&bytes_of, 1 << 20)? {
        FieldValues::U8(v) => v,
        FieldValues::I32(v) => v.iter().map(|&x| x as u8).collect(),
        FieldValues::I64(v) => v.iter().map(|&x| x as u8).collect(),
        FieldValues::F32(_) | FieldValues::F64(_) => return Ok(None),
    };
    let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
    Ok(Some(String::from_utf8_lossy(&raw[..end]).into_owned()))
}

/// Splits off the appended data and parses the XML before it.
fn parse_head(bytes: &[u8]) -> Result<Doc<'_>, IoError> {
    let (head, appended_start) = match find(bytes, b"<AppendedData", 0) {
        Some(p) => {
            let gt = find(bytes, b">", p).ok_or_else(|| {
                IoError::malformed(
                    Location::Line(line_of(bytes, p)),
                    "the <AppendedData> tag is not closed",
                )
            })?;
            let us = find(bytes, b"_", gt).ok_or_else(|| {
                IoError::malformed(
                    Location::Line(line_of(bytes, gt)),
                    "no '_' marks the start of the appended data",
                )
            })?;
            (&bytes[..gt + 1], Some(us + 1))
        }
        None => (bytes, None),
    };
    let err_at =
        |pos: usize, msg: String| IoError::malformed(Location::Line(line_of(head, pos)), msg);
    let mut doc = Doc {
        head,
        poly: false,
        big_endian: false,
        header64: false,
        compressor: Ok(false),
        piece: None,
        arrays: Vec::new(),
        appended: None,
    };
    let mut kind: Option<String> = None;
    let mut appended_raw: Option<bool> = None;
    let mut stack: Vec<Elem> = Vec::new();
    let mut seen_root = false;
    let mut reader = Reader::from_reader(head);
    loop {
        let before = reader.buffer_position() as usize;
        let event = reader.read_event().map_err(|e| {
            err_at(
                reader.error_position() as usize,
                format!("invalid XML: {e}"),
            )
        })?;
        let (e, empty) = match event {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                stack.pop();
                continue;
            }
            Event::Text(t) => {
                let end = reader.buffer_position() as usize;
                if let Some(Elem::Array(i)) = stack.last() {
                    let t = t.into_inner();
                    add_text(&mut doc.arrays[*i], t, end);
                }
                continue;
            }
            Event::CData(t) => {
                let end = reader.buffer_position() as usize;
                if let Some(Elem::Array(i)) = stack.last() {
                    let t = t.into_inner();
                    add_text(&mut doc.arrays[*i], t, end);
                }
                continue;
            }
            Event::GeneralRef(_) => {
                if let Some(Elem::Array(_)) = stack.last() {
                    return Err(err_at(
                        before,
                        "an entity reference inside array data".into(),
                    ));
                }
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        let name = e.local_name();
        let name = name.as_ref();
        let attrs = attributes(&e).map_err(|m| err_at(before, m))?;
        let get = |k: &str| attrs.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str());
        let elem = match stack.last() {
            None => {
                if seen_root || name != "VTKFile" {
                    return Err(err_at(
                        before,
                        format!(
                            "not a VTK XML file: expected the <VTKFile> element, found <{name}>"
                        ),
                    ));
                }
                seen_root = true;
                let t = get("type").unwrap_or("");
                doc.poly = match t {
                    "UnstructuredGrid" => false,
                    "PolyData" => true,
                    "" => return Err(err_at(before, "<VTKFile> has no type attribute".into())),
                    other => {
                        return Err(IoError::unsupported(format!(
                            "VTK XML files of type '{other}' are not supported \
                             (only UnstructuredGrid .vtu and PolyData .vtp)"
                        )));
                    }
                };
                kind = Some(t.to_string());
                doc.big_endian = match get("byte_order").unwrap_or("LittleEndian") {
                    "LittleEndian" => false,
                    "BigEndian" => true,
                    o => {
                        return Err(err_at(
                            before,
                            format!("byte_order '{o}' (expected LittleEndian or BigEndian)"),
                        ));
                    }
                };
                doc.header64 = match get("header_type").unwrap_or("UInt32") {
                    "UInt32" => false,
                    "UInt64" => true,
                    o => {
                        return Err(err_at(
                            before,
                            format!("header_type '{o}' (expected UInt32 or UInt64)"),
                        ));
                    }
                };
                doc.compressor = match get("compressor").unwrap_or("") {
                    "" => Ok(false),
                    "vtkZLibDataCompressor" => Ok(true),
                    o => Err(o.to_string()),
                };
                Elem::VtkFile
            }
            Some(Elem::VtkFile) if Some(name) == kind.as_deref() => Elem::Dataset,
            Some(Elem::VtkFile) if name == "AppendedData" => {
                appended_raw = Some(match get("encoding").unwrap_or("raw") {
                    "raw" => true,
                    "base64" => false,
                    o => {
                        return Err(err_at(
                            before,
                            format!("AppendedData encoding '{o}' (expected raw or base64)"),
                        ));
                    }
                });
                Elem::Other
            }
            Some(Elem::Dataset) if name == "Piece" => {
                if doc.piece.is_some() {
                    return Err(IoError::unsupported(
                        "VTK XML files with more than one <Piece> are not supported",
                    ));
                }
                let count = |k: &str| -> Result<usize, IoError> {
                    match get(k) {
                        None => Ok(0),
                        Some(v) => v.trim().parse::<usize>().map_err(|_| {
                            err_at(
                                before,
                                format!("{k}=\"{}\" is not a count", shown(v.as_bytes())),
                            )
                        }),
                    }
                };
                doc.piece = Some(Piece {
                    pos: before,
                    points: count("NumberOfPoints")?,
                    cells: count("NumberOfCells")?,
                    verts: count("NumberOfVerts")?,
                    lines: count("NumberOfLines")?,
                    strips: count("NumberOfStrips")?,
                    polys: count("NumberOfPolys")?,
                });
                Elem::Piece
            }
            Some(Elem::Piece) => match Section::from_name(name) {
                Some(s) => Elem::Section(s),
                None => Elem::Other,
            },
            Some(Elem::Dataset) if name == "FieldData" => Elem::Section(Section::FieldData),
            // Field data (Slicer's `SPACE` string array) never fails a read:
            // an array it cannot describe is skipped.
            Some(Elem::Section(Section::FieldData)) if name == "Array" || name == "DataArray" => {
                let format = match get("format").unwrap_or("ascii") {
                    "ascii" => Some(Format::Ascii),
                    "binary" => Some(Format::Binary),
                    "appended" => get("offset")
                        .and_then(|o| o.trim().parse::<usize>().ok())
                        .map(Format::Appended),
                    _ => None,
                };
                match (get("type"), format) {
                    (Some(ty), Some(format)) => {
                        doc.arrays.push(ArrayDesc {
                            section: Section::FieldData,
                            name: get("Name").map(str::to_string),
                            ty: ty.to_string(),
                            ncomp: 1,
                            format,
                            text: Cow::Borrowed(&[]),
                            text_pos: before,
                            pos: before,
                        });
                        Elem::Array(doc.arrays.len() - 1)
                    }
                    _ => Elem::Other,
                }
            }
            Some(Elem::Section(s)) if name == "DataArray" => {
                let ty = get("type")
                    .ok_or_else(|| err_at(before, "a <DataArray> without a type".into()))?
                    .to_string();
                let ncomp = match get("NumberOfComponents") {
                    None => 1,
                    Some(v) => v
                        .trim()
                        .parse::<usize>()
                        .ok()
                        .filter(|&n| n > 0)
                        .ok_or_else(|| {
                            err_at(
                                before,
                                format!(
                                    "NumberOfComponents=\"{}\" (expected a positive count)",
                                    shown(v.as_bytes())
                                ),
                            )
                        })?,
                };
                let format = match get("format").unwrap_or("ascii") {
                    "ascii" => Format::Ascii,
                    "binary" => Format::Binary,
                    "appended" => {
                        let off = get("offset").unwrap_or("");
                        Format::Appended(off.trim().parse::<usize>().map_err(|_| {
                            err_at(
                                before,
                                format!(
                                    "offset=\"{}\" is not a byte offset",
                                    shown(off.as_bytes())
                                ),
                            )
                        })?)
                    }
                    o => {
                        return Err(err_at(
                            before,
                            format!(
                                "format '{}' (expected ascii, binary or appended)",
                                shown(o.as_bytes())
                            ),
                        ));
                    }
                };
                doc.arrays.push(ArrayDesc {
                    section: *s,
                    name: get("Name").map(str::to_string),
                    ty,
                    ncomp,
                    format,
                    text: Cow::Borrowed(&[]),
                    text_pos: before,
                    pos: before,
                });
                Elem::Array(doc.arrays.len() - 1)
            }
            Some(_) => Elem::Other,
        };
        if !empty {
            stack.push(elem);
        }
    }
    if !seen_root {
        return Err(IoError::malformed(
            Location::Unknown,
            "not a VTK XML file: no <VTKFile> element",
        ));
    }
    if let Some(start) = appended_start {
        let raw = appended_raw.ok_or_else(|| {
            IoError::malformed(
                Location::Line(line_of(head, head.len())),
                "<AppendedData> is not inside <VTKFile>",
            )
        })?;
        doc.appended = Some((bytes.get(start..).unwrap_or_default(), raw, start));
    }
    Ok(doc)
}

fn add_text<'a>(a: &mut ArrayDesc<'a>, t: Cow<'a, str>, end: usize) {
    if a.text.is_empty() {
        a.text_pos = end.saturating_sub(t.len());
        a.text = match t {
            Cow::Borrowed(s) => Cow::Borrowed(s.as_bytes()),
            Cow::Owned(s) => Cow::Owned(s.into_bytes()),
        };
    } else {
        let v = a.text.to_mut();
        v.push(b' ');
        v.extend_from_slice(t.as_bytes());
    }
}

fn attributes(e: &BytesStart<'_>) -> Result<Vec<(String, String)>, String> {
    let mut out = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|e| format!("invalid attribute: {e}"))?;
        let v = a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|e| format!("invalid attribute value: {e}"))?;
        out.push((a.key.local_name().as_ref().to_string(), v.into_owned()));
    }
    Ok(out)
}

/// White space removed from base64 text (borrowed when only at the ends).
fn compact(text: &[u8]) -> Cow<'_, [u8]> {
    let t = text.trim_ascii();
    if t.iter().any(u8::is_ascii_whitespace) {
        Cow::Owned(
            t.iter()
                .copied()
                .filter(|c| !c.is_ascii_whitespace())
                .collect(),
        )
    } else {
        Cow::Borrowed(t)
    }
}

fn b64_len(n: usize) -> Option<usize> {
    n.div_ceil(3).checked_mul(4)
}

impl<'a> Doc<'a> {
    fn hs(&self) -> usize {
        if self.header64 { 8 } else { 4 }
    }

    fn word(&self, b: &[u8], i: usize) -> Option<usize> {
        let hs = self.hs();
        let c = b.get(i.checked_mul(hs)?..)?.get(..hs)?;
        let v = if self.header64 {
            let mut a = [0u8; 8];
            a.copy_from_slice(c);
            if self.big_endian {
                u64::from_be_bytes(a)
            } else {
                u64::from_le_bytes(a)
            }
        } else {
            let mut a = [0u8; 4];
            a.copy_from_slice(c);
            u64::from(if self.big_endian {
                u32::from_be_bytes(a)
            } else {
                u32::from_le_bytes(a)
            })
        };
        usize::try_from(v).ok()
    }

    fn zlib(&self) -> Result<bool, IoError> {
        self.compressor.clone().map_err(|c| {
            IoError::unsupported(format!(
                "VTK XML compressor '{c}' is not supported (only vtkZLibDataCompressor)"
            ))
        })
    }

    /// The compressed-block header at the start of `b`: block size, last
    /// block size, compressed sizes, and the header length in bytes.
    fn block_header(&self, b: &[u8]) -> Option<(usize, usize, Vec<usize>, usize)> {
        let nb = self.word(b, 0)?;
        let len = nb.checked_add(3)?.checked_mul(self.hs())?;
        let h = b.get(..len)?;
        let sizes = (0..nb)
            .map(|i| self.word(h, 3 + i))
            .collect::<Option<Vec<_>>>()?;
        Some((self.word(h, 1)?, self.word(h, 2)?, sizes, len))
    }

    /// The data of an array stored raw at the start of `b` (`at`: its file
    /// offset, for messages).
    /// `limit`: the most bytes the array can hold (its values times the
    /// type size); compressed data announcing more is refused before it is
    /// inflated.
    fn raw_block<'b>(
        &self,
        b: &'b [u8],
        at: usize,
        limit: usize,
    ) -> Result<Cow<'b, [u8]>, IoError> {
        let bad = |m: &str| IoError::malformed(Location::Byte(at as u64), m.to_string());
        let hs = self.hs();
        if !self.zlib()? {
            let n = self
                .word(b, 0)
                .ok_or_else(|| bad("the data ends inside an array header"))?;
            let data = b.get(hs..).and_then(|r| r.get(..n)).ok_or_else(|| {
                bad(&format!(
                    "the array header announces {n} bytes, but the data ends before"
                ))
            })?;
            Ok(Cow::Borrowed(data))
        } else {
            let (bs, last, sizes, h) = self
                .block_header(b)
                .ok_or_else(|| bad("the data ends inside a compressed-array header"))?;
            let total = sizes.iter().try_fold(0usize, |s, &c| s.checked_add(c));
            let payload = total
                .and_then(|t| b.get(h..)?.get(..t))
                .ok_or_else(|| bad("the data ends inside a compressed array"))?;
            inflate(payload, &sizes, bs, last, limit, at).map(Cow::Owned)
        }
    }

    /// The data of an array stored as base64 at the start of `text` (no
    /// white space inside); `limit` as in [`Doc::raw_block`].
    fn b64_block(&self, text: &[u8], at: usize, limit: usize) -> Result<Vec<u8>, IoError> {
        let bad = |m: &str| IoError::malformed(Location::Byte(at as u64), m.to_string());
        let short = || bad("the base64 data ends early");
        let decode = |t: &[u8]| {
            B64.decode(t)
                .map_err(|e| bad(&format!("invalid base64: {e}")))
        };
        let chunk = |from: usize, n: usize| -> Result<&[u8], IoError> {
            b64_len(n)
                .and_then(|l| text.get(from..)?.get(..l))
                .ok_or_else(short)
        };
        let hs = self.hs();
        let first = decode(chunk(0, hs)?)?;
        let first_chars = b64_len(hs).unwrap_or(0);
        if !self.zlib()? {
            let n = self.word(&first, 0).ok_or_else(short)?;
            // Encoded alone, the header decodes to exactly its own length;
            // encoded with the data, its last quantum holds data bytes too.
            let separate = first.len() == hs;
            let data = if separate {
                decode(chunk(first_chars, n)?)?
            } else {
                let total = n.checked_add(hs).ok_or_else(short)?;
                let mut all = decode(chunk(0, total)?)?;
                all.drain(..hs.min(all.len()));
                all
            };
            if data.len() < n {
                return Err(short());
            }
            let mut data = data;
            data.truncate(n);
            Ok(data)
        } else {
            let nb = self.word(&first, 0).ok_or_else(short)?;
            let h = nb
                .checked_add(3)
                .and_then(|k| k.checked_mul(hs))
                .ok_or_else(|| bad("impossible block count"))?;
            let hchars = b64_len(h).ok_or_else(short)?;
            let header = decode(chunk(0, h)?)?;
            let (bs, last, sizes, _) = self
                .block_header(&header)
                .ok_or_else(|| bad("the compressed-array header ends early"))?;
            let total = sizes
                .iter()
                .try_fold(0usize, |s, &c| s.checked_add(c))
                .ok_or_else(|| bad("impossible compressed sizes"))?;
            let separate = header.len() == h;
            let payload = if separate {
                decode(chunk(hchars, total)?)?
            } else {
                let all_len = h.checked_add(total).ok_or_else(short)?;
                let mut all = decode(chunk(0, all_len)?)?;
                all.drain(..h.min(all.len()));
                all
            };
            let payload = payload.get(..total).ok_or_else(short)?;
            inflate(payload, &sizes, bs, last, limit, at)
        }
    }

    /// The values of an array that holds at most `max_values` values (the
    /// bound that keeps a compressed array from inflating beyond what the
    /// mesh can use).
    fn values(&self, a: &ArrayDesc<'_>, max_values: usize) -> Result<FieldValues, IoError> {
        let ty = Scalar::from_xml(&a.ty).ok_or_else(|| {
            IoError::unsupported(format!(
                "line {}: {} has type '{}', which is not supported (expected Int8..Int64, \
                 UInt8..UInt64, Float32 or Float64)",
                line_of(self.head, a.pos),
                a.label(),
                a.ty
            ))
        })?;
        let limit = max_values.saturating_mul(ty.size());
        let (bytes, at) = match a.format {
            Format::Ascii => {
                let mut out = empty_values(ty, a.text.len() / 2 + 1);
                let mut pos = 0;
                for tok in a.text.split(u8::is_ascii_whitespace) {
                    if !tok.is_empty() && !push_ascii(ty, tok, &mut out) {
                        return Err(IoError::malformed(
                            Location::Line(line_of(self.head, a.text_pos + pos)),
                            format!(
                                "{}: '{}' is not a valid {} value",
                                a.label(),
                                shown(tok),
                                a.ty
                            ),
                        ));
                    }
                    pos += tok.len() + 1;
                }
                return Ok(out);
            }
            Format::Binary => (
                Cow::Owned(self.b64_block(&compact(&a.text), a.text_pos, limit)?),
                a.text_pos,
            ),
            Format::Appended(off) => {
                let (data, raw, start) = self.appended.ok_or_else(|| {
                    IoError::malformed(
                        Location::Line(line_of(self.head, a.pos)),
                        format!(
                            "{} is appended, but the file has no <AppendedData>",
                            a.label()
                        ),
                    )
                })?;
                let at = start.saturating_add(off);
                let rest = data.get(off..).ok_or_else(|| {
                    IoError::malformed(
                        Location::Line(line_of(self.head, a.pos)),
                        format!("{} has offset {off}, beyond the appended data", a.label()),
                    )
                })?;
                if raw {
                    (self.raw_block(rest, at, limit)?, at)
                } else {
                    (Cow::Owned(self.b64_block(rest, at, limit)?), at)
                }
            }
        };
        decode_binary(ty, &bytes, self.big_endian).map_err(|m| {
            IoError::malformed(Location::Byte(at as u64), format!("{}: {m}", a.label()))
        })
    }

    /// The values of an array that must hold `tuples` tuples.
    fn tuples(&self, a: &ArrayDesc<'_>, tuples: usize) -> Result<FieldValues, IoError> {
        let expected = tuples.checked_mul(a.ncomp);
        let v = self.values(a, expected.unwrap_or(usize::MAX))?;
        if Some(v.len()) != expected {
            return Err(IoError::malformed(
                Location::Line(line_of(self.head, a.pos)),
                format!(
                    "{} holds {} values, expected {tuples} tuples of {} components",
                    a.label(),
                    v.len(),
                    a.ncomp
                ),
            ));
        }
        Ok(v)
    }

    fn array(&self, s: Section, name: Option<&str>) -> Option<&ArrayDesc<'a>> {
        self.arrays
            .iter()
            .find(|a| a.section == s && (name.is_none() || a.name.as_deref() == name))
    }

    fn err(&self, pos: usize, msg: String) -> IoError {
        IoError::malformed(Location::Line(line_of(self.head, pos)), msg)
    }

    fn positions(&self, piece: &Piece) -> Result<Vec<Point3<f64>>, IoError> {
        let Some(a) = self.array(Section::Points, None) else {
            if piece.points == 0 {
                return Ok(Vec::new());
            }
            return Err(self.err(
                piece.pos,
                format!("{} points but no <Points> array", piece.points),
            ));
        };
        if a.ncomp != 3 {
            return Err(self.err(
                a.pos,
                format!("the points have {} components, expected 3", a.ncomp),
            ));
        }
        let v = into_f64(self.tuples(a, piece.points)?);
        Ok(v.chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect())
    }

    /// Connectivity and CSR offsets of a cell section holding `n` cells.
    fn csr(&self, s: Section, n: usize, pos: usize) -> Result<Option<PolyGroup>, IoError> {
        let conn = self.array(s, Some("connectivity"));
        let offs = self.array(s, Some("offsets"));
        let (conn, offs) = match (conn, offs) {
            (Some(c), Some(o)) => (c, o),
            (None, None) if n == 0 => return Ok(None),
            _ => {
                return Err(self.err(
                    pos,
                    format!(
                        "{n} cells in <{s:?}>, but its connectivity or offsets array is missing"
                    ),
                ));
            }
        };
        // The offsets first: their last value bounds the connectivity.
        let ends = into_i64(self.values(offs, n.saturating_add(1))?)
            .ok_or_else(|| self.err(offs.pos, "offsets must be integers".into()))?;
        let most = ends.last().map_or(0, |&e| usize::try_from(e).unwrap_or(0));
        let cpos = conn.pos;
        let conn = into_indices(self.values(conn, most)?)
            .map_err(|m| self.err(cpos, format!("connectivity: {m}")))?;
        let offsets = if ends.len() == n {
            checked_offsets(std::iter::once(0).chain(ends), conn.len())
        } else if Some(ends.len()) == n.checked_add(1) && ends.first() == Some(&0) {
            checked_offsets(ends, conn.len())
        } else {
            Err(format!("{} offsets for {n} cells", ends.len()))
        }
        .map_err(|m| self.err(offs.pos, format!("offsets: {m}")))?;
        Ok(Some(PolyGroup { offsets, conn }))
    }

    /// Point data and cell data (`cells` tuples).
    fn fields(&self, npoints: usize, cells: usize) -> Result<(Fields, Fields), IoError> {
        let mut pd = Fields::new();
        let mut cd = Fields::new();
        for (k, a) in self.arrays.iter().enumerate() {
            let (target, n) = match a.section {
                Section::PointData => (&mut pd, npoints),
                Section::CellData => (&mut cd, cells),
                _ => continue,
            };
            let v = self.tuples(a, n)?;
            let name = a.name.clone().unwrap_or_else(|| format!("array{k}"));
            let f = Field::new(name, a.ncomp, v).map_err(|e| self.err(a.pos, e.to_string()))?;
            target.insert(f);
        }
        Ok((pd, cd))
    }
}

/// Inflates zlib blocks of `sizes` compressed bytes each (`bs` bytes each
/// uncompressed; the last `last` bytes, or `bs` when 0). The uncompressed
/// total the header announces must be at most `limit` bytes (what the
/// array can hold): checked before anything is inflated, so a small file
/// cannot announce gigabytes (a compression bomb). Each block's stream
/// must end exactly at its declared size: inflation stops one byte past
/// it, and a stream running over (or ending short) is
/// [`IoError::BlockSize`], so a small block declaring a few bytes cannot
/// hide a stream that inflates to gigabytes. `at`: the file offset of the
/// array's data, for messages.
fn inflate(
    payload: &[u8],
    sizes: &[usize],
    bs: usize,
    last: usize,
    limit: usize,
    at: usize,
) -> Result<Vec<u8>, IoError> {
    let bad = |m: String| IoError::malformed(Location::Byte(at as u64), m);
    let nb = sizes.len();
    let mut expected = Vec::with_capacity(nb);
    for (i, &c) in sizes.iter().enumerate() {
        let e = if i + 1 == nb && last != 0 { last } else { bs };
        // Deflate expands at most ~1032:1.
        if e > c.saturating_mul(1032).saturating_add(64) {
            return Err(bad(format!(
                "compressed block {i} of {c} bytes cannot hold the {e} bytes it announces"
            )));
        }
        expected.push(e);
    }
    let total = expected.iter().fold(0usize, |s, &e| s.saturating_add(e));
    if total > limit {
        return Err(bad(format!(
            "the compressed array announces {total} bytes, more than the {limit} bytes its \
             values can take"
        )));
    }
    crate::decode_limit::claim(total as u64).map_err(bad)?;
    // Grown block by block, so a corrupt block fails before the memory its
    // successors announce is allocated.
    let mut out = Vec::with_capacity(total.min(payload.len().saturating_mul(4) + 4096));
    let mut d = Decompress::new(true);
    let (mut i_in, mut i_out) = (0usize, 0usize);
    for (i, (&c, &e)) in sizes.iter().zip(&expected).enumerate() {
        let input = payload
            .get(i_in..)
            .and_then(|r| r.get(..c))
            .ok_or_else(|| bad(format!("zlib block {i} is cut off")))?;
        // One byte of room past the declared size: a stream that fills it
        // runs over, and nothing more of it is inflated.
        out.resize(i_out + e + 1, 0);
        d.reset(true);
        let status = d
            .decompress(input, &mut out[i_out..], FlushDecompress::Finish)
            .map_err(|err| bad(format!("zlib block {i} is corrupt: {err}")))?;
        let found = d.total_out();
        if found != e as u64 {
            return Err(IoError::BlockSize {
                path: Default::default(),
                location: Location::Byte(at as u64),
                block: i,
                compressed: c as u64,
                declared: e as u64,
                found,
            });
        }
        if status != Status::StreamEnd {
            return Err(bad(format!(
                "zlib block {i} ({c} compressed bytes) stops at its declared {e} bytes without \
                 the end of its stream: the file is truncated or corrupt"
            )));
        }
        out.truncate(i_out + e);
        i_in += c;
        i_out += e;
    }
    Ok(out)
}

fn build_grid(doc: &Doc<'_>) -> Result<CellMesh, IoError> {
    let piece = doc
        .piece
        .as_ref()
        .ok_or_else(|| IoError::malformed(Location::Unknown, "the file has no <Piece>"))?;
    let positions = doc.positions(piece)?;
    let n = piece.cells;
    let group = doc.csr(Section::Cells, n, piece.pos)?.unwrap_or(PolyGroup {
        offsets: vec![0],
        conn: Vec::new(),
    });
    let types = match doc.array(Section::Cells, Some("types")) {
        Some(a) => {
            let ids = into_i64(doc.tuples(a, n)?)
                .ok_or_else(|| doc.err(a.pos, "cell types must be integers".into()))?;
            ids.into_iter()
                .map(cell_type)
                .collect::<Result<Vec<_>, _>>()?
        }
        None if n == 0 => Vec::new(),
        None => return Err(doc.err(piece.pos, format!("{n} cells but no types array"))),
    };
    check_cells(&types, &group.offsets, &group.conn, positions.len())
        .map_err(|m| doc.err(piece.pos, m))?;
    let (point_data, cell_data) = doc.fields(positions.len(), n)?;
    Ok(CellMesh {
        positions,
        cell_types: types,
        offsets: group.offsets,
        connectivity: group.conn,
        point_data,
        cell_data,
    })
}

fn build_poly(doc: &Doc<'_>) -> Result<CellMesh, IoError> {
    let piece = doc
        .piece
        .as_ref()
        .ok_or_else(|| IoError::malformed(Location::Unknown, "the file has no <Piece>"))?;
    let positions = doc.positions(piece)?;
    let sections = [
        (Section::Verts, piece.verts),
        (Section::Lines, piece.lines),
        (Section::Polys, piece.polys),
        (Section::Strips, piece.strips),
    ];
    let mut groups: [Option<PolyGroup>; 4] = [None, None, None, None];
    for (slot, (s, n)) in groups.iter_mut().zip(sections) {
        let g = doc.csr(s, n, piece.pos)?;
        if let Some(g) = &g
            && g.offsets.len() - 1 != n
        {
            return Err(doc.err(
                piece.pos,
                format!("<{s:?}> holds a different number of cells than the {n} announced"),
            ));
        }
        *slot = g;
    }
    let j = join_poly(groups)
        .map_err(|(g, m)| doc.err(piece.pos, format!("<{:?}>: {m}", sections[g].0)))?;
    let (types, offsets, conn, file_cells, rows) =
        (j.types, j.offsets, j.conn, j.file_cells, j.rows);
    check_cells(&types, &offsets, &conn, positions.len()).map_err(|m| doc.err(piece.pos, m))?;
    let (point_data, cell_data) = doc.fields(positions.len(), file_cells)?;
    let cell_data = match rows {
        Some(r) => cell_data.select(&r),
        None => cell_data,
    };
    Ok(CellMesh {
        positions,
        cell_types: types,
        offsets,
        connectivity: conn,
        point_data,
        cell_data,
    })
}

// ---------------------------------------------------------------------------
// Writing.
// ---------------------------------------------------------------------------

/// The values of one array to write.
enum Data<'m> {
    Values(&'m FieldValues),
    Points(&'m [Point3<f64>]),
    /// Point indices, written as Int64.
    Conn(&'m [u32]),
    /// CSR offsets minus `base`, written as Int64 (without the leading 0).
    Offsets(&'m [usize], usize),
    Types(&'m [CellType]),
}

impl Data<'_> {
    fn type_name(&self) -> &'static str {
        match self {
            Data::Values(FieldValues::F64(_)) | Data::Points(_) => "Float64",
            Data::Values(FieldValues::F32(_)) => "Float32",
            Data::Values(FieldValues::I64(_)) | Data::Conn(_) | Data::Offsets(..) => "Int64",
            Data::Values(FieldValues::I32(_)) => "Int32",
            Data::Values(FieldValues::U8(_)) | Data::Types(_) => "UInt8",
        }
    }

    fn byte_len(&self) -> usize {
        match self {
            Data::Values(v) => {
                v.len()
                    * match v {
                        FieldValues::F64(_) | FieldValues::I64(_) => 8,
                        FieldValues::F32(_) | FieldValues::I32(_) => 4,
                        FieldValues::U8(_) => 1,
                    }
            }
            Data::Points(p) => p.len() * 24,
            Data::Conn(c) => c.len() * 8,
            Data::Offsets(o, _) => o.len() * 8,
            Data::Types(t) => t.len(),
        }
    }

    fn write_le(&self, out: &mut Vec<u8>) {
        out.reserve(self.byte_len());
        match self {
            Data::Values(FieldValues::F64(v)) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Data::Values(FieldValues::F32(v)) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Data::Values(FieldValues::I64(v)) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Data::Values(FieldValues::I32(v)) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Data::Values(FieldValues::U8(v)) => out.extend_from_slice(v),
            Data::Points(p) => p.iter().for_each(|p| {
                out.extend_from_slice(&p.x.to_le_bytes());
                out.extend_from_slice(&p.y.to_le_bytes());
                out.extend_from_slice(&p.z.to_le_bytes());
            }),
            Data::Conn(c) => c
                .iter()
                .for_each(|&x| out.extend_from_slice(&i64::from(x).to_le_bytes())),
            Data::Offsets(o, base) => o
                .iter()
                .for_each(|&x| out.extend_from_slice(&((x - base) as i64).to_le_bytes())),
            Data::Types(t) => out.extend(t.iter().map(|t| t.vtk_id())),
        }
    }

    fn write_ascii(&self, out: &mut Vec<u8>, ncomp: usize) {
        match self {
            Data::Values(v) => put_ascii_values(out, v, ncomp),
            Data::Points(p) => p.iter().for_each(|p| {
                put_f64(out, p.x);
                out.push(b' ');
                put_f64(out, p.y);
                out.push(b' ');
                put_f64(out, p.z);
                out.push(b'\n');
            }),
            Data::Conn(c) => c.iter().for_each(|x| {
                let _ = writeln!(out, "{x}");
            }),
            Data::Offsets(o, base) => o.iter().for_each(|x| {
                let _ = writeln!(out, "{}", x - base);
            }),
            Data::Types(t) => t.iter().for_each(|t| {
                let _ = writeln!(out, "{}", t.vtk_id());
            }),
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    Ascii,
    Inline,
    Raw,
    Base64,
}

struct XmlOut {
    head: Vec<u8>,
    appended: Vec<u8>,
    mode: Mode,
    compress: bool,
    scratch: Vec<u8>,
    zbuf: Vec<u8>,
    zlib: Option<Compress>,
    /// Appended arrays: where their offset goes in `head`, and their bytes
    /// in `appended`.
    slots: Vec<(usize, std::ops::Range<usize>)>,
}

fn escape_into(out: &mut Vec<u8>, s: &str) {
    for c in s.chars() {
        match c {
            '&' => out.extend_from_slice(b"&amp;"),
            '<' => out.extend_from_slice(b"&lt;"),
            '>' => out.extend_from_slice(b"&gt;"),
            '"' => out.extend_from_slice(b"&quot;"),
            '\'' => out.extend_from_slice(b"&apos;"),
            '\t' => out.extend_from_slice(b"&#9;"),
            '\n' => out.extend_from_slice(b"&#10;"),
            '\r' => out.extend_from_slice(b"&#13;"),
            c if c.is_control() || c == '\u{fffe}' || c == '\u{ffff}' => out.push(b'_'),
            c => {
                let mut buf = [0u8; 4];
                out.extend_from_slice(c.encode_utf8(&mut buf).as_bytes());
            }
        }
    }
}

fn b64_append(out: &mut Vec<u8>, data: &[u8]) {
    let start = out.len();
    let n = base64::encoded_len(data.len(), true).unwrap_or(0);
    out.resize(start + n, 0);
    let written = B64.encode_slice(data, &mut out[start..]).unwrap_or(0);
    out.truncate(start + written);
}

impl XmlOut {
    fn new(kind: &str, opts: &WriteOptions, capacity: usize) -> XmlOut {
        let mode = if opts.ascii {
            Mode::Ascii
        } else {
            match opts.xml_encoding {
                XmlEncoding::Ascii => Mode::Ascii,
                XmlEncoding::InlineBase64 => Mode::Inline,
                XmlEncoding::AppendedRaw => Mode::Raw,
                XmlEncoding::AppendedBase64 => Mode::Base64,
            }
        };
        let compress = opts.compress && mode != Mode::Ascii;
        let (head_cap, app_cap) = match mode {
            Mode::Raw | Mode::Base64 => (4096, capacity),
            _ => (capacity, 0),
        };
        let mut o = XmlOut {
            head: Vec::with_capacity(head_cap),
            appended: Vec::with_capacity(app_cap),
            mode,
            compress,
            scratch: Vec::new(),
            zbuf: Vec::new(),
            zlib: None,
            slots: Vec::new(),
        };
        let _ = write!(
            o.head,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"{kind}\" version=\"1.0\" \
             byte_order=\"LittleEndian\" header_type=\"UInt64\"{}>\n  <{kind}>\n",
            if compress {
                " compressor=\"vtkZLibDataCompressor\""
            } else {
                ""
            }
        );
        o
    }

    fn line(&mut self, s: &str) {
        self.head.extend_from_slice(s.as_bytes());
        self.head.push(b'\n');
    }

    /// Compresses `self.scratch` into `self.zbuf` as VTK zlib blocks.
    fn compress_scratch(&mut self) -> Result<(), IoError> {
        let data = &self.scratch;
        let z = &mut self.zbuf;
        z.clear();
        let nb = data.len().div_ceil(BLOCK);
        let last = data.len() - nb.saturating_sub(1) * BLOCK;
        for w in [nb, BLOCK, if nb == 0 { 0 } else { last }] {
            z.extend_from_slice(&(w as u64).to_le_bytes());
        }
        let sizes_at = z.len();
        z.resize(sizes_at + 8 * nb, 0);
        let c = self
            .zlib
            .get_or_insert_with(|| Compress::new(Compression::new(LEVEL), true));
        for (i, block) in data.chunks(BLOCK).enumerate() {
            c.reset();
            let before = z.len();
            loop {
                let done = c.total_in() as usize;
                z.reserve(block.len() / 2 + 1024);
                let st = c
                    .compress_vec(&block[done.min(block.len())..], z, FlushCompress::Finish)
                    .map_err(|e| IoError::unsupported(format!("zlib compression failed: {e}")))?;
                if st == Status::StreamEnd {
                    break;
                }
            }
            let size = (z.len() - before) as u64;
            z[sizes_at + 8 * i..sizes_at + 8 * i + 8].copy_from_slice(&size.to_le_bytes());
        }
        Ok(())
    }

    /// The binary form of `data` (header included) appended to `dst` as raw
    /// bytes or base64.
    fn binary(&mut self, data: &Data<'_>, base64: bool, dst: &mut Vec<u8>) -> Result<(), IoError> {
        if self.compress {
            self.scratch.clear();
            data.write_le(&mut self.scratch);
            self.compress_scratch()?;
            if base64 {
                // Header and blocks are encoded separately, as VTK does.
                let nb = self.scratch.len().div_ceil(BLOCK);
                let h = 8 * (3 + nb);
                b64_append(dst, &self.zbuf[..h]);
                b64_append(dst, &self.zbuf[h..]);
            } else {
                dst.extend_from_slice(&self.zbuf);
            }
        } else if base64 {
            self.scratch.clear();
            self.scratch
                .extend_from_slice(&(data.byte_len() as u64).to_le_bytes());
            data.write_le(&mut self.scratch);
            b64_append(dst, &self.scratch);
        } else {
            dst.extend_from_slice(&(data.byte_len() as u64).to_le_bytes());
            data.write_le(dst);
        }
        Ok(())
    }

    fn array(&mut self, name: &str, ncomp: usize, data: Data<'_>) -> Result<(), IoError> {
        let fmt = match self.mode {
            Mode::Ascii => "ascii",
            Mode::Inline => "binary",
            Mode::Raw | Mode::Base64 => "appended",
        };
        let _ = write!(
            self.head,
            "        <DataArray type=\"{}\" Name=\"",
            data.type_name()
        );
        escape_into(&mut self.head, name);
        let _ = write!(
            self.head,
            "\" NumberOfComponents=\"{ncomp}\" format=\"{fmt}\""
        );
        match self.mode {
            Mode::Ascii => {
                self.head.extend_from_slice(b">\n");
                data.write_ascii(&mut self.head, ncomp);
                self.line("        </DataArray>");
            }
            Mode::Inline => {
                self.head.extend_from_slice(b">\n          ");
                let mut head = std::mem::take(&mut self.head);
                let r = self.binary(&data, true, &mut head);
                self.head = head;
                r?;
                self.head.push(b'\n');
                self.line("        </DataArray>");
            }
            Mode::Raw | Mode::Base64 => {
                self.head.extend_from_slice(b" offset=\"");
                let at = self.head.len();
                self.head.extend_from_slice(b"\"/>\n");
                let start = self.appended.len();
                let mut app = std::mem::take(&mut self.appended);
                let r = self.binary(&data, self.mode == Mode::Base64, &mut app);
                self.appended = app;
                r?;
                self.slots.push((at, start..self.appended.len()));
            }
        }
        Ok(())
    }

    fn fields(&mut self, tag: &str, fields: &Fields) -> Result<(), IoError> {
        self.line(&format!("      <{tag}>"));
        for f in fields {
            self.array(f.name(), f.components(), Data::Values(f.values()))?;
        }
        self.line(&format!("      </{tag}>"));
        Ok(())
    }

    fn points(&mut self, positions: &[Point3<f64>]) -> Result<(), IoError> {
        self.line("      <Points>");
        self.array("Points", 3, Data::Points(positions))?;
        self.line("      </Points>");
        Ok(())
    }

    /// The file. Appended arrays are stored in reverse order (the last
    /// `<DataArray>` first): readers locate them by offset, and this order
    /// keeps meshio's raw-data reader, which rewrites offsets in place while
    /// it walks the arrays, from mistaking a rewritten offset for a later
    /// array's.
    fn finish(mut self, kind: &str) -> Vec<u8> {
        self.line("    </Piece>");
        self.line(&format!("  </{kind}>"));
        let mut out = Vec::with_capacity(self.head.len() + self.appended.len() + 256);
        let mut offset: usize = self.slots.iter().map(|(_, r)| r.len()).sum();
        let mut from = 0;
        for (at, r) in &self.slots {
            offset -= r.len();
            out.extend_from_slice(&self.head[from..*at]);
            let _ = write!(out, "{offset}");
            from = *at;
        }
        out.extend_from_slice(&self.head[from..]);
        if matches!(self.mode, Mode::Raw | Mode::Base64) {
            let enc = if self.mode == Mode::Raw {
                "raw"
            } else {
                "base64"
            };
            let _ = write!(out, "  <AppendedData encoding=\"{enc}\">\n   _");
            for (_, r) in self.slots.iter().rev() {
                out.extend_from_slice(&self.appended[r.clone()]);
            }
            out.extend_from_slice(b"\n  </AppendedData>\n");
        }
        out.extend_from_slice(b"</VTKFile>\n");
        out
    }
}

fn size_estimate(mesh: &CellMesh, opts: &WriteOptions) -> usize {
    let fields: usize = mesh
        .point_data
        .iter()
        .chain(mesh.cell_data.iter())
        .map(|f| Data::Values(f.values()).byte_len())
        .sum();
    let raw =
        mesh.num_points() * 24 + mesh.connectivity.len() * 8 + mesh.num_cells() * 9 + fields + 1024;
    if opts.compress {
        raw / 3
    } else if opts.ascii || opts.xml_encoding == XmlEncoding::Ascii {
        raw * 2
    } else {
        raw / 3 * 4 + 64
    }
}

/// Serializes a mesh as a VTK XML unstructured grid (`.vtu`), with the
/// encoding and compression of `opts` (see the module documentation).
pub fn write_vtu(mesh: &CellMesh, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    let kind = "UnstructuredGrid";
    let mut o = XmlOut::new(kind, opts, size_estimate(mesh, opts));
    o.line(&format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        mesh.num_points(),
        mesh.num_cells()
    ));
    o.fields("PointData", &mesh.point_data)?;
    o.fields("CellData", &mesh.cell_data)?;
    o.points(&mesh.positions)?;
    o.line("      <Cells>");
    o.array("connectivity", 1, Data::Conn(&mesh.connectivity))?;
    o.array(
        "offsets",
        1,
        Data::Offsets(mesh.offsets.get(1..).unwrap_or_default(), 0),
    )?;
    o.array("types", 1, Data::Types(&mesh.cell_types))?;
    o.line("      </Cells>");
    Ok(o.finish(kind))
}

/// Serializes a mesh as VTK XML polydata (`.vtp`), with the encoding and
/// compression of `opts`. Volume cells are an unsupported error; cells are
/// reordered stably into verts, lines, polys order when needed, cell data
/// permuted alongside (see the module documentation).
pub fn write_vtp(mesh: &CellMesh, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    let mut classes = Vec::with_capacity(mesh.num_cells());
    for (i, &t) in mesh.cell_types.iter().enumerate() {
        classes.push(poly_class(t).ok_or_else(|| {
            IoError::unsupported(format!(
                "cell {i} is a {t:?}; VTK polydata (.vtp) cannot hold volume cells, write .vtu instead"
            ))
        })?);
    }
    let sorted = classes.windows(2).all(|w| w[0] <= w[1]);
    let reordered;
    let m = if sorted {
        mesh
    } else {
        let mut perm: Vec<usize> = (0..mesh.num_cells()).collect();
        perm.sort_by_key(|&i| classes[i]);
        let mut r = CellMesh {
            positions: Vec::new(),
            cell_types: Vec::with_capacity(perm.len()),
            offsets: Vec::with_capacity(perm.len() + 1),
            connectivity: Vec::with_capacity(mesh.connectivity.len()),
            point_data: Fields::new(),
            cell_data: mesh.cell_data.select(&perm),
        };
        r.offsets.push(0);
        for &i in &perm {
            let (t, vs) = mesh.cell(i);
            r.push_cell(t, vs);
        }
        classes.sort_unstable();
        reordered = r;
        &reordered
    };
    let kind = "PolyData";
    let count = |c: usize| classes.iter().filter(|&&k| k == c).count();
    let (nv, nl, np) = (count(0), count(1), count(2));
    let mut o = XmlOut::new(kind, opts, size_estimate(mesh, opts));
    o.line(&format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"{nv}\" NumberOfLines=\"{nl}\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{np}\">",
        mesh.num_points()
    ));
    o.fields("PointData", &mesh.point_data)?;
    o.fields("CellData", &m.cell_data)?;
    o.points(&mesh.positions)?;
    let ranges = [
        (0, nv),
        (nv, nv + nl),
        (nv + nl + np, nv + nl + np),
        (nv + nl, nv + nl + np),
    ];
    for ((start, end), tag) in ranges
        .into_iter()
        .zip(["Verts", "Lines", "Strips", "Polys"])
    {
        let offs = &m.offsets[start..=end];
        let base = offs[0];
        o.line(&format!("      <{tag}>"));
        o.array(
            "connectivity",
            1,
            Data::Conn(&m.connectivity[base..offs[offs.len() - 1]]),
        )?;
        o.array("offsets", 1, Data::Offsets(&offs[1..], base))?;
        o.line(&format!("      </{tag}>"));
    }
    Ok(o.finish(kind))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vtk_legacy::tests::{Cells, arb_mesh, assert_same};
    use proptest::prelude::*;
    use unfold_mesh::FieldValues;

    fn all_opts() -> Vec<WriteOptions> {
        let mut v = Vec::new();
        for xml_encoding in [
            XmlEncoding::AppendedRaw,
            XmlEncoding::AppendedBase64,
            XmlEncoding::InlineBase64,
            XmlEncoding::Ascii,
        ] {
            for compress in [false, true] {
                v.push(WriteOptions {
                    xml_encoding,
                    compress,
                    ..WriteOptions::default()
                });
            }
        }
        v.push(WriteOptions::ascii());
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

    /// The mesh with its cells stably sorted as verts, lines, polys.
    fn poly_sorted(m: &CellMesh) -> CellMesh {
        let mut perm: Vec<usize> = (0..m.num_cells()).collect();
        perm.sort_by_key(|&i| m.cell_types[i].dimension());
        let mut r = CellMesh::from_points(m.positions.clone());
        for &i in &perm {
            let (t, vs) = m.cell(i);
            r.push_cell(t, vs);
        }
        r.point_data = m.point_data.clone();
        r.cell_data = m.cell_data.select(&perm);
        r
    }

    fn sample() -> CellMesh {
        let mut m = CellMesh::from_points(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.5, -2.25, 1e-300),
            Point3::new(0.1, 1e300, 3.0),
            Point3::new(-7.0, 2.0, 0.5),
        ]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        m.push_cell(CellType::Vertex, &[3]);
        m.push_cell(CellType::Quad, &[0, 1, 2, 3]);
        m.push_cell(CellType::PolyLine, &[0, 1, 3]);
        m.add_point_field(Field::new("p q", 2, FieldValues::F32(vec![0.5; 8])).unwrap())
            .unwrap();
        m.add_cell_field(Field::labels("<&\"'>", vec![1, 2, 3, 4]))
            .unwrap();
        m.add_cell_field(Field::new("b", 1, FieldValues::U8(vec![9, 8, 7, 6])).unwrap())
            .unwrap();
        m
    }

    #[test]
    /// A file written by another tool: meshio's zlib-compressed binary VTU
    /// (`tests/data/ellipsoid-heart/make.py`).
    fn meshio_heart_vtu_reads() {
        let bytes = std::fs::read("../../tests/data/ellipsoid-heart/heart.vtu").unwrap();
        let m = read(&bytes).unwrap();
        assert_eq!(m.num_points(), 3844);
        assert_eq!(m.num_cells(), 16848);
        assert!(m.cell_types.iter().all(|&t| t == CellType::Tetra));
        let mat = m.cell_data.get("Material").unwrap();
        assert_eq!(mat.components(), 1);
        assert_eq!(mat.tuples(), 16848);
        assert!(mat.values().to_f64().iter().all(|&v| v == 31.0));
        assert!(m.check().is_ok());
        assert!(m.to_tet_mesh().is_ok());
        // And it survives being written and read back in every encoding.
        for opts in all_opts() {
            assert_eq!(read(&write_vtu(&m, &opts).unwrap()).unwrap(), m);
        }
    }

    #[test]
    fn written_layout_is_the_standard_one() {
        let b = write_vtu(&sample(), &WriteOptions::default()).unwrap();
        let text = String::from_utf8_lossy(&b);
        assert!(text.starts_with(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
             byte_order=\"LittleEndian\" header_type=\"UInt64\">"
        ));
        assert!(text.contains("<Piece NumberOfPoints=\"4\" NumberOfCells=\"4\">"));
        assert!(text.contains("Name=\"&lt;&amp;&quot;&apos;&gt;\""));
        assert!(text.contains("<DataArray type=\"Int64\" Name=\"offsets\""));
        assert!(text.contains("<DataArray type=\"UInt8\" Name=\"types\""));
        assert!(text.contains("<AppendedData encoding=\"raw\">"));
        let opts = WriteOptions {
            compress: true,
            ..WriteOptions::default()
        };
        let b = write_vtu(&sample(), &opts).unwrap();
        assert!(String::from_utf8_lossy(&b).contains("compressor=\"vtkZLibDataCompressor\""));
    }

    #[test]
    fn vtp_reorders_cells_and_rejects_volumes() {
        let m = sample();
        for opts in all_opts() {
            let back = read(&write_vtp(&m, &opts).unwrap()).unwrap();
            assert_eq!(
                back.cell_types,
                vec![
                    CellType::Vertex,
                    CellType::PolyLine,
                    CellType::Triangle,
                    CellType::Quad
                ]
            );
            assert_eq!(
                back.cell_data.get("<&\"'>").unwrap().values(),
                &FieldValues::I32(vec![2, 4, 1, 3])
            );
            assert_eq!(back, poly_sorted(&m));
        }
        let mut t = m.clone();
        t.cell_data = Fields::new();
        t.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        let e = write_vtp(&t, &WriteOptions::default()).unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        assert!(e.to_string().contains("cell 4 is a Tetra"), "{e}");
    }

    #[test]
    fn ascii_polydata_with_strips_by_hand() {
        let text = r#"<?xml version="1.0"?>
<!-- a comment -->
<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">
  <PolyData>
    <FieldData>
      <DataArray type="Float64" Name="TIME" NumberOfTuples="1" format="ascii">1.5</DataArray>
    </FieldData>
    <Piece NumberOfPoints="5" NumberOfVerts="0" NumberOfLines="1" NumberOfStrips="1" NumberOfPolys="1">
      <PointData Scalars="s">
        <DataArray type="Int16" Name="s" format="ascii">1 2 3 4 5</DataArray>
      </PointData>
      <CellData>
        <DataArray type="UInt32" Name="id" format="ascii">
          10 20
          30
        </DataArray>
      </CellData>
      <Points>
        <DataArray type="Float32" NumberOfComponents="3" format="ascii">
          0 0 0 1 0 0 1 1 0 0 1 0 0.5 0.5 1
        </DataArray>
      </Points>
      <Lines>
        <DataArray type="Int32" Name="connectivity" format="ascii">0 4</DataArray>
        <DataArray type="Int32" Name="offsets" format="ascii">2</DataArray>
      </Lines>
      <Strips>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 3 2</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>
      </Strips>
      <Polys>
        <DataArray type="UInt8" Name="connectivity" format="ascii">0 1 4</DataArray>
        <DataArray type="UInt8" Name="offsets" format="ascii">3</DataArray>
      </Polys>
    </Piece>
  </PolyData>
</VTKFile>
"#;
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 5);
        assert_eq!(
            m.cell_types,
            vec![
                CellType::Line,
                CellType::Triangle,
                CellType::Triangle,
                CellType::Triangle
            ]
        );
        assert_eq!(m.connectivity, vec![0, 4, 0, 1, 4, 0, 1, 3, 3, 1, 2]);
        assert_eq!(
            m.point_data.get("s").unwrap().values(),
            &FieldValues::I32(vec![1, 2, 3, 4, 5])
        );
        // Cell data in VTK order: lines, polys, strips (strip repeated).
        assert_eq!(
            m.cell_data.get("id").unwrap().values(),
            &FieldValues::I64(vec![10, 20, 30, 30])
        );
        assert!(m.check().is_ok());
    }

    /// A little-endian or big-endian `.vtu` with UInt32 or UInt64 headers,
    /// written here byte by byte: one triangle, one Float64 point array.
    fn hand_binary(be: bool, h64: bool, enc: &str, compress: bool, joint: bool) -> Vec<u8> {
        let word = |x: usize| -> Vec<u8> {
            match (h64, be) {
                (true, true) => (x as u64).to_be_bytes().to_vec(),
                (true, false) => (x as u64).to_le_bytes().to_vec(),
                (false, true) => (x as u32).to_be_bytes().to_vec(),
                (false, false) => (x as u32).to_le_bytes().to_vec(),
            }
        };
        let f64s = |v: &[f64]| -> Vec<u8> {
            v.iter()
                .flat_map(|x| if be { x.to_be_bytes() } else { x.to_le_bytes() })
                .collect()
        };
        let i32s = |v: &[i32]| -> Vec<u8> {
            v.iter()
                .flat_map(|x| if be { x.to_be_bytes() } else { x.to_le_bytes() })
                .collect()
        };
        let arrays: Vec<(&str, &str, usize, Vec<u8>)> = vec![
            ("Float64", "temp", 1, f64s(&[1.0, 2.0, 3.0])),
            (
                "Float64",
                "Points",
                3,
                f64s(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]),
            ),
            ("Int32", "connectivity", 1, i32s(&[0, 1, 2])),
            ("Int32", "offsets", 1, i32s(&[3])),
            ("UInt8", "types", 1, vec![5]),
        ];
        // (header, payload) of each array.
        let blocks: Vec<(Vec<u8>, Vec<u8>)> = arrays
            .iter()
            .map(|(_, _, _, data)| {
                if compress {
                    // Two blocks of at most 16 bytes.
                    let bs = 16;
                    let chunks: Vec<&[u8]> = data.chunks(bs).collect();
                    let mut h = word(chunks.len());
                    h.extend(word(bs));
                    h.extend(word(chunks.last().map_or(0, |c| c.len())));
                    let mut payload = Vec::new();
                    for c in &chunks {
                        let mut e =
                            flate2::write::ZlibEncoder::new(Vec::new(), Compression::default());
                        std::io::Write::write_all(&mut e, c).unwrap();
                        let z = e.finish().unwrap();
                        h.extend(word(z.len()));
                        payload.extend(z);
                    }
                    (h, payload)
                } else {
                    (word(data.len()), data.clone())
                }
            })
            .collect();
        let b64 = |h: &[u8], p: &[u8]| -> String {
            if joint {
                B64.encode([h, p].concat())
            } else {
                B64.encode(h) + &B64.encode(p)
            }
        };
        let mut appended = Vec::new();
        let mut xml_arrays = Vec::new();
        for ((ty, name, nc, _), (h, p)) in arrays.iter().zip(&blocks) {
            let attrs = format!(r#"type="{ty}" Name="{name}" NumberOfComponents="{nc}""#);
            match enc {
                "binary" => xml_arrays.push(format!(
                    "<DataArray {attrs} format=\"binary\">\n   {}\n </DataArray>",
                    b64(h, p)
                )),
                _ => {
                    xml_arrays.push(format!(
                        "<DataArray {attrs} format=\"appended\" offset=\"{}\"/>",
                        appended.len()
                    ));
                    if enc == "raw" {
                        appended.extend_from_slice(h);
                        appended.extend_from_slice(p);
                    } else {
                        appended.extend_from_slice(b64(h, p).as_bytes());
                    }
                }
            }
        }
        let mut out = format!(
            r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{}" header_type="{}"{}>
<UnstructuredGrid><Piece NumberOfPoints="3" NumberOfCells="1">
<PointData>{}</PointData><Points>{}</Points><Cells>{}{}{}</Cells>
</Piece></UnstructuredGrid>
"#,
            if be { "BigEndian" } else { "LittleEndian" },
            if h64 { "UInt64" } else { "UInt32" },
            if compress {
                r#" compressor="vtkZLibDataCompressor""#
            } else {
                ""
            },
            xml_arrays[0],
            xml_arrays[1],
            xml_arrays[2],
            xml_arrays[3],
            xml_arrays[4],
        )
        .into_bytes();
        if enc != "binary" {
            out.extend_from_slice(format!("<AppendedData encoding=\"{enc}\">\n _").as_bytes());
            out.extend_from_slice(&appended);
            out.extend_from_slice(b"\n</AppendedData>\n");
        }
        out.extend_from_slice(b"</VTKFile>\n");
        out
    }

    #[test]
    fn byte_orders_header_types_and_base64_layouts() {
        for be in [false, true] {
            for h64 in [false, true] {
                for enc in ["raw", "base64", "binary"] {
                    for compress in [false, true] {
                        for joint in [false, true] {
                            let b = hand_binary(be, h64, enc, compress, joint);
                            let m = read(&b).unwrap_or_else(|e| {
                                panic!("{be} {h64} {enc} {compress} {joint}: {e}")
                            });
                            assert_eq!(m.cell_types, vec![CellType::Triangle]);
                            assert_eq!(m.connectivity, vec![0, 1, 2]);
                            assert_eq!(m.positions[1], Point3::new(1.0, 0.0, 0.0));
                            assert_eq!(
                                m.point_data.get("temp").unwrap().values(),
                                &FieldValues::F64(vec![1.0, 2.0, 3.0])
                            );
                        }
                    }
                }
            }
        }
    }

    /// A compression bomb: 27 points whose zlib header announces 16 blocks
    /// of 256 MiB (each compressed block large enough for deflate's ratio)
    /// is refused before anything is inflated or allocated.
    #[test]
    fn compressed_arrays_cannot_announce_more_than_they_hold() {
        let (blocks, bs, c) = (16u64, 256u64 << 20, 270_000u64);
        let mut header = Vec::new();
        for w in [blocks, bs, 0]
            .into_iter()
            .chain(std::iter::repeat_n(c, 16))
        {
            header.extend_from_slice(&w.to_le_bytes());
        }
        let mut b = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="27" NumberOfCells="0">
<Points><DataArray type="Float32" NumberOfComponents="3" format="appended" offset="0"/></Points>
</Piece></UnstructuredGrid>
<AppendedData encoding="raw">
 _"#
            .as_bytes()
            .to_vec();
        b.extend_from_slice(&header);
        b.resize(b.len() + (blocks * c) as usize, 0x78);
        b.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
        let e = read(&b).unwrap_err().to_string();
        assert!(
            e.contains("announces 4294967296 bytes, more than the 324 bytes"),
            "{e}"
        );
    }

    /// A 27-point Float64 `.vtu` whose one zlib block declares 648 bytes
    /// and holds a stream of `zeros` zero bytes.
    fn vtu_one_block(zeros: usize) -> Vec<u8> {
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), Compression::best());
        std::io::Write::write_all(&mut z, &vec![0u8; zeros]).unwrap();
        let stream = z.finish().unwrap();
        let mut b = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="27" NumberOfCells="0">
<Points><DataArray type="Float64" NumberOfComponents="3" format="appended" offset="0"/></Points>
</Piece></UnstructuredGrid>
<AppendedData encoding="raw">
 _"#
            .as_bytes()
            .to_vec();
        for w in [1u64, 648, 648, stream.len() as u64] {
            b.extend_from_slice(&w.to_le_bytes());
        }
        b.extend_from_slice(&stream);
        b.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
        b
    }

    /// A zlib block must inflate to exactly the size its header declares:
    /// a stream running over (4 MiB behind a 648-byte header) or ending
    /// short is a typed error naming the block and the sizes.
    #[test]
    fn a_zlib_block_must_end_at_its_declared_size() {
        assert_eq!(read(&vtu_one_block(648)).unwrap().positions.len(), 27);
        let e = read(&vtu_one_block(4 << 20)).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::BlockSize {
                    block: 0,
                    declared: 648,
                    found: 649,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .contains("inflates to more than the 648 bytes its header declares"),
            "{e}"
        );
        let e = read(&vtu_one_block(600)).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::BlockSize {
                    declared: 648,
                    found: 600,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .contains("inflates to only 600 bytes, but its header declares 648"),
            "{e}"
        );
    }

    #[test]
    fn other_compressors_and_types_are_unsupported() {
        let b = String::from_utf8(hand_binary(false, false, "raw", true, false))
            .unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
            .into_bytes();
        let lz4: Vec<u8> = String::from_utf8_lossy(&b)
            .replace("vtkZLibDataCompressor", "vtkLZ4DataCompressor")
            .into_bytes();
        let e = read(&lz4).unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        assert!(e.to_string().contains("vtkLZ4DataCompressor"), "{e}");

        let text = r#"<VTKFile type="ImageData"><ImageData/></VTKFile>"#;
        assert!(matches!(
            read(text.as_bytes()),
            Err(IoError::Unsupported { .. })
        ));

        let text = r#"<VTKFile type="UnstructuredGrid"><UnstructuredGrid>
<Piece NumberOfPoints="1" NumberOfCells="1"><Points>
<DataArray type="Float32" NumberOfComponents="3" format="ascii">0 0 0</DataArray></Points>
<Cells><DataArray type="Int32" Name="connectivity" format="ascii">0 0 0</DataArray>
<DataArray type="Int32" Name="offsets" format="ascii">3</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">22</DataArray></Cells>
</Piece></UnstructuredGrid></VTKFile>"#;
        let e = read(text.as_bytes()).unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        assert!(e.to_string().contains("cell type 22"), "{e}");
    }

    #[test]
    fn error_locations_and_messages() {
        let text = r#"<VTKFile type="UnstructuredGrid"><UnstructuredGrid>
<Piece NumberOfPoints="2" NumberOfCells="0">
<Points>
<DataArray type="Float64" NumberOfComponents="3" format="ascii">
0 0 0
1 zz 0
</DataArray></Points>
</Piece></UnstructuredGrid></VTKFile>"#;
        let (loc, msg) = location(read(text.as_bytes()).unwrap_err());
        assert_eq!(loc, Location::Line(6));
        assert!(msg.contains("'zz' is not a valid Float64 value"), "{msg}");

        let (loc, _) = location(read(&text.as_bytes()[..120]).unwrap_err());
        assert!(matches!(loc, Location::Line(_)), "{loc:?}");

        let (loc, msg) = location(read(b"<?xml version=\"1.0\"?>\n<html></html>").unwrap_err());
        assert_eq!(loc, Location::Line(2));
        assert!(msg.contains("not a VTK XML file"), "{msg}");

        let bad = text.replace("</Points>", "</Pointz>");
        let (loc, msg) = location(read(bad.as_bytes()).unwrap_err());
        assert_eq!(loc, Location::Line(7));
        assert!(msg.contains("invalid XML"), "{msg}");

        // Raw appended data cut short: the byte offset of the array.
        let b = write_vtu(&sample(), &WriteOptions::default()).unwrap();
        let data_at = b
            .windows(2)
            .position(|w| w == b"\n   _".get(3..).unwrap())
            .unwrap();
        let (loc, msg) = location(read(&b[..b.len() - 40]).unwrap_err());
        assert!(
            matches!(loc, Location::Byte(o) if o as usize > data_at),
            "{loc:?}"
        );
        assert!(msg.contains("the data ends"), "{msg}");
    }

    proptest! {
        #[test]
        fn vtu_round_trip_every_encoding(m in arb_mesh(Cells::Any, "[ -~]{0,8}")) {
            for opts in all_opts() {
                let bytes = write_vtu(&m, &opts).unwrap();
                let back = read(&bytes).unwrap();
                assert_same(&m, &back)?;
            }
        }

        #[test]
        fn vtp_round_trip_every_encoding(m in arb_mesh(Cells::Poly, "[ -~]{0,8}")) {
            let expected = poly_sorted(&m);
            for opts in all_opts() {
                let bytes = write_vtp(&m, &opts).unwrap();
                let back = read(&bytes).unwrap();
                assert_same(&expected, &back)?;
            }
        }

        #[test]
        fn random_bytes_are_an_error(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn corrupted_bytes_never_panic(
            opts in prop::sample::select(all_opts()),
            vtp in any::<bool>(),
            pokes in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
        ) {
            let mut b = if vtp { write_vtp(&sample(), &opts) } else { write_vtu(&sample(), &opts) }
                .unwrap();
            for (i, v) in pokes {
                let i = i.index(b.len());
                b[i] = v;
            }
            let _ = read(&b);
        }

        #[test]
        fn corrupted_hand_written_files_never_panic(
            be in any::<bool>(),
            h64 in any::<bool>(),
            enc in prop::sample::select(vec!["raw", "base64", "binary"]),
            compress in any::<bool>(),
            joint in any::<bool>(),
            pokes in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
        ) {
            let mut b = hand_binary(be, h64, enc, compress, joint);
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
            m in arb_mesh(Cells::Poly, "[ -~]{0,4}"),
        ) {
            for opts in all_opts() {
                for b in [write_vtu(&m, &opts).unwrap(), write_vtp(&m, &opts).unwrap()] {
                    for n in 0..b.len() {
                        let _ = read(&b[..n]);
                    }
                }
            }
        }
    }

    #[test]
    fn every_truncation_never_panics() {
        for opts in all_opts() {
            for b in [
                write_vtu(&sample(), &opts).unwrap(),
                write_vtp(&sample(), &opts).unwrap(),
            ] {
                assert!(read(&b).is_ok());
                for n in 0..b.len() {
                    let _ = read(&b[..n]);
                }
            }
        }
        for h64 in [false, true] {
            for enc in ["raw", "base64", "binary"] {
                for compress in [false, true] {
                    let b = hand_binary(true, h64, enc, compress, false);
                    for n in 0..b.len() {
                        let _ = read(&b[..n]);
                    }
                }
            }
        }
    }
}
