//! Gmsh `.msh` (read only): versions 2.2 and 4.1, ASCII and binary.
//!
//! Written here: the `mshio` crate reads 4.1 only and is no longer
//! maintained.
//!
//! - `$MeshFormat` gives the version (2.0-2.2 are read as 2.2; 4.0 and 1.x
//!   are unsupported), the file type (0 ASCII, 1 binary) and the data size
//!   (8 = sizeof(double) in 2.2; sizeof(size_t), 4 or 8, in 4.1). Binary
//!   files of either byte order are read (the integer `1` after the format
//!   line tells which).
//! - `$Nodes`: node tags may be any (non-contiguous, unsorted) numbers; they
//!   are mapped to point indices in file order. 4.1 parametric coordinates
//!   are skipped.
//! - `$Elements`: linear elements only, in file order: 1 line, 2 triangle,
//!   3 quad, 4 tetrahedron, 5 hexahedron, 6 prism (VTK wedge), 7 pyramid,
//!   15 point (VTK vertex); Gmsh and VTK number the vertices of these the
//!   same way. Any other (higher-order) type is unsupported, and the error
//!   names it.
//! - Cell data, as I32 fields: `gmsh:physical` (2.2: the first element tag;
//!   4.1: the first physical tag of the element's entity in `$Entities`, 0 if
//!   it has none) when some element has one, and `gmsh:geometrical` (2.2:
//!   the second element tag; 4.1: the entity tag) when some element has one.
//! - `$Entities` (4.1) is read for the physical tags; every other section
//!   (`$PhysicalNames`, `$NodeData`, `$ElementData`, `$Periodic`,
//!   `$Comments`, ...) is skipped up to its `$End...` line.
//! - Errors give the 1-based line (ASCII) or the byte offset (binary).

use crate::off::{Tokens, cap, show};
use crate::{IoError, Location};
use nalgebra::Point3;
use std::collections::HashMap;
use unfold_mesh::{CellMesh, CellType, Field};

/// Cell-data field with the physical tags.
pub const PHYSICAL_FIELD: &str = "gmsh:physical";
/// Cell-data field with the elementary (geometrical entity) tags.
pub const GEOMETRICAL_FIELD: &str = "gmsh:geometrical";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Version {
    V2,
    V4,
}

/// The cell type and vertex count of a linear Gmsh element type.
fn element_type(ty: i64, loc: Location) -> Result<(CellType, usize), IoError> {
    use CellType::*;
    Ok(match ty {
        1 => (Line, 2),
        2 => (Triangle, 3),
        3 => (Quad, 4),
        4 => (Tetra, 4),
        5 => (Hexahedron, 8),
        6 => (Wedge, 6),
        7 => (Pyramid, 5),
        15 => (Vertex, 1),
        _ => {
            let name = match ty {
                8 => "3-node second-order line",
                9 => "6-node second-order triangle",
                10 => "9-node second-order quadrangle",
                11 => "10-node second-order tetrahedron",
                12 => "27-node second-order hexahedron",
                13 => "18-node second-order prism",
                14 => "14-node second-order pyramid",
                16 => "8-node second-order quadrangle",
                17 => "20-node second-order hexahedron",
                18 => "15-node second-order prism",
                19 => "13-node second-order pyramid",
                20 => "9-node third-order incomplete triangle",
                21 => "10-node third-order triangle",
                26 => "4-node third-order line",
                29 => "20-node third-order tetrahedron",
                _ if ty > 0 && ty < 200 => "a higher-order or special element",
                _ => "not a Gmsh element type",
            };
            return Err(IoError::unsupported(format!(
                "{loc}Gmsh element type {ty} ({name}) is not supported; only linear elements (types 1-7 and 15) are read"
            )));
        }
    })
}

/// Binary values of the file's byte order.
struct Bin<'a> {
    bytes: &'a [u8],
    pos: usize,
    big: bool,
    size_t: usize,
}

impl Bin<'_> {
    fn err(&self, at: usize, msg: impl Into<String>) -> IoError {
        IoError::malformed(Location::Byte(at as u64), msg)
    }

    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], IoError> {
        let bytes: Option<[u8; N]> = self
            .pos
            .checked_add(N)
            .and_then(|end| self.bytes.get(self.pos..end))
            .and_then(|s| s.try_into().ok());
        let Some(mut a) = bytes else {
            return Err(self.err(
                self.pos,
                format!("unexpected end of file; expected {what} ({N} bytes)"),
            ));
        };
        self.pos += N;
        if self.big {
            a.reverse();
        }
        Ok(a)
    }

    fn i32(&mut self, what: &str) -> Result<i32, IoError> {
        Ok(i32::from_le_bytes(self.take(what)?))
    }

    /// An i32 that must be >= 0.
    fn count32(&mut self, what: &str) -> Result<usize, IoError> {
        let at = self.pos;
        let v = self.i32(what)?;
        usize::try_from(v).map_err(|_| self.err(at, format!("{what} is negative ({v})")))
    }

    fn f64(&mut self, what: &str) -> Result<f64, IoError> {
        Ok(f64::from_le_bytes(self.take(what)?))
    }

    /// A size_t of the file's data size (4 or 8 bytes).
    fn size(&mut self, what: &str) -> Result<u64, IoError> {
        if self.size_t == 4 {
            Ok(u32::from_le_bytes(self.take(what)?).into())
        } else {
            Ok(u64::from_le_bytes(self.take(what)?))
        }
    }

    fn usize(&mut self, what: &str) -> Result<usize, IoError> {
        let at = self.pos;
        let v = self.size(what)?;
        usize::try_from(v).map_err(|_| self.err(at, format!("{what} is too large ({v})")))
    }

    fn coord(&mut self, what: &str) -> Result<f64, IoError> {
        let at = self.pos;
        let v = self.f64(what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(at, format!("{what} is not finite ({v})")))
        }
    }
}

struct Reader<'a> {
    t: Tokens<'a>,
    bytes: &'a [u8],
    version: Version,
    binary: bool,
    big: bool,
    size_t: usize,
    tag_index: HashMap<u64, u32>,
    mesh: CellMesh,
    nodes_seen: bool,
    physical: Vec<i32>,
    geometrical: Vec<i32>,
    has_physical: bool,
    has_geometrical: bool,
    /// 4.1: (dimension, entity tag) -> first physical tag.
    entities: Option<HashMap<(i32, i32), i32>>,
    cell: Vec<u32>,
}

fn to_i32(v: i64, what: &str, loc: Location) -> Result<i32, IoError> {
    i32::try_from(v)
        .map_err(|_| IoError::malformed(loc, format!("{what} {v} is out of the i32 range")))
}

impl<'a> Reader<'a> {
    fn bin(&self) -> Bin<'a> {
        Bin {
            bytes: self.bytes,
            pos: self.t.pos(),
            big: self.big,
            size_t: self.size_t,
        }
    }

    fn add_node(&mut self, tag: u64, p: Point3<f64>, loc: Location) -> Result<(), IoError> {
        let Ok(index) = u32::try_from(self.mesh.positions.len()) else {
            return Err(IoError::unsupported("more than 2^32 nodes"));
        };
        if self.tag_index.insert(tag, index).is_some() {
            return Err(IoError::malformed(
                loc,
                format!("node tag {tag} appears twice"),
            ));
        }
        self.mesh.positions.push(p);
        Ok(())
    }

    fn node(&self, tag: u64, loc: Location) -> Result<u32, IoError> {
        self.tag_index.get(&tag).copied().ok_or_else(|| {
            IoError::malformed(
                loc,
                format!("an element refers to node {tag}, which is not in $Nodes"),
            )
        })
    }

    fn push_cell(&mut self, ct: CellType, physical: Option<i32>, geometrical: Option<i32>) {
        self.mesh.push_cell(ct, &self.cell);
        self.physical.push(physical.unwrap_or(0));
        self.geometrical.push(geometrical.unwrap_or(0));
        self.has_physical |= physical.is_some();
        self.has_geometrical |= geometrical.is_some();
    }

    /// Finishes a section: `$End<name>` must follow.
    fn end(&mut self, name: &str) -> Result<(), IoError> {
        self.t.expect_keyword(&format!("$End{name}"))
    }

    /// After a binary payload: continue the text at `pos`.
    fn resume(&mut self, pos: usize) {
        self.t.seek(pos);
    }

    fn skip_section(&mut self, start: &[u8]) -> Result<(), IoError> {
        let name = start.get(1..).unwrap_or_default();
        let mut marker = b"$End".to_vec();
        marker.extend_from_slice(name);
        let from = self.t.pos();
        let rest = self.bytes.get(from..).unwrap_or_default();
        match rest
            .windows(marker.len())
            .position(|w| w == marker.as_slice())
        {
            Some(i) => {
                self.t.seek(from + i + marker.len());
                Ok(())
            }
            None => Err(self.t.error(format!(
                "section '{}' is not closed by '{}'",
                show(start),
                show(&marker)
            ))),
        }
    }

    fn nodes_v2(&mut self) -> Result<(), IoError> {
        let n: usize = self.t.expect("the number of nodes")?;
        self.mesh
            .positions
            .reserve(cap(n, self.t.remaining(), if self.binary { 28 } else { 8 }));
        if self.binary {
            self.t.skip_line();
            let mut b = self.bin();
            for _ in 0..n {
                let at = b.pos;
                let tag = b.i32("a node tag")?;
                let tag = u64::try_from(tag)
                    .map_err(|_| b.err(at, format!("negative node tag {tag}")))?;
                let x = b.coord("a node coordinate")?;
                let y = b.coord("a node coordinate")?;
                let z = b.coord("a node coordinate")?;
                self.add_node(tag, Point3::new(x, y, z), Location::Byte(at as u64))?;
            }
            self.resume(b.pos);
        } else {
            for _ in 0..n {
                let tag: u64 = self.t.expect("a node tag")?;
                let loc = self.t.location();
                let x = self.t.expect_coord("a node coordinate")?;
                let y = self.t.expect_coord("a node coordinate")?;
                let z = self.t.expect_coord("a node coordinate")?;
                self.add_node(tag, Point3::new(x, y, z), loc)?;
            }
        }
        self.end("Nodes")
    }

    fn elements_v2(&mut self) -> Result<(), IoError> {
        let n: usize = self.t.expect("the number of elements")?;
        let c = cap(n, self.t.remaining(), 8);
        self.mesh.cell_types.reserve(c);
        self.mesh.offsets.reserve(c);
        if self.binary {
            self.t.skip_line();
            let mut b = self.bin();
            let mut done = 0usize;
            while done < n {
                let at = b.pos;
                let ty = b.i32("an element type")?;
                let follow = b.count32("the number of elements in the block")?;
                let ntags = b.count32("the number of tags")?;
                if follow > n - done {
                    return Err(b.err(
                        at,
                        format!("an element block of {follow} elements goes past the {n} declared"),
                    ));
                }
                let (ct, k) = element_type(ty.into(), Location::Byte(at as u64))?;
                for _ in 0..follow {
                    b.i32("an element tag")?;
                    let (mut phys, mut geom) = (None, None);
                    for j in 0..ntags {
                        let v = b.i32("an element tag")?;
                        match j {
                            0 => phys = Some(v),
                            1 => geom = Some(v),
                            _ => {}
                        }
                    }
                    self.cell.clear();
                    for _ in 0..k {
                        let at = b.pos;
                        let tag = b.i32("a node tag")?;
                        let loc = Location::Byte(at as u64);
                        let tag = u64::try_from(tag).map_err(|_| {
                            IoError::malformed(loc, format!("negative node tag {tag}"))
                        })?;
                        let v = self.node(tag, loc)?;
                        self.cell.push(v);
                    }
                    self.push_cell(ct, phys, geom);
                }
                done += follow;
            }
            self.resume(b.pos);
        } else {
            for _ in 0..n {
                self.t.expect::<i64>("an element tag")?;
                let ty: i64 = self.t.expect("an element type")?;
                let (ct, k) = element_type(ty, self.t.location())?;
                let ntags: usize = self.t.expect("the number of element tags")?;
                let (mut phys, mut geom) = (None, None);
                for j in 0..ntags {
                    let v: i64 = self.t.expect("an element tag")?;
                    let v = to_i32(v, "element tag", self.t.location())?;
                    match j {
                        0 => phys = Some(v),
                        1 => geom = Some(v),
                        _ => {}
                    }
                }
                self.cell.clear();
                for _ in 0..k {
                    let tag: u64 = self.t.expect("a node tag")?;
                    let v = self.node(tag, self.t.location())?;
                    self.cell.push(v);
                }
                self.push_cell(ct, phys, geom);
            }
        }
        self.end("Elements")
    }

    fn entities_v4(&mut self) -> Result<(), IoError> {
        let mut map = HashMap::new();
        if self.binary {
            self.t.skip_line();
            let mut b = self.bin();
            let mut counts = [0u64; 4];
            for c in &mut counts {
                *c = b.size("an entity count")?;
            }
            for (dim, &count) in counts.iter().enumerate() {
                for _ in 0..count {
                    let tag = b.i32("an entity tag")?;
                    for _ in 0..if dim == 0 { 3 } else { 6 } {
                        b.f64("an entity coordinate")?;
                    }
                    let nphys = b.size("the number of physical tags")?;
                    let mut first = None;
                    for j in 0..nphys {
                        let p = b.i32("a physical tag")?;
                        if j == 0 {
                            first = Some(p);
                        }
                    }
                    if dim > 0 {
                        let nb = b.size("the number of bounding entities")?;
                        for _ in 0..nb {
                            b.i32("a bounding entity tag")?;
                        }
                    }
                    if let Some(p) = first {
                        map.insert((dim as i32, tag), p);
                    }
                }
            }
            self.resume(b.pos);
        } else {
            let mut counts = [0usize; 4];
            for c in &mut counts {
                *c = self.t.expect("an entity count")?;
            }
            for (dim, &count) in counts.iter().enumerate() {
                for _ in 0..count {
                    let tag: i64 = self.t.expect("an entity tag")?;
                    let tag = to_i32(tag, "entity tag", self.t.location())?;
                    for _ in 0..if dim == 0 { 3 } else { 6 } {
                        self.t.expect_f64("an entity coordinate")?;
                    }
                    let nphys: usize = self.t.expect("the number of physical tags")?;
                    let mut first = None;
                    for j in 0..nphys {
                        let p: i64 = self.t.expect("a physical tag")?;
                        let p = to_i32(p, "physical tag", self.t.location())?;
                        if j == 0 {
                            first = Some(p);
                        }
                    }
                    if dim > 0 {
                        let nb: usize = self.t.expect("the number of bounding entities")?;
                        for _ in 0..nb {
                            self.t.expect::<i64>("a bounding entity tag")?;
                        }
                    }
                    if let Some(p) = first {
                        map.insert((dim as i32, tag), p);
                    }
                }
            }
        }
        self.entities = Some(map);
        self.end("Entities")
    }

    fn nodes_v4(&mut self) -> Result<(), IoError> {
        if self.binary {
            self.t.skip_line();
            let mut b = self.bin();
            let blocks = b.size("the number of node blocks")?;
            let total = b.usize("the number of nodes")?;
            b.size("the smallest node tag")?;
            b.size("the largest node tag")?;
            self.mesh
                .positions
                .reserve(cap(total, b.bytes.len().saturating_sub(b.pos), 32));
            let mut tags = Vec::new();
            for _ in 0..blocks {
                let at = b.pos;
                let dim = b.i32("an entity dimension")?;
                b.i32("an entity tag")?;
                let parametric = b.i32("the parametric flag")?;
                let n = b.usize("the number of nodes in the block")?;
                let extra = parametric_extra(dim, parametric, Location::Byte(at as u64))?;
                tags.clear();
                tags.reserve(cap(n, b.bytes.len().saturating_sub(b.pos), self.size_t));
                for _ in 0..n {
                    tags.push((b.pos, b.size("a node tag")?));
                }
                for &(at, tag) in &tags {
                    let x = b.coord("a node coordinate")?;
                    let y = b.coord("a node coordinate")?;
                    let z = b.coord("a node coordinate")?;
                    for _ in 0..extra {
                        b.f64("a parametric coordinate")?;
                    }
                    self.add_node(tag, Point3::new(x, y, z), Location::Byte(at as u64))?;
                }
            }
            self.resume(b.pos);
        } else {
            let blocks: usize = self.t.expect("the number of node blocks")?;
            let total: usize = self.t.expect("the number of nodes")?;
            self.t.expect::<u64>("the smallest node tag")?;
            self.t.expect::<u64>("the largest node tag")?;
            self.mesh
                .positions
                .reserve(cap(total, self.t.remaining(), 8));
            let mut tags = Vec::new();
            for _ in 0..blocks {
                let dim: i32 = self.t.expect("an entity dimension")?;
                self.t.expect::<i32>("an entity tag")?;
                let parametric: i32 = self.t.expect("the parametric flag (0 or 1)")?;
                let extra = parametric_extra(dim, parametric, self.t.location())?;
                let n: usize = self.t.expect("the number of nodes in the block")?;
                tags.clear();
                tags.reserve(cap(n, self.t.remaining(), 2));
                for _ in 0..n {
                    let tag: u64 = self.t.expect("a node tag")?;
                    tags.push((self.t.location(), tag));
                }
                for &(loc, tag) in &tags {
                    let x = self.t.expect_coord("a node coordinate")?;
                    let y = self.t.expect_coord("a node coordinate")?;
                    let z = self.t.expect_coord("a node coordinate")?;
                    for _ in 0..extra {
                        self.t.expect_f64("a parametric coordinate")?;
                    }
                    self.add_node(tag, Point3::new(x, y, z), loc)?;
                }
            }
        }
        self.end("Nodes")
    }

    fn elements_v4(&mut self) -> Result<(), IoError> {
        if self.binary {
            self.t.skip_line();
            let mut b = self.bin();
            let blocks = b.size("the number of element blocks")?;
            let total = b.usize("the number of elements")?;
            b.size("the smallest element tag")?;
            b.size("the largest element tag")?;
            let c = cap(total, b.bytes.len().saturating_sub(b.pos), 16);
            self.mesh.cell_types.reserve(c);
            self.mesh.offsets.reserve(c);
            for _ in 0..blocks {
                let at = b.pos;
                let dim = b.i32("an entity dimension")?;
                let tag = b.i32("an entity tag")?;
                let ty = b.i32("an element type")?;
                let n = b.size("the number of elements in the block")?;
                let (ct, k) = element_type(ty.into(), Location::Byte(at as u64))?;
                let phys = self.physical_of(dim, tag);
                for _ in 0..n {
                    b.size("an element tag")?;
                    self.cell.clear();
                    for _ in 0..k {
                        let at = b.pos;
                        let node = b.size("a node tag")?;
                        let v = self.node(node, Location::Byte(at as u64))?;
                        self.cell.push(v);
                    }
                    self.push_cell(ct, phys, Some(tag));
                }
            }
            self.resume(b.pos);
        } else {
            let blocks: usize = self.t.expect("the number of element blocks")?;
            let total: usize = self.t.expect("the number of elements")?;
            self.t.expect::<u64>("the smallest element tag")?;
            self.t.expect::<u64>("the largest element tag")?;
            let c = cap(total, self.t.remaining(), 8);
            self.mesh.cell_types.reserve(c);
            self.mesh.offsets.reserve(c);
            for _ in 0..blocks {
                let dim: i32 = self.t.expect("an entity dimension")?;
                let tag: i32 = self.t.expect("an entity tag")?;
                let ty: i64 = self.t.expect("an element type")?;
                let (ct, k) = element_type(ty, self.t.location())?;
                let n: usize = self.t.expect("the number of elements in the block")?;
                let phys = self.physical_of(dim, tag);
                for _ in 0..n {
                    self.t.expect::<u64>("an element tag")?;
                    self.cell.clear();
                    for _ in 0..k {
                        let node: u64 = self.t.expect("a node tag")?;
                        let v = self.node(node, self.t.location())?;
                        self.cell.push(v);
                    }
                    self.push_cell(ct, phys, Some(tag));
                }
            }
        }
        self.end("Elements")
    }

    /// 4.1: the physical tag of an entity: None without `$Entities` or
    /// when the entity has none.
    fn physical_of(&self, dim: i32, tag: i32) -> Option<i32> {
        self.entities.as_ref()?.get(&(dim, tag)).copied()
    }
}

/// The number of parametric coordinates after x y z in a 4.1 node block.
fn parametric_extra(dim: i32, parametric: i32, loc: Location) -> Result<usize, IoError> {
    if !(0..=3).contains(&dim) {
        return Err(IoError::malformed(
            loc,
            format!("entity dimension {dim}; expected 0 to 3"),
        ));
    }
    match parametric {
        0 => Ok(0),
        1 => Ok(dim as usize),
        p => Err(IoError::malformed(
            loc,
            format!("parametric flag {p}; expected 0 or 1"),
        )),
    }
}

/// Parses a Gmsh `.msh` file's bytes (see the module documentation).
pub fn read(bytes: &[u8]) -> Result<CellMesh, IoError> {
    let mut t = Tokens::new(bytes, None);
    match t.next() {
        Some(tok) if tok == b"$MeshFormat" => {}
        Some(tok) => {
            return Err(t.error(format!(
                "not a Gmsh file: expected '$MeshFormat', found '{}'",
                show(tok)
            )));
        }
        None => return Err(t.error("empty file; expected '$MeshFormat'")),
    }
    let Some(v) = t.next() else {
        return Err(t.error("unexpected end of file; expected the format version"));
    };
    let version = match v {
        b"2" | b"2.0" | b"2.1" | b"2.2" => Version::V2,
        b"4.1" => Version::V4,
        _ => {
            return Err(IoError::unsupported(format!(
                "{}Gmsh file format version '{}' is not supported; save the mesh as version 4.1 or 2.2",
                t.location(),
                show(v)
            )));
        }
    };
    let file_type: i64 = t.expect("the file type (0 ASCII, 1 binary)")?;
    if file_type != 0 && file_type != 1 {
        return Err(t.error(format!(
            "file type {file_type}; expected 0 (ASCII) or 1 (binary)"
        )));
    }
    let binary = file_type == 1;
    let data_size: usize = t.expect("the data size")?;
    let mut big = false;
    if binary {
        let ok = match version {
            Version::V2 => data_size == 8,
            Version::V4 => data_size == 8 || data_size == 4,
        };
        if !ok {
            return Err(IoError::unsupported(format!(
                "{}binary Gmsh file with data size {data_size} is not supported",
                t.location()
            )));
        }
        t.skip_line();
        let at = t.pos();
        let one: Option<[u8; 4]> = bytes.get(at..at + 4).and_then(|s| s.try_into().ok());
        match one {
            Some(b) if i32::from_le_bytes(b) == 1 => {}
            Some(b) if i32::from_be_bytes(b) == 1 => big = true,
            _ => {
                return Err(IoError::malformed(
                    Location::Byte(at as u64),
                    "expected the binary integer 1 (byte-order check) after the format line",
                ));
            }
        }
        t.seek(at + 4);
        t.use_byte_locations();
    }
    t.expect_keyword("$EndMeshFormat")?;
    let mut r = Reader {
        t,
        bytes,
        version,
        binary,
        big,
        size_t: data_size,
        tag_index: HashMap::new(),
        mesh: CellMesh::default(),
        nodes_seen: false,
        physical: Vec::new(),
        geometrical: Vec::new(),
        has_physical: false,
        has_geometrical: false,
        entities: None,
        cell: Vec::new(),
    };
    let mut elements_seen = false;
    while let Some(tok) = r.t.next() {
        match tok {
            b"$Nodes" => {
                if r.nodes_seen {
                    return Err(r.t.error("a second $Nodes section"));
                }
                r.nodes_seen = true;
                match r.version {
                    Version::V2 => r.nodes_v2()?,
                    Version::V4 => r.nodes_v4()?,
                }
            }
            b"$Elements" => {
                if !r.nodes_seen {
                    return Err(r.t.error("$Elements comes before $Nodes"));
                }
                if elements_seen {
                    return Err(r.t.error("a second $Elements section"));
                }
                elements_seen = true;
                match r.version {
                    Version::V2 => r.elements_v2()?,
                    Version::V4 => r.elements_v4()?,
                }
            }
            b"$Entities" if r.version == Version::V4 => r.entities_v4()?,
            _ if tok.starts_with(b"$") && !tok.starts_with(b"$End") && tok.len() > 1 => {
                r.skip_section(tok)?;
            }
            _ => {
                return Err(r.t.error(format!(
                    "expected a section such as $Nodes or $Elements, found '{}'",
                    show(tok)
                )));
            }
        }
    }
    if !r.nodes_seen {
        return Err(r.t.error("the file has no $Nodes section"));
    }
    let mut mesh = r.mesh;
    if r.has_physical {
        mesh.add_cell_field(Field::labels(PHYSICAL_FIELD, r.physical))?;
    }
    if r.has_geometrical {
        mesh.add_cell_field(Field::labels(GEOMETRICAL_FIELD, r.geometrical))?;
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::off::test_support::*;
    use proptest::prelude::*;
    use unfold_mesh::FieldValues;

    /// A unit square: 2 triangles, 2 boundary lines, a point; node tags
    /// non-contiguous and unsorted.
    const V22_ASCII: &str = r#"$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
1 5 "boundary"
2 6 "surface"
$EndPhysicalNames
$Nodes
4
10 0 0 0
30 1 1 0
20 1 0 0
40 0 1 0
$EndNodes
$Elements
5
1 15 2 0 1 10
2 1 2 5 1 10 20
3 1 2 5 2 20 30
4 2 2 6 3 10 20 30
5 2 2 6 3 10 30 40
$EndElements
$NodeData
1
"temperature"
1
0.0
3
0
1
4
10 1
20 2
30 3
40 4
$EndNodeData
"#;

    fn check_square(m: &CellMesh, physical: &[i32], geometrical: &[i32]) {
        m.check().unwrap();
        assert_eq!(m.num_points(), 4);
        assert_eq!(m.positions[1], Point3::new(1.0, 1.0, 0.0));
        assert_eq!(
            m.cell_types,
            vec![
                CellType::Vertex,
                CellType::Line,
                CellType::Line,
                CellType::Triangle,
                CellType::Triangle
            ]
        );
        assert_eq!(m.connectivity, vec![0, 0, 2, 2, 1, 0, 2, 1, 0, 1, 3]);
        let field = |n: &str| m.cell_data.get(n).unwrap().values().clone();
        assert_eq!(field(PHYSICAL_FIELD), FieldValues::I32(physical.to_vec()));
        assert_eq!(
            field(GEOMETRICAL_FIELD),
            FieldValues::I32(geometrical.to_vec())
        );
    }

    #[test]
    fn gmsh22_ascii() {
        let m = read(V22_ASCII.as_bytes()).unwrap();
        check_square(&m, &[0, 5, 5, 6, 6], &[1, 1, 2, 3, 3]);
    }

    /// The same square as 4.1 ASCII, with a parametric node block.
    const V41_ASCII: &str = "$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
1 5 \"boundary\"
2 6 \"surface\"
$EndPhysicalNames
$Entities
1 2 1 0
7 0 0 0 0
1 0 0 0 1 0 0 1 5 2 7 -8
2 1 0 0 1 1 0 1 5 2 8 -9
3 0 0 0 1 1 0 1 6 4 1 2 -3 -4
$EndEntities
$Nodes
2 4 10 40
0 7 0 1
10
0 0 0
2 3 1 3
30
20
40
1 1 0 0.5 0.5
1 0 0 0.5 0.0
0 1 0 0.0 0.5
$EndNodes
$Elements
4 5 1 5
0 7 15 1
1 10
1 1 1 1
2 10 20
1 2 1 1
3 20 30
2 3 2 2
4 10 20 30
5 10 30 40
$EndElements
";

    #[test]
    fn gmsh41_ascii() {
        let m = read(V41_ASCII.as_bytes()).unwrap();
        // The point entity 7 has no physical tag: 0.
        check_square(&m, &[0, 5, 5, 6, 6], &[7, 1, 2, 3, 3]);
        assert_eq!(
            m.positions,
            vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ]
        );
    }

    /// Writes `m` as Gmsh (test only): node tags `3 i + 7`; the cell fields
    /// give the tags (4.1: physical tags come from `$Entities`, one entity
    /// per (dimension, geometrical tag), so they must be a function of it).
    fn write_msh(m: &CellMesh, v4: bool, binary: bool, big: bool) -> Vec<u8> {
        let tag = |i: u32| u64::from(i) * 3 + 7;
        let gmsh_type = |t: CellType| match t {
            CellType::Line => 1,
            CellType::Triangle => 2,
            CellType::Quad => 3,
            CellType::Tetra => 4,
            CellType::Hexahedron => 5,
            CellType::Wedge => 6,
            CellType::Pyramid => 7,
            _ => 15,
        };
        let get = |n: &str, i: usize| m.cell_data.get(n).map(|f| f.get(i, 0).unwrap() as i32);
        let mut o: Vec<u8> = Vec::new();
        let push = |o: &mut Vec<u8>, s: &str| o.extend_from_slice(s.as_bytes());
        macro_rules! put {
            ($o:expr, $x:expr) => {
                if big {
                    $o.extend_from_slice(&$x.to_be_bytes())
                } else {
                    $o.extend_from_slice(&$x.to_le_bytes())
                }
            };
        }
        let version = if v4 { "4.1" } else { "2.2" };
        push(
            &mut o,
            &format!("$MeshFormat\n{version} {} 8\n", binary as u8),
        );
        if binary {
            put!(o, 1i32);
            push(&mut o, "\n");
        }
        push(
            &mut o,
            "$EndMeshFormat\n$Comments\nanything $Nodes\n$EndComments\n",
        );
        let n = m.num_points();
        if !v4 {
            push(&mut o, &format!("$Nodes\n{n}\n"));
            for (i, p) in m.positions.iter().enumerate() {
                if binary {
                    put!(o, tag(i as u32) as i32);
                    put!(o, p.x);
                    put!(o, p.y);
                    put!(o, p.z);
                } else {
                    push(
                        &mut o,
                        &format!("{} {:?} {:?} {:?}\n", tag(i as u32), p.x, p.y, p.z),
                    );
                }
            }
            push(
                &mut o,
                &format!("\n$EndNodes\n$Elements\n{}\n", m.num_cells()),
            );
            for (i, (t, vs)) in m.cells().enumerate() {
                let tags: Vec<i32> = [get(PHYSICAL_FIELD, i), get(GEOMETRICAL_FIELD, i)]
                    .into_iter()
                    .flatten()
                    .collect();
                if binary {
                    for x in [gmsh_type(t), 1, tags.len() as i32, i as i32 + 1] {
                        put!(o, x);
                    }
                    for &x in &tags {
                        put!(o, x);
                    }
                    for &v in vs {
                        put!(o, tag(v) as i32);
                    }
                } else {
                    push(
                        &mut o,
                        &format!("{} {} {}", i + 1, gmsh_type(t), tags.len()),
                    );
                    for x in tags {
                        push(&mut o, &format!(" {x}"));
                    }
                    for &v in vs {
                        push(&mut o, &format!(" {}", tag(v)));
                    }
                    push(&mut o, "\n");
                }
            }
            push(&mut o, "\n$EndElements\n");
            return o;
        }
        // 4.1: one entity per (dimension, geometrical tag).
        let dims = |t: CellType| t.dimension() as i32;
        let mut entities: std::collections::BTreeMap<(i32, i32), Option<i32>> = Default::default();
        for (i, (t, _)) in m.cells().enumerate() {
            entities.insert(
                (dims(t), get(GEOMETRICAL_FIELD, i).unwrap()),
                get(PHYSICAL_FIELD, i),
            );
        }
        // size_t values are 8 bytes here.
        let text = |o: &mut Vec<u8>, xs: &[String]| {
            o.extend_from_slice(xs.join(" ").as_bytes());
            o.push(b'\n');
        };
        push(&mut o, "$Entities\n");
        let count = |d: i32| entities.keys().filter(|k| k.0 == d).count() as u64;
        if binary {
            for d in 0..4 {
                put!(o, count(d));
            }
        } else {
            text(
                &mut o,
                &(0..4).map(|d| count(d).to_string()).collect::<Vec<_>>(),
            );
        }
        for (&(d, tg), phys) in &entities {
            let ph: Vec<i32> = phys.iter().copied().collect();
            if binary {
                put!(o, tg);
                for _ in 0..if d == 0 { 3 } else { 6 } {
                    put!(o, 0.5f64);
                }
                put!(o, ph.len() as u64);
                for &p in &ph {
                    put!(o, p);
                }
                if d > 0 {
                    put!(o, 1u64);
                    put!(o, -1i32);
                }
            } else {
                let mut xs = vec![tg.to_string()];
                xs.extend((0..if d == 0 { 3 } else { 6 }).map(|_| "0.5".to_string()));
                xs.push(ph.len().to_string());
                xs.extend(ph.iter().map(|p| p.to_string()));
                if d > 0 {
                    xs.extend(["1".to_string(), "-1".to_string()]);
                }
                text(&mut o, &xs);
            }
        }
        push(&mut o, "$EndEntities\n$Nodes\n");
        // Nodes: one block (parametric on a curve when binary, to test it).
        let param = binary as i32;
        if binary {
            for x in [1u64, n as u64, 7, tag(n as u32)] {
                put!(o, x);
            }
            for x in [1i32, 1, param] {
                put!(o, x);
            }
            put!(o, n as u64);
            for i in 0..n {
                put!(o, tag(i as u32));
            }
            for p in &m.positions {
                for c in [p.x, p.y, p.z, 0.25] {
                    put!(o, c);
                }
            }
            push(&mut o, "\n");
        } else {
            push(&mut o, &format!("1 {n} 7 {}\n1 1 0 {n}\n", tag(n as u32)));
            for i in 0..n {
                push(&mut o, &format!("{}\n", tag(i as u32)));
            }
            for p in &m.positions {
                push(&mut o, &format!("{:?} {:?} {:?}\n", p.x, p.y, p.z));
            }
        }
        push(&mut o, "$EndNodes\n$Elements\n");
        // One block per cell.
        let k = m.num_cells();
        if binary {
            for x in [k as u64, k as u64, 1, k as u64] {
                put!(o, x);
            }
        } else {
            push(&mut o, &format!("{k} {k} 1 {k}\n"));
        }
        for (i, (t, vs)) in m.cells().enumerate() {
            let g = get(GEOMETRICAL_FIELD, i).unwrap();
            if binary {
                for x in [dims(t), g, gmsh_type(t)] {
                    put!(o, x);
                }
                put!(o, 1u64);
                put!(o, i as u64 + 1);
                for &v in vs {
                    put!(o, tag(v));
                }
            } else {
                push(
                    &mut o,
                    &format!("{} {g} {} 1\n{}", dims(t), gmsh_type(t), i + 1),
                );
                for &v in vs {
                    push(&mut o, &format!(" {}", tag(v)));
                }
                push(&mut o, "\n");
            }
        }
        push(&mut o, "\n$EndElements\n");
        o
    }

    #[test]
    fn gmsh_binary_files_read_like_ascii() {
        let ascii = read(V22_ASCII.as_bytes()).unwrap();
        for big in [false, true] {
            let b22 = write_msh(&ascii, false, true, big);
            assert!(b22.starts_with(b"$MeshFormat\n2.2 1 8\n"));
            assert_eq!(read(&b22).unwrap(), ascii);
            let b41 = write_msh(&ascii, true, true, big);
            assert!(b41.starts_with(b"$MeshFormat\n4.1 1 8\n"));
            assert_eq!(read(&b41).unwrap(), ascii);
        }
    }

    #[test]
    fn gmsh_binary_22_hand_built() {
        // Two tets sharing a face, in one element block.
        let mut b = b"$MeshFormat\n2.2 1 8\n".to_vec();
        b.extend_from_slice(&1i32.to_le_bytes());
        b.extend_from_slice(b"\n$EndMeshFormat\n$Nodes\n5\n");
        for (tag, p) in [
            (5, [0.0, 0.0, 0.0]),
            (4, [1.0, 0.0, 0.0]),
            (3, [0.0, 1.0, 0.0]),
            (2, [0.0, 0.0, 1.0]),
            (1, [1.0, 1.0, 1.0]),
        ] {
            b.extend_from_slice(&i32::to_le_bytes(tag));
            for c in p {
                b.extend_from_slice(&f64::to_le_bytes(c));
            }
        }
        b.extend_from_slice(b"\n$EndNodes\n$Elements\n2\n");
        for x in [4i32, 2, 2, 1, 9, 8, 5, 4, 3, 2, 2, 9, 8, 4, 3, 2, 1] {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b.extend_from_slice(b"\n$EndElements\n");
        let m = read(&b).unwrap();
        assert_eq!(m.cell_types, vec![CellType::Tetra; 2]);
        assert_eq!(m.connectivity, vec![0, 1, 2, 3, 1, 2, 3, 4]);
        assert_eq!(
            m.cell_data.get(PHYSICAL_FIELD).unwrap().values(),
            &FieldValues::I32(vec![9, 9])
        );
        assert_eq!(
            m.cell_data.get(GEOMETRICAL_FIELD).unwrap().values(),
            &FieldValues::I32(vec![8, 8])
        );
        // Truncations report byte offsets and never panic.
        check_truncations(&b, read);
        let e = read(&b[..b.len() - 30]).unwrap_err().to_string();
        assert!(e.contains("byte "), "{e}");
    }

    #[test]
    fn gmsh_errors() {
        let higher = V22_ASCII.replace("5 2 2 6 3 10 30 40", "5 9 2 6 3 10 30 40 10 20 30");
        let e = read(higher.as_bytes()).unwrap_err();
        assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        let e = e.to_string();
        assert!(
            e.contains("line 22: Gmsh element type 9 (6-node second-order triangle)"),
            "{e}"
        );
        let cases = [
            (
                V22_ASCII.replace("5 2 2 6 3 10 30 40", "5 2 2 6 3 10 30 41"),
                "line 22: an element refers to node 41",
            ),
            (
                V22_ASCII.replace("30 1 1 0", "30 1 x 0"),
                "line 12: expected a node coordinate, found 'x'",
            ),
            (
                V22_ASCII.replace("40 0 1 0", "10 0 1 0"),
                "line 14: node tag 10 appears twice",
            ),
            (
                V22_ASCII.replace("$EndPhysicalNames", "$EndPhysical"),
                "is not closed by '$EndPhysicalNames'",
            ),
            (
                V22_ASCII.replace("$EndNodes", "$EndNode"),
                "line 15: expected '$EndNodes'",
            ),
            ("hello".to_string(), "line 1: not a Gmsh file"),
            ("$MeshFormat\n2.2 3 8\n".to_string(), "line 2: file type 3"),
            (
                V41_ASCII.replace("1 1 0 0.5 0.5", "1 1 0 0.5"),
                "expected a parametric coordinate",
            ),
        ];
        for (text, want) in cases {
            let e = read(text.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(want), "{want}: {e}");
        }
        for v in ["4.0", "1.0", "3"] {
            let e = read(format!("$MeshFormat\n{v} 0 8\n$EndMeshFormat\n").as_bytes()).unwrap_err();
            assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
        }
        let mut b = b"$MeshFormat\n2.2 1 8\n\x07\0\0\0\n$EndMeshFormat\n".to_vec();
        let e = read(&b).unwrap_err().to_string();
        assert!(e.contains("byte 20: expected the binary integer 1"), "{e}");
        b[20] = 1;
        b.extend_from_slice(b"$Nodes\n1\n\x01\0\0\0");
        let e = read(&b).unwrap_err().to_string();
        assert!(
            e.contains("byte 53: unexpected end of file; expected a node coordinate"),
            "{e}"
        );
    }

    #[test]
    fn gmsh_truncations_never_panic() {
        check_truncations(V22_ASCII.as_bytes(), read);
        check_truncations(V41_ASCII.as_bytes(), read);
        let m = read(V22_ASCII.as_bytes()).unwrap();
        check_truncations(&write_msh(&m, true, true, false), read);
    }

    fn tagged_mesh() -> impl Strategy<Value = CellMesh> {
        let cs = cells(
            vec![
                (CellType::Vertex, 1..=1),
                (CellType::Line, 2..=2),
                (CellType::Triangle, 3..=3),
                (CellType::Quad, 4..=4),
                (CellType::Tetra, 4..=4),
                (CellType::Pyramid, 5..=5),
                (CellType::Wedge, 6..=6),
                (CellType::Hexahedron, 8..=8),
            ],
            0..15,
        );
        (
            points(coord(), 1..15),
            cs,
            prop::collection::vec(1i32..4, 15),
        )
            .prop_map(|(p, c, g)| {
                let mut m = mesh_with(p, &c);
                let k = m.num_cells();
                if k > 0 {
                    let geom: Vec<i32> = g[..k].to_vec();
                    // Physical tag: a function of (dimension, entity) for 4.1.
                    let phys = geom
                        .iter()
                        .zip(&m.cell_types)
                        .map(|(&g, t)| 100 * i32::from(t.dimension()) + g)
                        .collect();
                    m.add_cell_field(Field::labels(PHYSICAL_FIELD, phys))
                        .unwrap();
                    m.add_cell_field(Field::labels(GEOMETRICAL_FIELD, geom))
                        .unwrap();
                }
                m
            })
    }

    proptest! {
        #[test]
        fn gmsh_all_encodings_read_back(m in tagged_mesh(), v4: bool, binary: bool, big: bool) {
            let bytes = write_msh(&m, v4, binary, big && binary);
            let back = read(&bytes).unwrap();
            prop_assert_eq!(back, m);
        }

        #[test]
        fn gmsh_random_bytes_are_errors(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
            prop_assert!(read(&bytes).is_err());
        }

        #[test]
        fn gmsh_random_payload_never_panics(
            v4: bool,
            tail in prop::collection::vec(any::<u8>(), 0..300),
            section in prop::sample::select(vec!["$Nodes\n", "$Elements\n", "$Entities\n", "$Nodes\n2\n", "$Elements\n1\n"]),
        ) {
            let mut b = format!("$MeshFormat\n{} 1 8\n", if v4 { "4.1" } else { "2.2" }).into_bytes();
            b.extend_from_slice(&1i32.to_le_bytes());
            b.extend_from_slice(b"\n$EndMeshFormat\n$Nodes\n");
            b.extend_from_slice(&tail);
            b.extend_from_slice(section.as_bytes());
            b.extend_from_slice(&tail);
            if let Ok(m) = read(&b) {
                prop_assert!(m.check().is_ok());
            }
        }

        #[test]
        fn gmsh_corruptions_never_panic(
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
            which in 0usize..4,
        ) {
            let m = read(V22_ASCII.as_bytes()).unwrap();
            let mut bytes = match which {
                0 => V22_ASCII.as_bytes().to_vec(),
                1 => V41_ASCII.as_bytes().to_vec(),
                2 => write_msh(&m, false, true, false),
                _ => write_msh(&m, true, true, true),
            };
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
