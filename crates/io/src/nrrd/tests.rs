//! Tests of NRRD reading and writing as a whole (header and data parts have
//! their own unit tests).

use super::*;
use crate::Datatype;
use flate2::write::GzEncoder;
use nalgebra::{Point3, Rotation3, Vector3};
use proptest::prelude::*;
use std::io::Write;
use unfold_mesh::Volume;

/// A hand-written header (lines joined, empty line added) followed by `data`.
fn file(lines: &[&str], data: &[u8]) -> Vec<u8> {
    let mut b = lines.join("\n").into_bytes();
    b.extend_from_slice(b"\n\n");
    b.extend_from_slice(data);
    b
}

fn gz(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn err(bytes: &[u8]) -> String {
    read(bytes, None).unwrap_err().to_string()
}

#[test]
fn slicer_lps_header_gives_the_world_positions_of_the_ras_nifti() {
    // A Slicer-style header: LPS, axes along -x and -y of LPS, i.e. +x, +y
    // of RAS, with the origin at LPS (10, 20, -30) = RAS (-10, -20, -30).
    let values: Vec<u8> = (0..24).collect();
    let nrrd = file(
        &[
            "NRRD0004",
            "# Complete NRRD file format specification at:",
            "type: unsigned char",
            "dimension: 3",
            "space: left-posterior-superior",
            "sizes: 2 3 4",
            "space directions: (-0.8,0,0) (0,-0.8,0) (0,0,1.5)",
            "kinds: domain domain domain",
            "encoding: raw",
            "space origin: (10,20,-30)",
        ],
        &values,
    );
    let img = read(&nrrd, None).unwrap();
    assert_eq!(img.datatype, Datatype::Uint8);
    assert_eq!(img.affine_source, AffineSource::SpaceDirections);
    assert_eq!(img.volume.dims(), [2, 3, 4, 1]);

    // The equivalent NIfTI, built independently: RAS affine by hand.
    let mut ras = Matrix4::identity();
    ras[(0, 0)] = 0.8;
    ras[(1, 1)] = 0.8;
    ras[(2, 2)] = 1.5;
    ras[(0, 3)] = -10.0;
    ras[(1, 3)] = -20.0;
    ras[(2, 3)] = -30.0;
    let data: Vec<f32> = values.iter().map(|&v| f32::from(v)).collect();
    let nifti = NiftiImage::new(Volume::new([2, 3, 4, 1], ras, data).unwrap())
        .with_datatype(Datatype::Uint8);
    let nifti = crate::nifti::read(&crate::nifti::write(&nifti, false).unwrap()).unwrap();
    for (i, j, k) in [(0, 0, 0), (1, 0, 0), (0, 2, 0), (1, 2, 3), (0, 1, 2)] {
        let v = Point3::new(i as f64, j as f64, k as f64);
        let a = img.volume.voxel_to_world(&v);
        let b = nifti.volume.voxel_to_world(&v);
        assert!((a - b).norm() < 1e-6, "voxel {v}: nrrd {a} vs nifti {b}");
        assert_eq!(
            img.volume.get(i, j, k, 0),
            nifti.volume.get(i, j, k, 0),
            "value at {v}"
        );
    }
    // Voxel (1, 2, 3) is at RAS (-10 + 0.8, -20 + 1.6, -30 + 4.5).
    let p = img.volume.voxel_to_world(&Point3::new(1.0, 2.0, 3.0));
    assert!((p - Point3::new(-9.2, -18.4, -25.5)).norm() < 1e-12, "{p}");
}

#[test]
fn las_and_ras_spaces_and_spacings_only() {
    let base = |space: &str| {
        file(
            &[
                "NRRD0004",
                "type: uint8",
                "dimension: 3",
                "sizes: 1 1 1",
                "encoding: raw",
                space,
                "space directions: (2,0,0) (0,3,0) (0,0,4)",
                "space origin: (1,2,3)",
            ],
            &[7],
        )
    };
    let t = |b: &[u8]| {
        let a = *read(b, None).unwrap().volume.affine();
        (
            [a[(0, 0)], a[(1, 1)], a[(2, 2)]],
            [a[(0, 3)], a[(1, 3)], a[(2, 3)]],
        )
    };
    assert_eq!(
        t(&base("space: right-anterior-superior")),
        ([2.0, 3.0, 4.0], [1.0, 2.0, 3.0])
    );
    assert_eq!(t(&base("space: RAS")), t(&base("space dimension: 3")));
    assert_eq!(
        t(&base("space: left-anterior-superior")),
        ([-2.0, 3.0, 4.0], [-1.0, 2.0, 3.0])
    );
    assert_eq!(
        t(&base("space: LPS")),
        ([-2.0, -3.0, 4.0], [-1.0, -2.0, 3.0])
    );
    let img = read(
        &file(
            &[
                "NRRD0001",
                "type: float",
                "dimension: 3",
                "sizes: 2 1 1",
                "spacings: 0.5 nan 2",
                "encoding: ascii",
            ],
            b"1.25 -3\n",
        ),
        None,
    )
    .unwrap();
    assert_eq!(img.affine_source, AffineSource::Spacings);
    assert_eq!(
        img.volume.affine(),
        &Matrix4::from_diagonal(&nalgebra::Vector4::new(0.5, 1.0, 2.0, 1.0))
    );
    assert_eq!(img.volume.data(), &[1.25, -3.0]);
}

/// A 2 x 3 x 2 x 3 series as values `v = 100 t + index`, stored with the frame
/// axis at `frame` (0 or 3).
fn series(frame: usize) -> Vec<u8> {
    let (nx, ny, nz, nt) = (2usize, 3, 2, 3);
    let mut vals = Vec::new();
    let val = |i: usize, j: usize, k: usize, t: usize| (100 * t + i + nx * (j + ny * k)) as i16;
    if frame == 0 {
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    for t in 0..nt {
                        vals.extend_from_slice(&val(i, j, k, t).to_be_bytes());
                    }
                }
            }
        }
    } else {
        for t in 0..nt {
            for k in 0..nz {
                for j in 0..ny {
                    for i in 0..nx {
                        vals.extend_from_slice(&val(i, j, k, t).to_be_bytes());
                    }
                }
            }
        }
    }
    let (sizes, dirs, kinds) = if frame == 0 {
        (
            "sizes: 3 2 3 2",
            "space directions: none (1,0,0) (0,1,0) (0,0,1)",
            "kinds: list domain domain domain",
        )
    } else {
        (
            "sizes: 2 3 2 3",
            "space directions: (1,0,0) (0,1,0) (0,0,1) none",
            "kinds: domain domain domain time",
        )
    };
    file(
        &[
            "NRRD0004",
            "type: short",
            "dimension: 4",
            sizes,
            "endian: big",
            "encoding: gzip",
            "space: RAS",
            dirs,
            kinds,
            "spacings: nan nan nan nan",
        ],
        &gz(&vals),
    )
}

#[test]
fn four_d_frame_axis_first_or_last() {
    for frame in [0, 3] {
        let img = read(&series(frame), None).unwrap();
        let v = &img.volume;
        assert_eq!(v.dims(), [2, 3, 2, 3], "frame axis {frame}");
        for t in 0..3 {
            for k in 0..2 {
                for j in 0..3 {
                    for i in 0..2 {
                        let want = (100 * t + i + 2 * (j + 3 * k)) as f32;
                        assert_eq!(v.get(i, j, k, t), Some(want), "frame axis {frame}");
                    }
                }
            }
        }
        assert_eq!(img.datatype, Datatype::Int16);
    }
    // Without space directions: the non-spatial kind, else the last axis.
    let img = read(
        &file(
            &[
                "NRRD0004",
                "type: uint8",
                "dimension: 4",
                "sizes: 2 1 1 1",
                "kinds: vector domain domain domain",
                "spacings: 2.5 1 1 1",
                "encoding: raw",
            ],
            &[1, 2],
        ),
        None,
    )
    .unwrap();
    assert_eq!(img.volume.dims(), [1, 1, 1, 2]);
    assert_eq!(img.time_step, 2.5);
    let img = read(
        &file(
            &[
                "NRRD0004",
                "type: uint8",
                "dimension: 4",
                "sizes: 1 1 1 2",
                "encoding: raw",
            ],
            &[1, 2],
        ),
        None,
    )
    .unwrap();
    assert_eq!(img.volume.dims(), [1, 1, 1, 2]);
    // Two non-spatial axes, or a 3D image with one, are refused.
    let e = err(&file(
        &[
            "NRRD0004",
            "type: uint8",
            "dimension: 4",
            "sizes: 1 1 1 2",
            "space: RAS",
            "space directions: none (1,0,0) (0,1,0) none",
            "encoding: raw",
        ],
        &[1, 2],
    ));
    assert!(e.contains("2 are not spatial"), "{e}");
    let e = err(&file(
        &[
            "NRRD0004",
            "type: uint8",
            "dimension: 3",
            "sizes: 2 1 1",
            "kinds: list domain domain",
            "encoding: raw",
        ],
        &[1, 2],
    ));
    assert!(e.contains("only 3D images and 4D series"), "{e}");
}

/// A Slicer `.seg.nrrd` of `layers` layers of a 2 x 2 x 1 grid.
fn slicer_seg(layers: usize) -> Vec<u8> {
    let mut lines = vec![
        "NRRD0004".to_string(),
        "type: unsigned char".into(),
        "space: right-anterior-superior".into(),
        "encoding: gzip".into(),
        "Segment0_ID:=Segment_1".into(),
        "Segment0_LabelValue:=1".into(),
        "Segment0_Layer:=0".into(),
        "Segment1_ID:=Segment_2".into(),
        "Segment1_LabelValue:=1".into(),
        format!("Segment1_Layer:={}", layers - 1),
    ];
    let data: Vec<u8> = if layers == 1 {
        lines.extend([
            "dimension: 3".into(),
            "sizes: 2 2 1".into(),
            "space directions: (1,0,0) (0,1,0) (0,0,1)".into(),
            "kinds: domain domain domain".into(),
        ]);
        vec![0, 1, 1, 0]
    } else {
        lines.extend([
            "dimension: 4".into(),
            format!("sizes: {layers} 2 2 1"),
            "space directions: none (1,0,0) (0,1,0) (0,0,1)".into(),
            "kinds: list domain domain domain".into(),
        ]);
        (0..4 * layers).map(|i| (i % 2) as u8).collect()
    };
    let refs: Vec<&str> = lines.iter().map(String::as_str).collect();
    file(&refs, &gz(&data))
}

#[test]
fn slicer_segmentations_one_layer_read_several_refused() {
    let img = read(&slicer_seg(1), None).unwrap();
    assert_eq!(img.volume.data(), &[0.0, 1.0, 1.0, 0.0]);
    assert_eq!(img.datatype, Datatype::Uint8);
    let e = read(&slicer_seg(2), None).unwrap_err();
    assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
    let e = e.to_string();
    assert!(e.contains("2 layers") && e.contains("label map"), "{e}");
}

#[test]
fn detached_header_and_missing_data_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("img.raw.gz"), gz(&[5, 6])).unwrap();
    let nhdr = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: gzip\n\
                 data file: img.raw.gz\n";
    let img = read(nhdr, Some(dir.path())).unwrap();
    assert_eq!(img.volume.data(), &[5.0, 6.0]);
    // No directory given: refused.
    assert!(matches!(read(nhdr, None), Err(IoError::Unsupported { .. })));
    // The data file does not exist: an error on its line.
    let missing = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n\
                    datafile: nowhere.raw\n";
    let e = read(missing, Some(dir.path())).unwrap_err();
    assert!(
        matches!(
            e,
            IoError::Malformed {
                location: Location::Line(6),
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("nowhere.raw"), "{e}");
    // A truncated data file is named in the error.
    std::fs::write(dir.path().join("short.raw"), [1u8]).unwrap();
    let short = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n\
                  data file: short.raw\n";
    let e = read(short, Some(dir.path())).unwrap_err().to_string();
    assert!(e.contains("short.raw") && e.contains("truncated"), "{e}");
}

#[test]
fn attached_data_missing_or_truncated() {
    let e = err(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n");
    assert!(e.contains("no empty line"), "{e}");
    let lines = [
        "NRRD0004",
        "type: float",
        "dimension: 3",
        "sizes: 2 2 2",
        "endian: little",
        "encoding: raw",
    ];
    let e = err(&file(&lines, &[0u8; 31]));
    assert!(e.contains("truncated"), "{e}");
    // A singular affine fails before the data is decoded.
    let e = err(&file(
        &[
            "NRRD0004",
            "type: uint8",
            "dimension: 3",
            "sizes: 1 1 1",
            "space: RAS",
            "space directions: (1,0,0) (1,0,0) (0,0,1)",
            "encoding: raw",
        ],
        &[],
    ));
    assert!(e.contains("singular"), "{e}");
}

#[test]
fn written_header_is_slicer_style() {
    let mut a = Matrix4::identity();
    a[(0, 0)] = 0.8;
    a[(1, 1)] = 0.8;
    a[(2, 2)] = 1.5;
    a[(0, 3)] = -10.0;
    a[(1, 3)] = -20.0;
    a[(2, 3)] = -30.0;
    let vol = Volume::new([2, 3, 4, 2], a, vec![1.0; 48]).unwrap();
    let mut img = NiftiImage::new(vol).with_datatype(Datatype::Int16);
    img.description = "a\nb".into();
    let bytes = write(&img).unwrap();
    let end = bytes.windows(2).position(|w| w == b"\n\n").unwrap();
    let text = std::str::from_utf8(&bytes[..end]).unwrap();
    for line in [
        "NRRD0004",
        "type: int16",
        "dimension: 4",
        "space: left-posterior-superior",
        "sizes: 2 2 3 4",
        "space directions: none (-0.8,0.0,0.0) (0.0,-0.8,0.0) (0.0,0.0,1.5)",
        "kinds: list domain domain domain",
        "endian: little",
        "encoding: gzip",
        "space origin: (10.0,20.0,-30.0)",
        "content: a b",
    ] {
        assert!(text.lines().any(|l| l == line), "{line:?} not in\n{text}");
    }
    assert_eq!(&bytes[end + 2..end + 4], &[0x1f, 0x8b]);
}

/// Rotation × positive scaling, optionally a reflection, plus a translation.
fn rigid_affine() -> impl Strategy<Value = Matrix4<f64>> {
    (
        prop::array::uniform3(-4.0..4.0f64),
        prop::array::uniform3(0.1..5.0f64),
        any::<bool>(),
        prop::array::uniform3(-200.0..200.0f64),
    )
        .prop_map(|(axis, s, reflect, t)| {
            let r = Rotation3::from_scaled_axis(Vector3::from(axis));
            let mut m = Matrix4::identity();
            let sign = if reflect { -1.0 } else { 1.0 };
            let s = [s[0], s[1], sign * s[2]];
            for i in 0..3 {
                for j in 0..3 {
                    m[(i, j)] = r[(i, j)] * s[j];
                }
                m[(i, 3)] = t[i];
            }
            m
        })
}

/// A general (sheared) invertible affine.
fn general_affine() -> impl Strategy<Value = Matrix4<f64>> {
    (
        prop::array::uniform9(-5.0..5.0f64),
        prop::array::uniform3(-200.0..200.0f64),
    )
        .prop_filter_map("near-singular", |(m, t)| {
            let mut a = Matrix4::identity();
            for i in 0..3 {
                for j in 0..3 {
                    a[(i, j)] = m[3 * i + j];
                }
                a[(i, 3)] = t[i];
            }
            (a.fixed_view::<3, 3>(0, 0).determinant().abs() > 0.5).then_some(a)
        })
}

/// Values every data type stores exactly (integers in its range, and for
/// floats any finite f32).
fn value_for(dt: Datatype, x: u64) -> f32 {
    let i = (x % 2000) as f32 - 1000.0;
    match dt {
        Datatype::Uint8 => (x % 256) as f32,
        Datatype::Int8 => (x % 256) as f32 - 128.0,
        Datatype::Uint16 | Datatype::Uint32 | Datatype::Uint64 => (x % 60000) as f32,
        Datatype::Int16 | Datatype::Int32 | Datatype::Int64 => i,
        Datatype::Float32 | Datatype::Float64 => f32::from_bits(x as u32 & 0xff7f_ffff),
    }
}

fn image(affine: impl Strategy<Value = Matrix4<f64>>) -> impl Strategy<Value = NiftiImage> {
    (
        (1..5usize, 1..5usize, 1..5usize, 1..4usize),
        affine,
        prop::sample::select(Datatype::ALL.to_vec()),
    )
        .prop_flat_map(|((a, b, c, d), m, dt)| {
            let n = a * b * c * d;
            prop::collection::vec(any::<u64>(), n).prop_map(move |raw| {
                let data = raw.iter().map(|&x| value_for(dt, x)).collect();
                NiftiImage::new(Volume::new([a, b, c, d], m, data).unwrap()).with_datatype(dt)
            })
        })
}

fn bits(d: &[f32]) -> Vec<u32> {
    d.iter().map(|x| x.to_bits()).collect()
}

/// Writes `img`'s affine as a RAS header by hand (columns as they are), the
/// data raw little-endian in file order.
fn ras_file(img: &NiftiImage) -> Vec<u8> {
    let a = img.volume.affine();
    let [nx, ny, nz, nt] = img.volume.dims();
    let col = |c: usize| format!("({:?},{:?},{:?})", a[(0, c)], a[(1, c)], a[(2, c)]);
    let (dim, sizes, none) = if nt > 1 {
        (4, format!("{nx} {ny} {nz} {nt}"), " none")
    } else {
        (3, format!("{nx} {ny} {nz}"), "")
    };
    let lines = [
        "NRRD0005".to_string(),
        format!("type: {}", header::type_name(img.write_datatype)),
        format!("dimension: {dim}"),
        format!("sizes: {sizes}"),
        "space: right-anterior-superior".into(),
        format!("space directions: {} {} {}{none}", col(0), col(1), col(2)),
        format!("space origin: {}", col(3)),
        "endian: little".into(),
        "encoding: raw".into(),
    ];
    let mut raw = Vec::new();
    crate::nifti::encode(img.volume.data(), img.write_datatype, &mut raw);
    let refs: Vec<&str> = lines.iter().map(String::as_str).collect();
    file(&refs, &raw)
}

proptest! {
    #[test]
    fn write_read_round_trip_is_exact(img in image(general_affine())) {
        let back = read(&write(&img).unwrap(), None).unwrap();
        prop_assert_eq!(back.volume.dims(), img.volume.dims());
        prop_assert_eq!(back.volume.affine(), img.volume.affine());
        prop_assert_eq!(bits(back.volume.data()), bits(img.volume.data()));
        prop_assert_eq!(back.datatype, img.write_datatype);
    }

    #[test]
    fn ras_header_read_is_exact(img in image(rigid_affine())) {
        let back = read(&ras_file(&img), None).unwrap();
        prop_assert_eq!(back.volume.affine(), img.volume.affine());
        prop_assert_eq!(bits(back.volume.data()), bits(img.volume.data()));
        prop_assert_eq!(back.datatype, img.write_datatype);
    }

    #[test]
    fn nifti_to_nrrd_to_nifti_is_exact(img in image(rigid_affine()), gzip in any::<bool>()) {
        let nifti = crate::nifti::read(&crate::nifti::write(&img, gzip).unwrap()).unwrap();
        let dt = nifti.datatype;
        let nrrd = read(&write(&nifti.clone().with_datatype(dt)).unwrap(), None).unwrap();
        prop_assert_eq!(nrrd.datatype, dt);
        let again = crate::nifti::read(
            &crate::nifti::write(&nrrd.clone().with_datatype(dt), gzip).unwrap(),
        )
        .unwrap();
        prop_assert_eq!(again.datatype, dt);
        prop_assert_eq!(again.volume.affine(), nifti.volume.affine());
        prop_assert_eq!(bits(again.volume.data()), bits(nifti.volume.data()));
    }

    #[test]
    fn random_bytes_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..600),
        magic in any::<bool>(),
    ) {
        let mut b = if magic { b"NRRD0004\n".to_vec() } else { Vec::new() };
        b.extend_from_slice(&bytes);
        let _ = read(&b, None);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn every_truncation_is_an_error(img in image(rigid_affine())) {
        let bytes = write(&img).unwrap();
        for n in 0..bytes.len() {
            prop_assert!(read(&bytes[..n], None).is_err(), "prefix of {} bytes read", n);
        }
    }

    #[test]
    fn header_line_corruptions_never_panic(
        img in image(general_affine()),
        line in 0..14usize,
        junk in "[ -~]{0,40}",
    ) {
        let bytes = write(&img).unwrap();
        let end = bytes.windows(2).position(|w| w == b"\n\n").unwrap();
        let text = std::str::from_utf8(&bytes[..end]).unwrap();
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let i = line % lines.len();
        let name = lines[i].split(':').next().unwrap_or("").to_string();
        lines[i] = format!("{name}: {junk}");
        let mut b = lines.join("\n").into_bytes();
        b.extend_from_slice(&bytes[end..]);
        let _ = read(&b, None);
    }
}
