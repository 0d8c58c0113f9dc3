//! Read and write a 1,000,000-tet binary VTU (appended raw, and zlib).
//!
//! Run: `cargo bench --bench io_vtu`

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use unfold::io::{MeshFormat, WriteOptions, read_mesh, write_mesh};
use unfold::mesh::{CellMesh, Field, TetMesh};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// A structured grid of `n[0] x n[1] x n[2]` boxes, 6 Kuhn tets each, with a
/// cell label and a point scalar.
fn kuhn_grid(n: [usize; 3]) -> TetMesh {
    let mut m = unfold::mesh::shapes::kuhn_grid(n, [1.0, 1.0, 1.5]);
    let labels = (0..m.num_tets() as i32).map(|t| t % 5).collect();
    m.add_cell_field(Field::labels("Material", labels)).unwrap();
    let x: Vec<f64> = m.positions.iter().map(|p| p.x.sin()).collect();
    m.add_point_field(Field::scalars("f", x)).unwrap();
    m
}

fn bench(c: &mut Criterion) {
    let mesh = CellMesh::from(&kuhn_grid([64, 64, 41]));
    assert!(mesh.num_cells() > 1_000_000);
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("vtu_1m_tets");
    g.sample_size(10);
    for (name, compress) in [("raw", false), ("zlib", true)] {
        let opts = WriteOptions {
            compress,
            ..WriteOptions::default()
        };
        let path = dir.path().join(format!("{name}.vtu"));
        g.bench_function(format!("write_{name}"), |b| {
            b.iter(|| write_mesh(&path, black_box(&mesh), &opts).unwrap())
        });
        g.bench_function(format!("read_{name}"), |b| {
            b.iter(|| black_box(read_mesh(&path).unwrap()))
        });
        let bytes = MeshFormat::Vtu.write_bytes(&mesh, &opts).unwrap();
        g.bench_function(format!("parse_{name}_in_memory"), |b| {
            b.iter(|| black_box(MeshFormat::Vtu.read_bytes(&bytes).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
