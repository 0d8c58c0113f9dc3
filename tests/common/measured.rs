//! Running the binary with its peak memory measured: the kernel's `VmHWM`
//! of the unfold process itself, which it writes at exit to
//! `UNFOLD_PEAK_FILE` (a child's `ru_maxrss` from `wait4` would also count
//! the test process's memory, shared by the child until it executes).

use std::process::{Command, Output};

/// Runs `unfold args` and returns its output and its peak resident size in
/// bytes.
pub fn unfold_measured(args: &[&str]) -> (Output, u64) {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let peak_file = dir.path().join("peak");
    let output = Command::new(env!("CARGO_BIN_EXE_unfold"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("UNFOLD_PEAK_FILE", &peak_file)
        .output()
        .expect("the unfold binary runs");
    let peak = std::fs::read_to_string(&peak_file)
        .unwrap_or_else(|e| {
            panic!(
                "no peak written ({e}): {}",
                String::from_utf8_lossy(&output.stderr)
            )
        })
        .trim()
        .parse()
        .expect("the peak in bytes");
    (output, peak)
}
