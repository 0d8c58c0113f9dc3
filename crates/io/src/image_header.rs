//! An image's header alone: what a NIfTI or NRRD file says about its grid,
//! its voxel-to-world affine and its values, read without the voxel data.
//!
//! [`read_image_header`] reads only the header: a `.nii` file's first 348
//! bytes, a `.nii.gz` file's first 348 *decompressed* bytes (the gzip
//! stream is inflated no further), a NRRD file's header lines (at most
//! [`crate::nrrd::MAX_HEADER`] bytes). It checks what can be checked
//! without the data (a `.nii` file long enough for the data it declares, a
//! `.nii.gz` that can hold it), so it fails where [`crate::read_image`]
//! would fail for a header reason, and on success equals
//! [`ImageHeader::of`] the image [`crate::read_image`] returns.
//! [`crate::image_values`] streams the values after it.

use crate::nifti::AffineSource;
use crate::{Datatype, IoError, NiftiImage};
use nalgebra::{Matrix4, Vector3};
use std::path::Path;
use unfold_mesh::Volume;

/// The header fields of an image (everything in [`NiftiImage`] but the
/// values and [`NiftiImage::write_datatype`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ImageHeader {
    /// Voxels along x, y, z and frames (t, or vector components).
    pub dims: [usize; 4],
    /// The voxel-to-world (RAS, millimetres) affine.
    pub affine: Matrix4<f64>,
    /// The data type the file stores.
    pub datatype: Datatype,
    /// `scl_slope` (1 for NRRD).
    pub scl_slope: f32,
    /// `scl_inter` (0 for NRRD).
    pub scl_inter: f32,
    /// Where the affine came from.
    pub affine_source: AffineSource,
    /// `sform_code` (1 for NRRD).
    pub sform_code: i16,
    /// `qform_code` (0 for NRRD).
    pub qform_code: i16,
    /// `xyzt_units`.
    pub xyzt_units: u8,
    /// Time between frames (1 when not given).
    pub time_step: f32,
    /// `descrip` (NRRD: `content`).
    pub description: String,
    /// `intent_code` (0 for NRRD).
    pub intent_code: i16,
    /// `intent_p1`, `intent_p2`, `intent_p3`.
    pub intent_params: [f32; 3],
    /// `intent_name`.
    pub intent_name: String,
}

impl ImageHeader {
    /// The header of an image already read.
    pub fn of(img: &NiftiImage) -> ImageHeader {
        ImageHeader {
            dims: img.volume.dims(),
            affine: *img.volume.affine(),
            datatype: img.datatype,
            scl_slope: img.scl_slope,
            scl_inter: img.scl_inter,
            affine_source: img.affine_source,
            sform_code: img.sform_code,
            qform_code: img.qform_code,
            xyzt_units: img.xyzt_units,
            time_step: img.time_step,
            description: img.description.clone(),
            intent_code: img.intent_code,
            intent_params: img.intent_params,
            intent_name: img.intent_name.clone(),
        }
    }

    /// Voxel sizes: the norms of the affine's first three columns,
    /// `s_j = |A[0..3, j]|` (as [`Volume::spacing`]).
    pub fn spacing(&self) -> [f64; 3] {
        let a = &self.affine;
        let c = |j: usize| Vector3::new(a[(0, j)], a[(1, j)], a[(2, j)]).norm();
        [c(0), c(1), c(2)]
    }

    /// Number of values, `dims[0] · dims[1] · dims[2] · dims[3]` (saturating).
    pub fn value_count(&self) -> u64 {
        self.dims
            .iter()
            .fold(1u64, |a, &d| a.saturating_mul(d as u64))
    }

    /// Fails unless the affine is one a [`Volume`] accepts (finite, last row
    /// `(0, 0, 0, 1)`, invertible): readers check it before any data is read.
    pub(crate) fn check_affine(&self) -> Result<(), IoError> {
        Volume::new([1, 1, 1, 1], self.affine, vec![0.0f32])?;
        Ok(())
    }

    /// The image of these header fields and `data` (x fastest, then y, z,
    /// frames; `dims` values), to be written as FLOAT32.
    pub fn into_image(self, data: Vec<f32>) -> Result<NiftiImage, IoError> {
        let volume = Volume::new(self.dims, self.affine, data)?;
        Ok(NiftiImage {
            volume,
            datatype: self.datatype,
            write_datatype: Datatype::Float32,
            scl_slope: self.scl_slope,
            scl_inter: self.scl_inter,
            affine_source: self.affine_source,
            sform_code: self.sform_code,
            qform_code: self.qform_code,
            xyzt_units: self.xyzt_units,
            time_step: self.time_step,
            description: self.description,
            intent_code: self.intent_code,
            intent_params: self.intent_params,
            intent_name: self.intent_name,
        })
    }
}

/// Reads the header of an image file (NIfTI-1 `.nii` / `.nii.gz`, NRRD
/// `.nrrd` / `.seg.nrrd` / `.nhdr`) without its voxel data; see the
/// [module documentation](self).
pub fn read_image_header(path: impl AsRef<Path>) -> Result<ImageHeader, IoError> {
    let path = path.as_ref();
    match crate::format::image_kind(path)? {
        crate::FileKind::Nrrd { .. } => crate::nrrd::read_header_file(path).map(|(_, h)| h),
        _ => crate::nifti::open_file(path).map(|(h, _)| h.meta),
    }
    .map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ValueSummary, image_value_summary, read_image, scan_image_values, write_image};
    use proptest::prelude::*;
    use std::io::Write;

    /// An image with values `i * 0.5 - 3` and a scaled, shifted affine.
    fn image(dims: [usize; 4], scale: [f64; 3], t: [f64; 3], dt: Datatype) -> NiftiImage {
        let n: usize = dims.iter().product();
        let mut a = Matrix4::identity();
        for i in 0..3 {
            a[(i, i)] = scale[i];
            a[(i, 3)] = t[i];
        }
        let data = (0..n).map(|i| i as f32 * 0.5 - 3.0).collect();
        NiftiImage::new(Volume::new(dims, a, data).unwrap()).with_datatype(dt)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// The header alone equals the full read's header, and the streamed
        /// values are the full read's, for .nii, .nii.gz and .nrrd.
        #[test]
        fn header_only_equals_full_read(
            dims in (1..6usize, 1..6usize, 1..5usize, 1..3usize).prop_map(|(a, b, c, d)| [a, b, c, d]),
            scale in prop::array::uniform3(0.1..4.0f64),
            t in prop::array::uniform3(-100.0..100.0f64),
            dt in prop::sample::select(Datatype::ALL.to_vec()),
            ext in prop::sample::select(vec!["nii", "nii.gz", "nrrd"]),
        ) {
            let dir = tempfile::tempdir().unwrap();
            let p = dir.path().join(format!("img.{ext}"));
            write_image(&p, &image(dims, scale, t, dt)).unwrap();
            let full = read_image(&p).unwrap();
            let head = read_image_header(&p).unwrap();
            prop_assert_eq!(&head, &ImageHeader::of(&full));
            prop_assert_eq!(head.spacing(), full.volume.spacing());
            prop_assert_eq!(head.value_count(), full.volume.data().len() as u64);
            let mut streamed = Vec::new();
            let h2 = scan_image_values(&p, |v| streamed.extend_from_slice(v)).unwrap();
            prop_assert_eq!(&h2, &head);
            // File order: the NRRD writer puts a series' frame axis first.
            let sorted = |v: &[f32]| {
                let mut b: Vec<u32> = v.iter().map(|x| x.to_bits()).collect();
                b.sort_unstable();
                b
            };
            prop_assert_eq!(sorted(&streamed), sorted(full.volume.data()));
            if ext != "nrrd" {
                prop_assert_eq!(streamed.as_slice(), full.volume.data());
            }
            let (_, s) = image_value_summary(&p).unwrap();
            prop_assert_eq!(s.range, full.volume.value_range());
            prop_assert_eq!(s.count, head.value_count());
        }
    }

    fn gz(bytes: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn scaled_values_are_streamed_scaled() {
        // An INT16 .nii with scl_slope 2, scl_inter -1 (set in the header).
        let img = image([3, 2, 1, 1], [1.0; 3], [0.0; 3], Datatype::Int16);
        let mut b = crate::nifti::write(&img, false).unwrap();
        b[112..116].copy_from_slice(&2.0f32.to_le_bytes());
        b[116..120].copy_from_slice(&(-1.0f32).to_le_bytes());
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.nii");
        std::fs::write(&p, &b).unwrap();
        let full = read_image(&p).unwrap();
        let stored: Vec<f32> = img.volume.data().iter().map(|v| v.round()).collect();
        let want: Vec<f32> = stored.iter().map(|v| 2.0 * v - 1.0).collect();
        assert_eq!(full.volume.data(), want.as_slice());
        let (h, s) = image_value_summary(&p).unwrap();
        assert_eq!((h.scl_slope, h.scl_inter), (2.0, -1.0));
        // Stored -3, -3, -2, -2, -1, -1 (rounded half away from zero).
        assert_eq!(s.range, Some((-7.0, -3.0)));
    }

    #[test]
    fn header_only_reads_a_gzip_stream_whose_data_is_cut_short() {
        // A .nii.gz whose stream holds only the header: the header reads
        // (the data is not inflated), the values fail with both sizes.
        let img = image([4, 4, 4, 1], [1.0; 3], [0.0; 3], Datatype::Uint8);
        let b = crate::nifti::write(&img, false).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cut.nii.gz");
        std::fs::write(&p, gz(&b[..352])).unwrap();
        assert_eq!(read_image_header(&p).unwrap().dims, [4, 4, 4, 1]);
        for e in [
            read_image(&p).unwrap_err(),
            image_value_summary(&p).unwrap_err(),
        ] {
            assert!(
                matches!(
                    e,
                    IoError::DecompressedSize {
                        declared: 416,
                        found: 352,
                        ..
                    }
                ),
                "{e}"
            );
            assert!(e.to_string().starts_with(&p.display().to_string()), "{e}");
        }
        // More data than declared: refused, one byte past inflated.
        let mut more = b.clone();
        more.extend_from_slice(&[7u8; 5000]);
        std::fs::write(&p, gz(&more)).unwrap();
        let e = image_value_summary(&p).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::DecompressedSize {
                    declared: 416,
                    found: 417,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("more than 416 bytes"), "{e}");
    }

    #[test]
    fn header_only_read_refuses_what_the_full_read_refuses() {
        let dir = tempfile::tempdir().unwrap();
        let img = image([4, 4, 4, 1], [1.0; 3], [0.0; 3], Datatype::Float32);
        let b = crate::nifti::write(&img, false).unwrap();
        // A .nii shorter than its data.
        let p = dir.path().join("short.nii");
        std::fs::write(&p, &b[..b.len() - 1]).unwrap();
        let e = read_image_header(&p).unwrap_err();
        assert!(e.to_string().contains("the file ends after"), "{e}");
        assert!(read_image(&p).is_err());
        // A .nii.gz declaring far more than it can hold.
        let mut big = b[..352].to_vec();
        big[42..48].copy_from_slice(&[0xff, 0x7f, 0xff, 0x7f, 0xff, 0x7f]);
        let p = dir.path().join("bomb.nii.gz");
        std::fs::write(&p, gz(&big)).unwrap();
        let e = read_image_header(&p).unwrap_err();
        assert!(e.to_string().contains("can hold"), "{e}");
        // A mesh path, a missing file.
        assert!(read_image_header(dir.path().join("m.vtk")).is_err());
        let e = read_image_header(dir.path().join("none.nrrd")).unwrap_err();
        assert!(matches!(e, IoError::Io { .. }), "{e}");
        // A NRRD whose header never ends is refused having read at most
        // MAX_HEADER + 2 bytes.
        let p = dir.path().join("long.nrrd");
        let mut long = b"NRRD0004\n# ".to_vec();
        long.resize(crate::nrrd::MAX_HEADER * 2, b'x');
        std::fs::write(&p, &long).unwrap();
        let e = read_image_header(&p).unwrap_err();
        assert!(e.to_string().contains("longer than"), "{e}");
    }

    #[test]
    fn nrrd_gzip_and_detached_data_stream() {
        let dir = tempfile::tempdir().unwrap();
        // Detached raw data, a 4D series with the frame axis first.
        std::fs::write(dir.path().join("d.raw"), [1u8, 2, 3, 4, 5, 6, 7, 8]).unwrap();
        let p = dir.path().join("d.nhdr");
        std::fs::write(
            &p,
            "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 2 2 2 1\nkinds: list domain domain \
             domain\nencoding: raw\ndata file: d.raw\n",
        )
        .unwrap();
        let full = read_image(&p).unwrap();
        assert_eq!(read_image_header(&p).unwrap(), ImageHeader::of(&full));
        let (_, s) = image_value_summary(&p).unwrap();
        assert_eq!(s.range, Some((1.0, 8.0)));
        assert_eq!(s.count, 8);
        // Gzip data holding more than the header declares.
        let p = dir.path().join("g.nrrd");
        let mut f =
            b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 1\nencoding: gzip\n\n".to_vec();
        f.extend_from_slice(&gz(&[0u8; 100]));
        std::fs::write(&p, &f).unwrap();
        assert_eq!(read_image_header(&p).unwrap().dims, [2, 2, 1, 1]);
        let e = image_value_summary(&p).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::DecompressedSize {
                    declared: 4,
                    found: 5,
                    ..
                }
            ),
            "{e}"
        );
        // ValueSummary skips NaN, as Volume::value_range.
        let mut s = ValueSummary::default();
        s.add(&[f32::NAN, 2.0, f32::NEG_INFINITY]);
        assert_eq!((s.count, s.nan), (3, 1));
        assert_eq!(s.range, Some((f64::NEG_INFINITY, 2.0)));
    }
}
