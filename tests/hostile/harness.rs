//! Running one hostile case and checking what every case must hold: a
//! clean exit (1 or 2, never a panic, an abort or a signal), one line on
//! stderr naming the problem with no raw control character, a peak memory
//! under the case's bound, the inputs untouched, and nothing left at the
//! output (no file, no temporary).

use std::path::{Path, PathBuf};
use std::process::Output;

#[path = "../common/measured.rs"]
mod measured;

/// A hostile run: the command line, what the message must say, the most
/// memory it may take, its inputs and its output.
pub struct Case<'a> {
    /// A short name for the log.
    pub name: &'a str,
    /// The arguments of `unfold`.
    pub args: Vec<String>,
    /// A piece of the expected one-line error.
    pub expect: &'a str,
    /// The most the run may take, MiB.
    pub max_peak_mib: f64,
    /// Files that must be unchanged afterwards.
    pub inputs: Vec<PathBuf>,
    /// The output path, which must not exist afterwards (nor any
    /// temporary beside it).
    pub output: Option<PathBuf>,
}

fn snapshot(paths: &[PathBuf]) -> Vec<Option<Vec<u8>>> {
    paths.iter().map(|p| std::fs::read(p).ok()).collect()
}

/// Leftovers of a run beside `output`: unfold's temporaries and staging
/// directories.
fn leftovers(output: &Path) -> Vec<String> {
    let dir = match output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".unfold-") || n.contains(".unfold-") && n.ends_with(".partial"))
        .collect()
}

/// Runs `case` and asserts what every hostile case must hold.
pub fn run(case: &Case<'_>) {
    let before = snapshot(&case.inputs);
    let args: Vec<&str> = case.args.iter().map(String::as_str).collect();
    let (o, peak): (Output, u64) = measured::unfold_measured(&args);
    let name = case.name;
    let code = o.status.code().unwrap_or_else(|| {
        panic!("{name}: killed by a signal ({:?})", o.status);
    });
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        code == 1 || code == 2,
        "{name}: exit code {code} (1 or 2 expected): {err}"
    );
    assert!(!err.contains("panicked"), "{name}: a panic: {err}");
    let line = err.trim_end();
    assert_eq!(
        line.lines().count(),
        1,
        "{name}: one line expected: {err:?}"
    );
    assert!(line.starts_with("unfold: error: "), "{name}: {err}");
    assert!(
        !line.chars().any(char::is_control),
        "{name}: a raw control character on the terminal: {line:?}"
    );
    assert!(
        line.contains(case.expect),
        "{name}: {line:?} should say {:?}",
        case.expect
    );
    let peak_mib = peak as f64 / (1024.0 * 1024.0);
    assert!(
        peak_mib <= case.max_peak_mib,
        "{name}: peak {peak_mib:.1} MiB above {} MiB",
        case.max_peak_mib
    );
    assert!(
        snapshot(&case.inputs) == before,
        "{name}: an input was modified"
    );
    if let Some(out) = &case.output {
        assert!(!out.exists(), "{name}: {} was written", out.display());
        let left = leftovers(out);
        assert!(left.is_empty(), "{name}: temporaries left: {left:?}");
    }
    eprintln!(
        "hostile {name}: unfold {} -> exit {code}, peak {peak_mib:.1} MiB: {line}",
        case.args.join(" ")
    );
}

/// `p` as an argument.
pub fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Arguments from string slices.
pub fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|x| x.to_string()).collect()
}
