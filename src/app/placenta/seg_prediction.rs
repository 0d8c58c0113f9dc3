//! What `placenta --seg` will cost, predicted from the mask before it is
//! meshed (a fetal-atlas case: `--seg --dense` on a fine mask made 2.7M tets and ran
//! past 300 s and 3.8 GB with no warning).
//!
//! With `V` the mask's volume (voxels set times the voxel volume), `A` its
//! surface area and `s` the lattice cube side:
//!
//! - tets: `13 V / s^3` uniform (the BCC fill's 12 tets per cube and the
//!   boundary's few more: 181,770 made against 180,622 predicted for a
//!   375 cm^3 disc at 3 mm); graded, at most that and about
//!   `10 A / s^2` (the grading keeps the boundary's tets and coarsens the
//!   inside: 8.3 to 9.3 `A / s^2` measured at 2 to 4 mm). `A` is the
//!   voxel faces between inside and outside times their areas, times 2/3
//!   (a staircase over a smooth surface has on average 1.5 times its
//!   area);
//! - memory: the mesher's own estimate, and [`BYTES_PER_TET`] per tet to
//!   flatten;
//! - time: [`TETS_PER_SECOND`] tets flattened (mesh, parcellation and
//!   solve) per second.

use crate::mesh::Volume;
use crate::mesh::memory::format_bytes;
use serde::{Deserialize, Serialize};

/// Tets per lattice cube of a uniform mesh (the mesher's fill).
pub const TETS_PER_CUBE: f64 = 13.0;
/// Tets of a graded mesh per `A / s^2`.
pub const GRADED_TETS_PER_FACE: f64 = 10.0;
/// Bytes a flattening takes per tet at its peak: 1.4 to 2.0 kB measured
/// (3.8 GB for 2.7M tets in a fetal-atlas case; 355 MB for 182k tets), kept above
/// both.
pub const BYTES_PER_TET: f64 = 2_500.0;
/// Tets a `placenta --seg` run gets through per second, meshing included:
/// 2,300 to 8,200 measured on two cores (release build, 8k to 182k tets);
/// the prediction is good to a factor of about two.
pub const TETS_PER_SECOND: f64 = 4_000.0;
/// A prediction above this many tets is worth a note.
pub const LARGE_TETS: f64 = 1.0e6;
/// A prediction above this many bytes is worth a note.
pub const LARGE_BYTES: f64 = 2.0 * 1024.0 * 1024.0 * 1024.0;
/// A prediction above this many seconds is worth a note.
pub const LONG_SECONDS: f64 = 300.0;
/// The tet count the note's `--size-mm` aims at: many times the published
/// meshes' and fast to flatten.
pub const SUGGESTED_TETS: f64 = 200_000.0;

/// `prediction` of `segmentation` in `report.json`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegPrediction {
    /// Predicted tets.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub tets: f64,
    /// Predicted bytes to flatten them.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub flatten_bytes: f64,
    /// Predicted seconds of the run.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub seconds: f64,
    /// The mask's surface area the graded count comes from, mm^2.
    #[serde(with = "crate::mesh::nan_as_null")]
    pub surface_mm2: f64,
}

/// The mask's volume (mm^3) and surface area (mm^2, module docs).
pub fn volume_and_area(mask: &Volume<bool>) -> (f64, f64) {
    let [nx, ny, nz, _] = mask.dims();
    let [sx, sy, sz] = mask.spacing();
    let data = &mask.data()[..mask.frame_len()];
    let voxel = mask.affine().fixed_view::<3, 3>(0, 0).determinant().abs();
    let at = |x: usize, y: usize, z: usize| data[x + nx * (y + ny * z)];
    let mut inside = 0usize;
    let mut faces = [0usize; 3];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if !at(x, y, z) {
                    continue;
                }
                inside += 1;
                let open = |a: usize, lo: bool| -> bool {
                    let (p, n) = match a {
                        0 => (x, nx),
                        1 => (y, ny),
                        _ => (z, nz),
                    };
                    if (lo && p == 0) || (!lo && p + 1 == n) {
                        return true;
                    }
                    let q = if lo { p - 1 } else { p + 1 };
                    !match a {
                        0 => at(q, y, z),
                        1 => at(x, q, z),
                        _ => at(x, y, q),
                    }
                };
                for (a, face) in faces.iter_mut().enumerate() {
                    *face += usize::from(open(a, true)) + usize::from(open(a, false));
                }
            }
        }
    }
    let area = faces[0] as f64 * sy * sz + faces[1] as f64 * sx * sz + faces[2] as f64 * sx * sy;
    (inside as f64 * voxel, area * 2.0 / 3.0)
}

impl SegPrediction {
    /// The prediction for `mask` meshed at cube side `size_mm`, graded or
    /// not (module docs).
    pub fn of(mask: &Volume<bool>, size_mm: f64, graded: bool) -> Self {
        let (volume, area) = volume_and_area(mask);
        let uniform = TETS_PER_CUBE * volume / size_mm.powi(3);
        let tets = if graded {
            uniform.min(GRADED_TETS_PER_FACE * area / size_mm.powi(2))
        } else {
            uniform
        };
        SegPrediction {
            tets,
            flatten_bytes: tets * BYTES_PER_TET,
            seconds: tets / TETS_PER_SECOND,
            surface_mm2: area,
        }
    }

    /// Whether the run is large enough for a note.
    pub fn is_large(&self) -> bool {
        self.tets > LARGE_TETS || self.flatten_bytes > LARGE_BYTES || self.seconds > LONG_SECONDS
    }

    /// The one-line note for a large prediction: what it predicts and the
    /// `--size-mm` that brings it near [`SUGGESTED_TETS`] (the count scales
    /// as `1 / s^3` uniform, `1 / s^2` graded).
    pub fn note(&self, size_mm: f64, graded: bool) -> String {
        let power = if graded { 2.0 } else { 3.0 };
        let suggested = size_mm * (self.tets / SUGGESTED_TETS).powf(1.0 / power);
        format!(
            "meshing at {size_mm:.2} mm predicts about {:.0}k tets, {} to flatten and {:.0} min; \
             bound it with --size-mm {:.1} (about {:.0}k tets{}) or --max-memory",
            self.tets / 1e3,
            format_bytes(self.flatten_bytes),
            (self.seconds / 60.0).ceil(),
            (suggested * 10.0).ceil() / 10.0,
            SUGGESTED_TETS / 1e3,
            if graded {
                ""
            } else {
                "; without --dense the interior is graded"
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block of `n^3` unit voxels in a margin of one voxel.
    fn block(n: usize) -> Volume<bool> {
        let m = n + 2;
        let inside = |p: usize| (1..=n).contains(&p);
        let mut bits = Vec::with_capacity(m * m * m);
        for z in 0..m {
            for y in 0..m {
                for x in 0..m {
                    bits.push(inside(x) && inside(y) && inside(z));
                }
            }
        }
        Volume::new([m, m, m, 1], nalgebra::Matrix4::identity(), bits).unwrap()
    }

    #[test]
    fn a_block_has_its_volume_and_two_thirds_of_its_faces() {
        let (v, a) = volume_and_area(&block(10));
        assert_eq!(v, 1000.0);
        assert!((a - 600.0 * 2.0 / 3.0).abs() < 1e-9, "{a}");
    }

    #[test]
    fn the_prediction_scales_with_the_size_and_the_note_names_the_flags() {
        let mask = block(20);
        let coarse = SegPrediction::of(&mask, 2.0, false);
        let fine = SegPrediction::of(&mask, 1.0, false);
        assert!((fine.tets / coarse.tets - 8.0).abs() < 1e-9);
        assert!(
            SegPrediction::of(&mask, 0.1, true).tets < SegPrediction::of(&mask, 0.1, false).tets
        );
        let huge = SegPrediction::of(&mask, 0.05, false);
        assert!(huge.is_large() && !coarse.is_large());
        let note = huge.note(0.05, false);
        assert!(
            note.contains("--size-mm") && note.contains("--max-memory"),
            "{note}"
        );
        assert!(!note.contains('\n'));
    }
}
