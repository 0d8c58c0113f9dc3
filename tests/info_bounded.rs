//! `unfold info` reads an image header first and streams its values: on a
//! 1 MB `.nii.gz` of 1024³ zeros its peak memory stays small; a gzip stream
//! holding more or less than the header declares is refused; `--strict`
//! fails on a mesh whose volume overflows.

mod common;

use common::{assert_one_line_error, s, stdout, unfold};
use flate2::{Compress, Compression, Crc, FlushCompress};
use std::path::Path;

/// A NIfTI-1 header (352 bytes, little-endian, `vox_offset` 352) for a
/// UINT8 image of `dims`, unit spacing, sform = identity.
fn nifti_header(dims: [i16; 3]) -> Vec<u8> {
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
fn gzip_of_header_and_zeros(path: &Path, header: &[u8], zero_mib: usize) {
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

/// Runs `unfold args`, stdout to a file, and returns (exit success, stdout,
/// peak resident memory of the child in bytes from `wait4`).
#[expect(
    clippy::zombie_processes,
    reason = "the child is reaped by libc::wait4, which also gives its rusage"
)]
fn run_measured(args: &[&str], out: &Path) -> (bool, String, u64) {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_unfold"))
        .args(args)
        .stdout(std::fs::File::create(out).unwrap())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: an all-zero rusage is a valid value of the plain C struct.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not yet waited for (std waits only in
    // `wait`/`try_wait`, which are not called); the pointers are to locals.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4: {}", std::io::Error::last_os_error());
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    // Linux reports ru_maxrss in KiB.
    let peak = usage.ru_maxrss as u64 * 1024;
    (ok, std::fs::read_to_string(out).unwrap(), peak)
}

/// 1024³ UINT8 zeros in a ~1 MB `.nii.gz`: `info` prints the header and
/// the range reading the header first and streaming the gigabyte of values,
/// with a peak memory under 64 MB (it held 5.85 GB before).
#[cfg(target_os = "linux")]
#[test]
fn info_on_a_gigabyte_of_gzipped_zeros_stays_small() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("zeros.nii.gz");
    gzip_of_header_and_zeros(&img, &nifti_header([1024, 1024, 1024]), 1024);
    let size = std::fs::metadata(&img).unwrap().len();
    assert!(size < 1_200_000, "the test file is {size} bytes");

    let out = dir.path().join("out.txt");
    let (ok, text, peak) = run_measured(&["info", &s(&img)], &out);
    assert!(ok, "{text}");
    assert!(text.contains("  dims: [1024, 1024, 1024, 1]"), "{text}");
    assert!(text.contains("  data type: uint8"), "{text}");
    assert!(text.contains("  value range: [0, 0]"), "{text}");
    assert!(text.contains("  affine (sform):"), "{text}");
    assert!(
        text.contains("spacing: 1.000000 x 1.000000 x 1.000000 mm"),
        "{text}"
    );
    assert!(peak < 64 << 20, "peak memory {peak} bytes");
    eprintln!("info on 1024^3 gzipped zeros: peak RSS {} KiB", peak >> 10);

    let (ok, json, peak) = run_measured(&["info", &s(&img), "--json", "--strict"], &out);
    assert!(ok, "{json}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["dims"], serde_json::json!([1024, 1024, 1024, 1]));
    assert_eq!(v["value_range"], serde_json::json!([0.0, 0.0]));
    assert!(peak < 64 << 20, "peak memory {peak} bytes (--json)");
}

/// A `.nii.gz` whose stream holds more than its header declares is refused
/// naming the declared size; one holding less names both sizes.
#[test]
fn info_refuses_a_gzip_stream_of_the_wrong_size() {
    let dir = tempfile::tempdir().unwrap();
    // Declares 64³ bytes (+ 352 header bytes), holds 2 MiB.
    let declared = 352 + 64 * 64 * 64;
    let more = dir.path().join("more.nii.gz");
    gzip_of_header_and_zeros(&more, &nifti_header([64, 64, 64]), 2);
    assert_one_line_error(
        &unfold(&["info", &s(&more)]),
        &format!("decompresses to more than {declared} bytes"),
    );
    // (Declaring a little more than it holds: zeros compress ~1000:1, and a
    // header declaring more than 1100 times the file is refused up front.)
    let less = dir.path().join("less.nii.gz");
    gzip_of_header_and_zeros(&less, &nifti_header([128, 128, 65]), 1);
    let o = unfold(&["info", &s(&less), "--json"]);
    assert_one_line_error(
        &o,
        &format!(
            "decompresses to only {} bytes, but the header declares {}",
            352 + (1 << 20),
            352 + 128 * 128 * 65
        ),
    );
    assert!(stdout(&o).is_empty());
    // The exact size reads.
    let exact = dir.path().join("exact.nii.gz");
    gzip_of_header_and_zeros(&exact, &nifti_header([128, 128, 64]), 1);
    let o = unfold(&["info", &s(&exact)]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(stdout(&o).contains("  value range: [0, 0]"));
}

/// `info --strict` fails on a tet mesh whose coordinates are finite but so
/// large that its volume is not (1e308: the products overflow).
#[test]
fn info_strict_fails_on_an_infinite_volume() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("huge.vtk");
    std::fs::write(
        &m,
        "# vtk DataFile Version 4.2\nhuge\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
         0 0 0 1e308 0 0 0 1e308 0 0 0 1e308\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
    )
    .unwrap();
    let o = unfold(&["info", &s(&m), "--strict"]);
    assert_one_line_error(&o, "the volume of element 0 is");
    assert!(common::stderr(&o).contains("scale the mesh down"));
    // Infinite or NaN coordinates are refused by the readers themselves.
    let inf = dir.path().join("inf.vtk");
    std::fs::write(
        &inf,
        "# vtk DataFile Version 4.2\ninf\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
         0 0 0 inf 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
    )
    .unwrap();
    assert_one_line_error(
        &unfold(&["info", &s(&inf)]),
        "vertex 1 has a non-finite coordinate",
    );
    // Without --strict it is reported, not fatal.
    let o = unfold(&["info", &s(&m)]);
    assert!(o.status.success());
    assert!(
        stdout(&o).contains("problem non_finite_measure (x1)"),
        "{}",
        stdout(&o)
    );
}
