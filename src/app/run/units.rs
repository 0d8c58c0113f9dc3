//! Inputs whose size says they are not in millimetres.
//!
//! Mesh files carry no unit; unfold reads every coordinate as millimetres.
//! A placenta, a ventricle or a mitral valve exported in centimetres or
//! metres is ten or a thousand times too small, and its run fails on a size
//! (a margin that covers a whole side, a landmark far from the rim, a
//! leaflet within the ring's tolerance) without saying why. When an organ
//! command fails on its input and one of its mesh files is smaller than the
//! organ ([`OrganSize::smallest_mm`] across), the error says so, names the
//! unit the file is most likely in from the organ's size
//! ([`OrganSize::likely_unit`]) and how to scale it (`unfold convert IN OUT
//! --scale 10` for centimetres, `1000` for metres). Runs that succeed are
//! not second-guessed.
//!
//! An input larger than any organ ([`LARGEST_ORGAN_MM`] across: a mask
//! whose voxel size is wrong, a mesh in micrometres) is refused before
//! anything is meshed or solved ([`refuse_larger_than_an_organ`],
//! [`mask_side_mm`]): such a run would otherwise mesh or flatten for
//! minutes at the wrong scale.

use crate::app::AppError;
use crate::io::read_mesh;
use crate::mesh::Volume;
use crate::mesh::geometry::bounding_box;
use crate::mesh::nalgebra::Point3;
use std::path::{Path, PathBuf};

/// No organ unfold maps is smaller than this across (mm): a mitral annulus
/// is about 30 mm wide, a ventricle 50-120 mm long, a placenta 150-250 mm.
pub const SMALLEST_ORGAN_MM: f64 = 10.0;

/// No organ unfold maps is larger than this across (mm): a placenta is at
/// most about 350 mm, a dilated heart chamber 150 mm.
pub const LARGEST_ORGAN_MM: f64 = 1000.0;

/// The largest side of the bounding box of `positions` (mm) when it is
/// finite and over [`LARGEST_ORGAN_MM`]; `None` otherwise (an infinite
/// coordinate is left to the checks of the run).
pub fn too_large(positions: &[Point3<f64>]) -> Option<f64> {
    let side = bounding_box(positions)?.extent().max();
    (side.is_finite() && side > LARGEST_ORGAN_MM).then_some(side)
}

/// The largest side (mm) of the world bounding box of the voxels set in
/// the first frame of `mask`, each voxel taken as the box of half a voxel
/// about its centre (the 8 corners of the index box `[min - 1/2, max +
/// 1/2]` mapped by the affine); `None` for an empty mask.
pub fn mask_side_mm(mask: &Volume<bool>) -> Option<f64> {
    let [nx, ny, _, _] = mask.dims();
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    for (n, _) in mask
        .data()
        .iter()
        .take(mask.frame_len())
        .enumerate()
        .filter(|(_, set)| **set)
    {
        let ijk = [n % nx, (n / nx) % ny, n / (nx * ny)];
        for a in 0..3 {
            lo[a] = lo[a].min(ijk[a]);
            hi[a] = hi[a].max(ijk[a]);
        }
    }
    if lo[0] == usize::MAX {
        return None;
    }
    let corners: Vec<Point3<f64>> = (0..8)
        .map(|c: usize| {
            let pick = |a: usize| {
                if c >> a & 1 == 0 {
                    lo[a] as f64 - 0.5
                } else {
                    hi[a] as f64 + 0.5
                }
            };
            mask.voxel_to_world(&Point3::new(pick(0), pick(1), pick(2)))
        })
        .collect();
    Some(bounding_box(&corners)?.extent().max())
}

/// Refuses an input `path` whose organ spans `side_mm` (its bounding box's
/// largest side) when that is over [`LARGEST_ORGAN_MM`]
/// ([`AppError::LargerThanAnOrgan`], `fix` saying what to check).
///
/// # Errors
/// [`AppError::LargerThanAnOrgan`].
pub fn refuse_larger_than_an_organ(
    path: &Path,
    side_mm: Option<f64>,
    fix: impl FnOnce() -> String,
) -> Result<(), AppError> {
    match side_mm {
        Some(side) if side.is_finite() && side > LARGEST_ORGAN_MM => {
            Err(AppError::LargerThanAnOrgan {
                path: path.display().to_string(),
                side_mm: side,
                fix: fix(),
            })
        }
        _ => Ok(()),
    }
}

/// [`refuse_larger_than_an_organ`] for a mesh file `path` with these
/// points: the fix is to check its units.
///
/// # Errors
/// [`AppError::LargerThanAnOrgan`].
pub fn refuse_mesh_larger_than_an_organ(
    path: &Path,
    positions: &[Point3<f64>],
) -> Result<(), AppError> {
    refuse_larger_than_an_organ(path, too_large(positions), || {
        format!(
            "check the file's units (`unfold convert {} OUT --scale S` scales it to millimetres)",
            path.display()
        )
    })
}

/// [`refuse_larger_than_an_organ`] for a mask `path`: the fix is to check
/// the voxel size its header gives.
///
/// # Errors
/// [`AppError::LargerThanAnOrgan`].
pub fn refuse_mask_larger_than_an_organ(path: &Path, mask: &Volume<bool>) -> Result<(), AppError> {
    refuse_larger_than_an_organ(path, mask_side_mm(mask), || {
        let [a, b, c] = mask.spacing();
        format!(
            "check the voxel size in the image's header ({a} x {b} x {c} mm; a size in other \
             units or a wrong one makes the organ this large)"
        )
    })
}

/// A length unit a mesh file may have been written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetres, what unfold reads.
    Millimetres,
    /// Centimetres: 10 mm each.
    Centimetres,
    /// Metres: 1000 mm each.
    Metres,
}

impl LengthUnit {
    /// Millimetres per unit: the `--scale` that brings a file in this unit
    /// to millimetres.
    pub fn millimetres(self) -> f64 {
        match self {
            LengthUnit::Millimetres => 1.0,
            LengthUnit::Centimetres => 10.0,
            LengthUnit::Metres => 1000.0,
        }
    }

    /// The unit's name, plural.
    pub fn name(self) -> &'static str {
        match self {
            LengthUnit::Millimetres => "millimetres",
            LengthUnit::Centimetres => "centimetres",
            LengthUnit::Metres => "metres",
        }
    }
}

/// The sizes an organ comes in, as the largest side of its bounding box
/// in millimetres: a file smaller than `smallest_mm` is taken for one not
/// in millimetres, and the unit that brings it into `[typical_mm.0,
/// typical_mm.1]` is the one it is likely in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrganSize {
    /// Below this (mm), the file is not in millimetres.
    pub smallest_mm: f64,
    /// The organ's usual extent (mm): a human adult's and a large animal's.
    pub typical_mm: (f64, f64),
}

impl OrganSize {
    /// Any organ unfold maps (`info`, which does not know the organ).
    pub const ANY: OrganSize = OrganSize {
        smallest_mm: SMALLEST_ORGAN_MM,
        typical_mm: (10.0, 350.0),
    };
    /// A placenta in the second or third trimester: 100-350 mm across
    /// (150-250 mm at term); under 40 mm is not a placenta in millimetres.
    pub const PLACENTA: OrganSize = OrganSize {
        smallest_mm: 40.0,
        typical_mm: (100.0, 350.0),
    };
    /// A heart chamber, from a rabbit's (about 20 mm) to a dilated human
    /// one (150 mm); under 16 mm it may be one in centimetres (a failure on
    /// a smaller animal's heart in millimetres gets the note, worded "if").
    pub const VENTRICLE: OrganSize = OrganSize {
        smallest_mm: 16.0,
        typical_mm: (20.0, 150.0),
    };
    /// A mitral valve's leaflets: 20-70 mm across (the annulus about 30-40).
    pub const MITRAL: OrganSize = OrganSize {
        smallest_mm: SMALLEST_ORGAN_MM,
        typical_mm: (20.0, 70.0),
    };

    /// The largest side of the bounding box of `positions` when it is under
    /// [`OrganSize::smallest_mm`]; `None` for an organ-sized input or one
    /// without a point or with an infinite coordinate ([`bounding_box`]
    /// ignores NaN coordinates).
    pub fn too_small(&self, positions: &[Point3<f64>]) -> Option<f64> {
        let extent = bounding_box(positions)?.extent();
        let side = extent.max();
        (extent.iter().all(|x| x.is_finite()) && side < self.smallest_mm).then_some(side)
    }

    /// The unit a file whose largest side is `side` (in its own units) is
    /// most likely in: the one of centimetres and metres whose scaled side
    /// `side * u` lies in [`OrganSize::typical_mm`], or else lies nearest to
    /// it on a log scale (`|log(side u / t)|` to the nearer end `t`);
    /// millimetres when `side` is already organ-sized.
    pub fn likely_unit(&self, side: f64) -> LengthUnit {
        let (lo, hi) = self.typical_mm;
        let off = |unit: LengthUnit| {
            let mm = side * unit.millimetres();
            if mm < lo {
                (lo / mm).ln()
            } else if mm > hi {
                (mm / hi).ln()
            } else {
                0.0
            }
        };
        if side >= self.smallest_mm {
            return LengthUnit::Millimetres;
        }
        let (cm, m) = (off(LengthUnit::Centimetres), off(LengthUnit::Metres));
        if m < cm {
            LengthUnit::Metres
        } else {
            LengthUnit::Centimetres
        }
    }
}

/// The note a failure on an input smaller than an organ ends with: `name`
/// spans `side` (the largest side of its bounding box, in the file's
/// units), it is likely in `unit`, and `fix` says how to scale it.
pub fn note(name: &str, side: f64, unit: LengthUnit, fix: &str) -> String {
    format!(
        "note: {name} is only {side:.3} across (its bounding box's largest side), and unfold \
         reads coordinates as millimetres: if it is in {}, {fix}",
        unit.name()
    )
}

/// The fix of a mesh file `path` in `unit`: the `unfold convert` command
/// that scales it to millimetres.
pub fn convert_fix(path: &str, unit: LengthUnit) -> String {
    format!("`unfold convert {path} OUT --scale {}`", unit.millimetres())
}

/// `error` with the first of `inputs` that is smaller than `organ`
/// ([`OrganSize::too_small`]) named, with the unit it is likely in
/// ([`AppError::SmallerThanAnOrgan`]), when `error` is about the input (an
/// organ's or a mesh's error) and such a file exists; otherwise `error` as
/// it is. Files that cannot be read as meshes (an image, a text file of
/// points) are passed over.
pub(crate) fn with_units_hint(error: AppError, inputs: &[&Path], organ: OrganSize) -> AppError {
    if !matches!(error, AppError::Organ { .. } | AppError::Mesh(_)) {
        return error;
    }
    let small = inputs.iter().find_map(|path| {
        let mesh = read_mesh(path).ok()?;
        Some((path.to_path_buf(), organ.too_small(&mesh.positions)?))
    });
    match small {
        Some((path, side_mm)) => AppError::SmallerThanAnOrgan {
            source: Box::new(error),
            path: path.display().to_string(),
            side_mm,
            unit: organ.likely_unit(side_mm),
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
        assert_eq!(OrganSize::ANY.too_small(&p), Some(5.0));
        let organ = [Point3::new(0.0, 0.0, 0.0), Point3::new(0.0, 0.0, 10.0)];
        assert_eq!(OrganSize::ANY.too_small(&organ), None);
        let inf = [Point3::new(f64::INFINITY, 0.0, 0.0)];
        assert_eq!(OrganSize::ANY.too_small(&inf), None);
        assert_eq!(OrganSize::ANY.too_small(&[]), None);
        // a placenta 20 mm across is one in centimetres
        let cm = [Point3::new(0.0, 0.0, 0.0), Point3::new(20.0, 0.0, 0.0)];
        assert_eq!(OrganSize::PLACENTA.too_small(&cm), Some(20.0));
    }

    #[test]
    fn the_likely_unit_brings_the_organ_to_its_size() {
        use LengthUnit::*;
        let cases = [
            (OrganSize::VENTRICLE, 9.0, Centimetres),
            (OrganSize::VENTRICLE, 0.09, Metres),
            (OrganSize::VENTRICLE, 2.5, Centimetres),
            (OrganSize::VENTRICLE, 0.025, Metres),
            (OrganSize::VENTRICLE, 80.0, Millimetres),
            (OrganSize::PLACENTA, 22.0, Centimetres),
            (OrganSize::PLACENTA, 0.22, Metres),
            (OrganSize::MITRAL, 4.0, Centimetres),
            (OrganSize::MITRAL, 0.04, Metres),
            (OrganSize::ANY, 5.0, Centimetres),
            (OrganSize::ANY, 0.2, Metres),
        ];
        for (organ, side, unit) in cases {
            assert_eq!(organ.likely_unit(side), unit, "{organ:?} {side}");
        }
    }

    proptest::proptest! {
        /// An organ of any typical size written in centimetres or metres is
        /// recognised as such (when it is small enough to be noticed: a
        /// ventricle over 16 cm in centimetres is not).
        #[test]
        fn an_organ_in_any_unit_is_recognised(
            organ in proptest::sample::select(vec![
                OrganSize::PLACENTA, OrganSize::VENTRICLE, OrganSize::MITRAL,
            ]),
            at in 0.0..1.0f64,
            metres in proptest::bool::ANY,
        ) {
            let (lo, hi) = organ.typical_mm;
            let mm = lo * (hi / lo).powf(at);
            let unit = if metres { LengthUnit::Metres } else { LengthUnit::Centimetres };
            let side = mm / unit.millimetres();
            proptest::prop_assume!(side < organ.smallest_mm);
            proptest::prop_assert_eq!(organ.likely_unit(side), unit);
        }
    }

    /// A mask of 1000 x 1 x 1 mm voxels whose organ is 16 voxels long is
    /// 16 m across and refused, naming the extent and the voxel size; the
    /// same organ at 1 mm voxels is not; an empty mask has no extent.
    #[test]
    fn an_organ_over_a_metre_is_refused() {
        use crate::mesh::nalgebra::Matrix4;
        let dims = [20, 4, 4, 1];
        let mut data = vec![false; 20 * 16];
        for i in 2..18 {
            data[i + 20 + 20 * 4] = true;
        }
        let affine = Matrix4::new_nonuniform_scaling(&[1000.0, 1.0, 1.0].into());
        let long = Volume::new(dims, affine, data.clone()).unwrap();
        assert_eq!(mask_side_mm(&long), Some(16_000.0));
        let e = refuse_mask_larger_than_an_organ(Path::new("m.nii.gz"), &long).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, AppError::LargerThanAnOrgan { .. }), "{msg}");
        assert!(
            msg.contains("m.nii.gz: the organ is 16000 mm across"),
            "{msg}"
        );
        assert!(msg.contains("check the voxel size in the image's header (1000 x 1 x 1 mm"));
        let mm = Volume::new(dims, Matrix4::identity(), data).unwrap();
        assert_eq!(mask_side_mm(&mm), Some(16.0));
        assert!(refuse_mask_larger_than_an_organ(Path::new("m"), &mm).is_ok());
        let empty = Volume::filled(dims, Matrix4::identity(), false).unwrap();
        assert_eq!(mask_side_mm(&empty), None);
        // meshes: over a metre refused, a metre and infinities left alone
        let p = |x: f64| [Point3::origin(), Point3::new(x, 0.0, 0.0)];
        assert_eq!(too_large(&p(1500.0)), Some(1500.0));
        assert_eq!(too_large(&p(1000.0)), None);
        assert_eq!(too_large(&p(f64::INFINITY)), None);
        let e = refuse_mesh_larger_than_an_organ(Path::new("a.vtu"), &p(2e4)).unwrap_err();
        assert!(
            e.to_string().contains("unfold convert a.vtu OUT --scale S"),
            "{e}"
        );
    }

    #[test]
    fn errors_not_about_the_input_are_left_alone() {
        let e = with_units_hint(
            AppError::Usage("x".into()),
            &[Path::new("nowhere.vtu")],
            OrganSize::ANY,
        );
        assert!(matches!(e, AppError::Usage(_)));
    }
}
