//! Decoding a NRRD file's data: raw, gzip or ascii, after `line skip` and
//! `byte skip`, checked against the size the header declares.
//!
//! `line skip` lines are skipped first, in the stored bytes; `byte skip`
//! bytes are then skipped in the decoded stream (after decompression for
//! gzip, as teem does); `byte skip: -1` (raw only) means the data is the last
//! bytes of the file. The data must be exactly `product(sizes) × type size`
//! bytes (raw, and gzip after decompression: it is inflated about 1 MiB at a
//! time and never more than one byte past the declared size, so a compression
//! bomb costs no more than the declared data; a stream holding more or less
//! is refused with [`IoError::DecompressedSize`]), or exactly
//! `product(sizes)` numbers (ascii).

use super::header::{Encoding, Header};
use crate::nifti::{GZ_MAX_RATIO, fill, stream_packed};
use crate::{FilePath, IoError, Location};
use flate2::bufread::MultiGzDecoder;
use std::io::{BufRead, Read};

fn bad(at: u64, msg: impl Into<String>) -> IoError {
    IoError::malformed(Location::Byte(at), msg)
}

/// The values of the data in `source` (the bytes after an attached header,
/// or a detached data file), in file order (axis 0 fastest). `base` is the
/// offset of `source` in its file, for error locations.
pub(super) fn values(h: &Header, source: &[u8], base: u64) -> Result<Vec<f32>, IoError> {
    // The raw and gzip sizes are checked before anything is handed over, so
    // the vector grows only to what the header declares.
    let mut out = Vec::new();
    stream(
        h,
        &mut &source[..],
        source.len() as u64,
        base,
        &mut |v: &[f32]| out.extend_from_slice(v),
    )?;
    Ok(out)
}

/// Skips one line (through its `\n`) of `r`; false when the data ends first.
/// Returns the bytes skipped.
fn skip_line(r: &mut impl BufRead) -> std::io::Result<(bool, u64)> {
    let mut n = 0u64;
    loop {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            return Ok((false, n));
        }
        match buf.iter().position(|&c| c == b'\n') {
            Some(i) => {
                r.consume(i + 1);
                return Ok((true, n + i as u64 + 1));
            }
            None => {
                let k = buf.len();
                r.consume(k);
                n += k as u64;
            }
        }
    }
}

/// Streams the values of the data in `r` (`len` bytes: the bytes after an
/// attached header, or a detached data file) to `sink` in chunks of about
/// 1 MiB of stored data, in file order (axis 0 fastest). `base` is the
/// offset of `r` in its file, for error locations. See the [module
/// documentation](self) for the checks.
pub(super) fn stream(
    h: &Header,
    r: &mut impl BufRead,
    len: u64,
    base: u64,
    sink: &mut dyn FnMut(&[f32]),
) -> Result<(), IoError> {
    let io = |source| IoError::Io {
        path: FilePath::default(),
        source,
    };
    // line skip
    let mut start = 0u64;
    for skipped in 0..h.line_skip {
        match skip_line(r).map_err(io)? {
            (true, n) => start += n,
            (false, _) => {
                return Err(bad(
                    base + len,
                    format!(
                        "line skip is {}, but the data has only {skipped} lines",
                        h.line_skip
                    ),
                ));
            }
        }
    }
    let rest = len.saturating_sub(start);
    let at = base + start;
    let expected = h.data_len();
    let skip = match (h.byte_skip, h.encoding) {
        (-1, Encoding::Raw) => None,
        (-1, _) => {
            return Err(bad(
                at,
                "byte skip -1 (data at the end of the file) is only valid for raw data",
            ));
        }
        (b, _) => Some(b as u64),
    };
    let layout = (h.datatype, h.big_endian, None);
    match h.encoding {
        Encoding::Raw => {
            let from = match skip {
                None if rest >= expected => rest - expected,
                Some(b) if b.checked_add(expected) == Some(rest) => b,
                Some(b) if b.checked_add(expected).is_some_and(|e| e < rest) => {
                    return Err(bad(
                        at + b + expected,
                        format!(
                            "{} bytes follow the {expected} bytes of data the header declares \
                             (sizes {:?}); the sizes or type are wrong",
                            rest - b - expected,
                            h.sizes
                        ),
                    ));
                }
                _ => {
                    return Err(raw_short(
                        h,
                        at + rest,
                        rest.saturating_sub(skip.unwrap_or(0)),
                    ));
                }
            };
            let skipped = std::io::copy(&mut r.take(from), &mut std::io::sink()).map_err(io)?;
            let got = stream_packed(r, expected, layout, sink, &|e, _| io(e))?;
            if skipped < from || got < expected {
                // The file shrank while it was read.
                return Err(raw_short(h, at + skipped + got, got));
            }
            Ok(())
        }
        Encoding::Gzip => {
            let skip = skip.unwrap_or(0);
            let total = skip.saturating_add(expected);
            let most = rest.saturating_mul(GZ_MAX_RATIO).saturating_add(4096);
            if total > most {
                return Err(bad(
                    at,
                    format!(
                        "the header declares {total} bytes of data, more than {rest} \
                         gzip-compressed bytes can hold: the file is truncated or the sizes \
                         are wrong"
                    ),
                ));
            }
            let gz = |e: std::io::Error| bad(at, format!("gzip decompression failed: {e}"));
            let size = |found| IoError::DecompressedSize {
                path: FilePath::default(),
                declared: total,
                found,
            };
            let mut dec = MultiGzDecoder::new(r);
            let skipped =
                std::io::copy(&mut (&mut dec).take(skip), &mut std::io::sink()).map_err(gz)?;
            if skipped < skip {
                return Err(size(skipped));
            }
            let got = stream_packed(&mut dec, expected, layout, sink, &|e, _| gz(e))?;
            if got < expected {
                return Err(size(skip + got));
            }
            // Never more than one byte past the declared size.
            if fill(&mut dec, &mut [0u8; 1]).map_err(gz)? > 0 {
                return Err(size(total + 1));
            }
            Ok(())
        }
        Encoding::Ascii => {
            // Text is at least as long as its values: read it whole.
            let mut text = Vec::new();
            r.take(rest).read_to_end(&mut text).map_err(io)?;
            let b = skip.unwrap_or(0);
            if b > text.len() as u64 {
                return Err(bad(
                    at + text.len() as u64,
                    format!("byte skip {b} is past the end of the data"),
                ));
            }
            sink(&ascii(&text[b as usize..], h.count(), at + b)?);
            Ok(())
        }
    }
}

/// The error of raw data ending after `found` bytes of data at `end`.
fn raw_short(h: &Header, end: u64, found: u64) -> IoError {
    bad(
        end,
        format!(
            "the data ends after {found} bytes, but the header declares {} \
             (sizes {:?} of {}-byte values, byte skip {}): the file is truncated",
            h.data_len(),
            h.sizes,
            h.datatype.size(),
            h.byte_skip
        ),
    )
}

/// Parses `count` numbers separated by white space or commas.
fn ascii(text: &[u8], count: usize, at: u64) -> Result<Vec<f32>, IoError> {
    // Every number takes at least two bytes (digit and separator), so this
    // bounds the allocation by the input.
    let mut out = Vec::with_capacity(count.min(text.len() / 2 + 1));
    let is_sep = |c: &u8| c.is_ascii_whitespace() || *c == b',';
    let mut pos = 0usize;
    while pos < text.len() {
        if is_sep(&text[pos]) {
            pos += 1;
            continue;
        }
        let len = text[pos..]
            .iter()
            .position(is_sep)
            .unwrap_or(text.len() - pos);
        let word = &text[pos..pos + len];
        if out.len() == count {
            return Err(bad(
                at + pos as u64,
                format!("more than the {count} numbers the header declares"),
            ));
        }
        let v = std::str::from_utf8(word)
            .ok()
            .and_then(|w| w.parse::<f64>().ok())
            .ok_or_else(|| {
                bad(
                    at + pos as u64,
                    format!(
                        "{:?} is not a number",
                        String::from_utf8_lossy(&word[..word.len().min(32)])
                    ),
                )
            })?;
        out.push(v as f32);
        pos += len;
    }
    if out.len() != count {
        return Err(bad(
            at + text.len() as u64,
            format!(
                "the data has {} numbers, but the header declares {count}: the file is truncated",
                out.len()
            ),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Datatype;
    use flate2::write::GzEncoder;
    use std::io::Write;

    fn header(encoding: Encoding, sizes: &[usize], datatype: Datatype) -> Header {
        Header {
            datatype,
            sizes: sizes.to_vec(),
            big_endian: false,
            encoding,
            space: None,
            directions: None,
            origin: None,
            spacings: None,
            kinds: None,
            byte_skip: 0,
            line_skip: 0,
            data_file: None,
            content: None,
            key_values: Vec::new(),
            data_offset: Some(0),
        }
    }

    fn gz(bytes: &[u8]) -> Vec<u8> {
        let mut e = GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn raw_with_skips_and_byte_order() {
        let mut h = header(Encoding::Raw, &[2, 1, 1], Datatype::Int16);
        h.big_endian = true;
        assert_eq!(values(&h, &[0, 1, 255, 254], 0).unwrap(), [1.0, -2.0]);
        h.line_skip = 2;
        h.byte_skip = 3;
        assert_eq!(
            values(&h, b"ab\ncd\nxyz\x00\x01\xff\xfe", 0).unwrap(),
            [1.0, -2.0]
        );
        h.line_skip = 0;
        h.byte_skip = -1;
        assert_eq!(
            values(&h, b"anything\x00\x01\xff\xfe", 0).unwrap(),
            [1.0, -2.0]
        );
    }

    #[test]
    fn raw_size_must_match() {
        let h = header(Encoding::Raw, &[2, 2, 1], Datatype::Uint8);
        let e = values(&h, &[1, 2, 3], 10).unwrap_err();
        assert!(e.to_string().contains("truncated"), "{e}");
        assert!(matches!(
            e,
            IoError::Malformed {
                location: Location::Byte(13),
                ..
            }
        ));
        let e = values(&h, &[1, 2, 3, 4, 5], 0).unwrap_err();
        assert!(e.to_string().contains("1 bytes follow"), "{e}");
        let mut h = h;
        h.line_skip = 3;
        assert!(
            values(&h, b"a\nb\n", 0)
                .unwrap_err()
                .to_string()
                .contains("only 2 lines")
        );
        h.line_skip = 0;
        h.byte_skip = -1;
        assert!(values(&h, &[1, 2, 3], 0).is_err());
    }

    #[test]
    fn gzip_exact_size_and_bomb_bound() {
        let mut h = header(Encoding::Gzip, &[2, 2, 1], Datatype::Uint8);
        assert_eq!(
            values(&h, &gz(&[1, 2, 3, 4]), 0).unwrap(),
            [1.0, 2.0, 3.0, 4.0]
        );
        h.byte_skip = 2;
        assert_eq!(
            values(&h, &gz(&[9, 9, 1, 2, 3, 4]), 0).unwrap(),
            [1.0, 2.0, 3.0, 4.0]
        );
        h.byte_skip = 0;
        let e = values(&h, &gz(&[1, 2, 3]), 0).unwrap_err();
        assert!(e.to_string().contains("only 3 bytes"), "{e}");
        let e = values(&h, &gz(&[1, 2, 3, 4, 5, 6]), 0).unwrap_err();
        assert!(e.to_string().contains("more than 4 bytes"), "{e}");
        // Truncated compressed stream.
        let z = gz(&[7u8; 1000]);
        let h = header(Encoding::Gzip, &[10, 10, 10], Datatype::Uint8);
        assert!(values(&h, &z[..z.len() - 10], 0).is_err());
        // A bomb: 64 MiB of zeros declared as much bigger (fails before
        // inflating) and as smaller (inflates at most one byte more).
        let bomb = gz(&vec![0u8; 1 << 26]);
        let h = header(Encoding::Gzip, &[32767, 32767, 1], Datatype::Float64);
        let e = values(&h, &bomb, 0).unwrap_err();
        assert!(e.to_string().contains("can hold"), "{e}");
        let h = header(Encoding::Gzip, &[100, 100, 100], Datatype::Uint8);
        let e = values(&h, &bomb, 0).unwrap_err();
        assert!(e.to_string().contains("more than 1000000 bytes"), "{e}");
        let mut h = h;
        h.byte_skip = -1;
        assert!(values(&h, &bomb, 0).is_err());
    }

    #[test]
    fn ascii_numbers() {
        let h = header(Encoding::Ascii, &[3, 1, 1], Datatype::Float32);
        assert_eq!(
            values(&h, b" 1.5, -2\n3e2\n", 0).unwrap(),
            [1.5, -2.0, 300.0]
        );
        assert!(
            values(&h, b"1 2", 0)
                .unwrap_err()
                .to_string()
                .contains("truncated")
        );
        assert!(
            values(&h, b"1 2 3 4", 0)
                .unwrap_err()
                .to_string()
                .contains("more than")
        );
        assert!(
            values(&h, b"1 x 3", 0)
                .unwrap_err()
                .to_string()
                .contains("not a number")
        );
    }
}
