//! `unfold info` reads an image header first and streams its values: on a
//! 1 MB `.nii.gz` of 1024³ zeros its peak memory stays small; a gzip stream
//! holding more or less than the header declares is refused; `--strict`
//! fails on a mesh whose volume overflows.

mod common;
#[path = "common/gzip_zeros.rs"]
mod gzip_zeros;
use gzip_zeros::{gzip_of_header_and_zeros, nifti_header};
#[path = "common/measured.rs"]
mod measured;

use common::{assert_one_line_error, s, stdout, unfold};

/// Runs `unfold args` and returns (exit success, stdout, the process's own
/// peak resident memory in bytes, `VmHWM` written at exit).
fn run_measured(args: &[&str]) -> (bool, String, u64) {
    let (o, peak) = measured::unfold_measured(args);
    (o.status.success(), stdout(&o), peak)
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

    let (ok, text, peak) = run_measured(&["info", &s(&img)]);
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

    let (ok, json, peak) = run_measured(&["info", &s(&img), "--json", "--strict"]);
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
