//! Files a run reads and writes beside its meshes: images read within the
//! memory budget, directories, canonical paths for comparisons, figures.

use super::memory;
use crate::app::error::{AppError, at};
use std::path::PathBuf;

/// Reads an image after checking that its values fit the run's memory:
/// the header alone first ([`crate::io::read_image_header`]), then
/// `voxels x 4` bytes (the values as `f32`, decoded as they are read) plus
/// `voxels x extra_per_voxel` for what the caller derives from them (a
/// mask: 1 byte per voxel) and a 1 MiB read buffer, checked before the
/// values are read.
///
/// # Errors
/// The readers' errors; [`AppError::Memory`] when the values do not fit.
pub fn read_image_checked(
    path: &std::path::Path,
    extra_per_voxel: f64,
) -> Result<crate::io::NiftiImage, AppError> {
    let header = crate::io::read_image_header(path)?;
    let voxels = header.value_count() as f64;
    let estimate = crate::mesh::memory::MemoryEstimate::new()
        .with("image values", voxels, 4.0 + extra_per_voxel)
        .with("read buffer", 1.0, 1024.0 * 1024.0);
    memory::check(
        "reading the image",
        &estimate,
        "crop or resample the image (its header declares more voxels than fit), or raise \
         --max-memory",
    )
    .map_err(|e| at(path, e))?;
    Ok(crate::io::read_image(path)?)
}

/// Creates `dir` (and parents) if needed.
pub fn ensure_dir(dir: &std::path::Path) -> Result<(), AppError> {
    std::fs::create_dir_all(dir).map_err(|source| AppError::Fs {
        path: dir.display().to_string(),
        source,
    })
}

/// Canonical form of a path for comparisons (falls back to the path itself).
pub fn canonical(p: &std::path::Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
}

/// Writes `figures` as PNG files into `dir/figures/` (created if missing),
/// each atomically; returns the paths written.
pub fn write_figures(
    dir: &std::path::Path,
    figures: &[crate::figures::Figure],
) -> Result<Vec<PathBuf>, AppError> {
    let out = dir.join("figures");
    ensure_dir(&out)?;
    let mut written = Vec::with_capacity(figures.len());
    for f in figures {
        let path = out.join(&f.name);
        let png = f
            .image
            .to_png()
            .map_err(|e| at(&path, format!("cannot encode the figure: {e}")))?;
        crate::io::atomic_write(&path, &png)?;
        written.push(path);
    }
    Ok(written)
}
