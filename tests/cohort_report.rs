//! `OUT/index.html`, the cohort's visual report (issue 19), through the
//! binary: a batch with a broken subject, a not-converged one, a mitral
//! series and a hostile covariate writes a page whose every image is a
//! relative path to a PNG inside OUT, with no network or file URLs, one
//! section per subject, the broken subject's error, the covariate escaped,
//! and the cohort figures of `cohort/figures/index.json` (a broken index is
//! reported on the page, not fatal).

use std::path::Path;
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::CellMesh;
use unfold::mesh::CellType;
use unfold::mesh::shapes::{PlacentaParams, ValveParams, mitral_valve, placenta_slab};

mod common;
use common::*;

fn slab(path: &Path, cells_radial: usize) {
    let mesh = placenta_slab(&PlacentaParams {
        cells_radial,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh;
    write_mesh(path, &CellMesh::from(&mesh), &WriteOptions::default()).unwrap();
}

/// A mitral series of two steps in `dir` (the layout `unfold mitral
/// --series` reads).
fn valve_series(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let opts = WriteOptions::default();
    for step in 0..2 {
        let v = mitral_valve(&ValveParams {
            coaptation_gap: 1.0 + 3.0 * step as f64,
            ..ValveParams::default()
        })
        .unwrap();
        let p = |what: &str| dir.join(format!("t{step:02}_{what}.vtu"));
        write_mesh(p("anterior"), &CellMesh::from(&v.anterior), &opts).unwrap();
        write_mesh(p("posterior"), &CellMesh::from(&v.posterior), &opts).unwrap();
        let mut ring = CellMesh::from_points(v.annulus.clone());
        let n = v.annulus.len() as u32;
        for i in 0..n {
            ring.push_cell(CellType::Line, &[i, (i + 1) % n]);
        }
        write_mesh(p("annulus"), &ring, &opts).unwrap();
    }
}

/// The values of `attr="..."` in every `<tag ...>` of `html`.
fn attributes(html: &str, tag: &str, attr: &str) -> Vec<String> {
    let open = format!("<{tag} ");
    let key = format!("{attr}=\"");
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(i) = rest.find(&open) {
        let t = &rest[i..];
        let end = t.find('>').expect("a closed tag");
        let inside = &t[..end];
        if let Some(j) = inside.find(&key) {
            let v = &inside[j + key.len()..];
            out.push(v[..v.find('"').expect("a closed attribute")].to_string());
        }
        rest = &t[end..];
    }
    out
}

/// The HTML of subject `id`'s section.
fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html
        .find(&format!("<section id=\"s-{id}\""))
        .unwrap_or_else(|| panic!("no section for {id}"));
    let len = html[start..].find("</section>").unwrap();
    &html[start..start + len]
}

/// The PNG files directly in `dir`.
fn pngs(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .filter(|e| e.path().extension().is_some_and(|x| x == "png"))
                .count()
        })
        .unwrap_or(0)
}

#[test]
fn the_report_shows_every_subject_with_relative_images_and_escaped_text() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    slab(&d.join("s1.vtu"), 5);
    valve_series(&d.join("series"));
    std::fs::write(
        d.join("manifest.csv"),
        "id,organ,input,no-figures,solver,max-iterations,series,note\n\
         s1,placenta,s1.vtu,,,,,plain\n\
         broken,placenta,missing.vtu,true,,,,\"<script>alert(1)</script>\"\n\
         slow,placenta,s1.vtu,true,gd,3,,a&b\n\
         valves,mitral,,,,,series,\n",
    )
    .unwrap();
    let out = d.join("out");
    let o = unfold(&[
        "batch",
        &s(&d.join("manifest.csv")),
        "-o",
        &s(&out),
        "--jobs",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stdout(&o).contains("index.html"), "{}", stdout(&o));
    let page = out.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();

    // nothing outside the folder: no network, no file URLs, no absolute paths
    for bad in ["http://", "https://", "file://", "<script"] {
        assert!(!html.contains(bad), "{bad} in the page");
    }
    let srcs = attributes(&html, "img", "src");
    assert!(!srcs.is_empty());
    for src in srcs.iter().chain(&attributes(&html, "a", "href")) {
        if let Some(anchor) = src.strip_prefix('#') {
            assert!(html.contains(&format!("id=\"{anchor}\"")), "{src}");
            continue;
        }
        assert!(!src.starts_with('/') && !src.contains(".."), "{src}");
        assert!(out.join(src).is_file(), "{src} is not a file in OUT");
    }
    for src in &srcs {
        let bytes = std::fs::read(out.join(src)).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{src} is not a PNG"
        );
    }

    // a section per subject, with its own figures (and each series step's)
    for id in ["s1", "broken", "slow", "valves"] {
        section(&html, id);
    }
    let s1 = section(&html, "s1");
    let s1_figures = pngs(&out.join("s1").join("figures"));
    assert!(s1_figures > 0);
    assert_eq!(attributes(s1, "img", "src").len(), s1_figures);
    assert!(s1.contains("converged</span>"), "{s1}");
    assert!(s1.contains("inverted_tets"), "{s1}");
    let series = section(&html, "valves");
    let step_figures = pngs(&out.join("valves").join("step_000").join("figures"))
        + pngs(&out.join("valves").join("step_001").join("figures"));
    assert!(step_figures > 0);
    // and the series' own plot over the cycle
    let series_figures = pngs(&out.join("valves").join("figures"));
    assert_eq!(series_figures, 1);
    assert!(series.contains("valves/figures/series.png"), "{series}");
    assert_eq!(
        attributes(series, "img", "src").len(),
        step_figures + series_figures
    );
    assert!(series.contains("step_001: "), "{series}");

    // the broken subject: its error from failures.csv and its log
    let broken = section(&html, "broken");
    assert!(broken.contains("failed"), "{broken}");
    assert!(broken.contains("missing.vtu"), "{broken}");
    assert!(broken.contains("href=\"logs/broken.log\""), "{broken}");
    // the covariate from the manifest is escaped, here and in the cohort table
    assert!(
        broken.contains("&lt;script&gt;alert(1)&lt;/script&gt;"),
        "{broken}"
    );
    assert!(section(&html, "slow").contains("a&amp;b"));
    // the solver stopped early: outputs kept, marked
    assert!(section(&html, "slow").contains("not converged"));
    assert!(
        html.contains(
            "4 subjects: <span class=\"ok\">2 ok</span>, <span class=\"warn\">1 not \
         converged</span>, <span class=\"bad\">1 failed</span>"
        ),
        "{}",
        &html[..html.find("</header>").unwrap()]
    );

    // the statistics and tables are linked; every image is a file in OUT
    let cohort = &html[html.find("<section id=\"cohort\"").unwrap()..];
    let cohort = &cohort[..cohort.find("</section>").unwrap()];
    for src in attributes(&html, "img", "src") {
        let file = src.replace("%20", " ");
        assert!(out.join(&file).is_file(), "{src}");
    }
    // the statistics and tables are linked
    assert!(cohort.contains("href=\"cohort.csv\""), "{cohort}");
    assert!(cohort.contains("href=\"failures.csv\""), "{cohort}");
}
