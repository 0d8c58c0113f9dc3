//! The foundation from code: read (or generate) a surface, check it, repair
//! it, and ask it questions.
//!
//! ```sh
//! cargo run --example mesh_basics                                   # the synthetic ventricle cup
//! cargo run --example mesh_basics -- tests/data/cobiveco-geo2/heart_endo_lv.ply
//! ```

use unfold::io::{WriteOptions, read_tri_mesh, write_mesh};
use unfold::mesh::geodesic::EdgeGraph;
use unfold::mesh::geometry::{pca_frame, total_area};
use unfold::mesh::repair::repair_tri_mesh;
use unfold::mesh::shapes::{VentricleParams, ventricle_cup};
use unfold::mesh::spatial::ClosestPointQuery;
use unfold::mesh::topology::boundary_loops;
use unfold::mesh::validate::{ValidationOptions, check_tri_mesh};
use unfold::mesh::{CellMesh, Field};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let surface = match std::env::args().nth(1) {
        Some(path) => read_tri_mesh(&path)?,
        None => ventricle_cup(&VentricleParams::default())?.surface,
    };
    println!(
        "{} vertices, {} triangles, area {:.1} mm^2",
        surface.num_vertices(),
        surface.num_triangles(),
        total_area(&surface)
    );

    // Validity: every kind of problem, with a count.
    for p in check_tri_mesh(&surface, &ValidationOptions::default()) {
        println!("problem: {} (x{})", p.error, p.count);
    }
    // Real surfaces are messy: repair says what it changed.
    let (surface, report) = repair_tri_mesh(&surface)?;
    println!("repair: {report}");

    let loops = boundary_loops(&surface)?;
    println!(
        "boundary loops: {:?}",
        loops.iter().map(Vec::len).collect::<Vec<_>>()
    );

    // Principal axes (a proper rotation) and geodesic distance from the rim.
    let frame = pca_frame(&surface.positions).ok_or("no vertices")?;
    println!("principal variances (mm^2): {:?}", frame.variances);
    let graph = EdgeGraph::from_tri_mesh(&surface);
    let rim: Vec<u32> = loops.first().cloned().unwrap_or_default();
    let from_rim = graph.distances(&rim);
    let far = from_rim
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    println!("farthest vertex from the rim along edges: {far:.1} mm");

    // Closest point on the surface to its own centroid.
    let query = ClosestPointQuery::new(&surface);
    if let Some(hit) = query.closest(&frame.centroid) {
        println!(
            "closest point to the centroid: triangle {} at {:.2} mm",
            hit.triangle, hit.distance
        );
    }

    // Fields ride along to the writers.
    let mut out = surface.clone();
    out.add_point_field(Field::scalars("distance_from_rim", from_rim))?;
    let path = std::env::temp_dir().join("unfold_mesh_basics.vtp");
    write_mesh(&path, &CellMesh::from(&out), &WriteOptions::default())?;
    println!("wrote {}", path.display());
    Ok(())
}
