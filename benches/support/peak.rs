//! The peak resident memory of one bench case, measured in a process of its
//! own.
//!
//! The kernel's `VmHWM` (`/proc/self/status`) only grows, so criterion's
//! process holds the peak of every case it ran before. [`measure`] therefore
//! re-executes the bench binary (`std::env::current_exe`) with
//! `UNFOLD_BENCH_PEAK_CASE=<case>`; in that child, [`serve`] (called first
//! in the bench's `main`, before criterion) builds the case's inputs, runs
//! the case once, prints `peak_bytes N` (its `VmHWM` in bytes) and exits.
//! The peak is thus the whole process's: the program itself, the inputs and
//! one run. Outside Linux no child is started and the peak shows as `n/a`.
//!
//! Include it with `#[path = "support/peak.rs"] mod peak;`.

use std::fmt;
use std::process::Command;

/// Names the case a child process runs.
const CASE_VAR: &str = "UNFOLD_BENCH_PEAK_CASE";

/// The line a child prints its peak on.
const PREFIX: &str = "peak_bytes ";

/// A case's peak resident size in bytes; `None` where it cannot be read.
#[derive(Clone, Copy, Debug)]
pub struct Peak(pub Option<u64>);

/// Mebibytes with one decimal (`2^20` bytes), or `n/a`.
impl fmt::Display for Peak {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(bytes) => {
                let mib = format!("{:.1}", bytes as f64 / 1_048_576.0);
                f.pad(&mib)
            }
            None => f.pad("n/a"),
        }
    }
}

/// In a child started by [`measure`]: runs `run(case)` once, prints the
/// process's `VmHWM` and exits. Elsewhere: returns at once.
pub fn serve(run: impl FnOnce(&str)) {
    let Some(case) = std::env::var_os(CASE_VAR) else {
        return;
    };
    let case = case
        .into_string()
        .unwrap_or_else(|c| panic!("{CASE_VAR} is not UTF-8: {c:?}"));
    run(&case);
    match vm_hwm() {
        Some(bytes) => println!("{PREFIX}{bytes}"),
        None => println!("{PREFIX}n/a"),
    }
    std::process::exit(0);
}

/// The peak resident size of a fresh process that builds `case`'s inputs
/// and runs it once (see the module's text). Panics with the child's
/// output when the child fails.
pub fn measure(case: &str) -> Peak {
    if !cfg!(target_os = "linux") {
        return Peak(None);
    }
    let exe = std::env::current_exe().expect("the bench binary's own path");
    let out = Command::new(&exe)
        .env(CASE_VAR, case)
        .output()
        .unwrap_or_else(|e| panic!("peak of {case}: cannot start {}: {e}", exe.display()));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "peak of {case}: the child process failed ({}):\n{stdout}{stderr}",
        out.status
    );
    let value = stdout
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix(PREFIX))
        .unwrap_or_else(|| panic!("peak of {case}: no `{PREFIX}` line from the child:\n{stdout}"));
    match value.trim() {
        "n/a" => Peak(None),
        v => Peak(Some(v.parse().unwrap_or_else(|e| {
            panic!("peak of {case}: `{PREFIX}{v}` from the child: {e}")
        }))),
    }
}

/// `VmHWM:   123 kB` of `/proc/self/status`, in bytes.
fn vm_hwm() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?;
    let mut words = line.split_whitespace();
    let kib: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(kib * 1024)
}
