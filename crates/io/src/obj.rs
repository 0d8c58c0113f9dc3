//! Wavefront `.obj` (geometry only). Written here rather than with `tobj`,
//! whose errors carry no line numbers and which has no polylines.
//!
//! Reading, one statement per line:
//! - `v x y z [w | r g b]`: a vertex (anything after `z` is ignored);
//! - `f v1 v2 v3 ...`: a face of 3 or more vertices, each written `v`,
//!   `v/vt`, `v//vn` or `v/vt/vn`; 3 vertices make a triangle, 4 a quad, more
//!   a polygon;
//! - `l v1 v2 ...`: a line (2 vertices) or polyline (more), each `v` or
//!   `v/vt`;
//! - `p v1 ...`: a point (1 vertex: vertex cell) or point set (poly-vertex);
//! - indices are 1-based; negative indices count back from the last vertex
//!   defined so far (`-1` is the latest);
//! - ignored: comments (`#`), `vt`, `vn`, `vp`, `o`, `g`, `s`, `usemtl`,
//!   `mtllib` and the free-form geometry statements (`cstype`, `curv`,
//!   `surf`, ...); any other statement is an error.
//! - Errors give the 1-based line number.
//!
//! Writing: `v` lines (shortest round-trip decimal, so exact), then the cells
//! in order: surface cells as `f`, lines and polylines as `l`, vertex and
//! poly-vertex cells as `p`. Volume cells are unsupported. OBJ holds no data
//! arrays: point and cell data are not written.

use crate::off::show;
use crate::{IoError, Location, WriteOptions};
use nalgebra::Point3;
use std::fmt::Write as _;
use unfold_mesh::{CellMesh, CellType};

/// Statements that are read and ignored.
const IGNORED: &[&str] = &[
    "vt",
    "vn",
    "vp",
    "o",
    "g",
    "s",
    "usemtl",
    "mtllib",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "mg",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "maplib",
    "usemap",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "call",
    "csh",
];

/// Parses an OBJ file's bytes (see the module documentation).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let mut mesh = CellMesh::default();
    // The largest positive index met and its line: checked at the end, as
    // some files use vertices before defining them.
    let mut max_index: Option<(u64, usize)> = None;
    let mut cell = Vec::new();
    for (n, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = n + 1;
        let err = |msg: String| IoError::malformed(Location::Line(line_no), msg);
        // Drop a comment, then surrounding blanks.
        let raw = match raw.iter().position(|&b| b == b'#') {
            Some(i) => raw.get(..i).unwrap_or_default(),
            None => raw,
        };
        let Ok(text) = std::str::from_utf8(raw) else {
            return Err(err("the line is not text (UTF-8)".into()));
        };
        let mut words = text.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "v" => {
                let mut c = [0.0f64; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let Some(w) = words.next() else {
                        return Err(err(format!("a vertex needs 3 coordinates, found {k}")));
                    };
                    *slot = w
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| {
                            err(format!(
                                "expected a finite vertex coordinate, found '{}'",
                                show(w.as_bytes())
                            ))
                        })?;
                }
                mesh.positions.push(Point3::new(c[0], c[1], c[2]));
            }
            "f" | "l" | "p" => {
                cell.clear();
                for w in words {
                    let v = w.split('/').next().unwrap_or("");
                    let Ok(i) = v.parse::<i64>() else {
                        return Err(err(format!(
                            "expected a vertex index (v, v/vt, v//vn or v/vt/vn), found '{}'",
                            show(w.as_bytes())
                        )));
                    };
                    let count = mesh.positions.len() as i64;
                    let index = match i {
                        0 => return Err(err("vertex index 0 (OBJ indices start at 1)".into())),
                        i if i > 0 => {
                            let i = (i - 1) as u64;
                            if max_index.is_none_or(|(m, _)| i > m) {
                                max_index = Some((i, line_no));
                            }
                            i
                        }
                        i => {
                            let j = count + i;
                            if j < 0 {
                                return Err(err(format!(
                                    "relative vertex index {i} goes before the first vertex ({count} defined so far)"
                                )));
                            }
                            j as u64
                        }
                    };
                    if index > u64::from(u32::MAX) {
                        return Err(err(format!("vertex index {i} is too large")));
                    }
                    cell.push(index as u32);
                }
                let (t, min) = match (keyword, cell.len()) {
                    ("f", n) => (crate::off::polygon_type(n), 3),
                    ("l", 2) => (CellType::Line, 2),
                    ("l", _) => (CellType::PolyLine, 2),
                    (_, 1) => (CellType::Vertex, 1),
                    _ => (CellType::PolyVertex, 1),
                };
                if cell.len() < min {
                    return Err(err(format!(
                        "'{keyword}' needs at least {min} vertices, found {}",
                        cell.len()
                    )));
                }
                mesh.push_cell(t, &cell);
            }
            k if IGNORED.contains(&k) => {}
            k => {
                return Err(err(format!(
                    "unknown OBJ statement '{}'; expected v, f, l, p or one of the ignored ones (vt, vn, o, g, s, usemtl, mtllib, ...)",
                    show(k.as_bytes())
                )));
            }
        }
    }
    if let Some((i, line)) = max_index
        && i >= mesh.positions.len() as u64
    {
        return Err(IoError::malformed(
            Location::Line(line),
            format!(
                "vertex index {} is out of range: the file has {} vertices",
                i + 1,
                mesh.positions.len()
            ),
        ));
    }
    Ok(mesh)
}

/// Serializes a mesh as OBJ (see the module documentation).
pub fn write(mesh: &CellMesh, _opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    if let Some((i, t)) = mesh
        .cell_types
        .iter()
        .enumerate()
        .find(|(_, t)| t.dimension() == 3)
    {
        return Err(IoError::unsupported(format!(
            "OBJ stores points, lines and polygons only; cell {i} is a {t:?}"
        )));
    }
    let mut s = String::with_capacity(mesh.num_points() * 40 + mesh.connectivity.len() * 8 + 32);
    s.push_str("# written by unfold\n");
    for p in &mesh.positions {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for (t, vs) in mesh.cells() {
        s.push_str(match t.dimension() {
            0 => "p",
            1 => "l",
            _ => "f",
        });
        for v in vs {
            let _ = write!(s, " {}", u64::from(*v) + 1);
        }
        s.push('\n');
    }
    Ok(s.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::off::test_support::*;
    use proptest::prelude::*;

    const SAMPLE: &str = "# a quad, a triangle and a polyline
mtllib x.mtl
o thing
v 0 0 0
v 1 0 0 1.0
v 1 1 0 0.5 0.5 0.5
v 0 1 0
vt 0 0
vn 0 0 1
g group
usemtl red
s off
f 1/1/1 2/1/1 3/1/1 4/1/1
f -4//1 -3//1 -1//1
l 1 2 3
l 4/1 1/1
p 2
f 1 2 3 4 -1   # a pentagon with a repeated vertex
";

    #[test]
    fn obj_reads_faces_lines_and_negative_indices() {
        let m = read(SAMPLE.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 4);
        assert_eq!(
            m.cell_types,
            vec![
                CellType::Quad,
                CellType::Triangle,
                CellType::PolyLine,
                CellType::Line,
                CellType::Vertex,
                CellType::Polygon
            ]
        );
        assert_eq!(m.cell(0).1, &[0, 1, 2, 3]);
        assert_eq!(m.cell(1).1, &[0, 1, 3]);
        assert_eq!(m.cell(3).1, &[3, 0]);
        assert_eq!(m.cell(5).1, &[0, 1, 2, 3, 3]);
        assert_eq!(m.positions[2], Point3::new(1.0, 1.0, 0.0));
        m.check().unwrap();
    }

    #[test]
    fn obj_errors_give_lines() {
        let cases = [
            ("v 0 0 0\nv 1 0\n", "line 2: a vertex needs 3 coordinates"),
            (
                "v 0 0 0\nf 1 2 3\n",
                "line 2: vertex index 3 is out of range",
            ),
            ("v 0 0 0\n\nf 1 -2 1\n", "line 3: relative vertex index -2"),
            ("v 0 0 0\nf 0 1 1\n", "line 2: vertex index 0"),
            ("v 0 0 0\nf 1 1\n", "needs at least 3"),
            ("v 0 0 0\nl 1\n", "needs at least 2"),
            ("v 0 0 0\nf a b c\n", "expected a vertex index"),
            ("v 0 0 0\nfoo 1\n", "line 2: unknown OBJ statement 'foo'"),
            ("v 0 0 inf\n", "finite"),
        ];
        for (text, want) in cases {
            let e = read(text.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        let e = read(b"v 0 0 0\n\xff\n").unwrap_err().to_string();
        assert!(e.contains("line 2: the line is not text"), "{e}");
    }

    #[test]
    fn obj_write_rejects_volume_cells() {
        let mut m = CellMesh::from_points(vec![Point3::origin(); 4]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
    }

    #[test]
    fn obj_truncations_never_panic() {
        check_truncations(SAMPLE.as_bytes(), read);
    }

    fn obj_cells() -> impl Strategy<Value = Vec<(CellType, Vec<u32>)>> {
        cells(
            vec![
                (CellType::Triangle, 3..=3),
                (CellType::Quad, 4..=4),
                (CellType::Polygon, 5..=8),
                (CellType::Line, 2..=2),
                (CellType::PolyLine, 3..=6),
                (CellType::Vertex, 1..=1),
                (CellType::PolyVertex, 2..=4),
            ],
            0..20,
        )
    }

    proptest! {
        #[test]
        fn obj_round_trip(pts in points(coord(), 0..20), cs in obj_cells()) {
            let m = mesh_with(pts, &cs);
            let back = read(&write(&m, &WriteOptions::default()).unwrap()).unwrap();
            prop_assert_eq!(back, m);
        }

        /// Garbage is an error, or (comments / blank lines only) an empty mesh.
        #[test]
        fn obj_random_bytes_are_errors(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
            if let Ok(m) = read(&bytes) {
                prop_assert_eq!(m, CellMesh::default());
            }
        }

        #[test]
        fn obj_random_statements_never_panic(s in "((v|f|l|p|vt) [-0-9/ .e]{0,12}\n){0,12}") {
            if let Ok(m) = read(s.as_bytes()) {
                prop_assert!(m.check().is_ok());
            }
        }

        #[test]
        fn obj_corruptions_never_panic(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8)) {
            let mut bytes = SAMPLE.as_bytes().to_vec();
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
