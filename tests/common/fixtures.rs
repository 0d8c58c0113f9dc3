//! The organ inputs the tests build from the library's synthetic shapes
//! and write as files: a placenta slab, a small mitral valve and its
//! annulus ring.

#![allow(dead_code)] // each test crate uses its own subset

use std::path::{Path, PathBuf};
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{PlacentaParams, ValveParams, ValveShape, mitral_valve, placenta_slab};
use unfold::mesh::{CellMesh, CellType, TetMesh, TriMesh};

/// A placenta slab of `18 n^2 m` tets (`n` radial cells, `m` layers).
pub fn slab_mesh(cells_radial: usize, cells_through: usize) -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial,
        cells_through,
        ..PlacentaParams::default()
    })
    .expect("valid slab parameters")
    .mesh
}

/// Writes a tet mesh to `path`.
pub fn write_tets(path: &Path, mesh: &TetMesh) {
    write_mesh(path, &CellMesh::from(mesh), &WriteOptions::default()).expect("mesh written");
}

/// A small valve: 40 annulus segments, 8 rows down the leaflets.
pub fn small_valve() -> ValveShape {
    mitral_valve(&ValveParams {
        annulus_segments: 40,
        depth_segments: 8,
        ..ValveParams::default()
    })
    .unwrap()
}

/// A closed polyline through `points`.
pub fn ring_mesh(points: &[Point3<f64>]) -> CellMesh {
    let mut m = CellMesh::from_points(points.to_vec());
    let mut ids: Vec<u32> = (0..points.len() as u32).collect();
    ids.push(0);
    m.push_cell(CellType::PolyLine, &ids);
    m
}

/// Writes a valve's three files into `dir` with `prefix`; returns their
/// paths (anterior, posterior, annulus).
pub fn write_valve(
    dir: &Path,
    prefix: &str,
    anterior: &TriMesh,
    posterior: &TriMesh,
    ring: &[Point3<f64>],
) -> [PathBuf; 3] {
    let a = dir.join(format!("{prefix}anterior.vtp"));
    let p = dir.join(format!("{prefix}posterior.vtp"));
    let r = dir.join(format!("{prefix}annulus.vtp"));
    let opts = WriteOptions::default();
    write_mesh(&a, &CellMesh::from(anterior), &opts).unwrap();
    write_mesh(&p, &CellMesh::from(posterior), &opts).unwrap();
    write_mesh(&r, &ring_mesh(ring), &opts).unwrap();
    [a, p, r]
}
