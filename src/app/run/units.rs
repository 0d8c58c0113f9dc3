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

use crate::app::AppError;
use crate::io::read_mesh;
use crate::mesh::geometry::bounding_box;
use crate::mesh::nalgebra::Point3;
use std::path::{Path, PathBuf};

/// No organ unfold maps is smaller than this across (mm): a mitral annulus
/// is about 30 mm wide, a ventricle 50-120 mm long, a placenta 150-250 mm.
pub const SMALLEST_ORGAN_MM: f64 = 10.0;

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
