//! A gigabyte of gzipped zeros in about a megabyte, built in about a
//! second: a NIfTI-1 header and 1 MiB of zeros deflated once, its blocks
//! repeated.

use flate2::{Compress, Compression, Crc, FlushCompress};
use std::path::Path;

/// A NIfTI-1 header (352 bytes, little-endian, `vox_offset` 352) for a
/// UINT8 image of `dims`, unit spacing, sform = identity.
pub fn nifti_header(dims: [i16; 3]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    let mut put = |off: usize, v: &[u8]| h[off..off + v.len()].copy_from_slice(v);
    put(0, &348i32.to_le_bytes());
    put(40, &3i16.to_le_bytes());
    for (i, d) in dims.iter().enumerate() {
        put(42 + 2 * i, &d.to_le_bytes());
    }
    for i in 3..7 {
        put(42 + 2 * i, &1i16.to_le_bytes());
    }
    put(70, &2i16.to_le_bytes()); // UINT8
    put(72, &8i16.to_le_bytes());
    for i in 0..4 {
        put(76 + 4 * i, &1f32.to_le_bytes());
    }
    put(108, &352f32.to_le_bytes());
    put(112, &1f32.to_le_bytes());
    put(254, &2i16.to_le_bytes()); // sform_code aligned
    for r in 0..3 {
        put(280 + 16 * r + 4 * r, &1f32.to_le_bytes());
    }
    put(344, b"n+1\0");
    h
}

/// Raw deflate of `data` from a fresh compressor, ended by a sync flush (so
/// the bytes are a whole number of non-final blocks that can be followed by
/// more blocks).
fn deflate_sync(data: &[u8]) -> Vec<u8> {
    let mut c = Compress::new(Compression::best(), false);
    let mut out = Vec::with_capacity(data.len() + 1024);
    c.compress_vec(data, &mut out, FlushCompress::Sync).unwrap();
    assert_eq!(
        c.total_in(),
        data.len() as u64,
        "one call compresses it all"
    );
    out
}

/// A gzip file of `header` followed by `zero_mib` MiB of zeros, built in
/// about a second: 1 MiB of zeros is deflated once and its blocks repeated
/// (their back-references reach only zeros, so every copy decodes to the
/// same MiB), then a final empty block and the gzip trailer (CRC-32 and
/// length of everything).
pub fn gzip_of_header_and_zeros(path: &Path, header: &[u8], zero_mib: usize) {
    let zeros = vec![0u8; 1 << 20];
    let head = deflate_sync(header);
    let block = deflate_sync(&zeros);
    let mut crc = Crc::new();
    crc.update(header);
    for _ in 0..zero_mib {
        crc.update(&zeros);
    }
    let mut gz = vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 255];
    gz.extend_from_slice(&head);
    gz.reserve(block.len() * zero_mib + 16);
    for _ in 0..zero_mib {
        gz.extend_from_slice(&block);
    }
    gz.extend_from_slice(&[0x03, 0x00]); // final fixed-Huffman block, end of block only
    gz.extend_from_slice(&crc.sum().to_le_bytes());
    let len = header.len() as u64 + (zero_mib as u64) * (1 << 20);
    gz.extend_from_slice(&(len as u32).to_le_bytes());
    std::fs::write(path, gz).unwrap();
}
