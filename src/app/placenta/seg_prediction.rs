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
//! - memory: the mesher's own estimate, and [`FLATTEN_BASE_BYTES`] plus
//!   [`BYTES_PER_TET`] per tet to flatten (the run's peak: linear in the
//!   tets on both solvers' ranges);
//! - time: the whole command's seconds follow the tets of the uniform
//!   lattice `13 V / s^3`, graded or not: [`DENSE_TETS_PER_SECOND`] of them
//!   per second uniform (meshing and flattening), [`GRADED_LATTICE_TETS_PER_SECOND`]
//!   graded (meshing, grading that lattice down, and flattening far fewer
//!   tets: the grading is most of it).

use crate::mesh::Volume;
use crate::mesh::memory::{MemoryEstimate, format_bytes};
use serde::{Deserialize, Serialize};

/// Tets per lattice cube of a uniform mesh (the mesher's fill).
pub const TETS_PER_CUBE: f64 = 13.0;
/// Tets of a graded mesh per `A / s^2`.
pub const GRADED_TETS_PER_FACE: f64 = 10.0;
/// Bytes a flattening takes per tet at its peak, beyond
/// [`FLATTEN_BASE_BYTES`]: fitted on `benches/placenta_dense.py` (the
/// 105 x 85 x 20 mm ellipsoid at 5 to 1.5 mm), whose uniform peaks are
/// 136 MiB plus 1,380 B per tet from 145k to 2.72M tets (multigrid). With
/// 1,600 B and 384 MiB the prediction is 1.22 to 1.37 times the measured
/// uniform peak at 79k (Cholesky) and from 594k to 2.72M tets (4.4 GiB
/// against 3.63 GiB at 2.72M; 4.7 GiB for the 2.88M tets the mask
/// predicts), 1.55 to 1.85 between (145k to 348k), and 1.2 to 2.8 times
/// the graded runs' (20k to 259k tets). The earlier 2,500 B alone predicted 6.7 GiB at 2.72M
/// and fell below the peaks of meshes under 150k tets (0.34 to 0.84 times).
pub const BYTES_PER_TET: f64 = 1_600.0;
/// The fixed part of a flattening's peak (the process, the mesh's
/// resident arrays' fixed part and the margin that keeps the Cholesky
/// runs, whose factor grows faster than the mesh, below: the 79k-tet
/// uniform run peaks at 368 MiB, predicted 504 MiB).
pub const FLATTEN_BASE_BYTES: f64 = 384.0 * 1024.0 * 1024.0;
/// Uniform-lattice tets a `placenta --seg --dense` run gets through per
/// second, meshing included: 2,723,676 tets in 75.3 s on two idle cores
/// (release build, 98.8 s of CPU). On the smaller masks of
/// `benches/placenta_dense.py` (79k to 1.16M tets) the CPU seconds per
/// tet are 1.0 to 1.5 times the 2.72M run's, so the prediction is good to
/// a factor of about 1.5 from 79k tets up.
pub const DENSE_TETS_PER_SECOND: f64 = 36_000.0;
/// Uniform-lattice tets a graded `placenta --seg` run gets through per
/// second: the lattice of `13 V / s^3` tets is meshed and graded down
/// before the far fewer graded tets are flattened, and the time follows
/// the lattice (19.5 to 28 us of CPU per lattice tet from 79k to 2.72M
/// lattice tets, against 84 to 205 us per graded tet, which a rate per
/// graded tet would miss by 2.5 times). Fitted on two idle cores:
/// the 2,723,676-tet lattice graded to 258,554 tets in 37.2 s (53.1 s of
/// CPU), the planes template.
pub const GRADED_LATTICE_TETS_PER_SECOND: f64 = 73_000.0;
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
        let (tets, seconds) = if graded {
            (
                uniform.min(GRADED_TETS_PER_FACE * area / size_mm.powi(2)),
                uniform / GRADED_LATTICE_TETS_PER_SECOND,
            )
        } else {
            (uniform, uniform / DENSE_TETS_PER_SECOND)
        };
        SegPrediction {
            tets,
            flatten_bytes: Self::estimate_for(tets).total(),
            seconds,
            surface_mm2: area,
        }
    }

    /// The flattening's memory for `tets` tets, by part:
    /// [`FLATTEN_BASE_BYTES`] and [`BYTES_PER_TET`] per tet.
    pub fn estimate_for(tets: f64) -> MemoryEstimate {
        MemoryEstimate::new()
            .with("base", 1.0, FLATTEN_BASE_BYTES)
            .with("tets", tets, BYTES_PER_TET)
    }

    /// The flattening's memory of this prediction, by part
    /// ([`SegPrediction::estimate_for`]).
    pub fn estimate(&self) -> MemoryEstimate {
        Self::estimate_for(self.tets)
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

    /// Measured `placenta --seg` runs of `benches/placenta_dense.py` (the
    /// 105 x 85 x 20 mm ellipsoid): (cube mm, graded, tets, peak MiB).
    const MEASURED: [(f64, bool, f64, f64); 12] = [
        (5.0, false, 78_880.0, 368.0),
        (5.0, true, 20_266.0, 146.0),
        (4.0, false, 145_088.0, 327.0),
        (4.0, true, 30_512.0, 178.0),
        (3.0, false, 348_004.0, 590.0),
        (3.0, true, 58_591.0, 295.0),
        (2.5, false, 594_436.0, 939.0),
        (2.5, true, 86_235.0, 283.0),
        (2.0, false, 1_155_096.0, 1663.0),
        (2.0, true, 139_096.0, 375.0),
        (1.5, false, 2_723_676.0, 3717.0),
        (1.5, true, 258_554.0, 635.0),
    ];

    /// The fitted memory relation: above every measured peak (it gates
    /// refusal), and within 1.6 times it from 1M tets up.
    #[test]
    fn the_flattening_prediction_stays_above_the_measured_peaks_and_near_the_large_ones() {
        for (size, graded, tets, peak_mib) in MEASURED {
            let peak = peak_mib * 1024.0 * 1024.0;
            let predicted = SegPrediction::estimate_for(tets).total();
            assert!(
                predicted > peak,
                "{size} mm graded {graded}: {predicted} B predicted below the measured {peak} B"
            );
            if tets >= 1.0e6 {
                assert!(
                    predicted < 1.6 * peak,
                    "{size} mm: {predicted} B predicted, {peak} B measured"
                );
            }
        }
    }

    /// The fitted time relation on the two idle runs at 1.5 mm (75.3 s
    /// uniform, 37.2 s graded, both from the 2,723,676-tet lattice):
    /// within a factor of 1.25 either way.
    #[test]
    fn the_time_follows_the_lattice_uniform_and_graded() {
        let mask = block(20);
        let (volume, _) = volume_and_area(&mask);
        // the cube side whose uniform lattice has the measured 2.72M tets
        let size = (TETS_PER_CUBE * volume / 2_723_676.0).cbrt();
        for (graded, measured) in [(false, 75.3), (true, 37.2)] {
            let seconds = SegPrediction::of(&mask, size, graded).seconds;
            assert!(
                (seconds / measured - 1.0).abs() < 0.25,
                "graded {graded}: {seconds} s predicted, {measured} s measured"
            );
        }
    }
}
