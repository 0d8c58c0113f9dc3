//! The command line on real files and on bad input: counts, conversions,
//! one-line errors with a non-zero exit.

use std::path::{Path, PathBuf};

mod common;
use common::*;

/// A tet mesh written by another tool (meshio, zlib-compressed binary VTU;
/// `tests/data/ellipsoid-heart/make.py`).
const HEART_VTU: &str = "tests/data/ellipsoid-heart/heart.vtu";
const COBIVECO: &str = "tests/data/cobiveco-geo2";

fn info_json(path: &str) -> serde_json::Value {
    let o = unfold(&["info", path, "--json"]);
    assert!(o.status.success(), "info {path}: {}", stderr(&o));
    serde_json::from_str(&stdout(&o)).expect("info --json prints JSON")
}

#[test]
fn info_reads_a_meshio_written_heart_vtu() {
    let j = info_json(HEART_VTU);
    assert_eq!(j["points"], 3844);
    assert_eq!(j["cells"], 16848);
    assert_eq!(j["mesh_type"], "tetrahedral");
    assert_eq!(j["cell_types"]["Tetra"], 16848);
    assert!(
        j["cell_arrays"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["name"] == "Material")
    );
    let text = stdout(&unfold(&["info", HEART_VTU]));
    assert!(text.contains("points: 3844"), "{text}");
    assert!(text.contains("cells: 16848"), "{text}");
}

#[test]
fn info_reads_every_cobiveco_ply() {
    for (name, v, t, loops) in [
        ("heart_endo_lv.ply", 6309, 12479, 1),
        ("heart_endo_rv.ply", 5859, 11533, 1),
        ("heart_epi.ply", 11321, 22388, 1),
        ("heart_base.ply", 1349, 2125, 3),
    ] {
        let p = format!("{COBIVECO}/{name}");
        let j = info_json(&p);
        assert_eq!(j["points"], v, "{name}");
        assert_eq!(j["cells"], t, "{name}");
        assert_eq!(j["cell_types"]["Triangle"], t, "{name}");
        assert_eq!(
            j["boundary_loops"].as_array().map(Vec::len),
            Some(loops),
            "{name}"
        );
    }
}

#[test]
fn convert_keeps_the_heart_through_every_volume_format() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).display().to_string();
    let mut prev = HEART_VTU.to_string();
    for name in ["a.vtk", "b.mesh", "c.vtu", "d.vtk"] {
        let out = d(name);
        let o = unfold(&["convert", &prev, &out]);
        assert!(o.status.success(), "{prev} -> {out}: {}", stderr(&o));
        let j = info_json(&out);
        assert_eq!(j["points"], 3844, "{name}");
        assert_eq!(j["cells"], 16848, "{name}");
        prev = out;
    }
    // Arrays survive VTU -> VTK -> VTU (Medit keeps only its refs).
    let o = unfold(&["convert", HEART_VTU, &d("m.vtk"), "--ascii"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = unfold(&["convert", &d("m.vtk"), &d("m.vtu"), "--compress"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = info_json(HEART_VTU);
    let b = info_json(&d("m.vtu"));
    assert_eq!(a["bounding_box"], b["bounding_box"]);
    assert_eq!(a["cell_arrays"], b["cell_arrays"]);
}

#[test]
fn convert_converts_nifti_images_keeping_type_and_header() {
    use unfold::io::{Datatype, NiftiImage, read_image, write_image};
    use unfold::mesh::Volume;
    use unfold::mesh::nalgebra::Matrix4;
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).display().to_string();
    let mut affine = Matrix4::identity();
    affine[(0, 0)] = 1.5;
    affine[(2, 2)] = -2.0;
    affine[(0, 3)] = -30.0;
    let data: Vec<f32> = (0..4 * 5 * 6 * 2).map(|i| (i % 7) as f32 - 3.0).collect();
    let mut image = NiftiImage::new(Volume::new([4, 5, 6, 2], affine, data).unwrap())
        .with_datatype(Datatype::Int16);
    image.description = "labels".into();
    write_image(d("a.nii"), &image).unwrap();

    let o = unfold(&["convert", &d("a.nii"), &d("b.nii.gz")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("4 x 5 x 6 voxels, 2 frames, INT16"),
        "{}",
        stdout(&o)
    );
    let bytes = std::fs::read(d("b.nii.gz")).unwrap();
    assert_eq!(&bytes[..2], &[0x1f, 0x8b], "gzip");
    let (a, b) = (
        read_image(d("a.nii")).unwrap(),
        read_image(d("b.nii.gz")).unwrap(),
    );
    assert_eq!(b.datatype, Datatype::Int16);
    assert_eq!(b.volume, a.volume);
    assert_eq!(b.description, "labels");
    // And back: the same file.
    let o = unfold(&["convert", &d("b.nii.gz"), &d("c.nii")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d("c.nii")).unwrap(),
        std::fs::read(d("a.nii")).unwrap()
    );

    // Between a mesh and an image: refused, nothing written.
    assert_one_line_error(
        &unfold(&["convert", &d("a.nii"), &d("x.vtu")]),
        "between meshes or between images",
    );
    assert_one_line_error(
        &unfold(&["convert", HEART_VTU, &d("x.nii")]),
        "between meshes or between images",
    );
    assert!(!dir.path().join("x.vtu").exists() && !dir.path().join("x.nii").exists());
}

/// Control bytes in a file's array names and in file names never reach
/// the terminal raw: a file cannot retitle, recolour or ring it.
#[test]
fn control_bytes_from_files_are_escaped_on_the_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let evil = "bad\x1b]0;pwned\x07\x1b[31mname\u{9b}2J";
    let text = format!(
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n\
         0 0 0\n1 0 0\n0 1 0\nPOLYGONS 1 4\n3 0 1 2\nPOINT_DATA 3\n\
         SCALARS {evil} double 1\nLOOKUP_TABLE default\n1 2 3\n"
    );
    let p = dir.path().join("evil.vtk");
    std::fs::write(&p, text).unwrap();
    let raw = |b: &[u8]| {
        b.iter().any(|&c| c == 0x1b || c == 0x07) || String::from_utf8_lossy(b).contains('\u{9b}')
    };
    let o = unfold(&["info", &s(&p)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!raw(&o.stdout), "{}", stdout(&o));
    assert!(
        stdout(&o).contains("bad\\u{1b}]0;pwned\\u{7}"),
        "{}",
        stdout(&o)
    );
    // JSON escapes them, and the name reads back intact.
    let o = unfold(&["info", &s(&p), "--json"]);
    assert!(!raw(&o.stdout), "{}", stdout(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["point_arrays"][0]["name"], evil);
    // An error naming a hostile file name.
    let q = dir.path().join("x\x1b[2Jy\x07.xyz");
    std::fs::write(&q, "1 2 3").unwrap();
    let o = unfold(&["info", &s(&q)]);
    assert!(!o.status.success());
    assert!(!raw(&o.stderr), "{}", stderr(&o));
    assert_one_line_error(&o, "x\\u{1b}[2Jy\\u{7}.xyz");
}

#[test]
fn convert_refuses_to_overwrite_its_input() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.vtu");
    std::fs::copy(HEART_VTU, &p).unwrap();
    let before = std::fs::read(&p).unwrap();
    let s = p.display().to_string();
    assert_one_line_error(&unfold(&["convert", &s, &s]), "refusing to overwrite");
    assert_eq!(std::fs::read(&p).unwrap(), before);
}

#[test]
fn missing_unknown_and_garbage_files_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    assert_one_line_error(&unfold(&["info", "/no/such/file.vtu"]), "/no/such/file.vtu");
    let odd = dir.path().join("mesh.xyz");
    std::fs::write(&odd, "1 2 3").unwrap();
    assert_one_line_error(
        &unfold(&["info", &odd.display().to_string()]),
        "unknown file type",
    );
    for ext in [
        "vtk", "vtu", "vtp", "ply", "obj", "stl", "off", "mesh", "msh", "nii", "nii.gz",
    ] {
        let p = dir.path().join(format!("garbage.{ext}"));
        std::fs::write(&p, b"\x00\x01garbage\xff\xfe not a mesh\n 1 2 3\n").unwrap();
        let s = p.display().to_string();
        let o = unfold(&["info", &s]);
        // OBJ/OFF-like text may parse as an empty mesh; everything else must fail cleanly.
        if !o.status.success() {
            assert_one_line_error(&o, &s);
        }
    }
}

/// A legacy VTK file with the given points and cells (ASCII 4.2).
fn vtk(dir: &Path, name: &str, points: &[[f64; 3]], cells: &[&[u32]], tets: bool) -> String {
    let mut s =
        String::from("# vtk DataFile Version 4.2\nbad input\nASCII\nDATASET UNSTRUCTURED_GRID\n");
    s += &format!("POINTS {} double\n", points.len());
    for p in points {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    let size: usize = cells.iter().map(|c| c.len() + 1).sum();
    s += &format!("CELLS {} {size}\n", cells.len());
    for c in cells {
        let ids: Vec<String> = c.iter().map(u32::to_string).collect();
        s += &format!("{} {}\n", c.len(), ids.join(" "));
    }
    s += &format!("CELL_TYPES {}\n", cells.len());
    for _ in cells {
        s += if tets { "10\n" } else { "5\n" };
    }
    let p: PathBuf = dir.join(name);
    std::fs::write(&p, s).unwrap();
    p.display().to_string()
}

fn problem_kinds(path: &str) -> Vec<String> {
    let j = info_json(path);
    j["problems"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["kind"].as_str().unwrap().to_string())
        .collect()
}

const TET: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

#[test]
fn every_validation_error_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let square = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];

    // Errors that make the file unusable fail at reading.
    let p = vtk(d, "index.vtk", &TET, &[&[0, 1, 2, 9]], true);
    assert_one_line_error(&unfold(&["info", &p]), "point 9");
    let nan = [
        [0.0, 0.0, 0.0],
        [1.0, f64::NAN, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let p = vtk(d, "nan.vtk", &nan, &[&[0, 1, 2, 3]], true);
    assert_one_line_error(&unfold(&["info", &p]), "non-finite");

    // Problems of a readable mesh: reported by `info`, fatal with --strict.
    let good = vtk(d, "good.vtk", &TET, &[&[0, 1, 2, 3]], true);
    assert!(problem_kinds(&good).is_empty());
    assert!(unfold(&["info", &good, "--strict"]).status.success());

    let mut pts = TET.to_vec();
    pts.push([0.5, 0.5, 0.0]); // coplanar with 0, 1, 2
    let cases: Vec<(&str, String)> = vec![
        (
            "inverted_element",
            vtk(d, "inv.vtk", &TET, &[&[0, 2, 1, 3]], true),
        ),
        (
            "degenerate_element",
            vtk(d, "deg.vtk", &pts, &[&[0, 1, 2, 3], &[0, 1, 2, 4]], true),
        ),
        (
            "unused_vertices",
            vtk(d, "unused.vtk", &pts, &[&[0, 1, 2, 3]], true),
        ),
        ("non_manifold_face", {
            let mut q = TET.to_vec();
            q.extend([[0.2, 0.2, 0.5], [0.1, 0.3, 0.7]]);
            vtk(
                d,
                "nmface.vtk",
                &q,
                &[&[0, 1, 2, 3], &[0, 1, 2, 4], &[0, 1, 2, 5]],
                true,
            )
        }),
        ("non_manifold_edge", {
            let mut q = square.to_vec();
            q.push([0.5, 0.0, 1.0]);
            vtk(
                d,
                "nmedge.vtk",
                &q,
                &[&[0, 1, 2], &[1, 0, 3], &[0, 1, 4]],
                false,
            )
        }),
        (
            "inconsistent_orientation",
            vtk(d, "orient.vtk", &square, &[&[0, 1, 2], &[0, 3, 2]], false),
        ),
    ];
    for (kind, path) in &cases {
        let kinds = problem_kinds(path);
        assert!(
            kinds.iter().any(|k| k == kind),
            "{path}: {kinds:?} lacks {kind}"
        );
        assert_one_line_error(&unfold(&["info", path, "--strict"]), "validity problem");
    }
    // Several components are counted, not a validity problem (a valve's two
    // leaflets are one valid file).
    let mut q = TET.to_vec();
    q.extend(TET.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
    let two = vtk(d, "two.vtk", &q, &[&[0, 1, 2, 3], &[4, 5, 6, 7]], true);
    let j = info_json(&two);
    assert_eq!(j["components"], 2);
    assert_eq!(j["valid"], true, "{}", j["problems"]);
    assert!(unfold(&["info", &two, "--strict"]).status.success());
}

#[test]
fn demo_writes_valid_shapes_an_image_and_their_info() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let o = unfold(&["demo", "-o", &out.display().to_string()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("info.json")).unwrap()).unwrap();
    let files = info.as_object().unwrap();
    assert!(files.len() >= 9, "{:?}", files.keys());
    for (name, i) in files {
        assert!(out.join(name).is_file(), "{name} listed but missing");
        if i["kind"] == "mesh" {
            assert_eq!(i["valid"], true, "{name}: {}", i["problems"]);
        }
    }
    // The pipelines' own outputs are valid files too (--strict passes).
    for output in [
        "placenta/original.vtu",
        "placenta/flattened.vtu",
        "ventricle/normalized.vtu",
        "ventricle/anatomy.vtu",
        "ventricle/disk.vtu",
        "mitral/valve3d.vtu",
        "mitral/valve2d.vtu",
    ] {
        let p = out.join(output).display().to_string();
        let o = unfold(&["info", &p, "--strict"]);
        assert!(o.status.success(), "{output}: {}", stderr(&o));
    }
    let slab = &files["placenta.vtu"];
    assert_eq!(slab["mesh_type"], "tetrahedral");
    assert_eq!(slab["components"], 1);
    assert_eq!(slab["boundary_surface"]["euler_characteristic"], 2);
    assert!(
        slab["point_arrays"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["name"] == "side")
    );
    for leaflet in [
        "valve_anterior.vtu",
        "valve_posterior.vtu",
        "ventricle_surface.vtu",
    ] {
        assert_eq!(
            files[leaflet]["boundary_loops"].as_array().unwrap().len(),
            1,
            "{leaflet}"
        );
    }
    let img = info_json(&out.join("placenta_mri.nii.gz").display().to_string());
    assert_eq!(img["kind"], "image");
    assert_eq!(img["datatype"], "float32");
    assert_eq!(img["affine_source"], "sform");
    let spacing: Vec<f64> = img["spacing_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(
        spacing.iter().all(|s| (s - 2.0).abs() < 1e-6),
        "{spacing:?}"
    );
}

#[test]
fn converting_tets_to_a_surface_format_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["stl", "ply", "obj", "off", "vtp"] {
        let out = dir.path().join(format!("heart.{ext}"));
        let s = out.display().to_string();
        assert_one_line_error(&unfold(&["convert", HEART_VTU, &s]), &s);
        assert!(!out.exists(), "{ext}: a failed conversion left a file");
    }
    let out = dir.path().join("heart.msh").display().to_string();
    assert_one_line_error(&unfold(&["convert", HEART_VTU, &out]), "Gmsh");
}

/// Outputs honour the process umask (patient data in shared directories):
/// under `umask 077` a new file is 0600, and a replaced file keeps its mode.
#[cfg(unix)]
#[test]
fn outputs_honour_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("heart.vtk");
    let run = |mask: &str| {
        std::process::Command::new("sh")
            .arg("-c")
            .arg(format!("umask {mask} && exec \"$0\" convert \"$1\" \"$2\""))
            .arg(env!("CARGO_BIN_EXE_unfold"))
            .arg(HEART_VTU)
            .arg(&out)
            .output()
            .unwrap()
    };
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_ok(&run("077"));
    assert_eq!(mode(&out), 0o600);
    std::fs::remove_file(&out).unwrap();
    assert_ok(&run("027"));
    assert_eq!(mode(&out), 0o640);
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o604)).unwrap();
    assert_ok(&run("077"));
    assert_eq!(mode(&out), 0o604, "a replaced file keeps its mode");
}

/// `info --strict` fails on a mesh file with no vertex at all (a file of
/// bare points is fine).
#[test]
fn info_strict_fails_on_an_empty_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.vtk");
    std::fs::write(
        &empty,
        "# vtk DataFile Version 4.2\nempty\nASCII\nDATASET POLYDATA\nPOINTS 0 float\n",
    )
    .unwrap();
    let e = empty.display().to_string();
    assert_one_line_error(&unfold(&["info", &e, "--strict"]), "the mesh is empty");
    let points = dir.path().join("points.vtk");
    std::fs::write(
        &points,
        "# vtk DataFile Version 4.2\npts\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\n",
    )
    .unwrap();
    assert_ok(&unfold(&[
        "info",
        &points.display().to_string(),
        "--strict",
    ]));
}
