//! The Rust side of `benches/python_overhead.py`: the placenta pipeline
//! called from Rust on the 7,200-tet slab (`cells_radial = 10`,
//! `cells_through = 4`), the same call `unfold.placenta` makes with its
//! defaults, timed from the tet mesh in memory to the `Outcome` (the
//! preparation, parcellation, alignment, Newton and the evaluation).
//!
//! Prints one line `seconds S` per timed run after one untimed warm-up run.
//! Run with `cargo bench --bench placenta_call -- RUNS` (RUNS default 5);
//! the script runs it and the Python call in turns and prints the ratio.

use std::time::Instant;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::organs::Quiet;
use unfold::organs::placenta::Pipeline;

/// The allocator the `unfold` command and the Python module use.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    // `cargo bench` passes `--bench`; the first number is the run count.
    let runs = std::env::args()
        .skip(1)
        .find_map(|a| a.parse::<usize>().ok())
        .unwrap_or(5);
    let mesh = placenta_slab(&PlacentaParams {
        cells_radial: 10,
        cells_through: 4,
        ..PlacentaParams::default()
    })
    .expect("the slab's parameters are valid")
    .mesh;
    println!("tets {}", mesh.tets.len());
    for run in 0..=runs {
        let start = Instant::now();
        let outcome = Pipeline::new()
            .run(&mesh, &[], &mut Quiet)
            .expect("the slab flattens");
        let seconds = start.elapsed().as_secs_f64();
        assert!(outcome.report.converged, "{:?}", outcome.report.stop_reason);
        if run > 0 {
            println!("seconds {seconds}");
        }
    }
}
