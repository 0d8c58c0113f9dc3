//! Compression bombs: files whose compressed blocks announce far more than
//! the arrays they belong to can hold.

use crate::harness::{Case, args, run, s};

/// A VTK XML file of 27 points whose appended zlib header announces 16
/// blocks of 256 MiB (4 GiB) for an array of 324 bytes; 4.3 MB on disk.
fn vtu_bomb(path: &std::path::Path) {
    let (blocks, block_size, compressed) = (16u64, 256u64 << 20, 270_000u64);
    let mut bytes = br#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="27" NumberOfCells="0">
<Points><DataArray type="Float32" NumberOfComponents="3" format="appended" offset="0"/></Points>
</Piece></UnstructuredGrid>
<AppendedData encoding="raw">
 _"#
    .to_vec();
    for w in [blocks, block_size, 0]
        .into_iter()
        .chain(std::iter::repeat_n(compressed, blocks as usize))
    {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    // a zlib stream of zeros, repeated: what a real bomb holds
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut z, &vec![0u8; 1 << 20]).unwrap();
    let chunk = z.finish().unwrap();
    let mut data = Vec::with_capacity((blocks * compressed) as usize);
    while data.len() < (blocks * compressed) as usize {
        data.extend_from_slice(&chunk);
    }
    data.truncate((blocks * compressed) as usize);
    bytes.extend_from_slice(&data);
    bytes.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn a_vtu_announcing_gigabytes_is_refused_before_inflating() {
    let dir = tempfile::tempdir().unwrap();
    let bomb = dir.path().join("bomb.vtu");
    vtu_bomb(&bomb);
    for (name, a, out) in [
        ("vtu bomb: info", args(&["info", &s(&bomb)]), None),
        (
            "vtu bomb: convert",
            args(&["convert", &s(&bomb), &s(&dir.path().join("b.vtk"))]),
            Some(dir.path().join("b.vtk")),
        ),
        (
            "vtu bomb: placenta",
            args(&["placenta", &s(&bomb), "-o", &s(&dir.path().join("p"))]),
            Some(dir.path().join("p")),
        ),
    ] {
        run(&Case {
            name,
            args: a,
            expect: "more than the 324 bytes",
            max_peak_mib: 100.0,
            inputs: vec![bomb.clone()],
            output: out,
        });
    }
}

/// A VTK XML file of 178,956,970 points (2 GiB of Float32 coordinates, as
/// its array may hold) in 2048 zlib blocks of 1 MiB of zeros: 2 MB on disk.
fn vtu_honest_bomb(path: &std::path::Path) {
    let points: u64 = (2u64 << 30) / 12;
    let total = points * 12;
    let block = 1u64 << 20;
    let blocks = total.div_ceil(block);
    let last = total - (blocks - 1) * block;
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut z, &vec![0u8; block as usize]).unwrap();
    let full = z.finish().unwrap();
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut z, &vec![0u8; last as usize]).unwrap();
    let tail = z.finish().unwrap();
    let mut bytes = format!(
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="{points}" NumberOfCells="0">
<Points><DataArray type="Float32" NumberOfComponents="3" format="appended" offset="0"/></Points>
</Piece></UnstructuredGrid>
<AppendedData encoding="raw">
 _"#
    )
    .into_bytes();
    let mut header = vec![blocks, block, last];
    header.extend(std::iter::repeat_n(
        full.len() as u64,
        (blocks - 1) as usize,
    ));
    header.push(tail.len() as u64);
    for w in header {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    for _ in 0..blocks - 1 {
        bytes.extend_from_slice(&full);
    }
    bytes.extend_from_slice(&tail);
    bytes.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn a_vtu_holding_gigabytes_honestly_is_capped_by_the_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    let bomb = dir.path().join("honest.vtu");
    vtu_honest_bomb(&bomb);
    assert!(std::fs::metadata(&bomb).unwrap().len() < 8 << 20);
    run(&Case {
        name: "vtu holding 2 GiB: info --max-memory 512M",
        args: args(&["info", &s(&bomb), "--max-memory", "512M"]),
        expect: "would pass the",
        max_peak_mib: 100.0,
        inputs: vec![bomb.clone()],
        output: None,
    });
}

#[path = "../common/gzip_zeros.rs"]
mod gzip_zeros;

#[test]
fn a_gigabyte_of_gzipped_zeros_is_read_only_if_it_fits() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("zeros.nii.gz");
    gzip_zeros::gzip_of_header_and_zeros(&img, &gzip_zeros::nifti_header([1024, 1024, 1024]), 1024);
    let out = dir.path().join("m.vtu");
    run(&Case {
        name: "1 MB .nii.gz of 1024^3 zeros: mesh --max-memory 2G",
        args: args(&["mesh", &s(&img), "-o", &s(&out), "--max-memory", "2G"]),
        expect: "reading the image would need about 5.0 GiB",
        max_peak_mib: 100.0,
        inputs: vec![img.clone()],
        output: Some(out),
    });
    let out = dir.path().join("z.nrrd");
    run(&Case {
        name: "1 MB .nii.gz of 1024^3 zeros: convert --max-memory 2G",
        args: args(&["convert", &s(&img), &s(&out), "--max-memory", "2G"]),
        expect: "reading the image would need about",
        max_peak_mib: 100.0,
        inputs: vec![img.clone()],
        output: Some(out),
    });
}

/// A VTK XML file of 27 Float64 points whose one zlib block declares the
/// 648 bytes they take but holds a stream of 4 MiB of zeros (4 kB on disk):
/// inflation stops one byte past the declared size.
fn vtu_overrunning_block(path: &std::path::Path) {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut z, &vec![0u8; 4 << 20]).unwrap();
    let stream = z.finish().unwrap();
    let mut bytes = br#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="27" NumberOfCells="0">
<Points><DataArray type="Float64" NumberOfComponents="3" format="appended" offset="0"/></Points>
</Piece></UnstructuredGrid>
<AppendedData encoding="raw">
 _"#
    .to_vec();
    for w in [1u64, 648, 648, stream.len() as u64] {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    bytes.extend_from_slice(&stream);
    bytes.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn a_vtu_block_inflating_past_its_declared_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bomb = dir.path().join("overrun.vtu");
    vtu_overrunning_block(&bomb);
    run(&Case {
        name: "vtu block overrunning 648 bytes: info",
        args: args(&["info", &s(&bomb)]),
        expect: "compressed bytes) inflates to more than the 648 bytes its header declares",
        max_peak_mib: 100.0,
        inputs: vec![bomb.clone()],
        output: None,
    });
}
