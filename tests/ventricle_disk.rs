//! The LV disk map on the real enclosing surfaces (issue 6, in progress):
//! Cobiveco geo2's epicardium (`tests/data/cobiveco-geo2`, Apache-2.0) and a
//! synthetic ellipsoid's (`tests/data/ellipsoid-heart`) flatten without a flipped triangle, the rim on
//! the unit circle and the apex at the centre.

use unfold::io::read_tri_mesh;
use unfold::mesh::validate::{ValidationOptions, check_tri_mesh};
use unfold::mesh::{MeshError, TriMesh};
use unfold::organs::ventricle::disk::lv_disk;
use unfold::organs::ventricle::harmonic_disk::HarmonicDisk;
use unfold::organs::ventricle::landmarks::{DEFAULT_SNAP_MM, Landmarks};
use unfold::param::initializer::disk_boundary_loop;

/// Flattens `s` and checks the disk: no flip, rim on the unit circle, apex
/// at the centre, the anterior landmark on +y. Two rim points a third of
/// the loop apart stand in for the RV insertion points (the data sets do
/// not mark them).
fn flattens_flip_free(name: &str, s: &TriMesh) {
    let rim = disk_boundary_loop(s).unwrap();
    let (a, i) = (
        s.positions[rim[0] as usize],
        s.positions[rim[rim.len() / 3] as usize],
    );
    let l = Landmarks::resolve(s, &a, &i, None, DEFAULT_SNAP_MM).unwrap();
    let d = lv_disk(s, &l, &HarmonicDisk).unwrap();
    println!(
        "{name}: {} vertices, {} triangles, rim {}: flipped {}, weights {}, apex warp {}",
        s.positions.len(),
        s.triangles.len(),
        rim.len(),
        d.flipped_triangles,
        d.weights,
        d.apex_warp
    );
    assert_eq!(d.flipped_triangles, 0, "{name}");
    assert_eq!(d.uv[l.apex as usize], [0.0, 0.0], "{name}");
    for &v in &l.rim {
        let q = d.uv[v as usize];
        assert!((q[0].hypot(q[1]) - 1.0).abs() < 1e-12, "{name}");
    }
    let qa = d.uv[l.rim[l.anterior] as usize];
    assert!(qa[1] > 0.0, "{name}: anterior on +y: {qa:?}");
}

#[test]
fn cobiveco_epicardium_flattens_flip_free() {
    let s = read_tri_mesh("tests/data/cobiveco-geo2/heart_epi.ply").unwrap();
    flattens_flip_free("cobiveco geo2", &s);
}

/// The synthetic ellipsoid's epicardium comes with every second triangle
/// the other way round: after the mesh repair it is
/// a disk, and it flattens without a flipped triangle.
#[test]
fn ellipsoid_epicardium_flattens_flip_free_after_repair() {
    let raw = read_tri_mesh("tests/data/ellipsoid-heart/epi.obj").unwrap();
    let problems = check_tri_mesh(&raw, &ValidationOptions::default());
    let inconsistent = problems
        .iter()
        .find(|p| matches!(p.error, MeshError::InconsistentOrientation { .. }))
        .expect("inconsistent as read");
    // Every second triangle reversed: most interior edges disagree.
    assert!(
        inconsistent.count > raw.triangles.len() / 2,
        "{inconsistent}"
    );
    let (s, report) = unfold::mesh::repair::repair_tri_mesh(&raw).unwrap();
    assert!(report.flipped > 0);
    flattens_flip_free("ellipsoid (repaired)", &s);
}
