//! `unfold demo --cohort` (issue 19): a synthetic cohort of 8 placentas, 6
//! ventricles, 6 valves and a valve series run through `unfold batch` in
//! one command, with the cohort table and statistics; a rerun skips every
//! subject.

use unfold::io::read_image;

mod common;
use common::*;

#[test]
fn the_cohort_demo_runs_its_subjects_and_gathers_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cohort-demo");
    let o = unfold(&["demo", "--cohort", "-o", &s(&out)]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("batch: 21 subjects, 21 run"), "{text}");
    let study = out.join("study");
    let table = std::fs::read_to_string(study.join("cohort.csv")).unwrap();
    assert_eq!(table.lines().count(), 22, "{table}");
    assert!(table.lines().next().unwrap().contains("age_weeks,group"));
    assert_eq!(table.matches(",ok,").count(), 20, "{table}");
    assert_eq!(table.matches(",mitral,series,").count(), 1, "{table}");
    // the mitral measurements: six valves and the series' three steps
    let mitral =
        std::fs::read_to_string(study.join("cohort").join("mitral_measurements.csv")).unwrap();
    assert_eq!(mitral.lines().count(), 10, "{mitral}");
    assert_eq!(mitral.matches("valveseries,step_").count(), 3, "{mitral}");
    for line in mitral.lines().skip(1) {
        let length: f64 = line.split(',').nth(3).unwrap().parse().unwrap();
        assert!(length > 50.0, "{line}");
    }
    // every placenta on one grid: the count reaches 8
    let count = read_image(study.join("cohort").join("t2_count.nii.gz")).unwrap();
    let max = count.volume.data().iter().cloned().fold(0.0f32, f32::max);
    assert_eq!(max, 8.0);
    let segments =
        std::fs::read_to_string(study.join("cohort").join("ventricle_segments.csv")).unwrap();
    assert_eq!(
        segments.lines().filter(|l| l.starts_with("depth,")).count(),
        17
    );
    assert!(
        segments
            .lines()
            .skip(1)
            .all(|l| l.split(',').nth(2) == Some("6"))
    );
    // the mitral maps: six valves and three steps, nine maps on one grid
    let count = read_image(study.join("cohort").join("mitral_area_energy_count.nii.gz")).unwrap();
    let max = count.volume.data().iter().cloned().fold(0.0f32, f32::max);
    assert_eq!(max, 9.0);
    // a rerun regenerates the same inputs: nothing to do (the series by the
    // run hash in its series.json)
    let o = unfold(&["demo", "--cohort", "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("0 run"), "{}", stdout(&o));
    assert!(stdout(&o).contains("21 skipped"), "{}", stdout(&o));
}
