//! A slab wound through itself: locally injective, overlapping globally.

use unfold::mesh::TetMesh;
use unfold::mesh::nalgebra::Point3;

/// A long slab (`n` x 2 x 3 cells of 1.5 mm) wound round the z axis
/// through `turns` turns at radius 30 mm, climbing 0.5 mm and moving in
/// 0.5 mm per turn: every tet positive, no folded face; with more than
/// one turn its ends pass through each other.
pub fn wound_slab(n: usize, turns: f64) -> TetMesh {
    let mut m = unfold::mesh::shapes::kuhn_grid([n, 2, 3], [1.5; 3]);
    let len = 1.5 * n as f64;
    for p in &mut m.positions {
        let f = turns * p.x / len;
        let th = 2.0 * std::f64::consts::PI * f;
        let r = 30.0 - p.y - 0.5 * f;
        *p = Point3::new(r * th.cos(), r * th.sin(), p.z + 0.5 * f);
    }
    m
}
