//! Options for the writers.

/// How VTK XML (`.vtu`, `.vtp`) writers store binary arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum XmlEncoding {
    /// `<AppendedData encoding="raw">`: fastest and smallest (the default).
    #[default]
    AppendedRaw,
    /// `<AppendedData encoding="base64">`.
    AppendedBase64,
    /// `format="binary"` base64 inside each `<DataArray>`.
    InlineBase64,
    /// `format="ascii"` text.
    Ascii,
}

/// Which VTK legacy file version to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegacyVersion {
    /// `# vtk DataFile Version 4.2`: `CELLS n size` with per-cell counts
    /// (read by every VTK and meshio version).
    #[default]
    V4_2,
    /// `# vtk DataFile Version 5.1`: `CELLS` with `OFFSETS` / `CONNECTIVITY`.
    V5_1,
}

/// Options shared by all writers; each writer uses the ones that apply to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteOptions {
    /// Text instead of binary (legacy VTK, PLY, STL). For VTK XML use
    /// [`XmlEncoding::Ascii`] (either setting makes it ASCII).
    pub ascii: bool,
    /// VTK XML array storage.
    pub xml_encoding: XmlEncoding,
    /// zlib-compress VTK XML binary arrays.
    pub compress: bool,
    /// Legacy VTK file version.
    pub legacy_version: LegacyVersion,
    /// Big-endian binary PLY (default little-endian).
    pub big_endian: bool,
}

impl WriteOptions {
    /// ASCII output in every format.
    pub fn ascii() -> Self {
        WriteOptions {
            ascii: true,
            xml_encoding: XmlEncoding::Ascii,
            ..WriteOptions::default()
        }
    }
}
