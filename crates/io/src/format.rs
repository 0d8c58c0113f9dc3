//! Choosing the format by file extension, and file-level read / write.

use crate::{IoError, NiftiImage, WriteOptions};
use std::io::Write;
use std::path::Path;
use unfold_mesh::{CellMesh, TetMesh, TriMesh};

const KNOWN: &str =
    ".vtk .vtu .vtp .ply .obj .stl .off .mesh .msh .nii .nii.gz .nrrd .seg.nrrd .nhdr";

/// The mesh formats unfold reads, and (all but Gmsh) writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// VTK legacy `.vtk` (POLYDATA or UNSTRUCTURED_GRID).
    Vtk,
    /// VTK XML unstructured grid `.vtu`.
    Vtu,
    /// VTK XML polydata `.vtp`.
    Vtp,
    /// Stanford `.ply`.
    Ply,
    /// Wavefront `.obj`.
    Obj,
    /// `.stl` (triangles only, f32).
    Stl,
    /// `.off`.
    Off,
    /// Medit / INRIA `.mesh`.
    Medit,
    /// Gmsh `.msh` 2.2 and 4.1 (read only).
    Gmsh,
}

impl MeshFormat {
    /// Every mesh format.
    pub const ALL: [MeshFormat; 9] = [
        MeshFormat::Vtk,
        MeshFormat::Vtu,
        MeshFormat::Vtp,
        MeshFormat::Ply,
        MeshFormat::Obj,
        MeshFormat::Stl,
        MeshFormat::Off,
        MeshFormat::Medit,
        MeshFormat::Gmsh,
    ];

    /// The usual file extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            MeshFormat::Vtk => "vtk",
            MeshFormat::Vtu => "vtu",
            MeshFormat::Vtp => "vtp",
            MeshFormat::Ply => "ply",
            MeshFormat::Obj => "obj",
            MeshFormat::Stl => "stl",
            MeshFormat::Off => "off",
            MeshFormat::Medit => "mesh",
            MeshFormat::Gmsh => "msh",
        }
    }

    /// Whether unfold can write this format.
    pub fn writable(self) -> bool {
        self != MeshFormat::Gmsh
    }

    /// Whether the format stores volume cells (tets).
    pub fn holds_volume_cells(self) -> bool {
        matches!(
            self,
            MeshFormat::Vtk | MeshFormat::Vtu | MeshFormat::Medit | MeshFormat::Gmsh
        )
    }

    /// Whether the format stores arbitrary named point and cell arrays.
    pub fn holds_arrays(self) -> bool {
        matches!(
            self,
            MeshFormat::Vtk | MeshFormat::Vtu | MeshFormat::Vtp | MeshFormat::Ply
        )
    }

    /// Whether positions are stored as f32 only (so f64 input is rounded).
    pub fn single_precision(self) -> bool {
        self == MeshFormat::Stl
    }

    /// Parses bytes in this format.
    pub fn read_bytes(self, bytes: &[u8]) -> Result<CellMesh, IoError> {
        let mesh = match self {
            MeshFormat::Vtk => crate::vtk_legacy::read(bytes),
            MeshFormat::Vtu | MeshFormat::Vtp => crate::vtk_xml::read(bytes),
            MeshFormat::Ply => crate::ply::read(bytes),
            MeshFormat::Obj => crate::obj::read(bytes),
            MeshFormat::Stl => crate::stl::read(bytes),
            MeshFormat::Off => crate::off::read(bytes),
            MeshFormat::Medit => crate::medit::read(bytes),
            MeshFormat::Gmsh => crate::gmsh::read(bytes),
        }?;
        mesh.check()?;
        Ok(mesh)
    }

    /// Serializes a mesh in this format.
    pub fn write_bytes(self, mesh: &CellMesh, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
        mesh.check()?;
        match self {
            MeshFormat::Vtk => crate::vtk_legacy::write(mesh, opts),
            MeshFormat::Vtu => crate::vtk_xml::write_vtu(mesh, opts),
            MeshFormat::Vtp => crate::vtk_xml::write_vtp(mesh, opts),
            MeshFormat::Ply => crate::ply::write(mesh, opts),
            MeshFormat::Obj => crate::obj::write(mesh, opts),
            MeshFormat::Stl => crate::stl::write(mesh, opts),
            MeshFormat::Off => crate::off::write(mesh, opts),
            MeshFormat::Medit => crate::medit::write(mesh, opts),
            MeshFormat::Gmsh => Err(IoError::unsupported(
                "writing Gmsh .msh is not supported; write .vtu or .mesh instead",
            )),
        }
    }
}

/// What a file holds, judged by its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// A mesh in the given format.
    Mesh(MeshFormat),
    /// A NIfTI image (`gzip` for `.nii.gz`).
    Nifti {
        /// Whether the file is gzip-compressed.
        gzip: bool,
    },
    /// A NRRD image: `.nrrd` (also Slicer's `.seg.nrrd`) or `.nhdr`.
    Nrrd {
        /// Whether the header is detached (`.nhdr`, data in another file).
        detached: bool,
    },
}

impl FileKind {
    /// The kind of `path` from its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<FileKind, IoError> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if name.ends_with(".nii.gz") {
            return Ok(FileKind::Nifti { gzip: true });
        }
        let ext = name.rsplit_once('.').map(|(_, e)| e).unwrap_or("");
        match ext {
            "nii" => return Ok(FileKind::Nifti { gzip: false }),
            "nrrd" => return Ok(FileKind::Nrrd { detached: false }),
            "nhdr" => return Ok(FileKind::Nrrd { detached: true }),
            _ => {}
        }
        MeshFormat::ALL
            .into_iter()
            .find(|f| f.extension() == ext)
            .map(FileKind::Mesh)
            .ok_or_else(|| IoError::UnknownFormat {
                path: crate::FilePath(path.to_path_buf()),
                known: KNOWN,
            })
    }

    /// Whether this is an image (NIfTI or NRRD), read with [`read_image`].
    pub fn is_image(self) -> bool {
        !matches!(self, FileKind::Mesh(_))
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|source| IoError::Io {
        path: crate::FilePath(path.to_path_buf()),
        source,
    })
}

fn mesh_format(path: &Path) -> Result<MeshFormat, IoError> {
    match FileKind::from_path(path)? {
        FileKind::Mesh(f) => Ok(f),
        FileKind::Nifti { .. } | FileKind::Nrrd { .. } => Err(IoError::unsupported(
            "this is an image (NIfTI or NRRD), not a mesh",
        )
        .with_path(path)),
    }
}

/// Reads a mesh file of any supported format (by extension).
pub fn read_mesh(path: impl AsRef<Path>) -> Result<CellMesh, IoError> {
    let path = path.as_ref();
    let format = mesh_format(path)?;
    let bytes = read_file(path)?;
    format.read_bytes(&bytes).map_err(|e| e.with_path(path))
}

/// Reads a surface mesh (triangles; quads and polygons are split).
pub fn read_tri_mesh(path: impl AsRef<Path>) -> Result<TriMesh, IoError> {
    let path = path.as_ref();
    read_mesh(path)?
        .to_tri_mesh()
        .map_err(|e| IoError::from(e).with_path(path))
}

/// Reads a tetrahedral mesh.
pub fn read_tet_mesh(path: impl AsRef<Path>) -> Result<TetMesh, IoError> {
    let path = path.as_ref();
    read_mesh(path)?
        .to_tet_mesh()
        .map_err(|e| IoError::from(e).with_path(path))
}

/// Writes a mesh in the format of `path`'s extension, atomically.
pub fn write_mesh(
    path: impl AsRef<Path>,
    mesh: &CellMesh,
    opts: &WriteOptions,
) -> Result<(), IoError> {
    let path = path.as_ref();
    let format = mesh_format(path)?;
    let bytes = format
        .write_bytes(mesh, opts)
        .map_err(|e| e.with_path(path))?;
    atomic_write(path, &bytes)
}

/// Reads an image: NIfTI-1 (`.nii`, `.nii.gz`) or NRRD (`.nrrd`,
/// `.seg.nrrd`, `.nhdr` with its data file beside it). The header is read
/// first and the values are decoded as they are read (or inflated), so the
/// memory used is the values' (`4 ×` voxels bytes) plus about 1 MiB.
pub fn read_image(path: impl AsRef<Path>) -> Result<NiftiImage, IoError> {
    let path = path.as_ref();
    match image_kind(path)? {
        FileKind::Nrrd { .. } => crate::nrrd::read_file(path),
        _ => crate::nifti::read_file(path),
    }
    .map_err(|e| e.with_path(path))
}

/// The kind of an image path; a mesh path is refused.
pub(crate) fn image_kind(path: &Path) -> Result<FileKind, IoError> {
    match FileKind::from_path(path)? {
        FileKind::Mesh(_) => {
            Err(IoError::unsupported("this is a mesh, not an image").with_path(path))
        }
        kind => Ok(kind),
    }
}

/// Opens a file for reading, with its length.
pub(crate) fn open(path: &Path) -> Result<(std::fs::File, u64), IoError> {
    let err = |source| IoError::Io {
        path: crate::FilePath(path.to_path_buf()),
        source,
    };
    let f = std::fs::File::open(path).map_err(err)?;
    let len = f.metadata().map_err(err)?.len();
    Ok((f, len))
}

/// Writes an image atomically: NIfTI-1 (gzip-compressed for `.nii.gz`) or
/// NRRD (`.nrrd`, gzip-encoded with an attached header). Writing `.nhdr` is
/// refused (write `.nrrd`).
pub fn write_image(path: impl AsRef<Path>, image: &NiftiImage) -> Result<(), IoError> {
    let path = path.as_ref();
    let bytes = match FileKind::from_path(path)? {
        FileKind::Nifti { gzip } => crate::nifti::write(image, gzip),
        FileKind::Nrrd { detached: false } => crate::nrrd::write(image),
        FileKind::Nrrd { detached: true } => Err(IoError::unsupported(
            "writing a detached NRRD header (.nhdr) is not supported; write .nrrd \
             (one file, header attached)",
        )),
        FileKind::Mesh(_) => Err(IoError::unsupported(
            "images are written as .nii, .nii.gz or .nrrd",
        )),
    }
    .map_err(|e| e.with_path(path))?;
    atomic_write(path, &bytes)
}

/// Writes `bytes` to `path` atomically: a temporary file
/// `.unfold-<pid>-<rand>.tmp` in the same directory is written, flushed to
/// disk, then renamed over `path`. A new
/// file gets the permissions of any new file (`0666` less the umask); a
/// replaced file keeps its own.
pub fn atomic_write(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), IoError> {
    let path = path.as_ref();
    let err = |source: std::io::Error| IoError::Io {
        path: crate::FilePath(path.to_path_buf()),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    // `.unfold-<pid>-<rand>.tmp`: the pid tells the next run whether the
    // writer is gone (the application's `clean_stale`).
    let prefix = format!(".unfold-{}-", std::process::id());
    builder.prefix(&prefix).suffix(".tmp");
    // Created like any new file, 0666 less the process umask (so a umask of
    // 077 keeps patient data private), not tempfile's private 0600.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(err)?;
    tmp.write_all(bytes).map_err(err)?;
    // A file replaced keeps its permissions.
    if let Ok(m) = std::fs::metadata(path) {
        tmp.as_file()
            .set_permissions(m.permissions())
            .map_err(err)?;
    }
    tmp.as_file().sync_all().map_err(err)?;
    tmp.persist(path).map_err(|e| err(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_by_extension() {
        assert_eq!(
            FileKind::from_path(Path::new("a/B.VTU")).unwrap(),
            FileKind::Mesh(MeshFormat::Vtu)
        );
        assert_eq!(
            FileKind::from_path(Path::new("x.nii.gz")).unwrap(),
            FileKind::Nifti { gzip: true }
        );
        assert_eq!(
            FileKind::from_path(Path::new("brain.seg.NRRD")).unwrap(),
            FileKind::Nrrd { detached: false }
        );
        assert_eq!(
            FileKind::from_path(Path::new("a.nhdr")).unwrap(),
            FileKind::Nrrd { detached: true }
        );
        assert!(FileKind::from_path(Path::new("a.nhdr")).unwrap().is_image());
        assert!(!FileKind::from_path(Path::new("a.vtk")).unwrap().is_image());
        let e = FileKind::from_path(Path::new("x.xyz")).unwrap_err();
        assert!(e.to_string().contains("x.xyz"), "{e}");
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.txt");
        atomic_write(&p, b"one").unwrap();
        atomic_write(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // The process umask, from /proc (Linux); 022 where unknown.
            let umask = std::fs::read_to_string("/proc/self/status")
                .ok()
                .and_then(|s| {
                    s.lines()
                        .find_map(|l| l.strip_prefix("Umask:"))
                        .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
                })
                .unwrap_or(0o022);
            let mode = std::fs::metadata(&p).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o666 & !umask);
            // A replaced file keeps its permissions.
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
            atomic_write(&p, b"three").unwrap();
            let mode = std::fs::metadata(&p).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o640);
        }
    }

    #[test]
    fn nrrd_files_by_extension() {
        let dir = tempfile::tempdir().unwrap();
        let vol = unfold_mesh::Volume::new(
            [2, 1, 1, 1],
            nalgebra::Matrix4::identity(),
            vec![1.0f32, 2.0],
        )
        .unwrap();
        let img = NiftiImage::new(vol);
        let p = dir.path().join("brain.seg.nrrd");
        write_image(&p, &img).unwrap();
        assert_eq!(read_image(&p).unwrap().volume, img.volume);
        let e = write_image(dir.path().join("x.nhdr"), &img).unwrap_err();
        assert!(e.to_string().contains("write .nrrd"), "{e}");
        // A detached header finds its data file beside it.
        std::fs::write(dir.path().join("d.raw"), [3u8, 4]).unwrap();
        std::fs::write(
            dir.path().join("d.nhdr"),
            "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n\
             data file: d.raw\n",
        )
        .unwrap();
        let d = read_image(dir.path().join("d.nhdr")).unwrap();
        assert_eq!(d.volume.data(), &[3.0, 4.0]);
        let e = read_mesh(&p).unwrap_err();
        assert!(e.to_string().contains("not a mesh"), "{e}");
    }

    #[test]
    fn missing_file_error_names_it() {
        let e = read_mesh("/nonexistent/dir/m.vtu").unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/dir/m.vtu: "), "{e}");
    }
}
