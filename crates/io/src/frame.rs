//! The world frame a mesh file's coordinates are in, as far as the file
//! says: RAS (NIfTI's world: +x Right, +y Anterior, +z Superior) or LPS
//! (ITK's and DICOM's: +x Left, +y Posterior, +z Superior). The two differ by negating x and y, a
//! rotation by 180 degrees about z (so tets keep their orientation).
//!
//! 3D Slicer (`vtkMRMLModelStorageNode`, Slicer 4.11 and later) records the
//! frame of every model it saves, and reads it back the same way:
//!
//! | file | where | text |
//! | --- | --- | --- |
//! | legacy `.vtk` | the header line (line 2) | `3D Slicer output. SPACE=LPS` |
//! | `.stl` | the header (ASCII `solid` line, or the binary 80 bytes) | `3D Slicer output. SPACE=LPS` |
//! | `.obj` | a `#` comment | `3D Slicer output. SPACE=LPS` |
//! | `.ply` | a `comment` header line | `SPACE=LPS` |
//! | `.vtu`, `.vtp` | a field-data string array `SPACE` | `LPS` |
//!
//! (`RAS` in place of `LPS` for a model saved in RAS; Slicer saves in LPS by
//! default.) [`mesh_frame_hint`] finds that marker; a file without one says
//! nothing about its frame.

use crate::vtk_xml;

/// A patient-based world frame of mesh coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Frame {
    /// +x Right, +y Anterior, +z Superior: NIfTI's world frame.
    Ras,
    /// +x Left, +y Posterior, +z Superior: ITK's and DICOM's.
    Lps,
}

impl Frame {
    /// `"RAS"` or `"LPS"`.
    pub fn name(self) -> &'static str {
        match self {
            Frame::Ras => "RAS",
            Frame::Lps => "LPS",
        }
    }

    /// The factors that take coordinates in this frame to RAS:
    /// `(1, 1, 1)` for RAS, `(-1, -1, 1)` for LPS (the map is its own
    /// inverse, so they also take RAS to this frame).
    pub fn to_ras_signs(self) -> [f64; 3] {
        match self {
            Frame::Ras => [1.0, 1.0, 1.0],
            Frame::Lps => [-1.0, -1.0, 1.0],
        }
    }
}

/// How far into a text header the `SPACE=` marker is looked for: Slicer
/// writes it in the first lines, before any data.
const HEADER_BYTES: usize = 4096;

/// The frame 3D Slicer recorded in a mesh file's bytes (see the module
/// documentation for where each format keeps it), or `None` when the file
/// carries no marker (or, for `.vtu` / `.vtp`, cannot be parsed as VTK XML).
///
/// Text formats: the first `SPACE=RAS` or `SPACE=LPS` within the first
/// 4096 bytes (the headers; a binary STL's 80-byte header included), as
/// Slicer's own reader searches its header string. VTK XML: the field-data
/// string array `SPACE` holding `RAS` or `LPS`.
pub fn mesh_frame_hint(bytes: &[u8]) -> Option<Frame> {
    let head = &bytes[..bytes.len().min(HEADER_BYTES)];
    if find(head, b"<VTKFile").is_some() {
        let text = vtk_xml::field_data_text(bytes, "SPACE").ok()??;
        return frame_in(text.as_bytes(), b"");
    }
    frame_in(head, b"SPACE=")
}

/// The frame named right after `prefix` at its first occurrence followed by
/// `RAS` or `LPS` (`prefix` empty: the text contains `RAS` or `LPS`, RAS
/// first as Slicer's reader does).
fn frame_in(text: &[u8], prefix: &[u8]) -> Option<Frame> {
    let ras = [prefix, b"RAS"].concat();
    let lps = [prefix, b"LPS"].concat();
    match (find(text, &ras), find(text, &lps)) {
        (Some(r), Some(l)) => Some(if r <= l { Frame::Ras } else { Frame::Lps }),
        (Some(_), None) => Some(Frame::Ras),
        (None, Some(_)) => Some(Frame::Lps),
        (None, None) => None,
    }
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    if needle.is_empty() || hay.len() < needle.len() {
        return None;
    }
    hay.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{WriteOptions, XmlEncoding};
    use proptest::prelude::*;
    use unfold_mesh::nalgebra::Point3;
    use unfold_mesh::{CellMesh, CellType};

    fn tet() -> CellMesh {
        let mut m = CellMesh::from_points(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
        ]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        m
    }

    /// A VTK XML file as Slicer writes it: `<FieldData>` with the string
    /// array `SPACE` before the `<Piece>`, in the array encoding of `opts`.
    fn slicer_xml(space: &str, opts: &WriteOptions) -> Vec<u8> {
        let plain = vtk_xml::write_vtu(&tet(), opts).expect("written");
        let text = String::from_utf8_lossy(&plain).into_owned();
        let bytes: Vec<String> = space.bytes().chain([0]).map(|b| b.to_string()).collect();
        let field = format!(
            "<FieldData>\n<Array type=\"String\" Name=\"SPACE\" NumberOfTuples=\"1\" \
             format=\"ascii\">\n{}\n</Array>\n</FieldData>\n<Piece",
            bytes.join(" ")
        );
        let at = text.find("<Piece").expect("a piece");
        let mut out = plain[..at].to_vec();
        out.extend_from_slice(field.as_bytes());
        out.extend_from_slice(&plain[at + "<Piece".len()..]);
        out
    }

    #[test]
    fn slicer_text_headers_are_found() {
        let vtk = b"# vtk DataFile Version 4.2\n3D Slicer output. SPACE=LPS\nASCII\n";
        assert_eq!(mesh_frame_hint(vtk), Some(Frame::Lps));
        let vtk = b"# vtk DataFile Version 4.2\n3D Slicer output. SPACE=RAS\nASCII\n";
        assert_eq!(mesh_frame_hint(vtk), Some(Frame::Ras));
        let ply = b"ply\nformat ascii 1.0\ncomment SPACE=LPS\nelement vertex 3\n";
        assert_eq!(mesh_frame_hint(ply), Some(Frame::Lps));
        let obj = b"# 3D Slicer output. SPACE=LPS\nv 0 0 0\n";
        assert_eq!(mesh_frame_hint(obj), Some(Frame::Lps));
        let stl = b"solid 3D Slicer output. SPACE=RAS\nfacet normal 0 0 1\n";
        assert_eq!(mesh_frame_hint(stl), Some(Frame::Ras));
        // A binary STL: an 80-byte header, then binary data.
        let mut bin = b"3D Slicer output. SPACE=LPS".to_vec();
        bin.resize(80, b' ');
        bin.extend_from_slice(&[1, 0, 0, 0, 0xff, 0x00, 0x7f]);
        assert_eq!(mesh_frame_hint(&bin), Some(Frame::Lps));
    }

    #[test]
    fn files_without_a_marker_say_nothing() {
        assert_eq!(mesh_frame_hint(b""), None);
        assert_eq!(
            mesh_frame_hint(b"# vtk DataFile Version 4.2\nunfold\nASCII\n"),
            None
        );
        // "LPS" alone (not after SPACE=) in a text header is no marker.
        assert_eq!(mesh_frame_hint(b"solid LPS model\n"), None);
        let plain = vtk_xml::write_vtu(&tet(), &WriteOptions::default()).unwrap();
        assert_eq!(mesh_frame_hint(&plain), None);
        // Broken XML: no hint, no panic.
        assert_eq!(mesh_frame_hint(b"<VTKFile type=\"Unstru"), None);
    }

    #[test]
    fn slicer_field_data_is_found_in_every_encoding() {
        for encoding in [
            XmlEncoding::Ascii,
            XmlEncoding::InlineBase64,
            XmlEncoding::AppendedRaw,
            XmlEncoding::AppendedBase64,
        ] {
            for compress in [false, true] {
                let opts = WriteOptions {
                    xml_encoding: encoding,
                    compress,
                    ..WriteOptions::default()
                };
                for (space, frame) in [("LPS", Frame::Lps), ("RAS", Frame::Ras)] {
                    let b = slicer_xml(space, &opts);
                    assert_eq!(mesh_frame_hint(&b), Some(frame), "{encoding:?} {compress}");
                    // The mesh still reads, the field data ignored.
                    let m = vtk_xml::read(&b).expect("reads");
                    assert_eq!(m.num_points(), 4);
                }
            }
        }
    }

    #[test]
    fn a_binary_string_array_is_decoded() {
        // `SPACE` stored as inline base64 of a UInt32 header (4 bytes:
        // length 4) followed by "LPS\0", as VTK writes binary string arrays.
        let plain = vtk_xml::write_vtu(&tet(), &WriteOptions::default()).unwrap();
        let text = String::from_utf8_lossy(&plain).into_owned();
        let at = text.find("<Piece").unwrap();
        // header_type is UInt64 in unfold's files: an 8-byte length.
        let mut block = 4u64.to_le_bytes().to_vec();
        block.extend_from_slice(b"LPS\0");
        use base64::Engine as _;
        let b64 = base64::engine::general_purpose::STANDARD.encode(&block);
        let field = format!(
            "<FieldData><Array type=\"String\" Name=\"SPACE\" NumberOfTuples=\"1\" \
             format=\"binary\">{b64}</Array></FieldData><Piece"
        );
        let mut b = plain[..at].to_vec();
        b.extend_from_slice(field.as_bytes());
        b.extend_from_slice(&plain[at + "<Piece".len()..]);
        assert_eq!(mesh_frame_hint(&b), Some(Frame::Lps));
    }

    #[test]
    fn frames_negate_x_and_y() {
        assert_eq!(Frame::Lps.to_ras_signs(), [-1.0, -1.0, 1.0]);
        assert_eq!(Frame::Ras.to_ras_signs(), [1.0, 1.0, 1.0]);
        assert_eq!(Frame::Lps.name(), "LPS");
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
            let _ = mesh_frame_hint(&bytes);
            let mut xml = b"<VTKFile type=\"UnstructuredGrid\">".to_vec();
            xml.extend_from_slice(&bytes);
            let _ = mesh_frame_hint(&xml);
        }

        #[test]
        fn the_marker_is_found_after_any_prefix(prefix in "[ -~]{0,200}", lps in any::<bool>()) {
            prop_assume!(!prefix.contains("SPACE=") && !prefix.contains("<VTKFile"));
            let space = if lps { "LPS" } else { "RAS" };
            let text = format!("{prefix}\nSPACE={space}\n");
            let want = if lps { Frame::Lps } else { Frame::Ras };
            prop_assert_eq!(mesh_frame_hint(text.as_bytes()), Some(want));
        }
    }
}
