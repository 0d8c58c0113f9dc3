//! `unfold deform` on its benchmark problem, the bowl-shaped shell
//! ([`bowl_shell`]: radius 60 mm, 8 mm thick, 60 degree opening) flattened
//! into an 8 mm slab: every vertex of the top (inner) surface gets the target
//! `(x, y, +4)` and every vertex of the bottom (outer) surface `(x, y, -4)`,
//! `(x, y)` being its own rest coordinates; rim vertices have no target
//! (the problem of `tests/deform.rs`). It minimizes
//!
//! ```text
//! E(x) = sum_k (V_k / sum_j V_j) (|J_k|_F^2 + |J_k^-1|_F^2)  +  W sum_b |x_b - t_b|^2
//! ```
//!
//! (symmetric Dirichlet, `V_k` the rest volumes) from the identity with
//! projected Newton, stopping at `|grad E|_F < 1e-4` (the command's
//! defaults but the weight), through the command's own library call
//! ([`deform_mesh`]: repair, memory check, solve), on two meshes:
//!
//! - `bowl_7k`: the default [`ShellParams`] (`cells_radial = 14`,
//!   `cells_through = 2`): 1,893 vertices, 7,056 tets;
//! - `bowl_60k`: `cells_radial = 41`, `cells_through = 2`: 15,501
//!   vertices, 60,516 tets;
//!
//! each with `W = 1000` (the benchmark's weight: the targets met to about
//! 1e-6 mm; `deform/bowl_7k_w1000`, `deform/bowl_60k_w1000`) and with
//! `W = 1` (soft targets, where SLIM gets closer to the minimum;
//! `deform/bowl_7k_w1`, `deform/bowl_60k_w1`).
//!
//! Before timing, one solve per case asserts convergence and 0 inverted
//! tets, and writes the problem and our result for `benches/slim_compare.py`
//! (libigl's SLIM on the same meshes and targets) into `DEFORM_BENCH_DIR`
//! (default `target/deform-bench`): `MESH.vtu` (the rest mesh),
//! `MESH.targets.csv` (`vertex,x,y,z`, the format of `unfold deform
//! --targets`), `CASE.ours.vtu` (our deformed mesh) and `CASE.ours.json`
//! (settings, median seconds, iterations, `E` and its parts, and the
//! objective after every Newton iteration with its time, from one more run
//! through [`Deform::run_with`]). The summary printed at the end gives per
//! case the median seconds, iterations and `E`, and beside each median the
//! peak resident memory of a process that builds the bowl and solves it
//! once (`support/peak.rs`).
//!
//! Target (issue 21): at least 3x less time than SLIM at equal or lower `E`
//! on the 60k mesh. Run with `cargo bench --bench deform` (about 3 minutes
//! on 2 cores), or through `benches/slim_compare.py`, which runs this bench
//! and then SLIM and prints both with their ratio.

#[path = "support/peak.rs"]
mod peak;
#[path = "support/summary.rs"]
mod summary;

use criterion::{Criterion, SamplingMode, criterion_group};
use serde_json::json;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use summary::{Runs, Summary};
use unfold::app::deform::{Deformed, Inputs, Rest, Settings as DeformSettings, deform_mesh};
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::shapes::{ShellParams, ShellShape, bowl_shell};
use unfold::mesh::{CellMesh, TetMesh};
use unfold::param::energy::SymmetricDirichlet;
use unfold::param::solver::History;
use unfold::param::{Deform, DeformReport, ProjectedNewton, Solver};

/// The allocator the `unfold` command uses (see `src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// `W` of the target term: the benchmark's, then a soft one.
const WEIGHTS: [f64; 2] = [1000.0, 1.0];
/// The gradient-norm tolerance (`--tol`, the command's default).
const TOL: f64 = 1e-4;

/// One bowl: the mesh as `unfold deform` reads it and the flattening targets.
struct Bowl {
    name: &'static str,
    tets: TetMesh,
    cells: CellMesh,
    targets: Vec<(usize, [f64; 3])>,
}

impl Bowl {
    fn new(name: &'static str, cells_radial: usize, cells_through: usize) -> Bowl {
        let shape = bowl_shell(&ShellParams {
            cells_radial,
            cells_through,
            ..ShellParams::default()
        })
        .expect("valid shell parameters");
        let targets = flat_targets(&shape);
        Bowl {
            name,
            cells: CellMesh::from(&shape.mesh),
            tets: shape.mesh,
            targets,
        }
    }

    /// Writes `NAME.vtu` and `NAME.targets.csv` into `dir`.
    fn write(&self, dir: &Path) {
        write_mesh(
            dir.join(format!("{}.vtu", self.name)),
            &self.cells,
            &WriteOptions::default(),
        )
        .expect("write mesh");
        let mut csv = String::from("vertex,x,y,z\n");
        for (v, t) in &self.targets {
            csv += &format!("{v},{},{},{}\n", t[0], t[1], t[2]);
        }
        std::fs::write(dir.join(format!("{}.targets.csv", self.name)), csv).expect("write csv");
    }

    /// The command's library call with weight `weight`; the mesh is copied
    /// before the clock starts (the command owns the mesh it read).
    fn solve(&self, weight: f64) -> (Deformed, f64) {
        let inputs = Inputs {
            mesh: self.name.into(),
            targets: Some("targets".into()),
            init: None,
            fixed_file: None,
            cells: self.cells.clone(),
            rest: Rest::Tets(self.tets.clone()),
            pairs: self.targets.clone(),
            start: None,
            handles: Vec::new(),
            fixed_boundary: false,
        };
        let settings = DeformSettings {
            weight,
            tol: TOL,
            ..DeformSettings::default()
        };
        let t0 = Instant::now();
        let deformed =
            deform_mesh(inputs, &settings, &mut unfold::app::observer::Quiet).expect("deform runs");
        (deformed, t0.elapsed().as_secs_f64())
    }

    /// One solve that must converge without inverting a tet; writes the
    /// result and the per-iteration trace into `dir` as `case`.
    fn check_and_write(&self, weight: f64, case: &str, dir: &Path) -> DeformReport {
        let (deformed, seconds) = self.solve(weight);
        let r = deformed.report;
        assert!(r.converged, "{case}: did not converge: {r:?}");
        assert_eq!(r.end.inverted, 0, "{case}: inverted tets: {r:?}");
        assert_eq!(r.end.folded, 0, "{case}: folded faces: {r:?}");

        // The same problem through `Deform::run_with` (the mesh needs no
        // repair), for the objective after every iteration.
        let mut stopping = ProjectedNewton::default().default_stopping();
        stopping.grad_tol = TOL;
        let mut history = History::default();
        let traced = Deform::new()
            .weight(weight)
            .energy(SymmetricDirichlet)
            .solver(ProjectedNewton::default())
            .stopping(stopping)
            .run_with(&self.tets, &self.targets, &mut history)
            .expect("deform runs");
        assert_eq!(traced.report.iterations, r.iterations, "{case}");
        assert!(
            (traced.report.objective - r.objective).abs() <= 1e-12 * r.objective,
            "{case}: {} vs {}",
            traced.report.objective,
            r.objective
        );

        write_mesh(
            dir.join(format!("{case}.ours.vtu")),
            &deformed.mesh,
            &WriteOptions::default(),
        )
        .expect("write mesh");
        let trace: Vec<_> = history
            .0
            .iter()
            .map(|it| json!({"iteration": it.iteration, "objective": it.value, "seconds": it.seconds}))
            .collect();
        let summary = json!({
            "mesh": self.name,
            "tets": self.tets.num_tets(),
            "vertices": self.tets.num_vertices(),
            "targets": self.targets.len(),
            "weight": weight,
            "tol": TOL,
            "check_seconds": seconds,
            "report": r,
            "trace": trace,
        });
        write_json(&dir.join(format!("{case}.ours.json")), &summary);
        r
    }
}

/// The flattening targets: top -> `(x, y, +4)`, bottom -> `(x, y, -4)`.
fn flat_targets(shape: &ShellShape) -> Vec<(usize, [f64; 3])> {
    let p = &shape.mesh.positions;
    let at = |v: u32, z: f64| (v as usize, [p[v as usize].x, p[v as usize].y, z]);
    let top = shape.top.iter().map(|&v| at(v, 4.0));
    top.chain(shape.bottom.iter().map(|&v| at(v, -4.0)))
        .collect()
}

fn write_json(path: &Path, value: &serde_json::Value) {
    let text = serde_json::to_string_pretty(value).expect("JSON");
    std::fs::write(path, text).expect("write JSON");
}

fn out_dir() -> PathBuf {
    let dir = std::env::var_os("DEFORM_BENCH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target/deform-bench"));
    std::fs::create_dir_all(&dir).expect("create the output directory");
    dir
}

/// The two bowls: 7,056 and 60,516 tets.
fn bowls() -> [Bowl; 2] {
    [Bowl::new("bowl_7k", 14, 2), Bowl::new("bowl_60k", 41, 2)]
}

/// A case's name: the bowl's and the weight's, e.g. `bowl_60k_w1000`.
fn case_name(bowl: &Bowl, weight: f64) -> String {
    format!("{}_w{weight}", bowl.name)
}

fn deform(c: &mut Criterion) {
    let dir = out_dir();
    let bowls = bowls();
    assert_eq!(bowls[0].tets.num_tets(), 7_056);
    assert_eq!(bowls[1].tets.num_tets(), 60_516);

    let mut g = c.benchmark_group("deform");
    g.sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(1));
    let mut results = Vec::new();
    let mut summary = Summary::default();
    for weight in WEIGHTS {
        for (bowl, measure) in bowls.iter().zip([5, 40]) {
            bowl.write(&dir);
            let case = case_name(bowl, weight);
            let report = bowl.check_and_write(weight, &case, &dir);
            let mut runs = Runs::default();
            g.measurement_time(Duration::from_secs(measure));
            g.bench_function(&case, |b| {
                b.iter_custom(|iters| {
                    let mut total = Duration::ZERO;
                    for _ in 0..iters {
                        let (deformed, seconds) = bowl.solve(weight);
                        black_box(deformed);
                        runs.push(seconds);
                        total += Duration::from_secs_f64(seconds);
                    }
                    total
                })
            });
            // Filtered out (`cargo bench --bench deform -- bowl_7k`): no runs.
            if let Some(med) = runs.median() {
                let path = dir.join(format!("{case}.ours.json"));
                let text = std::fs::read_to_string(&path).expect("read JSON");
                let mut json_summary: serde_json::Value =
                    serde_json::from_str(&text).expect("JSON");
                json_summary["seconds_median"] = json!(med);
                json_summary["runs"] = json!(runs.len());
                write_json(&path, &json_summary);
                results.push((case.clone(), bowl.tets.num_tets(), report, med, runs.len()));
            }
            summary.add(&case, format!("{} tets", bowl.tets.num_tets()), &runs);
        }
    }
    g.finish();

    println!(
        "\ndeform summary (symmetric Dirichlet, |grad|_F < {TOL:e}; wall clock per solve of \
         `deform_mesh`, every run criterion made, warm-up included; E = volume-normalized \
         distortion + target term):"
    );
    for (case, tets, r, med, runs) in &results {
        println!(
            "  {case:<15} {tets:>6} tets: {med:8.3} s (median of {runs}), {:3} iterations, \
             E = {:.12e} (target term {:.3e}), {} inverted",
            r.iterations, r.objective, r.target_term, r.end.inverted
        );
    }
    println!("  problem files and results in {}", dir.display());
    summary
        .print("deform: median time beside peak resident memory (one solve in a fresh process):");
}

criterion_group!(benches, deform);

fn main() {
    // A child of `peak::measure`: one solve of the named case, then exit.
    peak::serve(|name| {
        let found = bowls().into_iter().find_map(|bowl| {
            let weight = WEIGHTS.into_iter().find(|&w| case_name(&bowl, w) == name)?;
            Some((bowl, weight))
        });
        let (bowl, weight) = found.unwrap_or_else(|| panic!("deform bench: no case {name}"));
        black_box(bowl.solve(weight));
    });
    benches();
    Criterion::default().configure_from_args().final_summary();
}
