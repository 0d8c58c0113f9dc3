//! The summary a pipeline bench prints at its end: per case, the median
//! wall-clock time of its runs beside its peak resident memory (measured in
//! a process of its own, `support/peak.rs`).
//!
//! Include it with `#[path = "support/summary.rs"] mod summary;` beside
//! `mod peak;`.

use crate::peak::{self, Peak};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// The wall-clock seconds of every run of one case.
#[derive(Default)]
pub struct Runs(Vec<f64>);

impl Runs {
    /// Runs `f` `iters` times and records each run's seconds; returns their
    /// total, as criterion's `iter_custom` expects. (`deform` times its
    /// runs itself, without the input's copy, hence the allowance.)
    #[allow(dead_code)]
    pub fn time<R>(&mut self, iters: u64, mut f: impl FnMut() -> R) -> Duration {
        let mut total = Duration::ZERO;
        for _ in 0..iters {
            let t0 = Instant::now();
            black_box(f());
            let dt = t0.elapsed();
            self.push(dt.as_secs_f64());
            total += dt;
        }
        total
    }

    /// Records one run timed elsewhere.
    pub fn push(&mut self, seconds: f64) {
        self.0.push(seconds);
    }

    /// How many runs were recorded.
    #[allow(dead_code)]
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// The median of the runs (the mean of the two middle ones for an even
    /// count); `None` without runs.
    pub fn median(&self) -> Option<f64> {
        let mut v = self.0.clone();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        match n {
            0 => None,
            _ if n % 2 == 1 => Some(v[n / 2]),
            _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
        }
    }
}

/// One row: the case, its size in words, the runs' median and count.
struct Row {
    case: String,
    size: String,
    median: f64,
    runs: usize,
}

/// The rows of a bench's summary, printed by [`Summary::print`].
#[derive(Default)]
pub struct Summary(Vec<Row>);

impl Summary {
    /// Adds `case` (the name [`peak::serve`] runs) unless it has no runs
    /// (filtered out, e.g. `cargo bench --bench placenta -- planes_7k`).
    pub fn add(&mut self, case: &str, size: impl Into<String>, runs: &Runs) {
        if let Some(median) = runs.median() {
            self.0.push(Row {
                case: case.to_owned(),
                size: size.into(),
                median,
                runs: runs.0.len(),
            });
        }
    }

    /// Measures each case's peak (one child process per case, one after
    /// the other, after every timing) and prints the table under `title`.
    pub fn print(&self, title: &str) {
        let peaks: Vec<Peak> = self.0.iter().map(|r| peak::measure(&r.case)).collect();
        let wc = self
            .0
            .iter()
            .map(|r| r.case.len())
            .max()
            .unwrap_or(0)
            .max(4);
        let ws = self
            .0
            .iter()
            .map(|r| r.size.len())
            .max()
            .unwrap_or(0)
            .max(4);
        println!("\n{title}");
        println!(
            "  {:<wc$}  {:<ws$}  {:>11}  {:>5}  {:>14}",
            "case", "size", "median time", "runs", "peak RSS (MiB)"
        );
        for (r, p) in self.0.iter().zip(&peaks) {
            println!(
                "  {:<wc$}  {:<ws$}  {:>11}  {:>5}  {:>14}",
                r.case,
                r.size,
                seconds(r.median),
                r.runs,
                p
            );
        }
    }
}

/// `11.9 s`, `2.38 s`, `0.231 s`, `18.3 ms`: three significant digits.
fn seconds(s: f64) -> String {
    if s >= 10.0 {
        format!("{s:.1} s")
    } else if s >= 1.0 {
        format!("{s:.2} s")
    } else if s >= 0.1 {
        format!("{s:.3} s")
    } else if s >= 0.01 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{:.2} ms", s * 1e3)
    }
}
