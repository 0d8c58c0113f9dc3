//! The LV disk map on a real enclosing surface (issue 6, in progress):
//! Cobiveco geo2's epicardium (`../shared/data/cobiveco-geo2`, see its
//! licence in `../shared/data/README.md`) flattens without a flipped
//! triangle, its rim on the unit circle and its apex at the centre.

use unfold::io::read_tri_mesh;
use unfold::organs::ventricle::disk::lv_disk;
use unfold::organs::ventricle::landmarks::{DEFAULT_SNAP_MM, Landmarks};
use unfold::param::initializer::disk_boundary_loop;

#[test]
fn cobiveco_epicardium_flattens_flip_free() {
    let s = read_tri_mesh("../shared/data/cobiveco-geo2/heart_epi.ply").unwrap();
    let rim = disk_boundary_loop(&s).unwrap();
    // Two rim points a third of the loop apart stand in for the RV
    // insertion points (the data set does not mark them).
    let (a, i) = (
        s.positions[rim[0] as usize],
        s.positions[rim[rim.len() / 3] as usize],
    );
    let l = Landmarks::resolve(&s, &a, &i, None, DEFAULT_SNAP_MM).unwrap();
    let d = lv_disk(&s, &l).unwrap();
    println!(
        "{} vertices, {} triangles, rim {}: flipped {}, weights {}",
        s.positions.len(),
        s.triangles.len(),
        rim.len(),
        d.flipped_triangles,
        d.weights
    );
    assert_eq!(d.flipped_triangles, 0);
    assert_eq!(d.uv[l.apex as usize], [0.0, 0.0]);
    for &v in &l.rim {
        let q = d.uv[v as usize];
        assert!((q[0].hypot(q[1]) - 1.0).abs() < 1e-12);
    }
    let qa = d.uv[l.rim[l.anterior] as usize];
    assert!(qa[1] > 0.0, "anterior on +y: {qa:?}");
}
