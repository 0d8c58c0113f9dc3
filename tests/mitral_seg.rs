//! `unfold mitral --seg`: a valve cut from a label map built here (a saddle
//! annulus ring of label 1, two leaflet slabs of labels 2 and 3 below it
//! meeting at a coaptation line, 0.75 mm voxels, a rotated and moved
//! affine), written as NIfTI and NRRD; bad label maps and leaflet files
//! that are not surfaces get one-line errors naming the route.

use std::path::Path;
use std::process::Output;
use unfold::io::{Datatype, NiftiImage, write_image, write_mesh};
use unfold::mesh::shapes::{ValveLabelParams, valve_labels};
use unfold::mesh::{CellMesh, Volume};

mod common;
use common::*;

fn write_labels(path: &Path, v: Volume<f32>) {
    write_image(path, &NiftiImage::new(v).with_datatype(Datatype::Int16)).unwrap();
}

fn seg(map: &Path, out: &Path, extra: &[&str]) -> Output {
    let (m, o) = (s(map), s(out));
    let mut args = vec!["mitral", "--seg", &m, "-o", &o, "--no-figures"];
    args.extend(extra);
    unfold(&args)
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

#[test]
fn a_label_map_maps_flip_free_on_its_annulus_nifti_and_nrrd() {
    let d = tempfile::tempdir().unwrap();
    let p = ValveLabelParams::default();
    let want = p.ring_length_mm();
    for (name, annulus) in [("labels.nii.gz", true), ("labels.nrrd", false)] {
        let map = d.path().join(name);
        write_labels(&map, valve_labels(&p));
        let out = d.path().join(format!("out-{name}"));
        let mut flags = vec!["--anterior-label", "2", "--posterior-label", "3"];
        if annulus {
            flags.extend(["--annulus-label", "1"]);
        }
        let o = seg(&map, &out, &flags);
        assert_ok(&o);
        let r = report(&out);
        let sg = &r["segmentation"];
        println!(
            "{name}: annulus {} mm (generated ring {want:.1} mm), flipped {}, triangles {} + {}, \
             gates {}",
            r["annulus_length_mm"],
            r["flipped_triangles"],
            sg["triangles"]["anterior"],
            sg["triangles"]["posterior"],
            sg["gates"]
        );
        assert_eq!(r["flipped_triangles"], 0, "{r}");
        let length = r["annulus_length_mm"].as_f64().unwrap();
        assert!((length / want - 1.0).abs() < 0.1, "{length} vs {want}");
        assert_eq!(sg["anterior_label"], 2);
        assert_eq!(
            sg["annulus_label"],
            if annulus {
                1.into()
            } else {
                serde_json::Value::Null
            }
        );
        assert!(sg["triangles"]["posterior"].as_u64().unwrap() > 100);
        assert!(
            sg["gates"]
                .as_array()
                .unwrap()
                .iter()
                .all(|g| g["passed"] == true)
        );
    }
}

#[test]
fn bad_label_maps_and_flags_get_one_line_errors() {
    let d = tempfile::tempdir().unwrap();
    let p = ValveLabelParams::default();
    let map = d.path().join("labels.nii.gz");
    write_labels(&map, valve_labels(&p));
    let out = d.path().join("out");
    let o = seg(
        &map,
        &out,
        &["--anterior-label", "7", "--posterior-label", "3"],
    );
    assert_one_line_error(&o, "label 7 has no voxel; the map holds labels 0, 1, 2, 3");
    let o = seg(&map, &out, &["--anterior-label", "2"]);
    assert_one_line_error(&o, "give --anterior-label A --posterior-label P");
    let grey = d.path().join("grey.nii.gz");
    write_image(&grey, &NiftiImage::new(valve_labels(&p).map(|v| v * 0.37))).unwrap();
    let o = seg(
        &grey,
        &out,
        &["--anterior-label", "2", "--posterior-label", "3"],
    );
    assert_one_line_error(&o, "is not a label map");
    let o = unfold(&[
        "mitral",
        "--anterior",
        &s(&map),
        "--posterior",
        &s(&map),
        "-o",
        &s(&out),
    ]);
    assert_one_line_error(
        &o,
        "is an image, not a leaflet surface; from a label map, give --seg",
    );
    // a closed surface as a leaflet
    let sphere = unfold::mesh::shapes::uv_sphere(8, 12, 5.0);
    let closed = d.path().join("closed.vtu");
    write_mesh(&closed, &CellMesh::from(&sphere), &Default::default()).unwrap();
    let o = unfold(&[
        "mitral",
        "--anterior",
        &s(&closed),
        "--posterior",
        &s(&closed),
        "-o",
        &s(&out),
    ]);
    assert_one_line_error(&o, "is a closed surface");
    assert!(!out.exists());
}
