//! Inputs whose size says they are not in millimetres.
//!
//! Mesh files carry no unit; unfold reads every coordinate as millimetres.
//! A placenta, a ventricle or a mitral valve exported in metres is a
//! thousand times too small, and its run fails on a size (a margin that
//! covers a whole side, a landmark far from the rim, a leaflet within the
//! ring's tolerance) without saying why. When an organ command fails on its
//! input and one of its mesh files is smaller than any organ it maps
//! ([`SMALLEST_ORGAN_MM`] across), the error says so and how to scale the
//! file (`unfold convert IN OUT --scale 1000`). Runs that succeed are not
//! second-guessed.

use crate::app::AppError;
use crate::io::read_mesh;
use crate::mesh::geometry::bounding_box;
use crate::mesh::nalgebra::Point3;
use std::path::{Path, PathBuf};

/// No organ unfold maps is smaller than this across (mm): a mitral annulus
/// is about 30 mm wide, a ventricle 50-120 mm long, a placenta 150-250 mm.
pub const SMALLEST_ORGAN_MM: f64 = 10.0;

/// The note a failure on an input smaller than an organ ends with: `name`
/// spans `side` (the largest side of its bounding box, in the file's
/// units), and `fix` says how to scale it.
pub fn note(name: &str, side: f64, fix: &str) -> String {
    format!(
        "note: {name} is only {side:.3} across (its bounding box's largest side), and unfold \
         reads coordinates as millimetres: {fix}"
    )
}

/// The largest side of the bounding box of `positions` when it is under
/// [`SMALLEST_ORGAN_MM`]; `None` for an organ-sized input or one without a
/// point or with an infinite coordinate ([`bounding_box`] ignores NaN
/// coordinates).
pub fn smaller_than_an_organ(positions: &[Point3<f64>]) -> Option<f64> {
    let extent = bounding_box(positions)?.extent();
    let side = extent.max();
    (extent.iter().all(|x| x.is_finite()) && side < SMALLEST_ORGAN_MM).then_some(side)
}

/// `error` with the first of `inputs` that is smaller than
/// [`SMALLEST_ORGAN_MM`] named ([`AppError::SmallerThanAnOrgan`]), when
/// `error` is about the input (an organ's or a mesh's error) and such a file
/// exists; otherwise `error` as it is. Files that cannot be read as meshes
/// (an image, a text file of points) are passed over.
pub(crate) fn with_units_hint(error: AppError, inputs: &[&Path]) -> AppError {
    if !matches!(error, AppError::Organ { .. } | AppError::Mesh(_)) {
        return error;
    }
    let small = inputs.iter().find_map(|path| {
        let mesh = read_mesh(path).ok()?;
        Some((path.to_path_buf(), smaller_than_an_organ(&mesh.positions)?))
    });
    match small {
        Some((path, side_mm)) => AppError::SmallerThanAnOrgan {
            source: Box::new(error),
            path: path.display().to_string(),
            side_mm,
        },
        None => error,
    }
}

/// The mesh files of an organ command, for [`with_units_hint`].
pub(crate) fn mesh_inputs(paths: &[&Option<PathBuf>]) -> Vec<PathBuf> {
    paths.iter().filter_map(|p| p.as_ref().cloned()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_inputs_under_an_organ_s_size_are_small() {
        let p = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(f64::NAN, 5.0, 1.0),
            Point3::new(2.0, 3.0, -1.0),
        ];
        assert_eq!(smaller_than_an_organ(&p), Some(5.0));
        let organ = [Point3::new(0.0, 0.0, 0.0), Point3::new(0.0, 0.0, 10.0)];
        assert_eq!(smaller_than_an_organ(&organ), None);
        assert_eq!(
            smaller_than_an_organ(&[Point3::new(f64::INFINITY, 0.0, 0.0)]),
            None
        );
        assert_eq!(smaller_than_an_organ(&[]), None);
    }

    #[test]
    fn errors_not_about_the_input_are_left_alone() {
        let e = with_units_hint(AppError::Usage("x".into()), &[Path::new("nowhere.vtu")]);
        assert!(matches!(e, AppError::Usage(_)));
    }
}
