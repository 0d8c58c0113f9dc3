//! Untangling from any start (ALGORITHMS 1.7): success rate, time per case
//! and peak memory on a generated set of tangled problems that are
//! feasible by construction (`unfold::mesh::shapes::tangled_case`: a smooth
//! bijective warp of a square or cube is a known injective map; the handles
//! sit on it, every other vertex is scrambled).
//!
//! The set: the three kinds (a planar grid, the grid lifted to a curved
//! surface and mapped to the plane, a Kuhn tet grid), two handle sets (the
//! whole boundary; 2 % of the vertices), five sizes (about 1k, 4k, 12k, 20k
//! and 30k elements) and two scrambles (free vertices moved by up to 10 % and
//! 25 % of the domain's width, plus swaps): 60 cases.
//!
//! Each case runs [`Deform`] from the tangled start with the handles fixed
//! (the untangler, then projected Newton on the symmetric Dirichlet energy,
//! every iterate flip-free) and is checked independently: every element
//! positively oriented by the exact orientation predicate, every handle bit
//! for bit at its start. Beside it, the flip-free path: the same solve
//! started from the known solution (no untangling). A line per case, then
//! the success rate, the times of the cases of up to 20k elements against
//! the 10 s target, and the peak resident memory of the largest case of
//! each kind, each in a process of its own (`support/peak.rs`).
//!
//! Run: `cargo bench --bench untangle` (several minutes on 2 cores);
//! `UNTANGLE_BENCH_QUICK=1` keeps the sizes up to 4k;
//! `UNTANGLE_BENCH_ONLY="tets sparse 12000"` runs the cases whose
//! `kind handles size` line starts so;
//! `UNTANGLE_BENCH_VARIANTS="1,5"` solves each case once per untangler
//! variant, given by its [`Untangler::refactor_every`], side by side in one run, a line each, without the peak memory
//! (the default: the untangler's defaults only).

#[path = "support/peak.rs"]
mod peak;

use std::time::Instant;
use unfold::mesh::shapes::{Handles, TangledCase, TangledKind, TangledParams, tangled_case};
use unfold::param::{Deform, NoObserver, RestShape, Untangler};

/// The element counts of the set.
const SIZES: [usize; 5] = [1_000, 4_000, 12_000, 20_000, 30_000];
/// The scrambles of the set.
const SCRAMBLES: [f64; 2] = [0.1, 0.25];
/// The speed target per case of up to 20k elements, seconds.
const TARGET_SECONDS: f64 = 10.0;

/// One case's parameters.
fn params(kind: TangledKind, sparse: bool, elements: usize, scramble: f64) -> TangledParams {
    TangledParams {
        kind,
        elements,
        handles: if sparse {
            Handles::Sparse { fraction: 0.02 }
        } else {
            Handles::Boundary
        },
        scramble,
        seed: 2026,
    }
}

/// What one solve gave.
struct Solved {
    injective: bool,
    seconds: f64,
    /// CPU seconds (user + system, all threads) of the solve.
    cpu_seconds: f64,
    untangle_seconds: f64,
    stages: usize,
    factorizations: usize,
    iterations: usize,
}

/// This process's CPU seconds so far (user + system, `/proc/self/stat`;
/// NaN where it cannot be read).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // Fields after the command's closing parenthesis: utime and stime are
    // the 14th and 15th of the line, the 12th and 13th after it.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok());
    match (ticks(11), ticks(12)) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// The untangler variants of `UNTANGLE_BENCH_VARIANTS` ("R,...": stages
/// per factorization); the default untangler without it.
fn variants() -> Vec<(String, Untangler)> {
    let spec = std::env::var("UNTANGLE_BENCH_VARIANTS").unwrap_or_default();
    if spec.trim().is_empty() {
        return vec![(String::new(), Untangler::default())];
    }
    spec.split(',')
        .map(|v| {
            let untangler = Untangler {
                refactor_every: v.trim().parse().expect("UNTANGLE_BENCH_VARIANTS: R,..."),
                ..Untangler::default()
            };
            (format!(" [{}]", v.trim()), untangler)
        })
        .collect()
}

/// Solves `case` from `start` (the tangled init or the solution) with its
/// handles fixed, and checks the result independently.
fn solve(case: &TangledCase, start: &[[f64; 3]], untangler: Untangler) -> Solved {
    let d = if case.is_tets() { 3 } else { 2 };
    let x: Vec<f64> = start.iter().flat_map(|p| p[..d].to_vec()).collect();
    let fixed: Vec<usize> = case.fixed.iter().map(|&v| v as usize).collect();
    let (tets, tris) = (case.to_tet_mesh(), case.to_tri_mesh());
    let rest = match (&tets, &tris) {
        (Some(t), _) => RestShape::Tets(t),
        (None, Some(t)) => RestShape::Triangles(t),
        _ => panic!("a case has tets or triangles"),
    };
    let (t0, c0) = (Instant::now(), cpu_seconds());
    let out = Deform::new()
        .untangler(untangler)
        .start(x)
        .fixed(fixed)
        .run_shape(rest, &[], &mut NoObserver)
        .expect("the solve runs");
    let seconds = t0.elapsed().as_secs_f64();
    let cpu_seconds = cpu_seconds() - c0;
    let positions: Vec<[f64; 3]> = out.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
    let handles_exact = case.fixed.iter().all(|&h| {
        let h = h as usize;
        (0..d).all(|c| positions[h][c].to_bits() == start[h][c].to_bits())
    });
    let r = &out.report;
    let (untangle_seconds, stages, factorizations) = r
        .untangle
        .as_ref()
        .map_or((0.0, 0, 0), |u| (u.seconds, u.stages, u.factorizations));
    Solved {
        injective: r.injective && handles_exact && case.inverted_in(&positions) == 0,
        seconds,
        cpu_seconds,
        untangle_seconds,
        stages,
        factorizations,
        iterations: r.iterations,
    }
}

fn kind_name(kind: TangledKind) -> &'static str {
    match kind {
        TangledKind::Planar => "planar",
        TangledKind::SurfaceToPlane => "surface",
        TangledKind::Tets => "tets",
    }
}

fn main() {
    // A child process measuring one case's peak memory: "KIND SPARSE ELEMENTS SCRAMBLE".
    peak::serve(|case| {
        let f: Vec<&str> = case.split(' ').collect();
        let kind = match f[0] {
            "planar" => TangledKind::Planar,
            "surface" => TangledKind::SurfaceToPlane,
            _ => TangledKind::Tets,
        };
        let p = params(
            kind,
            f[1] == "sparse",
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
        );
        let c = tangled_case(&p).unwrap();
        assert!(solve(&c, &c.init, Untangler::default()).injective);
    });
    let quick = std::env::var_os("UNTANGLE_BENCH_QUICK").is_some();
    let only = std::env::var("UNTANGLE_BENCH_ONLY").unwrap_or_default();
    let sizes: Vec<usize> = SIZES
        .iter()
        .copied()
        .filter(|&s| !quick || s <= 4_000)
        .collect();
    let variants = variants();
    println!(
        "{:<8} {:<8} {:>5} {:>6} {:>8} {:>5} {:>8} {:>7} {:>6} {:>6} {:>6} {:>8} {:>9}",
        "kind",
        "handles",
        "scr",
        "elems",
        "inverted",
        "ok",
        "total s",
        "cpu s",
        "untgl s",
        "stages",
        "factor",
        "newton",
        "flipfree s"
    );
    let (mut cases, mut ok, mut within, mut small) = (0, 0, 0, 0);
    let mut worst_small = 0.0f64;
    for kind in [
        TangledKind::Planar,
        TangledKind::SurfaceToPlane,
        TangledKind::Tets,
    ] {
        for sparse in [false, true] {
            for &elements in &sizes {
                for &scramble in &SCRAMBLES {
                    let name = format!(
                        "{} {} {elements}",
                        kind_name(kind),
                        if sparse { "sparse" } else { "boundary" }
                    );
                    if !name.starts_with(only.as_str()) {
                        continue;
                    }
                    let case = tangled_case(&params(kind, sparse, elements, scramble)).unwrap();
                    let free = solve(&case, &case.solution, Untangler::default());
                    for (label, untangler) in &variants {
                        let s = solve(&case, &case.init, *untangler);
                        cases += 1;
                        ok += usize::from(s.injective);
                        if case.elements() <= 20_000 {
                            small += 1;
                            worst_small = worst_small.max(s.seconds);
                            within += usize::from(s.seconds < TARGET_SECONDS);
                        }
                        println!(
                            "{:<8} {:<8} {:>5.2} {:>6} {:>8} {:>5} {:>8.2} {:>7.2} {:>6.2} {:>6} {:>6} {:>8} {:>9.2}{label}",
                            kind_name(kind),
                            if sparse { "sparse" } else { "boundary" },
                            scramble,
                            case.elements(),
                            case.inverted_in_init(),
                            if s.injective { "yes" } else { "NO" },
                            s.seconds,
                            s.cpu_seconds,
                            s.untangle_seconds,
                            s.stages,
                            s.factorizations,
                            s.iterations,
                            free.seconds,
                        );
                    }
                }
            }
        }
    }
    println!(
        "success: {ok} of {cases} cases injective with exact handles; cases of <= 20k elements \
         under {TARGET_SECONDS} s: {within} of {small} (slowest {worst_small:.2} s)"
    );
    if std::env::var_os("UNTANGLE_BENCH_VARIANTS").is_some() {
        // Comparing variants: the peaks are the default's.
        return;
    }
    let largest = *sizes.last().unwrap();
    for kind in ["planar", "surface", "tets"] {
        let case = format!("{kind} sparse {largest} 0.2");
        println!("peak memory, {case}: {} MiB", peak::measure(&case));
    }
}
