//! Running the binary with its peak memory measured (Linux: `wait4`'s
//! `ru_maxrss` of the child).

use std::io::Read;
use std::os::unix::process::ExitStatusExt;
use std::process::{Command, Output, Stdio};

/// Runs `unfold args` and returns its output and its peak resident size in
/// bytes.
#[allow(clippy::zombie_processes)] // reaped by wait4 below
pub fn unfold_measured(args: &[&str]) -> (Output, u64) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_unfold"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the unfold binary runs");
    let mut out = child.stdout.take().expect("piped stdout");
    let mut err = child.stderr.take().expect("piped stderr");
    let reader = std::thread::spawn(move || {
        let mut v = Vec::new();
        out.read_to_end(&mut v).map(|_| v)
    });
    let mut stderr = Vec::new();
    err.read_to_end(&mut stderr).expect("stderr read");
    let stdout = reader.join().expect("reader thread").expect("stdout read");
    let mut status = 0i32;
    // SAFETY: rusage is plain old data, zeroed is a valid value; wait4 on
    // our own child's pid, which nothing else waits for.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = child.id() as libc::pid_t;
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4 failed");
    let output = Output {
        status: std::process::ExitStatus::from_raw(status),
        stdout,
        stderr,
    };
    (output, usage.ru_maxrss as u64 * 1024)
}

/// The predicted peak in a refusal `... a peak of 1.2 GiB: ...`, bytes.
pub fn predicted_peak(message: &str) -> f64 {
    let rest = message
        .split("a peak of ")
        .nth(1)
        .unwrap_or_else(|| panic!("no predicted peak in {message:?}"));
    let mut words = rest.split_whitespace();
    let value: f64 = words.next().and_then(|w| w.parse().ok()).expect("a number");
    let unit = words.next().expect("a unit").trim_end_matches(':');
    let scale = match unit {
        "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1024.0 * 1024.0,
        "GiB" => 1024.0 * 1024.0 * 1024.0,
        "TiB" => 1024.0f64.powi(4),
        u => panic!("unit {u}"),
    };
    value * scale
}
