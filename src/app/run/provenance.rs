//! Where a run's results come from (issue 19): the unfold version, the
//! command line, the inputs' SHA-256, the time, and one hash of all that
//! bears on the outputs, so a batch can tell a subject already done with
//! the same inputs and options from one to run again.
//!
//! The run hash is SHA-256 over the unfold version, then every argument
//! after the program name except the output path (`-o`/`--output` and its
//! value) and `--max-memory` (which does not change what is written), each
//! followed by a NUL byte, then for every argument after the subcommand
//! naming an existing file (also the value of `--flag=FILE`) its SHA-256
//! (the subcommand, `placenta`, is a name even where a file or folder of
//! that name, such as an earlier run's output, lies); for an argument naming a
//! directory (`mitral --series DIR`), the path and SHA-256 of every file
//! directly in it, sorted by name. Paths are taken as given: the same files
//! under other names hash differently. An output file named by a flag
//! (`--displacement FILE`, [`OUTPUT_FILE_FLAGS`]) counts by its path only:
//! its contents, an earlier run's output, are not an input.

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::borrow::Cow;
use std::io::Read;
use std::path::Path;

/// One input file and its content hash.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputHash {
    /// The path as given.
    pub path: String,
    /// SHA-256 of its bytes, hexadecimal.
    pub sha256: String,
    /// Its size, bytes.
    pub bytes: u64,
}

/// What `report.json` says of where the run comes from.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// The unfold version.
    pub unfold_version: Cow<'static, str>,
    /// `python` for a run from the Python package (none: the command
    /// line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interface: Option<Cow<'static, str>>,
    /// The command line, as given.
    pub command_line: Vec<String>,
    /// Every option's value after parsing (defaults included).
    pub parameters: String,
    /// The input files and their hashes.
    pub inputs: Vec<InputHash>,
    /// The hash of everything that bears on the outputs (module doc).
    pub run_hash: String,
    /// When the run started, UTC (RFC 3339).
    pub started: String,
}

static THIS_RUN: std::sync::OnceLock<Provenance> = std::sync::OnceLock::new();

/// Records this process's run before any work: the command line
/// `command_line` (program name first), the parsed command's `Debug` text
/// as `parameters`, the inputs' hashes now (before anything could change
/// them), the start time. The first call wins.
pub fn init(command_line: Vec<String>, parameters: &dyn std::fmt::Debug) {
    THIS_RUN.get_or_init(|| {
        let started = now();
        let (run_hash, inputs) = run_hash(command_line.get(1..).unwrap_or_default());
        Provenance {
            unfold_version: env!("CARGO_PKG_VERSION").into(),
            interface: None,
            command_line,
            parameters: format!("{parameters:?}"),
            inputs,
            run_hash,
            started,
        }
    });
}

impl Provenance {
    /// A Python run's provenance: `parameters` (the call's settings) and
    /// when it `started` ([`now`]); no command line, no input files.
    pub fn python(parameters: String, started: String) -> Self {
        Provenance {
            unfold_version: env!("CARGO_PKG_VERSION").into(),
            interface: Some("python".into()),
            command_line: Vec::new(),
            parameters,
            inputs: Vec::new(),
            run_hash: String::new(),
            started,
        }
    }
}

/// Now, as `started` says it: RFC 3339 to the second, UTC.
pub fn now() -> String {
    humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string()
}

/// This process's run (recorded by [`init`]; empty before).
pub fn this_run() -> Provenance {
    THIS_RUN.get().cloned().unwrap_or_else(|| Provenance {
        unfold_version: env!("CARGO_PKG_VERSION").into(),
        interface: None,
        command_line: std::env::args().collect(),
        parameters: String::new(),
        inputs: Vec::new(),
        run_hash: String::new(),
        started: String::new(),
    })
}

/// Flags whose value is a file the run writes: their path bears on the
/// outputs, their contents do not.
pub const OUTPUT_FILE_FLAGS: [&str; 1] = ["--displacement"];

/// The arguments that bear on the outputs: all but the output path and
/// `--max-memory`.
fn significant(args: &[String]) -> Vec<&str> {
    let mut out = Vec::with_capacity(args.len());
    let mut skip_next = false;
    for a in args {
        if std::mem::take(&mut skip_next) {
            continue;
        }
        match a.as_str() {
            "-o" | "--output" | "--max-memory" => skip_next = true,
            s if s.starts_with("--output=") || s.starts_with("--max-memory=") => {}
            s if s.starts_with("-o") && s.len() > 2 => {}
            s => out.push(s),
        }
    }
    out
}

/// SHA-256 of a file's bytes, read in blocks.
fn file_sha256(path: &Path) -> Option<(String, u64)> {
    let mut f = std::fs::File::open(path).ok()?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut total = 0u64;
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            break;
        }
        total += n as u64;
        h.update(&buf[..n]);
    }
    Some((hex(&h.finalize()), total))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The regular files directly in `dir` (not in its subdirectories),
/// sorted by name.
fn dir_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// The run hash of `args` (the arguments after the program name) and the
/// input files among them (module doc).
pub fn run_hash(args: &[String]) -> (String, Vec<InputHash>) {
    let mut h = Sha256::new();
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update([0]);
    let mut inputs = Vec::new();
    let mut output_next = false;
    for (k, a) in significant(args).into_iter().enumerate() {
        h.update(a.as_bytes());
        h.update([0]);
        if k == 0 {
            continue; // the subcommand
        }
        let output = std::mem::take(&mut output_next)
            || OUTPUT_FILE_FLAGS
                .iter()
                .any(|f| a.strip_prefix(f).is_some_and(|v| v.starts_with('=')));
        output_next = OUTPUT_FILE_FLAGS.contains(&a);
        if output {
            continue;
        }
        let candidate = a.split_once('=').map_or(a, |(_, v)| v);
        let p = Path::new(candidate);
        if candidate.is_empty() {
            continue;
        }
        let files = if p.is_file() {
            vec![p.to_path_buf()]
        } else if p.is_dir() {
            dir_files(p)
        } else {
            Vec::new()
        };
        for f in files {
            if let Some((sha256, bytes)) = file_sha256(&f) {
                let path = f.display().to_string();
                if p.is_dir() {
                    h.update(path.as_bytes());
                    h.update([0]);
                }
                h.update(sha256.as_bytes());
                h.update([0]);
                inputs.push(InputHash {
                    path,
                    sha256,
                    bytes,
                });
            }
        }
    }
    (hex(&h.finalize()), inputs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn the_output_and_the_memory_limit_do_not_count() {
        let a = run_hash(&v(&["placenta", "m.vtu", "-o", "a", "--max-memory", "4G"])).0;
        let b = run_hash(&v(&["placenta", "m.vtu", "--output=b"])).0;
        let c = run_hash(&v(&["placenta", "m.vtu", "-ob", "--max-memory=1G"])).0;
        assert_eq!(a, b);
        assert_eq!(a, c);
        let d = run_hash(&v(&[
            "placenta",
            "m.vtu",
            "-o",
            "a",
            "--template",
            "ellipsoid",
        ]))
        .0;
        assert_ne!(a, d);
    }

    #[test]
    fn input_contents_count() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("m.vtu");
        std::fs::write(&f, b"one").unwrap();
        let args = v(&["placenta", &f.display().to_string(), "-o", "x"]);
        let (h1, inputs) = run_hash(&args);
        assert_eq!(inputs.len(), 1);
        assert_eq!(inputs[0].bytes, 3);
        // sha256("one")
        assert_eq!(
            inputs[0].sha256,
            "7692c3ad3540bb803c020b3aee66cd8887123234ea0c6e7143c0add73ff431ed"
        );
        std::fs::write(&f, b"two").unwrap();
        assert_ne!(run_hash(&args).0, h1);
        let flag = v(&[
            "placenta",
            "m",
            &format!("--image={}", f.display()),
            "-o",
            "x",
        ]);
        assert_eq!(run_hash(&flag).1.len(), 1);
    }

    /// A displacement field written by an earlier run is an output: its
    /// path counts, its contents (there or not) do not.
    #[test]
    fn an_output_file_counts_by_its_path_only() {
        let dir = tempfile::tempdir().unwrap();
        let field = dir.path().join("field.nii.gz");
        let f = field.display().to_string();
        let eq = v(&["placenta", "m.vtu", &format!("--displacement={f}")]);
        let sep = v(&["placenta", "m.vtu", "--displacement", &f]);
        let (before_eq, before_sep) = (run_hash(&eq).0, run_hash(&sep).0);
        std::fs::write(&field, b"written").unwrap();
        let (after, inputs) = run_hash(&eq);
        assert_eq!(after, before_eq);
        assert!(inputs.is_empty());
        assert_eq!(run_hash(&sep), (before_sep, Vec::new()));
        let elsewhere = v(&["placenta", "m.vtu", "--displacement=other.nii.gz"]);
        assert_ne!(run_hash(&elsewhere).0, before_eq);
    }

    #[test]
    fn the_subcommand_is_never_an_input() {
        // `unfold mitral ... -o mitral` run twice in one folder: the first
        // run's output folder is not an input of the second.
        let dir = tempfile::tempdir().unwrap();
        let earlier = dir.path().join("mitral");
        std::fs::create_dir(&earlier).unwrap();
        std::fs::write(earlier.join("report.json"), b"{}").unwrap();
        let args = v(&["placenta", "m.vtu", "-o", "x"]);
        let mut named = args.clone();
        named[0] = earlier.display().to_string();
        assert!(run_hash(&named).1.is_empty());
        // a file named by a later argument still counts
        let as_input = v(&["mitral", "--series", &earlier.display().to_string()]);
        assert_eq!(run_hash(&as_input).1.len(), 1);
    }

    #[test]
    fn a_directory_counts_by_the_files_in_it() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("t00_anterior.vtu"), b"a").unwrap();
        std::fs::write(d.join("t00_annulus.vtu"), b"r").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        std::fs::write(d.join("sub").join("deeper"), b"x").unwrap();
        let args = v(&["mitral", &format!("--series={}", d.display()), "-o", "x"]);
        let (h1, inputs) = run_hash(&args);
        let names: Vec<&str> = inputs.iter().map(|i| i.path.as_str()).collect();
        assert_eq!(names.len(), 2, "{names:?}");
        assert!(names[0].ends_with("t00_annulus.vtu") && names[1].ends_with("t00_anterior.vtu"));
        // a changed file, an added file and a renamed file each count
        std::fs::write(d.join("t00_anterior.vtu"), b"b").unwrap();
        let h2 = run_hash(&args).0;
        assert_ne!(h2, h1);
        std::fs::write(d.join("t01_anterior.vtu"), b"b").unwrap();
        let h3 = run_hash(&args).0;
        assert_ne!(h3, h2);
        std::fs::rename(d.join("t01_anterior.vtu"), d.join("t02_anterior.vtu")).unwrap();
        assert_ne!(run_hash(&args).0, h3);
        // the subdirectory does not
        let h4 = run_hash(&args).0;
        std::fs::write(d.join("sub").join("deeper"), b"z").unwrap();
        assert_eq!(run_hash(&args).0, h4);
    }
}
