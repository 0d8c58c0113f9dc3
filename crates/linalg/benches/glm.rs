//! The voxelwise GLM's permutation test (ALGORITHMS 5.3) at the size of a
//! placenta cohort: 100 subjects in two groups of 50 with one continuous
//! covariate, 60,000 voxels (a 2 mm grid over a placenta template) and
//! 1,000 Freedman-Lane relabelings. The target is under 60 s on 2 cores,
//! with memory flat in the number of relabelings.
//!
//! Prints the time of one full run and the peak resident memory of a
//! process that builds the data and runs the test once (its own process,
//! `benches/support/peak.rs` of the workspace), for 1,000 and for 4,000
//! relabelings; then criterion times the full run (10 samples).
//!
//! Run: `cargo bench -p unfold-linalg --bench glm`;
//! `GLM_BENCH_QUICK=1` runs the one-shot time and the peaks only.

#[path = "../../../benches/support/peak.rs"]
mod peak;

use criterion::{Criterion, criterion_group};
use std::hint::black_box;
use std::time::{Duration, Instant};
use unfold_linalg::glm::{
    Design, PermutationSettings, Regressor, RegressorValues, permutation_test,
};

const SUBJECTS: usize = 100;
const VOXELS: usize = 60_000;
const PERMUTATIONS: usize = 1_000;

/// SplitMix64 normal deviates (Box-Muller), deterministic.
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
    }
}

/// Two groups of 50, a gestational-age covariate, and voxel values with a
/// covariate effect and an effect of the group in the first 5 % of voxels.
fn cohort() -> (Design, Vec<f64>) {
    let mut rng = Normal(38);
    let group: Vec<String> = (0..SUBJECTS)
        .map(|i| if i % 2 == 0 { "control" } else { "case" }.to_string())
        .collect();
    let age: Vec<f64> = (0..SUBJECTS).map(|_| 32.0 + 3.0 * rng.next()).collect();
    let mut y = Vec::with_capacity(SUBJECTS * VOXELS);
    for v in 0..VOXELS {
        for (i, a) in age.iter().enumerate() {
            let effect = if v < VOXELS / 20 && i % 2 == 1 {
                0.8
            } else {
                0.0
            };
            y.push(0.1 * a + effect + rng.next());
        }
    }
    let design = Design::new(
        Regressor {
            name: "group".into(),
            values: RegressorValues::Categorical(group),
        },
        vec![Regressor {
            name: "ga".into(),
            values: RegressorValues::Continuous(age),
        }],
    )
    .expect("a valid design");
    (design, y)
}

/// The test; returns the voxels at FWE p < 0.05 inside and outside the
/// planted region.
fn run(design: &Design, y: &[f64], permutations: usize) -> (usize, usize) {
    let settings = PermutationSettings {
        permutations,
        seed: 1,
    };
    let result = permutation_test(design, y, &settings).expect("the test runs");
    let (planted, rest) = result.p_fwe.split_at(VOXELS / 20);
    let count = |p: &[f64]| p.iter().filter(|&&p| p < 0.05).count();
    (count(planted), count(rest))
}

fn glm(c: &mut Criterion) {
    let (design, y) = cohort();
    let mut group = c.benchmark_group("glm");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(60));
    group.bench_function("100 subjects, 60k voxels, 1000 permutations", |b| {
        b.iter(|| black_box(run(&design, &y, PERMUTATIONS)))
    });
    group.finish();
}

criterion_group!(benches, glm);

fn main() {
    // A child process measuring one run's peak memory: "PERMUTATIONS".
    peak::serve(|case| {
        let (design, y) = cohort();
        black_box(run(
            &design,
            &y,
            case.parse().expect("a number of permutations"),
        ));
    });
    let (design, y) = cohort();
    println!(
        "{}, {} voxels, threads {}",
        design.describe(),
        VOXELS,
        rayon::current_num_threads()
    );
    let t0 = Instant::now();
    let (found, false_positives) = run(&design, &y, PERMUTATIONS);
    println!(
        "one run, {PERMUTATIONS} permutations: {:.2} s (target 60 s); FWE p < 0.05 in {found} of \
         the {} planted voxels (effect 0.8 sd) and {false_positives} of the {} others",
        t0.elapsed().as_secs_f64(),
        VOXELS / 20,
        VOXELS - VOXELS / 20
    );
    println!("input y: {:.1} MiB", (y.len() * 8) as f64 / 1_048_576.0);
    drop(y);
    for permutations in [PERMUTATIONS, 4 * PERMUTATIONS] {
        println!(
            "peak memory, {permutations} permutations: {} MiB",
            peak::measure(&permutations.to_string())
        );
    }
    if std::env::var_os("GLM_BENCH_QUICK").is_none() {
        benches();
        Criterion::default().configure_from_args().final_summary();
    }
}
