//! STL `.stl`, ASCII and binary: triangles only, positions in single
//! precision. Written here rather than with `stl_io`, whose errors carry no
//! byte offset or line number.
//!
//! Reading:
//! - Binary or ASCII is decided by size: a file of exactly `84 + 50 n` bytes,
//!   where `n` is the triangle count at byte 80, is binary even when its
//!   80-byte header starts with `solid` (many exporters do that). Otherwise a
//!   file starting with `solid` is ASCII; anything else is an error.
//! - ASCII: `solid [name]`, then `facet normal nx ny nz` / `outer loop` /
//!   three `vertex x y z` / `endloop` / `endfacet`, and `endsolid [name]`;
//!   several solids in one file are read one after the other; keywords are
//!   case-insensitive.
//! - Normals, solid names and the binary attribute bytes are ignored.
//! - Coordinates are stored as f32 in binary files, and ASCII coordinates are
//!   rounded to f32 as well, so both encodings give the same mesh.
//! - Corners with identical coordinates (exact match, `-0.0` equal to `0.0`)
//!   are merged, so the result is an indexed triangle mesh; points are
//!   numbered in order of first appearance.
//! - Errors give the byte offset (binary) or the 1-based line (ASCII).
//!
//! Writing (binary unless [`WriteOptions::ascii`]): triangles only; any
//! other cell is unsupported. Positions are rounded to f32 (a coordinate
//! beyond the f32 range is unsupported); normals are computed from the
//! rounded corners. Points used by no triangle and all data arrays are lost.
//! The binary header never starts with `solid`.

use crate::off::{Tokens, show};
use crate::{IoError, Location, WriteOptions};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;
use std::fmt::Write as _;
use unfold_mesh::{CellMesh, CellType};

/// Builds an indexed mesh from triangle corners, merging equal points.
struct Merger {
    mesh: CellMesh,
    index: HashMap<[u32; 3], u32>,
}

impl Merger {
    fn new(triangles: usize) -> Merger {
        let mut mesh = CellMesh::default();
        mesh.positions.reserve(triangles / 2 + 3);
        mesh.cell_types.reserve(triangles);
        mesh.offsets.reserve(triangles);
        mesh.connectivity.reserve(triangles * 3);
        Merger {
            mesh,
            index: HashMap::with_capacity(triangles / 2 + 3),
        }
    }

    fn corner(&mut self, p: [f32; 3]) -> u32 {
        // +0.0 for -0.0 so that equal coordinates share a key.
        let key = p.map(|c| (c + 0.0).to_bits());
        let next = self.mesh.positions.len() as u32;
        *self.index.entry(key).or_insert_with(|| {
            self.mesh
                .positions
                .push(Point3::new(p[0].into(), p[1].into(), p[2].into()));
            next
        })
    }

    fn triangle(&mut self, corners: [[f32; 3]; 3]) {
        let t = corners.map(|c| self.corner(c));
        self.mesh.push_cell(CellType::Triangle, &t);
    }
}

fn read_binary(bytes: &[u8], n: usize) -> Result<CellMesh, IoError> {
    let mut m = Merger::new(n);
    for (i, rec) in bytes
        .get(84..)
        .unwrap_or_default()
        .chunks_exact(50)
        .enumerate()
    {
        let mut corners = [[0f32; 3]; 3];
        for (k, corner) in corners.iter_mut().enumerate() {
            for (c, slot) in corner.iter_mut().enumerate() {
                let at = 12 + 12 * k + 4 * c;
                let raw: [u8; 4] = rec
                    .get(at..at + 4)
                    .and_then(|s| s.try_into().ok())
                    .unwrap_or_default();
                *slot = f32::from_le_bytes(raw);
                if !slot.is_finite() {
                    return Err(IoError::malformed(
                        Location::Byte((84 + 50 * i + at) as u64),
                        format!("triangle {i} has a non-finite coordinate ({slot})"),
                    ));
                }
            }
        }
        m.triangle(corners);
    }
    Ok(m.mesh)
}

fn read_ascii(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let mut t = Tokens::new(bytes, None);
    let mut m = Merger::new(bytes.len() / 256);
    t.expect_keyword("solid")?;
    t.skip_line(); // the solid's name
    let mut facet = 0usize;
    loop {
        let Some(tok) = t.next() else {
            return Err(t.error("unexpected end of file; expected 'facet' or 'endsolid'"));
        };
        if tok.eq_ignore_ascii_case(b"endsolid") {
            t.skip_line();
            // Another solid may follow.
            match t.next() {
                None => return Ok(m.mesh),
                Some(s) if s.eq_ignore_ascii_case(b"solid") => {
                    t.skip_line();
                    continue;
                }
                Some(s) => {
                    return Err(t.error(format!(
                        "expected 'solid' or the end of the file after 'endsolid', found '{}'",
                        show(s)
                    )));
                }
            }
        }
        if !tok.eq_ignore_ascii_case(b"facet") {
            return Err(t.error(format!(
                "expected 'facet' or 'endsolid', found '{}'",
                show(tok)
            )));
        }
        t.expect_keyword("normal")?;
        for _ in 0..3 {
            t.expect_f64("a normal component")?;
        }
        t.expect_keyword("outer")?;
        t.expect_keyword("loop")?;
        let mut corners = [[0f32; 3]; 3];
        for corner in &mut corners {
            t.expect_keyword("vertex").map_err(|_| {
                t.error(format!(
                    "facet {facet}: expected 'vertex' (STL facets are triangles)"
                ))
            })?;
            for c in corner.iter_mut() {
                let v: f32 = t.expect_by(|| format!("a coordinate of facet {facet}"))?;
                if !v.is_finite() {
                    return Err(t.error(format!(
                        "facet {facet} has a non-finite coordinate ({v}) (or one beyond the f32 range)"
                    )));
                }
                *c = v;
            }
        }
        match t.next() {
            Some(tok) if tok.eq_ignore_ascii_case(b"endloop") => {}
            Some(tok) => {
                return Err(t.error(format!(
                    "facet {facet}: expected 'endloop' after 3 vertices, found '{}' (STL facets are triangles)",
                    show(tok)
                )));
            }
            None => return Err(t.error("unexpected end of file; expected 'endloop'")),
        }
        t.expect_keyword("endfacet")?;
        m.triangle(corners);
        facet += 1;
    }
}

/// Parses an STL file's bytes (see the module documentation).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let count = bytes
        .get(80..84)
        .and_then(|s| s.try_into().ok())
        .map(u32::from_le_bytes);
    if let Some(n) = count {
        let n = n as usize;
        if n.checked_mul(50).and_then(|b| b.checked_add(84)) == Some(bytes.len()) {
            return read_binary(bytes, n);
        }
    }
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    let is_solid = bytes
        .get(start..start + 5)
        .is_some_and(|s| s.eq_ignore_ascii_case(b"solid"));
    if is_solid {
        return read_ascii(bytes);
    }
    match count {
        Some(n) => Err(IoError::malformed(
            Location::Byte(80),
            format!(
                "not an STL file: a binary STL with {n} triangles has {} bytes, this one has {} (and it does not start with 'solid')",
                84 + 50 * u64::from(n),
                bytes.len()
            ),
        )),
        None => Err(IoError::malformed(
            Location::Byte(0),
            format!(
                "not an STL file: {} bytes, too short for a binary STL (84 bytes at least) and no 'solid' keyword",
                bytes.len()
            ),
        )),
    }
}

/// Serializes the triangles of a mesh as STL (see the module documentation).
pub fn write(mesh: &CellMesh, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    if let Some((i, t)) = mesh
        .cell_types
        .iter()
        .enumerate()
        .find(|(_, t)| **t != CellType::Triangle)
    {
        return Err(IoError::unsupported(format!(
            "STL stores triangles only; cell {i} is a {t:?} (triangulate surfaces first)"
        )));
    }
    let n = mesh.num_cells();
    let Ok(n32) = u32::try_from(n) else {
        return Err(IoError::unsupported(format!(
            "binary STL holds at most 2^32 - 1 triangles, this mesh has {n}"
        )));
    };
    let mut corners = Vec::with_capacity(n);
    for (i, (_, vs)) in mesh.cells().enumerate() {
        let mut tri = [[0f32; 3]; 3];
        for (slot, &v) in tri.iter_mut().zip(vs) {
            let p = mesh.positions[v as usize];
            *slot = [p.x as f32, p.y as f32, p.z as f32];
            if !slot.iter().all(|c| c.is_finite()) {
                return Err(IoError::unsupported(format!(
                    "triangle {i}: point {v} ({}, {}, {}) is beyond the f32 range of STL",
                    p.x, p.y, p.z
                )));
            }
        }
        let [a, b, c] = tri.map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64));
        let normal = (b - a).cross(&(c - a));
        let len = normal.norm();
        let normal = if len > 0.0 && len.is_finite() {
            normal / len
        } else {
            Vector3::zeros()
        };
        corners.push(([normal.x as f32, normal.y as f32, normal.z as f32], tri));
    }
    if opts.ascii {
        let mut s = String::with_capacity(n * 250 + 40);
        s.push_str("solid unfold\n");
        for (nrm, tri) in &corners {
            let _ = writeln!(s, "  facet normal {:e} {:e} {:e}", nrm[0], nrm[1], nrm[2]);
            s.push_str("    outer loop\n");
            for p in tri {
                let _ = writeln!(s, "      vertex {:e} {:e} {:e}", p[0], p[1], p[2]);
            }
            s.push_str("    endloop\n  endfacet\n");
        }
        s.push_str("endsolid unfold\n");
        return Ok(s.into_bytes());
    }
    let mut b = Vec::with_capacity(84 + 50 * n);
    let mut header = [b' '; 80];
    let text = b"binary STL written by unfold";
    header[..text.len()].copy_from_slice(text);
    b.extend_from_slice(&header);
    b.extend_from_slice(&n32.to_le_bytes());
    for (nrm, tri) in &corners {
        for c in nrm.iter().chain(tri.iter().flatten()) {
            b.extend_from_slice(&c.to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::off::test_support::*;
    use proptest::prelude::*;

    const ASCII: &str = "solid two triangles
  facet normal 0 0 1
    outer loop
      vertex 0 0 0
      vertex 1 0 0
      vertex 1 1 0
    endloop
  endfacet
  FACET NORMAL 0 0 1
    OUTER LOOP
      VERTEX 0 0 -0
      VERTEX 1 1 0
      VERTEX 0 1 0.1
    ENDLOOP
  ENDFACET
endsolid two triangles
";

    #[test]
    fn stl_reads_ascii_and_merges_vertices() {
        let m = read(ASCII.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 4);
        assert_eq!(m.connectivity, vec![0, 1, 2, 0, 2, 3]);
        // Rounded to f32.
        assert_eq!(m.positions[3].z, f64::from(0.1f32));
        m.check().unwrap();
    }

    /// A binary file whose header starts with "solid", like many exporters'.
    fn binary_solid() -> Vec<u8> {
        let mut b = vec![b' '; 80];
        b[..22].copy_from_slice(b"solid exported by CAD ");
        b.extend_from_slice(&2u32.to_le_bytes());
        let tris = [
            [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
            [[-0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.5]],
        ];
        for tri in tris {
            b.extend_from_slice(&[0u8; 12]);
            for c in tri.iter().flatten() {
                b.extend_from_slice(&c.to_le_bytes());
            }
            b.extend_from_slice(&[7, 7]);
        }
        b
    }

    #[test]
    fn stl_binary_starting_with_solid() {
        let m = read(&binary_solid()).unwrap();
        assert_eq!(m.num_points(), 4);
        assert_eq!(m.connectivity, vec![0, 1, 2, 0, 2, 3]);
        assert_eq!(m.positions[3], Point3::new(0.0, 1.0, 0.5));
    }

    #[test]
    fn stl_errors_give_lines_and_offsets() {
        let mut nan = binary_solid();
        nan[84 + 50 + 12 + 12 + 4..84 + 50 + 12 + 12 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = read(&nan).unwrap_err().to_string();
        assert!(e.contains("byte 162: triangle 1 has a non-finite"), "{e}");
        let mut short = binary_solid();
        short[0] = b'x';
        short.pop();
        let e = read(&short).unwrap_err().to_string();
        assert!(e.contains("byte 80: not an STL file"), "{e}");
        let quad = ASCII.replacen(
            "      vertex 1 1 0\n    endloop",
            "      vertex 1 1 0\n      vertex 2 2 2\n    endloop",
            1,
        );
        let e = read(quad.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("line 7: facet 0: expected 'endloop'"), "{e}");
        let e = read(ASCII.replace("0.1", "zz").as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 13: expected a coordinate of facet 1, found 'zz'"),
            "{e}"
        );
        let e = read(b"solid x\n facet normal 0 0 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unexpected end of file"), "{e}");
        let e = read(b"hello").unwrap_err().to_string();
        assert!(e.contains("not an STL file"), "{e}");
    }

    #[test]
    fn stl_write_rules() {
        let mut m = CellMesh::from_points(vec![Point3::origin(); 4]);
        m.push_cell(CellType::Line, &[0, 1]);
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        let mut m = CellMesh::from_points(vec![
            Point3::origin(),
            Point3::new(1e300, 0.0, 0.0),
            Point3::origin(),
        ]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        let b = write(&CellMesh::default(), &WriteOptions::default()).unwrap();
        assert_eq!(b.len(), 84);
        assert!(!b.starts_with(b"solid"));
        assert_eq!(read(&b).unwrap(), CellMesh::default());
    }

    #[test]
    fn stl_truncations_never_panic() {
        check_truncations(ASCII.as_bytes(), read);
        check_truncations(&binary_solid(), read);
    }

    /// The triangles as corner coordinates.
    fn corners(m: &CellMesh) -> Vec<[Point3<f64>; 3]> {
        m.cells()
            .map(|(_, v)| {
                [
                    m.positions[v[0] as usize],
                    m.positions[v[1] as usize],
                    m.positions[v[2] as usize],
                ]
            })
            .collect()
    }

    proptest! {
        #[test]
        fn stl_round_trip(pts in points(coord_f32(), 1..20), cs in cells(vec![(CellType::Triangle, 3..=3)], 0..20), ascii: bool) {
            let m = mesh_with(pts, &cs);
            let opts = if ascii { WriteOptions::ascii() } else { WriteOptions::default() };
            let back = read(&write(&m, &opts).unwrap()).unwrap();
            back.check().unwrap();
            // Same triangles, coordinate for coordinate (-0.0 may become 0.0).
            prop_assert_eq!(corners(&back), corners(&m));
            // Merged: no two points are equal.
            let mut seen = std::collections::HashSet::new();
            for p in &back.positions {
                prop_assert!(seen.insert([p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f64::to_bits)));
            }
        }

        #[test]
        fn stl_random_bytes_are_errors(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn stl_random_after_solid_never_panics(tail in "[a-z0-9 .\n-]{0,300}") {
            let text = format!("solid x\n{tail}");
            if let Ok(m) = read(text.as_bytes()) {
                prop_assert!(m.check().is_ok());
            }
        }

        #[test]
        fn stl_corruptions_never_panic(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8), which: bool) {
            let mut bytes = if which { ASCII.as_bytes().to_vec() } else { binary_solid() };
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
