//! Parsing a NRRD header (`NRRD0001` .. `NRRD0005`) into checked fields.
//!
//! The header is lines of text (`\n` or `\r\n`): the magic line, then
//! `field: description` lines, `key:=value` pairs and `#` comments, ended by
//! an empty line (attached data follows it) or by the end of a detached
//! `.nhdr` file. Field names are matched case-insensitively with their
//! spaces as written (`space directions`, also `datafile`, `byteskip` ...).

use super::{MAX_HEADER, MAX_SIZE};
use crate::{Datatype, IoError, Location};

/// How the data is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Encoding {
    /// Packed binary values.
    Raw,
    /// Packed binary values, gzip-compressed.
    Gzip,
    /// Numbers in text, separated by white space (or commas).
    Ascii,
}

/// The world frame of `space directions` and `space origin`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Space {
    /// Right-anterior-superior (NIfTI's world frame); also used when only
    /// `space dimension: 3` is given.
    Ras,
    /// Left-posterior-superior (DICOM, ITK and Slicer's files).
    Lps,
    /// Left-anterior-superior.
    Las,
}

/// A `data file` field: where detached data is, and the header line naming it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct DataFile {
    /// The file name as written (relative to the header's directory unless
    /// absolute).
    pub name: String,
    /// The header line of the field.
    pub line: usize,
}

/// The checked fields of a NRRD header.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Header {
    /// The value type.
    pub datatype: Datatype,
    /// `sizes`, one per axis (axis 0 fastest); 3 or 4 of them, each 1 to
    /// [`MAX_SIZE`].
    pub sizes: Vec<usize>,
    /// `endian: big` (false when absent, for 1-byte types and text).
    pub big_endian: bool,
    /// `encoding`.
    pub encoding: Encoding,
    /// `space` (or RAS for a bare `space dimension: 3`); `None` without
    /// either.
    pub space: Option<Space>,
    /// `space directions`, one per axis (`None` for `none`).
    pub directions: Option<Vec<Option<[f64; 3]>>>,
    /// `space origin`.
    pub origin: Option<[f64; 3]>,
    /// `spacings`, one per axis (NaN allowed).
    pub spacings: Option<Vec<f64>>,
    /// `kinds`, one per axis, lower case.
    pub kinds: Option<Vec<String>>,
    /// `byte skip` (-1: the data is the last bytes of a raw data file).
    pub byte_skip: i64,
    /// `line skip`.
    pub line_skip: u64,
    /// `data file`, for detached data.
    pub data_file: Option<DataFile>,
    /// `content`.
    pub content: Option<String>,
    /// `key:=value` pairs, in order.
    pub key_values: Vec<(String, String)>,
    /// Offset of the byte after the empty line ending the header (`None`
    /// when no empty line ends it: the header is the whole file).
    pub data_offset: Option<usize>,
}

impl Header {
    /// Bytes of data the header declares: the product of `sizes` times the
    /// type size (no overflow: every size is at most [`MAX_SIZE`] and there are
    /// at most 4).
    pub fn data_len(&self) -> u64 {
        self.sizes
            .iter()
            .fold(self.datatype.size() as u64, |a, &s| a * s as u64)
    }

    /// Number of values.
    pub fn count(&self) -> usize {
        self.sizes.iter().product()
    }
}

fn bad(line: usize, msg: impl Into<String>) -> IoError {
    IoError::malformed(Location::Line(line), msg)
}

/// Text from the file as shown in a message: quoted, at most 40 characters.
pub(super) fn shown(s: &str) -> String {
    if s.chars().count() <= 40 {
        format!("{s:?}")
    } else {
        let head: String = s.chars().take(40).collect();
        format!("{head:?}...")
    }
}

/// The data type of a NRRD `type` (every spelling of the format's
/// definition, case-insensitive, white space collapsed).
pub(super) fn datatype(name: &str) -> Option<Datatype> {
    let n = name
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_ascii_lowercase();
    Some(match n.as_str() {
        "signed char" | "int8" | "int8_t" => Datatype::Int8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Datatype::Uint8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            Datatype::Int16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            Datatype::Uint16
        }
        "int" | "signed int" | "int32" | "int32_t" => Datatype::Int32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Datatype::Uint32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => Datatype::Int64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            Datatype::Uint64
        }
        "float" => Datatype::Float32,
        "double" => Datatype::Float64,
        _ => return None,
    })
}

/// The NRRD `type` name written for a data type.
pub(super) fn type_name(dt: Datatype) -> &'static str {
    match dt {
        Datatype::Int8 => "int8",
        Datatype::Uint8 => "uint8",
        Datatype::Int16 => "int16",
        Datatype::Uint16 => "uint16",
        Datatype::Int32 => "int32",
        Datatype::Uint32 => "uint32",
        Datatype::Int64 => "int64",
        Datatype::Uint64 => "uint64",
        Datatype::Float32 => "float",
        Datatype::Float64 => "double",
    }
}

/// Parses `(x,y,z)` (white space allowed around the numbers).
fn vector(s: &str, line: usize, what: &str) -> Result<[f64; 3], IoError> {
    let inner = s
        .trim()
        .strip_prefix('(')
        .and_then(|r| r.strip_suffix(')'))
        .ok_or_else(|| {
            bad(
                line,
                format!("{what}: expected (x,y,z), found {}", shown(s)),
            )
        })?;
    let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(IoError::unsupported(format!(
            "line {line}: {what} {} has {} components; only 3D spaces are supported",
            shown(s),
            parts.len()
        )));
    }
    let mut v = [0.0; 3];
    for (x, p) in v.iter_mut().zip(&parts) {
        *x = p
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| bad(line, format!("{what}: {} is not a finite number", shown(p))))?;
    }
    Ok(v)
}

/// Splits a `space directions` description into its entries: `none` or a
/// parenthesized vector (which may contain spaces).
fn direction_entries(s: &str, line: usize) -> Result<Vec<Option<[f64; 3]>>, IoError> {
    let mut out = Vec::new();
    let mut rest = s.trim_start();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push(None);
            rest = r.trim_start();
        } else if rest.starts_with('(') {
            let end = rest.find(')').ok_or_else(|| {
                bad(
                    line,
                    format!("space directions: unclosed '(' in {}", shown(s)),
                )
            })?;
            out.push(Some(vector(&rest[..=end], line, "space directions")?));
            rest = rest[end + 1..].trim_start();
        } else {
            return Err(bad(
                line,
                format!(
                    "space directions: expected (x,y,z) or none, found {}",
                    shown(rest)
                ),
            ));
        }
    }
    Ok(out)
}

/// Parses `n` numbers separated by white space.
fn numbers<T: std::str::FromStr>(
    s: &str,
    n: usize,
    line: usize,
    what: &str,
) -> Result<Vec<T>, IoError> {
    let words: Vec<&str> = s.split_whitespace().collect();
    if words.len() != n {
        return Err(bad(
            line,
            format!(
                "{what} has {} entries, expected {n} (one per axis)",
                words.len()
            ),
        ));
    }
    words
        .iter()
        .map(|w| {
            w.parse::<T>()
                .map_err(|_| bad(line, format!("{what}: {} is not a valid number", shown(w))))
        })
        .collect()
}

/// One `field: description` line.
struct Field<'a> {
    line: usize,
    desc: &'a str,
}

/// Parses the header at the start of `bytes`. See the [module
/// documentation](self).
pub(super) fn parse(bytes: &[u8]) -> Result<Header, IoError> {
    // Split the header into lines, up to the empty line that ends it.
    let mut lines: Vec<(usize, &str)> = Vec::new();
    let mut pos = 0usize;
    let mut data_offset = None;
    while pos < bytes.len() {
        let end = bytes[pos..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(bytes.len(), |e| pos + e);
        if end > MAX_HEADER {
            return Err(IoError::malformed(
                Location::Byte(pos as u64),
                format!(
                    "the header is longer than {MAX_HEADER} bytes (no empty line ends it): \
                     not a NRRD file, or a damaged one"
                ),
            ));
        }
        let number = lines.len() + 1;
        let raw = &bytes[pos..end];
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        pos = (end + 1).min(bytes.len());
        if raw.is_empty() && number > 1 {
            data_offset = Some(pos);
            break;
        }
        let text = std::str::from_utf8(raw)
            .map_err(|_| bad(number, "the header line is not text (UTF-8)"))?;
        lines.push((number, text));
    }

    // The magic line.
    let magic = lines.first().map_or("", |l| l.1);
    match magic.strip_prefix("NRRD000") {
        Some("1" | "2" | "3" | "4" | "5") => {}
        Some(v) => {
            return Err(IoError::unsupported(format!(
                "NRRD format version {} is not supported (NRRD0001 to NRRD0005 are)",
                shown(v)
            )));
        }
        None => {
            let start: String = magic.chars().take(16).collect();
            return Err(bad(
                1,
                format!("the file starts with {start:?}, not NRRD000N: not a NRRD file"),
            ));
        }
    }

    // Fields and key/value pairs.
    let mut fields: Vec<(String, Field)> = Vec::new();
    let mut key_values = Vec::new();
    for &(line, text) in &lines[1..] {
        if text.starts_with('#') {
            continue;
        }
        let Some((name, rest)) = text.split_once(':') else {
            return Err(bad(
                line,
                format!(
                    "expected 'field: value' or 'key:=value', found {}",
                    shown(text)
                ),
            ));
        };
        if let Some(value) = rest.strip_prefix('=') {
            key_values.push((name.to_string(), value.to_string()));
            continue;
        }
        let name = name.trim().to_ascii_lowercase();
        let name = match name.as_str() {
            "datafile" => "data file".to_string(),
            "byteskip" => "byte skip".to_string(),
            "lineskip" => "line skip".to_string(),
            _ => name,
        };
        if let Some((_, f)) = fields.iter().find(|(n, _)| *n == name) {
            return Err(bad(
                line,
                format!("field '{name}' appears twice (first on line {})", f.line),
            ));
        }
        fields.push((
            name,
            Field {
                line,
                desc: rest.trim(),
            },
        ));
    }
    let get = |name: &str| fields.iter().find(|(n, _)| n == name).map(|(_, f)| f);
    let required = |name: &str| {
        get(name).ok_or_else(|| {
            IoError::malformed(
                Location::Unknown,
                format!("the header has no '{name}' field, which NRRD requires"),
            )
        })
    };

    // Type, dimension, sizes.
    let f = required("type")?;
    let datatype = match datatype(f.desc) {
        Some(d) => d,
        None if f.desc.eq_ignore_ascii_case("block") => {
            return Err(IoError::unsupported(format!(
                "line {}: NRRD type 'block' is not supported; store numbers (integers, float, \
                 double)",
                f.line
            )));
        }
        None => return Err(bad(f.line, format!("unknown NRRD type {}", shown(f.desc)))),
    };
    let f = required("dimension")?;
    let dimension: usize = f.desc.parse().map_err(|_| {
        bad(
            f.line,
            format!("dimension {} is not a number", shown(f.desc)),
        )
    })?;
    if !(3..=4).contains(&dimension) {
        return Err(IoError::unsupported(format!(
            "line {}: a {dimension}-dimensional NRRD; only 3D images and 4D series are supported",
            f.line
        )));
    }
    let f = required("sizes")?;
    let sizes: Vec<usize> = numbers(f.desc, dimension, f.line, "sizes")?;
    if let Some(&s) = sizes.iter().find(|&&s| s == 0 || s > MAX_SIZE) {
        return Err(bad(
            f.line,
            format!("size {s} in sizes {sizes:?} is out of range (1 to {MAX_SIZE} per axis)"),
        ));
    }

    // Encoding and byte order.
    let f = required("encoding")?;
    let encoding = match f.desc.to_ascii_lowercase().as_str() {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        "ascii" | "txt" | "text" => Encoding::Ascii,
        e @ ("bzip2" | "bz2" | "hex" | "zstd" | "zrl") => {
            return Err(IoError::unsupported(format!(
                "line {}: NRRD encoding {e:?} is not supported; use raw, gzip or ascii",
                f.line
            )));
        }
        e => return Err(bad(f.line, format!("unknown NRRD encoding {}", shown(e)))),
    };
    let big_endian = match get("endian") {
        Some(f) => match f.desc.to_ascii_lowercase().as_str() {
            "little" => false,
            "big" => true,
            e => {
                return Err(bad(
                    f.line,
                    format!("endian is {}, expected little or big", shown(e)),
                ));
            }
        },
        None if datatype.size() > 1 && encoding != Encoding::Ascii => {
            return Err(IoError::malformed(
                Location::Unknown,
                format!(
                    "the header has no 'endian' field, which {}-byte {} data needs",
                    datatype.size(),
                    type_name(datatype)
                ),
            ));
        }
        None => false,
    };

    // Space.
    let space = match get("space") {
        Some(f) => Some(match f.desc.to_ascii_lowercase().as_str() {
            "right-anterior-superior" | "ras" => Space::Ras,
            "left-posterior-superior" | "lps" => Space::Lps,
            "left-anterior-superior" | "las" => Space::Las,
            s @ ("right-anterior-superior-time"
            | "rast"
            | "left-posterior-superior-time"
            | "lpst"
            | "left-anterior-superior-time"
            | "last"
            | "scanner-xyz"
            | "scanner-xyz-time"
            | "3d-right-handed"
            | "3d-left-handed"
            | "3d-right-handed-time"
            | "3d-left-handed-time") => {
                return Err(IoError::unsupported(format!(
                    "line {}: NRRD space {s:?} is not supported; use left-posterior-superior, \
                     right-anterior-superior or left-anterior-superior",
                    f.line
                )));
            }
            s => return Err(bad(f.line, format!("unknown NRRD space {}", shown(s)))),
        }),
        None => None,
    };
    let space = match (space, get("space dimension")) {
        (s, None) => s,
        (s, Some(f)) => match f.desc.trim() {
            "3" => Some(s.unwrap_or(Space::Ras)),
            d => {
                return Err(IoError::unsupported(format!(
                    "line {}: space dimension {}; only 3D spaces are supported",
                    f.line,
                    shown(d)
                )));
            }
        },
    };
    let directions = match get("space directions") {
        Some(f) => {
            let d = direction_entries(f.desc, f.line)?;
            if d.len() != dimension {
                return Err(bad(
                    f.line,
                    format!(
                        "space directions has {} entries, expected {dimension} (one per axis)",
                        d.len()
                    ),
                ));
            }
            Some(d)
        }
        None => None,
    };
    let origin = match get("space origin") {
        Some(f) => Some(vector(f.desc, f.line, "space origin")?),
        None => None,
    };
    if space.is_none()
        && let Some(f) = get("space directions").or(get("space origin"))
    {
        return Err(bad(
            f.line,
            "space directions / space origin without a 'space' or 'space dimension' field",
        ));
    }
    let spacings = match get("spacings") {
        Some(f) => Some(numbers::<f64>(f.desc, dimension, f.line, "spacings")?),
        None => None,
    };
    let kinds = match get("kinds") {
        Some(f) => {
            let k: Vec<String> = f
                .desc
                .split_whitespace()
                .map(|w| w.to_ascii_lowercase())
                .collect();
            if k.len() != dimension {
                return Err(bad(
                    f.line,
                    format!(
                        "kinds has {} entries, expected {dimension} (one per axis)",
                        k.len()
                    ),
                ));
            }
            Some(k)
        }
        None => None,
    };

    // Where the data is.
    let byte_skip = match get("byte skip") {
        Some(f) => match f.desc.parse::<i64>() {
            Ok(b) if b >= -1 => b,
            _ => {
                return Err(bad(
                    f.line,
                    format!("byte skip {} is not -1 or a byte count", shown(f.desc)),
                ));
            }
        },
        None => 0,
    };
    let line_skip = match get("line skip") {
        Some(f) => f.desc.parse::<u64>().map_err(|_| {
            bad(
                f.line,
                format!("line skip {} is not a line count", shown(f.desc)),
            )
        })?,
        None => 0,
    };
    let data_file = match get("data file") {
        Some(f) => {
            let name = f.desc;
            if name.starts_with("LIST") || name.contains('%') {
                return Err(IoError::unsupported(format!(
                    "line {}: 'data file: {}' (several data files) is not supported; save \
                     the image as a single .nrrd",
                    f.line,
                    shown(name)
                )));
            }
            if name.is_empty() {
                return Err(bad(f.line, "data file is empty"));
            }
            Some(DataFile {
                name: name.to_string(),
                line: f.line,
            })
        }
        None => None,
    };
    Ok(Header {
        datatype,
        sizes,
        big_endian,
        encoding,
        space,
        directions,
        origin,
        spacings,
        kinds,
        byte_skip,
        line_skip,
        data_file,
        content: get("content").map(|f| f.desc.to_string()),
        key_values,
        data_offset,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(lines: &[&str]) -> Vec<u8> {
        let mut s = lines.join("\n");
        s.push_str("\n\n");
        s.into_bytes()
    }

    const BASE: [&str; 5] = [
        "NRRD0004",
        "type: short",
        "dimension: 3",
        "sizes: 2 3 4",
        "encoding: raw",
    ];

    fn with(extra: &[&str]) -> Vec<u8> {
        let mut l: Vec<&str> = BASE.to_vec();
        l.extend_from_slice(extra);
        header(&l)
    }

    fn err(bytes: &[u8]) -> String {
        parse(bytes).unwrap_err().to_string()
    }

    #[test]
    fn every_type_spelling() {
        let cases = [
            ("signed char", Datatype::Int8),
            ("int8_t", Datatype::Int8),
            ("uchar", Datatype::Uint8),
            ("unsigned  char", Datatype::Uint8),
            ("uint8", Datatype::Uint8),
            ("short", Datatype::Int16),
            ("signed short int", Datatype::Int16),
            ("int16", Datatype::Int16),
            ("ushort", Datatype::Uint16),
            ("unsigned short int", Datatype::Uint16),
            ("int", Datatype::Int32),
            ("signed int", Datatype::Int32),
            ("int32", Datatype::Int32),
            ("uint", Datatype::Uint32),
            ("unsigned int", Datatype::Uint32),
            ("longlong", Datatype::Int64),
            ("long long int", Datatype::Int64),
            ("int64", Datatype::Int64),
            ("ulonglong", Datatype::Uint64),
            ("unsigned long long", Datatype::Uint64),
            ("uint64_t", Datatype::Uint64),
            ("float", Datatype::Float32),
            ("DOUBLE", Datatype::Float64),
        ];
        for (name, dt) in cases {
            assert_eq!(datatype(name), Some(dt), "{name}");
        }
        for dt in Datatype::ALL {
            assert_eq!(datatype(type_name(dt)), Some(dt));
        }
    }

    #[test]
    fn fields_comments_and_key_values() {
        let h = parse(&with(&[
            "# a comment",
            "endian: little",
            "space: left-posterior-superior",
            "space directions: (-0.8,0,0) ( 0, -0.8, 0 ) (0,0,1.5)",
            "space origin: (10,20,-30)",
            "kinds: domain domain domain",
            "content: a label map",
            "Segment0_Name:=placenta: main",
            "byte skip: 3",
            "line skip: 1",
        ]))
        .unwrap();
        assert_eq!(h.datatype, Datatype::Int16);
        assert_eq!(h.sizes, [2, 3, 4]);
        assert_eq!(h.space, Some(Space::Lps));
        assert_eq!(
            h.directions.as_deref(),
            Some(
                &[
                    Some([-0.8, 0.0, 0.0]),
                    Some([0.0, -0.8, 0.0]),
                    Some([0.0, 0.0, 1.5])
                ][..]
            )
        );
        assert_eq!(h.origin, Some([10.0, 20.0, -30.0]));
        assert_eq!(h.content.as_deref(), Some("a label map"));
        assert_eq!(
            h.key_values,
            [("Segment0_Name".to_string(), "placenta: main".to_string())]
        );
        assert_eq!((h.byte_skip, h.line_skip), (3, 1));
        assert_eq!(h.data_len(), 48);
    }

    #[test]
    fn crlf_and_space_dimension_alone_is_ras() {
        let text = "NRRD0005\r\ntype: uint8\r\ndimension: 3\r\nsizes: 1 1 1\r\n\
                    encoding: gz\r\nspace dimension: 3\r\n\
                    space directions: (1,0,0) (0,1,0) (0,0,1)\r\n\r\nDATA";
        let h = parse(text.as_bytes()).unwrap();
        assert_eq!(h.space, Some(Space::Ras));
        assert_eq!(h.encoding, Encoding::Gzip);
        assert_eq!(&text.as_bytes()[h.data_offset.unwrap()..], b"DATA");
    }

    #[test]
    fn four_d_with_none_direction() {
        let h = parse(&header(&[
            "NRRD0004",
            "type: float",
            "dimension: 4",
            "sizes: 3 2 2 2",
            "encoding: raw",
            "endian: big",
            "space: RAS",
            "space directions: none (1,0,0) (0,1,0) (0,0,1)",
            "kinds: list domain domain domain",
        ]))
        .unwrap();
        assert!(h.big_endian);
        assert_eq!(h.directions.as_ref().unwrap()[0], None);
        assert_eq!(h.kinds.as_ref().unwrap()[0], "list");
    }

    #[test]
    fn bad_headers_are_typed_errors_with_location() {
        let line_of = |b: &[u8]| match parse(b).unwrap_err() {
            IoError::Malformed { location, .. } => location,
            e => panic!("not malformed: {e}"),
        };
        assert!(err(b"P5\n1 1\n").contains("not a NRRD file"));
        assert_eq!(line_of(b"hello\n\n"), Location::Line(1));
        assert!(matches!(
            parse(b"NRRD0009\n\n"),
            Err(IoError::Unsupported { .. })
        ));
        // Missing required fields.
        for missing in 1..5 {
            let mut l: Vec<&str> = BASE.to_vec();
            let name = l.remove(missing).split(':').next().unwrap().to_string();
            let e = err(&header(&l));
            assert!(e.contains(&format!("no '{name}' field")), "{e}");
        }
        assert!(err(&with(&[])).contains("'endian'"));
        // Unknown values.
        let mut l = BASE.to_vec();
        l[1] = "type: quaternion";
        assert_eq!(line_of(&header(&l)), Location::Line(2));
        l[1] = "type: block";
        assert!(matches!(
            parse(&header(&l)),
            Err(IoError::Unsupported { .. })
        ));
        let mut l = BASE.to_vec();
        l[4] = "encoding: zip";
        assert_eq!(line_of(&header(&l)), Location::Line(5));
        l[4] = "encoding: bzip2";
        assert!(err(&header(&l)).contains("bzip2"));
        assert_eq!(
            line_of(&with(&["endian: little", "space: martian"])),
            Location::Line(7)
        );
        assert!(matches!(
            parse(&with(&["endian: little", "space: scanner-xyz"])),
            Err(IoError::Unsupported { .. })
        ));
        // Dimension and sizes.
        let mut l = BASE.to_vec();
        l[2] = "dimension: 2";
        assert!(err(&header(&l)).contains("only 3D images and 4D series"));
        let mut l = BASE.to_vec();
        l[3] = "sizes: 2 3";
        assert_eq!(line_of(&header(&l)), Location::Line(4));
        l[3] = "sizes: 2 3 0";
        assert!(err(&header(&l)).contains("out of range"));
        l[3] = "sizes: 2 3 99999999999999999999999";
        assert_eq!(line_of(&header(&l)), Location::Line(4));
        l[3] = "sizes: 32768 1 1";
        assert!(err(&header(&l)).contains("out of range"));
        // Per-axis fields of the wrong length, bad vectors, duplicates.
        assert!(
            err(&with(&[
                "endian: little",
                "space: LPS",
                "space directions: (1,0,0) (0,1,0)"
            ]))
            .contains("2 entries")
        );
        assert!(
            err(&with(&[
                "endian: little",
                "space: LPS",
                "space directions: (1,0,0) (0,1,0) (0,0,nan)"
            ]))
            .contains("finite")
        );
        assert!(
            err(&with(&[
                "endian: little",
                "space: LPS",
                "space origin: (1,0)"
            ]))
            .contains("only 3D spaces")
        );
        assert!(
            err(&with(&[
                "endian: little",
                "space directions: (1,0,0) (0,1,0) (0,0,1)"
            ]))
            .contains("without a 'space'")
        );
        assert!(err(&with(&["endian: little", "endian: big"])).contains("appears twice"));
        assert!(err(&with(&["endian: little", "kinds: domain"])).contains("1 entries"));
        assert!(err(&with(&["endian: little", "byte skip: -2"])).contains("byte skip"));
        assert!(err(&with(&["endian: little", "just words"])).contains("expected 'field"));
        assert!(matches!(
            parse(&with(&["endian: little", "data file: LIST"])),
            Err(IoError::Unsupported { .. })
        ));
        assert!(matches!(
            parse(&with(&["endian: little", "data file: slice%03d.raw 0 9 1"])),
            Err(IoError::Unsupported { .. })
        ));
    }

    #[test]
    fn header_size_is_bounded() {
        let mut b = b"NRRD0004\n".to_vec();
        b.resize(MAX_HEADER + 100, b'a');
        let e = parse(&b).unwrap_err();
        assert!(e.to_string().contains("longer than"), "{e}");
        // Text from the file in messages is cut short.
        let mut l = BASE.to_vec();
        let long = format!("type: {}", "x".repeat(5000));
        l[1] = &long;
        let e = err(&header(&l));
        assert!(e.len() < 200 && e.contains("..."), "{e}");
        // Long lines of comments also count.
        let mut b = b"NRRD0004\n".to_vec();
        while b.len() <= MAX_HEADER + 10 {
            b.extend_from_slice(b"# comment comment comment\n");
        }
        assert!(parse(&b).unwrap_err().to_string().contains("longer than"));
    }
}
