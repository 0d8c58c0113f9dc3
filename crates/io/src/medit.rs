//! Medit / INRIA `.mesh` (ASCII; the binary `.meshb` is not supported).
//!
//! Reading:
//! - `MeshVersionFormatted 1|2` (3 and 4 are accepted too: in ASCII they
//!   differ only in the integer width), `Dimension 3` or `Dimension 2` (z = 0);
//! - `Vertices` (`x y z ref`), and the cell sections `Edges`, `Triangles`,
//!   `Quadrilaterals`, `Tetrahedra`, `Pyramids`, `Prisms` (or `Pentahedra`,
//!   wedges) and `Hexahedra` (or `Hexaedra`), each entry its 1-based vertex
//!   indices and a ref; Medit numbers the corners of these cells as VTK does;
//! - the refs become the point-data field `medit:ref` and the cell-data field
//!   `medit:ref` (both I32, always present); cells keep the file's order;
//! - the sections `Corners`, `Ridges`, `Required*`, `Normals`, `Tangents`,
//!   `NormalAtVertices`, `NormalAtTriangleVertices`,
//!   `NormalAtQuadrilateralVertices`, `TangentAtVertices`, `TangentAtEdges`
//!   are skipped; higher-order sections (`TrianglesP2`, ...) are unsupported
//!   and any other section is an error (its entry size is unknown);
//! - keywords are case-insensitive, `#` starts a comment, `End` (optional)
//!   ends the file; Fortran exponents (`1.0D+00`) are accepted;
//! - errors give the 1-based line.
//!
//! Writing: `MeshVersionFormatted 2`, `Dimension 3`, `Vertices`, then one
//! section per cell type in the order Edges, Triangles, Quadrilaterals,
//! Tetrahedra, Pyramids, Prisms, Hexahedra (so cells are grouped by type:
//! a mesh whose cells are already in that order reads back unchanged), and
//! `End`. Refs come from the one-component point / cell fields `medit:ref`
//! when present (their values must be integers in the i32 range), else 0.
//! Point cells, polylines and polygons are unsupported; other data arrays
//! are not written.

use crate::off::{Tokens, cap, show};
use crate::{IoError, Location, WriteOptions};
use nalgebra::Point3;
use std::fmt::Write as _;
use unfold_mesh::{CellMesh, CellType, Field, FieldValues};

/// The name of the point- and cell-data fields holding Medit refs.
pub const REF_FIELD: &str = "medit:ref";

/// Cell sections: keyword (lowercase), cell type, vertices per entry.
const CELL_SECTIONS: &[(&str, CellType, usize)] = &[
    ("edges", CellType::Line, 2),
    ("triangles", CellType::Triangle, 3),
    ("quadrilaterals", CellType::Quad, 4),
    ("tetrahedra", CellType::Tetra, 4),
    ("pyramids", CellType::Pyramid, 5),
    ("prisms", CellType::Wedge, 6),
    ("pentahedra", CellType::Wedge, 6),
    ("hexahedra", CellType::Hexahedron, 8),
    ("hexaedra", CellType::Hexahedron, 8),
];

/// Written section names, in write order.
const WRITE_ORDER: &[(CellType, &str)] = &[
    (CellType::Line, "Edges"),
    (CellType::Triangle, "Triangles"),
    (CellType::Quad, "Quadrilaterals"),
    (CellType::Tetra, "Tetrahedra"),
    (CellType::Pyramid, "Pyramids"),
    (CellType::Wedge, "Prisms"),
    (CellType::Hexahedron, "Hexahedra"),
];

/// Skipped sections: keyword (lowercase), integers per entry (None: the
/// dimension's number of floats).
const SKIPPED: &[(&str, Option<usize>)] = &[
    ("corners", Some(1)),
    ("ridges", Some(1)),
    ("requiredvertices", Some(1)),
    ("requirededges", Some(1)),
    ("requiredtriangles", Some(1)),
    ("requiredquadrilaterals", Some(1)),
    ("requiredtetrahedra", Some(1)),
    ("requiredhexahedra", Some(1)),
    ("normals", None),
    ("tangents", None),
    ("normalatvertices", Some(2)),
    ("normalattrianglevertices", Some(3)),
    ("normalatquadrilateralvertices", Some(3)),
    ("tangentatvertices", Some(2)),
    ("tangentatedges", Some(3)),
];

fn read_ref(t: &mut Tokens, what: impl Fn() -> String) -> Result<i32, IoError> {
    let r: i64 = t.expect_by(&what)?;
    i32::try_from(r).map_err(|_| t.error(format!("{} {r} is out of the i32 range", what())))
}

/// Parses a Medit file's bytes (see the module documentation).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    if bytes.len() >= 4 && matches!(bytes.get(..4), Some([1, 0, 0, 0] | [0, 0, 0, 1])) {
        return Err(IoError::unsupported(
            "this is a binary Medit file (.meshb); only ASCII .mesh is supported",
        ));
    }
    let mut t = Tokens::new(bytes, Some(b'#'));
    let mut mesh = CellMesh::default();
    let mut point_refs: Vec<i32> = Vec::new();
    let mut cell_refs: Vec<i32> = Vec::new();
    let mut dim = 3usize;
    let mut seen_vertices = false;
    let mut max_index: Option<(u64, usize)> = None;
    let mut first = true;
    let mut cell = Vec::new();
    while let Some(tok) = t.next() {
        let keyword = String::from_utf8_lossy(tok).to_ascii_lowercase();
        if first && keyword != "meshversionformatted" {
            return Err(t.error(format!(
                "not a Medit file: expected 'MeshVersionFormatted', found '{}'",
                show(tok)
            )));
        }
        first = false;
        let line = t.location();
        match keyword.as_str() {
            "meshversionformatted" => {
                let v: i64 = t.expect("the version (1 or 2)")?;
                if !(1..=4).contains(&v) {
                    return Err(
                        t.error(format!("unknown MeshVersionFormatted {v}; expected 1 or 2"))
                    );
                }
            }
            "dimension" => {
                dim = t.expect("the dimension (2 or 3)")?;
                if dim != 2 && dim != 3 {
                    return Err(t.error(format!("Dimension {dim}: only 2 and 3 are supported")));
                }
            }
            "vertices" => {
                if seen_vertices {
                    return Err(t.error("a second Vertices section"));
                }
                seen_vertices = true;
                let n: usize = t.expect("the number of vertices")?;
                mesh.positions.reserve(cap(n, t.remaining(), 2 * (dim + 1)));
                point_refs.reserve(cap(n, t.remaining(), 2 * (dim + 1)));
                for i in 0..n {
                    let what = || format!("a coordinate of vertex {}", i + 1);
                    let x = t.expect_coord_by(what)?;
                    let y = t.expect_coord_by(what)?;
                    let z = if dim == 3 {
                        t.expect_coord_by(what)?
                    } else {
                        0.0
                    };
                    mesh.positions.push(Point3::new(x, y, z));
                    point_refs.push(read_ref(&mut t, || format!("the ref of vertex {}", i + 1))?);
                }
            }
            "end" => break,
            k => {
                if let Some(&(_, ct, nv)) = CELL_SECTIONS.iter().find(|s| s.0 == keyword) {
                    let n: usize = t.expect(&format!("the number of {}", show(tok)))?;
                    let c = cap(n, t.remaining(), 2 * (nv + 1));
                    mesh.cell_types.reserve(c);
                    mesh.offsets.reserve(c);
                    cell_refs.reserve(c);
                    for i in 0..n {
                        cell.clear();
                        for _ in 0..nv {
                            let what = || format!("a vertex index of {} {}", show(tok), i + 1);
                            let v: u64 = t.expect_by(what)?;
                            if v == 0 || v > u64::from(u32::MAX) {
                                return Err(t.error(format!(
                                    "{} is {v}; indices run from 1 to the number of vertices",
                                    what()
                                )));
                            }
                            let v = v - 1;
                            if let Location::Line(l) = t.location()
                                && max_index.is_none_or(|(m, _)| v > m)
                            {
                                max_index = Some((v, l));
                            }
                            cell.push(v as u32);
                        }
                        cell_refs.push(read_ref(&mut t, || {
                            format!("the ref of {} {}", show(tok), i + 1)
                        })?);
                        mesh.push_cell(ct, &cell);
                    }
                } else if let Some(&(_, ints)) = SKIPPED.iter().find(|s| s.0 == keyword) {
                    let n: usize = t.expect(&format!("the number of {}", show(tok)))?;
                    let per = ints.unwrap_or(dim);
                    for i in 0..n {
                        for _ in 0..per {
                            if t.next().is_none() {
                                return Err(t.error(format!(
                                    "unexpected end of file in entry {} of {}",
                                    i + 1,
                                    show(tok)
                                )));
                            }
                        }
                    }
                } else if k.ends_with("p2") || k.ends_with("q2") || k.ends_with("p3") {
                    return Err(IoError::unsupported(format!(
                        "{line}higher-order Medit section '{}' is not supported; only linear cells are read",
                        show(tok)
                    )));
                } else {
                    return Err(IoError::malformed(
                        line,
                        format!(
                            "unknown Medit section '{}' (its entry size is unknown, so it cannot be skipped)",
                            show(tok)
                        ),
                    ));
                }
            }
        }
    }
    if first {
        return Err(t.error("empty file; expected 'MeshVersionFormatted'"));
    }
    if let Some((v, l)) = max_index
        && v >= mesh.positions.len() as u64
    {
        return Err(IoError::malformed(
            Location::Line(l),
            format!(
                "vertex index {} is out of range: the file has {} vertices",
                v + 1,
                mesh.positions.len()
            ),
        ));
    }
    mesh.add_point_field(Field::labels(REF_FIELD, point_refs))?;
    mesh.add_cell_field(Field::labels(REF_FIELD, cell_refs))?;
    Ok(mesh)
}

/// The refs to write: from a one-component integer-valued field, else 0.
fn refs(field: Option<&Field>, n: usize, what: &str) -> Result<Vec<i32>, IoError> {
    let Some(f) = field else {
        return Ok(vec![0; n]);
    };
    if f.components() != 1 {
        return Err(IoError::unsupported(format!(
            "the {what} field '{REF_FIELD}' has {} components; Medit refs are one integer",
            f.components()
        )));
    }
    if let FieldValues::I32(v) = f.values() {
        return Ok(v.clone());
    }
    (0..n)
        .map(|i| {
            let x = f.values().get_f64(i).unwrap_or(0.0);
            if x.fract() == 0.0 && x >= i32::MIN as f64 && x <= i32::MAX as f64 {
                Ok(x as i32)
            } else {
                Err(IoError::unsupported(format!(
                    "the {what} field '{REF_FIELD}' holds {x} at {i}; Medit refs are i32 integers"
                )))
            }
        })
        .collect()
}

/// Serializes a mesh as Medit `.mesh` (see the module documentation).
pub fn write(mesh: &CellMesh, _opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    mesh.check()?;
    if let Some((i, t)) = mesh
        .cell_types
        .iter()
        .enumerate()
        .find(|(_, t)| !WRITE_ORDER.iter().any(|w| w.0 == **t))
    {
        return Err(IoError::unsupported(format!(
            "Medit stores edges, triangles, quads, tets, pyramids, prisms and hexahedra; cell {i} is a {t:?}"
        )));
    }
    let point_refs = refs(mesh.point_data.get(REF_FIELD), mesh.num_points(), "point")?;
    let cell_refs = refs(mesh.cell_data.get(REF_FIELD), mesh.num_cells(), "cell")?;
    let mut s = String::with_capacity(mesh.num_points() * 60 + mesh.connectivity.len() * 8 + 64);
    s.push_str("MeshVersionFormatted 2\n\nDimension 3\n\n");
    let _ = writeln!(s, "Vertices\n{}", mesh.num_points());
    for (p, r) in mesh.positions.iter().zip(&point_refs) {
        let _ = writeln!(s, "{:?} {:?} {:?} {r}", p.x, p.y, p.z);
    }
    for &(ct, name) in WRITE_ORDER {
        let count = mesh.cell_types.iter().filter(|&&t| t == ct).count();
        if count == 0 {
            continue;
        }
        let _ = writeln!(s, "\n{name}\n{count}");
        for ((t, vs), r) in mesh.cells().zip(&cell_refs) {
            if t != ct {
                continue;
            }
            for v in vs {
                let _ = write!(s, "{} ", u64::from(*v) + 1);
            }
            let _ = writeln!(s, "{r}");
        }
    }
    s.push_str("\nEnd\n");
    Ok(s.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::off::test_support::*;
    use proptest::prelude::*;

    const SAMPLE: &str = "MeshVersionFormatted 1
# two tets sharing a face
Dimension
3
Vertices
5
0 0 0 1
1 0 0 1
0 1 0 2
0 0 1 2
1.0D+00 1 1 3
Corners
2
1 2
RequiredVertices 1 3
Normals
1
0 0 1
NormalAtVertices
1
1 1
Edges
1
1 2 7
Triangles
2
1 2 3 10
2 3 4 11
Tetrahedra
2
1 2 3 4 20
2 3 4 5 21
End
";

    #[test]
    fn medit_reads_sections_and_refs() {
        let m = read(SAMPLE.as_bytes()).unwrap();
        assert_eq!(m.num_points(), 5);
        assert_eq!(m.positions[4], Point3::new(1.0, 1.0, 1.0));
        assert_eq!(
            m.cell_types,
            vec![
                CellType::Line,
                CellType::Triangle,
                CellType::Triangle,
                CellType::Tetra,
                CellType::Tetra
            ]
        );
        assert_eq!(m.cell(4).1, &[1, 2, 3, 4]);
        assert_eq!(
            m.point_data.get(REF_FIELD).unwrap().values(),
            &FieldValues::I32(vec![1, 1, 2, 2, 3])
        );
        assert_eq!(
            m.cell_data.get(REF_FIELD).unwrap().values(),
            &FieldValues::I32(vec![7, 10, 11, 20, 21])
        );
        m.check().unwrap();
        // And back.
        let again = read(&write(&m, &WriteOptions::default()).unwrap()).unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn medit_reads_2d_and_mixed_volume_cells() {
        let text = "MeshVersionFormatted 2\nDimension 2\nVertices\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 5\nQuadrilaterals\n1\n1 2 3 4 9\nEnd\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.positions[3], Point3::new(0.0, 1.0, 0.0));
        assert_eq!(m.cell_types, vec![CellType::Quad]);
        let text = "MeshVersionFormatted 2\nDimension 3\nVertices\n6\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 0 1 0\n0 1 1 0\nPrisms\n1\n1 2 3 4 5 6 0\n";
        assert_eq!(
            read(text.as_bytes()).unwrap().cell_types,
            vec![CellType::Wedge]
        );
    }

    #[test]
    fn medit_errors_give_lines() {
        let cases = [
            ("", "empty file"),
            ("Vertices\n", "line 1: not a Medit file"),
            (
                "MeshVersionFormatted 1\nDimension 3\nVertices\n1\n0 0 x 1\n",
                "line 5: expected a coordinate of vertex 1, found 'x'",
            ),
            (
                "MeshVersionFormatted 1\nVertices\n1\n0 0 0 1\nTriangles\n1\n1 1 2 0\n",
                "line 7: vertex index 2 is out of range",
            ),
            (
                "MeshVersionFormatted 1\nVertices\n1\n0 0 0 1\nTriangles\n1\n1 0 1 0\n",
                "line 7: a vertex index of Triangles 1 is 0",
            ),
            (
                "MeshVersionFormatted 1\nVertices\n1\n0 0 0 1\nFoo\n1\n",
                "line 5: unknown Medit section 'Foo'",
            ),
            (
                "MeshVersionFormatted 1\nVertices\n1\n0 0 0 99999999999\n",
                "out of the i32 range",
            ),
            (
                "MeshVersionFormatted 1\nVertices\n2\n0 0 0 1\n",
                "unexpected end of file",
            ),
            (
                "MeshVersionFormatted 7\n",
                "line 1: unknown MeshVersionFormatted 7",
            ),
        ];
        for (text, want) in cases {
            let e = read(text.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        let e = read(b"MeshVersionFormatted 1\nTrianglesP2\n1\n").unwrap_err();
        assert!(
            matches!(e, IoError::Unsupported { .. }) && e.to_string().contains("line 2"),
            "{e}"
        );
        let e = read(&[1, 0, 0, 0, 2, 0, 0, 0]).unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
    }

    #[test]
    fn medit_write_rules() {
        let mut m = CellMesh::from_points(vec![Point3::origin(); 5]);
        m.push_cell(CellType::Polygon, &[0, 1, 2, 3, 4]);
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        let mut m = CellMesh::from_points(vec![Point3::origin(); 3]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        m.add_cell_field(Field::scalars(REF_FIELD, vec![2.5]))
            .unwrap();
        assert!(matches!(
            write(&m, &WriteOptions::default()),
            Err(IoError::Unsupported { .. })
        ));
        // Refs default to 0; float refs with integer values are fine.
        m.add_cell_field(Field::scalars(REF_FIELD, vec![4.0]))
            .unwrap();
        let back = read(&write(&m, &WriteOptions::default()).unwrap()).unwrap();
        assert_eq!(
            back.point_data.get(REF_FIELD).unwrap().values(),
            &FieldValues::I32(vec![0; 3])
        );
        assert_eq!(
            back.cell_data.get(REF_FIELD).unwrap().values(),
            &FieldValues::I32(vec![4])
        );
    }

    #[test]
    fn medit_truncations_never_panic() {
        check_truncations(SAMPLE.as_bytes(), read);
    }

    fn medit_cells() -> impl Strategy<Value = Vec<(CellType, Vec<u32>)>> {
        cells(
            vec![
                (CellType::Line, 2..=2),
                (CellType::Triangle, 3..=3),
                (CellType::Quad, 4..=4),
                (CellType::Tetra, 4..=4),
                (CellType::Pyramid, 5..=5),
                (CellType::Wedge, 6..=6),
                (CellType::Hexahedron, 8..=8),
            ],
            0..20,
        )
        .prop_map(|mut cs| {
            // Medit groups cells by type, in write order.
            let order = |t: CellType| WRITE_ORDER.iter().position(|w| w.0 == t);
            cs.sort_by_key(|c| order(c.0));
            cs
        })
    }

    proptest! {
        #[test]
        fn medit_round_trip(
            pts in points(coord(), 1..20),
            cs in medit_cells(),
            prefs in prop::collection::vec(any::<i32>(), 20),
            crefs in prop::collection::vec(any::<i32>(), 20),
        ) {
            let mut m = mesh_with(pts, &cs);
            m.add_point_field(Field::labels(REF_FIELD, prefs[..m.num_points()].to_vec())).unwrap();
            m.add_cell_field(Field::labels(REF_FIELD, crefs[..m.num_cells()].to_vec())).unwrap();
            let back = read(&write(&m, &WriteOptions::default()).unwrap()).unwrap();
            prop_assert_eq!(back, m);
        }

        #[test]
        fn medit_random_bytes_are_errors(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn medit_random_sections_never_panic(tail in "((Vertices|Triangles|Edges|Tetrahedra|Corners|Normals|End)\n[0-9 .\n-]{0,30}){0,6}") {
            let text = format!("MeshVersionFormatted 1\nDimension 3\n{tail}");
            if let Ok(m) = read(text.as_bytes()) {
                prop_assert!(m.check().is_ok());
            }
        }

        #[test]
        fn medit_corruptions_never_panic(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8)) {
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
