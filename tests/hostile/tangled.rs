//! Tangled meshes: locally folded (a vertex dragged past its neighbour, a
//! strong jitter) are refused naming the first folded face, never mapped
//! with folds.

use crate::harness::{Case, args, run, s};
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::nalgebra::Vector3;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::mesh::{CellMesh, TetMesh};

fn slab() -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial: 6,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .unwrap()
    .mesh
}

fn refused(dir: &std::path::Path, name: &str, mesh: &TetMesh, expect: &str) {
    let input = dir.join(format!("{name}.vtu"));
    write_mesh(&input, &CellMesh::from(mesh), &WriteOptions::default()).unwrap();
    let out = dir.join(format!("{name}_out"));
    run(&Case {
        name,
        args: args(&["placenta", &s(&input), "-o", &s(&out), "--no-figures"]),
        expect,
        max_peak_mib: 150.0,
        inputs: vec![input],
        output: Some(out),
    });
}

#[test]
fn folded_slabs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let clean = slab();
    let boundary = unfold::mesh::topology::tet_boundary(&clean).unwrap();
    let on_boundary: std::collections::HashSet<u32> = boundary.to_volume.iter().copied().collect();
    let (a, b) = clean
        .tets
        .iter()
        .find_map(|t| {
            let a = *t.iter().find(|v| !on_boundary.contains(v))?;
            Some((a as usize, *t.iter().find(|&&v| v != a)? as usize))
        })
        .expect("an interior vertex");
    let mut dragged = clean.clone();
    let (pa, pb) = (clean.positions[a], clean.positions[b]);
    dragged.positions[a] = pa + (pb - pa) * 1.7;
    refused(
        dir.path(),
        "dragged vertex",
        &dragged,
        "the mesh is tangled",
    );

    let mut jittered = clean.clone();
    for (k, p) in jittered.positions.iter_mut().enumerate() {
        let f = k as f64;
        *p += Vector3::new(
            3.0 * (1.3 * f).sin(),
            3.0 * (2.1 * f).cos(),
            1.5 * (0.7 * f).sin(),
        );
    }
    refused(
        dir.path(),
        "jittered slab",
        &jittered,
        "the mesh is tangled",
    );
    // no local fold, but the ends pass through each other
    let wound = wound::wound_slab(150, 1.25);
    refused(
        dir.path(),
        "slab wound through itself",
        &wound,
        "the mesh overlaps itself",
    );
}

#[path = "../common/wound.rs"]
mod wound;
