//! Whole-run atomicity of output sets, through the binary: a failed run
//! leaves the previous set byte for byte; every output path is checked
//! before any input is read; a killed run's staging directory is removed by
//! the next run; a second run replaces the whole set; dead runs' temporary
//! files are removed by the one-file commands, live ones and a user's files
//! kept.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use unfold::app::run::MANIFEST;
use unfold::io::{NiftiImage, WriteOptions, write_image, write_mesh};
use unfold::mesh::nalgebra::{Matrix4, Vector3};
use unfold::mesh::shapes::{PlacentaParams, ValveParams, mitral_valve, placenta_slab};
use unfold::mesh::{CellMesh, CellType, TetMesh, Volume};

mod common;
#[path = "common/scan.rs"]
mod scan;
use common::*;

/// A placenta slab of `18 n^2 m` tets.
fn slab(cells_radial: usize, cells_through: usize) -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial,
        cells_through,
        ..PlacentaParams::default()
    })
    .expect("valid slab parameters")
    .mesh
}

fn write_tets(path: &Path, mesh: &TetMesh) {
    write_mesh(path, &CellMesh::from(mesh), &WriteOptions::default()).expect("mesh written");
}

/// A 2 mm image covering `mesh` with a 6 mm margin, shifted by `offset`
/// mm in x, intensity affine in position.
fn image_around(mesh: &TetMesh, offset: f64) -> NiftiImage {
    scan::image_around(mesh, [2.0; 3], 1, Vector3::new(offset, 0.0, 0.0), |p, _| {
        300.0 + p.x - 0.5 * p.y + 2.0 * p.z
    })
}

/// Every file below `dir` (hidden ones too) with its bytes; directories as
/// `None`, so that an empty one left behind counts too.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(dir).unwrap().to_path_buf();
            if p.is_dir() {
                out.insert(rel, None);
                stack.push(p);
            } else {
                out.insert(rel, Some(std::fs::read(&p).unwrap()));
            }
        }
    }
    out
}

/// The names of the entries of `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The files listed in a directory's manifest.
fn manifest(dir: &Path) -> Vec<String> {
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(MANIFEST)).unwrap()).unwrap();
    m["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect()
}

/// Every file below `dir` (relative, `/`-separated), sorted.
fn files_below(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = snapshot(dir)
        .into_iter()
        .filter(|(_, b)| b.is_some())
        .map(|(p, _)| p.to_string_lossy().replace('\\', "/"))
        .collect();
    v.sort();
    v
}

/// A pid that is certainly not running: a child that exited and was
/// waited for.
fn dead_pid() -> u32 {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_unfold"))
        .arg("--version")
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id();
    child.wait().unwrap();
    pid
}

#[test]
fn a_failed_placenta_run_leaves_the_previous_set_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = slab(6, 2);
    let mesh_path = dir.path().join("slab.vtu");
    write_tets(&mesh_path, &mesh);
    let t2 = dir.path().join("t2.nii.gz");
    write_image(&t2, &image_around(&mesh, 0.0)).unwrap();
    // Not an image at all.
    let bad = dir.path().join("bad.nii");
    std::fs::write(&bad, b"not a NIfTI file").unwrap();
    // An image that misses the mesh (refused by the pipeline's checks).
    let far = dir.path().join("far.nii.gz");
    write_image(&far, &image_around(&mesh, 500.0)).unwrap();
    let out = dir.path().join("out");
    let (m, o_) = (s(&mesh_path), s(&out));
    let o = unfold(&["placenta", &m, "--image", &s(&t2), "-o", &o_]);
    assert_ok(&o);
    let first = snapshot(dir.path());
    assert!(out.join("figures").is_dir() && out.join("t2_flat.nii.gz").is_file());

    let nowhere = s(&dir.path().join("nowhere/d.nii.gz"));
    let (bad, far) = (s(&bad), s(&far));
    let failing: [(&[&str], &str); 3] = [
        (&["--image", &bad], "bad.nii"),
        (&["--image", &far], "far.nii.gz"),
        (&["--displacement", &nowhere], "does not exist"),
    ];
    for (extra, needle) in failing {
        let mut args = vec!["placenta", &m, "-o", &o_, "--no-figures"];
        args.extend(extra);
        let o = unfold(&args);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {}", stderr(&o));
        assert_one_line_error(&o, needle);
        // Every file as the first run left it; nothing beside or inside.
        assert!(
            snapshot(dir.path()) == first,
            "{extra:?}: the directory changed"
        );
    }
}

#[test]
fn output_paths_are_checked_before_any_input_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Inputs that cannot be read: an error about them would mean the
    // output was checked after reading.
    let junk = d.join("junk.vtu");
    std::fs::write(&junk, b"junk").unwrap();
    let junk_nii = d.join("junk.nii.gz");
    std::fs::write(&junk_nii, b"junk").unwrap();
    let targets = d.join("targets.csv");
    std::fs::write(&targets, b"0,0,0,0\n").unwrap();
    let file = d.join("a_file");
    std::fs::write(&file, b"mine").unwrap();
    let foreign = d.join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), b"mine").unwrap();
    let inputs_dir = d.join("inputs");
    std::fs::create_dir(&inputs_dir).unwrap();
    let inner = inputs_dir.join("slab.vtu");
    std::fs::write(&inner, b"junk").unwrap();
    let missing = d.join("missing/out.vtu");
    // A directory named like a mesh file.
    let dir_vtk = d.join("dir.vtk");
    std::fs::create_dir(&dir_vtk).unwrap();
    // A placenta run directory whose meshes are junk (never read).
    let run = d.join("run");
    std::fs::create_dir(&run).unwrap();
    for f in ["original.vtu", "flattened.vtu"] {
        std::fs::write(run.join(f), b"junk").unwrap();
    }
    let (j, jn, t) = (s(&junk), s(&junk_nii), s(&targets));
    let cases: Vec<(Vec<String>, String)> = vec![
        (
            vec!["placenta".into(), j.clone(), "-o".into(), s(&file)],
            "exists and is not a directory".into(),
        ),
        (
            vec!["placenta".into(), j.clone(), "-o".into(), s(&foreign)],
            "holds 1 file(s) not written by an earlier unfold run into it (notes.txt)".into(),
        ),
        (
            vec!["placenta".into(), s(&inner), "-o".into(), s(&inputs_dir)],
            format!("{}: is an input and would be replaced", s(&inner)),
        ),
        (
            vec![
                "placenta".into(),
                j.clone(),
                "-o".into(),
                s(&d.join("new")),
                "--displacement".into(),
                s(&d.join("nowhere/d.nii.gz")),
            ],
            "nowhere does not exist".into(),
        ),
        (
            vec![
                "ventricle".into(),
                j.clone(),
                "--surface".into(),
                j.clone(),
                "--anterior".into(),
                "1,0,0".into(),
                "--inferior".into(),
                "0,1,0".into(),
                "-o".into(),
                s(&foreign),
            ],
            "unfold run into it (notes.txt)".into(),
        ),
        (
            vec![
                "mitral".into(),
                "--anterior".into(),
                j.clone(),
                "--posterior".into(),
                j.clone(),
                "--annulus".into(),
                j.clone(),
                "-o".into(),
                s(&foreign),
            ],
            "unfold run into it (notes.txt)".into(),
        ),
        (
            vec!["demo".into(), "-o".into(), s(&foreign)],
            "choose a new or empty directory".into(),
        ),
        // (The binary runs in the package root.)
        (
            vec!["demo".into(), "-o".into(), ".".into()],
            ".: is the current directory".into(),
        ),
        (
            vec![
                "deform".into(),
                j.clone(),
                "--targets".into(),
                t.clone(),
                "-o".into(),
                s(&missing),
            ],
            "missing does not exist".into(),
        ),
        (
            vec!["repair".into(), j.clone(), "-o".into(), s(&missing)],
            "missing does not exist".into(),
        ),
        (
            vec!["convert".into(), j.clone(), s(&dir_vtk)],
            "is a directory".into(),
        ),
        (
            vec!["mesh".into(), jn.clone(), "-o".into(), s(&missing)],
            "missing does not exist".into(),
        ),
        (
            vec![
                "pushback".into(),
                jn.clone(),
                "--run".into(),
                s(&run),
                "--reference".into(),
                jn.clone(),
                "-o".into(),
                s(&d.join("missing/x.nii.gz")),
            ],
            "missing does not exist".into(),
        ),
    ];
    let before = snapshot(d);
    for (args, needle) in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = unfold(&args);
        assert_one_line_error(&o, needle);
        assert!(snapshot(d) == before, "{args:?}: something was created");
    }
}

#[test]
fn a_killed_run_leaves_a_partial_that_the_next_run_removes() {
    let dir = tempfile::tempdir().unwrap();
    // Large enough that the debug binary is still reading and preparing
    // it when killed.
    let big = dir.path().join("big.vtu");
    write_tets(&big, &slab(16, 4));
    let out = dir.path().join("out");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_unfold"))
        .args(["placenta", &s(&big), "-o", &s(&out)])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let prefix = format!(".out.unfold-{}-", child.id());
    let partial = |d: &Path| -> Vec<String> {
        names(d)
            .into_iter()
            .filter(|n| n.ends_with(".partial"))
            .collect()
    };
    let start = Instant::now();
    loop {
        if partial(dir.path()).iter().any(|n| n.starts_with(&prefix)) {
            break;
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended ({status}) before its staging directory was seen");
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no staging directory"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL: no destructor runs
    child.wait().unwrap();
    let left = partial(dir.path());
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(left[0].starts_with(&prefix), "{left:?}");
    assert!(!out.exists(), "nothing in place");

    // The next run writing beside it removes it, and succeeds.
    let small = dir.path().join("small.vtu");
    write_tets(&small, &slab(4, 2));
    let o = unfold(&["placenta", &s(&small), "-o", &s(&out), "--no-figures"]);
    assert_ok(&o);
    assert_eq!(names(dir.path()), ["big.vtu", "out", "small.vtu"]);
}

#[test]
fn a_second_run_replaces_the_whole_set() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = dir.path().join("slab.vtu");
    write_tets(&mesh_path, &slab(4, 2));
    let out = dir.path().join("out");
    let o = unfold(&["placenta", &s(&mesh_path), "-o", &s(&out)]);
    assert_ok(&o);
    let first = files_below(&out);
    assert!(first.iter().any(|f| f.starts_with("figures/")), "{first:?}");
    let mut listed = manifest(&out);
    listed.push(MANIFEST.to_string());
    listed.sort();
    assert_eq!(first, listed, "the manifest lists every file");
    let report_before = std::fs::read(out.join("report.json")).unwrap();

    let o = unfold(&[
        "placenta",
        &s(&mesh_path),
        "-o",
        &s(&out),
        "--no-figures",
        "--template",
        "single-plane",
    ]);
    assert_ok(&o);
    let second = files_below(&out);
    assert!(!out.join("figures").exists(), "{second:?}");
    assert_eq!(
        second,
        [MANIFEST, "flattened.vtu", "original.vtu", "report.json"]
    );
    assert_ne!(
        std::fs::read(out.join("report.json")).unwrap(),
        report_before
    );
    // Every path printed is in place (none in a staging directory).
    let text = stdout(&o);
    assert!(!text.contains(".partial"), "{text}");
    for f in ["flattened.vtu", "report.json"] {
        assert!(text.contains(&s(&out.join(f))), "{text}");
    }
    assert_eq!(names(dir.path()), ["out", "slab.vtu"]);
}

#[test]
fn dead_runs_temporaries_are_removed_by_one_file_commands() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh_path = d.join("slab.vtu");
    write_tets(&mesh_path, &slab(3, 1));
    // A sphere mask for `unfold mesh`.
    let n = 24;
    let mut data = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let c = (n as f64 - 1.0) / 2.0;
                let r2 = (i as f64 - c).powi(2) + (j as f64 - c).powi(2) + (k as f64 - c).powi(2);
                data.push(if r2 < 64.0 { 1.0 } else { 0.0 });
            }
        }
    }
    let mask = d.join("mask.nii.gz");
    let vol = Volume::new([n, n, n, 1], Matrix4::identity(), data).unwrap();
    write_image(&mask, &NiftiImage::new(vol)).unwrap();

    let dead = dead_pid();
    let live = std::process::id();
    for (command, out_dir) in [("repair", d.join("r")), ("mesh", d.join("m"))] {
        std::fs::create_dir(&out_dir).unwrap();
        let stale = out_dir.join(format!(".unfold-{dead}-x.tmp"));
        let stale_dir = out_dir.join(format!(".out.vtu.unfold-{dead}-ab12.partial"));
        let kept = [
            out_dir.join(format!(".unfold-{live}-y.tmp")),
            out_dir.join(".unfold-notes.tmp"),
            out_dir.join(format!(".unfold-{dead}-x.tmp.bak")),
        ];
        std::fs::write(&stale, vec![7u8; 1000]).unwrap();
        std::fs::create_dir(&stale_dir).unwrap();
        std::fs::write(stale_dir.join("out.vtu"), b"half").unwrap();
        for k in &kept {
            std::fs::write(k, b"keep").unwrap();
        }
        let out = out_dir.join("out.vtu");
        let o = match command {
            "repair" => unfold(&["repair", &s(&mesh_path), "-o", &s(&out)]),
            _ => unfold(&["mesh", &s(&mask), "-o", &s(&out)]),
        };
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        assert!(!stale.exists() && !stale_dir.exists(), "{command}");
        for k in &kept {
            assert_eq!(
                std::fs::read(k).unwrap(),
                b"keep",
                "{command}: {}",
                k.display()
            );
        }
        let mut want: Vec<String> = kept
            .iter()
            .map(|k| k.file_name().unwrap().to_string_lossy().into_owned())
            .chain(["out.vtu".to_string()])
            .collect();
        want.sort();
        assert_eq!(names(&out_dir), want, "{command}");
    }
}

#[test]
fn the_demo_is_one_set_whose_reports_name_final_paths() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let o = unfold(&["demo", "-o", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stdout(&o).contains(".partial"), "{}", stdout(&o));
    let mut listed = manifest(&out);
    listed.push(MANIFEST.to_string());
    listed.sort();
    assert_eq!(files_below(&out), listed);
    for sub in [
        "placenta/report.json",
        "mitral/report.json",
        "ventricle/report.json",
    ] {
        assert!(listed.iter().any(|f| f == sub), "{sub} in {listed:?}");
    }
    let read = |p: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join(p)).unwrap()).unwrap()
    };
    let placenta = read("placenta/report.json");
    assert_eq!(
        placenta["images"][0]["input"],
        s(&out.join("placenta_mri.nii.gz"))
    );
    assert_eq!(
        placenta["images"][0]["output"],
        s(&out.join("placenta/placenta_mri_flat.nii.gz"))
    );
    let mitral = read("mitral/report.json");
    let inputs = mitral["inputs"].as_str().unwrap();
    assert!(
        inputs.contains(&s(&out.join("valve_anterior.vtu"))) && !inputs.contains(".partial"),
        "{inputs}"
    );
    assert_eq!(names(dir.path()), ["demo"]);
    // The ventricle demo maps its own rings and meridians: the line says
    // how close they come to circles and rays (ALGORITHMS 3.7 bounds).
    let text = stdout(&o);
    let line = text
        .lines()
        .find(|l| l.contains("rings of constant height -> circles"))
        .unwrap_or_else(|| panic!("no rings line in {text}"));
    let number_after = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key} in {line}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    assert!(number_after("worst radius spread ") < 2.0, "{line}");
    assert!(number_after("worst angle spread ") < 1.0, "{line}");
    let normalized = unfold::io::read_mesh(out.join("ventricle/normalized.vtu")).unwrap();
    let polylines = normalized
        .cells()
        .filter(|(t, _)| *t == unfold::mesh::CellType::PolyLine)
        .count();
    assert_eq!(polylines, 5 + 12, "rings and meridians in normalized.vtu");
}

#[test]
fn a_mitral_series_with_a_failing_step_leaves_the_previous_series() {
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    let v = mitral_valve(&ValveParams {
        annulus_segments: 32,
        depth_segments: 6,
        ..ValveParams::default()
    })
    .unwrap();
    let opts = WriteOptions::default();
    let write_step = |prefix: &str, shift: f64| {
        let mut posterior = v.posterior.clone();
        for p in &mut posterior.positions {
            *p -= v.atrium_direction * shift;
        }
        let mut ring = CellMesh::from_points(v.annulus.clone());
        let n = v.annulus.len() as u32;
        for i in 0..n {
            ring.push_cell(CellType::Line, &[i, (i + 1) % n]);
        }
        let file = |what: &str| series.join(format!("{prefix}_{what}.vtp"));
        write_mesh(file("anterior"), &CellMesh::from(&v.anterior), &opts).unwrap();
        write_mesh(file("posterior"), &CellMesh::from(&posterior), &opts).unwrap();
        write_mesh(file("annulus"), &ring, &opts).unwrap();
    };
    write_step("t00", 0.0);
    let out = dir.path().join("out");
    let run = || {
        unfold(&[
            "mitral",
            "--series",
            &s(&series),
            "-o",
            &s(&out),
            "--no-figures",
        ])
    };
    let o = run();
    assert!(o.status.success(), "{}", stderr(&o));
    let first = snapshot(&out);
    assert!(first.contains_key(Path::new("step_000/report.json")));
    assert!(first.contains_key(Path::new("series.csv")));

    // Two steps, the second's posterior leaflet away from the ring: the
    // run fails after step 0 is solved, and writes nothing at all.
    write_step("t01", 6.0);
    let o = run();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_one_line_error(&o, "does not touch the annulus ring");
    assert!(snapshot(&out) == first, "the previous series changed");
    assert_eq!(names(dir.path()), ["out", "series"]);
}
