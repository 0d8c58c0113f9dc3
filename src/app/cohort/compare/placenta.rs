//! The placenta images' voxelwise tests on their common grids.

use super::study::Study;
use super::*;

/// The placenta images' tests.
pub(super) fn placenta(
    study: &mut Study<'_>,
    out: &Path,
    subjects: &[SubjectRow],
    observer: &mut dyn Observer,
) -> Result<Vec<Analysis>, AppError> {
    let with_outputs: Vec<&SubjectRow> = subjects
        .iter()
        .filter(|s| s.organ == "placenta" && out.join(&s.id).join("report.json").is_file())
        .collect();
    let mut analyses = Vec::new();
    for (name, members) in placenta_images(out, subjects) {
        let what = format!("placenta image {name}");
        observer.progress(&format!("compare: {what}"));
        let Some((grid, off_grid)) = choose(&name, &members)? else {
            continue;
        };
        for (id, why) in off_grid.iter().cloned() {
            study.leave_out(&id, why);
        }
        for s in &with_outputs {
            if !members.iter().any(|(id, _)| *id == s.id) {
                study.leave_out(&s.id, format!("no {name}_flat.nii.gz"));
            }
        }
        let candidates: Vec<&SubjectRow> = with_outputs
            .iter()
            .copied()
            .filter(|s| members.iter().any(|(id, _)| *id == s.id))
            .filter(|s| !off_grid.iter().any(|(id, _)| *id == s.id))
            .collect();
        let rows = study.eligible(candidates);
        let dir_of = |s: &SubjectRow| out.join(&s.id);
        // pass 1: the values every subject has
        let len = grid.frame_len() * grid.dims[3];
        let mut covered = vec![true; len];
        for s in &rows {
            let (vol, mask) = on_grid(&grid, &dir_of(s), &name)?;
            let per_frame = mask.len();
            for (i, (c, &x)) in covered.iter_mut().zip(vol.data()).enumerate() {
                *c &= mask[i % per_frame] && x.is_finite();
            }
        }
        let tested: Vec<usize> = (0..len)
            .filter(|&i| covered[i] && !rows.is_empty())
            .collect();
        if tested.is_empty() {
            return Err(AppError::Usage(format!(
                "--compare {}: {what}: no voxel is covered by all {} subjects; check their \
                 flattened meshes (cohort/{name}_count.nii.gz)",
                study.settings.column,
                rows.len()
            )));
        }
        // pass 2: y, subjects x tested voxels, column-major
        let n = rows.len();
        let mut y = vec![0.0f64; n * tested.len()];
        for (k, s) in rows.iter().enumerate() {
            let (vol, _) = on_grid(&grid, &dir_of(s), &name)?;
            for (j, &i) in tested.iter().enumerate() {
                y[j * n + k] = f64::from(vol.data()[i]);
            }
        }
        let (design, result) = study.test(&what, &rows, &y)?;
        let stem = format!("{}_{}", file_part(&name), file_part(&study.settings.column));
        let images = [
            (statistic_suffix(result.kind), &result.statistic, f32::NAN),
            ("pfwe", &result.p_fwe, 1.0),
            ("p", &result.p_uncorrected, 1.0),
        ];
        let mut files = Vec::new();
        for (suffix, values, untested) in images {
            let mut data = vec![untested; len];
            for (j, &i) in tested.iter().enumerate() {
                data[i] = values[j] as f32;
            }
            let file = format!("{stem}_{suffix}.nii.gz");
            let path = study.dir.join(&file);
            let vol = Volume::new(grid.dims, grid.affine, data).map_err(|e| at(&path, e))?;
            write_image(&path, &NiftiImage::new(vol))?;
            files.push(file);
        }
        let a = study.analysis("placenta", &name, &rows, &design, &result, files);
        tell(observer, &what, &a);
        analyses.push(a);
    }
    Ok(analyses)
}
