//! The cohort figures (issue 19 point 3) through the binary: `unfold demo
//! --cohort` draws every expected figure into `study/cohort/figures/`, the
//! index lists exactly the PNGs present, a rerun gives the same bytes,
//! `--plot` draws the asked scatter plots and refuses unknown columns.

use std::collections::BTreeSet;
use std::path::Path;

mod common;
use common::*;

fn pngs(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect()
}

fn index(dir: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("index.json")).unwrap();
    serde_json::from_str::<serde_json::Value>(&text)
        .unwrap()
        .as_array()
        .unwrap()
        .clone()
}

#[test]
fn the_cohort_demo_draws_every_cohort_figure_and_indexes_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let o = unfold(&["demo", "--cohort", "-o", &s(&out)]);
    assert_ok(&o);
    let study = out.join("study");
    let figs = study.join("cohort").join("figures");
    let present = pngs(&figs);
    let mut expected: BTreeSet<String> = [
        "placenta_distortion.png",
        "placenta_t2_slices.png",
        "mitral_energies.png",
        "scatter_estimates.volume_mm3_vs_age_weeks.png",
        "scatter_dirichlet_excess_percent_vs_age_weeks.png",
        "scatter_roundtrip_error_um.mean_vs_age_weeks.png",
        "scatter_annulus_length_mm_vs_age_weeks.png",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for array in ["depth", "xi", "zeta"] {
        expected.insert(format!("ventricle_{array}_mean_bullseye.png"));
        expected.insert(format!("ventricle_{array}_std_bullseye.png"));
        for k in 1..=6 {
            expected.insert(format!("ventricle_{array}_z_ventricle{k:02}_bullseye.png"));
        }
    }
    assert_eq!(present, expected);
    // The index lists exactly the PNGs present, each once, with a title,
    // a caption and the subject of a z bull's-eye.
    let entries = index(&figs);
    let listed: Vec<String> = entries
        .iter()
        .map(|e| e["file"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(listed.len(), present.len());
    assert_eq!(listed.iter().cloned().collect::<BTreeSet<_>>(), present);
    for e in &entries {
        let file = e["file"].as_str().unwrap();
        assert!(!e["title"].as_str().unwrap().is_empty(), "{e}");
        assert!(!e["caption"].as_str().unwrap().is_empty(), "{e}");
        match file.split("_z_").nth(1) {
            Some(rest) => assert_eq!(
                e["subject"].as_str(),
                rest.strip_suffix("_bullseye.png"),
                "{e}"
            ),
            None => assert!(e["subject"].is_null(), "{e}"),
        }
    }
    // Every PNG decodes; the box plots show the phases and templates.
    for f in &present {
        let bytes = std::fs::read(figs.join(f)).unwrap();
        let img = unfold::figures::render::Image::from_png(&bytes).unwrap();
        assert!(img.width() >= 480 && img.height() >= 400, "{f}");
    }
    let energies = entries
        .iter()
        .find(|e| e["file"] == "mitral_energies.png")
        .unwrap();
    let caption = energies["caption"].as_str().unwrap();
    assert!(
        caption.contains("3 open") && caption.contains("3 closed"),
        "{caption}"
    );

    // The cohort report shows every indexed figure in its cohort section,
    // and a subject's figure in that subject's section too.
    let html = std::fs::read_to_string(study.join("index.html")).unwrap();
    let section = |id: &str| {
        let start = html
            .find(&format!("<section id=\"{id}\""))
            .unwrap_or_else(|| panic!("no section {id}"));
        let rest = &html[start..];
        rest[..rest.find("</section>").unwrap()].to_string()
    };
    let cohort_section = section("cohort");
    for e in &entries {
        let src = format!("src=\"cohort/figures/{}\"", e["file"].as_str().unwrap());
        assert!(
            cohort_section.contains(&src),
            "{src} not in the cohort section"
        );
        if let Some(id) = e["subject"].as_str() {
            assert!(
                section(&format!("s-{id}")).contains(&src),
                "{src} not in {id}'s section"
            );
        }
    }

    // `unfold cohort` again: the same bytes, the same index.
    let before: Vec<Vec<u8>> = present
        .iter()
        .map(|f| std::fs::read(figs.join(f)).unwrap())
        .collect();
    let o = unfold(&["cohort", &s(&study)]);
    assert_ok(&o);
    for (f, b) in present.iter().zip(&before) {
        assert_eq!(&std::fs::read(figs.join(f)).unwrap(), b, "{f} changed");
    }

    // `--plot` draws the asked plot only; the PNGs of the default plots go.
    let o = unfold(&[
        "cohort",
        &s(&study),
        "--plot",
        "saddle_horn_height_mm:age_weeks",
    ]);
    assert_ok(&o);
    let now = pngs(&figs);
    assert!(now.contains("scatter_saddle_horn_height_mm_vs_age_weeks.png"));
    assert!(!now.contains("scatter_estimates.volume_mm3_vs_age_weeks.png"));
    let listed: BTreeSet<String> = index(&figs)
        .iter()
        .map(|e| e["file"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(listed, now);

    // Unknown columns and a categorical covariate are clear errors.
    let o = unfold(&["cohort", &s(&study), "--plot", "nonsense:age_weeks"]);
    assert_one_line_error(&o, "MEASURE 'nonsense' is not a column");
    assert!(
        stderr(&o).contains("estimates.volume_mm3"),
        "{}",
        stderr(&o)
    );
    let o = unfold(&["cohort", &s(&study), "--plot", "annulus_length_mm:nope"]);
    assert_one_line_error(&o, "COVARIATE 'nope' is not a column");
    let o = unfold(&["cohort", &s(&study), "--plot", "annulus_length_mm:group"]);
    assert_one_line_error(&o, "is not numeric");
    let o = unfold(&["cohort", &s(&study), "--plot", "annulus_length_mm"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("is not MEASURE:COVARIATE"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn too_few_subjects_skip_a_figure_with_a_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    assert_ok(&unfold(&[
        "demo",
        "--cohort",
        "--placentas",
        "2",
        "-o",
        &s(&out),
    ]));
    let study = out.join("study");
    let o = unfold(&["cohort", &s(&study)]);
    assert_ok(&o);
    let text = stdout(&o);
    assert!(
        text.contains("figure placenta_distortion.png skipped: 2 placentas"),
        "{text}"
    );
    let figs = study.join("cohort").join("figures");
    let present = pngs(&figs);
    assert!(!present.contains("placenta_distortion.png"));
    assert!(!present.contains("placenta_t2_slices.png"));
    assert!(present.contains("mitral_energies.png"));
    assert_eq!(index(&figs).len(), present.len());
}
