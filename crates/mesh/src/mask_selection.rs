//! Which voxels of a segmentation image are the object: the first step of
//! meshing a mask.
//!
//! Segmentations come as an image holding 0 outside and one other value
//! inside (1, 255 or a label number, whatever the tool wrote), as a label
//! map with several structures (the placenta 1, the uterus 2, ...), or as a
//! probability or intensity map. [`MaskSelection`] says which voxels are
//! inside: the one nonzero value of a two-valued image (the default), the
//! voxels equal to a label, or those above a threshold. A label map without
//! a label, or a label the image does not hold, is refused naming the
//! values it holds ([`MeshError::MaskValues`], [`MeshError::MaskLabelAbsent`]).

use crate::{MeshError, Volume};

/// How many distinct nonzero values an error lists at most.
pub const LISTED_VALUES: usize = 8;

/// How many distinct nonzero values are counted at most (an intensity image
/// has millions; their count is not worth the memory).
pub const COUNTED_VALUES: usize = 1 << 16;

/// Which voxels of an image are inside the mask.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum MaskSelection {
    /// The image's one value other than 0 (an image holding 0 and one
    /// other value; all voxels inside when it holds that value alone).
    #[default]
    Nonzero,
    /// The voxels equal to this label (a label map).
    Label(f64),
    /// The voxels above this value.
    Above(f64),
}

/// The mask of `image`'s voxels that `selection` says are inside, with
/// `image`'s dims and affine.
///
/// # Errors
/// `Image` for a 4D image or a NaN voxel; `InvalidArgument` for a label or
/// threshold that is not finite; [`MeshError::MaskValues`] for
/// [`MaskSelection::Nonzero`] on an image with two or more values besides 0;
/// [`MeshError::MaskLabelAbsent`] for a label no voxel holds.
pub fn mask_from_image<T: Copy + Into<f64>>(
    image: &Volume<T>,
    selection: MaskSelection,
) -> Result<Volume<bool>, MeshError> {
    let d = image.dims();
    if d[3] != 1 {
        return Err(MeshError::Image(format!(
            "a mask must be a 3D image, got {} frames (dims {}x{}x{}x{})",
            d[3], d[0], d[1], d[2], d[3]
        )));
    }
    match selection {
        MaskSelection::Label(v) | MaskSelection::Above(v) if !v.is_finite() => {
            return Err(MeshError::InvalidArgument(format!(
                "a mask's label or threshold must be finite, got {v}"
            )));
        }
        _ => {}
    }
    // One pass (an image may be large): the bits, NaNs refused, and for
    // the default selection the distinct values besides 0.
    let values = || image.data().iter().map(|&x| -> f64 { x.into() });
    let mut distinct = NonzeroValues::default();
    let mut bits = Vec::with_capacity(image.data().len());
    for (i, x) in values().enumerate() {
        if x.is_nan() {
            return Err(MeshError::Image(format!("the mask has a NaN at voxel {i}")));
        }
        bits.push(match selection {
            MaskSelection::Above(t) => x > t,
            MaskSelection::Label(label) => x == label,
            MaskSelection::Nonzero => {
                distinct.see(x);
                x != 0.0
            }
        });
    }
    match selection {
        MaskSelection::Nonzero if distinct.count() > 1 => {
            let (values, more, all_counted) = distinct.listed();
            Err(MeshError::MaskValues {
                values,
                more,
                all_counted,
            })
        }
        MaskSelection::Label(label) if !bits.contains(&true) => {
            // (a failure: a second pass to name what the image holds)
            let mut held = NonzeroValues::default();
            values().for_each(|x| held.see(x));
            let (values, more, all_counted) = held.listed();
            Err(MeshError::MaskLabelAbsent {
                label,
                values,
                more,
                all_counted,
            })
        }
        _ => Volume::new(d, *image.affine(), bits),
    }
}

/// The distinct nonzero values of an image (up to [`COUNTED_VALUES`]),
/// seen one voxel at a time.
#[derive(Default)]
struct NonzeroValues {
    /// Their bit patterns (no NaN comes here; 0 and -0 are skipped).
    seen: std::collections::HashSet<u64>,
    /// The first [`LISTED_VALUES`] of them.
    first: Vec<f64>,
    /// The last value seen (runs of one value are the common case).
    last: f64,
    /// Whether a value was passed over because `seen` was full.
    overflowed: bool,
}

impl NonzeroValues {
    fn see(&mut self, x: f64) {
        if x == 0.0 || x == self.last {
            return;
        }
        self.last = x;
        if self.seen.len() == COUNTED_VALUES {
            self.overflowed |= !self.seen.contains(&x.to_bits());
        } else if self.seen.insert(x.to_bits()) && self.first.len() < LISTED_VALUES {
            self.first.push(x);
        }
    }

    fn count(&self) -> usize {
        self.seen.len()
    }

    /// The first [`LISTED_VALUES`] values, ascending, how many more were
    /// counted, and whether that is all of them.
    fn listed(mut self) -> (Vec<f64>, usize, bool) {
        self.first.sort_by(f64::total_cmp);
        let more = self.seen.len() - self.first.len();
        (self.first, more, !self.overflowed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix4;
    use proptest::prelude::*;

    fn image(values: Vec<f32>) -> Volume<f32> {
        let n = values.len();
        Volume::new([n, 1, 1, 1], Matrix4::identity(), values).unwrap()
    }

    fn inside(m: &Volume<bool>) -> Vec<usize> {
        (0..m.data().len()).filter(|&i| m.data()[i]).collect()
    }

    #[test]
    fn a_two_valued_image_is_its_nonzero_value() {
        for v in [1.0, 255.0, 3.0, -1.0] {
            let m = mask_from_image(&image(vec![0.0, v, v, 0.0]), MaskSelection::Nonzero).unwrap();
            assert_eq!(inside(&m), [1, 2]);
        }
        // one value alone: every voxel inside
        let m = mask_from_image(&image(vec![7.0; 3]), MaskSelection::Nonzero).unwrap();
        assert_eq!(inside(&m), [0, 1, 2]);
    }

    #[test]
    fn a_label_map_needs_a_label_and_lists_its_values() {
        let labels = image(vec![0.0, 2.0, 1.0, 2.0, 0.0, 3.0]);
        let e = mask_from_image(&labels, MaskSelection::Nonzero).unwrap_err();
        assert_eq!(
            e,
            MeshError::MaskValues {
                values: vec![1.0, 2.0, 3.0],
                more: 0,
                all_counted: true
            }
        );
        assert!(e.to_string().contains("1, 2, 3"), "{e}");
        let m = mask_from_image(&labels, MaskSelection::Label(2.0)).unwrap();
        assert_eq!(inside(&m), [1, 3]);
        let m = mask_from_image(&labels, MaskSelection::Above(1.5)).unwrap();
        assert_eq!(inside(&m), [1, 3, 5]);
        let e = mask_from_image(&labels, MaskSelection::Label(4.0)).unwrap_err();
        assert_eq!(
            e,
            MeshError::MaskLabelAbsent {
                label: 4.0,
                values: vec![1.0, 2.0, 3.0],
                more: 0,
                all_counted: true
            }
        );
    }

    #[test]
    fn many_values_are_listed_up_to_a_bound() {
        let values: Vec<f32> = (0..20).map(|i| (i % 12) as f32).collect();
        match mask_from_image(&image(values), MaskSelection::Nonzero) {
            Err(MeshError::MaskValues {
                values,
                more,
                all_counted,
            }) => {
                assert_eq!(values.len(), LISTED_VALUES);
                assert_eq!(more, 11 - LISTED_VALUES);
                assert!(all_counted);
                assert!(values.windows(2).all(|w| w[0] < w[1]));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn an_intensity_image_is_counted_up_to_a_bound() {
        let n = COUNTED_VALUES + 10;
        let values: Vec<f32> = (1..=n).map(|i| i as f32).collect();
        let e = mask_from_image(&image(values), MaskSelection::Nonzero).unwrap_err();
        match &e {
            MeshError::MaskValues {
                values,
                more,
                all_counted,
            } => {
                assert_eq!(values.len() + more, COUNTED_VALUES);
                assert!(!all_counted);
            }
            other => panic!("{other:?}"),
        }
        assert!(
            e.to_string()
                .starts_with("the mask holds at least 65536 values"),
            "{e}"
        );
    }

    #[test]
    fn bad_selections_and_images_are_refused() {
        let one = image(vec![0.0, 1.0]);
        for s in [
            MaskSelection::Label(f64::NAN),
            MaskSelection::Above(f64::INFINITY),
        ] {
            assert!(matches!(
                mask_from_image(&one, s),
                Err(MeshError::InvalidArgument(_))
            ));
        }
        let nan = image(vec![0.0, f32::NAN]);
        assert!(matches!(
            mask_from_image(&nan, MaskSelection::Above(0.5)),
            Err(MeshError::Image(_))
        ));
        let series = Volume::new([1, 1, 1, 2], Matrix4::identity(), vec![0.0f32, 1.0]).unwrap();
        assert!(matches!(
            mask_from_image(&series, MaskSelection::Nonzero),
            Err(MeshError::Image(_))
        ));
    }

    proptest! {
        /// A label's mask is the threshold mask between its neighbours: the
        /// voxels above `label - 1/2` and not above `label + 1/2` (integer
        /// labels).
        #[test]
        fn a_label_is_the_band_between_two_thresholds(
            values in prop::collection::vec(0u8..6, 1..64),
            label in 1u8..6,
        ) {
            let img = image(values.iter().map(|&v| v as f32).collect());
            let l = label as f64;
            let Ok(m) = mask_from_image(&img, MaskSelection::Label(l)) else {
                prop_assert!(!values.contains(&label));
                return Ok(());
            };
            let lo = mask_from_image(&img, MaskSelection::Above(l - 0.5)).unwrap();
            let hi = mask_from_image(&img, MaskSelection::Above(l + 0.5)).unwrap();
            for i in 0..values.len() {
                prop_assert_eq!(m.data()[i], lo.data()[i] && !hi.data()[i]);
            }
        }
    }
}
