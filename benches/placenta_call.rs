//! The Rust side of `benches/python_overhead.py`: the placenta pipeline
//! called from Rust on the 7,200-tet slab (`cells_radial = 10`,
//! `cells_through = 4`), the same call `unfold.placenta` makes with its
//! defaults, timed from the tet mesh in memory to the `Outcome` (the
//! preparation, parcellation, alignment, Newton and the evaluation).
//!
//! Prints one line `seconds S` per timed run after one untimed warm-up run,
//! then a summary: the median of the timed runs beside the peak resident
//! memory of a process that builds the slab and runs the call once
//! (`support/peak.rs`).
//! Run with `cargo bench --bench placenta_call -- RUNS` (RUNS default 5);
//! the script runs it and the Python call in turns and prints the ratio.

#[path = "support/peak.rs"]
mod peak;
#[path = "support/summary.rs"]
mod summary;

use summary::{Runs, Summary};
use unfold::mesh::TetMesh;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::organs::Quiet;
use unfold::organs::placenta::Pipeline;

/// The allocator the `unfold` command and the Python module use.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The one case's name.
const CASE: &str = "slab_7k";

fn slab() -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial: 10,
        cells_through: 4,
        ..PlacentaParams::default()
    })
    .expect("the slab's parameters are valid")
    .mesh
}

/// The timed call; asserts convergence.
fn call(mesh: &TetMesh) {
    let outcome = Pipeline::new()
        .run(mesh, &[], &mut Quiet)
        .expect("the slab flattens");
    assert!(outcome.report.converged, "{:?}", outcome.report.stop_reason);
}

fn main() {
    // A child of `peak::measure`: one call, then exit.
    peak::serve(|case| {
        assert_eq!(case, CASE, "placenta_call bench: no case {case}");
        call(&slab());
    });
    // `cargo bench` passes `--bench`; the first number is the run count.
    let runs = std::env::args()
        .skip(1)
        .find_map(|a| a.parse::<usize>().ok())
        .unwrap_or(5);
    let mesh = slab();
    println!("tets {}", mesh.tets.len());
    call(&mesh); // warm-up, not timed
    let mut times = Runs::default();
    for _ in 0..runs {
        let seconds = times.time(1, || call(&mesh)).as_secs_f64();
        println!("seconds {seconds}");
    }
    let mut summary = Summary::default();
    summary.add(CASE, format!("{} tets", mesh.tets.len()), &times);
    summary.print("placenta_call summary (the library call from Rust, timed runs):");
}
