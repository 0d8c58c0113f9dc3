//! `unfold convert IN OUT`: between mesh formats, keeping point and cell data.

use super::CliError;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use unfold::io::{FileKind, LegacyVersion, WriteOptions, XmlEncoding, read_mesh, write_mesh};

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Encoding {
    AppendedRaw,
    AppendedBase64,
    InlineBase64,
    Ascii,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum VtkVersion {
    #[value(name = "4.2")]
    V42,
    #[value(name = "5.1")]
    V51,
}

/// Arguments of `unfold convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Input mesh (.vtk .vtu .vtp .ply .obj .stl .off .mesh .msh).
    input: PathBuf,
    /// Output mesh (.vtk .vtu .vtp .ply .obj .stl .off .mesh).
    output: PathBuf,
    /// Write text instead of binary where the format has both.
    #[arg(long)]
    ascii: bool,
    /// How VTK XML files store arrays.
    #[arg(long, value_enum, default_value = "appended-raw")]
    encoding: Encoding,
    /// zlib-compress VTK XML arrays.
    #[arg(long)]
    compress: bool,
    /// Legacy VTK file version.
    #[arg(long, value_enum, default_value = "4.2")]
    vtk_version: VtkVersion,
    /// Big-endian binary PLY.
    #[arg(long)]
    big_endian: bool,
}

/// Runs `unfold convert`.
pub fn run(a: &ConvertArgs) -> Result<(), CliError> {
    if super::canonical(&a.input) == super::canonical(&a.output) {
        return Err(CliError::Usage(format!(
            "{}: refusing to overwrite the input; choose another output path",
            a.output.display()
        )));
    }
    let mesh = read_mesh(&a.input)?;
    let opts = WriteOptions {
        ascii: a.ascii,
        xml_encoding: match (a.ascii, a.encoding) {
            (true, _) | (_, Encoding::Ascii) => XmlEncoding::Ascii,
            (_, Encoding::AppendedRaw) => XmlEncoding::AppendedRaw,
            (_, Encoding::AppendedBase64) => XmlEncoding::AppendedBase64,
            (_, Encoding::InlineBase64) => XmlEncoding::InlineBase64,
        },
        compress: a.compress,
        legacy_version: match a.vtk_version {
            VtkVersion::V42 => LegacyVersion::V4_2,
            VtkVersion::V51 => LegacyVersion::V5_1,
        },
        big_endian: a.big_endian,
    };
    write_mesh(&a.output, &mesh, &opts)?;
    if let FileKind::Mesh(f) = FileKind::from_path(&a.output)?
        && !f.holds_arrays()
    {
        let dropped: Vec<&str> = mesh
            .point_data
            .iter()
            .chain(mesh.cell_data.iter())
            .map(|f| f.name())
            .filter(|n| !n.starts_with("medit:"))
            .collect();
        if !dropped.is_empty() {
            eprintln!(
                "unfold: note: .{} files hold no data arrays; not written: {}",
                f.extension(),
                dropped.join(", ")
            );
        }
    }
    println!(
        "{} -> {}: {} points, {} cells, {} point arrays, {} cell arrays",
        a.input.display(),
        a.output.display(),
        mesh.num_points(),
        mesh.num_cells(),
        mesh.point_data.len(),
        mesh.cell_data.len()
    );
    Ok(())
}
