//! The LV disk map on the real enclosing surfaces (issue 6, in progress):
//! Cobiveco geo2's and the LDRB ellipsoid's epicardia (`../shared/data/`,
//! licences in its README) flatten without a flipped triangle, the rim on
//! the unit circle and the apex at the centre.

use unfold::io::read_tri_mesh;
use unfold::mesh::TriMesh;
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
    let s = read_tri_mesh("../shared/data/cobiveco-geo2/heart_epi.ply").unwrap();
    flattens_flip_free("cobiveco geo2", &s);
}

/// The LDRB ellipsoid's epicardium (`../shared/data/ldrb-ellipsoid`) comes
/// with half its triangles the other way round: after the mesh repair it is
/// a disk, and it flattens without a flipped triangle.
#[test]
fn ldrb_epicardium_flattens_flip_free_after_repair() {
    let raw = read_tri_mesh("../shared/data/ldrb-ellipsoid/epi.obj").unwrap();
    assert!(disk_boundary_loop(&raw).is_err(), "inconsistent as read");
    let (s, report) = unfold::mesh::repair::repair_tri_mesh(&raw).unwrap();
    assert!(report.flipped > 0 && report.non_orientable_components == 0);
    flattens_flip_free("ldrb ellipsoid (repaired)", &s);
}
